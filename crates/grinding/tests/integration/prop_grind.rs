//! Property test of `grind` at library level (issue 13): random valid gear and worm geometry
//! (teeth, module, pressure angle, helix angle, profile shift, worm starts, radius and hand,
//! flank), worm line modifications, diagonal ratio and shift offset; gear points inside the
//! usable flank that the worm thread reaches. The envelope grinder must not panic; where it
//! returns a value, every number is finite and equals the independent bounded brute-force
//! envelope (`brute_envelope.rs`) within 1e-8 mm (normal; measured agreement ~1e-11 mm); where it refuses, the error names
//! the gear point. Random invalid inputs give errors that name the field.
//! Fixed seeds plus fresh ones; 16 + 16 cases, 3 points each (about 3 s in the test profile).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder};
use gearcomp_grinding::GrindError;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError, TestRunner};

use crate::brute_envelope::{brute_envelope, BruteSettings};

/// Stated tolerance of production vs brute force (mm, normal).
const TOL_MM: f64 = 1e-8;

#[derive(Debug, Clone)]
struct Case {
    teeth: u32,
    m_n: f64,
    alpha_deg: f64,
    beta_deg: f64,
    x: f64,
    starts: u32,
    worm_r_per_m: f64,
    worm_right: bool,
    right_flank: bool,
    rho1_deg: f64,
    c: Vec<f64>,
    l: Vec<f64>,
    q: Vec<f64>,
    k: f64,
    z_v01: f64,
    face_mm: f64,
    points: Vec<(f64, f64)>,
}

fn case() -> impl Strategy<Value = Case> {
    (
        (
            12u32..90,
            1.0f64..5.0,
            15.0f64..25.0,
            -30.0f64..30.0,
            -0.3f64..0.6,
        ),
        (1u32..4, 18.0f64..45.0, any::<bool>(), any::<bool>()),
        (
            -60.0f64..60.0,
            proptest::collection::vec(-1.0f64..1.0, 3),
            proptest::collection::vec(-1.0f64..1.0, 2),
            -1.0f64..1.0,
        ),
        (-2.0f64..2.0, -20.0f64..20.0, 10.0f64..40.0),
        proptest::collection::vec((0.0f64..1.0, -0.5f64..0.5), 3),
    )
        .prop_map(
            |(
                (teeth, m_n, alpha_deg, beta_deg, x),
                (starts, wr, wh, fl),
                (rho1, c, l, q),
                (k, zv, b),
                pts,
            )| {
                Case {
                    teeth,
                    m_n,
                    alpha_deg,
                    beta_deg,
                    x,
                    starts,
                    worm_r_per_m: wr,
                    worm_right: wh,
                    right_flank: fl,
                    rho1_deg: rho1,
                    // µm, µm/mm, µm/mm² (F_C); µm/mm, µm/mm² (F_L); µm/mm² (F_Q)
                    c: vec![10.0 * c[0], 0.5 * c[1], 0.01 * c[2]],
                    l: vec![1.0 * l[0], 0.02 * l[1]],
                    q: vec![0.05 * q],
                    k,
                    z_v01: zv,
                    face_mm: b,
                    points: pts,
                }
            },
        )
}

fn um(v: &[f64]) -> Poly {
    Poly(v.iter().map(|c| c * 1e-3).collect())
}

fn run_case(c: &Case) -> Result<(), TestCaseError> {
    let a = c.alpha_deg.to_radians();
    let flank = if c.right_flank {
        Flank::Right
    } else {
        Flank::Left
    };
    let gear =
        InvoluteGear::asymmetric(c.teeth, c.m_n, a, a, c.beta_deg.to_radians(), c.x).unwrap();
    // only gears the geometry crate accepts (no undercut, no pointed tooth)
    let Ok(lim) = gear.flank_limits(flank) else {
        return Ok(());
    };
    let r1 = c.worm_r_per_m * c.m_n * f64::from(c.starts).sqrt();
    let hand = if c.worm_right {
        Hand::Right
    } else {
        Hand::Left
    };
    let worm = InvoluteGear::worm(c.starts, c.m_n, a, r1, hand).unwrap();
    let Ok(pair) = WormGearPair::new(
        &worm,
        &gear,
        flank,
        r1 + gear.reference_radius_mm() + c.x * c.m_n,
        -(worm.beta_rad + gear.beta_rad),
    ) else {
        return Ok(());
    };
    let (root, tip) = (r1 - 1.25 * c.m_n, r1 + 1.25 * c.m_n);
    let rb1 = pair.worm.r_b_mm;
    let w1 = |r: f64| (r * r - rb1 * rb1).sqrt();
    let (pa, pb) = (pair.path.a, pair.path.b_mm);
    let (u1, u2) = ((w1(root) - pb) / pa, (w1(tip) - pb) / pa);
    // a worm tip reaching below the base circle undercuts the involute: `grind` refuses such
    // set-ups (the local envelope search would miss the undercut), so they are not drawn
    prop_assume!(u1.min(u2) > 0.05);
    let lo = lim.w_root_form_mm.max(u1.min(u2));
    let hi = lim.w_tip_mm.min(u1.max(u2));
    prop_assume!(hi > lo + 0.1);
    let m = LineModification::new(
        c.rho1_deg.to_radians(),
        pair.worm.w_ref_mm,
        um(&c.c),
        um(&c.l),
        um(&c.q),
    )
    .unwrap();
    let cpl = FeedCoupling::linear(c.k, c.z_v01).unwrap();
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
        .with_worm_radii(root, tip)
        .unwrap();
    let cb1 = pair.worm.beta_b_rad.cos();
    for &(fw, fz) in &c.points {
        // inside the roll range, 1 % away from its ends (a grid never samples past them)
        let w2 = lo + (hi - lo) * (0.01 + 0.98 * fw);
        let z2 = fz * c.face_mm;
        // the ray scan covers three times the worm modification at the analytic worm point
        let seed = pair.map_gear_point(&cpl, w2, z2);
        use gearcomp_grinding::modification::FlankModification;
        let half = 3.0 * (cb1 * m.f_ft_mm(seed.w1_mm, seed.z1_mm)).abs() + 0.02;
        let set = BruteSettings {
            w1_bounds_mm: (w1(root), w1(tip)),
            ray_half_mm: half,
            ray_step_mm: half / 40.0,
            half_u_mm: 2.0,
            half_v_mm: 8.0,
        };
        match g.grind_point(w2, z2) {
            Ok(p) => {
                for v in [p.f_n_mm, p.f_ft_mm, p.w1_mm, p.z1_mm, p.z_v2_mm, p.phi2_rad] {
                    prop_assert!(v.is_finite(), "{p:?}");
                }
                let b = brute_envelope(&pair, c.starts, &cpl, &m, &set, w2, z2);
                prop_assert!(
                    b.is_some(),
                    "brute force found no cut at ({w2}, {z2}): {p:?}"
                );
                let (t, bw1, _) = b.unwrap();
                prop_assert!(
                    (p.f_n_mm - t).abs() <= TOL_MM,
                    "({w2}, {z2}): grinder {} vs brute {} (worm w1 {} vs {})",
                    p.f_n_mm,
                    t,
                    p.w1_mm,
                    bw1
                );
            }
            Err(e) => {
                prop_assert!(
                    matches!(e, GrindError::NoWormContact { .. }) && e.to_string().contains("w = "),
                    "{e}"
                );
            }
        }
    }
    Ok(())
}

fn runners(cases: u32) -> [TestRunner; 2] {
    let fixed = Config {
        cases,
        rng_seed: RngSeed::Fixed(0x0013_9a1d),
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
fn grind_equals_bounded_brute_force_on_random_inputs() {
    for mut runner in runners(16) {
        runner.run(&case(), |c| run_case(&c)).unwrap();
    }
}

/// Random invalid inputs: each error names the field.
#[test]
fn invalid_grind_inputs_name_the_field() {
    let strat = prop_oneof![
        (0u32..3).prop_map(|z| ("teeth", z, 3.0, 0.0, 0.0, 1.0)),
        (-5.0f64..0.0).prop_map(|m| ("m_n_mm", 31, m, 0.0, 0.0, 1.0)),
        (6.0f64..50.0).prop_map(|x| ("x_shift", 31, 3.0, x, 0.0, 1.0)),
        (0.0f64..1.0).prop_map(|d| ("worm_tip_radius_mm", 31, 3.0, 0.0, d, 1.0)),
        (1.0f64..1e3).prop_map(|w| ("w_end_mm", 31, 3.0, 0.0, 0.0, -w)),
    ];
    for mut runner in runners(24) {
        runner
            .run(&strat, |(field, teeth, m_n, x, dr, w)| {
                let a = 20f64.to_radians();
                let e = match field {
                    "worm_tip_radius_mm" => {
                        let gear = InvoluteGear::new(31, 3.0, a, 0.2).unwrap();
                        let worm = InvoluteGear::worm(1, 3.0, a, 130.0, Hand::Right).unwrap();
                        let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
                        let cpl = FeedCoupling::linear(0.0, 0.0).unwrap();
                        let m = LineModification::default();
                        Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
                            .with_worm_radii(130.0, 130.0 - dr)
                            .err()
                            .unwrap()
                    }
                    "w_end_mm" => FlankGrid::new((10.0, 10.0 + w), (-1.0, 1.0), 3, 3)
                        .err()
                        .unwrap(),
                    "teeth" => InvoluteGear::new(teeth, m_n, a, 0.2)
                        .and_then(|g| g.flank_limits(Flank::Right))
                        .err()
                        .unwrap(),
                    _ => InvoluteGear::asymmetric(teeth, m_n, a, a, 0.2, x)
                        .and_then(|g| g.flank_limits(Flank::Right))
                        .err()
                        .unwrap(),
                };
                prop_assert!(e.to_string().contains(field), "{field}: {e}");
                Ok(())
            })
            .unwrap();
    }
}
