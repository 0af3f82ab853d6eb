//! The delay transform of the model file (`model::Transform::Delay`) as the engine runs it
//! and the fit evaluates it: one line, so that what the fit validates is what the machine
//! computes. A fixed ring of points, allocated once; updating it allocates nothing.

/// The value `delay_s` ago, linearly interpolated, from a fixed ring of decimated points.
#[derive(Debug, Clone)]
pub struct DelayLine {
    delay_s: f64,
    spacing_s: f64,
    // Fixed-size rings: an index reduced modulo the capacity needs no bounds check.
    t: Box<[f64; DELAY_CAPACITY]>,
    v: Box<[f64; DELAY_CAPACITY]>,
    head: usize,
    len: usize,
    /// Points stored since the start; with `len`, turns `hint` into a ring position.
    stored: u64,
    /// The sequence number of the bracket's lower point found last time: the target
    /// moves forward by about one cycle, so the next bracket is at or just after it.
    hint: u64,
}

/// Points kept by a [`DelayLine`]; at a spacing of delay/(CAP/2) they span twice the delay.
pub const DELAY_CAPACITY: usize = 512;

impl DelayLine {
    /// A delay of `delay_s ≥ 0` s (validated by the caller).
    pub fn new(delay_s: f64) -> Self {
        Self {
            delay_s,
            spacing_s: delay_s / (DELAY_CAPACITY as f64 / 2.0),
            t: Box::new([0.0; DELAY_CAPACITY]),
            v: Box::new([0.0; DELAY_CAPACITY]),
            head: 0,
            len: 0,
            stored: 0,
            hint: 0,
        }
    }

    /// Forgets the history without freeing the rings (no allocation): the next sample is
    /// the first.
    pub fn reset(&mut self) {
        self.head = 0;
        self.len = 0;
        self.stored = 0;
        self.hint = 0;
    }

    fn at(&self, k: usize) -> (f64, f64) {
        // k = 0 is the oldest stored point.
        let idx = (self.head + DELAY_CAPACITY - self.len + k) % DELAY_CAPACITY;
        (self.t[idx], self.v[idx])
    }

    /// Feeds a sample at `t_s` and returns u(t − delay).
    ///
    /// # Formula
    /// u(t − d) by linear interpolation between stored points; before `d` of history
    /// exists, the oldest value. Points are stored at least d/256 apart, so the ring of 512
    /// covers 2·d; a thermal signal sampled that finely interpolates to well below its noise.
    /// # Source
    /// semantics of `gearcomp_core::model::Transform::Delay` [PROJECT CONVENTION]
    pub fn update(&mut self, t_s: f64, u: f64) -> f64 {
        let newest_t = if self.len > 0 {
            self.at(self.len - 1).0
        } else {
            f64::NEG_INFINITY
        };
        if self.len == 0 || t_s - newest_t >= self.spacing_s {
            self.t[self.head] = t_s;
            self.v[self.head] = u;
            self.head = (self.head + 1) % DELAY_CAPACITY;
            self.len = (self.len + 1).min(DELAY_CAPACITY);
            self.stored += 1;
        }
        let target = t_s - self.delay_s;
        let (t0, v0) = self.at(0);
        if target <= t0 {
            return v0;
        }
        // The current sample is the newest point even when it was not stored.
        let (tn, vn) = self.at(self.len - 1);
        if target >= tn {
            let span = t_s - tn;
            return if span > 0.0 {
                vn + (u - vn) * (target - tn) / span
            } else {
                u
            };
        }
        // The last stored point at or before the target. Stored times never decrease, so
        // that point is unique whichever way it is found: first a few steps forward from
        // last cycle's, else a binary search. Here t[0] ≤ target < t[len − 1].
        let first_seq = self.stored - self.len as u64;
        let mut lo = usize::MAX;
        if self.hint >= first_seq {
            let k = ((self.hint - first_seq) as usize).min(self.len - 2);
            if self.at(k).0 <= target {
                for j in k..(k + 4).min(self.len - 1) {
                    if self.at(j + 1).0 > target {
                        lo = j;
                        break;
                    }
                }
            }
        }
        if lo == usize::MAX {
            let mut hi;
            (lo, hi) = (0usize, self.len - 1);
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if self.at(mid).0 <= target {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
        }
        self.hint = first_seq + lo as u64;
        let hi = lo + 1;
        let (ta, va) = self.at(lo);
        let (tb, vb) = self.at(hi);
        if tb > ta {
            va + (vb - va) * (target - ta) / (tb - ta)
        } else {
            va
        }
    }
}

impl DelayLine {
    /// Appends the state (counts, then the rings) to `out`.
    pub fn save(&self, out: &mut Vec<f64>) {
        out.extend_from_slice(&[
            self.head as f64,
            self.len as f64,
            self.stored as f64,
            self.hint as f64,
        ]);
        out.extend_from_slice(&self.t[..]);
        out.extend_from_slice(&self.v[..]);
    }

    /// Reads back a state [`DelayLine::save`] wrote, value by value from `next`; `None`
    /// when a value is missing or a count is not one.
    pub fn restore(&mut self, next: &mut dyn FnMut() -> Option<f64>) -> Option<()> {
        let mut count = |max: u64| -> Option<u64> {
            let v = next()?;
            (v >= 0.0 && v.fract() == 0.0 && v < max as f64).then_some(v as u64)
        };
        self.head = count(DELAY_CAPACITY as u64)? as usize;
        self.len = count(DELAY_CAPACITY as u64 + 1)? as usize;
        // Counts of points stored: exact in an f64 up to 2^53.
        self.stored = count(1 << 53)?;
        self.hint = count(1 << 53)?;
        for x in self.t.iter_mut() {
            *x = next()?;
        }
        for x in self.v.iter_mut() {
            *x = next()?;
        }
        Some(())
    }
}
