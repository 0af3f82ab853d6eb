//! Wires the service together: engine, store, cycle thread, inputs, HTTP; runs until a
//! signal or the requested duration, then stops in order (inputs, cycle, store) so the
//! last cycle is recorded and committed.

use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::sync_channel;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gearcomp_thermal::presets::bundle;
use gearcomp_thermal::{Engine, EngineConfig, Preset, Simulator};

use crate::auth::Tokens;
use crate::clock::Clock;
use crate::config::{InputSection, MachineEntry, ServiceConfig};
use crate::cycle::{Cycle, CycleParts, InputMsg, Live, OffsetOut, ResumeState};
use crate::error::{Result, ServiceError};
use crate::http::{self, AppState, ModelInfo};
use crate::storage::{self, StoreStats};

/// Command-line overrides of the configuration.
#[derive(Debug, Clone, Default)]
pub struct Overrides {
    /// Stop after this many wall-clock seconds (tests, demonstrations).
    pub duration_s: Option<f64>,
    /// Simulator speed-up.
    pub speedup: Option<f64>,
    /// HTTP port (0 = any free port).
    pub port: Option<u16>,
    /// Database file.
    pub db: Option<PathBuf>,
}

/// Capacity of the input queue (messages; declared with the input adapters that fill it).
pub use crate::sources::INPUT_QUEUE;
/// Capacity of the record queue (records) with SQLite; a full queue holds the cycle back
/// rather than dropping a sample. Each backend sizes its own (`Store::record_queue`).
pub use crate::storage::RECORD_QUEUE;

/// The engine configuration and where it came from.
pub fn engine_config(cfg: &ServiceConfig) -> Result<(EngineConfig, String)> {
    if let Some(f) = &cfg.engine.file {
        let c = EngineConfig::load(f).map_err(|e| ServiceError::EngineFile {
            path: f.display().to_string(),
            message: crate::error::shorten_message(&e.to_string()),
        })?;
        return Ok((c, f.display().to_string()));
    }
    let p = preset_of(cfg)?;
    Ok((bundle(p).config, format!("preset:{}", p.name())))
}

fn preset_of(cfg: &ServiceConfig) -> Result<Preset> {
    let sim_preset = match &cfg.input {
        InputSection::Simulator { preset, .. } => preset.clone(),
        #[allow(unreachable_patterns)]
        _ => None,
    };
    let name = cfg
        .engine
        .preset
        .clone()
        .or(sim_preset)
        .unwrap_or_else(|| "grinder".into());
    Ok(Preset::from_name(&name)?)
}

fn input_name(cfg: &ServiceConfig) -> String {
    match &cfg.input {
        InputSection::Simulator { .. } => "simulator".into(),
        #[cfg(feature = "mqtt")]
        InputSection::Mqtt(m) => format!("mqtt {}:{}", m.host, m.port),
        #[cfg(feature = "modbus")]
        InputSection::Modbus(m) => format!("modbus ({} module(s))", m.modules.len()),
        #[cfg(feature = "opcua")]
        InputSection::OpcUa(o) => format!("opcua {}", o.endpoint),
        InputSection::Replay(r) => format!("replay {}", r.path.display()),
    }
}

/// Runs the service until ctrl-c, SIGTERM or the duration; returns after everything is
/// flushed.
pub fn serve(cfg: ServiceConfig, ov: Overrides) -> Result<()> {
    serve_many(
        vec![MachineEntry {
            source: "(default)".into(),
            config: cfg,
        }],
        ov,
    )
}

/// Runs several machines in one process, each with its own engine, cycle thread, inputs,
/// record and HTTP API, until ctrl-c, SIGTERM or the duration; then stops every machine
/// (each flushes its record) and returns the first error, if any.
///
/// `--port` and `--db` name one machine's port and record, so they are refused with more
/// than one machine; `--speedup` and `--duration-s` apply to all.
pub fn serve_many(mut machines: Vec<MachineEntry>, ov: Overrides) -> Result<()> {
    if machines.is_empty() {
        return Err(crate::error::invalid(
            "--config",
            "none",
            "at least one machine configuration",
        ));
    }
    let several = machines.len() > 1;
    if several {
        if let Some(p) = ov.port {
            return Err(crate::error::invalid(
                "--port",
                p,
                "no --port with several --config (set http.port in each file; 0 picks a free port)",
            ));
        }
        if let Some(db) = &ov.db {
            return Err(crate::error::invalid(
                "--db",
                db.display(),
                "no --db with several --config (set storage.path in each file)",
            ));
        }
    }
    // The options are checked under their own names before they replace a key.
    if let Some(s) = ov.speedup {
        crate::error::check_range("--speedup", s, 0.001, 1e6, "0.001…1e6")?;
    }
    if let Some(db) = &ov.db {
        if db.as_os_str().is_empty() || db.is_dir() {
            return Err(crate::error::invalid(
                "--db",
                format!("{:?}", db.display().to_string()),
                "the SQLite record file (created if missing), not a folder",
            ));
        }
    }
    for m in &mut machines {
        apply_overrides(&mut m.config, &ov);
        m.config
            .validate()
            .map_err(|e| in_machine(several, &m.source, e))?;
    }
    crate::config::check_machines_apart(&machines)?;
    if let Some(d) = ov.duration_s {
        crate::error::check_range("--duration-s", d, 0.0, 1e9, "0…1e9 s")?;
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .map_err(|source| ServiceError::Io {
            action: "start",
            path: "the async runtime".into(),
            source,
        })?;
    rt.block_on(async {
        let mut running: Vec<Running> = Vec::with_capacity(machines.len());
        for m in machines {
            match start(m.config).await {
                Ok(r) => {
                    announce(&r);
                    running.push(r);
                }
                Err(e) => {
                    // The machines already started are stopped cleanly (records flushed)
                    // before the error is returned.
                    for r in running {
                        let _ = r.stop().await;
                    }
                    return Err(in_machine(several, &m.source, db_named(e, &ov)));
                }
            }
        }
        wait_for_stop(ov.duration_s).await;
        let mut first_error = None;
        for r in running {
            let (machine, record) = (r.machine.clone(), r.store.describe());
            match r.stop().await {
                Ok(n) => println!(
                    "gearcomp serve: machine {machine} stopped; {n} samples committed in {record}"
                ),
                Err(e) => {
                    eprintln!("gearcomp serve: machine {machine}: {e}");
                    first_error.get_or_insert(e);
                }
            }
        }
        first_error.map_or(Ok(()), Err)
    })
}

fn apply_overrides(cfg: &mut ServiceConfig, ov: &Overrides) {
    if let Some(p) = ov.port {
        cfg.http.port = p;
    }
    if let Some(db) = &ov.db {
        cfg.storage.path = db.clone();
    }
    if let (Some(s), InputSection::Simulator { speedup, .. }) = (ov.speedup, &mut cfg.input) {
        *speedup = s;
    }
    if let (Some(s), InputSection::Replay(r)) = (ov.speedup, &mut cfg.input) {
        r.speedup = s;
    }
}

/// A record that cannot be opened is named `--db` when that option set it.
fn db_named(e: ServiceError, ov: &Overrides) -> ServiceError {
    match e {
        ServiceError::Invalid {
            field,
            value,
            expected,
        } if ov.db.is_some() && field == "storage.path" => ServiceError::Invalid {
            field: "--db".into(),
            value,
            expected,
        },
        e => e,
    }
}

/// With several machines an error names the configuration file it belongs to.
fn in_machine(several: bool, source: &str, e: ServiceError) -> ServiceError {
    if several {
        ServiceError::Machine {
            source_file: source.to_string(),
            cause: Box::new(e),
        }
    } else {
        e
    }
}

/// Prints the machine's generated tokens (shown once) and where it listens.
fn announce(r: &Running) {
    let mut out = std::io::stdout().lock();
    if let Some(g) = &r.generated {
        let _ = writeln!(out, "operator token (shown once): {}", g.operator);
        let _ = writeln!(out, "read-only token (shown once): {}", g.read_only);
        if let Some(f) = &g.file {
            let _ = writeln!(out, "tokens written to {} (owner-only)", f.display());
        }
    }
    let _ = writeln!(
        out,
        "gearcomp serve: machine {} ({}), record {}, listening on {}://{}",
        r.machine,
        r.model_source,
        r.store.describe(),
        r.scheme,
        r.addr
    );
    let _ = out.flush();
}

async fn wait_for_stop(duration_s: Option<f64>) {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    let timer = async {
        match duration_s {
            Some(d) => tokio::time::sleep(Duration::from_secs_f64(d)).await,
            None => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
        _ = timer => {},
    }
}

/// A started service.
pub struct Running {
    /// The HTTP address bound.
    pub addr: std::net::SocketAddr,
    /// `http`, or `https` with `[http.tls]`.
    pub scheme: &'static str,
    /// Tokens generated at this (first) start, to be shown once.
    pub generated: Option<crate::auth::Generated>,
    /// The database file.
    pub db: PathBuf,
    /// Machine name.
    pub machine: String,
    /// Where the model came from.
    pub model_source: String,
    /// Store counters.
    pub stats: Arc<StoreStats>,
    /// The record (SQLite or PostgreSQL).
    pub store: Arc<dyn storage::Store>,
    shutdown: Arc<AtomicBool>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
    sim_thread: Option<std::thread::JoinHandle<()>>,
    in_tx: std::sync::mpsc::SyncSender<InputMsg>,
    cycle_thread: std::thread::JoinHandle<()>,
    writer: std::thread::JoinHandle<Result<()>>,
    http_stop: tokio::sync::oneshot::Sender<()>,
    server: tokio::task::JoinHandle<()>,
}

/// What the input needs, worked out from the configuration and the engine's names before
/// anything starts.
struct InputPlan {
    /// Service-clock seconds per wall-clock second.
    speedup: f64,
    /// The simulator and its channel map, for `kind = "simulator"`.
    sim: Option<(Simulator, Vec<usize>)>,
    /// The cycle's tick, s.
    period_s: f64,
    /// The opened log, for `kind = "replay"`.
    replay: Option<crate::sources::replay::ReplayPlan>,
    /// Names of the target series the record keeps.
    targets: Vec<String>,
}

/// Phase 1: the configuration's inputs checked against the engine (a bad credential, a
/// channel the input does not map, a log that does not fit stop the start here).
fn plan_input(cfg: &ServiceConfig, channels: &[String], axes: &[String]) -> Result<InputPlan> {
    // The broker password is read at start so a missing file or variable stops it here.
    #[cfg(feature = "mqtt")]
    if let crate::config::InputSection::Mqtt(m) = &cfg.input {
        m.credentials()?;
        if let Some(t) = &m.tls {
            crate::sources::mqtt::tls_config(t)?;
        }
    }
    // Inputs that need the engine's channels are checked before anything starts.
    let replay = match &cfg.input {
        InputSection::Replay(r) => Some(crate::sources::replay::ReplayPlan::open_with_axes(
            r, channels, axes,
        )?),
        _ => None,
    };
    let (speedup, sim, period_s) = match &cfg.input {
        InputSection::Simulator {
            seed, speedup: s, ..
        } => {
            let p = preset_of(cfg)?;
            let simulator = Simulator::new(bundle(p).machine, *seed)?;
            let map = crate::sources::sim::channel_map(&simulator, channels)?;
            // The simulator scans every dt_s; a shorter tick would only re-sample held
            // readings between scans, and a tick of exactly dt_s fired just before a scan
            // that came a little late (thread scheduling), cutting it in two: two cycles
            // for one scan (15 for 13 at real time), a held reading averaged twice and
            // the offset moving twice per scan. Twice dt_s: only a missing scan ticks.
            let period_s = cfg.cycle.period_s.max(2.0 * simulator.spec().dt_s);
            (*s, Some((simulator, map)), period_s)
        }
        #[cfg(feature = "mqtt")]
        InputSection::Mqtt(_) => (1.0, None, cfg.cycle.period_s),
        #[cfg(feature = "modbus")]
        InputSection::Modbus(m) => {
            crate::sources::modbus::resolve(m, channels, axes)?;
            (1.0, None, cfg.cycle.period_s)
        }
        #[cfg(feature = "opcua")]
        InputSection::OpcUa(o) => {
            crate::sources::opcua::resolve(o, channels, axes)?;
            (1.0, None, cfg.cycle.period_s)
        }
        // The log's rows time every step: a clock tick between two rows would add a step
        // an offline replay of the same log does not have.
        InputSection::Replay(r) => (r.speedup, None, f64::INFINITY),
    };
    let targets = match &replay {
        Some(p) => p.target_names(),
        None if sim.is_some() => vec!["measured_drift_um".into()],
        None => vec![],
    };
    Ok(InputPlan {
        speedup,
        sim,
        period_s,
        replay,
        targets,
    })
}

/// What the record holds at start.
struct Opened {
    store: Arc<dyn storage::Store>,
    /// Where the clock resumes, s.
    origin_s: f64,
    tokens: Tokens,
    generated: Option<crate::auth::Generated>,
    /// Committed samples and the last sample id.
    totals: (u64, u64),
    /// The state the last run kept, encoded.
    resume: Option<String>,
}

/// Phase 2: the record opened (names registered, stale alarms closed, tokens loaded or
/// generated, the model logged). Opening blocks (a PostgreSQL client runs its own small
/// runtime), so it happens off the async workers.
async fn open_record(
    cfg: &ServiceConfig,
    names: [Vec<String>; 3],
    model_src: String,
    model_toml: String,
) -> Result<Opened> {
    let store_cfg = cfg.clone();
    tokio::task::spawn_blocking(move || -> Result<Opened> {
        let [ch, ax, tg] = names;
        let store = storage::open_store(&store_cfg)?;
        store.register_names(&ch, &ax, &tg)?;
        let last = store.last_time_s()?;
        // Resume the clock one second after the record ends so time stays increasing.
        let origin_s = if last.is_finite() {
            last.ceil() + 1.0
        } else {
            0.0
        };
        store.close_stale_alarms(origin_s)?;
        let (tokens, mut generated) = Tokens::load_or_generate_in(&*store, &store_cfg.auth.tokens)?;
        crate::auth::secure_record(&store_cfg, generated.as_mut())?;
        store.add_model(&model_src, &model_toml)?;
        let totals = store.sample_totals()?;
        let resume = store.resume_state()?;
        Ok(Opened {
            store,
            origin_s,
            tokens,
            generated,
            totals,
            resume,
        })
    })
    .await
    .map_err(|_| ServiceError::Stopped("opening the store"))?
}

/// The HTTP side before it serves: the listener bound, TLS and limits read.
struct HttpBound {
    listener: tokio::net::TcpListener,
    addr: std::net::SocketAddr,
    tls: Option<tokio_rustls::TlsAcceptor>,
    limits: http::ServerLimits,
}

/// Phase 3: the HTTP listener bound (a port in use or a bad certificate stop the start).
async fn bind_http(cfg: &ServiceConfig) -> Result<HttpBound> {
    let tls = cfg.http.tls.as_ref().map(http::tls_acceptor).transpose()?;
    let limits = http::ServerLimits::of(&cfg.http);
    let io_err = |source| ServiceError::Io {
        action: "bind",
        path: format!("{}:{}", cfg.http.bind, cfg.http.port),
        source,
    };
    let listener = tokio::net::TcpListener::bind((cfg.http.bind, cfg.http.port))
        .await
        .map_err(io_err)?;
    let addr = listener.local_addr().map_err(io_err)?;
    Ok(HttpBound {
        listener,
        addr,
        tls,
        limits,
    })
}

/// The running sources: a thread (simulator, replay) or tasks (network inputs).
struct Sources {
    thread: Option<std::thread::JoinHandle<()>>,
    tasks: Vec<tokio::task::JoinHandle<()>>,
}

/// Phase 5: the input started, feeding the cycle; network outputs watch `off_rx`.
#[allow(clippy::too_many_arguments)]
#[cfg_attr(
    not(any(feature = "mqtt", feature = "modbus", feature = "opcua")),
    allow(unused_variables)
)]
fn start_sources(
    cfg: &ServiceConfig,
    sim: Option<(Simulator, Vec<usize>)>,
    replay_plan: Option<crate::sources::replay::ReplayPlan>,
    channels: &[String],
    axes: &[String],
    clock: Clock,
    in_tx: &std::sync::mpsc::SyncSender<InputMsg>,
    off_rx: tokio::sync::watch::Receiver<OffsetOut>,
    shutdown: &Arc<AtomicBool>,
    alive: Arc<std::sync::atomic::AtomicU64>,
) -> Result<Sources> {
    let mut sim_thread = None;
    #[cfg_attr(
        not(any(feature = "mqtt", feature = "modbus", feature = "opcua")),
        allow(unused_mut)
    )]
    let mut tasks: Vec<tokio::task::JoinHandle<()>> = Vec::new();
    if let Some((simulator, map)) = sim {
        let tx = in_tx.clone();
        let sd = shutdown.clone();
        sim_thread = Some(
            std::thread::Builder::new()
                .name("gearcomp-sim".into())
                .spawn(move || crate::sources::sim::run(simulator, map, clock, tx, sd))
                .map_err(|source| ServiceError::Io {
                    action: "start",
                    path: "the simulator thread".into(),
                    source,
                })?,
        );
    }
    if let Some(plan) = replay_plan {
        let parts = crate::sources::replay::ReplayParts {
            plan,
            looping: matches!(&cfg.input, InputSection::Replay(r) if r.looping),
            clock,
            tx: in_tx.clone(),
            shutdown: shutdown.clone(),
        };
        // Joined like the simulator's thread when the service stops.
        sim_thread = Some(
            std::thread::Builder::new()
                .name("gearcomp-replay".into())
                .spawn(move || crate::sources::replay::run(parts))
                .map_err(|source| ServiceError::Io {
                    action: "start",
                    path: "the replay thread".into(),
                    source,
                })?,
        );
    }
    match &cfg.input {
        InputSection::Simulator { .. } | InputSection::Replay(_) => {}
        #[cfg(feature = "mqtt")]
        InputSection::Mqtt(m) => {
            let tx = crate::sources::InputTx::new(in_tx.clone());
            let adapter = crate::sources::mqtt::run(crate::sources::mqtt::MqttParts {
                cfg: m.clone(),
                machine: cfg.machine.name.clone(),
                channels: channels.to_vec(),
                axes: axes.to_vec(),
                clock,
                tx: tx.clone(),
                offsets: off_rx.clone(),
                alive: alive.clone(),
            });
            tasks.push(tokio::spawn(crate::sources::supervised(
                "MQTT", tx, adapter,
            )));
        }
        #[cfg(feature = "modbus")]
        InputSection::Modbus(m) => {
            let parts = crate::sources::modbus::ModbusParts {
                cfg: m.clone(),
                channels: channels.to_vec(),
                axes: axes.to_vec(),
                clock,
                tx: crate::sources::InputTx::new(in_tx.clone()),
                offsets: off_rx.clone(),
                alive: alive.clone(),
            };
            tasks.push(tokio::spawn(async move {
                let _ = crate::sources::modbus::run(parts).await;
            }));
        }
        #[cfg(feature = "opcua")]
        InputSection::OpcUa(o) => {
            // Prepared here so a bad client setup or a missing password fails the start.
            let adapter = crate::sources::opcua::prepare(crate::sources::opcua::OpcUaParts {
                cfg: (**o).clone(),
                channels: channels.to_vec(),
                axes: axes.to_vec(),
                clock,
                tx: crate::sources::InputTx::new(in_tx.clone()),
                offsets: off_rx.clone(),
                alive: alive.clone(),
            })?;
            let tx = crate::sources::InputTx::new(in_tx.clone());
            tasks.push(tokio::spawn(crate::sources::supervised(
                "OPC UA",
                tx,
                adapter.run(),
            )));
        }
    }
    drop(off_rx);
    Ok(Sources {
        thread: sim_thread,
        tasks,
    })
}

/// Starts every part of the service on the current tokio runtime (multi-threaded), in
/// phases: the input planned, the record opened, HTTP bound, the store writer and the
/// cycle started (resuming the last run's state), the input started, HTTP served.
pub async fn start(cfg: ServiceConfig) -> Result<Running> {
    cfg.validate()?;
    let (engine_cfg, model_source) = engine_config(&cfg)?;
    let engine = Engine::new(&engine_cfg)?;
    let channels: Vec<String> = engine.channel_names().to_vec();
    let axes: Vec<String> = engine.axis_names().to_vec();
    let plan = plan_input(&cfg, &channels, &axes)?;
    let opened = open_record(
        &cfg,
        [channels.clone(), axes.clone(), plan.targets.clone()],
        model_source.clone(),
        engine_cfg.to_toml_string().unwrap_or_default(),
    )
    .await?;
    let store = opened.store;
    let stats = Arc::new(StoreStats::default());
    stats
        .committed_samples
        .store(opened.totals.0, Ordering::Release);
    stats
        .last_sample_id
        .store(opened.totals.1, Ordering::Release);
    let bound = bind_http(&cfg).await?;
    let scheme = if bound.tls.is_some() { "https" } else { "http" };

    // Phase 4: the store writer and the cycle.
    let clock = Clock::new(opened.origin_s, plan.speedup);
    let shutdown = Arc::new(AtomicBool::new(false));
    let (rec_tx, rec_rx) = sync_channel(store.record_queue());
    let (in_tx, in_rx) = sync_channel::<InputMsg>(INPUT_QUEUE);
    let (off_tx, off_rx) = tokio::sync::watch::channel(OffsetOut::default());
    let live = Arc::new(Mutex::new(Live::new(&channels, &axes)));
    let commit = Duration::from_secs_f64(cfg.storage.commit_interval_s);
    let writer = {
        let (store, stats) = (store.clone(), stats.clone());
        let params = storage::WriterParams {
            commit_interval: commit,
            clock,
        };
        tokio::task::spawn_blocking(move || store.spawn_writer(rec_rx, params, stats))
            .await
            .map_err(|_| ServiceError::Stopped("the store thread"))??
    };
    let mut cycle = Cycle::new(CycleParts {
        engine,
        config: engine_cfg.clone(),
        clock,
        period_s: plan.period_s,
        bumpless_step_um: cfg.cycle.bumpless_step_um,
        records: rec_tx.clone(),
        live: live.clone(),
        offsets: off_tx,
        shutdown: shutdown.clone(),
    });
    // Bumpless restart: the state the last run kept (applied offsets, filters, rate
    // limit, latched stop) is taken over; it is kept again while this run goes on.
    cycle.keep_state(commit);
    if let Some(state) = opened.resume.as_deref().and_then(ResumeState::decode) {
        cycle.resume(&state);
    }
    // A source that reports the machine state starts "not at a safe point", so nothing
    // moves mid-cut before its first report.
    #[cfg(feature = "opcua")]
    if let InputSection::OpcUa(o) = &cfg.input {
        if o.program_state.is_some() {
            cycle.set_safe_point(false);
        }
    }
    let alive = cycle.alive();
    let cycle_thread = std::thread::Builder::new()
        .name("gearcomp-cycle".into())
        .spawn(move || cycle.run(in_rx))
        .map_err(|source| ServiceError::Io {
            action: "start",
            path: "the cycle thread".into(),
            source,
        })?;

    let sources = start_sources(
        &cfg,
        plan.sim,
        plan.replay,
        &channels,
        &axes,
        clock,
        &in_tx,
        off_rx,
        &shutdown,
        alive,
    )?;

    // Phase 6: HTTP served.
    let db_path = cfg.storage.path.clone();
    let state = Arc::new(AppState {
        db: db_path.clone(),
        machine: cfg.machine.name.clone(),
        input: input_name(&cfg),
        live,
        tokens: opened.tokens,
        cycle: in_tx.clone(),
        records: rec_tx.clone(),
        store: store.clone(),
        model: Mutex::new(ModelInfo {
            source: model_source.clone(),
            config: engine_cfg,
        }),
        stats: stats.clone(),
        clock,
        started: Instant::now(),
        body_read_timeout: Duration::from_secs_f64(cfg.http.body_read_timeout_s),
    });
    let (http_stop_tx, http_stop_rx) = tokio::sync::oneshot::channel::<()>();
    let HttpBound {
        listener,
        addr,
        tls,
        limits,
    } = bound;
    let server = tokio::spawn(async move {
        http::serve(listener, http::router(state), limits, tls, http_stop_rx).await;
    });

    Ok(Running {
        addr,
        scheme,
        generated: opened.generated,
        db: db_path,
        machine: cfg.machine.name.clone(),
        model_source,
        stats,
        store,
        shutdown,
        tasks: sources.tasks,
        sim_thread: sources.thread,
        in_tx,
        cycle_thread,
        writer,
        http_stop: http_stop_tx,
        server,
    })
}

impl Running {
    /// Stops in order (inputs, then the cycle finishing its step, then the store
    /// committing) and returns the number of committed samples.
    pub async fn stop(self) -> Result<u64> {
        self.shutdown.store(true, Ordering::Release);
        for t in &self.tasks {
            t.abort();
        }
        // The server holds a record sender: it goes first so the store can see the end.
        let _ = self.http_stop.send(());
        let _ = self.server.await;
        let (sim_thread, in_tx, cycle_thread, writer) =
            (self.sim_thread, self.in_tx, self.cycle_thread, self.writer);
        let joined = tokio::task::spawn_blocking(move || {
            if let Some(t) = sim_thread {
                let _ = t.join();
            }
            let _ = in_tx.send(InputMsg::Shutdown);
            drop(in_tx);
            let c = cycle_thread.join().is_ok();
            let w = writer.join();
            (c, w)
        })
        .await
        .map_err(|_| ServiceError::Stopped("shutdown"))?;
        if !joined.0 {
            return Err(ServiceError::Stopped("the cycle thread"));
        }
        match joined.1 {
            Ok(r) => r?,
            Err(_) => return Err(ServiceError::Stopped("the store thread")),
        }
        Ok(self.stats.committed_samples.load(Ordering::Acquire))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    fn refusal(ov: Overrides) -> String {
        let mut config = ServiceConfig::default();
        config.http.port = 0;
        let m = MachineEntry {
            source: "m.toml".into(),
            config,
        };
        serve_many(vec![m], ov).unwrap_err().to_string()
    }

    #[test]
    fn options_are_refused_under_their_own_names() {
        // --speedup replaces input.speedup, but the user wrote --speedup.
        for (s, shown) in [
            (0.0, "0"),
            (-1.0, "-1"),
            (f64::NAN, "NaN"),
            (1e300, "1e300"),
        ] {
            let e = refusal(Overrides {
                speedup: Some(s),
                ..Overrides::default()
            });
            assert_eq!(
                e,
                format!("invalid --speedup = {shown}: expected 0.001…1e6")
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let e = refusal(Overrides {
            db: Some(dir.path().to_path_buf()),
            ..Overrides::default()
        });
        assert!(
            e.starts_with("invalid --db = ") && e.contains("not a folder"),
            "{e}"
        );
        let missing = dir.path().join("no-such-folder").join("r.db");
        let e = refusal(Overrides {
            db: Some(missing.clone()),
            ..Overrides::default()
        });
        assert!(
            e.starts_with(&format!("invalid --db = {}", missing.display())),
            "{e}"
        );
    }
}
