//! Exact rational coupling factors and exact axis positions in encoder counts.
//!
//! A coupling factor is kept as a reduced fraction of integers, as SINUMERIK's Zi/Ni and
//! FANUC's T:L are, and positions are integer counts plus an exact remainder, so the ideal
//! coupling never drifts however many strokes are run.

use crate::error::{Result, ShapingError};

/// A reduced fraction num/den with den > 0.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Ratio {
    num: i128,
    den: i128,
}

/// Greatest common divisor of |a| and |b| (0 when both are 0).
pub(crate) fn gcd(mut a: i128, mut b: i128) -> i128 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Ratio {
    /// The ratio 1/1.
    pub const ONE: Ratio = Ratio { num: 1, den: 1 };

    /// The fraction num/den, reduced; den must not be zero.
    pub fn new(num: i128, den: i128) -> Result<Self> {
        if den == 0 {
            return Err(ShapingError::OutOfRange {
                field: "ratio denominator",
                value: 0.0,
                min: 1.0,
                max: f64::INFINITY,
                unit: "",
            });
        }
        let g = gcd(num, den).max(1);
        let sign = if den < 0 { -1 } else { 1 };
        Ok(Self {
            num: sign * num / g,
            den: sign * den / g,
        })
    }

    /// Numerator (carries the sign).
    pub fn numer(&self) -> i128 {
        self.num
    }

    /// Denominator (> 0).
    pub fn denom(&self) -> i128 {
        self.den
    }

    /// Product of two ratios, reduced; fails rather than wraps on overflow.
    pub fn checked_mul(self, other: Ratio) -> Result<Ratio> {
        let g1 = gcd(self.num, other.den).max(1);
        let g2 = gcd(other.num, self.den).max(1);
        let overflow = || ShapingError::Overflow {
            what: "coupling ratio",
            detail: format!("{}/{} × {}/{}", self.num, self.den, other.num, other.den),
        };
        let num = (self.num / g1)
            .checked_mul(other.num / g2)
            .ok_or_else(overflow)?;
        let den = (self.den / g2)
            .checked_mul(other.den / g1)
            .ok_or_else(overflow)?;
        Ratio::new(num, den)
    }

    /// The ratio as a float (for display and feed-forward only, never for positions).
    pub fn to_f64(&self) -> f64 {
        self.num as f64 / self.den as f64
    }

    /// Exact product ratio × counts as whole counts plus a remainder; `None` on overflow.
    ///
    /// # Formula
    /// whole = ⌊num·n/den⌋, rem = num·n − whole·den ∈ [0, den)
    pub fn apply(&self, counts: i64) -> Option<ExactCounts> {
        // 64-bit fast path: 128-bit division is a slow library call on most targets.
        if let (Ok(num), Ok(den)) = (i64::try_from(self.num), i64::try_from(self.den)) {
            if let Some(p) = num.checked_mul(counts) {
                return Some(ExactCounts {
                    whole: p.div_euclid(den),
                    rem: i128::from(p.rem_euclid(den)),
                    den: self.den,
                });
            }
        }
        let p = self.num.checked_mul(i128::from(counts))?;
        let whole = p.div_euclid(self.den);
        let rem = p.rem_euclid(self.den);
        Some(ExactCounts {
            whole: i64::try_from(whole).ok()?,
            rem,
            den: self.den,
        })
    }
}

/// An exact axis position: `whole + rem/den` encoder counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct ExactCounts {
    /// Whole counts (floor).
    pub whole: i64,
    /// Remainder numerator, 0 ≤ rem < den.
    pub rem: i128,
    /// Remainder denominator (> 0 once set).
    pub den: i128,
}

impl ExactCounts {
    /// The position in counts as a float (loses exactness only in the last bits).
    pub fn to_f64(&self) -> f64 {
        if self.den == 0 {
            self.whole as f64
        } else {
            self.whole as f64 + self.rem as f64 / self.den as f64
        }
    }

    /// Fractional part in [0, 1).
    pub fn fraction(&self) -> f64 {
        if self.den == 0 {
            0.0
        } else {
            self.rem as f64 / self.den as f64
        }
    }
}
