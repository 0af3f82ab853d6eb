//! The `[input] kind = "opcua"` configuration: the server, its security, the nodes mapped to
//! engine channels, the trigger and program-state nodes, and the offset output node.
//!
//! Re-exported from [`crate::config`]; checked by [`OpcUaInput::validate`] (called from
//! `ServiceConfig::validate`), which names the key, the value and the allowed range.

use std::path::PathBuf;
use std::str::FromStr;

use opcua::types::NodeId;
use serde::{Deserialize, Serialize};

use crate::backoff::Backoff;
use crate::error::{check_range, invalid, Result};

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

/// OPC UA input (CNC variables, temperatures the CNC exposes) and offset output.
///
/// `Debug` prints the password as `Some("(hidden)")`, so a configuration printed for a
/// diagnosis never shows it.
#[derive(Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaInput {
    /// Server endpoint URL, `opc.tcp://host:port/path`.
    pub endpoint: String,
    /// Security policy: None, Basic256Sha256, Aes128Sha256RsaOaep, Aes256Sha256RsaPss
    /// (the deprecated Basic128Rsa15 and Basic256 are accepted for old controls).
    #[serde(default = "none_name")]
    pub security_policy: String,
    /// Message security mode: None, Sign, SignAndEncrypt (None exactly with policy None).
    #[serde(default = "none_name")]
    pub security_mode: String,
    /// User name; anonymous when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub user: Option<String>,
    /// Password of `user`, written in the file (prefer `password_env`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password: Option<String>,
    /// Environment variable holding the password of `user`, so it stays out of the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password_env: Option<String>,
    /// File holding the password of `user` (first line; relative to the configuration file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password_file: Option<PathBuf>,
    /// X.509 user login: the user's certificate (DER `.der` or PEM `.pem`; relative to the
    /// configuration file), instead of `user`; needs `user_private_key`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub user_certificate: Option<PathBuf>,
    /// The private key of `user_certificate` (PEM; relative to the configuration file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub user_private_key: Option<PathBuf>,
    /// Client certificate store: own certificate (created at first start when a secure
    /// policy is used), `trusted/` and `rejected/` server certificates.
    #[serde(default = "default_pki_dir")]
    pub pki_dir: PathBuf,
    /// Trust any server certificate without placing it in `pki_dir/trusted` (commissioning
    /// only; irrelevant with security None).
    #[serde(default)]
    pub trust_server_cert: bool,
    /// Subscription publishing interval and monitored-item sampling interval, s (0.01…60).
    #[serde(default = "default_publishing_interval_s")]
    pub publishing_interval_s: f64,
    /// Period of the scans handed to the cycle while the session lives, s (0.01…3600);
    /// not used when a `trigger` node sets the scans.
    #[serde(default = "default_scan_period_s")]
    pub scan_period_s: f64,
    /// Session keep-alive interval, s (0.1…3600); two failed keep-alives drop the session.
    #[serde(default = "default_keep_alive_s")]
    pub keep_alive_s: f64,
    /// Reconnect back-off.
    #[serde(default)]
    pub reconnect: Backoff,
    /// Nodes read as engine channels (temperatures, or any numeric CNC variable the engine
    /// configuration defines a channel for).
    #[serde(default)]
    pub channels: Vec<OpcUaChannel>,
    /// Nodes read as axis positions for the engine's position-dependent terms.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<OpcUaPosition>,
    /// A stroke trigger or cut counter: each event hands one scan to the cycle.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trigger: Option<OpcUaTrigger>,
    /// The program state, telling the engine when the machine is between cuts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub program_state: Option<OpcUaProgramState>,
    /// Where the offset is written, if anywhere (one output; the earlier form, still
    /// accepted: it counts as the first of `offset_outputs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_output: Option<OpcUaOffsetOutput>,
    /// One offset output per axis (Z and X each to their own node).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub offset_outputs: Vec<OpcUaOffsetOutput>,
    /// The stop / feed-hold output: a writable Boolean node, true while the engine's stop
    /// request is latched (until the operator acknowledges it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_output: Option<OpcUaStopOutput>,
    /// The heartbeat: a writable Int32 node counting up every `period_s` while the
    /// compensation cycle steps.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heartbeat: Option<OpcUaHeartbeat>,
    /// EP0138375 infeed pulses: per axis applied as pulses, a writable node receiving the
    /// cumulative pulse total (the PLC applies the difference to the total it last applied).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pulse_outputs: Vec<OpcUaPulseOutput>,
}

impl std::fmt::Debug for OpcUaInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OpcUaInput")
            .field("endpoint", &self.endpoint)
            .field("security_policy", &self.security_policy)
            .field("security_mode", &self.security_mode)
            .field("user", &self.user)
            .field("password", &self.password.as_ref().map(|_| "(hidden)"))
            .field("password_env", &self.password_env)
            .field("password_file", &self.password_file)
            .field("user_certificate", &self.user_certificate)
            .field("user_private_key", &self.user_private_key)
            .field("pki_dir", &self.pki_dir)
            .field("trust_server_cert", &self.trust_server_cert)
            .field("publishing_interval_s", &self.publishing_interval_s)
            .field("scan_period_s", &self.scan_period_s)
            .field("keep_alive_s", &self.keep_alive_s)
            .field("reconnect", &self.reconnect)
            .field("channels", &self.channels)
            .field("positions", &self.positions)
            .field("trigger", &self.trigger)
            .field("program_state", &self.program_state)
            .field("offset_output", &self.offset_output)
            .field("offset_outputs", &self.offset_outputs)
            .field("stop_output", &self.stop_output)
            .field("heartbeat", &self.heartbeat)
            .field("pulse_outputs", &self.pulse_outputs)
            .finish()
    }
}

/// The stop / feed-hold node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaStopOutput {
    /// Node id of a writable Boolean.
    pub node: String,
}

/// The heartbeat node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaHeartbeat {
    /// Node id of a writable Int32 (or Int16 with `data_type = "Int16"`).
    pub node: String,
    /// The node's data type: Int32 (default) or Int16; the counter wraps within it.
    #[serde(default = "int32")]
    pub data_type: OpcUaNumericType,
    /// Period, s (0.05…3600; at least `cycle.period_s` so a live cycle always moves it).
    #[serde(default = "one")]
    pub period_s: f64,
}

/// The infeed-pulse node of one axis applied as pulses (EP0138375).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaPulseOutput {
    /// Axis name (an engine axis with `apply = { kind = "pulses", ... }`).
    pub axis: String,
    /// Node id of a writable variable receiving the cumulative pulse total.
    pub node: String,
    /// The node's data type: Int32 (DINT, default) or Double (LREAL, a whole number).
    #[serde(default = "int32")]
    pub data_type: OpcUaNumericType,
}

fn none_name() -> String {
    "None".into()
}
fn default_pki_dir() -> PathBuf {
    PathBuf::from("pki-opcua")
}
fn default_publishing_interval_s() -> f64 {
    0.1
}
fn default_scan_period_s() -> f64 {
    1.0
}
fn default_keep_alive_s() -> f64 {
    5.0
}
fn one() -> f64 {
    1.0
}
fn int32() -> OpcUaNumericType {
    OpcUaNumericType::Int32
}

/// The data type of an output node, as the server declares it (its `DataType` attribute).
/// IEC 61131-3 names are accepted as aliases (LREAL, REAL, INT, DINT).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum OpcUaNumericType {
    /// 64-bit IEEE 754 (LREAL).
    #[default]
    #[serde(alias = "LREAL")]
    Double,
    /// 32-bit IEEE 754 (REAL).
    #[serde(alias = "REAL")]
    Float,
    /// 16-bit signed integer (INT), in counts.
    #[serde(alias = "INT")]
    Int16,
    /// 32-bit signed integer (DINT), in counts.
    #[serde(alias = "DINT")]
    Int32,
}

impl OpcUaNumericType {
    /// The OPC UA name (Part 6 built-in type).
    pub fn name(self) -> &'static str {
        match self {
            Self::Double => "Double",
            Self::Float => "Float",
            Self::Int16 => "Int16",
            Self::Int32 => "Int32",
        }
    }
}

/// One node read as one engine channel: `value = node·scale + offset`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaChannel {
    /// Engine channel name.
    pub channel: String,
    /// Node id, e.g. `ns=2;s=/Plc/Temp/Bed` or `ns=4;i=1021`.
    pub node: String,
    /// Factor to the channel's raw unit (e.g. 0.1 for tenths of °C), finite, ≠ 0.
    #[serde(default = "one")]
    pub scale: f64,
    /// Added after `scale`.
    #[serde(default)]
    pub offset: f64,
}

/// One node read as an engine axis's actual position: `position_mm = node·scale + offset`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaPosition {
    /// Engine axis name, e.g. "Z".
    pub axis: String,
    /// Node id, e.g. `ns=2;s=/Channel/MachineAxis/actToolBasePos[u1,3]`.
    pub node: String,
    /// Factor to mm (1 for mm, 25.4 for inch, 0.001 for µm), finite, ≠ 0.
    #[serde(default = "one")]
    pub scale: f64,
    /// Added after `scale`, mm.
    #[serde(default)]
    pub offset: f64,
}

/// The stroke trigger or cut counter node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaTrigger {
    /// Node id: a Boolean (rising edge = event) or an integer counter (a change = event).
    pub node: String,
}

/// The program-state node and the values that mean "between cuts".
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaProgramState {
    /// Node id: an integer state (SINUMERIK `progStatus`) or a Boolean (true = 1).
    pub node: String,
    /// State values at which an offset may change (e.g. 2 = stopped, 5 = aborted).
    pub safe_values: Vec<i64>,
}

/// The offset written to a node (absolute value, in the node's data type).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OpcUaOffsetOutput {
    /// Axis name.
    pub axis: String,
    /// Node id of a writable variable (a CNC's temperature-compensation value).
    pub node: String,
    /// Node units per µm: 1 for µm, 0.001 for mm, 10 for Int16 counts of 0.1 µm; negative
    /// flips the sign. 1e-6…1e6 in magnitude.
    #[serde(default = "one")]
    pub scale: f64,
    /// The node's data type: Double (default), Float (REAL), Int16 (INT), Int32 (DINT).
    /// Integer nodes get `round(offset_um·scale)` counts; a value outside the type's range
    /// raises an alarm and the node keeps its last value (never wraps).
    #[serde(default)]
    pub data_type: OpcUaNumericType,
}

/// The security policies this client accepts, by the names used in the configuration.
pub const SECURITY_POLICIES: [&str; 6] = [
    "None",
    "Basic256Sha256",
    "Aes128Sha256RsaOaep",
    "Aes256Sha256RsaPss",
    "Basic128Rsa15",
    "Basic256",
];

/// The message security modes, by name.
pub const SECURITY_MODES: [&str; 3] = ["None", "Sign", "SignAndEncrypt"];

impl OpcUaInput {
    /// Checks every key; the error names the key, the value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let rest = self.endpoint.strip_prefix("opc.tcp://").unwrap_or("");
        if rest.is_empty() || rest.starts_with('/') || rest.chars().any(char::is_whitespace) {
            return Err(invalid(
                "input.endpoint",
                format!("{:?}", self.endpoint),
                "opc.tcp://host:port/path",
            ));
        }
        if !SECURITY_POLICIES.contains(&self.security_policy.as_str()) {
            return Err(invalid(
                "input.security_policy",
                &self.security_policy,
                SECURITY_POLICIES.join(" | "),
            ));
        }
        if !SECURITY_MODES.contains(&self.security_mode.as_str()) {
            return Err(invalid(
                "input.security_mode",
                &self.security_mode,
                SECURITY_MODES.join(" | "),
            ));
        }
        if (self.security_policy == "None") != (self.security_mode == "None") {
            return Err(invalid(
                "input.security_mode",
                &self.security_mode,
                "None exactly when security_policy = \"None\" (Sign or SignAndEncrypt otherwise)",
            ));
        }
        let sources = [
            self.password.is_some(),
            self.password_env.is_some(),
            self.password_file.is_some(),
        ]
        .iter()
        .filter(|b| **b)
        .count();
        match &self.user {
            None if sources > 0 => {
                return Err(invalid(
                    "input.user",
                    "(missing)",
                    "a user name when password, password_env or password_file is given",
                ))
            }
            None => {}
            Some(u) => {
                if u.is_empty() {
                    return Err(invalid("input.user", "\"\"", "a user name"));
                }
                if sources != 1 {
                    return Err(invalid(
                        "input.password / input.password_env / input.password_file",
                        if sources == 0 { "none" } else { "several" },
                        "exactly one of them with input.user",
                    ));
                }
            }
        }
        match (&self.user_certificate, &self.user_private_key) {
            (None, None) => {}
            (Some(_), Some(_)) if self.user.is_some() => {
                return Err(invalid(
                    "input.user_certificate",
                    "given with input.user",
                    "one login: user + password, or user_certificate + user_private_key",
                ))
            }
            (Some(_), Some(_)) => {}
            (Some(_), None) => {
                return Err(invalid(
                    "input.user_private_key",
                    "(missing)",
                    "the PEM private key of input.user_certificate",
                ))
            }
            (None, Some(_)) => {
                return Err(invalid(
                    "input.user_certificate",
                    "(missing)",
                    "the certificate (.der or .pem) of input.user_private_key",
                ))
            }
        }
        check_range(
            "input.publishing_interval_s",
            self.publishing_interval_s,
            0.01,
            60.0,
            "0.01…60 s",
        )?;
        check_range(
            "input.scan_period_s",
            self.scan_period_s,
            0.01,
            3600.0,
            "0.01…3600 s",
        )?;
        check_range(
            "input.keep_alive_s",
            self.keep_alive_s,
            0.1,
            3600.0,
            "0.1…3600 s",
        )?;
        self.reconnect.validate("input.reconnect")?;
        if self.channels.is_empty() && self.outputs().is_empty() {
            return Err(invalid(
                "input.channels",
                0,
                "at least one channel node (or an offset_output)",
            ));
        }
        for (i, c) in self.channels.iter().enumerate() {
            let f = format!("input.channels[{i}]");
            parse_node(&format!("{f}.node"), &c.node)?;
            check_range(&format!("{f}.scale"), c.scale, -1e6, 1e6, "finite, ≠ 0")?;
            if c.scale == 0.0 {
                return Err(invalid(format!("{f}.scale"), 0, "≠ 0"));
            }
            check_range(&format!("{f}.offset"), c.offset, -1e9, 1e9, "finite")?;
        }
        for (i, p) in self.positions.iter().enumerate() {
            let f = format!("input.positions[{i}]");
            parse_node(&format!("{f}.node"), &p.node)?;
            check_range(&format!("{f}.scale"), p.scale, -1e6, 1e6, "finite, ≠ 0")?;
            if p.scale == 0.0 {
                return Err(invalid(format!("{f}.scale"), 0, "≠ 0"));
            }
            check_range(&format!("{f}.offset"), p.offset, -1e9, 1e9, "finite")?;
            if self.positions[..i].iter().any(|q| q.axis == p.axis) {
                return Err(invalid(
                    format!("{f}.axis"),
                    format!("{:?}", p.axis),
                    "an axis not already given a position node",
                ));
            }
        }
        if let Some(t) = &self.trigger {
            parse_node("input.trigger.node", &t.node)?;
        }
        if let Some(p) = &self.program_state {
            parse_node("input.program_state.node", &p.node)?;
            if p.safe_values.is_empty() {
                return Err(invalid(
                    "input.program_state.safe_values",
                    "[]",
                    "at least one state value meaning \"between cuts\"",
                ));
            }
        }
        if let Some(s) = &self.stop_output {
            parse_node("input.stop_output.node", &s.node)?;
        }
        if let Some(h) = &self.heartbeat {
            parse_node("input.heartbeat.node", &h.node)?;
            if !matches!(
                h.data_type,
                OpcUaNumericType::Int16 | OpcUaNumericType::Int32
            ) {
                return Err(invalid(
                    "input.heartbeat.data_type",
                    h.data_type.name(),
                    "Int16 | Int32 (a counter)",
                ));
            }
            crate::error::check_range(
                "input.heartbeat.period_s",
                h.period_s,
                0.05,
                3600.0,
                "0.05…3600 s",
            )?;
        }
        for (i, o) in self.pulse_outputs.iter().enumerate() {
            let f = format!("input.pulse_outputs[{i}]");
            parse_node(&format!("{f}.node"), &o.node)?;
            if !matches!(
                o.data_type,
                OpcUaNumericType::Int32 | OpcUaNumericType::Double
            ) {
                return Err(invalid(
                    format!("{f}.data_type"),
                    o.data_type.name(),
                    "Int32 | Double (a cumulative pulse count)",
                ));
            }
            if self.pulse_outputs[..i].iter().any(|p| p.axis == o.axis) {
                return Err(invalid(
                    format!("{f}.axis"),
                    format!("{:?}", o.axis),
                    "an axis not already given a pulse output (one per axis)",
                ));
            }
            if self.pulse_outputs[..i].iter().any(|p| p.node == o.node)
                || self.outputs().iter().any(|(_, p)| p.node == o.node)
            {
                return Err(invalid(
                    format!("{f}.node"),
                    format!("{:?}", o.node),
                    "a node not already written by another output",
                ));
            }
        }
        let outputs = self.outputs();
        for (i, (f, o)) in outputs.iter().enumerate() {
            parse_node(&format!("{f}.node"), &o.node)?;
            let a = o.scale.abs();
            if !(o.scale.is_finite() && (1e-6..=1e6).contains(&a)) {
                return Err(invalid(
                    format!("{f}.scale"),
                    o.scale,
                    "1e-6…1e6 in magnitude (1 = µm, 0.001 = mm), sign free",
                ));
            }
            if outputs[..i].iter().any(|(_, p)| p.axis == o.axis) {
                return Err(invalid(
                    format!("{f}.axis"),
                    format!("{:?}", o.axis),
                    "an axis not already given an offset output (one output per axis)",
                ));
            }
            if outputs[..i].iter().any(|(_, p)| p.node == o.node) {
                return Err(invalid(
                    format!("{f}.node"),
                    format!("{:?}", o.node),
                    "a node not already written by another offset output",
                ));
            }
        }
        Ok(())
    }

    /// Every offset output with its key: `input.offset_output` (the single-output form)
    /// first, then `input.offset_outputs[i]`.
    pub fn outputs(&self) -> Vec<(String, &OpcUaOffsetOutput)> {
        let mut v: Vec<(String, &OpcUaOffsetOutput)> = self
            .offset_output
            .iter()
            .map(|o| ("input.offset_output".to_string(), o))
            .collect();
        v.extend(
            self.offset_outputs
                .iter()
                .enumerate()
                .map(|(i, o)| (format!("input.offset_outputs[{i}]"), o)),
        );
        v
    }

    /// The password: from the configuration, the environment variable named or the
    /// password file (its first line). The error never contains the password.
    pub fn password(&self) -> Result<Option<String>> {
        if let Some(p) = &self.password {
            return Ok(Some(p.clone()));
        }
        if let Some(f) = &self.password_file {
            let text = std::fs::read_to_string(f).map_err(|e| {
                invalid(
                    "input.password_file",
                    f.display(),
                    format!("a readable file holding the password ({e})"),
                )
            })?;
            let line = text.lines().next().unwrap_or("").trim_end_matches('\r');
            if line.is_empty() {
                return Err(invalid(
                    "input.password_file",
                    f.display(),
                    "a file whose first line is the password (it is empty)",
                ));
            }
            return Ok(Some(line.to_string()));
        }
        match &self.password_env {
            Some(v) => std::env::var(v)
                .map(Some)
                .map_err(|_| invalid("input.password_env", v, "a set environment variable")),
            None => Ok(None),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::{OpcUaInput, OpcUaNumericType};
    use crate::config::{InputSection, ServiceConfig};

    const BASE: &str = "[input]\nkind = \"opcua\"\nendpoint = \"opc.tcp://cnc:4840/\"\n\
                        channels = [{ channel = \"bed_c\", node = \"ns=2;s=Temp.Bed\" }]\n";

    fn err(extra: &str) -> String {
        ServiceConfig::from_toml_str(&format!("{BASE}{extra}"), "m.toml")
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn defaults_and_round_trip() {
        let c = ServiceConfig::from_toml_str(BASE, "m.toml").unwrap();
        let InputSection::OpcUa(o) = &c.input else {
            panic!("not opcua: {:?}", c.input)
        };
        assert_eq!(o.security_policy, "None");
        assert_eq!(o.security_mode, "None");
        assert_eq!(o.scan_period_s, 1.0);
        let text = toml::to_string(&c).unwrap();
        assert_eq!(ServiceConfig::from_toml_str(&text, "t").unwrap(), c);
        let with_pos = format!(
            "{BASE}positions = [{{ axis = \"Z\", node = \"ns=2;s=Pos.Z\", scale = 25.4 }}]\n"
        );
        let c = ServiceConfig::from_toml_str(&with_pos, "m.toml").unwrap();
        let InputSection::OpcUa(o) = &c.input else {
            panic!("not opcua: {:?}", c.input)
        };
        assert_eq!(o.positions.len(), 1);
        assert_eq!((o.positions[0].scale, o.positions[0].offset), (25.4, 0.0));
        let text = toml::to_string(&c).unwrap();
        assert_eq!(ServiceConfig::from_toml_str(&text, "t").unwrap(), c);
    }

    #[test]
    fn outputs_per_axis_types_and_logins() {
        // The single-output form (Double by default) and the list, IEC names as aliases.
        let c = ServiceConfig::from_toml_str(
            &format!(
                "{BASE}offset_output = {{ axis = \"Z\", node = \"ns=2;s=CZ\" }}\n\
                 offset_outputs = [{{ axis = \"X\", node = \"ns=2;s=CX\", data_type = \"INT\", scale = 10.0 }}]\n\
                 heartbeat = {{ node = \"ns=2;s=HB\", data_type = \"Int16\" }}\n"
            ),
            "m.toml",
        )
        .unwrap();
        let InputSection::OpcUa(o) = &c.input else {
            panic!("not opcua: {:?}", c.input)
        };
        let outs = o.outputs();
        assert_eq!(outs.len(), 2);
        assert_eq!(outs[0].0, "input.offset_output");
        assert_eq!(outs[0].1.data_type, OpcUaNumericType::Double);
        assert_eq!(outs[1].0, "input.offset_outputs[0]");
        assert_eq!(outs[1].1.data_type, OpcUaNumericType::Int16);
        assert_eq!(
            o.heartbeat.as_ref().unwrap().data_type,
            OpcUaNumericType::Int16
        );
        let text = toml::to_string(&c).unwrap();
        assert_eq!(ServiceConfig::from_toml_str(&text, "t").unwrap(), c);
        for (alias, ty) in [
            ("LREAL", OpcUaNumericType::Double),
            ("REAL", OpcUaNumericType::Float),
            ("Float", OpcUaNumericType::Float),
            ("DINT", OpcUaNumericType::Int32),
        ] {
            let c = ServiceConfig::from_toml_str(
                &format!(
                    "{BASE}offset_outputs = [{{ axis = \"Z\", node = \"ns=2;s=C\", data_type = \"{alias}\" }}]\n"
                ),
                "m.toml",
            )
            .unwrap();
            let InputSection::OpcUa(o) = &c.input else {
                panic!()
            };
            assert_eq!(o.offset_outputs[0].data_type, ty, "{alias}");
        }
        // One output per axis, one axis per node.
        let e = err("offset_output = { axis = \"Z\", node = \"ns=2;s=A\" }\n\
             offset_outputs = [{ axis = \"Z\", node = \"ns=2;s=B\" }]\n");
        assert!(
            e.contains("input.offset_outputs[0].axis") && e.contains("one output per axis"),
            "{e}"
        );
        let e = err(
            "offset_outputs = [{ axis = \"Z\", node = \"ns=2;s=A\" }, { axis = \"X\", node = \"ns=2;s=A\" }]\n",
        );
        assert!(e.contains("input.offset_outputs[1].node"), "{e}");
        let e =
            err("offset_outputs = [{ axis = \"Z\", node = \"ns=2;s=A\", data_type = \"Int8\" }]\n");
        assert!(e.contains("Int8") && e.contains("Int16"), "{e}");
        let e = err("heartbeat = { node = \"ns=2;s=HB\", data_type = \"Double\" }\n");
        assert!(
            e.contains("input.heartbeat.data_type") && e.contains("Int16 | Int32"),
            "{e}"
        );
        // Logins: one password source; a certificate login needs its key and no user.
        let e = err("user = \"op\"\npassword = \"a\"\npassword_file = \"pw\"\n");
        assert!(e.contains("password_file") && e.contains("several"), "{e}");
        let e = err("user_certificate = \"u.der\"\n");
        assert!(e.contains("input.user_private_key"), "{e}");
        let e = err(
            "user = \"op\"\npassword_env = \"X\"\nuser_certificate = \"u.der\"\nuser_private_key = \"u.pem\"\n",
        );
        assert!(
            e.contains("input.user_certificate") && e.contains("one login"),
            "{e}"
        );
    }

    #[test]
    fn debug_hides_the_password() {
        let o: OpcUaInput = toml::from_str(
            "endpoint = \"opc.tcp://cnc:4840/\"\nuser = \"op\"\npassword = \"Hunter-2-pw\"\n",
        )
        .unwrap();
        let d = format!("{o:?}");
        assert!(
            !d.contains("Hunter-2-pw") && d.contains("(hidden)") && d.contains("\"op\""),
            "{d}"
        );
    }

    #[test]
    fn password_file_first_line_never_in_errors() {
        let dir = tempfile::tempdir().unwrap();
        let pw = dir.path().join("ua.pw");
        std::fs::write(&pw, "Secret-1\r\nsecond line\n").unwrap();
        let mut o: OpcUaInput = toml::from_str(&format!(
            "endpoint = \"opc.tcp://cnc:4840/\"\nuser = \"op\"\npassword_file = {:?}\n",
            pw.display().to_string()
        ))
        .unwrap();
        assert_eq!(o.password().unwrap().as_deref(), Some("Secret-1"));
        std::fs::write(&pw, "\n").unwrap();
        let e = o.password().unwrap_err().to_string();
        assert!(
            e.contains("input.password_file") && e.contains("empty"),
            "{e}"
        );
        o.password_file = Some(dir.path().join("missing.pw"));
        let e = o.password().unwrap_err().to_string();
        assert!(
            e.contains("input.password_file") && !e.contains("Secret"),
            "{e}"
        );
    }

    #[test]
    fn errors_name_key_value_and_range() {
        let e = err("sekurity_mode = \"None\"\n");
        assert!(e.contains("sekurity_mode"), "{e}");
        let e = err("security_policy = \"Basic256Sha256\"\n");
        assert!(
            e.contains("input.security_mode") && e.contains("Sign"),
            "{e}"
        );
        let e = err("security_policy = \"Rot13\"\nsecurity_mode = \"Sign\"\n");
        assert!(
            e.contains("input.security_policy") && e.contains("Aes256Sha256RsaPss"),
            "{e}"
        );
        let e = err("user = \"op\"\n");
        assert!(e.contains("password_env"), "{e}");
        let e = err("trigger = { node = \"CutCounter\" }\n");
        assert!(
            e.contains("input.trigger.node") && e.contains("ns=2;s="),
            "{e}"
        );
        let e = err("offset_output = { axis = \"Z\", node = \"ns=2;s=C\", scale = 0.0 }\n");
        assert!(
            e.contains("input.offset_output.scale") && e.contains("1e-6"),
            "{e}"
        );
        let e = err("positions = [{ axis = \"Z\", node = \"ns=2;s=P\", scale = 0.0 }]\n");
        assert!(
            e.contains("input.positions[0].scale") && e.contains("≠ 0"),
            "{e}"
        );
        let e = err("positions = [{ axis = \"Z\", node = \"P\" }]\n");
        assert!(
            e.contains("input.positions[0].node") && e.contains("ns=2;s="),
            "{e}"
        );
        let e = err(
            "positions = [{ axis = \"Z\", node = \"ns=2;s=P\" }, { axis = \"Z\", node = \"ns=2;s=Q\" }]\n",
        );
        assert!(
            e.contains("input.positions[1].axis") && e.contains("\"Z\""),
            "{e}"
        );
        let e = err("positions = [{ position_axis = \"Z\", node = \"ns=2;s=P\" }]\n");
        assert!(e.contains("position_axis"), "{e}");
        let e = err("scan_period_s = 0.0\n");
        assert!(
            e.contains("input.scan_period_s") && e.contains("0.01…3600"),
            "{e}"
        );
        let e = ServiceConfig::from_toml_str(
            "[input]\nkind = \"opcua\"\nendpoint = \"http://cnc/\"\nchannels = []\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("input.endpoint") && e.contains("opc.tcp://"),
            "{e}"
        );
    }

    #[test]
    fn pulse_outputs_parse_or_name_the_key() {
        let c = ServiceConfig::from_toml_str(
            &format!(
                "{BASE}pulse_outputs = [{{ axis = \"Z\", node = \"ns=2;s=PZ\" }}, \
                 {{ axis = \"X\", node = \"ns=2;s=PX\", data_type = \"LREAL\" }}]\n"
            ),
            "m.toml",
        )
        .unwrap();
        let InputSection::OpcUa(o) = &c.input else {
            panic!("not opcua")
        };
        assert_eq!(o.pulse_outputs[0].data_type, OpcUaNumericType::Int32);
        assert_eq!(o.pulse_outputs[1].data_type, OpcUaNumericType::Double);
        let e =
            err("pulse_outputs = [{ axis = \"Z\", node = \"ns=2;s=P\", data_type = \"Int16\" }]\n");
        assert!(
            e.contains("input.pulse_outputs[0].data_type") && e.contains("Int32 | Double"),
            "{e}"
        );
        let e = err(
            "pulse_outputs = [{ axis = \"Z\", node = \"ns=2;s=P\" }, { axis = \"Z\", node = \"ns=2;s=Q\" }]\n",
        );
        assert!(e.contains("input.pulse_outputs[1].axis"), "{e}");
        let e = err("offset_output = { axis = \"Z\", node = \"ns=2;s=P\" }\n\
             pulse_outputs = [{ axis = \"Z\", node = \"ns=2;s=P\" }]\n");
        assert!(e.contains("input.pulse_outputs[0].node"), "{e}");
        let e = err("pulse_outputs = [{ axis = \"Z\", node = \"nonsense\" }]\n");
        assert!(e.contains("input.pulse_outputs[0].node"), "{e}");
    }
}
