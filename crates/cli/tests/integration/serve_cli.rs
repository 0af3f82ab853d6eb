//! `gearcomp serve` as a process: clean stop on SIGTERM, kill -9 mid-write and restart,
//! configuration errors, and the CSV export read back by `gearcomp fit`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use crate::common::{assert_grinder_law, gearcomp_cmd, temp_dir};

fn tmp(name: &str) -> PathBuf {
    temp_dir("serve", name)
}

fn bin() -> Command {
    gearcomp_cmd()
}

struct Served {
    child: Child,
    lines: Receiver<String>,
    base: String,
    operator: Option<String>,
    read_only: Option<String>,
}

/// Starts the service on a free loopback port and reads its first stdout lines.
// The child is handed back to the caller, which waits on it.
#[allow(clippy::zombie_processes)]
fn start(db: &Path, extra: &[&str]) -> Served {
    let mut child = bin()
        .args(["serve", "--port", "0", "--db"])
        .arg(db)
        .args(extra)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
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
    let (mut operator, mut read_only) = (None, None);
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let l = lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("the service printed its address");
        if let Some(t) = l.strip_prefix("operator token (shown once): ") {
            operator = Some(t.to_string());
        } else if let Some(t) = l.strip_prefix("read-only token (shown once): ") {
            read_only = Some(t.to_string());
        } else if let Some(i) = l.find("listening on http://") {
            let base = l[i + "listening on ".len()..].trim().to_string();
            assert!(base.starts_with("http://127.0.0.1:"), "{base}");
            return Served {
                child,
                lines,
                base,
                operator,
                read_only,
            };
        }
    }
}

fn status(s: &Served, token: &str) -> serde_json::Value {
    reqwest::blocking::Client::new()
        .get(format!("{}/api/status", s.base))
        .bearer_auth(token)
        .timeout(Duration::from_secs(5))
        .send()
        .unwrap()
        .json()
        .unwrap()
}

fn wait_committed(s: &Served, token: &str, at_least: u64) -> serde_json::Value {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let st = status(s, token);
        if st["committed_samples"].as_u64().unwrap() >= at_least {
            return st;
        }
        assert!(Instant::now() < deadline, "no samples committed: {st}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn sigterm_finishes_the_cycle_flushes_and_exits_0() {
    let dir = tmp("term");
    let db = dir.join("s.db");
    let mut s = start(&db, &["--speedup", "3000"]);
    let ro = s.read_only.clone().unwrap();
    assert!(s.operator.is_some());
    wait_committed(&s, &ro, 200);
    let pid = s.child.id().to_string();
    assert!(Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .unwrap()
        .success());
    let code = s.child.wait().unwrap();
    assert!(code.success(), "{code:?}");
    let last: Vec<String> = s.lines.try_iter().collect();
    let stopped = last
        .iter()
        .find(|l| l.contains("stopped;"))
        .expect("stop line");
    let n: u64 = stopped
        .split("stopped; ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .unwrap()
        .parse()
        .unwrap();
    // Every sample received was committed at the clean stop.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let rows: i64 = conn
        .query_row("SELECT COUNT(*) FROM samples", [], |r| r.get(0))
        .unwrap();
    assert_eq!(rows as u64, n);

    // Independent check of the recorded law (JPH0761598B2's Kz·(A − B), in common).
    assert_grinder_law(&db);
}

#[test]
fn kill_9_mid_write_loses_no_acknowledged_sample() {
    let dir = tmp("kill");
    let db = dir.join("k.db");
    // 20 000× speed-up: 2000 scans of 4 channels per second, written continuously.
    let mut s = start(&db, &["--speedup", "20000"]);
    let ro = s.read_only.clone().unwrap();
    let st = wait_committed(&s, &ro, 2000);
    let acked = st["committed_samples"].as_u64().unwrap();
    let last_id = st["last_sample_id"].as_u64().unwrap();
    s.child.kill().unwrap(); // SIGKILL: no flush, no clean-up
    s.child.wait().unwrap();

    let conn = rusqlite::Connection::open(&db).unwrap();
    let ok: String = conn
        .query_row("PRAGMA integrity_check", [], |r| r.get(0))
        .unwrap();
    assert_eq!(ok, "ok");
    let (count, max_id): (i64, i64) = conn
        .query_row("SELECT COUNT(*), MAX(id) FROM samples", [], |r| {
            Ok((r.get(0)?, r.get(1)?))
        })
        .unwrap();
    assert!(count as u64 >= acked, "{count} < {acked}");
    assert!(max_id as u64 >= last_id);
    let upto: i64 = conn
        .query_row(
            "SELECT COUNT(*) FROM samples WHERE id <= ?1",
            [last_id as i64],
            |r| r.get(0),
        )
        .unwrap();
    assert_eq!(
        upto as u64, last_id,
        "acknowledged ids 1…{last_id} all present"
    );
    let max_t: f64 = conn
        .query_row("SELECT MAX(time_s) FROM samples", [], |r| r.get(0))
        .unwrap();
    drop(conn);

    // Restart on the same record: no new tokens, the clock resumes after the record.
    let mut s2 = start(&db, &["--speedup", "20000", "--duration-s", "1"]);
    assert!(s2.operator.is_none() && s2.read_only.is_none());
    let st2 = status(&s2, &ro);
    assert!(st2["clock_origin_s"].as_f64().unwrap() > max_t);
    assert!(st2["committed_samples"].as_u64().unwrap() >= count as u64);
    assert!(s2.child.wait().unwrap().success());
}

#[test]
fn config_errors_name_the_key() {
    let dir = tmp("cfg");
    let cfg = dir.join("machine.toml");
    std::fs::write(&cfg, "[storage]\npath = \"x.db\"\ncomit_interval_s = 0.5\n").unwrap();
    let out = bin()
        .args(["serve", "--config"])
        .arg(&cfg)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("comit_interval_s"), "{err}");

    std::fs::write(&cfg, "[storage]\ncommit_interval_s = 5.0\n").unwrap();
    let out = bin()
        .args(["serve", "--config"])
        .arg(&cfg)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("storage.commit_interval_s") && err.contains('5') && err.contains("0.01…1 s"),
        "{err}"
    );
}

#[test]
fn export_is_read_by_gearcomp_fit() {
    let dir = tmp("fit");
    let db = dir.join("f.db");
    // About 3 simulated hours of the grinder in ~1.5 s.
    let mut s = start(&db, &["--speedup", "8000", "--duration-s", "1.5"]);
    assert!(s.child.wait().unwrap().success());
    let csv = dir.join("log.csv");
    let out = bin()
        .args(["serve", "--db"])
        .arg(&db)
        .arg("--export-csv")
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(
        header,
        "time_s,bed_top_c,wheel_head_c,column_c,oil_c,measured_drift_um,Z_offset_um"
    );
    assert!(text.lines().count() > 100);
    // The exact follow-up command `serve --help` prints, with its log.csv.
    let help = bin().args(["serve", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout).into_owned();
    let example = help
        .split("(then: gearcomp ")
        .nth(1)
        .and_then(|rest| rest.split(')').next())
        .unwrap_or_else(|| panic!("no follow-up example in serve --help: {help}"));
    let model = dir.join("model.toml");
    let example_args: Vec<std::ffi::OsString> = example
        .split_whitespace()
        .map(|w| {
            if w == "log.csv" {
                csv.clone().into_os_string()
            } else {
                w.into()
            }
        })
        .collect();
    let out = bin()
        .args(&example_args)
        .args(["--model", "static", "--out"])
        .arg(&model)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let m = std::fs::read_to_string(&model).unwrap();
    assert!(m.contains("measured_drift_um"), "{m}");
}
