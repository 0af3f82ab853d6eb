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

/// Values read as empty cells (`--missing-code`): numbers (−9999, 32767) and texts (`#N/A`,
/// `OVF`, `---`), at most [`MissingCodes::MAX`] in all. Kept inline (no allocation) so the
/// reading options stay `Copy`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MissingCodes {
    codes: [f64; MissingCodes::MAX],
    len: usize,
    texts: [([u8; MissingCodes::TEXT_MAX], u8); MissingCodes::MAX],
    n_texts: usize,
}

impl MissingCodes {
    /// The most codes one read takes.
    pub const MAX: usize = 8;

    /// The longest text code, in bytes.
    pub const TEXT_MAX: usize = 24;

    /// The numeric codes given.
    ///
    /// # Errors
    /// More than [`MissingCodes::MAX`] codes, or one that is not finite, naming
    /// `--missing-code`.
    pub fn new(codes: &[f64]) -> Result<Self> {
        let texts: Vec<String> = codes.iter().map(|c| format!("{c}")).collect();
        Self::parse(&texts)
    }

    /// The codes as the user wrote them: a cell that reads as a finite number is a numeric
    /// code (compared with the cell's value, so `-9999` matches `-9999.0`); any other text
    /// is a text code, compared with the cell's text without regard to ASCII case (`#N/A`
    /// matches `#n/a`).
    ///
    /// # Errors
    /// More than [`MissingCodes::MAX`] codes, an empty one, NaN or ±∞, or a text longer than
    /// [`MissingCodes::TEXT_MAX`] bytes, naming `--missing-code`.
    pub fn parse(codes: &[String]) -> Result<Self> {
        if codes.len() > Self::MAX {
            return Err(invalid(
                "--missing-code",
                format!("{} values", codes.len()),
                &format!("at most {} codes", Self::MAX),
            ));
        }
        let mut out = Self::default();
        for code in codes {
            let c = code.trim();
            match c.parse::<f64>() {
                Ok(v) if v.is_finite() => {
                    out.codes[out.len] = v;
                    out.len += 1;
                }
                Ok(v) => {
                    return Err(invalid(
                        "--missing-code",
                        v,
                        "a finite number or a text (an empty or NaN cell is missing already)",
                    ))
                }
                Err(_) if c.is_empty() => {
                    return Err(invalid(
                        "--missing-code",
                        "\"\"",
                        "a number or a text (an empty cell is missing already)",
                    ))
                }
                Err(_) if c.len() > Self::TEXT_MAX => {
                    return Err(invalid(
                        "--missing-code",
                        format!("a text of {} bytes", c.len()),
                        &format!("a text of at most {} bytes", Self::TEXT_MAX),
                    ))
                }
                Err(_) => {
                    let mut buf = [0u8; Self::TEXT_MAX];
                    buf[..c.len()].copy_from_slice(c.as_bytes());
                    out.texts[out.n_texts] = (buf, c.len() as u8);
                    out.n_texts += 1;
                }
            }
        }
        Ok(out)
    }

    /// No code given.
    pub fn is_empty(&self) -> bool {
        self.len == 0 && self.n_texts == 0
    }

    /// Whether `v` is one of the numeric codes (exactly, as parsed).
    pub fn contains(&self, v: f64) -> bool {
        self.codes[..self.len].contains(&v)
    }

    /// Whether the cell text `s` (trimmed) is one of the text codes, without regard to
    /// ASCII case.
    pub fn contains_text(&self, s: &str) -> bool {
        let s = s.trim().as_bytes();
        self.texts[..self.n_texts]
            .iter()
            .any(|(buf, n)| buf[..usize::from(*n)].eq_ignore_ascii_case(s))
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

/// A group of values counts as far (a sensor fault, not a measurement) when the empty gap
/// between it and the column's other values is more than this many times those values' span.
pub const FAR_GAP_RATIO: f64 = 15.0;

/// At most this fraction of a column's values (and at least one) form a far group.
pub const FAR_GROUP_FRACTION: f64 = 0.01;

/// Columns shorter than this are not judged (too few values to tell a fault from a level).
pub const FAR_MIN_VALUES: usize = 20;

/// Refuses a column (name and values as written: a table's inputs and targets) in which a
/// few values ([`FAR_GROUP_FRACTION`] of the column at most) stand apart from all the
/// others by an empty gap more than [`FAR_GAP_RATIO`] times the others' span: an open
/// Pt100 reading 850 °C, an int16 overflow written as 3276.7, a probe lifted off its
/// surface, among temperatures of 18–32 °C or displacements of a few µm. Such values are
/// not codes a logger documents ([`LOGGER_CODES`]), and three of them among 600 rows turn
/// an exact law into a fit several µm off, without a word. The message names the column,
/// the values, their lines, the others' range, and the two ways on: `--missing-code` (the
/// values read as empty cells) or `--keep-far-values` (fitted as written, for a real
/// reading that is rare and far, such as a short run at a speed the log otherwise never
/// reaches).
///
/// A column whose other values are all equal (a sensor constant but for one excursion) is
/// not judged: there is no span to compare the gap with.
///
/// # Method
/// One pass gives each column's mean, standard deviation and extremes. A far group of at
/// most 1 % of the values, separated by a gap of at least 10 spans of the others, puts the
/// extreme more than 6 standard deviations from the mean (the group's share of the variance
/// is at most 1 % of the squared distance, the others' spread at most a tenth of it), so a
/// column with both extremes within 4 standard deviations has no far group and is not
/// sorted. Otherwise the sorted values are searched for the widest gap, relative to the
/// span of the values on the near side of it (without the 1 % at the other end), among the
/// last and the first 1 %.
///
/// # Errors
/// The first such column.
pub fn check_far_values<'a>(
    columns: impl Iterator<Item = (&'a str, &'a [f64])>,
    line_of: &dyn Fn(usize) -> String,
) -> Result<()> {
    for (name, col) in columns {
        let Some(far) = far_group(col) else {
            continue;
        };
        let (lo, hi) = (far.others_lo, far.others_hi);
        let rows: Vec<usize> = (0..col.len()).filter(|&i| far.contains(col[i])).collect();
        let shown: Vec<String> = rows.iter().take(5).map(|&i| line_of(i)).collect();
        let more = if rows.len() > 5 { ", …" } else { "" };
        let mut values: Vec<f64> = rows.iter().map(|&i| col[i]).collect();
        values.sort_by(f64::total_cmp);
        values.dedup();
        let listed: Vec<String> = values.iter().take(4).map(|v| format!("{v}")).collect();
        let etc = if values.len() > 4 { " …" } else { "" };
        let codes = if values.len() <= MissingCodes::MAX {
            format!(
                "read them as empty cells with --missing-code {}",
                values
                    .iter()
                    .map(|v| format!("{v}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            )
        } else {
            "clean them from the log (more distinct values than --missing-code takes)".into()
        };
        return Err(invalid(
            name,
            format!(
                "{}{etc} on {} row(s) ({}{more})",
                listed.join(", "),
                rows.len(),
                shown.join(", ")
            ),
            &format!(
                "a measured value: these lie {:.0} spans of the column's other values ({lo} … {hi}) apart from them, as a sensor fault does (an open or shorted sensor, an overflow, a probe off its surface); {codes} (an empty input cell then follows --missing, an empty target cell is a row without a measurement); if they are real readings (a short run at a speed or power the log reaches nowhere else), fit them as written with --keep-far-values",
                far.ratio
            ),
        ));
    }
    Ok(())
}

/// The far group of a column ([`check_far_values`]): values above `above` or below
/// `below`, the others' range and the gap-to-span ratio.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FarGroup {
    /// Values greater than this are far (∞: none above).
    pub above: f64,
    /// Values less than this are far (−∞: none below).
    pub below: f64,
    /// Least and greatest of the other values.
    pub others_lo: f64,
    /// Greatest of the other values.
    pub others_hi: f64,
    /// The gap divided by the others' span.
    pub ratio: f64,
}

impl FarGroup {
    /// Whether `v` belongs to the far group.
    pub fn contains(&self, v: f64) -> bool {
        v > self.above || v < self.below
    }
}

/// The far group of `col` ([`check_far_values`]), `None` when it has none.
pub fn far_group(col: &[f64]) -> Option<FarGroup> {
    // One pass: count, mean and sum of squared deviations (Welford), extremes.
    let (mut n, mut mean, mut m2) = (0usize, 0.0f64, 0.0f64);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in col.iter().filter(|v| v.is_finite()) {
        n += 1;
        let d = v - mean;
        mean += d / n as f64;
        m2 += d * (v - mean);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if n < FAR_MIN_VALUES {
        return None;
    }
    let sd = (m2 / n as f64).sqrt();
    if hi - mean <= 4.0 * sd && mean - lo <= 4.0 * sd {
        return None;
    }
    let mut v: Vec<f64> = col.iter().copied().filter(|v| v.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let m = ((n as f64 * FAR_GROUP_FRACTION) as usize).max(1);
    // Upper side: the k largest values against v[m] … v[n−k−1].
    let mut best: Option<FarGroup> = None;
    for k in 1..=m {
        let (near_lo, near_hi) = (v[m.min(n - k - 1)], v[n - k - 1]);
        let span = near_hi - near_lo;
        let gap = v[n - k] - near_hi;
        if span > 0.0 && gap > FAR_GAP_RATIO * span {
            let ratio = gap / span;
            if best.is_none_or(|b| ratio > b.ratio) {
                best = Some(FarGroup {
                    above: near_hi,
                    below: f64::NEG_INFINITY,
                    others_lo: v[0],
                    others_hi: near_hi,
                    ratio,
                });
            }
        }
    }
    // Lower side: the k least values against v[k] … v[n−m−1].
    let mut low: Option<FarGroup> = None;
    for k in 1..=m {
        let (near_lo, near_hi) = (v[k], v[(n - m - 1).max(k)]);
        let span = near_hi - near_lo;
        let gap = near_lo - v[k - 1];
        if span > 0.0 && gap > FAR_GAP_RATIO * span {
            let ratio = gap / span;
            if low.is_none_or(|b| ratio > b.ratio) {
                low = Some(FarGroup {
                    above: f64::INFINITY,
                    below: near_lo,
                    others_lo: near_lo,
                    others_hi: v[n - 1],
                    ratio,
                });
            }
        }
    }
    match (best, low) {
        (Some(u), Some(l)) => Some(FarGroup {
            above: u.above,
            below: l.below,
            others_lo: l.others_lo,
            others_hi: u.others_hi,
            ratio: u.ratio.min(l.ratio),
        }),
        (u, l) => u.or(l),
    }
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
        let t = MissingCodes::parse(&["#N/A".into(), " OVF ".into(), "-9999".into()]).unwrap();
        assert!(t.contains_text("#n/a") && t.contains_text("ovf") && !t.contains_text("OV"));
        assert!(t.contains(-9999.0) && !t.contains_text("-9999") && !t.is_empty());
        for bad in ["", "inf", "NaN", &"x".repeat(25)] {
            let e = MissingCodes::parse(&[bad.to_string()])
                .unwrap_err()
                .to_string();
            assert!(e.contains("--missing-code"), "{e}");
        }
        let e = MissingCodes::new(&[1.0; 9]).unwrap_err().to_string();
        assert!(
            e.contains("--missing-code") && e.contains("at most 8"),
            "{e}"
        );
    }
}
