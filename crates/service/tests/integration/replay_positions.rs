//! CSV replay with a `position_<axis>_mm` column (issue 14 item 9): the service's live
//! replay hands the positions to the SINUMERIK/TwinCAT position law, and every stored
//! offset equals the law worked by hand at that row's position.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::{position_law_um, replay_to_end, stored_offsets, POSITION_ENGINE};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn replayed_positions_reach_the_position_law() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), POSITION_ENGINE).unwrap();
    // A at 24 °C throughout; positions 140, (empty: held), 60, 237.5, −50 mm.
    let rows = [
        ("24", "140"),
        ("24", ""),
        ("24", "60"),
        ("24", "237.5"),
        ("24", "-50"),
    ];
    let mut log = String::from("time_s,A,position_Z_mm\n");
    for (k, (a, p)) in rows.iter().enumerate() {
        log += &format!("{k},{a},{p}\n");
    }
    std::fs::write(dir.path().join("log.csv"), log).unwrap();
    let (run, _) = replay_to_end(dir.path(), "100", 30.0).await;
    let db = run.db.clone();
    run.stop().await.unwrap();
    let ys = stored_offsets(&db);
    let want: Vec<f64> = [140.0, 140.0, 60.0, 237.5, -50.0]
        .iter()
        .map(|p| position_law_um(24.0, *p))
        .collect();
    // One stored row per replayed row (the law changes or holds at each).
    assert_eq!(ys, want);
}
