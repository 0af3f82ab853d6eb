//! Grinding simulation (envelope over rotation and feed) against the reference numbers of
//! docs/grinding.md "Independent reference: reference example" and docs/grinding.md "Independent
//! reference: brute-force envelope" (an independent brute-force calculation).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, predicted_gear_f_ft_mm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly, Uniform};
use gearcomp_grinding::simulate::{
    fit_contact_path, EnvelopeMode, FlankGrid, Grinder, GroundFlank,
};

fn example(flank: Flank) -> WormGearPair {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    WormGearPair::reference(&worm, &gear, flank).unwrap()
}

fn none() -> LineModification {
    LineModification::default()
}

/// T1: an unmodified worm grinds an unmodified gear, |f_n2| < 1e-9 mm (exact-time variant),
/// on the 15×15 grid of docs/grinding.md "Independent reference: reference example", for axial (K =
/// 0) and diagonal (K = −0.877) grinding, both
/// flanks; searches start 0.3 mm (rotation) and 0.5 mm (feed) away from the analytic seed.
#[test]
fn t1_unmodified_worm_grinds_unmodified_gear() {
    for flank in [Flank::Right, Flank::Left] {
        let pair = example(flank);
        for k in [0.0, -0.877] {
            let cpl = FeedCoupling::linear(k, 5.0).unwrap();
            let m = none();
            let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
                .with_seed_offset(0.3, 0.5);
            let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 15, 15).unwrap();
            let mut out = GroundFlank::new(grid);
            g.grind_flank(&mut out).unwrap();
            let worst = out
                .points
                .iter()
                .map(|p| p.f_n_mm.abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "{flank:?} K={k}: {worst}");
        }
    }
}

/// T2: uniform normal stock +0.010 mm on the worm ⇒ f_n2 = −0.010 mm, f_Ft2 = −0.010310 mm.
#[test]
fn t2_uniform_stock() {
    let pair = example(Flank::Right);
    let cb1 = pair.worm.beta_b_rad.cos();
    let stock = Uniform {
        f_ft_mm: 0.010 / cb1,
    };
    for k in [0.0, -0.877] {
        let cpl = FeedCoupling::linear(k, 0.0).unwrap();
        let g = Grinder::new(&pair, &cpl, &stock, EnvelopeMode::RotationAndFeed);
        for &(w, z) in &[(11.0, -15.0), (17.0, 0.0), (23.0, 15.0)] {
            let p = g.grind_point(w, z).unwrap();
            assert!((p.f_n_mm + 0.010).abs() < 1e-6, "{}", p.f_n_mm);
            assert!((p.f_ft_mm + 0.010310).abs() < 1e-6, "{}", p.f_ft_mm);
        }
    }
}

/// T3: profile crowning C_q·(w1 − w1P)² on the worm, axial grinding. Full envelope vs
/// docs/grinding.md "Independent reference: brute-force envelope", true envelope; restricted
/// (rotation-only) envelope vs the rotation-only brute force of docs/grinding.md "Independent
/// reference: brute-force envelope";
/// analytic map vs the last column.
#[test]
fn t3_profile_crowning_transfer() {
    let pair = example(Flank::Right);
    let worm = LineModification::new(
        -std::f64::consts::FRAC_PI_2,
        pair.worm.w_ref_mm,
        Poly(vec![]),
        Poly(vec![]),
        Poly(vec![4.555125e-3]),
    )
    .unwrap();
    let cpl = FeedCoupling::linear(0.0, 0.0).unwrap();
    let full = Grinder::new(&pair, &cpl, &worm, EnvelopeMode::RotationAndFeed);
    let restricted = Grinder::new(&pair, &cpl, &worm, EnvelopeMode::RotationOnly);
    let w2p = pair.gear.w_ref_mm;
    for &(w2, env_um, rotation_only_um, analytic_um) in &[
        (12.0, -4.9791, -4.978, -4.9494),
        (w2p, 0.0, 0.0, 0.0),
        (22.0, -5.0670, -5.067, -5.0508),
    ] {
        let f = full.grind_point(w2, 0.0).unwrap().f_ft_mm * 1e3;
        let r = restricted.grind_point(w2, 0.0).unwrap().f_ft_mm * 1e3;
        let a = predicted_gear_f_ft_mm(&pair, &cpl, &worm, w2, 0.0) * 1e3;
        assert!((f - env_um).abs() < 1e-3, "full {w2}: {f} vs {env_um}");
        assert!(
            (r - rotation_only_um).abs() < 1e-3,
            "restricted {w2}: {r} vs {rotation_only_um}"
        );
        assert!(
            (a - analytic_um).abs() < 1e-4,
            "analytic {w2}: {a} vs {analytic_um}"
        );
        // the T3 criterion: analytic within 1 % of the envelope
        assert!((a - f).abs() <= 0.01 * f.abs() + 1e-9);
    }
}

fn t8_worm(pair: &WormGearPair, b: f64, cq: f64) -> LineModification {
    LineModification::new(
        20f64.to_radians(),
        pair.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, b]),
        Poly(vec![cq]),
    )
    .unwrap()
}

/// T8: diagonal grinding K = K(20°, 45°), z_V01 = 5 mm; full envelope vs docs/grinding.md
/// "Independent reference: brute-force envelope", analytic
/// map within 0.5 %; a worm modification constant along ρ1 lines is constant along the
/// ρ2 = 45° gear line X2 = 10 within 0.02 µm.
#[test]
fn t8_diagonal_line_mapping_by_simulation() {
    let pair = example(Flank::Right);
    let k = diagonal_ratio(&pair, 20f64.to_radians(), 45f64.to_radians()).unwrap();
    let cpl = FeedCoupling::linear(k, 5.0).unwrap();
    let worm = t8_worm(&pair, 1e-5, -3e-5);
    let g = Grinder::new(&pair, &cpl, &worm, EnvelopeMode::RotationAndFeed);
    for &(w2, z2, env_um) in &[
        (15.0, 0.0, -13.6759),
        (19.0, 8.0, -8.0404),
        (13.0, -10.0, -20.6535),
        (21.0, 12.0, -5.7648),
    ] {
        let f = g.grind_point(w2, z2).unwrap().f_ft_mm * 1e3;
        let a = predicted_gear_f_ft_mm(&pair, &cpl, &worm, w2, z2) * 1e3;
        assert!((f - env_um).abs() < 2e-3, "({w2},{z2}): {f} vs {env_um}");
        assert!(
            (a - f).abs() < 0.005 * f.abs(),
            "({w2},{z2}): analytic {a} vs {f}"
        );
    }
    let line_worm = t8_worm(&pair, 0.0, 0.0);
    let g = Grinder::new(&pair, &cpl, &line_worm, EnvelopeMode::RotationAndFeed);
    let r2 = 45f64.to_radians();
    let mut vals = Vec::new();
    for &(w2, env_um) in &[(12.0, -14.0261), (16.0, -14.0201), (20.0, -14.0163)] {
        let z2 = (10.0 - w2 * r2.sin()) / r2.cos();
        let f = g.grind_point(w2, z2).unwrap().f_ft_mm * 1e3;
        assert!((f - env_um).abs() < 2e-3, "line {w2}: {f} vs {env_um}");
        vals.push(f);
    }
    let spread = vals.iter().cloned().fold(f64::MIN, f64::max)
        - vals.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread < 0.02, "{spread}");
}

/// T4/T12: the contact path fitted from the simulation's stored feeds and worm points agrees
/// with the analytic plane-of-action coefficients (tolerance 1e-3).
#[test]
fn t4_t12_contact_path_fitted_from_simulation() {
    for flank in [Flank::Right, Flank::Left] {
        let pair = example(flank);
        let cpl = FeedCoupling::linear(-0.877, 5.0).unwrap();
        let m = none();
        let g =
            Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed).with_seed_offset(0.3, 0.5);
        let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 7, 5).unwrap();
        let mut out = GroundFlank::new(grid);
        g.grind_flank(&mut out).unwrap();
        let fit = fit_contact_path(&out, &cpl).unwrap();
        let s = flank.sign();
        assert!((fit.c_w2 - s * 0.250739).abs() < 1e-3, "{}", fit.c_w2);
        assert!((fit.c_w1 - s * 2.745915).abs() < 1e-3, "{}", fit.c_w1);
        assert!((fit.a + 0.352785).abs() < 1e-3, "{}", fit.a);
        assert!(
            (fit.r7_sum_mm - 397.213083).abs() < 1e-3,
            "{}",
            fit.r7_sum_mm
        );
        assert!((fit.c_c2_mm - pair.path.c_c2_mm).abs() < 1e-3);
        assert!((fit.c_c1_mm - pair.path.c_c1_mm).abs() < 1e-2);
    }
}

/// Bad input is an error, not a panic.
#[test]
fn bad_points_are_errors() {
    let pair = example(Flank::Right);
    let cpl = FeedCoupling::linear(0.0, 0.0).unwrap();
    let m = none();
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed);
    assert!(g.grind_point(f64::NAN, 0.0).is_err());
    assert!(g.grind_point(-3.0, 0.0).is_err());
    assert!(FlankGrid::new((11.0, 10.0), (-1.0, 1.0), 3, 3).is_err());
    assert!(FlankGrid::new((11.0, 12.0), (-1.0, 1.0), 1, 3).is_err());
}

/// Other hands and a spur gear: a left-hand worm on a left-hand gear and a right-hand worm on
/// a spur gear also grind the exact involute (T1), and for the spur gear the contact path runs
/// at constant z (C_Fw2 = 0, ρ_KF = 0; T4 of docs/grinding.md "Independent reference: reference
/// example").
#[test]
fn t1_t4_other_hands_and_spur_gear() {
    let a20 = 20f64.to_radians();
    let cases = [
        (
            InvoluteGear::new(31, 3.0, a20, -15f64.to_radians()).unwrap(),
            Hand::Left,
        ),
        (InvoluteGear::new(40, 2.0, a20, 0.0).unwrap(), Hand::Right),
    ];
    for (gear, hand) in cases {
        let worm = InvoluteGear::worm(2, gear.m_n_mm, a20, 50.0, hand).unwrap();
        for flank in [Flank::Right, Flank::Left] {
            let pair = WormGearPair::reference(&worm, &gear, flank).unwrap();
            if gear.beta_rad == 0.0 {
                assert!(pair.path.c_w2.abs() < 1e-12 && pair.rho_kf_rad().abs() < 1e-12);
            }
            let cpl = FeedCoupling::linear(0.5, 0.0).unwrap();
            let m = none();
            let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
                .with_seed_offset(0.2, 0.3);
            let wp = pair.gear.w_ref_mm;
            for &(w, z) in &[(wp - 3.0, -8.0), (wp, 0.0), (wp + 3.0, 9.0)] {
                let f = g.grind_point(w, z).unwrap().f_n_mm;
                assert!(
                    f.abs() < 1e-9,
                    "{hand:?} β={} {flank:?}: {f}",
                    gear.beta_rad
                );
            }
        }
    }
}
