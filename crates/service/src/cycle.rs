//! The cycle thread: the engine steps here, on a plain OS thread with no async runtime, no
//! allocation per cycle and only short uncontended locks. Inputs arrive over a bounded
//! channel; records leave over another; the applied offset goes to the outputs through a
//! `watch` cell (latest value wins, so a slow output never holds the cycle up).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use gearcomp_thermal::{
    Alarm, Application, AxisStatus, Engine, EngineConfig, EngineStatus, Fault, Inputs, Output,
    Reading, StopReason, MAX_AXES,
};
use serde::Serialize;

// The clock has its own module; re-exported for the sources that name it from here.
pub use crate::clock::Clock;
use crate::storage::Record;

/// A message to the cycle thread.
#[derive(Debug)]
pub enum InputMsg {
    /// One raw reading of a channel (engine order).
    Sample {
        /// Channel index.
        channel: u16,
        /// Raw value in the sensor's unit; NaN marks a reading known to be bad.
        raw: f64,
        /// Acquisition time, s (service clock).
        stamp_s: f64,
    },
    /// An axis's actual position, for the engine's position-dependent terms
    /// (offset(T) + slope(T)·(P − P0)); held until the next one. NaN marks a position
    /// known to be unknown (node of the wrong type, connection lost): the axes whose law
    /// needs it freeze.
    Position {
        /// Axis index (engine order).
        axis: u8,
        /// Position, mm.
        position_mm: f64,
    },
    /// The machine state that comes with the next readings.
    MachineState {
        /// Between cuts (simulator: load/unload), where an offset change cannot mark a
        /// flank.
        safe_point: bool,
    },
    /// The source finished a scan of its channels: step now if anything is new, or in any
    /// case when the scan carried its own time ([`InputMsg::ScanTime`], one replayed row).
    ScanEnd,
    /// The time of the next step, from a source that carries its own time (CSV replay):
    /// the step of the scan that follows runs at this time instead of the clock's, so a
    /// replayed log steps the engine at the log's times.
    ScanTime {
        /// Time, s (service clock scale).
        time_s: f64,
    },
    /// A reference value to keep with the record (simulator: probe drift).
    Target {
        /// Target index.
        target: u16,
        /// Value, µm.
        value: f64,
        /// Time, s.
        stamp_s: f64,
    },
    /// An input-side alarm became active (kept until cleared).
    RaiseAlarm {
        /// Stable key, e.g. `mqtt.connection`.
        key: String,
        /// Text naming what, which value and what was expected.
        message: String,
    },
    /// An input-side alarm is no longer active.
    ClearAlarm {
        /// The key it was raised with.
        key: String,
    },
    /// An adapter that counts a repeated cause itself: the total so far for an active
    /// input alarm (shown with the alarm; no new row).
    AlarmCount {
        /// The key it was raised with.
        key: String,
        /// Occurrences so far.
        count: u64,
    },
    /// Replace the engine (operator model change), with a bumpless transfer.
    SwapEngine(Box<Engine>, Box<EngineConfig>),
    /// The operator acknowledged the stop request.
    AckStop,
    /// A pulse output's device acknowledged every pulse of an axis up to this total (a
    /// Modbus write response, an MQTT PUBACK): kept in the resume state, so a restarted
    /// service sends only what the device has not acknowledged.
    PulsesAcked {
        /// Axis index (engine order).
        axis: u8,
        /// Cumulative pulses acknowledged.
        total: i64,
    },
    /// Finish the cycle, flush and end.
    Shutdown,
}

/// The offsets as they leave the process.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OffsetOut {
    /// Cycle time, s.
    pub time_s: f64,
    /// Increments with every change (outputs skip values they have written).
    pub seq: u64,
    /// Applied offset per axis, µm.
    pub offsets_um: [f64; MAX_AXES],
    /// Axes in use.
    pub n_axes: u8,
    /// Per axis: the offset is a valid one (resumed from the record, or computed by an
    /// engine whose law has had every input). Outputs write nothing for an axis that is
    /// not valid: never a 0 that only means "no value yet".
    pub valid: [bool; MAX_AXES],
    /// The engine's latched stop request (until the operator acknowledges it), for a
    /// stop / feed-hold output.
    pub stop: bool,
    /// Per axis: the size of one infeed pulse, µm, for an axis applied as pulses
    /// (EP0138375); 0 for any other axis.
    pub pulse_um: [f64; MAX_AXES],
    /// Per pulse axis: the cumulative pulses issued for the applied offset (the count
    /// the device should hold).
    pub pulse_total: [i64; MAX_AXES],
    /// Per pulse axis: the cumulative pulses the device had acknowledged when this run
    /// started or last reported (where a pulse output resumes).
    pub pulses_acked: [i64; MAX_AXES],
    /// Wall-clock instant the scan that caused it completed.
    pub scan_at: Option<Instant>,
}

impl Default for OffsetOut {
    fn default() -> Self {
        Self {
            time_s: f64::NAN,
            seq: 0,
            offsets_um: [0.0; MAX_AXES],
            n_axes: 0,
            valid: [false; MAX_AXES],
            stop: false,
            pulse_um: [0.0; MAX_AXES],
            pulse_total: [0; MAX_AXES],
            pulses_acked: [0; MAX_AXES],
            scan_at: None,
        }
    }
}

/// A channel as the API shows it.
#[derive(Debug, Clone, Serialize)]
pub struct LiveChannel {
    /// Name.
    pub name: String,
    /// Last raw reading.
    pub raw: Option<f64>,
    /// Its acquisition time, s.
    pub stamp_s: Option<f64>,
    /// Averaged, filtered value (°C or µm).
    pub value: Option<f64>,
    /// The fault of the last cycle.
    pub fault: Option<&'static str>,
}

/// An axis as the API shows it.
#[derive(Debug, Clone, Serialize)]
pub struct LiveAxis {
    /// Name.
    pub name: String,
    /// Applied offset (what leaves the process), µm.
    pub offset_um: f64,
    /// The engine's offset, µm (differs from `offset_um` during a bumpless transfer).
    pub engine_offset_um: f64,
    /// Running compensation, µm.
    pub target_um: f64,
    /// Law value, µm.
    pub law_um: Option<f64>,
    /// The last position received for the axis, mm.
    pub position_mm: Option<f64>,
    /// Status.
    pub status: &'static str,
}

/// The state the cycle publishes after every step.
#[derive(Debug, Clone, Serialize)]
pub struct Live {
    /// Last cycle time, s.
    pub time_s: f64,
    /// Engine status.
    pub status: &'static str,
    /// Cycles run.
    pub cycles: u64,
    /// Samples received.
    pub samples: u64,
    /// Channels.
    pub channels: Vec<LiveChannel>,
    /// Axes.
    pub axes: Vec<LiveAxis>,
    /// The latched stop request.
    pub stop: Option<String>,
    /// Occurrences of each active input alarm (see [`crate::alarms`]).
    pub input_alarm_counts: std::collections::BTreeMap<String, u64>,
    /// Scan complete → offset in the output cell, per scan-triggered step.
    #[serde(skip)]
    pub latency: Arc<crate::latency::Histogram>,
}

impl Live {
    /// The initial state for these names.
    pub fn new(channels: &[String], axes: &[String]) -> Self {
        Self {
            time_s: f64::NAN,
            status: "starting",
            cycles: 0,
            samples: 0,
            channels: channels
                .iter()
                .map(|n| LiveChannel {
                    name: n.clone(),
                    raw: None,
                    stamp_s: None,
                    value: None,
                    fault: None,
                })
                .collect(),
            axes: axes
                .iter()
                .map(|n| LiveAxis {
                    name: n.clone(),
                    offset_um: 0.0,
                    engine_offset_um: 0.0,
                    target_um: 0.0,
                    law_um: None,
                    position_mm: None,
                    status: "starting",
                })
                .collect(),
            stop: None,
            input_alarm_counts: Default::default(),
            latency: Default::default(),
        }
    }
}

/// Bumpless transfer after an engine swap: the output holds the last applied offset until
/// the new engine has a value, then moves to the new engine's offset at no more than the
/// rate `r` per cycle, and follows it once it has reached it.
///
/// # Formula
/// out(k₀−1) = y_old; while transferring
/// out(k) = y_new(k) if |y_new(k) − out(k−1)| ≤ r (the transfer ends), else
/// out(k) = out(k−1) + r·sign(y_new(k) − out(k−1));
/// so the output never moves by more than r per cycle (the axis's rate limit, also while
/// the new engine itself ramps from 0), and it reaches y_new within ⌈|y_new − y_old|/r⌉
/// cycles of the new engine holding still. (A decaying bias y_new + b(k), b(k+1) =
/// b(k) − clamp(b(k), −r, r), moved by r + |Δy_new|: twice the rate limit while the new
/// engine ramped.)
/// # Source
/// bumpless transfer as used for controller mode changes [STANDARD control practice];
/// the rate r is the axis's `max_step_um`, else `cycle.bumpless_step_um` [CONVENTION,
/// docs/service.md]
#[derive(Debug, Clone, Copy)]
pub struct Bumpless {
    last_um: [f64; MAX_AXES],
    rate_um: [f64; MAX_AXES],
    pending: [bool; MAX_AXES],
    active: [bool; MAX_AXES],
}

impl Default for Bumpless {
    fn default() -> Self {
        Self {
            last_um: [0.0; MAX_AXES],
            rate_um: [f64::INFINITY; MAX_AXES],
            pending: [false; MAX_AXES],
            active: [false; MAX_AXES],
        }
    }
}

impl Bumpless {
    /// Starts a transfer from the applied offsets `last_um` at rates `rate_um` (µm/cycle).
    pub fn start(&mut self, last_um: &[f64], rate_um: &[f64]) {
        for (i, (&l, &r)) in last_um.iter().zip(rate_um).enumerate().take(MAX_AXES) {
            self.last_um[i] = l;
            self.rate_um[i] = r;
            self.pending[i] = true;
            self.active[i] = true;
        }
    }

    /// The offset to apply for axis `i` given the engine's offset and whether the engine
    /// has a value for it yet.
    pub fn apply(&mut self, i: usize, engine_um: f64, ready: bool) -> f64 {
        if i >= MAX_AXES || !self.active[i] {
            return engine_um;
        }
        if self.pending[i] {
            if !ready {
                return self.last_um[i];
            }
            self.pending[i] = false;
        }
        let (last, r) = (self.last_um[i], self.rate_um[i]);
        let gap = engine_um - last;
        let out = if gap.abs() <= r || !gap.is_finite() {
            // Reached (or nothing to move towards): the engine's offset from now on.
            self.active[i] = false;
            engine_um
        } else {
            last + r.copysign(gap)
        };
        self.last_um[i] = out;
        out
    }
}

/// What a restarted service resumes from, kept in the record (`Record::Resume`): the
/// offsets last applied per axis and the engine's state (averages, filters, rate limit,
/// latched stop).
#[derive(Debug, Clone, PartialEq)]
pub struct ResumeState {
    /// [`config_hash`] of the engine configuration the state belongs to.
    pub config_hash: u64,
    /// Per axis: a valid offset had been applied.
    pub valid: Vec<bool>,
    /// Per axis: the offset last applied, µm.
    pub applied_um: Vec<f64>,
    /// `Engine::save_state`.
    pub engine: Vec<f64>,
    /// Per axis: cumulative infeed pulses issued for the applied offset.
    pub pulse_total: Vec<i64>,
    /// Per axis: the rounding remainder carried to the next pulse, in pulses.
    pub pulse_carry: Vec<f64>,
    /// Per axis: cumulative pulses the device acknowledged.
    pub pulses_acked: Vec<i64>,
}

/// The first form (no pulse section): still read, its pulse counts as 0.
const RESUME_TAG_1: &str = "gearcomp-resume-1";
const RESUME_TAG: &str = "gearcomp-resume-2";

impl ResumeState {
    /// Text form: every number as the 16 hex digits of its bits, so nothing is rounded.
    pub fn encode(&self) -> String {
        use std::fmt::Write;
        let mut s = String::with_capacity(32 + 17 * (self.applied_um.len() + self.engine.len()));
        let _ = write!(
            s,
            "{RESUME_TAG} {:016x} {} {}",
            self.config_hash,
            self.applied_um.len(),
            self.engine.len()
        );
        for v in &self.valid {
            s.push_str(if *v { " 1" } else { " 0" });
        }
        for v in self.applied_um.iter().chain(&self.engine) {
            let _ = write!(s, " {:016x}", v.to_bits());
        }
        for i in 0..self.applied_um.len() {
            let total = self.pulse_total.get(i).copied().unwrap_or(0);
            let carry = self.pulse_carry.get(i).copied().unwrap_or(0.0);
            let acked = self.pulses_acked.get(i).copied().unwrap_or(0);
            let _ = write!(
                s,
                " {:016x} {:016x} {:016x}",
                total as u64,
                carry.to_bits(),
                acked as u64
            );
        }
        s
    }

    /// Parses [`ResumeState::encode`]'s text; None if it is not one.
    pub fn decode(text: &str) -> Option<Self> {
        let mut it = text.split_ascii_whitespace();
        let with_pulses = match it.next()? {
            RESUME_TAG => true,
            RESUME_TAG_1 => false,
            _ => return None,
        };
        let config_hash = u64::from_str_radix(it.next()?, 16).ok()?;
        let n_axes: usize = it.next()?.parse().ok()?;
        let n_engine: usize = it.next()?.parse().ok()?;
        if n_axes > MAX_AXES || n_engine > 1 << 24 {
            return None;
        }
        let mut valid = Vec::with_capacity(n_axes);
        for _ in 0..n_axes {
            valid.push(match it.next()? {
                "1" => true,
                "0" => false,
                _ => return None,
            });
        }
        let mut word = || -> Option<u64> {
            let t = it.next()?;
            (t.len() == 16).then_some(())?;
            u64::from_str_radix(t, 16).ok()
        };
        let mut applied_um = Vec::with_capacity(n_axes);
        for _ in 0..n_axes {
            applied_um.push(f64::from_bits(word()?));
        }
        let mut engine = Vec::with_capacity(n_engine);
        for _ in 0..n_engine {
            engine.push(f64::from_bits(word()?));
        }
        let mut pulse_total = vec![0i64; n_axes];
        let mut pulse_carry = vec![0.0; n_axes];
        let mut pulses_acked = vec![0i64; n_axes];
        if with_pulses {
            for i in 0..n_axes {
                pulse_total[i] = word()? as i64;
                pulse_carry[i] = f64::from_bits(word()?);
                pulses_acked[i] = word()? as i64;
            }
        }
        it.next().is_none().then_some(Self {
            config_hash,
            valid,
            applied_um,
            engine,
            pulse_total,
            pulse_carry,
            pulses_acked,
        })
    }
}

/// FNV-1a of an engine configuration's text: a saved engine state is restored only into
/// an engine built from the same configuration.
pub fn config_hash(config_toml: &str) -> u64 {
    config_toml.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

/// What [`Cycle::resume`] took over.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resumed {
    /// Nothing usable (another axis layout, or no valid offset).
    Nothing,
    /// The applied offsets; the engine starts afresh (its configuration changed) and holds
    /// them until its laws have values.
    Offsets,
    /// The applied offsets and the engine's state.
    OffsetsAndEngine,
}

/// Periodic saving of the resume state.
#[derive(Debug)]
struct Persist {
    interval: Duration,
    last: Instant,
    dirty: bool,
    hash: u64,
}

fn status_name(s: AxisStatus) -> &'static str {
    match s {
        AxisStatus::Starting => "starting",
        AxisStatus::Updated => "updated",
        AxisStatus::Held => "held",
        AxisStatus::Clamped => "clamped",
        AxisStatus::Ramping => "ramping",
        AxisStatus::WaitingSafePoint => "waiting_safe_point",
        AxisStatus::Frozen => "frozen",
        AxisStatus::Stopped => "stopped",
    }
}

fn engine_status_name(s: EngineStatus) -> &'static str {
    match s {
        EngineStatus::Running => "running",
        EngineStatus::Alarm => "alarm",
        EngineStatus::StopRequested => "stop_requested",
    }
}

/// The name of a channel fault.
pub fn fault_name(f: Fault) -> &'static str {
    match f {
        Fault::NotANumber => "not_a_number",
        Fault::OpenCircuit => "open_circuit",
        Fault::ShortCircuit => "short_circuit",
        Fault::OutOfRange => "out_of_range",
        Fault::Stale => "stale",
        Fault::Stuck => "stuck",
        Fault::OutOfOrder => "out_of_order",
        Fault::RateOfChange => "rate_of_change",
        Fault::Spike => "spike",
    }
}

fn engine_alarm_key(a: Alarm) -> Option<&'static str> {
    match a {
        Alarm::Channel { .. } => None,
        Alarm::TimeOutOfOrder { .. } => Some("engine.time_out_of_order"),
        Alarm::InputCount { .. } => Some("engine.input_count"),
        Alarm::PositionMissing { .. } => Some("engine.position_missing"),
        Alarm::LawNotFinite { .. } => Some("engine.law_not_finite"),
        Alarm::Envelope { .. } => Some("engine.envelope"),
    }
}

/// Infeed pulses for the applied offset of every axis applied as pulses (EP0138375,
/// Fig. 9 blocks 606–608): each change of the applied offset becomes a count of pulses
/// with the rounding remainder carried, by the thermal crate's own
/// [`gearcomp_thermal::law::pulses_with_carry`] (the rule `gearcomp`'s offline pulse
/// application uses). The issued total, the remainder and the total the device has
/// acknowledged are kept in the resume state, so a restart neither loses nor repeats a
/// pulse.
#[derive(Debug, Clone, Copy)]
pub struct Pulses {
    /// Pulse size per axis, µm (0: the axis is not applied as pulses).
    pub pulse_um: [f64; MAX_AXES],
    /// Cumulative pulses issued.
    pub total: [i64; MAX_AXES],
    /// Remainder carried, pulses (|r| ≤ ½).
    pub carry: [f64; MAX_AXES],
    /// Cumulative pulses the device acknowledged.
    pub acked: [i64; MAX_AXES],
}

impl Pulses {
    /// The pulse axes of an engine configuration, nothing issued yet.
    pub fn of(cfg: &EngineConfig) -> Self {
        let mut pulse_um = [0.0; MAX_AXES];
        for (p, a) in pulse_um.iter_mut().zip(&cfg.axes) {
            if let Application::Pulses { pulse_um } = a.apply {
                *p = pulse_um;
            }
        }
        Self {
            pulse_um,
            total: [0; MAX_AXES],
            carry: [0.0; MAX_AXES],
            acked: [0; MAX_AXES],
        }
    }

    /// Issues the pulses of a change of axis `i`'s applied offset from `from_um` to
    /// `to_um`; returns the count (0 for an axis not applied as pulses).
    pub fn issue(&mut self, i: usize, from_um: f64, to_um: f64) -> i64 {
        let p = self.pulse_um.get(i).copied().unwrap_or(0.0);
        let delta = to_um - from_um;
        if p <= 0.0 || delta == 0.0 || !delta.is_finite() {
            return 0;
        }
        let n = gearcomp_thermal::law::pulses_with_carry(delta, p, &mut self.carry[i]);
        self.total[i] = self.total[i].saturating_add(n);
        n
    }
}

/// Everything the cycle thread owns.
pub struct Cycle {
    engine: Engine,
    config: EngineConfig,
    clock: Clock,
    period: Duration,
    bumpless_step_um: f64,
    records: SyncSender<Record>,
    live: Arc<Mutex<Live>>,
    latency: Arc<crate::latency::Histogram>,
    offsets: tokio::sync::watch::Sender<OffsetOut>,
    readings: Vec<Reading>,
    /// Held axis positions, mm, NaN until received; the engine reads the first
    /// `n_axes` (fixed size: nothing to allocate per cycle).
    positions_mm: [f64; MAX_AXES],
    n_axes: usize,
    /// The engine's result, filled in place by `Engine::step_into` every cycle.
    out: Output,
    fresh: Vec<bool>,
    n_fresh: usize,
    safe_point: bool,
    last_time_s: f64,
    prev_fault: Vec<Option<Fault>>,
    /// When each channel's alarmed fault was last seen (wall clock), for the clear hold.
    fault_seen: Vec<Option<Instant>>,
    prev_engine_alarm: Option<&'static str>,
    prev_stop: bool,
    input_alarms: crate::alarms::InputAlarms,
    bumpless: Bumpless,
    applied_um: [f64; MAX_AXES],
    /// Per axis: a valid offset exists (see [`OffsetOut::valid`]).
    valid: [bool; MAX_AXES],
    /// Infeed pulses of the applied offset (see [`Pulses`]).
    pulses: Pulses,
    /// Where the resume state is saved (None: not kept, e.g. benchmarks).
    persist: Option<Persist>,
    /// The stop request as last published to the outputs.
    published_stop: bool,
    /// Steps run, shared with the heartbeat outputs (a stalled count = a dead cycle).
    alive: Arc<std::sync::atomic::AtomicU64>,
    seq: u64,
    cycles: u64,
    samples: u64,
    scan_at: Option<Instant>,
    scan_time_s: Option<f64>,
    last_step: Instant,
    shutdown: Arc<AtomicBool>,
}

/// What the cycle needs to start.
pub struct CycleParts {
    /// The engine, built from `config`.
    pub engine: Engine,
    /// Its configuration (kept for model changes and the API).
    pub config: EngineConfig,
    /// The service clock.
    pub clock: Clock,
    /// Longest time between steps, s of service time.
    pub period_s: f64,
    /// Bumpless rate for axes without `max_step_um`, µm/cycle.
    pub bumpless_step_um: f64,
    /// Where records go.
    pub records: SyncSender<Record>,
    /// Shared status.
    pub live: Arc<Mutex<Live>>,
    /// Where the offsets go.
    pub offsets: tokio::sync::watch::Sender<OffsetOut>,
    /// Set when the service is stopping.
    pub shutdown: Arc<AtomicBool>,
}

/// The latency histogram the API reads (kept in the live snapshot).
fn latency_of(live: &Mutex<Live>) -> Arc<crate::latency::Histogram> {
    let guard = live.lock().unwrap_or_else(|e| e.into_inner());
    guard.latency.clone()
}

impl Cycle {
    /// Builds the cycle with all its buffers.
    pub fn new(p: CycleParts) -> Self {
        let n = p.engine.channel_names().len();
        let n_axes = p.engine.axis_names().len().min(MAX_AXES);
        let clock = p.clock;
        let pulses = Pulses::of(&p.config);
        // The outputs learn which axes are pulse axes before any offset (sequence 0:
        // nothing is written for it).
        p.offsets.send_modify(|o| {
            o.pulse_um = pulses.pulse_um;
            o.n_axes = n_axes as u8;
        });
        Self {
            period: clock.wall(p.period_s),
            bumpless_step_um: p.bumpless_step_um,
            readings: vec![
                Reading {
                    raw: f64::NAN,
                    stamp_s: f64::NEG_INFINITY,
                };
                n
            ],
            positions_mm: [f64::NAN; MAX_AXES],
            n_axes,
            out: Output::EMPTY,
            fresh: vec![false; n],
            n_fresh: 0,
            safe_point: true,
            last_time_s: f64::NEG_INFINITY,
            prev_fault: vec![None; n],
            fault_seen: vec![None; n],
            prev_engine_alarm: None,
            prev_stop: false,
            input_alarms: Default::default(),
            bumpless: Bumpless::default(),
            applied_um: [0.0; MAX_AXES],
            valid: [false; MAX_AXES],
            pulses,
            persist: None,
            published_stop: false,
            alive: Arc::new(std::sync::atomic::AtomicU64::new(0)),
            seq: 0,
            cycles: 0,
            samples: 0,
            scan_at: None,
            scan_time_s: None,
            last_step: Instant::now(),
            engine: p.engine,
            config: p.config,
            clock,
            records: p.records,
            latency: latency_of(&p.live),
            live: p.live,
            offsets: p.offsets,
            shutdown: p.shutdown,
        }
    }

    /// Keeps the resume state in the record at most every `interval` (wall clock) while
    /// anything changes, and at the end of the run.
    pub fn keep_state(&mut self, interval: Duration) {
        self.persist = Some(Persist {
            interval,
            last: Instant::now(),
            dirty: false,
            hash: config_hash(&self.config.to_toml_string().unwrap_or_default()),
        });
    }

    /// The count of steps run, for heartbeat outputs: it stops moving when the cycle is
    /// dead, so the heartbeat stops and the PLC holds its last offset.
    pub fn alive(&self) -> Arc<std::sync::atomic::AtomicU64> {
        self.alive.clone()
    }

    /// Whether the machine is at a safe point before the source has said so (true unless
    /// the source reports the machine state: then false, so nothing moves before it has).
    pub fn set_safe_point(&mut self, safe_point: bool) {
        self.safe_point = safe_point;
    }

    /// The rate of the bumpless transfer per axis of `config`, µm per cycle: the axis's
    /// `max_step_um`, else `cycle.bumpless_step_um`.
    fn bumpless_rates(&self, config: &EngineConfig) -> Vec<f64> {
        config
            .axes
            .iter()
            .map(|a| a.max_step_um.unwrap_or(self.bumpless_step_um))
            .collect()
    }

    /// Resumes from the state a previous run kept (call before `run`): the last applied
    /// offsets are published at once as valid (the first value the outputs write), the
    /// engine's state is restored when its configuration is unchanged, and the engine's
    /// rate limit and safe-point gate move on from the applied offsets.
    pub fn resume(&mut self, r: &ResumeState) -> Resumed {
        let n = self.n_axes;
        if r.applied_um.len() != n || r.valid.len() != n || !r.valid.iter().any(|v| *v) {
            return Resumed::Nothing;
        }
        let hash = config_hash(&self.config.to_toml_string().unwrap_or_default());
        let engine_ok = hash == r.config_hash && self.engine.restore_state(&r.engine).is_ok();
        for i in 0..n {
            let y = r.applied_um[i];
            if r.valid[i] && y.is_finite() {
                self.engine.resume_offset(i, y, engine_ok);
                self.applied_um[i] = y;
                self.valid[i] = true;
            }
            // The pulses issued for the applied offset and those the device acknowledged
            // go on from where they were: the output sends only the difference.
            self.pulses.total[i] = r.pulse_total.get(i).copied().unwrap_or(0);
            let carry = r.pulse_carry.get(i).copied().unwrap_or(0.0);
            self.pulses.carry[i] = if carry.is_finite() { carry } else { 0.0 };
            self.pulses.acked[i] = r.pulses_acked.get(i).copied().unwrap_or(0);
        }
        // From the applied offsets the outputs move only at the transfer's rate, as after a
        // model change: a changed configuration (a smaller max_offset_um, an axis without
        // max_step_um, another law) would otherwise step to its first value at once; with
        // the state restored the engine goes on from the applied offsets and the transfer
        // ends in its first cycle.
        let rates = self.bumpless_rates(&self.config);
        self.bumpless.start(&self.applied_um[..n], &rates);
        self.seq += 1;
        self.offsets.send_replace(self.offset_out(f64::NAN, None));
        if let Ok(mut live) = self.live.lock() {
            for (i, l) in live.axes.iter_mut().enumerate() {
                l.offset_um = self.applied_um[i];
                l.engine_offset_um = self.applied_um[i];
            }
        }
        if engine_ok {
            Resumed::OffsetsAndEngine
        } else {
            Resumed::Offsets
        }
    }

    /// The state to resume from now.
    pub fn resume_state(&self) -> ResumeState {
        self.state_with(config_hash(
            &self.config.to_toml_string().unwrap_or_default(),
        ))
    }

    fn state_with(&self, config_hash: u64) -> ResumeState {
        let mut engine = Vec::new();
        self.engine.save_state(&mut engine);
        let n = self.n_axes;
        ResumeState {
            config_hash,
            valid: self.valid[..n].to_vec(),
            applied_um: self.applied_um[..n].to_vec(),
            engine,
            pulse_total: self.pulses.total[..n].to_vec(),
            pulse_carry: self.pulses.carry[..n].to_vec(),
            pulses_acked: self.pulses.acked[..n].to_vec(),
        }
    }

    /// The output cell's value for the current state.
    fn offset_out(&self, time_s: f64, scan_at: Option<Instant>) -> OffsetOut {
        OffsetOut {
            time_s,
            seq: self.seq,
            offsets_um: self.applied_um,
            n_axes: self.n_axes as u8,
            valid: self.valid,
            stop: self.published_stop,
            pulse_um: self.pulses.pulse_um,
            pulse_total: self.pulses.total,
            pulses_acked: self.pulses.acked,
            scan_at,
        }
    }

    fn save_state(&mut self, time_s: f64) {
        let Some(p) = self.persist.as_mut() else {
            return;
        };
        p.last = Instant::now();
        p.dirty = false;
        let hash = p.hash;
        let st = self.state_with(hash);
        self.record(Record::Resume {
            time_s,
            state: st.encode(),
        });
    }

    fn record(&self, r: Record) {
        // A closed store means the service is ending; the cycle must not panic over it.
        let _ = self.records.send(r);
    }

    fn raise(&self, time_s: f64, key: String, message: String) {
        self.record(Record::AlarmRaised {
            time_s,
            key,
            message,
        });
    }

    fn input_alarm_edge(&self, e: crate::alarms::Edge) {
        match e {
            crate::alarms::Edge::Raised { key, message } => {
                self.raise(self.clock.now_s(), key, message)
            }
            crate::alarms::Edge::Cleared { key } => self.record(Record::AlarmCleared {
                time_s: self.clock.now_s(),
                key,
            }),
        }
    }

    fn publish_alarm_counts(&self) {
        if let Ok(mut live) = self.live.lock() {
            live.input_alarm_counts = self.input_alarms.counts();
        }
    }

    /// Handles one message; returns false on shutdown.
    pub fn handle(&mut self, msg: InputMsg) -> bool {
        match msg {
            InputMsg::Sample {
                channel,
                raw,
                stamp_s,
            } => {
                let c = channel as usize;
                self.samples += 1;
                self.record(Record::Sample {
                    time_s: stamp_s,
                    channel,
                    raw,
                });
                if let Some(r) = self.readings.get_mut(c) {
                    *r = Reading { raw, stamp_s };
                    if !self.fresh[c] {
                        self.fresh[c] = true;
                        self.n_fresh += 1;
                    }
                    if self.n_fresh == self.fresh.len() {
                        self.scan_at = Some(Instant::now());
                        self.step();
                    }
                }
            }
            InputMsg::Position { axis, position_mm } => {
                if let Some(p) = self.positions_mm[..self.n_axes].get_mut(axis as usize) {
                    *p = position_mm;
                }
            }
            InputMsg::MachineState { safe_point } => self.safe_point = safe_point,
            InputMsg::ScanTime { time_s } => self.scan_time_s = Some(time_s),
            InputMsg::ScanEnd => {
                // A live scan steps when something is new; a scan that carries its own time
                // (a replayed log row) steps in any case, as the offline replay steps every
                // row: a row of empty cells still advances the rate limit by one cycle.
                if self.n_fresh > 0 || self.scan_time_s.is_some() {
                    self.scan_at = Some(Instant::now());
                    self.step();
                }
            }
            InputMsg::Target {
                target,
                value,
                stamp_s,
            } => self.record(Record::Target {
                time_s: stamp_s,
                target,
                value,
            }),
            InputMsg::RaiseAlarm { key, message } => {
                if let Some(e) = self.input_alarms.raise(key, message) {
                    self.input_alarm_edge(e);
                }
                self.publish_alarm_counts();
            }
            InputMsg::ClearAlarm { key } => {
                for e in self.input_alarms.clear(key) {
                    self.input_alarm_edge(e);
                }
                self.publish_alarm_counts();
            }
            InputMsg::AlarmCount { key, count } => {
                self.input_alarms.set_count(key, count);
                self.publish_alarm_counts();
            }
            InputMsg::SwapEngine(engine, config) => {
                let rates = self.bumpless_rates(&config);
                let n = self.engine.axis_names().len();
                self.bumpless.start(&self.applied_um[..n], &rates);
                self.engine = *engine;
                self.config = *config;
                if let Some(p) = self.persist.as_mut() {
                    p.hash = config_hash(&self.config.to_toml_string().unwrap_or_default());
                    p.dirty = true;
                }
            }
            InputMsg::AckStop => self.engine.acknowledge_stop(),
            InputMsg::PulsesAcked { axis, total } => {
                if let Some(a) = self.pulses.acked[..self.n_axes].get_mut(axis as usize) {
                    if *a != total {
                        *a = total;
                        if let Some(p) = self.persist.as_mut() {
                            p.dirty = true;
                        }
                    }
                }
            }
            InputMsg::Shutdown => return false,
        }
        true
    }

    /// Runs one engine step with the latest readings.
    pub fn step(&mut self) {
        let mut t = match self.scan_time_s.take() {
            Some(t) => t,
            None => self.clock.now_s(),
        };
        if t <= self.last_time_s {
            // Two steps inside the clock's resolution: keep time strictly increasing.
            t = self.last_time_s + 1e-6;
        }
        self.last_time_s = t;
        let trigger = self.n_fresh > 0;
        for f in &mut self.fresh {
            *f = false;
        }
        self.n_fresh = 0;
        self.last_step = Instant::now();
        self.engine.step_into(
            &Inputs {
                time_s: t,
                readings: &self.readings,
                trigger,
                safe_point: self.safe_point,
                positions_mm: &self.positions_mm[..self.n_axes],
            },
            &mut self.out,
        );
        let out = &self.out;
        self.cycles += 1;
        self.alive.store(self.cycles, Ordering::Release);

        // Alarms on their edges only: a fault lasting an hour is one alarm. A fault is
        // raised at once but cleared only after the channel has been good for
        // CHANNEL_CLEAR_HOLD of wall time, so a fault that comes and goes from step to step
        // (a stale check at a high speed-up, a flickering sensor) is one alarm, not one
        // row per step.
        for i in 0..self.prev_fault.len() {
            let f = self.engine.channel_fault(i);
            if f.is_some() && f == self.prev_fault[i] {
                self.fault_seen[i] = Some(self.last_step);
            }
            if f.is_none()
                && self.prev_fault[i].is_some()
                && self.fault_seen[i].is_some_and(|seen| {
                    self.last_step.saturating_duration_since(seen)
                        < crate::alarms::CHANNEL_CLEAR_HOLD
                })
            {
                continue;
            }
            if f != self.prev_fault[i] {
                self.fault_seen[i] = f.map(|_| self.last_step);
                let name = &self.engine.channel_names()[i];
                if let Some(old) = self.prev_fault[i] {
                    self.record(Record::AlarmCleared {
                        time_s: t,
                        key: format!("channel.{name}.{}", fault_name(old)),
                    });
                }
                if let Some(new) = f {
                    let r = self.readings[i];
                    let range = self
                        .config
                        .channels
                        .get(i)
                        .map(|c| format!("{}…{}", c.valid_min, c.valid_max))
                        .unwrap_or_default();
                    let message = if r.stamp_s == f64::NEG_INFINITY {
                        // Nothing has arrived since the start: say so, not "NaN at −inf s".
                        format!(
                            "channel {name}: no reading yet at cycle {t:.3} s (valid {range}); axes reading it are frozen until one arrives"
                        )
                    } else {
                        format!(
                            "channel {name}: {} (raw = {}, stamped {:.3} s at cycle {:.3} s; valid {range}); axes reading it are frozen",
                            fault_name(new),
                            r.raw,
                            r.stamp_s,
                            t
                        )
                    };
                    self.raise(t, format!("channel.{name}.{}", fault_name(new)), message);
                }
                self.prev_fault[i] = f;
            }
        }
        // A warning (the model extrapolating: compensation goes on) shows when no engine
        // alarm does.
        let shown = out
            .alarm
            .filter(|a| engine_alarm_key(*a).is_some())
            .or(out.warning);
        let engine_alarm = shown.and_then(engine_alarm_key);
        if engine_alarm != self.prev_engine_alarm {
            if let Some(k) = self.prev_engine_alarm {
                self.record(Record::AlarmCleared {
                    time_s: t,
                    key: k.into(),
                });
            }
            if let (Some(k), Some(a)) = (engine_alarm, shown) {
                let names = (self.engine.channel_names(), self.engine.axis_names());
                let text = gearcomp_thermal::replay::describe_alarm(&a, names.0, names.1);
                self.raise(t, k.into(), text);
            }
            self.prev_engine_alarm = engine_alarm;
        }
        let stop = out.stop.is_some();
        if stop != self.prev_stop {
            if let Some(s) = out.stop {
                self.raise(t, "engine.stop".into(), stop_text(&self.engine, s));
            } else {
                self.record(Record::AlarmCleared {
                    time_s: t,
                    key: "engine.stop".into(),
                });
            }
            self.prev_stop = stop;
        }

        if out.averaged {
            for i in 0..self.readings.len() {
                let v = self.engine.channel_value(i);
                if v.is_finite() {
                    self.record(Record::Average {
                        time_s: t,
                        channel: i as u16,
                        value: v,
                    });
                }
            }
        }
        let mut changed = false;
        let mut next = [0.0; MAX_AXES];
        for (i, a) in out.axes().iter().enumerate() {
            if !self.valid[i] && self.engine.axis_ready(i) {
                // The first valid offset: outputs may write from now on.
                self.valid[i] = true;
                changed = true;
            }
            let ready = a.status != AxisStatus::Starting;
            let y = self.bumpless.apply(i, a.offset_um, ready);
            next[i] = y;
            if y != self.applied_um[i] {
                if self.valid[i] {
                    self.pulses.issue(i, self.applied_um[i], y);
                }
                changed = true;
            }
        }
        let n_axes = out.axes().len();
        if changed || out.averaged {
            for (i, a) in out.axes().iter().enumerate() {
                self.record(Record::Offset {
                    time_s: t,
                    axis: i as u8,
                    offset_um: next[i],
                    target_um: a.target_um,
                    law_um: a.law_um,
                    status: status_name(a.status),
                });
            }
        }
        self.applied_um = next;
        // Nothing leaves before an axis has a valid offset (no 0 meaning "no value yet");
        // a change of the stop request always does.
        let stop_changed = stop != self.published_stop;
        self.published_stop = stop;
        if (changed && self.valid[..n_axes].iter().any(|v| *v)) || stop_changed {
            self.seq += 1;
            let o = self.offset_out(t, self.scan_at);
            self.offsets.send_replace(o);
        }
        let averaged = out.averaged;
        if trigger {
            if let Some(at) = self.scan_at {
                self.latency.add(at.elapsed());
            }
        }
        if let Ok(mut live) = self.live.lock() {
            live.time_s = t;
            live.status = engine_status_name(out.status);
            live.cycles = self.cycles;
            live.samples = self.samples;
            for (i, c) in live.channels.iter_mut().enumerate() {
                let r = self.readings[i];
                c.raw = r.raw.is_finite().then_some(r.raw);
                c.stamp_s = r.stamp_s.is_finite().then_some(r.stamp_s);
                let v = self.engine.channel_value(i);
                c.value = v.is_finite().then_some(v);
                c.fault = self.engine.channel_fault(i).map(fault_name);
            }
            for (i, (l, a)) in live.axes.iter_mut().zip(out.axes()).enumerate() {
                l.offset_um = next[i];
                l.engine_offset_um = a.offset_um;
                l.target_um = a.target_um;
                l.law_um = a.law_um.is_finite().then_some(a.law_um);
                let p = self.positions_mm[i];
                l.position_mm = p.is_finite().then_some(p);
                l.status = status_name(a.status);
            }
            if stop != live.stop.is_some() {
                live.stop = out.stop.map(|s| stop_text(&self.engine, s));
            }
        }
        if let Some(p) = self.persist.as_mut() {
            p.dirty |= changed || averaged;
            // A new applied offset is kept at once, right after its offset rows (so in
            // the same commit but at a batch boundary): after a kill -9 the restart
            // resumes from the offset the record ends with, not from one up to a
            // commit interval older (which stepped the machine back by more than the
            // rate limit in the chaos test). Other changes (averages, filters) are kept
            // at most every interval.
            if changed || (p.dirty && p.last.elapsed() >= p.interval) {
                self.save_state(t);
            }
        }
    }

    /// Runs until shutdown: steps on complete scans, and at the latest every period so a
    /// silent input is detected as stale.
    pub fn run(mut self, rx: Receiver<InputMsg>) {
        loop {
            if self.shutdown.load(Ordering::Acquire) {
                break;
            }
            let due = self.last_step + self.period;
            let wait = due.saturating_duration_since(Instant::now());
            match rx.recv_timeout(wait) {
                Ok(m) => {
                    if !self.handle(m) {
                        break;
                    }
                }
                Err(RecvTimeoutError::Timeout) => self.step(),
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if self.last_step.elapsed() >= self.period {
                self.step();
            }
        }
        // Finish: whatever arrived is stepped once more so the record ends on a cycle.
        while let Ok(m) = rx.try_recv() {
            if !self.handle(m) {
                break;
            }
        }
        if self.n_fresh > 0 {
            self.step();
        }
        if self.cycles > 0 {
            self.save_state(self.last_time_s);
        }
    }
}

fn stop_text(engine: &Engine, s: StopReason) -> String {
    let name = engine
        .channel_names()
        .get(s.channel as usize)
        .map_or("?", String::as_str);
    format!(
        "stop requested: channel {name} averaged value {} outside its limits {}…{}",
        s.value, s.limit_min, s.limit_max
    )
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    #[test]
    fn bumpless_holds_then_moves_at_the_rate() {
        let mut b = Bumpless::default();
        b.start(&[10.0], &[2.0]);
        // Not ready: hold the old output whatever the new engine says.
        assert_eq!(b.apply(0, 0.0, false), 10.0);
        // Ready at 3 µm: 10 − 2k until within 2 µm, then 3 (closed form max(10 − 2k, 3)).
        let ys: Vec<f64> = (0..6).map(|_| b.apply(0, 3.0, true)).collect();
        assert_eq!(ys, vec![8.0, 6.0, 4.0, 3.0, 3.0, 3.0]);
        // Transfer over: the engine's offset passes unchanged, steps included.
        assert_eq!(b.apply(0, 30.0, true), 30.0);
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(128))]
        /// A model change while the new engine ramps from 0 at its rate limit r (as the
        /// engine's own max_step_um does): the applied offset never moves by more than r
        /// per cycle, and equals the new engine's once that holds still. Reference: the
        /// new engine's ramp written here, y(k) = y(k−1) + clamp(target − y(k−1), −r, r).
        #[test]
        fn bumpless_never_steps_beyond_the_rate(
            old in -60.0f64..60.0,
            target in -60.0f64..60.0,
            r in 0.05f64..2.0,
            hold in 0usize..5,
        ) {
            let mut b = Bumpless::default();
            b.start(&[old], &[r]);
            let mut prev = old;
            for _ in 0..hold {
                let y = b.apply(0, 0.0, false);
                proptest::prop_assert_eq!(y, old);
            }
            let mut engine = 0.0f64;
            let n = 4 + (2.0 * 120.0 / r) as usize;
            for _ in 0..n {
                engine += (target - engine).clamp(-r, r);
                let y = b.apply(0, engine, true);
                proptest::prop_assert!((y - prev).abs() <= r * (1.0 + 1e-12), "{} -> {}", prev, y);
                prev = y;
            }
            proptest::prop_assert_eq!(prev, engine);
        }
    }

    #[test]
    fn bumpless_without_start_is_identity() {
        let mut b = Bumpless::default();
        for y in [0.0, 1.5, -3.0] {
            assert_eq!(b.apply(0, y, true), y);
        }
    }

    /// Channel A (°C) and axis Z with the SINUMERIK/TwinCAT position law
    /// K0(T) + tanβ(T)·(P − P0): K0 = 2 + 0.5·(T − 20) µm, tanβ = 0.25 + 0.0625·(T − 20)
    /// µm/mm, P0 = 100 mm.
    const POSITION_ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
        valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
        [[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\nmax_offset_um = 100.0\n\
        [[axes.terms]]\nkind = \"position\"\nchannel = \"A\"\nt_ref_c = 20.0\noffset_um = 2.0\n\
        offset_um_per_c = 0.5\nslope_um_per_mm = 0.25\nslope_um_per_mm_per_c = 0.0625\np0_mm = 100.0\n";

    #[test]
    fn positions_reach_the_position_law() {
        let cfg = EngineConfig::from_toml_str(POSITION_ENGINE).unwrap();
        let engine = Engine::new(&cfg).unwrap();
        let (rec_tx, rec_rx) = std::sync::mpsc::sync_channel(1024);
        let (off_tx, off_rx) = tokio::sync::watch::channel(OffsetOut::default());
        let live = Arc::new(Mutex::new(Live::new(
            engine.channel_names(),
            engine.axis_names(),
        )));
        let clock = Clock::new(0.0, 1.0);
        let mut cycle = Cycle::new(CycleParts {
            engine,
            config: cfg,
            clock,
            period_s: 1.0,
            bumpless_step_um: 0.5,
            records: rec_tx,
            live: live.clone(),
            offsets: off_tx,
            shutdown: Arc::new(AtomicBool::new(false)),
        });
        let sample = |c: &mut Cycle, temp_c: f64| {
            assert!(c.handle(InputMsg::Sample {
                channel: 0,
                raw: temp_c,
                stamp_s: clock.now_s(),
            }));
        };
        // No position yet: the axis freezes at 0 and the engine says why.
        sample(&mut cycle, 24.0);
        assert_eq!(off_rx.borrow().offsets_um[0], 0.0);
        assert_eq!(live.lock().unwrap().axes[0].status, "frozen");
        let raised: Vec<String> = rec_rx
            .try_iter()
            .filter_map(|r| match r {
                Record::AlarmRaised { key, .. } => Some(key),
                _ => None,
            })
            .collect();
        assert_eq!(raised, vec!["engine.position_missing".to_string()]);

        // By hand at T = 24 °C: K0 = 2 + 0.5·4 = 4 µm, tanβ = 0.25 + 0.0625·4 = 0.5 µm/mm.
        // P = 140 mm: 4 + 0.5·(140 − 100) = 24 µm; P = 60 mm: 4 + 0.5·(60 − 100) = −16 µm.
        for (p_mm, want_um) in [(140.0, 24.0), (60.0, -16.0)] {
            assert!(cycle.handle(InputMsg::Position {
                axis: 0,
                position_mm: p_mm,
            }));
            sample(&mut cycle, 24.0);
            assert_eq!(off_rx.borrow().offsets_um[0], want_um, "P = {p_mm} mm");
            let l = live.lock().unwrap();
            assert_eq!(l.axes[0].position_mm, Some(p_mm));
            assert_eq!(l.axes[0].law_um, Some(want_um));
        }
        // An axis index past the engine's axes is ignored, not a panic.
        assert!(cycle.handle(InputMsg::Position {
            axis: 200,
            position_mm: 1.0,
        }));
        // A position known to be unknown freezes the axis at its last value.
        assert!(cycle.handle(InputMsg::Position {
            axis: 0,
            position_mm: f64::NAN,
        }));
        sample(&mut cycle, 24.0);
        assert_eq!(off_rx.borrow().offsets_um[0], -16.0);
        assert_eq!(live.lock().unwrap().axes[0].status, "frozen");
    }

    /// A and B in °C, Cz = −3.75·(A − B) on Z, rate limit 0.5 µm per cycle, applied only
    /// at safe points.
    const RATE_ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
        valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
        [[channels]]\nname = \"B\"\nsensor = { kind = \"celsius\" }\n\
        valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
        [[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\nmax_offset_um = 100.0\n\
        max_step_um = 0.5\nsafe_points_only = true\n\
        [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n";

    type Rig = (
        Cycle,
        std::sync::mpsc::Receiver<Record>,
        tokio::sync::watch::Receiver<OffsetOut>,
        Clock,
    );

    fn rig(origin_s: f64) -> Rig {
        rig_with(RATE_ENGINE, origin_s)
    }

    fn rig_with(engine_toml: &str, origin_s: f64) -> Rig {
        let cfg = EngineConfig::from_toml_str(engine_toml).unwrap();
        let engine = Engine::new(&cfg).unwrap();
        let (rec_tx, rec_rx) = std::sync::mpsc::sync_channel(1 << 16);
        let (off_tx, off_rx) = tokio::sync::watch::channel(OffsetOut::default());
        let live = Arc::new(Mutex::new(Live::new(
            engine.channel_names(),
            engine.axis_names(),
        )));
        let clock = Clock::new(origin_s, 1.0);
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
        (cycle, rec_rx, off_rx, clock)
    }

    /// One complete scan (A, B) at the given machine state; returns the offset published.
    fn scan(r: &mut Rig, a_c: f64, safe_point: bool) -> (u64, f64) {
        assert!(r.0.handle(InputMsg::MachineState { safe_point }));
        for (c, raw) in [(0u16, a_c), (1u16, 20.0)] {
            assert!(r.0.handle(InputMsg::Sample {
                channel: c,
                raw,
                stamp_s: r.3.now_s(),
            }));
        }
        let o = *r.2.borrow();
        (o.seq, o.offsets_um[0])
    }

    #[test]
    fn resume_state_text_round_trips_every_bit() {
        let st = ResumeState {
            config_hash: 0xfeed_beef_0123_4567,
            valid: vec![true, false],
            applied_um: vec![-22.5, 0.1 + 0.2],
            engine: vec![
                1.0,
                f64::NEG_INFINITY,
                f64::INFINITY,
                -0.0,
                5e-324,
                1.0 / 3.0,
            ],
            pulse_total: vec![-7, i64::MAX],
            pulse_carry: vec![-0.5, 0.25],
            pulses_acked: vec![-6, i64::MIN],
        };
        let back = ResumeState::decode(&st.encode()).unwrap();
        assert_eq!(back.config_hash, st.config_hash);
        assert_eq!(back.valid, st.valid);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.applied_um), bits(&st.applied_um));
        assert_eq!(bits(&back.engine), bits(&st.engine));
        assert_eq!(back.pulse_total, st.pulse_total);
        assert_eq!(bits(&back.pulse_carry), bits(&st.pulse_carry));
        assert_eq!(back.pulses_acked, st.pulses_acked);
        // The first form (no pulse section) is still read, with no pulses.
        let v1 = format!(
            "gearcomp-resume-1 {:016x} 1 0 1 {:016x}",
            7u64,
            (-22.5f64).to_bits()
        );
        let old = ResumeState::decode(&v1).unwrap();
        assert_eq!(
            (old.applied_um, old.pulse_total, old.pulses_acked),
            (vec![-22.5], vec![0], vec![0])
        );
        // Truncated, extended or foreign text is refused.
        let text = st.encode();
        assert!(ResumeState::decode(&text[..text.len() - 1]).is_none());
        assert!(ResumeState::decode(&format!("{text} 00")).is_none());
        assert!(ResumeState::decode("gearcomp-resume-0 0 0 0").is_none());
    }

    /// Restart mid-cut: the first value out is the last applied offset, nothing moves
    /// until the next safe point, then the rate limit governs; a fault freezes and alarms,
    /// never writes 0; a fresh start with a fault writes nothing at all.
    #[test]
    fn restart_resumes_mid_cut_without_a_step() {
        let mut r1 = rig(0.0);
        // A = 24 °C: target −15 µm, reached at 0.5 µm per cycle; stop at −5 µm.
        let mut ys = Vec::new();
        for _ in 0..10 {
            ys.push(scan(&mut r1, 24.0, true).1);
        }
        let want: Vec<f64> = (1..=10).map(|k| -0.5 * f64::from(k)).collect();
        assert_eq!(ys, want);
        let state = r1.0.resume_state();
        assert_eq!(state.applied_um, vec![-5.0]);

        // The new run starts mid-cut (the source reports the machine state).
        let mut r2 = rig(100.0);
        r2.0.set_safe_point(false);
        assert_eq!(r2.0.resume(&state), Resumed::OffsetsAndEngine);
        let first = *r2.2.borrow();
        assert_eq!(
            (first.seq, first.offsets_um[0], first.valid[0]),
            (1, -5.0, true)
        );
        // Mid-cut with a new temperature (target −22.5 µm): held at −5 µm.
        for _ in 0..5 {
            assert_eq!(scan(&mut r2, 26.0, false), (1, -5.0));
        }
        // At the safe point: one rate step per cycle, −5.5, −6, −6.5.
        let ys: Vec<f64> = (0..3).map(|_| scan(&mut r2, 26.0, true).1).collect();
        assert_eq!(ys, vec![-5.5, -6.0, -6.5]);
        // A fault: the target freezes at its last good value (−22.5 µm) with an alarm;
        // the offset goes on towards it at the rate limit, never to 0.
        let ys: Vec<f64> = (0..3).map(|_| scan(&mut r2, f64::NAN, true).1).collect();
        assert_eq!(ys, vec![-7.0, -7.5, -8.0]);
        let raised: Vec<String> =
            r2.1.try_iter()
                .filter_map(|r| match r {
                    Record::AlarmRaised { key, .. } => Some(key),
                    _ => None,
                })
                .collect();
        assert_eq!(raised, vec!["channel.A.not_a_number".to_string()]);

        // Another configuration (engine state not restorable): the offsets still resume
        // and are held until the new law has a value.
        let mut r3 = rig(200.0);
        let mut other = state.clone();
        other.config_hash ^= 1;
        assert_eq!(r3.0.resume(&other), Resumed::Offsets);
        assert_eq!(r3.2.borrow().offsets_um[0], -5.0);

        // A fresh start whose first readings are faulty publishes nothing.
        let mut r4 = rig(300.0);
        for _ in 0..3 {
            assert_eq!(scan(&mut r4, f64::NAN, true).0, 0);
        }
        assert!(!r4.2.borrow().valid[0]);
    }

    /// A restart with another engine configuration moves from the applied offset at the
    /// transfer's rate, as a model change does: an axis without max_step_um ramps at
    /// cycle.bumpless_step_um to its law (it stepped from −5 to −15 µm at once), and a
    /// smaller max_offset_um is reached at the axis's rate (it was clamped at once, −5 to
    /// −2 µm). Closed forms: target −3.75·(24 − 20) = −15 µm, clamp ±2 µm; rate 0.5 µm.
    #[test]
    fn restart_with_another_configuration_never_steps() {
        let mut r1 = rig(0.0);
        for _ in 0..10 {
            scan(&mut r1, 24.0, true);
        }
        let state = r1.0.resume_state();
        assert_eq!(state.applied_um, vec![-5.0]);
        let no_step = RATE_ENGINE.replace("max_step_um = 0.5\nsafe_points_only = true\n", "");
        let small_max = RATE_ENGINE.replace("max_offset_um = 100.0", "max_offset_um = 2.0");
        assert!(no_step != RATE_ENGINE && small_max != RATE_ENGINE);
        for (engine, target) in [(no_step.as_str(), -15.0), (small_max.as_str(), -2.0)] {
            let mut r2 = rig_with(engine, 100.0);
            assert_eq!(r2.0.resume(&state), Resumed::Offsets);
            assert_eq!(r2.2.borrow().offsets_um[0], -5.0);
            let mut last = -5.0f64;
            let mut ys = Vec::new();
            for _ in 0..40 {
                let y = scan(&mut r2, 24.0, true).1;
                assert!((y - last).abs() <= 0.5 + 1e-12, "{last} → {y} ({engine})");
                last = y;
                ys.push(y);
            }
            let cycles = ((target - -5.0f64).abs() / 0.5).ceil() as usize;
            assert_eq!(ys[cycles - 1], target, "{ys:?}");
            assert!(ys[cycles..].iter().all(|&y| y == target), "{ys:?}");
        }
    }

    /// As RATE_ENGINE, applied as infeed pulses of 0.7 µm at any time.
    const PULSE_ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
        valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
        [[channels]]\nname = \"B\"\nsensor = { kind = \"celsius\" }\n\
        valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
        [[axes]]\nname = \"Z\"\napply = { kind = \"pulses\", pulse_um = 0.7 }\n\
        max_offset_um = 100.0\nmax_step_um = 0.5\n\
        [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n";

    /// Pulses follow the applied offset with the remainder carried, so after every cycle
    /// the total is round(applied / pulse) (closed form: Σn = X − r with |r| ≤ ½); the
    /// issued total, remainder and acknowledged total survive a restart.
    #[test]
    fn pulses_follow_the_applied_offset_across_a_restart() {
        const P: f64 = 0.7;
        let mut r1 = rig_with(PULSE_ENGINE, 0.0);
        for k in 1..=12 {
            scan(&mut r1, 24.0, true);
            let o = *r1.2.borrow();
            let y = -0.5 * f64::from(k);
            assert_eq!(o.offsets_um[0], y);
            assert_eq!(o.pulse_um[0], P);
            assert_eq!(o.pulse_total[0], (y / P).round() as i64, "cycle {k}");
        }
        // −6 µm / 0.7 µm = −8.571… → −9 pulses issued; the device acknowledged −5.
        assert!(r1.0.handle(InputMsg::PulsesAcked { axis: 0, total: -5 }));
        let state = r1.0.resume_state();
        assert_eq!(
            (state.pulse_total.clone(), state.pulses_acked.clone()),
            (vec![-9], vec![-5])
        );
        let back = ResumeState::decode(&state.encode()).unwrap();

        let mut r2 = rig_with(PULSE_ENGINE, 100.0);
        assert_eq!(r2.0.resume(&back), Resumed::OffsetsAndEngine);
        let first = *r2.2.borrow();
        // The output resumes: 4 pulses issued but not acknowledged are still to be sent.
        assert_eq!((first.pulse_total[0], first.pulses_acked[0]), (-9, -5));
        for k in 13..=22 {
            scan(&mut r2, 26.0, true);
            let o = *r2.2.borrow();
            let y = -0.5 * f64::from(k);
            assert_eq!(o.offsets_um[0], y);
            assert_eq!(o.pulse_total[0], (y / P).round() as i64, "cycle {k}");
        }
        // An axis applied otherwise issues no pulses.
        let mut r3 = rig(0.0);
        scan(&mut r3, 24.0, true);
        let o = *r3.2.borrow();
        assert_eq!((o.pulse_um[0], o.pulse_total[0]), (0.0, 0));
    }

    #[test]
    fn clock_runs_at_speedup() {
        let c = Clock::new(100.0, 1000.0);
        std::thread::sleep(Duration::from_millis(20));
        let t = c.now_s();
        assert!((120.0..200.0).contains(&t), "{t}");
        assert_eq!(c.wall(10.0), Duration::from_millis(10));
    }
}
