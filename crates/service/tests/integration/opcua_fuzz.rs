//! The OPC UA input against a CNC stand-in (an async-opcua server on loopback) whose
//! temperature nodes take a random script of values: good readings as Double, Float or
//! Int32, and values no reading can come from — String (one of 5 000 characters), Boolean,
//! Empty, an array, NaN and ±∞, a UInt64 far beyond the channel's range, and good-typed
//! values with a Bad status. Asserted on the record, for a fixed seed and a fresh one:
//!
//! - the session and the input live on: no `opcua.connection` alarm after the first
//!   reading, and good values afterwards bring the offset to the law by hand,
//!   −3.75·(24 − 20) = −15 µm;
//! - no step: consecutive stored offsets differ by at most the rate limit (0.5 µm);
//! - a bad value is alarmed (`opcua.node.<node>`, or the channel's own fault alarm for a
//!   number the engine refuses), and every alarm message stays short (< 500 characters).
//!
//! The subscription delivers the latest value per publishing interval (0.05 s); each
//! scripted value is held 0.1 s so each is seen.
#![cfg(feature = "opcua")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::{Duration, Instant};

use crate::common::{
    add_variable, engine_ab_rate_limited, fixed_then_fresh, free_port, opcua_input_head,
    start_with, step_beyond, stored_offsets, Api, OpcUaStandIn,
};
use opcua::types::{DataTypeId, DataValue, DateTime, NodeId, StatusCode, Variant};
use proptest::prelude::*;

/// One scripted value of a temperature node: the variant, a Bad status instead of Good,
/// and whether the service can take it as a reading the engine accepts.
#[derive(Debug, Clone)]
struct Step {
    ch: usize,
    value: Variant,
    bad_status: bool,
    good: bool,
}

fn step() -> impl Strategy<Value = Step> {
    let good = prop_oneof![
        (15.0f64..30.0).prop_map(Variant::Double),
        (15.0f32..30.0).prop_map(Variant::Float),
        (15i32..30).prop_map(Variant::Int32),
    ];
    let bad = prop_oneof![
        Just(Variant::from("hot")),
        Just(Variant::from("q".repeat(5000).as_str())),
        Just(Variant::Boolean(true)),
        Just(Variant::Empty),
        Just(Variant::from(vec![20.0f64, 21.0])),
        Just(Variant::Double(f64::NAN)),
        Just(Variant::Double(f64::INFINITY)),
        Just(Variant::Double(f64::NEG_INFINITY)),
        Just(Variant::UInt64(u64::MAX)),
        Just(Variant::Double(500.0)),
    ];
    (
        0usize..2,
        prop_oneof![
            5 => good.prop_map(|v| (v, false, true)),
            1 => (15.0f64..30.0).prop_map(|x| (Variant::Double(x), true, false)),
            3 => bad.prop_map(|v| (v, false, false)),
        ],
    )
        .prop_map(|(ch, (value, bad_status, good))| Step {
            ch,
            value,
            bad_status,
            good,
        })
}

fn run_case(script: Vec<Step>) -> Result<(), TestCaseError> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async move {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("engine.toml"),
            engine_ab_rate_limited(30.0, 0.5),
        )
        .unwrap();
        let port = free_port();
        let ua = OpcUaStandIn::bind(
            port,
            "gearcomp fuzz CNC",
            "urn:gearcomp-fuzz-cnc-server",
            "cnc",
            "urn:gearcomp-fuzz-cnc",
        )
        .await;
        let ns = ua.ns;
        {
            let mut space = ua.nm.address_space().write();
            for (name, v) in [("Temp.A", 24.0f64), ("Temp.B", 20.0)] {
                add_variable(&mut space, ns, name, DataTypeId::BaseDataType, v, false);
            }
        }
        let ua = ua.run();
        let run = start_with(
            dir.path(),
            &opcua_input_head(port, "path = \"ua.db\"", ns, 0.2),
        )
        .await;
        let ro = run.generated.clone().unwrap().read_only;
        let api = Api::new(&run);
        api.wait_for("/api/status", &ro, 20.0, |st| {
            st["samples_received"].as_u64().unwrap_or(0) > 0
        })
        .await;

        let set = |ch: usize, value: Variant, bad_status: bool| {
            let mut dv = DataValue::new_now(value);
            if bad_status {
                dv.status = Some(StatusCode::BadSensorFailure);
            }
            dv.source_timestamp = Some(DateTime::now());
            ua.nm
                .set_value(
                    ua.handle.subscriptions(),
                    &NodeId::new(ns, ["Temp.A", "Temp.B"][ch]),
                    None,
                    dv,
                )
                .unwrap();
        };
        for s in &script {
            set(s.ch, s.value.clone(), s.bad_status);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        // Good values again: the law on them, through the rate limit.
        set(0, Variant::Double(24.0), false);
        set(1, Variant::Double(20.0), false);
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let (_, st) = api.get("/api/status", Some(&ro)).await;
            if st["axes"][0]["offset_um"].as_f64() == Some(-15.0) {
                break;
            }
            prop_assert!(
                Instant::now() < deadline,
                "input dead or off the law: {}",
                st
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        let (_, all) = api.get("/api/alarms?limit=10000", Some(&ro)).await;
        let db = run.db.clone();
        run.stop().await.unwrap();
        ua.stop().await;

        let first_sample: f64 = {
            let conn = gearcomp_service::storage::open_read(&db).unwrap();
            conn.query_row("SELECT MIN(time_s) FROM samples", [], |r| r.get(0))
                .unwrap()
        };
        for a in all.as_array().unwrap() {
            let m = a["message"].as_str().unwrap();
            prop_assert!(m.chars().count() < 500, "{}", m);
            prop_assert!(
                !(a["key"] == "opcua.connection" && a["time_s"].as_f64().unwrap() > first_sample),
                "session dropped: {}",
                a
            );
        }
        for ch in 0..2 {
            if script.iter().any(|s| s.ch == ch && !s.good) {
                let name = ["A", "B"][ch];
                let node_key = format!("opcua.node.ns={ns};s=Temp.{name}");
                let chan_key = format!("channel.{name}.");
                let alarmed = all.as_array().unwrap().iter().any(|a| {
                    let k = a["key"].as_str().unwrap();
                    k == node_key || k.starts_with(&chan_key)
                });
                prop_assert!(alarmed, "bad values on {} without an alarm: {}", name, all);
            }
        }
        let step = step_beyond(&stored_offsets(&db), 0.5);
        prop_assert!(
            step.is_none(),
            "offset (row, value, before) {:?}: a step beyond the rate limit",
            step
        );
        Ok(())
    })
}

#[test]
fn hostile_node_values_never_kill_the_input_nor_step_the_offset() {
    let strat = proptest::collection::vec(step(), 8..30);
    fixed_then_fresh(&strat, 0x5e11_0005, 2, 1, run_case);
}
