//! OPC UA (async-opcua client): the CNC's variables as monitored items of one subscription
//! in, the applied offset written to a node out.
//!
//! * **Channels.** Each configured node feeds one engine channel,
//!   `value = node·scale + offset`. OPC UA reports changes only, so the adapter holds the
//!   latest value of every node and hands a complete scan (every held value, stamped with
//!   the service clock, then [`InputMsg::ScanEnd`]) to the cycle every `scan_period_s`, or
//!   at each trigger event when a `trigger` node is configured. While the session is lost
//!   nothing is handed over: the readings go stale and the engine freezes the axes.
//! * **Positions.** Each `positions` node feeds one engine axis's actual position,
//!   `position_mm = node·scale + offset`, held and handed over with every scan
//!   ([`InputMsg::Position`]) for the position-dependent terms; a wrong value or a lost
//!   session sends NaN, so the axes whose law needs the position freeze.
//! * **Trigger.** A Boolean node fires on its rising edge, an integer counter on any change
//!   (the first value after a (re)connect is the baseline and fires nothing).
//! * **Program state.** An integer (or Boolean, true = 1) node; the machine is at a safe
//!   point when its value is one of `safe_values`.
//! * **Wrong data.** A node of the wrong data type, with a bad status or without a value
//!   raises `opcua.node.<node id>` naming the node, the type found and the type expected;
//!   a channel then gets NaN (the engine freezes the axes reading it), nothing crashes.
//! * **Output.** The applied offset is written as an absolute Double,
//!   `node = offset_um·scale`, once per offset sequence number, and once more at the
//!   start of every session (a CNC restarted while the service runs gets the current value
//!   at once); a failed write raises `opcua.offset_output` and is retried with back-off with
//!   the newest value.
//! * **Reconnect.** A failed connect or a lost session raises `opcua.connection` and is
//!   retried with the same capped exponential back-off as Modbus and MQTT.

use std::str::FromStr;
use std::sync::mpsc::SyncSender;
use std::sync::Arc;
use std::time::Duration;

use futures::StreamExt;
use opcua::client::{
    Client, ClientBuilder, DataChangeCallback, IdentityToken, MonitoredItem, Session,
    SessionPollResult,
};
use opcua::crypto::SecurityPolicy;
use opcua::types::{
    AttributeId, DataValue, MessageSecurityMode, MonitoredItemCreateRequest, MonitoringMode,
    MonitoringParameters, NodeId, NumericRange, ReadValueId, TimestampsToReturn, Variant,
    WriteValue,
};
use tokio::sync::watch;
use tokio::time::Instant;

use crate::config::OpcUaInput;
use crate::cycle::{Clock, InputMsg, OffsetOut};
use crate::error::{invalid, Result};

/// Parses a node id in the OPC UA text form (`ns=2;s=Name`, `ns=3;i=42`, `i=2258`).
pub fn parse_node(field: &str, s: &str) -> Result<NodeId> {
    NodeId::from_str(s.trim()).map_err(|_| {
        invalid(
            field,
            format!("{s:?}"),
            "an OPC UA node id such as \"ns=2;s=Temp.Bed\" or \"ns=3;i=1021\"",
        )
    })
}

/// The OPC UA name of a value's data type, for messages.
pub fn type_name(v: &Variant) -> &'static str {
    match v {
        Variant::Empty => "Empty",
        Variant::Boolean(_) => "Boolean",
        Variant::SByte(_) => "SByte",
        Variant::Byte(_) => "Byte",
        Variant::Int16(_) => "Int16",
        Variant::UInt16(_) => "UInt16",
        Variant::Int32(_) => "Int32",
        Variant::UInt32(_) => "UInt32",
        Variant::Int64(_) => "Int64",
        Variant::UInt64(_) => "UInt64",
        Variant::Float(_) => "Float",
        Variant::Double(_) => "Double",
        Variant::String(_) => "String",
        Variant::DateTime(_) => "DateTime",
        Variant::Guid(_) => "Guid",
        Variant::StatusCode(_) => "StatusCode",
        Variant::ByteString(_) => "ByteString",
        Variant::XmlElement(_) => "XmlElement",
        Variant::QualifiedName(_) => "QualifiedName",
        Variant::LocalizedText(_) => "LocalizedText",
        Variant::NodeId(_) => "NodeId",
        Variant::ExpandedNodeId(_) => "ExpandedNodeId",
        Variant::ExtensionObject(_) => "ExtensionObject",
        Variant::Variant(_) => "Variant",
        Variant::DataValue(_) => "DataValue",
        Variant::DiagnosticInfo(_) => "DiagnosticInfo",
        Variant::Array(_) => "Array",
    }
}

/// The value of a data-change notification, or a message saying why it is not usable.
fn good_value(dv: &DataValue) -> std::result::Result<&Variant, String> {
    if let Some(s) = dv.status {
        if !s.is_good() {
            return Err(format!("status {s}"));
        }
    }
    match &dv.value {
        None | Some(Variant::Empty) => Err("no value (Empty)".into()),
        Some(v) => Ok(v),
    }
}

/// Converts a channel node's value into the channel's raw unit.
///
/// # Formula
/// value = node·scale + offset, for a node of a numeric type (Double expected; Float and
/// the integer types are widened to f64)
/// # Source
/// OPC UA Part 3 §8.2 / Part 6 §5.1.2 (built-in numeric types) [STANDARD]; linear scaling
/// as for Modbus registers [CONVENTION, docs/service.md]
pub fn channel_value(dv: &DataValue, scale: f64, offset: f64) -> std::result::Result<f64, String> {
    let v = good_value(dv)?;
    let x = match v {
        Variant::Double(x) => *x,
        Variant::Float(x) => f64::from(*x),
        Variant::SByte(x) => f64::from(*x),
        Variant::Byte(x) => f64::from(*x),
        Variant::Int16(x) => f64::from(*x),
        Variant::UInt16(x) => f64::from(*x),
        Variant::Int32(x) => f64::from(*x),
        Variant::UInt32(x) => f64::from(*x),
        Variant::Int64(x) => *x as f64,
        Variant::UInt64(x) => *x as f64,
        other => {
            return Err(format!(
                "data type {}, expected Double (or another numeric type)",
                type_name(other)
            ))
        }
    };
    if !x.is_finite() {
        return Err(format!("value {x} is not finite"));
    }
    Ok(x * scale + offset)
}

/// The integer value of a state or counter node (Boolean → 0/1).
pub fn integer_value(dv: &DataValue, expected: &str) -> std::result::Result<i64, String> {
    let v = good_value(dv)?;
    Ok(match v {
        Variant::Boolean(b) => i64::from(*b),
        Variant::SByte(x) => i64::from(*x),
        Variant::Byte(x) => i64::from(*x),
        Variant::Int16(x) => i64::from(*x),
        Variant::UInt16(x) => i64::from(*x),
        Variant::Int32(x) => i64::from(*x),
        Variant::UInt32(x) => i64::from(*x),
        Variant::Int64(x) => *x,
        // Counters beyond i64 wrap; only changes matter.
        Variant::UInt64(x) => *x as i64,
        other => {
            return Err(format!(
                "data type {}, expected {expected}",
                type_name(other)
            ))
        }
    })
}

/// Whether a trigger node's new value is an event, given its previous value.
///
/// A Boolean fires on its rising edge; a counter on any change. The first value (no
/// previous) is the baseline.
pub fn trigger_fires(prev: Option<i64>, new: i64, boolean: bool) -> bool {
    match prev {
        None => false,
        Some(p) if boolean => p == 0 && new != 0,
        Some(p) => p != new,
    }
}

/// The value written to the offset node.
///
/// # Formula
/// node = offset_um · scale   (scale = 1 for µm, 0.001 for mm)
/// # Source
/// absolute compensation value as SINUMERIK's temperature-compensation setting data or a
/// TwinCAT external-compensation variable take it [CONVENTION, docs/service.md]
pub fn encode_offset(offset_um: f64, scale: f64) -> std::result::Result<f64, String> {
    let v = offset_um * scale;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!(
            "offset {offset_um} µm × scale {scale} = {v}: not a finite value"
        ))
    }
}

/// What a monitored item feeds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Role {
    /// Index into [`Resolved::channels`].
    Channel(usize),
    /// Index into [`Resolved::positions`].
    Position(usize),
    /// The trigger node.
    Trigger,
    /// The program-state node.
    ProgramState,
}

/// A channel node with its engine channel index.
#[derive(Debug, Clone)]
struct ChannelNode {
    node: NodeId,
    name: String,
    channel: u16,
    scale: f64,
    offset: f64,
}

/// A position node with its engine axis index.
#[derive(Debug, Clone)]
struct PositionNode {
    node: NodeId,
    name: String,
    axis: u8,
    scale: f64,
    offset: f64,
}

/// The configuration with node ids parsed and names resolved against the engine.
#[derive(Debug, Clone)]
pub struct Resolved {
    channels: Vec<ChannelNode>,
    positions: Vec<PositionNode>,
    trigger: Option<NodeId>,
    program_state: Option<(NodeId, Vec<i64>)>,
    output: Option<(NodeId, usize, f64)>,
    stop: Option<NodeId>,
    beat: Option<(NodeId, Duration)>,
}

/// Checks every node id, mapped channel and the offset axis.
pub fn resolve(cfg: &OpcUaInput, channels: &[String], axes: &[String]) -> Result<Resolved> {
    let mut out = Vec::new();
    for (i, c) in cfg.channels.iter().enumerate() {
        let ch = channels
            .iter()
            .position(|n| n == &c.channel)
            .ok_or_else(|| {
                invalid(
                    format!("input.channels[{i}].channel"),
                    &c.channel,
                    format!("an engine channel: {}", channels.join(", ")),
                )
            })?;
        out.push(ChannelNode {
            node: parse_node(&format!("input.channels[{i}].node"), &c.node)?,
            name: c.channel.clone(),
            channel: ch as u16,
            scale: c.scale,
            offset: c.offset,
        });
    }
    let mut positions = Vec::new();
    for (i, p) in cfg.positions.iter().enumerate() {
        let axis = axes.iter().position(|a| a == &p.axis).ok_or_else(|| {
            invalid(
                format!("input.positions[{i}].axis"),
                &p.axis,
                format!("an engine axis: {}", axes.join(", ")),
            )
        })?;
        positions.push(PositionNode {
            node: parse_node(&format!("input.positions[{i}].node"), &p.node)?,
            name: p.axis.clone(),
            // The engine has at most MAX_AXES (≤ 255) axes.
            axis: u8::try_from(axis).unwrap_or(u8::MAX),
            scale: p.scale,
            offset: p.offset,
        });
    }
    let trigger = match &cfg.trigger {
        Some(t) => Some(parse_node("input.trigger.node", &t.node)?),
        None => None,
    };
    let program_state = match &cfg.program_state {
        Some(p) => Some((
            parse_node("input.program_state.node", &p.node)?,
            p.safe_values.clone(),
        )),
        None => None,
    };
    let output = match &cfg.offset_output {
        Some(o) => {
            let axis = axes.iter().position(|a| a == &o.axis).ok_or_else(|| {
                invalid(
                    "input.offset_output.axis",
                    &o.axis,
                    format!("an engine axis: {}", axes.join(", ")),
                )
            })?;
            Some((
                parse_node("input.offset_output.node", &o.node)?,
                axis,
                o.scale,
            ))
        }
        None => None,
    };
    let stop = match &cfg.stop_output {
        Some(s) => Some(parse_node("input.stop_output.node", &s.node)?),
        None => None,
    };
    let beat = match &cfg.heartbeat {
        Some(h) => Some((
            parse_node("input.heartbeat.node", &h.node)?,
            Duration::from_secs_f64(h.period_s),
        )),
        None => None,
    };
    Ok(Resolved {
        channels: out,
        positions,
        trigger,
        program_state,
        output,
        stop,
        beat,
    })
}

/// Everything the OPC UA adapter needs.
pub struct OpcUaParts {
    /// The configuration.
    pub cfg: OpcUaInput,
    /// Engine channels in order.
    pub channels: Vec<String>,
    /// Axis names in order.
    pub axes: Vec<String>,
    /// The service clock.
    pub clock: Clock,
    /// To the cycle.
    pub tx: SyncSender<InputMsg>,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
    /// The cycle's step count (`Cycle::alive`), for the heartbeat output.
    pub alive: Arc<std::sync::atomic::AtomicU64>,
}

/// The stop / feed-hold and heartbeat outputs and what was last written to them.
struct Flags {
    stop: Option<NodeId>,
    stop_written: Option<bool>,
    beat: Option<(NodeId, Duration)>,
    counter: i32,
    last_alive: u64,
    next_beat: Instant,
    alive: Arc<std::sync::atomic::AtomicU64>,
}

const STOP_KEY: &str = "opcua.stop_output";
const BEAT_KEY: &str = "opcua.heartbeat";

/// Writes one value (value only, no timestamps); Err names the status or the failure.
async fn write_value(
    session: &Arc<Session>,
    node: &NodeId,
    v: Variant,
) -> std::result::Result<(), String> {
    let wv = WriteValue {
        node_id: node.clone(),
        attribute_id: AttributeId::Value as u32,
        index_range: NumericRange::None,
        value: DataValue {
            value: Some(v),
            ..Default::default()
        },
    };
    match tokio::time::timeout(Duration::from_secs(5), session.write(&[wv])).await {
        Ok(Ok(codes)) => match codes.first() {
            Some(c) if c.is_good() => Ok(()),
            Some(c) => Err(format!("{c}")),
            None => Err("no result".into()),
        },
        Ok(Err(e)) => Err(format!("{e}")),
        Err(_) => Err("no answer within 5 s".into()),
    }
}

/// The stop flag when it changed or the session is new; the heartbeat counter every
/// period while the cycle steps (a dead cycle stops it, so the PLC holds its offset).
async fn write_flags(
    session: &Arc<Session>,
    f: &mut Flags,
    offsets: &watch::Receiver<OffsetOut>,
    tx: &SyncSender<InputMsg>,
) {
    if let Some(node) = &f.stop {
        let want = offsets.borrow().stop;
        if f.stop_written != Some(want) {
            match write_value(session, node, Variant::Boolean(want)).await {
                Ok(()) => {
                    f.stop_written = Some(want);
                    send(
                        tx,
                        InputMsg::ClearAlarm {
                            key: STOP_KEY.into(),
                        },
                    );
                }
                Err(why) => send(
                    tx,
                    InputMsg::RaiseAlarm {
                        key: STOP_KEY.into(),
                        message: format!("OPC UA stop output {node} = {want}: {why}; retrying"),
                    },
                ),
            }
        }
    }
    if let Some((node, period)) = &f.beat {
        let now = Instant::now();
        if now >= f.next_beat {
            f.next_beat = now + *period;
            let a = f.alive.load(std::sync::atomic::Ordering::Acquire);
            if a != f.last_alive {
                f.last_alive = a;
                let c = f.counter.wrapping_add(1);
                match write_value(session, node, Variant::Int32(c)).await {
                    Ok(()) => {
                        f.counter = c;
                        send(
                            tx,
                            InputMsg::ClearAlarm {
                                key: BEAT_KEY.into(),
                            },
                        );
                    }
                    Err(why) => send(
                        tx,
                        InputMsg::RaiseAlarm {
                            key: BEAT_KEY.into(),
                            message: format!("OPC UA heartbeat {node} = {c}: {why}; retrying"),
                        },
                    ),
                }
            }
        }
    }
}

fn send(tx: &SyncSender<InputMsg>, m: InputMsg) {
    // try_send: an async task must not block the runtime (as MQTT and Modbus).
    let _ = tx.try_send(m);
}

const CONN_KEY: &str = "opcua.connection";
const OUT_KEY: &str = "opcua.offset_output";

fn node_key(n: &NodeId) -> String {
    format!("opcua.node.{n}")
}

/// The offset output's state, kept across reconnects so a sequence number confirmed once
/// is not written again without need.
struct Output {
    node: NodeId,
    axis: usize,
    scale: f64,
    written_seq: u64,
    /// The node value last confirmed: a new sequence number that only changed another
    /// axis leaves it as it is.
    written_value: Option<f64>,
    /// Write the newest value even if its sequence number was confirmed: set at the start
    /// of a session, since the server may have restarted and lost the value.
    rewrite: bool,
    failures: u32,
    next_try: Instant,
}

/// State of one live session.
struct Live<'a> {
    r: &'a Resolved,
    clock: Clock,
    tx: &'a SyncSender<InputMsg>,
    held: Vec<Option<f64>>,
    held_pos: Vec<Option<f64>>,
    trigger_prev: Option<i64>,
    safe_point: Option<bool>,
    /// Nodes with a raised `opcua.node.*` alarm, so a good value clears it once.
    alarmed: std::collections::HashSet<NodeId>,
}

impl Live<'_> {
    fn scan(&self) {
        if let Some(s) = self.safe_point {
            send(self.tx, InputMsg::MachineState { safe_point: s });
        }
        for (p, v) in self.r.positions.iter().zip(&self.held_pos) {
            if let Some(position_mm) = *v {
                send(
                    self.tx,
                    InputMsg::Position {
                        axis: p.axis,
                        position_mm,
                    },
                );
            }
        }
        let stamp_s = self.clock.now_s();
        for (c, v) in self.r.channels.iter().zip(&self.held) {
            if let Some(raw) = *v {
                send(
                    self.tx,
                    InputMsg::Sample {
                        channel: c.channel,
                        raw,
                        stamp_s,
                    },
                );
            }
        }
        send(self.tx, InputMsg::ScanEnd);
    }

    fn alarm(&mut self, node: &NodeId, what: &str, msg: String) {
        self.alarmed.insert(node.clone());
        send(
            self.tx,
            InputMsg::RaiseAlarm {
                key: node_key(node),
                message: format!("OPC UA node {node} ({what}): {msg}"),
            },
        );
    }

    fn clear(&mut self, node: &NodeId) {
        if !self.alarmed.remove(node) {
            return;
        }
        send(
            self.tx,
            InputMsg::ClearAlarm {
                key: node_key(node),
            },
        );
    }

    fn on_value(&mut self, role: Role, dv: &DataValue) {
        match role {
            Role::Channel(i) => {
                let Some(c) = self.r.channels.get(i) else {
                    return;
                };
                match channel_value(dv, c.scale, c.offset) {
                    Ok(v) => {
                        self.clear(&c.node);
                        self.held[i] = Some(v);
                    }
                    Err(msg) => {
                        self.alarm(&c.node, &format!("channel {}", c.name), msg);
                        // NaN reaches the engine as a faulty reading: the axes freeze.
                        self.held[i] = Some(f64::NAN);
                    }
                }
            }
            Role::Position(i) => {
                let Some(p) = self.r.positions.get(i) else {
                    return;
                };
                match channel_value(dv, p.scale, p.offset) {
                    Ok(v) => {
                        self.clear(&p.node);
                        self.held_pos[i] = Some(v);
                    }
                    Err(msg) => {
                        self.alarm(&p.node, &format!("position of axis {}", p.name), msg);
                        // Unknown position: the axes whose law needs it freeze.
                        self.held_pos[i] = Some(f64::NAN);
                    }
                }
            }
            Role::Trigger => {
                let Some(node) = &self.r.trigger else { return };
                let boolean = matches!(dv.value, Some(Variant::Boolean(_)));
                match integer_value(dv, "Boolean or an integer counter") {
                    Ok(v) => {
                        self.clear(node);
                        let fire = trigger_fires(self.trigger_prev, v, boolean);
                        self.trigger_prev = Some(v);
                        if fire {
                            self.scan();
                        }
                    }
                    Err(msg) => self.alarm(node, "trigger", msg),
                }
            }
            Role::ProgramState => {
                let Some((node, safe)) = &self.r.program_state else {
                    return;
                };
                match integer_value(dv, "an integer state or Boolean") {
                    Ok(v) => {
                        self.clear(node);
                        self.safe_point = Some(safe.contains(&v));
                    }
                    Err(msg) => {
                        self.alarm(node, "program state", msg);
                        // Unknown state: not a safe point, so safe-point axes wait.
                        self.safe_point = Some(false);
                    }
                }
                if let Some(s) = self.safe_point {
                    send(self.tx, InputMsg::MachineState { safe_point: s });
                }
            }
        }
    }
}

fn build_client(cfg: &OpcUaInput) -> Result<Client> {
    ClientBuilder::new()
        .application_name("gearcomp serve")
        .application_uri("urn:gearcomp:serve")
        .product_uri("urn:gearcomp")
        .pki_dir(cfg.pki_dir.clone())
        .create_sample_keypair(cfg.security_policy != "None")
        .trust_server_certs(cfg.trust_server_cert)
        .session_retry_limit(0)
        .keep_alive_interval(Duration::from_secs_f64(cfg.keep_alive_s))
        .max_failed_keep_alive_count(2)
        .request_timeout(Duration::from_secs(5))
        .client()
        .map_err(|e| {
            invalid(
                "input (OPC UA client)",
                e.join("; "),
                "a valid client setup",
            )
        })
}

fn identity(cfg: &OpcUaInput) -> Result<IdentityToken> {
    Ok(match (&cfg.user, cfg.password()?) {
        (Some(u), Some(p)) => IdentityToken::new_user_name(u.clone(), p),
        _ => IdentityToken::new_anonymous(),
    })
}

/// The adapter, checked and ready to run.
pub struct Adapter {
    p: OpcUaParts,
    r: Resolved,
    client: Client,
    token: IdentityToken,
}

/// Resolves the nodes, builds the client and reads the password, so that a configuration
/// error stops the start instead of a background task.
pub fn prepare(p: OpcUaParts) -> Result<Adapter> {
    let r = resolve(&p.cfg, &p.channels, &p.axes)?;
    let client = build_client(&p.cfg)?;
    let token = identity(&p.cfg)?;
    Ok(Adapter {
        p,
        r,
        client,
        token,
    })
}

impl Adapter {
    /// Runs until the task is aborted (service stop).
    pub async fn run(self) {
        run(self).await;
    }
}

async fn run(a: Adapter) {
    let Adapter {
        p,
        r,
        mut client,
        token,
    } = a;
    let mut offsets = p.offsets.clone();
    let mut output = r.output.clone().map(|(node, axis, scale)| Output {
        node,
        axis,
        scale,
        written_seq: 0,
        written_value: None,
        rewrite: true,
        failures: 0,
        next_try: Instant::now(),
    });
    let mut failures = 0u32;
    let mut flags = Flags {
        stop: r.stop.clone(),
        stop_written: None,
        beat: r.beat.clone(),
        counter: 0,
        last_alive: 0,
        next_beat: Instant::now(),
        alive: p.alive.clone(),
    };
    loop {
        let why = session(
            &mut client,
            &p.cfg,
            token.clone(),
            &r,
            p.clock,
            &p.tx,
            &mut offsets,
            &mut output,
            &mut flags,
            &mut failures,
        )
        .await;
        if r.program_state.is_some() {
            // The machine's state is unknown without the CNC.
            send(&p.tx, InputMsg::MachineState { safe_point: false });
        }
        for pn in &r.positions {
            // So are the axis positions (the axes may move while the session is down).
            send(
                &p.tx,
                InputMsg::Position {
                    axis: pn.axis,
                    position_mm: f64::NAN,
                },
            );
        }
        failures = failures.saturating_add(1);
        let wait_s = p.cfg.reconnect.wait_s(failures);
        send(
            &p.tx,
            InputMsg::RaiseAlarm {
                key: CONN_KEY.into(),
                message: format!(
                    "OPC UA server {}: {why}; retrying with back-off ({wait_s} s)",
                    p.cfg.endpoint
                ),
            },
        );
        tokio::time::sleep(Duration::from_secs_f64(wait_s)).await;
    }
}

/// One session: connect, subscribe, hand scans over and write offsets until the session
/// is lost; returns why it ended.
#[allow(clippy::too_many_arguments)]
async fn session(
    client: &mut Client,
    cfg: &OpcUaInput,
    token: IdentityToken,
    r: &Resolved,
    clock: Clock,
    tx: &SyncSender<InputMsg>,
    offsets: &mut watch::Receiver<OffsetOut>,
    output: &mut Option<Output>,
    flags: &mut Flags,
    failures: &mut u32,
) -> String {
    let policy = SecurityPolicy::from_str(&cfg.security_policy).unwrap_or(SecurityPolicy::None);
    let mode = match cfg.security_mode.as_str() {
        "Sign" => MessageSecurityMode::Sign,
        "SignAndEncrypt" => MessageSecurityMode::SignAndEncrypt,
        _ => MessageSecurityMode::None,
    };
    let endpoint = (cfg.endpoint.as_str(), policy.to_uri(), mode);
    let connect = tokio::time::timeout(
        Duration::from_secs(10),
        client.connect_to_matching_endpoint(endpoint, token),
    )
    .await;
    let (session, event_loop) = match connect {
        Ok(Ok(s)) => s,
        Ok(Err(e)) => return format!("cannot open a session ({e})"),
        Err(_) => return "no answer within 10 s".into(),
    };
    // The event loop drives the connection; it runs in a JoinSet so that it ends with
    // this future (service stop aborts the adapter task).
    let (state_tx, mut state_rx) = watch::channel::<Option<std::result::Result<(), String>>>(None);
    let mut tasks = tokio::task::JoinSet::new();
    tasks.spawn(async move {
        let stream = event_loop.enter();
        futures::pin_mut!(stream);
        let end = loop {
            match stream.next().await {
                Some(Ok(SessionPollResult::Reconnected(_))) => {
                    let _ = state_tx.send(Some(Ok(())));
                }
                Some(Ok(SessionPollResult::ConnectionLost(c))) => {
                    break format!("connection lost ({c})")
                }
                Some(Ok(SessionPollResult::ReconnectFailed(c))) => {
                    break format!("cannot connect ({c})")
                }
                Some(Ok(_)) => {}
                Some(Err(c)) => break format!("session ended ({c})"),
                None => break "session closed".into(),
            }
        };
        let _ = state_tx.send(Some(Err(end)));
    });
    let failed: Option<String> = {
        let up =
            tokio::time::timeout(Duration::from_secs(10), state_rx.wait_for(Option::is_some)).await;
        match up {
            Ok(Ok(s)) => match &*s {
                Some(Err(why)) => Some(why.clone()),
                _ => None,
            },
            Ok(Err(_)) => Some("session ended".into()),
            Err(_) => Some("no session within 10 s".into()),
        }
    };
    if let Some(why) = failed {
        return why;
    }

    let roles = monitored_roles(r);
    let (dv_tx, mut dv_rx) = tokio::sync::mpsc::channel::<(u32, DataValue)>(4096);
    let sub = session
        .create_subscription(
            Duration::from_secs_f64(cfg.publishing_interval_s),
            // Lifetime and keep-alive counts in publishing intervals (lifetime ≥ 3×).
            60,
            10,
            0,
            0,
            true,
            DataChangeCallback::new(move |dv: DataValue, item: &MonitoredItem| {
                let _ = dv_tx.try_send((item.client_handle(), dv));
            }),
        )
        .await;
    let sub = match sub {
        Ok(s) => s,
        Err(e) => return format!("cannot create the subscription ({e})"),
    };
    let items: Vec<MonitoredItemCreateRequest> = roles
        .iter()
        .enumerate()
        .map(|(h, (node, role))| MonitoredItemCreateRequest {
            item_to_monitor: ReadValueId {
                node_id: node.clone(),
                attribute_id: AttributeId::Value as u32,
                ..Default::default()
            },
            monitoring_mode: MonitoringMode::Reporting,
            requested_parameters: MonitoringParameters {
                // Handles start at 1: 0 asks the client library to pick one.
                client_handle: h as u32 + 1,
                sampling_interval: cfg.publishing_interval_s * 1000.0,
                // Keep every counter step of a trigger; other nodes only need the latest.
                queue_size: if *role == Role::Trigger { 16 } else { 1 },
                discard_oldest: true,
                ..Default::default()
            },
        })
        .collect();
    let mut live = Live {
        r,
        clock,
        tx,
        held: vec![None; r.channels.len()],
        held_pos: vec![None; r.positions.len()],
        trigger_prev: None,
        alarmed: Default::default(),
        safe_point: None,
    };
    if !items.is_empty() {
        match session
            .create_monitored_items(sub, TimestampsToReturn::Both, items)
            .await
        {
            Ok(res) => {
                for ((node, role), it) in roles.iter().zip(&res) {
                    let code = it.result.status_code;
                    if !code.is_good() {
                        live.alarm(
                            node,
                            &role_name(r, *role),
                            format!("cannot monitor ({code})"),
                        );
                    }
                }
            }
            Err(e) => return format!("cannot create the monitored items ({e})"),
        }
    }
    *failures = 0;
    send(
        tx,
        InputMsg::ClearAlarm {
            key: CONN_KEY.into(),
        },
    );

    // A CNC restarted while the service ran holds 0 (or whatever it kept): write the
    // current offset at once, not at the next change. The value is absolute, so writing it
    // again where it is already in place changes nothing.
    if let Some(o) = output.as_mut() {
        o.rewrite = true;
        o.failures = 0;
        o.next_try = Instant::now();
        write_offset(&session, o, offsets, tx).await;
    }
    // A new session: the stop flag is written at once (the server may have restarted).
    flags.stop_written = None;
    write_flags(&session, flags, offsets, tx).await;

    let timed = r.trigger.is_none() && (!r.channels.is_empty() || !r.positions.is_empty());
    let mut tick = tokio::time::interval(Duration::from_secs_f64(cfg.scan_period_s));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut offsets_open = true;
    loop {
        let retry_at = output.as_ref().map_or_else(
            || Instant::now() + Duration::from_secs(3600),
            |o| o.next_try,
        );
        tokio::select! {
            ch = state_rx.changed() => {
                let why = match (ch, state_rx.borrow().clone()) {
                    (Ok(()), Some(Err(why))) => why,
                    (Ok(()), _) => continue,
                    (Err(_), _) => "session ended".to_string(),
                };
                return why;
            }
            Some((h, dv)) = dv_rx.recv() => {
                if let Some((_, role)) = (h as usize).checked_sub(1).and_then(|i| roles.get(i)) {
                    live.on_value(*role, &dv);
                }
            }
            _ = tick.tick(), if timed => live.scan(),
            ch = offsets.changed(), if offsets_open => {
                if ch.is_err() {
                    offsets_open = false;
                }
            }
            _ = tokio::time::sleep_until(retry_at), if output.is_some() => {}
            _ = tokio::time::sleep_until(flags.next_beat), if flags.beat.is_some() => {}
        }
        if let Some(o) = output.as_mut() {
            write_offset(&session, o, offsets, tx).await;
        }
        write_flags(&session, flags, offsets, tx).await;
    }
}

/// Writes the newest offset if its sequence number has not been written (or a rewrite is
/// due) and no back-off is running.
async fn write_offset(
    session: &Arc<Session>,
    o: &mut Output,
    offsets: &watch::Receiver<OffsetOut>,
    tx: &SyncSender<InputMsg>,
) {
    let snap = *offsets.borrow();
    // Nothing before the axis has a valid offset: a session opened before the first
    // scan must not write the 0 that only means "no value yet".
    if (snap.seq == o.written_seq && !o.rewrite)
        || o.axis >= snap.n_axes as usize
        || !snap.valid[o.axis]
        || Instant::now() < o.next_try
    {
        return;
    }
    let value = match encode_offset(snap.offsets_um[o.axis], o.scale) {
        Ok(v) => v,
        Err(msg) => {
            o.written_seq = snap.seq;
            o.written_value = None;
            o.rewrite = false;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: OUT_KEY.into(),
                    message: format!("OPC UA offset node {}: {msg}", o.node),
                },
            );
            return;
        }
    };
    if !o.rewrite && o.written_value == Some(value) {
        o.written_seq = snap.seq;
        return;
    }
    // Value only, no timestamps: many CNC servers refuse writes carrying them.
    let wv = WriteValue {
        node_id: o.node.clone(),
        attribute_id: AttributeId::Value as u32,
        index_range: NumericRange::None,
        value: DataValue {
            value: Some(Variant::Double(value)),
            ..Default::default()
        },
    };
    let res = tokio::time::timeout(Duration::from_secs(5), session.write(&[wv])).await;
    let failure = match res {
        Ok(Ok(codes)) => match codes.first() {
            Some(c) if c.is_good() => None,
            Some(c) => Some(format!("{c}")),
            None => Some("no result".into()),
        },
        Ok(Err(e)) => Some(format!("{e}")),
        Err(_) => Some("no answer within 5 s".into()),
    };
    match failure {
        None => {
            // Confirmed: this sequence number is not written again in this session.
            o.written_seq = snap.seq;
            o.written_value = Some(value);
            o.rewrite = false;
            o.failures = 0;
            send(
                tx,
                InputMsg::ClearAlarm {
                    key: OUT_KEY.into(),
                },
            );
        }
        Some(why) => {
            // An unanswered write may still have landed: the node's value is unknown now.
            o.written_value = None;
            o.failures = o.failures.saturating_add(1);
            let wait_s = (0.2 * 2f64.powi(o.failures.min(6) as i32 - 1)).min(5.0);
            o.next_try = Instant::now() + Duration::from_secs_f64(wait_s);
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: OUT_KEY.into(),
                    message: format!(
                        "OPC UA offset write of {value} (= {} µm × {}) to node {}: {why}; retrying with back-off",
                        snap.offsets_um[o.axis], o.scale, o.node
                    ),
                },
            );
        }
    }
}

fn monitored_roles(r: &Resolved) -> Vec<(NodeId, Role)> {
    let mut v: Vec<(NodeId, Role)> = r
        .channels
        .iter()
        .enumerate()
        .map(|(i, c)| (c.node.clone(), Role::Channel(i)))
        .collect();
    v.extend(
        r.positions
            .iter()
            .enumerate()
            .map(|(i, p)| (p.node.clone(), Role::Position(i))),
    );
    if let Some(t) = &r.trigger {
        v.push((t.clone(), Role::Trigger));
    }
    if let Some((n, _)) = &r.program_state {
        v.push((n.clone(), Role::ProgramState));
    }
    v
}

fn role_name(r: &Resolved, role: Role) -> String {
    match role {
        Role::Channel(i) => r
            .channels
            .get(i)
            .map_or_else(|| "channel".into(), |c| format!("channel {}", c.name)),
        Role::Position(i) => r.positions.get(i).map_or_else(
            || "position".into(),
            |p| format!("position of axis {}", p.name),
        ),
        Role::Trigger => "trigger".into(),
        Role::ProgramState => "program state".into(),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use opcua::types::{StatusCode, UAString};
    use proptest::prelude::*;

    fn dv(v: Variant) -> DataValue {
        DataValue {
            value: Some(v),
            ..Default::default()
        }
    }

    #[test]
    fn numeric_types_widen_and_scale() {
        assert_eq!(
            channel_value(&dv(Variant::Double(21.5)), 1.0, 0.0),
            Ok(21.5)
        );
        assert_eq!(channel_value(&dv(Variant::Int16(215)), 0.1, 0.0), Ok(21.5));
        // 0.25 is exact in f32: the widening adds nothing.
        assert_eq!(
            channel_value(&dv(Variant::Float(0.25)), 4.0, 20.0),
            Ok(21.0)
        );
    }

    #[test]
    fn wrong_type_names_found_and_expected() {
        let e = channel_value(&dv(Variant::String(UAString::from("21.5"))), 1.0, 0.0).unwrap_err();
        assert!(e.contains("String") && e.contains("expected Double"), "{e}");
        let e = channel_value(&dv(Variant::Boolean(true)), 1.0, 0.0).unwrap_err();
        assert!(e.contains("Boolean"), "{e}");
        let e = channel_value(&DataValue::default(), 1.0, 0.0).unwrap_err();
        assert!(e.contains("Empty"), "{e}");
        let bad = DataValue {
            value: Some(Variant::Double(1.0)),
            status: Some(StatusCode::BadSensorFailure),
            ..Default::default()
        };
        assert!(channel_value(&bad, 1.0, 0.0)
            .unwrap_err()
            .contains("BadSensorFailure"));
        let e =
            integer_value(&dv(Variant::Double(3.0)), "Boolean or an integer counter").unwrap_err();
        assert!(e.contains("Double") && e.contains("integer counter"), "{e}");
    }

    #[test]
    fn trigger_edges_and_counters() {
        // Boolean: rising edge only.
        assert!(!trigger_fires(None, 1, true));
        assert!(trigger_fires(Some(0), 1, true));
        assert!(!trigger_fires(Some(1), 1, true));
        assert!(!trigger_fires(Some(1), 0, true));
        // Counter: any change, the first value being the baseline.
        assert!(!trigger_fires(None, 41, false));
        assert!(trigger_fires(Some(41), 42, false));
        assert!(!trigger_fires(Some(42), 42, false));
        assert!(trigger_fires(Some(65535), 0, false));
    }

    #[test]
    fn offset_scaling() {
        assert_eq!(encode_offset(-15.0, 1.0), Ok(-15.0));
        assert_eq!(encode_offset(-15.0, 0.001), Ok(-15.0 * 0.001));
        assert_eq!(encode_offset(2.5, -1.0), Ok(-2.5));
        assert!(encode_offset(f64::NAN, 1.0).is_err());
    }

    #[test]
    fn node_ids_parse_or_name_the_key() {
        assert_eq!(
            parse_node("k", "ns=2;s=Temp.A").unwrap(),
            NodeId::new(2, "Temp.A")
        );
        assert_eq!(
            parse_node("k", "ns=3;i=1021").unwrap(),
            NodeId::new(3, 1021u32)
        );
        let e = parse_node("input.channels[0].node", "Temp.A")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("input.channels[0].node") && e.contains("ns=2;s="),
            "{e}"
        );
    }

    #[test]
    fn position_axes_resolve_or_name_the_key() {
        let mut cfg: OpcUaInput = toml::from_str(
            "endpoint = \"opc.tcp://cnc:4840/\"\n\
             positions = [{ axis = \"X\", node = \"ns=2;s=Pos.X\" }]\n",
        )
        .unwrap();
        let axes = ["Z".to_string(), "X".to_string()];
        let r = resolve(&cfg, &[], &axes).unwrap();
        assert_eq!(r.positions[0].axis, 1);
        assert_eq!(r.positions[0].node, NodeId::new(2, "Pos.X"));
        cfg.positions[0].axis = "Y".into();
        let e = resolve(&cfg, &[], &axes).unwrap_err().to_string();
        assert!(
            e.contains("input.positions[0].axis") && e.contains("Y") && e.contains("Z, X"),
            "{e}"
        );
    }

    proptest! {
        #[test]
        fn never_panics_on_any_node_text(s in "\\PC{0,40}") {
            let _ = parse_node("k", &s);
        }

        #[test]
        fn doubles_round_trip(x in -1e6f64..1e6) {
            prop_assert_eq!(channel_value(&dv(Variant::Double(x)), 1.0, 0.0).unwrap(), x);
        }
    }
}
