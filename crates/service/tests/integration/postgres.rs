//! The PostgreSQL record against a real server started by the test: every record type
//! round-trips and reads back exactly as from SQLite, several machines share a database,
//! the JPH0761598B2 grinder recorded by both backends at once gives the same offsets and the
//! same CSV export, and a server stopped mid-run loses no sample.
#![cfg(feature = "postgres")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;
use crate::postgres_common;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gearcomp_service::config::StorageBackend;
use gearcomp_service::cycle::{Clock, Cycle, CycleParts, InputMsg, Live, OffsetOut};
use gearcomp_service::storage::{
    self, open_store, Range, Record, SeriesKind, Store, StoreStats, WriterParams,
};
use gearcomp_service::ServiceConfig;
use gearcomp_thermal::presets::bundle;
use gearcomp_thermal::{Engine, Preset, Simulator};
use postgres_common::PgServer;

const ALL: Range = Range {
    from_s: f64::MIN,
    to_s: f64::MAX,
    limit: 100_000,
};

fn pg_cfg(server: &PgServer, machine: &str) -> ServiceConfig {
    let mut cfg = ServiceConfig::default();
    cfg.machine.name = machine.into();
    cfg.storage.backend = StorageBackend::Postgres;
    cfg.storage.url = Some(server.url());
    // Not the working directory's default: a test's spill must not outlive it.
    cfg.storage.spill_path = Some(std::env::temp_dir().join(format!(
        "gearcomp-spill-test-{}-{machine}.db",
        std::process::id()
    )));
    cfg
}

fn sqlite_cfg(dir: &std::path::Path) -> ServiceConfig {
    let mut cfg = ServiceConfig::default();
    cfg.storage.path = dir.join("ref.db");
    cfg
}

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

/// Starts the store's writer; the returned sender feeds it, joining returns its result.
fn writer(
    store: &Arc<dyn Store>,
    stats: &Arc<StoreStats>,
) -> (
    SyncSender<Record>,
    std::thread::JoinHandle<gearcomp_service::Result<()>>,
) {
    let (tx, rx) = sync_channel(1 << 16);
    let h = store
        .spawn_writer(
            rx,
            WriterParams {
                commit_interval: Duration::from_millis(20),
                clock: Clock::new(0.0, 1.0),
            },
            stats.clone(),
        )
        .unwrap();
    (tx, h)
}

fn every_record_type() -> Vec<Record> {
    let mut v = Vec::new();
    for i in 0..50 {
        v.push(Record::Sample {
            time_s: i as f64 * 0.5,
            channel: (i % 2) as u16,
            // Values that a decimal text round trip would not keep exactly, and a NaN.
            raw: if i == 7 {
                f64::NAN
            } else {
                108.0 + i as f64 / 3.0
            },
        });
    }
    for i in 0..10 {
        let t = i as f64 * 2.5 + 0.25;
        v.push(Record::Average {
            time_s: t,
            channel: 0,
            value: 20.0 + 0.1 * i as f64,
        });
        v.push(Record::Average {
            time_s: t,
            channel: 1,
            value: 21.0 + 0.7 * i as f64,
        });
        v.push(Record::Target {
            time_s: t - 0.1,
            target: 0,
            // Not −0.0: SQLite hands a stored −0.0 back as 0 (PostgreSQL keeps the sign).
            value: -1.5 * i as f64 - 0.25,
        });
        v.push(Record::Offset {
            time_s: t,
            axis: 0,
            offset_um: -3.75 * (0.6 * i as f64 - 1.0),
            target_um: 1.0 / 3.0,
            law_um: if i == 0 { f64::NAN } else { 2.0 / 7.0 },
            status: "updated",
        });
    }
    v.push(Record::AlarmRaised {
        time_s: 3.0,
        key: "channel.a_c.range".into(),
        message: "a_c = 99 °C: expected −10…80 °C".into(),
    });
    v.push(Record::AlarmRaised {
        time_s: 4.0,
        key: "mqtt.connection".into(),
        message: "broker gone".into(),
    });
    v.push(Record::AlarmCleared {
        time_s: 5.5,
        key: "channel.a_c.range".into(),
    });
    v.push(Record::Audit {
        token_id: "0badc0de".into(),
        role: "operator",
        action: "change_model",
        detail: "123 bytes".into(),
    });
    v.push(Record::Model {
        source: "api:0badc0de".into(),
        config_toml: "[[channels]]\n".into(),
    });
    v
}

/// Writes `records` through a store and returns it with its counters.
fn write_through(store: Arc<dyn Store>, records: &[Record]) -> (Arc<dyn Store>, Arc<StoreStats>) {
    store
        .register_names(
            &names(&["a_c", "b_c"]),
            &names(&["X"]),
            &names(&["drift_um"]),
        )
        .unwrap();
    let stats = Arc::new(StoreStats::default());
    let (tx, h) = writer(&store, &stats);
    for r in records {
        tx.send(r.clone()).unwrap();
    }
    drop(tx);
    h.join().unwrap().unwrap();
    (store, stats)
}

#[test]
fn every_record_type_round_trips_as_in_sqlite_and_machines_stay_apart() {
    let server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let recs = every_record_type();
    let (pg, pg_stats) = write_through(open_store(&pg_cfg(&server, "gs300-1")).unwrap(), &recs);
    let (sq, _) = write_through(open_store(&sqlite_cfg(dir.path())).unwrap(), &recs);
    assert_eq!(pg.backend(), "postgres");
    assert!(!pg.describe().contains("password"));

    // Acknowledge the first alarm the way the API does (through the writer).
    for s in [&pg, &sq] {
        let a = s.alarms(false, 10).unwrap();
        let id = a.iter().find(|r| r.key == "channel.a_c.range").unwrap().id;
        assert!(s.alarm_exists(id).unwrap());
        write_through(
            s.clone(),
            &[Record::AlarmAcknowledged {
                id,
                by: "0badc0de".into(),
            }],
        );
    }

    // Hand-written expectations (independent of either backend).
    assert_eq!(pg_stats.committed_samples.load(Ordering::Acquire), 50);
    assert_eq!(pg_stats.last_sample_id.load(Ordering::Acquire), 50);
    assert_eq!(pg.sample_totals().unwrap(), (50, 50));
    let raw1 = pg.channel_history(1, SeriesKind::Raw, ALL).unwrap();
    assert_eq!(raw1.len(), 25);
    assert_eq!(raw1[3].time_s, 3.5);
    assert_eq!(raw1[3].value, None, "NaN is stored as NULL");
    assert_eq!(raw1[4].value, Some(108.0 + 9.0 / 3.0));
    let cut = pg
        .channel_history(
            0,
            SeriesKind::Raw,
            Range {
                from_s: 2.0,
                to_s: 6.0,
                limit: 3,
            },
        )
        .unwrap();
    // Samples of channel 0 at 2, 3, 4, 5, 6 s; the newest three are kept, oldest first.
    let ts: Vec<f64> = cut.iter().map(|p| p.time_s).collect();
    assert_eq!(ts, vec![4.0, 5.0, 6.0]);
    let offs = pg.offset_history(ALL).unwrap();
    assert_eq!(offs.len(), 10);
    assert_eq!(offs[0].axis, "X");
    assert_eq!(offs[0].law_um, None);
    assert_eq!(offs[1].target_um, Some(1.0 / 3.0));
    assert_eq!(offs[1].law_um, Some(2.0 / 7.0));
    let alarms = pg.alarms(false, 10).unwrap();
    assert_eq!(alarms.len(), 2);
    assert_eq!(alarms[0].key, "mqtt.connection", "newest first");
    assert_eq!(alarms[1].cleared_s, Some(5.5));
    assert_eq!(alarms[1].acknowledged_by.as_deref(), Some("0badc0de"));
    assert_eq!(alarms[1].message, "a_c = 99 °C: expected −10…80 °C");
    // Active = not cleared or not acknowledged: only the MQTT alarm is left.
    assert_eq!(pg.alarms(true, 10).unwrap().len(), 1);
    let audit = pg.audit_log(10).unwrap();
    assert_eq!(audit.len(), 1);
    assert_eq!(
        (audit[0].action.as_str(), audit[0].role.as_str()),
        ("change_model", "operator")
    );

    // Every query reads the same from both backends.
    for c in 0..2u16 {
        for k in [SeriesKind::Raw, SeriesKind::Average] {
            assert_eq!(
                pg.channel_history(c, k, ALL).unwrap(),
                sq.channel_history(c, k, ALL).unwrap()
            );
        }
    }
    assert_eq!(offs, sq.offset_history(ALL).unwrap());
    let strip = |v: Vec<storage::AlarmRow>| {
        v.into_iter()
            .map(|a| (a.time_s, a.key, a.message, a.cleared_s, a.acknowledged_by))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        strip(pg.alarms(false, 10).unwrap()),
        strip(sq.alarms(false, 10).unwrap())
    );
    assert_eq!(pg.export_data().unwrap(), sq.export_data().unwrap());
    let (a, b) = (dir.path().join("pg.csv"), dir.path().join("sq.csv"));
    let n = storage::export_csv_from(&*pg, &a).unwrap();
    assert_eq!(n, storage::export_csv_from(&*sq, &b).unwrap());
    assert!(n >= 9, "{n}");
    assert_eq!(
        std::fs::read_to_string(&a).unwrap(),
        std::fs::read_to_string(&b).unwrap()
    );

    // A second machine in the same database: its own ids, names and rows only.
    let other = open_store(&pg_cfg(&server, "hob-2")).unwrap();
    other
        .register_names(&names(&["oil_c"]), &names(&["Z"]), &[])
        .unwrap();
    let (tx, h) = writer(&other, &Arc::new(StoreStats::default()));
    tx.send(Record::Sample {
        time_s: 1.0,
        channel: 0,
        raw: 42.0,
    })
    .unwrap();
    drop(tx);
    h.join().unwrap().unwrap();
    assert_eq!(other.sample_totals().unwrap(), (1, 1));
    assert_eq!(other.alarms(false, 10).unwrap().len(), 0);
    assert_eq!(pg.sample_totals().unwrap(), (50, 50));
    assert_eq!(other.export_data().unwrap().channels, names(&["oil_c"]));
    // A second writer for a machine that has one running is refused.
    let stats = Arc::new(StoreStats::default());
    let (_tx, _h) = writer(&pg, &stats);
    let (_rx2_tx, rx2) = sync_channel(1);
    let e = pg
        .spawn_writer(
            rx2,
            WriterParams {
                commit_interval: Duration::from_millis(20),
                clock: Clock::new(0.0, 1.0),
            },
            stats,
        )
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("machine.name") && e.contains("gs300-1"), "{e}");

    // The layout is fixed per machine; the schema is created once and versioned.
    let e = pg
        .register_names(&names(&["b_c", "a_c"]), &names(&["X"]), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("channels[0]") && e.contains("b_c"), "{e}");
    open_store(&pg_cfg(&server, "gs300-1")).unwrap();
    let mut c = server.client();
    let v: Vec<i32> = c
        .query("SELECT version FROM gearcomp_schema", &[])
        .unwrap()
        .iter()
        .map(|r| r.get(0))
        .collect();
    // Version 2 added the resume state (bumpless restart).
    assert_eq!(v, vec![1, 2]);
    let machines: i64 = c
        .query_one("SELECT COUNT(*) FROM machines", &[])
        .unwrap()
        .get(0);
    assert_eq!(machines, 2);
}

/// Runs the JPH0761598B2 grinder (the grinder preset's simulator and engine) through the
/// service's simulator and cycle threads for `wall`, with every record sent to both stores.
fn grinder_into_both(pg: &Arc<dyn Store>, sq: &Arc<dyn Store>, wall: Duration) {
    let b = bundle(Preset::from_name("grinder").unwrap());
    let engine = Engine::new(&b.config).unwrap();
    let sim = Simulator::new(b.machine.clone(), 1).unwrap();
    let channels = engine.channel_names().to_vec();
    let axes = engine.axis_names().to_vec();
    let map = gearcomp_service::sources::sim::channel_map(&sim, &channels).unwrap();
    let targets = names(&["measured_drift_um"]);
    let mut handles = Vec::new();
    let mut senders = Vec::new();
    let clock = Clock::new(0.0, 20_000.0);
    for s in [pg, sq] {
        s.register_names(&channels, &axes, &targets).unwrap();
        let stats = Arc::new(StoreStats::default());
        let (tx, rx) = sync_channel(1 << 16);
        handles.push(
            s.spawn_writer(
                rx,
                WriterParams {
                    commit_interval: Duration::from_millis(100),
                    clock,
                },
                stats,
            )
            .unwrap(),
        );
        senders.push(tx);
    }
    let (rec_tx, rec_rx) = sync_channel::<Record>(1 << 16);
    let tee = std::thread::spawn(move || {
        for r in rec_rx {
            for s in &senders {
                s.send(r.clone()).unwrap();
            }
        }
    });
    let period_s = sim.spec().dt_s;
    let shutdown = Arc::new(AtomicBool::new(false));
    let (off_tx, _off_rx) = tokio::sync::watch::channel(OffsetOut::default());
    let cycle = Cycle::new(CycleParts {
        engine,
        config: b.config.clone(),
        clock,
        period_s,
        bumpless_step_um: 0.5,
        records: rec_tx,
        live: Arc::new(Mutex::new(Live::new(&channels, &axes))),
        offsets: off_tx,
        shutdown: shutdown.clone(),
    });
    let (in_tx, in_rx) = sync_channel(1 << 14);
    let cycle_thread = std::thread::spawn(move || cycle.run(in_rx));
    let sd = shutdown.clone();
    let sim_tx = in_tx.clone();
    let sim_thread = std::thread::spawn(move || {
        gearcomp_service::sources::sim::run(sim, map, clock, sim_tx, sd)
    });
    std::thread::sleep(wall);
    shutdown.store(true, Ordering::Release);
    sim_thread.join().unwrap();
    let _ = in_tx.send(InputMsg::Shutdown);
    drop(in_tx);
    cycle_thread.join().unwrap();
    tee.join().unwrap();
    for h in handles {
        h.join().unwrap().unwrap();
    }
}

#[test]
fn seed001_grinder_stores_the_same_offsets_in_postgres_as_in_sqlite() {
    let server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let pg = open_store(&pg_cfg(&server, "grinder-1")).unwrap();
    let sq = open_store(&sqlite_cfg(dir.path())).unwrap();
    grinder_into_both(&pg, &sq, Duration::from_millis(1500));

    let offs = pg.offset_history(ALL).unwrap();
    assert!(offs.len() > 100, "{}", offs.len());
    assert_eq!(offs, sq.offset_history(ALL).unwrap(), "bit-identical rows");
    for c in 0..4u16 {
        assert_eq!(
            pg.channel_history(c, SeriesKind::Average, ALL).unwrap(),
            sq.channel_history(c, SeriesKind::Average, ALL).unwrap()
        );
    }
    assert_eq!(pg.sample_totals().unwrap(), sq.sample_totals().unwrap());

    // Independent reference: JPH0761598B2's law Cz = Kz·(A − B), Kz = −3.75 µm/°C, on the
    // averaged bed-top (A) and wheel-head (B) temperatures of the same cycle.
    let a = pg.channel_history(0, SeriesKind::Average, ALL).unwrap();
    let bb = pg.channel_history(1, SeriesKind::Average, ALL).unwrap();
    let mut checked = 0;
    // A frozen axis (a channel went stale: on a loaded machine the simulator's scans can
    // arrive late in service time) keeps its last law value while averages move on, so
    // only rows whose law was evaluated in their own cycle are compared.
    for o in offs.iter().filter(|o| {
        o.law_um.is_some() && !matches!(o.status.as_str(), "frozen" | "stopped" | "starting")
    }) {
        let at = |v: &[storage::Point]| {
            v.iter()
                .find(|p| p.time_s == o.time_s)
                .and_then(|p| p.value)
        };
        if let (Some(x), Some(y)) = (at(&a), at(&bb)) {
            let law = o.law_um.unwrap();
            assert!((law - -3.75 * (x - y)).abs() < 1e-9, "{law} vs {x} {y}");
            checked += 1;
        }
    }
    assert!(checked > 100, "{checked}");

    // The export `gearcomp fit` reads is the same file from either backend.
    let (p, q) = (dir.path().join("pg.csv"), dir.path().join("sq.csv"));
    let rows = storage::export_csv_from(&*pg, &p).unwrap();
    assert!(rows > 100, "{rows}");
    assert_eq!(rows, storage::export_csv_from(&*sq, &q).unwrap());
    let text = std::fs::read_to_string(&p).unwrap();
    assert_eq!(text, std::fs::read_to_string(&q).unwrap());
    assert!(text.starts_with(
        "time_s,bed_top_c,wheel_head_c,column_c,oil_c,measured_drift_um,Z_offset_um\n"
    ));
}

/// The fallback when the spill file cannot be written (its folder is a plain file): the
/// behaviour without a spill, raw samples dropped beyond the bound, counted and alarmed.
#[test]
fn an_unwritable_spill_file_falls_back_to_dropping_raw_samples_with_an_alarm() {
    let mut server = PgServer::start();
    let mut cfg = pg_cfg(&server, "small-buffer");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("not-a-folder"), b"x").unwrap();
    cfg.storage.spill_path = Some(dir.path().join("not-a-folder").join("spill.db"));
    cfg.storage.buffer_records = 1000;
    cfg.storage.reconnect.min_s = 0.05;
    cfg.storage.reconnect.max_s = 0.2;
    let store = open_store(&cfg).unwrap();
    store
        .register_names(&names(&["a_c"]), &names(&["X"]), &[])
        .unwrap();
    let stats = Arc::new(StoreStats::default());
    let (tx, h) = writer(&store, &stats);
    server.stop();
    // 3000 samples and 10 averages while the server is down: the first 1000 samples fit.
    for i in 0..3000 {
        tx.send(Record::Sample {
            time_s: i as f64,
            channel: 0,
            raw: i as f64,
        })
        .unwrap();
        if i % 300 == 0 {
            tx.send(Record::Average {
                time_s: i as f64,
                channel: 0,
                value: 1.0,
            })
            .unwrap();
        }
    }
    let deadline = Instant::now() + Duration::from_secs(10);
    while stats.dropped_records.load(Ordering::Acquire) < 2000 - 5 {
        assert!(Instant::now() < deadline, "nothing dropped");
        std::thread::sleep(Duration::from_millis(20));
    }
    while !stats.unreachable.load(Ordering::Acquire) {
        assert!(Instant::now() < deadline, "the outage was not noticed");
        std::thread::sleep(Duration::from_millis(20));
    }
    server.restart();
    drop(tx);
    h.join().unwrap().unwrap();
    assert!(!stats.unreachable.load(Ordering::Acquire));
    let raw = store.channel_history(0, SeriesKind::Raw, ALL).unwrap();
    // The bound counts records: the oldest samples are kept, contiguous, until samples and
    // averages (and the outage alarm, if it came first) fill the 1000 places.
    let k = raw.len();
    assert!((995..=996).contains(&k), "{k}");
    for (i, p) in raw.iter().enumerate() {
        assert_eq!((p.time_s, p.value), (i as f64, Some(i as f64)));
    }
    assert_eq!(
        store
            .channel_history(0, SeriesKind::Average, ALL)
            .unwrap()
            .len(),
        10
    );
    // Every later sample dropped and counted (the averages after the bound are kept).
    assert_eq!(
        stats.dropped_records.load(Ordering::Acquire),
        3000 - k as u64
    );
    let alarms = store.alarms(false, 10).unwrap();
    let keys: Vec<&str> = alarms.iter().map(|a| a.key.as_str()).collect();
    for k in [
        "storage.connection",
        "storage.buffer_full",
        "storage.records_dropped",
    ] {
        assert!(keys.contains(&k), "{keys:?}");
    }
    assert!(!keys.contains(&"storage.spilling"), "{keys:?}");
    let full = alarms
        .iter()
        .find(|a| a.key == "storage.buffer_full")
        .unwrap();
    assert!(
        full.message.contains("not-a-folder") && full.message.contains("cannot be written"),
        "{}",
        full.message
    );
    let note = alarms
        .iter()
        .find(|a| a.key == "storage.records_dropped")
        .unwrap();
    assert!(
        note.message.starts_with(&format!("{} records", 3000 - k)),
        "{}",
        note.message
    );
    assert!(alarms.iter().all(|a| a.cleared_s.is_some()), "{alarms:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn postgres_stopped_mid_run_loses_no_sample_and_raises_an_alarm() {
    let mut server = tokio::task::block_in_place(PgServer::start);
    let dir = tempfile::tempdir().unwrap();
    let toml = format!(
        "[machine]\nname = \"gs300-7\"\n[storage]\nbackend = \"postgres\"\nurl = \"{}\"\n\
         commit_interval_s = 0.1\nreconnect = {{ min_s = 0.05, max_s = 0.3 }}\n\
         [http]\nport = 0\n[input]\nkind = \"simulator\"\nspeedup = 6000\n",
        server.url()
    );
    let running = common::start_with(dir.path(), &toml).await;
    let token = running.generated.clone().unwrap().read_only;
    let api = common::Api::new(&running);
    api.wait_for("/api/status", &token, 20.0, |v| {
        v["committed_samples"].as_u64().unwrap_or(0) > 200
    })
    .await;
    let down_at = running.stats.commits.load(Ordering::Acquire);
    tokio::task::block_in_place(|| server.stop());
    let st = api
        .wait_for("/api/status", &token, 10.0, |v| {
            v["storage"]["reachable"] == false
                && v["storage"]["buffered_records"].as_u64().unwrap_or(0) > 500
        })
        .await;
    assert_eq!(st["storage"]["backend"], "postgres");
    // The compensation keeps running while the record waits in memory.
    let cycles = st["cycles"].as_u64().unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (_, st2) = api.get("/api/status", Some(&token)).await;
    assert!(st2["cycles"].as_u64().unwrap() > cycles);
    assert!(running.stats.commits.load(Ordering::Acquire) <= down_at + 1);
    tokio::task::block_in_place(|| server.restart());
    api.wait_for("/api/status", &token, 20.0, |v| {
        v["storage"]["reachable"] == true && v["storage"]["buffered_records"] == 0
    })
    .await;
    let store = running.store.clone();
    let committed = running.stop().await.unwrap();

    // Synchronous PostgreSQL clients must not run (or close) on an async worker.
    tokio::task::block_in_place(move || check_no_gap(&server, store, committed));
}

fn check_no_gap(server: &PgServer, store: Arc<dyn Store>, committed: u64) {
    // No sample lost: ids 1…N contiguous, N = every acknowledged sample, and each
    // channel's samples follow the simulator's scan step with no gap across the outage.
    let mut c = server.client();
    let (n, max_id): (i64, i64) = {
        let r = c
            .query_one(
                "SELECT COUNT(*), MAX(s.id) FROM samples s JOIN machines m \
                 ON m.id = s.machine_id WHERE m.name = 'gs300-7'",
                &[],
            )
            .unwrap();
        (r.get(0), r.get(1))
    };
    assert_eq!(n as u64, committed);
    assert_eq!(max_id, n);
    let dt = Simulator::new(bundle(Preset::from_name("grinder").unwrap()).machine, 0)
        .unwrap()
        .spec()
        .dt_s;
    let raw = store.channel_history(0, SeriesKind::Raw, ALL).unwrap();
    assert_eq!(raw.len() as u64 * 4, committed);
    for w in raw.windows(2) {
        assert!(
            (w[1].time_s - w[0].time_s - dt).abs() < 1e-6,
            "gap {} → {}",
            w[0].time_s,
            w[1].time_s
        );
    }
    let alarms = store.alarms(false, 50).unwrap();
    let a = alarms
        .iter()
        .find(|a| a.key == "storage.connection")
        .expect("connection alarm recorded");
    assert!(a.message.contains("unreachable"), "{}", a.message);
    let cleared = a.cleared_s.expect("cleared after the reconnect");
    assert!(cleared > a.time_s);
    assert!(raw[0].time_s < a.time_s && a.time_s < raw.last().unwrap().time_s);
}

/// `(machine name, sample id, raw)` of every stored sample of the named machines.
fn stored_samples(server: &PgServer, machine: &str) -> Vec<(i64, f64)> {
    server
        .client()
        .query(
            "SELECT s.id, s.raw FROM samples s JOIN machines m ON m.id = s.machine_id \
             WHERE m.name = $1 ORDER BY s.id",
            &[&machine],
        )
        .unwrap()
        .iter()
        .map(|r| (r.get(0), r.get(1)))
        .collect()
}

#[test]
fn machines_of_one_process_share_one_writer_and_each_keeps_exactly_once_and_its_resume_state() {
    let mut server = PgServer::start();
    let names_of = ["share-a", "share-b", "share-c"];
    let params = || WriterParams {
        commit_interval: Duration::from_millis(100),
        clock: Clock::new(0.0, 1.0),
    };
    let open = |name: &str| {
        let mut cfg = pg_cfg(&server, name);
        cfg.storage.reconnect = gearcomp_service::config::Backoff {
            min_s: 0.05,
            max_s: 0.2,
        };
        let s = open_store(&cfg).unwrap();
        s.register_names(&names(&["a_c"]), &names(&["X"]), &[])
            .unwrap();
        s
    };
    let stores: Vec<Arc<dyn Store>> = names_of.iter().map(|n| open(n)).collect();
    let stats: Vec<Arc<StoreStats>> = (0..3).map(|_| Arc::new(StoreStats::default())).collect();
    let mut txs = Vec::new();
    let mut handles = Vec::new();
    for (s, st) in stores.iter().zip(&stats) {
        let (tx, rx) = sync_channel(s.record_queue());
        handles.push(s.spawn_writer(rx, params(), st.clone()).unwrap());
        txs.push(tx);
    }
    // One session holds the three machines' writer locks (one writer per machine would
    // hold them in three).
    let held: (i64, i64) = {
        let r = server
            .client()
            .query_one(
                "SELECT COUNT(DISTINCT l.pid), COUNT(*) FROM pg_locks l JOIN machines m \
                 ON l.objid::int = m.id WHERE l.locktype = 'advisory' AND l.granted \
                 AND l.classid::int = 1734569837 AND m.name LIKE 'share-%'",
                &[],
            )
            .unwrap();
        (r.get(0), r.get(1))
    };
    assert_eq!(held, (1, 3));

    // Each machine sends its own numbered samples (raw = its own count) and, with every
    // scan, an offset and a resume state; machine c sends 3 times as many.
    let feed = |txs: &[SyncSender<Record>], from: &mut [u64; 3], scans: u64| {
        for k in 0..scans {
            for (m, tx) in txs.iter().enumerate() {
                let per = if m == 2 { 3 } else { 1 };
                for _ in 0..per {
                    from[m] += 1;
                    tx.send(Record::Sample {
                        time_s: from[m] as f64,
                        channel: 0,
                        raw: from[m] as f64,
                    })
                    .unwrap();
                }
                tx.send(Record::Offset {
                    time_s: from[m] as f64,
                    axis: 0,
                    offset_um: m as f64 + k as f64 * 1e-3,
                    target_um: 0.0,
                    law_um: 0.0,
                    status: "ok",
                })
                .unwrap();
                tx.send(Record::Resume {
                    time_s: from[m] as f64,
                    state: format!("{}:{}", names_of[m], from[m]),
                })
                .unwrap();
            }
            std::thread::sleep(Duration::from_micros(200));
        }
    };
    let mut sent = [0u64; 3];
    feed(&txs, &mut sent, 1500);
    // The server goes away mid-run and comes back: commits in doubt are settled per
    // machine, nothing is lost or written twice.
    server.stop();
    feed(&txs, &mut sent, 1500);
    std::thread::sleep(Duration::from_millis(300));
    server.restart();
    feed(&txs, &mut sent, 1500);
    drop(txs);
    for h in handles {
        h.join().unwrap().unwrap();
    }
    let mut c = server.client();
    for (m, name) in names_of.iter().enumerate() {
        let rows = stored_samples(&server, name);
        // Ids 1…N with raw = id: every sample once, in order, none from another machine.
        assert_eq!(rows.len() as u64, sent[m], "{name}");
        for (i, (id, raw)) in rows.iter().enumerate() {
            assert_eq!((*id, *raw), (i as i64 + 1, (i + 1) as f64), "{name}");
        }
        assert_eq!(stats[m].committed_samples.load(Ordering::Acquire), sent[m]);
        assert_eq!(stats[m].last_sample_id.load(Ordering::Acquire), sent[m]);
        // Its own resume state, the newest, committed with its last offset row.
        assert_eq!(
            stores[m].resume_state().unwrap(),
            Some(format!("{name}:{}", sent[m]))
        );
        let same: bool = c
            .query_one(
                "SELECT r.xmin::text = (SELECT o.xmin::text FROM offsets o \
                 WHERE o.machine_id = r.machine_id ORDER BY o.id DESC LIMIT 1) \
                 FROM resume_state r JOIN machines m ON m.id = r.machine_id WHERE m.name = $1",
                &[name],
            )
            .unwrap()
            .get(0);
        assert!(same, "{name}");
        // Its own outage alarm, raised and cleared.
        let alarms = stores[m].alarms(false, 10).unwrap();
        assert!(
            alarms
                .iter()
                .any(|a| a.key == "storage.connection" && a.cleared_s.is_some()),
            "{name}: {alarms:?}"
        );
    }
    // The machines' rows went in together: transactions holding samples of all three.
    let shared: i64 = c
        .query_one(
            "SELECT COUNT(*) FROM (SELECT s.xmin::text FROM samples s JOIN machines m \
             ON m.id = s.machine_id WHERE m.name LIKE 'share-%' GROUP BY 1 \
             HAVING COUNT(DISTINCT s.machine_id) = 3) t",
            &[],
        )
        .unwrap()
        .get(0);
    assert!(shared >= 1, "{shared}");
    // Every machine has left: the shared writer's session and locks are gone.
    let locks: i64 = c
        .query_one(
            "SELECT COUNT(*) FROM pg_locks WHERE locktype = 'advisory' \
             AND classid::int = 1734569837",
            &[],
        )
        .unwrap()
        .get(0);
    assert_eq!(locks, 0);
}

#[test]
fn a_machine_whose_records_the_server_refuses_holds_back_only_itself() {
    let server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let params = || WriterParams {
        commit_interval: Duration::from_millis(50),
        clock: Clock::new(0.0, 1.0),
    };
    let start = |name: &str| {
        let mut cfg = pg_cfg(&server, name);
        cfg.storage.spill_path = Some(dir.path().join(format!("{name}.db")));
        cfg.storage.reconnect = gearcomp_service::config::Backoff {
            min_s: 0.05,
            max_s: 0.2,
        };
        let s = open_store(&cfg).unwrap();
        s.register_names(&names(&["a_c"]), &names(&["X"]), &[])
            .unwrap();
        let stats = Arc::new(StoreStats::default());
        let (tx, rx) = sync_channel(s.record_queue());
        let h = s.spawn_writer(rx, params(), stats.clone()).unwrap();
        (tx, h, stats)
    };
    let (tx_a, _h_a, stats_a) = start("refused-a");
    let (tx_b, h_b, stats_b) = start("refused-b");
    let sample = |i: u64| Record::Sample {
        time_s: i as f64,
        channel: 0,
        raw: i as f64,
    };
    for i in 1..=100 {
        tx_a.send(sample(i)).unwrap();
    }
    let t0 = Instant::now();
    while stats_a.committed_samples.load(Ordering::Acquire) < 100 {
        assert!(t0.elapsed() < Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(10));
    }
    // A record the server refuses for good (here a constraint the test adds; in a plant
    // e.g. a trigger or a full tablespace): machine a's next chunk can never be written.
    server
        .client()
        .batch_execute(
            "ALTER TABLE alarms ADD CONSTRAINT refused_for_test CHECK (key <> 'input.refused')",
        )
        .unwrap();
    tx_a.send(Record::AlarmRaised {
        time_s: 100.5,
        key: "input.refused".into(),
        message: "refused".into(),
    })
    .unwrap();
    // A NUL character, which PostgreSQL's text cannot hold, no longer holds a machine
    // back: machine b's alarm is stored with U+FFFD in its place.
    tx_b.send(Record::AlarmRaised {
        time_s: 0.5,
        key: "input.bad\0key".into(),
        message: "bad\0text".into(),
    })
    .unwrap();
    for i in 101..=200 {
        tx_a.send(sample(i)).unwrap();
    }
    // Machine b, sharing the writer, goes on committing everything.
    for i in 1..=1000 {
        tx_b.send(sample(i)).unwrap();
        if i % 100 == 0 {
            std::thread::sleep(Duration::from_millis(30));
        }
    }
    drop(tx_b);
    h_b.join().unwrap().unwrap();
    assert_eq!(stats_b.committed_samples.load(Ordering::Acquire), 1000);
    let rows = stored_samples(&server, "refused-b");
    assert_eq!(rows.len(), 1000);
    assert!(rows
        .iter()
        .enumerate()
        .all(|(i, r)| *r == (i as i64 + 1, (i + 1) as f64)));
    let alarm = server
        .client()
        .query_one(
            "SELECT a.key, a.message FROM alarms a JOIN machines m ON m.id = a.machine_id \
             WHERE m.name = 'refused-b'",
            &[],
        )
        .unwrap();
    assert_eq!(alarm.get::<_, String>(0), "input.bad\u{FFFD}key");
    assert_eq!(alarm.get::<_, String>(1), "bad\u{FFFD}text");
    // Machine a kept its first 100 and holds the rest, flagged, in order.
    assert_eq!(stats_a.committed_samples.load(Ordering::Acquire), 100);
    assert_eq!(stored_samples(&server, "refused-a").len(), 100);
    assert!(stats_a.unreachable.load(Ordering::Acquire));
    assert!(stats_a.buffered_records.load(Ordering::Acquire) >= 101);
}
