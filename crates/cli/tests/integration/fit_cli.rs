//! `gearcomp fit` end to end: embedded data → model file + report; the model file the
//! engine would load reproduces the printed test error; bad rows name their lines.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-fit-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn fit_help_lists_every_option() {
    let out = bin().args(["fit", "--help"]).output().unwrap();
    let help = String::from_utf8(out.stdout).unwrap();
    for opt in [
        "--data",
        "--target",
        "--inputs",
        "--out",
        "--report",
        "--model",
        "--grouping",
        "--representative",
        "--classes",
        "--tau-s",
        "--folds",
        "--run-column",
        "--test-runs",
        "--train-before-h",
        "--workpiece-data",
        "--module-mm",
        "--shrink-reference",
        "--sample-interval-s",
        "--json",
        "--family",
        "--delay-s",
    ] {
        assert!(help.contains(opt), "missing {opt} in help");
    }
}

#[test]
fn fit_on_embedded_data_writes_a_loadable_model_and_report() {
    let d = tmp("embedded");
    let model = d.join("model.toml");
    let report = d.join("fit.html");
    let out = bin()
        .args([
            "fit", "--target", "ch1_um", "ch5_um", "--axis", "X", "Z", "--model", "dynamic",
            "--out",
        ])
        .arg(&model)
        .arg("--report")
        .arg(&report)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("ch1_um: 12 classes; 8 sensor(s)"), "{text}");
    let m = gearcomp_core::model::ModelFile::load(&model).unwrap();
    assert_eq!(m.axes.len(), 2);
    assert_eq!(m.axes[0].axis, "X");
    assert!(m.axes[0].machine.channels().len() < 16);
    let test = &m.provenance.as_ref().unwrap().test_rmse_um;
    assert!(test[0] < 3.937 && test[1] < 16.471, "{test:?}");
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(
        html.contains("Fuzzy-equivalence dendrogram") && html.contains("measured vs predicted")
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn fit_reports_bad_rows_with_line_numbers() {
    let d = tmp("bad");
    let csv = d.join("log.csv");
    let mut text = String::from("time_s,a_c,b_c,y_um\n");
    for k in 0..40 {
        let t = k as f64 * 60.0;
        text += &format!(
            "{t},{},{},{}\n",
            20.0 + (t / 500.0).sin(),
            21.0 + (t / 900.0).cos(),
            (t / 500.0).sin()
        );
    }
    text += "2460,x,1,2\n";
    std::fs::write(&csv, text).unwrap();
    let out = bin()
        .args(["fit", "--data"])
        .arg(&csv)
        .args(["--target", "y_um", "--no-test"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("line(s) 42") && err.contains("a_c = \"x\" is not a number"),
        "{err}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// One run's CSV (time restarting at 0) with a lagged truth y = 2·a + 3·lag(b, 900 s).
fn run_csv(k: usize, with_time: bool) -> String {
    let mut s = String::from(if with_time {
        "time_s,a_c,b_c,y_um\n"
    } else {
        "a_c,b_c,y_um\n"
    });
    let mut lag = None::<f64>;
    for i in 0..240 {
        let t = i as f64 * 60.0;
        let a = 20.0 + k as f64 + 2.0 * (t / (1500.0 + 300.0 * k as f64)).sin();
        let b = 22.0 + 3.0 * (t / 2600.0 + k as f64).cos();
        let l = match lag {
            None => b,
            Some(l) => l + (1.0 - (-60.0f64 / 900.0).exp()) * (b - l),
        };
        lag = Some(l);
        let y = 2.0 * a + 3.0 * l;
        if with_time {
            s += &format!("{t},{a},{b},{y}\n");
        } else {
            s += &format!("{a},{b},{y}\n");
        }
    }
    s
}

#[test]
fn fit_reads_one_file_per_run_and_prints_json() {
    let d = tmp("runs");
    let mut paths = Vec::new();
    for k in 0..4 {
        let p = d.join(format!("run{k}.csv"));
        std::fs::write(&p, run_csv(k, true)).unwrap();
        paths.push(p);
    }
    let out = bin()
        .args(["fit", "--target", "y_um", "--json", "--data"])
        .args(&paths)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!text.contains("NaN"), "{text}");
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["runs"].as_array().unwrap().len(), 4);
    assert_eq!(v["test_rows"].as_u64(), Some(240), "the last run tests");
    let t = &v["targets"][0];
    assert!(t["family"].as_str().is_some());
    assert_eq!(t["validation_folds_um"].as_array().unwrap().len(), 3);
    assert!(t["test_rmse_um"].as_f64().unwrap() < 1e-3, "{t}");
    assert!(t["terms"].as_array().unwrap().len() >= 2);
    assert!(t["comparison"].as_array().unwrap().len() >= 8);
    assert!(v["method"].as_str().unwrap().contains("leave-one-run-out"));
    // The same runs without a time column, at a 60 s sample interval.
    let p = d.join("notime.csv");
    std::fs::write(&p, run_csv(0, false)).unwrap();
    let out = bin()
        .args(["fit", "--target", "y_um", "--train-before-h", "3", "--data"])
        .arg(&p)
        .args(["--sample-interval-s", "60"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("rolling origin") && !text.contains("NaN"),
        "{text}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn fit_refuses_unknown_test_runs_and_a_split_past_the_end() {
    let d = tmp("refuse");
    let p = d.join("runs.csv");
    let mut text = String::from("run,time_s,a_c,b_c,y_um\n");
    for k in 0..3 {
        for l in run_csv(k, true).lines().skip(1) {
            text += &format!("{k},{l}\n");
        }
    }
    std::fs::write(&p, text).unwrap();
    let out = bin()
        .args([
            "fit",
            "--target",
            "y_um",
            "--run-column",
            "run",
            "--test-runs",
            "7",
            "--data",
        ])
        .arg(&p)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--test-runs = 7") && err.contains("0, 1, 2"),
        "{err}"
    );
    let out = bin()
        .args(["fit", "--target", "ch1_um", "--train-before-h", "100"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--train-before-h = 100 h"), "{err}");
    std::fs::remove_dir_all(&d).unwrap();
}
