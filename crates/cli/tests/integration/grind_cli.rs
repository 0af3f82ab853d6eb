//! `gearcomp grind` end to end: the reference example of JP6903407B2, part 2 (docs/grinding.md
//! "Independent reference: reference example") with the
//! T8 worm; numbers checked against docs/grinding.md "Independent reference: brute-force envelope"
//! (true
//! envelope and analytic map).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp_cmd as gearcomp, gearcomp_json, T8_WORM_ARGS};

/// The example gear (z2 = 31, m_n = 3, α_n = 20°, β = 15°) and worm (z1 = 1, r1 = 130 mm) are
/// the defaults; this grid puts the T8 points on grid nodes.
const GRID: [&str; 8] = [
    "--roll-start-mm",
    "11",
    "--roll-end-mm",
    "23",
    "--grid-w",
    "13",
    "--grid-z",
    "31",
];

fn json(args: &[&str]) -> serde_json::Value {
    gearcomp_json(&[args, &GRID[..]].concat())
}

fn at(v: &serde_json::Value, key: &str, w: f64, z: f64) -> f64 {
    let i = ((w - 11.0) / 1.0).round() as usize;
    let j = ((z + 15.0) / 1.0).round() as usize;
    v["map"][key][i][j].as_f64().unwrap()
}

/// T8 through the CLI: ground values vs the true envelope (docs/grinding.md "Independent reference:
/// brute-force envelope", true envelope), analytic
/// values vs the analytic values of docs/grinding.md "Independent reference: brute-force
/// envelope"), contact path and K as in docs/grinding.md "Independent reference: reference
/// example".
#[test]
fn grind_simulate_t8_matches_reference_envelope() {
    let v = json(&[&["grind", "simulate"][..], &T8_WORM_ARGS[..]].concat());
    assert!((v["diagonal_ratio"].as_f64().unwrap() + 0.877178).abs() < 1e-6);
    assert!((v["path"]["c_w2"].as_f64().unwrap() - 0.250739).abs() < 1e-6);
    assert!((v["path"]["r7_sum_mm"].as_f64().unwrap() - 397.213083).abs() < 1e-6);
    for &(w, z, env, analytic) in &[
        (15.0, 0.0, -13.6759, -13.6314),
        (19.0, 8.0, -8.0404, -8.0171),
        (13.0, -10.0, -20.6535, -20.5812),
        (21.0, 12.0, -5.7648, -5.7488),
    ] {
        let g = at(&v, "ground_um", w, z);
        let a = at(&v, "analytic_um", w, z);
        assert!((g - env).abs() < 2e-3, "({w},{z}) ground {g} vs {env}");
        assert!(
            (a - analytic).abs() < 5e-4,
            "({w},{z}) analytic {a} vs {analytic}"
        );
    }
}

/// `solve`: the worm found for a wanted ρ_F2 = 45° modification grinds it (simulated) within
/// 0.05 µm on a 10 µm-class modification, with the K of T7, and the evaluation passes.
#[test]
fn grind_solve_reproduces_the_wanted_modification() {
    let dir = std::env::temp_dir().join(format!("gearcomp-grind-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let report = dir.join("solve.html");
    let v = json(&[
        "grind",
        "solve",
        "--gear-rho-deg",
        "45",
        "--gear-c",
        "-2,0.1,-0.01",
        "--gear-q",
        "-0.05",
        "--worm-rho-deg",
        "20",
        "--shift-offset-mm",
        "5",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert!((v["diagonal_ratio"].as_f64().unwrap() + 0.877178).abs() < 1e-6);
    assert!(v["max_abs_ground_um"].as_f64().unwrap() > 5.0);
    assert!(v["max_abs_deviation_um"].as_f64().unwrap() < 0.05);
    assert_eq!(
        v["iso1328"]["within_tolerance"],
        serde_json::Value::Bool(true)
    );
    // the wanted modification at (15, 0): X2 = 15·sin 45° = 10.6066; w − w_P2 = −1.974655
    let x = 15.0 * std::f64::consts::FRAC_1_SQRT_2;
    let dw = 15.0 - 16.974655;
    let wanted = -2.0 + 0.1 * x - 0.01 * x * x - 0.05 * dw * dw;
    assert!((at(&v, "ground_um", 15.0, 0.0) - wanted).abs() < 0.02);
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(html.contains("<svg") && html.contains("ISO 1328-1:2013 evaluation"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Table output names the contact path and the ISO verdict.
#[test]
fn grind_table_output() {
    let out = gearcomp()
        .args([
            "grind", "simulate", "--worm-c", "3", "--grid-w", "5", "--grid-z", "5",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    assert!(s.contains("C_Fw2 0.250739"), "{s}");
    assert!(s.contains("verdict:"), "{s}");
}

/// Bad input: clear error naming the field and the range, exit code 2, no panic.
#[test]
fn grind_rejects_bad_input() {
    for (args, needle) in [
        (
            vec!["grind", "simulate", "--module-mm=-3"],
            "--module-mm = -3",
        ),
        (
            vec![
                "grind",
                "solve",
                "--gear-rho-deg=-14.076095",
                "--gear-c",
                "1",
            ],
            "singular",
        ),
        (vec!["grind", "simulate", "--grid-w", "1"], "n_w"),
        (
            vec!["grind", "simulate", "--class", "12"],
            "flank tolerance class = 12",
        ),
    ] {
        let out = gearcomp().args(&args).output().unwrap();
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"));
    }
}

/// Gears outside ISO 1328-1:2013's scope (m_n < 0.5 mm, b < 4 mm) are ground and their
/// deviations evaluated, without tolerances: they were refused "ISO 1328-1 tolerances: normal
/// module m_n = 0.363 mm is outside the allowed range 0.5 … 70 mm" (no option named), although
/// the simulation does not need the standard. Checked against a construction written here: a
/// constant worm modification c grinds the constant f_Ft2 = −c·cos β_b1/cos β_b2 (docs/grinding.md
/// "Modifications"), with cos β1 = z1·m_n/(2·r1) and sin β_b = sin β·cos α_n.
#[test]
fn grind_outside_the_iso1328_scope_gives_deviations_without_tolerances() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 12,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[5; 32]),
    );
    let strategy = (
        0.3..0.49f64,
        30u32..200,
        16.0..25.0f64,
        -30.0..30.0f64,
        1u32..4,
        -15.0..15.0f64,
        any::<bool>(),
    );
    runner
        .run(&strategy, |(m, z, a_deg, b_deg, starts, c, narrow)| {
            let r1 = 40.0 * m;
            let b = if narrow { 3.0 } else { 10.0 };
            let args: Vec<String> = vec![
                "grind".into(),
                "simulate".into(),
                format!("--module-mm={m}"),
                format!("--teeth={z}"),
                format!("--pressure-angle-deg={a_deg}"),
                format!("--helix-angle-deg={b_deg}"),
                format!("--worm-starts={starts}"),
                format!("--worm-radius-mm={r1}"),
                format!("--face-width-mm={b}"),
                format!("--worm-c={c}"),
                "--grid-w=9".into(),
                "--grid-z=9".into(),
            ];
            let a: Vec<&str> = args.iter().map(String::as_str).collect();
            let v = gearcomp_json(&a);
            let iso = &v["iso1328"];
            prop_assert!(iso["tolerances"].is_null() && iso["within_tolerance"].is_null());
            prop_assert!(v["iso1328_traces"]["from_design"]["class_achieved"].is_null());
            let w = v["warnings"].to_string();
            prop_assert!(w.contains("--module-mm") && w.contains("scope"), "{}", w);
            let an = a_deg.to_radians();
            let beta1 = (f64::from(starts) * m / (2.0 * r1)).acos();
            let bb1 = (beta1.sin() * an.cos()).asin();
            let bb2 = (b_deg.to_radians().sin() * an.cos()).asin();
            let want = c.abs() * bb1.cos() / bb2.cos();
            let got = v["max_abs_ground_um"].as_f64().unwrap();
            prop_assert!(
                (got - want).abs() < 1e-6 * (1.0 + want),
                "{} vs {}",
                got,
                want
            );
            Ok(())
        })
        .unwrap();
}
