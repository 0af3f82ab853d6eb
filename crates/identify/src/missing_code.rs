//! Numbers a data logger writes for a missing sample. Many loggers write a code such as
//! −9999 or 32767 where a sensor gave no reading (an open thermocouple, a probe out of
//! range, a channel not yet sampled). Read as a measurement, one such value among
//! temperatures of 18–32 °C dominates every least-squares fit and the model is garbage,
//! without a word. The reader refuses a log holding a common code far outside its column's
//! other values ([`check_logger_codes`]), and `--missing-code` reads the codes named as
//! empty cells ([`MissingCodes`]), which the missing-cell rules then handle: an empty input
//! cell follows `--missing`, an empty target cell is a row without a measurement.

use crate::error::{invalid, Result};

/// The codes data loggers commonly write for a missing sample, checked on every log.
pub const LOGGER_CODES: [f64; 10] = [
    -99.0, -999.0, -9999.0, -99999.0, 999.0, 9999.0, 99999.0, 32767.0, -32768.0, 65535.0,
];

/// A value counts as a code when it lies more than this many spans of the column's other
/// values beyond them.
pub const FAR_SPANS: f64 = 3.0;

/// Values read as empty cells (`--missing-code`), at most [`MissingCodes::MAX`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MissingCodes {
    codes: [f64; MissingCodes::MAX],
    len: usize,
}

impl MissingCodes {
    /// The most codes one read takes.
    pub const MAX: usize = 8;

    /// The codes given.
    ///
    /// # Errors
    /// More than [`MissingCodes::MAX`] codes, or one that is not finite, naming
    /// `--missing-code`.
    pub fn new(codes: &[f64]) -> Result<Self> {
        if codes.len() > Self::MAX {
            return Err(invalid(
                "--missing-code",
                format!("{} values", codes.len()),
                &format!("at most {} codes", Self::MAX),
            ));
        }
        let mut out = Self::default();
        for &c in codes {
            if !c.is_finite() {
                return Err(invalid(
                    "--missing-code",
                    c,
                    "a finite number (an empty or NaN cell is missing already)",
                ));
            }
            out.codes[out.len] = c;
            out.len += 1;
        }
        Ok(out)
    }

    /// No code given.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether `v` is one of the codes (exactly, as parsed).
    pub fn contains(&self, v: f64) -> bool {
        self.codes[..self.len].contains(&v)
    }
}

/// Refuses the columns (name and values as written, before any unit conversion: a table's
/// inputs and targets) of which one holds one of [`LOGGER_CODES`] more than [`FAR_SPANS`]
/// spans of the column's other finite values beyond them, naming the column, the code, its
/// rows (`line_of(i)`: where row i is, for messages) and `--missing-code`.
///
/// # Errors
/// The first such column and code.
pub fn check_logger_codes<'a>(
    columns: impl Iterator<Item = (&'a str, &'a [f64])>,
    line_of: &dyn Fn(usize) -> String,
) -> Result<()> {
    for (name, col) in columns {
        // A code far outside the others is the column's least or greatest value: one pass
        // over the column decides for almost every log.
        let (lo, hi) = min_max(col.iter().copied());
        if !(LOGGER_CODES.contains(&lo) || LOGGER_CODES.contains(&hi)) {
            continue;
        }
        let (lo, hi) = min_max(col.iter().copied().filter(|v| !LOGGER_CODES.contains(v)));
        if lo > hi {
            continue;
        }
        let span = (hi - lo).max(1e-6 * lo.abs().max(hi.abs()).max(1.0));
        for code in LOGGER_CODES {
            if code >= lo - FAR_SPANS * span && code <= hi + FAR_SPANS * span {
                continue;
            }
            let rows: Vec<usize> = (0..col.len()).filter(|&i| col[i] == code).collect();
            if rows.is_empty() {
                continue;
            }
            let shown: Vec<String> = rows.iter().take(5).map(|&i| line_of(i)).collect();
            let more = if rows.len() > 5 { ", …" } else { "" };
            return Err(invalid(
                name,
                format!(
                    "{code} on {} row(s) ({}{more})",
                    rows.len(),
                    shown.join(", ")
                ),
                &format!(
                    "a measured value: {code} lies far outside the column's other values ({lo} … {hi}), as a data logger's code for a missing sample does; read it as an empty cell with --missing-code {code} (an empty input cell then follows --missing, an empty target cell is a row without a measurement)"
                ),
            ));
        }
    }
    Ok(())
}

/// The least and greatest finite value (∞, −∞ when there is none).
fn min_max(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn codes_are_finite_and_few() {
        let c = MissingCodes::new(&[-9999.0, 32767.0]).unwrap();
        assert!(c.contains(-9999.0) && c.contains(32767.0) && !c.contains(0.0));
        assert!(MissingCodes::default().is_empty());
        let e = MissingCodes::new(&[f64::NAN]).unwrap_err().to_string();
        assert!(e.contains("--missing-code"), "{e}");
        let e = MissingCodes::new(&[1.0; 9]).unwrap_err().to_string();
        assert!(
            e.contains("--missing-code") && e.contains("at most 8"),
            "{e}"
        );
    }
}
