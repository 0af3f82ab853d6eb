//! Prints the JP6903407B2 part-2 reference numbers (docs/grinding.md "Independent reference:
//! reference example", docs/grinding.md "Independent reference: brute-force envelope") as computed
//! by
//! this crate: contact path, diagonal ratios, and T3/T8 by full envelope, rotation-only
//! envelope and analytic map.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, predicted_gear_f_ft_mm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, Grinder};

fn main() -> Result<(), gearcomp_grinding::GrindError> {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians())?;
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right)?;
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right)?;
    let p = pair.path;
    println!(
        "C_Fw1 {:.6} C_Fc1 {:.6} C_Fw2 {:.6} C_Fc2 {:.6} R7 {:.6} dw1/dw2 {:.6}",
        p.c_w1, p.c_c1_mm, p.c_w2, p.c_c2_mm, p.r7_sum_mm, p.a
    );
    for r2 in [0.0, 30.0, 45.0, 60.0, 75.923905] {
        let k = diagonal_ratio(&pair, 20f64.to_radians(), f64::to_radians(r2))?;
        println!("K(20°, {r2}°) = {k:.6}");
    }
    let t3 = LineModification::new(
        -std::f64::consts::FRAC_PI_2,
        pair.worm.w_ref_mm,
        Poly(vec![]),
        Poly(vec![]),
        Poly(vec![4.555125e-3]),
    )?;
    let axial = FeedCoupling::linear(0.0, 0.0)?;
    let full = Grinder::new(&pair, &axial, &t3, EnvelopeMode::RotationAndFeed);
    let rot = Grinder::new(&pair, &axial, &t3, EnvelopeMode::RotationOnly);
    for w2 in [12.0, pair.gear.w_ref_mm, 22.0] {
        println!(
            "T3 w2 {w2:.6}: envelope {:.4} µm, rotation-only {:.4} µm, analytic {:.4} µm",
            full.grind_point(w2, 0.0)?.f_ft_mm * 1e3,
            rot.grind_point(w2, 0.0)?.f_ft_mm * 1e3,
            predicted_gear_f_ft_mm(&pair, &axial, &t3, w2, 0.0) * 1e3
        );
    }
    let k = diagonal_ratio(&pair, 20f64.to_radians(), 45f64.to_radians())?;
    let cpl = FeedCoupling::linear(k, 5.0)?;
    let t8 = LineModification::new(
        20f64.to_radians(),
        pair.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, 1e-5]),
        Poly(vec![-3e-5]),
    )?;
    let full = Grinder::new(&pair, &cpl, &t8, EnvelopeMode::RotationAndFeed);
    let rot = Grinder::new(&pair, &cpl, &t8, EnvelopeMode::RotationOnly);
    for (w2, z2) in [(15.0, 0.0), (19.0, 8.0), (13.0, -10.0), (21.0, 12.0)] {
        println!(
            "T8 ({w2}, {z2}): envelope {:.4} µm, rotation-only {:.4} µm, analytic {:.4} µm",
            full.grind_point(w2, z2)?.f_ft_mm * 1e3,
            rot.grind_point(w2, z2)?.f_ft_mm * 1e3,
            predicted_gear_f_ft_mm(&pair, &cpl, &t8, w2, z2) * 1e3
        );
    }
    Ok(())
}
