//! Averaging and filtering state: fixed-capacity, allocated once at build time, updated
//! in the control cycle without allocation.

/// N-sample block average (EP0138375 Fig. 4: take N samples at the trigger, then average).
#[derive(Debug, Clone)]
pub struct BlockAverage {
    n: usize,
    // N as f64, converted once: the per-sample division is by the same value.
    n_f64: f64,
    count: usize,
    sum: f64,
}

impl BlockAverage {
    /// A block of `n ≥ 1` samples (validated by the caller).
    pub fn new(n: usize) -> Self {
        let n = n.max(1);
        Self {
            n,
            n_f64: n as f64,
            count: 0,
            sum: 0.0,
        }
    }

    /// Adds a sample; returns the average when the block is complete.
    ///
    /// # Formula
    /// P̄ = (1/N)·Σ P_i
    /// # Source
    /// EP0138375, Fig. 4 blocks 104–110 and Fig. 6 block 300 [SEED]
    #[inline]
    pub fn push(&mut self, v: f64) -> Option<f64> {
        self.sum += v;
        self.count += 1;
        if self.count >= self.n {
            let mean = self.sum / self.n_f64;
            self.count = 0;
            self.sum = 0.0;
            Some(mean)
        } else {
            None
        }
    }

    /// Discards a partial block (after a fault, so bad and good samples never mix).
    pub fn reset(&mut self) {
        self.count = 0;
        self.sum = 0.0;
    }
}

/// First-order lag, exact discretisation for a piecewise-constant input.
#[derive(Debug, Clone, Copy)]
pub struct FirstOrderLag {
    tau_s: f64,
    // The gain for the last Δt: a fixed cycle reuses it instead of calling exp().
    last_dt_s: f64,
    gain: f64,
    y: f64,
    t_last_s: f64,
    started: bool,
}

impl FirstOrderLag {
    /// A lag with time constant `tau_s > 0` (validated by the caller).
    pub fn new(tau_s: f64) -> Self {
        Self {
            tau_s,
            last_dt_s: f64::NAN,
            gain: 0.0,
            y: 0.0,
            t_last_s: 0.0,
            started: false,
        }
    }

    /// Starts afresh: the next sample is the first (y = u there).
    pub fn reset(&mut self) {
        *self = Self::new(self.tau_s);
    }

    /// Feeds a sample at time `t_s`; returns the filtered value.
    ///
    /// # Formula
    /// y ← y + (1 − e^(−Δt/τ))·(u − y); y = u at the first sample
    /// # Units
    /// t, τ in s; y in the unit of u.
    /// # Source
    /// exact zero-order-hold discretisation of τ·ẏ + y = u [DERIVED]; the same semantics
    /// as `gearcomp_core::model::Transform::FirstOrderLag`
    #[inline]
    pub fn update(&mut self, t_s: f64, u: f64) -> f64 {
        if !self.started {
            self.started = true;
            self.y = u;
        } else {
            let dt_s = (t_s - self.t_last_s).max(0.0);
            if dt_s != self.last_dt_s {
                self.last_dt_s = dt_s;
                self.gain = 1.0 - (-dt_s / self.tau_s).exp();
            }
            self.y += self.gain * (u - self.y);
        }
        self.t_last_s = t_s;
        self.y
    }

    /// The current output.
    pub fn value(&self) -> f64 {
        self.y
    }
}

/// Moving average over the last M values (fixed ring).
#[derive(Debug, Clone)]
pub struct MovingWindow {
    buf: Vec<f64>,
    head: usize,
    len: usize,
    sum: f64,
}

impl MovingWindow {
    /// A window of `m ≥ 1` values (validated by the caller).
    pub fn new(m: usize) -> Self {
        Self {
            buf: vec![0.0; m.max(1)],
            head: 0,
            len: 0,
            sum: 0.0,
        }
    }

    /// Adds a value; returns the mean of the values held (fewer than M at the start).
    ///
    /// # Formula
    /// T̄ = (1/M)·Σ_{k=0}^{M−1} T_{n−k}
    pub fn push(&mut self, v: f64) -> f64 {
        let cap = self.buf.len();
        if self.len == cap {
            self.sum -= self.buf[self.head];
        } else {
            self.len += 1;
        }
        self.buf[self.head] = v;
        self.sum += v;
        self.head = (self.head + 1) % cap;
        // Re-summing once per wrap bounds the floating-point drift of the running sum.
        if self.head == 0 {
            self.sum = self.buf[..self.len].iter().sum();
        }
        self.sum / self.len as f64
    }
}

/// The delay transform's line, shared with the fit (`gearcomp_core::delay`).
pub use gearcomp_core::delay::{DelayLine, DELAY_CAPACITY};

/// Reads a saved state back value by value (see `Engine::save_state`).
#[derive(Debug)]
pub(crate) struct StateCursor<'a> {
    s: &'a [f64],
    i: usize,
}

impl<'a> StateCursor<'a> {
    pub(crate) fn new(s: &'a [f64]) -> Self {
        Self { s, i: 0 }
    }

    /// The next value, or None past the end.
    pub(crate) fn next(&mut self) -> Option<f64> {
        let v = self.s.get(self.i).copied();
        self.i += 1;
        v
    }

    /// The next value as a count (a non-negative integer below `max`).
    pub(crate) fn count(&mut self, max: usize) -> Option<usize> {
        let v = self.next()?;
        (v >= 0.0 && v.fract() == 0.0 && v < max as f64).then_some(v as usize)
    }

    /// True when every value was read.
    pub(crate) fn at_end(&self) -> bool {
        self.i == self.s.len()
    }
}

impl BlockAverage {
    pub(crate) fn save(&self, out: &mut Vec<f64>) {
        out.extend_from_slice(&[self.count as f64, self.sum]);
    }

    pub(crate) fn restore(&mut self, c: &mut StateCursor) -> Option<()> {
        self.count = c.count(self.n)?;
        self.sum = c.next()?;
        Some(())
    }
}

impl FirstOrderLag {
    pub(crate) fn save(&self, out: &mut Vec<f64>) {
        out.extend_from_slice(&[
            self.last_dt_s,
            self.gain,
            self.y,
            self.t_last_s,
            f64::from(u8::from(self.started)),
        ]);
    }

    pub(crate) fn restore(&mut self, c: &mut StateCursor) -> Option<()> {
        self.last_dt_s = c.next()?;
        self.gain = c.next()?;
        self.y = c.next()?;
        self.t_last_s = c.next()?;
        self.started = c.count(2)? == 1;
        Some(())
    }
}

impl MovingWindow {
    pub(crate) fn save(&self, out: &mut Vec<f64>) {
        out.extend_from_slice(&[self.head as f64, self.len as f64, self.sum]);
        out.extend_from_slice(&self.buf);
    }

    pub(crate) fn restore(&mut self, c: &mut StateCursor) -> Option<()> {
        let cap = self.buf.len();
        self.head = c.count(cap)?;
        self.len = c.count(cap + 1)?;
        self.sum = c.next()?;
        for b in self.buf.iter_mut() {
            *b = c.next()?;
        }
        Some(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn block_average_of_eight() {
        let mut b = BlockAverage::new(8);
        let xs = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0];
        let outs: Vec<_> = xs.iter().map(|&x| b.push(x)).collect();
        assert!(outs[..7].iter().all(Option::is_none));
        assert_eq!(outs[7], Some(4.5));
    }

    /// Step response of a first-order lag: y(τ) = 1 − e^(−1) = 0.632 12 (closed form),
    /// independent of the step size because the discretisation is exact.
    #[test]
    fn lag_step_response_is_exact() {
        for dt in [1.0, 7.0, 60.0] {
            let mut f = FirstOrderLag::new(600.0);
            f.update(0.0, 0.0);
            let mut t: f64 = 0.0;
            let mut y = 0.0;
            while t < 600.0 - 1e-9 {
                t += dt;
                y = f.update(t.min(600.0), 1.0);
            }
            assert!((y - (1.0 - (-1.0f64).exp())).abs() < 1e-12, "dt {dt}: {y}");
        }
    }

    #[test]
    fn moving_window_mean() {
        let mut w = MovingWindow::new(3);
        assert_eq!(w.push(3.0), 3.0);
        assert_eq!(w.push(6.0), 4.5);
        assert_eq!(w.push(9.0), 6.0);
        assert_eq!(w.push(12.0), 9.0);
    }

    /// Against a reference written the plain way (every stored point kept in a `Vec`, a
    /// linear scan for the bracket): bit-identical for irregular steps, including gaps
    /// longer than the delay (which defeat the forward search from last cycle's bracket)
    /// and runs long enough to wrap the ring many times.
    #[test]
    fn delay_matches_linear_scan_reference_bit_for_bit() {
        let delay_s = 50.0;
        let spacing_s = delay_s / (DELAY_CAPACITY as f64 / 2.0);
        let mut d = DelayLine::new(delay_s);
        let mut stored: Vec<(f64, f64)> = Vec::new();
        let mut t = 0.0;
        for k in 0..20_000u32 {
            t += match k % 97 {
                0 => 80.0,
                1..=3 => 0.01,
                _ => 0.05 + f64::from(k % 7) * 0.11,
            };
            let u = (t * 0.05).sin() * 10.0 + t * 0.01;
            let got = d.update(t, u);
            if stored.last().is_none_or(|p| t - p.0 >= spacing_s) {
                stored.push((t, u));
            }
            let ring = &stored[stored.len().saturating_sub(DELAY_CAPACITY)..];
            let target = t - delay_s;
            let (t0, v0) = ring[0];
            let (tn, vn) = ring[ring.len() - 1];
            let want = if target <= t0 {
                v0
            } else if target >= tn {
                let span = t - tn;
                if span > 0.0 {
                    vn + (u - vn) * (target - tn) / span
                } else {
                    u
                }
            } else {
                let j = ring.iter().rposition(|p| p.0 <= target).unwrap();
                let ((ta, va), (tb, vb)) = (ring[j], ring[j + 1]);
                va + (vb - va) * (target - ta) / (tb - ta)
            };
            assert_eq!(got.to_bits(), want.to_bits(), "t {t}: {got} vs {want}");
        }
    }

    /// A ramp delayed by d is the ramp shifted by d, exactly (linear interpolation).
    #[test]
    fn delay_of_a_ramp() {
        let mut d = DelayLine::new(100.0);
        let mut last = 0.0;
        for k in 0..2000 {
            let t = k as f64 * 1.5;
            last = d.update(t, 2.0 * t);
            if t < 100.0 {
                assert_eq!(last, 0.0);
            }
        }
        let t_end = 1999.0 * 1.5;
        assert!((last - 2.0 * (t_end - 100.0)).abs() < 1e-9, "{last}");
    }
}
