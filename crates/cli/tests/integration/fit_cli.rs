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
            "fit", "--target", "ch1_um", "ch5_um", "--axis", "X", "Z", "--out",
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
    assert!(text.contains("ch1_um: 12 classes, 8 sensor(s)"), "{text}");
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
