//! The dense decompositions gearcomp's crates share, on nalgebra matrices.
//!
//! - [`r_factor`]: the R factor of a Householder QR, blocked (faer) for wide matrices.
//! - [`Svd`]: the thin singular value decomposition A = U·Σ·Vᵀ (singular values in
//!   decreasing order), its least-squares solve with a cut on small singular values
//!   ([`Svd::solve`]), and [`singular_values`].
//!
//! The factorisation is faer's. nalgebra's own SVD (bidiagonalisation and implicitly shifted
//! QR) returns, for some matrices with close singular values, factors whose product misses A
//! by up to 1e-2 relative while U and V stay orthonormal (dimforge/nalgebra#1172, open, and
//! the same in nalgebra 0.33 to 0.35). Such matrices are ordinary here: a column of ones beside
//! centred, unit-norm sensor columns has a singular value of exactly 1 and others near it. The
//! tests below build them and hold the factors to the definition: U·Σ·Vᵀ = A to 1e-13
//! relative, UᵀU = VᵀV = I, Σ decreasing and non-negative.
//!
//! ```
//! use nalgebra::{DMatrix, DVector};
//! let a = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 1.0, 1.0, 1.0, 2.0]);
//! let svd = gearcomp_linalg::Svd::new(&a)?;
//! // Least squares of y = 1 + 2x through three exact points.
//! let b = svd.solve(&DVector::from_column_slice(&[1.0, 3.0, 5.0]), 1e-12);
//! assert!((b[0] - 1.0).abs() < 1e-12 && (b[1] - 2.0).abs() < 1e-12);
//! # Ok::<(), gearcomp_linalg::LinalgError>(())
//! ```

use nalgebra::{DMatrix, DVector};

/// What can go wrong in a decomposition.
#[derive(Debug, thiserror::Error)]
pub enum LinalgError {
    /// The iteration did not converge (a matrix with a NaN or an infinity in it, say).
    #[error("the SVD of a {rows}×{cols} matrix did not converge (a NaN or an infinite entry?)")]
    NoConvergence {
        /// Rows of the matrix.
        rows: usize,
        /// Columns of the matrix.
        cols: usize,
    },
}

/// The thin SVD A = U·Σ·Vᵀ of an m×n matrix: U m×k, Σ k, Vᵀ k×n with k = min(m, n), the
/// singular values in decreasing order.
#[derive(Debug, Clone)]
pub struct Svd {
    /// The left singular vectors, one column each.
    pub u: DMatrix<f64>,
    /// The singular values, decreasing, non-negative.
    pub singular_values: DVector<f64>,
    /// The right singular vectors, one row each.
    pub v_t: DMatrix<f64>,
}

impl Svd {
    /// The thin SVD of `a`. An empty matrix has an empty decomposition.
    pub fn new(a: &DMatrix<f64>) -> Result<Self, LinalgError> {
        let (m, n) = a.shape();
        let k = m.min(n);
        if k == 0 {
            return Ok(Self {
                u: DMatrix::zeros(m, 0),
                singular_values: DVector::zeros(0),
                v_t: DMatrix::zeros(0, n),
            });
        }
        let err = LinalgError::NoConvergence { rows: m, cols: n };
        if a.iter().any(|v| !v.is_finite()) {
            return Err(err);
        }
        let fa = faer::Mat::<f64>::from_fn(m, n, |i, j| a[(i, j)]);
        let svd = fa.thin_svd().map_err(|_| err)?;
        let (u, s, v) = (svd.U(), svd.S().column_vector(), svd.V());
        // faer orders them already; the order is part of this type's contract, so it is
        // made explicit (a stable sort keeps faer's order among equal values).
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&x, &y| s[y].total_cmp(&s[x]));
        Ok(Self {
            u: DMatrix::from_fn(m, k, |i, c| u[(i, order[c])]),
            singular_values: DVector::from_fn(k, |c, _| s[order[c]]),
            v_t: DMatrix::from_fn(k, n, |c, j| v[(j, order[c])]),
        })
    }

    /// x = V·Σ⁺·Uᵀ·b, the singular values at or below `eps` (absolute) taken as zero: the
    /// least-squares solution of A·x ≈ b of least norm among those the cut leaves.
    pub fn solve(&self, b: &DVector<f64>, eps: f64) -> DVector<f64> {
        let c = self.u.transpose() * b;
        let mut x = DVector::zeros(self.v_t.ncols());
        for (k, &s) in self.singular_values.iter().enumerate() {
            if s > eps {
                x.axpy(c[k] / s, &self.v_t.row(k).transpose(), 1.0);
            }
        }
        x
    }
}

/// The singular values of `a`, decreasing.
pub fn singular_values(a: &DMatrix<f64>) -> Result<DVector<f64>, LinalgError> {
    Svd::new(a).map(|s| s.singular_values)
}

/// Columns from which [`r_factor`] uses faer's blocked Householder QR. `cargo run --release
/// -p gearcomp-linalg --example qr_threshold` (medians of alternating runs, two runs on this
/// project's 2-core machine), nalgebra against faer: 1440 × 24 0.60–0.62 against
/// 0.74–0.77 ms (nalgebra faster), 1440 × 48 1.5–2.3 against 1.4–2.2 ms (even),
/// 1440 × 96 7.0–8.6 against 4.6–5.7 ms, 1440 × 214 31–37 against 13–15 ms. The switch
/// sits where faer is clearly ahead; the fixed kinds' designs (≈ 20 columns) stay on
/// nalgebra.
pub const BLOCKED_QR_MIN_COLS: usize = 96;

/// The R factor of a Householder QR of `a` (m × n): min(m, n) × n, upper triangular, with
/// RᵀR = AᵀA (its rows' signs are the factorisation's own). From
/// [`BLOCKED_QR_MIN_COLS`] columns on the factorisation is faer's blocked one, below them
/// nalgebra's. An empty matrix has an empty factor.
pub fn r_factor(a: DMatrix<f64>) -> DMatrix<f64> {
    let (m, n) = a.shape();
    if m == 0 || n == 0 {
        return DMatrix::zeros(m.min(n), n);
    }
    if n < BLOCKED_QR_MIN_COLS {
        return a.qr().r();
    }
    let fa = faer::MatRef::from_column_major_slice(a.as_slice(), m, n);
    let qr = fa.qr();
    let r = qr.thin_R();
    DMatrix::from_fn(m.min(n), n, |i, j| if j >= i { r[(i, j)] } else { 0.0 })
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A uniform generator on [0, 1) (splitmix64), so a seed names a matrix.
    fn uniform(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The design matrices of a least-squares fit on sensors: a column of ones scaled to
    /// unit norm beside 1–5 centred unit-norm columns that drift together (one random walk
    /// plus a little noise each), n rows. The ones column is orthogonal to the others, so
    /// 1 is a singular value and the others cluster near it when the drifts differ: the
    /// case nalgebra's SVD gets wrong.
    fn design(seed: u64) -> DMatrix<f64> {
        let mut u = uniform(seed);
        let n = 20 + (u() * 600.0) as usize;
        let p = 1 + (u() * 5.0) as usize;
        let mut walk = 0.0;
        let drift: Vec<f64> = (0..n)
            .map(|_| {
                walk += u() - 0.5;
                walk
            })
            .collect();
        let mut cols: Vec<Vec<f64>> = vec![vec![1.0; n]];
        for _ in 0..p {
            let gain = 0.5 + u();
            let noise = 0.05 + u();
            cols.push(
                drift
                    .iter()
                    .map(|d| gain * d + noise * (u() - 0.5))
                    .collect(),
            );
        }
        for (j, c) in cols.iter_mut().enumerate() {
            let mean = if j == 0 {
                0.0
            } else {
                c.iter().sum::<f64>() / n as f64
            };
            c.iter_mut().for_each(|v| *v -= mean);
            let norm = c.iter().map(|v| v * v).sum::<f64>().sqrt();
            c.iter_mut().for_each(|v| *v /= norm);
        }
        DMatrix::from_fn(n, p + 1, |i, j| cols[j][i])
    }

    /// A general random matrix: m×n of 1–40 each, entries of mixed scale, sometimes of
    /// deficient rank (a column repeated).
    fn general(seed: u64) -> DMatrix<f64> {
        let mut u = uniform(seed);
        let m = 1 + (u() * 40.0) as usize;
        let n = 1 + (u() * 40.0) as usize;
        let scale = 10f64.powf(6.0 * u() - 3.0);
        let mut a = DMatrix::from_fn(m, n, |_, _| scale * (u() - 0.5));
        if n > 1 && u() < 0.3 {
            let col = a.column(0).clone_owned();
            a.set_column(n - 1, &col);
        }
        a
    }

    fn check_definition(a: &DMatrix<f64>) -> Result<(), String> {
        let svd = Svd::new(a).map_err(|e| e.to_string())?;
        let k = a.nrows().min(a.ncols());
        let s = &svd.singular_values;
        if s.len() != k || svd.u.shape() != (a.nrows(), k) || svd.v_t.shape() != (k, a.ncols()) {
            return Err(format!(
                "shapes {:?} {} {:?}",
                svd.u.shape(),
                s.len(),
                svd.v_t.shape()
            ));
        }
        if s.iter().any(|&v| v < 0.0) || s.as_slice().windows(2).any(|w| w[1] > w[0]) {
            return Err(format!("singular values not decreasing: {s:?}"));
        }
        let rec = &svd.u * DMatrix::from_diagonal(s) * &svd.v_t;
        let rel = (&rec - a).norm() / a.norm().max(f64::MIN_POSITIVE);
        if rel > 1e-13 {
            return Err(format!("U·Σ·Vᵀ misses A by {rel:e} relative"));
        }
        let eye = DMatrix::<f64>::identity(k, k);
        let ou = (svd.u.transpose() * &svd.u - &eye).norm();
        let ov = (&svd.v_t * svd.v_t.transpose() - &eye).norm();
        if ou > 1e-13 || ov > 1e-13 {
            return Err(format!("orthogonality UᵀU {ou:e}, VᵀV {ov:e}"));
        }
        Ok(())
    }

    /// The least-squares solve against its definition: the residual is orthogonal to the
    /// columns (normal equations Aᵀ(b − A·x) = 0), checked on full-rank designs.
    fn check_solve(a: &DMatrix<f64>, seed: u64) -> Result<(), String> {
        let mut u = uniform(seed ^ 0xb);
        let b = DVector::from_fn(a.nrows(), |_, _| u() - 0.5);
        let svd = Svd::new(a).map_err(|e| e.to_string())?;
        let x = svd.solve(&b, 1e-12 * svd.singular_values[0]);
        let g = a.transpose() * (&b - a * &x);
        if g.amax() > 1e-12 * b.norm() {
            return Err(format!("Aᵀ·r = {:e}", g.amax()));
        }
        Ok(())
    }

    #[test]
    fn designs_with_close_singular_values_are_decomposed_to_the_definition() {
        for seed in 0..200 {
            let a = design(seed);
            check_definition(&a)
                .map_err(|e| format!("seed {seed}: {e}"))
                .unwrap();
            check_solve(&a, seed)
                .map_err(|e| format!("seed {seed}: {e}"))
                .unwrap();
        }
    }

    #[test]
    fn general_matrices_are_decomposed_to_the_definition() {
        for seed in 0..200 {
            check_definition(&general(seed))
                .map_err(|e| format!("seed {seed}: {e}"))
                .unwrap();
        }
    }

    #[test]
    fn a_rank_deficient_system_gets_the_least_norm_solution() {
        // Two equal columns: x1 + x2 = 2 on every row; the least-norm answer splits evenly.
        let a = DMatrix::from_row_slice(3, 2, &[1.0, 1.0, 2.0, 2.0, 3.0, 3.0]);
        let b = DVector::from_column_slice(&[2.0, 4.0, 6.0]);
        let svd = Svd::new(&a).unwrap();
        let x = svd.solve(&b, 1e-12 * svd.singular_values[0]);
        assert!(
            (x[0] - 1.0).abs() < 1e-12 && (x[1] - 1.0).abs() < 1e-12,
            "{x:?}"
        );
    }

    #[test]
    fn empty_and_non_finite_matrices() {
        let e = Svd::new(&DMatrix::zeros(0, 3)).unwrap();
        assert_eq!(
            (e.u.shape(), e.singular_values.len(), e.v_t.shape()),
            ((0, 0), 0, (0, 3))
        );
        let mut a = DMatrix::from_element(3, 2, 1.0);
        a[(1, 1)] = f64::NAN;
        let msg = Svd::new(&a).unwrap_err().to_string();
        assert!(msg.contains("3×2"), "{msg}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Fresh seeds each run: both kinds of matrix, the same checks.
        #[test]
        fn fresh_matrices_are_decomposed_to_the_definition(seed in 0u64..u64::MAX) {
            prop_assert!(check_definition(&design(seed)).is_ok(), "{:?}", check_definition(&design(seed)));
            prop_assert!(check_solve(&design(seed), seed).is_ok(), "{:?}", check_solve(&design(seed), seed));
            prop_assert!(check_definition(&general(seed)).is_ok(), "{:?}", check_definition(&general(seed)));
        }
    }

    /// [`r_factor`] against its definition and against an unblocked Householder QR written
    /// out here (the reference): R upper triangular of min(m, n) rows, RᵀR = AᵀA, and each
    /// row the reference's up to its sign, for matrices on both sides of the blocked
    /// threshold (tall, square, wide, with a column of ones and a repeated column).
    fn check_r_factor(seed: u64) -> Result<(), String> {
        let mut u = uniform(seed);
        let n =
            [1, 5, 40, BLOCKED_QR_MIN_COLS - 1, BLOCKED_QR_MIN_COLS, 130][(u() * 6.0) as usize % 6];
        let m = match (u() * 3.0) as usize {
            0 => n + (u() * 300.0) as usize,
            1 => n,
            _ => 1 + (u() * n as f64) as usize,
        };
        let mut a = DMatrix::from_fn(m, n, |_, _| u() * 2.0 - 1.0);
        a.column_mut(0).fill(1.0);
        if n > 3 {
            let c = a.column(1).clone_owned();
            a.set_column(n - 1, &c);
        }
        let r = r_factor(a.clone());
        let k = m.min(n);
        if r.shape() != (k, n) {
            return Err(format!("{m}×{n}: R is {:?}", r.shape()));
        }
        let scale = a.norm_squared().max(1.0);
        for i in 0..k {
            for j in 0..i {
                if r[(i, j)] != 0.0 {
                    return Err(format!("{m}×{n}: R[{i},{j}] = {}", r[(i, j)]));
                }
            }
        }
        let gap = (r.transpose() * &r - a.transpose() * &a).amax();
        if gap > 1e-12 * scale {
            return Err(format!("{m}×{n}: |RᵀR − AᵀA| = {gap:e}"));
        }
        // The reference: Householder reflections column by column.
        let mut w = a.clone();
        for j in 0..k {
            let x = w.view((j, j), (m - j, 1)).clone_owned();
            let alpha = -x[0].signum() * x.norm();
            let mut v = x;
            v[0] -= alpha;
            let vn = v.norm_squared();
            if vn > 0.0 {
                for c in j..n {
                    let d = v.dot(&w.view((j, c), (m - j, 1)));
                    for i in 0..m - j {
                        w[(j + i, c)] -= 2.0 * d / vn * v[i];
                    }
                }
            }
        }
        // Rows of full rank (above the repeated column) agree up to sign.
        let full = if n > 3 { (n - 1).min(k) } else { k };
        for i in 0..full {
            let s = if (r[(i, i)] >= 0.0) == (w[(i, i)] >= 0.0) {
                1.0
            } else {
                -1.0
            };
            for j in i..n {
                let d = (r[(i, j)] - s * w[(i, j)]).abs();
                if d > 1e-9 * scale.sqrt() {
                    return Err(format!(
                        "{m}×{n}: R[{i},{j}] = {} against {}",
                        r[(i, j)],
                        w[(i, j)]
                    ));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn r_factor_is_the_householder_r() {
        for seed in 0..60 {
            check_r_factor(seed).unwrap();
        }
        assert_eq!(r_factor(DMatrix::zeros(0, 4)).shape(), (0, 4));
        assert_eq!(r_factor(DMatrix::zeros(3, 0)).shape(), (0, 0));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]
        #[test]
        fn fresh_r_factors_are_the_householder_r(seed in 0u64..u64::MAX) {
            let got = check_r_factor(seed);
            prop_assert!(got.is_ok(), "{:?}", got);
        }
    }
}
