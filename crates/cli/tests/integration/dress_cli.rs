//! `gearcomp dress` end to end: design, solve (docs/dressing.md "Reference case G1-Z5" G1-Z5 reference), plan, errors.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp, write_config};

fn write_config_here(name: &str, text: &str) -> PathBuf {
    write_config("dress", name, "dress.toml", text)
}

use std::path::PathBuf;

const CONFIG: &str = concat!(
    include_str!("../fixtures/worm_z5_dresser.toml"),
    r#"
[solve]
flank = "right"
method = "three-point"
crowning_um = 0.2

[plan]
diameters_mm = [160.0, 150.0, 140.0]
budget_mm = 0.1
"#
);

/// `dress solve --json` reproduces the docs/dressing.md "Reference case G1-Z5" root and profile for G1-Z5, c = 0.2 µm.
#[test]
fn dress_solve_json_matches_reference_case_g1_z5() {
    let cfg = write_config_here("solve", CONFIG);
    let report = cfg.with_file_name("solve.html");
    let out = gearcomp(&[
        "dress",
        "solve",
        cfg.to_str().unwrap(),
        "--json",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |k: &str| v[k].as_f64().unwrap();
    assert!((f("dgamma_deg") / 0.5580 - 1.0).abs() < 0.01);
    assert!((f("dnu_ya_mm") / -1.0413 - 1.0).abs() < 0.01);
    assert!((f("dphi_s_rad") / 6.057e-4 - 1.0).abs() < 0.1);
    assert!((f("dd_mm") / -0.02450 - 1.0).abs() < 0.1);
    let prof = v["profile_um"].as_array().unwrap();
    let mid = prof[10][1].as_f64().unwrap();
    let start = prof[0][1].as_f64().unwrap();
    assert!((mid + 0.2).abs() < 1e-3 && (start - 0.0469).abs() < 1e-3);
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("<svg") && html.contains("Contact line"));
}

/// `dress design` and `dress plan` print their tables; the plan has one row per diameter.
#[test]
fn dress_design_and_plan() {
    let cfg = write_config_here("plan", CONFIG);
    let out = gearcomp(&["dress", "design", cfg.to_str().unwrap()]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("fillet radius 0.8455 mm"), "{text}");
    let out = gearcomp(&["dress", "plan", cfg.to_str().unwrap(), "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = v.as_array().unwrap();
    assert_eq!(rows.len(), 3);
    for r in rows {
        assert!(r["deviation_max_um"].as_f64().unwrap() < 0.1);
    }
}

/// Bad input: the message names the field and its allowed range; no panic.
#[test]
fn dress_bad_input_names_the_field() {
    let cfg = write_config_here(
        "bad",
        &CONFIG.replace("jacket_width_mm = 0.8", "jacket_width_mm = 9.0"),
    );
    let out = gearcomp(&["dress", "design", cfg.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("jacket_width_mm") && err.contains("outside the allowed range"),
        "{err}"
    );
    let cfg = write_config_here(
        "noroot",
        &CONFIG.replace("crowning_um = 0.2", "crowning_um = 200.0"),
    );
    let out = gearcomp(&["dress", "solve", cfg.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("[solve] crowning_um = 200 µm is outside the allowed range -50 ..= 50 µm"),
        "{err}"
    );
}
