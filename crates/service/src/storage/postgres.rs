//! The record in PostgreSQL: one plant database for many machines, each row keyed by the
//! machine (`machines.id`, from `[machine] name`).
//!
//! * **Schema**: created at first start, versioned in `gearcomp_schema`, migrations run
//!   under a transaction-level advisory lock so machines starting together do not race.
//! * **Batched commits**: the same rule as SQLite: one transaction at the latest every
//!   `storage.commit_interval_s`; a sample is acknowledged once committed. Samples,
//!   averages, offsets and targets go in with binary `COPY`.
//! * **Exactly once**: every transaction also sets `machines.last_batch`; when a commit's
//!   outcome is unknown (the connection broke during `COMMIT`), the writer reads it back
//!   after reconnecting and drops the batch only if it went in. Sample ids are assigned by
//!   the writer (`1, 2, …` per machine), so a gap would be visible.
//! * **Connection loss**: records wait in memory, in arrival order, while the writer
//!   reconnects with the back-off of `storage.reconnect`; the alarm `storage.connection`
//!   is raised at the first failure and cleared when the buffer is written. The buffer is
//!   bounded by `storage.buffer_records`: beyond it records go to the local spill file
//!   (`storage.spill_path`, [`spill`]), and every newer one too until it has drained, so
//!   the order is kept; alarm `storage.spilling` while records are in it. Only if the
//!   spill cannot be written are new *raw samples* dropped (counted, alarm
//!   `storage.buffer_full`, and a `storage.records_dropped` alarm naming how many and
//!   when); averages, offsets, targets and alarms, what the export and the audit need,
//!   are then still kept up to twice the bound. A clean stop with the server still down
//!   puts what is in memory into the spill. The compensation never waits for the database.
//! * **One writer per machine**: the writer holds a session advisory lock on its machine
//!   id, so a second `gearcomp serve` with the same machine name is refused.
//! * **TLS** (`storage.tls`): rustls with the *ring* provider, no system library. Every
//!   connection (the writer and the read pool) uses the same connector: `require`
//!   encrypts without checking the certificate (libpq's `require`), `verify-full` checks
//!   the chain to `storage.ca_file` and the host name.

mod spill;

use std::collections::VecDeque;
use std::path::PathBuf;
use std::str::FromStr;
use std::sync::atomic::Ordering;
use std::sync::mpsc::{Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use postgres::binary_copy::BinaryCopyInWriter;
use postgres::config::SslMode;
use postgres::types::{ToSql, Type};
use postgres::{Client, Config, NoTls};
use rustls::client::danger::{HandshakeSignatureValid, ServerCertVerified, ServerCertVerifier};
use rustls::crypto::{verify_tls12_signature, verify_tls13_signature, CryptoProvider};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, ServerName, UnixTime};
use rustls::{ClientConfig, DigitallySignedStruct, RootCertStore, SignatureScheme};
use tokio_postgres_rustls::MakeRustlsConnect;

use super::{
    unix_now_s, AlarmRow, AuditRow, ExportData, IndexedRow, OffsetRow, Point, Range, Record,
    SeriesKind, Store, StoreStats, WriterParams,
};
use crate::config::{split_sslmode, Backoff, ServiceConfig, TlsMode};
use crate::error::{invalid, Result, ServiceError};
use spill::Spill;

/// Schema version this build writes.
pub const SCHEMA_VERSION: i32 = 2;

/// Advisory-lock class of gearcomp (first key of the two-key lock functions).
const LOCK_CLASS: i32 = 0x6763_6f6d; // "gcom"

/// Most records written in one transaction when catching up after an outage.
const CHUNK_RECORDS: usize = 100_000;

/// How long a stopping service keeps trying to write what is left in memory.
pub const SHUTDOWN_RETRY: Duration = Duration::from_secs(10);

/// Migrations, index = version − 1. Each runs once, in the transaction that records it.
const MIGRATIONS: [&str; 2] = [
    "
CREATE TABLE machines (id SERIAL PRIMARY KEY, name TEXT NOT NULL UNIQUE,
    last_batch BIGINT NOT NULL DEFAULT 0, created_unix_s DOUBLE PRECISION NOT NULL);
CREATE TABLE channels (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE axes (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE targets (machine_id INTEGER NOT NULL REFERENCES machines(id),
    idx INTEGER NOT NULL, name TEXT NOT NULL, PRIMARY KEY (machine_id, idx));
CREATE TABLE samples (machine_id INTEGER NOT NULL, id BIGINT NOT NULL,
    time_s DOUBLE PRECISION NOT NULL, channel INTEGER NOT NULL, raw DOUBLE PRECISION,
    PRIMARY KEY (machine_id, id));
CREATE INDEX samples_time ON samples (machine_id, channel, time_s);
CREATE TABLE averages (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL,
    channel INTEGER NOT NULL, value DOUBLE PRECISION);
CREATE INDEX averages_time ON averages (machine_id, time_s);
CREATE TABLE offsets (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL, axis INTEGER NOT NULL,
    offset_um DOUBLE PRECISION, target_um DOUBLE PRECISION, law_um DOUBLE PRECISION,
    status TEXT NOT NULL);
CREATE INDEX offsets_time ON offsets (machine_id, time_s);
CREATE TABLE target_values (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL,
    target INTEGER NOT NULL, value DOUBLE PRECISION);
CREATE INDEX target_values_time ON target_values (machine_id, time_s);
CREATE TABLE alarms (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, time_s DOUBLE PRECISION NOT NULL, key TEXT NOT NULL,
    message TEXT NOT NULL, cleared_s DOUBLE PRECISION, acknowledged_by TEXT,
    acknowledged_unix_s DOUBLE PRECISION);
CREATE INDEX alarms_machine ON alarms (machine_id, id);
CREATE TABLE tokens (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, role TEXT NOT NULL, sha256 TEXT NOT NULL,
    created_unix_s DOUBLE PRECISION NOT NULL, UNIQUE (machine_id, sha256));
CREATE TABLE audit (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, unix_s DOUBLE PRECISION NOT NULL, token_id TEXT NOT NULL,
    role TEXT NOT NULL, action TEXT NOT NULL, detail TEXT NOT NULL);
CREATE TABLE models (id BIGINT GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
    machine_id INTEGER NOT NULL, unix_s DOUBLE PRECISION NOT NULL, source TEXT NOT NULL,
    config_toml TEXT NOT NULL);
",
    "
CREATE TABLE resume_state (machine_id INTEGER PRIMARY KEY REFERENCES machines(id),
    time_s DOUBLE PRECISION NOT NULL, state TEXT NOT NULL);
",
];

/// Connection settings and the machine's key, shared by the readers and the writer.
#[derive(Clone)]
struct Target {
    conn: Connection,
    describe: String,
    machine: String,
    machine_id: i32,
}

impl Target {
    fn connect(&self) -> Result<Client> {
        self.conn.connect()
    }
}

/// How to reach the server: the parsed settings and the TLS connector they need.
#[derive(Clone)]
pub struct Connection {
    /// Host, user, database, timeouts (`ssl_mode` set from `storage.tls`).
    pub config: Config,
    /// The TLS mode in force.
    pub mode: TlsMode,
    /// The rustls connector; `None` with `disable`.
    tls: Option<MakeRustlsConnect>,
}

impl Connection {
    /// Opens one session (TLS as configured).
    pub fn connect(&self) -> Result<Client> {
        Ok(self.config.connect_with(self)?)
    }
}

/// `Config::connect` with the connection's TLS choice, keeping the driver's error.
trait ConnectWith {
    fn connect_with(&self, c: &Connection) -> std::result::Result<Client, postgres::Error>;
}

impl ConnectWith for Config {
    fn connect_with(&self, c: &Connection) -> std::result::Result<Client, postgres::Error> {
        match &c.tls {
            None => self.connect(NoTls),
            Some(tls) => self.connect(tls.clone()),
        }
    }
}

/// The first connection's error with its whole cause chain (the driver's own message
/// stops at "error performing TLS handshake") and, for TLS, what the mode demands.
fn connect_error(
    describe: &str,
    conn: &Connection,
    cfg: &ServiceConfig,
    e: &postgres::Error,
) -> ServiceError {
    let mut cause = e.to_string();
    let mut src = std::error::Error::source(e);
    while let Some(s) = src {
        let m = s.to_string();
        if !cause.contains(&m) {
            cause.push_str(": ");
            cause.push_str(&m);
        }
        src = s.source();
    }
    if cause.contains("TLS") {
        let need = match conn.mode {
            TlsMode::VerifyFull => format!(
                "with storage.tls = \"verify-full\" the server's certificate must chain to \
                 storage.ca_file = {} and name the host of storage.url",
                cfg.storage
                    .ca_file
                    .as_deref()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default()
            ),
            _ => "with storage.tls = \"require\" the server must have ssl = on".into(),
        };
        cause = format!("{cause} ({need})");
    }
    ServiceError::Connect {
        store: describe.to_string(),
        cause,
    }
}

/// The ring provider, named explicitly so no process-wide default needs installing.
fn provider() -> Arc<CryptoProvider> {
    Arc::new(rustls::crypto::ring::default_provider())
}

/// The CA certificates of `storage.ca_file`; the error names the key, the file and what
/// it must hold.
fn read_ca_file(path: &std::path::Path) -> Result<RootCertStore> {
    let shown = path.display().to_string();
    let bad = |why: String| {
        invalid(
            "storage.ca_file",
            &shown,
            format!("a readable PEM file of CA certificates (-----BEGIN CERTIFICATE-----); {why}"),
        )
    };
    let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read it: {e}")))?;
    let certs = CertificateDer::pem_slice_iter(&bytes)
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|e| bad(format!("not valid PEM: {e}")))?;
    if certs.is_empty() {
        return Err(bad("it holds no CERTIFICATE block".into()));
    }
    let mut roots = RootCertStore::empty();
    for (i, c) in certs.into_iter().enumerate() {
        roots.add(c).map_err(|e| {
            bad(format!(
                "certificate {} is not a usable X.509 CA: {e}",
                i + 1
            ))
        })?;
    }
    Ok(roots)
}

/// The rustls client configuration of a mode (`None` for `disable`).
fn tls_connector(
    mode: TlsMode,
    ca_file: Option<&std::path::Path>,
) -> Result<Option<MakeRustlsConnect>> {
    let provider = provider();
    let builder = || {
        ClientConfig::builder_with_provider(provider.clone())
            .with_safe_default_protocol_versions()
            .map_err(|e| {
                invalid(
                    "storage.tls",
                    format!("\"{}\"", mode.name()),
                    format!("TLS 1.2 or 1.3 support ({e})"),
                )
            })
    };
    let config = match mode {
        TlsMode::Disable => return Ok(None),
        TlsMode::Require => builder()?
            .dangerous()
            .with_custom_certificate_verifier(Arc::new(EncryptOnly(provider.clone())))
            .with_no_client_auth(),
        TlsMode::VerifyFull => {
            let path = ca_file.ok_or_else(|| {
                invalid(
                    "storage.ca_file",
                    "(missing)",
                    "a PEM file of the CA that signed the server's certificate (required with storage.tls = \"verify-full\")",
                )
            })?;
            builder()?
                .with_root_certificates(read_ca_file(path)?)
                .with_no_client_auth()
        }
    };
    Ok(Some(MakeRustlsConnect::new(config)))
}

/// `tls = "require"`: the handshake's signatures are checked (the session key belongs to
/// whoever holds the certificate's key) but the certificate itself is not, exactly as
/// libpq's `sslmode=require`: encryption against eavesdropping, no proof of identity.
#[derive(Debug)]
struct EncryptOnly(Arc<CryptoProvider>);

impl ServerCertVerifier for EncryptOnly {
    fn verify_server_cert(
        &self,
        _end_entity: &CertificateDer<'_>,
        _intermediates: &[CertificateDer<'_>],
        _server_name: &ServerName<'_>,
        _ocsp_response: &[u8],
        _now: UnixTime,
    ) -> std::result::Result<ServerCertVerified, rustls::Error> {
        Ok(ServerCertVerified::assertion())
    }

    fn verify_tls12_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> std::result::Result<HandshakeSignatureValid, rustls::Error> {
        verify_tls12_signature(
            message,
            cert,
            dss,
            &self.0.signature_verification_algorithms,
        )
    }

    fn verify_tls13_signature(
        &self,
        message: &[u8],
        cert: &CertificateDer<'_>,
        dss: &DigitallySignedStruct,
    ) -> std::result::Result<HandshakeSignatureValid, rustls::Error> {
        verify_tls13_signature(
            message,
            cert,
            dss,
            &self.0.signature_verification_algorithms,
        )
    }

    fn supported_verify_schemes(&self) -> Vec<SignatureScheme> {
        self.0.signature_verification_algorithms.supported_schemes()
    }
}

/// The PostgreSQL record of one machine.
pub struct PgStore {
    target: Target,
    buffer_records: u64,
    reconnect: Backoff,
    /// The local spill file (`storage.spill_path`).
    spill_path: PathBuf,
    /// Idle read connections, reused by the API's queries.
    pool: Mutex<Vec<Client>>,
}

/// Parses `storage.url` (and the password from `storage.password_env`), and builds the
/// TLS connector of `storage.tls` / the URL's `sslmode` (reading `storage.ca_file`).
pub fn connection_config(cfg: &ServiceConfig) -> Result<Connection> {
    let url = cfg.storage.url.as_deref().unwrap_or_default();
    let mode = cfg.storage.tls_mode()?;
    // The URL's sslmode (checked against storage.tls above) is taken out: the parser
    // knows neither verify-full nor our rule, and ssl_mode is set from `mode` below.
    let (url_rest, _) = split_sslmode(url);
    let mut c = Config::from_str(&url_rest).map_err(|e| {
        invalid(
            "storage.url",
            redact(url),
            format!("a PostgreSQL URL or key=value string ({e})"),
        )
    })?;
    if let Some(var) = &cfg.storage.password_env {
        let pw = std::env::var(var).map_err(|_| {
            invalid(
                "storage.password_env",
                var,
                "the name of a set environment variable holding the password",
            )
        })?;
        c.password(pw);
    }
    if c.get_connect_timeout().is_none() {
        c.connect_timeout(Duration::from_secs(5));
    }
    // A dead peer must not hold the writer for the kernel's default ~2 h.
    c.keepalives(true).keepalives_idle(Duration::from_secs(10));
    c.application_name(&format!("gearcomp-serve {}", cfg.machine.name));
    #[cfg(unix)]
    if mode != TlsMode::Disable
        && c.get_hosts()
            .iter()
            .any(|h| matches!(h, postgres::config::Host::Unix(_)))
    {
        return Err(invalid(
            "storage.tls",
            format!("\"{}\"", mode.name()),
            "\"disable\" with a Unix-socket host (TLS runs over TCP; use host=<name> for TLS)",
        ));
    }
    c.ssl_mode(if mode == TlsMode::Disable {
        SslMode::Disable
    } else {
        SslMode::Require
    });
    let tls = tls_connector(mode, cfg.storage.ca_file.as_deref())?;
    Ok(Connection {
        config: c,
        mode,
        tls,
    })
}

/// `postgresql://user@host:port/dbname tls <mode>`, for messages (never a password).
fn describe_connection(c: &Connection) -> String {
    format!("{} tls {}", describe_config(&c.config), c.mode.name())
}

/// `user@host:port/dbname`, for messages.
fn describe_config(c: &Config) -> String {
    let host = match c.get_hosts().first() {
        Some(postgres::config::Host::Tcp(h)) => h.clone(),
        #[cfg(unix)]
        Some(postgres::config::Host::Unix(p)) => p.display().to_string(),
        None => "localhost".into(),
    };
    let port = c.get_ports().first().copied().unwrap_or(5432);
    format!(
        "postgresql://{}@{host}:{port}/{}",
        c.get_user().unwrap_or("?"),
        c.get_dbname().unwrap_or("?")
    )
}

/// A URL with any password replaced by `***`.
fn redact(url: &str) -> String {
    if let (Some(scheme_end), Some(at)) = (url.find("://"), url.rfind('@')) {
        let cred = &url[scheme_end + 3..at];
        if let Some(colon) = cred.find(':') {
            return format!(
                "{}{}:***{}",
                &url[..scheme_end + 3],
                &cred[..colon],
                &url[at..]
            );
        }
    }
    if url.contains("password") {
        return "(a key=value string with a password)".into();
    }
    url.to_string()
}

/// Creates or upgrades the schema (idempotent; safe when several services start at once).
pub fn migrate(client: &mut Client) -> Result<()> {
    let mut tx = client.transaction()?;
    tx.execute("SELECT pg_advisory_xact_lock($1, 0)", &[&LOCK_CLASS])?;
    tx.batch_execute(
        "CREATE TABLE IF NOT EXISTS gearcomp_schema (version INTEGER PRIMARY KEY, \
         applied_unix_s DOUBLE PRECISION NOT NULL)",
    )?;
    let row = tx.query_one("SELECT COALESCE(MAX(version), 0) FROM gearcomp_schema", &[])?;
    let have: i32 = row.try_get(0)?;
    if have > SCHEMA_VERSION {
        return Err(invalid(
            "gearcomp_schema.version",
            have,
            format!("≤ {SCHEMA_VERSION} (the database was written by a newer gearcomp)"),
        ));
    }
    for v in have + 1..=SCHEMA_VERSION {
        if let Some(sql) = MIGRATIONS.get((v - 1) as usize) {
            tx.batch_execute(sql)?;
        }
        tx.execute(
            "INSERT INTO gearcomp_schema (version, applied_unix_s) VALUES ($1, $2)",
            &[&v, &unix_now_s()],
        )?;
    }
    tx.commit()?;
    Ok(())
}

impl PgStore {
    /// Connects, creates the schema if needed and registers the machine.
    pub fn open(cfg: &ServiceConfig) -> Result<Self> {
        let conn = connection_config(cfg)?;
        let describe = describe_connection(&conn);
        let mut client = conn
            .config
            .connect_with(&conn)
            .map_err(|e| connect_error(&describe, &conn, cfg, &e))?;
        migrate(&mut client)?;
        let name = cfg.machine.name.clone();
        client.execute(
            "INSERT INTO machines (name, created_unix_s) VALUES ($1, $2) \
             ON CONFLICT (name) DO NOTHING",
            &[&name, &unix_now_s()],
        )?;
        let machine_id: i32 = client
            .query_one("SELECT id FROM machines WHERE name = $1", &[&name])?
            .try_get(0)?;
        Ok(Self {
            target: Target {
                conn,
                describe: format!("{describe} (machine {name})"),
                machine: name,
                machine_id,
            },
            buffer_records: cfg.storage.buffer_records,
            reconnect: cfg.storage.reconnect,
            spill_path: cfg.storage.spill_file(&cfg.machine.name),
            pool: Mutex::new(vec![client]),
        })
    }

    /// The machine's key in this database.
    pub fn machine_id(&self) -> i32 {
        self.target.machine_id
    }

    /// Runs `f` on a pooled connection (a new one if none is idle); a pooled connection
    /// that turns out closed (the server restarted) is replaced and `f` run once more.
    fn with<T>(&self, f: impl Fn(&mut Client, i32) -> Result<T>) -> Result<T> {
        let idle = self.pool.lock().unwrap_or_else(|p| p.into_inner()).pop();
        let pooled = idle.is_some();
        let mut c = match idle {
            Some(c) if !c.is_closed() => c,
            _ => self.target.connect()?,
        };
        let mut r = f(&mut c, self.target.machine_id);
        if r.is_err() && pooled && c.is_closed() {
            c = self.target.connect()?;
            r = f(&mut c, self.target.machine_id);
        }
        if !c.is_closed() {
            let mut pool = self.pool.lock().unwrap_or_else(|p| p.into_inner());
            if pool.len() < 4 {
                pool.push(c);
            }
        }
        r
    }

    fn names(c: &mut Client, mid: i32, table: &str) -> Result<Vec<String>> {
        let rows = c.query(
            &format!("SELECT name FROM {table} WHERE machine_id = $1 ORDER BY idx"),
            &[&mid],
        )?;
        rows.iter()
            .map(|r| Ok(r.try_get::<_, String>(0)?))
            .collect()
    }
}

impl Drop for PgStore {
    fn drop(&mut self) {
        // Closing a synchronous client blocks on its own runtime, which tokio forbids on
        // an async worker: the idle connections are closed on a plain thread then.
        let idle = std::mem::take(self.pool.get_mut().unwrap_or_else(|p| p.into_inner()));
        if !idle.is_empty() && tokio::runtime::Handle::try_current().is_ok() {
            let _ = std::thread::Builder::new()
                .name("gearcomp-pg-close".into())
                .spawn(move || drop(idle));
        }
    }
}

fn lim(limit: u32) -> i64 {
    i64::from(limit)
}

impl Store for PgStore {
    fn backend(&self) -> &'static str {
        "postgres"
    }

    fn describe(&self) -> String {
        self.target.describe.clone()
    }

    fn register_names(
        &self,
        channels: &[String],
        axes: &[String],
        targets: &[String],
    ) -> Result<()> {
        self.with(|c, mid| {
            let mut tx = c.transaction()?;
            for (table, names) in [("channels", channels), ("axes", axes), ("targets", targets)] {
                for (i, n) in names.iter().enumerate() {
                    let idx = i as i32;
                    let existing = tx.query_opt(
                        &format!("SELECT name FROM {table} WHERE machine_id = $1 AND idx = $2"),
                        &[&mid, &idx],
                    )?;
                    match existing {
                        Some(row) => {
                            let e: String = row.try_get(0)?;
                            if &e != n {
                                return Err(invalid(
                                    format!("{table}[{i}]"),
                                    n,
                                    format!(
                                        "{e:?} as recorded for machine {} in this database (use a new machine name for a new channel layout)",
                                        self.target.machine
                                    ),
                                ));
                            }
                        }
                        None => {
                            tx.execute(
                                &format!(
                                    "INSERT INTO {table} (machine_id, idx, name) VALUES ($1, $2, $3)"
                                ),
                                &[&mid, &idx, n],
                            )?;
                        }
                    }
                }
            }
            tx.commit()?;
            Ok(())
        })
    }

    fn last_time_s(&self) -> Result<f64> {
        // Records still in the spill file are later than anything in the database.
        let spilled = spill::max_time_s(&self.spill_path)?.unwrap_or(f64::NEG_INFINITY);
        let db = self.with(|c, mid| {
            let mut t = f64::NEG_INFINITY;
            for table in ["samples", "averages", "offsets", "target_values", "alarms"] {
                let row = c.query_one(
                    &format!("SELECT MAX(time_s) FROM {table} WHERE machine_id = $1"),
                    &[&mid],
                )?;
                if let Some(v) = row.try_get::<_, Option<f64>>(0)? {
                    t = t.max(v);
                }
            }
            Ok(t)
        })?;
        Ok(db.max(spilled))
    }

    fn close_stale_alarms(&self, time_s: f64) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "UPDATE alarms SET cleared_s = $1 WHERE machine_id = $2 AND cleared_s IS NULL",
                &[&time_s, &mid],
            )?;
            Ok(())
        })
    }

    fn token_hashes(&self) -> Result<Vec<(String, String)>> {
        self.with(|c, mid| {
            c.query(
                "SELECT sha256, role FROM tokens WHERE machine_id = $1 ORDER BY id",
                &[&mid],
            )?
            .iter()
            .map(|r| Ok((r.try_get(0)?, r.try_get(1)?)))
            .collect()
        })
    }

    fn add_token(&self, role: &str, sha256: &str) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "INSERT INTO tokens (machine_id, role, sha256, created_unix_s) \
                 VALUES ($1, $2, $3, $4)",
                &[&mid, &role, &sha256, &unix_now_s()],
            )?;
            Ok(())
        })
    }

    fn remove_token(&self, id: &str) -> Result<usize> {
        self.with(|c, mid| {
            let n = c.execute(
                "DELETE FROM tokens WHERE machine_id = $1 AND left(sha256, length($2)) = $2",
                &[&mid, &id],
            )?;
            Ok(n as usize)
        })
    }

    fn add_model(&self, source: &str, config_toml: &str) -> Result<()> {
        self.with(|c, mid| {
            c.execute(
                "INSERT INTO models (machine_id, unix_s, source, config_toml) \
                 VALUES ($1, $2, $3, $4)",
                &[&mid, &unix_now_s(), &source, &config_toml],
            )?;
            Ok(())
        })
    }

    fn resume_state(&self) -> Result<Option<String>> {
        self.with(|c, mid| {
            let row = c.query_opt(
                "SELECT state FROM resume_state WHERE machine_id = $1",
                &[&mid],
            )?;
            Ok(match row {
                Some(r) => Some(r.try_get(0)?),
                None => None,
            })
        })
    }

    fn sample_totals(&self) -> Result<(u64, u64)> {
        self.with(|c, mid| {
            let r = c.query_one(
                "SELECT COUNT(*), COALESCE(MAX(id), 0) FROM samples WHERE machine_id = $1",
                &[&mid],
            )?;
            let (n, max): (i64, i64) = (r.try_get(0)?, r.try_get(1)?);
            Ok((n.max(0) as u64, max.max(0) as u64))
        })
    }

    fn channel_history(&self, channel: u16, kind: SeriesKind, range: Range) -> Result<Vec<Point>> {
        let sql = match kind {
            SeriesKind::Raw => {
                "SELECT time_s, raw FROM samples WHERE machine_id = $1 AND channel = $2 \
                 AND time_s BETWEEN $3 AND $4 ORDER BY time_s DESC, id DESC LIMIT $5"
            }
            SeriesKind::Average => {
                "SELECT time_s, value FROM averages WHERE machine_id = $1 AND channel = $2 \
                 AND time_s BETWEEN $3 AND $4 ORDER BY time_s DESC, id DESC LIMIT $5"
            }
        };
        self.with(|c, mid| {
            let ch = i32::from(channel);
            let rows = c.query(
                sql,
                &[&mid, &ch, &range.from_s, &range.to_s, &lim(range.limit)],
            )?;
            let mut v = rows
                .iter()
                .map(|r| {
                    Ok(Point {
                        time_s: r.try_get(0)?,
                        value: r.try_get(1)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            v.reverse();
            Ok(v)
        })
    }

    fn offset_history(&self, range: Range) -> Result<Vec<OffsetRow>> {
        self.with(|c, mid| {
            let axes = Self::names(c, mid, "axes")?;
            let rows = c.query(
                "SELECT time_s, axis, offset_um, target_um, law_um, status FROM offsets \
                 WHERE machine_id = $1 AND time_s BETWEEN $2 AND $3 \
                 ORDER BY time_s DESC, id DESC LIMIT $4",
                &[&mid, &range.from_s, &range.to_s, &lim(range.limit)],
            )?;
            let mut v = rows
                .iter()
                .map(|r| {
                    let axis: i32 = r.try_get(1)?;
                    Ok(OffsetRow {
                        time_s: r.try_get(0)?,
                        axis: axes
                            .get(axis.max(0) as usize)
                            .cloned()
                            .unwrap_or_else(|| axis.to_string()),
                        offset_um: r.try_get(2)?,
                        target_um: r.try_get(3)?,
                        law_um: r.try_get(4)?,
                        status: r.try_get(5)?,
                    })
                })
                .collect::<Result<Vec<_>>>()?;
            v.reverse();
            Ok(v)
        })
    }

    fn alarms(&self, active_only: bool, limit: u32) -> Result<Vec<AlarmRow>> {
        let sql = if active_only {
            "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
             WHERE machine_id = $1 AND (cleared_s IS NULL OR acknowledged_by IS NULL) \
             ORDER BY id DESC LIMIT $2"
        } else {
            "SELECT id, time_s, key, message, cleared_s, acknowledged_by FROM alarms \
             WHERE machine_id = $1 ORDER BY id DESC LIMIT $2"
        };
        self.with(|c, mid| {
            c.query(sql, &[&mid, &lim(limit)])?
                .iter()
                .map(|r| {
                    Ok(AlarmRow {
                        id: r.try_get(0)?,
                        time_s: r.try_get(1)?,
                        key: r.try_get(2)?,
                        message: r.try_get(3)?,
                        cleared_s: r.try_get(4)?,
                        acknowledged_by: r.try_get(5)?,
                    })
                })
                .collect()
        })
    }

    fn alarm_exists(&self, id: i64) -> Result<bool> {
        self.with(|c, mid| {
            Ok(c.query_opt(
                "SELECT 1 FROM alarms WHERE id = $1 AND machine_id = $2",
                &[&id, &mid],
            )?
            .is_some())
        })
    }

    fn audit_log(&self, limit: u32) -> Result<Vec<AuditRow>> {
        self.with(|c, mid| {
            c.query(
                "SELECT unix_s, token_id, role, action, detail FROM audit \
                 WHERE machine_id = $1 ORDER BY id DESC LIMIT $2",
                &[&mid, &lim(limit)],
            )?
            .iter()
            .map(|r| {
                Ok(AuditRow {
                    unix_s: r.try_get(0)?,
                    token_id: r.try_get(1)?,
                    role: r.try_get(2)?,
                    action: r.try_get(3)?,
                    detail: r.try_get(4)?,
                })
            })
            .collect()
        })
    }

    fn export_data(&self) -> Result<ExportData> {
        self.with(|c, mid| {
            let mut series = |sql: &str| -> Result<Vec<IndexedRow>> {
                c.query(sql, &[&mid])?
                    .iter()
                    .map(|r| {
                        Ok((
                            r.try_get(0)?,
                            i64::from(r.try_get::<_, i32>(1)?),
                            r.try_get(2)?,
                        ))
                    })
                    .collect()
            };
            let averages = series(
                "SELECT time_s, channel, value FROM averages WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            let target_values = series(
                "SELECT time_s, target, value FROM target_values WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            let offsets = series(
                "SELECT time_s, axis, offset_um FROM offsets WHERE machine_id = $1 \
                 ORDER BY time_s, id",
            )?;
            Ok(ExportData {
                channels: Self::names(c, mid, "channels")?,
                targets: Self::names(c, mid, "targets")?,
                axes: Self::names(c, mid, "axes")?,
                averages,
                target_values,
                offsets,
            })
        })
    }

    fn spawn_writer(
        &self,
        rx: Receiver<Record>,
        params: WriterParams,
        stats: Arc<StoreStats>,
    ) -> Result<JoinHandle<Result<()>>> {
        let (_, last_id) = self.sample_totals()?;
        let mut w = Writer {
            target: self.target.clone(),
            client: None,
            pending: VecDeque::new(),
            next_id: last_id + 1,
            attempted: None,
            last_batch: 0,
            bound: self.buffer_records.max(1) as usize,
            backoff: self.reconnect,
            failures: 0,
            retry_at: Instant::now(),
            last_error: String::new(),
            down_alarm: false,
            full_alarm: false,
            dropped: 0,
            dropped_from_s: 0.0,
            spill: Spill::new(self.spill_path.clone(), self.target.machine.clone()),
            spilling: false,
            spill_alarm: false,
            spill_failed: false,
            spill_error: String::new(),
            loaded: None,
            params,
            stats,
        };
        // Take the writer's lock now so a second service for this machine fails at start.
        w.connect_locked(Duration::from_secs(5))?;
        // A spill left by a process that ended during an outage goes in before anything new.
        let left = w.spill.resume(w.last_batch)?;
        if left > 0 {
            w.spilling = true;
            let now = w.params.clock.now_s();
            // Alarms the earlier process raised in the spill and never cleared.
            for key in w.spill.open_alarm_keys()? {
                w.spill.stage(Record::AlarmCleared { time_s: now, key });
            }
            w.raise_spilling(format!(
                "{left} records left in the spill file {} by an earlier run are written to {} \
                 before new ones",
                w.spill.path().display(),
                w.target.describe
            ));
        }
        w.publish();
        std::thread::Builder::new()
            .name("gearcomp-store".into())
            .spawn(move || w.run(rx))
            .map_err(|source| ServiceError::Io {
                action: "start",
                path: "the store thread".into(),
                source,
            })
    }
}

/// A chunk whose `COMMIT` was sent but whose outcome is not known yet.
#[derive(Debug, Clone, Copy)]
struct Attempt {
    batch: i64,
    records: usize,
    samples: u64,
    /// The chunk is spilled rows up to this `seq` (deleted from the file once committed).
    spill_upto: Option<i64>,
}

/// The writer thread's state: the connection (if any), the records waiting, the counters.
struct Writer {
    target: Target,
    client: Option<Client>,
    pending: VecDeque<Record>,
    /// Id of the next sample (ids are 1, 2, … per machine).
    next_id: u64,
    attempted: Option<Attempt>,
    /// The last batch number known committed (`machines.last_batch`).
    last_batch: i64,
    bound: usize,
    backoff: Backoff,
    failures: u32,
    retry_at: Instant,
    last_error: String,
    down_alarm: bool,
    full_alarm: bool,
    dropped: u64,
    dropped_from_s: f64,
    /// The local file taking records beyond the bound.
    spill: Spill,
    /// True from the first spilled record until the spill is written: every newer record
    /// goes to the spill too, so the arrival order is kept.
    spilling: bool,
    spill_alarm: bool,
    /// The spill could not be written: records beyond the bound are dropped as without
    /// a spill until it has drained.
    spill_failed: bool,
    spill_error: String,
    /// `pending` holds spilled rows up to this `seq`, loaded to be written.
    loaded: Option<i64>,
    params: WriterParams,
    stats: Arc<StoreStats>,
}

impl Writer {
    /// Connects and takes the machine's writer lock, retrying for up to `patience` (a
    /// killed predecessor's session may take a moment to end).
    fn connect_locked(&mut self, patience: Duration) -> Result<()> {
        let t0 = Instant::now();
        loop {
            let mut c = self.target.connect()?;
            let got: bool = c
                .query_one(
                    "SELECT pg_try_advisory_lock($1, $2)",
                    &[&LOCK_CLASS, &self.target.machine_id],
                )?
                .try_get(0)?;
            if got {
                let last: i64 = c
                    .query_one(
                        "SELECT last_batch FROM machines WHERE id = $1",
                        &[&self.target.machine_id],
                    )?
                    .try_get(0)?;
                self.settle(last);
                self.last_batch = last;
                self.client = Some(c);
                return Ok(());
            }
            if t0.elapsed() >= patience {
                return Err(invalid(
                    "machine.name",
                    &self.target.machine,
                    format!(
                        "a machine no other running gearcomp serve writes to {}",
                        self.target.describe
                    ),
                ));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// Resolves a chunk in doubt: the database's `last_batch` tells whether it went in.
    fn settle(&mut self, last_batch: i64) {
        if let Some(a) = self.attempted.take() {
            if last_batch >= a.batch {
                self.committed(a);
            }
        }
    }

    fn committed(&mut self, a: Attempt) {
        self.pending.drain(..a.records.min(self.pending.len()));
        if let Some(upto) = a.spill_upto {
            self.loaded = None;
            // Only now that PostgreSQL has them; a failed delete is settled at next start.
            if let Err(e) = self.spill.delete_upto(upto) {
                eprintln!("gearcomp serve: {e}");
            }
        }
        self.next_id += a.samples;
        self.stats.commits.fetch_add(1, Ordering::Relaxed);
        if a.samples > 0 {
            self.stats
                .last_sample_id
                .store(self.next_id - 1, Ordering::Release);
            self.stats
                .committed_samples
                .fetch_add(a.samples, Ordering::Release);
        }
        self.publish();
    }

    fn publish(&self) {
        // A chunk loaded from the spill is counted there, not twice.
        let memory = if self.loaded.is_some() {
            0
        } else {
            self.pending.len()
        };
        self.stats
            .buffered_records
            .store(memory as u64, Ordering::Release);
        self.stats
            .spilled_records
            .store(self.spill.len(), Ordering::Release);
    }

    /// Takes one record: into the memory buffer, beyond its bound into the spill file
    /// (and every later one too while anything is spilled), or, if the spill cannot be
    /// written, drops it (counted, alarmed).
    fn push(&mut self, r: Record) {
        if self.spilling && !self.spill_failed {
            self.spill.stage(r);
            return;
        }
        let cap = if matches!(r, Record::Sample { .. }) {
            self.bound
        } else {
            self.bound.saturating_mul(2)
        };
        if self.spilling {
            // The spill failed while older records wait in it: a sample kept in memory
            // would get an id before them, so samples are dropped; the rest (ordered by
            // time in every query) is kept.
            if !matches!(r, Record::Sample { .. }) && self.pending.len() < cap {
                self.pending.push_back(r);
            } else {
                self.drop_record();
            }
            return;
        }
        if self.pending.len() < cap {
            self.pending.push_back(r);
            return;
        }
        if !self.spill_failed {
            self.spilling = true;
            self.spill.stage(r);
            return;
        }
        self.drop_record();
    }

    /// Counts one dropped record and raises `storage.buffer_full` at the first.
    fn drop_record(&mut self) {
        let now = self.params.clock.now_s();
        if self.dropped == 0 {
            self.dropped_from_s = now;
        }
        self.dropped += 1;
        self.stats.dropped_records.fetch_add(1, Ordering::Release);
        if !self.full_alarm {
            self.full_alarm = true;
            let message = format!(
                "storage.buffer_records = {} reached while {} is unreachable and the spill \
                 file {} cannot be written ({}): new raw samples are dropped (counted in \
                 /api/status dropped_records); averages, offsets and alarms are kept up to {} \
                 records",
                self.bound,
                self.target.describe,
                self.spill.path().display(),
                self.spill_error,
                self.bound.saturating_mul(2)
            );
            eprintln!("gearcomp serve: {message}");
            self.pending.push_back(Record::AlarmRaised {
                time_s: now,
                key: "storage.buffer_full".into(),
                message,
            });
        }
    }

    /// Raises `storage.spilling` (in memory, ahead of the spill: alarms are few).
    fn raise_spilling(&mut self, message: String) {
        self.spill_alarm = true;
        eprintln!("gearcomp serve: {message}");
        self.pending.push_back(Record::AlarmRaised {
            time_s: self.params.clock.now_s(),
            key: "storage.spilling".into(),
            message,
        });
    }

    /// Commits the staged spill records to the file; if that fails they are handled as
    /// without a spill (samples dropped and counted, the rest kept in memory).
    fn commit_spill(&mut self) {
        if self.spill.staged() == 0 {
            return;
        }
        match self.spill.commit() {
            Ok(()) => {
                if !self.spill_alarm {
                    let message = format!(
                        "storage.buffer_records = {} reached while {} is unreachable: newer \
                         records go to the spill file {} ({} so far; /api/status \
                         storage.spilled_records counts them) and are written in order when \
                         the server is back",
                        self.bound,
                        self.target.describe,
                        self.spill.path().display(),
                        self.spill.len()
                    );
                    self.raise_spilling(message);
                }
            }
            Err((e, records)) => {
                self.spill_failed = true;
                eprintln!("gearcomp serve: spill failed: {e}");
                self.spill_error = e;
                for r in records {
                    if !matches!(r, Record::Sample { .. })
                        && self.pending.len() < self.bound.saturating_mul(2)
                    {
                        self.pending.push_back(r);
                    } else {
                        self.drop_record();
                    }
                }
                if self.spill.is_empty() {
                    self.spilling = false;
                }
            }
        }
        self.publish();
    }

    /// When memory is written and records wait in the spill: loads the next chunk of
    /// them into `pending`, or, once the spill is empty, ends spilling.
    fn next_from_spill(&mut self) {
        self.commit_spill();
        if !self.spilling {
            return;
        }
        match self.spill.load(CHUNK_RECORDS) {
            Ok(Some((records, upto))) => {
                self.pending.extend(records);
                self.loaded = Some(upto);
            }
            Ok(None) if self.spill_failed => {
                // Nothing readable left: back to memory (records staged meanwhile were
                // handled by `commit_spill`).
                self.spilling = false;
            }
            Ok(None) => {
                self.spilling = false;
                self.spill_failed = false;
                if self.spill_alarm {
                    self.spill_alarm = false;
                    eprintln!(
                        "gearcomp serve: spill file {} written to {}",
                        self.spill.path().display(),
                        self.target.describe
                    );
                    self.pending.push_back(Record::AlarmCleared {
                        time_s: self.params.clock.now_s(),
                        key: "storage.spilling".into(),
                    });
                }
            }
            Err(e) => {
                // Rows that cannot be read stay in the file for the next start.
                eprintln!("gearcomp serve: {e}");
                self.spill_failed = true;
                self.spill_error = e.to_string();
                self.spilling = false;
            }
        }
        self.publish();
    }

    /// Clears the buffer-full alarm once the buffer has drained, leaving a record of what
    /// was lost.
    fn after_drain(&mut self) {
        if self.full_alarm && self.pending.len() < self.bound / 2 {
            self.full_alarm = false;
            let now = self.params.clock.now_s();
            let message = format!(
                "{} records (raw samples first) were dropped between {:.3} s and {:.3} s \
                 because {} was unreachable and storage.buffer_records = {} was reached",
                self.dropped, self.dropped_from_s, now, self.target.describe, self.bound
            );
            eprintln!("gearcomp serve: {message}");
            self.dropped = 0;
            for r in [
                Record::AlarmCleared {
                    time_s: now,
                    key: "storage.buffer_full".into(),
                },
                Record::AlarmRaised {
                    time_s: now,
                    key: "storage.records_dropped".into(),
                    message,
                },
                Record::AlarmCleared {
                    time_s: now,
                    key: "storage.records_dropped".into(),
                },
            ] {
                self.pending.push_back(r);
            }
        }
    }

    fn fail(&mut self, e: &ServiceError) {
        self.client = None;
        self.failures += 1;
        self.last_error = e.to_string();
        let wait = self.backoff.wait_s(self.failures);
        self.retry_at = Instant::now() + Duration::from_secs_f64(wait);
        self.stats.unreachable.store(true, Ordering::Release);
        if !self.down_alarm {
            self.down_alarm = true;
            let message = format!(
                "{} unreachable ({e}); retrying with back-off {}…{} s, records kept in memory \
                 (storage.buffer_records = {})",
                self.target.describe, self.backoff.min_s, self.backoff.max_s, self.bound
            );
            eprintln!("gearcomp serve: {message}");
            let time_s = self.params.clock.now_s();
            self.push(Record::AlarmRaised {
                time_s,
                key: "storage.connection".into(),
                message,
            });
        }
        self.publish();
    }

    /// Writes what is waiting, chunk by chunk; returns false if the store is unreachable
    /// (the records stay, in order).
    fn flush(&mut self) -> bool {
        while !self.write_pending() {
            // The alarms that closing an outage adds are written in the same flush.
        }
        self.publish();
        self.pending.is_empty() && !self.spilling
    }

    /// Writes every waiting chunk. Returns false when the alarms closing an outage were
    /// added (call again to write them), true otherwise, also when the store is
    /// unreachable (the records stay, in order).
    fn write_pending(&mut self) -> bool {
        loop {
            if self.pending.is_empty() && self.spilling {
                self.next_from_spill();
            }
            if self.pending.is_empty() {
                break;
            }
            if self.client.is_none() {
                if Instant::now() < self.retry_at {
                    return true;
                }
                if let Err(e) = self.connect_locked(Duration::ZERO) {
                    self.fail(&e);
                    return true;
                }
            }
            let n = self.pending.len().min(CHUNK_RECORDS);
            let samples = self
                .pending
                .range(..n)
                .filter(|r| matches!(r, Record::Sample { .. }))
                .count() as u64;
            let Some(client) = self.client.as_mut() else {
                return true;
            };
            // The writer lock makes this thread the only one advancing `last_batch`.
            let batch = self.last_batch + 1;
            let a = Attempt {
                batch,
                records: n,
                samples,
                spill_upto: self.loaded,
            };
            if let Some(upto) = self.loaded {
                // Recorded before sending, so a crash in between is settled at next start.
                if let Err(e) = self.spill.mark_in_flight(batch, upto) {
                    eprintln!("gearcomp serve: {e}");
                }
            }
            self.attempted = Some(a);
            match write_chunk(
                client,
                self.target.machine_id,
                self.pending.range(..n),
                self.next_id,
                batch,
            ) {
                Ok(()) => {
                    self.attempted = None;
                    self.last_batch = batch;
                    self.committed(a);
                    self.failures = 0;
                }
                Err(e) => {
                    self.fail(&e);
                    return true;
                }
            }
        }
        self.after_drain();
        if self.down_alarm {
            self.down_alarm = false;
            self.stats.unreachable.store(false, Ordering::Release);
            eprintln!(
                "gearcomp serve: {} reachable again; buffered records written",
                self.target.describe
            );
            self.pending.push_back(Record::AlarmCleared {
                time_s: self.params.clock.now_s(),
                key: "storage.connection".into(),
            });
        }
        self.pending.is_empty()
    }

    /// The loop: take records as they come, write them at the latest `commit_interval`
    /// after the oldest unwritten one arrived (or at the next reconnect attempt).
    fn run(mut self, rx: Receiver<Record>) -> Result<()> {
        let mut oldest: Option<Instant> = None;
        loop {
            let db_due = match (oldest, self.client.is_some()) {
                (None, _) => None,
                (Some(t), true) => Some(t + self.params.commit_interval),
                (Some(t), false) => Some(self.retry_at.max(t + self.params.commit_interval)),
            };
            // The spill file commits at the same cadence, whether or not the server is up.
            let spill_due = self
                .spill
                .staged_since
                .map(|t| t + self.params.commit_interval);
            let due = match (db_due, spill_due) {
                (Some(a), Some(b)) => Some(a.min(b)),
                (a, b) => a.or(b),
            };
            let got = match due {
                None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
                Some(d) => rx.recv_timeout(d.saturating_duration_since(Instant::now())),
            };
            match got {
                Ok(r) => {
                    self.push(r);
                    oldest.get_or_insert_with(Instant::now);
                    if due.is_none_or(|d| Instant::now() < d) {
                        continue;
                    }
                }
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            self.commit_spill();
            self.flush();
            if self.pending.is_empty() && !self.spilling {
                oldest = None;
            } else {
                // Unwritten records (or the alarms the flush itself added) stay due.
                oldest.get_or_insert_with(Instant::now);
            }
            self.publish();
        }
        // Every sender is gone: write what is left, retrying for a bounded time.
        let until = Instant::now() + SHUTDOWN_RETRY;
        while !self.flush() && Instant::now() < until {
            let wait = self
                .retry_at
                .min(until)
                .saturating_duration_since(Instant::now());
            std::thread::sleep(wait.max(Duration::from_millis(10)));
        }
        if self.pending.is_empty() && !self.spilling {
            return Ok(());
        }
        self.commit_spill();
        if self.loaded.is_some() {
            // A chunk read from the spill: it is still in the file.
            self.pending.clear();
        }
        let memory: Vec<Record> = self.pending.drain(..).collect();
        let in_doubt = self
            .attempted
            .filter(|a| a.spill_upto.is_none())
            .map(|a| (a.batch, a.records));
        let kept = if self.spill_failed && !memory.is_empty() {
            Err(invalid(
                "storage.spill_path",
                self.spill.path().display(),
                "writable",
            ))
        } else {
            self.spill.prepend(&memory, in_doubt)
        };
        match kept {
            Ok(()) if self.spill.staged() == 0 => {
                eprintln!(
                    "gearcomp serve: {} unreachable at stop; {} records kept in the spill file \
                     {}, written at the next start",
                    self.target.describe,
                    self.spill.len(),
                    self.spill.path().display()
                );
                Ok(())
            }
            Ok(()) => Err(ServiceError::Unflushed {
                records: self.spill.staged() as u64,
                store: self.target.describe.clone(),
                cause: format!("{}; {}", self.last_error, self.spill_error),
            }),
            Err(e) => Err(ServiceError::Unflushed {
                records: (memory.len() + self.spill.staged()) as u64,
                store: self.target.describe.clone(),
                cause: format!("{}; the spill file too: {e}", self.last_error),
            }),
        }
    }
}

/// Writes one chunk in one transaction: events (alarms, audit, models) in order, the
/// series with binary COPY, then `last_batch`.
fn write_chunk<'a>(
    client: &mut Client,
    mid: i32,
    chunk: impl Iterator<Item = &'a Record> + Clone,
    first_id: u64,
    batch: i64,
) -> Result<()> {
    let mut tx = client.transaction()?;
    let (mut n_s, mut n_a, mut n_o, mut n_t) = (0usize, 0usize, 0usize, 0usize);
    for r in chunk.clone() {
        match r {
            Record::Sample { .. } => n_s += 1,
            Record::Average { .. } => n_a += 1,
            Record::Offset { .. } => n_o += 1,
            Record::Target { .. } => n_t += 1,
            Record::AlarmRaised {
                time_s,
                key,
                message,
            } => {
                tx.execute(
                    "INSERT INTO alarms (machine_id, time_s, key, message) VALUES ($1, $2, $3, $4)",
                    &[&mid, time_s, key, message],
                )?;
            }
            Record::AlarmCleared { time_s, key } => {
                tx.execute(
                    "UPDATE alarms SET cleared_s = $1 \
                     WHERE machine_id = $2 AND key = $3 AND cleared_s IS NULL",
                    &[time_s, &mid, key],
                )?;
            }
            Record::AlarmAcknowledged { id, by } => {
                tx.execute(
                    "UPDATE alarms SET acknowledged_by = $1, acknowledged_unix_s = $2 \
                     WHERE id = $3 AND machine_id = $4",
                    &[by, &unix_now_s(), id, &mid],
                )?;
            }
            Record::Audit {
                token_id,
                role,
                action,
                detail,
            } => {
                tx.execute(
                    "INSERT INTO audit (machine_id, unix_s, token_id, role, action, detail) \
                     VALUES ($1, $2, $3, $4, $5, $6)",
                    &[&mid, &unix_now_s(), token_id, role, action, detail],
                )?;
            }
            Record::Model {
                source,
                config_toml,
            } => {
                tx.execute(
                    "INSERT INTO models (machine_id, unix_s, source, config_toml) \
                     VALUES ($1, $2, $3, $4)",
                    &[&mid, &unix_now_s(), source, config_toml],
                )?;
            }
            Record::Resume { time_s, state } => {
                tx.execute(
                    "INSERT INTO resume_state (machine_id, time_s, state) VALUES ($1, $2, $3) \
                     ON CONFLICT (machine_id) DO UPDATE SET time_s = EXCLUDED.time_s, \
                     state = EXCLUDED.state",
                    &[&mid, time_s, state],
                )?;
            }
        }
    }
    const F8: Type = Type::FLOAT8;
    const I4: Type = Type::INT4;
    if n_s > 0 {
        let sink = tx.copy_in(
            "COPY samples (machine_id, id, time_s, channel, raw) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, Type::INT8, F8, I4, F8]);
        let mut id = first_id as i64;
        for r in chunk.clone() {
            if let Record::Sample {
                time_s,
                channel,
                raw,
            } = r
            {
                let ch = i32::from(*channel);
                let raw = finite(*raw);
                w.write(&[&mid, &id, time_s, &ch, &raw])?;
                id += 1;
            }
        }
        w.finish()?;
    }
    if n_a > 0 {
        let sink = tx.copy_in(
            "COPY averages (machine_id, time_s, channel, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for r in chunk.clone() {
            if let Record::Average {
                time_s,
                channel,
                value,
            } = r
            {
                let ch = i32::from(*channel);
                w.write(&[&mid, time_s, &ch, &finite(*value)])?;
            }
        }
        w.finish()?;
    }
    if n_o > 0 {
        let sink = tx.copy_in(
            "COPY offsets (machine_id, time_s, axis, offset_um, target_um, law_um, status) \
             FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8, F8, F8, Type::TEXT]);
        for r in chunk.clone() {
            if let Record::Offset {
                time_s,
                axis,
                offset_um,
                target_um,
                law_um,
                status,
            } = r
            {
                let ax = i32::from(*axis);
                let vals: [&(dyn ToSql + Sync); 7] = [
                    &mid,
                    time_s,
                    &ax,
                    &finite(*offset_um),
                    &finite(*target_um),
                    &finite(*law_um),
                    status,
                ];
                w.write(&vals)?;
            }
        }
        w.finish()?;
    }
    if n_t > 0 {
        let sink = tx.copy_in(
            "COPY target_values (machine_id, time_s, target, value) FROM STDIN (FORMAT binary)",
        )?;
        let mut w = BinaryCopyInWriter::new(sink, &[I4, F8, I4, F8]);
        for r in chunk {
            if let Record::Target {
                time_s,
                target,
                value,
            } = r
            {
                let t = i32::from(*target);
                w.write(&[&mid, time_s, &t, &finite(*value)])?;
            }
        }
        w.finish()?;
    }
    tx.execute(
        "UPDATE machines SET last_batch = $1 WHERE id = $2",
        &[&batch, &mid],
    )?;
    tx.commit()?;
    Ok(())
}

/// NaN and ±∞ are stored as NULL, as in the SQLite record.
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    #[test]
    fn passwords_never_appear_in_messages() {
        assert_eq!(
            redact("postgresql://gc:s3cret@db:5432/plant"),
            "postgresql://gc:***@db:5432/plant"
        );
        assert_eq!(
            redact("postgresql://gc@db/plant"),
            "postgresql://gc@db/plant"
        );
        assert!(!redact("host=db password=s3cret").contains("s3cret"));
        let c = Config::from_str("postgresql://gc:s3cret@db:6543/plant").unwrap();
        assert_eq!(describe_config(&c), "postgresql://gc@db:6543/plant");
    }
}
