//! Reaching the server: `storage.url` parsed (password from `storage.password_env`),
//! the TLS connector of `storage.tls` (rustls, ring provider; `require` encrypts without
//! checking, `verify-full` checks the chain to `storage.ca_file` and the host name), and
//! messages that never show a password.

use std::str::FromStr;
use std::sync::Arc;
use std::time::Duration;

use postgres::config::SslMode;
use postgres::{Client, Config, NoTls};
use rustls::client::danger::{HandshakeSignatureValid, ServerCertVerified, ServerCertVerifier};
use rustls::crypto::{verify_tls12_signature, verify_tls13_signature, CryptoProvider};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, ServerName, UnixTime};
use rustls::{ClientConfig, DigitallySignedStruct, RootCertStore, SignatureScheme};
use tokio_postgres_rustls::MakeRustlsConnect;

use crate::config::{split_sslmode, ServiceConfig, TlsMode};
use crate::error::{invalid, Result, ServiceError};

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
pub(super) trait ConnectWith {
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
pub(super) fn connect_error(
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
pub(super) fn provider() -> Arc<CryptoProvider> {
    Arc::new(rustls::crypto::ring::default_provider())
}

/// The CA certificates of `storage.ca_file`; the error names the key, the file and what
/// it must hold.
pub(super) fn read_ca_file(path: &std::path::Path) -> Result<RootCertStore> {
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
pub(super) fn tls_connector(
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
pub(super) struct EncryptOnly(Arc<CryptoProvider>);

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
pub(super) fn describe_connection(c: &Connection) -> String {
    format!("{} tls {}", describe_config(&c.config), c.mode.name())
}

/// `user@host:port/dbname`, for messages.
pub(super) fn describe_config(c: &Config) -> String {
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
pub(super) fn redact(url: &str) -> String {
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
