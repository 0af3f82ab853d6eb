//! "A plant on one box": many simulated machines in one process, each with its own cycle
//! thread (16 °C channels read at 10 Hz, Cz = −3.75·(c0 − c1) stepped on every complete
//! scan) and its own record queue, all written by the process's one shared PostgreSQL
//! writer into a server that this benchmark starts (the integration tests' helper),
//! against a baseline of one machine and of the cycles alone measured in the same run.
//!
//! Measured per configuration: the sample rate achieved, the sample → offset latency (the
//! last sample of a scan leaves the source → the changed offset is seen by a task waiting
//! on the machine's output cell, as the OPC UA / Modbus / MQTT output tasks wait), p50 and
//! p99, and the record's write rate (committed samples per second); after the source stops,
//! every sample sent must be committed (nothing acknowledged is lost). The process's
//! resident memory (VmRSS) is read at the end of each measurement.
//!
//! `cargo bench -p gearcomp-service --bench plant` (machines: `PLANT_MACHINES`, default
//! 500; seconds measured: `PLANT_SECONDS`, default 10; `PLANT_RECORD_QUEUE` overrides the
//! record queue's capacity, e.g. 65536 to see what the earlier fixed queue held). A plain
//! binary (no criterion):
//! one long run per configuration is the measurement.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

#[cfg(feature = "postgres")]
#[path = "../tests/integration/postgres_common/mod.rs"]
mod postgres_common;

#[cfg(feature = "postgres")]
mod plant {
    use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
    use std::sync::mpsc::{sync_channel, SyncSender};
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    use gearcomp_service::cycle::{Clock, Cycle, CycleParts, InputMsg, Live, OffsetOut};
    use gearcomp_service::latency::Histogram;
    use gearcomp_service::storage::{self, Record, StoreStats, WriterParams};
    use gearcomp_service::ServiceConfig;
    use gearcomp_thermal::{Engine, EngineConfig};

    pub const CHANNELS: usize = 16;
    pub const RATE_HZ: f64 = 10.0;

    fn engine_toml() -> String {
        let mut s = String::new();
        for c in 0..CHANNELS {
            s += &format!(
                "[[channels]]\nname = \"c{c}\"\nsensor = {{ kind = \"celsius\" }}\n\
                 valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 60.0\n"
            );
        }
        s + "[[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\n\
             max_offset_um = 100.0\n[[axes.terms]]\nkind = \"difference\"\na = \"c0\"\n\
             b = \"c1\"\nkz_um_per_c = -3.75\n"
    }

    struct Machine {
        tx: SyncSender<InputMsg>,
        offsets: tokio::sync::watch::Receiver<OffsetOut>,
        stats: Arc<StoreStats>,
        writer: std::thread::JoinHandle<gearcomp_service::Result<()>>,
        cycle: std::thread::JoinHandle<()>,
    }

    /// Where a machine's records go.
    #[derive(Debug, Clone)]
    pub enum Sink {
        /// PostgreSQL at this URL, the process's shared writer, commits every `commit_s`;
        /// record queues of `queue` records (the store's own size when `None`).
        Postgres {
            url: String,
            commit_s: f64,
            queue: Option<usize>,
        },
        /// Nowhere: a thread receives and counts them (the cycle's cost alone); record
        /// queues of `queue` records (PostgreSQL's size when `None`).
        Discard { queue: Option<usize> },
    }

    fn machine(sink: &Sink, name: String, clock: Clock) -> Machine {
        let cfg = EngineConfig::from_toml_str(&engine_toml()).unwrap();
        let engine = Engine::new(&cfg).unwrap();
        let stats = Arc::new(StoreStats::default());
        let (rec_tx, writer) = match sink {
            Sink::Postgres {
                url,
                commit_s,
                queue,
            } => {
                let mut sc = ServiceConfig::default();
                sc.machine.name = name;
                sc.storage.backend = gearcomp_service::config::StorageBackend::Postgres;
                sc.storage.url = Some(url.to_string());
                let store = storage::open_store(&sc).unwrap();
                let (rec_tx, rec_rx) = sync_channel(queue.unwrap_or(store.record_queue()));
                store
                    .register_names(engine.channel_names(), engine.axis_names(), &[])
                    .unwrap();
                let writer = store
                    .spawn_writer(
                        rec_rx,
                        WriterParams {
                            commit_interval: Duration::from_secs_f64(*commit_s),
                            clock,
                        },
                        stats.clone(),
                    )
                    .unwrap();
                (rec_tx, writer)
            }
            Sink::Discard { queue } => {
                let (rec_tx, rec_rx) =
                    sync_channel(queue.unwrap_or(storage::postgres::RECORD_HANDOFF));
                let stats = stats.clone();
                let writer = std::thread::spawn(move || {
                    for r in rec_rx {
                        if matches!(r, Record::Sample { .. }) {
                            stats.committed_samples.fetch_add(1, Ordering::Release);
                        }
                    }
                    Ok(())
                });
                (rec_tx, writer)
            }
        };
        let (off_tx, offsets) = tokio::sync::watch::channel(OffsetOut::default());
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
        let cycle = std::thread::spawn(move || cycle.run(rx));
        Machine {
            tx,
            offsets,
            stats,
            writer,
            cycle,
        }
    }

    /// What one configuration achieved.
    pub struct Figures {
        pub machines: usize,
        pub sent_per_s: f64,
        pub p50_s: f64,
        pub p99_s: f64,
        pub scans: u64,
        pub committed_per_s: f64,
        pub drained_s: f64,
        pub lost: u64,
        pub rss_mb: f64,
        /// The machine's 1-minute load average at the end of the measurement.
        pub load: String,
    }

    /// The process's resident memory, MB (VmRSS of /proc/self/status).
    fn rss_mb() -> f64 {
        std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("VmRSS:"))
                    .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
            })
            .map_or(f64::NAN, |kb| kb / 1024.0)
    }

    /// Runs `n` machines for `secs` s (after 2 s of warm-up) into the server at `url`.
    pub fn run(label: &str, sink: &Sink, n: usize, secs: f64) -> Figures {
        let clock = Clock::new(0.0, 1.0);
        let machines: Vec<Machine> = (0..n)
            .map(|m| machine(sink, format!("{label}-{m}"), clock))
            .collect();
        let epoch = Instant::now();
        let sent_ns: Arc<Vec<AtomicU64>> = Arc::new((0..n).map(|_| AtomicU64::new(0)).collect());
        let hist = Arc::new(Histogram::default());
        let measuring = Arc::new(AtomicBool::new(false));

        // The output side: one task per machine waits on its offset cell (as the output
        // tasks of the service do) on a two-worker runtime.
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        for (m, mach) in machines.iter().enumerate() {
            let mut rx = mach.offsets.clone();
            let (sent_ns, hist, measuring) = (sent_ns.clone(), hist.clone(), measuring.clone());
            rt.spawn(async move {
                while rx.changed().await.is_ok() {
                    let now = epoch.elapsed().as_nanos() as u64;
                    let sent = sent_ns[m].load(Ordering::Acquire);
                    if measuring.load(Ordering::Relaxed) && sent > 0 && now >= sent {
                        hist.add(Duration::from_nanos(now - sent));
                    }
                }
            });
        }

        // The source: every 100 ms a scan of 16 channels per machine, the machines spread
        // evenly over the period; c0 alternates 24/25 °C so every scan changes the offset.
        let period = Duration::from_secs_f64(1.0 / RATE_HZ);
        let slot = period / n as u32;
        let warmup = Duration::from_secs(2);
        let total = warmup + Duration::from_secs_f64(secs);
        let mut sent = 0u64;
        let mut sent_at_measure = 0u64;
        let mut committed_at_measure = 0u64;
        let mut t_measure = Instant::now();
        let t0 = Instant::now();
        let committed = |ms: &[Machine]| -> u64 {
            ms.iter()
                .map(|m| m.stats.committed_samples.load(Ordering::Acquire))
                .sum()
        };
        let mut k = 0u64;
        'ticks: loop {
            for (m, mach) in machines.iter().enumerate() {
                let due = t0 + period * k as u32 + slot * m as u32;
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                }
                if t0.elapsed() >= total {
                    break 'ticks;
                }
                let a = 24.0 + (k % 2) as f64;
                let stamp_s = clock.now_s();
                for c in 0..CHANNELS as u16 {
                    let raw = if c == 0 { a } else { 20.0 };
                    if c == CHANNELS as u16 - 1 {
                        sent_ns[m].store(epoch.elapsed().as_nanos() as u64, Ordering::Release);
                    }
                    mach.tx
                        .send(InputMsg::Sample {
                            channel: c,
                            raw,
                            stamp_s,
                        })
                        .unwrap();
                }
                sent += CHANNELS as u64;
            }
            k += 1;
            if !measuring.load(Ordering::Relaxed) && t0.elapsed() >= warmup {
                measuring.store(true, Ordering::Relaxed);
                t_measure = Instant::now();
                sent_at_measure = sent;
                committed_at_measure = committed(&machines);
            }
        }
        let window = t_measure.elapsed().as_secs_f64();
        let sent_per_s = (sent - sent_at_measure) as f64 / window;
        let committed_per_s = (committed(&machines) - committed_at_measure) as f64 / window;
        measuring.store(false, Ordering::Relaxed);
        let rss_mb = rss_mb();
        let load = std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|s| s.split_whitespace().next().map(str::to_string))
            .unwrap_or_else(|| "?".into());

        // Drain: every sample sent must be committed.
        let t_drain = Instant::now();
        while committed(&machines) < sent && t_drain.elapsed() < Duration::from_secs(120) {
            std::thread::sleep(Duration::from_millis(20));
        }
        let drained_s = t_drain.elapsed().as_secs_f64();
        let lost = sent.saturating_sub(committed(&machines));
        for m in machines {
            let _ = m.tx.send(InputMsg::Shutdown);
            drop(m.tx);
            let _ = m.cycle.join();
            let _ = m.writer.join();
        }
        rt.shutdown_timeout(Duration::from_secs(5));
        Figures {
            machines: n,
            sent_per_s,
            p50_s: hist.quantile_s(0.5).unwrap_or(f64::NAN),
            p99_s: hist.quantile_s(0.99).unwrap_or(f64::NAN),
            scans: hist.count(),
            committed_per_s,
            drained_s,
            lost,
            rss_mb,
            load,
        }
    }
}

#[cfg(feature = "postgres")]
fn main() {
    // `cargo test --all-targets` builds benches; `cargo bench` passes --bench.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let n: usize = std::env::var("PLANT_MACHINES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(500);
    let secs: f64 = std::env::var("PLANT_SECONDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(10.0);
    // One read connection per machine and the shared writer's.
    let server = match postgres_common::PgServer::try_start_settings(&[
        format!("max_connections={}", 2 * n + 40),
        "shared_buffers=128MB".into(),
    ]) {
        Ok(s) => s,
        Err(why) => {
            println!("plant skipped: no PostgreSQL server ({why})");
            return;
        }
    };
    let url = server.url();
    println!(
        "plant: {} channels at {} Hz per machine, {secs} s measured after 2 s warm-up; \
         PostgreSQL on loopback, one shared writer per process",
        plant::CHANNELS,
        plant::RATE_HZ
    );
    let queue: Option<usize> = std::env::var("PLANT_RECORD_QUEUE")
        .ok()
        .and_then(|v| v.parse().ok());
    let pg = |commit_s: f64| plant::Sink::Postgres {
        url: url.clone(),
        commit_s,
        queue,
    };
    let runs = [
        ("baseline-1-machine-pg", pg(0.25), 1),
        ("cycles-only-no-record", plant::Sink::Discard { queue }, n),
        ("pg-commit-0.25s", pg(0.25), n),
        ("pg-commit-1s", pg(1.0), n),
    ];
    for (label, sink, machines) in runs {
        let f = plant::run(label, &sink, machines, secs);
        println!(
            "plant/{label:<22} {:>4} machines: {:>6.0} samples/s sent (target {:>6.0}), \
             sample→offset p50 {:.3} ms p99 {:.3} ms ({} scans), record {:>6.0} samples/s \
             committed, drained in {:.2} s, {} lost, RSS {:.0} MB, load {}",
            f.machines,
            f.sent_per_s,
            f.machines as f64 * plant::CHANNELS as f64 * plant::RATE_HZ,
            f.p50_s * 1e3,
            f.p99_s * 1e3,
            f.scans,
            f.committed_per_s,
            f.drained_s,
            f.lost,
            f.rss_mb,
            f.load
        );
    }
}

#[cfg(not(feature = "postgres"))]
fn main() {
    println!("plant skipped: built without the postgres feature");
}
