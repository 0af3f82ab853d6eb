//! The `[input] kind = "replay"` configuration: the CSV log, its speed-up, looping and the
//! target columns kept in the record.
//!
//! Re-exported from [`crate::config`] and [`super::replay`]; a file of its own so that the
//! configuration does not import the replay runner, which imports the cycle.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::error::{check_range, invalid, Result};

/// `[input] kind = "replay"`: a CSV log replayed as if it arrived live.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReplayInput {
    /// The CSV log (relative paths are taken from the configuration file's folder).
    pub path: PathBuf,
    /// Log seconds per wall-clock second, 0.001…1e6.
    #[serde(default = "one")]
    pub speedup: f64,
    /// Start again from the first row after the last one, for ever.
    #[serde(default, rename = "loop")]
    pub looping: bool,
    /// Further columns kept in the record as targets (e.g. a measured drift), so an export
    /// of the replay is again a `gearcomp fit` data set.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub targets: Vec<String>,
}

fn one() -> f64 {
    1.0
}

impl ReplayInput {
    /// Checks the keys that need no file: `speedup` in range, a path, distinct targets.
    pub fn validate(&self) -> Result<()> {
        if self.path.as_os_str().is_empty() {
            return Err(invalid("input.path", "\"\"", "the CSV log to replay"));
        }
        check_range("input.speedup", self.speedup, 0.001, 1e6, "0.001…1e6")?;
        for (i, t) in self.targets.iter().enumerate() {
            if t.is_empty() || t == "time_s" || self.targets[..i].contains(t) {
                return Err(invalid(
                    format!("input.targets[{i}]"),
                    format!("{t:?}"),
                    "a column name of the log, not time_s, each once",
                ));
            }
        }
        Ok(())
    }
}
