//! Issue 13 items 2 and 3: the bounded worm and the robust envelope search, against the
//! independent bounded brute-force envelope of `brute_envelope.rs`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{rho1_estimate_rad, worm_modification_for_gear};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};
use gearcomp_grinding::GrindError;

use crate::brute_envelope::{brute_envelope, BruteSettings};

fn um(v: &[f64]) -> Poly {
    Poly(v.iter().map(|c| c * 1e-3).collect())
}

/// Roll-distance bounds of a worm flank between radii.
fn w_bounds(pair: &WormGearPair, root: f64, tip: f64) -> (f64, f64) {
    let rb = pair.worm.r_b_mm;
    ((root * root - rb * rb).sqrt(), (tip * tip - rb * rb).sqrt())
}

/// The reproduction (z2 = 62, m_n = 1, left flank, a strongly modified worm).
fn item2() -> (WormGearPair, LineModification, FeedCoupling) {
    let a = 17.933f64.to_radians();
    let gear = InvoluteGear::new(62, 1.0, a, (-10.35f64).to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 1.0, a, 114.024, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Left).unwrap();
    let m = LineModification::new(
        (-27.106f64).to_radians(),
        pair.worm.w_ref_mm,
        um(&[301.443014935705, 7.156780488102248, 0.042326528055858376]),
        um(&[-13.37289545684647, 0.2524376444872974]),
        um(&[-76.36925062461678]),
    )
    .unwrap();
    let cpl = FeedCoupling::linear(1.4872868675123294, 14.153).unwrap();
    (pair, m, cpl)
}

/// Item 2: the unbounded search found −2987.10 µm at (w2 8.127, z2 8.39) on another thread
/// turn; bounded to the worm thread (r1 ± 1.25·m_n) it finds the brute-force envelope,
/// −0.3673 µm with the worm contact at r = 114.55 mm (the independent value −0.367 µm),
/// and the point is consistent with its second-order model. The other grid corners agree with
/// the brute force to 1e-6 mm.
#[test]
fn item2_bounded_worm_matches_brute_force() {
    let (pair, m, cpl) = item2();
    let (root, tip) = (114.024 - 1.25, 114.024 + 1.25);
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
        .with_worm_radii(root, tip)
        .unwrap();
    let set = BruteSettings {
        w1_bounds_mm: w_bounds(&pair, root, tip),
        ray_half_mm: 0.2,
        ray_step_mm: 0.005,
        half_u_mm: 2.0,
        half_v_mm: 5.0,
    };
    let cb2 = pair.gear.beta_b_rad.cos();
    for &(w2, z2) in &[(8.127, 8.39), (8.127, -8.39), (12.6, 8.39), (10.0, 0.0)] {
        let p = g.grind_point(w2, z2).unwrap();
        let (t, w1, _) = brute_envelope(&pair, 1, &cpl, &m, &set, w2, z2).unwrap();
        assert!(
            (p.f_n_mm - t).abs() < 1e-6,
            "({w2}, {z2}): {} vs brute {}",
            p.f_n_mm,
            t
        );
        assert!((p.w1_mm - w1).abs() < 1e-3);
        assert!(!p.worm_edge && p.explained, "({w2}, {z2}) {p:?}");
    }
    let p = g.grind_point(8.127, 8.39).unwrap();
    assert!(
        (p.f_ft_mm * 1e3 + 0.3673).abs() < 1e-3,
        "{}",
        p.f_ft_mm * 1e3
    );
    assert!((pair.worm.r_b_mm.hypot(p.w1_mm) - 114.550).abs() < 1e-3);
    assert!((p.f_n_mm / cb2 - p.f_ft_mm).abs() < 1e-15);
}

/// Item 2, the bound itself: a worm whose tip is below the contact radius 114.55 mm cannot
/// grind the point with its flank: the search ends on the tip edge (marked) or finds no
/// contact (an error naming the point), never a value from beyond the worm.
#[test]
fn item2_contact_beyond_the_worm_is_marked_or_refused() {
    let (pair, m, cpl) = item2();
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
        .with_worm_radii(112.774, 114.5)
        .unwrap();
    match g.grind_point(8.127, 8.39) {
        Ok(p) => {
            assert!(p.worm_edge && !p.explained, "{p:?}");
            assert!(pair.worm.r_b_mm.hypot(p.w1_mm) <= 114.5 + 1e-9);
        }
        Err(e) => {
            assert!(matches!(e, GrindError::NoWormContact { .. }), "{e}");
            assert!(e.to_string().contains("w = 8.127 mm"), "{e}");
        }
    }
    // bad radii are refused with the field name
    let e = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed)
        .with_worm_radii(115.0, 114.0)
        .err()
        .unwrap();
    assert!(e.to_string().contains("worm_tip_radius_mm"), "{e}");
}

/// Item 3: `grind solve --gear-rho-deg 0 --gear-l=0,0.3` on the default gear. The worm for a
/// plain twist (F_L = 0.3 µm/mm²·X) failed to converge ("residual −140.99 mm") at 137 of 775
/// points; now every point of the default grid converges, warm-started from its neighbour,
/// and sampled points equal the brute-force envelope to 1e-6 mm.
#[test]
fn item3_twist_worm_grinds_every_point() {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let wanted = LineModification::new(
        0.0,
        pair.gear.w_ref_mm,
        Poly(vec![]),
        um(&[0.0, 0.3]),
        Poly(vec![]),
    )
    .unwrap();
    let (lm, wm) =
        worm_modification_for_gear(&pair, &wanted, rho1_estimate_rad(&pair), 0.0).unwrap();
    let cpl = FeedCoupling::linear(lm.k_zv1, 0.0).unwrap();
    let (root, tip) = (130.0 - 3.75, 130.0 + 3.75);
    let g = Grinder::new(&pair, &cpl, &wm, EnvelopeMode::RotationAndFeed)
        .with_worm_radii(root, tip)
        .unwrap();
    let wp = pair.gear.w_ref_mm;
    let grid = FlankGrid::new((wp - 6.0, wp + 6.0), (-15.0, 15.0), 25, 31).unwrap();
    let mut out = GroundFlank::new(grid);
    g.grind_flank(&mut out).unwrap();
    let set = BruteSettings {
        w1_bounds_mm: w_bounds(&pair, root, tip),
        ray_half_mm: 0.1,
        ray_step_mm: 0.004,
        half_u_mm: 3.0,
        half_v_mm: 10.0,
    };
    for &(i, j) in &[(0, 0), (0, 30), (12, 15), (24, 0), (24, 30), (6, 22)] {
        let p = out.at(i, j);
        let (t, _, _) =
            brute_envelope(&pair, 1, &cpl, &wm, &set, grid.w_mm(i), grid.z_mm(j)).unwrap();
        assert!(
            (p.f_n_mm - t).abs() < 1e-6,
            "({i}, {j}): {} vs {t}",
            p.f_n_mm
        );
        assert!(p.explained, "({i}, {j}) {p:?}");
    }
}

/// Item 4: the iterated solve on the reference gear (z2 = 31, m_n = 3, β = 15°, worm r1 =
/// 130 mm, grid w_P ± 6 mm × ±15 mm, 25 × 31). The first-order worm leaves 1.44 % of a lead
/// crowning (−0.02 µm/mm²·z², 4.5 µm) and 0.38 µm of a 0.2 µm/mm² twist (18 µm), as the issue
/// measured; the iteration brings both below 0.5 % of the wish. The final worm is ground again
/// by the brute-force envelope at sample points: the wish is met there within the same bound.
#[test]
fn item4_iterated_solve_meets_the_wish() {
    use gearcomp_grinding::modification::FlankModification;
    use gearcomp_grinding::solve::{solve_iterated, IterationOptions};
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let wp = pair.gear.w_ref_mm;
    let grid = FlankGrid::new((wp - 6.0, wp + 6.0), (-15.0, 15.0), 25, 31).unwrap();
    let (root, tip) = (126.25, 133.75);
    for (name, c, l, first_lo, first_hi) in [
        (
            "lead crowning",
            um(&[0.0, 0.0, -0.02]),
            Poly(vec![]),
            0.0640,
            0.0650,
        ),
        ("twist", Poly(vec![]), um(&[0.0, 0.2]), 0.380, 0.386),
    ] {
        let wanted = LineModification::new(0.0, wp, c, l, Poly(vec![])).unwrap();
        let rho1 = rho1_estimate_rad(&pair);
        let r = solve_iterated(
            &pair,
            &wanted,
            rho1,
            0.0,
            grid,
            (root, tip),
            &IterationOptions::default(),
        )
        .unwrap();
        let first_um = r.iterations[0].max_abs_deviation_mm * 1e3;
        assert!(
            first_um > first_lo && first_um < first_hi,
            "{name}: first order {first_um}"
        );
        let bound = (0.005 * r.wish_max_abs_mm).max(1e-5);
        assert!(r.converged && r.remaining_mm <= bound, "{name}: {r:?}");
        assert!(r.iterations.len() >= 2);
        // independent check of the final worm
        let cpl = FeedCoupling::linear(r.line_map.k_zv1, 0.0).unwrap();
        let set = BruteSettings {
            w1_bounds_mm: w_bounds(&pair, root, tip),
            ray_half_mm: 0.1,
            ray_step_mm: 0.004,
            half_u_mm: 3.0,
            half_v_mm: 10.0,
        };
        let cb2 = pair.gear.beta_b_rad.cos();
        for &(i, j) in &[(0, 0), (24, 30), (12, 15), (3, 27)] {
            let (w2, z2) = (grid.w_mm(i), grid.z_mm(j));
            let (t, _, _) = brute_envelope(&pair, 1, &cpl, &r.worm, &set, w2, z2).unwrap();
            let miss = (t / cb2 - wanted.f_ft_mm(w2, z2)).abs();
            assert!(miss <= bound + 1e-6, "{name} ({i}, {j}): {miss}");
        }
    }
}
