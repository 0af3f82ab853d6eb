//! Slider-crank kinematics against the test vectors of docs/shaping.md "Derivation: slider-crank
//! kinematics" (Procedia CIRP 56 (2016) eqs. (2)–(3) continued) and finite differences.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_abs_diff_eq;
use gearcomp_shaping::crank::{Branch, SliderCrank};
use gearcomp_shaping::units::rpm_to_rad_s;
use proptest::prelude::*;

fn rows(text: &str) -> Vec<Vec<f64>> {
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("theta"))
        .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
        .collect()
}

#[test]
fn seed002_crank_case_a() {
    let crank = SliderCrank::new(25.0, 200.0).unwrap();
    let omega = rpm_to_rad_s(300.0);
    let table = rows(include_str!("../golden/crank_case_a.csv"));
    assert_eq!(table.len(), 9);
    for r in table {
        let th = r[0].to_radians();
        // Tolerances are half a unit in the last digit the table prints.
        assert_abs_diff_eq!(crank.rod_angle_rad(th).to_degrees(), r[1], epsilon = 1e-6);
        assert_abs_diff_eq!(crank.h_mm(th), r[2], epsilon = 1e-6);
        assert_abs_diff_eq!(crank.z_mm(th), r[3], epsilon = 1e-6);
        assert_abs_diff_eq!(crank.velocity_mm_s(th, omega), r[4], epsilon = 1e-5);
        assert_abs_diff_eq!(
            crank.acceleration_mm_s2(th, omega, 0.0),
            r[5],
            epsilon = 0.01
        );
    }
}

#[test]
fn seed002_crank_case_b() {
    let crank = SliderCrank::new(10.0, 100.0).unwrap();
    let omega = rpm_to_rad_s(600.0);
    for r in rows(include_str!("../golden/crank_case_b.csv")) {
        let th = r[0].to_radians();
        assert_abs_diff_eq!(crank.h_mm(th), r[1], epsilon = 1e-6);
        assert_abs_diff_eq!(crank.velocity_mm_s(th, omega), r[2], epsilon = 1e-5);
    }
}

#[test]
fn peak_velocity_matches_derivation() {
    // docs/shaping.md (K5): peak |v_Z| = 791.512 mm/s at 97.02° (λ = 0.125, 300 rpm); 95.65° for λ = 0.1.
    let a = SliderCrank::new(25.0, 200.0).unwrap();
    let (th, dz) = a.peak_velocity();
    assert_abs_diff_eq!(th.to_degrees(), 97.02, epsilon = 0.005);
    assert_abs_diff_eq!(dz * rpm_to_rad_s(300.0), 791.512, epsilon = 5e-4);
    let b = SliderCrank::new(10.0, 100.0).unwrap();
    assert_abs_diff_eq!(b.peak_velocity().0.to_degrees(), 95.65, epsilon = 0.005);
}

#[test]
fn closed_forms_at_dead_points_and_quadrature() {
    // a_Z(0) = Rω²(1 − λ), a_Z(π) = −Rω²(1 + λ), v_Z(90°) = ωR: docs/shaping.md (K3), (K4).
    let c = SliderCrank::new(25.0, 200.0).unwrap();
    let w = rpm_to_rad_s(300.0);
    let (r, lam) = (25.0, 0.125);
    assert_abs_diff_eq!(
        c.acceleration_mm_s2(0.0, w, 0.0),
        r * w * w * (1.0 - lam),
        epsilon = 1e-8
    );
    assert_abs_diff_eq!(
        c.acceleration_mm_s2(std::f64::consts::PI, w, 0.0),
        -r * w * w * (1.0 + lam),
        epsilon = 1e-8
    );
    assert_abs_diff_eq!(
        c.velocity_mm_s(std::f64::consts::FRAC_PI_2, w),
        w * r,
        epsilon = 1e-10
    );
    assert_abs_diff_eq!(c.z_mm(std::f64::consts::PI), 50.0, epsilon = 1e-12);
}

#[test]
fn finite_differences_are_consistent() {
    // Central differences: error O(h²) ≈ 1e-8 relative at h = 1e-4 rad.
    let c = SliderCrank::new(25.0, 200.0).unwrap();
    let h = 1e-4;
    for i in 0..72 {
        let th = f64::from(i) * 5f64.to_radians() + 0.01;
        let fd1 = (c.z_mm(th + h) - c.z_mm(th - h)) / (2.0 * h);
        assert_abs_diff_eq!(fd1, c.dz_dtheta_mm(th), epsilon = 1e-6);
        let fd2 = (c.dz_dtheta_mm(th + h) - c.dz_dtheta_mm(th - h)) / (2.0 * h);
        assert_abs_diff_eq!(fd2, c.d2z_dtheta2_mm(th), epsilon = 1e-6);
        // ω̇ term: d/dt(ω·dZ/dθ) with ω = ω0 + ω̇t.
        let (w0, wd, dt) = (30.0, 50.0, 1e-6);
        let v = |t: f64| {
            let w = w0 + wd * t;
            let theta = th + w0 * t + 0.5 * wd * t * t;
            c.velocity_mm_s(theta, w)
        };
        let fd_a = (v(dt) - v(-dt)) / (2.0 * dt);
        assert_abs_diff_eq!(fd_a, c.acceleration_mm_s2(th, w0, wd), epsilon = 1e-3);
    }
}

#[test]
fn inverse_on_both_branches() {
    let c = SliderCrank::new(25.0, 200.0).unwrap();
    let th = c.theta_from_z_rad(2.958358, Branch::Cutting).unwrap();
    assert_abs_diff_eq!(th.to_degrees(), 30.0, epsilon = 1e-5);
    let th = c.theta_from_z_rad(23.431348, Branch::Return).unwrap();
    assert_abs_diff_eq!(th.to_degrees(), 270.0, epsilon = 1e-5);
    assert!(c.theta_from_z_rad(50.1, Branch::Cutting).is_err());
    assert!(c.theta_from_z_rad(f64::NAN, Branch::Cutting).is_err());
}

#[test]
fn bad_geometry_is_refused_with_field_and_range() {
    let e = SliderCrank::new(25.0, 40.0).unwrap_err().to_string();
    assert!(
        e.contains("rod length K") && e.contains("40") && e.contains("50"),
        "{e}"
    );
    assert!(SliderCrank::new(f64::NAN, 200.0).is_err());
    assert!(SliderCrank::new(-1.0, 200.0).is_err());
}

proptest! {
    #[test]
    fn crank_round_trip(r in 1.0f64..150.0, lam in 0.02f64..0.5, frac in 0.0f64..1.0) {
        let c = SliderCrank::new(r, r / lam).unwrap();
        let th = frac * std::f64::consts::PI;
        let back = c.theta_from_z_rad(c.z_mm(th), Branch::Cutting).unwrap();
        // Near the dead points dZ/dθ → 0, so angle error grows like √(ε_Z/R): compare Z.
        prop_assert!((c.z_mm(back) - c.z_mm(th)).abs() <= 1e-9 * r);
        if (0.05..0.95).contains(&frac) {
            prop_assert!((back - th).abs() < 1e-7);
            let ret = c.theta_from_z_rad(c.z_mm(th), Branch::Return).unwrap();
            prop_assert!((ret - (std::f64::consts::TAU - th)).abs() < 1e-7);
        }
    }

    #[test]
    fn crank_new_never_panics(r in proptest::num::f64::ANY, l in proptest::num::f64::ANY, th in proptest::num::f64::ANY) {
        if let Ok(c) = SliderCrank::new(r, l) {
            let _ = c.z_mm(th);
            let _ = c.theta_from_z_rad(th, Branch::Return);
        }
    }
}

#[test]
fn combined_state_matches_the_separate_formulas() {
    let c = SliderCrank::new(25.0, 200.0).unwrap();
    for i in 0..=720 {
        let th = f64::from(i) * 0.5f64.to_radians();
        let (z, dz, d2z) = c.state(th);
        assert_abs_diff_eq!(z, c.z_mm(th), epsilon = 1e-12);
        assert_abs_diff_eq!(dz, c.dz_dtheta_mm(th), epsilon = 1e-12);
        assert_abs_diff_eq!(d2z, c.d2z_dtheta2_mm(th), epsilon = 1e-10);
    }
}
