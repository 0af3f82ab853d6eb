//! The service clock, shared by the cycle, the sources, the store and the API (its own
//! module so that none of them imports another just for the time).

use std::time::{Duration, Instant};

/// The service clock: seconds of (possibly sped-up) time, continuing the record of
/// earlier runs.
#[derive(Debug, Clone, Copy)]
pub struct Clock {
    start: Instant,
    origin_s: f64,
    speedup: f64,
    origin_unix_s: f64,
}

impl Clock {
    /// A clock reading `origin_s` now and advancing `speedup` s per wall-clock second.
    pub fn new(origin_s: f64, speedup: f64) -> Self {
        Self {
            start: Instant::now(),
            origin_s,
            speedup,
            origin_unix_s: unix_now_s(),
        }
    }

    /// Current time, s.
    ///
    /// # Formula
    /// t = origin + speedup·(wall time since start)
    /// # Source
    /// [CONVENTION, docs/service.md: the record's time continues across restarts]
    pub fn now_s(&self) -> f64 {
        self.origin_s + self.speedup * self.start.elapsed().as_secs_f64()
    }

    /// The time the clock started at, s.
    pub fn origin_s(&self) -> f64 {
        self.origin_s
    }

    /// Clock seconds per wall-clock second.
    pub fn speedup(&self) -> f64 {
        self.speedup
    }

    /// Wall-clock duration of `clock_s` seconds of service time.
    pub fn wall(&self, clock_s: f64) -> Duration {
        Duration::from_secs_f64((clock_s / self.speedup).clamp(0.0, 1e9))
    }

    /// Seconds since the Unix epoch at which the clock read [`Self::origin_s`] (this run's
    /// start).
    pub fn origin_unix_s(&self) -> f64 {
        self.origin_unix_s
    }

    /// The wall-clock time (s since the Unix epoch) of service time `t_s` in this run.
    ///
    /// # Formula
    /// unix = unix(origin) + (t − origin) / speedup
    /// # Source
    /// [CONVENTION, docs/service.md "Time"]: exact within this run; a time of an earlier
    /// run maps as if the runs had followed each other without a gap.
    pub fn unix_s(&self, t_s: f64) -> f64 {
        self.origin_unix_s + (t_s - self.origin_s) / self.speedup
    }
}

/// Seconds since the Unix epoch (audit rows, and the wall-clock anchor of the clock; the
/// record itself uses the service clock).
pub fn unix_now_s() -> f64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unix_time_of_service_time() {
        // 1000× speed-up: 3000 s of service time after the origin are 3 s of wall time.
        let c = Clock::new(500.0, 1000.0);
        let u0 = c.origin_unix_s();
        assert!((c.unix_s(3500.0) - (u0 + 3.0)).abs() < 1e-9);
        assert!((c.unix_s(500.0) - u0).abs() < 1e-9);
        // The anchor is the wall time at creation.
        assert!((u0 - unix_now_s()).abs() < 5.0);
    }
}
