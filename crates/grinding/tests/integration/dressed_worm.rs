//! Closing the loop: a worm dressed by `gearcomp-dressing` grinds a gear here.
//!
//! References: the closed-form offset r_b·cos β_b·Δφ of a rotated involute helicoid (T2), the
//! docs/dressing.md "Reference case G1-Z5" profile of the 3-point crowned G1-Z5 worm (an
//! independent reference
//! calculation), and the first-order worm → gear relation f_n2 = −f_n1 at associated points
//! (JP6903407B2 text to eq. (38), docs/grinding.md "Independent reference: reference example").
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::simulation::{contact_line, fit_contact_line};
use gearcomp_dressing::solve::{solve_three_point, NewtonOptions, ThreePoint};
use gearcomp_dressing::worm::{Flank as DFlank, Worm};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{predicted_gear_f_ft_mm, rho1_estimate_rad};
use gearcomp_grinding::dressed::{DressedProfile, DressedWorm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};

fn d_flank(f: Flank) -> DFlank {
    match f {
        Flank::Right => DFlank::Right,
        Flank::Left => DFlank::Left,
    }
}

/// Tabulates the dressed profile over the active profile (41 points) and fits ρ_F1 (37).
fn dressed_profile(setup: &DressingSetup, flank: Flank, dk: &AxisCorrection) -> DressedProfile {
    let fl = d_flank(flank);
    let (w_nf0, w_na) = setup.active_profile(fl).unwrap();
    // Where the dresser dressed under ΔK: from its fillet/flank tangent point up to the tip.
    let side = setup.dresser.side(fl);
    let r_t = setup.dresser.profile(side.u_tangent_mm * side.z_sign).0;
    let w_nf = setup.roll_dressed_by(fl, r_t, dk, w_nf0).unwrap();
    let ws: Vec<f64> = (0..41)
        .map(|i| w_nf + (w_na - w_nf) * f64::from(i) / 40.0)
        .collect();
    let f = setup.profile(fl, &ws, dk).unwrap();
    let line = contact_line(setup, fl, &ws, dk).unwrap();
    let (rho, _, _) = fit_contact_line(&line);
    DressedProfile::new(
        flank,
        setup.worm.r_b_mm,
        setup.worm.beta_b_rad,
        ws,
        f,
        (w_nf, w_na),
        rho,
    )
    .unwrap()
}

/// Gear G1 (docs/dressing.md "Reference case G1 and its worms"): z = 40, m_n = 3, α_n = 20°, β =
/// 15° right hand.
fn gear_g1() -> InvoluteGear {
    InvoluteGear::new(40, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap()
}

/// Worm G1 (1 start, d_S0 = 280 mm) with its dresser (d_A = 125 mm, jacket 0.8 mm).
fn setup_g1() -> DressingSetup {
    let worm = Worm::design(1, 280.0, 3.0, 20f64.to_radians()).unwrap();
    let spec = DresserSpec {
        d_a_mm: 125.0,
        jacket_width_mm: 0.8,
        clearance_mm: 0.0,
    };
    DressingSetup::new(worm, Dresser::design(&worm, spec).unwrap())
}

fn pair_g1(flank: Flank) -> WormGearPair {
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 140.0, Hand::Right).unwrap();
    WormGearPair::reference(&worm, &gear_g1(), flank).unwrap()
}

/// (a) A worm dressed uncorrected by its own dresser grinds the unmodified gear: |f_n2| below
/// the dressing residual, < 0.1 µm (here < 1e-6 µm), on both flanks, axial and diagonal.
/// The dressing crate's helicoid must be the grinding crate's (checked by `DressedWorm::new`),
/// and the exact dresser contact line (37) is close to the axial-section estimate.
#[test]
fn a_uncorrected_dressing_grinds_the_unmodified_gear() {
    let setup = setup_g1();
    for flank in [Flank::Right, Flank::Left] {
        let pair = pair_g1(flank);
        let table = dressed_profile(&setup, flank, &AxisCorrection::default());
        let est = rho1_estimate_rad(&pair);
        assert!(
            (table.rho_f1_rad - est).abs() < 5f64.to_radians(),
            "{flank:?}: ρ_F1 {} vs estimate {}",
            table.rho_f1_rad.to_degrees(),
            est.to_degrees()
        );
        let worm = DressedWorm::new(table, &pair.worm).unwrap();
        let w2p = pair.gear.w_ref_mm;
        let grid = FlankGrid::new((w2p - 5.0, w2p + 5.0), (-10.0, 10.0), 5, 3).unwrap();
        worm.check_covers(&pair, grid.w_range_mm).unwrap();
        for k in [0.0, -0.8] {
            let cpl = FeedCoupling::linear(k, 2.0).unwrap();
            let g = Grinder::new(&pair, &cpl, &worm, EnvelopeMode::RotationAndFeed);
            let mut out = GroundFlank::new(grid);
            g.grind_flank(&mut out).unwrap();
            let worst = out
                .points
                .iter()
                .map(|p| p.f_n_mm.abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-9, "{flank:?} K = {k}: {worst} mm");
        }
    }
}

/// (b) A pure Δφ_S = 1e-3 rad of the dresser is a uniform normal offset r_b·cos β_b·Δφ =
/// 1.4095 µm on the worm (+ on the right flank, − on the left: the thread turns as a whole),
/// and the opposite uniform deviation on the gear, f_n2 = ∓1.4095 µm, f_Ft2 = f_n2/cos β_b2
/// (T2 through the whole chain).
#[test]
fn b_dphi_offset_is_uniform_and_opposite_on_the_gear() {
    let setup = setup_g1();
    let dk = AxisCorrection {
        dphi_s_rad: 1e-3,
        ..Default::default()
    };
    let closed_form = setup.worm.r_b_mm * setup.worm.beta_b_rad.cos() * 1e-3;
    assert!((closed_form - 1.40954e-3).abs() < 1e-8);
    for flank in [Flank::Right, Flank::Left] {
        let s = flank.sign();
        let pair = pair_g1(flank);
        let table = dressed_profile(&setup, flank, &dk);
        for (w, f) in table.w_mm.iter().zip(&table.f_n_mm) {
            assert!((f - s * closed_form).abs() < 1e-9, "{flank:?}: {w} {f}");
        }
        let worm = DressedWorm::new(table, &pair.worm).unwrap();
        let cb2 = pair.gear.beta_b_rad.cos();
        let w2p = pair.gear.w_ref_mm;
        for k in [0.0, -0.8] {
            let cpl = FeedCoupling::linear(k, 0.0).unwrap();
            let g = Grinder::new(&pair, &cpl, &worm, EnvelopeMode::RotationAndFeed);
            for (w, z) in [(w2p - 4.0, -10.0), (w2p, 0.0), (w2p + 4.0, 10.0)] {
                let p = g.grind_point(w, z).unwrap();
                assert!((p.f_n_mm + s * closed_form).abs() < 1e-9, "{flank:?} {p:?}");
                assert!((p.f_ft_mm + s * closed_form / cb2).abs() < 1e-9);
            }
        }
    }
}

/// docs/dressing.md "Reference case G1-Z5" (G1-Z5, c = 0.2 µm): the dressed profile at 0, 10, …,
/// 100 % of
/// the active profile, µm.
const D3_PROFILE_UM: [f64; 11] = [
    0.0469, -0.0420, -0.1111, -0.1605, -0.1901, -0.2000, -0.1901, -0.1605, -0.1111, -0.0420, 0.0469,
];

/// (c) A 3-point crowned worm (G1-Z5, c = 0.2 µm, docs/dressing.md "Reference case G1-Z5") grinds
/// gear G1: at the gear roll
/// distances associated with the worm's 0, 10, …, 100 % points the ground f_n2 is the
/// negative of the reference worm profile (so the gear gets +c of profile crowning) and agrees with
/// the analytic map (T3 through the chain) within 1 % of c, for axial and diagonal grinding.
#[test]
fn c_three_point_crowned_worm_maps_to_gear_profile_crowning() {
    let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
    let spec = DresserSpec {
        d_a_mm: 100.0,
        jacket_width_mm: 0.8,
        clearance_mm: 0.0,
    };
    let setup = DressingSetup::new(worm, Dresser::design(&worm, spec).unwrap());
    let (w_nf, w_na) = setup.active_profile(DFlank::Right).unwrap();
    let at = |q: f64| w_nf + q * (w_na - w_nf);
    let c_mm = 0.2e-3;
    let k0 = AxisCorrection::default();
    let problem = ThreePoint {
        flank: DFlank::Right,
        w_mm: [at(0.05), at(0.5), at(0.95)],
        f_mm: [0.0, -c_mm, 0.0],
        w_assoc_mm: w_na,
        r_a_mm: setup.association(DFlank::Right, w_na, &k0).unwrap(),
    };
    let sol = solve_three_point(&setup, &problem, k0, &NewtonOptions::default()).unwrap();
    let table = dressed_profile(&setup, Flank::Right, &sol.dk);

    let gworm = InvoluteGear::worm(5, 3.0, 20f64.to_radians(), 80.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&gworm, &gear_g1(), Flank::Right).unwrap();
    let dressed = DressedWorm::new(table, &pair.worm).unwrap();
    let tol_mm = 0.01 * c_mm;
    for (k, z_v01) in [(0.0, 0.0), (-0.6, 4.0)] {
        let cpl = FeedCoupling::linear(k, z_v01).unwrap();
        let g = Grinder::new(&pair, &cpl, &dressed, EnvelopeMode::RotationAndFeed);
        let cb2 = pair.gear.beta_b_rad.cos();
        let mut f_at = [0.0; 3];
        for (i, want_um) in D3_PROFILE_UM.iter().enumerate() {
            let q = i as f64 / 10.0;
            let w1 = at(q);
            let w2 = (w1 - pair.path.b_mm) / pair.path.a;
            let z2 = -8.0 + 1.6 * i as f64;
            let p = g.grind_point(w2, z2).unwrap();
            // the interpolated worm table reproduces the reference table to its 1e-3 µm tolerance
            assert!((dressed.f_n_mm(w1) * 1e3 - want_um).abs() < 1e-3);
            // ground gear = −worm (reference table) within 1 % of c plus that tolerance
            assert!(
                (p.f_n_mm + want_um * 1e-3).abs() < tol_mm + 1e-6,
                "K = {k}, {q}: {} µm vs {} µm",
                p.f_n_mm * 1e3,
                -want_um
            );
            // envelope vs analytic map within 1 % of c
            let an = predicted_gear_f_ft_mm(&pair, &cpl, &dressed, w2, z2) * cb2;
            assert!(
                (p.f_n_mm - an).abs() < tol_mm,
                "{q}: {} vs {}",
                p.f_n_mm,
                an
            );
            // the worm point of the shortest cut is the associated one (R7)
            assert!((p.w1_mm - w1).abs() < 1e-3);
        }
        for (j, q) in [0.05, 0.5, 0.95].into_iter().enumerate() {
            let w2 = (at(q) - pair.path.b_mm) / pair.path.a;
            f_at[j] = g.grind_point(w2, 0.0).unwrap().f_n_mm;
        }
        // gear profile crowning between the associated 5 % / 95 % points: +c within 1 %
        let crowning = f_at[1] - 0.5 * (f_at[0] + f_at[2]);
        assert!((crowning - c_mm).abs() < tol_mm, "crowning {crowning}");
    }
}

/// The shared `Flank` on a right-hand worm (docs/dressing.md "Gear vocabulary"): the end-face
/// right flank (outward normal clockwise seen from +z) is the thread's +z face, so its outward
/// normal also points towards +z, as the dressing crate's worm-frame `Right` flank does; the
/// left flank the other way. e_θ is the counter-clockwise tangent at the point.
#[test]
fn shared_flank_end_face_right_is_the_worm_plus_z_face() {
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    for (flank, s) in [(Flank::Right, 1.0), (Flank::Left, -1.0)] {
        let f = worm.flank(flank);
        for w in [0.5, f.w_ref_mm, f.w_ref_mm + 3.0] {
            for z in [-10.0, 0.0, 7.5] {
                let p = f.point(w, z);
                let n = f.normal(w, z);
                let e_theta = nalgebra::Vector3::new(-p.y, p.x, 0.0).normalize();
                assert!(s * n.z > 0.0, "{flank:?} w {w} z {z}: n = {n:?}");
                assert!(
                    s * n.dot(&e_theta) < 0.0,
                    "{flank:?} w {w} z {z}: n = {n:?}"
                );
            }
        }
    }
}
