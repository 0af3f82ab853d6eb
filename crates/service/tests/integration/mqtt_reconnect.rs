//! Live broker loss: an embedded rumqttd broker on loopback is stopped while the service
//! runs (its listener and every connection closed), and started again on the same port.
//! While it is away the engine freezes at its last good offset with stale alarms, and the
//! service retries with a doubling wait (measured on a stand-in listener that accepts and
//! drops each attempt); when it is back the client reconnects and the offset resumes from
//! its frozen value without a jump.
#![cfg(feature = "mqtt")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::io::Read;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::{engine_ab, free_port, start_with, Api};
use rumqttc::{AsyncClient, MqttOptions, QoS};

/// A broker that can be stopped: its own router, and a server on a current-thread runtime
/// that is dropped on stop, which closes the listener and every client connection.
pub struct Broker {
    stop: Option<tokio::sync::oneshot::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Broker {
    pub fn start(port: u16) -> Self {
        let router: rumqttd::RouterConfig = toml::from_str(
            "max_connections = 100\nmax_outgoing_packet_count = 200\n\
             max_segment_size = 1048576\nmax_segment_count = 10\n",
        )
        .unwrap();
        let settings: rumqttd::ServerSettings = toml::from_str(&format!(
            "name = \"v4-1\"\nlisten = \"127.0.0.1:{port}\"\nnext_connection_delay_ms = 1\n\
             [connections]\nconnection_timeout_ms = 5000\nmax_payload_size = 20480\n\
             max_inflight_count = 100\ndynamic_filters = true\n"
        ))
        .unwrap();
        let router_tx = rumqttd::Router::new(0, router).spawn();
        let mut server = rumqttd::Server::new(settings, router_tx, rumqttd::protocol::v4::V4);
        let (tx, rx) = tokio::sync::oneshot::channel::<()>();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .unwrap();
            rt.block_on(async {
                tokio::select! {
                    r = server.start(rumqttd::LinkType::Remote) => panic!("broker ended: {r:?}"),
                    _ = rx => {}
                }
            });
            // Dropping the runtime drops every connection task: sockets close.
            drop(rt);
        });
        // Listening before it counts as started.
        let deadline = Instant::now() + Duration::from_secs(10);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            assert!(Instant::now() < deadline, "broker did not listen on {port}");
            std::thread::sleep(Duration::from_millis(10));
        }
        Self {
            stop: Some(tx),
            thread: Some(thread),
        }
    }

    pub fn stop(mut self) {
        let _ = self.stop.take().unwrap().send(());
        self.thread.take().unwrap().join().unwrap();
    }
}

/// Stands in on the broker's port while it is away: accepts each connection, reads the
/// MQTT CONNECT and drops it; returns when `n` attempts of `client_id` were seen, with
/// their arrival instants.
fn refuse_attempts(listener: std::net::TcpListener, client_id: &str, n: usize) -> Vec<Instant> {
    let mut seen = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(20);
    listener.set_nonblocking(true).unwrap();
    while seen.len() < n {
        assert!(
            Instant::now() < deadline,
            "only {} attempts: {seen:?}",
            seen.len()
        );
        match listener.accept() {
            Ok((mut s, _)) => {
                let at = Instant::now();
                s.set_nonblocking(false).unwrap();
                s.set_read_timeout(Some(Duration::from_millis(500)))
                    .unwrap();
                let mut buf = [0u8; 256];
                let k = s.read(&mut buf).unwrap_or(0);
                if buf[..k]
                    .windows(client_id.len())
                    .any(|w| w == client_id.as_bytes())
                {
                    seen.push(at);
                }
            }
            Err(_) => std::thread::sleep(Duration::from_millis(2)),
        }
    }
    seen
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn broker_lost_and_back_on_the_same_port() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(0.6)).unwrap();
    let port = free_port();
    let broker = Broker::start(port);
    let (min_s, max_s) = (0.1, 0.8);
    let run = start_with(
        dir.path(),
        &format!(
            "[machine]\nname = \"m7\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
             [http]\nport = 0\n[storage]\npath = \"loss.db\"\n\
             [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
             reconnect = {{ min_s = {min_s}, max_s = {max_s} }}\n"
        ),
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);

    // A sensor gateway publishing A and B every 50 ms; it reconnects by itself.
    let values = Arc::new(Mutex::new((24.0f64, 20.0f64)));
    let mut opts = MqttOptions::new("gateway", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (gw, mut el) = AsyncClient::new(opts, 64);
    tokio::spawn(async move {
        loop {
            if el.poll().await.is_err() {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    });
    let v = values.clone();
    tokio::spawn(async move {
        loop {
            let (a, b) = *v.lock().unwrap();
            let _ = gw.try_publish(
                "gearcomp/m7/channel/A",
                QoS::AtMostOnce,
                false,
                a.to_string(),
            );
            let _ = gw.try_publish(
                "gearcomp/m7/channel/B",
                QoS::AtMostOnce,
                false,
                b.to_string(),
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    });

    // Alarms not cleared yet (`active=true` also lists cleared, unacknowledged ones).
    let active = |v: &serde_json::Value| -> Vec<String> {
        v.as_array()
            .unwrap()
            .iter()
            .filter(|a| a["cleared_s"].is_null())
            .map(|a| a["key"].as_str().unwrap().to_string())
            .collect()
    };

    // Cz = −3.75·(A − B) = −15 µm with the broker up, for a while.
    let axis = |v: &serde_json::Value| {
        (
            v["axes"][0]["offset_um"].as_f64().unwrap(),
            v["axes"][0]["status"].as_str().unwrap().to_string(),
        )
    };
    api.wait_for("/api/status", &ro, 15.0, |v| {
        axis(v).0 == -15.0 && axis(v).1 == "updated" && v["samples_received"].as_u64() > Some(20)
    })
    .await;
    assert!(active(&api.get("/api/alarms?active=true", Some(&ro)).await.1).is_empty());

    // The broker goes away; a stand-in listener takes the port and drops every attempt.
    broker.stop();
    let t_stop = Instant::now();
    let stand_in = std::net::TcpListener::bind(("127.0.0.1", port)).unwrap();
    let attempts = tokio::task::spawn_blocking(move || refuse_attempts(stand_in, "gearcomp-m7", 5))
        .await
        .unwrap();

    // Meanwhile the inputs went stale: frozen at the last good value, alarms raised.
    let st = api
        .wait_for("/api/status", &ro, 10.0, |v| axis(v).1 == "frozen")
        .await;
    assert_eq!(axis(&st).0, -15.0, "frozen at the last good offset");
    let alarms = api
        .wait_for("/api/alarms?active=true", &ro, 10.0, |v| {
            let keys = active(v);
            keys.iter().any(|k| k == "mqtt.connection")
                && keys.iter().any(|k| k == "channel.A.stale")
        })
        .await;
    let conn = alarms
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["key"] == "mqtt.connection" && a["cleared_s"].is_null())
        .unwrap()["message"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(
        conn.contains(&format!("127.0.0.1:{port}")) && conn.contains("back-off"),
        "{conn}"
    );

    // Back-off: wait = min(max_s, min_s·2^(k−1)) after the k-th failure in a row. The
    // attempts seen here follow failures k0, k0+1, …, so the gaps between them are the
    // waits k0+1, k0+2, … (sleep guarantees at least the wait; up to 0.3 s more is allowed
    // for connecting on a loaded 2-core machine). k0 ≥ 1 depends on how many attempts
    // met the closed port before the stand-in bound it.
    let gaps: Vec<f64> = attempts
        .windows(2)
        .map(|w| (w[1] - w[0]).as_secs_f64())
        .collect();
    let first = (attempts[0] - t_stop).as_secs_f64();
    assert!(first < 2.0, "first attempt {first} s after the loss");
    eprintln!("reconnect attempts: first {first:.3} s after the loss, then gaps {gaps:.3?} s");
    let wait = |k: i32| (min_s * 2f64.powi(k - 1)).min(max_s);
    let fits = |k0: i32| {
        gaps.iter().enumerate().all(|(i, g)| {
            *g >= wait(k0 + 1 + i as i32) - 0.01 && *g <= wait(k0 + 1 + i as i32) + 0.3
        })
    };
    assert!(
        (1..=6).any(fits),
        "gaps {gaps:?} s do not follow min({max_s}, {min_s}·2^(k−1))"
    );
    // Four gaps starting at ≥ 0.2 s reach the 0.8 s cap: the last one is capped.
    assert!(gaps[3] >= max_s - 0.01, "{gaps:?}");

    // Still frozen at −15 while the broker is away.
    let (_, st) = api.get("/api/status", Some(&ro)).await;
    assert_eq!(axis(&st), (-15.0, "frozen".to_string()));

    // The broker comes back on the same port.
    let t_back = api.get("/api/status", Some(&ro)).await.1["time_s"]
        .as_f64()
        .unwrap();
    let broker = Broker::start(port);
    api.wait_for("/api/alarms?active=true", &ro, 15.0, |v| {
        active(v).is_empty()
    })
    .await;
    api.wait_for("/api/status", &ro, 15.0, |v| {
        axis(v) == (-15.0, "updated".into())
    })
    .await;
    // New readings after the return: A = 24.4 → −3.75·4.4 = −16.5 µm.
    *values.lock().unwrap() = (24.4, 20.0);
    api.wait_for("/api/status", &ro, 15.0, |v| {
        (axis(v).0 - (-16.5)).abs() < 1e-9
    })
    .await;
    let db = run.db.clone();
    run.stop().await.unwrap();
    broker.stop();

    // The record: every offset from the loss on is −15 (frozen, then resumed) or −16.5;
    // never 0 (a restart from scratch) nor anything between.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let ys: Vec<(f64, f64)> = conn
        .prepare(
            "SELECT time_s, offset_um FROM offsets WHERE axis = 0 AND time_s >= ?1 ORDER BY id",
        )
        .unwrap()
        .query_map([t_back - 5.0], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert!(ys.len() > 3, "{ys:?}");
    for (t, y) in &ys {
        assert!(
            *y == -15.0 || (*y - (-16.5)).abs() < 1e-9,
            "jump to {y} µm at {t} s: {ys:?}"
        );
    }
    let first_new = ys.iter().position(|(_, y)| *y != -15.0).unwrap();
    assert!(first_new > 0, "{ys:?}");
}
