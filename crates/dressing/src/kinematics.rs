//! The worm–dresser kinematic chain (JP6903407B2 eq. (1)), the example machines (eqs. (4), (5))
//! and the inverse from a relative pose to machine axis values.

use crate::error::{DressError, Result};
use crate::transform::{rigid_inverse, rotation, rx, ry, rz, translation, tx, ty, tz, Mat4};
use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The five relevant relative degrees of freedom of worm and dresser plus the dresser rotation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DressPose {
    /// φ_S, worm rotation angle (rad).
    pub phi_s_rad: f64,
    /// ν_zS, worm axial position (mm).
    pub nu_zs_mm: f64,
    /// γ, axis crossing angle worm–dresser (rad).
    pub gamma_rad: f64,
    /// d, centre distance worm–dresser (mm).
    pub d_mm: f64,
    /// ν_yA, dresser position along y (mm).
    pub nu_ya_mm: f64,
    /// φ_A, dresser rotation (rad); irrelevant for a dresser of revolution.
    pub phi_a_rad: f64,
}

/// ΔK = (Δφ_S, Δγ, Δd, Δν_yA): the axis corrections on top of the uncorrected dressing motion.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct AxisCorrection {
    /// Δφ_S (rad).
    pub dphi_s_rad: f64,
    /// Δγ (rad).
    pub dgamma_rad: f64,
    /// Δd (mm).
    pub dd_mm: f64,
    /// Δν_yA (mm).
    pub dnu_ya_mm: f64,
}

impl AxisCorrection {
    /// ΔK from an array (Δφ_S rad, Δγ rad, Δd mm, Δν_yA mm).
    pub fn from_array(a: [f64; 4]) -> Self {
        Self {
            dphi_s_rad: a[0],
            dgamma_rad: a[1],
            dd_mm: a[2],
            dnu_ya_mm: a[3],
        }
    }
    /// ΔK as an array (Δφ_S rad, Δγ rad, Δd mm, Δν_yA mm).
    pub fn to_array(self) -> [f64; 4] {
        [self.dphi_s_rad, self.dgamma_rad, self.dd_mm, self.dnu_ya_mm]
    }
    /// Every component multiplied by `k`.
    pub fn scaled(self, k: f64) -> Self {
        let a = self.to_array();
        Self::from_array([k * a[0], k * a[1], k * a[2], k * a[3]])
    }
}

/// K_R, the worm–dresser chain: maps dresser coordinates into worm coordinates.
///
/// # Formula
/// K_R = R_z(−φ_S)·T_z(−ν_zS)·R_x(−γ)·T_x(−d)·T_y(ν_yA)·R_z(φ_A)
/// # Source
/// JP6903407B2, eq. (1) [SEED]
pub fn k_r(p: &DressPose) -> Mat4 {
    rz(-p.phi_s_rad)
        * tz(-p.nu_zs_mm)
        * rx(-p.gamma_rad)
        * tx(-p.d_mm)
        * ty(p.nu_ya_mm)
        * rz(p.phi_a_rad)
}

/// Axis values of the example machine of eq. (5) (no dresser swivel): B1, V1, A1, X1, Z1, B3.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxesBsp2 {
    /// φ_B1, worm rotation (rad).
    pub b1_rad: f64,
    /// ν_V1, shift along the worm axis (mm).
    pub v1_mm: f64,
    /// φ_A1, swivel (rad).
    pub a1_rad: f64,
    /// ν_X1, radial axis (mm).
    pub x1_mm: f64,
    /// ν_Z1, vertical axis (mm).
    pub z1_mm: f64,
    /// φ_B3, dresser rotation (rad).
    pub b3_rad: f64,
}

/// Axis values of the example machine of eq. (4) (with dresser swivel C5).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AxesBsp1 {
    /// φ_B1, worm rotation (rad).
    pub b1_rad: f64,
    /// ν_V1, shift along the worm axis (mm).
    pub v1_mm: f64,
    /// φ_A1, swivel (rad).
    pub a1_rad: f64,
    /// ν_X1, radial axis (mm).
    pub x1_mm: f64,
    /// ν_Z1, vertical axis (mm).
    pub z1_mm: f64,
    /// φ_C5, dresser swivel (rad).
    pub c5_rad: f64,
    /// φ_B3, dresser rotation (rad).
    pub b3_rad: f64,
}

/// H_Bsp1, machine chain with dresser swivel C5.
///
/// # Formula
/// H_Bsp1 = R_z(−φ_B1)·T_z(−ν_V1)·R_x(−φ_A1)·T_x(−ν_X1)·T_y(ν_Z1)·R_y(φ_C5)·R_z(φ_B3)
/// # Source
/// JP6903407B2, eq. (4) [SEED]
pub fn h_bsp1(a: &AxesBsp1) -> Mat4 {
    rz(-a.b1_rad)
        * tz(-a.v1_mm)
        * rx(-a.a1_rad)
        * tx(-a.x1_mm)
        * ty(a.z1_mm)
        * ry(a.c5_rad)
        * rz(a.b3_rad)
}

/// H_Bsp2, machine chain without dresser swivel.
///
/// # Formula
/// H_Bsp2 = R_z(−φ_B1)·T_z(−ν_V1)·R_x(−φ_A1)·T_x(−ν_X1)·T_y(ν_Z1)·R_z(φ_B3)
/// # Source
/// JP6903407B2, eq. (5) [SEED]
pub fn h_bsp2(a: &AxesBsp2) -> Mat4 {
    rz(-a.b1_rad) * tz(-a.v1_mm) * rx(-a.a1_rad) * tx(-a.x1_mm) * ty(a.z1_mm) * rz(a.b3_rad)
}

/// The angle in (ref − π, ref + π] congruent to `a` modulo 2π: least travel from `ref`.
fn unwrap_near(a: f64, reference: f64) -> f64 {
    let mut x = a;
    while x - reference > PI {
        x -= 2.0 * PI;
    }
    while x - reference <= -PI {
        x += 2.0 * PI;
    }
    x
}

/// Axis values of machine (4) for a given pose `k` and a chosen C5 angle, closest to `reference`.
///
/// Matches the dresser axis line and the dresser reference point exactly, and B3 so the full
/// matrix is reproduced. Of the two solutions (A1, B1) and (−A1, B1 + π) the one with least travel
/// from `reference` is returned; B1 and B3 are unwrapped next to the reference (no reversal of a
/// full turn).
///
/// # Formula
/// a = R e_z = R_z(−φ_B1)·(sin φ_C5, cos φ_C5 sin φ_A1, cos φ_C5 cos φ_A1);
/// t = R_z(−φ_B1)·(−ν_X1, ν_Z1 cos φ_A1, −ν_V1 − ν_Z1 sin φ_A1)
/// # Domain
/// |a_z| ≤ |cos φ_C5| (the swivel can reach the crossing angle), |φ_A1| ≠ π/2
/// # Source
/// JP6903407B2, eqs. (3), (4) [SEED]; inversion docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn solve_bsp1(k: &Mat4, c5_rad: f64, reference: &AxesBsp1) -> Result<AxesBsp1> {
    let r = rotation(k);
    let t = translation(k);
    let a = r * Vector3::new(0.0, 0.0, 1.0);
    let (s5, c5) = c5_rad.sin_cos();
    if c5.abs() < 1e-12 || a.z.abs() > c5.abs() * (1.0 + 1e-12) {
        return Err(DressError::Unreachable(format!(
            "C5 = {:.6} deg cannot realise a crossing with axis z-component {:.9}",
            c5_rad.to_degrees(),
            a.z
        )));
    }
    let cos_a1 = (a.z / c5).clamp(-1.0, 1.0);
    let a1_base = cos_a1.acos();
    let mut best: Option<(f64, AxesBsp1)> = None;
    for a1 in [a1_base, -a1_base] {
        // R_z(φ_B1)·a = (sin c5, cos c5 sin a1, ·): B1 is the angle between the xy-parts.
        let target = (s5, c5 * a1.sin());
        let ang_a = a.y.atan2(a.x);
        let ang_t = target.1.atan2(target.0);
        let b1 = unwrap_near(ang_t - ang_a, reference.b1_rad);
        let u = rz(b1).fixed_view::<3, 3>(0, 0).into_owned() * t;
        let (sa, ca) = a1.sin_cos();
        if ca.abs() < 1e-12 {
            continue;
        }
        let x1 = -u.x;
        let z1 = u.y / ca;
        let v1 = -u.z - z1 * sa;
        let partial = rz(-b1) * tz(-v1) * rx(-a1) * tx(-x1) * ty(z1) * ry(c5_rad);
        let rem = rotation(&partial).transpose() * r;
        let b3 = unwrap_near(rem[(1, 0)].atan2(rem[(0, 0)]), reference.b3_rad);
        let axes = AxesBsp1 {
            b1_rad: b1,
            v1_mm: v1,
            a1_rad: a1,
            x1_mm: x1,
            z1_mm: z1,
            c5_rad,
            b3_rad: b3,
        };
        let travel = axis_travel_bsp1(&axes, reference);
        if best.as_ref().is_none_or(|(c, _)| travel < *c) {
            best = Some((travel, axes));
        }
    }
    best.map(|(_, a)| a)
        .ok_or_else(|| DressError::Unreachable("swivel A1 at ±90°".into()))
}

/// Travel from `reference` in a common measure (rad weighted by 100 mm, plus mm).
fn axis_travel_bsp1(a: &AxesBsp1, r: &AxesBsp1) -> f64 {
    const MM_PER_RAD: f64 = 100.0;
    MM_PER_RAD
        * ((a.b1_rad - r.b1_rad).abs() + (a.a1_rad - r.a1_rad).abs() + (a.c5_rad - r.c5_rad).abs())
        + (a.v1_mm - r.v1_mm).abs()
        + (a.x1_mm - r.x1_mm).abs()
        + (a.z1_mm - r.z1_mm).abs()
}

/// Axis values of machine (5) for a pose: the unique solution nearest `reference`.
///
/// # Formula
/// (5) is (1) with φ_B1 = φ_S, ν_V1 = ν_zS, φ_A1 = γ, ν_X1 = d, ν_Z1 = ν_yA, φ_B3 = φ_A,
/// so this is [`solve_bsp1`] with φ_C5 = 0.
/// # Source
/// JP6903407B2, eqs. (3), (5) [SEED]; correspondence docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn solve_bsp2(k: &Mat4, reference: &AxesBsp2) -> Result<AxesBsp2> {
    let r1 = AxesBsp1 {
        b1_rad: reference.b1_rad,
        v1_mm: reference.v1_mm,
        a1_rad: reference.a1_rad,
        x1_mm: reference.x1_mm,
        z1_mm: reference.z1_mm,
        c5_rad: 0.0,
        b3_rad: reference.b3_rad,
    };
    let a = solve_bsp1(k, 0.0, &r1)?;
    Ok(AxesBsp2 {
        b1_rad: a.b1_rad,
        v1_mm: a.v1_mm,
        a1_rad: a.a1_rad,
        x1_mm: a.x1_mm,
        z1_mm: a.z1_mm,
        b3_rad: a.b3_rad,
    })
}

/// Of the one-parameter family of machine-(4) solutions, the one with least travel from
/// `reference` for C5 within ±`c5_limit_rad`.
///
/// Golden-section search on the travel over C5 (the family is smooth in C5); the patent asks
/// to choose among the redundant solutions of chain (4) (machine of Fig. 22) so as to avoid
/// axis reversals; least travel from a reference is our form of that choice.
///
/// # Source
/// JP6903407B2, eq. (3), chain (4), Fig. 22 [SEED]; cost docs/dressing.md "Derivation: frames and inverse kinematics" [RECONSTRUCTED]
pub fn pick_bsp1(k: &Mat4, reference: &AxesBsp1, c5_limit_rad: f64) -> Result<AxesBsp1> {
    let cost = |c5: f64| -> f64 {
        solve_bsp1(k, c5, reference)
            .map(|a| axis_travel_bsp1(&a, reference))
            .unwrap_or(f64::INFINITY)
    };
    let (mut lo, mut hi) = (-c5_limit_rad.abs(), c5_limit_rad.abs());
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (cost(x1), cost(x2));
    for _ in 0..80 {
        if f1 < f2 {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - g * (hi - lo);
            f1 = cost(x1);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + g * (hi - lo);
            f2 = cost(x2);
        }
    }
    solve_bsp1(k, 0.5 * (lo + hi), reference)
}

/// Shortest distance between the worm axis (z) and the dresser axis of a pose `k`, and the angle
/// between the axes: the invariants |d| and |γ| of chain (1).
pub fn axis_distance_and_angle(k: &Mat4) -> (f64, f64) {
    let a = rotation(k) * Vector3::new(0.0, 0.0, 1.0);
    let c = translation(k);
    let ez = Vector3::new(0.0, 0.0, 1.0);
    let n = ez.cross(&a);
    let dist = if n.norm() < 1e-14 {
        (c - ez * c.z).norm()
    } else {
        (c.dot(&n) / n.norm()).abs()
    };
    (dist, a.z.clamp(-1.0, 1.0).acos())
}

/// The inverse pose (worm in dresser coordinates).
pub fn k_r_inverse(p: &DressPose) -> Mat4 {
    rigid_inverse(&k_r(p))
}
