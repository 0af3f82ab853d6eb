//! Long high-rate logs made searchable: bin means over a fixed time step.
//!
//! A thermal test logged every second for days has far more rows than its physics needs:
//! the thermal time constants are minutes to hours. The dynamic families' search costs
//! training rows × (candidate columns)² ([`crate::pipeline::DYNAMIC_SEARCH_BUDGET`]), so on
//! such a log the default used to skip them. [`Table::resample`] replaces each bin of
//! `step_s` seconds within a segment by one row: the mean of every input and of the measured
//! target values in it, at the time of the bin's last sample. The model transforms treat an
//! input as held at each new sample over the step that ends at it
//! (`gearcomp_core::model`), and the bin mean is the best such held value over the bin, so
//! a lag of τ sees the bin means with an error of order step/τ. [`search_step_s`] picks the
//! step the default uses.

use crate::data::Table;
use crate::error::{invalid, Result};
use crate::fit::{IdentifyOptions, Split};
use crate::pipeline::{train_rows_of_any_target, DYNAMIC_SEARCH_BUDGET};

/// The shortest time constant or delay of the search over this step is the longest step
/// [`search_step_s`] chooses (a lag then sees at least this many bins per τ).
pub const BINS_PER_TAU: f64 = 10.0;

impl Table {
    /// The table of bin means over `step_s` seconds: within each segment, bins
    /// [t₀ + j·step, t₀ + (j + 1)·step) from the segment's first time t₀, also cut at
    /// `cut_s` (a train/test split time, so that no bin mixes training and test rows); each
    /// non-empty bin becomes one row at the time, line and file of its last sample, holding
    /// the mean of each input and the mean of each target's measured values (NaN where none
    /// is measured in the bin). Segments, runs and data issues stay as they were; a segment
    /// starts at the first bin of each old one.
    ///
    /// # Errors
    /// `step_s` not finite and > 0.
    pub fn resample(&self, step_s: f64, cut_s: Option<f64>) -> Result<Table> {
        if !(step_s.is_finite() && step_s > 0.0) {
            return Err(invalid("--resample-s", step_s, "a time step > 0 s"));
        }
        let mut out = Table {
            input_names: self.input_names.clone(),
            target_names: self.target_names.clone(),
            inputs: vec![Vec::new(); self.inputs.len()],
            targets: vec![Vec::new(); self.targets.len()],
            runs: self.runs.as_ref().map(|_| Vec::new()),
            run_names: self.run_names.clone(),
            files: self.files.clone(),
            issues: self.issues.clone(),
            // The gaps of the data read: resampling fills no gap (segments are kept).
            gap_after_s: self.gap_after_s,
            ..Table::default()
        };
        for (s, e) in self.segment_ranges() {
            out.segments.push(out.time_s.len());
            let t0 = self.time_s[s];
            let bin_of = |i: usize| {
                let t = self.time_s[i];
                let j = ((t - t0) / step_s).floor();
                // A bin never straddles the split: rows after it start a new bin.
                let after = cut_s.is_some_and(|c| t >= c);
                (j, after)
            };
            let mut start = s;
            while start < e {
                let key = bin_of(start);
                let mut end = start + 1;
                while end < e && bin_of(end) == key {
                    end += 1;
                }
                self.push_bin(&mut out, start, end);
                start = end;
            }
        }
        Ok(out)
    }

    /// Appends the mean row of rows `[start, end)` to `out`.
    fn push_bin(&self, out: &mut Table, start: usize, end: usize) {
        let last = end - 1;
        let mean = |v: &[f64]| {
            let (sum, n) = v[start..end]
                .iter()
                .filter(|x| x.is_finite())
                .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
            if n == 0 {
                f64::NAN
            } else {
                sum / n as f64
            }
        };
        out.time_s.push(self.time_s[last]);
        for (o, x) in out.inputs.iter_mut().zip(&self.inputs) {
            o.push(mean(x));
        }
        for (o, y) in out.targets.iter_mut().zip(&self.targets) {
            o.push(mean(y));
        }
        if let (Some(o), Some(r)) = (out.runs.as_mut(), self.runs.as_ref()) {
            o.push(r[last]);
        }
        out.lines.push(self.lines.get(last).copied().unwrap_or(0));
        out.file_of_row
            .push(self.file_of_row.get(last).copied().unwrap_or(0));
    }
}

/// The step in s over which the default ([`crate::fit::ModelKind::Auto`] with no families
/// named) resamples a log whose dynamic search would exceed
/// [`DYNAMIC_SEARCH_BUDGET`] on its `training_rows`: the smallest whole multiple k of the
/// median sample step that brings training rows / k × (candidate columns)² within it.
/// `None` when the search fits as it is, when families were named, or when that step
/// would exceed the shortest τ or delay searched / [`BINS_PER_TAU`] (the search is then
/// bounded to the static families, as before, and says so).
pub fn search_step_s(table: &Table, training_rows: usize, opts: &IdentifyOptions) -> Option<f64> {
    if !opts.families.is_empty() || opts.model != crate::fit::ModelKind::Auto {
        return None;
    }
    let cols = table.inputs.len() * (1 + opts.taus_s.len() + opts.delays_s.len());
    let cost = training_rows as f64 * (cols as f64).powi(2);
    if cost <= DYNAMIC_SEARCH_BUDGET {
        return None;
    }
    let mut steps: Vec<f64> = table
        .segment_ranges()
        .iter()
        .flat_map(|&(s, e)| (s + 1..e).map(|i| table.time_s[i] - table.time_s[i - 1]))
        .collect();
    if steps.is_empty() {
        return None;
    }
    let mid = steps.len() / 2;
    let median = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
    // A margin for the bins the segments and the split cut short.
    let k = (1.1 * cost / DYNAMIC_SEARCH_BUDGET).ceil();
    let step = k * median;
    let shortest = opts
        .taus_s
        .iter()
        .chain(&opts.delays_s)
        .copied()
        .fold(f64::INFINITY, f64::min);
    (step.is_finite() && step * BINS_PER_TAU <= shortest).then_some(step)
}

/// The table a fit runs on: bin means over `step_s` (`--resample-s`) when given, else over
/// the default's [`search_step_s`] when the search needs it; `None` to fit the table as it
/// is. With the table of bin means comes the note saying so (rows before and after, the
/// step, and why).
///
/// # Errors
/// A bad split of `table` (as `pipeline::train_mask` names it); a step that is not > 0 s,
/// or that leaves fewer than 10 training rows, naming `--resample-s`.
pub fn for_fit(
    table: &Table,
    split: &Split,
    opts: &IdentifyOptions,
    step_s: Option<f64>,
) -> Result<Option<(Table, String)>> {
    let before = train_rows_of_any_target(table, split)?
        .iter()
        .filter(|&&m| m)
        .count();
    let Some(step) = step_s.or_else(|| search_step_s(table, before, opts)) else {
        return Ok(None);
    };
    let cut = match split {
        Split::TimeBefore(s) => Some(*s),
        _ => None,
    };
    let r = table.resample(step, cut)?;
    if train_rows_of_any_target(&r, split).is_err() {
        return Err(invalid(
            "--resample-s",
            format!("{step} s"),
            &format!(
                "a step that leaves at least 10 training rows (fewer are left of the {before})"
            ),
        ));
    }
    let why = match step_s {
        Some(_) => "--resample-s",
        None => "the default: the dynamic families' search on every row would exceed its budget; --resample-s sets the step, --family searches every row",
    };
    let note = format!(
        "{} rows resampled to {} bin means of {step} s ({why})",
        table.time_s.len(),
        r.time_s.len()
    );
    Ok(Some((r, note)))
}
