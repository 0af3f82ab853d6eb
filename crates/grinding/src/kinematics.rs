//! Worm–workpiece kinematics: the kinematic chain (28), the feed coupling (36)/(94) and the
//! machine chain (34) with its inverse.
//!
//! Convention (fixed here, docs/grinding.md "Derivation: flank and chain conventions"
//! [RECONSTRUCTED]): K_R maps workpiece
//! coordinates p2 to tool (worm) coordinates p1 = K_R·p2. In the space frame the worm axis is
//! z, the common perpendicular of the axes is y, the workpiece axis passes through (0, d, 0)
//! with direction R_y(γ)·e_z.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{check_range, GrindError, Result};

fn rx(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(a, 0.0, 0.0),
    )
}
fn ry(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(0.0, a, 0.0),
    )
}
fn rz(a: f64) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::identity(),
        UnitQuaternion::from_euler_angles(0.0, 0.0, a),
    )
}
fn tx(v: f64) -> Isometry3<f64> {
    Isometry3::translation(v, 0.0, 0.0)
}
fn ty(v: f64) -> Isometry3<f64> {
    Isometry3::translation(0.0, v, 0.0)
}
fn tz(v: f64) -> Isometry3<f64> {
    Isometry3::translation(0.0, 0.0, v)
}

/// Relative pose of a cylindrical worm and a cylindrical workpiece.
///
/// # Formula
/// K_R = R_z(−φ1)·T_z(−z_V1)·T_y(d)·R_y(γ)·T_z(z_V2)·R_z(φ2)
/// # Units
/// rad, mm.
/// # Source
/// JP6903407B2, eq. (28) [SEED] (docs/grinding.md "Derivation: flank and chain conventions").
pub fn chain_cyl_cyl(
    phi1_rad: f64,
    z_v1_mm: f64,
    centre_distance_mm: f64,
    crossing_rad: f64,
    z_v2_mm: f64,
    phi2_rad: f64,
) -> Isometry3<f64> {
    rz(-phi1_rad)
        * tz(-z_v1_mm)
        * ty(centre_distance_mm)
        * ry(crossing_rad)
        * tz(z_v2_mm)
        * rz(phi2_rad)
}

/// Coupling of the worm shift z_V1 to the workpiece feed z_V2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum FeedCoupling {
    /// Constant diagonal ratio: z_V1 = K_ZV1·z_V2 + z_V01 (eq. (36)); K = 0 is axial grinding.
    Linear {
        /// Diagonal ratio K_ZV1.
        k_zv1: f64,
        /// Shift offset z_V01 in mm (selects the used worm region).
        z_v01_mm: f64,
    },
    /// Non-constant diagonal ratio z_V1 = F_ZV1(z_V2) (eq. (94)) given as polynomial
    /// coefficients c0 + c1·z_V2 + c2·z_V2² + … (mm, mm/mm, 1/mm, …).
    Polynomial {
        /// Coefficients, lowest power first.
        coeffs: Vec<f64>,
    },
}

/// Largest |K_ZV1| and |z_V01| (mm) of a [`FeedCoupling::linear`].
pub const MAX_LINEAR_COEFF: f64 = 1e6;

impl FeedCoupling {
    /// A validated constant diagonal ratio.
    pub fn linear(k_zv1: f64, z_v01_mm: f64) -> Result<Self> {
        check_range(
            "k_zv1",
            k_zv1,
            -MAX_LINEAR_COEFF,
            MAX_LINEAR_COEFF,
            "finite, |K| ≤ 1e6",
        )?;
        check_range(
            "z_v01_mm",
            z_v01_mm,
            -MAX_LINEAR_COEFF,
            MAX_LINEAR_COEFF,
            "finite, |z_V01| ≤ 1e6 mm",
        )?;
        Ok(FeedCoupling::Linear { k_zv1, z_v01_mm })
    }

    /// Worm shift for a workpiece feed.
    ///
    /// # Formula
    /// z_V1 = K_ZV1·z_V2 + z_V01 (36), or z_V1 = F_ZV1(z_V2) (94).
    /// # Source
    /// JP6903407B2, eqs. (36), (94) [SEED].
    #[inline]
    pub fn z_v1_mm(&self, z_v2_mm: f64) -> f64 {
        match self {
            FeedCoupling::Linear { k_zv1, z_v01_mm } => k_zv1 * z_v2_mm + z_v01_mm,
            FeedCoupling::Polynomial { coeffs } => {
                coeffs.iter().rev().fold(0.0, |acc, c| acc * z_v2_mm + c)
            }
        }
    }

    /// dz_V1/dz_V2 at a feed.
    #[inline]
    pub fn slope(&self, z_v2_mm: f64) -> f64 {
        match self {
            FeedCoupling::Linear { k_zv1, .. } => *k_zv1,
            FeedCoupling::Polynomial { coeffs } => coeffs
                .iter()
                .enumerate()
                .skip(1)
                .rev()
                .fold(0.0, |acc, (i, c)| acc * z_v2_mm + c * i as f64),
        }
    }
}

/// Axis values of the example grinding machine of JP6903407B2, FIG. 22 (chain (34)).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MachineAxes {
    /// Tool spindle rotation φ_B1 in rad.
    pub phi_b1_rad: f64,
    /// Tool shift ν_V1 in mm.
    pub nu_v1_mm: f64,
    /// Tool swivel φ_A1 in rad.
    pub phi_a1_rad: f64,
    /// Vertical slide ν_Z1 in mm.
    pub nu_z1_mm: f64,
    /// Radial slide ν_X1 in mm.
    pub nu_x1_mm: f64,
    /// Workpiece table rotation φ_C2 in rad.
    pub phi_c2_rad: f64,
}

impl MachineAxes {
    /// Relative pose produced by the machine.
    ///
    /// # Formula
    /// H_Bsp1 = R_z(φ_B1)·T_z(−ν_V1)·R_x(90° − φ_A1)·T_z(−ν_Z1)·T_x(−ν_X1)·R_z(φ_C2)
    /// # Source
    /// JP6903407B2, eq. (34) [SEED].
    pub fn pose(&self) -> Isometry3<f64> {
        rz(self.phi_b1_rad)
            * tz(-self.nu_v1_mm)
            * rx(std::f64::consts::FRAC_PI_2 - self.phi_a1_rad)
            * tz(-self.nu_z1_mm)
            * tx(-self.nu_x1_mm)
            * rz(self.phi_c2_rad)
    }

    /// Axis values that realise a relative pose, H_Bsp1 = K_R (eq. (33)).
    ///
    /// # Formula
    /// The rotation is a z-x-z Euler sequence R_z(φ_B1)·R_x(θ)·R_z(φ_C2), θ = 90° − φ_A1:
    /// cos θ = R₂₂, φ_B1 = atan2(R₀₂, −R₁₂), φ_C2 = atan2(R₂₀, R₂₁) (branch sin θ > 0).
    /// With t' = R_z(−φ_B1)·t: ν_X1 = −t'_x, ν_Z1 = t'_y/sin θ, ν_V1 = −t'_z − ν_Z1·cos θ.
    /// # Domain
    /// Axes not parallel (sin θ > 1e-9). The other branch (sin θ < 0) is the machine's
    /// redundant solution and is not returned.
    /// # Source
    /// JP6903407B2, eqs. (33), (34) [SEED]; inversion derived here [RECONSTRUCTED].
    pub fn from_pose(pose: &Isometry3<f64>) -> Result<Self> {
        let r = pose.rotation.to_rotation_matrix();
        let m = r.matrix();
        let cos_t = m[(2, 2)].clamp(-1.0, 1.0);
        let theta = cos_t.acos();
        let sin_t = theta.sin();
        if sin_t < 1e-9 {
            return Err(GrindError::Singular {
                what: "machine axes from pose",
                field: "axis crossing (90° − φ_A1)",
                value: theta,
                expected: "tool and workpiece axes not parallel",
            });
        }
        let phi_b1 = m[(0, 2)].atan2(-m[(1, 2)]);
        let phi_c2 = m[(2, 0)].atan2(m[(2, 1)]);
        let t = pose.translation.vector;
        let tp = rz(-phi_b1).rotation * t;
        let nu_z1 = tp.y / sin_t;
        Ok(Self {
            phi_b1_rad: phi_b1,
            nu_v1_mm: -tp.z - nu_z1 * cos_t,
            phi_a1_rad: std::f64::consts::FRAC_PI_2 - theta,
            nu_z1_mm: nu_z1,
            nu_x1_mm: -tp.x,
            phi_c2_rad: phi_c2,
        })
    }
}

/// Maps a workpiece point through a pose (helper for tests and reports).
pub fn transform_point(pose: &Isometry3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
    pose.transform_point(&(*p).into()).coords
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    /// (28) written out by hand with explicit matrices: an independent check of the
    /// composition order and of the rotation senses.
    #[test]
    fn chain_28_matches_hand_composition() {
        let (phi1, zv1, d, g, zv2, phi2) = (0.3, 2.0, 178.1, -1.82, -4.0, 0.7);
        let k = chain_cyl_cyl(phi1, zv1, d, g, zv2, phi2);
        let p = Vector3::new(40.0, -12.0, 5.0);
        // R_z(φ2)
        let a = Vector3::new(
            p.x * phi2.cos() - p.y * phi2.sin(),
            p.x * phi2.sin() + p.y * phi2.cos(),
            p.z + zv2,
        );
        let b = Vector3::new(
            a.x * g.cos() + a.z * g.sin(),
            a.y + d,
            -a.x * g.sin() + a.z * g.cos(),
        );
        let c = Vector3::new(b.x, b.y, b.z - zv1);
        let e = Vector3::new(
            c.x * phi1.cos() + c.y * phi1.sin(),
            -c.x * phi1.sin() + c.y * phi1.cos(),
            c.z,
        );
        assert!((transform_point(&k, &p) - e).norm() < 1e-12);
    }

    #[test]
    fn feed_coupling_values() {
        let l = FeedCoupling::linear(-0.877178, 5.0).unwrap();
        assert!((l.z_v1_mm(2.0) - (5.0 - 1.754356)).abs() < 1e-12);
        let p = FeedCoupling::Polynomial {
            coeffs: vec![0.0, 0.5, 0.01],
        };
        assert!((p.z_v1_mm(10.0) - 6.0).abs() < 1e-12);
        assert!((p.slope(10.0) - 0.7).abs() < 1e-12);
        assert!(FeedCoupling::linear(f64::NAN, 0.0).is_err());
    }

    proptest! {
        /// T13: machine axes → pose → axes round trip, and any chain-(28) pose is reachable
        /// by the machine (33) with the identical relative pose.
        #[test]
        fn machine_chain_34_round_trip(
            b1 in -3.0f64..3.0, v1 in -50.0f64..50.0, a1 in -1.4f64..1.4,
            z1 in -80.0f64..80.0, x1 in 50.0f64..300.0, c2 in -3.0f64..3.0,
        ) {
            let axes = MachineAxes { phi_b1_rad: b1, nu_v1_mm: v1, phi_a1_rad: a1,
                                     nu_z1_mm: z1, nu_x1_mm: x1, phi_c2_rad: c2 };
            let back = MachineAxes::from_pose(&axes.pose()).unwrap();
            let d = back.pose().inverse() * axes.pose();
            prop_assert!(d.translation.vector.norm() < 1e-9);
            prop_assert!(d.rotation.angle() < 1e-12);
            prop_assert!((back.nu_x1_mm - x1).abs() < 1e-9 && (back.nu_v1_mm - v1).abs() < 1e-9);
        }

        #[test]
        fn chain_28_is_realised_by_machine(
            phi1 in -3.0f64..3.0, zv1 in -30.0f64..30.0, g in -2.0f64..-1.2,
            zv2 in -20.0f64..20.0, phi2 in -3.0f64..3.0,
        ) {
            let k = chain_cyl_cyl(phi1, zv1, 178.14, g, zv2, phi2);
            let axes = MachineAxes::from_pose(&k).unwrap();
            let d = axes.pose().inverse() * k;
            prop_assert!(d.translation.vector.norm() < 1e-9);
            prop_assert!(d.rotation.angle() < 1e-12);
        }
    }
}
