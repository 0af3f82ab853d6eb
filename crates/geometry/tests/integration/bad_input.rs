//! Bad input gives a clear error naming the parameter, its value and the allowed range.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_geometry::{Gear, GearPair, GearSpec, GeometryError, Hand};

fn spur(m: f64, a_deg: f64, z: u32) -> GearSpec {
    GearSpec::spur(m, a_deg.to_radians(), z)
}

fn msg(spec: GearSpec) -> String {
    Gear::new(spec).unwrap_err().to_string()
}

#[test]
fn module_pressure_and_helix_angle_ranges() {
    let e = msg(spur(0.0, 20.0, 20));
    assert!(
        e.contains("normal_module_mm = 0") && e.contains("0.01 … 1000 mm"),
        "{e}"
    );
    let e = msg(spur(-3.0, 20.0, 20));
    assert!(e.contains("normal_module_mm = -3"), "{e}");
    let e = msg(spur(1.0, 45.0, 20));
    assert!(
        e.contains("normal_pressure_angle = 45") && e.contains("0 … 45 °"),
        "{e}"
    );
    let e = msg(spur(1.0, 0.0, 20));
    assert!(e.contains("normal_pressure_angle = 0"), "{e}");
    let mut s = spur(1.0, 20.0, 20);
    s.helix_angle_rad = 60f64.to_radians();
    let e = msg(s);
    assert!(
        e.contains("helix_angle = 60") && e.contains("0 … 60 °"),
        "{e}"
    );
    s.helix_angle_rad = f64::NAN;
    assert!(msg(s).contains("helix_angle = NaN"));
}

#[test]
fn too_few_teeth_undercut_and_pointed() {
    let e = msg(spur(1.0, 20.0, 2));
    assert!(e.contains("teeth = 2") && e.contains("3 … 10000"), "{e}");
    // z = 10 at x = 0 is undercut: x_min = h_FfP* − z·sin²20°/2 = 1.0855 − 0.5849 = 0.5006,
    // z_min = 2·1.0855/sin²20° = 18.56 (DIN 867 rack, ρ_fP* = 0.25). Computed, with the
    // undercut described by `undercut()` (issue 13: a designer still needs the numbers).
    let g = Gear::new(spur(1.0, 20.0, 10)).unwrap();
    match g.undercut("profile_shift", 0.0).unwrap() {
        GeometryError::Undercut {
            value,
            min,
            teeth,
            min_teeth,
            ..
        } => {
            assert_eq!(value, 0.0);
            assert!((min - 0.5006).abs() < 1e-4, "{min}");
            assert_eq!(teeth, 10);
            assert!((min_teeth - 18.56).abs() < 0.01, "{min_teeth}");
        }
        e => panic!("{e}"),
    }
    let mut s = spur(1.0, 20.0, 10);
    s.profile_shift = 1.2;
    let e = msg(s);
    assert!(
        e.contains("pointed tooth") && e.contains("profile_shift = 1.2"),
        "{e}"
    );
}

#[test]
fn measurement_limits() {
    let g = Gear::new(spur(1.0, 20.0, 20)).unwrap();
    for k in [0, 20, 21] {
        let e = g.span(k, 0.0).unwrap_err().to_string();
        assert!(
            e.contains(&format!("span_k = {k}")) && e.contains("1 … 19"),
            "{e}"
        );
    }
    // k = 6 of 20 teeth: the anvils would touch above the tip.
    let e = g.span(6, 0.0).unwrap_err().to_string();
    assert!(
        e.contains("span_k = 6") && e.contains("does not touch"),
        "{e}"
    );
    // A 0.5 mm ball sinks to the root; a 4 mm ball sits above the tip.
    for b in [0.5, 4.0] {
        let e = g.ball_dimension(b, 0.0).unwrap_err().to_string();
        assert!(
            e.contains(&format!("ball_mm = {b}")) && e.contains("does not touch"),
            "{e}"
        );
    }
    let e = g.ball_dimension(-1.0, 0.0).unwrap_err().to_string();
    assert!(e.contains("ball_mm = -1"), "{e}");
    let e = g
        .transverse_thickness_at_mm(10.0, 0.0)
        .unwrap_err()
        .to_string();
    assert!(e.contains("diameter_mm = 10") && e.contains("18.79"), "{e}");
    let e = g.generating_shift(0.9).unwrap_err().to_string();
    assert!(e.contains("thickness_allowance_mm = 0.9"), "{e}");
}

#[test]
fn helical_span_must_fit_the_face_width() {
    let mut s = spur(3.5, 20.0, 31);
    s.helix_angle_rad = 21f64.to_radians();
    s.face_width_mm = Some(5.0);
    let g = Gear::new(s).unwrap();
    let e = g.span(4, 0.0).unwrap_err().to_string();
    assert!(e.contains("face width"), "{e}");
}

#[test]
fn pair_mismatches() {
    let mut s1 = spur(3.5, 20.0, 31);
    s1.helix_angle_rad = 21f64.to_radians();
    let g1 = Gear::new(s1).unwrap();
    let mut s2 = s1;
    s2.teeth = 30; // same hand: wrong for an external pair
    let g2 = Gear::new(s2).unwrap();
    let e = GearPair::new(&g1, &g2, 116.5).unwrap_err().to_string();
    assert!(e.contains("signed helix angle") && e.contains("-21"), "{e}");
    s2.hand = Hand::Left;
    let g2 = Gear::new(s2).unwrap();
    let e = GearPair::new(&g1, &g2, 100.0).unwrap_err().to_string();
    assert!(e.contains("centre_distance_mm = 100"), "{e}");
    s2.normal_module_mm = 3.0;
    let g3 = Gear::new(s2).unwrap();
    let e = GearPair::new(&g1, &g3, 116.5).unwrap_err().to_string();
    assert!(e.contains("normal_module_mm differs (3.5 vs 3)"), "{e}");
}
