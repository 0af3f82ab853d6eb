//! Alarm rows stay few when a fault comes and goes from step to step: the built-in
//! simulator at a speed-up of 3·10⁵ (a millisecond of scheduling delay is 300 s of service
//! time, so the stale check trips and recovers at random) for a few seconds of wall time.
//! Asserted on the record: every channel alarm row lasted, or is still open; per channel
//! and fault at most one new row per CHANNEL_CLEAR_HOLD of wall time (before the hold,
//! such a run wrote thousands of rows: 7,260 in 10 s were reported).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::time::{Duration, Instant};

use common::{start_with, Api};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_flickering_fault_is_one_alarm_per_hold_not_one_per_step() {
    let dir = tempfile::tempdir().unwrap();
    let run = start_with(
        dir.path(),
        "[http]\nport = 0\n[storage]\npath = \"fast.db\"\n[input]\nkind = \"simulator\"\nspeedup = 300000.0\n",
    )
    .await;
    let t0 = Instant::now();
    tokio::time::sleep(Duration::from_secs(4)).await;
    // Sample→offset latency in /api/status: counted for the scans, p50 ≤ p99, both
    // positive and far below a second (the step itself takes microseconds).
    let ro = run.generated.clone().unwrap().read_only;
    let (_, st) = Api::new(&run).get("/api/status", Some(&ro)).await;
    let lat = &st["latency"];
    let (p50, p99) = (
        lat["p50_s"].as_f64().unwrap(),
        lat["p99_s"].as_f64().unwrap(),
    );
    eprintln!(
        "latency over {} scans: p50 {p50:.2e} s, p99 {p99:.2e} s",
        lat["scans"]
    );
    assert!(lat["scans"].as_u64().unwrap() > 100, "{st}");
    assert!(0.0 < p50 && p50 <= p99 && p99 < 1.0, "{st}");
    let db = run.db.clone();
    run.stop().await.unwrap();
    let wall_s = t0.elapsed().as_secs_f64();
    let conn = gearcomp_service::storage::open_read(&db).unwrap();
    let cycles: i64 = conn
        .query_row("SELECT COUNT(DISTINCT time_s) FROM offsets", [], |r| {
            r.get(0)
        })
        .unwrap();
    let mut st = conn
        .prepare("SELECT key, COUNT(*) FROM alarms WHERE key LIKE 'channel.%' GROUP BY key")
        .unwrap();
    let rows: Vec<(String, i64)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    let total: i64 = rows.iter().map(|r| r.1).sum();
    eprintln!("{cycles} cycles recorded in {wall_s:.1} s; channel alarm rows: {total} {rows:?}");
    // One row per key per second of wall time at most (the hold), plus the first.
    let bound =
        (wall_s / gearcomp_service::alarms::CHANNEL_CLEAR_HOLD.as_secs_f64()).ceil() as i64 + 1;
    for (key, n) in &rows {
        assert!(
            *n <= bound,
            "{key}: {n} rows in {wall_s:.1} s (bound {bound})"
        );
    }
}
