//! Numbers a data logger writes for a missing sample. Many loggers write a code such as
//! −9999 or 32767 where a sensor gave no reading (an open thermocouple, a probe out of
//! range, a channel not yet sampled). Read as a measurement, one such value among
//! temperatures of 18–32 °C dominates every least-squares fit and the model is garbage,
//! without a word. The reader refuses a log holding a common code far outside its column's
//! other values ([`check_columns`]), and `--missing-code` reads the codes named as
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

/// Tables of fewer cells are checked on one thread (a thread costs more than it saves).
const PARALLEL_MIN_CELLS: usize = 1 << 17;

/// Checks the columns (name and values as written, before any unit conversion: a table's
/// inputs and targets; `line_of(i)`: where row i is, for messages): logger codes
/// (`logger_codes`) and, unless `keep_far_values`, far groups (`far_values`), in that
/// order, with one pass over each column for both.
///
/// # Errors
/// The first column holding a logger code, else the first holding a far group.
pub fn check_columns<'a>(
    columns: impl Iterator<Item = (&'a str, &'a [f64])>,
    line_of: &dyn Fn(usize) -> String,
    keep_far_values: bool,
) -> Result<()> {
    let columns: Vec<(&str, &[f64])> = columns.collect();
    // Each column's pass on its own, on every core for a large table (the same extents: a
    // column's figures do not depend on the others).
    let cells: usize = columns.iter().map(|(_, c)| c.len()).sum();
    let extents: Vec<Extent> = if cells >= PARALLEL_MIN_CELLS {
        crate::par::par_map(&columns, |(_, c)| Extent::of(c))
    } else {
        columns.iter().map(|(_, c)| Extent::of(c)).collect()
    };
    logger_codes(&columns, &extents, line_of)?;
    if keep_far_values {
        return Ok(());
    }
    far_values(&columns, &extents, line_of)
}

/// Refuses the columns of which one holds one of [`LOGGER_CODES`] more than [`FAR_SPANS`]
/// spans of the column's other finite values beyond them, naming the column, the code, its
/// rows and `--missing-code`.
fn logger_codes(
    columns: &[(&str, &[f64])],
    extents: &[Extent],
    line_of: &dyn Fn(usize) -> String,
) -> Result<()> {
    for (&(name, col), ext) in columns.iter().zip(extents) {
        // A code far outside the others is the column's least or greatest value: one pass
        // over the column decides for almost every log.
        let (lo, hi) = (ext.lo, ext.hi);
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
/// One pass gives each column's mean, standard deviation and extremes. Far groups hold at
/// most m = max(1, ⌊n/100⌋) values on each side, separated from the others by gaps of more
/// than 15 of their spans. With the farthest value at distance L from the others, the groups
/// hold at most 2m of the n values, all within L: their share of the variance is at most
/// (2m/n)·L², the others' at most (L/30)², the mean moves by at most (2m/n)·L; for n ≥ 200
/// (2m/n ≤ 0.02) the farthest value then lies more than 6.5 standard deviations from the
/// mean, so such a column with both extremes within 4 standard deviations has no far group
/// and is not sorted. A shorter column (one far value on each side of 20–31 values can sit
/// within 4 of them) is always searched. The search reads the two ends of the sorted
/// values (a partial sort: linear time) for the widest gap, relative to the span of the
/// values on the near side of it (without the m values at the other end), among the last
/// and the first m.
///
/// # Errors
/// The first such column.
fn far_values(
    columns: &[(&str, &[f64])],
    extents: &[Extent],
    line_of: &dyn Fn(usize) -> String,
) -> Result<()> {
    for (&(name, col), ext) in columns.iter().zip(extents) {
        let Some(far) = far_group_of(col, ext) else {
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

/// The far group of a column (`far_values`): values above `above` or below
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

/// The far group of `col` (`far_values`), `None` when it has none.
pub fn far_group(col: &[f64]) -> Option<FarGroup> {
    far_group_of(col, &Extent::of(col))
}

/// [`far_group`] with the column's [`Extent`] taken already.
fn far_group_of(col: &[f64], ext: &Extent) -> Option<FarGroup> {
    let n = ext.n;
    if n < FAR_MIN_VALUES {
        return None;
    }
    let (lo, hi) = (ext.lo, ext.hi);
    let mean = ext.mean();
    let sd = ext.sd();
    // The pre-check of the method (`far_values`): sound for n ≥ 200 only.
    if n >= 200 && hi - mean <= 4.0 * sd && mean - lo <= 4.0 * sd {
        return None;
    }
    let mut v: Vec<f64> = col.iter().copied().filter(|v| v.is_finite()).collect();
    let m = ((n as f64 * FAR_GROUP_FRACTION) as usize).max(1);
    // Only v[..=m] and v[n−m−1..] of the sorted column are read below: partition around
    // those two ranks and sort the two ends alone (the same values at every index read as a
    // full sort puts there; `n ≥ FAR_MIN_VALUES` keeps the ends apart).
    sorted_ends(&mut v, m);
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

/// Puts at every index of `..=m` and of `n − m − 1..` of `v` the value a full sort (by
/// `total_cmp`) puts there, in linear time; the middle is left unordered.
fn sorted_ends(v: &mut [f64], m: usize) {
    let n = v.len();
    if n <= 2 * m + 2 {
        v.sort_by(f64::total_cmp);
        return;
    }
    v.select_nth_unstable_by(m, f64::total_cmp);
    v[..m].sort_by(f64::total_cmp);
    let upper = &mut v[m + 1..];
    let at = n - m - 1 - (m + 1);
    upper.select_nth_unstable_by(at, f64::total_cmp);
    upper[at + 1..].sort_by(f64::total_cmp);
}

/// Count, mean, spread and extremes of a column's finite values, in one pass (the column
/// checks read every column of every log: one pass over memory instead of three).
#[derive(Debug, Clone, Copy)]
struct Extent {
    n: usize,
    /// The first finite value: the sums are of deviations from it, so a column of large
    /// values with a small spread (epoch seconds, 1e6 + x) keeps its variance's digits.
    shift: f64,
    /// Σ (v − shift) and Σ (v − shift)².
    sum: f64,
    sq: f64,
    lo: f64,
    hi: f64,
}

impl Extent {
    /// In [`LANES`] independent lanes, then combined. A column of more than 2³² · 8 cells does
    /// not fit in memory.
    fn of(col: &[f64]) -> Self {
        let shift = col.iter().copied().find(|v| v.is_finite()).unwrap_or(0.0);
        // `f64::min`/`max` ignore NaN (a missing cell); a cell is never ±∞ here (the reader
        // refuses non-finite numbers), but one would be left out of every figure alike.
        let mut n = [0u32; LANES];
        let mut sum = [0.0f64; LANES];
        let mut sq = [0.0f64; LANES];
        let mut lo = [f64::INFINITY; LANES];
        let mut hi = [f64::NEG_INFINITY; LANES];
        let mut chunks = col.chunks_exact(LANES);
        for c in &mut chunks {
            for l in 0..LANES {
                let v = c[l];
                let finite = v.is_finite();
                let d = if finite { v - shift } else { 0.0 };
                n[l] += u32::from(finite);
                sum[l] += d;
                sq[l] += d * d;
                lo[l] = if finite { lo[l].min(v) } else { lo[l] };
                hi[l] = if finite { hi[l].max(v) } else { hi[l] };
            }
        }
        let mut out = Self {
            n: n.iter().map(|&k| k as usize).sum(),
            shift,
            sum: sum.iter().sum(),
            sq: sq.iter().sum(),
            lo: lo.iter().copied().fold(f64::INFINITY, f64::min),
            hi: hi.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        };
        for &v in chunks.remainder().iter().filter(|v| v.is_finite()) {
            out.n += 1;
            out.sum += v - shift;
            out.sq += (v - shift) * (v - shift);
            out.lo = out.lo.min(v);
            out.hi = out.hi.max(v);
        }
        out
    }

    fn mean(&self) -> f64 {
        self.shift + self.sum / self.n.max(1) as f64
    }

    /// The population standard deviation.
    fn sd(&self) -> f64 {
        let n = self.n.max(1) as f64;
        ((self.sq - self.sum * self.sum / n) / n).max(0.0).sqrt()
    }
}

/// Lanes of the column pass (independent additions the compiler can keep in vectors).
const LANES: usize = 8;

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

    /// The far group by its definition: every value sorted, every group size tried.
    fn far_group_by_full_sort(col: &[f64]) -> Option<(f64, f64, f64, f64, f64)> {
        let mut v: Vec<f64> = col.iter().copied().filter(|v| v.is_finite()).collect();
        let n = v.len();
        if n < FAR_MIN_VALUES {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let m = ((n as f64 * FAR_GROUP_FRACTION) as usize).max(1);
        // (ratio, above, below, others_lo, others_hi) of the best group on each side.
        let mut up: Option<(f64, f64, f64, f64, f64)> = None;
        let mut down: Option<(f64, f64, f64, f64, f64)> = None;
        for k in 1..=m {
            let (a, b) = (v[m.min(n - k - 1)], v[n - k - 1]);
            let r = (v[n - k] - b) / (b - a);
            if b > a && v[n - k] - b > FAR_GAP_RATIO * (b - a) && up.is_none_or(|u| r > u.0) {
                up = Some((r, b, f64::NEG_INFINITY, v[0], b));
            }
            let (a, b) = (v[k], v[(n - m - 1).max(k)]);
            let r = (a - v[k - 1]) / (b - a);
            if b > a && a - v[k - 1] > FAR_GAP_RATIO * (b - a) && down.is_none_or(|d| r > d.0) {
                down = Some((r, f64::INFINITY, a, a, v[n - 1]));
            }
        }
        match (up, down) {
            (Some(u), Some(d)) => Some((u.0.min(d.0), u.1, d.2, d.3, u.4)),
            (u, d) => u.or(d),
        }
    }

    /// The linear-time far group (partial sort, lane sums) against the full sort, on random
    /// columns with far groups planted above, below or both, ties, NaN cells and none at all.
    #[test]
    fn far_group_is_the_full_sort_definition() {
        let seeds = [1u64, 2, 3, 4, 5, 6, 7, 8, 13744, std::process::id() as u64];
        for seed in seeds {
            let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut r = move || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 11) as f64 / (1u64 << 53) as f64
            };
            for case in 0..400 {
                let n = 1 + (r() * 3000.0) as usize;
                let mut col: Vec<f64> = (0..n)
                    .map(|_| {
                        if case % 5 == 0 {
                            (r() * 8.0).round() // ties
                        } else {
                            20.0 + 5.0 * r()
                        }
                    })
                    .collect();
                let groups = (r() * 4.0) as usize;
                for g in 0..groups {
                    let size = 1 + (r() * (n as f64 * 0.012)) as usize;
                    let level = if g % 2 == 0 { 1.0 } else { -1.0 } * (50.0 + 500.0 * r());
                    for _ in 0..size {
                        let i = (r() * n as f64) as usize % n;
                        col[i] = level + r();
                    }
                }
                if case % 3 == 0 {
                    let i = (r() * n as f64) as usize % n;
                    col[i] = f64::NAN;
                }
                let got =
                    far_group(&col).map(|f| (f.ratio, f.above, f.below, f.others_lo, f.others_hi));
                let want = far_group_by_full_sort(&col);
                match (got, want) {
                    (Some(g), Some(w)) => assert_eq!(g, w, "seed {seed} case {case}"),
                    // The pre-check (an extreme beyond 4 sd) may only skip a column whose
                    // definition finds no group.
                    (None, w) => assert!(w.is_none(), "seed {seed} case {case}: {w:?}"),
                    (g, None) => panic!("seed {seed} case {case}: {g:?} not in the definition"),
                }
            }
        }
    }

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
