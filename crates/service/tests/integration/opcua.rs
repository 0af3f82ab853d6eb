//! OPC UA against an async-opcua server standing in for the CNC, on loopback: the service
//! starts before the server (reconnect with back-off), subscribes to the temperatures,
//! writes the offset into the CNC's compensation node; a node of the wrong type and a
//! refused write are alarmed; the server stopped freezes the offset, restarted on the same
//! port it gets the current offset at once and resumes without a jump. An axis X with the
//! SINUMERIK/TwinCAT position law reads its position from a node. A second test drives the scans by a cut counter and
//! holds a safe-point axis until the program state says "stopped".
#![cfg(feature = "opcua")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{
    add_variable, alarm_active as active, engine_ab, free_port, opcua_input_head, start_with, Api,
    OpcUaRunning, OpcUaStandIn,
};
use opcua::types::{DataTypeId, DataValue, StatusCode, UAString, Variant};

const NS_URI: &str = "urn:gearcomp-test-cnc";

/// The CNC stand-in: variables in namespace 2, the compensation node `TempComp` whose
/// accepted writes are logged (that log is the node's value, read back by the test).
struct Cnc {
    ua: OpcUaRunning,
    writes: Arc<Mutex<Vec<f64>>>,
}

impl Cnc {
    async fn start(port: u16, vars: &[(&str, Variant)], refuse: Arc<AtomicBool>) -> Cnc {
        let ua = OpcUaStandIn::bind(
            port,
            "gearcomp test CNC",
            "urn:gearcomp-test-cnc-server",
            "cnc",
            NS_URI,
        )
        .await;
        let (nm, ns) = (ua.nm.clone(), ua.ns);
        let writes: Arc<Mutex<Vec<f64>>> = Arc::default();
        {
            let mut space = nm.address_space().write();
            for (name, v) in vars {
                let dt = match v {
                    Variant::Double(_) => DataTypeId::Double,
                    Variant::UInt32(_) => DataTypeId::UInt32,
                    Variant::Int32(_) => DataTypeId::Int32,
                    _ => DataTypeId::BaseDataType,
                };
                add_variable(&mut space, ns, name, dt, v.clone(), false);
            }
            let comp = add_variable(&mut space, ns, "TempComp", DataTypeId::Double, 0.0f64, true);
            let w = writes.clone();
            nm.inner()
                .add_write_callback(comp, move |dv: DataValue, _| {
                    if refuse.load(Ordering::SeqCst) {
                        return StatusCode::BadOutOfService;
                    }
                    match dv.value {
                        Some(Variant::Double(x)) => {
                            w.lock().unwrap().push(x);
                            StatusCode::Good
                        }
                        _ => StatusCode::BadTypeMismatch,
                    }
                });
        }
        Cnc {
            ua: ua.run(),
            writes,
        }
    }

    /// The compensation node's value (0 until the first accepted write).
    fn comp(&self) -> f64 {
        self.writes.lock().unwrap().last().copied().unwrap_or(0.0)
    }

    fn log(&self) -> Vec<f64> {
        self.writes.lock().unwrap().clone()
    }

    /// Waits (bounded) until the compensation node holds `want` (± 1e-9).
    async fn wait_comp(&self, want: f64, secs: f64) {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        while (self.comp() - want).abs() > 1e-9 {
            assert!(
                Instant::now() < deadline,
                "TempComp = {}, expected {want}; writes {:?}",
                self.comp(),
                self.log()
            );
            tokio::time::sleep(Duration::from_millis(30)).await;
        }
    }
}

fn message(v: &serde_json::Value, key: &str) -> String {
    v.as_array()
        .unwrap()
        .iter()
        .find(|a| a["key"] == key)
        .unwrap()["message"]
        .as_str()
        .unwrap()
        .to_string()
}

/// Engine AB plus an axis X with the position law ΔK = K0(T) + tanβ(T)·(P − P0) on
/// channel A: K0 = 2 + 0.5·(T − 20) µm, tanβ = 0.25 + 0.0625·(T − 20) µm/mm, P0 = 100 mm.
fn engine_ab_position() -> String {
    format!(
        "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 100.0\n\
         [[axes.terms]]\nkind = \"position\"\nchannel = \"A\"\nt_ref_c = 20.0\noffset_um = 2.0\n\
         offset_um_per_c = 0.5\nslope_um_per_mm = 0.25\nslope_um_per_mm_per_c = 0.0625\np0_mm = 100.0\n",
        engine_ab(0.6)
    )
}

/// The law of [`engine_ab_position`] written out by hand.
fn position_law_um(temp_c: f64, p_mm: f64) -> f64 {
    let dt = temp_c - 20.0;
    (2.0 + 0.5 * dt) + (0.25 + 0.0625 * dt) * (p_mm - 100.0)
}

fn no_value_written_twice_in_a_row(log: &[f64]) {
    let twice = log.windows(2).position(|w| w[0] == w[1]);
    assert!(
        twice.is_none(),
        "an offset was written twice: write {twice:?} of {} ({:?}…)",
        log.len(),
        &log[..log.len().min(8)]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_in_offset_out_with_faults_and_restart() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab_position()).unwrap();
    let port = free_port();
    let run = start_with(
        dir.path(),
        &format!(
            "{}positions = [{{ axis = \"X\", node = \"ns=2;s=Pos.X\", scale = 0.5 }}]\n\
             offset_output = {{ axis = \"Z\", node = \"ns=2;s=TempComp\" }}\n",
            opcua_input_head(port, "path = \"ua.db\"", 2, 0.2)
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // No server yet: the connection alarm is raised, the service keeps running.
    api.wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
        active(v, "opcua.connection")
    })
    .await;

    let refuse = Arc::new(AtomicBool::new(false));
    // Pos.X in half-millimetres (scale 0.5 to mm): 280 → 140 mm.
    let vars = |a: f64, pos_x: f64| {
        vec![
            ("Temp.A", Variant::Double(a)),
            ("Temp.B", Variant::Double(20.0)),
            ("Pos.X", Variant::Double(pos_x)),
        ]
    };
    let cnc = Cnc::start(port, &vars(24.0, 280.0), refuse.clone()).await;
    assert_eq!(
        cnc.ua.ns, 2,
        "the node ids of the configuration assume ns=2"
    );

    // JPH0761598B2's grinder law Cz = −3.75·(A − B): A − B = 4 K → −15 µm, exact in binary.
    cnc.wait_comp(-15.0, 20.0).await;
    let log = cnc.log();
    assert!(log.iter().all(|v| *v == 0.0 || *v == -15.0), "{log:?}");
    no_value_written_twice_in_a_row(&log);
    api.wait_for("/api/alarms?active=true", &ro, 5.0, |v| {
        !active(v, "opcua.connection")
    })
    .await;
    let (_, ch) = api.get("/api/channels", Some(&ro)).await;
    assert_eq!(ch[0]["value"].as_f64().unwrap(), 24.0);
    assert_eq!(ch[1]["value"].as_f64().unwrap(), 20.0);

    // Axis X from its position node, by hand at T = 24 °C (K0 = 4 µm, tanβ = 0.5 µm/mm):
    // P = 140 mm → 4 + 0.5·40 = 24 µm; P = 60 mm → 4 + 0.5·(−40) = −16 µm.
    for (node, p_mm, want_um) in [(280.0, 140.0, 24.0), (120.0, 60.0, -16.0)] {
        assert_eq!(position_law_um(24.0, p_mm), want_um);
        cnc.ua.set("Pos.X", Variant::Double(node));
        let st = api
            .wait_for("/api/status", &ro, 10.0, |v| {
                v["axes"][1]["offset_um"].as_f64() == Some(want_um)
            })
            .await;
        assert_eq!(st["axes"][1]["position_mm"].as_f64(), Some(p_mm), "{st}");
        assert_eq!(st["axes"][1]["law_um"].as_f64(), Some(want_um), "{st}");
    }

    // A String where a Double is expected: alarm naming node, type found and expected;
    // the axis freezes at −15.
    cnc.ua
        .set("Temp.A", Variant::String(UAString::from("24.4")));
    let key = "opcua.node.ns=2;s=Temp.A";
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| active(v, key))
        .await;
    let m = message(&alarms, key);
    assert!(
        m.contains("ns=2;s=Temp.A") && m.contains("String") && m.contains("expected Double"),
        "{m}"
    );
    api.wait_for("/api/status", &ro, 10.0, |v| {
        v["axes"][0]["status"] == "frozen"
    })
    .await;
    assert_eq!(cnc.comp(), -15.0);

    // The node a Double again at 24.4 °C, but the CNC refuses the write: alarm, retried.
    refuse.store(true, Ordering::SeqCst);
    let writes_before = cnc.log().len();
    cnc.ua.set("Temp.A", Variant::Double(24.4));
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
            active(v, "opcua.offset_output.Z") && !active(v, key)
        })
        .await;
    let m = message(&alarms, "opcua.offset_output.Z");
    assert!(
        m.contains("BadOutOfService") && m.contains("ns=2;s=TempComp") && m.contains("retrying"),
        "{m}"
    );
    assert_eq!(cnc.log().len(), writes_before);
    // Accepted again: the retry lands −3.75·4.4 = −16.5 µm, and the alarm clears.
    refuse.store(false, Ordering::SeqCst);
    let want = -3.75 * (24.4 - 20.0);
    cnc.wait_comp(want, 15.0).await;
    api.wait_for("/api/alarms?active=true", &ro, 5.0, |v| {
        !active(v, "opcua.offset_output.Z")
    })
    .await;
    no_value_written_twice_in_a_row(&cnc.log());

    // Server stopped: connection alarm, readings stale, the axis freezes at −16.5.
    let before = cnc.log();
    cnc.ua.stop().await;
    api.wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
        active(v, "opcua.connection")
    })
    .await;
    let frozen = api
        .wait_for("/api/status", &ro, 10.0, |v| {
            v["axes"][0]["status"] == "frozen"
        })
        .await;
    assert!((frozen["axes"][0]["offset_um"].as_f64().unwrap() - want).abs() < 1e-9);
    no_value_written_twice_in_a_row(&before);

    // Restarted on the same port (a fresh CNC: TempComp = 0) with the same temperatures:
    // the offset does not change, yet the node gets the current −16.5 µm right after the
    // reconnect, as the first and only write.
    let cnc = Cnc::start(port, &vars(24.4, 120.0), refuse.clone()).await;
    assert_eq!(cnc.comp(), 0.0);
    cnc.wait_comp(want, 20.0).await;
    api.wait_for("/api/alarms?active=true", &ro, 5.0, |v| {
        !active(v, "opcua.connection")
    })
    .await;
    // Axis X resumes from the position node: at T = 24.4 °C, P = 60 mm,
    // K0 = 2 + 0.5·4.4 = 4.2 µm, tanβ = 0.25 + 0.0625·4.4 = 0.525 µm/mm → 4.2 − 21 = −16.8 µm.
    let want_x = 4.2 - 0.525 * 40.0;
    api.wait_for("/api/status", &ro, 10.0, |v| {
        v["axes"][1]["offset_um"]
            .as_f64()
            .is_some_and(|x| (x - want_x).abs() < 1e-9)
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(cnc.log(), vec![want], "writes after the reconnect");
    let (_, st) = api.get("/api/status", Some(&ro)).await;
    assert_eq!(st["axes"][0]["offset_um"].as_f64(), Some(want), "{st}");

    // A = 24.8 °C: resume to −18 µm straight from −16.5 (never through 0).
    cnc.ua.set("Temp.A", Variant::Double(24.8));
    let want2 = -3.75 * (24.8 - 20.0);
    cnc.wait_comp(want2, 20.0).await;
    let log = cnc.log();
    assert!(
        log.iter().all(|v| (want2 - 1e-9..=want + 1e-9).contains(v)),
        "jump on resume: {log:?}"
    );
    no_value_written_twice_in_a_row(&log);
    run.stop().await.unwrap();
    cnc.ua.stop().await;
}

/// Engine AB sampling at the trigger input only, the axis moving only at safe points.
fn engine_ab_triggered() -> String {
    let e = engine_ab(60.0).replace(
        "max_offset_um = 100.0\n",
        "max_offset_um = 100.0\nsafe_points_only = true\n",
    );
    format!("[sampling]\ntrigger = {{ kind = \"input\" }}\n{e}")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_cut_counter_and_program_state() {
    let dir = tempfile::tempdir().unwrap();
    let engine = engine_ab_triggered();
    assert!(engine.contains("safe_points_only = true"));
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let cnc = Cnc::start(
        port,
        &[
            ("Temp.A", Variant::Double(24.0)),
            ("Temp.B", Variant::Double(20.0)),
            ("CutCounter", Variant::UInt32(41)),
            // SINUMERIK progStatus: 3 = running, 2 = stopped.
            ("ProgStatus", Variant::Int32(3)),
        ],
        Arc::new(AtomicBool::new(false)),
    )
    .await;
    let run = start_with(
        dir.path(),
        &format!(
            "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
             [storage]\npath = \"ua2.db\"\n\
             [input]\nkind = \"opcua\"\nendpoint = \"opc.tcp://127.0.0.1:{port}/\"\n\
             publishing_interval_s = 0.05\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
             channels = [{{ channel = \"A\", node = \"ns=2;s=Temp.A\" }}, {{ channel = \"B\", node = \"ns=2;s=Temp.B\" }}]\n\
             trigger = {{ node = \"ns=2;s=CutCounter\" }}\n\
             program_state = {{ node = \"ns=2;s=ProgStatus\", safe_values = [2] }}\n\
             offset_output = {{ axis = \"Z\", node = \"ns=2;s=TempComp\" }}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // Connected, but no cut yet: no scan reaches the engine, nothing is sampled.
    api.wait_for("/api/status", &ro, 10.0, |v| v["cycles"].as_u64() > Some(5))
        .await;
    tokio::time::sleep(Duration::from_millis(500)).await;
    let (_, st) = api.get("/api/status", Some(&ro)).await;
    assert_eq!(st["samples_received"], 0, "sampled without a cut: {st}");
    assert_eq!(cnc.comp(), 0.0);

    // One cut: a scan; the law says −15 µm but the program runs, so the axis waits.
    cnc.ua.set("CutCounter", Variant::UInt32(42));
    api.wait_for("/api/status", &ro, 10.0, |v| {
        v["axes"][0]["status"] == "waiting_safe_point"
    })
    .await;
    // Exactly one scan: one reading of A and one of B.
    let (_, st) = api.get("/api/status", Some(&ro)).await;
    assert_eq!(st["samples_received"], 2, "{st}");
    let (_, ch) = api.get("/api/channels", Some(&ro)).await;
    assert_eq!(ch[0]["raw"].as_f64(), Some(24.0));
    assert_eq!(cnc.comp(), 0.0);

    // Program stopped (a safe point): the offset goes out.
    cnc.ua.set("ProgStatus", Variant::Int32(2));
    cnc.wait_comp(-15.0, 10.0).await;
    no_value_written_twice_in_a_row(&cnc.log());

    // A trigger node of the wrong type: alarm naming node, type found and expected.
    cnc.ua.set("CutCounter", Variant::Double(43.0));
    let key = "opcua.node.ns=2;s=CutCounter";
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| active(v, key))
        .await;
    let m = message(&alarms, key);
    assert!(
        m.contains("trigger") && m.contains("Double") && m.contains("integer counter"),
        "{m}"
    );
    run.stop().await.unwrap();
    cnc.ua.stop().await;
}

/// Issue 14 item 1 over OPC UA: the service restarted four times against a CNC that
/// holds −15 µm. Each new session writes the offset the last run applied, resumed from
/// the record, never the 0.0 that only meant "no value yet" (before: 3 of 8 restarts
/// wrote 0.0 at session start, before the first full scan).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_service_restarts_never_write_zero() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), common::engine_ab(5.0)).unwrap();
    let port = free_port();
    let cnc = Cnc::start(
        port,
        &[
            ("Temp.A", Variant::Double(24.0)),
            ("Temp.B", Variant::Double(20.0)),
        ],
        Arc::new(AtomicBool::new(false)),
    )
    .await;
    let config = format!(
        "[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n[http]\nport = 0\n\
         [storage]\npath = \"ua.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"opcua\"\nendpoint = \"opc.tcp://127.0.0.1:{port}/\"\n\
         publishing_interval_s = 0.05\nscan_period_s = 0.5\n\
         reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n\
         channels = [{{ channel = \"A\", node = \"ns=2;s=Temp.A\" }}, {{ channel = \"B\", node = \"ns=2;s=Temp.B\" }}]\n\
         offset_output = {{ axis = \"Z\", node = \"ns=2;s=TempComp\" }}\n"
    );
    // Cz = −3.75·(24 − 20) = −15 µm.
    let run = start_with(dir.path(), &config).await;
    cnc.wait_comp(-15.0, 20.0).await;
    run.stop().await.unwrap();
    for restart in 1..=4 {
        let before = cnc.log().len();
        let run = start_with(dir.path(), &config).await;
        // The session's first write: at once, before the first scan (0.5 s period).
        let deadline = Instant::now() + Duration::from_secs(20);
        while cnc.log().len() == before {
            assert!(Instant::now() < deadline, "restart {restart}: no write");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        tokio::time::sleep(Duration::from_millis(700)).await;
        run.stop().await.unwrap();
        let log = cnc.log();
        assert!(
            log[before..].iter().all(|v| *v == -15.0),
            "restart {restart} wrote {:?}",
            &log[before..]
        );
    }
    cnc.ua.stop().await;
}

/// A PLC-like OPC UA server: Temp.A and Temp.B, a writable Boolean `FeedHold` and a
/// writable Int32 `Heartbeat`, every accepted write logged.
struct Plc {
    ua: OpcUaRunning,
    holds: Arc<Mutex<Vec<bool>>>,
    beats: Arc<Mutex<Vec<i32>>>,
}

impl Plc {
    async fn start(port: u16) -> Plc {
        let ua = OpcUaStandIn::bind(
            port,
            "gearcomp test PLC",
            "urn:gearcomp-test-plc",
            "plc",
            NS_URI,
        )
        .await;
        let (nm, ns) = (ua.nm.clone(), ua.ns);
        let holds: Arc<Mutex<Vec<bool>>> = Arc::default();
        let beats: Arc<Mutex<Vec<i32>>> = Arc::default();
        {
            let mut space = nm.address_space().write();
            for (name, v) in [("Temp.A", 24.0), ("Temp.B", 20.0)] {
                add_variable(&mut space, ns, name, DataTypeId::Double, v, false);
            }
            let hold = add_variable(&mut space, ns, "FeedHold", DataTypeId::Boolean, false, true);
            let beat = add_variable(&mut space, ns, "Heartbeat", DataTypeId::Int32, 0i32, true);
            let h = holds.clone();
            nm.inner()
                .add_write_callback(hold, move |dv: DataValue, _| match dv.value {
                    Some(Variant::Boolean(x)) => {
                        h.lock().unwrap().push(x);
                        StatusCode::Good
                    }
                    _ => StatusCode::BadTypeMismatch,
                });
            let b = beats.clone();
            nm.inner()
                .add_write_callback(beat, move |dv: DataValue, _| match dv.value {
                    Some(Variant::Int32(x)) => {
                        b.lock().unwrap().push(x);
                        StatusCode::Good
                    }
                    _ => StatusCode::BadTypeMismatch,
                });
        }
        Plc {
            ua: ua.run(),
            holds,
            beats,
        }
    }

    fn hold(&self) -> Option<bool> {
        self.holds.lock().unwrap().last().copied()
    }

    fn beats(&self) -> Vec<i32> {
        self.beats.lock().unwrap().clone()
    }
}

async fn wait(what: &str, secs: f64, f: impl Fn() -> bool) {
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    while !f() {
        assert!(Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Issue 14 item 8 over OPC UA: the feed-hold Boolean follows the latched stop request
/// (set over the limit, kept when back in range, released by the operator), and the
/// heartbeat Int32 counts 1, 2, 3, … while the service runs and stops with it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn opcua_feed_hold_and_heartbeat() {
    let dir = tempfile::tempdir().unwrap();
    let engine = engine_ab(5.0).replacen(
        "stale_timeout_s = 5\n",
        "stale_timeout_s = 5\nlimit_max = 30.0\n",
        1,
    );
    assert!(engine.contains("limit_max"));
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let plc = Plc::start(port).await;
    assert_eq!(plc.ua.ns, 2);
    let run = start_with(
        dir.path(),
        &format!(
            "{}stop_output = {{ node = \"ns=2;s=FeedHold\" }}\n\
             heartbeat = {{ node = \"ns=2;s=Heartbeat\", period_s = 0.1 }}\n",
            opcua_input_head(port, "path = \"plc.db\"", 2, 0.2)
        ),
    )
    .await;
    let op = run.generated.clone().unwrap().operator;
    let api = Api::new(&run);
    wait("feed hold written false", 20.0, || {
        plc.hold() == Some(false)
    })
    .await;
    wait("heartbeat counts", 20.0, || plc.beats().len() >= 3).await;
    plc.ua.set("Temp.A", 35.0);
    wait("feed hold set", 10.0, || plc.hold() == Some(true)).await;
    plc.ua.set("Temp.A", 24.0);
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(plc.hold(), Some(true), "released without acknowledgement");
    let r = api
        .client
        .post(format!("{}/api/stop/ack", api.base))
        .bearer_auth(&op)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    wait("feed hold released", 10.0, || plc.hold() == Some(false)).await;
    run.stop().await.unwrap();
    let beats = plc.beats();
    // Counted 1, 2, 3, … one per period.
    assert_eq!(beats, (1..=beats.len() as i32).collect::<Vec<_>>());
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(plc.beats().len(), beats.len(), "heartbeat after the stop");
    plc.ua.stop().await;
}
