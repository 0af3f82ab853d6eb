//! `request::solve_request` (what `gearcomp dress solve` runs) over random inputs, fixed seed
//! plus fresh ones: valid inputs never panic; a solution (exit 0) has finite numbers, its
//! dressing simulation (screw evaluation) agrees with the independent analytic envelope of
//! `analytic.rs`, and its ΔK reproduces the wanted modification at the target points by that
//! envelope; a refusal is a cause the user can act on (a TOML key, never a bare "did not
//! converge"); invalid inputs name the TOML key and its unit.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::analytic::Analytic;
use crate::common;

use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::request::{
    solve_request, DresserInput, Method, SolveInput, WormInput, DEFAULT_BUDGET_MM,
};
use gearcomp_dressing::worm::Flank;
use gearcomp_dressing::DressError;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};

/// Screw evaluation vs the analytic envelope (µm): both are exact constructions, the test's
/// bisections stop at 1e-13 mm, the chain velocity by central differences is good to ~1e-9.
const TOL_ENVELOPE_UM: f64 = 1e-3;
/// ΔK reproduces the targets (µm): the solver stops at 1e-9 mm (stall 1e-6 mm).
const TOL_TARGET_UM: f64 = 2e-3;

/// The envelope of one ΔK matches at G1-Z5 (docs/dressing.md "Reference case G1-Z5" root and a few others).
#[test]
fn analytic_envelope_matches_screw_evaluation_g1_z5() {
    let s = common::g1_z5();
    let (a, b) = s.active_profile(Flank::Right).unwrap();
    for dk in [
        AxisCorrection::default(),
        AxisCorrection::from_array([6.057e-4, 0.009739, -0.024495, -1.04127]),
        AxisCorrection::from_array([-2e-3, -0.01, 0.05, 2.0]),
    ] {
        let an = Analytic::new(&s, &dk);
        for q in [0.05, 0.3, 0.5, 0.7, 0.95] {
            let w = a + q * (b - a);
            let f_an = an.f_mm(Flank::Right, w).unwrap();
            let f_sc = s.dress_point(Flank::Right, w, &dk).unwrap().f_mm;
            assert!(
                (f_an - f_sc).abs() * 1e3 < TOL_ENVELOPE_UM,
                "{dk:?} w {w}: analytic {f_an} vs screw {f_sc}"
            );
        }
    }
}

#[derive(Debug, Clone)]
struct Case {
    worm: WormInput,
    dresser: DresserInput,
    solve: SolveInput,
}

fn valid_case() -> impl Strategy<Value = Case> {
    (
        (1u32..=6, 1.0f64..5.0, 40.0f64..90.0, 16.0f64..24.0),
        (25.0f64..45.0, 0.15f64..0.35, 0.0f64..0.01),
        (
            proptest::bool::ANY,
            0.0f64..0.12,
            prop_oneof![
                (-0.6f64..0.6).prop_map(|c| (Some(c), None)),
                (
                    0.02f64..0.3,
                    0.35f64..0.65,
                    0.7f64..0.98,
                    proptest::array::uniform3(-0.3f64..0.3)
                )
                    .prop_map(|(a, b, c, f)| (None, Some(vec![[a, f[0]], [b, f[1]], [c, f[2]]]))),
                // Four-point: four targets (minimum-norm correction).
                (
                    0.02f64..0.25,
                    0.3f64..0.45,
                    0.55f64..0.7,
                    0.75f64..0.98,
                    proptest::array::uniform4(-0.3f64..0.3)
                )
                    .prop_map(|(a, b, c, e, f)| (
                        None,
                        Some(vec![[a, f[0]], [b, f[1]], [c, f[2]], [e, f[3]]])
                    )),
            ],
        ),
    )
        .prop_map(
            |((z, m, d_rel, alpha), (da_rel, jw_rel, cl_rel), (left, wear, tgt))| {
                let d0 = d_rel * m;
                Case {
                    worm: WormInput {
                        starts: z,
                        diameter_mm: d0,
                        normal_module_mm: m,
                        profile_angle_deg: alpha,
                    },
                    dresser: DresserInput {
                        diameter_mm: da_rel * m,
                        jacket_width_mm: jw_rel * m,
                        clearance_mm: cl_rel * m,
                    },
                    solve: SolveInput {
                        flank: if left { Flank::Left } else { Flank::Right },
                        method: if tgt.1.as_ref().is_some_and(|p| p.len() == 4) {
                            Method::FourPoint
                        } else {
                            Method::ThreePoint
                        },
                        diameter_mm: (wear > 0.0).then_some(d0 * (1.0 - wear)),
                        crowning_um: tgt.0,
                        points: tgt.1,
                        budget_mm: DEFAULT_BUDGET_MM,
                        accept_penetration: false,
                    },
                }
            },
        )
}

fn run_valid(c: &Case) -> Result<(), TestCaseError> {
    let worm = match c.worm.build() {
        Ok(w) => w,
        Err(e) => return Err(TestCaseError::fail(format!("valid worm refused: {e}"))),
    };
    let dresser = match c.dresser.build(&worm) {
        Ok(d) => d,
        // A dresser that cannot be built is refused naming [dresser] (e.g. no fillet fits).
        Err(e) => {
            prop_assert!(e.to_string().starts_with("[dresser]"), "{e}");
            return Ok(());
        }
    };
    match solve_request(&worm, &dresser, &c.solve) {
        Err(e) => {
            let msg = e.to_string();
            prop_assert!(
                matches!(e, DressError::NotProducible { .. }),
                "a valid request must be solved or refused as not producible: {msg}"
            );
            prop_assert!(msg.contains("[solve]") && !msg.contains("NaN"), "{msg}");
        }
        Ok(o) => {
            let dk = o.solution.dk;
            for v in dk.to_array() {
                prop_assert!(v.is_finite());
            }
            prop_assert!(o.stretch.is_finite());
            prop_assert!(o.checks.ok(), "within the budget unless accepted");
            prop_assert!(
                o.checks.opposite_cut_mm.is_finite() && o.checks.jacket_depth_mm.is_finite()
            );
            let an = Analytic::new(&o.setup, &dk);
            let fl = c.solve.flank;
            // The targets, by the independent envelope.
            for (w, f) in o.target_w_mm.iter().zip(o.target_f_mm.iter()) {
                let f_an = an.f_mm(fl, *w).unwrap();
                prop_assert!(
                    (f_an - f).abs() * 1e3 < TOL_TARGET_UM,
                    "target at w {w}: wanted {} µm, analytic envelope {} µm",
                    f * 1e3,
                    f_an * 1e3
                );
            }
            // The dressing simulation over the evaluation range.
            let (a, b) = o.active_mm;
            for i in 1..=9 {
                let w = a + (b - a) * (0.05 + 0.9 * f64::from(i - 1) / 8.0);
                let f_sc = o.setup.dress_point(fl, w, &dk).unwrap().f_mm;
                let f_an = an.f_mm(fl, w).unwrap();
                prop_assert!(
                    (f_sc - f_an).abs() * 1e3 < TOL_ENVELOPE_UM,
                    "w {w}: screw {} µm vs analytic {} µm",
                    f_sc * 1e3,
                    f_an * 1e3
                );
            }
        }
    }
    Ok(())
}

fn runners(cases: u32) -> [TestRunner; 2] {
    let fixed = Config {
        cases,
        rng_seed: RngSeed::Fixed(0x0d2e_5513),
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

#[test]
fn random_valid_requests_agree_with_the_analytic_envelope() {
    for mut runner in runners(10) {
        runner.run(&valid_case(), |c| run_valid(&c)).unwrap();
    }
}

/// One key out of range: (TOML key, unit the message must carry, the mutated case).
fn invalid_case() -> impl Strategy<Value = (&'static str, &'static str, Case)> {
    let base = Case {
        worm: WormInput {
            starts: 5,
            diameter_mm: 160.0,
            normal_module_mm: 3.0,
            profile_angle_deg: 20.0,
        },
        dresser: DresserInput {
            diameter_mm: 100.0,
            jacket_width_mm: 0.8,
            clearance_mm: 0.0,
        },
        solve: SolveInput {
            flank: Flank::Right,
            method: Method::ThreePoint,
            diameter_mm: None,
            crowning_um: Some(0.2),
            points: None,
            budget_mm: 0.1,
            accept_penetration: false,
        },
    };
    let bad = prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        -1e6f64..-1e-9,
        1e3f64..1e7,
    ];
    (0usize..12, bad, 0.0f64..1.0).prop_map(move |(k, v, q)| {
        let mut c = base.clone();
        let (key, unit) = match k {
            0 => {
                c.worm.starts = if q < 0.5 { 0 } else { 21 + (q * 100.0) as u32 };
                ("[worm] starts", "")
            }
            1 => {
                c.worm.normal_module_mm = v;
                ("[worm] normal_module_mm", "mm")
            }
            2 => {
                c.worm.profile_angle_deg = if v.is_finite() {
                    v.clamp(-89.0, 4.9)
                } else {
                    v
                };
                ("[worm] profile_angle_deg", "degrees")
            }
            3 => {
                c.worm.diameter_mm = if v.is_finite() { 15.0 * q } else { v };
                ("[worm] diameter_mm", "mm")
            }
            4 => {
                c.dresser.diameter_mm = if v.is_finite() { 4.9 * q } else { v };
                ("[dresser] diameter_mm", "mm")
            }
            5 => {
                c.dresser.jacket_width_mm = if v.is_finite() { -v.abs() * q } else { v };
                ("[dresser] jacket_width_mm", "mm")
            }
            6 => {
                c.dresser.clearance_mm = v;
                ("[dresser] clearance_mm", "mm")
            }
            7 => {
                c.solve.diameter_mm = Some(if v.is_finite() { 160.0 + v.abs() } else { v });
                ("[solve] diameter_mm", "mm")
            }
            8 => {
                c.solve.diameter_mm = Some(53.0 * q);
                ("[solve] diameter_mm", "mm")
            }
            9 => {
                c.solve.crowning_um = Some(if v.is_finite() { 50.001 + v.abs() } else { v });
                ("[solve] crowning_um", "µm")
            }
            10 => {
                c.solve.crowning_um = None;
                let f = 0.05 + 0.9 * q;
                c.solve.points = Some(vec![[f, 0.0], [0.5, -0.2], [f, 0.0]]);
                ("[solve] points", "fraction")
            }
            _ => {
                c.solve.budget_mm = if v.is_finite() { -v.abs() - 1e-6 } else { v };
                ("[solve] budget_mm", "mm")
            }
        };
        (key, unit, c)
    })
}

fn run_invalid(key: &str, unit: &str, c: &Case) -> Result<(), TestCaseError> {
    let r = c.worm.build().and_then(|w| {
        let d = c.dresser.build(&w)?;
        solve_request(&w, &d, &c.solve).map(|_| ())
    });
    let Err(e) = r else {
        return Err(TestCaseError::fail(format!("{key} accepted: {c:?}")));
    };
    let msg = e.to_string();
    prop_assert!(msg.contains(key), "key {key} missing: {msg}");
    prop_assert!(msg.contains(unit), "unit {unit} missing: {msg}");
    for lib in ["_rad", "z_s", "d_s_mm", "alpha_n", "d_a_mm", "m_n_mm"] {
        prop_assert!(!msg.contains(lib), "library name {lib} in: {msg}");
    }
    Ok(())
}

#[test]
fn random_invalid_requests_name_the_key_and_unit() {
    for mut runner in runners(24) {
        runner
            .run(&invalid_case(), |(k, u, c)| run_invalid(k, u, &c))
            .unwrap();
    }
}

/// Four-point targets that are producible by construction: f at four random fractions from a
/// random ΔK, by the analytic envelope. The solve (minimum norm, a ΔK of its own) must hit
/// them on that envelope, or refuse with the key.
#[test]
fn random_four_point_targets_from_a_reachable_correction() {
    let strategy = (
        valid_case(),
        proptest::array::uniform4(-1.0f64..1.0),
        (0.02f64..0.25, 0.3f64..0.45, 0.55f64..0.7, 0.75f64..0.98),
    );
    for mut runner in runners(6) {
        runner
            .run(&strategy, |(mut c, k, q)| {
                let Ok(worm) = c.worm.build() else {
                    return Ok(());
                };
                let Ok(dresser) = c.dresser.build(&worm) else {
                    return Ok(());
                };
                let now = match c.solve.diameter_mm {
                    Some(d) => worm.worn(d).unwrap(),
                    None => worm,
                };
                let s = gearcomp_dressing::envelope::DressingSetup::new(now, dresser.clone());
                let fl = c.solve.flank;
                let Ok((a, b)) = s.active_profile(fl) else {
                    return Err(TestCaseError::fail("active profile of a valid worm"));
                };
                let dk =
                    AxisCorrection::from_array([2e-4 * k[0], 2e-3 * k[1], 0.01 * k[2], 0.3 * k[3]]);
                let an = Analytic::new(&s, &dk);
                let fr = [q.0, q.1, q.2, q.3];
                let mut pts = Vec::new();
                for f in fr {
                    let Some(v) = an.f_mm(fl, a + f * (b - a)) else {
                        return Ok(());
                    };
                    pts.push([f, 1e3 * v]);
                }
                if pts.iter().any(|p| p[1].abs() > 1000.0) {
                    return Ok(());
                }
                c.solve.method = Method::FourPoint;
                c.solve.crowning_um = None;
                c.solve.points = Some(pts.clone());
                match solve_request(&worm, &dresser, &c.solve) {
                    Err(e) => {
                        let msg = e.to_string();
                        prop_assert!(
                            matches!(e, DressError::NotProducible { .. })
                                && msg.contains("[solve] points"),
                            "{msg}"
                        );
                    }
                    Ok(o) => {
                        let an2 = Analytic::new(&o.setup, &o.solution.dk);
                        for p in &pts {
                            let f = an2.f_mm(fl, a + p[0] * (b - a)).unwrap();
                            prop_assert!(
                                (1e3 * f - p[1]).abs() < TOL_TARGET_UM,
                                "fraction {}: wanted {} µm, got {} µm",
                                p[0],
                                p[1],
                                1e3 * f
                            );
                        }
                    }
                }
                Ok(())
            })
            .unwrap();
    }
}
