//! Tests F1, F2, F4: a worm's life with the dresser designed for the new worm (claims 1–2).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use gearcomp_dressing::campaign::{plan, Correction, PlanSpec};
use gearcomp_dressing::worm::Flank;

fn spec(corr: Correction, ds: &[f64], budget: f64) -> PlanSpec {
    PlanSpec {
        flank: Flank::Right,
        diameters_mm: ds.to_vec(),
        correction: corr,
        crowning_mm: 0.0,
        budget_mm: budget,
    }
}

/// F1/F2 on G1: uncorrected, the profile error grows monotonically as the worm shrinks; with the
/// 3-point correction it stays < 0.1 µm, the corrections grow with |d_S − d_S0|, and the profile
/// stretching P_FS grows in magnitude.
#[test]
fn f1_f2_g1_life() {
    let s = common::g1();
    let ds = [280.0, 265.0, 250.0, 235.0, 220.0];
    let none = plan(&s.worm, &s.dresser, &spec(Correction::None, &ds, 0.1)).unwrap();
    assert!(none[0].deviation_max_um < 1e-6);
    for w in none.windows(2) {
        assert!(w[1].deviation_max_um > w[0].deviation_max_um);
        assert!(w[1].deviation_range_um > w[0].deviation_range_um);
    }
    assert!(
        none[4].deviation_max_um > 0.3,
        "{}",
        none[4].deviation_max_um
    );
    let corr = plan(&s.worm, &s.dresser, &spec(Correction::ThreePoint, &ds, 0.1)).unwrap();
    for (i, r) in corr.iter().enumerate() {
        assert!(
            r.deviation_max_um < 0.1,
            "d {}: {}",
            r.d_s_mm,
            r.deviation_max_um
        );
        if i > 0 {
            let (a, b) = (corr[i - 1].dk, r.dk);
            assert!(b.dnu_ya_mm.abs() > a.dnu_ya_mm.abs() && b.dd_mm.abs() > a.dd_mm.abs());
            assert!(r.stretch.abs() > corr[i - 1].stretch.abs());
        }
        // The uncorrected centre distance follows the root circle: d_0 = r_fS + d_A/2.
        assert!((r.d0_mm - (r.d_s_mm / 2.0 - 3.75 + 62.5)).abs() < 1e-9);
        // Machine (5) axes realise the corrected pose.
        assert!((r.axes.x1_mm - (r.d0_mm + r.dk.dd_mm)).abs() < 1e-9);
        assert!((r.axes.z1_mm - r.dk.dnu_ya_mm).abs() < 1e-9);
    }
}

/// F4: the penetration and undercut checks run at every step; a small worm (G1-Z5 life) with a
/// tight budget A = 0.01 mm is flagged once the correction grows.
#[test]
fn f4_penetration_and_undercut_flags() {
    let s = common::g1_z5();
    let rows = plan(
        &s.worm,
        &s.dresser,
        &spec(Correction::ThreePoint, &[160.0, 150.0, 130.0], 0.01),
    )
    .unwrap();
    assert!(!rows[0].penetration && !rows[0].undercut);
    assert!(rows[2].penetration && rows[2].undercut);
    assert!(rows[2].opposite_cut_mm > rows[1].opposite_cut_mm);
    // The correction still holds the profile.
    assert!(rows.iter().all(|r| r.deviation_max_um < 0.1));
}
