//! Modbus TCP against a tokio-modbus server standing in for a temperature module, on
//! loopback: reconnect with back-off, scaled registers in, the offset written to a holding
//! register, an out-of-range register value alarmed and frozen.
#![cfg(feature = "modbus")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use common::{engine_ab, free_port, start_with, Api};
// The temperature module stand-in of `modbus_output` (registers, coils, a write log).
use crate::modbus_output::{serve_module, Module};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn modbus_module_in_offset_register_out() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(1.0)).unwrap();
    let port = free_port();
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"mb.db\"\n\
             [input]\nkind = \"modbus\"\npoll_period_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             offset_output = {{ axis = \"Z\", address = 10, um_per_count = 0.1 }}\n\
             [[input.modules]]\nhost = \"127.0.0.1\"\nport = {port}\n\
             registers = [{{ channel = \"A\", address = 0, scale = 0.1 }}, {{ channel = \"B\", address = 1, scale = 0.1 }}]\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // Module not there yet: connection alarm, retried with back-off.
    api.wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .any(|a| a["key"] == "modbus.0.connection")
    })
    .await;
    let module = Module::default();
    *module.input.lock().unwrap() = [240, 200, 0, 0]; // 24.0 °C, 20.0 °C at 0.1 °C/count
    tokio::spawn(serve_module(port, module.clone()));

    // Cz = −3.75·(24.0 − 20.0) = −15 µm → −150 counts of 0.1 µm in holding register 10.
    let holding = |m: &Module| m.holding.lock().unwrap()[10] as i16;
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(15);
    while holding(&module) != -150 {
        assert!(
            std::time::Instant::now() < deadline,
            "register 10 = {}",
            holding(&module)
        );
        tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    }
    let (_, ch) = api.get("/api/channels", Some(&ro)).await;
    assert!((ch[0]["value"].as_f64().unwrap() - 24.0).abs() < 1e-12);

    // An open sensor (0x7FFF): alarm naming register, value and range; the axis freezes,
    // the register keeps −150.
    module.input.lock().unwrap()[0] = 0x7FFF;
    let a = api
        .wait_alarm("/api/alarms?active=true", &ro, "modbus.0.register.0", 10.0)
        .await;
    let m = a["message"].as_str().unwrap();
    assert!(
        m.contains("32767") && m.contains("-32767…32766") && m.contains("channel A"),
        "{m}"
    );
    api.wait_for("/api/status", &ro, 10.0, |v| {
        v["axes"][0]["status"] == "frozen"
    })
    .await;
    assert_eq!(holding(&module), -150);

    // Sensor back at 24.4 °C: −16.5 µm → −165 counts.
    module.input.lock().unwrap()[0] = 244;
    while holding(&module) != -165 {
        assert!(
            std::time::Instant::now() < deadline,
            "register 10 = {}",
            holding(&module)
        );
        tokio::time::sleep(std::time::Duration::from_millis(30)).await;
    }
    run.stop().await.unwrap();
}
