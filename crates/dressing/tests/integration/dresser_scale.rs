//! Fuzzing of `gearcomp dress` (session 10): on large worms (module 25–100 mm, b of tens to
//! thousands of mm) the dresser design's contact-point Newton never met its absolute
//! 1e-13 mm step, the rounding floor of g/g′ being 1.5e-13 mm and more, and valid
//! configurations were refused with "dresser design contact point did not converge".
//!
//! Reference: geometric similarity. Scaling every length of worm and dresser (module,
//! diameters, jacket width) by k scales the designed dresser by k: R_A(k·z) = k·R_A(z), the
//! fillet radius, its tangent point and the active-profile foot by k. The small worm is
//! G1-Z5's module (3 mm) with z = 20 starts, where the design always converged.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::dresser::Dresser;
use gearcomp_dressing::request::{DresserInput, WormInput};
use gearcomp_dressing::worm::{Flank, Worm};
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// z = 20, d = 90 mm, m_n = 3 mm, α_n = 20°, dresser 117 mm with a 0.8 mm jacket, all × k.
fn design(k: f64) -> (Worm, Dresser) {
    let worm = WormInput {
        starts: 20,
        diameter_mm: 90.0 * k,
        normal_module_mm: 3.0 * k,
        profile_angle_deg: 20.0,
    }
    .build()
    .unwrap();
    let dresser = DresserInput {
        diameter_mm: 117.0 * k,
        jacket_width_mm: 0.8 * k,
        clearance_mm: 0.0,
    }
    .build(&worm)
    .unwrap_or_else(|e| panic!("k = {k}: {e}"));
    (worm, dresser)
}

fn similar(k: f64) {
    let (_, small) = design(1.0);
    let (_, large) = design(k);
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-12);
    for flank in [Flank::Left, Flank::Right] {
        let (s, l) = (small.side(flank), large.side(flank));
        for (what, a, b) in [
            ("fillet radius", l.fillet_radius_mm, k * s.fillet_radius_mm),
            ("fillet tangent", l.u_tangent_mm, k * s.u_tangent_mm),
            ("active foot w_Nf", l.w_nf_mm, k * s.w_nf_mm),
        ] {
            assert!(rel(a, b) < 1e-6, "k = {k} {flank:?} {what}: {a} vs {b}");
        }
    }
    let u_max = small.u_max();
    for i in 0..=40 {
        let z = -u_max + 2.0 * u_max * f64::from(i) / 40.0;
        let (r_small, ..) = small.profile(z);
        let (r_large, ..) = large.profile(k * z);
        assert!(
            (r_large - k * r_small).abs() < 1e-6 * k,
            "k = {k}, z = {z}: {r_large} vs {}",
            k * r_small
        );
    }
}

/// The fuzzer's case: module 24.90546 mm, d = 747.1638 mm (k = 8.30182), dresser
/// 971.4584 mm: refused before.
#[test]
fn a_module_25_worm_gets_its_dresser() {
    similar(8.30182);
}

/// Random scales up to module 51 mm (k ≤ 17, the dresser then 1989 mm of the 2000 mm
/// allowed; fixed seed + fresh cases).
#[test]
fn the_dresser_design_scales_with_the_worm() {
    let prop = |k: f64| {
        similar(k);
        Ok(())
    };
    let cfg = Config {
        cases: 12,
        failure_persistence: None,
        ..Config::default()
    };
    let mut fixed = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[10; 32]),
    );
    fixed.run(&(1.0..17.0f64), prop).unwrap();
    TestRunner::new(cfg).run(&(1.0..17.0f64), prop).unwrap();
}

/// A 3-point plan of G1-Z5 × k (z = 5, d = 160 mm, m_n = 3 mm, dresser 100 mm, jacket
/// 0.8 mm; crowning 2 µm (docs/dressing.md's stress case), two redressings, budget 0.1 mm; all lengths × k).
fn plan_of(k: f64) -> Vec<gearcomp_dressing::campaign::PlanRow> {
    use gearcomp_dressing::campaign::{plan, Correction, PlanSpec};
    let worm = WormInput {
        starts: 5,
        diameter_mm: 160.0 * k,
        normal_module_mm: 3.0 * k,
        profile_angle_deg: 20.0,
    }
    .build()
    .unwrap();
    let dresser = DresserInput {
        diameter_mm: 100.0 * k,
        jacket_width_mm: 0.8 * k,
        clearance_mm: 0.0,
    }
    .build(&worm)
    .unwrap_or_else(|e| panic!("k = {k}: {e}"));
    let spec = PlanSpec {
        flank: Flank::Right,
        diameters_mm: vec![160.0 * k, 157.0 * k, 154.0 * k],
        correction: Correction::ThreePoint,
        crowning_mm: 2e-3 * k,
        budget_mm: 0.1 * k,
    };
    plan(&worm, &dresser, &spec).unwrap_or_else(|e| panic!("k = {k}: {e}"))
}

/// Fuzzing of `gearcomp dress solve/plan` (session 10): module 25–100 worms took 11–85 s
/// because the entry-depth scan of the screw evaluation stepped 0.02 mm over 4 m_n and the
/// envelope Newton clamped its depth step to 1 mm (so it rarely converged and fell back to
/// that scan). Both are now in units of m_n. With 2 µm crowning the module-51 plan was also
/// refused "every damped step leaves the search box": the box's 3 mm / 30 mm on Δd / Δν_yA
/// did not grow with the worm (it now does above module 3). Reference: geometric similarity again. Every
/// length of the plan (d_0, active profile, Δd, Δν_yA, deviations, opposite cut, jacket
/// depth, lead, profile) scales by k, the angles (Δφ_S, Δγ, α_n) and the stretching P_FS do
/// not; lengths within 1e-6 relative or 2e-6·k µm absolute (the deviations are ~1e-3 µm).
fn plan_similar(k: f64, small: &[gearcomp_dressing::campaign::PlanRow]) {
    let large = plan_of(k);
    assert_eq!(small.len(), large.len());
    let len = |what: &str, a: f64, b_small: f64| {
        let b = k * b_small;
        assert!(
            (a - b).abs() <= 1e-6 * b.abs() + 2e-9 * k,
            "k = {k} {what}: {a} vs {b} (k × {b_small})"
        );
    };
    let um = |what: &str, a: f64, b_small: f64| {
        let b = k * b_small;
        assert!(
            (a - b).abs() <= 1e-4 * b.abs() + 2e-6 * k,
            "k = {k} {what}: {a} vs {b} µm"
        );
    };
    let ang = |what: &str, a: f64, b: f64| {
        assert!(
            (a - b).abs() <= 1e-6 * b.abs() + 1e-10,
            "k = {k} {what}: {a} vs {b}"
        );
    };
    for (s, l) in small.iter().zip(&large) {
        len("d_0", l.d0_mm, s.d0_mm);
        len("w_Nf", l.active_mm.0, s.active_mm.0);
        len("w_Na", l.active_mm.1, s.active_mm.1);
        len("Δd", l.dk.dd_mm, s.dk.dd_mm);
        len("Δν_yA", l.dk.dnu_ya_mm, s.dk.dnu_ya_mm);
        ang("Δφ_S", l.dk.dphi_s_rad, s.dk.dphi_s_rad);
        ang("Δγ", l.dk.dgamma_rad, s.dk.dgamma_rad);
        ang("P_FS", l.stretch, s.stretch);
        ang("α_n", l.alpha_n_rad, s.alpha_n_rad);
        len("opposite cut", l.opposite_cut_mm, s.opposite_cut_mm);
        len("jacket depth", l.jacket_depth_mm, s.jacket_depth_mm);
        len("lead", l.lead_mm, s.lead_mm);
        um("deviation max", l.deviation_max_um, s.deviation_max_um);
        um(
            "deviation range",
            l.deviation_range_um,
            s.deviation_range_um,
        );
        um("deviation foot", l.deviation_foot_um, s.deviation_foot_um);
        um("deviation tip", l.deviation_tip_um, s.deviation_tip_um);
        assert_eq!(l.profile.len(), s.profile.len());
        for (pl, ps) in l.profile.iter().zip(&s.profile) {
            len("profile w", pl.0, ps.0);
            um("profile f − target", pl.1, ps.1);
        }
        assert_eq!(l.penetration, s.penetration);
        assert_eq!(l.undercut, s.undercut);
    }
}

/// The module-51 worm (k = 17, d = 2720 mm) plans like G1-Z5, scaled.
#[test]
fn a_module_51_plan_is_the_module_3_plan_scaled() {
    plan_similar(17.0, &plan_of(1.0));
}

/// Random scales k in [1, 17] (fixed seed + fresh cases).
#[test]
fn the_plan_scales_with_the_worm() {
    let small = plan_of(1.0);
    let prop = |k: f64| {
        plan_similar(k, &small);
        Ok(())
    };
    let cfg = Config {
        cases: 4,
        failure_persistence: None,
        ..Config::default()
    };
    let mut fixed = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[11; 32]),
    );
    fixed.run(&(1.0..17.0f64), prop).unwrap();
    TestRunner::new(cfg).run(&(1.0..17.0f64), prop).unwrap();
}
