//! The second example grinding machine of JP6903407B2, FIG. 22, chain (35), and its inverse (33).
//!
//! # Reading of (35) (decided here)
//! Both language versions print H_Bsp2 = R_z(φ_B1)·R_x(90° − φ_A1)·T_z(−ν_Y1)·T_z(−ν_Z1)·
//! T_x(−ν_X1)·R_z(φ_C2). Read literally, T_z(−ν_Y1) and T_z(−ν_Z1) are two translations along
//! the same direction, so the machine would have only two independent translations; its
//! relative translation, seen in the swivelled frame, would then have no component along the
//! swivelled y axis and could not follow the worm shift z_V1 of chain (28) (the test
//! `literal_reading_cannot_shift_the_worm` shows a pose it cannot reach). With
//! T_y(−ν_Y1) (a tangential slide on the swivel head) the three translations span space and every
//! chain-(28) pose is reachable in closed form. We therefore read (35) as
//!
//! H_Bsp2 = R_z(φ_B1)·R_x(90° − φ_A1)·T_y(−ν_Y1)·T_z(−ν_Z1)·T_x(−ν_X1)·R_z(φ_C2)
//!
//! (the same probable typo is discussed in the section cited below). See `docs/grinding.md`,
//! "Machine chain (35)".

use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{GrindError, Result};

/// Axis values of the example machine with a tangential slide Y1 on the swivel head
/// (chain (35)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MachineAxes2 {
    /// Tool spindle rotation φ_B1 in rad.
    pub phi_b1_rad: f64,
    /// Tool swivel φ_A1 in rad.
    pub phi_a1_rad: f64,
    /// Tangential slide ν_Y1 in mm.
    pub nu_y1_mm: f64,
    /// Vertical slide ν_Z1 in mm.
    pub nu_z1_mm: f64,
    /// Radial slide ν_X1 in mm.
    pub nu_x1_mm: f64,
    /// Workpiece table rotation φ_C2 in rad.
    pub phi_c2_rad: f64,
}

fn rot(axis: &nalgebra::Unit<Vector3<f64>>, a: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(axis, a)
}

impl MachineAxes2 {
    /// Relative pose (workpiece → tool coordinates) produced by the machine.
    ///
    /// # Formula
    /// H_Bsp2 = R_z(φ_B1)·R_x(90° − φ_A1)·T_y(−ν_Y1)·T_z(−ν_Z1)·T_x(−ν_X1)·R_z(φ_C2)
    /// # Source
    /// JP6903407B2, eq. (35) [SEED], with T_z(−ν_Y1) read as T_y(−ν_Y1) (module doc)
    /// [RECONSTRUCTED].
    pub fn pose(&self) -> Isometry3<f64> {
        let theta = std::f64::consts::FRAC_PI_2 - self.phi_a1_rad;
        let r_b = rot(&Vector3::z_axis(), self.phi_b1_rad);
        let r_a = rot(&Vector3::x_axis(), theta);
        let r_c = rot(&Vector3::z_axis(), self.phi_c2_rad);
        let t = Vector3::new(-self.nu_x1_mm, -self.nu_y1_mm, -self.nu_z1_mm);
        Isometry3::from_parts(Translation3::identity(), r_b * r_a)
            * Isometry3::from_parts(Translation3::from(t), r_c)
    }

    /// Axis values that realise a relative pose, H_Bsp2 = K_R (eq. (33)).
    ///
    /// # Formula
    /// Rotation: z-x-z Euler sequence R_z(φ_B1)·R_x(θ)·R_z(φ_C2), θ = 90° − φ_A1:
    /// cos θ = R₂₂, φ_B1 = atan2(R₀₂, −R₁₂), φ_C2 = atan2(R₂₀, R₂₁) (branch sin θ > 0).
    /// Translation: (ν_X1, ν_Y1, ν_Z1) = −R_x(θ)ᵀ·R_z(−φ_B1)·t (unique: the three slides are
    /// orthogonal in the swivelled frame).
    /// # Domain
    /// Axes not parallel (sin θ > 1e-9); the other Euler branch (sin θ < 0) is the machine's
    /// redundant solution and is not returned.
    /// # Source
    /// JP6903407B2, eqs. (33), (35) [SEED]; inversion derived here [RECONSTRUCTED].
    pub fn from_pose(pose: &Isometry3<f64>) -> Result<Self> {
        let r: Rotation3<f64> = pose.rotation.to_rotation_matrix();
        let m = r.matrix();
        let cos_t = m[(2, 2)].clamp(-1.0, 1.0);
        let theta = cos_t.acos();
        if theta.sin() < 1e-9 {
            return Err(GrindError::Singular {
                what: "machine (35) axes from pose",
                field: "axis crossing (90° − φ_A1)",
                value: theta,
                expected: "tool and workpiece axes not parallel",
            });
        }
        let phi_b1 = m[(0, 2)].atan2(-m[(1, 2)]);
        let phi_c2 = m[(2, 0)].atan2(m[(2, 1)]);
        let back = rot(&Vector3::x_axis(), -theta) * rot(&Vector3::z_axis(), -phi_b1);
        let t = -(back * pose.translation.vector);
        Ok(Self {
            phi_b1_rad: phi_b1,
            phi_a1_rad: std::f64::consts::FRAC_PI_2 - theta,
            nu_y1_mm: t.y,
            nu_z1_mm: t.z,
            nu_x1_mm: t.x,
            phi_c2_rad: phi_c2,
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::kinematics::{chain_cyl_cyl, transform_point, MachineAxes};
    use proptest::prelude::*;

    /// (35) written out with explicit matrices, independent of nalgebra's quaternions.
    fn hand_pose(a: &MachineAxes2, p: Vector3<f64>) -> Vector3<f64> {
        let th = std::f64::consts::FRAC_PI_2 - a.phi_a1_rad;
        let (sc, cc) = a.phi_c2_rad.sin_cos();
        let q = Vector3::new(
            cc * p.x - sc * p.y - a.nu_x1_mm,
            sc * p.x + cc * p.y - a.nu_y1_mm,
            p.z - a.nu_z1_mm,
        );
        let (st, ct) = th.sin_cos();
        let q = Vector3::new(q.x, ct * q.y - st * q.z, st * q.y + ct * q.z);
        let (sb, cb) = a.phi_b1_rad.sin_cos();
        Vector3::new(cb * q.x - sb * q.y, sb * q.x + cb * q.y, q.z)
    }

    #[test]
    fn pose_35_matches_hand_composition() {
        let a = MachineAxes2 {
            phi_b1_rad: 0.4,
            phi_a1_rad: -0.3,
            nu_y1_mm: 12.0,
            nu_z1_mm: -7.0,
            nu_x1_mm: 178.0,
            phi_c2_rad: 1.1,
        };
        let p = Vector3::new(40.0, -12.0, 5.0);
        assert!((transform_point(&a.pose(), &p) - hand_pose(&a, p)).norm() < 1e-12);
    }

    /// The printed (35) with T_z(−ν_Y1): the relative translation in the swivelled frame has
    /// no y component, so a chain-(28) pose with a worm shift is out of reach.
    #[test]
    fn literal_reading_cannot_shift_the_worm() {
        // The literal (35): R_z(φ_B1)·R_x(θ)·T_z(−ν_Y1)·T_z(−ν_Z1)·T_x(−ν_X1)·R_z(φ_C2).
        let literal = |b1: f64, a1: f64, y1: f64, z1: f64, x1: f64, c2: f64| {
            let th = std::f64::consts::FRAC_PI_2 - a1;
            Isometry3::from_parts(
                Translation3::identity(),
                rot(&Vector3::z_axis(), b1) * rot(&Vector3::x_axis(), th),
            ) * Isometry3::from_parts(
                Translation3::new(-x1, 0.0, -(y1 + z1)),
                rot(&Vector3::z_axis(), c2),
            )
        };
        // Every literal pose needs no tangential slide in our reading: its reach is ν_Y1 = 0.
        for (y1, z1) in [(3.0, 4.0), (-20.0, 1.0), (0.0, 9.0)] {
            let a = MachineAxes2::from_pose(&literal(0.3, -0.2, y1, z1, 180.0, 0.9)).unwrap();
            assert!(a.nu_y1_mm.abs() < 1e-9 && (a.nu_z1_mm - (y1 + z1)).abs() < 1e-9);
        }
        // A worm shift z_V1 in chain (28) moves the tangential slide by z_V1·sin θ (closed
        // form: the tool axis e_z seen in the swivelled frame), so the literal machine cannot
        // follow diagonal generating.
        let k0 = chain_cyl_cyl(0.3, 0.0, 178.14, -1.82, -4.0, 0.7);
        let k7 = chain_cyl_cyl(0.3, 7.0, 178.14, -1.82, -4.0, 0.7);
        let (a0, a7) = (
            MachineAxes2::from_pose(&k0).unwrap(),
            MachineAxes2::from_pose(&k7).unwrap(),
        );
        let sin_t = (std::f64::consts::FRAC_PI_2 - a7.phi_a1_rad).sin();
        assert!(((a7.nu_y1_mm - a0.nu_y1_mm) - 7.0 * sin_t).abs() < 1e-9);
        assert!((a7.nu_y1_mm - a0.nu_y1_mm).abs() > 1.0);
    }

    proptest! {
        /// T13 for (35): axes → pose → axes round trip.
        #[test]
        fn machine_chain_35_round_trip(
            b1 in -3.0f64..3.0, a1 in -1.4f64..1.4, y1 in -50.0f64..50.0,
            z1 in -80.0f64..80.0, x1 in 50.0f64..300.0, c2 in -3.0f64..3.0,
        ) {
            let axes = MachineAxes2 { phi_b1_rad: b1, phi_a1_rad: a1, nu_y1_mm: y1,
                                      nu_z1_mm: z1, nu_x1_mm: x1, phi_c2_rad: c2 };
            let back = MachineAxes2::from_pose(&axes.pose()).unwrap();
            let d = back.pose().inverse() * axes.pose();
            prop_assert!(d.translation.vector.norm() < 1e-9);
            prop_assert!(d.rotation.angle() < 1e-12);
            prop_assert!((back.nu_x1_mm - x1).abs() < 1e-9 && (back.nu_y1_mm - y1).abs() < 1e-9
                && (back.nu_z1_mm - z1).abs() < 1e-9);
            prop_assert!((back.phi_a1_rad - a1).abs() < 1e-12);
        }

        /// T13 for (35): every chain-(28) pose is realised by machine (35) with the identical
        /// relative pose (so every workpiece point lands on the same tool point), and machines
        /// (34) and (35) realise the same pose.
        #[test]
        fn chain_28_is_realised_by_machine_35(
            phi1 in -3.0f64..3.0, zv1 in -30.0f64..30.0, g in -2.0f64..-1.2,
            zv2 in -20.0f64..20.0, phi2 in -3.0f64..3.0,
            px in -60.0f64..60.0, py in -60.0f64..60.0, pz in -20.0f64..20.0,
        ) {
            let k = chain_cyl_cyl(phi1, zv1, 178.14, g, zv2, phi2);
            let a2 = MachineAxes2::from_pose(&k).unwrap();
            let p = Vector3::new(px, py, pz);
            let want = transform_point(&k, &p);
            prop_assert!((hand_pose(&a2, p) - want).norm() < 1e-9);
            let a1 = MachineAxes::from_pose(&k).unwrap();
            prop_assert!((transform_point(&a1.pose(), &p) - want).norm() < 1e-9);
            // both machines share B1, A1, C2 (same Euler decomposition of the rotation)
            prop_assert!((a1.phi_a1_rad - a2.phi_a1_rad).abs() < 1e-12);
        }
    }

    #[test]
    fn parallel_axes_are_singular() {
        let k = chain_cyl_cyl(0.3, 0.0, 100.0, 0.0, 0.0, 0.2);
        assert!(MachineAxes2::from_pose(&k).is_err());
    }
}
