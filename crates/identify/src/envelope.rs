//! Extrapolation awareness (issue 12): the training envelope of a model's inputs, rows
//! outside it, and prediction intervals.
//!
//! The envelope holds each channel's training range and a Mahalanobis bound on the model's
//! regressors (`gearcomp_core::model::Envelope`). The 95 % prediction interval of a row is
//! ŷ ± 1.96·σ_v·√(1 + h), σ_v the validation RMSE (the honest out-of-sample scale, not the
//! training residual) and h the row's leverage 1/n + d²/(n − 1).

use crate::data::Table;
use crate::error::{IdentifyError, Result};
use crate::fit::TrainRows;
use crate::transform::transform_segments;
use gearcomp_core::model::{ChannelRange, Envelope, LinearModel};
use nalgebra::DMatrix;

/// The regressor series of each term of `model` over the table (engine semantics).
pub fn regressors(table: &Table, model: &LinearModel) -> Result<Vec<Vec<f64>>> {
    let segs = table.segment_ranges();
    model
        .terms
        .iter()
        .map(|t| {
            let i = channel(table, &t.channel)?;
            transform_segments(&table.time_s, &table.inputs[i], t.transform, &segs)
        })
        .collect()
}

fn channel(table: &Table, name: &str) -> Result<usize> {
    table
        .input_names
        .iter()
        .position(|n| n == name)
        .ok_or_else(|| IdentifyError::ColumnNotFound {
            pattern: name.to_string(),
            available: table.input_names.join(", "),
        })
}

/// The envelope of `model` over the training rows (`axis` names the model file's axis).
#[allow(clippy::needless_range_loop)] // rows of column-major series
pub fn training_envelope(
    table: &Table,
    train: &[bool],
    axis: &str,
    model: &LinearModel,
) -> Result<Envelope> {
    let rows = TrainRows::new(train);
    let mut ranges = Vec::new();
    for name in model.channels() {
        let x = rows.of(&table.inputs[channel(table, name)?]);
        let (min, max) = x.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
            (a.0.min(v), a.1.max(v))
        });
        ranges.push(ChannelRange {
            channel: name.to_string(),
            min,
            max,
        });
    }
    let all = regressors(table, model)?;
    let feats: Vec<std::borrow::Cow<[f64]>> = all.iter().map(|f| rows.of(f)).collect();
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
    let mut row = vec![0.0; p];
    for i in 0..n {
        for j in 0..p {
            row[j] = feats[j][i];
        }
        env.max_d2 = env.max_d2.max(env.d2(&row));
    }
    Ok(env)
}

/// Per row: outside the envelope, and the 95 % prediction-interval half-width in the
/// target unit for a validation RMSE `sigma_v`.
#[allow(clippy::needless_range_loop)] // rows of column-major series
pub fn rows_outside_and_intervals(
    table: &Table,
    model: &LinearModel,
    env: &Envelope,
    sigma_v: f64,
) -> Result<(Vec<bool>, Vec<f64>)> {
    let feats = regressors(table, model)?;
    let chans: Vec<usize> = env
        .ranges
        .iter()
        .map(|r| channel(table, &r.channel))
        .collect::<Result<_>>()?;
    let n = table.time_s.len();
    let mut outside = Vec::with_capacity(n);
    let mut half = Vec::with_capacity(n);
    let mut f = vec![0.0; feats.len()];
    let mut c = vec![0.0; chans.len()];
    for i in 0..n {
        for (k, x) in feats.iter().enumerate() {
            f[k] = x[i];
        }
        for (k, &ch) in chans.iter().enumerate() {
            c[k] = table.inputs[ch][i];
        }
        let (out, h) = env.check_and_leverage(&c, &f);
        outside.push(out.is_some());
        half.push(1.96 * sigma_v * (1.0 + h).sqrt());
    }
    Ok((outside, half))
}
