//! Tests B1–B4 (DIN 3960 and the involute helicoid) and the dresser design (docs/dressing.md "Reference case G1-Z5", docs/dressing.md "Derivation: dresser envelope and tip fillet").
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use gearcomp_dressing::gear::*;
use gearcomp_dressing::worm::{Flank, Worm};
use nalgebra::{Rotation3, Vector3};

const DEG: f64 = std::f64::consts::PI / 180.0;

/// B1: gear G1 (m_n 3, α_n 20°, z 40, β 15°), docs/dressing.md "Reference case G1 and its worms" (hand calculation with ISO 21771).
#[test]
fn b1_gear_g1_din3960() {
    let g = helical_params(3.0, 20.0 * DEG, 40.0, 15.0 * DEG).unwrap();
    assert!((g.r_mm - 62.11657).abs() < 1e-5);
    assert!((g.alpha_t_rad / DEG - 20.64690).abs() < 1e-5);
    assert!((g.r_b_mm - 58.12690).abs() < 1e-5);
    assert!((g.beta_b_rad / DEG - 14.07610).abs() < 1e-5);
    assert!((g.m_b_mm * g.beta_b_rad.cos() - 2.819078).abs() < 1e-6);
    // Normal base pitch identity m_b cos β_b = m_n cos α_n (closed form).
    assert!((g.m_b_mm * g.beta_b_rad.cos() - 3.0 * (20.0 * DEG).cos()).abs() < 1e-12);
}

/// B2: the worm table of docs/dressing.md "Reference case G1 and its worms" and the meshing condition (20).
#[test]
fn b2_worm_table_and_meshing() {
    let gear = helical_params(3.0, 20.0 * DEG, 40.0, 15.0 * DEG).unwrap();
    // z_S, d_S, lead angle °, α_t °, r_b, β_b °, p_z
    let rows = [
        (1, 280.0, 0.61390, 88.31386, 4.11943, 69.99097, 9.42532),
        (1, 200.0, 0.85947, 87.64005, 4.11772, 69.98230, 9.42584),
        (2, 280.0, 1.22786, 86.63063, 8.22818, 69.96389, 18.85389),
        (2, 200.0, 1.71913, 85.28809, 8.21458, 69.92927, 18.85804),
        (3, 280.0, 1.84197, 84.95320, 12.31572, 69.91882, 28.28895),
        (3, 200.0, 2.57918, 82.95192, 12.27022, 69.84114, 28.30301),
    ];
    for (z, d, lead, at, rb, bb, pz) in rows {
        let w = worm_params(z, d, 3.0, 20.0 * DEG).unwrap();
        let worm = Worm::design(z, d, 3.0, 20.0 * DEG).unwrap();
        assert!(
            (worm.lead_angle_at(d / 2.0) / DEG - lead).abs() < 1e-5,
            "z {z} d {d}"
        );
        assert!((w.alpha_t_rad / DEG - at).abs() < 1e-5);
        assert!((w.r_b_mm - rb).abs() < 1e-5);
        assert!((w.beta_b_rad / DEG - bb).abs() < 1e-5);
        assert!((w.lead_mm - pz).abs() < 1e-5);
        assert!(meshes(&gear, &w, 1e-9));
    }
    let w22 = worm_params(1, 280.0, 3.0, 22.0 * DEG).unwrap();
    assert!((w22.m_b_mm * w22.beta_b_rad.cos() - 2.781552).abs() < 1e-6);
    assert!(!meshes(&gear, &w22, 1e-6));
    let m = normal_module_for_profile_angle(3.0, 20.0 * DEG, 22.0 * DEG);
    assert!((m - 3.040473).abs() < 1e-6);
    assert!((normal_module_for_profile_angle(3.0, 20.0 * DEG, 18.0 * DEG) - 2.964154).abs() < 1e-6);
    assert!(meshes(
        &gear,
        &worm_params(1, 280.0, m, 22.0 * DEG).unwrap(),
        1e-9
    ));
}

/// B3: roll distance ↔ radius, normal orthogonal to the flank tangents, |n_z| = sin β_b.
#[test]
fn b3_involute_helicoid() {
    let worm = Worm::design(1, 280.0, 3.0, 20.0 * DEG).unwrap();
    assert!((worm.roll_from_radius(140.0) - 139.93938).abs() < 1e-5);
    assert!((worm.roll_from_radius(136.25) - 136.18771).abs() < 1e-5);
    assert!((worm.roll_from_radius(143.0) - 142.94065).abs() < 1e-5);
    assert!(((58.12690f64.powi(2) + 400.0).sqrt() - 61.47143).abs() < 1e-5);
    for flank in [Flank::Left, Flank::Right] {
        for &(w, b) in &[(137.0, 0.0), (140.0, 3.5), (142.5, -7.0)] {
            let h = 1e-6;
            let n = worm.normal(flank, w, b);
            let dw = (worm.point(flank, w + h, b) - worm.point(flank, w - h, b)) / (2.0 * h);
            let db = (worm.point(flank, w, b + h) - worm.point(flank, w, b - h)) / (2.0 * h);
            // Central differences of 1e-6 mm leave ~1e-10 of truncation/rounding.
            assert!(n.dot(&dw).abs() < 1e-8 && n.dot(&db).abs() < 1e-8);
            assert!((n.z.abs() - 0.939639).abs() < 1e-6);
            assert!((worm.point(flank, w, b).xy().norm() - worm.radius_from_roll(w)).abs() < 1e-10);
        }
    }
}

/// Signed distance along n from P to the surface E rotated by `dphi` about z (closest point by
/// Gauss–Newton on the rotated surface, independent of the crate's envelope code).
fn rotated_offset(worm: &Worm, flank: Flank, w0: f64, b0: f64, dphi: f64) -> f64 {
    let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), dphi);
    let p = worm.point(flank, w0, b0);
    let (mut w, mut b) = (w0, b0);
    for _ in 0..50 {
        let q = rot * worm.point(flank, w, b);
        let h = 1e-6;
        let tw = rot * (worm.point(flank, w + h, b) - worm.point(flank, w - h, b)) / (2.0 * h);
        let tb = rot * (worm.point(flank, w, b + h) - worm.point(flank, w, b - h)) / (2.0 * h);
        let r = q - p;
        let a = nalgebra::Matrix2::new(tw.dot(&tw), tw.dot(&tb), tb.dot(&tw), tb.dot(&tb));
        let g = nalgebra::Vector2::new(tw.dot(&r), tb.dot(&r));
        let step = a.lu().solve(&g).unwrap();
        w -= step.x;
        b -= step.y;
        if step.norm() < 1e-14 {
            break;
        }
    }
    (rot * worm.point(flank, w, b) - p).dot(&worm.normal(flank, w0, b0))
}

/// B4: turning the worm by Δφ is a uniform normal offset r_b cos β_b Δφ (1.409538 µm per
/// 1e-3 rad for the G1 worm), opposite on the two flanks.
#[test]
fn b4_rotation_is_uniform_normal_offset() {
    let worm = Worm::design(1, 280.0, 3.0, 20.0 * DEG).unwrap();
    let expect = worm.r_b_mm * worm.beta_b_rad.cos() * 1e-3;
    assert!((expect - 1.409538e-3).abs() < 1e-9);
    for &(w, b) in &[(136.5, 0.0), (139.0, 2.0), (142.9, -5.0), (138.0, 20.0)] {
        let r = rotated_offset(&worm, Flank::Right, w, b, 1e-3);
        let l = rotated_offset(&worm, Flank::Left, w, b, 1e-3);
        assert!((r.abs() - expect).abs() / expect < 1e-6, "right {r}");
        assert!((l.abs() - expect).abs() / expect < 1e-6, "left {l}");
        assert!(r * l < 0.0);
    }
}

/// Dresser design for G1 and G1-Z5 against docs/dressing.md "Reference case G1-Z5" and docs/dressing.md "Derivation: dresser envelope and tip fillet": fillet radius, w_Nf, r_Nf, the
/// root gap in the dresser plane, the tip association, and left/right symmetry.
#[test]
fn dresser_design_reference_cases() {
    let g1 = common::g1();
    for side in &g1.dresser.sides {
        assert!(
            (side.fillet_radius_mm - 0.8445).abs() < 6e-5,
            "{}",
            side.fillet_radius_mm
        );
        assert!((side.w_nf_mm - 136.74363).abs() < 1e-5);
        assert!((g1.worm.radius_from_roll(side.w_nf_mm) - 136.8057).abs() < 1e-4);
    }
    // Axial gap of the worm at the root circle, docs/dressing.md "Derivation: dresser envelope and tip fillet": 1.9826 mm.
    let wr = g1.worm.roll_from_radius(g1.worm.r_f_mm);
    let gap = (g1.worm.b_axial_section(Flank::Right, wr)
        - g1.worm.b_axial_section(Flank::Left, wr))
    .abs();
    assert!((gap - 1.9826).abs() < 2e-4, "G1 gap {gap}");

    let z5 = common::g1_z5();
    assert!((z5.worm.r_b_mm - 19.95476).abs() < 1e-5);
    assert!((z5.worm.beta_b_rad / DEG - 69.31783).abs() < 1e-5);
    assert!((z5.worm.p_mm * 2.0 * std::f64::consts::PI - 47.33235).abs() < 1e-5);
    assert!((z5.nominal.gamma_rad / DEG - 5.37938).abs() < 1e-5);
    assert!((z5.nominal.d_mm - 126.25).abs() < 1e-12);
    let (w_nf, w_na) = z5.active_profile(Flank::Right).unwrap();
    assert!((w_nf - 74.17113).abs() < 1e-5 && (w_na - 80.56555).abs() < 1e-5);
    for side in &z5.dresser.sides {
        assert!((side.fillet_radius_mm - 0.8455).abs() < 6e-5);
        // Root gap 1.9848 mm: width of the dresser flanks at the jacket radius d_A/2.
        let (mut lo, mut hi) = (0.5, 1.5);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if side.radius.eval(mid).0 > 50.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        assert!((2.0 * lo - 1.9848).abs() < 1e-4, "gap {}", 2.0 * lo);
    }
    let r_tip = z5
        .association(Flank::Right, w_na, &Default::default())
        .unwrap();
    assert!((r_tip - 43.25164).abs() < 1e-5, "{r_tip}");
    // Symmetric worm ⇒ mirror-symmetric dresser (independent envelopes of the two flanks).
    let (l, r) = (&z5.dresser.sides[0], &z5.dresser.sides[1]);
    assert!(l.z_sign * r.z_sign < 0.0);
    for u in [1.3, 2.0, 3.0, 3.4] {
        assert!((l.radius.eval(u).0 - r.radius.eval(u).0).abs() < 1e-9);
    }
}

/// Bad input is an error naming the field, never a panic.
#[test]
fn invalid_input_is_an_error() {
    let e = Worm::design(0, 280.0, 3.0, 20.0 * DEG).unwrap_err();
    assert!(e.to_string().contains("z_s"));
    assert!(helical_params(f64::NAN, 0.3, 40.0, 0.2).is_err());
    let worm = Worm::design(1, 280.0, 3.0, 20.0 * DEG).unwrap();
    let spec = gearcomp_dressing::dresser::DresserSpec {
        d_a_mm: 125.0,
        jacket_width_mm: 2.5,
        clearance_mm: 0.0,
    };
    assert!(gearcomp_dressing::dresser::Dresser::design(&worm, spec).is_err());
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

    /// No panic on wide input: worm, dresser and one dressing evaluation either work or return
    /// an error.
    #[test]
    fn no_panic_on_wide_input(
        z in 0u32..9, d in 20.0..400.0f64, m in 0.3..8.0f64, alpha in 0.05..0.7f64,
        da in 10.0..400.0f64, jacket in -0.2..3.0f64, clearance in -0.05..0.3f64,
        w in -10.0..600.0f64, dk in proptest::array::uniform4(-5.0..5.0f64),
    ) {
        if let Ok(worm) = Worm::design(z, d, m, alpha) {
            let spec = gearcomp_dressing::dresser::DresserSpec {
                d_a_mm: da, jacket_width_mm: jacket, clearance_mm: clearance,
            };
            let designed = gearcomp_dressing::dresser::Dresser::design(&worm, spec);
            if let Ok(dr) = designed {
                let s = gearcomp_dressing::envelope::DressingSetup::new(worm, dr);
                let k = gearcomp_dressing::kinematics::AxisCorrection::from_array(dk);
                let _ = s.dress_point(Flank::Right, w, &k);
                let _ = s.active_profile(Flank::Left);
                let _ = s.jacket_depth(&k);
            }
        }
    }
}

/// The shared `Flank` (docs/dressing.md "Gear vocabulary"): on this crate's right-hand worm the
/// `Right` flank is the +z face of the thread, whose outward normal points towards +z and
/// clockwise seen from +z (the end-face right flank of the grinding crate); `Left` the other
/// way. Checked on the code's normal against the hand derivation: n·ẑ and n·e_θ, e_θ the
/// counter-clockwise tangent at the point.
#[test]
fn shared_flank_worm_frame_is_the_end_face_convention() {
    let worm = Worm::design(5, 160.0, 3.0, 20.0 * DEG).unwrap();
    for (flank, s) in [(Flank::Right, 1.0), (Flank::Left, -1.0)] {
        for r in [worm.r_f_mm + 0.5, worm.d_s_mm / 2.0, worm.r_a_mm - 0.1] {
            let w = (r * r - worm.r_b_mm * worm.r_b_mm).sqrt();
            for b in [-7.0, 0.0, 3.5] {
                let p = worm.point(flank, w, b);
                let n = worm.normal(flank, w, b);
                let e_theta = Vector3::new(-p.y, p.x, 0.0).normalize();
                assert!(s * n.z > 0.0, "{flank:?} r {r} b {b}: n = {n:?}");
                assert!(
                    s * n.dot(&e_theta) < 0.0,
                    "{flank:?} r {r} b {b}: n = {n:?}"
                );
            }
        }
    }
}
