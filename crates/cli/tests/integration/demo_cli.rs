//! `gearcomp demo` end to end: the default run, another preset, a model file in place of
//! the preset's law, and a bad option.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::PathBuf;
use std::process::Command;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-demo-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn demo(dir: &PathBuf, extra: &[&str]) -> (serde_json::Value, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .current_dir(dir)
        .arg("demo")
        .arg("--json")
        .args(extra)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{stderr}");
    (serde_json::from_slice(&o.stdout).unwrap(), stderr)
}

/// The default demo (grinder, JPH0761598B2): uncompensated > 15 µm, compensated ≤ 5 µm, and a
/// self-contained HTML report with the charts.
#[test]
fn demo_default_grinder() {
    let dir = tmp("default");
    let (v, stderr) = demo(&dir, &[]);
    assert_eq!(v["preset"], "grinder");
    assert!(
        v["uncompensated"]["max_abs_um"].as_f64().unwrap() > 15.0,
        "{v}"
    );
    assert!(
        v["compensated"]["max_abs_um"].as_f64().unwrap() <= 5.0,
        "{v}"
    );
    // stderr is a pipe here, not a terminal: one closing line, no carriage-return progress.
    assert!(
        stderr.contains("simulated 8 h on the grinder preset") && !stderr.contains('\r'),
        "{stderr:?}"
    );
    let html = std::fs::read_to_string(dir.join("gearcomp-demo.html")).unwrap();
    assert!(html.matches("<svg").count() >= 4);
    assert!(html.contains("Applied offset") && html.contains("Residual"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn demo_shaper_pulses_and_custom_out() {
    let dir = tmp("shaper");
    let (v, _) = demo(
        &dir,
        &[
            "--preset", "shaper", "--hours", "4", "--seed", "3", "--out", "s.html",
        ],
    );
    assert_eq!(v["hours"], 4.0);
    assert!(v["pulse_total"].as_i64().unwrap() > 5, "{v}");
    assert!(
        v["compensated"]["max_abs_um"].as_f64().unwrap()
            < v["uncompensated"]["max_abs_um"].as_f64().unwrap() / 3.0
    );
    assert!(dir.join("s.html").exists());
    std::fs::remove_dir_all(&dir).ok();
}

/// A model file equivalent to JPH0761598B2's Kz·(A − B) gives the same quality as the preset.
#[test]
fn demo_with_model_file() {
    let dir = tmp("model");
    std::fs::write(
        dir.join("m.toml"),
        r#"format = "gearcomp-thermal-model/1"
name = "grinder as a model file"
[[axes]]
axis = "Z"
[axes.machine]
intercept = 0.0
[[axes.machine.terms]]
channel = "bed_top_c"
coefficient = -3.75
[[axes.machine.terms]]
channel = "wheel_head_c"
coefficient = 3.75
"#,
    )
    .unwrap();
    let (v, _) = demo(&dir, &["--model", "m.toml"]);
    assert!(v["law"].as_str().unwrap().contains("m.toml"));
    assert!(
        v["compensated"]["max_abs_um"].as_f64().unwrap() <= 5.0,
        "{v}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn demo_rejects_unknown_preset() {
    let o = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["demo", "--preset", "lathe", "--out", "/nonexistent/x.html"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(
        stderr.contains("preset = lathe") && stderr.contains("grinder, shaper, hobbing"),
        "{stderr}"
    );
}
