//! Conical (beveloid) bodies: chains (29)–(31), beveloid flanks, contact path (76)/(77)/(86).
//! References: the cylindrical chain (28) and contact path (docs/grinding.md "Independent
//! reference: reference example" numbers), the ISO
//! tooth-thickness formula of a spur gear with the local profile shift x(z) = x0 + z·tan ϑ/m_n,
//! the rack geometry written out here, and independent surface checks.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use approx::assert_relative_eq;
use gearcomp_grinding::conical::{BeveloidGear, ConeChain, ConicalPair};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::diagonal_ratio;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::{chain_cyl_cyl, FeedCoupling};
use nalgebra::{Point3, Vector3};

fn gear_body() -> InvoluteGear {
    InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap()
}
fn worm_body() -> InvoluteGear {
    InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap()
}
fn pair(cone1_deg: f64, cone2_deg: f64, flank: Flank) -> ConicalPair {
    let w = BeveloidGear::new(worm_body(), cone1_deg.to_radians()).unwrap();
    let g = BeveloidGear::new(gear_body(), cone2_deg.to_radians()).unwrap();
    ConicalPair::reference(&w, &g, flank).unwrap()
}
fn same_angle(a: f64, b: f64) -> bool {
    (a - b).sin().abs() < 1e-12 && (a - b).cos() > 0.0
}

/// ϑ1 = ϑ2 = 0 reproduces chain (28) exactly, for any axis distance (not only r1 + r2).
#[test]
fn chain_reduces_to_28() {
    for &d in &[178.140342, 150.0, 201.5] {
        let c = ConeChain {
            centre_distance_mm: d,
            crossing_rad: -1.82,
            r_w1_mm: 130.0,
            cone1_rad: 0.0,
            r_w2_mm: 48.14,
            cone2_rad: 0.0,
        };
        let (phi1, zv1, zv2, phi2) = (0.3, 2.0, -4.0, 0.7);
        let a = c.pose(phi1, zv1, zv2, phi2);
        let b = chain_cyl_cyl(phi1, zv1, d, -1.82, zv2, phi2);
        let d_iso = a.inverse() * b;
        assert!(d_iso.translation.vector.norm() < 1e-12);
        assert!(d_iso.rotation.angle() < 1e-14);
    }
}

/// Invariants of (29)–(31): rotations change neither the axis crossing angle nor the axis
/// distance; the crossing angle has the closed form cos Σ = R_x(ϑ1)e_z · R_y(γ)R_x(−ϑ2)e_z;
/// the worm feed runs along the worm's reference cone (the gear pivot stays on it, radius
/// r_w1 + z1·tan ϑ1) and the workpiece feed along the gear's (radius r_w2 + z2·tan ϑ2).
#[test]
fn chain_29_31_invariants() {
    let (t1, t2, g) = (7f64.to_radians(), -4f64.to_radians(), -1.82);
    for (c1, c2) in [(t1, 0.0), (0.0, t2), (t1, t2)] {
        let c = ConeChain {
            centre_distance_mm: 178.14,
            crossing_rad: g,
            r_w1_mm: 130.0,
            cone1_rad: c1,
            r_w2_mm: 48.14,
            cone2_rad: c2,
        };
        let ax = |p: &nalgebra::Isometry3<f64>| {
            // gear axis in worm coordinates: origin and direction
            (
                p.transform_point(&Point3::origin()).coords,
                p.rotation * Vector3::z(),
            )
        };
        let dist = |o: Vector3<f64>, d: Vector3<f64>| {
            let m = Vector3::z().cross(&d);
            o.dot(&m).abs() / m.norm()
        };
        let a1 = Vector3::new(0.0, -c1.sin(), c1.cos());
        let a2 = Vector3::new(g.sin() * c2.cos(), c2.sin(), g.cos() * c2.cos());
        let (o0, d0) = ax(&c.pose(0.0, 3.0, -2.0, 0.0));
        for &(phi1, phi2) in &[(0.4, -1.1), (2.0, 0.3)] {
            let (o, d) = ax(&c.pose(phi1, 3.0, -2.0, phi2));
            assert_relative_eq!(d.z, d0.z, epsilon = 1e-12);
            assert_relative_eq!(dist(o, d), dist(o0, d0), epsilon = 1e-9);
        }
        // angle between the axes: worm axis e_z in worm frame, gear axis d0
        assert_relative_eq!(d0.z, a1.dot(&a2), epsilon = 1e-12);
        for &zv1 in &[-20.0, 0.0, 15.0] {
            // gear pivot (0, −r_w2, 0) in worm coordinates lies on the worm reference cone
            let p = c
                .pose(0.0, zv1, 0.0, 0.0)
                .transform_point(&Point3::new(0.0, -48.14, 0.0));
            assert_relative_eq!(p.x.hypot(p.y), 130.0 + p.z * c1.tan(), epsilon = 1e-9);
        }
        for &zv2 in &[-12.0, 0.0, 9.0] {
            // worm pivot (0, r_w1, 0) in gear coordinates lies on the gear reference cone
            let p = c
                .pose(0.0, 0.0, zv2, 0.0)
                .inverse()
                .transform_point(&Point3::new(0.0, 130.0, 0.0));
            assert_relative_eq!(p.x.hypot(p.y), 48.14 + p.z * c2.tan(), epsilon = 1e-9);
        }
    }
}

/// ϑ = 0: the rack-generated flank is the ISO 21771 flank of `InvoluteGear` (helical, profile
/// shift, asymmetric, both hands).
#[test]
fn beveloid_at_zero_cone_is_the_cylinder() {
    let bodies = [
        gear_body(),
        InvoluteGear::asymmetric(
            23,
            2.5,
            25f64.to_radians(),
            18f64.to_radians(),
            -21f64.to_radians(),
            0.3,
        )
        .unwrap(),
        worm_body(),
    ];
    for b in bodies {
        let bev = BeveloidGear::cylindrical(b);
        for f in [Flank::Left, Flank::Right] {
            let (x, y) = (bev.flank(f), b.flank(f));
            assert_relative_eq!(x.r_b_mm, y.r_b_mm, epsilon = 1e-10);
            assert_relative_eq!(x.beta_b_rad, y.beta_b_rad, epsilon = 1e-12);
            assert_relative_eq!(x.w_ref_mm, y.w_ref_mm, epsilon = 1e-9);
            assert!(
                same_angle(x.eta_rad, y.eta_rad),
                "{} {}",
                x.eta_rad,
                y.eta_rad
            );
        }
    }
}

/// Spur beveloid: the transverse section at z is the spur gear of a rack with profile angle
/// tan α_t' = tan α_n·cos ϑ and the local profile shift x(z) = x0 + z·tan ϑ/m_n (ISO tooth
/// thickness s = m·(π/2 + 2x·tan α)): same base radius, same flank position at every z.
#[test]
fn spur_beveloid_local_profile_shift() {
    let (m, an, x0) = (3.0, 20f64.to_radians(), 0.2);
    for cone_deg in [3.0, -8.0, 20.0] {
        let t = f64::to_radians(cone_deg);
        let body = InvoluteGear::asymmetric(31, m, an, an, 0.0, x0).unwrap();
        let bev = BeveloidGear::new(body, t).unwrap();
        let at = (an.tan() * t.cos()).atan();
        for f in [Flank::Left, Flank::Right] {
            let fl = bev.flank(f);
            for &z in &[-12.0, 0.0, 7.5, 15.0] {
                let xz = x0 + z * t.tan() / m;
                assert_relative_eq!(bev.local_profile_shift(z), xz, epsilon = 1e-14);
                let spur = InvoluteGear::asymmetric(31, m, at, at, 0.0, xz)
                    .unwrap()
                    .flank(f);
                assert_relative_eq!(fl.r_b_mm, spur.r_b_mm, epsilon = 1e-10);
                let local_eta = fl.eta_rad + z * fl.beta_b_rad.tan() / fl.r_b_mm;
                assert!(same_angle(local_eta, spur.eta_rad), "ϑ={cone_deg} z={z}");
            }
        }
    }
}

/// Helical beveloid: the normal base pitch is that of the cylinder on both flanks, the flanks
/// get different base helix angles (different leads), and the transverse tooth thickness at
/// the reference circle grows with z like a radial rack shift z·tan ϑ does, by
/// tan ϑ·(tan α_tl' + tan α_tr') per mm, α_tF' the transverse angles of the tilted rack.
#[test]
fn helical_beveloid_thickness_grows_with_profile_shift() {
    let t = 6f64.to_radians();
    let b = InvoluteGear::asymmetric(
        31,
        3.0,
        22f64.to_radians(),
        18f64.to_radians(),
        15f64.to_radians(),
        0.0,
    )
    .unwrap();
    let bev = BeveloidGear::new(b, t).unwrap();
    let r = b.reference_radius_mm();
    let beta = b.beta_rad;
    let mut rate = 0.0;
    let mut expected = 0.0;
    for f in [Flank::Left, Flank::Right] {
        let fl = bev.flank(f);
        let an = b.alpha_n_rad(f);
        assert_relative_eq!(
            2.0 * std::f64::consts::PI * fl.r_b_mm * fl.beta_b_rad.cos() / 31.0,
            std::f64::consts::PI * 3.0 * an.cos(),
            epsilon = 1e-10
        );
        // polar angle change of the flank per mm of z at fixed radius, as arc at r, outward
        rate += -f.sign() * r * fl.beta_b_rad.tan() / fl.r_b_mm;
        // rack transverse angle: flank plane normal projected into the transverse plane,
        // written out from the tilted rack (tooth lines at β to the generatrix)
        let tan_at = (an.tan() * t.cos() + f.sign() * beta.sin() * t.sin()) / beta.cos();
        expected += t.tan() * tan_at;
    }
    assert!((bev.flank(Flank::Left).beta_b_rad - bev.flank(Flank::Right).beta_b_rad).abs() > 0.01);
    assert_relative_eq!(rate, expected, epsilon = 1e-12);
}

/// ϑ1 = ϑ2 = 0: the conical construction gives the cylindrical contact path, the numbers of
/// docs/grinding.md "Independent reference: reference example", the feed coefficients (−1, 0, 0,
/// −1), the same generating coupling and T7's K.
#[test]
fn conical_path_reduces_to_cylinder() {
    for flank in [Flank::Right, Flank::Left] {
        let c = pair(0.0, 0.0, flank);
        let w = WormGearPair::reference(&worm_body(), &gear_body(), flank).unwrap();
        let (p, q) = (c.path, w.path);
        assert_relative_eq!(p.c_w1, q.c_w1, epsilon = 1e-10);
        assert_relative_eq!(p.c_w2, q.c_w2, epsilon = 1e-10);
        assert_relative_eq!(p.c_c1_mm, q.c_c1_mm, epsilon = 1e-8);
        assert_relative_eq!(p.c_c2_mm, q.c_c2_mm, epsilon = 1e-9);
        assert_relative_eq!(p.a, q.a, epsilon = 1e-12);
        assert_relative_eq!(p.b_mm, q.b_mm, epsilon = 1e-9);
        for (v, e) in [
            (p.c_zv11, -1.0),
            (p.c_zv12, 0.0),
            (p.c_zv21, 0.0),
            (p.c_zv22, -1.0),
        ] {
            assert!((v - e).abs() < 1e-12, "{v} vs {e}");
        }
        assert!(p.b_zv1.abs() < 1e-12 && p.b_zv2.abs() < 1e-12);
        let s = flank.sign();
        assert_relative_eq!(p.c_w1, s * 2.745915, epsilon = 1e-6);
        assert_relative_eq!(p.c_w2, s * 0.250739, epsilon = 1e-6);
        assert_relative_eq!(p.c_c1_mm, s * -356.789715, epsilon = 1e-6);
        assert_relative_eq!(p.c_c2_mm, s * -4.256211, epsilon = 1e-6);
        for &(phi2, zv1, zv2) in &[(0.1, 3.0, -2.0), (-0.4, -7.0, 5.0)] {
            let (a, b) = (c.phi1_rad(phi2, zv1, zv2), w.phi1_rad(phi2, zv1, zv2));
            assert!(same_angle(a, b), "{a} {b}");
        }
        let (r1, r2) = (s * 20f64.to_radians(), s * 45f64.to_radians());
        assert_relative_eq!(c.diagonal_ratio(r1, r2).unwrap(), -0.877178, epsilon = 1e-6);
        assert_relative_eq!(
            c.diagonal_ratio(r1, r2).unwrap(),
            diagonal_ratio(&w, r1, r2).unwrap(),
            epsilon = 1e-12
        );
    }
}

/// The common normal is the flank normal of the common generating rack: the worm's and the
/// gear's rack normals, carried into the frame S by the chain, both equal n, and the contact
/// line passes through the pitch point C (origin of S) at zero feeds.
#[test]
fn common_rack_and_pitch_point() {
    for &(c1, c2) in &[(5.0, 0.0), (0.0, -6.0), (4.0, 3.0), (-9.0, 2.0)] {
        for flank in [Flank::Right, Flank::Left] {
            let p = pair(c1, c2, flank);
            let x = p.contact_point(0.0, 0.0, 0.0);
            assert!(x.norm() < 1e-9, "{c1} {c2} {flank:?}: {x}");
            // worm rack (at the body's +x side) turned to the mesh side (+y): R_z(90°);
            // gear rack turned to its mesh side (−y): R_z(−90°); then into S.
            let w = BeveloidGear::new(worm_body(), c1.to_radians()).unwrap();
            let g = BeveloidGear::new(gear_body(), c2.to_radians()).unwrap();
            let mw = w.rack_normal(flank);
            let mg = g.rack_normal(flank);
            let mw = Vector3::new(-mw.y, mw.x, mw.z);
            let mg = Vector3::new(mg.y, -mg.x, mg.z);
            let chain = p.chain;
            let to_s_worm = chain.pose(0.0, 0.0, 0.0, 0.0); // gear → worm
            let t1 = c1.to_radians();
            // worm frame → S: R_x(ϑ1) (translation irrelevant for directions)
            let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), t1);
            let n = p.normal_vec();
            let mw_s = rx * mw;
            let mg_s = rx * (to_s_worm.rotation * mg);
            // rack normals are the outward normals of the flanks they generate: +n on the worm,
            // −n on the workpiece
            assert!((mw_s - n).norm() < 1e-9, "{mw_s} {n}");
            assert!((mg_s + n).norm() < 1e-9, "{mg_s} {n}");
        }
    }
}

/// Independent surface check of the path coefficients: for a gear point and feeds, the
/// contact feed from (77), the worm point from (86) and (76), and the rotations from (R4)
/// put the real worm surface point exactly on the real gear surface point, with opposite
/// normals, in every combination of cones; the contact line points agree as well.
#[test]
fn path_coefficients_put_surfaces_in_contact() {
    for &(c1, c2) in &[
        (0.0, 0.0),
        (6.0, 0.0),
        (0.0, -5.0),
        (4.0, 7.0),
        (-10.0, -3.0),
    ] {
        for flank in [Flank::Right, Flank::Left] {
            let p = pair(c1, c2, flank);
            for &(k, z01) in &[(0.0, 2.0), (-0.877, 5.0), (1.3, -4.0)] {
                let cpl = FeedCoupling::linear(k, z01).unwrap();
                for &(w2, z2) in &[(12.0, -10.0), (17.0, 0.0), (22.0, 13.0)] {
                    let m = p.map_gear_point(&cpl, w2, z2).unwrap();
                    let pose = p.chain.pose(m.phi1_rad, m.z_v1_mm, m.z_v2_mm, m.phi2_rad);
                    let e2 = pose
                        .transform_point(&Point3::from(p.gear.point(w2, z2)))
                        .coords;
                    let n2 = pose.rotation * p.gear.normal(w2, z2);
                    let e1 = p.worm.point(m.w1_mm, m.z1_mm);
                    let n1 = p.worm.normal(m.w1_mm, m.z1_mm);
                    assert!(
                        (e1 - e2).norm() < 1e-9,
                        "{c1} {c2} {flank:?} {k}: {}",
                        (e1 - e2).norm()
                    );
                    assert!((n1 + n2).norm() < 1e-9);
                }
            }
            for &(lam, zv1, zv2) in &[(-3.249, 1.0, -2.0), (2.11, -6.0, 4.0)] {
                let x = p.contact_point(lam, zv1, zv2);
                let (w1, z1) = p.worm_wz(&x, zv1);
                let (w2, z2) = p.gear_wz(&x, zv2);
                let c = p.path;
                assert_relative_eq!(
                    z1,
                    c.c_w1 * w1 + c.c_zv11 * zv1 + c.c_zv21 * zv2 + c.c_c1_mm,
                    epsilon = 1e-9
                );
                assert_relative_eq!(
                    z2,
                    c.c_w2 * w2 + c.c_zv12 * zv1 + c.c_zv22 * zv2 + c.c_c2_mm,
                    epsilon = 1e-9
                );
                assert_relative_eq!(
                    w1,
                    c.a * w2 + c.b_zv1 * zv1 + c.b_zv2 * zv2 + c.b_mm,
                    epsilon = 1e-9
                );
            }
        }
    }
}

/// Structure of (50)/(51) and (63)/(64): a conical tool leaves C_FzV21 = 0, C_FzV22 = −1 and
/// the (R7) feed term of z_V2 at 0 (the workpiece feed is along its axis); a conical workpiece
/// leaves C_FzV11 = −1, C_FzV12 = 0, b_zv1 = 0; C_Fw_i = s·tan β_bFi of the conical flank (52)/(54).
#[test]
fn coefficient_structure_by_chain() {
    for flank in [Flank::Right, Flank::Left] {
        let s = flank.sign();
        let tool = pair(7.0, 0.0, flank).path;
        assert!(tool.c_zv21.abs() < 1e-12 && (tool.c_zv22 + 1.0).abs() < 1e-12);
        assert!(tool.b_zv2.abs() < 1e-12);
        assert!((tool.c_zv11 + 1.0).abs() > 1e-3 && tool.c_zv12.abs() > 1e-4);
        let wp = pair(0.0, 7.0, flank).path;
        assert!(wp.c_zv12.abs() < 1e-12 && (wp.c_zv11 + 1.0).abs() < 1e-12);
        assert!(wp.b_zv1.abs() < 1e-12);
        assert!((wp.c_zv22 + 1.0).abs() > 1e-4 && wp.c_zv21.abs() > 1e-4);
        let both = pair(7.0, -4.0, flank);
        let wb = BeveloidGear::new(worm_body(), 7f64.to_radians()).unwrap();
        assert_relative_eq!(
            both.path.c_w1,
            s * wb.flank(flank).beta_b_rad.tan(),
            epsilon = 1e-10
        );
        assert_relative_eq!(
            both.path.c_w2,
            s * both.gear.beta_b_rad.tan(),
            epsilon = 1e-10
        );
    }
}

/// JP6903407B2: a cylindrical worm on a conical workpiece needs different K on the two flanks
/// for the same (mirrored) direction even for a symmetric gear; on a cylindrical gear the two
/// are equal (JP6903407B2, text after eq. (49)).
#[test]
fn conical_workpiece_splits_the_diagonal_ratio() {
    let (r1, r2) = (20f64.to_radians(), 45f64.to_radians());
    let k = |c2: f64, f: Flank| {
        let s = f.sign();
        pair(0.0, c2, f).diagonal_ratio(s * r1, s * r2).unwrap()
    };
    assert_relative_eq!(k(0.0, Flank::Left), k(0.0, Flank::Right), epsilon = 1e-9);
    let (kl, kr) = (k(5.0, Flank::Left), k(5.0, Flank::Right));
    assert!((kl - kr).abs() > 1e-3, "{kl} {kr}");
}

#[test]
fn bad_cone_angles_are_rejected() {
    let e = BeveloidGear::new(gear_body(), 60f64.to_radians()).unwrap_err();
    assert!(e.to_string().contains("cone_angle_deg"), "{e}");
    assert!(BeveloidGear::new(gear_body(), f64::NAN).is_err());
}

mod props {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use gearcomp_grinding::conical_equalise::{equalise_worm_cone_angle, EqualiseSpec, WormLines};
    use proptest::prelude::*;

    proptest! {
        /// No panic on wide input: any cone angles, directions, feeds and couplings give a
        /// value or an error, never a panic; finite results where Ok.
        #[test]
        fn no_panic_on_wide_input(
            c1 in -1.0f64..1.0, c2 in -1.0f64..1.0, rho1 in -4.0f64..4.0, rho2 in -4.0f64..4.0,
            k in -1e3f64..1e3, w2 in -50.0f64..80.0, z2 in -1e3f64..1e3,
            lo in -1.0f64..1.0, hi in -1.0f64..1.0,
        ) {
            let w = BeveloidGear::new(worm_body(), c1);
            let g = BeveloidGear::new(gear_body(), c2);
            if let (Ok(w), Ok(g)) = (w, g) {
                for flank in [Flank::Left, Flank::Right] {
                    if let Ok(p) = ConicalPair::reference(&w, &g, flank) {
                        if let Ok(kk) = p.diagonal_ratio(rho1, rho2) {
                            prop_assert!(kk.is_finite());
                        }
                        if let Ok(cpl) = FeedCoupling::linear(k, 1.0) {
                            if let Ok(m) = p.map_gear_point(&cpl, w2, z2) {
                                prop_assert!(m.w1_mm.is_finite() || k.abs() > 1e2);
                            }
                        }
                    }
                }
            }
            let spec = EqualiseSpec {
                worm: worm_body(),
                gear: BeveloidGear::cylindrical(gear_body()),
                rho2_left_rad: -rho2,
                rho2_right_rad: rho2,
                worm_lines: WormLines::AxialSection,
                cone_range_rad: (lo, hi),
            };
            let _ = equalise_worm_cone_angle(&spec);
        }

        /// ϑ = 0 limit: a tiny cone angle changes the path coefficients continuously (no jump
        /// between the cylindrical and the conical construction).
        #[test]
        fn small_cone_is_continuous(t in 1e-9f64..1e-7, flank_right in proptest::bool::ANY) {
            let f = if flank_right { Flank::Right } else { Flank::Left };
            let a = pair(0.0, 0.0, f).path;
            let b = pair(t.to_degrees(), -t.to_degrees(), f).path;
            prop_assert!((a.c_w1 - b.c_w1).abs() < 1e-5 && (a.c_zv11 - b.c_zv11).abs() < 1e-5);
            prop_assert!((a.c_zv12 - b.c_zv12).abs() < 1e-5 && (a.a - b.a).abs() < 1e-6);
        }
    }
}

#[test]
fn bad_points_are_clear_errors() {
    let p = pair(3.0, 0.0, Flank::Right);
    let cpl = FeedCoupling::linear(-0.877, 5.0).unwrap();
    let e = p.map_gear_point(&cpl, f64::NAN, 0.0).unwrap_err();
    assert!(e.to_string().contains("w2_mm"), "{e}");
    let e = p.map_gear_point(&cpl, 17.0, f64::INFINITY).unwrap_err();
    assert!(e.to_string().contains("z2_mm"), "{e}");
}

/// `RollLimits::conical` gives the root form and tip circles at z = 0 as roll distances on the
/// beveloid flank the grid lies on (base radius r_bF of the pair's gear flank), not on the
/// cylinder's base circle. Mixing the two put the usable range [lo, hi] and the default end in
/// different parametrisations: `grind simulate --teeth 269 --module-mm 4.946
/// --helix-angle-deg=-25.63 --face-width-mm 80.3 --profile-shift=0.587 --flank left
/// --pressure-angle-left-deg 23.52 --gear-cone-deg=-3.94` was refused with "w_end_mm = 311.88
/// is out of range: expected w_end > w_start" (+3.94° was accepted). Checked: √(hi² + r_bF²)
/// is the tip radius r + m_n(1 + x) written here (DIN 867 addendum), and the default range is
/// not empty whenever the narrow end's tip r + m_n(1 + x) − (b/2)|tan ϑ2| lies above the
/// reference circle by m_n/4.
#[test]
fn conical_roll_limits_are_on_the_beveloid_flank() {
    use gearcomp_grinding::setup::{checked_gear, grinding_worm, RollLimits};
    use proptest::prelude::*;
    use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
    let strategy = (
        20u32..300,
        0.5..20.0f64,
        16.0..28.0f64,
        16.0..28.0f64,
        -40.0..40.0f64,
        -0.2..0.6f64,
        -5.0..5.0f64,
        3.0..20.0f64,
        any::<bool>(),
    );
    let checked = std::cell::Cell::new(0);
    for seed in [[7u8; 32], [41u8; 32]] {
        let mut runner = TestRunner::new_with_rng(
            Config {
                cases: 120,
                failure_persistence: None,
                ..Config::default()
            },
            TestRng::from_seed(RngAlgorithm::ChaCha, &seed),
        );
        runner
            .run(
                &strategy,
                |(z, m, ar, al, b_deg, x, cone_deg, b_m, left)| {
                    let (ar, al, beta) = (ar.to_radians(), al.to_radians(), b_deg.to_radians());
                    let Ok(gear) = checked_gear(z, m, ar, al, beta, x) else {
                        return Ok(()); // not a valid gear (pointed, undercut): not the subject
                    };
                    let worm = grinding_worm(1, m, ar, al, 30.0 * m, Hand::Right).unwrap();
                    let flank = if left { Flank::Left } else { Flank::Right };
                    let cone = cone_deg.to_radians();
                    let bev2 = BeveloidGear::new(gear, cone).unwrap();
                    let bev1 = BeveloidGear::new(worm, 0.0).unwrap();
                    let Ok(pair) = ConicalPair::reference(&bev1, &bev2, flank) else {
                        return Ok(());
                    };
                    let b = b_m * m;
                    let lim = RollLimits::conical(&gear, flank, &pair, b, cone).unwrap();
                    let r = f64::from(z) * m / (2.0 * beta.cos());
                    let rb = pair.gear.r_b_mm;
                    let r_a = r + m * (1.0 + x);
                    let r_hi = (lim.hi_mm * lim.hi_mm + rb * rb).sqrt();
                    prop_assert!((r_hi - r_a).abs() < 1e-9 * r_a, "tip {r_hi} vs {r_a}");
                    let r_tip_narrow = r_a - 0.5 * b * cone.tan().abs();
                    if r_tip_narrow > r + 0.25 * m {
                        let (w0, w1) = lim.default_range_mm(&pair.gear, m);
                        prop_assert!(w0 < w1, "default range {w0} … {w1}");
                        checked.set(checked.get() + 1);
                    }
                    // The largest face width whose narrow-end tip stays beyond the default
                    // start w0: the tip radius written here, and the default end of
                    // `conical` just inside and just outside it.
                    let (w0, _) = lim.default_range_mm(&pair.gear, m);
                    let t = cone.tan().abs();
                    let got = RollLimits::conical_max_face_width_mm(&gear, &pair, cone, w0);
                    let room = r_a - (w0 * w0 + rb * rb).sqrt();
                    match got {
                        Some(b_max) => {
                            let want = 2.0 * room / t;
                            prop_assert!((b_max - want).abs() <= 1e-9 * want, "{b_max} vs {want}");
                            for (f, beyond) in [(0.999, true), (1.001, false)] {
                                let l = RollLimits::conical(&gear, flank, &pair, f * b_max, cone)
                                    .unwrap();
                                prop_assert_eq!(l.default_hi_mm > w0, beyond, "b = {}", f * b_max);
                            }
                        }
                        None => prop_assert!(t == 0.0 || room <= 0.0, "{t} {room}"),
                    }
                    Ok(())
                },
            )
            .unwrap();
    }
    assert!(checked.get() > 100, "{} gears checked", checked.get());
}
