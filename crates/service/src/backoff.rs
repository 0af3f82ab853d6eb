//! Reconnect back-off of every client (MQTT, Modbus TCP, OPC UA, PostgreSQL), the
//! `reconnect = { min_s, max_s }` tables of the configuration (re-exported as
//! `config::Backoff`). A file of its own so that the input configurations of the sources
//! and the storage can use it without importing `config.rs`, which imports them.

use serde::{Deserialize, Serialize};

use crate::error::{check_range, Result};

/// Reconnect back-off: the wait doubles from `min_s` up to `max_s` after each failure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Backoff {
    /// First wait, s (0.01…60).
    #[serde(default = "backoff_min")]
    pub min_s: f64,
    /// Longest wait, s (min_s…600).
    #[serde(default = "backoff_max")]
    pub max_s: f64,
}

fn backoff_min() -> f64 {
    0.2
}
fn backoff_max() -> f64 {
    10.0
}

impl Default for Backoff {
    fn default() -> Self {
        Self {
            min_s: backoff_min(),
            max_s: backoff_max(),
        }
    }
}

impl Backoff {
    /// The wait after `failures` consecutive failures (1 = first).
    ///
    /// # Formula
    /// wait = min(max_s, min_s·2^(failures−1))
    /// # Source
    /// capped exponential back-off [CONVENTION, docs/service.md]
    pub fn wait_s(&self, failures: u32) -> f64 {
        let exp = failures.saturating_sub(1).min(30) as i32;
        (self.min_s * 2f64.powi(exp)).min(self.max_s)
    }

    #[cfg_attr(
        not(any(feature = "mqtt", feature = "modbus", feature = "opcua")),
        allow(dead_code)
    )]
    pub(crate) fn validate(&self, field: &str) -> Result<()> {
        check_range(
            &format!("{field}.min_s"),
            self.min_s,
            0.01,
            60.0,
            "0.01…60 s",
        )?;
        check_range(
            &format!("{field}.max_s"),
            self.max_s,
            self.min_s,
            600.0,
            "min_s…600 s",
        )
    }
}
