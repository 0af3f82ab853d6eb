//! The regressor transforms of the model file, evaluated exactly as the compensation
//! engine evaluates them at the data's sample instants (see `gearcomp_core::model`).

use crate::error::{invalid, Result};
use gearcomp_core::model::Transform;

/// Streaming state of one transform; stepping allocates nothing.
///
/// `Delay` is not streamed here (it needs a history buffer); use [`transform_series`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransformState {
    kind: Transform,
    lag: f64,
    last_t_s: f64,
    started: bool,
}

impl TransformState {
    /// A fresh state (the lag starts at the first sample).
    pub fn new(kind: Transform) -> Self {
        Self {
            kind,
            lag: 0.0,
            last_t_s: 0.0,
            started: false,
        }
    }

    /// Feeds the sample `u` taken at `t_s` and returns the regressor value.
    ///
    /// # Formula
    /// FirstOrderLag: y ← y + (1 − e^(−Δt/τ))·(u − y), y₀ = u₀;  Rate: (u − y)/τ
    /// # Source
    /// `gearcomp_core::model` module docs (exact discretisation of τ·ẏ + y = u for a
    /// piecewise-constant input) [PROJECT CONVENTION]
    pub fn step(&mut self, t_s: f64, u: f64) -> f64 {
        match self.kind {
            Transform::Value | Transform::Delay { .. } => u,
            Transform::FirstOrderLag { tau_s } | Transform::Rate { tau_s } => {
                if self.started {
                    let a = 1.0 - (-(t_s - self.last_t_s) / tau_s).exp();
                    self.lag += a * (u - self.lag);
                } else {
                    self.lag = u;
                    self.started = true;
                }
                self.last_t_s = t_s;
                match self.kind {
                    Transform::Rate { tau_s } => (u - self.lag) / tau_s,
                    _ => self.lag,
                }
            }
        }
    }
}

fn check(kind: Transform) -> Result<()> {
    match kind {
        Transform::Value => Ok(()),
        Transform::FirstOrderLag { tau_s } | Transform::Rate { tau_s } => {
            if tau_s.is_finite() && tau_s > 0.0 {
                Ok(())
            } else {
                Err(invalid("transform.tau_s", tau_s, "a time constant > 0 s"))
            }
        }
        Transform::Delay { delay_s } => {
            if delay_s.is_finite() && delay_s >= 0.0 {
                Ok(())
            } else {
                Err(invalid("transform.delay_s", delay_s, "a delay ≥ 0 s"))
            }
        }
    }
}

/// The transform applied to a whole series sampled at `time_s` (strictly increasing).
///
/// Delay: the value `delay_s` ago, linearly interpolated between samples; the oldest value
/// until that much history exists.
pub fn transform_series(time_s: &[f64], u: &[f64], kind: Transform) -> Result<Vec<f64>> {
    check(kind)?;
    if time_s.len() != u.len() {
        return Err(invalid(
            "series length",
            u.len(),
            &format!("{} samples, as the time column", time_s.len()),
        ));
    }
    if let Transform::Delay { delay_s } = kind {
        let mut out = Vec::with_capacity(u.len());
        let mut j = 0usize;
        for &t in time_s {
            let target = t - delay_s;
            if time_s.first().is_none_or(|&t0| target <= t0) {
                out.push(u.first().copied().unwrap_or(f64::NAN));
                continue;
            }
            while j + 1 < time_s.len() && time_s[j + 1] < target {
                j += 1;
            }
            let (t0, t1) = (time_s[j], time_s[j + 1]);
            let w = (target - t0) / (t1 - t0);
            out.push(u[j] + w * (u[j + 1] - u[j]));
        }
        return Ok(out);
    }
    let mut s = TransformState::new(kind);
    Ok(time_s.iter().zip(u).map(|(&t, &v)| s.step(t, v)).collect())
}

/// The transform applied segment by segment: every state (lag, rate filter, delay history)
/// restarts at each segment's first sample, as the engine's would after a restart.
///
/// `segments` are `[start, end)` row ranges covering the series in order (see
/// `Table::segment_ranges`); time must increase strictly within each.
pub fn transform_segments(
    time_s: &[f64],
    u: &[f64],
    kind: Transform,
    segments: &[(usize, usize)],
) -> Result<Vec<f64>> {
    if time_s.len() != u.len() {
        return Err(invalid(
            "series length",
            u.len(),
            &format!("{} samples, as the time column", time_s.len()),
        ));
    }
    let mut out = Vec::with_capacity(u.len());
    let mut next = 0usize;
    for &(s, e) in segments {
        if s != next || e > u.len() || e <= s {
            return Err(invalid(
                "segments",
                format!("[{s}, {e})"),
                &format!("consecutive row ranges starting at {next}"),
            ));
        }
        out.extend(transform_series(&time_s[s..e], &u[s..e], kind)?);
        next = e;
    }
    if next != u.len() {
        return Err(invalid(
            "segments",
            format!("rows up to {next}"),
            &format!("ranges covering all {} rows", u.len()),
        ));
    }
    Ok(out)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn lag_of_a_step_follows_the_exponential_even_with_uneven_steps() {
        let t = [0.0, 10.0, 25.0, 100.0, 400.0];
        let u = [0.0, 1.0, 1.0, 1.0, 1.0];
        let tau = 50.0;
        let y = transform_series(&t, &u, Transform::FirstOrderLag { tau_s: tau }).unwrap();
        // The step enters at t = 10 s (piecewise constant from that sample on):
        // y(t) = 1 − e^(−(t − 0)/τ) because the new value is held over [0, 10] too
        // in the zero-order-hold reading (u sampled at the end of each interval).
        for k in 1..t.len() {
            let expect = 1.0 - (-(t[k]) / tau).exp();
            assert!((y[k] - expect).abs() < 1e-14, "{k}: {} vs {expect}", y[k]);
        }
        let r = transform_series(&t, &u, Transform::Rate { tau_s: tau }).unwrap();
        assert!((r[2] - (1.0 - y[2]) / tau).abs() < 1e-16);
    }

    #[test]
    fn delay_interpolates_and_holds_the_oldest_value() {
        let t = [0.0, 10.0, 20.0, 30.0];
        let u = [1.0, 3.0, 5.0, 11.0];
        let d = transform_series(&t, &u, Transform::Delay { delay_s: 15.0 }).unwrap();
        assert_eq!(d, vec![1.0, 1.0, 2.0, 4.0]);
        assert!(transform_series(&t, &u, Transform::Rate { tau_s: 0.0 }).is_err());
    }
}
