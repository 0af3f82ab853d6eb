//! Flank modifications over the (w, z) plane: the line class (25)/(26), quadratic polynomials
//! (101) and crowning (103). All values are transverse modifications f_Ft in mm
//! (> 0 = more material), as JP6903407B2 uses them.

use serde::{Deserialize, Serialize};

use crate::error::{check_range, GrindError, Result};

/// A modification f_Ft(w, z) of a flank, in mm.
pub trait FlankModification {
    /// Transverse modification f_Ft in mm at roll distance w and width position z (mm).
    fn f_ft_mm(&self, w_mm: f64, z_mm: f64) -> f64;

    /// (∂f/∂w, ∂f/∂z); the default uses central differences with a 1e-4 mm step.
    fn gradient(&self, w_mm: f64, z_mm: f64) -> (f64, f64) {
        let h = 1e-4;
        (
            (self.f_ft_mm(w_mm + h, z_mm) - self.f_ft_mm(w_mm - h, z_mm)) / (2.0 * h),
            (self.f_ft_mm(w_mm, z_mm + h) - self.f_ft_mm(w_mm, z_mm - h)) / (2.0 * h),
        )
    }
}

/// Most coefficients a [`Poly`] of a line modification may have (degree 15).
pub const MAX_POLY_COEFFS: usize = 16;

/// Largest magnitude of a coefficient of a line modification's [`Poly`], in mm·mm⁻ᵏ (1e15 µm).
pub const MAX_POLY_COEFF_MM: f64 = 1e12;

/// A polynomial in one variable, coefficients lowest power first.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Poly(pub Vec<f64>);

impl Poly {
    /// Value at x (Horner).
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        self.0.iter().rev().fold(0.0, |acc, c| acc * x + c)
    }

    /// Derivative at x.
    #[inline]
    pub fn deriv(&self, x: f64) -> f64 {
        self.0
            .iter()
            .enumerate()
            .skip(1)
            .rev()
            .fold(0.0, |acc, (i, c)| acc * x + c * i as f64)
    }

    /// P(k·x + c) as a polynomial in x (exact composition with an affine map).
    pub fn compose_affine(&self, k: f64, c: f64) -> Poly {
        // Horner with polynomial arithmetic: acc ← acc·(k x + c) + a_i
        let mut acc: Vec<f64> = Vec::with_capacity(self.0.len());
        for &a in self.0.iter().rev() {
            let mut next = vec![0.0; acc.len() + 1];
            for (i, &v) in acc.iter().enumerate() {
                next[i] += v * c;
                next[i + 1] += v * k;
            }
            next[0] += a;
            acc = next;
        }
        Poly(acc)
    }

    /// α·P.
    pub fn scaled(&self, alpha: f64) -> Poly {
        Poly(self.0.iter().map(|v| v * alpha).collect())
    }

    /// P + Q.
    pub fn plus(&self, other: &Poly) -> Poly {
        let n = self.0.len().max(other.0.len());
        Poly(
            (0..n)
                .map(|i| {
                    self.0.get(i).copied().unwrap_or(0.0) + other.0.get(i).copied().unwrap_or(0.0)
                })
                .collect(),
        )
    }

    fn check(&self, field: &'static str) -> Result<()> {
        if self.0.len() > MAX_POLY_COEFFS {
            return Err(GrindError::BadData {
                field,
                got: self.0.len(),
                expected: "at most 16 polynomial coefficients",
            });
        }
        for &v in &self.0 {
            check_range(
                field,
                v,
                -MAX_POLY_COEFF_MM,
                MAX_POLY_COEFF_MM,
                "finite coefficients of magnitude ≤ 1e12 mm·mm⁻ᵏ (1e15 µm·mm⁻ᵏ at the CLI)",
            )?;
        }
        Ok(())
    }
}

/// A modification of the line class: quadratic in w along every line of direction ρ.
///
/// # Formula
/// f_Ft(w, z) = F_C(X) + F_L(X)·(w − w_0) + F_Q(X)·(w − w_0)², X = w·sin ρ + z·cos ρ.
/// JP6903407B2 writes it with w_0 = 0; the reference roll distance w_0 (a convention fixed here)
/// keeps coefficients small and well conditioned. ρ = 0: pure lead modification; ρ = ±π/2:
/// pure profile modification.
/// # Units
/// mm; F_C in mm, F_L in mm/mm, F_Q in 1/mm (each a polynomial in X/mm).
/// # Source
/// JP6903407B2, eqs. (25), (26) [SEED form; (25) partly LOST, docs/grinding.md "Derivation:
/// line-class transfer"].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct LineModification {
    /// Direction ρ in rad.
    pub rho_rad: f64,
    /// Reference roll distance w_0 in mm.
    pub w0_mm: f64,
    /// F_C(X).
    pub c: Poly,
    /// F_L(X).
    pub l: Poly,
    /// F_Q(X).
    pub q: Poly,
}

impl LineModification {
    /// A validated line modification.
    pub fn new(rho_rad: f64, w0_mm: f64, c: Poly, l: Poly, q: Poly) -> Result<Self> {
        check_range("rho_rad", rho_rad, -3.2, 3.2, "-π ..= π")?;
        check_range("w0_mm", w0_mm, -1e6, 1e6, "finite")?;
        c.check("F_C coefficients")?;
        l.check("F_L coefficients")?;
        q.check("F_Q coefficients")?;
        Ok(Self {
            rho_rad,
            w0_mm,
            c,
            l,
            q,
        })
    }

    /// Line coordinate X = w·sin ρ + z·cos ρ (26).
    #[inline]
    pub fn x_of(&self, w_mm: f64, z_mm: f64) -> f64 {
        w_mm * self.rho_rad.sin() + z_mm * self.rho_rad.cos()
    }
}

impl FlankModification for LineModification {
    #[inline]
    fn f_ft_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        let x = self.x_of(w_mm, z_mm);
        let dw = w_mm - self.w0_mm;
        self.c.eval(x) + dw * (self.l.eval(x) + dw * self.q.eval(x))
    }

    #[inline]
    fn gradient(&self, w_mm: f64, z_mm: f64) -> (f64, f64) {
        let (sr, cr) = self.rho_rad.sin_cos();
        let x = self.x_of(w_mm, z_mm);
        let dw = w_mm - self.w0_mm;
        let dx = self.c.deriv(x) + dw * (self.l.deriv(x) + dw * self.q.deriv(x));
        let dwp = self.l.eval(x) + 2.0 * dw * self.q.eval(x);
        (dx * sr + dwp, dx * cr)
    }
}

/// A uniform stock (constant transverse modification).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Uniform {
    /// f_Ft in mm.
    pub f_ft_mm: f64,
}

impl FlankModification for Uniform {
    fn f_ft_mm(&self, _w_mm: f64, _z_mm: f64) -> f64 {
        self.f_ft_mm
    }
    fn gradient(&self, _w_mm: f64, _z_mm: f64) -> (f64, f64) {
        (0.0, 0.0)
    }
}

/// A quadratic polynomial in w and z.
///
/// # Formula
/// f_p2(w, z) = c00 + c10·w + c01·z + c20·w² + c11·w·z + c02·z²
/// # Source
/// JP6903407B2, eq. (101) [LOST]; form per docs/grinding.md "Decomposition" [RECONSTRUCTED].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Poly2 {
    /// c00 in mm.
    pub c00: f64,
    /// c10 (per w).
    pub c10: f64,
    /// c01 (per z).
    pub c01: f64,
    /// c20 in 1/mm.
    pub c20: f64,
    /// c11 in 1/mm.
    pub c11: f64,
    /// c02 in 1/mm.
    pub c02: f64,
}

impl FlankModification for Poly2 {
    #[inline]
    fn f_ft_mm(&self, w: f64, z: f64) -> f64 {
        self.c00
            + self.c10 * w
            + self.c01 * z
            + self.c20 * w * w
            + self.c11 * w * z
            + self.c02 * z * z
    }
    #[inline]
    fn gradient(&self, w: f64, z: f64) -> (f64, f64) {
        (
            self.c10 + 2.0 * self.c20 * w + self.c11 * z,
            self.c01 + self.c11 * w + 2.0 * self.c02 * z,
        )
    }
}

/// Crowning in any direction.
///
/// # Formula
/// f_B(w, z) = K_B2·X² + K_B1·X + K_B0, X = w·sin ρ_B + z·cos ρ_B.
/// ρ_B = 0: lead crowning; ρ_B = ±π/2: profile crowning; otherwise directed crowning.
/// # Source
/// JP6903407B2, eq. (103) [SEED].
pub fn crowning(rho_b_rad: f64, k_b0: f64, k_b1: f64, k_b2: f64) -> Poly2 {
    let (s, c) = rho_b_rad.sin_cos();
    Poly2 {
        c00: k_b0,
        c10: k_b1 * s,
        c01: k_b1 * c,
        c20: k_b2 * s * s,
        c11: 2.0 * k_b2 * s * c,
        c02: k_b2 * c * c,
    }
}

/// Sum of two modifications.
#[derive(Debug, Clone, Copy)]
pub struct Sum<'a, A: ?Sized, B: ?Sized>(pub &'a A, pub &'a B);

impl<A: FlankModification + ?Sized, B: FlankModification + ?Sized> FlankModification
    for Sum<'_, A, B>
{
    fn f_ft_mm(&self, w: f64, z: f64) -> f64 {
        self.0.f_ft_mm(w, z) + self.1.f_ft_mm(w, z)
    }
    fn gradient(&self, w: f64, z: f64) -> (f64, f64) {
        let (a, b) = (self.0.gradient(w, z), self.1.gradient(w, z));
        (a.0 + b.0, a.1 + b.1)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Composition with an affine map agrees with evaluating at the mapped point.
        #[test]
        fn compose_affine_is_exact(
            coeffs in proptest::collection::vec(-2.0f64..2.0, 0..5),
            k in -3.0f64..3.0, c in -3.0f64..3.0, x in -3.0f64..3.0,
        ) {
            let p = Poly(coeffs);
            let q = p.compose_affine(k, c);
            prop_assert!((q.eval(x) - p.eval(k * x + c)).abs() < 1e-9 * (1.0 + p.eval(k * x + c).abs()));
        }

        /// Analytic gradients agree with central differences.
        #[test]
        fn gradients_match_differences(rho in -1.5f64..1.5, w in 5.0f64..30.0, z in -20.0f64..20.0) {
            let m = LineModification::new(rho, 17.0, Poly(vec![1e-3, 2e-4, 3e-6]),
                Poly(vec![1e-4, -2e-6]), Poly(vec![-3e-5, 1e-7])).unwrap();
            let (gw, gz) = m.gradient(w, z);
            let h = 1e-4;
            let fw = (m.f_ft_mm(w + h, z) - m.f_ft_mm(w - h, z)) / (2.0 * h);
            let fz = (m.f_ft_mm(w, z + h) - m.f_ft_mm(w, z - h)) / (2.0 * h);
            prop_assert!((gw - fw).abs() < 1e-9 && (gz - fz).abs() < 1e-9);
            let p = crowning(rho, 1e-3, 2e-4, -3e-5);
            let (gw, gz) = p.gradient(w, z);
            let fw = (p.f_ft_mm(w + h, z) - p.f_ft_mm(w - h, z)) / (2.0 * h);
            let fz = (p.f_ft_mm(w, z + h) - p.f_ft_mm(w, z - h)) / (2.0 * h);
            prop_assert!((gw - fw).abs() < 1e-9 && (gz - fz).abs() < 1e-9);
        }
    }

    /// (103): a crowning is constant along lines ⊥ its direction and quadratic along it.
    #[test]
    fn crowning_103_closed_form() {
        let rho = 0.4f64;
        let p = crowning(rho, 0.0, 0.0, 2e-4);
        // along the iso-line direction (cos ρ, −sin ρ) X does not change
        let (w, z) = (12.0, 3.0);
        let f0 = p.f_ft_mm(w, z);
        let f1 = p.f_ft_mm(w + 5.0 * rho.cos(), z - 5.0 * rho.sin());
        assert!((f0 - f1).abs() < 1e-15);
        let x = w * rho.sin() + z * rho.cos();
        assert!((f0 - 2e-4 * x * x).abs() < 1e-15);
    }

    #[test]
    fn bad_line_modification_is_rejected() {
        assert!(LineModification::new(
            f64::NAN,
            0.0,
            Poly::default(),
            Poly::default(),
            Poly::default()
        )
        .is_err());
        assert!(LineModification::new(
            0.1,
            0.0,
            Poly(vec![f64::INFINITY]),
            Poly::default(),
            Poly::default()
        )
        .is_err());
    }
}
