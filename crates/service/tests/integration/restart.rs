//! Bumpless restart (issue 14 item 1): a restart of `serve` under load resumes from the
//! offset it last applied and the engine's state kept in the record, so the record shows
//! no step larger than the rate limit across the restart, and nothing but a valid offset
//! leaves at start.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::time::{Duration, Instant};

use crate::common::{start_with, Api};
use gearcomp_service::service::Running;
use gearcomp_service::storage::{OffsetRow, Range, Store};
use std::sync::Arc;

/// The hobbing preset's rate limit (`max_step_um`), µm per cycle; its axis applies only at
/// safe points.
const RATE_UM: f64 = 0.5;

fn config(storage: &str) -> String {
    format!(
        "[machine]\nname = \"hob-1\"\n[engine]\npreset = \"hobbing\"\n[http]\nport = 0\n\
         {storage}\n[input]\nkind = \"simulator\"\nspeedup = 3000\n"
    )
}

fn history(store: &Arc<dyn Store>) -> Vec<OffsetRow> {
    // The PostgreSQL store's client blocks: off the async workers.
    tokio::task::block_in_place(|| {
        store
            .offset_history(Range {
                from_s: f64::NEG_INFINITY,
                to_s: f64::INFINITY,
                limit: 10_000_000,
            })
            .unwrap()
    })
}

/// Waits until the first axis's applied offset is at least `um` in magnitude.
async fn wait_offset(run: &Running, um: f64, secs: f64) -> f64 {
    let ro = run.generated.clone().map(|g| g.read_only);
    let api = Api::new(run);
    let deadline = Instant::now() + Duration::from_secs_f64(secs);
    loop {
        let (_, st) = api.get("/api/status", ro.as_deref()).await;
        let y = st["axes"][0]["offset_um"].as_f64().unwrap_or(0.0);
        if y.abs() >= um {
            return y;
        }
        assert!(Instant::now() < deadline, "offset still {y} µm: {st}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

async fn restart_under_load(dir: &std::path::Path, storage: &str) {
    let run = start_with(dir, &config(storage)).await;
    let token = run.generated.clone().unwrap().read_only;
    wait_offset(&run, 3.0, 90.0).await;
    run.stop().await.unwrap();

    // Second run on the same record (tokens kept from the first start).
    let run = start_with(dir, &config(storage)).await;
    let api = Api::new(&run);
    let before = history(&run.store);
    let last1 = before
        .iter()
        .rev()
        .find(|r| r.axis == before[0].axis)
        .unwrap()
        .clone();
    let y1 = last1.offset_um.unwrap();
    assert!(y1.abs() >= 3.0, "offset before the restart {y1}");
    // Run until the engine has moved the offset under its new (cold) simulator.
    api.wait_for("/api/status", &token, 90.0, |v| {
        let y = v["axes"][0]["offset_um"].as_f64().unwrap_or(y1);
        (y - y1).abs() >= 2.0 * RATE_UM
    })
    .await;
    let store = run.store.clone();
    run.stop().await.unwrap();
    let rows: Vec<OffsetRow> = history(&store)
        .into_iter()
        .filter(|r| r.axis == last1.axis)
        .collect();
    let after: Vec<&OffsetRow> = rows.iter().filter(|r| r.time_s > last1.time_s).collect();
    assert!(after.len() >= 2, "{} rows after the restart", after.len());
    // The first row of the new run: the resumed offset (or one rate step from it), never
    // the starting 0.
    let first = after[0];
    assert_ne!(first.status, "starting", "{first:?}");
    let y2 = first.offset_um.unwrap();
    assert!(
        (y2 - y1).abs() <= RATE_UM + 1e-9,
        "restart stepped the offset: {y1} µm at {} s → {y2} µm at {} s",
        last1.time_s,
        first.time_s
    );
    // Every cycle of both runs and across the restart within the rate limit.
    let mut worst = 0.0f64;
    for w in rows.windows(2) {
        let (a, b) = (w[0].offset_um.unwrap(), w[1].offset_um.unwrap());
        worst = worst.max((b - a).abs());
        assert!(
            (b - a).abs() <= RATE_UM + 1e-9,
            "step {a} → {b} µm at {} s",
            w[1].time_s
        );
    }
    println!(
        "restart: {y1:.3} µm before, {y2:.3} µm first after; {} rows, largest step {worst:.3} µm",
        rows.len()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn restart_under_load_resumes_the_applied_offset_sqlite() {
    let dir = tempfile::tempdir().unwrap();
    restart_under_load(
        dir.path(),
        "[storage]\npath = \"r.db\"\ncommit_interval_s = 0.05",
    )
    .await;
}

#[cfg(feature = "postgres")]
#[test]
fn restart_under_load_resumes_the_applied_offset_postgres() {
    // The server's helper blocks: started outside the runtime.
    let server = crate::postgres_common::PgServer::start();
    let dir = tempfile::tempdir().unwrap();
    let storage = format!(
        "[storage]\nbackend = \"postgres\"\nurl = \"{}\"\ncommit_interval_s = 0.05",
        server.url()
    );
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap()
        .block_on(restart_under_load(dir.path(), &storage));
}
