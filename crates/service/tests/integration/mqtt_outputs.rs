//! MQTT outputs for the PLC (issue 14 items 8 and 9) against a real rumqttd broker that is
//! restarted: EP0138375 infeed pulses exactly once across a broker restart and a service
//! restart, the latched stop / feed-hold state (retained) and the heartbeat, and axis
//! positions for a position-dependent law.
#![cfg(feature = "mqtt")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{free_port, position_law_um, start_with, Api, POSITION_ENGINE, PULSE_ENGINE};
use crate::mqtt_reconnect::Broker;
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};

/// A PLC on the broker: subscribes to `topics` on every (re)connection and keeps every
/// message as (topic, JSON, retained).
#[derive(Clone, Default)]
struct Plc {
    seen: Arc<Mutex<Vec<(String, serde_json::Value, bool)>>>,
}

impl Plc {
    fn start(port: u16, id: &str, topics: &[&str]) -> Self {
        let plc = Plc::default();
        let seen = plc.seen.clone();
        let mut opts = MqttOptions::new(id, "127.0.0.1", port);
        opts.set_keep_alive(Duration::from_secs(5));
        let (c, mut el) = AsyncClient::new(opts, 64);
        let topics: Vec<String> = topics.iter().map(|t| t.to_string()).collect();
        tokio::spawn(async move {
            loop {
                match el.poll().await {
                    Ok(Event::Incoming(Packet::ConnAck(_))) => {
                        for t in &topics {
                            let _ = c.try_subscribe(t.clone(), QoS::AtLeastOnce);
                        }
                    }
                    Ok(Event::Incoming(Packet::Publish(p))) => {
                        let v: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
                        seen.lock().unwrap().push((p.topic.clone(), v, p.retain));
                    }
                    Ok(_) => {}
                    Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
                }
            }
        });
        plc
    }

    fn on(&self, topic: &str) -> Vec<serde_json::Value> {
        self.seen
            .lock()
            .unwrap()
            .iter()
            .filter(|(t, _, _)| t == topic)
            .map(|(_, v, _)| v.clone())
            .collect()
    }
}

/// A gateway publishing channel readings (and positions) every `period`; `values` is
/// read at each round, so the test can change them.
fn gateway(port: u16, values: Arc<Mutex<Vec<(String, String)>>>, period: Duration) {
    let mut opts = MqttOptions::new("gateway", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (gw, mut el) = AsyncClient::new(opts, 256);
    tokio::spawn(async move {
        loop {
            if el.poll().await.is_err() {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    });
    tokio::spawn(async move {
        loop {
            let v = values.lock().unwrap().clone();
            for (topic, payload) in v {
                let _ = gw.try_publish(topic, QoS::AtLeastOnce, false, payload);
            }
            tokio::time::sleep(period).await;
        }
    });
}

async fn wait_until(what: &str, secs: f64, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    while !f() {
        assert!(Instant::now() < deadline, "timed out: {what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// What the PLC did with the pulse batches: applying `total` minus the total it last
/// applied, as the protocol says, and checking each batch against the one before.
#[derive(Debug, Default)]
struct Applied {
    /// The count applied (the infeed moved by this many pulses).
    total: i64,
    /// Batches received again (same total: moved nothing).
    repeats: usize,
    /// Batches whose `total − pulses` is not the last total (one missed while away).
    gaps: usize,
    /// Σ pulses over the batches applied.
    sum_pulses: i64,
}

fn apply(batches: &[serde_json::Value]) -> Applied {
    let mut a = Applied::default();
    for b in batches {
        let (n, t) = (b["pulses"].as_i64().unwrap(), b["total"].as_i64().unwrap());
        if t == a.total {
            a.repeats += 1;
            continue;
        }
        if t - n != a.total {
            a.gaps += 1;
        }
        a.sum_pulses += n;
        a.total = t;
    }
    a
}

/// Issue 14 item 9: pulses of 1 µm for the applied offset, with a broker restart and a
/// service restart in the middle; the PLC's count equals round(final offset / 1 µm),
/// computed here from the offset the service reports.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn pulses_exactly_once_across_broker_and_service_restarts() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), PULSE_ENGINE).unwrap();
    let port = free_port();
    let broker = Broker::start(port);
    let config = format!(
        "[machine]\nname = \"m1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
         [http]\nport = 0\n[storage]\npath = \"p.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
         reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n"
    );
    let run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    let plc = Plc::start(port, "plc", &["gearcomp/m1/pulses/Z"]);
    let values = Arc::new(Mutex::new(vec![
        ("gearcomp/m1/channel/A".to_string(), "24.0".to_string()),
        ("gearcomp/m1/channel/B".to_string(), "20.0".to_string()),
    ]));
    gateway(port, values.clone(), Duration::from_millis(25));
    let applied = |plc: &Plc| apply(&plc.on("gearcomp/m1/pulses/Z")).total;

    // Ramp towards −15 µm; the broker restarts mid-ramp.
    wait_until("first pulses", 30.0, || applied(&plc) <= -4).await;
    broker.stop();
    tokio::time::sleep(Duration::from_millis(400)).await;
    let broker = Broker::start(port);
    wait_until("pulses after the broker restart", 30.0, || {
        applied(&plc) <= -8
    })
    .await;

    // The service restarts mid-ramp on the same record.
    run.stop().await.unwrap();
    let run = start_with(dir.path(), &config).await;
    let api = Api::new(&run);
    // A new target: −3.75·(25.5 − 20) = −20.625 µm.
    values.lock().unwrap()[0].1 = "25.5".into();
    let st = api
        .wait_for("/api/status", &ro, 60.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(-20.625)
        })
        .await;
    let y = st["axes"][0]["offset_um"].as_f64().unwrap();
    // Independent: the count a pulse train of 1 µm needs for y, to the nearest pulse
    // (EP0138375 Fig. 9 carries the remainder, so the train never drifts by more than
    // half a pulse): −20.625 → −21.
    let want = (y / 1.0).round() as i64;
    assert_eq!(want, -21);
    wait_until("the last pulses", 20.0, || applied(&plc) == want).await;
    // Nothing more arrives afterwards (no pulse repeated late).
    tokio::time::sleep(Duration::from_millis(500)).await;
    let batches = plc.on("gearcomp/m1/pulses/Z");
    let a = apply(&batches);
    println!(
        "pulses: final offset {y} µm → {want} pulses; PLC applied {} from {} batches ({} repeats, {} gaps, Σ pulses of applied batches {})",
        a.total,
        batches.len(),
        a.repeats,
        a.gaps,
        a.sum_pulses
    );
    assert_eq!(a.total, want, "{batches:?}");
    // Every batch carries the total before it: a PLC that adds `pulses` gets the same
    // count unless it missed a batch while away.
    if a.gaps == 0 {
        assert_eq!(a.sum_pulses, want, "{batches:?}");
    }
    // The offset ramps monotonically here, so the totals do too: a repeated batch would
    // show as a total going back.
    for w in batches.windows(2) {
        assert!(
            w[1]["total"].as_i64() <= w[0]["total"].as_i64(),
            "{batches:?}"
        );
    }
    let store = run.store.clone();
    run.stop().await.unwrap();
    // The record keeps what the device acknowledged: all of it.
    let text = tokio::task::block_in_place(|| store.resume_state().unwrap().unwrap());
    let st = gearcomp_service::cycle::ResumeState::decode(&text).unwrap();
    assert_eq!((st.pulse_total[0], st.pulses_acked[0]), (want, want));
    broker.stop();
}

/// Issue 14 item 8 over MQTT: the stop / feed-hold state retained on `…/stop`, latched
/// until the operator acknowledges it, seen by a PLC that connects later and again after
/// a broker restart (which loses retained messages); the heartbeat counts while the
/// cycle runs and stops when the service stops.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stop_state_retained_and_heartbeat_over_mqtt() {
    let dir = tempfile::tempdir().unwrap();
    let engine = crate::common::engine_ab(2.0).replacen(
        "stale_timeout_s = 2\n",
        "stale_timeout_s = 2\nlimit_max = 30.0\n",
        1,
    );
    assert!(engine.contains("limit_max = 30.0"), "{engine}");
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    let port = free_port();
    let broker = Broker::start(port);
    let run = start_with(
        dir.path(),
        &format!(
            "[machine]\nname = \"m1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
             [http]\nport = 0\n[storage]\npath = \"s.db\"\n\
             [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\nheartbeat_s = 0.1\n\
             reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n"
        ),
    )
    .await;
    let op = run.generated.clone().unwrap().operator;
    let api = Api::new(&run);
    let plc = Plc::start(port, "plc", &["gearcomp/m1/stop", "gearcomp/m1/heartbeat"]);
    let values = Arc::new(Mutex::new(vec![
        ("gearcomp/m1/channel/A".to_string(), "24.0".to_string()),
        ("gearcomp/m1/channel/B".to_string(), "20.0".to_string()),
    ]));
    gateway(port, values.clone(), Duration::from_millis(50));
    let stop = |plc: &Plc| {
        plc.on("gearcomp/m1/stop")
            .last()
            .map(|v| v["stop"].as_bool().unwrap())
    };
    // The heartbeat counts up one by one.
    wait_until("heartbeats", 10.0, || {
        plc.on("gearcomp/m1/heartbeat").len() >= 5
    })
    .await;
    let beats: Vec<u64> = plc
        .on("gearcomp/m1/heartbeat")
        .iter()
        .map(|v| v["beat"].as_u64().unwrap())
        .collect();
    assert!(beats.windows(2).all(|w| w[1] == w[0] + 1), "{beats:?}");

    // A at 35 °C: the stop request → stop = true.
    values.lock().unwrap()[0].1 = "35.0".into();
    wait_until("stop published", 10.0, || stop(&plc) == Some(true)).await;
    // Back in range: latched.
    values.lock().unwrap()[0].1 = "24.0".into();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(stop(&plc), Some(true), "released without acknowledgement");
    // A PLC connecting now reads the retained state at once.
    let late = Plc::start(port, "plc-late", &["gearcomp/m1/stop"]);
    wait_until("retained stop", 10.0, || stop(&late) == Some(true)).await;
    assert!(late.seen.lock().unwrap()[0].2, "not retained");
    // The broker restarts (its retained messages are gone): the service publishes the
    // state again on its new connection.
    broker.stop();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let broker = Broker::start(port);
    let after = Plc::start(port, "plc-after", &["gearcomp/m1/stop"]);
    wait_until("stop after the broker restart", 15.0, || {
        stop(&after) == Some(true)
    })
    .await;

    // The operator acknowledges: released.
    let r = api
        .client
        .post(format!("{}/api/stop/ack", api.base))
        .bearer_auth(&op)
        .send()
        .await
        .unwrap();
    assert!(r.status().is_success(), "{}", r.status());
    wait_until("stop released", 10.0, || stop(&after) == Some(false)).await;

    run.stop().await.unwrap();
    // A dead compensator: no more heartbeats.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let n = plc.on("gearcomp/m1/heartbeat").len();
    tokio::time::sleep(Duration::from_millis(600)).await;
    assert_eq!(plc.on("gearcomp/m1/heartbeat").len(), n);
    broker.stop();
}

/// Issue 14 item 9: positions over MQTT for the SINUMERIK/TwinCAT position law
/// K0(T) + tanβ(T)·(P − P0), checked against the law worked by hand; a malformed
/// position freezes the axis with an alarm.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn positions_over_mqtt_reach_the_position_law() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), POSITION_ENGINE).unwrap();
    let port = free_port();
    let broker = Broker::start(port);
    let run = start_with(
        dir.path(),
        &format!(
            "[machine]\nname = \"m1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
             [http]\nport = 0\n[storage]\npath = \"q.db\"\n\
             [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
             reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let values = Arc::new(Mutex::new(vec![
        ("gearcomp/m1/position/Z".to_string(), "140.0".to_string()),
        ("gearcomp/m1/channel/A".to_string(), "24.0".to_string()),
    ]));
    gateway(port, values.clone(), Duration::from_millis(30));
    for p_mm in [140.0, 60.0, 100.0, 237.5] {
        values.lock().unwrap()[0].1 = format!("{p_mm}");
        let want = position_law_um(24.0, p_mm);
        api.wait_for("/api/status", &ro, 20.0, |v| {
            v["axes"][0]["offset_um"].as_f64() == Some(want)
                && v["axes"][0]["position_mm"].as_f64() == Some(p_mm)
        })
        .await;
    }
    // A malformed position: alarm, and the axis freezes at its last value.
    values.lock().unwrap()[0].1 = "\"far\"".into();
    let alarm = api
        .wait_alarm("/api/alarms?active=true", &ro, "mqtt.position.Z", 10.0)
        .await;
    assert!(
        alarm["message"]
            .as_str()
            .unwrap()
            .contains("position in mm"),
        "{alarm}"
    );
    let st = api
        .wait_for("/api/status", &ro, 10.0, |v| {
            v["axes"][0]["status"] == "frozen"
        })
        .await;
    assert_eq!(
        st["axes"][0]["offset_um"].as_f64(),
        Some(position_law_um(24.0, 237.5))
    );
    run.stop().await.unwrap();
    broker.stop();
}
