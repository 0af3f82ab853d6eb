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
/// K_F10 is free (it sets the dresser swivel C5; JP6903407B2 text to (101)/(102): seven
/// coefficients, one free); the rest follows from it.
/// # Source
/// JP6903407B2, eqs. (99)–(102), quadratic modifications in w and z [SEED text; equations LOST];
/// docs/grinding.md "Decomposition"
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
/// JP6903407B2, text to eq. (100) (decomposition by curve fitting) [SEED]; basis per
/// docs/grinding.md "Decomposition" [RECONSTRUCTED].
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
/// docs/grinding.md "Decomposition" [RECONSTRUCTED, VERIFIED].
pub fn decompose_poly2(
    f: &Poly2,
    rho_rad: f64,
    rho_kf_rad: f64,
    k_f10: f64,
) -> Result<Decomposition> {
    let samples = sample_grid(f, (-1.0, 1.0), (-1.0, 1.0), 3, 3);
    decompose_weighted(&samples, rho_rad, rho_kf_rad, k_f10)
}

/// Which terms the general decomposition (100) may use, and their polynomial degrees.
///
/// Terms, in priority order (a term that is a linear combination of earlier ones on the
/// samples is dropped and reported, see [`decompose_general`]):
/// 1. dresser profile f_PFt(w) = Σ_{k=2..=profile_degree} P_k·(w − w_P0)^k (97);
/// 2. worm topology F_FtC(X) = Σ_{j=0..=worm_c_degree} C_j·X^j;
/// 3. F_FtL(X)·w with F_FtL(X) = K_F10 + Σ_{j=1..=worm_l_degree} L_j·X^j (K_F10 chosen);
/// 4. F_FtQ(X)·w² with F_FtQ(X) = Σ_{j=0..=n} Q_j·X^j (`worm_q_degree = Some(n)`);
/// 5. kinematic part F_KFt(X_K) = Σ_{k=1..=kinematic_degree} K_k·X_K^k (99).
///
/// The constant lives in F_FtC only and the linear term in w is K_F10 (+ nothing in f_PFt),
/// so the three linear forms X, w, X_K (which span only a plane) do not compete.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DecompositionBasis {
    /// Worm-line direction ρ_F in rad.
    pub rho_rad: f64,
    /// Kinematic direction ρ_KF in rad.
    pub rho_kf_rad: f64,
    /// K_F10, the constant part of F_FtL (free; JP6903407B2 text to (101)/(102)), mm/mm.
    pub k_f10: f64,
    /// Degree of F_FtC in X.
    pub worm_c_degree: usize,
    /// Degree of F_FtL in X (0 = only K_F10).
    pub worm_l_degree: usize,
    /// Degree of F_FtQ in X (`None` = no F_FtQ).
    pub worm_q_degree: Option<usize>,
    /// Degree of f_PFt in w (< 2 = no profile part).
    pub profile_degree: usize,
    /// Reference roll distance w_P0 of f_PFt in mm.
    pub profile_w0_mm: f64,
    /// Degree of F_KFt in X_K (0 = no kinematic part).
    pub kinematic_degree: usize,
}

impl DecompositionBasis {
    /// The basis of (102) (quadratic worm part, quadratic kinematic part, no profile part;
    /// set `profile_degree` ≥ 2 to add one).
    pub fn quadratic(rho_rad: f64, rho_kf_rad: f64, k_f10: f64) -> Self {
        Self {
            rho_rad,
            rho_kf_rad,
            k_f10,
            worm_c_degree: 2,
            worm_l_degree: 1,
            worm_q_degree: None,
            profile_degree: 0,
            profile_w0_mm: 0.0,
            kinematic_degree: 2,
        }
    }

    fn check(&self) -> Result<()> {
        check_range("rho_rad", self.rho_rad, -3.2, 3.2, "-π ..= π")?;
        check_range("rho_kf_rad", self.rho_kf_rad, -3.2, 3.2, "-π ..= π")?;
        check_range("k_f10", self.k_f10, -1e6, 1e6, "finite")?;
        check_range("profile_w0_mm", self.profile_w0_mm, -1e6, 1e6, "finite")?;
        for (field, d) in [
            ("worm_c_degree", self.worm_c_degree),
            ("worm_l_degree", self.worm_l_degree),
            ("worm_q_degree", self.worm_q_degree.unwrap_or(0)),
            ("profile_degree", self.profile_degree),
            ("kinematic_degree", self.kinematic_degree),
        ] {
            if d > 8 {
                return Err(GrindError::BadData {
                    field,
                    got: d,
                    expected: "a polynomial degree ≤ 8",
                });
            }
        }
        Ok(())
    }

    /// The terms in priority order: (part, power).
    fn terms(&self) -> Vec<(Part, usize)> {
        let mut t = Vec::new();
        t.extend((2..=self.profile_degree).map(|k| (Part::Profile, k)));
        t.extend((0..=self.worm_c_degree).map(|j| (Part::WormC, j)));
        t.extend((1..=self.worm_l_degree).map(|j| (Part::WormL, j)));
        if let Some(n) = self.worm_q_degree {
            t.extend((0..=n).map(|j| (Part::WormQ, j)));
        }
        t.extend((1..=self.kinematic_degree).map(|k| (Part::Kinematic, k)));
        t
    }
}

/// A part of the decomposition (100).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Part {
    /// Dresser profile f_PFt(w) (97).
    Profile,
    /// Worm topology F_FtC(X).
    WormC,
    /// Worm topology F_FtL(X)·w.
    WormL,
    /// Worm topology F_FtQ(X)·w².
    WormQ,
    /// Kinematic correction F_KFt(X_K) (99).
    Kinematic,
}

impl Part {
    fn basis_value(self, power: usize, w: f64, x: f64, xk: f64, w0: f64) -> f64 {
        let p = power as i32;
        match self {
            Part::Profile => (w - w0).powi(p),
            Part::WormC => x.powi(p),
            Part::WormL => w * x.powi(p),
            Part::WormQ => w * w * x.powi(p),
            Part::Kinematic => xk.powi(p),
        }
    }
}

/// Result of the general decomposition (100): dresser profile + worm topology + kinematics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeneralDecomposition {
    /// The basis used.
    pub basis: DecompositionBasis,
    /// f_PFt coefficients by power of (w − w_P0) (entries 0 and 1 are zero).
    pub profile: Poly,
    /// F_FtC(X) coefficients.
    pub worm_c: Poly,
    /// F_FtL(X) coefficients (entry 0 is K_F10).
    pub worm_l: Poly,
    /// F_FtQ(X) coefficients.
    pub worm_q: Poly,
    /// F_KFt(X_K) coefficients (entry 0 is zero).
    pub kinematic: Poly,
    /// Terms dropped because they are linear combinations of earlier terms on the samples
    /// (their coefficient is 0).
    pub dropped: Vec<(Part, usize)>,
    /// Weighted RMS of the residual, √(Σ g·r² / Σ g), in mm.
    pub rms_residual_mm: f64,
}

impl GeneralDecomposition {
    /// The worm part (line class (25), w_0 = 0, direction ρ_F).
    pub fn worm_part(&self) -> LineModification {
        LineModification {
            rho_rad: self.basis.rho_rad,
            w0_mm: 0.0,
            c: self.worm_c.clone(),
            l: self.worm_l.clone(),
            q: self.worm_q.clone(),
        }
    }

    /// The dresser profile part f_PFt(w) in mm (97), the same on every worm thread.
    pub fn profile_part_mm(&self, w_mm: f64) -> f64 {
        self.profile.eval(w_mm - self.basis.profile_w0_mm)
    }

    /// The kinematic part F_KFt(X_K) in mm (99).
    pub fn kinematic_part_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        let xk = w_mm * self.basis.rho_kf_rad.sin() + z_mm * self.basis.rho_kf_rad.cos();
        self.kinematic.eval(xk)
    }
}

impl FlankModification for GeneralDecomposition {
    fn f_ft_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        self.worm_part().f_ft_mm(w_mm, z_mm)
            + self.profile_part_mm(w_mm)
            + self.kinematic_part_mm(w_mm, z_mm)
    }
}

/// Weighted least-squares decomposition of a wanted modification into the three producible
/// parts (100): dresser profile f_PFt (97), worm topology of the line class (25) and the
/// kinematic correction F_KFt (99).
///
/// # Formula
/// f_GFt(w, z) = [F_FtC(X) + F_FtL(X)·w + F_FtQ(X)·w²] + f_PFt(w) + F_KFt(X_K),
/// X = w·sin ρ_F + z·cos ρ_F, X_K = w·sin ρ_KF + z·cos ρ_KF; minimise
/// Σ_j g_j·(f_j − K_F10·w_j − Σ_t θ_t·b_t(w_j, z_j))² by QR of the row-weighted,
/// column-equilibrated basis matrix.
/// # Domain
/// The function classes overlap (e.g. w², X², w·X and X_K² span only the 3 quadratic forms),
/// so the split is defined by the priority order of [`DecompositionBasis`]: terms are taken
/// in that order and a term whose column lies in the span of the accepted ones (relative
/// residual < 1e-9 after two projections) is dropped, coefficient 0, and listed in
/// `dropped`. A profile part therefore takes the pure-w content first (the dresser makes
/// profile modifications; JP6903407B2, "Superimposition with other modifications"), the kinematic
/// part only what nothing else can make.
/// # Source
/// JP6903407B2, eqs. (97)–(100), "Superimposition with other modifications" [SEED; (100) LOST];
/// form per docs/grinding.md "Decomposition"
/// [RECONSTRUCTED].
pub fn decompose_general(
    samples: &[Sample],
    basis: &DecompositionBasis,
) -> Result<GeneralDecomposition> {
    basis.check()?;
    let terms = basis.terms();
    if samples.len() < terms.len().max(1) {
        return Err(GrindError::BadData {
            field: "samples",
            got: samples.len(),
            expected: "at least as many samples as basis terms",
        });
    }
    let (s, c) = basis.rho_rad.sin_cos();
    let (sk, ck) = basis.rho_kf_rad.sin_cos();
    let n = samples.len();
    let mut y = DVector::<f64>::zeros(n);
    let mut cols: Vec<DVector<f64>> = Vec::with_capacity(terms.len());
    let mut sum_g = 0.0;
    for (j, p) in samples.iter().enumerate() {
        check_range("sample.w_mm", p.w_mm, -1e6, 1e6, "finite")?;
        check_range("sample.z_mm", p.z_mm, -1e6, 1e6, "finite")?;
        check_range("sample.f_mm", p.f_mm, -1e3, 1e3, "finite, |f| ≤ 1000 mm")?;
        check_range("sample.weight", p.weight, 1e-300, 1e300, "> 0")?;
        sum_g += p.weight;
        y[j] = p.weight.sqrt() * (p.f_mm - basis.k_f10 * p.w_mm);
    }
    for &(part, power) in &terms {
        let col = DVector::from_iterator(
            n,
            samples.iter().map(|p| {
                let x = p.w_mm * s + p.z_mm * c;
                let xk = p.w_mm * sk + p.z_mm * ck;
                p.weight.sqrt() * part.basis_value(power, p.w_mm, x, xk, basis.profile_w0_mm)
            }),
        );
        cols.push(col);
    }
    // Sequential rank detection in priority order.
    let mut accepted: Vec<usize> = Vec::new();
    let mut dropped = Vec::new();
    let mut q_cols: Vec<DVector<f64>> = Vec::new();
    for (t, col) in cols.iter().enumerate() {
        let norm = col.norm();
        let mut r = if norm > 0.0 && norm.is_finite() {
            col / norm
        } else {
            DVector::zeros(n)
        };
        for _ in 0..2 {
            for q in &q_cols {
                let d = q.dot(&r);
                r -= q * d;
            }
        }
        let rn = r.norm();
        if rn < 1e-9 {
            dropped.push(terms[t]);
        } else {
            q_cols.push(r / rn);
            accepted.push(t);
        }
    }
    let k = accepted.len();
    let mut theta = vec![0.0; terms.len()];
    if k > 0 {
        let scale: Vec<f64> = accepted.iter().map(|&t| cols[t].norm()).collect();
        let a = DMatrix::from_fn(n, k, |i, jj| cols[accepted[jj]][i] / scale[jj]);
        let qr = a.qr();
        let r = qr.r();
        let qty = qr.q().transpose() * &y;
        let sol = r.solve_upper_triangular(&qty).ok_or(GrindError::Singular {
            what: "general decomposition (100)",
            field: "samples",
            value: 0.0,
            expected: "a regular triangular factor",
        })?;
        for (jj, &t) in accepted.iter().enumerate() {
            theta[t] = sol[jj] / scale[jj];
        }
    }
    let mut out = GeneralDecomposition {
        basis: *basis,
        profile: Poly(vec![0.0; basis.profile_degree.max(1) + 1]),
        worm_c: Poly(vec![0.0; basis.worm_c_degree + 1]),
        worm_l: Poly(vec![0.0; basis.worm_l_degree + 1]),
        worm_q: Poly(vec![0.0; basis.worm_q_degree.map_or(0, |d| d + 1)]),
        kinematic: Poly(vec![0.0; basis.kinematic_degree + 1]),
        dropped,
        rms_residual_mm: 0.0,
    };
    out.worm_l.0[0] = basis.k_f10;
    for (t, &(part, power)) in terms.iter().enumerate() {
        let target = match part {
            Part::Profile => &mut out.profile,
            Part::WormC => &mut out.worm_c,
            Part::WormL => &mut out.worm_l,
            Part::WormQ => &mut out.worm_q,
            Part::Kinematic => &mut out.kinematic,
        };
        target.0[power] = theta[t];
    }
    let ss: f64 = samples
        .iter()
        .map(|p| p.weight * (p.f_mm - out.f_ft_mm(p.w_mm, p.z_mm)).powi(2))
        .sum();
    out.rms_residual_mm = (ss / sum_g).sqrt();
    Ok(out)
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

    /// T9: docs/grinding.md "Independent reference: reference example" numbers (independent
    /// calculation), relative 1e-6 of the printed values.
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

    /// Known parts: f_PFt = P2·(w−17)² + P3·(w−17)³ + P4·(w−17)⁴, worm F_C = C0 + C1·X + C2·X²,
    /// F_L = K_F10 + L1·X, kinematic K1·X_K.
    fn known() -> (DecompositionBasis, GeneralDecomposition) {
        let rho = 45f64.to_radians();
        let rho_k = -14.076095f64.to_radians();
        let mut basis = DecompositionBasis::quadratic(rho, rho_k, 2e-4);
        basis.profile_degree = 4;
        basis.profile_w0_mm = 17.0;
        let parts = GeneralDecomposition {
            basis,
            profile: Poly(vec![0.0, 0.0, -3e-5, 2e-6, -4e-7]),
            worm_c: Poly(vec![-0.02, 3e-3, 1.5e-4]),
            worm_l: Poly(vec![2e-4, -2e-4]),
            worm_q: Poly(vec![]),
            kinematic: Poly(vec![0.0, -4e-3, 0.0]),
            dropped: vec![],
            rms_residual_mm: 0.0,
        };
        (basis, parts)
    }

    fn rel_close(a: &Poly, b: &Poly) {
        let scale = b.0.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in 0..a.0.len().max(b.0.len()) {
            let (x, y) = (
                a.0.get(i).copied().unwrap_or(0.0),
                b.0.get(i).copied().unwrap_or(0.0),
            );
            assert!(
                (x - y).abs() <= 1e-9 * y.abs().max(1e-3 * scale),
                "coefficient {i}: {x} vs {y}"
            );
        }
    }

    /// (97)–(100): a modification synthesised from known dresser-profile, worm and kinematic
    /// parts is split back into them (1e-9 relative). X_K² is a combination of (w−17)², X²,
    /// w·X on any sample set, so it is dropped and reported.
    #[test]
    fn general_decomposition_recovers_known_parts() {
        let (basis, truth) = known();
        let samples = sample_grid(&truth, (11.0, 23.0), (-15.0, 15.0), 9, 11);
        let d = decompose_general(&samples, &basis).unwrap();
        assert_eq!(d.dropped, vec![(Part::Kinematic, 2)]);
        rel_close(&d.profile, &truth.profile);
        rel_close(&d.worm_c, &truth.worm_c);
        rel_close(&d.worm_l, &truth.worm_l);
        rel_close(&d.kinematic, &truth.kinematic);
        assert!(d.rms_residual_mm < 1e-12);
        // the parts add up to the wanted modification
        for p in &samples {
            let sum = d.worm_part().f_ft_mm(p.w_mm, p.z_mm)
                + d.profile_part_mm(p.w_mm)
                + d.kinematic_part_mm(p.w_mm, p.z_mm);
            assert!((sum - p.f_mm).abs() < 1e-12);
        }
    }

    /// Weights: a disturbance of 1 mm on the samples with w > 20 mm, weighted 1e-14, leaves the
    /// recovered parts at 1e-9 relative; with unit weights it spoils them.
    #[test]
    fn general_decomposition_with_weights() {
        let (basis, truth) = known();
        let mut samples = sample_grid(&truth, (11.0, 23.0), (-15.0, 15.0), 13, 9);
        for p in samples.iter_mut().filter(|p| p.w_mm > 20.0) {
            p.f_mm += 1e-3 * (p.z_mm / 15.0).powi(3) * p.w_mm;
            p.weight = 1e-14;
        }
        let d = decompose_general(&samples, &basis).unwrap();
        rel_close(&d.profile, &truth.profile);
        rel_close(&d.worm_c, &truth.worm_c);
        rel_close(&d.kinematic, &truth.kinematic);
        for p in samples.iter_mut() {
            p.weight = 1.0;
        }
        let u = decompose_general(&samples, &basis).unwrap();
        assert!((u.profile.0[2] - truth.profile.0[2]).abs() > 1e-3 * truth.profile.0[2].abs());
    }

    /// Closed form for untwisted crowning (T9's wanted modification) with a profile part taking
    /// priority: quadratic parts w² (profile), X², w·X; with s = sin ρ, c = cos ρ:
    /// C2 = −4c_β/(900·c²), L1 = −2s·C2, P2 = −4c_α/100 + s²·C2; no kinematic crowning.
    #[test]
    fn profile_part_takes_profile_crowning_first() {
        let rho = 45f64.to_radians();
        let rho_k = -14.076095f64.to_radians();
        let mut basis = DecompositionBasis::quadratic(rho, rho_k, 0.0);
        basis.profile_degree = 2;
        basis.profile_w0_mm = 17.0;
        let samples = sample_grid(&t9_wanted(), (11.0, 23.0), (-15.0, 15.0), 7, 9);
        let d = decompose_general(&samples, &basis).unwrap();
        let (s, c) = rho.sin_cos();
        let c2 = -4.0 * 0.010 / (900.0 * c * c);
        assert_relative_eq!(d.worm_c.0[2], c2, max_relative = 1e-9);
        assert_relative_eq!(d.worm_l.0[1], -2.0 * s * c2, max_relative = 1e-9);
        assert_relative_eq!(
            d.profile.0[2],
            -4.0 * 0.005 / 100.0 + s * s * c2,
            max_relative = 1e-9
        );
        assert_eq!(d.dropped, vec![(Part::Kinematic, 2)]);
        // without a profile part the general solver reproduces (102) (T9 numbers)
        let plain =
            decompose_general(&samples, &DecompositionBasis::quadratic(rho, rho_k, 0.0)).unwrap();
        assert!(plain.dropped.is_empty());
        assert_relative_eq!(plain.kinematic.0[2], -1.660837e-4, max_relative = 1e-6);
        assert_relative_eq!(plain.worm_l.0[1], -4.270799e-4, max_relative = 1e-6);
        assert!(decompose_general(&samples[..3], &basis).is_err());
        let mut bad = basis;
        bad.profile_degree = 20;
        assert!(decompose_general(&samples, &bad).is_err());
    }
}
