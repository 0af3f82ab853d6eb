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
    // Cutter lead π·3·25/sin 15° = 910.36364 mm (docs/shaping.md, control-cycle test vector).
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

// ---------------------------------------------------------------------------------------
// Issue 13 item 7 through the binary, and random G83 blocks against closed forms.

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn run_file(name: &str, text: &str, extra: &[&str]) -> std::process::Output {
    let p = write(name, text);
    bin()
        .args(["shape", "run"])
        .arg(&p)
        .args(extra)
        .output()
        .unwrap()
}

fn all_finite_or_null(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Number(n) => n.as_f64().is_some_and(f64::is_finite),
        serde_json::Value::Array(a) => a.iter().all(all_finite_or_null),
        serde_json::Value::Object(o) => o.values().all(all_finite_or_null),
        _ => true,
    }
}

/// `G83 T40 L25 Q3 P15 R25 K200 S300 F0 B40` was accepted and "cut" with 0 counts/stroke.
#[test]
fn issue13_f0_is_refused_with_line_word_and_range() {
    let out = run_file("f0.nc", "%\nG83 T40 L25 Q3 P15 R25 K200 S300 F0 B40\n", &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("f0.nc:2:34:")
            && err.contains("circular feed F")
            && err.contains("= 0 mm")
            && err.contains("..= 10 mm"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}

/// Range errors of S, B, U, X, E, F carry the line (here the second block, line 3) and
/// the word's column; nothing is printed for the first block before the refusal.
#[test]
fn issue13_range_errors_carry_the_line() {
    for (word, needle) in [
        ("S0", "strokes per minute S"),
        ("B100", "facewidth B"),
        ("U3", "radial feed U"),
        ("X200", "radial depth X"),
        ("E20", "lift-off E"),
        ("F30", "circular feed F"),
    ] {
        let base = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40";
        let block: Vec<&str> = base
            .split(' ')
            .map(|w| if w[..1] == word[..1] { word } else { w })
            .collect();
        let block = block.join(" ");
        let col = block.find(word).unwrap() + 1;
        let out = run_file("range.nc", &format!("{base}\n(next)\n{block}\n"), &[]);
        assert_eq!(out.status.code(), Some(2), "{word}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains(&format!("range.nc:3:{col}:")) && err.contains(needle),
            "{word}: {err}"
        );
        assert!(out.stdout.is_empty(), "{word}: output before the refusal");
    }
}

/// A spur gear's JSON gave `simulated_lead_mm: 4.89e20`: a spur gear has no lead (null).
#[test]
fn issue13_spur_gear_has_null_lead() {
    let out = run_file(
        "spur.nc",
        "G83 T40 L25 Q3 P0 R25 K200 S300 F0.5 B40\n",
        &["--json", "--strokes", "2"],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let s = &v[0]["simulation"];
    assert!(s["simulated_lead_mm"].is_null(), "{s}");
    assert!(
        s["design_lead_mm"].is_null() && s["lead_rel_error"].is_null(),
        "{s}"
    );
    assert!(s["f_h_beta_um"].as_f64().unwrap().is_finite());
    assert!(all_finite_or_null(&v));
    let out = run_file(
        "spur.nc",
        "G83 T40 L25 Q3 P0 R25 K200 S300 F0.5 B40\n",
        &["--strokes", "2"],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("spur gear (straight tooth trace, no lead)"),
        "{text}"
    );
}

/// 250 000 G83 blocks ran for minutes at 170 MB with no output: refused at parse time
/// naming the first block too many; a program within the cap prints one result per block.
#[test]
fn issue13_huge_program_is_capped_and_results_stream() {
    let line = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40\n";
    let out = run_file("big.nc", &line.repeat(250_000), &[]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("big.nc:101:1:") && err.contains("at most 100"),
        "{err}"
    );
    let out = run_file("three.nc", &line.repeat(3), &["--strokes", "2"]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches("G83 on line").count(), 3, "{text}");
    let out = run_file("three.nc", &line.repeat(3), &["--strokes", "2", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v.as_array().unwrap().len(), 3);
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 {
        a.abs()
    } else {
        gcd(b, a % b)
    }
}

/// Random valid G83 blocks through the binary (ideal servos): the generating ratio, C1
/// counts per stroke, realised feed, cutter lead, peak stroke velocity and peak C2 speed
/// against closed forms written here (slider crank: dZ/dθ = R·sin θ − R²·sin θ·cos θ/√(K² −
/// R²·sin²θ); EGB law of Procedia CIRP 56 (2016) 173–177 eq. (1): n_C2 = ρ·n_C1 +
/// σ·sin β/(π·m_n·Z_C2)·v_Z), every number finite or null, and the simulated lead equal to
/// the design lead π·m_n·Z_C1/sin β.
#[test]
fn shape_matches_closed_forms_on_random_blocks() {
    type Block = (u32, u32, f64, f64, f64, f64, f64, f64);
    let strategy = (
        20u32..120,
        15u32..60,
        1.0..6.0f64,
        prop_oneof![Just(0.0), -35.0..35.0f64],
        15.0..50.0f64,
        4.0..8.0f64,
        60.0..250.0f64,
        0.3..1.5f64,
    );
    let compared = std::cell::Cell::new(0u32);
    let check = |(z1, z2, m_n, beta, r, lam, s, f): Block| {
        let k = r * lam;
        let text = format!("G83 T{z1} L{z2} Q{m_n} P{beta} R{r} K{k} S{s} F{f} B10\n");
        let out = run_file(
            "rand.nc",
            &text,
            &["--json", "--ideal-servos", "--strokes", "2"],
        );
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert!(
                err.contains("rand.nc:1:") && err.contains("infeasible"),
                "{text}: {err}"
            );
            return Ok(());
        }
        compared.set(compared.get() + 1);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        prop_assert!(all_finite_or_null(&v), "{text}: {v}");
        let g = &v[0]["gear"];
        let num = |x: &serde_json::Value| x.as_f64().unwrap();
        // ρ = −Z_C1/Z_C2, reduced.
        let d = gcd(i64::from(z1), i64::from(z2));
        prop_assert_eq!(
            g["generating_ratio"].as_str().unwrap(),
            format!("{}/{}", -i64::from(z1) / d, i64::from(z2) / d)
        );
        let beta_r = beta.abs().to_radians();
        let r_c1 = m_n * f64::from(z1) / (2.0 * beta_r.cos());
        let cpr = 3_600_000.0;
        let c1 = (f / r_c1 * cpr / std::f64::consts::TAU).round();
        prop_assert_eq!(num(&g["c1_counts_per_stroke"]), c1);
        let feed = c1 * std::f64::consts::TAU / cpr * r_c1;
        prop_assert!((num(&g["realised_circular_feed_mm"]) - feed).abs() < 1e-12 * (1.0 + feed));
        if beta == 0.0 {
            prop_assert!(g["cutter_lead_mm"].is_null());
            prop_assert!(v[0]["simulation"]["simulated_lead_mm"].is_null());
        } else {
            let lead = std::f64::consts::PI * m_n * f64::from(z2) / beta_r.sin();
            prop_assert!((num(&g["cutter_lead_mm"]) - lead).abs() < 1e-9 * lead);
            let design = std::f64::consts::PI * m_n * f64::from(z1) / beta_r.sin();
            let sim = num(&v[0]["simulation"]["simulated_lead_mm"]);
            // Ideal servos; what remains is the crank encoder's quantisation (a random S
            // gives a fractional count per cycle): a few 1e-6 of the lead.
            prop_assert!(
                ((sim - design) / design).abs() < 2e-5,
                "{text}: {sim} vs {design}"
            );
        }
        // Peak dZ/dθ by dense sampling and golden refinement of the closed form.
        let dz = |th: f64| {
            r * th.sin() - r * r * th.sin() * th.cos() / (k * k - r * r * th.sin().powi(2)).sqrt()
        };
        let mut best = (0.0f64, 0.0f64);
        for i in 0..=2000 {
            let th = std::f64::consts::PI * f64::from(i) / 2000.0;
            if dz(th) > best.0 {
                best = (dz(th), th);
            }
        }
        let (mut a, mut b) = (best.1 - 0.01, best.1 + 0.01);
        for _ in 0..100 {
            let (c, e) = (a + 0.382 * (b - a), a + 0.618 * (b - a));
            if dz(c) > dz(e) {
                b = e;
            } else {
                a = c;
            }
        }
        let dz_max = dz(0.5 * (a + b));
        let omega = s / 60.0 * std::f64::consts::TAU;
        let v_peak = omega * dz_max;
        prop_assert!(
            (num(&g["v_z_peak_mm_s"]) - v_peak).abs() < 1e-6 * v_peak,
            "{text}: {} vs {v_peak}",
            g["v_z_peak_mm_s"]
        );
        // Peak C2 speed (rpm): |ρ|·n_C1 + |σ·sin β/(π·m_n·Z_C2)|·v_Z,peak (v in mm/min).
        let n_c1 = c1 / cpr * s;
        let n_c2 = f64::from(z1) / f64::from(z2) * n_c1
            + beta_r.sin() / (std::f64::consts::PI * m_n * f64::from(z2)) * v_peak * 60.0;
        prop_assert!(
            (num(&g["c2_speed_peak_rpm"]) - n_c2).abs() < 1e-6 * (1.0 + n_c2),
            "{text}: {} vs {n_c2}",
            g["c2_speed_peak_rpm"]
        );
        Ok(())
    };
    let cfg = Config {
        cases: 8,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[6u8; 32], [17u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
    assert!(
        compared.get() >= 12,
        "only {} blocks compared",
        compared.get()
    );
}

/// Random invalid words through the binary: exit 2 with file:line:column of the word.
#[test]
fn shape_refuses_random_invalid_words_with_line() {
    let bad = prop_oneof![
        (-100.0..0.9f64).prop_map(|v| ('S', v)),
        (-10.0..3.9f64).prop_map(|v| ('B', v)),
        (1.01..100.0f64).prop_map(|v| ('U', v)),
        (100.1..1e5f64).prop_map(|v| ('X', v)),
        (10.1..1e3f64).prop_map(|v| ('E', v)),
        (-5.0..0.00005f64).prop_map(|v| ('F', v)),
        (10.01..1e3f64).prop_map(|v| ('F', v)),
    ];
    let check = |((letter, value), pre): ((char, f64), usize)| {
        let base = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40";
        let word = format!("{letter}{value}");
        let block: Vec<String> = base
            .split(' ')
            .map(|w| {
                if w.starts_with(letter) {
                    word.clone()
                } else {
                    w.to_string()
                }
            })
            .collect();
        let block = block.join(" ");
        let col = block.find(&word).unwrap() + 1;
        let text = format!("{}{block}\n", format!("{base}\n").repeat(pre));
        let out = run_file("inv.nc", &text, &[]);
        prop_assert_eq!(out.status.code(), Some(2));
        let err = String::from_utf8_lossy(&out.stderr);
        let at = format!("inv.nc:{}:{col}:", pre + 1);
        prop_assert!(err.contains(&at) && err.contains(letter), "{block}: {err}");
        Ok(())
    };
    let cfg = Config {
        cases: 10,
        failure_persistence: None,
        ..Config::default()
    };
    let strategy = (bad, 0usize..3);
    let mut r = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[8u8; 32]),
    );
    r.run(&strategy, check).unwrap();
    TestRunner::new(cfg).run(&strategy, check).unwrap();
}
