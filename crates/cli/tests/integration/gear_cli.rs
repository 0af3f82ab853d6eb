//! Issue 2's test vectors through the binary: `gearcomp gear --json`, parsed with serde_json.
//! Tolerance 5e-5 mm is half a unit of the published 4th decimal (Σx: 5e-7, 6 decimals).
#![allow(clippy::unwrap_used, clippy::expect_used)]
// The published s_n = 1.5708 mm is a 4-decimal value, not an attempt at π/2.
#![allow(clippy::approx_constant)]

use std::process::Command;

use serde_json::Value;

fn gearcomp(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .arg("gear")
        .args(args)
        .output()
        .unwrap()
}

fn json(args: &[&str]) -> Value {
    let mut a = args.to_vec();
    a.push("--json");
    let out = gearcomp(&a);
    assert!(
        out.status.success(),
        "gearcomp gear {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

fn num(v: &Value, path: &str) -> f64 {
    let mut cur = v;
    for key in path.split('.') {
        cur = match key.parse::<usize>() {
            Ok(i) => &cur[i],
            Err(_) => &cur[key],
        };
    }
    cur.as_f64()
        .unwrap_or_else(|| panic!("{path} is not a number: {cur}"))
}

fn close(v: &Value, path: &str, want: f64, tol: f64) {
    let got = num(v, path);
    assert!(
        (got - want).abs() <= tol,
        "{path}: got {got}, want {want} ± {tol}"
    );
}

/// TV1 (MESYS): z = 20, m_n = 1, α_n = 20°, x = 0, k = 2, D_M = 1.7.
#[test]
fn tv1_spur_z20() {
    let v = json(&[
        "--module", "1", "--teeth", "20", "--span-k", "2", "--ball", "1.7",
    ]);
    close(&v, "gear.base_diameter_mm", 18.7939, 5e-5);
    close(&v, "gear.root_form_diameter_mm", 18.8003, 5e-5);
    close(&v, "tooth.0.normal_thickness_mm", 1.5708, 5e-5);
    close(&v, "tooth.0.tip_normal_thickness_mm", 0.6949, 5e-5);
    close(&v, "tooth.0.span.span_mm", 4.7083, 5e-5);
    close(&v, "tooth.0.ball.dimension_mm", 22.2941, 5e-5);
    assert_eq!(v["recommended"]["span_k"], 3);
}

/// TV2 (Ondrives/MESYS): z = 30, m_n = 1, A_sn = −0.06/−0.03 mm, D_M = 1.7.
#[test]
fn tv2_spur_z30_allowances() {
    let v = json(&[
        "--module",
        "1",
        "--teeth",
        "30",
        "--allowances=-0.06,-0.03",
        "--ball",
        "1.7",
    ]);
    close(&v, "gear.base_diameter_mm", 28.1908, 5e-5);
    assert_eq!(v["tooth"][1]["case"], "lower");
    close(&v, "tooth.1.normal_thickness_mm", 1.5108, 5e-5);
    close(&v, "tooth.2.normal_thickness_mm", 1.5408, 5e-5);
    close(&v, "tooth.1.generating_shift", -0.0824, 5e-5);
    close(&v, "tooth.2.generating_shift", -0.0412, 5e-5);
    close(&v, "tooth.1.root_diameter_mm", 27.3352, 5e-5);
    close(&v, "tooth.2.root_diameter_mm", 27.4176, 5e-5);
    close(&v, "tooth.1.ball.dimension_mm", 32.1641, 5e-5);
    close(&v, "tooth.2.ball.dimension_mm", 32.2380, 5e-5);
}

/// TV3: helical pair m_n = 3.5, α_n = 20°, β = 21°, z1 = 31, z2 = 30, a_w = 116.5 mm.
#[test]
fn tv3_helical_pair() {
    let v = json(&[
        "--module",
        "3.5",
        "--pressure-angle",
        "20",
        "--helix",
        "21",
        "--teeth",
        "31",
        "--width",
        "30",
        "--mate-teeth",
        "30",
        "--centre-distance",
        "116.5",
    ]);
    close(&v, "gear.transverse_pressure_angle_deg", 21.2991, 5e-5);
    close(&v, "pair.reference_centre_distance_mm", 114.3447, 5e-5);
    close(&v, "pair.working_pressure_angle_deg", 23.8708, 5e-5);
    close(&v, "pair.shift_sum", 0.651877, 5e-7);
    // The mate takes the rest of Σx, so the nominal design has zero backlash.
    close(&v, "pair.mate.profile_shift", 0.651877, 5e-7);
    close(&v, "pair.backlash.0.normal_mm", 0.0, 1e-12);
    assert_eq!(v["pair"]["mate"]["hand"], "left");
}

/// The same gear from a TOML file with the flags' names; a flag overrides the file.
#[test]
fn toml_file_matches_flags() {
    let dir = std::env::temp_dir().join(format!("gearcomp-gear-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("gear.toml");
    std::fs::write(
        &path,
        "module = 1.0\nteeth = 31\npressure-angle = 20\nallowances = [-0.06, -0.03]\nball = 1.7\n",
    )
    .unwrap();
    let p = path.to_str().unwrap();
    let v = json(&["--file", p, "--teeth", "30"]);
    close(&v, "tooth.1.ball.dimension_mm", 32.1641, 5e-5);
    std::fs::write(&path, "module = 1.0\nteeth = 30\ntypo-key = 3\n").unwrap();
    let out = gearcomp(&["--file", p]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("typo-key"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Bad input: exit code 2 and a message naming the parameter, its value and the range.
#[test]
fn bad_input_is_a_clear_error() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--module", "0", "--teeth", "20"],
            &["--module", "normal_module_mm = 0", "0.01 … 1000 mm"],
        ),
        (
            &["--module", "-2", "--teeth", "20"],
            &["normal_module_mm = -2"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--pressure-angle", "45"],
            &["normal_pressure_angle = 45", "0 … 45 °"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--helix", "-60"],
            &["helix = -60", "−60 < β < 60"],
        ),
        (
            &["--module", "1", "--teeth", "2"],
            &["teeth = 2", "3 … 10000"],
        ),
        (
            &["--module", "1", "--teeth", "10", "--shift", "1.2"],
            &["pointed tooth"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--ball", "0.5"],
            &["--ball", "ball_mm = 0.5", "does not touch"],
        ),
        (
            &["--module", "1", "--teeth", "20", "--span-k", "21"],
            &["--span-k", "span_k = 21", "1 … 19"],
        ),
        (
            &[
                "--module",
                "1",
                "--teeth",
                "20",
                "--mate-teeth",
                "20",
                "--centre-distance",
                "5",
            ],
            &["centre_distance_mm = 5"],
        ),
        (&["--teeth", "20"], &["--module"]),
    ];
    for (args, needles) in cases {
        let out = gearcomp(args);
        assert_eq!(out.status.code(), Some(2), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        for n in *needles {
            assert!(err.contains(n), "{args:?}: {err:?} lacks {n:?}");
        }
    }
}

/// `--help` explains every parameter with its unit.
#[test]
fn help_names_units() {
    let out = gearcomp(&["--help"]);
    assert!(out.status.success());
    let h = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "--module",
        "in mm",
        "--pressure-angle",
        "in degrees",
        "--helix",
        "right hand",
        "--teeth",
        "--shift",
        "--width",
        "--internal",
        "--allowances",
        "--ball",
        "--span-k",
        "--mate-teeth",
        "--centre-distance",
        "--file",
        "--json",
    ] {
        assert!(h.contains(needle), "--help lacks {needle:?}");
    }
}

/// The table prints the main values with units.
#[test]
fn table_output_has_units() {
    let out = gearcomp(&[
        "--module", "1", "--teeth", "20", "--span-k", "2", "--ball", "1.7",
    ]);
    assert!(out.status.success());
    let t = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "18.7939 mm",
        "4.7083 mm",
        "22.2941 mm",
        "1.5708 mm",
        "20.0000 °",
    ] {
        assert!(t.contains(needle), "table lacks {needle:?}:\n{t}");
    }
}

// ---------------------------------------------------------------------------------------
// Issue 13 item 1: reproductions through the binary, and random gears against the
// independent flank construction (the same file the library tests use).

#[path = "../../../geometry/tests/integration/construct.rs"]
mod construct;

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn run(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .arg("gear")
        .args(args)
        .output()
        .unwrap()
}

fn strings(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

/// Every number in a JSON document is finite (serde_json writes NaN/∞ as null, so a null
/// where a number belongs is caught by the field checks; here: no "NaN" text at all).
fn all_finite(v: &Value) -> bool {
    match v {
        Value::Number(n) => n.as_f64().is_some_and(f64::is_finite),
        Value::Array(a) => a.iter().all(all_finite),
        Value::Object(o) => o.values().all(all_finite),
        _ => true,
    }
}

/// `--span-k 8` on m = 2, z = 40, β = 30° was refused (contact 99.8192 mm computed with
/// W_k/cos β_b); the anvils touch at 94.33 mm, and DIN 3960 recommends k = 7.
#[test]
fn issue13_helical_span_k8_is_computed() {
    let v = json(&[
        "--module", "2", "--teeth", "40", "--helix", "30", "--span-k", "8",
    ]);
    close(&v, "tooth.0.span.contact_diameter_mm", 94.33, 0.005);
    let g = construct::Gear3::new(2.0, 20f64.to_radians(), 30f64.to_radians(), 40, 0.0);
    let c = construct::span(&g, 8).unwrap();
    close(
        &v,
        "tooth.0.span.contact_diameter_mm",
        c.contact_diameter_mm,
        1e-9,
    );
    close(&v, "tooth.0.span.span_mm", c.span_mm, 1e-9);
    assert_eq!(v["recommended"]["span_k"], 7);
    // The recommended k given back is accepted.
    let v = json(&[
        "--module", "2", "--teeth", "40", "--helix", "30", "--span-k", "7",
    ]);
    assert_eq!(v["tooth"][0]["span"]["k"], 7);
}

/// `--width 5` on that gear: refused, stating W_k·sin β_b against the face width, for
/// the default k and for a k the user gives.
#[test]
fn issue13_helical_span_face_width_message() {
    let base = [
        "--module", "2", "--teeth", "40", "--helix", "30", "--width", "5",
    ];
    let out = gearcomp(&base);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("W_k·sin β_b = 13.2751 mm")
            && err.contains("face width b = 5 mm")
            && err.contains("b > W_k·sin β_b"),
        "{err}"
    );
    let mut a = base.to_vec();
    a.extend(["--span-k", "7"]);
    let out = gearcomp(&a);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--span-k")
            && err.contains("span_k = 7")
            && err.contains("W_k·sin β_b = 18.8233 mm")
            && err.contains("face width b = 5 mm"),
        "{err}"
    );
}

/// `--ball 1` on z = 20, m = 2 printed "contact diameter NaN mm": refused naming --ball
/// and the balls that fit.
#[test]
fn issue13_small_ball_names_the_valid_range() {
    let out = gearcomp(&["--module", "2", "--teeth", "20", "--ball", "1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("NaN"), "{err}");
    assert!(
        err.contains("--ball")
            && err.contains("ball_mm = 1 mm")
            && err.contains("balls from 2.40103 to"),
        "{err}"
    );
}

/// `--module 1e-300` passed validation.
#[test]
fn issue13_tiny_module_is_refused() {
    let out = gearcomp(&["--module", "1e-300", "--teeth", "20"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--module") && err.contains("1e-300") && err.contains("0.01 … 1000 mm"),
        "{err}"
    );
}

/// Undercut gears are computed with a warning; pointed teeth stay refused.
#[test]
fn issue13_undercut_is_a_warning() {
    let v = json(&["--module", "1", "--teeth", "10"]);
    let w = v["warnings"][0].as_str().unwrap();
    assert!(
        w.contains("undercut") && w.contains("x_min = 0.5006"),
        "{w}"
    );
    assert!(all_finite(&v));
    let g = construct::Gear3::new(1.0, 20f64.to_radians(), 0.0, 10, 0.0);
    let k = v["recommended"]["span_k"].as_u64().unwrap() as u32;
    close(
        &v,
        "tooth.0.span.span_mm",
        construct::span(&g, k).unwrap().span_mm,
        1e-9,
    );
    let out = gearcomp(&["--module", "1", "--teeth", "10", "--shift", "1.2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("pointed tooth"));
}

/// Random valid external gears (spur and helical, either hand, shifted, with and without
/// face width and allowances) through the binary: exit 0 ⇒ every number finite, W_k and
/// its contact diameter equal to the base-tangent-plane construction, M_dK and its contact
/// equal to the ball placed against the helical flank, the recommended k is DIN 3960's
/// whenever that k is measurable, and giving the recommended k back never fails;
/// exit ≠ 0 ⇒ the message names an option.
#[test]
fn gear_matches_construction_on_random_gears() {
    let strategy = (
        0.5..10.0f64,
        15.0..25.0f64,
        prop_oneof![Just(0.0), -40.0..40.0f64],
        12u32..150,
        -0.3..0.7f64,
        prop_oneof![Just(None), (4.0..80.0f64).prop_map(Some)],
        prop_oneof![Just(None), (-0.05..0.0f64).prop_map(Some)],
    );
    let ok_runs = std::cell::Cell::new(0u32);
    let check = |(m, a, b, z, x, w, al): (f64, f64, f64, u32, f64, Option<f64>, Option<f64>)| {
        let mut args = vec![
            format!("--module={m}"),
            format!("--pressure-angle={a}"),
            format!("--helix={b}"),
            format!("--teeth={z}"),
            format!("--shift={x}"),
        ];
        if let Some(w) = w {
            args.push(format!("--width={}", w * m));
        }
        if let Some(al) = al {
            args.push(format!("--allowances={},{}", al * m, 0.5 * al * m));
        }
        let mut j = args.clone();
        j.push("--json".into());
        let out = run(&j);
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert!(
                err.contains("--") && !err.contains("NaN"),
                "{args:?}: {err}"
            );
            return Ok(());
        }
        ok_runs.set(ok_runs.get() + 1);
        let v: Value = serde_json::from_slice(&out.stdout).unwrap();
        prop_assert!(all_finite(&v), "{args:?}: {v}");
        let k = v["recommended"]["span_k"].as_u64().unwrap() as u32;
        for t in v["tooth"].as_array().unwrap() {
            let x_e = t["generating_shift"].as_f64().unwrap();
            let g = construct::Gear3::new(m, a.to_radians(), b.abs().to_radians(), z, x_e);
            let c = construct::span(&g, k).unwrap();
            let sp = &t["span"];
            prop_assert!(
                (sp["span_mm"].as_f64().unwrap() - c.span_mm).abs() < 1e-9 * (1.0 + c.span_mm)
            );
            prop_assert!(
                (sp["contact_diameter_mm"].as_f64().unwrap() - c.contact_diameter_mm).abs()
                    < 1e-8 * (1.0 + c.contact_diameter_mm),
                "{args:?}: {sp} vs {c:?}"
            );
            if let Some(w) = w {
                prop_assert!(c.axial_mm < w * m);
            }
            let ball = t["ball"]["ball_mm"].as_f64().unwrap();
            let cb = construct::ball(&g, ball).unwrap();
            prop_assert!(
                (t["ball"]["dimension_mm"].as_f64().unwrap() - cb.dimension_mm).abs()
                    < 1e-6 * (1.0 + m),
                "{args:?}: {} vs {cb:?}",
                t["ball"]
            );
            prop_assert!(
                (t["ball"]["contact_diameter_mm"].as_f64().unwrap() - cb.contact_diameter_mm).abs()
                    < 1e-5 * (1.0 + m)
            );
        }
        // DIN 3960's k when it is measurable at every thickness case.
        let g0 = construct::Gear3::new(m, a.to_radians(), b.abs().to_radians(), z, x);
        let din = construct::din3960_k(&g0, x);
        let mut with_din = args.clone();
        with_din.push(format!("--span-k={din}"));
        if din != k && din >= 1 && din < z {
            prop_assert!(
                !run(&with_din).status.success(),
                "{args:?}: k {k} but DIN {din} is measurable"
            );
        }
        // The recommended k given back is accepted.
        let mut with_k = args.clone();
        with_k.push(format!("--span-k={k}"));
        let again = run(&with_k);
        prop_assert!(
            again.status.success(),
            "{args:?} --span-k={k}: {}",
            String::from_utf8_lossy(&again.stderr)
        );
        Ok(())
    };
    let cfg = Config {
        cases: 10,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[5u8; 32], [21u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
    assert!(ok_runs.get() >= 15, "only {} runs computed", ok_runs.get());
}

/// Random invalid options: exit 2, a message that names the option, never NaN.
#[test]
fn gear_refuses_random_invalid_input_naming_the_option() {
    let strategy = prop_oneof![
        prop_oneof![
            Just(-1.0),
            Just(0.0),
            Just(1e-300),
            Just(5e-3),
            Just(2e3),
            Just(1e300)
        ]
        .prop_map(|m: f64| (
            vec![format!("--module={m}"), "--teeth=20".to_string()],
            "--module"
        )),
        (-89.0..-60.0f64).prop_map(|b| (
            strings(&["--module=1", "--teeth=20"])
                .into_iter()
                .chain([format!("--helix={b}")])
                .collect(),
            "helix"
        )),
        (0u32..3).prop_map(|z| (
            vec!["--module=1".to_string(), format!("--teeth={z}")],
            "--teeth"
        )),
        (0.01..1.2f64).prop_map(|d| (
            vec![
                "--module=2".to_string(),
                "--teeth=20".to_string(),
                format!("--ball={d}")
            ],
            "--ball"
        )),
        (12u32..40).prop_map(|k| (
            vec![
                "--module=2".to_string(),
                "--teeth=20".to_string(),
                format!("--span-k={k}")
            ],
            "--span-k"
        )),
        (45.0..90.0f64).prop_map(|a| (
            vec![
                "--module=2".to_string(),
                "--teeth=20".to_string(),
                format!("--pressure-angle={a}")
            ],
            "--pressure-angle"
        )),
        (1.5..5.0f64).prop_map(|x| (
            vec![
                "--module=2".to_string(),
                "--teeth=20".to_string(),
                format!("--shift={x}")
            ],
            "--shift"
        )),
        prop_oneof![1.0..37.5f64, 44.01..300.0f64].prop_map(|d| (
            vec![
                "--module=2".to_string(),
                "--teeth=20".to_string(),
                format!("--at-diameter={d}")
            ],
            "--at-diameter"
        )),
    ];
    let check = |(args, flag): (Vec<String>, &str)| {
        let out = run(&args);
        prop_assert_eq!(out.status.code(), Some(2), "{:?}", args);
        let err = String::from_utf8_lossy(&out.stderr);
        prop_assert!(
            err.contains(flag) && !err.contains("NaN"),
            "{args:?}: {err}"
        );
        Ok(())
    };
    let cfg = Config {
        cases: 16,
        failure_persistence: None,
        ..Config::default()
    };
    let mut r = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[9u8; 32]),
    );
    r.run(&strategy, check).unwrap();
    TestRunner::new(cfg).run(&strategy, check).unwrap();
}

/// Random option sets over the whole command (internal gears, mates, centre distances,
/// face widths, allowances, diameters, balls): exit 0 ⇒ no NaN anywhere (serde writes NaN as
/// null, so every field that is not optional must be a finite number); exit ≠ 0 ⇒ exit 2 and a
/// message naming an option, never NaN or a panic.
#[test]
fn gear_random_option_sets_never_print_nan() {
    type Opts = (
        (f64, u32, f64, f64, bool),
        (Option<(u32, Option<f64>, Option<f64>)>, Option<f64>),
        (Option<(f64, f64)>, Option<f64>, Option<f64>),
    );
    let strategy = (
        (
            0.3..10.0f64,
            5u32..200,
            -45.0..45.0f64,
            -0.6..1.2f64,
            prop::bool::weighted(0.3),
        ),
        (
            prop::option::weighted(
                0.5,
                (
                    5u32..120,
                    prop::option::of(-0.6..1.2f64),
                    prop::option::weighted(0.3, 10.0..600.0f64),
                ),
            ),
            prop::option::weighted(0.3, 1.0..100.0f64),
        ),
        (
            prop::option::weighted(0.3, (-0.2..0.0f64, -0.1..0.0f64)),
            prop::option::weighted(0.2, 5.0..300.0f64),
            prop::option::weighted(0.2, 0.5..20.0f64),
        ),
    );
    let check = |((m, z, b, x, internal), (mate, w), (al, at, ball)): Opts| {
        let mut a = vec![
            format!("--module={m}"),
            format!("--teeth={z}"),
            format!("--helix={b}"),
            format!("--shift={x}"),
            "--json".to_string(),
        ];
        if internal {
            a.push("--internal".into());
        }
        if let Some((z2, x2, cd)) = mate {
            a.push(format!("--mate-teeth={z2}"));
            if let Some(x2) = x2 {
                a.push(format!("--mate-shift={x2}"));
            } else if let Some(cd) = cd {
                a.push(format!("--centre-distance={cd}"));
            }
        }
        if let Some(w) = w {
            a.push(format!("--width={w}"));
        }
        if let Some((l, u)) = al {
            a.push(format!("--allowances={l},{u}"));
        }
        if let Some(d) = at {
            a.push(format!("--at-diameter={d}"));
        }
        if let Some(d) = ball {
            a.push(format!("--ball={d}"));
        }
        let out = run(&a);
        if out.status.success() {
            let v: Value = serde_json::from_slice(&out.stdout).unwrap();
            prop_assert!(all_finite(&v), "{a:?}");
            for t in v["tooth"].as_array().unwrap() {
                for (key, val) in t.as_object().unwrap() {
                    if key == "root_form_diameter_mm" {
                        continue;
                    }
                    prop_assert!(!val.is_null(), "{a:?}: tooth.{key} is null");
                }
                for key in ["span", "ball"] {
                    for (k2, v2) in t[key].as_object().unwrap() {
                        prop_assert!(!v2.is_null(), "{a:?}: tooth.{key}.{k2} is null");
                    }
                }
            }
            for d in v["at_diameter"].as_array().unwrap() {
                for (k2, v2) in d.as_object().unwrap() {
                    prop_assert!(!v2.is_null(), "{a:?}: at_diameter.{k2} is null");
                }
            }
            if let Some(p) = v["pair"].as_object() {
                for key in [
                    "centre_distance_mm",
                    "working_pressure_angle_deg",
                    "shift_sum",
                    "transverse_contact_ratio",
                    "working_diameter_1_mm",
                    "working_diameter_2_mm",
                ] {
                    prop_assert!(
                        p[key].as_f64().is_some_and(f64::is_finite),
                        "{a:?}: pair.{key}"
                    );
                }
            }
        } else {
            prop_assert_eq!(out.status.code(), Some(2), "{:?}", a);
            let err = String::from_utf8_lossy(&out.stderr);
            let msg = err.split("error:").last().unwrap_or("");
            prop_assert!(msg.contains("--") && !err.contains("NaN"), "{a:?}: {err}");
        }
        Ok(())
    };
    let cfg = Config {
        cases: 20,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[31u8; 32], [32u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
}

/// `--at-diameter` above the tip printed a negative thickness: the tooth is not there.
#[test]
fn at_diameter_outside_the_tooth_is_refused() {
    let out = gearcomp(&["--module", "1", "--teeth", "20", "--at-diameter", "30"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--at-diameter 30 mm") && err.contains("18.7939 … 22.0000 mm"),
        "{err}"
    );
    // At the tip circle itself: the tip thickness s_an of TV1 (0.6949 mm).
    let v = json(&["--module", "1", "--teeth", "20", "--at-diameter", "22"]);
    close(&v, "at_diameter.0.transverse_thickness_mm", 0.6949, 5e-5);
}

/// Mating-gear options without --mate-teeth were ignored with exit 0 (--mate-allowances,
/// --mate-width); a mate shift derived from --centre-distance was reported as "--mate-shift"
/// (an option the user had not written); an external tip circle below the base circle named
/// no option and printed "… inf mm".
#[test]
fn mate_options_and_derived_mate_shift_name_what_the_user_wrote() {
    for (flag, value) in [
        ("--mate-allowances", "-0.05,-0.02"),
        ("--mate-width", "20"),
        ("--mate-shift", "0.2"),
        ("--centre-distance", "21"),
    ] {
        let out = gearcomp(&["--module", "1", "--teeth", "20", &format!("{flag}={value}")]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{flag}: {err}");
        assert!(
            err.contains(flag) && err.contains("--mate-teeth"),
            "{flag}: {err}"
        );
    }
    let out = gearcomp(&["--module", "1", "--teeth", "10", "--shift=-1.5"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--shift") && err.contains("tip diameter d_a = 9 mm") && !err.contains("inf"),
        "{err}"
    );
    // random pairs whose a_w asks for x2 far beyond any valid tooth: a_w from
    // inv α_wt = inv α_t + 2 tan α_n (x1 + x2)/(z1 + z2) written here (ISO 21771 6.2)
    let inv = |a: f64| a.tan() - a;
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: 24,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &[23; 32]),
    );
    let strategy = (
        0.5..10.0f64,
        17.0..25.0f64,
        0.0..30.0f64,
        20u32..120,
        12u32..120,
        10.5..14.0f64,
    );
    runner
        .run(&strategy, |(m, a_deg, b_deg, z1, z2, x2)| {
            let (an, b) = (a_deg.to_radians(), b_deg.to_radians());
            let at = (an.tan() / b.cos()).atan();
            let zs = f64::from(z1 + z2);
            let target = inv(at) + 2.0 * an.tan() * x2 / zs;
            let (mut lo, mut hi) = (0.0f64, 1.5f64);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if inv(mid) < target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            let a_w = 0.5 * m / b.cos() * zs * at.cos() / (0.5 * (lo + hi)).cos();
            let args = [
                format!("--module={m}"),
                format!("--pressure-angle={a_deg}"),
                format!("--helix={b_deg}"),
                format!("--teeth={z1}"),
                format!("--mate-teeth={z2}"),
                format!("--centre-distance={a_w}"),
            ];
            let out = run(&args);
            let err = String::from_utf8_lossy(&out.stderr);
            prop_assert_eq!(out.status.code(), Some(2), "{:?}: {}", args, err);
            prop_assert!(
                err.contains("x2 (from --centre-distance)") && !err.contains("--mate-shift"),
                "{:?}: {}",
                args,
                err
            );
            Ok(())
        })
        .unwrap();
}

/// The tester's findings on `gear` (F1–F7): exit codes and messages naming the option the
/// user wrote, the value and the range.
fn fails_with(args: &[&str], needles: &[&str], absent: &[&str]) {
    let out = gearcomp(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?} should fail: {err}");
    assert!(out.stdout.is_empty(), "{args:?}: output on failure");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err:?} lacks {n:?}");
    }
    for n in absent {
        assert!(!err.contains(n), "{args:?}: {err:?} has {n:?}");
    }
}

/// F1: a NaN (or ∞) in one of two allowances was dropped by the lower/upper sort.
#[test]
fn f1_non_finite_allowance_is_refused_naming_the_option() {
    let g = ["--module", "2", "--teeth", "30"];
    for v in ["nan,0", "nan,-0.05", "0,nan", "inf,0", "-0.05,-inf", "nan"] {
        let a = format!("--allowances={v}");
        let bad = v
            .split(',')
            .find(|s| s.contains("nan") || s.contains("inf"))
            .unwrap();
        let args = [&g[..], &[a.as_str(), "--json"]].concat();
        fails_with(&args, &["--allowances", &format!("'{bad}'"), "finite"], &[]);
        let a = format!("--mate-allowances={v}");
        let args = [&g[..], &["--mate-teeth", "20", a.as_str(), "--json"]].concat();
        fails_with(
            &args,
            &["--mate-allowances", &format!("'{bad}'"), "finite"],
            &[],
        );
    }
    // through a TOML file too (TOML has nan)
    let dir = std::env::temp_dir().join(format!("gearcomp-f1-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("gear.toml");
    std::fs::write(&f, "module = 2\nteeth = 30\nallowances = [nan, 0.0]\n").unwrap();
    fails_with(
        &["--file", f.to_str().unwrap()],
        &["--allowances=NaN,0", "NaN is not a number of mm"],
        &[],
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// F2: errors in the mate's allowances named --allowances.
#[test]
fn f2_mate_allowance_errors_name_mate_allowances() {
    for v in ["2", "-5", "1e308"] {
        let a = format!("--mate-allowances=-0.05,{v}");
        fails_with(
            &["--module", "2", "--teeth", "30", "--mate-teeth", "20", &a],
            &["--mate-allowances", &format!("= {v} mm"), "-1 … 1 mm"],
            &["--allowances:"],
        );
    }
    // this gear's own allowances still name --allowances
    fails_with(
        &[
            "--module",
            "2",
            "--teeth",
            "30",
            "--mate-teeth",
            "20",
            "--allowances=-0.05,2",
        ],
        &["--allowances", "= 2 mm"],
        &["--mate-allowances"],
    );
}

/// F3: the recommended ball at α_n ≤ 3° touched at the base circle (reference values solved
/// independently: inv α_K = inv α_t − e_t/d + D/(d_b·cos β_b), d_c = d + 2·x·m_n).
#[test]
fn f3_recommended_ball_at_small_pressure_angles() {
    for (args, want, d_c) in [
        (
            [
                "--module",
                "1.66854",
                "--teeth",
                "127",
                "--pressure-angle",
                "2.682",
                "--helix",
                "0",
            ],
            2.625466,
            211.9046,
        ),
        (
            [
                "--module",
                "2",
                "--teeth",
                "80",
                "--pressure-angle",
                "3",
                "--helix",
                "30",
            ],
            3.148178,
            184.7521,
        ),
        (
            [
                "--module",
                "2",
                "--teeth",
                "200",
                "--pressure-angle",
                "2",
                "--helix",
                "0",
            ],
            3.144435,
            400.0,
        ),
    ] {
        let v = json(&args);
        close(&v, "recommended.ball_mm", want, 1e-6);
        close(&v, "recommended.ball_contact_diameter_mm", d_c, 5e-5);
        assert_eq!(v["recommended"]["ball_at_target"], true, "{args:?}");
        close(&v, "tooth.0.ball.contact_diameter_mm", d_c, 5e-5);
    }
}

/// F4: an undercut gear whose d + 2·x·m_n lies inside the base circle: the output says
/// where the recommended ball really touches, and the JSON carries it.
#[test]
fn f4_recommended_ball_of_undercut_gear_says_where_it_touches() {
    for args in [
        &["--module", "1.64319", "--teeth", "10", "--shift=-0.4572"][..],
        &[
            "--module",
            "2.22872",
            "--teeth",
            "8",
            "--helix=29.5821",
            "--shift=-0.4876",
            "--width",
            "10.4354",
        ][..],
    ] {
        let v = json(args);
        assert_eq!(v["recommended"]["ball_at_target"], false, "{args:?}");
        let d_b = num(&v, "gear.base_diameter_mm");
        let d_c = num(&v, "recommended.ball_contact_diameter_mm");
        assert!(d_c > d_b + 0.1, "{args:?}: contact {d_c} vs d_b {d_b}");
        assert!(num(&v, "recommended.ball_target_diameter_mm") < d_b);
        close(&v, "tooth.0.ball.contact_diameter_mm", d_c, 1e-9);
        let out = gearcomp(args);
        let text = String::from_utf8_lossy(&out.stdout);
        let line = text.lines().find(|l| l.contains("recommended:")).unwrap();
        assert!(
            line.contains("middle of the usable flank") && line.contains("off the usable flank"),
            "{line}"
        );
    }
    // a gear on target keeps the old wording
    let out = gearcomp(&["--module", "2", "--teeth", "30"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("(touching at d + 2·x·m_n = 60.0000 mm)"),
        "{text}"
    );
}

/// F5: a pointed tool tooth named --dedendum-coeff with min > max; it is the pressure
/// angle's limit for this rack (32.14° for DIN 867), and both options when both were given.
#[test]
fn f5_pointed_tool_names_the_pressure_angle_and_its_limit() {
    let g = ["--module", "2", "--teeth", "30"];
    for a in ["40", "32.15", "44"] {
        let args = [&g[..], &["--pressure-angle", a]].concat();
        fails_with(
            &args,
            &[
                "--pressure-angle:",
                &format!("α_n = {a}°"),
                "below 32.1419076353°",
            ],
            &["--dedendum-coeff", "dedendum_coeff"],
        );
    }
    fails_with(
        &[&g[..], &["--dedendum-coeff", "2.2"]].concat(),
        &[
            "--pressure-angle/--dedendum-coeff",
            "h_fP* = 2.2",
            "below 2.15786371922",
        ],
        &[],
    );
    // the default rack works up to the limit (root radius reduced to what the tip carries)
    for a in ["25", "30", "32.14"] {
        let v = json(&[&g[..], &["--pressure-angle", a]].concat());
        assert!(all_finite(&v), "{a}: {v}");
    }
    let out = Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(["gear", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&out.stdout);
    assert!(
        help.contains("atan(π/(4·h_fP*))") && help.contains("32.14"),
        "{help}"
    );
}

/// F6: h_fP* = h_aP* was refused with "range 1.2 … 2.157864" (1.2 inside it).
#[test]
fn f6_dedendum_bound_is_shown_exclusive() {
    fails_with(
        &[
            "--module",
            "2",
            "--teeth",
            "30",
            "--addendum-coeff",
            "1.2",
            "--dedendum-coeff",
            "1.2",
        ],
        &[
            "--dedendum-coeff:",
            "h_fP* = 1.2",
            "above 1.2 (the addendum coefficient",
            "below 2.15786371922",
        ],
        &["dedendum_coeff", "1.2 … "],
    );
    let v = json(&[
        "--module",
        "2",
        "--teeth",
        "30",
        "--addendum-coeff",
        "1.2",
        "--dedendum-coeff",
        "1.2000001",
    ]);
    assert!(all_finite(&v));
    fails_with(
        &[
            "--module",
            "2",
            "--teeth",
            "30",
            "--dedendum-coeff",
            "3.5",
            "--pressure-angle",
            "5",
        ],
        &["--dedendum-coeff:", "h_fP* = 3.5", "at most 3"],
        &[],
    );
}

/// F7: α_n = 1e-300° printed "z ≥ inf".
#[test]
fn f7_tiny_pressure_angle_prints_no_inf() {
    let out = gearcomp(&["--module", "2", "--teeth", "30", "--pressure-angle=1e-300"]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        !text.contains("inf") && !text.contains("NaN") && !text.contains('∞'),
        "{text}"
    );
    assert!(
        text.contains("no tooth count up to 10000 avoids it"),
        "{text}"
    );
}
