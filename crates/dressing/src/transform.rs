//! Homogeneous 4×4 transforms: the elementary rotations and translations of the kinematic chains.
//!
//! Convention (docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED], confirmed by test A2): right-handed, active
//! rotations, products evaluated left to right, and a chain maps coordinates of the right-hand
//! body (dresser) into the frame of the left-hand body (worm): p_S = K_R · p_A.

use nalgebra::{Matrix3, Matrix4, Vector3};

/// A homogeneous rigid transform.
pub type Mat4 = Matrix4<f64>;

/// R_x(φ): rotation by `phi_rad` about the x-axis.
///
/// # Formula
/// [[1,0,0,0],[0,c,−s,0],[0,s,c,0],[0,0,0,1]], c = cos φ, s = sin φ
/// # Source
/// JP6903407B2, symbol definitions before eq. (1) [SEED]; matrix form docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn rx(phi_rad: f64) -> Mat4 {
    let (s, c) = phi_rad.sin_cos();
    Matrix4::new(
        1.0, 0.0, 0.0, 0.0, 0.0, c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}

/// R_y(φ): rotation by `phi_rad` about the y-axis.
///
/// # Formula
/// [[c,0,s,0],[0,1,0,0],[−s,0,c,0],[0,0,0,1]]
/// # Source
/// JP6903407B2, symbol definitions before eq. (1) [SEED]; matrix form docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn ry(phi_rad: f64) -> Mat4 {
    let (s, c) = phi_rad.sin_cos();
    Matrix4::new(
        c, 0.0, s, 0.0, 0.0, 1.0, 0.0, 0.0, -s, 0.0, c, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}

/// R_z(φ): rotation by `phi_rad` about the z-axis.
///
/// # Formula
/// [[c,−s,0,0],[s,c,0,0],[0,0,1,0],[0,0,0,1]]
/// # Source
/// JP6903407B2, symbol definitions before eq. (1) [SEED]; matrix form docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn rz(phi_rad: f64) -> Mat4 {
    let (s, c) = phi_rad.sin_cos();
    Matrix4::new(
        c, -s, 0.0, 0.0, s, c, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    )
}

/// T_x(ν): translation by `nu_mm` along x.
pub fn tx(nu_mm: f64) -> Mat4 {
    Matrix4::new_translation(&Vector3::new(nu_mm, 0.0, 0.0))
}

/// T_y(ν): translation by `nu_mm` along y.
pub fn ty(nu_mm: f64) -> Mat4 {
    Matrix4::new_translation(&Vector3::new(0.0, nu_mm, 0.0))
}

/// T_z(ν): translation by `nu_mm` along z.
pub fn tz(nu_mm: f64) -> Mat4 {
    Matrix4::new_translation(&Vector3::new(0.0, 0.0, nu_mm))
}

/// The rotation block of a rigid transform.
pub fn rotation(m: &Mat4) -> Matrix3<f64> {
    m.fixed_view::<3, 3>(0, 0).into_owned()
}

/// The translation column of a rigid transform.
pub fn translation(m: &Mat4) -> Vector3<f64> {
    Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)])
}

/// Inverse of a rigid transform.
///
/// # Formula
/// [R t; 0 1]⁻¹ = [Rᵀ −Rᵀt; 0 1]
pub fn rigid_inverse(m: &Mat4) -> Mat4 {
    let r = rotation(m);
    let rt = r.transpose();
    let t = -(rt * translation(m));
    let mut out = Mat4::identity();
    out.fixed_view_mut::<3, 3>(0, 0).copy_from(&rt);
    out[(0, 3)] = t.x;
    out[(1, 3)] = t.y;
    out[(2, 3)] = t.z;
    out
}

/// Applies a transform to a point.
pub fn apply_point(m: &Mat4, p: &Vector3<f64>) -> Vector3<f64> {
    rotation(m) * p + translation(m)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// Test A1: the elementary rotations turn the unit axes as the right-hand rule says.
    #[test]
    fn a1_elementary_rotations() {
        let e = |m: Mat4, v: [f64; 3]| apply_point(&m, &Vector3::new(v[0], v[1], v[2]));
        let a = e(rz(FRAC_PI_2), [1.0, 0.0, 0.0]);
        let b = e(rx(FRAC_PI_2), [0.0, 1.0, 0.0]);
        let c = e(ry(FRAC_PI_2), [0.0, 0.0, 1.0]);
        // cos(π/2) is 6e-17 in floating point, hence 1e-15.
        assert!((a - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
        assert!((b - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-15);
        assert!((c - Vector3::new(1.0, 0.0, 0.0)).norm() < 1e-15);
    }
}
