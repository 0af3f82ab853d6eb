//! CSV replay with an `ack_stop` column (issue 14 item 10): one reading past a stop limit
//! latches the stop request; without an acknowledgement the compensation stays stopped
//! for the rest of the log, with an `ack_stop` row it resumes there.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::{engine_ab, replay_to_end};

/// (offset_um, status) of every stored offset of axis 0, in order.
fn stored(db: &std::path::Path) -> Vec<(f64, String)> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT offset_um, status FROM offsets WHERE axis = 0 ORDER BY id")
        .unwrap();
    st.query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect()
}

async fn replay(ack: bool) -> Vec<(f64, String)> {
    let dir = tempfile::tempdir().unwrap();
    let engine = engine_ab(100.0).replacen(
        "stale_timeout_s = 100\n",
        "stale_timeout_s = 100\nlimit_max = 30.0\n",
        1,
    );
    assert!(engine.contains("limit_max"));
    std::fs::write(dir.path().join("engine.toml"), engine).unwrap();
    // Row 3: A = 45 °C, one spike past the 30 °C limit; row 5 acknowledges.
    let a = [24.0, 24.4, 45.0, 24.8, 25.2, 25.6];
    let mut log = String::from(if ack {
        "time_s,A,B,ack_stop\n"
    } else {
        "time_s,A,B\n"
    });
    for (k, a) in a.iter().enumerate() {
        let ack_cell = match (ack, k) {
            (false, _) => String::new(),
            (true, 4) => ",1".into(),
            (true, _) => ",".into(),
        };
        log += &format!("{k},{a},20{ack_cell}\n");
    }
    std::fs::write(dir.path().join("log.csv"), log).unwrap();
    let (run, _) = replay_to_end(dir.path(), "100", 30.0).await;
    let db = run.db.clone();
    run.stop().await.unwrap();
    stored(&db)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ack_stop_row_resumes_the_compensation() {
    // By hand: Cz = −3.75·(A − 20): 24 → −15, 24.4 → −16.5, 25.2 → −19.5, 25.6 → −21.
    let close = |got: &[(f64, String)], want: &[f64]| {
        got.len() == want.len() && got.iter().zip(want).all(|(g, w)| (g.0 - w).abs() < 1e-9)
    };
    let without = replay(false).await;
    assert!(
        close(&without, &[-15.0, -16.5, -16.5, -16.5, -16.5, -16.5]),
        "{without:?}"
    );
    assert!(without[2..].iter().all(|r| r.1 == "stopped"), "{without:?}");

    let with = replay(true).await;
    assert!(
        close(&with, &[-15.0, -16.5, -16.5, -16.5, -19.5, -21.0]),
        "{with:?}"
    );
    assert_eq!(with[4].1, "updated", "{with:?}");
}
