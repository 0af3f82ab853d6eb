//! Multiple linear regression by Householder QR (never the normal equations), with
//! standard errors, R², RMSE and residuals; ridge regression by QR of the augmented system.

use crate::error::{invalid, IdentifyError, Result};
use nalgebra::{DMatrix, DVector};

/// Relative pivot threshold below which R is called rank deficient.
const RANK_TOL: f64 = 1e-11;

/// `v > threshold`, false for NaN: a pivot or spread that is NaN counts as too small.
pub(crate) fn exceeds(v: f64, threshold: f64) -> bool {
    v > threshold
}

/// A least-squares fit y ≈ b0 + Σ b_j·x_j.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearFit {
    /// Intercept first, then one coefficient per column.
    pub coefficients: Vec<f64>,
    /// Standard error of each coefficient (same order); for ridge, the OLS formula
    /// applied to the ridge solution is not meaningful, so these are NaN.
    pub std_errors: Vec<f64>,
    /// Coefficient of determination on the fitted rows.
    pub r2: f64,
    /// Root-mean-square residual on the fitted rows (same unit as y).
    pub rmse: f64,
    /// Residual sum of squares Q.
    pub sse: f64,
    /// Residuals y − ŷ on the fitted rows.
    pub residuals: Vec<f64>,
}

impl LinearFit {
    /// Prediction b0 + Σ b_j·x_j for one row of regressor values.
    pub fn predict(&self, row: &[f64]) -> f64 {
        self.coefficients[0]
            + self.coefficients[1..]
                .iter()
                .zip(row)
                .map(|(b, x)| b * x)
                .sum::<f64>()
    }
}

/// A regression on `regressors` columns and an intercept needs one row more than its
/// coefficients (a residual degree of freedom for σ̂).
fn enough_rows(regressors: usize, n: usize) -> Result<()> {
    let p = regressors + 1;
    if n < p + 1 {
        return Err(IdentifyError::TooFewRows {
            what: format!("regression on {regressors} regressors"),
            rows: n,
            needed: p + 1,
        });
    }
    Ok(())
}

fn design(columns: &[&[f64]], y: &[f64], names: &[String]) -> Result<DMatrix<f64>> {
    let n = y.len();
    let p = columns.len() + 1;
    enough_rows(columns.len(), n)?;
    for (j, c) in columns.iter().enumerate() {
        if c.len() != n {
            return Err(invalid(
                &format!("column {}", names.get(j).map_or("?", |s| s)),
                format!("{} rows", c.len()),
                &format!("{n} rows, as the target"),
            ));
        }
    }
    Ok(DMatrix::from_fn(n, p, |i, j| {
        if j == 0 {
            1.0
        } else {
            columns[j - 1][i]
        }
    }))
}

/// Solves min ‖a·b − y‖ by Householder QR of `a` (full column rank required).
///
/// Returns the solution and R⁻¹ (for the covariance). `names` label an error.
pub fn lstsq_qr(
    a: DMatrix<f64>,
    y: &DVector<f64>,
    names: &[String],
) -> Result<(DVector<f64>, DMatrix<f64>)> {
    let s = QrSolver::new(a, names)?;
    Ok((s.solve(y)?, s.r_inv))
}

/// One Householder QR of a design, solving for any number of right-hand sides (the same
/// figures as a QR per right-hand side: the factorisation does not depend on it).
struct QrSolver<'a> {
    qr: nalgebra::linalg::QR<f64, nalgebra::Dyn, nalgebra::Dyn>,
    r: DMatrix<f64>,
    r_inv: DMatrix<f64>,
    min_pivot: f64,
    max_pivot: f64,
    names: &'a [String],
}

impl<'a> QrSolver<'a> {
    fn new(a: DMatrix<f64>, names: &'a [String]) -> Result<Self> {
        let p = a.ncols();
        let qr = a.qr();
        let r = qr.r();
        let max_pivot = (0..p).map(|j| r[(j, j)].abs()).fold(0.0, f64::max);
        let min_pivot = (0..p)
            .map(|j| r[(j, j)].abs())
            .fold(f64::INFINITY, f64::min);
        if !exceeds(min_pivot, RANK_TOL * max_pivot) {
            return Err(IdentifyError::RankDeficient {
                columns: names.join(", "),
                pivot: min_pivot,
                tolerance: RANK_TOL * max_pivot,
            });
        }
        let r_inv = r
            .solve_upper_triangular(&DMatrix::identity(p, p))
            .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
        Ok(Self {
            qr,
            r,
            r_inv,
            min_pivot,
            max_pivot,
            names,
        })
    }

    fn solve(&self, y: &DVector<f64>) -> Result<DVector<f64>> {
        let p = self.r.ncols();
        let mut qty = y.clone();
        self.qr.q_tr_mul(&mut qty);
        let rhs = qty.rows(0, p).into_owned();
        self.r
            .solve_upper_triangular(&rhs)
            .ok_or_else(|| IdentifyError::RankDeficient {
                columns: self.names.join(", "),
                pivot: self.min_pivot,
                tolerance: RANK_TOL * self.max_pivot,
            })
    }
}

fn summarise(
    coefficients: Vec<f64>,
    std_errors: Vec<f64>,
    a: &DMatrix<f64>,
    y: &[f64],
) -> LinearFit {
    let b = DVector::from_column_slice(&coefficients);
    let fitted = a * &b;
    summarise_fitted(coefficients, std_errors, fitted.as_slice(), y)
}

/// The fitted values [1 X]·b of the design [`design`] builds from `columns` (n rows), bit
/// for bit what nalgebra's `a * b` gives: its gemv starts from the first column times b0
/// (here 1·b0) and adds x_j·b_j column after column.
fn fitted_of(coefficients: &[f64], columns: &[&[f64]], n: usize) -> Vec<f64> {
    let mut fitted = vec![coefficients[0]; n];
    for (&b, x) in coefficients[1..].iter().zip(columns) {
        for (f, &xi) in fitted.iter_mut().zip(&x[..n]) {
            // nalgebra's x_j·b_j + y, the same sum (addition commutes exactly).
            *f += xi * b;
        }
    }
    fitted
}

/// [`summarise`] from the fitted values.
fn summarise_fitted(
    coefficients: Vec<f64>,
    std_errors: Vec<f64>,
    fitted: &[f64],
    y: &[f64],
) -> LinearFit {
    let n = y.len();
    let residuals: Vec<f64> = y.iter().zip(fitted.iter()).map(|(y, f)| y - f).collect();
    let sse: f64 = residuals.iter().map(|e| e * e).sum();
    let mean = y.iter().sum::<f64>() / n as f64;
    let sst: f64 = y.iter().map(|v| (v - mean) * (v - mean)).sum();
    LinearFit {
        coefficients,
        std_errors,
        r2: if sst > 0.0 { 1.0 - sse / sst } else { f64::NAN },
        rmse: (sse / n as f64).sqrt(),
        sse,
        residuals,
    }
}

/// Ordinary least squares with intercept, by Householder QR.
///
/// # Formula
/// y = X·A + ε, X = [1 x_1 … x_p];  Â = argmin ‖y − X·A‖² solved as R·Â = Qᵀy;
/// s.e.(Â_j) = σ̂·‖(R⁻¹)_j·‖, σ̂² = Q/(n − p − 1), Q = Σ residual²
/// # Source
/// CN105397560, [0026]–[0036], eqs. (3)–(5) (docs/identification.md) [RECONSTRUCTED]; QR instead of the
/// normal equations of eq. (5) for accuracy (same minimiser).
pub fn ols(columns: &[&[f64]], y: &[f64], names: &[String]) -> Result<LinearFit> {
    let mut fits = ols_many(columns, &[y], names)?;
    fits.pop()
        .ok_or_else(|| invalid("targets", "none", "one target"))
}

/// [`ols`] of each target in `ys` on the same `columns`, from one QR of the design (the
/// same fits as one [`ols`] call per target, without refactoring the design each time).
pub fn ols_many(columns: &[&[f64]], ys: &[&[f64]], names: &[String]) -> Result<Vec<LinearFit>> {
    let Some(first) = ys.first() else {
        return Ok(Vec::new());
    };
    let a = design(columns, first, names)?;
    if let Some(y) = ys.iter().find(|y| y.len() != first.len()) {
        return Err(invalid(
            "targets",
            format!("{} and {} rows", first.len(), y.len()),
            "targets of equal length",
        ));
    }
    // The design goes into the factorisation (no copy); the fitted values come from the
    // columns (`fitted_of`: the same figures as the design times the coefficients).
    let solver = QrSolver::new(a, names)?;
    ys.iter()
        .map(|y| {
            let b = solver.solve(&DVector::from_column_slice(y))?;
            let coefficients: Vec<f64> = b.iter().copied().collect();
            Ok(fit_on_rows(coefficients, &solver.r_inv, columns, y))
        })
        .collect()
}

/// The least-squares coefficients of column `ycol` on the columns `cols` of `r`, the R
/// factor of a design [1 X Y] over some rows (`cols[0]` its intercept column 0), and the
/// upper triangle R_s of those columns' own factor (for R⁻¹): since ‖Q·R·v‖ = ‖R·v‖, the
/// minimiser over the rows is the minimiser over the rows of `r`, found by a QR of the small
/// matrix r[:, cols ∪ {ycol}] instead of the rows' design (the same problem, the rounding
/// of another factorisation). `None` when the columns are rank deficient on those rows
/// (|R_jj| ≤ 10⁻¹¹·max |R_ii|, as [`ols`] refuses them) or `r` has too few rows.
pub(crate) fn lstsq_of_r(
    r: &DMatrix<f64>,
    cols: &[usize],
    ycol: usize,
) -> Option<(Vec<f64>, DMatrix<f64>)> {
    let p = cols.len();
    if p == 0 || r.nrows() < p + 1 || cols.iter().chain([&ycol]).any(|&c| c >= r.ncols()) {
        return None;
    }
    let mut idx = cols.to_vec();
    idx.push(ycol);
    let rs = r.select_columns(&idx).qr().r();
    let max_p = (0..p).map(|j| rs[(j, j)].abs()).fold(0.0, f64::max);
    if (0..p).any(|j| !exceeds(rs[(j, j)].abs(), RANK_TOL * max_p)) {
        return None;
    }
    let top = rs.view((0, 0), (p, p)).into_owned();
    let rhs = rs.view((0, p), (p, 1)).into_owned();
    let b = top.solve_upper_triangular(&rhs)?;
    Some((b.iter().copied().collect(), top))
}

/// [`ols`] of `y` on `columns` (training rows) from `r`, the R factor of [1 X Y] over the
/// same rows, whose columns `cols` (intercept column 0 first) are `columns` and whose column
/// `ycol` is `y` ([`lstsq_of_r`]): the coefficients from the small factor, then the
/// residuals, R², RMSE and standard errors from the rows as [`ols`] computes them. The same
/// fit as [`ols`] to rounding (`ols_of_r_is_ols` below); the errors of [`ols`] (too few
/// rows, rank deficient) where it gives them.
pub(crate) fn ols_of_r(
    r: &DMatrix<f64>,
    cols: &[usize],
    ycol: usize,
    columns: &[&[f64]],
    y: &[f64],
    names: &[String],
) -> Result<LinearFit> {
    let n = y.len();
    let p = columns.len() + 1;
    enough_rows(columns.len(), n)?;
    let Some((coefficients, top)) = lstsq_of_r(r, cols, ycol) else {
        // The rows' own factorisation names the deficient column and its pivot.
        return ols(columns, y, names);
    };
    let r_inv = top
        .solve_upper_triangular(&DMatrix::identity(p, p))
        .unwrap_or_else(|| DMatrix::from_element(p, p, f64::NAN));
    Ok(fit_on_rows(coefficients, &r_inv, columns, y))
}

/// The least-squares fit of `coefficients` on the rows of `columns` and `y`: fitted values,
/// residuals, R², RMSE, and the standard errors σ̂·‖(R⁻¹)_j·‖, σ̂² = Q/(n − p).
fn fit_on_rows(
    coefficients: Vec<f64>,
    r_inv: &DMatrix<f64>,
    columns: &[&[f64]],
    y: &[f64],
) -> LinearFit {
    let p = coefficients.len();
    let fitted = fitted_of(&coefficients, columns, y.len());
    let mut fit = summarise_fitted(coefficients, Vec::new(), &fitted, y);
    let sigma = (fit.sse / (y.len() - p) as f64).sqrt();
    fit.std_errors = (0..p).map(|j| sigma * r_inv.row(j).norm()).collect();
    fit
}

/// Ridge regression with an unpenalised intercept, columns standardised on these rows.
///
/// # Formula
/// z_j = (x_j − x̄_j)/s_j; min ‖y − ȳ − Z·β‖² + α·n·‖β‖², solved by QR of [Z; √(α·n)·I];
/// b_j = β_j/s_j, b_0 = ȳ − Σ b_j·x̄_j
/// # Domain
/// α ≥ 0 (α = 0 is OLS); a constant column is an error.
/// # Source
/// Hoerl & Kennard (1970) ridge regression [STANDARD]; α scaled by n so it does not depend
/// on the number of rows (the scikit-learn `Ridge` α equals α·n here).
pub fn ridge(columns: &[&[f64]], y: &[f64], alpha: f64, names: &[String]) -> Result<LinearFit> {
    if !(alpha.is_finite() && alpha >= 0.0) {
        return Err(invalid("ridge alpha", alpha, "α ≥ 0"));
    }
    let a = design(columns, y, names)?;
    let n = y.len();
    let p = columns.len();
    let ym = y.iter().sum::<f64>() / n as f64;
    let mut mean = vec![0.0; p];
    let mut sd = vec![0.0; p];
    for (j, c) in columns.iter().enumerate() {
        mean[j] = c.iter().sum::<f64>() / n as f64;
        sd[j] = (c.iter().map(|v| (v - mean[j]).powi(2)).sum::<f64>() / n as f64).sqrt();
        if !exceeds(sd[j], 0.0) {
            return Err(invalid(
                &format!("column {}", names.get(j).map_or("?", |s| s)),
                "a constant column",
                "a column that varies",
            ));
        }
    }
    let k = (alpha * n as f64).sqrt();
    let aug = DMatrix::from_fn(n + p, p, |i, j| {
        if i < n {
            (columns[j][i] - mean[j]) / sd[j]
        } else if i - n == j {
            k
        } else {
            0.0
        }
    });
    let rhs = DVector::from_fn(n + p, |i, _| if i < n { y[i] - ym } else { 0.0 });
    let (beta, _) = lstsq_qr(aug, &rhs, names)?;
    let mut coefficients = vec![0.0; p + 1];
    coefficients[0] = ym;
    for j in 0..p {
        coefficients[j + 1] = beta[j] / sd[j];
        coefficients[0] -= coefficients[j + 1] * mean[j];
    }
    Ok(summarise(coefficients, vec![f64::NAN; p + 1], &a, y))
}

/// Principal-component regression on the first `k` components of the standardised columns.
///
/// # Formula
/// z_j = (x_j − x̄_j)/s_j (population s_j); Z = U·S·Vᵀ (SVD); β = V_k·S_k⁻¹·U_kᵀ·(y − ȳ);
/// b_j = β_j/s_j, b_0 = ȳ − Σ b_j·x̄_j
/// # Domain
/// 1 ≤ k ≤ number of columns; a constant column is an error.
/// # Source
/// Massy (1965), principal-components regression [STANDARD]; Jolliffe, *Principal
/// Component Analysis* (2002), §8.1.
pub fn pcr(columns: &[&[f64]], y: &[f64], k: usize, names: &[String]) -> Result<LinearFit> {
    let a = design(columns, y, names)?;
    let n = y.len();
    let p = columns.len();
    if k == 0 || k > p {
        return Err(invalid(
            "PCR components",
            k,
            &format!("1 ≤ k ≤ {p} columns"),
        ));
    }
    let ym = y.iter().sum::<f64>() / n as f64;
    let mut mean = vec![0.0; p];
    let mut sd = vec![0.0; p];
    for (j, c) in columns.iter().enumerate() {
        mean[j] = c.iter().sum::<f64>() / n as f64;
        sd[j] = (c.iter().map(|v| (v - mean[j]).powi(2)).sum::<f64>() / n as f64).sqrt();
        if !exceeds(sd[j], 0.0) {
            return Err(invalid(
                &format!("column {}", names.get(j).map_or("?", |s| s)),
                "a constant column",
                "a column that varies",
            ));
        }
    }
    let z = DMatrix::from_fn(n, p, |i, j| (columns[j][i] - mean[j]) / sd[j]);
    let yc = DVector::from_fn(n, |i, _| y[i] - ym);
    let beta = pcr_solve(z, &yc, k, names)?;
    let mut coefficients = vec![0.0; p + 1];
    coefficients[0] = ym;
    for j in 0..p {
        coefficients[j + 1] = beta[j] / sd[j];
        coefficients[0] -= coefficients[j + 1] * mean[j];
    }
    Ok(summarise(coefficients, vec![f64::NAN; p + 1], &a, y))
}

/// β = V_k·S_k⁻¹·U_kᵀ·y of the SVD of `z` (components by decreasing singular value).
pub(crate) fn pcr_solve(
    z: DMatrix<f64>,
    y: &DVector<f64>,
    k: usize,
    names: &[String],
) -> Result<DVector<f64>> {
    let p = z.ncols();
    let svd = gearcomp_linalg::Svd::new(&z)
        .map_err(|_| invalid("PCR", "SVD", "a decomposable matrix"))?;
    let (u, vt) = (&svd.u, &svd.v_t);
    // The singular values come in decreasing order.
    let smax = svd.singular_values.get(0).copied().unwrap_or(0.0);
    let mut beta = DVector::zeros(p);
    for c in 0..k.min(svd.singular_values.len()) {
        let s = svd.singular_values[c];
        if !exceeds(s, RANK_TOL * smax) {
            return Err(IdentifyError::RankDeficient {
                columns: names.join(", "),
                pivot: s,
                tolerance: RANK_TOL * smax,
            });
        }
        let g = u.column(c).dot(y) / s;
        beta += vt.row(c).transpose() * g;
    }
    Ok(beta)
}

/// Rows `parts` stacked in order into one matrix of `cols` columns.
pub(crate) fn stack(parts: &[&DMatrix<f64>], cols: usize) -> DMatrix<f64> {
    let rows: usize = parts.iter().map(|p| p.nrows()).sum();
    let mut out = DMatrix::zeros(rows, cols);
    let mut r0 = 0;
    for p in parts {
        out.rows_mut(r0, p.nrows()).copy_from(*p);
        r0 += p.nrows();
    }
    out
}

/// The R factor of a Householder QR (an empty matrix for no rows): blocked for wide
/// matrices ([`gearcomp_linalg::r_factor`]).
pub(crate) fn r_factor(a: DMatrix<f64>) -> DMatrix<f64> {
    if a.nrows() == 0 {
        return DMatrix::zeros(0, a.ncols());
    }
    gearcomp_linalg::r_factor(a)
}

/// The R factor of the augmented block [1 X Y] over `rows`: intercept, `features`, `targets`.
/// Since ‖Q·R·v‖ = ‖R·v‖, the least-squares fit and the residual of any sub-model on these
/// rows follow from it exactly; the validation engines stack such blocks per fold.
pub(crate) fn augmented_r<F: AsRef<[f64]>, T: AsRef<[f64]>>(
    rows: &[usize],
    features: &[F],
    targets: &[T],
) -> DMatrix<f64> {
    let m = 1 + features.len() + targets.len();
    r_factor(DMatrix::from_fn(rows.len(), m, |r, c| {
        let i = rows[r];
        if c == 0 {
            1.0
        } else if c <= features.len() {
            features[c - 1].as_ref()[i]
        } else {
            targets[c - 1 - features.len()].as_ref()[i]
        }
    }))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn fitted_values_from_the_columns_are_the_design_times_b() {
        let mut u = crate::test_uniform(11);
        let mut next = move || u() * 60.0 - 30.0;
        for c in 0..7 {
            let n = 20 + 9 * c;
            let cols: Vec<Vec<f64>> = (0..c).map(|_| (0..n).map(|_| next()).collect()).collect();
            let refs: Vec<&[f64]> = cols.iter().map(|v| v.as_slice()).collect();
            let y: Vec<f64> = (0..n).map(|_| next()).collect();
            let b: Vec<f64> = (0..=c).map(|_| next()).collect();
            let a = design(&refs, &y, &[]).unwrap();
            let want = &a * DVector::from_column_slice(&b);
            let got = fitted_of(&b, &refs, n);
            for i in 0..n {
                assert_eq!(got[i].to_bits(), want[i].to_bits(), "{c} {i}");
            }
        }
    }

    #[test]
    fn exact_line_and_textbook_standard_errors() {
        // y = 1 + 2x + e with e = (+1, −1, −1, +1): closed forms by hand.
        let x = [0.0, 1.0, 2.0, 3.0];
        let y = [2.0, 2.0, 4.0, 8.0];
        let f = ols(&[&x], &y, &["x".into()]).unwrap();
        // x̄ = 1.5, ȳ = 4, Sxx = 5, Sxy = 10 → slope 2, intercept 1, residuals ±1.
        assert!((f.coefficients[1] - 2.0).abs() < 1e-12);
        assert!((f.coefficients[0] - 1.0).abs() < 1e-12);
        // Q = 4, σ̂² = 4/2, s.e.(slope) = √(2/5), s.e.(b0) = √(2·(1/4 + 1.5²/5)).
        assert!((f.sse - 4.0).abs() < 1e-12);
        assert!((f.std_errors[1] - (2.0f64 / 5.0).sqrt()).abs() < 1e-12);
        assert!((f.std_errors[0] - (2.0f64 * (0.25 + 2.25 / 5.0)).sqrt()).abs() < 1e-12);
        assert!((f.r2 - (1.0 - 4.0 / 24.0)).abs() < 1e-12);
    }

    #[test]
    fn ridge_zero_is_ols_and_shrinks_with_alpha() {
        let x1 = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let x2 = [2.0, 1.0, 4.0, 3.0, 6.0, 5.5];
        let y = [3.1, 3.9, 7.2, 7.8, 11.1, 11.6];
        let names = ["a".to_string(), "b".to_string()];
        let o = ols(&[&x1, &x2], &y, &names).unwrap();
        let r0 = ridge(&[&x1, &x2], &y, 0.0, &names).unwrap();
        for (a, b) in o.coefficients.iter().zip(&r0.coefficients) {
            assert!((a - b).abs() < 1e-10);
        }
        let r1 = ridge(&[&x1, &x2], &y, 1.0, &names).unwrap();
        let norm = |f: &LinearFit| f.coefficients[1..].iter().map(|b| b * b).sum::<f64>();
        assert!(norm(&r1) < norm(&o));
        // Closed form for standardised one-column ridge: β = Sxy/(Sxx + α·n).
        let r = ridge(&[&x1], &y, 0.5, &names[..1]).unwrap();
        let (mx, my) = (3.5, y.iter().sum::<f64>() / 6.0);
        let sxy: f64 = x1.iter().zip(&y).map(|(a, b)| (a - mx) * (b - my)).sum();
        let sxx: f64 = x1.iter().map(|a| (a - mx).powi(2)).sum();
        assert!((r.coefficients[1] - sxy / (sxx + 0.5 * 6.0 * sxx / 6.0)).abs() < 1e-12);
    }

    /// The fit from the R factor of [1 X Y] (one block, or blocks stacked and factorised
    /// again as the validation engine does) is [`ols`] of the rows: coefficients, standard
    /// errors, R² and RMSE to 1e-9 relative, on random designs of 1–6 columns of any subset;
    /// a collinear subset gives [`ols`]'s error.
    #[test]
    fn ols_of_r_is_ols() {
        let mut u = crate::test_uniform(29);
        let mut next = move || u() * 2.0 - 1.0;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()));
        for case in 0..40 {
            let c = 1 + case % 6;
            let n = 12 + 5 * case;
            // Correlated columns on offsets (as temperatures), a target of a few of them.
            let base: Vec<f64> = (0..n).map(|_| next()).collect();
            let cols: Vec<Vec<f64>> = (0..c)
                .map(|j| {
                    (0..n)
                        .map(|i| 20.0 + j as f64 + base[i] * (1.0 + j as f64) + 0.3 * next())
                        .collect()
                })
                .collect();
            let y: Vec<f64> = (0..n)
                .map(|i| 3.0 + (0..c).map(|j| cols[j][i] * (j as f64 - 1.5)).sum::<f64>() + next())
                .collect();
            let rows: Vec<usize> = (0..n).collect();
            let r = if case % 2 == 0 {
                augmented_r(&rows, &cols, &[&y])
            } else {
                let (a, b) = rows.split_at(n / 3);
                let parts = [augmented_r(a, &cols, &[&y]), augmented_r(b, &cols, &[&y])];
                r_factor(stack(&[&parts[0], &parts[1]], c + 2))
            };
            // Every other column subset (bit mask), the intercept always in.
            for mask in 1..(1u32 << c) {
                let pick: Vec<usize> = (0..c).filter(|&j| mask >> j & 1 == 1).collect();
                let refs: Vec<&[f64]> = pick.iter().map(|&j| cols[j].as_slice()).collect();
                let names: Vec<String> = pick.iter().map(|j| format!("x{j}")).collect();
                let mut rc = vec![0usize];
                rc.extend(pick.iter().map(|&j| j + 1));
                let want = ols(&refs, &y, &names);
                let got = ols_of_r(&r, &rc, c + 1, &refs, &y, &names);
                match (want, got) {
                    (Ok(w), Ok(g)) => {
                        for (a, b) in w.coefficients.iter().zip(&g.coefficients) {
                            assert!(close(*a, *b), "case {case} {pick:?}: {a} vs {b}");
                        }
                        for (a, b) in w.std_errors.iter().zip(&g.std_errors) {
                            assert!(close(*a, *b), "case {case} {pick:?}: se {a} vs {b}");
                        }
                        assert!(close(w.r2, g.r2) && close(w.rmse, g.rmse), "case {case}");
                        assert_eq!(w.residuals.len(), g.residuals.len());
                    }
                    (Err(w), Err(g)) => assert_eq!(w.to_string(), g.to_string()),
                    (w, g) => panic!("case {case} {pick:?}: {w:?} vs {g:?}"),
                }
            }
        }
        // A duplicated column: rank deficient from the factor as from the rows.
        let x = [1.0, 2.0, 3.0, 4.0, 6.0, 7.0];
        let y = [1.0, 2.0, 3.0, 5.0, 4.0, 8.0];
        let rows: Vec<usize> = (0..6).collect();
        let r = augmented_r(&rows, &[&x, &x], &[&y]);
        let names = ["a".to_string(), "b".to_string()];
        let e = ols_of_r(&r, &[0, 1, 2], 3, &[&x, &x], &y, &names).unwrap_err();
        assert!(e.to_string().contains("rank deficient"), "{e}");
        assert!(lstsq_of_r(&r, &[0, 1, 2], 3).is_none());
    }

    #[test]
    fn collinear_columns_are_reported() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let e = ols(&[&x, &x], &[1.0, 2.0, 3.0, 5.0], &["a".into(), "b".into()]).unwrap_err();
        assert!(e.to_string().contains("rank deficient"), "{e}");
    }
}
