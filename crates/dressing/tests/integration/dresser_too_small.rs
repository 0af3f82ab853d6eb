//! Fuzzing of `gearcomp dress` (session 10): a dresser far too small for the worm (100 mm on
//! a module-100 worm of 5330 mm) was accepted and `dress plan` printed a 138 mm deviation
//! flagged PENETRATION with exit code 0. The dresser axis sits at r_f + d_A/2 from the worm
//! axis, so it clears the tip circle only when d_A/2 > r_a − r_f; now `[dresser]
//! diameter_mm` at or below that bound is refused naming the key, the value and the range.
//!
//! Reference: the tooth depth of the worm from DIN 3960 / ISO 21771 reference-profile
//! proportions written here, addendum h_a = m_n and dedendum h_f = 1.25·m_n, so the bound is
//! d_A > 2·(h_a + h_f) = 4.5·m_n.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::request::{DresserInput, WormInput};
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn depth_bound_mm(m_n: f64) -> f64 {
    let (h_a, h_f) = (m_n, 1.25 * m_n);
    2.0 * (h_a + h_f)
}

fn dresser(m: f64, z: u32, d_a: f64) -> Result<(), String> {
    let worm = WormInput {
        starts: z,
        diameter_mm: 60.0 * m,
        normal_module_mm: m,
        profile_angle_deg: 20.0,
    }
    .build()
    .unwrap();
    DresserInput {
        diameter_mm: d_a,
        jacket_width_mm: 0.25 * m,
        clearance_mm: 0.0,
    }
    .build(&worm)
    .map(|_| ())
    .map_err(|e| e.to_string())
}

/// The fuzzer's case: 100 mm on module 100 (bound 450 mm).
#[test]
fn a_100_mm_dresser_on_a_module_100_worm_is_refused() {
    let err = dresser(100.0, 3, 100.0).unwrap_err();
    assert!(
        err.contains("[dresser] diameter_mm = 100 mm")
            && err.contains("admissible range > 450.0000 ..= 2000 mm"),
        "{err}"
    );
}

/// Random module (1.2–100 mm) and starts: 0.1 % below the bound refused at the key with the
/// bound to 1e-4 mm; 0.1 % above it not refused by this check (fixed seed + fresh cases).
#[test]
fn a_dresser_is_refused_exactly_below_twice_the_tooth_depth() {
    let prop = |(m, z): (f64, u32)| {
        let b = depth_bound_mm(m);
        let err = dresser(m, z, 0.999 * b).unwrap_err();
        let shown: f64 = err
            .split("admissible range > ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("m = {m}: {err}"));
        assert!(err.contains("[dresser] diameter_mm"), "{err}");
        assert!((shown - b).abs() < 1e-4, "m = {m}: {shown} vs {b}");
        if let Err(e) = dresser(m, z, 1.001 * b) {
            assert!(!e.contains("admissible range >"), "m = {m}: {e}");
        }
        Ok(())
    };
    let cfg = Config {
        cases: 16,
        failure_persistence: None,
        ..Config::default()
    };
    let strat = (1.2..100.0f64, 1u32..=6);
    let mut fixed = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[12; 32]),
    );
    fixed.run(&strat, prop).unwrap();
    TestRunner::new(cfg).run(&strat, prop).unwrap();
}

/// A jacket wider than the worm gap is refused naming `[dresser] jacket_width_mm` and its
/// upper bound: the gap width at the root circle. Reference: the normal space width of the
/// worm's rack at the root line, π·m_n/2 − 2·h_f·tan α_n with h_f = 1.25·m_n (DIN 3960), which
/// the dresser's axial width at its jacket radius matches up to the lead angle and the
/// curvature of the envelope (1-start, 280 mm: 1.98263 vs 1.98261 mm; asserted within 0.5 %).
#[test]
fn a_jacket_wider_than_the_gap_names_the_key_and_the_bound() {
    let m = 3.0;
    let worm = WormInput {
        starts: 1,
        diameter_mm: 280.0,
        normal_module_mm: m,
        profile_angle_deg: 20.0,
    }
    .build()
    .unwrap();
    for jw in [3.5, 2.5] {
        let err = DresserInput {
            diameter_mm: 125.0,
            jacket_width_mm: jw,
            clearance_mm: 0.0,
        }
        .build(&worm)
        .unwrap_err()
        .to_string();
        let shown: f64 = err
            .split("0 < jacket_width_mm < ")
            .nth(1)
            .and_then(|t| t.split(' ').next())
            .and_then(|t| t.parse().ok())
            .unwrap_or_else(|| panic!("{err}"));
        let s_f = std::f64::consts::PI * m / 2.0 - 2.0 * 1.25 * m * 20f64.to_radians().tan();
        assert!(err.contains("[dresser] jacket_width_mm"), "{err}");
        assert!((shown / s_f - 1.0).abs() < 0.005, "{shown} vs {s_f}: {err}");
    }
}
