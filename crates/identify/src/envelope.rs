//! Extrapolation awareness (issue 12): the training envelope of a model's inputs, rows
//! outside it, and prediction intervals.
//!
//! The envelope holds each channel's training range and a leverage bound on the model's
//! regressors (`gearcomp_core::model::Envelope`). The 95 % prediction interval of a row is
//! ŷ ± 1.96·σ_v·√(1 + h), σ_v the validation RMSE (the honest out-of-sample scale, not the
//! training residual) and h the row's leverage 1/n + d²/(n − 1).
//!
//! For a least-squares fit d² is the Mahalanobis distance of the regressors from their
//! training mean, and h the hat-matrix leverage. For a ridge fit (α > 0) h is the leverage
//! of the ridge fit itself: the variance of its prediction per unit noise variance. It
//! weighs a direction of the regressors by λ/(λ + α)² instead of 1/λ (λ an eigenvalue of
//! their correlation matrix), so a repeat run whose lag-minus-value noise differs from the
//! training runs' (directions of tiny λ, which the ridge fit shrinks away) is not taken for
//! an extrapolation, while a run hotter than any training run still is.

use crate::data::Table;
use crate::error::Result;
use crate::fit::{input_index, regressor_series, TrainRows};
use crate::transform::transform_segments;
use gearcomp_core::model::{ChannelRange, Envelope, LinearModel};
use nalgebra::DMatrix;
use std::borrow::Cow;

/// The regressor series of each term of `model` over the table (engine semantics).
pub fn regressors(table: &Table, model: &LinearModel) -> Result<Vec<Vec<f64>>> {
    let segs = table.segment_ranges();
    model
        .terms
        .iter()
        .map(|t| {
            let i = input_index(table, &t.channel)?;
            transform_segments(&table.time_s, &table.inputs[i], t.transform, &segs)
        })
        .collect()
}

/// `Envelope::d2` of each of the first `n` rows of the regressor series `feats`, bit for
/// bit: the same products added in the same order (each sum from −0.0, as
/// `Iterator::sum`), one row of W at a time over all rows instead of row by row.
fn d2_of_rows(env: &Envelope, feats: &[Cow<[f64]>], n: usize) -> Vec<f64> {
    let p = env.feature_mean.len();
    if p == 0 || env.whitening.len() != p * p || feats.len() != p {
        return vec![0.0; n];
    }
    let mut d2 = vec![-0.0f64; n];
    let mut s = vec![-0.0f64; n];
    for w_row in env.whitening.chunks(p) {
        s.fill(-0.0);
        for ((&w, &m), x) in w_row.iter().zip(&env.feature_mean).zip(feats) {
            // A zero weight (the upper triangle of a least-squares W) adds ±0 to each sum,
            // which changes no sum's square: skipped, bit for bit the same d² (the regressors
            // of a fit are finite).
            if w == 0.0 {
                continue;
            }
            for (si, &xi) in s.iter_mut().zip(&x[..n]) {
                *si += w * (xi - m);
            }
        }
        for (di, si) in d2.iter_mut().zip(&s) {
            *di += si.powi(2);
        }
    }
    d2
}

/// How a model's coefficients were fitted, which decides its leverage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FitKind {
    /// Least squares: the Mahalanobis distance.
    LeastSquares,
    /// Ridge regression with this α (standardised regressors, penalty α·n).
    Ridge(f64),
    /// Principal-component regression on this many leading components.
    Components(usize),
}

impl FitKind {
    /// The kind of a target's kept model.
    pub fn of(m: &crate::fit::TargetModel) -> Self {
        match (m.ridge_alpha, m.pcr_components) {
            (Some(a), _) if a > 0.0 && a.is_finite() => FitKind::Ridge(a),
            (_, Some(k)) if k > 0 => FitKind::Components(k),
            _ => FitKind::LeastSquares,
        }
    }
}

/// The envelope of `model` over the training rows (`axis` names the model file's axis);
/// `kind`: how the model was fitted (the leverage of that fit bounds the regressors).
///
/// # Formula
/// Least squares: W = √(n − 1)·R⁻ᵀ, Xc = Q·R the centred training regressors.
/// Ridge: Z = Xc·S⁻¹ (population standard deviations s_j, as the fit standardises),
/// Z = Q·R_z, A = R_zᵀ·R_z + α·n·I, W = √(n − 1)·R_z·A⁻¹·S⁻¹, so that
/// ‖W·(x − x̄)‖²/(n − 1) = zᵀA⁻¹ZᵀZ·A⁻¹z, the ridge prediction's variance over σ².
/// Principal components (k): Z = U·Σ·Vᵀ, W's rows √(n − 1)·v_iᵀ·S⁻¹/σ_i for the k largest
/// σ_i and zero rows for the others (the fit ignores those directions).
/// max_d2 = the largest d² = ‖W·(x − x̄)‖² over the training rows.
/// # Source
/// Hoaglin & Welsch (1978), the hat matrix; Walker & Birch (1988), *Influence measures in
/// ridge regression*, Technometrics 30, the ridge hat matrix [STANDARD].
pub fn training_envelope(
    table: &Table,
    train: &[bool],
    axis: &str,
    model: &LinearModel,
    kind: FitKind,
) -> Result<Envelope> {
    let all = regressor_series(table, model)?;
    let rows = TrainRows::new(train);
    let feats: Vec<Cow<[f64]>> = all.iter().map(|f| rows.of(f)).collect();
    let mut env = unbounded_envelope(table, &rows, axis, model, kind, &feats)?;
    if !env.whitening.is_empty() {
        env.max_d2 = max_training_d2(&env, &feats);
    }
    Ok(env)
}

/// [`training_envelope`] and [`rows_outside_and_intervals`] at once for a validation RMSE
/// `sigma_v`: the same envelope, flags and half-widths, bit for bit, with d² computed once
/// per row (the bound is its largest value over the training rows).
pub fn training_envelope_and_rows(
    table: &Table,
    train: &[bool],
    axis: &str,
    model: &LinearModel,
    kind: FitKind,
    sigma_v: f64,
) -> Result<(Envelope, Vec<bool>, Vec<f64>)> {
    let all = regressor_series(table, model)?;
    let rows = TrainRows::new(train);
    let mut env = {
        let feats: Vec<Cow<[f64]>> = all.iter().map(|f| rows.of(f)).collect();
        unbounded_envelope(table, &rows, axis, model, kind, &feats)?
    };
    let n = table.time_s.len();
    let d2 = d2_of_rows(&env, &all, n);
    if !env.whitening.is_empty() {
        env.max_d2 = d2
            .iter()
            .zip(train)
            .filter(|(_, &m)| m)
            .fold(0.0, |a, (&v, _)| f64::max(a, v));
    }
    let (outside, half) = outside_and_intervals(table, &env, &d2, sigma_v)?;
    Ok((env, outside, half))
}

/// The envelope of [`training_envelope`] with `max_d2` left at 0: the ranges, and the
/// whitening where the fit bounds the regressors (`feats`: the model's regressor series
/// over the training rows `rows`).
#[allow(clippy::needless_range_loop)] // rows of column-major series
fn unbounded_envelope(
    table: &Table,
    rows: &TrainRows,
    axis: &str,
    model: &LinearModel,
    kind: FitKind,
    feats: &[Cow<[f64]>],
) -> Result<Envelope> {
    let mut ranges = Vec::new();
    for name in model.channels() {
        // Over the training rows in row order (no copy of them).
        let x = &table.inputs[input_index(table, name)?];
        let (min, max) = x
            .iter()
            .zip(rows.mask)
            .filter(|(_, &m)| m)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, (&v, _)| {
                (a.0.min(v), a.1.max(v))
            });
        ranges.push(ChannelRange {
            channel: name.to_string(),
            min,
            max,
        });
    }
    let n = feats.first().map_or(0, |f| f.len());
    let p = feats.len();
    let mut env = Envelope {
        axis: axis.to_string(),
        ranges,
        feature_mean: Vec::new(),
        whitening: Vec::new(),
        max_d2: 0.0,
        rows: n as u64,
    };
    if p == 0 || n <= p + 1 {
        return Ok(env);
    }
    let mean: Vec<f64> = feats
        .iter()
        .map(|f| f.iter().sum::<f64>() / n as f64)
        .collect();
    if kind != FitKind::LeastSquares {
        let Some(w) = shrunk_whitening(feats, &mean, kind) else {
            return Ok(env);
        };
        env.feature_mean = mean;
        env.whitening = w;
        return Ok(env);
    }
    let xc = DMatrix::from_fn(n, p, |i, j| feats[j][i] - mean[j]);
    let r = xc.qr().r();
    let max_p = (0..p).map(|j| r[(j, j)].abs()).fold(0.0, f64::max);
    if (0..p).any(|j| !crate::regress::exceeds(r[(j, j)].abs(), 1e-11 * max_p)) {
        // Collinear regressors (e.g. a difference and its parts): ranges only.
        return Ok(env);
    }
    // W = √(n − 1)·R⁻ᵀ (lower triangular).
    let Some(rinv) = r.solve_upper_triangular(&DMatrix::identity(p, p)) else {
        return Ok(env);
    };
    let w = rinv.transpose() * ((n - 1) as f64).sqrt();
    env.feature_mean = mean;
    env.whitening = (0..p)
        .flat_map(|i| (0..p).map(move |j| (i, j)))
        .map(|(i, j)| if j <= i { w[(i, j)] } else { 0.0 })
        .collect();
    Ok(env)
}

/// The largest d² of the envelope's bound over the training regressors `feats` (in row
/// order, from 0, as a running `f64::max`).
fn max_training_d2(env: &Envelope, feats: &[Cow<[f64]>]) -> f64 {
    let n = feats.first().map_or(0, |f| f.len());
    d2_of_rows(env, feats, n).into_iter().fold(0.0, f64::max)
}

/// W of a ridge or principal-component fit (see [`training_envelope`]), row-major; None
/// when a regressor is constant on the training rows or the factorisation fails (the fit
/// refuses such regressors too).
fn shrunk_whitening(
    feats: &[std::borrow::Cow<[f64]>],
    mean: &[f64],
    kind: FitKind,
) -> Option<Vec<f64>> {
    let n = feats.first().map_or(0, |f| f.len());
    let p = feats.len();
    let sd: Vec<f64> = feats
        .iter()
        .zip(mean)
        .map(|(f, m)| (f.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n as f64).sqrt())
        .collect();
    if sd.iter().any(|&s| !crate::regress::exceeds(s, 0.0)) {
        return None;
    }
    let z = DMatrix::from_fn(n, p, |i, j| (feats[j][i] - mean[j]) / sd[j]);
    let w = match kind {
        FitKind::LeastSquares => return None,
        FitKind::Ridge(alpha) => {
            let rz = z.qr().r();
            let a = rz.transpose() * &rz + DMatrix::identity(p, p) * (alpha * n as f64);
            // (R_z·A⁻¹)ᵀ = A⁻¹·R_zᵀ (A symmetric).
            a.cholesky()?.inverse() * rz.transpose()
        }
        FitKind::Components(k) => {
            let svd = gearcomp_linalg::Svd::new(&z).ok()?;
            let vt = &svd.v_t;
            let mut w = DMatrix::zeros(p, p);
            for c in 0..k.min(svd.singular_values.len()) {
                let s = svd.singular_values[c];
                if !crate::regress::exceeds(s, 0.0) {
                    return None;
                }
                for j in 0..p {
                    w[(j, c)] = vt[(c, j)] / s;
                }
            }
            w
        }
    };
    // The whitening's row i is √(n − 1)·(column i of w)ᵀ·S⁻¹.
    let scale = ((n - 1) as f64).sqrt();
    Some(
        (0..p)
            .flat_map(|i| (0..p).map(move |j| (i, j)))
            .map(|(i, j)| scale * w[(j, i)] / sd[j])
            .collect(),
    )
}

/// Per row: outside the envelope, and the 95 % prediction-interval half-width in the
/// target unit for a validation RMSE `sigma_v`.
///
/// Per row, what `Envelope::check_and_leverage` gives (outside: a channel out of its range,
/// or d² above `max_d2` when the envelope has a bound; h = 1/n + d²/(n − 1)), with the d²
/// of every row computed at once ([`d2_of_rows`]).
pub fn rows_outside_and_intervals(
    table: &Table,
    model: &LinearModel,
    env: &Envelope,
    sigma_v: f64,
) -> Result<(Vec<bool>, Vec<f64>)> {
    let feats = regressor_series(table, model)?;
    let d2 = d2_of_rows(env, &feats, table.time_s.len());
    outside_and_intervals(table, env, &d2, sigma_v)
}

/// [`rows_outside_and_intervals`] from the d² of every row.
fn outside_and_intervals(
    table: &Table,
    env: &Envelope,
    d2: &[f64],
    sigma_v: f64,
) -> Result<(Vec<bool>, Vec<f64>)> {
    let chans: Vec<&[f64]> = env
        .ranges
        .iter()
        .map(|r| input_index(table, &r.channel).map(|i| table.inputs[i].as_slice()))
        .collect::<Result<_>>()?;
    let n = d2.len();
    let rows = env.rows.max(2) as f64;
    let bounded = !env.whitening.is_empty();
    // Column by column over all rows (the same flags as row by row: any channel out of its
    // range, or d² above the bound).
    let mut outside: Vec<bool> = d2.iter().map(|&v| bounded && v > env.max_d2).collect();
    for (r, c) in env.ranges.iter().zip(&chans) {
        for (o, &v) in outside.iter_mut().zip(&c[..n]) {
            *o |= v < r.min || v > r.max;
        }
    }
    let half = d2
        .iter()
        .map(|&d2| {
            let h = 1.0 / rows + d2 / (rows - 1.0);
            1.96 * sigma_v * (1.0 + h).sqrt()
        })
        .collect();
    Ok((outside, half))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::regress;
    use gearcomp_core::model::{Term, Transform};
    use proptest::prelude::*;

    /// Rows outside and intervals, and the training bound, as `Envelope::check_and_leverage`
    /// and `Envelope::d2` give them row by row (the engine's definition), bit for bit: value
    /// and rate terms, two segments, least-squares and ridge envelopes (a full W), rows
    /// outside the ranges and above the bound.
    #[test]
    fn every_row_at_once_is_the_engine_row_by_row() {
        let mut next = crate::test_uniform(7);
        for case in 0..12 {
            let (n, c) = (40 + 13 * case, 1 + case % 4);
            let drift: Vec<f64> = (0..n).map(|i| (i as f64 * 0.05).sin()).collect();
            let inputs: Vec<Vec<f64>> = (0..c)
                .map(|j| {
                    let a = 1.0 + next();
                    drift
                        .iter()
                        .map(|d| 20.0 + j as f64 + a * d + 0.3 * next())
                        .collect()
                })
                .collect();
            let names: Vec<String> = (0..c).map(|j| format!("x{j}")).collect();
            let table = Table {
                time_s: (0..n).map(|i| 15.0 * i as f64).collect(),
                input_names: names.clone(),
                inputs,
                segments: vec![0, n / 2],
                ..Table::default()
            };
            let mut terms: Vec<Term> = names
                .iter()
                .map(|ch| Term {
                    channel: ch.clone(),
                    coefficient: 1.0,
                    transform: Transform::Value,
                })
                .collect();
            if case % 2 == 1 {
                terms.push(Term {
                    channel: names[0].clone(),
                    coefficient: 0.5,
                    transform: Transform::Rate { tau_s: 300.0 },
                });
            }
            let model = LinearModel {
                intercept: 0.0,
                terms,
            };
            // Train on the first 60 % of the rows: the rest leaves the ranges now and then.
            let train: Vec<bool> = (0..n).map(|i| i < n * 3 / 5).collect();
            let kind = match case % 3 {
                0 => FitKind::LeastSquares,
                _ => FitKind::Ridge(0.01 * case as f64),
            };
            let env = training_envelope(&table, &train, "a", &model, kind).unwrap();
            let all = regressors(&table, &model).unwrap();
            let p = all.len();
            let row = |i: usize| (0..p).map(|j| all[j][i]).collect::<Vec<f64>>();
            let max_d2 = (0..n)
                .filter(|&i| train[i])
                .fold(0.0f64, |m, i| m.max(env.d2(&row(i))));
            assert_eq!(env.max_d2.to_bits(), max_d2.to_bits(), "case {case}");
            let sigma = 0.7 + next();
            let (outside, half) = rows_outside_and_intervals(&table, &model, &env, sigma).unwrap();
            // Both at once (what `identify` runs): the same, bit for bit.
            let (env2, outside2, half2) =
                training_envelope_and_rows(&table, &train, "a", &model, kind, sigma).unwrap();
            assert_eq!(env2, env, "case {case}");
            assert_eq!(outside2, outside, "case {case}");
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&half2), bits(&half), "case {case}");
            let chans: Vec<usize> = env
                .ranges
                .iter()
                .map(|r| names.iter().position(|x| *x == r.channel).unwrap())
                .collect();
            let mut seen_out = 0;
            for i in 0..n {
                let cv: Vec<f64> = chans.iter().map(|&k| table.inputs[k][i]).collect();
                let (out, h) = env.check_and_leverage(&cv, &row(i));
                assert_eq!(outside[i], out.is_some(), "case {case} row {i}");
                let want = 1.96 * sigma * (1.0 + h).sqrt();
                assert_eq!(half[i].to_bits(), want.to_bits(), "case {case} row {i}");
                seen_out += usize::from(outside[i]);
            }
            assert!(seen_out > 0, "case {case}: no row outside");
        }
    }

    /// A table of `cols` as inputs read by their current values, and the model reading them.
    fn table_and_model(cols: &[Vec<f64>]) -> (Table, LinearModel) {
        let n = cols[0].len();
        let names: Vec<String> = (0..cols.len()).map(|j| format!("x{j}")).collect();
        let table = Table {
            time_s: (0..n).map(|i| i as f64).collect(),
            input_names: names.clone(),
            inputs: cols.to_vec(),
            segments: vec![0],
            ..Table::default()
        };
        let model = LinearModel {
            intercept: 0.0,
            terms: names
                .into_iter()
                .map(|channel| Term {
                    channel,
                    coefficient: 1.0,
                    transform: Transform::Value,
                })
                .collect(),
        };
        (table, model)
    }

    /// The leverage of `x` by its definition: the prediction at `x` of a fit of `kind` is
    /// Σ_i c_i(x)·y_i, linear in the targets; with independent errors of variance σ² its
    /// variance is σ²·Σ_i c_i(x)², and c_i(x) is the prediction at `x` of the fit to the
    /// unit target e_i. One fit per training row, by the regression routines themselves.
    fn leverage_by_unit_fits(cols: &[Vec<f64>], kind: FitKind, x: &[f64]) -> f64 {
        let n = cols[0].len();
        let refs: Vec<&[f64]> = cols.iter().map(Vec::as_slice).collect();
        let names: Vec<String> = (0..cols.len()).map(|j| format!("x{j}")).collect();
        (0..n)
            .map(|i| {
                let e: Vec<f64> = (0..n).map(|k| f64::from(u8::from(k == i))).collect();
                let fit = match kind {
                    FitKind::LeastSquares => regress::ols(&refs, &e, &names),
                    FitKind::Ridge(a) => regress::ridge(&refs, &e, a, &names),
                    FitKind::Components(k) => regress::pcr(&refs, &e, k, &names),
                }
                .unwrap();
                fit.predict(x).powi(2)
            })
            .sum()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        /// The envelope's leverage 1/n + d²/(n − 1) is the fitted model's own leverage, for
        /// least squares, ridge and principal components, at training rows and at points
        /// far outside; max_d2 is the largest over the training rows.
        #[test]
        fn leverage_is_the_fits_prediction_variance(
            seed in any::<u64>(),
            n in 12usize..60,
            p in 1usize..6,
            kind_pick in 0usize..3,
            log_alpha in -4.0f64..0.5,
            k_pick in 0usize..8,
            collinear in any::<bool>(),
        ) {
            let mut u = crate::test_uniform(seed | 1);
            let mut lcg = move || u() - 0.5;
            let mut cols: Vec<Vec<f64>> = (0..p)
                .map(|j| (0..n).map(|_| 20.0 + (j + 1) as f64 * lcg()).collect())
                .collect();
            // Shrunk fits stay well defined on nearly collinear regressors.
            let kind = match kind_pick {
                0 => FitKind::LeastSquares,
                1 => FitKind::Ridge(10f64.powf(log_alpha)),
                _ => FitKind::Components(1 + k_pick % p),
            };
            if collinear && p > 1 && matches!(kind, FitKind::Ridge(_)) {
                let c0 = cols[0].clone();
                cols[p - 1] = c0.iter().map(|v| v + 1e-4 * lcg()).collect();
            }
            let (table, model) = table_and_model(&cols);
            let train = vec![true; n];
            let env = training_envelope(&table, &train, "z", &model, kind).unwrap();
            prop_assume!(n > p + 1);
            prop_assert_eq!(env.whitening.len(), p * p);
            let mut max_h: f64 = 0.0;
            for i in 0..n {
                let x: Vec<f64> = cols.iter().map(|c| c[i]).collect();
                let want = leverage_by_unit_fits(&cols, kind, &x);
                let got = env.leverage(&x);
                prop_assert!((got - want).abs() <= 1e-7 * want, "row {}: {} vs {}", i, got, want);
                max_h = max_h.max(want);
            }
            let bound = 1.0 / n as f64 + env.max_d2 / (n - 1) as f64;
            prop_assert!((bound - max_h).abs() <= 1e-7 * max_h, "{} vs {}", bound, max_h);
            for _ in 0..4 {
                let x: Vec<f64> = (0..p).map(|j| 20.0 + 4.0 * (j + 1) as f64 * lcg()).collect();
                let want = leverage_by_unit_fits(&cols, kind, &x);
                let got = env.leverage(&x);
                prop_assert!((got - want).abs() <= 1e-7 * want, "{:?}: {} vs {}", x, got, want);
            }
        }
    }
}
