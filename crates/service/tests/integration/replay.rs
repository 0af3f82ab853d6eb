//! CSV replay as a live input: the real FL_THERMAL log (46 h, 11 115 rows every 15 s)
//! replayed through the running service at 10⁵× gives, row for row, the offsets of the
//! offline replay (`gearcomp_thermal::replay`) and of the law evaluated here from the CSV
//! text; a looping replay repeats the log with time increasing; a malformed log is refused
//! at start with its line and column.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common;

use std::time::{Duration, Instant};

use common::{engine_ab, start_with, Api};
use gearcomp_thermal::{Engine, EngineConfig};

/// FL_THERMAL's 16 temperatures as °C channels; Cz = −1.2·t3 + 30 + 0.8·(t5 − t9) on X,
/// no averaging, dead band or rate limit (the law of `crates/cli/tests/integration/replay_cli.rs`).
fn fl_engine() -> String {
    let mut s = String::new();
    for i in 1..=16 {
        s += &format!(
            "[[channels]]\nname = \"t{i}_c\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 60.0\n"
        );
    }
    s + "[[axes]]\nname = \"X\"\napply = { kind = \"command\" }\nmax_offset_um = 200.0\n\
         [[axes.terms]]\nkind = \"linear\"\nchannel = \"t3_c\"\nkd_um_per_c = -1.2\nalpha_um = 30.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"t5_c\"\nb = \"t9_c\"\nkz_um_per_c = 0.8\n"
}

/// (time_s, offset_um, law_um) of every stored offset of axis 0, in order.
fn stored_offsets(db: &std::path::Path) -> Vec<(f64, f64, f64)> {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare("SELECT time_s, offset_um, law_um FROM offsets WHERE axis = 0 ORDER BY id")
        .unwrap();
    st.query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fl_thermal_live_replay_equals_offline_replay() {
    let text = gearcomp_datasets::fl_thermal_csv();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("fl_thermal.csv"), text).unwrap();
    std::fs::write(dir.path().join("engine.toml"), fl_engine()).unwrap();

    // Offline: the engine over the log, one step per row.
    let cfg = EngineConfig::from_toml_str(&fl_engine()).unwrap();
    let offline =
        gearcomp_thermal::replay::replay_csv(&mut Engine::new(&cfg).unwrap(), text).unwrap();
    assert_eq!(offline.rows.len(), 11_115);
    assert!(offline.bad_rows.is_empty());

    // Independent reference: the law evaluated from the CSV text.
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (i0, i3, i5, i9, ich1) = (
        idx("time_s"),
        idx("t3_c"),
        idx("t5_c"),
        idx("t9_c"),
        idx("ch1_um"),
    );
    let reference: Vec<(f64, f64, f64)> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            (f[i0], -1.2 * f[i3] + 30.0 + 0.8 * (f[i5] - f[i9]), f[ich1])
        })
        .collect();

    // Live: 166 710 s of log at 10⁵× ≈ 1.7 s, the measured drift ch1_um kept as a target.
    let run = start_with(
        dir.path(),
        "[engine]\nfile = \"engine.toml\"\n[http]\nport = 0\n[storage]\npath = \"replay.db\"\n\
         [input]\nkind = \"replay\"\npath = \"fl_thermal.csv\"\nspeedup = 1e5\ntargets = [\"ch1_um\"]\n",
    )
    .await;
    let ro = run.generated.clone().unwrap().read_only;
    let api = Api::new(&run);
    let (_, st) = api.get("/api/status", Some(&ro)).await;
    assert!(st["input"].as_str().unwrap().starts_with("replay "), "{st}");
    let ended = api
        .wait_alarm("/api/alarms", &ro, "replay.ended", 120.0)
        .await;
    let msg = ended["message"].as_str().unwrap();
    assert!(
        msg.contains("line 11116") && msg.contains("11115 rows"),
        "{msg}"
    );
    let db = run.db.clone();
    let n = run.stop().await.unwrap();
    assert_eq!(
        n,
        11_115 * 16,
        "every reading of the log is a stored sample"
    );

    let live = stored_offsets(&db);
    assert_eq!(
        live.len(),
        offline.rows.len(),
        "one stored offset per log row"
    );
    let mut worst_offline: f64 = 0.0;
    let mut worst_law: f64 = 0.0;
    for (k, ((t, y, law), row)) in live.iter().zip(&offline.rows).enumerate() {
        // A fresh record starts the clock at 0, where the log starts: same times.
        assert_eq!(*t, row.time_s, "row {k}");
        assert_eq!(*t, reference[k].0, "row {k}");
        worst_offline = worst_offline.max((y - row.offset_um[0]).abs());
        worst_law = worst_law
            .max((y - reference[k].1).abs())
            .max((law - reference[k].1).abs());
    }
    eprintln!(
        "{} rows: live vs offline replay {worst_offline:e} µm, vs the law {worst_law:e} µm",
        live.len()
    );
    assert!(
        worst_offline <= 1e-9,
        "live vs offline replay: {worst_offline} µm"
    );
    assert!(
        worst_law <= 1e-9,
        "live vs the law from the CSV: {worst_law} µm"
    );
    // Spot values: the first row and the last (−1.2·t3 + 30 + 0.8·(t5 − t9)).
    assert!(
        (live[0].1
            - (-1.2 * 27.0928032777835 + 30.0 + 0.8 * (31.4718556492793 - 33.1892103616527)))
            .abs()
            < 1e-9
    );
    assert!(
        (live[11_114].1
            - (-1.2 * 28.3699869382041 + 30.0 + 0.8 * (37.319136469476 - 35.1013313517288)))
            .abs()
            < 1e-9
    );

    // The target column is kept too, so the export of a replay is a `gearcomp fit` set.
    let conn = rusqlite::Connection::open(&db).unwrap();
    let targets: Vec<(f64, f64)> = conn
        .prepare("SELECT time_s, value FROM target_values ORDER BY id")
        .unwrap()
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert_eq!(targets.len(), 11_115);
    assert!(targets
        .iter()
        .zip(&reference)
        .all(|(a, b)| a.0 == b.0 && a.1 == b.2));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn looping_replay_repeats_with_time_increasing() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(10.0)).unwrap();
    // Cz = −3.75·(A − B): −15, −18.75, −7.5 µm; rows 1 s apart, so a pass lasts 3 s.
    std::fs::write(
        dir.path().join("log.csv"),
        "time_s,A,B\n0,24,20\n1,25,20\n2,22,20\n",
    )
    .unwrap();
    let run = start_with(
        dir.path(),
        "[engine]\nfile = \"engine.toml\"\n[http]\nport = 0\n[storage]\npath = \"loop.db\"\n\
         [input]\nkind = \"replay\"\npath = \"log.csv\"\nspeedup = 100.0\nloop = true\n",
    )
    .await;
    // At least four passes (12 s of log = 0.12 s), bounded.
    let deadline = Instant::now() + Duration::from_secs(20);
    while run
        .stats
        .committed_samples
        .load(std::sync::atomic::Ordering::Acquire)
        < 24
    {
        assert!(Instant::now() < deadline, "replay did not loop");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let db = run.db.clone();
    run.stop().await.unwrap();
    let live = stored_offsets(&db);
    assert!(live.len() >= 12, "{live:?}");
    let expect = [-15.0, -18.75, -7.5];
    for (k, (t, y, _)) in live.iter().enumerate() {
        assert_eq!(
            *t,
            k as f64,
            "row {k}: pass {} starts 1 s after the last row",
            k / 3
        );
        assert_eq!(*y, expect[k % 3], "row {k}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn malformed_log_is_refused_with_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("engine.toml"), engine_ab(10.0)).unwrap();
    let cfg = |log: &str| {
        std::fs::write(dir.path().join("log.csv"), log).unwrap();
        let p = dir.path().join("machine.toml");
        std::fs::write(
            &p,
            "[engine]\nfile = \"engine.toml\"\n[http]\nport = 0\n[storage]\npath = \"bad.db\"\n\
             [input]\nkind = \"replay\"\npath = \"log.csv\"\nspeedup = 1000.0\n",
        )
        .unwrap();
        gearcomp_service::ServiceConfig::load(&p).unwrap()
    };
    let cases = [
        (
            "time_s,A,B\n0,24,20\n1,24,hot\n",
            "line 3, column B: \"hot\"",
        ),
        (
            "time_s,A,B\n0,24,20\n1,24\n",
            "line 3, column (row): \"2 fields\"",
        ),
        (
            "time_s,A,B\n0,24,20\n0,24,20\n",
            "line 3, column time_s: \"0\"",
        ),
        ("time_s,A\n0,24\n", "line 1, column B"),
    ];
    for (log, want) in cases {
        let e = match gearcomp_service::service::start(cfg(log)).await {
            Ok(_) => panic!("{log:?} accepted"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(want) && e.contains("log.csv"), "{log:?}: {e}");
    }
    // An unknown key in the input table is refused by name.
    let p = dir.path().join("m2.toml");
    std::fs::write(
        &p,
        "[input]\nkind = \"replay\"\npath = \"log.csv\"\nspeed = 2.0\n",
    )
    .unwrap();
    let e = gearcomp_service::ServiceConfig::load(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("speed"), "{e}");
}
