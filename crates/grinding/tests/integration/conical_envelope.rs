//! Envelope grinding with conical worm and/or workpiece: the analytic conical contact path
//! (A1) against the envelope simulation (A3) — zero deviation for unmodified flanks and the
//! coefficients fitted from two simulated feed couplings.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_grinding::conical::{BeveloidGear, ConicalPair};
use gearcomp_grinding::conical_sim::{fit_conical_path, EnvelopeGrinder};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly, Uniform};
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};

fn pair(cone1_deg: f64, cone2_deg: f64, flank: Flank) -> ConicalPair {
    let g = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let w = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let w = BeveloidGear::new(w, cone1_deg.to_radians()).unwrap();
    let g = BeveloidGear::new(g, cone2_deg.to_radians()).unwrap();
    ConicalPair::reference(&w, &g, flank).unwrap()
}

fn grid() -> FlankGrid {
    FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 5, 5).unwrap()
}

/// T1 for cones: an unmodified conical worm grinds an unmodified (conical) gear with
/// |f_n2| < 1e-9 mm, searches started 0.3 mm / 0.5 mm away from the analytic seed; a uniform
/// worm stock of +10 µm normal gives −10 µm normal on the gear (T2).
#[test]
fn t1_t2_conical_unmodified_and_uniform() {
    for &(c1, c2) in &[(6.0, 0.0), (0.0, -5.0), (4.0, 7.0)] {
        for flank in [Flank::Right, Flank::Left] {
            let p = pair(c1, c2, flank);
            let cpl = FeedCoupling::linear(-0.877, 5.0).unwrap();
            let none = LineModification::default();
            let g = EnvelopeGrinder::new(&p, &cpl, &none, EnvelopeMode::RotationAndFeed)
                .with_seed_offset(0.3, 0.5);
            let mut out = GroundFlank::new(grid());
            g.grind_flank(&mut out).unwrap();
            let worst = out
                .points
                .iter()
                .map(|q| q.f_n_mm.abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "({c1},{c2}) {flank:?}: {worst}");
            let stock = Uniform {
                f_ft_mm: 0.010 / p.worm.beta_b_rad.cos(),
            };
            let g = EnvelopeGrinder::new(&p, &cpl, &stock, EnvelopeMode::RotationAndFeed);
            let q = g.grind_point(17.0, 4.0).unwrap();
            assert!((q.f_n_mm + 0.010).abs() < 1e-6, "{}", q.f_n_mm);
        }
    }
}

/// A3 step 8 / T12 cone variant: the contact path fitted from two simulations (z_V01 = 0 and
/// 6 mm, diagonal ratio −0.877) reproduces the analytic coefficients of A1, including the
/// feed terms C_FzV11, C_FzV12, C_FzV21, C_FzV22 and those of (86).
#[test]
fn t12_fitted_conical_path_matches_analytic() {
    for &(c1, c2) in &[(6.0, 0.0), (0.0, -5.0), (4.0, 7.0)] {
        let p = pair(c1, c2, Flank::Right);
        let none = LineModification::default();
        let c_a = FeedCoupling::linear(-0.877, 0.0).unwrap();
        let c_b = FeedCoupling::linear(-0.877, 6.0).unwrap();
        let mut out_a = GroundFlank::new(grid());
        let mut out_b = GroundFlank::new(grid());
        EnvelopeGrinder::new(&p, &c_a, &none, EnvelopeMode::RotationAndFeed)
            .with_seed_offset(0.2, -0.4)
            .grind_flank(&mut out_a)
            .unwrap();
        EnvelopeGrinder::new(&p, &c_b, &none, EnvelopeMode::RotationAndFeed)
            .with_seed_offset(-0.2, 0.4)
            .grind_flank(&mut out_b)
            .unwrap();
        let fit = fit_conical_path(&[(&out_a, &c_a), (&out_b, &c_b)]).unwrap();
        let an = p.path;
        let pairs = [
            ("C_Fw1", fit.c_w1, an.c_w1),
            ("C_FzV11", fit.c_zv11, an.c_zv11),
            ("C_FzV21", fit.c_zv21, an.c_zv21),
            ("C_Fw2", fit.c_w2, an.c_w2),
            ("C_FzV12", fit.c_zv12, an.c_zv12),
            ("C_FzV22", fit.c_zv22, an.c_zv22),
            ("a", fit.a, an.a),
            ("b_zv1", fit.b_zv1, an.b_zv1),
            ("b_zv2", fit.b_zv2, an.b_zv2),
        ];
        for (name, f, a) in pairs {
            assert!(
                (f - a).abs() < 1e-3,
                "({c1},{c2}) {name}: fitted {f} analytic {a}"
            );
        }
        assert!((fit.c_c2_mm - an.c_c2_mm).abs() < 1e-2);
        assert!((fit.b_mm - an.b_mm).abs() < 1e-2);
        // one run alone cannot separate z_V1 from z_V2
        assert!(fit_conical_path(&[(&out_a, &c_a)]).is_err());
    }
}

/// The generic simulation reproduces the cylindrical `Grinder` (T8 worm, K(20°, 45°)).
#[test]
fn generic_envelope_equals_cylindrical_grinder() {
    let g = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let w = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let p = WormGearPair::reference(&w, &g, Flank::Right).unwrap();
    let cpl = FeedCoupling::linear(-0.877178, 5.0).unwrap();
    let m = LineModification::new(
        20f64.to_radians(),
        p.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, 1e-5]),
        Poly(vec![-3e-5]),
    )
    .unwrap();
    let a = Grinder::new(&p, &cpl, &m, EnvelopeMode::RotationAndFeed);
    let b = EnvelopeGrinder::new(&p, &cpl, &m, EnvelopeMode::RotationAndFeed);
    // docs/grinding.md "Independent reference: brute-force envelope", true envelope, at (15, 0):
    // −13.6759 µm
    let qa = a.grind_point(15.0, 0.0).unwrap();
    let qb = b.grind_point(15.0, 0.0).unwrap();
    assert!((qa.f_ft_mm - qb.f_ft_mm).abs() < 1e-9);
    assert!(
        (qb.f_ft_mm * 1e3 + 13.6759).abs() < 2e-3,
        "{}",
        qb.f_ft_mm * 1e3
    );
}
