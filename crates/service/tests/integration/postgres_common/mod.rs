//! A real PostgreSQL server for the tests and the benchmark, started from scratch in a
//! temporary folder (initdb, then postgres on a free loopback port) and stopped when the
//! guard is dropped. As root, initdb and postgres run as the `postgres` system user.
//!
//! The server runs under `sh`, which stops it when its stdin closes, so even a test
//! process that dies without unwinding leaves no server behind.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::time::{Duration, Instant};

/// Where initdb and postgres are, or None.
pub fn find_bin_dir() -> Option<PathBuf> {
    let on_path = std::env::var_os("PATH").and_then(|p| {
        std::env::split_paths(&p)
            .map(|d| d.join("initdb"))
            .find(|f| f.is_file())
    });
    let found = on_path.or_else(|| {
        let mut v: Vec<PathBuf> = std::fs::read_dir("/usr/lib/postgresql")
            .ok()?
            .filter_map(|e| e.ok())
            .map(|e| e.path().join("bin/initdb"))
            .filter(|f| f.is_file())
            .collect();
        v.sort();
        v.pop()
    })?;
    let real = std::fs::canonicalize(&found).unwrap_or(found);
    let dir = real.parent()?.to_path_buf();
    dir.join("postgres").is_file().then_some(dir)
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

/// Runs a command as the `postgres` user when we are root.
fn as_pg_user(program: &Path) -> Command {
    if is_root() {
        let mut c = Command::new("runuser");
        c.args(["-u", "postgres", "--"]).arg(program);
        c
    } else {
        Command::new(program)
    }
}

/// A running server; stopped (and its folder removed) on drop.
pub struct PgServer {
    /// TCP port on 127.0.0.1.
    pub port: u16,
    bin: PathBuf,
    dir: tempfile::TempDir,
    child: Option<(Child, ChildStdin)>,
    /// Extra `-c name=value` settings (e.g. `ssl=on`).
    settings: Vec<String>,
}

/// The server's TLS certificate chain and private key (PEM), for [`PgServer::try_start_tls`].
pub struct ServerTls {
    /// Certificate (chain) PEM.
    pub cert_pem: String,
    /// Private key PEM.
    pub key_pem: String,
}

impl PgServer {
    /// initdb + start; panics with the fix when PostgreSQL is not installed.
    pub fn start() -> Self {
        Self::try_start().unwrap_or_else(|e| panic!("{e}"))
    }

    /// As [`PgServer::start`], returning why it could not start.
    pub fn try_start() -> Result<Self, String> {
        Self::try_start_with(None, &[])
    }

    /// As [`PgServer::try_start`] with extra `-c name=value` settings (they override the
    /// defaults here, e.g. `max_connections=1040` for the plant benchmark).
    pub fn try_start_settings(extra: &[String]) -> Result<Self, String> {
        Self::try_start_with(None, extra)
    }

    /// As [`PgServer::try_start`] with `ssl = on` and this certificate and key (written in
    /// the server's folder, mode 0600, owned by the server's user as PostgreSQL demands).
    pub fn try_start_tls(tls: ServerTls) -> Result<Self, String> {
        Self::try_start_with(Some(tls), &[])
    }

    fn try_start_with(tls: Option<ServerTls>, extra: &[String]) -> Result<Self, String> {
        let bin = find_bin_dir().ok_or(
            "PostgreSQL's initdb was not found on PATH or in /usr/lib/postgresql/*/bin: \
             run .ci/run, it installs postgresql",
        )?;
        let dir = tempfile::Builder::new()
            .prefix("gearcomp-pg-")
            .tempdir()
            .map_err(|e| e.to_string())?;
        let mut settings = extra.to_vec();
        if let Some(t) = tls {
            use std::os::unix::fs::PermissionsExt;
            let cert = dir.path().join("server.crt");
            let key = dir.path().join("server.key");
            std::fs::write(&cert, t.cert_pem).map_err(|e| e.to_string())?;
            std::fs::write(&key, t.key_pem).map_err(|e| e.to_string())?;
            std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600))
                .map_err(|e| e.to_string())?;
            settings.push("ssl=on".to_string());
            settings.push(format!("ssl_cert_file={}", cert.display()));
            settings.push(format!("ssl_key_file={}", key.display()));
        }
        if is_root() {
            let ok = Command::new("chown")
                .args(["-R", "postgres:postgres"])
                .arg(dir.path())
                .status()
                .map_err(|e| e.to_string())?
                .success();
            if !ok {
                return Err("chown of the data folder to postgres failed".into());
            }
        }
        let out = as_pg_user(&bin.join("initdb"))
            .args(["-A", "trust", "-U", "postgres", "-E", "UTF8", "--no-sync"])
            .args(["--locale", "C", "-D"])
            .arg(dir.path().join("data"))
            .output()
            .map_err(|e| format!("initdb: {e}"))?;
        if !out.status.success() {
            return Err(format!(
                "initdb failed: {}",
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .map_err(|e| e.to_string())?
            .port();
        let mut s = Self {
            port,
            bin,
            dir,
            child: None,
            settings,
        };
        s.launch()?;
        Ok(s)
    }

    fn launch(&mut self) -> Result<(), String> {
        let data = self.dir.path().join("data");
        let extra: String = self.settings.iter().map(|s| format!(" -c '{s}'")).collect();
        let script = format!(
            "'{}' -D '{}' -k '{}' -p {} -c listen_addresses=127.0.0.1 -c max_connections=50 \
             -c shared_buffers=32MB{extra} & pid=$!; read _; kill -INT $pid; wait $pid",
            self.bin.join("postgres").display(),
            data.display(),
            self.dir.path().display(),
            self.port
        );
        let mut cmd = as_pg_user(Path::new("/bin/sh"));
        let mut child = cmd
            .args(["-c", &script])
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| format!("postgres: {e}"))?;
        let stdin = child.stdin.take().ok_or("no stdin")?;
        self.child = Some((child, stdin));
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            if postgres::Client::connect(&self.url(), postgres::NoTls).is_ok() {
                return Ok(());
            }
            if Instant::now() > deadline {
                return Err("postgres did not accept connections within 30 s".into());
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// The connection URL of the `postgres` database.
    pub fn url(&self) -> String {
        format!("postgresql://postgres@127.0.0.1:{}/postgres", self.port)
    }

    /// Fast shutdown (SIGINT: sessions ended, everything committed flushed); waits.
    pub fn stop(&mut self) {
        if let Some((mut child, mut stdin)) = self.child.take() {
            let _ = stdin.write_all(b"\n");
            drop(stdin);
            let _ = child.wait();
        }
    }

    /// Starts the stopped server again on the same folder and port.
    pub fn restart(&mut self) {
        self.launch().unwrap();
    }

    /// A client of the `postgres` database.
    pub fn client(&self) -> postgres::Client {
        postgres::Client::connect(&self.url(), postgres::NoTls).unwrap()
    }
}

impl Drop for PgServer {
    fn drop(&mut self) {
        self.stop();
    }
}
