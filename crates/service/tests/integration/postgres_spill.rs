//! The spill file (`storage.spill_path`): an outage longer than `storage.buffer_records`
//! loses no sample, also across a kill -9 during the outage; the configuration errors
//! name the key. (The fallback when the spill cannot be written is in `postgres.rs`.)
#![cfg(feature = "postgres")]
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::postgres_common;
use crate::postgres_kill::{spawn, status, CHILD_ENV};

use std::collections::HashSet;
use std::sync::atomic::Ordering;
use std::sync::mpsc::sync_channel;
use std::sync::Arc;
use std::time::{Duration, Instant};

use gearcomp_service::config::StorageBackend;
use gearcomp_service::cycle::Clock;
use gearcomp_service::storage::{open_store, Record, StoreStats, WriterParams};
use gearcomp_service::ServiceConfig;
use postgres_common::PgServer;

fn wait_until(what: &str, secs: u64, mut f: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(secs);
    while !f() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Rows of the spill file: all, and the samples' `(time_s, channel)` in file order;
/// nothing while the writer has not created it yet (read-only: the test never creates it).
fn spill_rows(path: &std::path::Path) -> (i64, Vec<(f64, i64)>) {
    let flags = rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY;
    let Ok(db) = rusqlite::Connection::open_with_flags(path, flags) else {
        return (0, Vec::new());
    };
    let Ok(n) = db.query_row("SELECT COUNT(*) FROM records", [], |r| r.get(0)) else {
        return (0, Vec::new());
    };
    let mut st = db
        .prepare("SELECT time_s, i FROM records WHERE kind = 0 ORDER BY seq")
        .unwrap();
    let samples = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .collect::<Result<Vec<_>, _>>()
        .unwrap();
    (n, samples)
}

/// `(id, time_s, channel)` of a machine's samples in PostgreSQL, by id.
fn pg_samples(server: &PgServer, machine: &str) -> Vec<(i64, f64, i32)> {
    server
        .client()
        .query(
            "SELECT s.id, s.time_s, s.channel FROM samples s JOIN machines m \
             ON m.id = s.machine_id WHERE m.name = $1 ORDER BY s.id",
            &[&machine],
        )
        .unwrap()
        .iter()
        .map(|r| (r.get(0), r.get(1), r.get(2)))
        .collect()
}

#[test]
fn an_outage_of_six_times_the_buffer_spills_and_loses_no_sample() {
    let mut server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let spill = dir.path().join("spill.db");
    let mut cfg = ServiceConfig::default();
    cfg.machine.name = "spill-a".into();
    cfg.storage.backend = StorageBackend::Postgres;
    cfg.storage.url = Some(server.url());
    cfg.storage.spill_path = Some(spill.clone());
    cfg.storage.buffer_records = 1000; // the smallest allowed
    cfg.storage.reconnect.min_s = 0.05;
    cfg.storage.reconnect.max_s = 0.2;
    let store = open_store(&cfg).unwrap();
    store
        .register_names(&["a_c".to_string()], &["X".to_string()], &[])
        .unwrap();
    let stats = Arc::new(StoreStats::default());
    let (tx, rx) = sync_channel(1 << 16);
    let h = store
        .spawn_writer(
            rx,
            WriterParams {
                commit_interval: Duration::from_millis(20),
                clock: Clock::new(0.0, 1.0),
            },
            stats.clone(),
        )
        .unwrap();
    let send = |i: usize| {
        tx.send(Record::Sample {
            time_s: i as f64,
            channel: 0,
            raw: i as f64 * 0.25,
        })
        .unwrap();
        if i.is_multiple_of(300) {
            tx.send(Record::Average {
                time_s: i as f64,
                channel: 0,
                value: 1.0,
            })
            .unwrap();
        }
    };
    (0..100).for_each(send);
    wait_until("the first samples", 10, || {
        stats.committed_samples.load(Ordering::Acquire) == 100
    });
    server.stop();
    // 6000 samples (6 × the bound) and 20 averages while the server is down.
    const N: usize = 6100;
    (100..N).for_each(send);
    wait_until("the spill", 10, || {
        stats.unreachable.load(Ordering::Acquire)
            && stats.spilled_records.load(Ordering::Acquire) >= 5000
    });
    // Committed to the file, not only staged in memory.
    wait_until("the spill commit", 10, || spill_rows(&spill).0 >= 5000);
    server.restart();
    wait_until("the drain", 30, || {
        !stats.unreachable.load(Ordering::Acquire)
            && stats.spilled_records.load(Ordering::Acquire) == 0
            && stats.buffered_records.load(Ordering::Acquire) == 0
    });
    drop(tx);
    h.join().unwrap().unwrap();

    // Every sample, ids 1…N contiguous, in arrival (time) order, nothing dropped.
    let rows = pg_samples(&server, "spill-a");
    assert_eq!(rows.len(), N);
    for (k, (id, t, ch)) in rows.iter().enumerate() {
        assert_eq!((*id, *t, *ch), (k as i64 + 1, k as f64, 0));
    }
    assert_eq!(stats.dropped_records.load(Ordering::Acquire), 0);
    assert_eq!(stats.committed_samples.load(Ordering::Acquire), N as u64);
    let averages = store
        .channel_history(
            0,
            gearcomp_service::storage::SeriesKind::Average,
            gearcomp_service::storage::Range {
                from_s: f64::MIN,
                to_s: f64::MAX,
                limit: 1000,
            },
        )
        .unwrap();
    let times: Vec<f64> = averages.iter().map(|p| p.time_s).collect();
    let want: Vec<f64> = (0..N).step_by(300).map(|i| i as f64).collect();
    assert_eq!(times, want);
    let alarms = store.alarms(false, 50).unwrap();
    let keys: Vec<&str> = alarms.iter().map(|a| a.key.as_str()).collect();
    assert!(!keys.contains(&"storage.records_dropped"), "{keys:?}");
    assert!(!keys.contains(&"storage.buffer_full"), "{keys:?}");
    let spilling = alarms
        .iter()
        .find(|a| a.key == "storage.spilling")
        .expect("storage.spilling raised");
    assert!(
        spilling.message.contains("spill file") && spilling.message.contains("so far"),
        "{}",
        spilling.message
    );
    assert!(spilling.cleared_s.is_some(), "cleared once drained");
    assert!(alarms.iter().all(|a| a.cleared_s.is_some()), "{alarms:?}");
    // Only deleted from the file once PostgreSQL had them: the file is empty now.
    assert_eq!(spill_rows(&spill).0, 0);
}

#[test]
fn kill_9_while_spilling_then_restart_writes_every_spilled_sample_once() {
    if std::env::var(CHILD_ENV).is_ok() {
        return;
    }
    let mut server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("machine.toml");
    std::fs::write(
        &cfg,
        format!(
            "[machine]\nname = \"spill-kill\"\n[storage]\nbackend = \"postgres\"\nurl = \"{}\"\n\
             buffer_records = 1000\ncommit_interval_s = 0.1\n\
             reconnect = {{ min_s = 0.05, max_s = 0.3 }}\n\
             [http]\nport = 0\n[input]\nkind = \"simulator\"\nspeedup = 20000\n",
            server.url()
        ),
    )
    .unwrap();
    // The default spill file: next to the configuration, named after the machine.
    let spill = dir.path().join("gearcomp-spill-spill-kill.db");
    let mut s = spawn(&cfg, None);
    let ro = s.read_only.clone().unwrap();
    wait_until("the first commits", 30, || {
        status(&s, &ro)["committed_samples"].as_u64().unwrap() >= 500
    });
    server.stop();
    wait_until("the spill", 30, || {
        status(&s, &ro)["storage"]["spilled_records"]
            .as_u64()
            .unwrap()
            >= 5000
    });
    std::thread::sleep(Duration::from_millis(300));
    s.child.kill().unwrap(); // SIGKILL while records are spilled
    s.child.wait().unwrap();
    let (_, spilled) = spill_rows(&spill);
    assert!(spilled.len() >= 4000, "{}", spilled.len());

    server.restart();
    let mut s2 = spawn(&cfg, Some(1.0));
    assert!(s2.child.wait().unwrap().success());

    let rows = pg_samples(&server, "spill-kill");
    // Ids 1…N contiguous, times never going back, each (time, channel) once.
    for (k, (id, _, _)) in rows.iter().enumerate() {
        assert_eq!(*id, k as i64 + 1);
    }
    for w in rows.windows(2) {
        assert!(w[1].1 >= w[0].1, "time goes back at id {}", w[1].0);
    }
    let seen: HashSet<(u64, i32)> = rows.iter().map(|r| (r.1.to_bits(), r.2)).collect();
    assert_eq!(seen.len(), rows.len(), "a sample written twice");
    // Every sample the spill had committed is in PostgreSQL.
    for (t, ch) in &spilled {
        assert!(
            seen.contains(&(t.to_bits(), *ch as i32)),
            "spilled sample ({t}, {ch}) missing"
        );
    }
    // More than the spill: the second run recorded too; the file is drained.
    assert!(rows.len() > spilled.len());
    assert_eq!(spill_rows(&spill).0, 0);
}

#[test]
fn spill_path_errors_name_the_key_and_the_default_follows_the_machine() {
    let sqlite = ServiceConfig::from_toml_str("[storage]\nspill_path = \"x.db\"\n", "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        sqlite.contains("storage.spill_path") && sqlite.contains("sqlite"),
        "{sqlite}"
    );
    let pg = "[storage]\nbackend = \"postgres\"\nurl = \"postgresql://gc@db/plant\"\n";
    let empty = ServiceConfig::from_toml_str(&format!("{pg}spill_path = \"\"\n"), "m.toml")
        .unwrap_err()
        .to_string();
    assert!(empty.contains("storage.spill_path"), "{empty}");
    let dir = tempfile::tempdir().unwrap();
    let folder = ServiceConfig::from_toml_str(
        &format!("{pg}spill_path = {:?}\n", dir.path().display().to_string()),
        "m.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(folder.contains("storage.spill_path"), "{folder}");

    // Default: in the configuration's folder, named after the machine; relative paths
    // are taken from that folder like the other paths.
    let file = dir.path().join("m.toml");
    std::fs::write(&file, format!("[machine]\nname = \"gs300-7\"\n{pg}")).unwrap();
    let cfg = ServiceConfig::load(&file).unwrap();
    assert_eq!(
        cfg.storage.spill_path,
        Some(dir.path().join("gearcomp-spill-gs300-7.db"))
    );
    std::fs::write(&file, format!("{pg}spill_path = \"spill/a.db\"\n")).unwrap();
    let cfg = ServiceConfig::load(&file).unwrap();
    assert_eq!(cfg.storage.spill_path, Some(dir.path().join("spill/a.db")));
}

#[test]
fn a_clean_stop_during_the_outage_keeps_memory_and_spill_for_the_next_start() {
    let mut server = PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let spill = dir.path().join("spill.db");
    let mut cfg = ServiceConfig::default();
    cfg.machine.name = "spill-stop".into();
    cfg.storage.backend = StorageBackend::Postgres;
    cfg.storage.url = Some(server.url());
    cfg.storage.spill_path = Some(spill.clone());
    cfg.storage.buffer_records = 1000;
    cfg.storage.reconnect.min_s = 0.05;
    cfg.storage.reconnect.max_s = 0.2;
    let params = || WriterParams {
        commit_interval: Duration::from_millis(20),
        clock: Clock::new(0.0, 1.0),
    };
    let store = open_store(&cfg).unwrap();
    store
        .register_names(&["a_c".to_string()], &["X".to_string()], &[])
        .unwrap();
    let stats = Arc::new(StoreStats::default());
    let (tx, rx) = sync_channel(1 << 16);
    let h = store.spawn_writer(rx, params(), stats.clone()).unwrap();
    server.stop();
    for i in 0..3000 {
        tx.send(Record::Sample {
            time_s: i as f64,
            channel: 0,
            raw: 0.5,
        })
        .unwrap();
    }
    wait_until("the spill", 10, || spill_rows(&spill).0 >= 1900);
    // The stop gives up after its 10 s of retries: memory joins the spill, no error.
    drop(tx);
    h.join().unwrap().unwrap();
    let (rows, samples) = spill_rows(&spill);
    assert_eq!(samples.len(), 3000, "{rows} rows");
    let times: Vec<f64> = samples.iter().map(|s| s.0).collect();
    assert_eq!(times, (0..3000).map(f64::from).collect::<Vec<_>>());
    drop(store);

    server.restart();
    let store = open_store(&cfg).unwrap();
    let stats = Arc::new(StoreStats::default());
    let (tx, rx) = sync_channel(1 << 16);
    let h = store.spawn_writer(rx, params(), stats.clone()).unwrap();
    drop(tx);
    h.join().unwrap().unwrap();
    let rows = pg_samples(&server, "spill-stop");
    assert_eq!(rows.len(), 3000);
    for (k, (id, t, _)) in rows.iter().enumerate() {
        assert_eq!((*id, *t), (k as i64 + 1, k as f64));
    }
    assert_eq!(spill_rows(&spill).0, 0);
}
