//! Modbus outputs for the PLC (issue 14 item 9): EP0138375 infeed pulses as a cumulative
//! counter (i32 in two holding registers) exactly once across a device power cycle and a
//! service restart, and axis positions read from a register with a scale for the
//! SINUMERIK/TwinCAT position law.
#![cfg(feature = "modbus")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::Duration;

use crate::common::{
    free_port, plc_steps, position_law_um, start_with, Api, POSITION_ENGINE, PULSE_ENGINE,
};
use crate::modbus_output::{wait_until, Device, Module};

/// Counter registers: high word at 12, low word at 13.
const COUNTER: usize = 12;

fn module_at(a_counts: u16, b_counts: u16) -> Module {
    let m = Module::default();
    *m.input.lock().unwrap() = [a_counts, b_counts, 0, 0];
    m
}

/// The counter a device holds, by hand: (high·65536 + low) as i32.
fn counter(m: &Module) -> i64 {
    let h = m.holding.lock().unwrap();
    let u = (u32::from(h[COUNTER]) << 16) | u32::from(h[COUNTER + 1]);
    i64::from(u as i32)
}

/// The PLC's side: every value written to the counter, in order (pairs of the one write
/// of both registers).
fn counter_writes(m: &Module) -> Vec<i64> {
    let w = m.writes.lock().unwrap();
    let mut out = Vec::new();
    let mut hi = None;
    for &(a, v) in w.iter() {
        if a as usize == COUNTER {
            hi = Some(v);
        } else if a as usize == COUNTER + 1 {
            let u = (u32::from(hi.take().unwrap()) << 16) | u32::from(v);
            out.push(i64::from(u as i32));
        }
    }
    out
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pulse_counter_exactly_once_across_device_power_cycle_and_service_restart() {
    let dir = tempfile::tempdir().unwrap();
    let engine = PULSE_ENGINE.replacen("max_step_um = 0.1", "max_step_um = 0.25", 1);
    assert!(engine.contains("max_step_um = 0.25"));
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    // A = 24.0 °C, B = 20.0 °C at 0.1 °C per count: target −15 µm.
    let m1 = module_at(240, 200);
    let dev = Device::start(port, m1.clone());
    let config = format!(
        "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
         [storage]\npath = \"mp.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
         pulse_output = {{ axis = \"Z\", address = {COUNTER} }}\n\
         [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
         registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
    );
    let run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    wait_until("first pulses", 30.0, || counter(&m1) <= -4).await;

    // Power cycle: the device comes back with its counter at 0.
    drop(dev);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let m2 = module_at(240, 200);
    let _dev = Device::start(port, m2.clone());
    wait_until("pulses after the power cycle", 30.0, || counter(&m2) <= -8).await;
    let api = Api::new(&run);
    let held = api
        .wait_alarm("/api/alarms", &ro, "modbus.pulse_output.held", 10.0)
        .await;
    assert!(
        held["message"].as_str().unwrap().contains("holds 0"),
        "{held}"
    );

    // The service restarts mid-ramp; the target moves to −3.75·(25.5 − 20) = −20.625 µm.
    run.stop().await.unwrap();
    let run = start_with(dir.path(), &config).await;
    let api = Api::new(&run);
    m2.input.lock().unwrap()[0] = 255;
    let st = api
        .wait_for("/api/status", &ro, 60.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(-20.625)
        })
        .await;
    let y = st["axes"][0]["offset_um"].as_f64().unwrap();
    // Independent: the nearest whole count of 1 µm pulses (the remainder carried keeps
    // the train within half a pulse): −20.625 → −21.
    let want = y.round() as i64;
    assert_eq!(want, -21);
    wait_until("the last pulses", 20.0, || counter(&m2) == want).await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    run.stop().await.unwrap();

    // The PLC applies each written total minus the total it last applied, keeping that
    // in retained memory across its own power cycle.
    let (w1, w2) = (counter_writes(&m1), counter_writes(&m2));
    let steps = plc_steps(w1.iter().chain(&w2));
    let moved: i64 = steps.iter().sum();
    println!(
        "modbus pulses: final offset {y} µm → {want} pulses; device writes {w1:?} then {w2:?}; PLC moved {moved}"
    );
    assert_eq!(moved, want);
    assert_eq!(counter(&m2), want);
    // The ramp is monotonic: no total ever goes back (a repeated batch would).
    assert!(steps.iter().all(|s| *s <= 0), "{steps:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn positions_from_a_register_reach_the_position_law() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), POSITION_ENGINE).unwrap();
    let port = free_port();
    let m = module_at(240, 0);
    let _dev = Device::start(port, m.clone());
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"pos.db\"\n\
             [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             positions = [{{ axis = \"Z\", address = 2, mm_per_count = 0.01 }}]\n\
             [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
             registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}]\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    // Register counts of 0.01 mm (i16): 140 mm, 60 mm, 237.5 mm, −50 mm.
    for counts in [14000i16, 6000, 23750, -5000] {
        m.input.lock().unwrap()[2] = counts as u16;
        let p_mm = f64::from(counts) * 0.01;
        let t_c = 240.0 * 0.1;
        let want = position_law_um(t_c, p_mm);
        api.wait_for("/api/status", &ro, 20.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(want)
                && v["axes"][0]["position_mm"].as_f64() == Some(p_mm)
        })
        .await;
    }
    run.stop().await.unwrap();
}
