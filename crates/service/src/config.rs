//! The service configuration (`machine.toml`): which machine, which inputs, where the
//! record goes, how the API is reached.
//!
//! Every table denies unknown keys, so a misspelt key is an error naming it, not a setting
//! silently ignored. [`ServiceConfig::validate`] checks ranges and names the key, the
//! value and the allowed range. Relative paths are taken from the configuration file's
//! folder.

use std::net::IpAddr;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{check_range, invalid, Result, ServiceError};

/// The whole service configuration.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ServiceConfig {
    /// Which machine this process serves.
    #[serde(default)]
    pub machine: MachineSection,
    /// The compensation law (a preset or an engine configuration file).
    #[serde(default)]
    pub engine: EngineSection,
    /// The engine cycle.
    #[serde(default)]
    pub cycle: CycleSection,
    /// The SQLite record.
    #[serde(default)]
    pub storage: StorageSection,
    /// The HTTP API and dashboard.
    #[serde(default)]
    pub http: HttpSection,
    /// Access tokens.
    #[serde(default)]
    pub auth: AuthSection,
    /// Where the sensor readings come from (and where the offset goes).
    #[serde(default)]
    pub input: InputSection,
}

/// The machine's identity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MachineSection {
    /// Name used in MQTT topics and shown on the dashboard (letters, digits, `-`, `_`).
    pub name: String,
}

impl Default for MachineSection {
    fn default() -> Self {
        Self { name: "sim".into() }
    }
}

/// The compensation law.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EngineSection {
    /// A simulator preset whose engine configuration is used: grinder, shaper, hobbing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    /// An engine configuration file (`gearcomp_thermal::EngineConfig` TOML).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
}

/// The engine cycle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CycleSection {
    /// Longest time between two engine steps, in s of service time; a complete scan of
    /// every channel steps the engine at once. 0.001…3600 s.
    #[serde(default = "default_cycle_period_s")]
    pub period_s: f64,
    /// Rate of the bumpless transfer after a model change, in µm per cycle, for axes whose
    /// law has no `max_step_um`. 0.001…1000 µm.
    #[serde(default = "default_bumpless_step_um")]
    pub bumpless_step_um: f64,
}

fn default_cycle_period_s() -> f64 {
    1.0
}
fn default_bumpless_step_um() -> f64 {
    0.5
}

impl Default for CycleSection {
    fn default() -> Self {
        Self {
            period_s: default_cycle_period_s(),
            bumpless_step_um: default_bumpless_step_um(),
        }
    }
}

/// The SQLite record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StorageSection {
    /// Database file.
    #[serde(default = "default_db")]
    pub path: PathBuf,
    /// Longest time between two commits, in wall-clock s (what a crash can lose).
    /// 0.01…1 s.
    #[serde(default = "default_commit_interval_s")]
    pub commit_interval_s: f64,
    /// Which database keeps the record: `sqlite` (the file `path`, default) or `postgres`
    /// (a plant database shared by several machines, keyed by `machine.name`).
    #[serde(default)]
    pub backend: StorageBackend,
    /// PostgreSQL connection, as a URL (`postgresql://user@host:5432/plant`) or key-value
    /// string (`host=… user=… dbname=…`); postgres only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub url: Option<String>,
    /// Environment variable holding the PostgreSQL password, so it stays out of the file.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password_env: Option<String>,
    /// Records held in memory while PostgreSQL is unreachable, 1000…100 000 000 (about
    /// 64 bytes each); beyond it records go to the spill file `spill_path` (docs/service.md).
    #[serde(default = "default_buffer_records")]
    pub buffer_records: u64,
    /// Reconnect back-off to PostgreSQL.
    #[serde(default)]
    pub reconnect: Backoff,
    /// TLS to the PostgreSQL server: `disable` (default), `require` or `verify-full`;
    /// postgres only. Unset: the URL's `sslmode`, else `disable` ([`StorageSection::tls_mode`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tls: Option<TlsMode>,
    /// PEM file of the CA(s) the server's certificate must chain to; required with
    /// `tls = "verify-full"` and only allowed with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ca_file: Option<PathBuf>,
    /// Local SQLite file taking the records beyond `buffer_records` while PostgreSQL is
    /// unreachable (postgres only). Unset: `gearcomp-spill-<machine>.db` in the folder of
    /// the configuration file ([`StorageSection::spill_file`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spill_path: Option<PathBuf>,
}

/// TLS to the PostgreSQL server, named as libpq's `sslmode` values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TlsMode {
    /// Plain TCP (the server and network are trusted).
    #[default]
    Disable,
    /// Encrypted, but the server's certificate is not checked (as libpq's `require`):
    /// protects against eavesdropping, not against an impostor server.
    Require,
    /// Encrypted; the server's certificate must chain to `storage.ca_file` and name the
    /// host of `storage.url`.
    VerifyFull,
}

impl TlsMode {
    /// The name as written in the configuration (libpq's `sslmode` value).
    pub fn name(self) -> &'static str {
        match self {
            TlsMode::Disable => "disable",
            TlsMode::Require => "require",
            TlsMode::VerifyFull => "verify-full",
        }
    }
}

/// Splits `sslmode` out of a PostgreSQL URL (`…?sslmode=x&…`) or key=value string
/// (`… sslmode=x …`): the string without it, and its value if present (the last one
/// wins, as in libpq).
pub fn split_sslmode(url: &str) -> (String, Option<String>) {
    let mut mode = None;
    if url.starts_with("postgres://") || url.starts_with("postgresql://") {
        let Some((base, query)) = url.split_once('?') else {
            return (url.to_string(), None);
        };
        let kept: Vec<&str> = query
            .split('&')
            .filter(|kv| match kv.split_once('=') {
                Some(("sslmode", v)) => {
                    mode = Some(v.to_string());
                    false
                }
                _ => true,
            })
            .collect();
        return if kept.is_empty() {
            (base.to_string(), mode)
        } else {
            (format!("{base}?{}", kept.join("&")), mode)
        };
    }
    // key = value pairs; values may be single-quoted with backslash escapes.
    let mut out = String::with_capacity(url.len());
    let mut rest = url;
    loop {
        let trimmed = rest.trim_start();
        if trimmed.is_empty() {
            break;
        }
        let key_len = trimmed
            .find(|c: char| c == '=' || c.is_whitespace())
            .unwrap_or(trimmed.len());
        let key = &trimmed[..key_len];
        let after_key = trimmed[key_len..].trim_start();
        let Some(after_eq) = after_key.strip_prefix('=') else {
            // Malformed: leave the rest for the real parser to report.
            push_pair(&mut out, trimmed);
            break;
        };
        let value_start = after_eq.trim_start();
        let (value, used) = if let Some(q) = value_start.strip_prefix('\'') {
            let mut v = String::new();
            let mut end = None;
            let mut chars = q.char_indices();
            while let Some((i, c)) = chars.next() {
                match c {
                    '\\' => {
                        if let Some((_, n)) = chars.next() {
                            v.push(n);
                        }
                    }
                    '\'' => {
                        end = Some(i + 1);
                        break;
                    }
                    _ => v.push(c),
                }
            }
            let Some(end) = end else {
                push_pair(&mut out, trimmed);
                break;
            };
            (v, 1 + end)
        } else {
            let n = value_start
                .find(char::is_whitespace)
                .unwrap_or(value_start.len());
            (value_start[..n].to_string(), n)
        };
        let consumed = trimmed.len() - value_start.len() + used;
        if key == "sslmode" {
            mode = Some(value);
        } else {
            push_pair(&mut out, &trimmed[..consumed]);
        }
        rest = &trimmed[consumed..];
    }
    (out, mode)
}

fn push_pair(out: &mut String, pair: &str) {
    if !out.is_empty() {
        out.push(' ');
    }
    out.push_str(pair);
}

/// The database behind the record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StorageBackend {
    /// Embedded SQLite file (WAL).
    #[default]
    Sqlite,
    /// A PostgreSQL server (feature `postgres`).
    Postgres,
}

fn default_buffer_records() -> u64 {
    1_000_000
}

fn default_db() -> PathBuf {
    PathBuf::from("gearcomp.db")
}
fn default_commit_interval_s() -> f64 {
    0.25
}

impl Default for StorageSection {
    fn default() -> Self {
        Self {
            path: default_db(),
            commit_interval_s: default_commit_interval_s(),
            backend: StorageBackend::default(),
            url: None,
            password_env: None,
            buffer_records: default_buffer_records(),
            reconnect: Backoff::default(),
            tls: None,
            ca_file: None,
            spill_path: None,
        }
    }
}

/// The HTTP API and dashboard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HttpSection {
    /// Address to bind; 127.0.0.1 unless the plant network needs otherwise.
    #[serde(default = "default_bind")]
    pub bind: IpAddr,
    /// TCP port; 0 picks a free one (printed on stdout).
    #[serde(default = "default_port")]
    pub port: u16,
    /// HTTPS: the server's certificate chain and key (PEM). Required for a bind address
    /// other than loopback unless `allow_plaintext = true`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tls: Option<HttpTls>,
    /// Serve plain HTTP on a non-loopback address (tokens cross the network in clear):
    /// only on a network that is itself protected.
    #[serde(default)]
    pub allow_plaintext: bool,
    /// Most connections open at once (1…100000); a connection beyond is closed at once.
    #[serde(default = "default_max_connections")]
    pub max_connections: u32,
    /// A connection must deliver a request's headers within this time (0.1…600 s), also
    /// between the requests of a kept-alive connection; otherwise it is closed.
    #[serde(default = "default_header_read_timeout")]
    pub header_read_timeout_s: f64,
    /// A request's body (`PUT /api/model`) must arrive whole within this time after its
    /// headers (0.1…600 s); otherwise the request gets 408 and the connection is closed,
    /// so a body sent a byte at a time cannot hold a connection.
    #[serde(default = "default_body_read_timeout")]
    pub body_read_timeout_s: f64,
}

/// HTTPS certificate and key (PEM files, relative to the configuration file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HttpTls {
    /// Certificate chain, leaf first (PEM).
    pub cert_file: PathBuf,
    /// Private key (PEM: PKCS#8, PKCS#1 or SEC1).
    pub key_file: PathBuf,
    /// Client-certificate login: the plant CA (PEM) whose certificates the server accepts
    /// from clients. A client certificate of another CA fails the TLS handshake.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub client_ca_file: Option<PathBuf>,
    /// The roles of client certificates, by the certificate's subject CN or one of its
    /// DNS subject alternative names (needs `client_ca_file`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub client_roles: Vec<ClientRole>,
    /// Every client must present a certificate of `client_ca_file` named in
    /// `client_roles`; tokens are refused. Otherwise a certificate is optional and a
    /// request with a token is judged by the token.
    #[serde(default)]
    pub certificates_only: bool,
}

/// The role of a client certificate (`[http.tls] client_roles`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClientRole {
    /// The certificate's subject common name (CN) or one of its DNS subject alternative
    /// names, compared exactly (ASCII case-insensitive).
    pub name: String,
    /// What a client with that certificate may do.
    pub role: Role,
}

fn default_max_connections() -> u32 {
    256
}
fn default_header_read_timeout() -> f64 {
    10.0
}
fn default_body_read_timeout() -> f64 {
    30.0
}

fn default_bind() -> IpAddr {
    IpAddr::from([127, 0, 0, 1])
}
fn default_port() -> u16 {
    8080
}

impl Default for HttpSection {
    fn default() -> Self {
        Self {
            bind: default_bind(),
            port: default_port(),
            tls: None,
            allow_plaintext: false,
            max_connections: default_max_connections(),
            header_read_timeout_s: default_header_read_timeout(),
            body_read_timeout_s: default_body_read_timeout(),
        }
    }
}

/// Access tokens.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AuthSection {
    /// Configured tokens, stored as SHA-256 hashes; when empty and the database has none,
    /// one operator and one read-only token are generated at first start and printed once.
    #[serde(default)]
    pub tokens: Vec<TokenEntry>,
}

/// A configured token.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TokenEntry {
    /// What the token may do.
    pub role: Role,
    /// SHA-256 of the token, 64 lowercase hex digits (`gearcomp serve --hash-token`).
    pub sha256: String,
}

/// Access roles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// Reads status, history, alarms and the model.
    ReadOnly,
    /// Also acknowledges alarms and changes the model (logged).
    Operator,
}

impl Role {
    /// The name stored in the database and the audit log.
    pub fn name(self) -> &'static str {
        match self {
            Role::ReadOnly => "read_only",
            Role::Operator => "operator",
        }
    }

    /// Parses a stored name.
    pub fn from_name(s: &str) -> Option<Self> {
        match s {
            "read_only" => Some(Role::ReadOnly),
            "operator" => Some(Role::Operator),
            _ => None,
        }
    }
}

/// Where the sensor readings come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum InputSection {
    /// The lumped thermal simulator of a preset machine (gearcomp-thermal).
    Simulator {
        /// Preset: grinder, shaper, hobbing (default: the engine preset, else grinder).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        preset: Option<String>,
        /// Noise generator seed.
        #[serde(default)]
        seed: u64,
        /// Simulated seconds per wall-clock second, 0.001…1e6.
        #[serde(default = "one")]
        speedup: f64,
    },
    /// MQTT: JSON readings on `<prefix>/<machine>/channel/<channel>`, the offset published
    /// on `<prefix>/<machine>/offset/<axis>`.
    #[cfg(feature = "mqtt")]
    Mqtt(MqttInput),
    /// Modbus TCP temperature modules; optionally the offset written to a register.
    #[cfg(feature = "modbus")]
    Modbus(ModbusInput),
    /// OPC UA: monitored items of the CNC (temperatures, trigger, program state) in;
    /// optionally the offset written to a node.
    #[cfg(feature = "opcua")]
    #[serde(rename = "opcua")]
    OpcUa(Box<OpcUaInput>),
    /// A CSV log replayed live, paced by its time column (sped up, optionally looping).
    Replay(ReplayInput),
}

fn one() -> f64 {
    1.0
}

impl Default for InputSection {
    fn default() -> Self {
        InputSection::Simulator {
            preset: None,
            seed: 0,
            speedup: 1.0,
        }
    }
}

pub use crate::backoff::Backoff;

/// MQTT input and output.
#[cfg(feature = "mqtt")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MqttInput {
    /// Broker host name or address.
    pub host: String,
    /// Broker port.
    #[serde(default = "mqtt_port")]
    pub port: u16,
    /// Topic prefix.
    #[serde(default = "mqtt_prefix")]
    pub topic_prefix: String,
    /// Client id (default `gearcomp-<machine>`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub client_id: Option<String>,
    /// Keep-alive, s: a whole number of seconds 5…3600 (MQTT 3.1.1 §3.1.2.10 carries it
    /// in whole seconds), written as `30` or `30.0` like every other `_s` key.
    #[serde(default = "mqtt_keep_alive")]
    pub keep_alive_s: f64,
    /// Publish the applied offset.
    #[serde(default = "yes")]
    pub publish_offset: bool,
    /// Reconnect back-off.
    #[serde(default)]
    pub reconnect: Backoff,
    /// Largest message payload accepted, bytes (16…16 MiB). A larger message is dropped
    /// with an alarm; the connection stays (the client itself accepts any packet the
    /// broker forwards, so one oversized message cannot disconnect it).
    #[serde(default = "mqtt_max_payload")]
    pub max_payload_bytes: u32,
    /// Broker login name; the password comes from `password_file` or `password_env`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub username: Option<String>,
    /// File whose first line is the broker password (relative to the configuration file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password_file: Option<PathBuf>,
    /// Environment variable holding the broker password.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub password_env: Option<String>,
    /// TLS to the broker (rustls, ring provider); the broker's certificate must chain to
    /// `ca_file` and name `host`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tls: Option<MqttTls>,
    /// Publish the stop / feed-hold state (retained, QoS 1) on `<prefix>/<machine>/stop`:
    /// `{"stop": true|false, …}`, latched until the operator acknowledges it; a PLC that
    /// reconnects reads it from the broker.
    #[serde(default = "yes")]
    pub publish_stop: bool,
    /// Heartbeat period, s (≥ `cycle.period_s`, ≤ 3600): `{"beat": n, …}` on
    /// `<prefix>/<machine>/heartbeat` (QoS 1) while the cycle steps; it stops when the
    /// compensator is dead. None: no heartbeat.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heartbeat_s: Option<f64>,
    /// Publish the infeed pulses of every axis applied as pulses on
    /// `<prefix>/<machine>/pulses/<axis>` (QoS 1, retained): `{"pulses": n, "total": T, …}`,
    /// one batch in flight, counted sent only on the broker's PUBACK.
    #[serde(default = "yes")]
    pub publish_pulses: bool,
}

/// TLS to the MQTT broker.
#[cfg(feature = "mqtt")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MqttTls {
    /// The plant CA's certificate(s) (PEM), relative to the configuration file.
    pub ca_file: PathBuf,
    /// Client-certificate login (mutual TLS): this service's certificate chain, leaf first
    /// (PEM), issued by a CA the broker trusts. Only with `key_file`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cert_file: Option<PathBuf>,
    /// The private key of `cert_file` (PEM: PKCS#8, PKCS#1 or SEC1); read at start, never
    /// logged. Only with `cert_file`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub key_file: Option<PathBuf>,
}

#[cfg(feature = "mqtt")]
fn mqtt_max_payload() -> u32 {
    10_240
}

#[cfg(feature = "mqtt")]
impl MqttInput {
    /// The broker login: `None` without `username`; the password is read from the file or
    /// environment variable named in the configuration (never from the file itself, never
    /// logged).
    pub fn credentials(&self) -> Result<Option<(String, String)>> {
        self.check_login()?;
        let Some(user) = &self.username else {
            return Ok(None);
        };
        let password = match (&self.password_file, &self.password_env) {
            (Some(f), _) => {
                let text = std::fs::read_to_string(f).map_err(|e| {
                    invalid(
                        "input.password_file",
                        format!("{} ({e})", f.display()),
                        "a readable file whose first line is the broker password",
                    )
                })?;
                text.lines().next().unwrap_or("").to_string()
            }
            (None, Some(var)) => std::env::var(var).map_err(|_| {
                invalid(
                    "input.password_env",
                    var,
                    "the name of a set environment variable holding the broker password",
                )
            })?,
            (None, None) => String::new(),
        };
        Ok(Some((user.clone(), password)))
    }

    /// The login keys fit together (nothing is read).
    pub fn check_login(&self) -> Result<()> {
        let Some(user) = &self.username else {
            if self.password_file.is_some() || self.password_env.is_some() {
                return Err(invalid(
                    "input.username",
                    "(missing)",
                    "a broker login name when input.password_file or input.password_env is set",
                ));
            }
            return Ok(());
        };
        if self.password_file.is_some() == self.password_env.is_some() {
            return Err(invalid(
                "input.username",
                user,
                "exactly one of input.password_file or input.password_env with it",
            ));
        }
        Ok(())
    }
}

#[cfg(feature = "mqtt")]
fn mqtt_port() -> u16 {
    1883
}
#[cfg(feature = "mqtt")]
fn mqtt_prefix() -> String {
    "gearcomp".into()
}
#[cfg(feature = "mqtt")]
fn mqtt_keep_alive() -> f64 {
    30.0
}
#[cfg(feature = "mqtt")]
fn yes() -> bool {
    true
}

/// Modbus TCP temperature modules.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusInput {
    /// Polling period, s (0.01…3600).
    #[serde(default = "one")]
    pub poll_period_s: f64,
    /// Reconnect back-off.
    #[serde(default)]
    pub reconnect: Backoff,
    /// The modules.
    pub modules: Vec<ModbusModule>,
    /// Where the offset is written, if anywhere.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_output: Option<ModbusOffsetOutput>,
    /// The stop / feed-hold output (first module), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stop_output: Option<ModbusStopOutput>,
    /// The heartbeat output (first module), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heartbeat: Option<ModbusHeartbeat>,
    /// The infeed-pulse counter of an axis applied as pulses (first module), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pulse_output: Option<ModbusPulseOutput>,
    /// Axis positions read from registers of the first module (position-dependent laws).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<ModbusPosition>,
}

/// The infeed pulses of an axis applied as pulses (EP0138375): the cumulative count of
/// pulses issued, an i32 in two holding registers (`address` = high word, `address + 1` =
/// low word, written together with function 16). The PLC applies the difference to the
/// count it last applied; a batch counts as sent only on the device's write response.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusPulseOutput {
    /// Axis name (its engine `apply` must be `pulses`).
    pub axis: String,
    /// Address of the high word.
    pub address: u16,
}

/// An axis position read from a register of the first module.
///
/// position_mm = register·mm_per_count + offset_mm (register: i16, or i32 over two
/// registers high word first when `words = 2`).
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusPosition {
    /// Axis name.
    pub axis: String,
    /// Register address (the high word when `words = 2`).
    pub address: u16,
    /// Input or holding register.
    #[serde(default = "input_table")]
    pub table: RegisterTable,
    /// 1 (i16) or 2 (i32, high word first).
    #[serde(default = "one_word")]
    pub words: u8,
    /// mm per count (≠ 0, |·| ≤ 1000).
    #[serde(default = "micron_mm")]
    pub mm_per_count: f64,
    /// mm added after scaling.
    #[serde(default)]
    pub offset_mm: f64,
}

#[cfg(feature = "modbus")]
fn one_word() -> u8 {
    1
}

#[cfg(feature = "modbus")]
fn micron_mm() -> f64 {
    0.001
}

/// Where a Modbus flag is written.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FlagTable {
    /// A coil (function 5, Write Single Coil).
    Coil,
    /// A holding register (function 6), 1 or 0.
    Holding,
}

/// The stop / feed-hold output: 1 while the engine's stop request is latched (a limit
/// was exceeded; it stays until the operator acknowledges it), 0 otherwise.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusStopOutput {
    /// Coil or holding-register address.
    pub address: u16,
    /// `coil` (default) or `holding`.
    #[serde(default = "flag_coil")]
    pub table: FlagTable,
}

#[cfg(feature = "modbus")]
fn flag_coil() -> FlagTable {
    FlagTable::Coil
}

/// The heartbeat output: a holding register counting up (0…65535, wrapping) every
/// `period_s` while the compensation cycle runs; it stops when the compensator is dead.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusHeartbeat {
    /// Holding-register address.
    pub address: u16,
    /// Period, s (≥ `cycle.period_s`, ≥ the poll period, ≤ 3600).
    #[serde(default = "one")]
    pub period_s: f64,
}

/// One Modbus TCP module.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusModule {
    /// Host name or address.
    pub host: String,
    /// Port.
    #[serde(default = "modbus_port")]
    pub port: u16,
    /// Unit (slave) id.
    #[serde(default = "modbus_unit")]
    pub unit_id: u8,
    /// Registers mapped to channels.
    pub registers: Vec<RegisterMap>,
}

#[cfg(feature = "modbus")]
fn modbus_port() -> u16 {
    502
}
#[cfg(feature = "modbus")]
fn modbus_unit() -> u8 {
    1
}

/// Which register table.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RegisterTable {
    /// Function 04.
    Input,
    /// Function 03.
    Holding,
}

/// One register read as one channel.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RegisterMap {
    /// Engine channel name.
    pub channel: String,
    /// Register address (0-based protocol address).
    pub address: u16,
    /// Input or holding register.
    #[serde(default = "input_table")]
    pub table: RegisterTable,
    /// The register holds a two's-complement i16 (most temperature modules do).
    #[serde(default = "yes_modbus")]
    pub signed: bool,
    /// Engineering value = register·scale + offset (e.g. 0.1 for tenths of °C).
    #[serde(default = "one")]
    pub scale: f64,
    /// See `scale`.
    #[serde(default)]
    pub offset: f64,
    /// Lowest plausible register value; below it the reading is an alarm, not a value.
    #[serde(default = "i16_min")]
    pub raw_min: i32,
    /// Highest plausible register value (modules report 0x7FFF / 0x8000 for a broken
    /// sensor).
    #[serde(default = "i16_max")]
    pub raw_max: i32,
}

#[cfg(feature = "modbus")]
fn input_table() -> RegisterTable {
    RegisterTable::Input
}
#[cfg(feature = "modbus")]
fn yes_modbus() -> bool {
    true
}
#[cfg(feature = "modbus")]
fn i16_min() -> i32 {
    -32767
}
#[cfg(feature = "modbus")]
fn i16_max() -> i32 {
    32766
}

/// The offset written to a holding register of the first module.
#[cfg(feature = "modbus")]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModbusOffsetOutput {
    /// Axis name.
    pub axis: String,
    /// Holding register address.
    pub address: u16,
    /// µm per register count (i16, two's complement), 0.001…1000.
    #[serde(default = "tenth")]
    pub um_per_count: f64,
    /// Every `refresh_s` (0.05…3600 s) the register is read back and, if the device no
    /// longer holds the offset (restarted, overwritten), alarmed and written again; it is
    /// also written at once on every new connection.
    #[serde(default = "modbus_refresh_s")]
    pub refresh_s: f64,
}

#[cfg(feature = "modbus")]
fn tenth() -> f64 {
    0.1
}

#[cfg(feature = "modbus")]
fn modbus_refresh_s() -> f64 {
    1.0
}

pub use crate::sources::replay_config::ReplayInput;

#[cfg(feature = "opcua")]
pub use crate::sources::opcua_config::{
    OpcUaChannel, OpcUaInput, OpcUaNumericType, OpcUaOffsetOutput, OpcUaProgramState,
    OpcUaPulseOutput, OpcUaTrigger,
};

/// A preset name, or the error naming the key it was written under.
fn preset_named(field: &str, p: &str) -> Result<gearcomp_thermal::Preset> {
    gearcomp_thermal::Preset::from_name(p)
        .map_err(|_| invalid(field, format!("{p:?}"), "one of grinder, shaper, hobbing"))
}

/// The keys of `[input] kind = "simulator"`, as [`InputSection::Simulator`] has them
/// (only to name a wrong-typed key, see [`input_key_error`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SimulatorKeys {
    #[serde(default, rename = "preset")]
    _preset: Option<String>,
    #[serde(default, rename = "seed")]
    _seed: u64,
    #[serde(default, rename = "speedup")]
    _speedup: f64,
}

/// The key of the error `e` when it lies in `[input]`: `[input]` is a table tagged by
/// `kind`, which serde reads whole before choosing the variant, so toml's message names
/// only the table (`invalid type: string "1.0", expected f64` at the `[input]` line). The
/// table is read again as the variant's keys alone, which names the key
/// (`input.speedup`, `input.modules[0].registers[1].scale`) and keeps toml's line.
fn input_key_error(text: &str, e: &toml::de::Error) -> Option<String> {
    fn key_of<T: serde::de::DeserializeOwned>(v: toml::Value) -> Option<(String, String)> {
        serde_path_to_error::deserialize::<_, T>(v).err().map(|e| {
            // toml's own message adds "in `key`" lines; the first line is the cause.
            let cause = e.inner().to_string();
            let first = cause.lines().next().unwrap_or_default().to_string();
            (e.path().to_string(), first)
        })
    }
    let doc: toml::Table = toml::from_str(text).ok()?;
    let mut input = doc.get("input")?.as_table()?.clone();
    let kind = input.remove("kind")?;
    let v = toml::Value::Table(input);
    let (key, cause) = match kind.as_str()? {
        "simulator" => key_of::<SimulatorKeys>(v),
        #[cfg(feature = "mqtt")]
        "mqtt" => key_of::<MqttInput>(v),
        #[cfg(feature = "modbus")]
        "modbus" => key_of::<ModbusInput>(v),
        #[cfg(feature = "opcua")]
        "opcua" => key_of::<OpcUaInput>(v),
        "replay" => key_of::<ReplayInput>(v),
        _ => None,
    }?;
    let at = e
        .span()
        .map(|s| {
            let line = text[..s.start.min(text.len())].matches('\n').count() + 1;
            format!(" (the [input] table at line {line})")
        })
        .unwrap_or_default();
    Some(format!("invalid input.{key}: {cause}{at}"))
}

impl ServiceConfig {
    /// Parses a configuration text; `path` only names the file in messages.
    pub fn from_toml_str(text: &str, path: &str) -> Result<Self> {
        let cfg: Self = toml::from_str(text).map_err(|e| ServiceError::Config {
            path: path.into(),
            message: crate::error::shorten_message(
                &input_key_error(text, &e).unwrap_or_else(|| e.to_string()),
            ),
        })?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Reads and validates a configuration file, resolving relative paths against its
    /// folder.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| ServiceError::Io {
            action: "read",
            path: path.display().to_string(),
            source,
        })?;
        let shown = path.display().to_string();
        // A value out of range names the file too (several --config are read in turn).
        let mut cfg = Self::from_toml_str(&text, &shown).map_err(|e| match e {
            ServiceError::Config { .. } => e,
            e => ServiceError::Config {
                path: shown.clone(),
                message: e.to_string(),
            },
        })?;
        let dir = path.parent().unwrap_or_else(|| Path::new("."));
        if cfg.storage.path.is_relative() {
            cfg.storage.path = dir.join(&cfg.storage.path);
        }
        if let Some(f) = &cfg.storage.ca_file {
            if f.is_relative() {
                cfg.storage.ca_file = Some(dir.join(f));
            }
        }
        if cfg.storage.backend == StorageBackend::Postgres {
            let f = cfg.storage.spill_file(&cfg.machine.name);
            if f.is_relative() {
                cfg.storage.spill_path = Some(dir.join(f));
            }
        }
        if let Some(f) = &cfg.engine.file {
            if f.is_relative() {
                cfg.engine.file = Some(dir.join(f));
            }
        }
        if let InputSection::Replay(r) = &mut cfg.input {
            if r.path.is_relative() {
                r.path = dir.join(&r.path);
            }
        }
        if let Some(t) = &mut cfg.http.tls {
            for f in [&mut t.cert_file, &mut t.key_file]
                .into_iter()
                .chain(t.client_ca_file.as_mut())
            {
                if f.is_relative() {
                    *f = dir.join(&*f);
                }
            }
        }
        #[cfg(feature = "mqtt")]
        if let InputSection::Mqtt(m) = &mut cfg.input {
            if let Some(f) = m.password_file.as_mut().filter(|f| f.is_relative()) {
                *f = dir.join(&*f);
            }
            if let Some(t) = m.tls.as_mut() {
                for f in std::iter::once(&mut t.ca_file)
                    .chain(t.cert_file.as_mut())
                    .chain(t.key_file.as_mut())
                {
                    if f.is_relative() {
                        *f = dir.join(&*f);
                    }
                }
            }
        }
        #[cfg(feature = "opcua")]
        if let InputSection::OpcUa(o) = &mut cfg.input {
            if o.pki_dir.is_relative() {
                o.pki_dir = dir.join(&o.pki_dir);
            }
            for f in [
                &mut o.password_file,
                &mut o.user_certificate,
                &mut o.user_private_key,
            ]
            .into_iter()
            .flatten()
            .filter(|f| f.is_relative())
            {
                *f = dir.join(&*f);
            }
        }
        Ok(cfg)
    }

    /// Checks every range; the error names the key, the value and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let name = &self.machine.name;
        if name.is_empty()
            || name.len() > 64
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
        {
            return Err(invalid(
                "machine.name",
                format!("{name:?}"),
                "1–64 letters, digits, '-' or '_'",
            ));
        }
        if self.engine.preset.is_some() && self.engine.file.is_some() {
            return Err(invalid(
                "engine",
                "both preset and file",
                "either engine.preset or engine.file",
            ));
        }
        if let Some(p) = &self.engine.preset {
            preset_named("engine.preset", p)?;
        }
        check_range(
            "cycle.period_s",
            self.cycle.period_s,
            0.001,
            3600.0,
            "0.001…3600 s",
        )?;
        check_range(
            "cycle.bumpless_step_um",
            self.cycle.bumpless_step_um,
            0.001,
            1000.0,
            "0.001…1000 µm",
        )?;
        check_range(
            "storage.commit_interval_s",
            self.storage.commit_interval_s,
            0.01,
            1.0,
            "0.01…1 s (a crash loses at most this)",
        )?;
        if self.storage.backend == StorageBackend::Sqlite
            && self.storage.path.as_os_str().is_empty()
        {
            return Err(invalid(
                "storage.path",
                "\"\"",
                "the SQLite record file (created if missing)",
            ));
        }
        self.validate_postgres()?;
        self.validate_http()?;
        for (i, t) in self.auth.tokens.iter().enumerate() {
            if t.sha256.len() != 64
                || !t
                    .sha256
                    .chars()
                    .all(|c| c.is_ascii_digit() || ('a'..='f').contains(&c))
            {
                return Err(invalid(
                    format!("auth.tokens[{i}].sha256"),
                    &t.sha256,
                    "64 lowercase hex digits (SHA-256 of the token)",
                ));
            }
        }
        match &self.input {
            InputSection::Simulator {
                preset, speedup, ..
            } => {
                if let Some(p) = preset {
                    preset_named("input.preset", p)?;
                }
                check_range("input.speedup", *speedup, 0.001, 1e6, "0.001…1e6")?;
                if self.engine.file.is_none() {
                    if let (Some(a), Some(b)) = (preset, &self.engine.preset) {
                        if !a.eq_ignore_ascii_case(b) {
                            return Err(invalid(
                                "input.preset",
                                a,
                                format!("the engine preset {b:?} (or an engine.file)"),
                            ));
                        }
                    }
                }
            }
            #[cfg(feature = "mqtt")]
            InputSection::Mqtt(m) => {
                if m.host.is_empty() {
                    return Err(invalid("input.host", "\"\"", "a broker host"));
                }
                if m.topic_prefix.is_empty() || m.topic_prefix.contains(['+', '#']) {
                    return Err(invalid(
                        "input.topic_prefix",
                        &m.topic_prefix,
                        "a non-empty topic without wildcards",
                    ));
                }
                // One check: a whole number in range (MQTT sends whole seconds).
                let k = m.keep_alive_s;
                if !(k.is_finite() && (5.0..=3600.0).contains(&k) && k.fract() == 0.0) {
                    return Err(invalid(
                        "input.keep_alive_s",
                        crate::error::number(m.keep_alive_s),
                        "a whole number of seconds 5…3600 (MQTT sends the keep-alive in \
                         whole seconds)",
                    ));
                }
                m.reconnect.validate("input.reconnect")?;
                check_range(
                    "input.max_payload_bytes",
                    m.max_payload_bytes as f64,
                    16.0,
                    16.0 * 1024.0 * 1024.0,
                    "16…16777216 bytes",
                )?;
                m.check_login()?;
                if let Some(h) = m.heartbeat_s {
                    let lo = self.cycle.period_s;
                    check_range(
                        "input.heartbeat_s",
                        h,
                        lo,
                        3600.0,
                        &format!("{lo}…3600 s (≥ cycle.period_s)"),
                    )?;
                }
            }
            #[cfg(feature = "modbus")]
            InputSection::Modbus(m) => {
                check_range(
                    "input.poll_period_s",
                    m.poll_period_s,
                    0.01,
                    3600.0,
                    "0.01…3600 s",
                )?;
                m.reconnect.validate("input.reconnect")?;
                if m.modules.is_empty() {
                    return Err(invalid("input.modules", 0, "at least one module"));
                }
                for (i, md) in m.modules.iter().enumerate() {
                    for (j, r) in md.registers.iter().enumerate() {
                        let f = format!("input.modules[{i}].registers[{j}]");
                        check_range(&format!("{f}.scale"), r.scale, -1e6, 1e6, "finite, ≠ 0")?;
                        if r.scale == 0.0 {
                            return Err(invalid(format!("{f}.scale"), 0, "≠ 0"));
                        }
                        check_range(&format!("{f}.offset"), r.offset, -1e9, 1e9, "finite")?;
                        let (lo, hi) = if r.signed {
                            (-32768, 32767)
                        } else {
                            (0, 65535)
                        };
                        if r.raw_min < lo || r.raw_max > hi || r.raw_min > r.raw_max {
                            return Err(invalid(
                                format!("{f}.raw_min/raw_max"),
                                format!("{}…{}", r.raw_min, r.raw_max),
                                format!("{lo} ≤ raw_min ≤ raw_max ≤ {hi}"),
                            ));
                        }
                    }
                }
                if let Some(o) = &m.offset_output {
                    check_range(
                        "input.offset_output.um_per_count",
                        o.um_per_count,
                        0.001,
                        1000.0,
                        "0.001…1000 µm",
                    )?;
                    check_range(
                        "input.offset_output.refresh_s",
                        o.refresh_s,
                        0.05,
                        3600.0,
                        "0.05…3600 s",
                    )?;
                }
                for (i, p) in m.positions.iter().enumerate() {
                    let f = format!("input.positions[{i}]");
                    if p.words != 1 && p.words != 2 {
                        return Err(invalid(format!("{f}.words"), p.words, "1 or 2"));
                    }
                    check_range(
                        &format!("{f}.mm_per_count"),
                        p.mm_per_count.abs(),
                        1e-9,
                        1000.0,
                        "≠ 0, |mm_per_count| ≤ 1000 mm",
                    )?;
                    check_range(&format!("{f}.offset_mm"), p.offset_mm, -1e6, 1e6, "finite")?;
                }
                if let Some(h) = &m.heartbeat {
                    // The cycle steps at least every cycle.period_s: a shorter heartbeat
                    // would stall between two steps of a live cycle.
                    let lo = self.cycle.period_s.max(m.poll_period_s);
                    check_range(
                        "input.heartbeat.period_s",
                        h.period_s,
                        lo,
                        3600.0,
                        &format!("{lo}…3600 s (≥ cycle.period_s and poll_period_s)"),
                    )?;
                }
            }
            #[cfg(feature = "opcua")]
            InputSection::OpcUa(o) => o.validate()?,
            InputSection::Replay(r) => r.validate()?,
        }
        Ok(())
    }
}

impl ServiceConfig {
    /// The PostgreSQL keys of `[storage]`: a URL when the backend is postgres, a build with
    /// the `postgres` feature, a buffer bound and back-off in range.
    fn validate_http(&self) -> Result<()> {
        let h = &self.http;
        if !h.bind.is_loopback() && h.tls.is_none() && !h.allow_plaintext {
            return Err(invalid(
                "http.bind",
                h.bind,
                "a loopback address (127.0.0.1, ::1), or [http.tls] cert_file/key_file for \
                 HTTPS, or http.allow_plaintext = true to send tokens in clear on a protected \
                 network",
            ));
        }
        if let Some(t) = &h.tls {
            if t.client_ca_file.is_none() && (t.certificates_only || !t.client_roles.is_empty()) {
                return Err(invalid(
                    "http.tls.client_ca_file",
                    "missing",
                    "the plant CA (PEM) that issues client certificates, with \
                     http.tls.client_roles or http.tls.certificates_only",
                ));
            }
            if t.client_ca_file.is_some() && t.client_roles.is_empty() {
                return Err(invalid(
                    "http.tls.client_roles",
                    "empty",
                    "at least one { name = \"<certificate CN or DNS name>\", role = \
                     \"operator\" | \"read_only\" } with http.tls.client_ca_file",
                ));
            }
            for (i, r) in t.client_roles.iter().enumerate() {
                let n = r.name.trim();
                if n.is_empty() || n.len() > 255 || n != r.name {
                    return Err(invalid(
                        format!("http.tls.client_roles[{i}].name"),
                        format!("{:?}", r.name),
                        "a certificate CN or DNS name, 1…255 characters, no surrounding spaces",
                    ));
                }
            }
        }
        check_range(
            "http.max_connections",
            h.max_connections as f64,
            1.0,
            100_000.0,
            "1…100000",
        )?;
        check_range(
            "http.header_read_timeout_s",
            h.header_read_timeout_s,
            0.1,
            600.0,
            "0.1…600 s",
        )?;
        check_range(
            "http.body_read_timeout_s",
            h.body_read_timeout_s,
            0.1,
            600.0,
            "0.1…600 s",
        )
    }

    fn validate_postgres(&self) -> Result<()> {
        let s = &self.storage;
        check_range(
            "storage.buffer_records",
            s.buffer_records as f64,
            1000.0,
            1e8,
            "1000…100000000 records",
        )?;
        s.reconnect.validate("storage.reconnect")?;
        if s.backend == StorageBackend::Postgres {
            if !cfg!(feature = "postgres") {
                return Err(invalid(
                    "storage.backend",
                    "\"postgres\"",
                    "\"sqlite\" (this build has no `postgres` feature)",
                ));
            }
            if s.url.as_deref().is_none_or(|u| u.trim().is_empty()) {
                return Err(invalid(
                    "storage.url",
                    "(missing)",
                    "a PostgreSQL URL, e.g. postgresql://gearcomp@db-host:5432/plant",
                ));
            }
            if let Some(f) = &s.spill_path {
                if f.as_os_str().is_empty() || f.is_dir() {
                    return Err(invalid(
                        "storage.spill_path",
                        format!("{:?}", f.display().to_string()),
                        "a file path for the local spill database (not empty, not a folder)",
                    ));
                }
            }
            let mode = s.tls_mode()?;
            match (mode, &s.ca_file) {
                (TlsMode::VerifyFull, None) => {
                    return Err(invalid(
                        "storage.ca_file",
                        "(missing)",
                        "a PEM file of the CA that signed the server's certificate \
                         (required with storage.tls = \"verify-full\")",
                    ))
                }
                (TlsMode::Disable | TlsMode::Require, Some(f)) => {
                    return Err(invalid(
                        "storage.ca_file",
                        format!("{:?}", f.display().to_string()),
                        format!(
                            "no ca_file with storage.tls = \"{}\" (the CA is only checked \
                             with tls = \"verify-full\")",
                            mode.name()
                        ),
                    ))
                }
                _ => {}
            }
        } else {
            if let Some(t) = s.tls {
                return Err(invalid(
                    "storage.tls",
                    format!("\"{}\"", t.name()),
                    "no tls key with backend = \"sqlite\" (TLS is for a PostgreSQL server: \
                     set storage.backend = \"postgres\")",
                ));
            }
            if let Some(f) = &s.ca_file {
                return Err(invalid(
                    "storage.ca_file",
                    format!("{:?}", f.display().to_string()),
                    "no ca_file with backend = \"sqlite\" (TLS is for a PostgreSQL server: \
                     set storage.backend = \"postgres\")",
                ));
            }
            if let Some(f) = &s.spill_path {
                return Err(invalid(
                    "storage.spill_path",
                    format!("{:?}", f.display().to_string()),
                    "no spill_path with backend = \"sqlite\" (the spill file holds what a \
                     PostgreSQL server could not take: set storage.backend = \"postgres\")",
                ));
            }
        }
        Ok(())
    }
}

impl StorageSection {
    /// The spill file: `spill_path`, else `gearcomp-spill-<machine>.db` (machine names are
    /// letters, digits, `-` and `_`, safe in a file name) in the working directory;
    /// [`ServiceConfig::load`] puts it in the configuration file's folder.
    pub fn spill_file(&self, machine: &str) -> PathBuf {
        self.spill_path
            .clone()
            .unwrap_or_else(|| PathBuf::from(format!("gearcomp-spill-{machine}.db")))
    }

    /// The TLS mode in force: `storage.tls` if set, else the URL's `sslmode`, else
    /// `disable`. Both set and different, or an `sslmode` gearcomp does not offer
    /// (`prefer`, `allow`: TLS an attacker can strip; `verify-ca`), is an error.
    pub fn tls_mode(&self) -> Result<TlsMode> {
        let (_, url_mode) = split_sslmode(self.url.as_deref().unwrap_or_default());
        let from_url = match url_mode.as_deref() {
            None => None,
            Some("disable") => Some(TlsMode::Disable),
            Some("require") => Some(TlsMode::Require),
            Some("verify-full") => Some(TlsMode::VerifyFull),
            Some(other) => {
                return Err(invalid(
                    "storage.url",
                    format!("sslmode={other}"),
                    "sslmode=disable, require or verify-full (or no sslmode and storage.tls)",
                ))
            }
        };
        match (self.tls, from_url) {
            (Some(t), Some(u)) if t != u => Err(invalid(
                "storage.tls",
                format!("\"{}\"", t.name()),
                format!(
                    "the same mode as sslmode={} in storage.url (remove one of the two)",
                    u.name()
                ),
            )),
            (Some(t), _) => Ok(t),
            (None, Some(u)) => Ok(u),
            (None, None) => Ok(TlsMode::Disable),
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn empty_file_is_the_embedded_default() {
        let c = ServiceConfig::from_toml_str("", "t").unwrap();
        assert_eq!(c, ServiceConfig::default());
        assert_eq!(c.http.bind, IpAddr::from([127, 0, 0, 1]));
        assert!(matches!(c.input, InputSection::Simulator { .. }));
    }

    #[test]
    fn unknown_keys_and_ranges_are_named() {
        let e = ServiceConfig::from_toml_str("[http]\nprot = 1\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("prot") && e.contains("m.toml"), "{e}");
        let e = ServiceConfig::from_toml_str("[cycle]\nperiod_s = 0.0\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("cycle.period_s") && e.contains("0.001…3600"),
            "{e}"
        );
        let e = ServiceConfig::from_toml_str("[machine]\nname = \"a/b\"\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("machine.name"), "{e}");
        let e = ServiceConfig::from_toml_str(
            "[[auth.tokens]]\nrole = \"operator\"\nsha256 = \"xyz\"\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("auth.tokens[0].sha256"), "{e}");
    }

    #[test]
    fn backoff_doubles_to_its_ceiling() {
        let b = Backoff {
            min_s: 0.25,
            max_s: 3.0,
        };
        let w: Vec<f64> = (1..=6).map(|k| b.wait_s(k)).collect();
        assert_eq!(w, vec![0.25, 0.5, 1.0, 2.0, 3.0, 3.0]);
        assert_eq!(b.wait_s(u32::MAX), 3.0);
    }

    #[test]
    fn round_trip_through_toml() {
        let mut c = ServiceConfig::default();
        c.machine.name = "gs-300_2".into();
        c.http.port = 9000;
        let text = toml::to_string(&c).unwrap();
        assert_eq!(ServiceConfig::from_toml_str(&text, "t").unwrap(), c);
    }

    #[test]
    fn sslmode_is_split_out_of_urls_and_key_value_strings() {
        let u = "postgresql://gc:pw@db:5432/plant";
        assert_eq!(
            split_sslmode(&format!("{u}?sslmode=verify-full")),
            (u.to_string(), Some("verify-full".into()))
        );
        assert_eq!(
            split_sslmode(&format!(
                "{u}?connect_timeout=3&sslmode=require&application_name=x"
            )),
            (
                format!("{u}?connect_timeout=3&application_name=x"),
                Some("require".into())
            )
        );
        assert_eq!(split_sslmode(u), (u.to_string(), None));
        assert_eq!(
            split_sslmode("host=db sslmode = 'verify-full' password='a sslmode=x\\' b' dbname=p"),
            (
                "host=db password='a sslmode=x\\' b' dbname=p".to_string(),
                Some("verify-full".into())
            )
        );
        assert_eq!(
            split_sslmode("host=db dbname=p"),
            ("host=db dbname=p".into(), None)
        );
    }

    #[test]
    fn tls_mode_follows_the_key_then_the_url_and_refuses_contradictions() {
        let mut s = StorageSection {
            backend: StorageBackend::Postgres,
            url: Some("postgresql://gc@db/plant?sslmode=require".into()),
            ..StorageSection::default()
        };
        assert_eq!(s.tls_mode().unwrap(), TlsMode::Require);
        s.tls = Some(TlsMode::Require);
        assert_eq!(s.tls_mode().unwrap(), TlsMode::Require);
        s.tls = Some(TlsMode::VerifyFull);
        let e = s.tls_mode().unwrap_err().to_string();
        assert!(
            e.contains("storage.tls") && e.contains("sslmode=require"),
            "{e}"
        );
        s.url = Some("postgresql://gc@db/plant".into());
        assert_eq!(s.tls_mode().unwrap(), TlsMode::VerifyFull);
        s.tls = None;
        assert_eq!(s.tls_mode().unwrap(), TlsMode::Disable);
    }

    /// Keys of each `[input]` kind: (kind, group, key as the message must name it, TOML
    /// line with `{}` for the value, a valid value). Lines of one group share a top key;
    /// the valid table takes the first line of each group.
    const INPUT_KEYS: &[(&str, &str, &str, &str, &str)] = &[
        ("simulator", "preset", "preset", "preset = {}", "\"grinder\""),
        ("simulator", "seed", "seed", "seed = {}", "3"),
        ("simulator", "speedup", "speedup", "speedup = {}", "60.0"),
        ("replay", "path", "path", "path = {}", "\"log.csv\""),
        ("replay", "speedup", "speedup", "speedup = {}", "2.0"),
        ("replay", "loop", "loop", "loop = {}", "false"),
        ("replay", "targets", "targets", "targets = {}", "[\"x\"]"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "host", "host", "host = {}", "\"h\""),
        #[cfg(feature = "mqtt")]
        ("mqtt", "port", "port", "port = {}", "1883"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "topic_prefix", "topic_prefix", "topic_prefix = {}", "\"p\""),
        #[cfg(feature = "mqtt")]
        ("mqtt", "keep_alive_s", "keep_alive_s", "keep_alive_s = {}", "30.0"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "publish_offset", "publish_offset", "publish_offset = {}", "true"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "max_payload_bytes", "max_payload_bytes", "max_payload_bytes = {}", "1024"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "heartbeat_s", "heartbeat_s", "heartbeat_s = {}", "2.0"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "reconnect", "reconnect.min_s", "reconnect = { min_s = {}, max_s = 1.0 }", "0.2"),
        #[cfg(feature = "mqtt")]
        ("mqtt", "reconnect", "reconnect.max_s", "reconnect = { min_s = 0.2, max_s = {} }", "1.0"),
        #[cfg(feature = "modbus")]
        ("modbus", "poll_period_s", "poll_period_s", "poll_period_s = {}", "1.0"),
        #[cfg(feature = "modbus")]
        (
            "modbus",
            "modules",
            "modules[0].registers[0].scale",
            "modules = [{ host = \"h\", registers = [{ channel = \"a\", address = 0, scale = {} }] }]",
            "0.1",
        ),
        #[cfg(feature = "modbus")]
        (
            "modbus",
            "modules",
            "modules[0].port",
            "modules = [{ host = \"h\", port = {}, registers = [] }]",
            "502",
        ),
        #[cfg(feature = "modbus")]
        (
            "modbus",
            "offset_output",
            "offset_output.um_per_count",
            "offset_output = { axis = \"Z\", address = 10, um_per_count = {} }",
            "0.1",
        ),
    ];

    /// Values of another type than `valid`'s.
    fn wrong_values(valid: &str) -> &'static [&'static str] {
        if valid.starts_with('"') {
            &["1", "true", "1.5", "[]", "{ a = 1 }"]
        } else if valid == "true" || valid == "false" {
            &["\"yes\"", "1", "[]", "0.5", "\"\""]
        } else if valid.starts_with('[') {
            &["\"x\"", "1", "true", "{ a = 1 }", "1.5"]
        } else if valid.contains('.') {
            &["\"1.0\"", "true", "[]", "{ a = 1 }", "\" \""]
        } else {
            &["\"1\"", "true", "1.5", "-1", "nan"]
        }
    }

    /// The `[input]` table of `kind` with every key valid except entry `bad`, which has
    /// `value`.
    fn input_text(bad: usize, value: &str) -> String {
        let kind = INPUT_KEYS[bad].0;
        let mut groups: Vec<&str> = Vec::new();
        let mut text = format!("[input]\nkind = \"{kind}\"\n");
        for (i, (k, group, _, _, valid)) in INPUT_KEYS.iter().enumerate() {
            if *k != kind || groups.contains(group) {
                continue;
            }
            let i = if INPUT_KEYS[bad].1 == *group { bad } else { i };
            let v = if i == bad { value } else { valid };
            text += &INPUT_KEYS[i].3.replace("{}", v);
            text += "\n";
            groups.push(group);
        }
        text
    }

    #[test]
    fn every_input_table_of_the_key_list_is_valid() {
        // The reference tables are valid, so a refusal below comes from the one value.
        for (i, key) in INPUT_KEYS.iter().enumerate() {
            let t = input_text(i, key.4);
            ServiceConfig::from_toml_str(&t, "m.toml").unwrap_or_else(|e| panic!("{t}\n{e}"));
        }
    }

    #[test]
    fn a_wrong_type_in_input_names_the_key_and_line() {
        // toml names only the [input] table for a wrong type inside it (a tagged table).
        let t = "[cycle]\nperiod_s = 1.0\n\n[input]\nkind = \"simulator\"\nspeedup = \"1.0\"\n";
        let e = ServiceConfig::from_toml_str(t, "m.toml")
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "configuration m.toml: invalid input.speedup: invalid type: string \"1.0\", \
             expected f64 (the [input] table at line 4)"
        );
    }

    /// The MQTT keep-alive is written like every other `_s` key (`30` or `30.0`); a
    /// fraction or a value outside 5…3600 s is refused naming the key, the value and the
    /// form, never as a type error of the parser.
    #[cfg(feature = "mqtt")]
    #[test]
    fn mqtt_keep_alive_takes_whole_seconds_written_either_way() {
        let text =
            |v: &str| format!("[input]\nkind = \"mqtt\"\nhost = \"h\"\nkeep_alive_s = {v}\n");
        for (v, want) in [("30", 30.0), ("30.0", 30.0), ("5", 5.0), ("3600.0", 3600.0)] {
            let c = ServiceConfig::from_toml_str(&text(v), "m.toml").unwrap();
            match c.input {
                InputSection::Mqtt(m) => assert_eq!(m.keep_alive_s, want, "{v}"),
                other => panic!("{other:?}"),
            }
        }
        for (v, shown) in [
            ("1.5", "1.5"),
            ("30.5", "30.5"),
            ("4", "4"),
            ("3601", "3601"),
        ] {
            let e = ServiceConfig::from_toml_str(&text(v), "m.toml")
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with(&format!("invalid input.keep_alive_s = {shown}: expected a whole number of seconds 5…3600")),
                "{v}: {e}"
            );
        }
    }

    /// Every line of an error and the whole of it stay readable: a refused 5000-character
    /// value shows its first 80 characters and its length, never itself.
    fn assert_short(e: &str, text: &str) {
        assert!(e.chars().count() < 1500, "{} characters: {e}", e.len());
        assert!(e.lines().all(|l| l.chars().count() < 480), "{e}");
        assert!(
            !text.contains(&"q".repeat(200)) || !e.contains(&"q".repeat(81)),
            "{e}"
        );
    }

    #[test]
    fn a_long_value_is_shown_by_its_start_and_length() {
        let long = "q".repeat(5000);
        let head = format!("{}…", "q".repeat(80));
        let v = format!("{long:?}");
        // (configuration, what the message names besides the value)
        let places = [
            (format!("[storage]\nbackend = {v}\n"), "line 2"),
            (format!("[storage]\ntls = {v}\n"), "line 2"),
            (format!("[input]\nkind = {v}\n"), "line 2"),
            (format!("[engine]\npreset = {v}\n"), "engine.preset"),
            (format!("[machine]\nname = {v}\n"), "machine.name"),
            (format!("[cycle]\nperiod_s = {v}\n"), "line 2"),
            (format!("[storage]\n{long} = 1\n"), "line 2"),
            (format!("[{long}]\na = 1\n"), "line 1"),
            (
                format!("[auth]\ntokens = [{{ role = {v}, sha256 = \"00\" }}]\n"),
                "line 2",
            ),
            (
                format!("[input]\nkind = \"replay\"\npath = \"l.csv\"\ntargets = [{v}, {v}]\n"),
                "input.targets[1]",
            ),
            (
                format!("[input]\nkind = \"replay\"\npath = \"l.csv\"\n{long} = 1\n"),
                "[input] table at line 1",
            ),
        ];
        for (text, key) in &places {
            let e = ServiceConfig::from_toml_str(text, "m.toml")
                .unwrap_err()
                .to_string();
            assert_short(&e, text);
            assert!(
                e.contains(key) && e.contains(&head) && e.contains("(5000 characters)"),
                "{key}: {e}"
            );
        }
        // The engine file's own messages, through `engine.file`.
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("engine.toml");
        for engine in [
            format!("[[channels]]\nname = \"A\"\nsensor = {{ kind = {v} }}\n"),
            format!("[[channels]]\nname = {v}\nsensor = {{ kind = \"celsius\" }}\nvalid_min = 0.0\nvalid_max = 50.0\nstale_timeout_s = 5.0\n\
                     [[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 10.0\n\
                     [[axes.terms]]\nkind = \"linear\"\nchannel = \"B\"\nkd_um_per_c = 1.0\n"),
        ] {
            std::fs::write(&f, &engine).unwrap();
            let mut cfg = ServiceConfig::default();
            cfg.engine.file = Some(f.clone());
            let e = crate::service::engine_config(&cfg)
                .and_then(|(c, _)| Ok(gearcomp_thermal::Engine::new(&c)?))
                .map(|_| ())
                .unwrap_err()
                .to_string();
            assert_short(&e, &engine);
            assert!(e.contains("engine") && e.contains(&head), "{e}");
        }
        // Every key of every [input] kind written as the long string: refused (a wrong
        // type, a name too long) or accepted, never echoed whole.
        for (i, key) in INPUT_KEYS.iter().enumerate() {
            let text = input_text(i, &v);
            if let Err(e) = ServiceConfig::from_toml_str(&text, "m.toml") {
                let e = e.to_string();
                assert_short(&e, &text);
                assert!(e.contains(key.2), "{}: {e}", key.2);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, failure_persistence: None, ..ProptestConfig::default() })]
        /// Random long values (spaces, quotes, backslashes, non-ASCII letters) in an enum,
        /// a name and a number: the message stays short and says the value's length.
        #[test]
        fn random_long_values_are_shortened(
            v in "[a-zA-Z0-9 \"\\\\'µé中_-]{300,3000}",
            place in 0usize..3,
        ) {
            let quoted = toml::Value::String(v.clone()).to_string();
            let text = match place {
                0 => format!("[storage]\nbackend = {quoted}\n"),
                1 => format!("[engine]\npreset = {quoted}\n"),
                _ => format!("[cycle]\nperiod_s = {quoted}\n"),
            };
            let e = ServiceConfig::from_toml_str(&text, "m.toml").unwrap_err().to_string();
            prop_assert!(e.chars().count() < 1500, "{}", e);
            prop_assert!(e.lines().all(|l| l.chars().count() < 480), "{}", e);
            let n = v.chars().count();
            prop_assert!(e.contains(&format!("({n} characters)")), "{}", e);
        }
    }

    #[test]
    fn presets_and_engine_files_are_named_by_their_key() {
        let e = ServiceConfig::from_toml_str("[engine]\npreset = \"lathe\"\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("engine.preset = \"lathe\""), "{e}");
        let e = ServiceConfig::from_toml_str(
            "[input]\nkind = \"simulator\"\npreset = \"lathe\"\n",
            "m.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("input.preset = \"lathe\""), "{e}");
        // A folder, a missing file and a file that is no engine configuration: the key, the
        // file and the cause, once (the cause was repeated by the error chain).
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("log.csv");
        std::fs::write(&csv, "time_s,a_c\n0,20\n").unwrap();
        for (f, cause) in [
            (dir.path().to_path_buf(), "directory"),
            (dir.path().join("nope.toml"), "No such file"),
            (csv, "TOML parse error"),
        ] {
            let mut cfg = ServiceConfig::default();
            cfg.engine.file = Some(f.clone());
            let e = crate::service::engine_config(&cfg).unwrap_err();
            assert!(std::error::Error::source(&e).is_none(), "{e}");
            let e = e.to_string();
            assert!(
                e.starts_with(&format!("invalid engine.file = {}: ", f.display()))
                    && e.matches(cause).count() == 1,
                "{e}"
            );
        }
    }

    #[test]
    fn load_names_the_file_of_a_value_out_of_range() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("grinder2.toml");
        std::fs::write(&p, "[cycle]\nperiod_s = 0.0\n").unwrap();
        let e = ServiceConfig::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("grinder2.toml") && e.contains("cycle.period_s = 0:"),
            "{e}"
        );
    }

    #[test]
    fn huge_and_tiny_values_are_shown_in_exponent_form() {
        for (v, shown) in [
            ("1e300", "= 1e300:"),
            ("-1e300", "= -1e300:"),
            ("1e-300", "= 1e-300:"),
            ("3601.0", "= 3601:"),
            ("-1.0", "= -1:"),
        ] {
            let e = ServiceConfig::from_toml_str(&format!("[cycle]\nperiod_s = {v}\n"), "m")
                .unwrap_err()
                .to_string();
            assert!(e.contains(shown) && e.len() < 120, "{v}: {e}");
        }
    }

    #[test]
    fn a_record_that_cannot_be_opened_names_storage_path() {
        let dir = tempfile::tempdir().unwrap();
        let text_file = dir.path().join("notes.txt");
        std::fs::write(&text_file, "not a database\n".repeat(100)).unwrap();
        let e = ServiceConfig::from_toml_str("[storage]\npath = \"\"\n", "m.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("storage.path = \"\""), "{e}");
        for path in [
            dir.path().to_path_buf(),
            dir.path().join("missing").join("r.db"),
            text_file.clone(),
        ] {
            let mut cfg = ServiceConfig::default();
            cfg.storage.path = path.clone();
            let e = crate::storage::open_store(&cfg).err().unwrap().to_string();
            assert!(
                e.starts_with(&format!("invalid storage.path = {}", path.display())),
                "{e}"
            );
        }
        // The text file is left as it was.
        assert_eq!(
            std::fs::read_to_string(&text_file).unwrap(),
            "not a database\n".repeat(100)
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// A value of the wrong type for any key of any input kind is refused naming that
        /// key (`input.<key>`), whichever kind and key.
        #[test]
        fn a_wrong_typed_input_key_is_named(i in 0..INPUT_KEYS.len(), j in 0..5usize) {
            let value = wrong_values(INPUT_KEYS[i].4)[j];
            let t = input_text(i, value);
            let e = ServiceConfig::from_toml_str(&t, "m.toml").unwrap_err().to_string();
            let key = format!("invalid input.{}:", INPUT_KEYS[i].2);
            prop_assert!(e.contains(&key) && e.contains("m.toml"), "{}\n{}", t, e);
        }
    }

    proptest! {
        #[test]
        fn split_sslmode_never_panics(s in "\\PC{0,200}") {
            let _ = split_sslmode(&s);
            let _ = split_sslmode(&format!("postgresql://h/d?{s}"));
        }

        #[test]
        fn never_panics_on_any_text(s in "\\PC{0,200}") {
            let _ = ServiceConfig::from_toml_str(&s, "p");
        }

        #[test]
        fn never_panics_on_any_numbers(p in any::<f64>(), c in any::<f64>(), s in any::<f64>()) {
            let text = format!("[cycle]\nperiod_s = {p:?}\n[storage]\ncommit_interval_s = {c:?}\n[input]\nkind = \"simulator\"\nspeedup = {s:?}\n");
            let _ = ServiceConfig::from_toml_str(&text, "p");
        }
    }
}

/// One machine of a multi-machine process: the configuration file it came from (for
/// messages) and its configuration.
#[derive(Debug, Clone, PartialEq)]
pub struct MachineEntry {
    /// The configuration file (or `(default)` for the embedded default).
    pub source: String,
    /// The machine's configuration.
    pub config: ServiceConfig,
}

/// What two machines of one process must not share: an identity, a record, a listening
/// address, or a place the offset is written to (two machines writing one CNC node would
/// overwrite each other's compensation).
fn shared_resources(cfg: &ServiceConfig) -> Vec<(&'static str, String)> {
    let mut keys = vec![("machine.name", cfg.machine.name.clone())];
    if cfg.storage.backend == StorageBackend::Sqlite {
        let path = cfg
            .storage
            .path
            .canonicalize()
            .unwrap_or_else(|_| cfg.storage.path.clone());
        keys.push(("storage.path", path.display().to_string()));
    }
    if cfg.http.port != 0 {
        keys.push(("http.port", format!("{}:{}", cfg.http.bind, cfg.http.port)));
    }
    match &cfg.input {
        #[cfg(feature = "modbus")]
        InputSection::Modbus(m) => {
            if let (Some(o), Some(first)) = (&m.offset_output, m.modules.first()) {
                keys.push((
                    "input.offset_output",
                    format!(
                        "modbus {}:{} unit {} register {}",
                        first.host, first.port, first.unit_id, o.address
                    ),
                ));
            }
        }
        #[cfg(feature = "opcua")]
        InputSection::OpcUa(u) => {
            for (_, o) in u.outputs() {
                keys.push((
                    "input.offset_output",
                    format!("opcua {} node {}", u.endpoint, o.node),
                ));
            }
        }
        _ => {}
    }
    keys
}

/// Checks that the machines of one process keep apart (see [`shared_resources`]); the
/// error names the key, the shared value and both configuration files.
pub fn check_machines_apart(machines: &[MachineEntry]) -> Result<()> {
    let mut seen: std::collections::HashMap<(&'static str, String), &str> =
        std::collections::HashMap::new();
    for m in machines {
        for key in shared_resources(&m.config) {
            let (field, value) = key.clone();
            if let Some(first) = seen.insert(key, &m.source) {
                return Err(invalid(
                    field,
                    format!("{value:?} in both {first} and {}", m.source),
                    "a different value for every machine of one process",
                ));
            }
        }
    }
    Ok(())
}
