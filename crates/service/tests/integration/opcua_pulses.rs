//! OPC UA pulse output (issue 14 item 9): EP0138375 infeed pulses as a cumulative total
//! written to an Int32 node of an async-opcua server standing in for the PLC, exactly
//! once across a server restart (the node comes back at 0) and a service restart; the
//! PLC applies each written total minus the total it last applied.
#![cfg(feature = "opcua")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{
    add_variable, free_port, opcua_input_head, plc_steps, start_with, Api, OpcUaRunning,
    OpcUaStandIn, PULSE_ENGINE,
};
use opcua::types::{DataTypeId, DataValue, StatusCode, Variant};

const NS_URI: &str = "urn:gearcomp-test-pulse-plc-vars";

/// The PLC stand-in: Temp.A and Temp.B (Double) and a writable `Pulses` node (Int32, or
/// Double with `double`) whose accepted writes are logged and held (a read returns the
/// last accepted write, 0 after a start: the server keeps nothing across its restart).
struct Plc {
    ua: OpcUaRunning,
    held: Arc<Mutex<f64>>,
    writes: Arc<Mutex<Vec<f64>>>,
    /// While set, a write is stored (it lands) but answered BadTimeout: the status of a
    /// write that arrived is lost.
    lose_status: Arc<AtomicBool>,
}

impl Plc {
    async fn start(port: u16, temp_a: f64) -> Plc {
        Self::start_typed(port, temp_a, false, 0.0).await
    }

    /// `held`: the node's value at start (0 for a server that keeps nothing).
    async fn start_typed(port: u16, temp_a: f64, double: bool, held: f64) -> Plc {
        let ua = OpcUaStandIn::bind(
            port,
            "gearcomp test pulse PLC",
            "urn:gearcomp-test-pulse-plc",
            "plc",
            NS_URI,
        )
        .await;
        let (nm, ns) = (ua.nm.clone(), ua.ns);
        let held: Arc<Mutex<f64>> = Arc::new(Mutex::new(held));
        let lose_status = Arc::new(AtomicBool::new(false));
        let writes: Arc<Mutex<Vec<f64>>> = Arc::default();
        {
            let mut space = nm.address_space().write();
            for (name, v) in [("Temp.A", temp_a), ("Temp.B", 20.0)] {
                add_variable(&mut space, ns, name, DataTypeId::Double, v, false);
            }
            let (dt, zero) = if double {
                (DataTypeId::Double, Variant::Double(0.0))
            } else {
                (DataTypeId::Int32, Variant::Int32(0))
            };
            let pulses = add_variable(&mut space, ns, "Pulses", dt, zero, true);
            let (h, w, lose) = (held.clone(), writes.clone(), lose_status.clone());
            nm.inner()
                .add_write_callback(pulses.clone(), move |dv: DataValue, _| {
                    let x = match (dv.value, double) {
                        (Some(Variant::Int32(x)), false) => f64::from(x),
                        (Some(Variant::Double(x)), true) => x,
                        _ => return StatusCode::BadTypeMismatch,
                    };
                    *h.lock().unwrap() = x;
                    w.lock().unwrap().push(x);
                    if lose.load(Ordering::SeqCst) {
                        StatusCode::BadTimeout
                    } else {
                        StatusCode::Good
                    }
                });
            let h = held.clone();
            nm.inner().add_read_callback(pulses, move |_, _, _| {
                let x = *h.lock().unwrap();
                Ok(DataValue::new_now(if double {
                    Variant::Double(x)
                } else {
                    Variant::Int32(x as i32)
                }))
            });
        }
        Plc {
            ua: ua.run(),
            held,
            writes,
            lose_status,
        }
    }

    /// The total held (every value written here is a whole number: checked).
    fn held(&self) -> i64 {
        let x = *self.held.lock().unwrap();
        assert_eq!(x.fract(), 0.0, "{x}");
        x as i64
    }

    fn writes(&self) -> Vec<i64> {
        let w = self.writes.lock().unwrap();
        assert!(w.iter().all(|x| x.fract() == 0.0), "{w:?}");
        w.iter().map(|x| *x as i64).collect()
    }
}

async fn wait(what: &str, secs: f64, f: impl Fn() -> bool) {
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    while !f() {
        assert!(Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_pulses_exactly_once_across_server_and_service_restarts() {
    let dir = tempfile::tempdir().unwrap();
    let engine = PULSE_ENGINE.replacen("max_step_um = 0.1", "max_step_um = 0.25", 1);
    assert!(engine.contains("max_step_um = 0.25"));
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    // A = 24 °C, B = 20 °C: target −3.75·4 = −15 µm, ramped 0.25 µm per 0.1 s cycle.
    let plc1 = Plc::start(port, 24.0).await;
    let ns = plc1.ua.ns;
    let config = format!(
        "{}pulse_outputs = [{{ axis = \"Z\", node = \"ns={ns};s=Pulses\" }}]\n",
        opcua_input_head(port, "path = \"op.db\"\ncommit_interval_s = 0.05", ns, 0.2)
    );
    let run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    wait("first pulses", 30.0, || plc1.held() <= -4).await;

    // The server restarts mid-ramp: its node comes back holding 0.
    let w1_len = plc1.writes().len();
    let w1 = plc1.writes();
    plc1.ua.stop().await;
    let plc2 = Plc::start(port, 24.0).await;
    assert_eq!(plc2.ua.ns, ns);
    wait("pulses after the server restart", 30.0, || {
        plc2.held() <= -8
    })
    .await;
    let api = Api::new(&run);
    let held = api
        .wait_alarm("/api/alarms", &ro, "opcua.pulse_output.Z.held", 10.0)
        .await;
    assert!(
        held["message"].as_str().unwrap().contains("holds 0"),
        "{held}"
    );
    assert_eq!(w1.len(), w1_len);

    // The service restarts mid-ramp on the same record; the target moves to
    // −3.75·(25.5 − 20) = −20.625 µm.
    run.stop().await.unwrap();
    let run = start_with(dir.path(), &config).await;
    let api = Api::new(&run);
    plc2.ua.set("Temp.A", 25.5);
    let st = api
        .wait_for("/api/status", &ro, 60.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(-20.625)
        })
        .await;
    let y = st["axes"][0]["offset_um"].as_f64().unwrap();
    // Independent: the nearest whole count of 1 µm pulses (the remainder carried keeps
    // the train within half a pulse): −20.625 → −21.
    let want = (y / 1.0).round() as i64;
    assert_eq!(want, -21);
    wait("the last pulses", 20.0, || plc2.held() == want).await;
    // Nothing more arrives afterwards (no total repeated late).
    tokio::time::sleep(Duration::from_millis(500)).await;
    let store = run.store.clone();
    run.stop().await.unwrap();

    // The PLC applies each written total minus the total it last applied, keeping that
    // in retained memory across the server's restart.
    let w2 = plc2.writes();
    let steps = plc_steps(w1.iter().chain(&w2));
    let moved: i64 = steps.iter().sum();
    println!(
        "opcua pulses: final offset {y} µm → {want} pulses; server writes {w1:?} then {w2:?}; PLC moved {moved}"
    );
    assert_eq!(moved, want);
    assert_eq!(plc2.held(), want);
    // The ramp is monotonic: no total ever goes back (a repeated batch would).
    assert!(steps.iter().all(|s| *s <= 0), "{steps:?}");
    // After the server restart the first write restores the total acknowledged before it
    // (or more), never starts again from 0.
    assert!(w2[0] <= *w1.last().unwrap(), "{w1:?} {w2:?}");
    // The record keeps what the PLC acknowledged: all of it.
    let text = tokio::task::block_in_place(|| store.resume_state().unwrap().unwrap());
    let st = gearcomp_service::cycle::ResumeState::decode(&text).unwrap();
    assert_eq!((st.pulse_total[0], st.pulses_acked[0]), (want, want));
    plc2.ua.stop().await;
}

/// A Double (LREAL) pulse node: refused at connect while the configuration says Int32 (the
/// alarm names both types, nothing is written), taken once `data_type = "Double"`; the
/// total reaches round(−15 µm / 1 µm) = −15 as whole Doubles.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_pulses_to_a_double_node_and_a_wrong_type_named() {
    let dir = tempfile::tempdir().unwrap();
    let engine = PULSE_ENGINE.replacen("max_step_um = 0.1", "max_step_um = 0.25", 1);
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let plc = Plc::start_typed(port, 24.0, true, 0.0).await;
    let ns = plc.ua.ns;
    let config = |ty: &str| {
        format!(
            "{}pulse_outputs = [{{ axis = \"Z\", node = \"ns={ns};s=Pulses\"{ty} }}]\n",
            opcua_input_head(port, "path = \"od.db\"\ncommit_interval_s = 0.05", ns, 0.2)
        )
    };
    let run = start_with(dir.path(), &config("")).await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let a = api
        .wait_alarm("/api/alarms", &ro, "opcua.pulse_output.Z", 20.0)
        .await;
    let m = a["message"].as_str().unwrap();
    assert!(
        m.contains("has data type Double") && m.contains("writes Int32"),
        "{m}"
    );
    // The offset ramps meanwhile (pulses issued), but nothing reaches the node.
    api.wait_for("/api/status", &ro, 20.0, |v| {
        v["axes"][0]["offset_um"]
            .as_f64()
            .is_some_and(|y| y <= -3.0)
    })
    .await;
    assert!(plc.writes().is_empty(), "{:?}", plc.writes());
    run.stop().await.unwrap();

    let run = start_with(dir.path(), &config(", data_type = \"Double\"")).await;
    let api = Api::new(&run);
    let st = api
        .wait_for("/api/status", &ro, 60.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(-15.0)
        })
        .await;
    let want = st["axes"][0]["offset_um"].as_f64().unwrap().round() as i64;
    wait("the last pulses", 20.0, || plc.held() == want).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let store = run.store.clone();
    run.stop().await.unwrap();
    let w = plc.writes();
    println!("opcua Double pulses: writes {w:?}");
    // The first write carries every pulse issued while the node was refused.
    assert!(w[0] <= -3, "{w:?}");
    assert!(w.windows(2).all(|p| p[1] < p[0]), "{w:?}");
    assert_eq!(*w.last().unwrap(), -15);
    let text = tokio::task::block_in_place(|| store.resume_state().unwrap().unwrap());
    let st = gearcomp_service::cycle::ResumeState::decode(&text).unwrap();
    assert_eq!((st.pulse_total[0], st.pulses_acked[0]), (want, want));
    plc.ua.stop().await;
}

/// A write that landed but whose status was lost (the server stores the total, answers
/// BadTimeout), then the session lost (the server restarts keeping its node, as a PLC
/// with retained memory): the read-back at the new session finds the total written and
/// counts it as acknowledged, no `…held` alarm, no rewrite; the count still ends at
/// round(−15 µm / 1 µm) = −15 with issued = acknowledged in the record.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_pulse_write_landed_with_status_lost_counts_once() {
    let dir = tempfile::tempdir().unwrap();
    let engine = PULSE_ENGINE.replacen("max_step_um = 0.1", "max_step_um = 0.25", 1);
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let plc1 = Plc::start(port, 24.0).await;
    let ns = plc1.ua.ns;
    let run = start_with(
        dir.path(),
        &format!(
            "{}pulse_outputs = [{{ axis = \"Z\", node = \"ns={ns};s=Pulses\" }}]\n",
            opcua_input_head(port, "path = \"ol.db\"\ncommit_interval_s = 0.05", ns, 0.2)
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    wait("first pulses", 30.0, || plc1.held() <= -3).await;
    let n_good = plc1.writes().len();
    plc1.lose_status.store(true, Ordering::SeqCst);
    wait("a write with its status lost", 10.0, || {
        plc1.writes().len() > n_good
    })
    .await;
    api.wait_alarm("/api/alarms", &ro, "opcua.pulse_output.Z", 10.0)
        .await;
    // The session ends; the server comes back holding what it was last written.
    let w1 = plc1.writes();
    let kept = *plc1.held.lock().unwrap();
    plc1.ua.stop().await;
    let plc2 = Plc::start_typed(port, 24.0, false, kept).await;
    let st = api
        .wait_for("/api/status", &ro, 60.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(-15.0)
        })
        .await;
    let want = st["axes"][0]["offset_um"].as_f64().unwrap().round() as i64;
    wait("the last pulses", 20.0, || plc2.held() == want).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (_, alarms) = api.get("/api/alarms", Some(&ro)).await;
    let store = run.store.clone();
    run.stop().await.unwrap();
    let w2 = plc2.writes();
    println!(
        "opcua pulses, status lost: first server {w1:?} ({} answered Good), kept {kept}, second server {w2:?}",
        n_good
    );
    assert!(
        !alarms
            .as_array()
            .unwrap()
            .iter()
            .any(|a| a["key"] == "opcua.pulse_output.Z.held"),
        "{alarms}"
    );
    // The total that landed is not written again: the second server's writes go on
    // from it.
    assert!(w2.iter().all(|t| (*t as f64) < kept), "{kept} {w2:?}");
    let moved: i64 = plc_steps(w1.iter().chain(&w2)).iter().sum();
    assert_eq!(moved, want);
    let text = tokio::task::block_in_place(|| store.resume_state().unwrap().unwrap());
    let st = gearcomp_service::cycle::ResumeState::decode(&text).unwrap();
    assert_eq!((st.pulse_total[0], st.pulses_acked[0]), (want, want));
    plc2.ua.stop().await;
}
