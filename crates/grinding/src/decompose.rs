//! Decomposition of a wanted gear modification into a worm (diagonal-generating) part of the
//! line class (25) and a grinding-kinematics part F_KFt (99), by weighted least squares.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::error::{check_range, GrindError, Result};
use crate::modification::{FlankModification, LineModification, Poly, Poly2};

/// The seven coefficients of the quadratic decomposition.
///
/// # Formula
/// f(w, z) = K_F00 + K_F01·X + K_F02·X² + (K_F10 + K_F11·X)·w + K_KF1·X_K + K_KF2·X_K²,
/// X = w·sin ρ_F + z·cos ρ_F, X_K = w·sin ρ_KF + z·cos ρ_KF.
/// K_F10 is free (it sets the dresser swivel C5, E306); the rest follows from it.
/// # Source
/// Seed 004, eqs. (99)–(102), E304–E307 [SEED text; equations LOST]; digest §8.4
/// [RECONSTRUCTED, VERIFIED].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Decomposition {
    /// Worm-line direction ρ_F in rad.
    pub rho_rad: f64,
    /// Kinematic direction ρ_KF in rad.
    pub rho_kf_rad: f64,
    /// K_F00 in mm.
    pub k_f00: f64,
    /// K_F01.
    pub k_f01: f64,
    /// K_F02 in 1/mm.
    pub k_f02: f64,
    /// K_F10 (chosen).
    pub k_f10: f64,
    /// K_F11 in 1/mm.
    pub k_f11: f64,
    /// K_KF1.
    pub k_kf1: f64,
    /// K_KF2 in 1/mm.
    pub k_kf2: f64,
}

impl Decomposition {
    /// The part produced by the worm through diagonal generating (a line modification, w_0 = 0).
    pub fn worm_part(&self) -> LineModification {
        LineModification {
            rho_rad: self.rho_rad,
            w0_mm: 0.0,
            c: Poly(vec![self.k_f00, self.k_f01, self.k_f02]),
            l: Poly(vec![self.k_f10, self.k_f11]),
            q: Poly(vec![]),
        }
    }

    /// The kinematic part F_KFt(X_K) in mm (constant along the contact path).
    pub fn kinematic_part_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        let xk = w_mm * self.rho_kf_rad.sin() + z_mm * self.rho_kf_rad.cos();
        self.k_kf1 * xk + self.k_kf2 * xk * xk
    }
}

impl FlankModification for Decomposition {
    fn f_ft_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        self.worm_part().f_ft_mm(w_mm, z_mm) + self.kinematic_part_mm(w_mm, z_mm)
    }
}

/// One sample of a wanted modification.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Roll distance in mm.
    pub w_mm: f64,
    /// Width position in mm.
    pub z_mm: f64,
    /// Wanted f_Ft in mm.
    pub f_mm: f64,
    /// Weight (> 0; larger where the tolerance is tighter).
    pub weight: f64,
}

/// Weighted least-squares decomposition of sampled wanted modifications (A8/A9).
///
/// # Formula
/// minimise Σ_j g_j·(f_j − K_F10·w_j − [1, X, X², w·X, X_K, X_K²]_j·θ)² over
/// θ = (K_F00, K_F01, K_F02, K_F11, K_KF1, K_KF2), solved by QR of √g·A.
/// # Domain
/// Singular (error) when ρ_F = ±π/2 or ρ_F = ρ_KF (det of the quadratic part is
/// −cos ρ_F·sin²(ρ_F − ρ_KF)), or when the samples do not span the quadratic polynomials.
/// # Source
/// Seed 004 E295–E298 (A8) [SEED]; basis per digest §8.4 [RECONSTRUCTED].
pub fn decompose_weighted(
    samples: &[Sample],
    rho_rad: f64,
    rho_kf_rad: f64,
    k_f10: f64,
) -> Result<Decomposition> {
    check_range("rho_rad", rho_rad, -3.2, 3.2, "-π ..= π")?;
    check_range("rho_kf_rad", rho_kf_rad, -3.2, 3.2, "-π ..= π")?;
    check_range("k_f10", k_f10, -1e6, 1e6, "finite")?;
    if samples.len() < 6 {
        return Err(GrindError::BadData {
            field: "samples",
            got: samples.len(),
            expected: "at least 6 samples spanning the flank",
        });
    }
    let det = -rho_rad.cos() * (rho_rad - rho_kf_rad).sin().powi(2);
    if det.abs() < 1e-9 {
        return Err(GrindError::Singular {
            what: "polynomial decomposition (102)",
            field: "rho_rad",
            value: rho_rad,
            expected: "ρ_F ≠ ±90° and ρ_F ≠ ρ_KF",
        });
    }
    let (s, c) = rho_rad.sin_cos();
    let (sk, ck) = rho_kf_rad.sin_cos();
    let n = samples.len();
    let mut a = DMatrix::<f64>::zeros(n, 6);
    let mut y = DVector::<f64>::zeros(n);
    // Scale columns by the sample spread so the QR sees comparable magnitudes.
    let span = samples
        .iter()
        .map(|p| p.w_mm.abs().max(p.z_mm.abs()))
        .fold(1.0f64, f64::max);
    for (j, p) in samples.iter().enumerate() {
        check_range("sample.w_mm", p.w_mm, -1e6, 1e6, "finite")?;
        check_range("sample.z_mm", p.z_mm, -1e6, 1e6, "finite")?;
        check_range("sample.f_mm", p.f_mm, -1e3, 1e3, "finite, |f| ≤ 1000 mm")?;
        check_range("sample.weight", p.weight, 1e-300, 1e300, "> 0")?;
        let g = p.weight.sqrt();
        let x = (p.w_mm * s + p.z_mm * c) / span;
        let xk = (p.w_mm * sk + p.z_mm * ck) / span;
        let w = p.w_mm / span;
        let row = [1.0, x, x * x, w * x, xk, xk * xk];
        for (k, v) in row.iter().enumerate() {
            a[(j, k)] = g * v;
        }
        y[j] = g * (p.f_mm - k_f10 * p.w_mm);
    }
    let qr = a.qr();
    let r = qr.r();
    let rmax = (0..6).map(|i| r[(i, i)].abs()).fold(0.0, f64::max);
    let rmin = (0..6)
        .map(|i| r[(i, i)].abs())
        .fold(f64::INFINITY, f64::min);
    if rmin.is_nan() || rmin <= 1e-10 * rmax {
        return Err(GrindError::Singular {
            what: "polynomial decomposition (102)",
            field: "samples",
            value: rmin / rmax,
            expected: "samples spanning w, z, w², w·z, z² (rank 6)",
        });
    }
    let qty = qr.q().transpose() * y;
    let theta = r.solve_upper_triangular(&qty).ok_or(GrindError::Singular {
        what: "polynomial decomposition (102)",
        field: "samples",
        value: 0.0,
        expected: "a regular triangular factor",
    })?;
    Ok(Decomposition {
        rho_rad,
        rho_kf_rad,
        k_f00: theta[0],
        k_f01: theta[1] / span,
        k_f02: theta[2] / (span * span),
        k_f10,
        k_f11: theta[3] / (span * span),
        k_kf1: theta[4] / span,
        k_kf2: theta[5] / (span * span),
    })
}

/// Samples a modification on a uniform grid with unit weights (helper for exact polynomials).
pub fn sample_grid(
    f: &(impl FlankModification + ?Sized),
    w_range_mm: (f64, f64),
    z_range_mm: (f64, f64),
    n_w: usize,
    n_z: usize,
) -> Vec<Sample> {
    let mut out = Vec::with_capacity(n_w * n_z);
    for i in 0..n_w {
        let w = lerp(w_range_mm, i, n_w);
        for j in 0..n_z {
            let z = lerp(z_range_mm, j, n_z);
            out.push(Sample {
                w_mm: w,
                z_mm: z,
                f_mm: f.f_ft_mm(w, z),
                weight: 1.0,
            });
        }
    }
    out
}

fn lerp(r: (f64, f64), i: usize, n: usize) -> f64 {
    if n <= 1 {
        0.5 * (r.0 + r.1)
    } else {
        r.0 + (r.1 - r.0) * i as f64 / (n - 1) as f64
    }
}

/// Exact decomposition of a quadratic polynomial (square system; same result as the weighted
/// fit on exact data).
///
/// # Formula
/// K_F02·(s², 2sc, c²) + K_F11·(s, c, 0) + K_KF2·(s_K², 2s_K·c_K, c_K²) = (c20, c11, c02);
/// K_F01·(s, c) + K_F10·(1, 0) + K_KF1·(s_K, c_K) = (c10, c01); K_F00 = c00.
/// # Source
/// Digest §8.4 [RECONSTRUCTED, VERIFIED].
pub fn decompose_poly2(
    f: &Poly2,
    rho_rad: f64,
    rho_kf_rad: f64,
    k_f10: f64,
) -> Result<Decomposition> {
    let samples = sample_grid(f, (-1.0, 1.0), (-1.0, 1.0), 3, 3);
    decompose_weighted(&samples, rho_rad, rho_kf_rad, k_f10)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use approx::assert_relative_eq;

    fn t9_wanted() -> Poly2 {
        // −4·c_α·(w − 17)²/10² − 4·c_β·z²/30², c_α = 5 µm, c_β = 10 µm
        let ca = 0.005;
        let cb = 0.010;
        Poly2 {
            c00: -4.0 * ca * 289.0 / 100.0,
            c10: 4.0 * ca * 34.0 / 100.0,
            c01: 0.0,
            c20: -4.0 * ca / 100.0,
            c11: 0.0,
            c02: -4.0 * cb / 900.0,
        }
    }

    /// T9: digest §9.3 numbers (independent calculation), relative 1e-6 of the printed values.
    #[test]
    fn t9_untwisted_crowning_decomposition() {
        let rho = 45f64.to_radians();
        let rho_k = -14.076095f64.to_radians();
        let wanted = t9_wanted();
        let samples = sample_grid(&wanted, (11.0, 23.0), (-15.0, 15.0), 13, 31);
        let d = decompose_weighted(&samples, rho, rho_k, 0.0).unwrap();
        let rel = |a: f64, b: f64| ((a - b) / b).abs();
        assert!(rel(d.k_f00, -5.7800e-2) < 1e-6);
        assert!(rel(d.k_f01, 7.688775e-3) < 1e-5);
        assert!(rel(d.k_f02, 2.236303e-4) < 1e-5);
        assert!(rel(d.k_f11, -4.270799e-4) < 1e-5);
        assert!(rel(d.k_kf1, -5.605086e-3) < 1e-5);
        assert!(rel(d.k_kf2, -1.660837e-4) < 1e-5);
        // recomposition on a grid
        for s in &samples {
            assert!((d.f_ft_mm(s.w_mm, s.z_mm) - s.f_mm).abs() < 1e-12);
        }
        // K_F10 = 1e-3 changes only K_F01 and K_KF1
        let d2 = decompose_weighted(&samples, rho, rho_k, 1e-3).unwrap();
        assert!(rel(d2.k_f01, 6.558073e-3) < 1e-5);
        assert!(rel(d2.k_kf1, -4.780809e-3) < 1e-5);
        assert_relative_eq!(d2.k_f02, d.k_f02, max_relative = 1e-9);
        assert_relative_eq!(d2.k_kf2, d.k_kf2, max_relative = 1e-9);
        // det = −cos ρ_F·sin²(ρ_F − ρ_KF) = −0.520365
        assert_relative_eq!(
            -rho.cos() * (rho - rho_k).sin().powi(2),
            -0.520365,
            epsilon = 1e-6
        );
        // exact square system gives the same numbers
        let e = decompose_poly2(&wanted, rho, rho_k, 0.0).unwrap();
        assert!(rel(e.k_f11, d.k_f11) < 1e-9 && rel(e.k_kf2, d.k_kf2) < 1e-9);
    }

    #[test]
    fn t9_singular_directions_fail() {
        let rho_k = -14.076095f64.to_radians();
        let w = t9_wanted();
        assert!(decompose_poly2(&w, 90f64.to_radians(), rho_k, 0.0).is_err());
        assert!(decompose_poly2(&w, rho_k, rho_k, 0.0).is_err());
        assert!(decompose_weighted(&[], 0.5, rho_k, 0.0).is_err());
    }

    /// Weights matter: a non-polynomial wanted modification fitted with heavy weights on one
    /// region is matched better there than with uniform weights.
    #[test]
    fn weights_steer_the_fit() {
        let rho = 45f64.to_radians();
        let rho_k = -0.2457;
        let f = |w: f64, z: f64| 1e-3 * ((w - 17.0) / 4.0).powi(4) + 1e-4 * z.abs();
        let mut s = Vec::new();
        for i in 0..13 {
            for j in 0..13 {
                let (w, z) = (11.0 + i as f64, -15.0 + 2.5 * j as f64);
                s.push(Sample {
                    w_mm: w,
                    z_mm: z,
                    f_mm: f(w, z),
                    weight: 1.0,
                });
            }
        }
        let uni = decompose_weighted(&s, rho, rho_k, 0.0).unwrap();
        for p in s.iter_mut() {
            if p.w_mm > 20.0 {
                p.weight = 1e4;
            }
        }
        let wtd = decompose_weighted(&s, rho, rho_k, 0.0).unwrap();
        let err = |d: &Decomposition| {
            s.iter()
                .filter(|p| p.w_mm > 20.0)
                .map(|p| (d.f_ft_mm(p.w_mm, p.z_mm) - p.f_mm).powi(2))
                .sum::<f64>()
        };
        assert!(err(&wtd) < 0.5 * err(&uni));
    }
}
