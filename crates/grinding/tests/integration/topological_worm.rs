//! A topologically dressed worm grinds a gear diagonally (T8's line-to-line mapping through real
//! dressing).
//!
//! Chain: the dressing crate dresses worm G1-Z5 with ΔK(ν_zS) varying linearly over the worm
//! width (no correction at ν = 0, the docs/dressing.md "Reference case G1-Z5" crowning root plus a
//! Δφ_S slope at
//! ν ≈ −40 mm: the crowning and the thread thickness both vary along the width) and tabulates
//! f_nFS(w, b) with its quasi-static model on a grid; this crate interpolates the grid, grinds
//! gear G1 with diagonal ratio K (ρ_F1 from the dresser contact line, ρ_F2 = 45°) by the
//! envelope simulation over rotation and feed.
//!
//! Reference (independent of the grid, its interpolation and the simulation): for each gear
//! point, the analytic map (diagonal.rs / contact.rs, docs/grinding.md "Derivation: diagonal ratio
//! and line map") gives the worm point
//! (w1, z1); the dressing crate's own pointwise quasi-static value f_n1 there gives
//! f_Ft2 = −f_n1/cos β_b2 (JP6903407B2 text to eq. (38), f_n2 = −f_n1). Tolerance: 1 % of the
//! modification's
//! span over the gear region (brief of issue 7; the first-order map is within 0.5 % for T8).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::dresser::{Dresser, DresserSpec};
use gearcomp_dressing::envelope::DressingSetup;
use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::simulation::{contact_line, fit_contact_line};
use gearcomp_dressing::topology::{quasi_static_point, PolynomialSchedule, WormTopology};
use gearcomp_dressing::worm::{Flank as DFlank, Worm};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{line_map, predicted_gear_f_ft_mm};
use gearcomp_grinding::dressed_topology::{DressedTopology, TopologicalWorm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::simulate::{EnvelopeMode, Grinder};

const FL: DFlank = DFlank::Right;

/// Worm G1-Z5 (docs/dressing.md "Reference case G1-Z5"): z_S = 5, d_S0 = 160 mm, m_n = 3, α_n =
/// 20°, dresser d_A = 100 mm.
fn setup_g1_z5() -> DressingSetup {
    let worm = Worm::design(5, 160.0, 3.0, 20f64.to_radians()).unwrap();
    let spec = DresserSpec {
        d_a_mm: 100.0,
        jacket_width_mm: 0.8,
        clearance_mm: 0.0,
    };
    DressingSetup::new(worm, Dresser::design(&worm, spec).unwrap())
}

/// ΔK(ν) from 0 at ν = 0 to the docs/dressing.md "Reference case G1-Z5" crowning root (+ a Δφ_S
/// slope) at ν = −40 mm, as the
/// dressing crate's own linear-schedule test.
fn schedule() -> PolynomialSchedule {
    let ke = [6.057e-4, 0.5580f64.to_radians(), -0.02450, -1.0413];
    let per = AxisCorrection::from_array([
        ke[0] / 40.0 + 7e-6,
        ke[1] / 40.0,
        ke[2] / 40.0,
        ke[3] / 40.0,
    ]);
    PolynomialSchedule::linear(AxisCorrection::default(), per.scaled(-1.0))
}

/// Gear G1: z = 40, m_n = 3, α_n = 20°, β = 15°, and the grinding view of the G1-Z5 worm.
fn pair() -> WormGearPair {
    let gear = InvoluteGear::new(40, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(5, 3.0, 20f64.to_radians(), 80.0, Hand::Right).unwrap();
    WormGearPair::reference(&worm, &gear, Flank::Right).unwrap()
}

/// b ↔ z1: the two crates' helicoids of the same worm differ only by a rotation of the body
/// frame about the worm axis (a constant angle between their normals at (w, b) and
/// (w1 = w, z1 = b)), so identifying b with z1 keeps the axial datum and only fixes the worm's
/// angular origin through the thread.
#[test]
fn dressing_and_grinding_helicoids_differ_by_a_body_rotation() {
    let s = setup_g1_z5();
    let p = pair();
    let mut angles = Vec::new();
    for (w, b) in [(18.0, -30.0), (20.0, 0.0), (23.0, 12.5), (25.0, 41.0)] {
        let nd = s.worm.normal(FL, w, b);
        let ng = p.worm.normal(w, b);
        assert!((nd.z - ng.z).abs() < 1e-12, "axial normal component");
        angles.push(ng.y.atan2(ng.x) - nd.y.atan2(nd.x));
    }
    let a0 = angles[0];
    for a in &angles {
        let d = (a - a0 + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        assert!(d.abs() < 1e-12, "{angles:?}");
    }
}

/// The whole chain: dressed topology → grid → diagonal envelope grinding ⇒ every ground gear
/// point carries the (dressing crate's own) worm value at the worm point that the analytic map
/// predicts, within 1 % of the modification span. Gear points on one gear line X2 = const
/// (ρ_F2 = 45°) map to one worm line X1 = k·X2 + c0 (docs/grinding.md "Derivation: diagonal ratio
/// and line map").
#[test]
fn diagonal_grinding_maps_gear_lines_to_dressed_worm_lines() {
    let s = setup_g1_z5();
    let sched = schedule();
    let p = pair();
    let (w_nf, w_na) = s.active_profile(FL).unwrap();
    // ρ_F1 of the dresser contact line (37) at the mid-width correction
    let ws: Vec<f64> = (0..9)
        .map(|i| w_nf + (w_na - w_nf) * f64::from(i) / 8.0)
        .collect();
    let mid: AxisCorrection = gearcomp_dressing::topology::CorrectionSchedule::at(&sched, -20.0);
    let (rho1, _, _) = fit_contact_line(&contact_line(&s, FL, &ws, &mid).unwrap());
    let rho2 = 45f64.to_radians();
    // gear region: the gear roll distances associated with 10–90 % of the worm's active profile
    let w2_of = |w1: f64| (w1 - p.path.b_mm) / p.path.a;
    let (wa, wb) = (
        w2_of(w_nf + 0.1 * (w_na - w_nf)),
        w2_of(w_nf + 0.9 * (w_na - w_nf)),
    );
    let w2_range = (wa.min(wb), wa.max(wb));
    let z2_range = (-10.0, 10.0);
    // K from ρ_F1/ρ_F2; z_V01 puts the used worm width around b = 20 mm (inside the schedule)
    let lm0 = line_map(&p, rho1, rho2, 0.0).unwrap();
    let cpl0 = FeedCoupling::linear(lm0.k_zv1, 0.0).unwrap();
    let (_, (zl, zh)) = TopologicalWorm::used_region_mm(&p, &cpl0, w2_range, z2_range);
    let z_v01 = 0.5 * (zl + zh) - 20.0;
    let lm = line_map(&p, rho1, rho2, z_v01).unwrap();
    let cpl = FeedCoupling::linear(lm.k_zv1, z_v01).unwrap();
    assert!(lm.k_zv1 < -0.1, "a real diagonal ratio: {}", lm.k_zv1);
    let ((ul, uh), (zl, zh)) = TopologicalWorm::used_region_mm(&p, &cpl, w2_range, z2_range);
    assert!(
        zh - zl > 15.0,
        "the contact path sweeps the worm width: {zl}..{zh}"
    );

    // The dressing crate's topology on a coarse grid (9 roll distances × 9 width positions,
    // quasi-static model: 81 pointwise solves, milliseconds).
    let gw: Vec<f64> = (0..9)
        .map(|i| w_nf + (w_na - w_nf) * f64::from(i) / 8.0)
        .collect();
    let gb: Vec<f64> = (0..9)
        .map(|j| (zl - 2.0) + (zh - zl + 4.0) * f64::from(j) / 8.0)
        .collect();
    let topo = WormTopology::quasi_static(&s, FL, gw.clone(), gb.clone(), &sched).unwrap();
    let table = DressedTopology::new(
        Flank::Right,
        s.worm.r_b_mm,
        s.worm.beta_b_rad,
        (topo.w_mm.clone(), topo.b_mm.clone()),
        topo.f_mm.clone(),
        rho1,
    )
    .unwrap();
    let worm = TopologicalWorm::new(table, &p.worm).unwrap();
    worm.check_covers(&p, &cpl, w2_range, z2_range).unwrap();
    assert!(ul >= w_nf && uh <= w_na);

    let g = Grinder::new(&p, &cpl, &worm, EnvelopeMode::RotationAndFeed);
    let cb2 = p.gear.beta_b_rad.cos();
    let reference = |w2: f64, z2: f64| {
        let m = p.map_gear_point(&cpl, w2, z2);
        let f_n1 = quasi_static_point(&s, FL, m.w1_mm, m.z1_mm, &sched)
            .unwrap()
            .f_mm;
        (-f_n1 / cb2, m)
    };
    // 5 × 5 gear points
    let mut rows = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            let w2 = w2_range.0 + (w2_range.1 - w2_range.0) * f64::from(i) / 4.0;
            let z2 = z2_range.0 + (z2_range.1 - z2_range.0) * f64::from(j) / 4.0;
            let (want, _) = reference(w2, z2);
            let got = g.grind_point(w2, z2).unwrap();
            let analytic = predicted_gear_f_ft_mm(&p, &cpl, &worm, w2, z2);
            rows.push((w2, z2, want, got.f_ft_mm, analytic));
        }
    }
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |a, r| {
            (a.0.min(r.2), a.1.max(r.2))
        });
    let span = hi - lo;
    let tol = 0.01 * span;
    // the modification is real (µm) and varies along the gear width at fixed roll distance
    assert!(span > 1.5e-3, "span {} µm", span * 1e3);
    let width_var = rows
        .chunks(5)
        .map(|c| {
            c.iter().map(|r| r.2).fold(f64::NEG_INFINITY, f64::max)
                - c.iter().map(|r| r.2).fold(f64::INFINITY, f64::min)
        })
        .fold(0.0, f64::max);
    assert!(
        width_var > 20.0 * tol,
        "width variation {} µm",
        width_var * 1e3
    );
    let mut worst: f64 = 0.0;
    for &(w2, z2, want, got, analytic) in &rows {
        eprintln!(
            "w2 {w2:8.4} z2 {z2:6.2}: reference {:9.5} µm, envelope {:9.5} µm, map+grid {:9.5} µm",
            want * 1e3,
            got * 1e3,
            analytic * 1e3
        );
        assert!(
            (got - want).abs() < tol,
            "({w2}, {z2}): envelope {} µm vs reference {} µm (tol {} µm)",
            got * 1e3,
            want * 1e3,
            tol * 1e3
        );
        worst = worst.max((got - want).abs() / span);
    }
    eprintln!(
        "span {:.4} µm, worst |envelope − reference| = {:.3} % of span",
        span * 1e3,
        worst * 100.0
    );

    // The width dependence is what is tested: a worm dressed with the constant mid-width ΔK
    // would miss the reference by far more than the tolerance.
    let flat = rows
        .iter()
        .map(|&(w2, z2, want, _, _)| {
            let m = p.map_gear_point(&cpl, w2, z2);
            let f = s.dress_point(FL, m.w1_mm, &mid).unwrap().f_mm;
            (-f / cb2 - want).abs()
        })
        .fold(0.0, f64::max);
    assert!(
        flat > 10.0 * tol,
        "constant-ΔK worm misses by only {} µm",
        flat * 1e3
    );

    // Line to line: gear points on X2 = const map onto the worm line X1 = k·X2 + c0, and the
    // ground values along the gear line are the dressed values along that worm line.
    let (s2, c2) = rho2.sin_cos();
    let (s1, c1) = rho1.sin_cos();
    let x2 = 0.5 * (w2_range.0 + w2_range.1) * s2;
    for t in [-0.4, -0.2, 0.0, 0.2, 0.4] {
        let w2 = 0.5 * (w2_range.0 + w2_range.1) + t * (w2_range.1 - w2_range.0);
        let z2 = (x2 - w2 * s2) / c2;
        let (want, m) = reference(w2, z2);
        let x1 = m.w1_mm * s1 + m.z1_mm * c1;
        assert!((x1 - (lm.k * x2 + lm.c0_mm)).abs() < 1e-9, "{x1}");
        let got = g.grind_point(w2, z2).unwrap().f_ft_mm;
        assert!((got - want).abs() < tol, "line point {w2}: {got} vs {want}");
    }
}
