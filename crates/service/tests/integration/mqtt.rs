//! MQTT against an embedded rumqttd broker on loopback: the service starts before the
//! broker (reconnect with back-off), readings in, the offset published, malformed
//! payloads alarmed, stale inputs freeze the offset and it resumes without a jump.
#![cfg(feature = "mqtt")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::time::{Duration, Instant};

use common::{engine_ab, free_port, start_with, Api};
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};

fn start_broker(port: u16) {
    let cfg = format!(
        r#"
id = 0
[router]
max_connections = 100
max_outgoing_packet_count = 200
max_segment_size = 1048576
max_segment_count = 10
[v4.1]
name = "v4-1"
listen = "127.0.0.1:{port}"
next_connection_delay_ms = 1
[v4.1.connections]
connection_timeout_ms = 5000
max_payload_size = 20480
max_inflight_count = 100
dynamic_filters = true
"#
    );
    let config: rumqttd::Config = toml::from_str(&cfg).unwrap();
    std::thread::spawn(move || {
        let mut broker = rumqttd::Broker::new(config);
        let _ = broker.start();
    });
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mqtt_in_and_out_with_faults() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(0.6)).unwrap();
    let port = free_port();
    let run = start_with(
        dir.path(),
        &format!(
            "[machine]\nname = \"m1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
             [http]\nport = 0\n[storage]\npath = \"mqtt.db\"\n\
             [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\nreconnect = {{ min_s = 0.05, max_s = 0.2 }}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // No broker yet: the connection alarm is raised, the service keeps running.
    api.wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .any(|a| a["key"] == "mqtt.connection")
    })
    .await;
    start_broker(port);

    // A plant gateway: publishes readings, listens to the offset.
    let mut opts = MqttOptions::new("gateway", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (gw, mut el) = AsyncClient::new(opts, 64);
    gw.subscribe("gearcomp/m1/offset/Z", QoS::AtLeastOnce)
        .await
        .unwrap();
    let (off_tx, mut off_rx) = tokio::sync::mpsc::unbounded_channel::<f64>();
    tokio::spawn(async move {
        loop {
            match el.poll().await {
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    let v: serde_json::Value = serde_json::from_slice(&p.payload).unwrap();
                    let _ = off_tx.send(v["offset_um"].as_f64().unwrap());
                }
                Ok(_) => {}
                Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
            }
        }
    });
    let publish = |ch: &'static str, payload: String| {
        let gw = gw.clone();
        async move {
            gw.publish(
                format!("gearcomp/m1/channel/{ch}"),
                QoS::AtLeastOnce,
                false,
                payload,
            )
            .await
            .unwrap();
        }
    };
    // Collects offsets until `want` (± 1e-9) is seen; returns every value seen.
    async fn until(
        rx: &mut tokio::sync::mpsc::UnboundedReceiver<f64>,
        want: f64,
        feed: impl Fn() -> tokio::task::JoinHandle<()>,
    ) -> Vec<f64> {
        let deadline = Instant::now() + Duration::from_secs(15);
        let mut seen = Vec::new();
        loop {
            let _ = feed().await;
            while let Ok(v) = rx.try_recv() {
                seen.push(v);
            }
            if seen.iter().any(|v| (v - want).abs() < 1e-9) {
                return seen;
            }
            assert!(
                Instant::now() < deadline,
                "offset {want} not published; saw {seen:?}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    // Cz = −3.75·(A − B): A = 24, B = 20 → −15 µm (JPH0761598B2's law, exact in binary).
    let f1 = || {
        let (gw1, gw2) = (gw.clone(), gw.clone());
        tokio::spawn(async move {
            gw1.publish(
                "gearcomp/m1/channel/A",
                QoS::AtLeastOnce,
                false,
                r#"{"value": 24.0}"#,
            )
            .await
            .unwrap();
            gw2.publish("gearcomp/m1/channel/B", QoS::AtLeastOnce, false, "20.0")
                .await
                .unwrap();
        })
    };
    let seen = until(&mut off_rx, -15.0, f1).await;
    assert!(seen.iter().all(|v| *v == 0.0 || *v == -15.0), "{seen:?}");
    // The connection alarm cleared once the broker answered.
    api.wait_for("/api/alarms?active=true", &ro, 5.0, |v| {
        v.as_array()
            .unwrap()
            .iter()
            .all(|a| a["key"] != "mqtt.connection" || !a["cleared_s"].is_null())
    })
    .await;

    // Malformed payloads: alarm naming the topic, no crash.
    publish("A", "garbage".into()).await;
    publish("B", r#"{"value": "hot"}"#.into()).await;
    publish("nope", "1.0".into()).await;
    let alarms = api
        .wait_for("/api/alarms", &ro, 10.0, |v| {
            let keys: Vec<&str> = v
                .as_array()
                .unwrap()
                .iter()
                .map(|a| a["key"].as_str().unwrap())
                .collect();
            keys.contains(&"mqtt.payload.A")
                && keys.contains(&"mqtt.payload.B")
                && keys.contains(&"mqtt.unknown_topic")
        })
        .await;
    let msg = |k: &str| {
        alarms
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["key"] == k)
            .unwrap()["message"]
            .as_str()
            .unwrap()
            .to_string()
    };
    assert!(
        msg("mqtt.payload.A").contains("not JSON"),
        "{}",
        msg("mqtt.payload.A")
    );
    assert!(msg("mqtt.payload.B").contains("\"value\" = \"hot\""));
    assert!(msg("mqtt.unknown_topic").contains("not configured"));

    // Inputs stale (nothing for > 0.6 s): the axis freezes at its last good value.
    let frozen = api
        .wait_for("/api/status", &ro, 10.0, |v| {
            v["axes"][0]["status"] == "frozen"
        })
        .await;
    assert_eq!(frozen["axes"][0]["offset_um"].as_f64().unwrap(), -15.0);
    let (_, ch) = api.get("/api/channels", Some(&ro)).await;
    assert_eq!(ch[0]["fault"], "stale");

    // Resume with A = 24.4: −3.75·4.4 = −16.5 µm, straight from −15 (never through 0).
    while off_rx.try_recv().is_ok() {}
    let f2 = || {
        let (gw1, gw2) = (gw.clone(), gw.clone());
        tokio::spawn(async move {
            gw1.publish("gearcomp/m1/channel/A", QoS::AtLeastOnce, false, "24.4")
                .await
                .unwrap();
            gw2.publish("gearcomp/m1/channel/B", QoS::AtLeastOnce, false, "20.0")
                .await
                .unwrap();
        })
    };
    let seen = until(&mut off_rx, -3.75 * (24.4 - 20.0), f2).await;
    assert!(
        seen.iter().all(|v| (-16.5 - 1e-9..=-15.0).contains(v)),
        "jump on resume: {seen:?}"
    );
    run.stop().await.unwrap();
}
