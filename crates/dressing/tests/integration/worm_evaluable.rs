//! Fuzzing of `gearcomp dress` (session 10): a worm with many starts on a small diameter
//! (z = 20, d = 90 mm, m_n = 3 mm) passed the `[worm]` checks, and `dress solve`/`dress plan`
//! then refused it under the wrong key with an empty range ("[plan] diameters_mm[0] = 90 mm
//! is outside the allowed range 92.494 ..= 90 mm"). Now both refuse `[worm] diameter_mm`,
//! naming the reference radius and the bound r_b + 2.25·m_n.
//!
//! Reference: the base radius of the worm as a helical gear written here from DIN 3960 /
//! ISO 21771 — lead angle sin γ = z·m_n/d, helix angle β = 90° − γ, tan α_t = tan α_n/cos β,
//! r_b = (d/2)·cos α_t — and the bound d/2 ≥ r_b + 2.25·m_n found by bisection on d.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::config::DressConfig;
use gearcomp_dressing::request::current_worm;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn margin(z: u32, m: f64, alpha_deg: f64, d: f64) -> f64 {
    let gamma = (f64::from(z) * m / d).asin();
    let beta = std::f64::consts::FRAC_PI_2 - gamma;
    let alpha_t = (alpha_deg.to_radians().tan() / beta.cos()).atan();
    d / 2.0 - (d / 2.0 * alpha_t.cos() + 2.25 * m)
}

/// Smallest evaluable diameter, or None when even a diameter just above z·m_n is evaluable.
fn bound(z: u32, m: f64, alpha_deg: f64) -> Option<f64> {
    let mut lo = f64::from(z) * m * 1.000_001;
    if margin(z, m, alpha_deg, lo) >= 0.0 {
        return None;
    }
    let mut hi = 1e4;
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if margin(z, m, alpha_deg, mid) >= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(hi)
}

fn config(z: u32, m: f64, alpha_deg: f64, d: f64) -> DressConfig {
    DressConfig::from_toml_str(&format!(
        "[worm]\nstarts = {z}\ndiameter_mm = {d:?}\nnormal_module_mm = {m:?}\n\
         profile_angle_deg = {alpha_deg:?}\n[dresser]\ndiameter_mm = 100.0\njacket_width_mm = 0.1\n\
         [plan]\ndiameters_mm = [{d:?}]\n"
    ))
    .unwrap()
}

/// Random starts, module and profile angle: 0.1 % below the bound both the solve's worm and
/// the plan's specification are refused at `[worm] diameter_mm`; 0.1 % above it both pass
/// that check (fixed seed + fresh cases).
#[test]
fn a_worm_too_small_to_evaluate_is_refused_at_its_diameter() {
    let strat = (1u32..=20, 0.5..10.0f64, 10.0..30.0f64);
    let prop = |(z, m, alpha): (u32, f64, f64)| {
        let Some(d_star) = bound(z, m, alpha) else {
            return Ok(());
        };
        let below = d_star * 0.999;
        if below > f64::from(z) * m {
            let cfg = config(z, m, alpha, below);
            let worm = cfg.worm.build().unwrap();
            let e = current_worm(&worm, None).unwrap_err().to_string();
            prop_assert!(
                e.contains("[worm] diameter_mm") && e.contains(&format!("= {below} mm")),
                "{}",
                e
            );
            let e = cfg.plan.unwrap().spec(&worm).unwrap_err().to_string();
            prop_assert!(e.contains("[worm] diameter_mm"), "{}", e);
        }
        let above = d_star * 1.001;
        let cfg = config(z, m, alpha, above);
        let worm = cfg.worm.build().unwrap();
        prop_assert!(current_worm(&worm, None).is_ok());
        let spec = cfg.plan.unwrap().spec(&worm);
        prop_assert!(spec.is_ok(), "{:?}", spec.err());
        Ok(())
    };
    let cfg = Config {
        cases: 64,
        failure_persistence: None,
        ..Config::default()
    };
    let mut fixed = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[14; 32]),
    );
    fixed.run(&strat, prop).unwrap();
    TestRunner::new(cfg).run(&strat, prop).unwrap();
    // The fuzzer's worm: z = 20, d = 90 mm, m_n = 3 mm, α_n = 20°.
    let cfg = config(20, 3.0, 20.0, 90.0);
    let worm = cfg.worm.build().unwrap();
    let e = current_worm(&worm, None).unwrap_err().to_string();
    assert!(e.contains("= 90 mm") && e.contains("46.2470 mm"), "{e}");
}
