//! Tests A2–A6: chain (1), machines (4)/(5), their inverse (docs/dressing.md "Reference case G1 and its worms").
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_dressing::kinematics::*;
use gearcomp_dressing::transform::{rigid_inverse, rotation, translation, Mat4};
use nalgebra::Vector3;
use proptest::prelude::*;

fn pose(a: [f64; 6]) -> DressPose {
    DressPose {
        phi_s_rad: a[0],
        nu_zs_mm: a[1],
        gamma_rad: a[2],
        d_mm: a[3],
        nu_ya_mm: a[4],
        phi_a_rad: a[5],
    }
}

/// A2: the pose matrix, docs/dressing.md "Reference case G1 and its worms" (6 decimals, computed independently with numpy).
#[test]
fn a2_pose_matrix_seed004_eq1() {
    let k = k_r(&pose([0.3, 12.0, 0.61390f64.to_radians(), 200.0, 5.0, 1.1]));
    let expect = [
        [0.696692, -0.717364, 0.003166, -189.589782],
        [0.717307, 0.696682, 0.010236, 63.880450],
        [-0.009549, -0.004860, 0.999943, -12.053572],
        [0.0, 0.0, 0.0, 1.0],
    ];
    for (i, row) in expect.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            // The reference is printed to 6 decimals.
            assert!(
                (k[(i, j)] - v).abs() < 5.1e-7,
                "({i},{j}) {} vs {v}",
                k[(i, j)]
            );
        }
    }
}

fn any_pose() -> impl Strategy<Value = [f64; 6]> {
    (
        -7.0..7.0f64,
        -100.0..100.0f64,
        -1.4..1.4f64,
        1.0..400.0f64,
        -50.0..50.0f64,
        -7.0..7.0f64,
    )
        .prop_map(|(a, b, c, d, e, f)| [a, b, c, d, e, f])
}

fn close(a: &Mat4, b: &Mat4, tol: f64) -> bool {
    (a - b).abs().max() < tol
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// A3: axis distance = |d| and crossing angle = |γ| for any pose.
    #[test]
    fn a3_axis_distance_and_crossing_angle_invariants(p in any_pose()) {
        let (dist, ang) = axis_distance_and_angle(&k_r(&pose(p)));
        prop_assert!((dist - p[3].abs()).abs() < 1e-9);
        prop_assert!((ang - p[2].abs()).abs() < 1e-9);
    }

    /// A4: K_R · K_R⁻¹ = I.
    #[test]
    fn a4_inverse(p in any_pose()) {
        let k = k_r(&pose(p));
        prop_assert!(close(&(k * rigid_inverse(&k)), &Mat4::identity(), 1e-12));
    }

    /// A5: machine (5) is chain (1) with renamed axes; machine (4) with C5 = 0 is machine (5);
    /// and the inverse of (5) returns the axes that built the pose.
    #[test]
    fn a5_machine_chains_and_inverse(p in any_pose()) {
        let ax = AxesBsp2 { b1_rad: p[0], v1_mm: p[1], a1_rad: p[2], x1_mm: p[3], z1_mm: p[4], b3_rad: p[5] };
        let h2 = h_bsp2(&ax);
        prop_assert!(close(&h2, &k_r(&pose(p)), 1e-12));
        let h1 = h_bsp1(&AxesBsp1 { b1_rad: p[0], v1_mm: p[1], a1_rad: p[2], x1_mm: p[3], z1_mm: p[4], c5_rad: 0.0, b3_rad: p[5] });
        prop_assert!(close(&h1, &h2, 1e-12));
        let back = solve_bsp2(&h2, &ax).unwrap();
        prop_assert!((back.b1_rad - p[0]).abs() < 1e-9 && (back.a1_rad - p[2]).abs() < 1e-9);
        prop_assert!((back.x1_mm - p[3]).abs() < 1e-9 && (back.v1_mm - p[1]).abs() < 1e-8);
        prop_assert!((back.z1_mm - p[4]).abs() < 1e-8 && (back.b3_rad - p[5]).abs() < 1e-9);
    }
}

/// A6: machine (4) realises a pose for several C5 (one-parameter family), reproducing the dresser
/// axis line and reference point, and the choice of least travel picks C5 near the reference.
#[test]
fn a6_bsp1_family() {
    // G1-Z5 crossing angle: C5 can only swivel within |C5| ≤ γ.
    let k = k_r(&pose([0.2, 3.0, 5.37938f64.to_radians(), 126.25, 0.4, 0.0]));
    let reference = AxesBsp1 {
        b1_rad: 0.2,
        v1_mm: 3.0,
        a1_rad: 0.09,
        x1_mm: 126.25,
        z1_mm: 0.0,
        c5_rad: 0.0,
        b3_rad: 0.0,
    };
    let a_k = rotation(&k) * Vector3::z();
    let c_k = translation(&k);
    let mut sols = Vec::new();
    for c5_deg in [-2.0f64, 0.0, 3.0] {
        let s = solve_bsp1(&k, c5_deg.to_radians(), &reference).unwrap();
        let h = h_bsp1(&s);
        assert!(close(&h, &k, 1e-9), "C5 = {c5_deg}: {h} vs {k}");
        let a_h = rotation(&h) * Vector3::z();
        assert!((a_h - a_k).norm() < 1e-9);
        assert!((translation(&h) - c_k).norm() < 1e-9);
        sols.push(s);
    }
    // One-dimensional family: the other axes change with C5.
    assert!((sols[0].a1_rad - sols[2].a1_rad).abs() > 1e-5);
    assert!((sols[0].b1_rad - sols[2].b1_rad).abs() > 1e-3, "{sols:?}");
    // Least travel from the axes of the C5 = 0 solution picks that solution (zero travel), and
    // from the C5 = 3° solution picks 3°: no needless swivel.
    let best = pick_bsp1(&k, &sols[1], 5f64.to_radians()).unwrap();
    assert!(best.c5_rad.abs() < 1e-6, "picked C5 = {}", best.c5_rad);
    let best3 = pick_bsp1(&k, &sols[2], 5f64.to_radians()).unwrap();
    assert!((best3.c5_rad - 3f64.to_radians()).abs() < 1e-6);
    assert!(close(&h_bsp1(&best), &k, 1e-9));
}
