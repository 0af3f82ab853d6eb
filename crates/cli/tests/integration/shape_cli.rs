//! `gearcomp shape run` end to end: text, JSON, report, refusals with line and column.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
}

fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gearcomp-shape-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const PROGRAM: &str = "%\n(seed 002 example gear)\nN10 G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40\nN20 G80\nN30 M30\n%\n";

#[test]
fn run_prints_json_with_the_design_lead_for_ideal_servos() {
    let p = write("ideal.nc", PROGRAM);
    let out = bin()
        .args(["shape", "run"])
        .arg(&p)
        .args(["--json", "--ideal-servos"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let c = &v[0];
    assert_eq!(c["line"], 3);
    // Cutter lead π·3·25/sin 15° = 910.36364 mm (seed_formulas.md).
    let lead = c["gear"]["cutter_lead_mm"].as_f64().unwrap();
    assert!((lead - 910.36364).abs() < 5e-6, "{lead}");
    assert_eq!(c["gear"]["generating_ratio"], "-8/5");
    assert_eq!(c["execution"]["coupling_residual"], 0);
    let rel = c["simulation"]["lead_rel_error"].as_f64().unwrap();
    assert!(rel.abs() < 1e-9, "{rel}");
    assert_eq!(c["simulation"]["within_tolerance"], true);
}

#[test]
fn run_writes_a_report_with_charts() {
    let p = write("report.nc", PROGRAM);
    let html = p.with_extension("html");
    let out = bin()
        .args(["shape", "run"])
        .arg(&p)
        .arg("--report")
        .arg(&html)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("f_Hb") && text.contains("ISO 1328-1 class 6"),
        "{text}"
    );
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.matches("<svg").count() >= 4);
    assert!(page.contains("C2 error against the ideal coupling"));
}

#[test]
fn parse_error_names_file_line_and_column() {
    let p = write("bad.nc", "%\nG83 T40 L25 Q P15 R25 K200 S300 F0.5 B40\n");
    let out = bin().args(["shape", "run"]).arg(&p).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.nc:2:15:") && err.contains("number after address 'Q'"),
        "{err}"
    );
}

#[test]
fn infeasible_stroke_rate_is_refused_before_start() {
    let p = write("fast.nc", "G83 T40 L25 Q3 P15 R25 K200 S1000 F0.5 B40\n");
    let out = bin().args(["shape", "run"]).arg(&p).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("fast.nc:1:29:") && err.contains("infeasible") && err.contains("C2"),
        "{err}"
    );
}
