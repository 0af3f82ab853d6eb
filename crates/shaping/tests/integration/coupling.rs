//! Coupling law (Procedia CIRP 56 (2016) eq. (1)) against the test vector of docs/shaping.md
//! "Derivation: the control cycle and the position form" and FANUC's published helical
//! compensation, plus exact-ratio behaviour.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_abs_diff_eq;
use gearcomp_shaping::coupling::{GearCut, Hand, Mesh};
use gearcomp_shaping::crank::SliderCrank;
use gearcomp_shaping::ratio::Ratio;
use gearcomp_shaping::units::rpm_to_rad_s;
use proptest::prelude::*;

fn seed_cut() -> GearCut {
    GearCut::new(
        40,
        25,
        3.0,
        15f64.to_radians(),
        0.0,
        Hand::Right,
        Mesh::External,
    )
    .unwrap()
}

#[test]
fn seed002_eq1_vectors() {
    // docs/shaping.md test vector: Z_C1 = 40, Z_C2 = 25, m_n = 3, β = 15°, n_C1 = 2 rpm, crank case A at 300 rpm.
    let cut = seed_cut();
    let crank = SliderCrank::new(25.0, 200.0).unwrap();
    let w = rpm_to_rad_s(300.0);
    assert_abs_diff_eq!(cut.cutter_lead_mm(), 910.36364, epsilon = 5e-6);
    for (deg, expected) in [
        (0.0, -3.20000),
        (180.0, -3.20000),
        (30.0, 19.87462),
        (90.0, 48.56381),
        (150.0, 25.48919),
        (270.0, -54.96381),
    ] {
        let v_z_mm_min = 60.0 * crank.velocity_mm_s(f64::to_radians(deg), w);
        // Half a unit in the 5th decimal docs/shaping.md prints.
        assert_abs_diff_eq!(cut.n_c2_rpm(2.0, v_z_mm_min), expected, epsilon = 5e-6);
    }
    // v_Z at 30° in mm/min from docs/shaping.md.
    assert_abs_diff_eq!(
        60.0 * crank.velocity_mm_s(30f64.to_radians(), w),
        21006.293,
        epsilon = 5e-4
    );
}

#[test]
fn seed002_extra_rotation_over_a_stroke() {
    // docs/shaping.md: 19.772319° of extra C2 rotation over the full 50 mm stroke.
    let d = seed_cut().c2_delta_rad(0.0, 50.0).to_degrees();
    assert_abs_diff_eq!(d, 19.772319, epsilon = 5e-7);
}

#[test]
fn fanuc_helical_compensation_cross_check() {
    // FANUC EGB manual: 10 mm of Z, helix 20°, 40 teeth, module 2 → 4.8991° (C = Z·sinP/(π·T·Q)·360).
    let cut = GearCut::new(
        41,
        40,
        2.0,
        20f64.to_radians(),
        0.0,
        Hand::Right,
        Mesh::External,
    )
    .unwrap();
    assert_abs_diff_eq!(
        cut.c2_delta_rad(0.0, 10.0).to_degrees(),
        4.8991,
        epsilon = 5e-5
    );
}

#[test]
fn signs_for_mesh_and_hand() {
    let b = 15f64.to_radians();
    let ext_r = GearCut::new(40, 25, 3.0, b, 0.0, Hand::Right, Mesh::External).unwrap();
    let ext_l = GearCut::new(40, 25, 3.0, b, 0.0, Hand::Left, Mesh::External).unwrap();
    let int_r = GearCut::new(40, 25, 3.0, b, 0.0, Hand::Right, Mesh::Internal).unwrap();
    assert_eq!(ext_r.generating_ratio(), Ratio::new(-8, 5).unwrap());
    assert_eq!(int_r.generating_ratio(), Ratio::new(8, 5).unwrap());
    assert!(ext_r.helical_gain_rad_per_mm() > 0.0);
    assert_abs_diff_eq!(
        ext_l.helical_gain_rad_per_mm(),
        -ext_r.helical_gain_rad_per_mm()
    );
    // Internal: the cutter has the workpiece's hand, so the helical sign flips.
    assert_abs_diff_eq!(
        int_r.helical_gain_rad_per_mm(),
        -ext_r.helical_gain_rad_per_mm()
    );
    // Internal gears need more teeth than the cutter.
    let e = GearCut::new(20, 25, 3.0, b, 0.0, Hand::Right, Mesh::Internal)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("internal") && e.contains("20") && e.contains("26"),
        "{e}"
    );
}

#[test]
fn helix_angle_correction_changes_the_lead() {
    let b = 15f64.to_radians();
    let db = 0.05f64.to_radians();
    let cut = GearCut::new(40, 25, 3.0, b, db, Hand::Right, Mesh::External).unwrap();
    let expected = std::f64::consts::PI * 3.0 * 40.0 / (b + db).sin();
    assert_abs_diff_eq!(cut.workpiece_lead_mm(), expected, epsilon = 1e-9);
    let e = GearCut::new(
        40,
        25,
        3.0,
        b,
        3f64.to_radians(),
        Hand::Right,
        Mesh::External,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("correction D") && e.contains("-2") && e.contains("2 deg"),
        "{e}"
    );
}

#[test]
fn ratio_reduces_and_applies_exactly() {
    let r = Ratio::new(-41 * 3_600_000, 27 * 3_600_000).unwrap();
    assert_eq!((r.numer(), r.denom()), (-41, 27));
    let p = r.apply(28).unwrap();
    // −41·28/27 = −1148/27 = −43 + 13/27 (floor with non-negative remainder).
    assert_eq!((p.whole, p.rem, p.den), (-43, 13, 27));
    assert!(Ratio::new(1, 0).is_err());
}

proptest! {
    #[test]
    fn spur_coupling_is_exactly_the_tooth_ratio(z1 in 2u32..1000, z2 in 1u32..1000, c1 in -1e3f64..1e3) {
        // v_Z = 0 or β = 0: n_C2 = −(Z_C1/Z_C2)·n_C1 (house style §2.7 identity).
        let cut = GearCut::new(z1, z2, 2.0, 0.0, 0.0, Hand::Right, Mesh::External).unwrap();
        let expected = -f64::from(z1) / f64::from(z2) * c1;
        prop_assert!((cut.n_c2_rpm(c1, 1234.5) - expected).abs() <= 1e-12 * expected.abs().max(1.0));
    }

    #[test]
    fn one_lead_of_z_is_one_cutter_revolution(z2 in 1u32..300, mn in 0.5f64..20.0, beta_deg in 1.0f64..45.0) {
        let cut = GearCut::new(z2 + 1, z2, mn, beta_deg.to_radians(), 0.0, Hand::Right, Mesh::External).unwrap();
        let turn = cut.c2_delta_rad(0.0, cut.cutter_lead_mm());
        prop_assert!((turn - std::f64::consts::TAU).abs() < 1e-9);
    }

    #[test]
    fn gear_cut_new_never_panics(z1 in any::<u32>(), z2 in any::<u32>(), mn in proptest::num::f64::ANY,
                                 b in proptest::num::f64::ANY, db in proptest::num::f64::ANY) {
        let _ = GearCut::new(z1, z2, mn, b, db, Hand::Left, Mesh::Internal);
    }
}
