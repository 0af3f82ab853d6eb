//! `gearcomp replay` on the real FL_THERMAL log (embedded in gearcomp-datasets) and on a
//! log with bad rows.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-replay-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn channels(names: &[String]) -> String {
    names
        .iter()
        .map(|n| format!("[[channels]]\nname = \"{n}\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 60.0\n"))
        .collect()
}

/// The FL_THERMAL log (11 115 rows, 16 temperatures) through Cz = −1.2·t3 + 30 +
/// 0.8·(t5 − t9) with no averaging, dead band or rate limit: every row's offset must equal
/// the law evaluated independently here from the CSV text.
#[test]
fn replay_fl_thermal_matches_independent_evaluation() {
    let dir = tmp("fl");
    let csv_text = gearcomp_datasets::fl_thermal_csv().unwrap();
    let data = dir.join("fl_thermal.csv");
    std::fs::write(&data, &csv_text).unwrap();
    let names: Vec<String> = (1..=16).map(|i| format!("t{i}_c")).collect();
    let cfg = format!(
        "{}[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 200.0\n\
         [[axes.terms]]\nkind = \"linear\"\nchannel = \"t3_c\"\nkd_um_per_c = -1.2\nalpha_um = 30.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"t5_c\"\nb = \"t9_c\"\nkz_um_per_c = 0.8\n",
        channels(&names)
    );
    let cfg_path = dir.join("cfg.toml");
    std::fs::write(&cfg_path, cfg).unwrap();
    let out = dir.join("offsets.csv");
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["replay", "--config"])
        .arg(&cfg_path)
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("11115 rows, 0 bad rows"), "{stderr}");

    let mut lines = csv_text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let idx = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (i3, i5, i9) = (idx("t3_c"), idx("t5_c"), idx("t9_c"));
    let expected: Vec<f64> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let f: Vec<f64> = l.split(',').map(|x| x.trim().parse().unwrap()).collect();
            -1.2 * f[i3] + 30.0 + 0.8 * (f[i5] - f[i9])
        })
        .collect();
    let written = std::fs::read_to_string(&out).unwrap();
    let mut rows = written.lines();
    assert!(rows
        .next()
        .unwrap()
        .starts_with("line,time_s,X_offset_um,X_target_um,X_pulses,X_status,status,alarm,stop"));
    let got: Vec<f64> = rows
        .map(|r| r.split(',').nth(2).unwrap().parse().unwrap())
        .collect();
    assert_eq!(got.len(), 11_115);
    for (k, (g, e)) in got.iter().zip(&expected).enumerate() {
        // Offsets are written with 4 decimals.
        assert!((g - e).abs() <= 5.1e-5, "row {k}: {g} vs {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad rows are reported with their line numbers: a non-number is fed as NaN (the engine
/// raises its alarm and holds the offset), a row with the wrong field count is skipped.
#[test]
fn replay_reports_bad_rows_with_line_numbers() {
    let dir = tmp("bad");
    let cfg = format!(
        "{}[[axes]]\nname = \"Z\"\napply = {{ kind = \"measuring_system\" }}\nmax_offset_um = 100.0\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"A\"\nb = \"B\"\nkz_um_per_c = -3.75\n",
        channels(&["A".into(), "B".into()])
    );
    std::fs::write(dir.join("cfg.toml"), cfg).unwrap();
    let log = "time_s,A,B\n0,24,20\n1,24,20\n2,abc,20\n3,24\n4,25,20\n";
    std::fs::write(dir.join("log.csv"), log).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(&dir)
        .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("log.csv:4: column A: \"abc\" is not a number"),
        "{stderr}"
    );
    assert!(
        stderr.contains("log.csv:5: 2 fields, the header has 3"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    let rows: Vec<&str> = stdout.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "{stdout}");
    assert!(rows[0].starts_with("2,0,-15.0000,"), "{}", rows[0]);
    assert!(
        rows[2].starts_with("4,2,-15.0000,")
            && rows[2].contains("Frozen")
            && rows[2].contains("NotANumber"),
        "{}",
        rows[2]
    );
    assert!(rows[3].starts_with("6,4,-18.7500,"), "{}", rows[3]);
    // --strict turns the report into a failure.
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(&dir)
        .args([
            "replay", "--config", "cfg.toml", "--data", "log.csv", "--strict",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn replay_config_errors_name_field_value_and_range() {
    let dir = tmp("cfgerr");
    let cfg = "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\nvalid_min = 50.0\nvalid_max = 10.0\nstale_timeout_s = 1.0\n\
               [[axes]]\nname = \"Z\"\napply = { kind = \"command\" }\nmax_offset_um = 10.0\n[[axes.terms]]\nkind = \"linear\"\nchannel = \"A\"\nkd_um_per_c = 1.0\n";
    std::fs::write(dir.join("cfg.toml"), cfg).unwrap();
    std::fs::write(dir.join("log.csv"), "time_s,A\n0,1\n").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(&dir)
        .args(["replay", "--config", "cfg.toml", "--data", "log.csv"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("channels[0].valid_max = 10") && stderr.contains("> valid_min = 50"),
        "{stderr}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
