//! Sustained ingest into SQLite with the engine running, against a storage-only baseline
//! measured in the same run, and the latency from a completed scan to the offset leaving
//! the cycle.
//!
//! Figures (samples/s) are printed as well: samples per iteration / time per iteration.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{sync_channel, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use gearcomp_service::cycle::{Clock, Cycle, CycleParts, InputMsg, Live, OffsetOut};
use gearcomp_service::storage::{self, Record, StoreStats};
use gearcomp_thermal::presets::grinder;
use gearcomp_thermal::{Engine, EngineConfig};

const BATCH: u64 = 20_000;

#[cfg(feature = "postgres")]
#[path = "../tests/integration/postgres_common/mod.rs"]
mod postgres_common;

struct Pipeline {
    tx: SyncSender<InputMsg>,
    stats: Arc<StoreStats>,
    offsets: tokio::sync::watch::Receiver<OffsetOut>,
    clock: Clock,
    _dir: tempfile::TempDir,
}

const AB: &str = r#"
[[channels]]
name = "A"
sensor = { kind = "celsius" }
valid_min = -10.0
valid_max = 80.0
stale_timeout_s = 60.0
[[channels]]
name = "B"
sensor = { kind = "celsius" }
valid_min = -10.0
valid_max = 80.0
stale_timeout_s = 60.0
[[axes]]
name = "Z"
apply = { kind = "measuring_system" }
max_offset_um = 100.0
[[axes.terms]]
kind = "difference"
a = "A"
b = "B"
kz_um_per_c = -3.75
"#;

fn pipeline(cfg: EngineConfig) -> Pipeline {
    let dir = tempfile::tempdir().unwrap();
    let engine = Engine::new(&cfg).unwrap();
    let conn = storage::open(&dir.path().join("b.db")).unwrap();
    storage::register_names(&conn, engine.channel_names(), engine.axis_names(), &[]).unwrap();
    let stats = Arc::new(StoreStats::default());
    let (rec_tx, rec_rx) = sync_channel(1 << 16);
    let s2 = stats.clone();
    std::thread::spawn(move || storage::writer_loop(conn, rec_rx, Duration::from_millis(50), s2));
    let (off_tx, offsets) = tokio::sync::watch::channel(OffsetOut::default());
    let clock = Clock::new(0.0, 1.0);
    let live = Arc::new(Mutex::new(Live::new(
        engine.channel_names(),
        engine.axis_names(),
    )));
    let cycle = Cycle::new(CycleParts {
        engine,
        config: cfg,
        clock,
        period_s: 1.0,
        bumpless_step_um: 0.5,
        records: rec_tx,
        live,
        offsets: off_tx,
        shutdown: Arc::new(AtomicBool::new(false)),
    });
    let (tx, rx) = sync_channel(1 << 14);
    std::thread::spawn(move || cycle.run(rx));
    Pipeline {
        tx,
        stats,
        offsets,
        clock,
        _dir: dir,
    }
}

fn wait_committed(stats: &StoreStats, n: u64) {
    while stats.committed_samples.load(Ordering::Acquire) < n {
        std::thread::sleep(Duration::from_micros(200));
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("ingest");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(8));
    g.throughput(Throughput::Elements(BATCH));

    // Baseline: the store alone, samples straight into the writer thread.
    {
        let dir = tempfile::tempdir().unwrap();
        let conn = storage::open(&dir.path().join("base.db")).unwrap();
        let stats = Arc::new(StoreStats::default());
        let (tx, rx) = sync_channel::<Record>(1 << 16);
        let s2 = stats.clone();
        std::thread::spawn(move || storage::writer_loop(conn, rx, Duration::from_millis(50), s2));
        let mut sent = 0u64;
        g.bench_function("store_only_baseline", |b| {
            b.iter_custom(|iters| {
                let t0 = Instant::now();
                for _ in 0..iters {
                    for i in 0..BATCH {
                        tx.send(Record::Sample {
                            time_s: (sent + i) as f64 * 1e-3,
                            channel: (i % 4) as u16,
                            raw: 108.0,
                        })
                        .unwrap();
                    }
                    sent += BATCH;
                    wait_committed(&stats, sent);
                }
                t0.elapsed()
            })
        });
    }

    // PostgreSQL: the same samples through the PostgreSQL writer (binary COPY, batched
    // commits) into a server this benchmark starts, as a ratio to the SQLite store above.
    #[cfg(feature = "postgres")]
    let _server = match postgres_common::PgServer::try_start() {
        Err(why) => {
            println!("ingest/postgres_store skipped: no PostgreSQL server ({why})");
            None
        }
        Ok(server) => {
            let mut cfg = gearcomp_service::ServiceConfig::default();
            cfg.machine.name = "bench".into();
            cfg.storage.backend = gearcomp_service::config::StorageBackend::Postgres;
            cfg.storage.url = Some(server.url());
            let store = storage::open_store(&cfg).unwrap();
            store
                .register_names(&["a".into(), "b".into(), "c".into(), "d".into()], &[], &[])
                .unwrap();
            let stats = Arc::new(StoreStats::default());
            let (tx, rx) = sync_channel::<Record>(1 << 16);
            let _writer = store
                .spawn_writer(
                    rx,
                    storage::WriterParams {
                        commit_interval: Duration::from_millis(50),
                        clock: Clock::new(0.0, 1.0),
                    },
                    stats.clone(),
                )
                .unwrap();
            let mut sent = 0u64;
            g.bench_function("postgres_store", |b| {
                b.iter_custom(|iters| {
                    let t0 = Instant::now();
                    for _ in 0..iters {
                        for i in 0..BATCH {
                            tx.send(Record::Sample {
                                time_s: (sent + i) as f64 * 1e-3,
                                channel: (i % 4) as u16,
                                raw: 108.0,
                            })
                            .unwrap();
                        }
                        sent += BATCH;
                        wait_committed(&stats, sent);
                    }
                    t0.elapsed()
                })
            });
            Some((server, tx))
        }
    };

    // Service pipeline: samples → cycle thread (grinder engine steps on every complete
    // scan of its 4 Pt100/°C channels, averages and offsets recorded) → store.
    {
        let p = pipeline(grinder().config);
        let mut sent = 0u64;
        g.bench_function("cycle_engine_store", |b| {
            b.iter_custom(|iters| {
                let t0 = Instant::now();
                for _ in 0..iters {
                    for i in 0..BATCH {
                        let c = (i % 4) as u16;
                        let raw = if c < 2 {
                            107.8 + 1e-6 * (i % 1000) as f64
                        } else {
                            20.0
                        };
                        p.tx.send(InputMsg::Sample {
                            channel: c,
                            raw,
                            stamp_s: p.clock.now_s(),
                        })
                        .unwrap();
                    }
                    sent += BATCH;
                    wait_committed(&p.stats, sent);
                }
                t0.elapsed()
            })
        });
    }
    g.finish();

    // Latency: a complete scan arrives → the cycle steps → the changed offset is in the
    // output cell. Cz = −3.75·(A − B) with no averaging, dead band or rate limit, and A
    // alternating, so every scan changes the offset.
    let mut g = c.benchmark_group("latency");
    g.sample_size(20);
    g.measurement_time(Duration::from_secs(5));
    let mut p = pipeline(EngineConfig::from_toml_str(AB).unwrap());
    let mut k = 0u64;
    g.bench_function("scan_to_offset", |b| {
        b.iter(|| {
            k += 1;
            let seq0 = p.offsets.borrow_and_update().seq;
            let a = 24.0 + (k % 2) as f64;
            for (c, raw) in [(0u16, a), (1u16, 20.0)] {
                p.tx.send(InputMsg::Sample {
                    channel: c,
                    raw,
                    stamp_s: p.clock.now_s(),
                })
                .unwrap();
            }
            let t = Instant::now();
            while p.offsets.borrow().seq == seq0 {
                assert!(t.elapsed() < Duration::from_secs(1), "no offset");
                std::hint::spin_loop();
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
