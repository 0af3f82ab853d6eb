//! Tests F1, F2, F4: a worm's life with the dresser designed for the new worm (claims 1–2).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use gearcomp_dressing::campaign::{plan, Correction, PlanSpec};
use gearcomp_dressing::worm::Flank;

fn spec(corr: Correction, ds: &[f64], budget: f64) -> PlanSpec {
    PlanSpec {
        flank: Flank::Right,
        diameters_mm: ds.to_vec(),
        correction: corr,
        crowning_mm: 0.0,
        budget_mm: budget,
    }
}

/// F1/F2 on G1: uncorrected, the profile error grows monotonically as the worm shrinks; with the
/// 3-point correction it stays < 0.1 µm, the corrections grow with |d_S − d_S0|, and the profile
/// stretching P_FS grows in magnitude.
#[test]
fn f1_f2_g1_life() {
    let s = common::g1();
    let ds = [280.0, 265.0, 250.0, 235.0, 220.0];
    let none = plan(&s.worm, &s.dresser, &spec(Correction::None, &ds, 0.1)).unwrap();
    assert!(none[0].deviation_max_um < 1e-6);
    for w in none.windows(2) {
        assert!(w[1].deviation_max_um > w[0].deviation_max_um);
        assert!(w[1].deviation_range_um > w[0].deviation_range_um);
    }
    assert!(
        none[4].deviation_max_um > 0.3,
        "{}",
        none[4].deviation_max_um
    );
    let corr = plan(&s.worm, &s.dresser, &spec(Correction::ThreePoint, &ds, 0.1)).unwrap();
    for (i, r) in corr.iter().enumerate() {
        assert!(
            r.deviation_max_um < 0.1,
            "d {}: {}",
            r.d_s_mm,
            r.deviation_max_um
        );
        if i > 0 {
            let (a, b) = (corr[i - 1].dk, r.dk);
            assert!(b.dnu_ya_mm.abs() > a.dnu_ya_mm.abs() && b.dd_mm.abs() > a.dd_mm.abs());
            assert!(r.stretch.abs() > corr[i - 1].stretch.abs());
        }
        // The uncorrected centre distance follows the root circle: d_0 = r_fS + d_A/2.
        assert!((r.d0_mm - (r.d_s_mm / 2.0 - 3.75 + 62.5)).abs() < 1e-9);
        // Machine (5) axes realise the corrected pose.
        assert!((r.axes.x1_mm - (r.d0_mm + r.dk.dd_mm)).abs() < 1e-9);
        assert!((r.axes.z1_mm - r.dk.dnu_ya_mm).abs() < 1e-9);
    }
}

/// F4: the penetration and undercut checks run at every step; a small worm (G1-Z5 life) with a
/// tight budget A = 0.01 mm is flagged once the correction grows.
#[test]
fn f4_penetration_and_undercut_flags() {
    let s = common::g1_z5();
    let rows = plan(
        &s.worm,
        &s.dresser,
        &spec(Correction::ThreePoint, &[160.0, 150.0, 130.0], 0.01),
    )
    .unwrap();
    assert!(!rows[0].penetration && !rows[0].undercut);
    assert!(rows[2].penetration && rows[2].undercut);
    assert!(rows[2].opposite_cut_mm > rows[1].opposite_cut_mm);
    // The correction still holds the profile.
    assert!(rows.iter().all(|r| r.deviation_max_um < 0.1));
}

/// Re-profiling identity: the unchanged helicoid's own profile angle at d_S/2, fed back through
/// the DIN 3960 worm-as-helical-gear relations with the normal base pitch kept, gives back the
/// same helicoid; any other angle keeps the normal base pitch π·m_n·cos α_n (eq. (20)).
#[test]
fn reprofiling_keeps_normal_base_pitch() {
    let s = common::g1();
    let worn = s.worm.worn(238.0).unwrap();
    let keep = worn.profile_angle_at(119.0);
    let same = worn.with_profile_angle(keep).unwrap();
    assert!((same.r_b_mm - worn.r_b_mm).abs() < 1e-9);
    assert!((same.beta_b_rad - worn.beta_b_rad).abs() < 1e-12);
    assert!((same.p_mm - worn.p_mm).abs() < 1e-9);
    let pbn = std::f64::consts::PI * 3.0 * 20f64.to_radians().cos();
    for deg in [18.0, 19.99, 22.0] {
        let w = worn.with_profile_angle(f64::to_radians(deg)).unwrap();
        assert!((w.normal_base_pitch_mm() - pbn).abs() < 1e-12);
        assert!((w.profile_angle_at(119.0) - f64::to_radians(deg)).abs() < 1e-12);
        assert_eq!((w.r_a_mm, w.r_f_mm), (worn.r_a_mm, worn.r_f_mm));
    }
    // docs/dressing.md "Reference case G1 and its worms": 22° needs m_nS = 3.040473 mm.
    let w22 = worn.with_profile_angle(22f64.to_radians()).unwrap();
    assert!((w22.m_n_mm - 3.040473).abs() < 1e-6);
    assert!(worn.with_profile_angle(60f64.to_radians()).is_err());
}

/// P_FS by the analytic envelope (meshing condition, independent of the screw evaluation the
/// plan uses): the roll distance a dresser radius dresses, found by bisection.
fn stretch_by_meshing(
    s: &gearcomp_dressing::envelope::DressingSetup,
    dk: &gearcomp_dressing::kinematics::AxisCorrection,
    r_a: (f64, f64),
    active0: (f64, f64),
    cos_beta_b0: f64,
) -> f64 {
    let (a, b) = s.active_profile(Flank::Right).unwrap();
    let w_of = |r: f64| {
        // r_FA(w) falls as w grows (the dresser tip dresses the worm root).
        let (mut lo, mut hi) = (a - 0.5, b + 0.5);
        for _ in 0..60 {
            let m = 0.5 * (lo + hi);
            let rm = s.dress_point_meshing(Flank::Right, m, dk).unwrap().r_a_mm;
            if rm > r {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    };
    ((w_of(r_a.1) - w_of(r_a.0)) / s.worm.beta_b_rad.cos())
        / ((active0.1 - active0.0) / cos_beta_b0)
        - 1.0
}

/// F3 (claim 2, Fig. 19(b)/(c)): for each worn diameter a profile angle with zero stretching
/// exists for z_S = 1, 2, 3 (G1-type worms, d_A = 125 mm). Closed loop: at the found angle a
/// fresh 3-point solve from ΔK = 0 and the analytic-envelope association give |P_FS| < 1e-6,
/// the profile still meets its target and the worm still meshes with the gear (eq. (20)).
/// Trend: the zero-stretch angle leaves the unchanged helicoid's angle further as the worm
/// shrinks and as the number of starts grows; it stays between that angle and the design angle.
#[test]
fn f3_zero_stretch_profile_angle() {
    use gearcomp_dressing::campaign::{plan_with_options, PlanOptions, StretchReference};
    use gearcomp_dressing::envelope::DressingSetup;
    use gearcomp_dressing::kinematics::AxisCorrection;
    use gearcomp_dressing::solve::{solve_three_point, NewtonOptions, ThreePoint};
    let opts = PlanOptions {
        zero_stretch: true,
        ..PlanOptions::default()
    };
    let mut shift_at_85 = Vec::new();
    for (z, d0) in [(1u32, 280.0), (2, 280.0), (3, 200.0)] {
        let s = common::setup(z, d0, 125.0);
        let ds = [d0, 0.95 * d0, 0.85 * d0];
        let plain = plan(&s.worm, &s.dresser, &spec(Correction::ThreePoint, &ds, 0.1)).unwrap();
        let rows = plan_with_options(
            &s.worm,
            &s.dresser,
            &spec(Correction::ThreePoint, &ds, 0.1),
            &opts,
        )
        .unwrap();
        let reference = StretchReference::new(&s.worm, &s.dresser, Flank::Right).unwrap();
        let mut last_shift = 0.0;
        for (r, p) in rows.iter().zip(plain.iter()) {
            assert!(
                r.stretch.abs() < 1e-8,
                "z {z} d {}: {}",
                r.d_s_mm,
                r.stretch
            );
            assert!(r.deviation_max_um < 0.1);
            let shift = r.alpha_n_rad - r.alpha_keep_rad;
            if r.d_s_mm < d0 {
                // Without the angle change the stretching is not zero (F2).
                assert!(p.stretch.abs() > 1e-5, "z {z}: {}", p.stretch);
                assert!(shift > last_shift, "z {z} d {}: shift {shift}", r.d_s_mm);
                assert!(r.alpha_n_rad < 20f64.to_radians());
                assert!((r.lead_mm - plain[0].lead_mm).abs() > 1e-6);
            }
            last_shift = shift;
            // Closed loop with independent pieces.
            let worm = s
                .worm
                .worn(r.d_s_mm)
                .unwrap()
                .with_profile_angle(r.alpha_n_rad)
                .unwrap();
            let pbn = std::f64::consts::PI * 3.0 * 20f64.to_radians().cos();
            assert!((worm.normal_base_pitch_mm() - pbn).abs() < 1e-12);
            let setup = DressingSetup::new(worm, s.dresser.clone());
            let (a, b) = setup.active_profile(Flank::Right).unwrap();
            let at = |q: f64| a + q * (b - a);
            let sol = solve_three_point(
                &setup,
                &ThreePoint {
                    flank: Flank::Right,
                    w_mm: [at(0.05), at(0.5), at(0.95)],
                    f_mm: [0.0; 3],
                    w_assoc_mm: b,
                    r_a_mm: reference.r_a_mm.1,
                },
                AxisCorrection::default(),
                &NewtonOptions::default(),
            )
            .unwrap();
            let pm = stretch_by_meshing(
                &setup,
                &sol.dk,
                reference.r_a_mm,
                reference.active0_mm,
                reference.cos_beta_b0,
            );
            assert!(pm.abs() < 1e-6, "z {z} d {}: P by meshing {pm}", r.d_s_mm);
        }
        shift_at_85.push(last_shift);
    }
    assert!(shift_at_85[0] < shift_at_85[1] && shift_at_85[1] < shift_at_85[2]);
}
