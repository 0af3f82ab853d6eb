//! Property tests: round trips between the forward and inverse relations, and no panic
//! (only clean errors) over wide random input including NaN and infinities.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_geometry::involute::{inv, inv_inverse};
use gearcomp_geometry::{
    centre_distance_for_shift_sum, shift_sum_for_centre_distance, BasicRack, Gear, GearPair,
    GearSpec, GeneratingWorm, Hand, Mesh, ShaperCutter, WormSpec,
};
use proptest::prelude::*;

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => -1e3..1e3f64,
        1 => -2.0..2.0f64,
        1 => Just(0.0),
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => proptest::num::f64::ANY,
    ]
}

fn any_mesh() -> impl Strategy<Value = Mesh> {
    prop_oneof![Just(Mesh::External), Just(Mesh::Internal)]
}

fn any_hand() -> impl Strategy<Value = Hand> {
    prop_oneof![Just(Hand::Right), Just(Hand::Left)]
}

prop_compose! {
    fn wild_spec()(m in any_f64(), a in any_f64(), b in any_f64(), z in 0u32..400,
                   mesh in any_mesh(), hand in any_hand(), x in any_f64(), w in any_f64(),
                   ha in any_f64(), hf in any_f64(), rho in any_f64(), has_w in any::<bool>())
                   -> GearSpec {
        GearSpec {
            normal_module_mm: m,
            normal_pressure_angle_rad: a,
            helix_angle_rad: b,
            hand,
            teeth: z,
            mesh,
            profile_shift: x,
            face_width_mm: has_w.then_some(w),
            rack: BasicRack { addendum_coeff: ha, dedendum_coeff: hf, root_radius_coeff: rho },
        }
    }
}

prop_compose! {
    /// Gears that mostly exist: practical ranges of every parameter.
    fn sane_spec()(m in 0.3..25.0f64, a_deg in 14.0..30.0f64, b_deg in 0.0..45.0f64,
                   z in 8u32..250, internal in any::<bool>(), hand in any_hand(),
                   x in -0.6..1.2f64) -> GearSpec {
        let mesh = if internal && z >= 30 { Mesh::Internal } else { Mesh::External };
        GearSpec {
            normal_module_mm: m,
            normal_pressure_angle_rad: a_deg.to_radians(),
            helix_angle_rad: b_deg.to_radians(),
            hand,
            teeth: z,
            mesh,
            profile_shift: x,
            face_width_mm: None,
            rack: BasicRack::DIN_867,
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn inverse_involute_round_trips(alpha in 1e-4..1.4f64) {
        let back = inv_inverse(inv(alpha));
        prop_assert!(((back - alpha) / alpha).abs() < 1e-12);
    }

    #[test]
    fn no_panic_on_wild_input(spec in wild_spec(), v in prop::collection::vec(any_f64(), 8),
                              k in any::<u32>(), z2 in 0u32..400, mesh2 in any_mesh()) {
        if let Ok(g) = Gear::new(spec) {
            let _ = g.transverse_thickness_at_mm(v[0], v[1]);
            let _ = g.normal_thickness_at_mm(v[0], v[1]);
            let _ = g.space_width_at_mm(v[0], v[1]);
            let _ = g.tip_normal_thickness_mm(v[1]);
            let _ = g.span(k, v[1]);
            let _ = g.normal_thickness_from_span(k, v[2]);
            let _ = g.recommended_span_k(v[1]);
            let _ = g.ball_dimension(v[3], v[1]);
            let _ = g.normal_thickness_from_ball_dimension(v[3], v[2]);
            let _ = g.recommended_ball_mm(v[1]);
            let _ = g.generating_shift(v[4]);
            let _ = g.root_form_diameter_mm(v[1]);
            let mut s2 = spec;
            s2.teeth = z2;
            s2.mesh = mesh2;
            s2.hand = spec.hand.opposite();
            if let Ok(g2) = Gear::new(s2) {
                let _ = shift_sum_for_centre_distance(g.spec(), g2.spec(), v[5]);
                let _ = centre_distance_for_shift_sum(g.spec(), g2.spec(), v[6]);
                if let Ok(p) = GearPair::new(&g, &g2, v[5]) {
                    let _ = p.backlash(v[6], v[7]);
                    let _ = p.generating_shift_sum_for_backlash(v[7]);
                }
                if let Ok(c) = ShaperCutter::new(spec) {
                    let _ = c.cutting(&g2, v[6]);
                }
            }
        }
        let worm = GeneratingWorm::new(WormSpec {
            starts: k % 100,
            normal_module_mm: v[0],
            normal_profile_angle_rad: v[1],
            reference_diameter_mm: v[2],
            hand: spec.hand,
        });
        if let (Ok(w), Ok(g)) = (worm, Gear::new(spec)) {
            let _ = w.check_generates(&g);
            let _ = w.setting_angle_rad(&g);
        }
    }

    #[test]
    fn thickness_and_shift_round_trip(spec in sane_spec()) {
        let Ok(g) = Gear::new(spec) else { return Ok(()); };
        let x = spec.profile_shift;
        let s_n = g.normal_thickness_at_reference_mm(x);
        prop_assert!((g.shift_from_normal_thickness(s_n) - x).abs() < 1e-12);
        // The general thickness-at-diameter route agrees at the reference circle.
        let s_d = g.normal_thickness_at_mm(g.dims().reference_diameter_mm, x).unwrap();
        prop_assert!((s_d - s_n).abs() < 1e-11 * spec.normal_module_mm);
        // r_b = r·cos α_t.
        let d = g.dims();
        prop_assert!((d.base_diameter_mm - d.reference_diameter_mm * d.transverse_pressure_angle_rad.cos()).abs() < 1e-12 * d.reference_diameter_mm);
    }

    #[test]
    fn span_and_thickness_round_trip(spec in sane_spec()) {
        let Ok(g) = Gear::new(spec) else { return Ok(()); };
        let x = spec.profile_shift;
        let Ok(k) = g.recommended_span_k(x) else { return Ok(()); };
        let w = g.span(k, x).unwrap();
        let s_n = g.normal_thickness_from_span(k, w.span_mm).unwrap();
        prop_assert!((s_n - g.normal_thickness_at_reference_mm(x)).abs() < 1e-11 * spec.normal_module_mm * f64::from(spec.teeth));
    }

    #[test]
    fn ball_and_thickness_round_trip(spec in sane_spec()) {
        let Ok(g) = Gear::new(spec) else { return Ok(()); };
        let x = spec.profile_shift;
        let Ok(ball) = g.recommended_ball_mm(x) else { return Ok(()); };
        let m = g.ball_dimension(ball, x).unwrap();
        let s_n = g.normal_thickness_from_ball_dimension(ball, m.dimension_mm).unwrap();
        prop_assert!((s_n - g.normal_thickness_at_reference_mm(x)).abs() < 1e-9 * spec.normal_module_mm,
            "{} vs {}", s_n, g.normal_thickness_at_reference_mm(x));
    }

    #[test]
    fn shift_sum_and_centre_distance_round_trip(spec in sane_spec(), z2 in 8u32..250, sum in -0.8..1.5f64) {
        let mut s1 = spec;
        s1.mesh = Mesh::External;
        let mut s2 = s1;
        s2.teeth = z2;
        s2.hand = s1.hand.opposite();
        let (Ok(g1), Ok(g2)) = (Gear::new(s1), Gear::new(s2)) else { return Ok(()); };
        let Ok(a) = centre_distance_for_shift_sum(g1.spec(), g2.spec(), sum) else { return Ok(()); };
        let back = shift_sum_for_centre_distance(g1.spec(), g2.spec(), a).unwrap();
        prop_assert!((back - sum).abs() < 1e-9, "{back} vs {sum}");
    }

    #[test]
    fn generating_shift_round_trip(spec in sane_spec(), a in -0.2..0.05f64) {
        let Ok(g) = Gear::new(spec) else { return Ok(()); };
        let allowance = a * spec.normal_module_mm;
        let Ok(x_e) = g.generating_shift(allowance) else { return Ok(()); };
        prop_assert!((g.allowance_from_shift(x_e) - allowance).abs() < 1e-12 * spec.normal_module_mm);
        let ds = g.normal_thickness_at_reference_mm(x_e) - g.normal_thickness_at_reference_mm(spec.profile_shift);
        prop_assert!((ds - allowance).abs() < 1e-12 * spec.normal_module_mm);
    }
}
