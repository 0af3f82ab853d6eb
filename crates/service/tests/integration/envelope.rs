//! Issue 12 item 4 through the service: a model whose live input leaves its training
//! envelope raises the active alarm `engine.envelope`, a warning whose message names the
//! channel, its value and the training range in °C; the compensation goes on (offsets
//! follow the law, nothing frozen, no stop).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::{replay_to_end, Api};

const MODEL: &str = "format = \"gearcomp-thermal-model/1\"\nname = \"env\"\n[[axes]]\naxis = \"Z\"\n\
    [axes.machine]\nintercept = 1.0\n[[axes.machine.terms]]\nchannel = \"A\"\ncoefficient = 2.0\n\
    [[envelopes]]\naxis = \"Z\"\nrows = 100\nranges = [{ channel = \"A\", min = 15.0, max = 30.0 }]\n";

const ENGINE: &str = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
    valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 100\n\
    [[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\nmax_offset_um = 100.0\n\
    [[axes.terms]]\nkind = \"model\"\nfile = \"model.toml\"\naxis = \"Z\"\n";

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn envelope_warning_is_an_active_alarm_and_the_offsets_go_on() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("model.toml"), MODEL).unwrap();
    std::fs::write(dir.path().join("engine.toml"), ENGINE).unwrap();
    // A leaves its training range 15…30 °C at row 3 and stays out.
    std::fs::write(
        dir.path().join("log.csv"),
        "time_s,A\n0,20\n1,22\n2,35\n3,36\n",
    )
    .unwrap();
    let (run, ro) = replay_to_end(dir.path(), "100", 30.0).await;
    let api = Api::new(&run);
    let a = api
        .wait_alarm("/api/alarms?active=true", &ro, "engine.envelope", 10.0)
        .await;
    let m = a["message"].as_str().unwrap();
    assert!(
        m.contains("axis Z: warning, model extrapolating")
            && m.contains("channel A = 35.000 °C outside its training range 15.000 … 30.000 °C"),
        "{m}"
    );
    let db = run.db.clone();
    run.stop().await.unwrap();
    // Offsets by hand: 1 + 2·A = 41, 45, 71, 73 µm, every one "updated" (not frozen).
    let conn = rusqlite::Connection::open(&db).unwrap();
    let mut st = conn
        .prepare("SELECT offset_um, status FROM offsets WHERE axis = 0 ORDER BY id")
        .unwrap();
    let rows: Vec<(f64, String)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    let want = [41.0, 45.0, 71.0, 73.0];
    assert_eq!(rows.len(), want.len(), "{rows:?}");
    for ((o, s), w) in rows.iter().zip(want) {
        assert!((o - w).abs() < 1e-9 && s == "updated", "{rows:?}");
    }
}
