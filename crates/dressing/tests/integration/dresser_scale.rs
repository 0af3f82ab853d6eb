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
