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
//! * **Outputs.** One offset output per axis: the applied offset is written absolute,
//!   `node = offset_um·scale`, in the node's data type (Double, Float, Int16 or Int32
//!   counts, rounded, never wrapped: a value outside the type raises
//!   `opcua.offset_output.<axis>` and the node keeps its last value), once per offset
//!   sequence number, and once more at the start of every session (a CNC restarted while
//!   the service runs gets the current value at once); a failed write raises the same key
//!   and is retried with back-off with the newest value. At every connect each output
//!   node (offsets, stop, heartbeat, pulses) is checked: it exists, declares the data type
//!   written and may be written; a node failing the check is alarmed and not written.
//! * **Infeed pulses** (EP0138375). One `pulse_outputs` node per axis applied as pulses
//!   receives the cumulative pulse total (Int32, or a whole Double); the PLC applies the
//!   difference to the total it last applied, so a total written twice moves nothing. A
//!   total counts as acknowledged (kept in the resume state) only on a Good write status;
//!   at every new session the node is read back and, when it does not hold the
//!   acknowledged total (server restarted), `opcua.pulse_output.<axis>.held` is raised
//!   and the issued total written again.
//! * **Security.** The server's endpoints are read first: a policy/mode it does not offer
//!   raises `opcua.security_policy` naming what it offers; its certificate must be in
//!   `pki_dir/trusted` under any file name (matched by thumbprint), else
//!   `opcua.certificate`; a refused login raises `opcua.login`.
//! * **Reconnect.** A failed connect or a lost session raises `opcua.connection` and is
//!   retried with the same capped exponential back-off as Modbus and MQTT.

use super::InputTx;
use std::str::FromStr;
use std::sync::Arc;
use std::time::Duration;

use futures::StreamExt;
use opcua::client::{
    Client, ClientBuilder, DataChangeCallback, IdentityToken, MonitoredItem, Session,
    SessionPollResult,
};
use opcua::crypto::{CertificateStore, SecurityPolicy, X509};
use opcua::types::{
    AttributeId, DataValue, EndpointDescription, MessageSecurityMode, MonitoredItemCreateRequest,
    MonitoringMode, MonitoringParameters, NodeId, NumericRange, ReadValueId, StatusCode,
    TimestampsToReturn, UserTokenType, Variant, WriteValue,
};
use tokio::sync::watch;
use tokio::time::Instant;

use crate::config::{OpcUaInput, OpcUaNumericType};
use crate::cycle::{Clock, InputMsg, OffsetOut};
use crate::error::{invalid, Result};

pub use super::opcua_config::parse_node;

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

/// The value written to the offset node, in the node's data type.
///
/// # Formula
/// node = offset_um · scale (Double; Float rounded to the nearest f32; Int16 and Int32
/// `round(offset_um · scale)` counts, half away from zero), scale = 1 for µm, 0.001 for
/// mm, 10 for counts of 0.1 µm. A value outside the type's range is an error (the caller
/// holds the node's last value), never a wrapped or saturated one.
/// # Source
/// absolute compensation value as SINUMERIK's temperature-compensation setting data or a
/// TwinCAT external-compensation variable take it; OPC UA Part 6 §5.1.2 built-in types
/// (Int16 −32768…32767, Int32 −2³¹…2³¹−1, Float IEEE 754 binary32) [STANDARD]
pub fn encode_offset(
    offset_um: f64,
    scale: f64,
    ty: OpcUaNumericType,
) -> std::result::Result<Variant, String> {
    let v = offset_um * scale;
    if !v.is_finite() {
        return Err(format!(
            "offset {offset_um} µm × scale {scale} = {v}: not a finite value"
        ));
    }
    let out_of_range = |lo: f64, hi: f64, what: &str| {
        format!(
            "offset {offset_um} µm × scale {scale} = {v} does not fit {} ({what}, {lo}…{hi}); \
             the node keeps its last value",
            ty.name()
        )
    };
    Ok(match ty {
        OpcUaNumericType::Double => Variant::Double(v),
        OpcUaNumericType::Float => {
            let f = v as f32;
            if !f.is_finite() {
                return Err(out_of_range(
                    -f64::from(f32::MAX),
                    f64::from(f32::MAX),
                    "node units",
                ));
            }
            Variant::Float(f)
        }
        OpcUaNumericType::Int16 => {
            let r = v.round();
            if !(f64::from(i16::MIN)..=f64::from(i16::MAX)).contains(&r) {
                return Err(out_of_range(
                    f64::from(i16::MIN),
                    f64::from(i16::MAX),
                    "counts",
                ));
            }
            Variant::Int16(r as i16)
        }
        OpcUaNumericType::Int32 => {
            let r = v.round();
            if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&r) {
                return Err(out_of_range(
                    f64::from(i32::MIN),
                    f64::from(i32::MAX),
                    "counts",
                ));
            }
            Variant::Int32(r as i32)
        }
    })
}

/// The OPC UA data type id (namespace 0) of a numeric output type.
fn type_id(ty: OpcUaNumericType) -> u32 {
    match ty {
        OpcUaNumericType::Double => 11,
        OpcUaNumericType::Float => 10,
        OpcUaNumericType::Int16 => 4,
        OpcUaNumericType::Int32 => 6,
    }
}

/// The name of a namespace-0 data type id, for messages.
fn data_type_name(id: &NodeId) -> String {
    let name = match (id.namespace, &id.identifier) {
        (0, opcua::types::Identifier::Numeric(n)) => match n {
            1 => "Boolean",
            2 => "SByte",
            3 => "Byte",
            4 => "Int16",
            5 => "UInt16",
            6 => "Int32",
            7 => "UInt32",
            8 => "Int64",
            9 => "UInt64",
            10 => "Float",
            11 => "Double",
            12 => "String",
            13 => "DateTime",
            24 => "BaseDataType",
            26 => "Number",
            27 => "Integer",
            28 => "UInteger",
            _ => "",
        },
        _ => "",
    };
    if name.is_empty() {
        format!("{id}")
    } else {
        format!("{name} ({id})")
    }
}

/// Whether a node declaring data type `declared` takes a value of type `want` (a type id
/// of namespace 0): the same type, or an abstract type above it (BaseDataType, Number, and
/// Integer for the integer types).
pub fn type_accepts(declared: &NodeId, want: u32) -> bool {
    let opcua::types::Identifier::Numeric(d) = declared.identifier else {
        return false;
    };
    declared.namespace == 0
        && (d == want || d == 24 || d == 26 && want != 1 || d == 27 && matches!(want, 4 | 6))
}

/// AccessLevel bit CurrentWrite (OPC UA Part 3 §5.6.2, Table 8).
const CURRENT_WRITE: u8 = 0x02;

/// Checks at connect that an output node exists, declares the data type written to it and
/// may be written (AccessLevel and this user's UserAccessLevel); Err says which and how.
async fn check_output_node(
    session: &Arc<Session>,
    node: &NodeId,
    want: u32,
    want_name: &str,
) -> std::result::Result<(), String> {
    let ids = [
        AttributeId::DataType,
        AttributeId::AccessLevel,
        AttributeId::UserAccessLevel,
    ]
    .map(|a| ReadValueId {
        node_id: node.clone(),
        attribute_id: a as u32,
        ..Default::default()
    });
    let values = match read_attributes(session, &ids).await {
        Ok(v) => v,
        Err(ReadFail::Incomplete) => {
            return Err("the server answered the attribute read incompletely".into())
        }
        Err(ReadFail::Service(e)) => return Err(format!("cannot read its attributes ({e})")),
        Err(ReadFail::Timeout) => return Err("no answer to the attribute read within 5 s".into()),
    };
    let status = |dv: &DataValue| dv.status.unwrap_or(StatusCode::Good);
    let dt_status = status(&values[0]);
    if dt_status == StatusCode::BadNodeIdUnknown {
        return Err("does not exist on the server (BadNodeIdUnknown)".into());
    }
    match &values[0].value {
        Some(Variant::NodeId(dt)) if dt_status.is_good() => {
            if !type_accepts(dt, want) {
                return Err(format!(
                    "has data type {}, the configuration writes {want_name}",
                    data_type_name(dt)
                ));
            }
        }
        _ => {
            return Err(format!(
                "its DataType attribute cannot be read ({dt_status}); a variable node is needed"
            ))
        }
    }
    for (dv, attr) in values[1..].iter().zip(["AccessLevel", "UserAccessLevel"]) {
        if let (Some(Variant::Byte(b)), true) = (&dv.value, status(dv).is_good()) {
            if b & CURRENT_WRITE == 0 {
                return Err(format!(
                    "is not writable: {attr} = {b:#04x} lacks CurrentWrite (0x02){}",
                    if attr == "UserAccessLevel" {
                        " for this login"
                    } else {
                        ""
                    }
                ));
            }
        }
    }
    Ok(())
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

/// An offset output node with its engine axis.
#[derive(Debug, Clone)]
struct OutSpec {
    node: NodeId,
    axis: usize,
    axis_name: String,
    /// The configuration key, e.g. `input.offset_outputs[1]`.
    field: String,
    scale: f64,
    ty: OpcUaNumericType,
}

/// An infeed-pulse output node with its engine axis.
#[derive(Debug, Clone)]
struct PulseSpec {
    node: NodeId,
    axis: usize,
    axis_name: String,
    /// The configuration key, e.g. `input.pulse_outputs[0]`.
    field: String,
    ty: OpcUaNumericType,
}

/// The configuration with node ids parsed and names resolved against the engine.
#[derive(Debug, Clone)]
pub struct Resolved {
    channels: Vec<ChannelNode>,
    positions: Vec<PositionNode>,
    trigger: Option<NodeId>,
    program_state: Option<(NodeId, Vec<i64>)>,
    outputs: Vec<OutSpec>,
    stop: Option<NodeId>,
    beat: Option<(NodeId, Duration, OpcUaNumericType)>,
    pulses: Vec<PulseSpec>,
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
        let axis = crate::error::engine_axis(format!("input.positions[{i}].axis"), &p.axis, axes)?;
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
    let mut outputs = Vec::new();
    for (field, o) in cfg.outputs() {
        let axis = crate::error::engine_axis(format!("{field}.axis"), &o.axis, axes)?;
        outputs.push(OutSpec {
            node: parse_node(&format!("{field}.node"), &o.node)?,
            axis,
            axis_name: o.axis.clone(),
            field,
            scale: o.scale,
            ty: o.data_type,
        });
    }
    let stop = match &cfg.stop_output {
        Some(s) => Some(parse_node("input.stop_output.node", &s.node)?),
        None => None,
    };
    let beat = match &cfg.heartbeat {
        Some(h) => Some((
            parse_node("input.heartbeat.node", &h.node)?,
            Duration::from_secs_f64(h.period_s),
            h.data_type,
        )),
        None => None,
    };
    let mut pulses = Vec::new();
    for (i, o) in cfg.pulse_outputs.iter().enumerate() {
        let field = format!("input.pulse_outputs[{i}]");
        let axis = crate::error::engine_axis(format!("{field}.axis"), &o.axis, axes)?;
        pulses.push(PulseSpec {
            node: parse_node(&format!("{field}.node"), &o.node)?,
            axis,
            axis_name: o.axis.clone(),
            field,
            ty: o.data_type,
        });
    }
    Ok(Resolved {
        channels: out,
        positions,
        trigger,
        program_state,
        outputs,
        stop,
        beat,
        pulses,
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
    pub tx: InputTx,
    /// From the cycle.
    pub offsets: watch::Receiver<OffsetOut>,
    /// The cycle's step count (`Cycle::alive`), for the heartbeat output.
    pub alive: Arc<std::sync::atomic::AtomicU64>,
}

/// The stop / feed-hold and heartbeat outputs and what was last written to them.
struct Flags {
    stop: Option<NodeId>,
    stop_written: Option<bool>,
    /// The stop node passed the connect check in this session.
    stop_ok: bool,
    beat: Option<(NodeId, Duration, OpcUaNumericType)>,
    /// The heartbeat node passed the connect check in this session.
    beat_ok: bool,
    counter: i32,
    last_alive: u64,
    next_beat: Instant,
    alive: Arc<std::sync::atomic::AtomicU64>,
    /// The infeed-pulse outputs, one per pulse axis.
    pulses: Vec<PulseOut>,
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
    tx: &InputTx,
) {
    if let (Some(node), true) = (&f.stop, f.stop_ok) {
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
    if let (Some((node, period, ty)), true) = (&f.beat, f.beat_ok) {
        let now = Instant::now();
        if now >= f.next_beat {
            f.next_beat = now + *period;
            let a = f.alive.load(std::sync::atomic::Ordering::Acquire);
            if a != f.last_alive {
                f.last_alive = a;
                // The counter wraps within the node's type (Int16: 32767 → −32768).
                let (c, v) = match ty {
                    OpcUaNumericType::Int16 => {
                        let c = (f.counter as i16).wrapping_add(1);
                        (i32::from(c), Variant::Int16(c))
                    }
                    _ => {
                        let c = f.counter.wrapping_add(1);
                        (c, Variant::Int32(c))
                    }
                };
                match write_value(session, node, v).await {
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

fn send(tx: &InputTx, m: InputMsg) {
    // try_send: an async task must not block the runtime (as MQTT and Modbus).
    let _ = tx.try_send(m);
}

const CONN_KEY: &str = "opcua.connection";
/// Prefix of the offset outputs' alarm keys: `opcua.offset_output.<axis>`.
const OUT_KEY: &str = "opcua.offset_output";
/// The server refused the login (user name / password or user certificate).
const LOGIN_KEY: &str = "opcua.login";
/// A certificate was refused: the server's here, or ours on the server.
const CERT_KEY: &str = "opcua.certificate";
/// The server offers no endpoint with the configured security policy and mode.
const POLICY_KEY: &str = "opcua.security_policy";

fn node_key(n: &NodeId) -> String {
    format!("opcua.node.{n}")
}

/// The offset output's state, kept across reconnects so a sequence number confirmed once
/// is not written again without need.
struct Output {
    spec: OutSpec,
    /// `opcua.offset_output.<axis>`.
    key: String,
    /// The node passed the connect check (exists, data type, writable) in this session.
    usable: bool,
    written_seq: u64,
    /// The node value last confirmed: a new sequence number that only changed another
    /// axis leaves it as it is.
    written_value: Option<Variant>,
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
    tx: &'a InputTx,
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
    if let (Some(c), Some(k)) = (&cfg.user_certificate, &cfg.user_private_key) {
        let cert = CertificateStore::read_cert(c).map_err(|e| {
            invalid(
                "input.user_certificate",
                c.display(),
                format!("a readable X.509 certificate, .der or .pem ({e})"),
            )
        })?;
        let key = CertificateStore::read_pkey(k).map_err(|e| {
            invalid(
                "input.user_private_key",
                k.display(),
                format!("a readable PEM private key ({e})"),
            )
        })?;
        return Ok(IdentityToken::new_x509(cert, key));
    }
    Ok(match (&cfg.user, cfg.password()?) {
        (Some(u), Some(p)) => IdentityToken::new_user_name(u.clone(), p),
        _ => IdentityToken::new_anonymous(),
    })
}

/// Makes every certificate in `pki_dir/trusted` trusted whatever its file name: the
/// stack looks a server certificate up by the name `CN [thumbprint].der` only, so a
/// certificate copied in under another name (`cnc.der`, `cnc.pem`) is written once more
/// under that name, and a copy of it in `rejected/` (where a first refused connect put it)
/// is removed. Returns the thumbprints (hex) of the trusted certificates.
pub fn normalise_trusted(pki_dir: &std::path::Path) -> Vec<String> {
    let trusted = pki_dir.join("trusted");
    let rejected = pki_dir.join("rejected");
    let mut thumbprints = Vec::new();
    let Ok(entries) = std::fs::read_dir(&trusted) else {
        return thumbprints;
    };
    for e in entries.flatten() {
        let path = e.path();
        let Ok(bytes) = std::fs::read(&path) else {
            continue;
        };
        let cert = match X509::from_der(&bytes) {
            Ok(c) => c,
            Err(_) => match X509::from_pem(&bytes) {
                Ok(c) => c,
                Err(_) => continue,
            },
        };
        thumbprints.push(cert.thumbprint().as_hex_string());
        let name = CertificateStore::cert_file_name(&cert);
        let canonical = trusted.join(&name);
        if !canonical.exists() {
            if let Ok(der) = cert.to_der() {
                let _ = std::fs::write(&canonical, der);
            }
        }
        let _ = std::fs::remove_file(rejected.join(&name));
    }
    thumbprints
}

/// The named alarm key of a connect failure's status code, if it has one.
fn failure_key(code: StatusCode) -> Option<&'static str> {
    use StatusCode as S;
    match code {
        S::BadUserAccessDenied | S::BadIdentityTokenInvalid | S::BadIdentityTokenRejected => {
            Some(LOGIN_KEY)
        }
        S::BadCertificateUntrusted
        | S::BadSecurityChecksFailed
        | S::BadCertificateInvalid
        | S::BadCertificateTimeInvalid
        | S::BadCertificateHostNameInvalid
        | S::BadCertificateUriInvalid
        | S::BadCertificateUseNotAllowed
        | S::BadCertificateRevoked => Some(CERT_KEY),
        _ => None,
    }
}

/// Why a session did not come up or ended: a message, and the named alarm key of the
/// cause when it is a login, certificate or security-policy problem.
struct Ended {
    key: Option<&'static str>,
    why: String,
}

impl From<String> for Ended {
    fn from(why: String) -> Self {
        Ended { key: None, why }
    }
}

impl From<&str> for Ended {
    fn from(why: &str) -> Self {
        Ended {
            key: None,
            why: why.into(),
        }
    }
}

/// The message of a connect failure with status `code`, with what to do for the named
/// causes. Never contains the password.
fn explain(cfg: &OpcUaInput, code: StatusCode, what: &str) -> Ended {
    let key = failure_key(code);
    let pki = cfg.pki_dir.display();
    let why = match key {
        Some(LOGIN_KEY) => match (&cfg.user, &cfg.user_certificate) {
            (Some(u), _) => format!(
                "the server refused the login of user {u:?} ({code}): check the password \
                 (input.password_env / password_file / password) and the user's rights"
            ),
            (None, Some(c)) => format!(
                "the server refused the login with user certificate {} ({code}): the server \
                 must know and trust it",
                c.display()
            ),
            _ => format!("the server refused the anonymous login ({code}): set input.user"),
        },
        Some(_) => format!(
            "certificate refused ({code}): the server does not trust this client's \
             certificate {pki}/own/cert.der (trust it on the server), or the server's \
             certificate is not valid for {} (time, host name or application URI)",
            cfg.endpoint
        ),
        None => format!("{what} ({code})"),
    };
    Ended { key, why }
}

/// `Policy/Mode` of an endpoint, for messages.
fn endpoint_name(e: &EndpointDescription) -> String {
    format!(
        "{}/{}",
        SecurityPolicy::from_uri(e.security_policy_uri.as_ref()),
        e.security_mode
    )
}

/// Picks the server's endpoint matching the configured policy and mode, and checks that
/// the server's certificate is trusted and that the endpoint takes the configured login;
/// Err names the mismatch and what the server offers.
fn pick_endpoint(
    cfg: &OpcUaInput,
    endpoints: &[EndpointDescription],
    policy: SecurityPolicy,
    mode: MessageSecurityMode,
    token: &IdentityToken,
) -> std::result::Result<EndpointDescription, Ended> {
    let offered: Vec<String> = endpoints.iter().map(endpoint_name).collect();
    let Some(ep) = Client::find_matching_endpoint(endpoints, &cfg.endpoint, policy, mode) else {
        let all_secure = !endpoints.is_empty()
            && endpoints
                .iter()
                .all(|e| e.security_mode != MessageSecurityMode::None);
        let why = if policy == SecurityPolicy::None && all_secure {
            format!(
                "the server requires a secure policy: it offers {} and no None endpoint; \
                 set input.security_policy and input.security_mode to one of them \
                 (e.g. security_policy = \"Basic256Sha256\", security_mode = \"SignAndEncrypt\")",
                offered.join(", ")
            )
        } else {
            format!(
                "the server offers no endpoint with input.security_policy = {:?} and \
                 input.security_mode = {:?}; it offers {}",
                cfg.security_policy,
                cfg.security_mode,
                if offered.is_empty() {
                    "none".to_string()
                } else {
                    offered.join(", ")
                }
            )
        };
        return Err(Ended {
            key: Some(POLICY_KEY),
            why,
        });
    };
    // The login must be one the endpoint takes.
    let (want, name) = match token {
        IdentityToken::UserName(..) => (UserTokenType::UserName, "user name / password"),
        IdentityToken::X509(..) => (UserTokenType::Certificate, "user certificate"),
        _ => (UserTokenType::Anonymous, "anonymous"),
    };
    let tokens = ep.user_identity_tokens.as_deref().unwrap_or(&[]);
    if !tokens.iter().any(|t| t.token_type == want) {
        let kinds: Vec<String> = tokens
            .iter()
            .map(|t| format!("{:?}", t.token_type))
            .collect();
        return Err(Ended {
            key: Some(LOGIN_KEY),
            why: format!(
                "the server's {} endpoint takes no {name} login (it takes {})",
                endpoint_name(&ep),
                kinds.join(", ")
            ),
        });
    }
    // The server's certificate must be trusted (by thumbprint, whatever the file name).
    if policy != SecurityPolicy::None && !cfg.trust_server_cert {
        let trusted = normalise_trusted(&cfg.pki_dir);
        if let Ok(cert) = X509::from_byte_string(&ep.server_certificate) {
            let thumb = cert.thumbprint().as_hex_string();
            if !trusted.contains(&thumb) {
                let name = CertificateStore::cert_file_name(&cert);
                let rejected = cfg.pki_dir.join("rejected");
                let _ = std::fs::create_dir_all(&rejected);
                let kept = rejected.join(&name);
                if let Ok(der) = cert.to_der() {
                    let _ = std::fs::write(&kept, der);
                }
                return Err(Ended {
                    key: Some(CERT_KEY),
                    why: format!(
                        "the server's certificate {:?} (SHA-1 thumbprint {thumb}) is not trusted: \
                         after checking the thumbprint with the CNC, copy {} into {} \
                         (any file name)",
                        cert.subject_name(),
                        kept.display(),
                        cfg.pki_dir.join("trusted").display()
                    ),
                });
            }
        }
    }
    Ok(ep)
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
    let mut outputs: Vec<Output> = r
        .outputs
        .iter()
        .map(|spec| Output {
            key: format!("{OUT_KEY}.{}", spec.axis_name),
            spec: spec.clone(),
            usable: false,
            written_seq: 0,
            written_value: None,
            rewrite: true,
            failures: 0,
            next_try: Instant::now(),
        })
        .collect();
    let mut failures = 0u32;
    let mut flags = Flags {
        stop: r.stop.clone(),
        stop_written: None,
        stop_ok: false,
        beat: r.beat.clone(),
        beat_ok: false,
        counter: 0,
        last_alive: 0,
        next_beat: Instant::now(),
        alive: p.alive.clone(),
        pulses: r
            .pulses
            .iter()
            .map(|spec| PulseOut {
                key: format!("{PULSE_KEY}.{}", spec.axis_name),
                spec: spec.clone(),
                usable: false,
                acked: None,
                pending: None,
                force: false,
                not_pulse_alarmed: false,
                failures: 0,
                next_try: Instant::now(),
            })
            .collect(),
    };
    loop {
        let ended = session(
            &mut client,
            &p.cfg,
            token.clone(),
            &r,
            p.clock,
            &p.tx,
            &mut offsets,
            &mut outputs,
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
        let message = format!(
            "OPC UA server {}: {}; retrying with back-off ({wait_s} s)",
            p.cfg.endpoint, ended.why
        );
        if let Some(key) = ended.key {
            send(
                &p.tx,
                InputMsg::RaiseAlarm {
                    key: key.into(),
                    message: message.clone(),
                },
            );
        }
        send(
            &p.tx,
            InputMsg::RaiseAlarm {
                key: CONN_KEY.into(),
                message,
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
    tx: &InputTx,
    offsets: &mut watch::Receiver<OffsetOut>,
    outputs: &mut [Output],
    flags: &mut Flags,
    failures: &mut u32,
) -> Ended {
    let policy = SecurityPolicy::from_str(&cfg.security_policy).unwrap_or(SecurityPolicy::None);
    let mode = match cfg.security_mode.as_str() {
        "Sign" => MessageSecurityMode::Sign,
        "SignAndEncrypt" => MessageSecurityMode::SignAndEncrypt,
        _ => MessageSecurityMode::None,
    };
    // The server's endpoints first (an unsecured GetEndpoints every server answers), so a
    // policy mismatch, an untrusted server certificate or a login the endpoint does not take
    // is named instead of the stack's BadTcpEndpointUrlInvalid.
    let endpoints = tokio::time::timeout(
        Duration::from_secs(10),
        client.get_server_endpoints_from_url(cfg.endpoint.as_str()),
    )
    .await;
    let endpoints = match endpoints {
        Ok(Ok(e)) => e,
        Ok(Err(e)) => return format!("cannot get the server's endpoints ({e})").into(),
        Err(_) => return "no answer within 10 s".into(),
    };
    let ep = match pick_endpoint(cfg, &endpoints, policy, mode, &token) {
        Ok(ep) => ep,
        Err(e) => return e,
    };
    let (session, event_loop) = match client.connect_to_endpoint_directly(ep, token) {
        Ok(s) => s,
        Err(e) => return explain(cfg, e.status(), "cannot open a session"),
    };
    // The event loop drives the connection; it runs in a JoinSet so that it ends with
    // this future (service stop aborts the adapter task).
    let (state_tx, mut state_rx) =
        watch::channel::<Option<std::result::Result<(), (StatusCode, String)>>>(None);
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
                    break (c, "connection lost".to_string())
                }
                Some(Ok(SessionPollResult::ReconnectFailed(c))) => {
                    break (c, "cannot connect".to_string())
                }
                Some(Ok(_)) => {}
                Some(Err(c)) => break (c, "session ended".to_string()),
                None => break (StatusCode::BadConnectionClosed, "session closed".into()),
            }
        };
        let _ = state_tx.send(Some(Err(end)));
    });
    let failed: Option<Ended> = {
        let up =
            tokio::time::timeout(Duration::from_secs(10), state_rx.wait_for(Option::is_some)).await;
        match up {
            Ok(Ok(s)) => match &*s {
                Some(Err((code, what))) => Some(explain(cfg, *code, what)),
                _ => None,
            },
            Ok(Err(_)) => Some("session ended".into()),
            Err(_) => Some("no session within 10 s".into()),
        }
    };
    if let Some(e) = failed {
        return e;
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
        Err(e) => return format!("cannot create the subscription ({e})").into(),
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
            Err(e) => return format!("cannot create the monitored items ({e})").into(),
        }
    }
    *failures = 0;
    for key in [CONN_KEY, LOGIN_KEY, CERT_KEY, POLICY_KEY] {
        send(tx, InputMsg::ClearAlarm { key: key.into() });
    }

    // Every output node is checked once per session: it exists, declares the data type
    // written to it and may be written. A node failing the check raises its output's alarm
    // and is not written in this session (instead of BadTypeMismatch at every write).
    for o in outputs.iter_mut() {
        let spec = &o.spec;
        let checked =
            check_output_node(&session, &spec.node, type_id(spec.ty), spec.ty.name()).await;
        o.usable = checked.is_ok();
        if let Err(why) = checked {
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: o.key.clone(),
                    message: format!(
                        "OPC UA offset output of axis {} ({}): node {} {why} ({}.data_type = \"{}\"; \
                         Double | Float | Int16 | Int32); nothing is written to it until it is \
                         fixed (checked at every connect)",
                        spec.axis_name,
                        spec.field,
                        spec.node,
                        spec.field,
                        spec.ty.name()
                    ),
                },
            );
        }
    }
    if let Some(node) = &flags.stop {
        let checked = check_output_node(&session, node, 1, "Boolean").await;
        flags.stop_ok = checked.is_ok();
        if let Err(why) = checked {
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: STOP_KEY.into(),
                    message: format!(
                        "OPC UA stop output (input.stop_output): node {node} {why} (a writable \
                         Boolean is needed); not written until fixed (checked at every connect)"
                    ),
                },
            );
        }
    }
    if let Some((node, _, ty)) = &flags.beat {
        let checked = check_output_node(&session, node, type_id(*ty), ty.name()).await;
        flags.beat_ok = checked.is_ok();
        if let Err(why) = checked {
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: BEAT_KEY.into(),
                    message: format!(
                        "OPC UA heartbeat (input.heartbeat): node {node} {why} \
                         (input.heartbeat.data_type = \"{}\"; Int16 | Int32); not written until \
                         fixed (checked at every connect)",
                        ty.name()
                    ),
                },
            );
        }
    }

    // Every pulse node: checked as the other outputs, then read back (a server that
    // restarted holds 0 or whatever it kept instead of the acknowledged total).
    for po in flags.pulses.iter_mut() {
        start_pulses(&session, po, offsets, tx).await;
    }

    // A CNC restarted while the service ran holds 0 (or whatever it kept): write the
    // current offset at once, not at the next change. The value is absolute, so writing it
    // again where it is already in place changes nothing.
    for o in outputs.iter_mut() {
        o.rewrite = true;
        o.failures = 0;
        o.next_try = Instant::now();
        write_offset(&session, o, offsets, tx).await;
    }
    // A new session: the stop flag is written at once (the server may have restarted).
    flags.stop_written = None;
    write_flags(&session, flags, offsets, tx).await;
    for po in flags.pulses.iter_mut() {
        write_pulses(&session, po, offsets, tx).await;
    }

    let timed = r.trigger.is_none() && (!r.channels.is_empty() || !r.positions.is_empty());
    let mut tick = tokio::time::interval(Duration::from_secs_f64(cfg.scan_period_s));
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut offsets_open = true;
    loop {
        let retry_at = outputs
            .iter()
            .filter(|o| o.usable)
            .map(|o| o.next_try)
            .min()
            .unwrap_or_else(|| Instant::now() + Duration::from_secs(3600));
        let pulse_retry = flags
            .pulses
            .iter()
            .filter(|p| p.usable && p.failures > 0)
            .map(|p| p.next_try)
            .min();
        tokio::select! {
            ch = state_rx.changed() => {
                let ended = match (ch, state_rx.borrow().clone()) {
                    (Ok(()), Some(Err((code, what)))) => explain(cfg, code, &what),
                    (Ok(()), _) => continue,
                    (Err(_), _) => "session ended".into(),
                };
                return ended;
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
            _ = tokio::time::sleep_until(retry_at), if !outputs.is_empty() => {}
            _ = tokio::time::sleep_until(flags.next_beat), if flags.beat.is_some() => {}
            _ = tokio::time::sleep_until(pulse_retry.unwrap_or_else(Instant::now)),
                if pulse_retry.is_some() => {}
        }
        for o in outputs.iter_mut() {
            write_offset(&session, o, offsets, tx).await;
        }
        write_flags(&session, flags, offsets, tx).await;
        for po in flags.pulses.iter_mut() {
            write_pulses(&session, po, offsets, tx).await;
        }
    }
}

/// Writes the newest offset if its sequence number has not been written (or a rewrite is
/// due), no back-off is running and the node passed the connect check.
async fn write_offset(
    session: &Arc<Session>,
    o: &mut Output,
    offsets: &watch::Receiver<OffsetOut>,
    tx: &InputTx,
) {
    let snap = *offsets.borrow();
    let axis = o.spec.axis;
    // Nothing before the axis has a valid offset: a session opened before the first
    // scan must not write the 0 that only means "no value yet".
    if !o.usable
        || (snap.seq == o.written_seq && !o.rewrite)
        || axis >= snap.n_axes as usize
        || !snap.valid[axis]
        || Instant::now() < o.next_try
    {
        return;
    }
    let value = match encode_offset(snap.offsets_um[axis], o.spec.scale, o.spec.ty) {
        Ok(v) => v,
        Err(msg) => {
            // Hold: the node keeps the last value written; the alarm stays until a value
            // fits again and is written.
            o.written_seq = snap.seq;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: o.key.clone(),
                    message: format!(
                        "OPC UA offset output of axis {} (node {}): {msg}",
                        o.spec.axis_name, o.spec.node
                    ),
                },
            );
            return;
        }
    };
    if !o.rewrite && o.written_value.as_ref() == Some(&value) {
        o.written_seq = snap.seq;
        return;
    }
    // Value only, no timestamps: many CNC servers refuse writes carrying them.
    match write_value(session, &o.spec.node, value.clone()).await {
        Ok(()) => {
            // Confirmed: this sequence number is not written again in this session.
            o.written_seq = snap.seq;
            o.written_value = Some(value);
            o.rewrite = false;
            o.failures = 0;
            send(tx, InputMsg::ClearAlarm { key: o.key.clone() });
        }
        Err(why) => {
            // An unanswered write may still have landed: the node's value is unknown now.
            o.written_value = None;
            o.failures = o.failures.saturating_add(1);
            let wait_s = (0.2 * 2f64.powi(o.failures.min(6) as i32 - 1)).min(5.0);
            o.next_try = Instant::now() + Duration::from_secs_f64(wait_s);
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: o.key.clone(),
                    message: format!(
                        "OPC UA offset write of {} {value} (= {} µm × {}) to node {} (axis {}): {why}; \
                         retrying with back-off",
                        o.spec.ty.name(),
                        snap.offsets_um[axis],
                        o.spec.scale,
                        o.spec.node,
                        o.spec.axis_name
                    ),
                },
            );
        }
    }
}

/// Prefix of the pulse outputs' alarm keys: `opcua.pulse_output.<axis>` (write failures)
/// and `opcua.pulse_output.<axis>.held` (the node does not hold the acknowledged total).
const PULSE_KEY: &str = "opcua.pulse_output";

/// An infeed-pulse output's state, kept across sessions: the total the PLC acknowledged
/// (a Good write status) and a total written whose status never arrived.
struct PulseOut {
    spec: PulseSpec,
    /// `opcua.pulse_output.<axis>`.
    key: String,
    /// The node passed the connect check in this session.
    usable: bool,
    /// The total acknowledged (None: the cycle's, from the resume state, at first use).
    acked: Option<i64>,
    /// A total written without a Good status seen (it may have landed).
    pending: Option<i64>,
    /// Write the issued total even when it equals `acked`: the node does not hold it.
    force: bool,
    /// The axis is not applied as pulses: alarmed once.
    not_pulse_alarmed: bool,
    failures: u32,
    next_try: Instant,
}

/// The value written to a pulse node for a cumulative total: Int32, or a whole Double.
///
/// # Formula
/// Int32: total (refused outside −2³¹…2³¹−1, never wrapped); Double: total as f64
/// (exact up to 2⁵³)
/// # Source
/// OPC UA Part 6 §5.1.2 (built-in types) [STANDARD]; the cumulative count is this
/// service's [CONVENTION, docs/service.md]
pub fn encode_pulse_total(
    total: i64,
    ty: OpcUaNumericType,
) -> std::result::Result<Variant, String> {
    match ty {
        OpcUaNumericType::Double if total.unsigned_abs() <= 1 << 53 => {
            Ok(Variant::Double(total as f64))
        }
        OpcUaNumericType::Int32 => i32::try_from(total)
            .map(Variant::Int32)
            .map_err(|_| format!("pulse total {total} outside the Int32 range of the node")),
        _ => Err(format!(
            "pulse total {total} cannot be written exactly as {}",
            ty.name()
        )),
    }
}

/// The cumulative total a pulse node holds (an integer type, or a whole Double).
pub fn decode_pulse_total(dv: &DataValue) -> std::result::Result<i64, String> {
    match good_value(dv)? {
        Variant::Double(x) if x.fract() == 0.0 && x.abs() <= 9.0e15 => Ok(*x as i64),
        Variant::Double(x) => Err(format!("{x}, not a whole pulse count")),
        _ => integer_value(dv, "Int32 or Double"),
    }
}

/// Reads a node's value once (5 s bound).
async fn read_value(
    session: &Arc<Session>,
    node: &NodeId,
) -> std::result::Result<DataValue, String> {
    let id = ReadValueId {
        node_id: node.clone(),
        attribute_id: AttributeId::Value as u32,
        ..Default::default()
    };
    match read_attributes(session, &[id]).await {
        Ok(mut v) => Ok(v.remove(0)),
        Err(ReadFail::Incomplete) => Err("the server answered the read incompletely".into()),
        Err(ReadFail::Service(e)) => Err(e),
        Err(ReadFail::Timeout) => Err("no answer within 5 s".into()),
    }
}

/// Why a read of node attributes gave no values.
enum ReadFail {
    /// Fewer or more values than attributes asked for.
    Incomplete,
    /// The service call failed; the status as text.
    Service(String),
    /// No answer within the 5 s bound.
    Timeout,
}

/// Reads the given attributes once (no timestamps, 5 s bound); exactly one value per id.
async fn read_attributes(
    session: &Arc<Session>,
    ids: &[ReadValueId],
) -> std::result::Result<Vec<DataValue>, ReadFail> {
    match tokio::time::timeout(
        Duration::from_secs(5),
        session.read(ids, TimestampsToReturn::Neither, 0.0),
    )
    .await
    {
        Ok(Ok(v)) if v.len() == ids.len() => Ok(v),
        Ok(Ok(_)) => Err(ReadFail::Incomplete),
        Ok(Err(e)) => Err(ReadFail::Service(format!("{e}"))),
        Err(_) => Err(ReadFail::Timeout),
    }
}

/// At every new session: the pulse node is checked (exists, data type, writable) and read
/// back. Holding the acknowledged total: nothing to do. Holding a total written whose
/// status was lost: that total counts as acknowledged. Anything else (the server
/// restarted, or someone wrote it): alarmed, and the issued total is written again — the
/// PLC applies the difference to the total it last applied, so nothing moves twice.
async fn start_pulses(
    session: &Arc<Session>,
    p: &mut PulseOut,
    offsets: &watch::Receiver<OffsetOut>,
    tx: &InputTx,
) {
    let spec = &p.spec;
    let held_key = format!("{}.held", p.key);
    p.failures = 0;
    p.next_try = Instant::now();
    let checked = check_output_node(session, &spec.node, type_id(spec.ty), spec.ty.name()).await;
    p.usable = checked.is_ok();
    if let Err(why) = checked {
        send(
            tx,
            InputMsg::RaiseAlarm {
                key: p.key.clone(),
                message: format!(
                    "OPC UA pulse output of axis {} ({}): node {} {why} ({}.data_type = \"{}\"; Int32 | Double); no pulses are sent until it is fixed (checked at every connect)",
                    spec.axis_name,
                    spec.field,
                    spec.node,
                    spec.field,
                    spec.ty.name()
                ),
            },
        );
        return;
    }
    // The node passed: an earlier session's check alarm is over (a node that is not of a
    // pulse axis is alarmed again by the first write attempt).
    send(tx, InputMsg::ClearAlarm { key: p.key.clone() });
    p.not_pulse_alarmed = false;
    let snap = *offsets.borrow();
    let axis = spec.axis;
    if axis >= snap.n_axes as usize || snap.pulse_um[axis] <= 0.0 {
        return;
    }
    let acked = *p.acked.get_or_insert(snap.pulses_acked[axis]);
    match read_value(session, &spec.node)
        .await
        .and_then(|dv| decode_pulse_total(&dv))
    {
        Ok(held) if held == acked => {
            p.force = false;
            send(tx, InputMsg::ClearAlarm { key: held_key });
        }
        Ok(held) if Some(held) == p.pending => {
            // Written before the session was lost, status never seen: it landed.
            p.acked = Some(held);
            p.force = false;
            send(
                tx,
                InputMsg::PulsesAcked {
                    axis: axis as u8,
                    total: held,
                },
            );
            send(tx, InputMsg::ClearAlarm { key: held_key });
        }
        Ok(held) => {
            p.force = true;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: held_key,
                    message: format!(
                        "OPC UA pulse node {} of axis {} holds {held}, the PLC had acknowledged {acked}: server restarted or node overwritten; the total is written again (the PLC applies the difference to the total it last applied)",
                        spec.node, spec.axis_name
                    ),
                },
            );
        }
        Err(why) => {
            p.force = true;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: held_key,
                    message: format!(
                        "OPC UA pulse node {} of axis {}: cannot read it back ({why}); the total is written again",
                        spec.node, spec.axis_name
                    ),
                },
            );
        }
    }
    p.pending = None;
}

/// Writes the cumulative pulse total of the axis when it differs from the acknowledged
/// one (or the node lost it); it counts as acknowledged only on a Good status, then the
/// cycle keeps it in the resume state. A failed write is retried with back-off.
async fn write_pulses(
    session: &Arc<Session>,
    p: &mut PulseOut,
    offsets: &watch::Receiver<OffsetOut>,
    tx: &InputTx,
) {
    let snap = *offsets.borrow();
    let axis = p.spec.axis;
    if !p.usable || axis >= snap.n_axes as usize || Instant::now() < p.next_try {
        return;
    }
    if snap.pulse_um[axis] <= 0.0 {
        if !p.not_pulse_alarmed {
            p.not_pulse_alarmed = true;
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: p.key.clone(),
                    message: format!(
                        "OPC UA pulse output of axis {} ({}): the axis is not applied as pulses (engine apply.kind); nothing is sent to node {}",
                        p.spec.axis_name, p.spec.field, p.spec.node
                    ),
                },
            );
        }
        return;
    }
    let acked = *p.acked.get_or_insert(snap.pulses_acked[axis]);
    let total = snap.pulse_total[axis];
    if total == acked && !p.force {
        return;
    }
    let value = match encode_pulse_total(total, p.spec.ty) {
        Ok(v) => v,
        Err(msg) => {
            p.failures = p.failures.saturating_add(1);
            p.next_try = Instant::now() + Duration::from_secs(5);
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: p.key.clone(),
                    message: format!("OPC UA pulse node {}: {msg}", p.spec.node),
                },
            );
            return;
        }
    };
    p.pending = Some(total);
    match write_value(session, &p.spec.node, value).await {
        Ok(()) => {
            p.pending = None;
            p.acked = Some(total);
            p.force = false;
            p.failures = 0;
            send(
                tx,
                InputMsg::PulsesAcked {
                    axis: axis as u8,
                    total,
                },
            );
            send(tx, InputMsg::ClearAlarm { key: p.key.clone() });
        }
        Err(why) => {
            // Unanswered, it may have landed (`pending`, settled by the read-back at the
            // next session); the same total written again moves nothing on the PLC.
            p.failures = p.failures.saturating_add(1);
            let wait_s = (0.2 * 2f64.powi(p.failures.min(6) as i32 - 1)).min(5.0);
            p.next_try = Instant::now() + Duration::from_secs_f64(wait_s);
            send(
                tx,
                InputMsg::RaiseAlarm {
                    key: p.key.clone(),
                    message: format!(
                        "OPC UA pulse total {total} (acknowledged {acked}) to node {} (axis {}):                          {why}; retrying with back-off",
                        p.spec.node, p.spec.axis_name
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

    use OpcUaNumericType as T;

    #[test]
    fn offset_scaling() {
        assert_eq!(
            encode_offset(-15.0, 1.0, T::Double),
            Ok(Variant::Double(-15.0))
        );
        assert_eq!(
            encode_offset(-15.0, 0.001, T::Double),
            Ok(Variant::Double(-0.015))
        );
        assert_eq!(
            encode_offset(2.5, -1.0, T::Double),
            Ok(Variant::Double(-2.5))
        );
        assert!(encode_offset(f64::NAN, 1.0, T::Double).is_err());
    }

    #[test]
    fn pulse_totals_written_and_read_back() {
        // Int32: the total itself; refused (never wrapped) outside ±2³¹.
        assert_eq!(
            encode_pulse_total(-21, T::Int32).unwrap(),
            Variant::Int32(-21)
        );
        assert_eq!(
            encode_pulse_total(2_147_483_647, T::Int32).unwrap(),
            Variant::Int32(i32::MAX)
        );
        let e = encode_pulse_total(2_147_483_648, T::Int32).unwrap_err();
        assert!(e.contains("2147483648") && e.contains("Int32"), "{e}");
        assert_eq!(
            encode_pulse_total(-3_000_000_000, T::Double).unwrap(),
            Variant::Double(-3.0e9)
        );
        assert!(encode_pulse_total(1, T::Float).is_err());
        assert!(encode_pulse_total(1, T::Int16).is_err());
        // Read back: integers, whole Doubles; a fraction, a bad status or no value is not
        // a total.
        assert_eq!(decode_pulse_total(&dv(Variant::Int32(-4))).unwrap(), -4);
        assert_eq!(decode_pulse_total(&dv(Variant::Double(-4.0))).unwrap(), -4);
        assert_eq!(decode_pulse_total(&dv(Variant::Int16(7))).unwrap(), 7);
        assert!(decode_pulse_total(&dv(Variant::Double(-4.5))).is_err());
        assert!(decode_pulse_total(&dv(Variant::Double(f64::NAN))).is_err());
        assert!(decode_pulse_total(&dv(Variant::String(UAString::from("4")))).is_err());
        let mut bad = dv(Variant::Int32(3));
        bad.status = Some(StatusCode::BadNodeIdUnknown);
        assert!(decode_pulse_total(&bad).is_err());
    }

    #[test]
    fn offset_in_float_and_integer_nodes() {
        // Float: the nearest binary32 (−16.5 exact; 0.1 → 0.100000001490116…).
        assert_eq!(
            encode_offset(-16.499999999999996, 1.0, T::Float),
            Ok(Variant::Float(-16.5))
        );
        assert_eq!(
            encode_offset(0.1, 1.0, T::Float),
            Ok(Variant::Float(0.1f32))
        );
        // Counts of 0.1 µm: −15.25 µm → −152.5 → −153 (half away from zero), 2.04 → 20.
        assert_eq!(
            encode_offset(-15.25, 10.0, T::Int16),
            Ok(Variant::Int16(-153))
        );
        assert_eq!(encode_offset(2.04, 10.0, T::Int16), Ok(Variant::Int16(20)));
        assert_eq!(encode_offset(-3.0, 1.0, T::Int32), Ok(Variant::Int32(-3)));
        // The ends of the range fit, one count past them does not (no wrap, no saturation).
        assert_eq!(
            encode_offset(32.767, 1000.0, T::Int16),
            Ok(Variant::Int16(32767))
        );
        assert_eq!(
            encode_offset(-32.768, 1000.0, T::Int16),
            Ok(Variant::Int16(-32768))
        );
        let e = encode_offset(32.768, 1000.0, T::Int16).unwrap_err();
        assert!(
            e.contains("Int16") && e.contains("32767") && e.contains("keeps"),
            "{e}"
        );
        assert!(encode_offset(-32.769, 1000.0, T::Int16).is_err());
        assert!(encode_offset(2147483.648, 1000.0, T::Int32).is_err());
        assert_eq!(
            encode_offset(-2147483.648, 1000.0, T::Int32),
            Ok(Variant::Int32(i32::MIN))
        );
        assert!(encode_offset(1e39, 1.0, T::Float).is_err());
    }

    #[test]
    fn declared_types_accepted() {
        let ns0 = |i: u32| NodeId::new(0, i);
        assert!(type_accepts(&ns0(11), 11));
        assert!(!type_accepts(&ns0(10), 11), "Float node, Double written");
        assert!(!type_accepts(&ns0(11), 10));
        assert!(!type_accepts(&ns0(6), 4), "Int32 node, Int16 written");
        assert!(type_accepts(&ns0(24), 4), "BaseDataType takes anything");
        assert!(type_accepts(&ns0(26), 10), "Number takes a Float");
        assert!(!type_accepts(&ns0(26), 1), "Number is not a Boolean");
        assert!(type_accepts(&ns0(27), 6) && !type_accepts(&ns0(27), 11));
        assert!(!type_accepts(&NodeId::new(2, 11u32), 11));
        assert_eq!(data_type_name(&ns0(10)), "Float (i=10)");
    }

    #[test]
    fn trusted_certificates_under_any_name() {
        let dir = tempfile::tempdir().unwrap();
        let pki = dir.path();
        std::fs::create_dir_all(pki.join("trusted")).unwrap();
        std::fs::create_dir_all(pki.join("rejected")).unwrap();
        let data = opcua::crypto::X509Data {
            common_name: "cnc".into(),
            ..opcua::crypto::X509Data::sample_cert()
        };
        let (cert, _) = X509::cert_and_pkey(&data).unwrap();
        let der = cert.to_der().unwrap();
        let canonical = CertificateStore::cert_file_name(&cert);
        // The refused copy the first connect left, and the operator's copy under a name
        // of their own.
        std::fs::write(pki.join("rejected").join(&canonical), &der).unwrap();
        std::fs::write(pki.join("trusted").join("machine 7.crt"), &der).unwrap();
        std::fs::write(pki.join("trusted").join("README.txt"), "not a certificate").unwrap();
        let t = normalise_trusted(pki);
        assert_eq!(t, vec![cert.thumbprint().as_hex_string()]);
        assert_eq!(
            std::fs::read(pki.join("trusted").join(&canonical)).unwrap(),
            der
        );
        assert!(!pki.join("rejected").join(&canonical).exists());
        // The stack's own check now trusts it.
        let store = CertificateStore::new(pki);
        assert!(store
            .validate_application_instance_cert(&cert, SecurityPolicy::Basic256Sha256, None, None)
            .is_ok());
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

        /// An offset built as `counts + fraction` (|fraction| < 0.5) encodes to `counts`
        /// when they fit Int16, and is refused (never wrapped) when they do not.
        #[test]
        fn int16_counts_round_or_refuse(c in -40000i32..40000, f in -0.49f64..0.49) {
            let got = encode_offset((f64::from(c) + f) / 10.0, 10.0, OpcUaNumericType::Int16);
            match i16::try_from(c) {
                Ok(want) => prop_assert_eq!(got, Ok(Variant::Int16(want))),
                Err(_) => prop_assert!(got.is_err()),
            }
        }

        #[test]
        fn doubles_round_trip(x in -1e6f64..1e6) {
            prop_assert_eq!(channel_value(&dv(Variant::Double(x)), 1.0, 0.0).unwrap(), x);
        }

        /// A pulse total written to an Int32 node reads back as itself inside
        /// −2147483648…2147483647 and is refused (never wrapped) outside; as a Double it
        /// reads back as itself everywhere in ±2⁵³.
        #[test]
        fn pulse_totals_round_trip_or_refuse(t in -5_000_000_000i64..5_000_000_000) {
            let fits = (-2_147_483_648..=2_147_483_647).contains(&t);
            match encode_pulse_total(t, OpcUaNumericType::Int32) {
                Ok(v) => {
                    prop_assert!(fits);
                    prop_assert_eq!(decode_pulse_total(&dv(v)), Ok(t));
                }
                Err(_) => prop_assert!(!fits),
            }
            let v = encode_pulse_total(t, OpcUaNumericType::Double).unwrap();
            prop_assert_eq!(decode_pulse_total(&dv(v)), Ok(t));
        }
    }
}
