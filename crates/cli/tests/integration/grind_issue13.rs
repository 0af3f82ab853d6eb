//! Issue 13 items 2–5 through the binary: the bounded worm, the robust search, the iterated
//! solve, the usable flank, profile shift, degenerate gears and the ISO 1328 evaluation over
//! several traces. The independent references are the bounded brute-force envelope of the
//! grinding crate's tests (`brute_envelope.rs`: −0.3673 µm at the item-2 point, the issue's
//! independent −0.367 µm) and closed forms written here.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{gearcomp_cmd as gearcomp, gearcomp_json};

fn f(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap()
}

/// The item-2 command; `end` replaces its --roll-end-mm.
fn item2_args(end: &str, q: &str) -> Vec<String> {
    [
        "grind",
        "simulate",
        "--teeth",
        "62",
        "--module-mm",
        "1.0",
        "--pressure-angle-deg",
        "17.933",
        "--helix-angle-deg=-10.35",
        "--worm-radius-mm",
        "114.024",
        "--flank",
        "left",
        "--roll-start-mm",
        "8.127",
        "--roll-end-mm",
        end,
        "--grid-w",
        "5",
        "--face-width-mm",
        "16.78",
        "--grid-z",
        "5",
        "--worm-rho-deg=-27.106",
        "--diagonal-ratio=1.4872868675123294",
        "--shift-offset-mm=14.153",
        "--worm-c=301.443014935705,7.156780488102248,0.042326528055858376",
        "--worm-l=-13.37289545684647,0.2524376444872974",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([format!("--worm-q={q}")])
    .collect()
}

fn err_of(args: &[&str]) -> String {
    let out = gearcomp().args(args).output().unwrap();
    assert!(!out.status.success(), "{args:?} succeeded");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Item 2. The exact command ends its roll range at 12.9876 mm, beyond the tip circle of this
/// gear (w_a = √(r_a² − r_b²) = 12.6888 mm, r_a = 32.5119, r_b = 29.9342 mm): refused, naming
/// the option and the range. Ending at 12.6 mm, the first point of the last column (w 8.127,
/// z 8.39) is −0.3673 µm (was −2987.10 µm), no point is flagged; all numbers finite.
#[test]
fn item2_silent_3mm_error_is_gone() {
    let a = item2_args("12.9876", "-76.36925062461678");
    let e = err_of(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(
        e.contains("--roll-end-mm = 12.9876") && e.contains("12.6888"),
        "{e}"
    );
    let a = item2_args("12.6", "-76.36925062461678");
    let v = gearcomp_json(&a.iter().map(String::as_str).collect::<Vec<_>>());
    let g = f(&v["map"]["ground_um"][0][4]);
    assert!((g + 0.3673).abs() < 1e-3, "{g}");
    assert_eq!(v["flagged_points"].as_array().unwrap().len(), 0);
    for row in v["map"]["ground_um"].as_array().unwrap() {
        for x in row.as_array().unwrap() {
            assert!(x.as_f64().unwrap().is_finite());
        }
    }
    let r = &v["worm_radii_mm"];
    assert!((f(&r[0]) - 112.774).abs() < 1e-9 && (f(&r[1]) - 115.274).abs() < 1e-9);
}

/// Item 2, the flag: a worm modification with −1000 µm/mm² profile curvature makes envelope
/// and first-order map differ by up to 100 µm, far beyond the second-order model: the points
/// are listed in `flagged_points` and a warning is printed (stderr with --json).
#[test]
fn item2_points_beyond_second_order_are_flagged() {
    let a = item2_args("12.6", "-1000");
    let out = gearcomp().args(&a).arg("--json").output().unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let flagged = v["flagged_points"].as_array().unwrap();
    assert!(!flagged.is_empty());
    let p = &flagged[0];
    assert!((f(&p["ground_um"]) - f(&p["analytic_um"])).abs() > 1.0);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("warning") && err.contains("second-order"),
        "{err}"
    );
}

/// Item 3: `grind solve --gear-rho-deg 0 --gear-l=0,0.3` grinds every point (was: "did not
/// converge in 40 iterations"), and the iterated solve meets the 27 µm twist within 0.5 %.
#[test]
fn item3_plain_twist_solves() {
    let v = gearcomp_json(&["grind", "solve", "--gear-rho-deg", "0", "--gear-l=0,0.3"]);
    let s = &v["solve"];
    assert_eq!(s["converged"], true);
    assert!((f(&s["wish_max_abs_um"]) - 27.0).abs() < 1e-9);
    assert!(f(&v["max_abs_deviation_um"]) < 0.005 * 27.0);
}

/// Item 4: the figures for the first-order worm (1.44 % of a −0.02 µm/mm² lead
/// crowning, 0.38 µm of a 0.2 µm/mm² twist) and the iteration below 0.5 % of the wish, with
/// the iterations reported.
#[test]
fn item4_iterated_solve_reports_iterations() {
    for (arg, wish, first_lo, first_hi) in [
        ("--gear-c=0,0,-0.02", 4.5, 0.0640, 0.0650),
        ("--gear-l=0,0.2", 18.0, 0.380, 0.386),
    ] {
        let v = gearcomp_json(&["grind", "solve", "--gear-rho-deg", "0", arg]);
        let s = &v["solve"];
        let it = s["iterations"].as_array().unwrap();
        assert!(it.len() >= 2, "{arg}");
        let first = f(&it[0]["max_abs_deviation_um"]);
        assert!(first > first_lo && first < first_hi, "{arg}: {first}");
        assert!((f(&s["wish_max_abs_um"]) - wish).abs() < 1e-9);
        let rem = f(&s["remaining_um"]);
        assert!(
            rem <= 0.005 * wish && s["converged"] == true,
            "{arg}: {rem}"
        );
        assert_eq!(rem, f(&v["max_abs_deviation_um"]));
        assert!(f(&s["remaining_percent_of_wish"]) < 0.5);
    }
}

/// Item 5: the usable flank. Default gear (z 31, m_n 3, α_n 20°, β 15°): tip w_a = 24.2070 mm,
/// root form (DIN 867 rack) w_Ff = r·sin α_t − h_FfP/sin α_t = 7.7391 mm; --roll-end-mm 40 and
/// --roll-start-mm 5 are refused naming the option and the range; z = 2 and a pointed tooth are
/// refused naming --teeth / --profile-shift.
#[test]
fn item5_range_and_degenerate_gears_are_refused() {
    let e = err_of(&["grind", "simulate", "--roll-end-mm", "40"]);
    assert!(
        e.contains("--roll-end-mm = 40") && e.contains("24.2070") && e.contains("7.7391"),
        "{e}"
    );
    let e = err_of(&["grind", "simulate", "--roll-start-mm", "5"]);
    assert!(
        e.contains("--roll-start-mm = 5") && e.contains("root form circle"),
        "{e}"
    );
    let e = err_of(&["grind", "simulate", "--teeth", "2"]);
    assert!(e.contains("--teeth") && e.contains("3"), "{e}");
    let e = err_of(&[
        "grind",
        "solve",
        "--gear-rho-deg",
        "0",
        "--profile-shift",
        "3",
    ]);
    assert!(
        e.contains("--profile-shift") && e.contains("pointed"),
        "{e}"
    );
    let e = err_of(&["grind", "simulate", "--worm-tip-radius-mm", "120"]);
    assert!(e.contains("--worm-tip-radius-mm"), "{e}");
    // closed forms of the limits
    let (m, z, an, b) = (3.0f64, 31.0, 20f64.to_radians(), 15f64.to_radians());
    let r = z * m / (2.0 * b.cos());
    let at = (an.tan() / b.cos()).atan();
    let rb = r * at.cos();
    let w_tip = ((r + m).powi(2) - rb * rb).sqrt();
    let w_ff = r * at.sin() - m * (1.25 - 0.25 * (1.0 - an.sin())) / at.sin();
    assert!((w_tip - 24.2070).abs() < 5e-5 && (w_ff - 7.7391).abs() < 5e-5);
}

/// Item 5: profile shift x = 0.5. The worm runs at d = r1 + r2 + x·m_n = 179.6403 mm, an
/// unmodified worm grinds the shifted involute exactly, and the usable flank ends at the
/// shifted tip w_a = √((r + m_n·(1 + x))² − r_b²) = 27.2333 mm: 26 mm is accepted (beyond
/// the unshifted tip 24.207 mm), 27.3 refused.
#[test]
fn item5_profile_shift() {
    let v = gearcomp_json(&[
        "grind",
        "simulate",
        "--profile-shift",
        "0.5",
        "--roll-end-mm",
        "26",
        "--grid-w",
        "7",
        "--grid-z",
        "5",
    ]);
    assert!((f(&v["path"]["centre_distance_mm"]) - (130.0 + 48.140342 + 1.5)).abs() < 1e-5);
    assert!(
        f(&v["max_abs_ground_um"]) < 1e-6,
        "{}",
        v["max_abs_ground_um"]
    );
    assert_eq!(f(&v["profile_shift"]), 0.5);
    let (m, z, an, b) = (3.0f64, 31.0, 20f64.to_radians(), 15f64.to_radians());
    let r = z * m / (2.0 * b.cos());
    let rb = r * (an.tan() / b.cos()).atan().cos();
    let w_tip = ((r + 1.5 * m).powi(2) - rb * rb).sqrt();
    assert!((w_tip - 27.2333).abs() < 5e-5, "{w_tip}");
    let e = err_of(&[
        "grind",
        "simulate",
        "--profile-shift",
        "0.5",
        "--roll-end-mm",
        "27.3",
    ]);
    assert!(e.contains("--roll-end-mm") && e.contains("27.2333"), "{e}");
}

/// Item 5: ISO 1328-1 over three profile and three helix traces. A solved 0.2 µm/mm² twist
/// (18 µm at the corners): from the design (wish removed) the flank is class 1; from the
/// involute the twist shows as f_Hα/f_Hβ on the outer traces (±0.2·12·... µm by hand:
/// f_Hα = 0.2·z·L_α at z = ±13.5 over L_α = 11.4 mm ⇒ ±30.78 µm) while the single mid-face
/// trace of `iso1328` sees no slope; f_pt/F_p are stated as not evaluated.
#[test]
fn item5_iso_traces_see_the_twist() {
    let v = gearcomp_json(&["grind", "solve", "--gear-rho-deg", "0", "--gear-l=0,0.2"]);
    let t = &v["iso1328_traces"];
    assert_eq!(t["from_design"]["profiles"].as_array().unwrap().len(), 3);
    assert_eq!(t["from_design"]["helices"].as_array().unwrap().len(), 3);
    assert_eq!(t["from_design"]["class_achieved"], 1);
    let inv = &t["from_involute"];
    let fha = f(&inv["profile_worst"]["slope_um"]).abs();
    assert!((fha - 0.2 * 13.5 * 11.4).abs() < 0.2, "{fha}");
    assert_eq!(inv["within_tolerance"], false);
    assert!(inv["class_achieved"].as_u64().unwrap_or(12) > 6);
    assert!(f(&v["iso1328"]["profile"]["slope_um"]).abs() < 0.2);
    assert!(t["from_design"]["pitch"]
        .as_str()
        .unwrap()
        .contains("not evaluated"));
}

mod binary_props {
    //! A few random cases through the binary: random gear and worm geometry (teeth, module,
    //! pressure angle, helix angle, profile shift, worm starts, radius, hand, flank, diagonal
    //! ratio, shift offset) with a uniform worm stock c0. Exit 0 ⇒ every number of the map is
    //! finite and the ground flank is the closed form f_Ft2 = −c0·cos β_b1/cos β_b2 (38) within
    //! 1e-6 µm, sin β_b = sin β·cos α_n, cos β1 = z1·m_n/(2·r1) signed by the hand; exit ≠ 0 ⇒
    //! the message names an option. Random invalid options are refused naming the option.
    use super::*;
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};

    fn runners(cases: u32) -> [TestRunner; 2] {
        let fixed = Config {
            cases,
            rng_seed: RngSeed::Fixed(0x0013_5eed),
            failure_persistence: None,
            ..Config::default()
        };
        let fresh = Config {
            cases,
            failure_persistence: None,
            ..Config::default()
        };
        [TestRunner::new(fixed), TestRunner::new(fresh)]
    }

    #[allow(clippy::type_complexity)]
    fn valid() -> impl Strategy<
        Value = (
            (u32, f64, f64, f64, f64),
            (u32, f64, bool, bool),
            (f64, f64, f64),
        ),
    > {
        (
            (
                17u32..80,
                1.0f64..5.0,
                17.0f64..25.0,
                -25.0f64..25.0,
                0.0f64..0.5,
            ),
            (1u32..4, 20.0f64..40.0, any::<bool>(), any::<bool>()),
            (-1.0f64..1.0, -10.0f64..10.0, -20.0f64..20.0),
        )
    }

    #[test]
    fn uniform_stock_on_random_gears_is_the_closed_form() {
        for mut runner in runners(4) {
            runner
                .run(
                    &valid(),
                    |((z, m, a, b, x), (s, rpm, wh, fl), (k, zv, c0))| {
                        let r1 = rpm * m * f64::from(s).sqrt();
                        let args: Vec<String> = [
                            "grind".to_string(),
                            "simulate".into(),
                            format!("--teeth={z}"),
                            format!("--module-mm={m}"),
                            format!("--pressure-angle-deg={a}"),
                            format!("--helix-angle-deg={b}"),
                            format!("--profile-shift={x}"),
                            format!("--worm-starts={s}"),
                            format!("--worm-radius-mm={r1}"),
                            format!("--worm-hand={}", if wh { "right" } else { "left" }),
                            format!("--flank={}", if fl { "right" } else { "left" }),
                            format!("--diagonal-ratio={k}"),
                            format!("--shift-offset-mm={zv}"),
                            format!("--worm-c={c0}"),
                            "--grid-w=4".into(),
                            "--grid-z=3".into(),
                            "--json".into(),
                        ]
                        .to_vec();
                        let out = gearcomp().args(&args).output().unwrap();
                        if !out.status.success() {
                            let e = String::from_utf8_lossy(&out.stderr);
                            prop_assert!(e.contains("--"), "{args:?}: {e}");
                            return Ok(());
                        }
                        let v: serde_json::Value = serde_json::from_slice(&out.stdout)
                            .map_err(|e| TestCaseError::fail(e.to_string()))?;
                        let an = a.to_radians();
                        let sbb2 = b.to_radians().sin() * an.cos();
                        let cos_b1 = f64::from(s) * m / (2.0 * r1);
                        let sbb1 = cos_b1.acos().sin() * an.cos();
                        let want = -c0 * (1.0 - sbb1 * sbb1).sqrt() / (1.0 - sbb2 * sbb2).sqrt();
                        for key in ["ground_um", "analytic_um", "deviation_um"] {
                            for row in v["map"][key].as_array().unwrap() {
                                for g in row.as_array().unwrap() {
                                    let g = g.as_f64().unwrap();
                                    prop_assert!(g.is_finite());
                                    if key != "deviation_um" {
                                        prop_assert!(
                                            (g - want).abs() < 1e-6,
                                            "{key} {g} vs {want}"
                                        );
                                    }
                                }
                            }
                        }
                        prop_assert_eq!(v["flagged_points"].as_array().unwrap().len(), 0);
                        Ok(())
                    },
                )
                .unwrap();
        }
    }

    #[test]
    fn random_invalid_options_are_named() {
        let strat = prop_oneof![
            (0u32..3).prop_map(|z| ("--teeth", format!("--teeth={z}"))),
            (24.3f64..1e4).prop_map(|w| ("--roll-end-mm", format!("--roll-end-mm={w}"))),
            (-1e3f64..7.7).prop_map(|w| ("--roll-start-mm", format!("--roll-start-mm={w}"))),
            (4.0f64..9.0).prop_map(|x| ("--profile-shift", format!("--profile-shift={x}"))),
            (0.0f64..130.0)
                .prop_map(|r| ("--worm-tip-radius-mm", format!("--worm-tip-radius-mm={r}"))),
            (130.0f64..1e4).prop_map(|r| (
                "--worm-root-radius-mm",
                format!("--worm-root-radius-mm={r}")
            )),
        ];
        for mut runner in runners(6) {
            runner
                .run(&strat, |(opt, arg)| {
                    let e = err_of(&["grind", "simulate", &arg]);
                    prop_assert!(e.contains(opt), "{arg}: {e}");
                    Ok(())
                })
                .unwrap();
        }
    }
}
