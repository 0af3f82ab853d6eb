//! Sample→offset latency: a lock-free log-scale histogram the cycle fills (from the
//! instant a scan is complete to the offset in the output cell) and `/api/status` reads
//! as p50 and p99.
//!
//! Bucket `k` holds durations in `[2^(k/4), 2^((k+1)/4))` ns (four buckets per octave,
//! so a reported quantile — the upper bound of its bucket — is at most 19 % above the
//! exact nearest-rank quantile and never below it); 1 ns … 2^40 ns ≈ 18 min. Adding is
//! one relaxed atomic increment: nothing allocates on the step path.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Buckets per octave.
pub const PER_OCTAVE: u32 = 4;
/// Number of buckets (40 octaves).
pub const BUCKETS: usize = 160;

/// The histogram.
#[derive(Debug)]
pub struct Histogram {
    counts: [AtomicU64; BUCKETS],
}

impl Default for Histogram {
    fn default() -> Self {
        Self {
            counts: std::array::from_fn(|_| AtomicU64::new(0)),
        }
    }
}

/// The bucket of a duration of `ns` nanoseconds (0 counts as 1 ns).
pub fn bucket(ns: u64) -> usize {
    let v = ns.max(1);
    let e = 63 - v.leading_zeros(); // 2^e ≤ v < 2^(e+1)
    let frac = v as f64 / 2f64.powi(e as i32); // [1, 2)
    let sub = ((frac.log2() * PER_OCTAVE as f64).floor() as u32).min(PER_OCTAVE - 1);
    ((e * PER_OCTAVE + sub) as usize).min(BUCKETS - 1)
}

/// The upper bound of bucket `k`, ns.
pub fn upper_ns(k: usize) -> f64 {
    2f64.powf((k as f64 + 1.0) / PER_OCTAVE as f64)
}

impl Histogram {
    /// Counts one latency.
    pub fn add(&self, d: Duration) {
        let ns = u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
        self.counts[bucket(ns)].fetch_add(1, Ordering::Relaxed);
    }

    /// Latencies counted.
    pub fn count(&self) -> u64 {
        self.counts.iter().map(|c| c.load(Ordering::Relaxed)).sum()
    }

    /// The nearest-rank quantile `q` (0 < q ≤ 1) as the upper bound of its bucket, s;
    /// `None` before the first latency.
    pub fn quantile_s(&self, q: f64) -> Option<f64> {
        let snap: Vec<u64> = self
            .counts
            .iter()
            .map(|c| c.load(Ordering::Relaxed))
            .collect();
        let n: u64 = snap.iter().sum();
        if n == 0 {
            return None;
        }
        let rank = ((q * n as f64).ceil() as u64).clamp(1, n);
        let mut cum = 0u64;
        for (k, c) in snap.iter().enumerate() {
            cum += c;
            if cum >= rank {
                return Some(upper_ns(k) * 1e-9);
            }
        }
        Some(upper_ns(BUCKETS - 1) * 1e-9)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        // Against the exact nearest-rank quantile of the same durations (sorted): the
        // reported value is above it by less than one bucket (2^(1/4)).
        #[test]
        fn quantiles_bracket_the_exact_ones(
            ns in proptest::collection::vec(1u64..10_000_000_000, 1..400),
            q in prop_oneof![Just(0.5), Just(0.99), 0.01f64..1.0],
        ) {
            let h = Histogram::default();
            for v in &ns {
                h.add(Duration::from_nanos(*v));
            }
            let mut sorted = ns.clone();
            sorted.sort_unstable();
            let rank = ((q * ns.len() as f64).ceil() as usize).clamp(1, ns.len());
            let exact = sorted[rank - 1] as f64;
            let got = h.quantile_s(q).unwrap() * 1e9;
            prop_assert!(got > exact * (1.0 - 1e-12), "{got} ≤ {exact}");
            prop_assert!(got <= exact * 2f64.powf(0.25) * (1.0 + 1e-9), "{got} vs {exact}");
            prop_assert_eq!(h.count(), ns.len() as u64);
        }
    }

    #[test]
    fn empty_and_bucket_edges() {
        assert_eq!(Histogram::default().quantile_s(0.5), None);
        assert_eq!(bucket(1), 0);
        assert_eq!(bucket(2), 4);
        assert_eq!(bucket(1024), 40);
        // 2^(1/4) = 1.189…: 1189 ns is in the first quarter-octave above 1024 ns.
        assert_eq!(bucket(1217), 40);
        assert_eq!(bucket(1218), 41);
    }
}
