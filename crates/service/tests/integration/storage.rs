//! The record: batched commits seen by a second connection, and the CSV export's layout
//! checked against rows written by hand.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::sync::atomic::Ordering;
use std::sync::mpsc::sync_channel;
use std::sync::Arc;
use std::time::Duration;

use gearcomp_service::storage::{self, Record, StoreStats};
use proptest::prelude::*;

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn write_all(db: &std::path::Path, records: Vec<Record>) -> Arc<StoreStats> {
    let conn = storage::open(db).unwrap();
    storage::register_names(
        &conn,
        &names(&["a_c", "b_c"]),
        &names(&["X"]),
        &names(&["drift_um"]),
    )
    .unwrap();
    let (tx, rx) = sync_channel(1024);
    let stats = Arc::new(StoreStats::default());
    let s2 = stats.clone();
    let h = std::thread::spawn(move || {
        storage::writer_loop(conn, rx, Duration::from_millis(20), s2).unwrap()
    });
    for r in records {
        tx.send(r).unwrap();
    }
    drop(tx);
    h.join().unwrap();
    stats
}

#[test]
fn export_pivots_averages_with_latest_target_and_offset() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("e.db");
    let avg = |t: f64, c: u16, v: f64| Record::Average {
        time_s: t,
        channel: c,
        value: v,
    };
    let off = |t: f64, v: f64| Record::Offset {
        time_s: t,
        axis: 0,
        offset_um: v,
        target_um: v,
        law_um: v,
        status: "updated",
    };
    let tgt = |t: f64, v: f64| Record::Target {
        time_s: t,
        target: 0,
        value: v,
    };
    write_all(
        &db,
        vec![
            // t = 1: no target yet → the row is incomplete and left out.
            avg(1.0, 0, 20.0),
            avg(1.0, 1, 21.0),
            off(1.0, -1.0),
            tgt(1.5, 3.0),
            avg(2.0, 0, 20.5),
            avg(2.0, 1, 21.5),
            off(2.0, -2.0),
            // Target at 2.5 belongs to the row at 3; the offset at 3 too.
            tgt(2.5, 4.0),
            tgt(3.5, 5.0),
            avg(3.0, 0, 22.0),
            avg(3.0, 1, 23.0),
            off(3.0, -3.0),
        ],
    );
    let out = dir.path().join("log.csv");
    assert_eq!(storage::export_csv(&db, &out).unwrap(), 2);
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(
        text,
        "time_s,a_c,b_c,drift_um,X_offset_um\n2,20.5,21.5,3,-2\n3,22,23,4,-3\n"
    );
}

#[test]
fn committed_samples_are_visible_to_another_connection() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("c.db");
    let records: Vec<Record> = (0..5000)
        .map(|i| Record::Sample {
            time_s: i as f64 * 0.01,
            channel: (i % 2) as u16,
            raw: 20.0 + i as f64 * 1e-3,
        })
        .collect();
    let stats = write_all(&db, records);
    assert_eq!(stats.committed_samples.load(Ordering::Acquire), 5000);
    assert_eq!(stats.last_sample_id.load(Ordering::Acquire), 5000);
    let r = storage::open_read(&db).unwrap();
    assert_eq!(storage::count(&r, "samples").unwrap(), 5000);
    let mode: String = r
        .query_row("PRAGMA journal_mode", [], |row| row.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
    let pts = storage::channel_history(
        &r,
        1,
        storage::SeriesKind::Raw,
        storage::Range {
            from_s: 10.0,
            to_s: 10.1,
            limit: 100,
        },
    )
    .unwrap();
    // Odd samples i = 1001, 1003, …, 1009 lie in [10.0, 10.1] (float time: 10.01…10.09).
    let ts: Vec<f64> = pts.iter().map(|p| p.time_s).collect();
    assert_eq!(ts.len(), 5, "{ts:?}");
    assert!((pts[0].value.unwrap() - (20.0 + 1001.0e-3)).abs() < 1e-12);
}

#[test]
fn a_second_layout_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let db = dir.path().join("l.db");
    write_all(&db, vec![]);
    let conn = storage::open(&db).unwrap();
    let e = storage::register_names(&conn, &names(&["b_c", "a_c"]), &names(&["X"]), &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("channels[0]") && e.contains("b_c") && e.contains("a_c"),
        "{e}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(16))]
    #[test]
    fn any_values_round_trip_or_become_null(vals in proptest::collection::vec(any::<f64>(), 1..40)) {
        let dir = tempfile::tempdir().unwrap();
        let db = dir.path().join("p.db");
        let recs = vals.iter().enumerate().map(|(i, &v)| Record::Sample { time_s: i as f64, channel: 0, raw: v }).collect();
        write_all(&db, recs);
        let r = storage::open_read(&db).unwrap();
        let pts = storage::channel_history(&r, 0, storage::SeriesKind::Raw,
            storage::Range { from_s: f64::MIN, to_s: f64::MAX, limit: 1000 }).unwrap();
        prop_assert_eq!(pts.len(), vals.len());
        for (p, v) in pts.iter().zip(&vals) {
            if v.is_finite() { prop_assert_eq!(p.value, Some(*v)); } else { prop_assert_eq!(p.value, None); }
        }
    }
}
