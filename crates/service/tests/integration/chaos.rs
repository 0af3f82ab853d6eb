//! The chaos test of issue 14: random faults while readings flow, for a fixed seed and a
//! fresh one (printed, so a failure can be replayed with `GEARCOMP_CHAOS_SEED=<seed>`).
//!
//! Phase 1, simulator (the hobbing preset at 1000× speed-up, so 8 s of wall time are
//! about two hours of service time): the service is restarted at random moments on the
//! same record. Phase 2, MQTT (a rumqttd broker on loopback, a gateway publishing a
//! simulated thermal drift at 20 Hz): random broker restarts, malformed payloads,
//! oversized payloads, spikes, unconfigured topics and service restarts. Phase 3, kill -9:
//! the service in a process of its own (simulator, 1000×) killed with SIGKILL at random
//! moments and started again on the same record.
//!
//! Asserted after both: no acknowledged sample lost (every `committed_samples` count the
//! API reported is in the record afterwards), no crash (every run answers and stops
//! cleanly), the applied offset in the record never moves by more than the axis's rate
//! limit from one cycle to the next (across every restart), and every fault injected has
//! its alarm (an alarm of its cause raised within 10 s and active at or after the fault).
#![cfg(feature = "mqtt")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::{free_port, start_with, Api};
use crate::mqtt_reconnect::Broker;
use gearcomp_service::service::Running;
use rumqttc::{AsyncClient, MqttOptions, QoS};

/// xorshift64* (Vigna 2016): the test's own random numbers, reproducible from the seed.
struct Rng(u64);

impl Rng {
    fn new(seed: u64) -> Self {
        Self(seed.max(1))
    }
    fn next(&mut self) -> u64 {
        let mut x = self.0;
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        self.0 = x;
        x.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [lo, hi).
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// Every applied offset of axis 0 in the record, in order.
fn offsets(db: &std::path::Path) -> Vec<(f64, f64)> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT time_s, offset_um FROM offsets WHERE axis = 0 ORDER BY id")
        .unwrap();
    st.query_map([], |r| Ok((r.get(0)?, r.get::<_, Option<f64>>(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .filter_map(|(t, y)| y.map(|y| (t, y)))
        .collect()
}

fn sample_rows(db: &std::path::Path) -> u64 {
    let conn = rusqlite::Connection::open(db).unwrap();
    conn.query_row("SELECT COUNT(*) FROM samples", [], |r| r.get::<_, i64>(0))
        .unwrap() as u64
}

/// (key, raised s, cleared s) of every alarm in the record.
fn alarm_rows(db: &std::path::Path) -> Vec<(String, f64, Option<f64>)> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT key, time_s, cleared_s FROM alarms ORDER BY id")
        .unwrap();
    st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect()
}

/// The largest change of the applied offset from one record row to the next.
fn assert_rate_limited(rows: &[(f64, f64)], rate_um: f64, what: &str) -> f64 {
    assert!(rows.len() > 10, "{what}: only {} offset rows", rows.len());
    let mut worst = 0.0f64;
    for w in rows.windows(2) {
        let d = (w[1].1 - w[0].1).abs();
        worst = worst.max(d);
        assert!(
            d <= rate_um + 1e-9,
            "{what}: offset {} → {} µm at {} s exceeds the rate limit {rate_um} µm/cycle",
            w[0].1,
            w[1].1,
            w[1].0
        );
    }
    worst
}

/// The service's status, or a panic naming the run (a crashed service does not answer).
async fn status(run: &Running, token: &str) -> serde_json::Value {
    let (code, v) = Api::new(run).get("/api/status", Some(token)).await;
    assert_eq!(code, 200, "the service did not answer: {v}");
    v
}

/// Phase 1: random restarts of a simulator-fed service at 1000× speed-up.
async fn simulator_restarts(rng: &mut Rng) {
    let dir = tempfile::tempdir().unwrap();
    let config = "[machine]\nname = \"hob-1\"\n[engine]\npreset = \"hobbing\"\n[http]\nport = 0\n\
         [storage]\npath = \"c.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"simulator\"\nspeedup = 1000\n";
    let mut acked = 0u64;
    let mut restarts = 0;
    let wall = Instant::now();
    let mut token = None;
    let mut t_end = 0.0;
    while wall.elapsed() < Duration::from_secs(8) {
        let run = start_with(dir.path(), config).await;
        let ro = token
            .get_or_insert_with(|| run.generated.clone().unwrap().read_only)
            .clone();
        // After a restart the record holds at least every sample acknowledged before.
        let v = status(&run, &ro).await;
        let found = v["committed_samples"].as_u64().unwrap();
        assert!(
            found >= acked,
            "{found} samples found at start, {acked} acknowledged"
        );
        tokio::time::sleep(Duration::from_secs_f64(rng.range(0.8, 2.5))).await;
        let v = status(&run, &ro).await;
        acked = acked.max(v["committed_samples"].as_u64().unwrap());
        t_end = v["time_s"].as_f64().unwrap_or(t_end);
        run.stop().await.unwrap();
        restarts += 1;
    }
    let db = dir.path().join("c.db");
    assert!(sample_rows(&db) >= acked);
    // The hobbing preset's rate limit: 0.5 µm per cycle.
    let ys = offsets(&db);
    let worst = assert_rate_limited(&ys, 0.5, "simulator");
    // Not a vacuous check: the offset did move under the restarts.
    let span = ys.iter().map(|r| r.1.abs()).fold(0.0, f64::max);
    assert!(span >= 1.0, "the offset never moved ({span} µm)");
    println!(
        "chaos phase 1: {restarts} runs, {t_end:.0} s of service time, {acked} samples acknowledged, offset up to {span:.3} µm, largest step {worst:.3} µm"
    );
}

/// Channels A and B (°C) with a Hampel spike test, Z = −3.75·(A − B), at most 0.5 µm per
/// cycle.
fn mqtt_engine() -> String {
    let ch = |n: &str| {
        format!(
            "[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\n\
             valid_max = 80.0\nstale_timeout_s = 1.0\n\
             plausibility = {{ spike = {{ window = 7, n_sigma = 3.0, min_mad = 0.1 }} }}\n"
        )
    };
    format!(
        "{}{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"measuring_system\" }}\n\
         max_offset_um = 100.0\nmax_step_um = 0.5\n[[axes.terms]]\nkind = \"difference\"\n\
         a = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n",
        ch("A"),
        ch("B")
    )
}

/// What the gateway publishes next round instead of channel A's reading, if anything.
type Inject = Arc<Mutex<Option<(String, Vec<u8>)>>>;

/// A gateway publishing A (a slow drift with noise) and B every 50 ms; a payload put in
/// `inject` replaces one round's A (a spike or a malformed message is then part of a
/// complete scan).
fn gateway(port: u16, seed: u64, inject: Inject) {
    let mut opts = MqttOptions::new("chaos-gateway", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    opts.set_max_packet_size(64 * 1024, 64 * 1024);
    let (gw, mut el) = AsyncClient::new(opts, 256);
    tokio::spawn(async move {
        loop {
            if el.poll().await.is_err() {
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
        }
    });
    tokio::spawn(async move {
        let mut rng = Rng::new(seed ^ 0x5eed);
        let t0 = Instant::now();
        loop {
            let t = t0.elapsed().as_secs_f64();
            let a = 24.0 + 4.0 * (std::f64::consts::TAU * t / 20.0).sin() + rng.range(-0.05, 0.05);
            let (topic, payload) = inject.lock().unwrap().take().unwrap_or((
                "gearcomp/m1/channel/A".into(),
                format!("{a:.3}").into_bytes(),
            ));
            let _ = gw.try_publish(topic, QoS::AtLeastOnce, false, payload);
            let _ = gw.try_publish("gearcomp/m1/channel/B", QoS::AtLeastOnce, false, "20.0");
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    });
}

#[derive(Debug, Clone, Copy)]
enum Fault {
    BrokerRestart,
    Malformed,
    Oversized,
    Spike,
    UnknownTopic,
    ServiceRestart,
}

impl Fault {
    const ALL: [Fault; 6] = [
        Fault::BrokerRestart,
        Fault::Malformed,
        Fault::Oversized,
        Fault::Spike,
        Fault::UnknownTopic,
        Fault::ServiceRestart,
    ];

    /// The alarm the fault must raise (None: a restart raises none; it is checked by the
    /// record's continuity instead).
    fn alarm(self) -> Option<&'static str> {
        match self {
            Fault::BrokerRestart => Some("mqtt.connection"),
            Fault::Malformed | Fault::Oversized => Some("mqtt.payload.A"),
            Fault::Spike => Some("channel.A.spike"),
            Fault::UnknownTopic => Some("mqtt.unknown_topic"),
            Fault::ServiceRestart => None,
        }
    }
}

/// Phase 2: random faults on the MQTT path.
async fn mqtt_faults(rng: &mut Rng, seed: u64) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), mqtt_engine()).unwrap();
    let port = free_port();
    let mut broker = Some(Broker::start(port));
    let config = format!(
        "[machine]\nname = \"m1\"\n[engine]\nfile = \"engine.toml\"\n[cycle]\nperiod_s = 0.1\n\
         [http]\nport = 0\n[storage]\npath = \"m.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"mqtt\"\nhost = \"127.0.0.1\"\nport = {port}\n\
         reconnect = {{ min_s = 0.05, max_s = 0.2 }}\n"
    );
    let mut run = start_with(dir.path(), &config).await;
    let ro = run.generated.clone().unwrap().read_only;
    let inject: Inject = Default::default();
    gateway(port, seed, inject.clone());
    // Warm up: a spike test needs its window of readings.
    tokio::time::sleep(Duration::from_secs(2)).await;
    let mut acked = 0u64;
    let mut injected: Vec<(Fault, f64)> = Vec::new();
    let wall = Instant::now();
    while wall.elapsed() < Duration::from_secs(16) {
        let f = Fault::ALL[rng.pick(Fault::ALL.len())];
        let v = status(&run, &ro).await;
        acked = acked.max(v["committed_samples"].as_u64().unwrap());
        let t = v["time_s"].as_f64().unwrap();
        match f {
            Fault::BrokerRestart => {
                broker.take().unwrap().stop();
                tokio::time::sleep(Duration::from_secs_f64(rng.range(0.2, 1.0))).await;
                broker = Some(Broker::start(port));
            }
            Fault::Malformed => {
                *inject.lock().unwrap() = Some((
                    "gearcomp/m1/channel/A".into(),
                    b"{\"value\": \"hot\"}".to_vec(),
                ));
            }
            Fault::Oversized => {
                // Over the service's 10240-byte limit, under the broker's 20480.
                *inject.lock().unwrap() =
                    Some(("gearcomp/m1/channel/A".into(), vec![b'7'; 15_000]));
            }
            Fault::Spike => {
                *inject.lock().unwrap() = Some(("gearcomp/m1/channel/A".into(), b"61.0".to_vec()));
            }
            Fault::UnknownTopic => {
                *inject.lock().unwrap() = Some(("gearcomp/m1/channel/C".into(), b"20.0".to_vec()));
            }
            Fault::ServiceRestart => {
                run.stop().await.unwrap();
                run = start_with(dir.path(), &config).await;
                let v = status(&run, &ro).await;
                let found = v["committed_samples"].as_u64().unwrap();
                assert!(
                    found >= acked,
                    "{found} samples found at start, {acked} acknowledged"
                );
            }
        }
        injected.push((f, t));
        // Let the alarm come and, for payload faults, clear again with good readings.
        tokio::time::sleep(Duration::from_secs_f64(rng.range(0.8, 1.6))).await;
    }
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let v = status(&run, &ro).await;
    acked = acked.max(v["committed_samples"].as_u64().unwrap());
    run.stop().await.unwrap();
    if let Some(b) = broker {
        b.stop();
    }
    let db = dir.path().join("m.db");
    let rows = sample_rows(&db);
    assert!(
        rows >= acked,
        "{rows} samples in the record, {acked} acknowledged"
    );
    let worst = assert_rate_limited(&offsets(&db), 0.5, "mqtt");
    let alarms = alarm_rows(&db);
    for (f, t) in &injected {
        let Some(key) = f.alarm() else { continue };
        let found = alarms.iter().any(|(k, raised, cleared)| {
            k == key && *raised <= t + 10.0 && cleared.is_none_or(|c| c >= *t)
        });
        assert!(
            found,
            "fault {f:?} at {t:.2} s has no {key} alarm; alarms: {alarms:?}"
        );
    }
    println!(
        "chaos phase 2: {} faults {:?}; {rows} samples recorded, {acked} acknowledged; largest step {worst:.3} µm; {} alarm rows",
        injected.len(),
        injected.iter().map(|(f, _)| *f).collect::<Vec<_>>(),
        alarms.len()
    );
}

#[cfg(feature = "postgres")]
/// A service in a process of its own (this test binary started again, running only
/// `postgres_kill::child_service` with the configuration named in its variable), so it
/// can be killed with SIGKILL.
struct Child {
    child: std::process::Child,
    base: String,
    read_only: Option<String>,
}

// The child is killed and waited for by the caller.
#[cfg(feature = "postgres")]
#[allow(clippy::zombie_processes)]
fn spawn_child(cfg: &std::path::Path) -> Child {
    use std::io::{BufRead, BufReader};
    let mut child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "postgres_kill::child_service",
            "--nocapture",
            "--test-threads",
            "1",
        ])
        .env(crate::postgres_kill::CHILD_ENV, cfg)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let (tx, lines) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for l in BufReader::new(out).lines() {
            let Ok(l) = l else { break };
            if tx.send(l).is_err() {
                break;
            }
        }
    });
    let mut read_only = None;
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let l = lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("the service printed its address");
        if let Some(t) = l.strip_prefix("read-only token (shown once): ") {
            read_only = Some(t.to_string());
        } else if let Some(i) = l.find("listening on http://") {
            return Child {
                child,
                base: l[i + "listening on ".len()..].trim().to_string(),
                read_only,
            };
        }
    }
}

#[cfg(feature = "postgres")]
fn child_status(c: &Child, token: &str) -> serde_json::Value {
    let r = reqwest::blocking::Client::new()
        .get(format!("{}/api/status", c.base))
        .bearer_auth(token)
        .timeout(Duration::from_secs(5))
        .send()
        .expect("the service did not answer");
    assert_eq!(r.status().as_u16(), 200);
    r.json().unwrap()
}

#[cfg(feature = "postgres")]
/// Phase 3: kill -9 of a service process at random moments (simulator, 1000× speed-up),
/// started again on the same record each time.
fn kill_9(rng: &mut Rng) {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("machine.toml");
    std::fs::write(
        &cfg,
        "[machine]\nname = \"hob-k\"\n[engine]\npreset = \"hobbing\"\n[http]\nport = 0\n\
         [storage]\npath = \"k.db\"\ncommit_interval_s = 0.05\n\
         [input]\nkind = \"simulator\"\nspeedup = 1000\n",
    )
    .unwrap();
    let db = dir.path().join("k.db");
    let mut token = None;
    let mut acked = 0u64;
    let mut kills = 0;
    let wall = Instant::now();
    while wall.elapsed() < Duration::from_secs(8) {
        let mut c = spawn_child(&cfg);
        let ro = token
            .get_or_insert_with(|| c.read_only.clone().unwrap())
            .clone();
        let found = child_status(&c, &ro)["committed_samples"].as_u64().unwrap();
        assert!(
            found >= acked,
            "{found} samples found at start, {acked} acknowledged"
        );
        std::thread::sleep(Duration::from_secs_f64(rng.range(0.8, 2.0)));
        acked = child_status(&c, &ro)["committed_samples"].as_u64().unwrap();
        c.child.kill().unwrap(); // SIGKILL: no flush, no clean-up
        c.child.wait().unwrap();
        kills += 1;
        let rows = sample_rows(&db);
        assert!(
            rows >= acked,
            "{rows} samples in the record after kill -9, {acked} acknowledged"
        );
    }
    let ys = offsets(&db);
    let worst = assert_rate_limited(&ys, 0.5, "kill -9");
    let span = ys.iter().map(|r| r.1.abs()).fold(0.0, f64::max);
    println!(
        "chaos phase 3: {kills} kill -9, {acked} samples acknowledged before the last, offset up to {span:.3} µm, largest step {worst:.3} µm"
    );
}

async fn chaos(seed: u64) {
    println!("chaos seed {seed} (replay with GEARCOMP_CHAOS_SEED={seed})");
    let mut rng = Rng::new(seed);
    simulator_restarts(&mut rng).await;
    mqtt_faults(&mut rng, seed).await;
    #[cfg(feature = "postgres")]
    tokio::task::block_in_place(|| kill_9(&mut rng));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn chaos_fixed_seed() {
    chaos(0x00C0_FFEE).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn chaos_fresh_seed() {
    let seed = std::env::var("GEARCOMP_CHAOS_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(1, |d| d.as_nanos() as u64)
        });
    chaos(seed).await;
}
