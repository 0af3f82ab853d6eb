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
/// Delay: the value `delay_s` ago, linearly interpolated between the points the engine's
/// delay line keeps (`gearcomp_core::delay::DelayLine`, fed sample by sample as the
/// engine feeds it: points at least delay/256 apart, so a series sampled more finely is
/// interpolated between every few samples, as on the machine); the oldest value until
/// that much history exists.
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
        // The engine's own delay line: what the fit validates and reports is what the
        // machine computes (the fit interpolated every sample before, and missed the
        // engine by up to 0.16 µm on a 3600 s delay sampled every 5 s).
        let mut line = gearcomp_core::delay::DelayLine::new(delay_s);
        return Ok(time_s
            .iter()
            .zip(u)
            .map(|(&t, &v)| line.update(t, v))
            .collect());
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

    /// A delay sampled more finely than delay/256 is the engine's: linear interpolation
    /// between the points kept at least delay/256 apart (the current sample the newest),
    /// the rule written out here; coarser sampling keeps every point (plain interpolation).
    #[test]
    fn delay_is_interpolated_between_the_points_the_engine_keeps() {
        let mut next = crate::test_uniform(0x9e37_79b9_7f4a_7c15);
        for case in 0..40 {
            let delay_s = 60.0 + 7000.0 * next();
            // Steps from far below delay/256 to above it, with jitter.
            let dt = delay_s / 256.0 * (0.05 + 3.0 * next());
            let n = 200 + (next() * 3000.0) as usize;
            let mut t = vec![0.0f64];
            for _ in 1..n {
                let last = t[t.len() - 1];
                t.push(last + dt * (0.5 + next()));
            }
            let u: Vec<f64> = t
                .iter()
                .map(|&x| (x / 900.0).sin() + 0.3 * next())
                .collect();
            let got = transform_series(&t, &u, Transform::Delay { delay_s }).unwrap();
            let spacing = delay_s / 256.0;
            let mut kept: Vec<(f64, f64)> = Vec::new();
            for i in 0..n {
                if kept.last().is_none_or(|&(tk, _)| t[i] - tk >= spacing) {
                    kept.push((t[i], u[i]));
                }
                let mut pts = kept.clone();
                if pts.last().is_some_and(|&(tk, _)| tk < t[i]) {
                    pts.push((t[i], u[i]));
                }
                let target = t[i] - delay_s;
                let want = if target <= pts[0].0 {
                    pts[0].1
                } else {
                    let k = pts.iter().rposition(|&(tk, _)| tk <= target).unwrap();
                    let ((ta, va), (tb, vb)) = (pts[k], pts[k + 1]);
                    va + (vb - va) * (target - ta) / (tb - ta)
                };
                assert!(
                    (got[i] - want).abs() <= 1e-12,
                    "case {case} row {i}: {} vs {want}",
                    got[i]
                );
            }
        }
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
