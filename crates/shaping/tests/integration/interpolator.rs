//! The cyclic interpolator: docs/shaping.md control-cycle vector, encoder wrap, zero drift over 10^6 strokes,
//! feasibility refusal.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_abs_diff_eq;
use gearcomp_shaping::coupling::{GearCut, Hand, Mesh};
use gearcomp_shaping::crank::SliderCrank;
use gearcomp_shaping::interpolator::{
    CycleStatus, Interpolator, InterpolatorConfig, LinearLimits, RotaryLimits,
};
use gearcomp_shaping::simulate::execute_program;
use gearcomp_shaping::units::{rad_s_to_rpm, rpm_to_rad_s};
use gearcomp_shaping::ShapingError;

include!("../support/setup.rs");

const CPR: u32 = 3_600_000;
const DEG: f64 = CPR as f64 / 360.0;

#[test]
fn seed002_one_cycle_at_90_degrees() {
    // docs/shaping.md test vector: one 1 ms cycle at θ = 90°, n_A = 300 rpm, n_C1 = 2 rpm: Δθ_A = 1.8°,
    // ΔZ = 0.786823 mm, helical ΔC2 = 0.311146°, generating ΔC2 = −0.0192° (ΔC1 = 0.012°),
    // and n_C2 = 48.56381 rpm at 90°.
    // n_C1 = 2 rpm at 300 strokes/min = 2.4° per stroke = 24 000 counts of 3.6e6.
    let mut ip = Interpolator::new(seed_config(300.0, 24_000.0)).unwrap();
    assert_eq!(ip.c1_counts_per_stroke(), 24_000);
    let a = ip.cycle((90.0 * DEG) as u32);
    assert_abs_diff_eq!(rad_s_to_rpm(a.c2_vel_rad_s), 48.56381, epsilon = 5e-6);
    let b = ip.cycle((91.8 * DEG) as u32);
    assert_abs_diff_eq!(b.z_mm - a.z_mm, 0.786823, epsilon = 5e-7);
    assert_abs_diff_eq!(rad_s_to_rpm(b.omega_rad_s), 300.0, epsilon = 1e-9);
    let dc1 = (b.c1_counts.to_f64() - a.c1_counts.to_f64()) / DEG;
    assert_abs_diff_eq!(dc1, 0.012, epsilon = 1e-12);
    let dgen = (b.c2_generating_counts.to_f64() - a.c2_generating_counts.to_f64()) / DEG;
    assert_abs_diff_eq!(dgen, -0.0192, epsilon = 1e-12);
    let dhel = (b.c2_helical_counts - a.c2_helical_counts) / DEG;
    assert_abs_diff_eq!(dhel, 0.311146, epsilon = 5e-7);
}

#[test]
fn encoder_wraps_backwards_and_forwards() {
    let mut ip = Interpolator::new(seed_config(300.0, 24_000.0)).unwrap();
    ip.cycle(CPR - 9_000);
    let out = ip.cycle(9_000); // crossed count 0 going forwards by 18 000 counts
    assert_eq!(out.crank_counts, i64::from(CPR) + 9_000);
    assert_eq!(out.stroke_index, 1);
    assert_abs_diff_eq!(rad_s_to_rpm(out.omega_rad_s), 300.0, epsilon = 1e-9);
    let back = ip.cycle(CPR - 9_000); // and back again
    assert_eq!(back.crank_counts, i64::from(CPR) - 9_000);
    // Out-of-range readings hold the last command and say so.
    let bad = ip.cycle(CPR);
    assert_eq!(bad.status, CycleStatus::EncoderOutOfRange);
    assert_eq!(bad.crank_counts, back.crank_counts);
}

#[test]
fn million_strokes_have_zero_drift() {
    // Awkward ratio on purpose: Z_C1 = 41, Z_C2 = 27, 7 919 C1 counts per stroke (prime), so
    // every C2 position has a non-trivial remainder.
    let mut cfg = seed_config(300.0, 7_919.0);
    cfg.cut = GearCut::new(
        41,
        27,
        3.0,
        15f64.to_radians(),
        0.0,
        Hand::Right,
        Mesh::External,
    )
    .unwrap();
    cfg.circular_feed_mm =
        7_919.0 / f64::from(CPR) * std::f64::consts::TAU * cfg.cut.workpiece_pitch_radius_mm();
    let mut ip = Interpolator::new(cfg).unwrap();
    assert_eq!(ip.c1_counts_per_stroke(), 7_919);
    let first = ip.cycle(0);
    let steps = [CPR / 3, 2 * (CPR / 3), 0];
    let strokes: i64 = 1_000_000;
    let mut out = first;
    let mut naive_c2 = 0.0f64; // what per-cycle float increments would give
    let inc = -41.0 / 27.0 * 7_919.0 / 3.0;
    for _ in 0..strokes {
        for &s in &steps {
            out = ip.cycle(s);
            naive_c2 += inc;
        }
    }
    // Fed a third of a revolution per cycle to keep the test fast, the interpolator rightly
    // flags the crank as far above its nominal speed; the positions are still exact.
    assert_eq!(out.status, CycleStatus::Overspeed);
    assert_eq!(out.crank_counts, strokes * i64::from(CPR));
    assert_eq!(out.stroke_index, strokes);
    // C1 is exactly 10^6 · 7 919 counts.
    assert_eq!(
        (out.c1_counts.whole, out.c1_counts.rem),
        (strokes * 7_919, 0)
    );
    // C2 generating part is exactly −(41/27)·C1: integer identity, no tolerance.
    let g = out.c2_generating_counts;
    let c2_times_den = i128::from(g.whole) * g.den + g.rem;
    assert_eq!(
        c2_times_den * 27,
        -41 * i128::from(out.c1_counts.whole) * g.den
    );
    // Back at θ = 0 the helical part is exactly zero again.
    assert_eq!(out.c2_helical_counts, 0.0);
    assert_eq!(out.z_mm, first.z_mm);
    // The float accumulation the exact form avoids does drift (documents why it matters).
    let exact = c2_times_den as f64 / g.den as f64;
    assert!(
        (naive_c2 - exact).abs() > 1e-6,
        "naive drift {}",
        naive_c2 - exact
    );
}

#[test]
fn infeasible_speed_is_refused_with_the_numbers() {
    // At 1000 strokes/min the helical peak alone is k_h·v_peak with v_peak = 791.512·10/3 mm/s
    // (docs/shaping.md (K5) peak at 300 rpm, scaled): far above the 150 rpm C2 limit.
    let err = Interpolator::new(seed_config(1000.0, 24_000.0)).unwrap_err();
    let k_h = 2.0 * 15f64.to_radians().sin() / (3.0 * 25.0);
    let helical_rpm = rad_s_to_rpm(k_h * 791.512 * 10.0 / 3.0);
    let generating_rpm = 1.6 * 2.0 * 10.0 / 3.0; // n_C1 scales with the stroke rate
    match &err {
        ShapingError::Infeasible {
            axis,
            quantity,
            required,
            limit,
            ..
        } => {
            assert_eq!((*axis, *quantity), ("C2", "speed"));
            assert_abs_diff_eq!(*required, helical_rpm + generating_rpm, epsilon = 0.01);
            assert_abs_diff_eq!(*limit, 150.0, epsilon = 1e-9);
        }
        other => panic!("expected Infeasible, got {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("C2") && msg.contains("150.0000 rpm") && msg.contains("strokes/min"),
        "{msg}"
    );
}

#[test]
fn infeasible_acceleration_is_refused() {
    // Required C2 acceleration = k_h·Rω²(1 + λ) (far dead point): at 300 strokes/min that is
    // 0.0069018·27758.26 mm/s² = 191.6 rad/s² = 30.49 rev/s²; a 20 rev/s² axis must refuse.
    let mut cfg = seed_config(300.0, 24_000.0);
    cfg.c2_limits.max_accel_rad_s2 = 20.0 * std::f64::consts::TAU;
    match Interpolator::new(cfg).unwrap_err() {
        ShapingError::Infeasible {
            axis,
            quantity,
            required,
            ..
        } => {
            assert_eq!((axis, quantity), ("C2", "acceleration"));
            let k_h = 2.0 * 15f64.to_radians().sin() / 75.0;
            assert_abs_diff_eq!(
                required,
                k_h * 27758.26 / std::f64::consts::TAU,
                epsilon = 1e-3
            );
        }
        other => panic!("expected Infeasible, got {other:?}"),
    }
}

#[test]
fn lift_off_and_infeed_follow_the_crank() {
    let mut ip = Interpolator::new(seed_config(300.0, 24_000.0)).unwrap();
    let at = |ip: &mut Interpolator, deg: f64| ip.cycle((deg * DEG) as u32);
    let cut = at(&mut ip, 0.0);
    assert_eq!((cut.x_lift_mm, cut.x_infeed_mm), (0.0, 0.0));
    at(&mut ip, 90.0);
    at(&mut ip, 180.0);
    let mid = at(&mut ip, 270.0);
    assert_abs_diff_eq!(mid.x_lift_mm, 0.2, epsilon = 1e-12); // full lift mid return stroke
    assert_abs_diff_eq!(mid.x_infeed_mm, 0.01, epsilon = 1e-12); // half the 0.02 mm feed
    at(&mut ip, 359.0);
    let next = at(&mut ip, 0.0);
    assert_eq!(next.stroke_index, 1);
    assert_abs_diff_eq!(next.x_mm, 0.02, epsilon = 1e-12);
}

#[test]
fn bad_machine_data_names_the_field() {
    let mut cfg = seed_config(300.0, 24_000.0);
    cfg.cycle_s = 5e-3;
    let e = Interpolator::new(cfg).unwrap_err().to_string();
    assert!(
        e.contains("cycle time") && e.contains("0.25") && e.contains("4 ms"),
        "{e}"
    );
}

#[test]
fn whole_cut_reaches_depth_and_keeps_the_exact_ratio() {
    // ⌈6.75 / 0.02⌉ = 338 infeed strokes + 3 600 000 / 24 000 = 150 strokes for one turn.
    let cfg = seed_config(300.0, 24_000.0);
    let e = execute_program(&cfg).unwrap();
    assert_eq!(e.strokes, 338 + 150);
    assert_eq!(e.coupling_residual, 0);
    assert_abs_diff_eq!(e.x_infeed_mm, 6.75, epsilon = 1e-12);
    // 488 strokes · 2.4° = 3.2533 turns of C1 (the last cycle may stop a few counts short).
    assert_abs_diff_eq!(e.c1_revolutions, 488.0 * 2.4 / 360.0, epsilon = 1e-3);
    assert_abs_diff_eq!(e.cut_time_s, 488.0 * 0.2, epsilon = 2e-3);
}

#[test]
fn zero_radial_feed_cuts_at_full_depth_from_the_start() {
    let mut cfg = seed_config(300.0, 24_000.0);
    cfg.radial_feed_mm = 0.0;
    let mut ip = Interpolator::new(cfg).unwrap();
    let first = ip.cycle(0);
    assert_abs_diff_eq!(first.x_mm, 6.75, epsilon = 1e-12);
    let e = execute_program(&cfg).unwrap();
    assert_eq!(e.strokes, 150); // one workpiece turn only
}
