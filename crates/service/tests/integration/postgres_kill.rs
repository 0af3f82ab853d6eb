//! Kill -9 of a service writing to PostgreSQL, then a restart on the same database: every
//! acknowledged sample is there, the clock resumes after the record, no new tokens.
//!
//! The service runs as a separate process: this test binary starts itself again with
//! `GEARCOMP_PG_CHILD` set, and that copy only runs [`child_service`].
#![cfg(feature = "postgres")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::postgres_common;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use gearcomp_service::{serve, Overrides, ServiceConfig};
use postgres_common::PgServer;

pub(crate) const CHILD_ENV: &str = "GEARCOMP_PG_CHILD";

/// In the child process: the service from the configuration file named by the variable.
#[test]
fn child_service() {
    let Ok(cfg_path) = std::env::var(CHILD_ENV) else {
        return; // the parent's run: nothing to do here
    };
    let duration_s = std::env::var("GEARCOMP_PG_CHILD_DURATION")
        .ok()
        .and_then(|d| d.parse().ok());
    let cfg = ServiceConfig::load(std::path::Path::new(&cfg_path)).unwrap();
    serve(
        cfg,
        Overrides {
            duration_s,
            ..Overrides::default()
        },
    )
    .unwrap();
}

pub(crate) struct Served {
    pub(crate) child: Child,
    base: String,
    pub(crate) read_only: Option<String>,
    _lines: Receiver<String>,
}

// The child is handed back to the caller, which waits on it.
#[allow(clippy::zombie_processes)]
pub(crate) fn spawn(cfg: &std::path::Path, duration_s: Option<f64>) -> Served {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.args([
        "--exact",
        // The test's name inside the crate's one integration-test binary.
        "postgres_kill::child_service",
        "--nocapture",
        "--test-threads",
        "1",
    ])
    .env(CHILD_ENV, cfg)
    .stdout(Stdio::piped())
    .stderr(Stdio::inherit());
    if let Some(d) = duration_s {
        cmd.env("GEARCOMP_PG_CHILD_DURATION", d.to_string());
    }
    let mut child = cmd.spawn().unwrap();
    let out = child.stdout.take().unwrap();
    let (tx, lines) = channel();
    std::thread::spawn(move || {
        for l in BufReader::new(out).lines() {
            let Ok(l) = l else { break };
            if tx.send(l).is_err() {
                break;
            }
        }
    });
    let mut read_only = None;
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let l = lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("the service printed its address");
        if let Some(t) = l.strip_prefix("read-only token (shown once): ") {
            read_only = Some(t.to_string());
        } else if let Some(i) = l.find("listening on http://") {
            assert!(l.contains("postgresql://postgres@127.0.0.1:"), "{l}");
            return Served {
                child,
                base: l[i + "listening on ".len()..].trim().to_string(),
                read_only,
                _lines: lines,
            };
        }
    }
}

pub(crate) fn status(s: &Served, token: &str) -> serde_json::Value {
    reqwest::blocking::Client::new()
        .get(format!("{}/api/status", s.base))
        .bearer_auth(token)
        .timeout(Duration::from_secs(5))
        .send()
        .unwrap()
        .json()
        .unwrap()
}

#[test]
fn kill_9_mid_write_loses_no_acknowledged_sample() {
    if std::env::var(CHILD_ENV).is_ok() {
        return;
    }
    let server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("machine.toml");
    std::fs::write(
        &cfg,
        format!(
            "[machine]\nname = \"kill-1\"\n[storage]\nbackend = \"postgres\"\nurl = \"{}\"\n\
             [http]\nport = 0\n[input]\nkind = \"simulator\"\nspeedup = 20000\n",
            server.url()
        ),
    )
    .unwrap();
    let mut s = spawn(&cfg, None);
    let ro = s.read_only.clone().unwrap();
    // Written continuously: 20 000× speed-up.
    let deadline = Instant::now() + Duration::from_secs(30);
    let st = loop {
        let st = status(&s, &ro);
        if st["committed_samples"].as_u64().unwrap() >= 2000 {
            break st;
        }
        assert!(Instant::now() < deadline, "no samples committed: {st}");
        std::thread::sleep(Duration::from_millis(50));
    };
    let acked = st["committed_samples"].as_u64().unwrap();
    let last_id = st["last_sample_id"].as_u64().unwrap();
    s.child.kill().unwrap(); // SIGKILL: no flush, no clean-up
    s.child.wait().unwrap();

    let mut c = server.client();
    let r = c
        .query_one(
            "SELECT COUNT(*), COALESCE(MAX(s.id), 0), MAX(s.time_s) FROM samples s \
             JOIN machines m ON m.id = s.machine_id WHERE m.name = 'kill-1'",
            &[],
        )
        .unwrap();
    let (count, max_id, max_t): (i64, i64, f64) = (r.get(0), r.get(1), r.get(2));
    assert!(count as u64 >= acked, "{count} < {acked}");
    assert!(max_id as u64 >= last_id);
    let upto: i64 = c
        .query_one(
            "SELECT COUNT(*) FROM samples s JOIN machines m ON m.id = s.machine_id \
             WHERE m.name = 'kill-1' AND s.id <= $1",
            &[&(last_id as i64)],
        )
        .unwrap()
        .get(0);
    assert_eq!(
        upto as u64, last_id,
        "acknowledged ids 1…{last_id} all present"
    );
    // Ids are contiguous: whatever committed after the last status is complete too.
    assert_eq!(count, max_id);

    // Restart on the same database: no new tokens, the clock resumes after the record,
    // the sample ids continue.
    let mut s2 = spawn(&cfg, Some(1.0));
    assert!(s2.read_only.is_none());
    let st2 = status(&s2, &ro);
    assert!(st2["clock_origin_s"].as_f64().unwrap() > max_t);
    assert!(st2["committed_samples"].as_u64().unwrap() >= count as u64);
    assert!(s2.child.wait().unwrap().success());
    let (n2, max2): (i64, i64) = {
        let r = c
            .query_one(
                "SELECT COUNT(*), MAX(s.id) FROM samples s JOIN machines m \
                 ON m.id = s.machine_id WHERE m.name = 'kill-1'",
                &[],
            )
            .unwrap();
        (r.get(0), r.get(1))
    };
    assert!(n2 > count);
    assert_eq!(n2, max2);
}
