//! Several machines in one `gearcomp serve` process: each with its own engine, record,
//! tokens and HTTP API; one SIGTERM stops and flushes them all; configurations that would
//! share a name, a record or a port are refused before anything starts.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc::channel;
use std::time::{Duration, Instant};

use crate::common::{assert_grinder_law, gearcomp_cmd, temp_dir};

fn tmp(name: &str) -> PathBuf {
    temp_dir("many", name)
}

fn bin() -> Command {
    gearcomp_cmd()
}

fn machine_toml(dir: &Path, file: &str, name: &str, preset: &str, db: &str) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(
        &p,
        format!(
            "[machine]\nname = \"{name}\"\n[storage]\npath = \"{db}\"\n[http]\nport = 0\n\
             [input]\nkind = \"simulator\"\npreset = \"{preset}\"\nspeedup = 3000.0\n"
        ),
    )
    .unwrap();
    p
}

/// One announced machine: its API base and its generated tokens.
#[derive(Debug, Clone)]
struct Announced {
    base: String,
    operator: String,
    read_only: String,
}

fn get(base: &str, path: &str, token: &str) -> reqwest::blocking::Response {
    reqwest::blocking::Client::new()
        .get(format!("{base}{path}"))
        .bearer_auth(token)
        .timeout(Duration::from_secs(5))
        .send()
        .unwrap()
}

fn channel_names(db: &Path) -> Vec<String> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT name FROM channels ORDER BY idx")
        .unwrap();
    let names = st
        .query_map([], |r| r.get(0))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    names
}

#[test]
fn two_machines_run_apart_in_one_process_and_stop_together() {
    let dir = tmp("two");
    let a = machine_toml(&dir, "a.toml", "grinder_a", "grinder", "a.db");
    let b = machine_toml(&dir, "b.toml", "shaper_b", "shaper", "b.db");
    let mut child = bin()
        .args(["serve", "--config"])
        .arg(&a)
        .arg("--config")
        .arg(&b)
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
    // Tokens are printed just before the line of the machine they belong to.
    let mut machines: HashMap<String, Announced> = HashMap::new();
    let (mut operator, mut read_only) = (None, None);
    let deadline = Instant::now() + Duration::from_secs(60);
    while machines.len() < 2 {
        let l = lines
            .recv_timeout(deadline.saturating_duration_since(Instant::now()))
            .expect("both machines announced");
        if let Some(t) = l.strip_prefix("operator token (shown once): ") {
            operator = Some(t.to_string());
        } else if let Some(t) = l.strip_prefix("read-only token (shown once): ") {
            read_only = Some(t.to_string());
        } else if let Some(i) = l.find("listening on http://") {
            let name = l
                .strip_prefix("gearcomp serve: machine ")
                .and_then(|r| r.split(' ').next())
                .unwrap()
                .to_string();
            machines.insert(
                name,
                Announced {
                    base: l[i + "listening on ".len()..].trim().to_string(),
                    operator: operator.take().unwrap(),
                    read_only: read_only.take().unwrap(),
                },
            );
        }
    }
    let (ga, sb) = (&machines["grinder_a"], &machines["shaper_b"]);
    assert_ne!(ga.base, sb.base);
    assert_ne!(ga.operator, sb.operator);

    // Each API serves its own machine and knows only its own tokens.
    for (name, m) in [("grinder_a", ga), ("shaper_b", sb)] {
        let deadline = Instant::now() + Duration::from_secs(30);
        loop {
            let st: serde_json::Value = get(&m.base, "/api/status", &m.read_only).json().unwrap();
            assert_eq!(st["machine"], name, "{st}");
            if st["committed_samples"].as_u64().unwrap() >= 200 {
                break;
            }
            assert!(
                Instant::now() < deadline,
                "{name}: no samples committed: {st}"
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    assert_eq!(get(&ga.base, "/api/status", &sb.read_only).status(), 401);
    assert_eq!(get(&sb.base, "/api/status", &ga.operator).status(), 401);

    let pid = child.id().to_string();
    assert!(Command::new("kill")
        .args(["-TERM", &pid])
        .status()
        .unwrap()
        .success());
    let code = child.wait().unwrap();
    assert!(code.success(), "{code:?}");
    let stops: HashMap<String, u64> = lines
        .try_iter()
        .filter_map(|l| {
            let rest = l.strip_prefix("gearcomp serve: machine ")?;
            let (name, rest) = rest.split_once(" stopped; ")?;
            Some((name.to_string(), rest.split(' ').next()?.parse().ok()?))
        })
        .collect();
    assert_eq!(stops.len(), 2, "{stops:?}");

    // Every sample each machine received is in its own record, and only there.
    for (name, db) in [
        ("grinder_a", dir.join("a.db")),
        ("shaper_b", dir.join("b.db")),
    ] {
        let conn = rusqlite::Connection::open(&db).unwrap();
        let rows: i64 = conn
            .query_row("SELECT COUNT(*) FROM samples", [], |r| r.get(0))
            .unwrap();
        assert_eq!(rows as u64, stops[name], "{name}");
    }
    let (ca, cb) = (
        channel_names(&dir.join("a.db")),
        channel_names(&dir.join("b.db")),
    );
    assert!(ca.iter().any(|c| c == "bed_top_c"), "{ca:?}");
    assert!(!ca.iter().any(|c| c == "proximity_um"), "{ca:?}");
    assert!(cb.iter().any(|c| c == "proximity_um"), "{cb:?}");

    // The grinder's record still follows its own law (JPH0761598B2's Kz·(A − B)): the second
    // machine in the process did not leak into it.
    assert_grinder_law(&dir.join("a.db"));
}

fn refused(args: &[&std::ffi::OsStr]) -> String {
    let out = bin().arg("serve").args(args).output().unwrap();
    assert!(!out.status.success());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn machines_that_would_share_a_name_record_or_port_are_refused() {
    let dir = tmp("clash");
    let a = machine_toml(&dir, "a.toml", "m1", "grinder", "a.db");
    let same_name = machine_toml(&dir, "b.toml", "m1", "shaper", "b.db");
    let same_db = machine_toml(&dir, "c.toml", "m3", "shaper", "a.db");
    let ok = machine_toml(&dir, "d.toml", "m4", "shaper", "d.db");
    let cfg = |p: &PathBuf| p.as_os_str().to_owned();
    let c = std::ffi::OsString::from("--config");

    let err = refused(&[&c, &cfg(&a), &c, &cfg(&same_name)]);
    assert!(
        err.contains("machine.name") && err.contains("a.toml") && err.contains("b.toml"),
        "{err}"
    );
    let err = refused(&[&c, &cfg(&a), &c, &cfg(&same_db)]);
    assert!(
        err.contains("storage.path") && err.contains("a.db") && err.contains("c.toml"),
        "{err}"
    );
    let port = std::ffi::OsString::from("--port");
    let zero = std::ffi::OsString::from("0");
    let err = refused(&[&c, &cfg(&a), &c, &cfg(&ok), &port, &zero]);
    assert!(err.contains("--port") && err.contains("http.port"), "{err}");

    // Two fixed, equal ports.
    std::fs::write(
        &ok,
        "[machine]\nname = \"m4\"\n[storage]\npath = \"d.db\"\n[http]\nport = 18080\n",
    )
    .unwrap();
    let e = dir.join("e.toml");
    std::fs::write(
        &e,
        "[machine]\nname = \"m5\"\n[storage]\npath = \"e.db\"\n[http]\nport = 18080\n",
    )
    .unwrap();
    let err = refused(&[&c, &cfg(&ok), &c, &cfg(&e)]);
    assert!(err.contains("http.port") && err.contains("18080"), "{err}");
    // Nothing was started: no record was created.
    assert!(!dir.join("d.db").exists() && !dir.join("e.db").exists());
}
