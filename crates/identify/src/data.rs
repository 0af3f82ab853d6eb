//! Reading thermal-test logs: a time column (or a fixed sample interval), input
//! (temperature) columns, target columns and optionally a run column, selected by name or
//! glob pattern; several files (one run each) are read by [`read_runs`]. Bad rows and time
//! gaps are reported with their line numbers; bad rows are an error unless the caller asks
//! to skip them, and skipped rows are still listed in [`Table::issues`].
//!
//! A table is cut into **segments**: a new run (run column value changes, next file) or a
//! time gap inside a run starts a new segment, and every filter, lag, delay and rate state
//! of the model restarts at a segment's first sample ([`Table::segments`]).

use crate::dialect::{self, CellError, Dialect};
use crate::error::{invalid, IdentifyError, Result};
use globset::Glob;

pub use crate::dialect::MissingCells;

/// Which columns to read.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Name of the time column (seconds; increasing within each run).
    pub time: String,
    /// Input columns: names or glob patterns (`t*_c`), in order; repeats are dropped.
    pub inputs: Vec<String>,
    /// Target columns: names or glob patterns.
    pub targets: Vec<String>,
    /// Optional column naming the run of each row (any text or number; time restarts in
    /// each run).
    pub run: Option<String>,
}

pub use crate::time_unit::DEFAULT_TIME_COLUMN;

impl Default for Selection {
    /// `time_s`, every `*_c` column (°C by the naming convention) as input, no target.
    fn default() -> Self {
        Self {
            time: DEFAULT_TIME_COLUMN.into(),
            inputs: vec!["*_c".into()],
            targets: Vec::new(),
            run: None,
        }
    }
}

/// How strict reading is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadOptions {
    /// Drop bad rows (still reported in [`Table::issues`]) instead of failing.
    pub skip_bad_rows: bool,
    /// A time step larger than this multiple of the median step (within runs) is a gap:
    /// it is reported and splits the run into segments.
    pub gap_factor: f64,
    /// The log has no time column: row k of a run (bad rows counted) is at k·Δt seconds.
    pub sample_interval_s: Option<f64>,
    /// Field delimiter (`,` `;` tab); `None`: detected from each file's header.
    pub delimiter: Option<u8>,
    /// Numbers written with a decimal comma; `None`: detected on the data when the
    /// delimiter is `;` or tab ([`dialect::detect_decimal_comma`]).
    pub decimal_comma: Option<bool>,
    /// Rows with an empty or NaN used cell: an error, or left out with the run split there.
    pub missing: MissingCells,
    /// The first row is data, not a header: columns are named by position, `c1` … `cN`
    /// ([`positional_name`]).
    pub no_header: bool,
    /// The unit of the target columns, converted to µm on reading
    /// ([`crate::target_unit`]); `None`: the values as written.
    pub target_unit: Option<crate::target_unit::TargetUnit>,
    /// The unit of a numeric time column, converted to seconds on reading
    /// ([`crate::time_unit`]); `None`: seconds as written.
    pub time_unit: Option<crate::time_unit::TimeUnitChoice>,
    /// Values read as empty cells: a data logger's codes for a missing sample
    /// ([`crate::missing_code`]).
    pub missing_codes: crate::missing_code::MissingCodes,
    /// A numeric time that falls starts a new run (several runs in one file without a run
    /// column: `1`, `2` … in file order; within a named run `name`, `name/2` …) instead of
    /// a bad row.
    pub runs_at_restarts: bool,
    /// Values standing far apart from their column's others (a sensor fault:
    /// [`crate::missing_code::check_columns`]) are fitted as written instead of refused.
    pub keep_far_values: bool,
    /// The order of day and month in slash dates (`03/01/2024`); `None`: from the dates,
    /// refusing one that reads either way ([`dialect::is_ambiguous_slash_date`]).
    pub date_order: Option<dialect::DateOrder>,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            skip_bad_rows: false,
            gap_factor: 3.0,
            sample_interval_s: None,
            delimiter: None,
            decimal_comma: None,
            missing: MissingCells::Error,
            no_header: false,
            target_unit: None,
            time_unit: None,
            missing_codes: crate::missing_code::MissingCodes::default(),
            runs_at_restarts: false,
            keep_far_values: false,
            date_order: None,
        }
    }
}

/// The name of the column at 0-based position `k` of a log read with
/// [`ReadOptions::no_header`]: `c1` for the first column.
pub fn positional_name(k: usize) -> String {
    format!("c{}", k + 1)
}

/// The hint added to a column that was not found when the header row holds numbers only:
/// the log seems to have no header row (`--no-header`).
pub(crate) fn no_header_hint(name: &str, header: &[String], decimal_comma: bool) -> String {
    let numeric = !header.is_empty()
        && header
            .iter()
            .all(|h| dialect::parse_number(h, "", decimal_comma).is_ok());
    if numeric {
        format!(
            " (the first row of {name} holds numbers only: it seems to have no header row; read it with --no-header, its columns are then named {} … {})",
            positional_name(0),
            positional_name(header.len() - 1)
        )
    } else {
        String::new()
    }
}

/// Something noticed while reading.
#[derive(Debug, Clone, PartialEq)]
pub enum DataIssue {
    /// A row that was rejected (and dropped, when skipping was asked for).
    BadRow {
        /// 1-based line number in the file (header = line 1).
        line: u64,
        /// Why.
        reason: String,
    },
    /// A time step much larger than the median step: the run is split there (every model
    /// state restarts after it).
    Gap {
        /// Line of the row after the gap.
        line: u64,
        /// Time before the gap in s.
        from_s: f64,
        /// Time after the gap in s.
        to_s: f64,
    },
    /// A row with an empty or NaN used cell, left out under [`MissingCells::Split`] (the
    /// run is split there: every model state restarts at the next row), or under
    /// [`MissingCells::Hold`] before the run's first value of that input.
    Missing {
        /// 1-based line number in the file.
        line: u64,
        /// Which cell.
        reason: String,
        /// Under [`MissingCells::Hold`]: no earlier value in the run to hold.
        hold: bool,
    },
    /// A target column converted to µm ([`ReadOptions::target_unit`]).
    Unit {
        /// The target column.
        column: String,
        /// Its unit.
        unit: crate::target_unit::LengthUnit,
        /// Where the unit came from (`the units row`, `the column name`, `--target-unit`).
        from: &'static str,
    },
    /// The time column converted to seconds ([`ReadOptions::time_unit`]).
    TimeUnit {
        /// The time column.
        column: String,
        /// Its unit.
        unit: crate::time_unit::TimeUnit,
        /// Where the unit came from (`the units row`, `the column name`, `--time-unit`).
        from: &'static str,
    },
    /// Empty or NaN cells of an input that hold its last value ([`MissingCells::Hold`]).
    Held {
        /// Line of the first such cell.
        line: u64,
        /// The input column.
        column: String,
        /// How many cells of it hold a value.
        cells: usize,
    },
    /// The log has no [`DEFAULT_TIME_COLUMN`] and one column that reads as a time axis,
    /// taken as the time.
    TimeColumn {
        /// The column taken.
        column: String,
    },
    /// A run whose rows came back after another run's: each run's rows were taken together.
    RunsTogether {
        /// 1-based line of the first row that came back.
        line: u64,
        /// The run and the blocks.
        reason: String,
    },
    /// A log file that is not UTF-8, decoded as `encoding` ([`crate::encoding`]).
    Encoding {
        /// The file.
        file: String,
        /// What it was read as (`UTF-16LE`, `windows-1252`, …).
        encoding: &'static str,
    },
    /// How a file was read where the log did not say it outright: the order of its slash
    /// dates from its first date that reads only one way (no `--date-order` given), inputs
    /// or targets found by their unit (the default patterns matching nothing).
    Note {
        /// 1-based line number it concerns (of that date; 1 for the columns).
        line: u64,
        /// What was read, and how.
        reason: String,
    },
    /// Lines that are not data: title lines above the header, a units row under it
    /// ([`crate::preamble`]).
    Skipped {
        /// 1-based line number in the file (the first of them).
        line: u64,
        /// What they are.
        reason: String,
    },
}

impl std::fmt::Display for DataIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DataIssue::BadRow { line, reason } => write!(f, "line {line}: bad row: {reason}"),
            DataIssue::Gap { line, from_s, to_s } => write!(
                f,
                "line {line}: time gap of {:.0} s ({from_s} s → {to_s} s): the run is split, filters restart",
                to_s - from_s
            ),
            DataIssue::Encoding { file, encoding } => write!(
                f,
                "{file}: not UTF-8, read as {encoding} (its °, µ and umlauts as that encoding writes them)"
            ),
            DataIssue::Skipped { line, reason }
            | DataIssue::Note { line, reason }
            | DataIssue::RunsTogether { line, reason } => {
                write!(f, "line {line}: {reason}")
            }
            DataIssue::TimeColumn { column } => write!(
                f,
                "time column: {column:?} (the log has no {DEFAULT_TIME_COLUMN} column and this one reads as a time axis; name another with --time-column)"
            ),
            DataIssue::Missing {
                line,
                reason,
                hold: false,
            } => write!(
                f,
                "line {line}: left out ({reason}; --missing split): the run is split there, filters restart"
            ),
            DataIssue::Missing {
                line,
                reason,
                hold: true,
            } => write!(
                f,
                "line {line}: left out ({reason}, with no earlier value in its run to hold; --missing hold)"
            ),
            DataIssue::Unit { column, unit, from } => write!(
                f,
                "{column}: in {} ({from}), read as µm (× {})",
                unit.symbol(),
                unit.um_per_unit()
            ),
            DataIssue::TimeUnit { column, unit, from } => write!(
                f,
                "{column}: in {} ({from}), read as seconds (× {}): every time constant, delay and split is in s",
                unit.symbol(),
                unit.s_per_unit()
            ),
            DataIssue::Held {
                line,
                column,
                cells,
            } => write!(
                f,
                "line {line}: {column}: {cells} empty or NaN cell(s) from here on hold the last value before them (--missing hold)"
            ),
        }
    }
}

/// A column-major table of the selected columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Time stamps in s, strictly increasing within each segment.
    pub time_s: Vec<f64>,
    /// Names of the input columns.
    pub input_names: Vec<String>,
    /// Input columns, each `time_s.len()` long.
    pub inputs: Vec<Vec<f64>>,
    /// Names of the target columns.
    pub target_names: Vec<String>,
    /// Target columns; NaN on the rows where a target was not measured (an empty or NaN
    /// cell: see [`Table::measured`]).
    pub targets: Vec<Vec<f64>>,
    /// Run of each row (index into `run_names`), when the data has runs (a run column or
    /// several files).
    pub runs: Option<Vec<usize>>,
    /// Name of each run, in order of first appearance.
    pub run_names: Vec<String>,
    /// First row of each segment (ascending, starts with 0 when there are rows): every
    /// model state restarts there (new run, or a gap inside a run).
    pub segments: Vec<usize>,
    /// The time step (s) beyond which a step inside a run is a gap (`gap_factor` × the
    /// median step within runs), when the data has steps: the model file's
    /// `restart_after_s`, so that the engine restarts its states where the fit did.
    pub gap_after_s: Option<f64>,
    /// Source line of each kept row.
    pub lines: Vec<u64>,
    /// File of each kept row's line (index into `files`).
    pub file_of_row: Vec<usize>,
    /// Names of the files read.
    pub files: Vec<String>,
    /// Bad rows and gaps, in file order (prefixed by the file name when several).
    pub issues: Vec<DataIssue>,
}

impl Table {
    /// The runs of the training rows in order of appearance, when there are at least two (the
    /// folds are then by run); `None` for a log without runs or with one training run, whose
    /// time increases (the folds are then blocks of time, as for a log without runs).
    pub(crate) fn training_runs(&self, train: &[bool]) -> Option<Vec<usize>> {
        let runs = self.runs.as_ref()?;
        let mut seen: Vec<usize> = Vec::new();
        for (r, &m) in runs.iter().zip(train) {
            if m && !seen.contains(r) {
                seen.push(*r);
            }
        }
        (seen.len() >= 2).then_some(seen)
    }

    /// The rows `[start, end)` of each segment.
    pub fn segment_ranges(&self) -> Vec<(usize, usize)> {
        let n = self.time_s.len();
        let mut out = Vec::with_capacity(self.segments.len());
        for (k, &s) in self.segments.iter().enumerate() {
            let e = self.segments.get(k + 1).copied().unwrap_or(n);
            if e > s {
                out.push((s, e));
            }
        }
        out
    }

    /// Rows left out of the table (bad rows skipped, rows with missing cells under
    /// [`MissingCells::Split`]): their count and the lines of the first ten, in file order.
    pub fn rows_left_out(&self) -> (usize, Vec<u64>) {
        let lines: Vec<u64> = self
            .issues
            .iter()
            .filter_map(|i| match i {
                DataIssue::BadRow { line, .. } | DataIssue::Missing { line, .. } => Some(*line),
                DataIssue::Gap { .. }
                | DataIssue::Skipped { .. }
                | DataIssue::Note { .. }
                | DataIssue::RunsTogether { .. }
                | DataIssue::Encoding { .. }
                | DataIssue::Held { .. }
                | DataIssue::Unit { .. }
                | DataIssue::TimeUnit { .. }
                | DataIssue::TimeColumn { .. } => None,
            })
            .collect();
        (lines.len(), lines.into_iter().take(10).collect())
    }

    /// The rows on which every target was measured. A log often probes the displacement
    /// every few minutes while it writes the temperatures every few seconds: the other
    /// rows hold NaN in a target, still drive every filter, lag and transfer function at
    /// the full rate, and are neither fitted nor scored.
    pub fn measured(&self) -> Vec<bool> {
        (0..self.time_s.len())
            .map(|i| self.targets.iter().all(|y| y[i].is_finite()))
            .collect()
    }

    /// The test rows: neither training rows (`train`, from `pipeline::train_mask`) nor rows
    /// with a target left unmeasured ([`Table::measured`]).
    pub fn test_mask(&self, train: &[bool]) -> Vec<bool> {
        train
            .iter()
            .zip(self.measured())
            .map(|(&t, m)| !t && m)
            .collect()
    }

    /// The note on targets not measured on every row (`None` when each is): how many rows
    /// each is measured on and what the other rows do.
    pub fn measured_note(&self) -> Option<String> {
        let n = self.time_s.len();
        let counts: Vec<usize> = self
            .targets
            .iter()
            .map(|y| y.iter().filter(|v| v.is_finite()).count())
            .collect();
        if counts.iter().all(|&c| c == n) {
            return None;
        }
        let each: Vec<String> = self
            .target_names
            .iter()
            .zip(&counts)
            .map(|(name, c)| format!("{name} on {c}"))
            .collect();
        let all = self.measured().iter().filter(|&&m| m).count();
        let both = if self.targets.len() > 1 && counts.iter().any(|&c| c != all) {
            format!(
                "; {all} rows have every target, and only those are fitted and scored (fit the targets one at a time to use every measurement)"
            )
        } else {
            String::new()
        };
        Some(format!(
            "targets measured on some rows only ({} of {n} rows){both}: the rows without a target value drive the filters, lags and transfer functions at the full rate and are neither fitted nor scored",
            each.join(", ")
        ))
    }

    /// Number of runs (1 without run information).
    pub fn run_count(&self) -> usize {
        self.runs.as_ref().map_or(1, |_| self.run_names.len())
    }

    /// Index of the run named `name`: the same text, or the same number ("3" = "3.0").
    pub fn run_index(&self, name: &str) -> Option<usize> {
        let name = name.trim();
        self.run_names.iter().position(|r| r == name).or_else(|| {
            let v: f64 = name.parse().ok()?;
            self.run_names
                .iter()
                .position(|r| r.parse::<f64>().is_ok_and(|w| w == v))
        })
    }

    /// Makes every segment a run of its own: a production log of many days whose nights are
    /// time gaps becomes one run per day, validated leave-one-run-out and named in
    /// `--test-runs`. Without runs before, the runs are named `1` … `N` in time order; a run
    /// that had a name keeps it when it is one segment and becomes `name/1` … `name/k` when
    /// gaps cut it. Returns the number of runs; a table of one segment is left as it is.
    pub fn make_segments_runs(&mut self) -> usize {
        let ranges = self.segment_ranges();
        if ranges.len() < 2 {
            return self.run_count();
        }
        let old = self.runs.take();
        let old_names = std::mem::take(&mut self.run_names);
        let mut runs = vec![0usize; self.time_s.len()];
        // Segments of each old run, to know which runs were cut.
        let pieces = |r: usize| {
            ranges
                .iter()
                .filter(|&&(s, _)| old.as_ref().map_or(0, |o| o[s]) == r)
                .count()
        };
        let mut seen_of_run: Vec<usize> = vec![0; old_names.len().max(1)];
        for (k, &(s, e)) in ranges.iter().enumerate() {
            let name = match &old {
                None => (k + 1).to_string(),
                Some(o) => {
                    let r = o[s];
                    let base = old_names.get(r).cloned().unwrap_or_default();
                    match seen_of_run.get_mut(r) {
                        Some(c) if pieces(r) > 1 => {
                            *c += 1;
                            format!("{base}/{c}")
                        }
                        _ => base,
                    }
                }
            };
            runs[s..e].iter_mut().for_each(|x| *x = k);
            self.run_names.push(name);
        }
        self.runs = Some(runs);
        self.run_names.len()
    }
}

fn resolve(patterns: &[String], header: &[String], exclude: &[usize]) -> Result<Vec<usize>> {
    let mut out: Vec<usize> = Vec::new();
    for p in patterns {
        let exact: Vec<usize> = header
            .iter()
            .enumerate()
            .filter(|(_, h)| *h == p)
            .map(|(i, _)| i)
            .collect();
        let hits = if exact.is_empty() {
            let m = Glob::new(p)
                .map_err(|e| invalid("column pattern", p, &format!("a glob pattern ({e})")))?
                .compile_matcher();
            header
                .iter()
                .enumerate()
                .filter(|(i, h)| m.is_match(h.as_str()) && !exclude.contains(i))
                .map(|(i, _)| i)
                .collect()
        } else {
            exact
        };
        if hits.is_empty() {
            return Err(IdentifyError::ColumnNotFound {
                pattern: p.clone(),
                available: header.join(", "),
            });
        }
        for h in hits {
            if !out.contains(&h) {
                out.push(h);
            }
        }
    }
    Ok(out)
}

/// Reads CSV text (header row, comma separated) into a [`Table`].
///
/// `name` is used in messages. Every selected cell must be a finite number and time must
/// increase strictly within a run; rows breaking that are listed by line and, unless
/// [`ReadOptions::skip_bad_rows`], make the read fail. With a run column, each change of
/// its value starts a new run (time may restart); without one the file is one run.
pub fn read_csv(text: &str, name: &str, sel: &Selection, opts: ReadOptions) -> Result<Table> {
    read_runs(&[(text, name)], sel, opts)
}

/// The selected columns of one file.
struct Cols<'a> {
    header: &'a [String],
    time_idx: Option<usize>,
    /// Time-of-day column when the time is a date column and a time column
    /// (`--time-column DATE+TIME`): the row's stamp is "date time".
    time2_idx: Option<usize>,
    run_idx: Option<usize>,
    input_idx: Vec<usize>,
    target_idx: Vec<usize>,
    many: bool,
    stem: String,
    dialect: Dialect,
    /// The time column as the log names it (`Date+Time` for a date and a time column).
    time_name: String,
}

/// The date column beside the time-of-day column `time` of a log (a `Date` or `Datum`
/// column, one only), when the first data row holds a clock time there and the two cells
/// read together as a time stamp.
fn date_beside(header: &[String], time: usize, text: &str, delimiter: u8) -> Option<usize> {
    let dates: Vec<usize> = (0..header.len())
        .filter(|&i| matches!(header[i].trim().to_lowercase().as_str(), "date" | "datum"))
        .collect();
    let [d] = dates[..] else {
        return None;
    };
    let row: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.contains(header[time].as_str()))
        .skip(1)
        .find(|l| !l.trim().is_empty())?
        .split(char::from(delimiter))
        .map(|c| c.trim().trim_matches('"'))
        .collect();
    let (date, clock) = (row.get(d)?, row.get(time)?);
    (dialect::parse_clock(clock, false).is_some()
        && (dialect::parse_timestamp(&format!("{date} {clock}")).is_some()
            || dialect::is_ambiguous_slash_date(&format!("{date} {clock}"))))
    .then_some(d)
}

/// The columns not in `exclude` whose unit is of `kind`: in brackets in the name (`Spindel
/// [°C]`, `Z (µm)`) or in the units row.
fn unit_columns(
    header: &[String],
    units_row: &[String],
    kind: crate::quantity::Quantity,
    exclude: &[usize],
) -> Vec<usize> {
    (0..header.len())
        .filter(|i| !exclude.contains(i))
        .filter(|&i| kind.in_brackets(&header[i]) || units_row.get(i).is_some_and(|u| kind.is(u)))
        .collect()
}

/// The column indices `idx` (named `names`) reordered to follow `wanted`, when `names` are
/// the names of `wanted` in any order, each once; None otherwise.
fn same_names_in_order(idx: &[usize], names: &[String], wanted: &[String]) -> Option<Vec<usize>> {
    if names.len() != wanted.len() {
        return None;
    }
    wanted
        .iter()
        .map(|w| {
            let at: Vec<usize> = (0..names.len()).filter(|&k| names[k] == *w).collect();
            match at[..] {
                [k] => Some(idx[k]),
                _ => None,
            }
        })
        .collect()
}

/// Per-file reading state carried from row to row.
#[derive(Default)]
struct RowState {
    last_line: u64,
    cur_run: Option<String>,
    ordinal: u64,
    prev_t: Option<f64>,
    /// The time column holds time stamps (decided at its first non-empty cell).
    stamps: Option<bool>,
    /// Those stamps are clock or elapsed times `h:mm:ss` ([`dialect::parse_clock`]).
    clock: bool,
    /// Instant of the run's first time stamp in ns.
    t0: Option<i64>,
    /// The file's time stamps carry a UTC offset (decided at the first one).
    has_offset: Option<bool>,
    /// The order of the file's slash dates: `--date-order`, else what its dates that read
    /// only one way say ([`dialect::date_order_of`]).
    date_order: Option<dialect::DateOrder>,
    /// A row was left out for a missing cell: the next kept row starts a segment.
    split_pending: bool,
    /// Under [`MissingCells::Hold`]: each input's value on the last kept row of the run.
    held: Vec<Option<f64>>,
    /// Under [`ReadOptions::runs_at_restarts`]: how often the time restarted in this run
    /// (of the run column, or of the file).
    restarts: usize,
    /// The state of each run left for another's rows, taken up again when its rows come
    /// back (two machines logged row by row in one file).
    parked: Vec<(String, RunState)>,
}

/// The part of [`RowState`] that belongs to one run.
#[derive(Default)]
struct RunState {
    ordinal: u64,
    prev_t: Option<f64>,
    t0: Option<i64>,
    split_pending: bool,
    held: Vec<Option<f64>>,
    restarts: usize,
}

impl RowState {
    /// Leaves the current run (its state parked) for `run`, whose parked state is taken up
    /// again when its rows came before, or which starts afresh.
    fn switch_run(&mut self, run: &str) {
        let leaving = RunState {
            ordinal: self.ordinal,
            prev_t: self.prev_t,
            t0: self.t0,
            split_pending: self.split_pending,
            held: std::mem::take(&mut self.held),
            restarts: self.restarts,
        };
        if let Some(cur) = self.cur_run.take() {
            self.parked.push((cur, leaving));
        }
        let back = match self.parked.iter().position(|(r, _)| r == run) {
            Some(k) => self.parked.swap_remove(k).1,
            None => RunState::default(),
        };
        self.cur_run = Some(run.to_string());
        self.ordinal = back.ordinal;
        self.prev_t = back.prev_t;
        self.t0 = back.t0;
        self.split_pending = back.split_pending;
        self.held = back.held;
        self.restarts = back.restarts;
    }
}

/// The records of quote-free CSV text from byte `start` (just after the header): each line
/// with its 1-based number (`\n` or `\r\n` ends). `None` when the text needs the full CSV
/// reader: a quote anywhere, or a lone `\r` (which the csv crate takes as a line end).
fn plain_records(text: &str, start: usize) -> Option<Vec<(u64, &str)>> {
    let b = text.as_bytes();
    if b.contains(&b'"') {
        return None;
    }
    let rest = text.get(start..)?;
    let first = 1 + b[..start].iter().filter(|&&c| c == b'\n').count() as u64;
    let mut out = Vec::with_capacity(rest.len() / 64 + 1);
    for (line, l) in (first..).zip(rest.split('\n')) {
        let l = l.strip_suffix('\r').unwrap_or(l);
        if l.as_bytes().contains(&b'\r') {
            return None;
        }
        out.push((line, l));
    }
    Some(out)
}

/// The selected columns of a clean quote-free log: `cols[s]` holds column `slots[s]`, with
/// the 1-based source line of each row.
struct CleanTable {
    cols: Vec<Vec<f64>>,
    lines: Vec<u64>,
}

/// One piece of a clean log: the columns of its rows, each row's line as an offset from the
/// piece's first line, and the number of lines the piece holds.
struct CleanPiece {
    cols: Vec<Vec<f64>>,
    line_offsets: Vec<u64>,
    line_count: u64,
}

/// Texts shorter than this are parsed on one thread (spawning costs more than it saves).
const PARALLEL_MIN_BYTES: usize = 1 << 18;

/// The records of quote-free CSV text from byte `start` (just after the header) when every
/// one is clean: `width` fields, the `slots` columns finite numbers (the time column first,
/// strictly increasing), or blank (every field empty, skipped as the row-by-row path skips
/// it). `None` at the first other record (wrong width, bad or non-finite cell, time not
/// increasing, a quote or a lone `\r` anywhere): the caller then reads row by row, which
/// reports it. The text is cut into pieces at line ends, one per core, parsed at once.
fn clean_table(text: &str, start: usize, width: usize, slots: &[usize]) -> Option<CleanTable> {
    let threads = if text.len() < PARALLEL_MIN_BYTES {
        1
    } else {
        crate::par::cores()
    };
    clean_table_in(text, start, width, slots, threads)
}

/// [`clean_table`] cut into at most `threads` pieces.
fn clean_table_in(
    text: &str,
    start: usize,
    width: usize,
    slots: &[usize],
    threads: usize,
) -> Option<CleanTable> {
    let rest = text.get(start..)?;
    // A quote in the header is seen here; one in the records declines the piece that holds
    // it (`field_end` stops at it, and no clean row or blank line holds one), so the text is
    // not scanned for quotes before the pieces start.
    if text.as_bytes()[..start].contains(&b'"') || slots.is_empty() {
        return None;
    }
    let first = 1 + text.as_bytes()[..start]
        .iter()
        .filter(|&&c| c == b'\n')
        .count() as u64;
    // Cut points just after a line end, so every piece is whole lines.
    let mut cuts = vec![0usize];
    for k in 1..threads {
        let from = (rest.len() * k / threads).max(*cuts.last().unwrap_or(&0));
        match rest.as_bytes()[from..].iter().position(|&b| b == b'\n') {
            Some(p) if from + p + 1 < rest.len() => cuts.push(from + p + 1),
            _ => break,
        }
    }
    cuts.push(rest.len());
    let pieces: Vec<&str> = cuts.windows(2).map(|w| &rest[w[0]..w[1]]).collect();
    let parsed: Vec<Option<CleanPiece>> = if pieces.len() == 1 {
        vec![clean_piece(pieces[0], width, slots)]
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = pieces[1..]
                .iter()
                .map(|p| s.spawn(move || clean_piece(p, width, slots)))
                .collect();
            let mut out = vec![clean_piece(pieces[0], width, slots)];
            out.extend(handles.into_iter().map(|h| h.join().ok().flatten()));
            out
        })
    };
    assemble(first, parsed.into_iter().collect::<Option<_>>()?)
}

/// The pieces of a clean log, in order, as one table (`first`: the line of the first
/// piece's first line).
fn assemble(first: u64, parsed: Vec<CleanPiece>) -> Option<CleanTable> {
    let rows: usize = parsed.iter().map(|p| p.line_offsets.len()).sum();
    // The first piece's columns grow to hold the others (no copy of the first piece).
    let mut parsed = parsed.into_iter();
    let p0 = parsed.next()?;
    let mut t = CleanTable {
        cols: p0.cols,
        lines: Vec::with_capacity(rows),
    };
    for col in &mut t.cols {
        col.reserve_exact(rows - col.len());
    }
    t.lines.extend(p0.line_offsets.iter().map(|o| first + o));
    let mut line0 = first + p0.line_count;
    for p in parsed {
        // Time must also increase across the cut.
        if let (Some(prev), Some(next)) = (t.cols[0].last(), p.cols[0].first()) {
            if next <= prev {
                return None;
            }
        }
        for (all, piece) in t.cols.iter_mut().zip(&p.cols) {
            all.extend_from_slice(piece);
        }
        t.lines.extend(p.line_offsets.iter().map(|o| line0 + o));
        line0 += p.line_count;
    }
    Some(t)
}

/// The end of the field that starts at `at`: the next `,`, line end or `\r`, or a quote
/// (`"`: the row is then not clean, since the byte after a field must be a delimiter or a
/// line end, and the text goes to the csv crate).
fn field_end(b: &[u8], at: usize) -> usize {
    b[at..]
        .iter()
        .position(|&c| matches!(c, b',' | b'\n' | b'\r' | b'"'))
        .map_or(b.len(), |p| at + p)
}

/// The row of a clean log that starts at byte `at` of `piece`: its `slot_of.len()` fields,
/// the selected ones (`slot_of[k]`: the column of field `k`, or `usize::MAX`) pushed onto
/// `cols` as finite numbers. The start of the next line, or `None` when the line is not
/// such a row (the caller then decides between a blank line and the row-by-row path).
///
/// A field is read by `fast_float2::parse_partial` when the number it reads ends the field
/// (the next byte a delimiter or a line end); any other field (spaces around it, text, an
/// empty cell) goes through `str::parse` of the trimmed field as before. Both round
/// correctly, so a value is the same bits either way (`fast_parse_is_std_parse` below).
fn clean_row(
    piece: &str,
    mut at: usize,
    slot_of: &[usize],
    cols: &mut [Vec<f64>],
) -> Option<usize> {
    let b = piece.as_bytes();
    for (k, &s) in slot_of.iter().enumerate() {
        if s == usize::MAX {
            at = field_end(b, at);
        } else {
            let v = match fast_float2::parse_partial::<f64, _>(&b[at..]) {
                Ok((v, n)) if matches!(b.get(at + n), None | Some(b',' | b'\n' | b'\r')) => {
                    at += n;
                    v
                }
                _ => {
                    let e = field_end(b, at);
                    let v = piece.get(at..e)?.trim_ascii().parse::<f64>().ok()?;
                    at = e;
                    v
                }
            };
            if !v.is_finite() {
                return None;
            }
            cols[s].push(v);
        }
        let last = k + 1 == slot_of.len();
        match (b.get(at), last) {
            (Some(b','), false) => at += 1,
            (None, true) => return Some(at),
            (Some(b'\n'), true) => return Some(at + 1),
            // `\r` only as part of a line end (`\r\n`, or the text's last byte).
            (Some(b'\r'), true) => {
                return match b.get(at + 1) {
                    None => Some(at + 1),
                    Some(b'\n') => Some(at + 2),
                    Some(_) => None,
                }
            }
            _ => return None,
        }
    }
    None
}

/// One piece of [`clean_table`] (whole lines; the last may lack its line end), read row by
/// row with [`clean_row`]. A line that is not a clean row is skipped when blank (every
/// field empty, as the row-by-row path skips it); any other makes the piece `None`.
fn clean_piece(piece: &str, width: usize, slots: &[usize]) -> Option<CleanPiece> {
    let mut p = PieceParser::new(width, slots, piece.len())?;
    p.lines(piece)?;
    Some(p.done())
}

/// [`clean_piece`] fed in consecutive slices of whole lines (a file read in chunks).
struct PieceParser {
    /// The column of each field, or `usize::MAX` for a field not read.
    slot_of: Vec<usize>,
    piece: CleanPiece,
    prev_t: f64,
}

impl PieceParser {
    /// A parser for a piece of about `bytes` bytes (its columns' capacity).
    fn new(width: usize, slots: &[usize], bytes: usize) -> Option<Self> {
        let mut slot_of = vec![usize::MAX; width];
        for (s, &k) in slots.iter().enumerate() {
            let e = slot_of.get_mut(k)?;
            if *e != usize::MAX {
                return None;
            }
            *e = s;
        }
        let rows = bytes / (8 * width).max(1) + 1;
        // One allocation per column (`vec![Vec::with_capacity(rows); k]` would clone an
        // empty vector, capacity 0, into all but the last: growth by reallocation and copies).
        let cols: Vec<Vec<f64>> = (0..slots.len()).map(|_| Vec::with_capacity(rows)).collect();
        Some(Self {
            slot_of,
            piece: CleanPiece {
                cols,
                line_offsets: Vec::with_capacity(rows),
                line_count: 0,
            },
            prev_t: f64::NEG_INFINITY,
        })
    }

    /// The next whole lines of the piece (`text` ends with a line end, except at the end
    /// of the piece); `None` at a line that is neither a clean row nor blank.
    fn lines(&mut self, text: &str) -> Option<()> {
        let b = text.as_bytes();
        let p = &mut self.piece;
        let mut pos = 0;
        while pos < b.len() {
            if let Some(next) = clean_row(text, pos, &self.slot_of, &mut p.cols) {
                let t = *p.cols[0].last()?;
                if t <= self.prev_t {
                    return None;
                }
                self.prev_t = t;
                p.line_offsets.push(p.line_count);
                pos = next;
            } else {
                for col in p.cols.iter_mut() {
                    col.truncate(p.line_offsets.len());
                }
                let nl = b[pos..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |q| pos + q);
                let end = if nl > pos && b[nl - 1] == b'\r' {
                    nl - 1
                } else {
                    nl
                };
                if !b[pos..end]
                    .iter()
                    .all(|c| matches!(c, b',' | b' ' | b'\t' | b'\x0c'))
                {
                    return None;
                }
                pos = nl + 1;
            }
            p.line_count += 1;
        }
        Some(())
    }

    fn done(self) -> CleanPiece {
        self.piece
    }
}

/// Bytes read at a time by [`clean_table_file`] (each thread reuses one such buffer).
const FILE_CHUNK_BYTES: usize = 1 << 18;

/// [`clean_table`] of the records of the file at `path` from byte `start` (just after the
/// header line(s) `head`), read in chunks of `chunk` bytes into a small buffer per thread and parsed as
/// they come, instead of reading the whole file into memory first (the fresh pages of a
/// 4.4 MB buffer cost more than the copy: ≈ 2.0 against 0.3 ms). The file is cut into one
/// byte range per core; a line belongs to the range its first byte is in, or to the one
/// before when it starts just at the cut (each thread finds its first line start after
/// its cut, and the thread before reads up to that line end). The same table as
/// [`clean_table`] of the file's text; `None` where that declines, and on any read error
/// or text that is not UTF-8 (the caller then reads the text, which reports it).
fn clean_table_file(
    path: &std::path::Path,
    head: &str,
    start: usize,
    width: usize,
    slots: &[usize],
    chunk: usize,
) -> Option<CleanTable> {
    let before = head.as_bytes().get(..start)?;
    if before.contains(&b'"') || slots.is_empty() {
        return None;
    }
    let first_line = 1 + before.iter().filter(|&&c| c == b'\n').count() as u64;
    let start = start as u64;
    let file = std::fs::File::open(path).ok()?;
    let len = file.metadata().ok()?.len();
    if start > len {
        return None;
    }
    let threads = if len - start < PARALLEL_MIN_BYTES as u64 {
        1
    } else {
        crate::par::cores()
    };
    clean_file_in(&file, first_line, start, len, width, slots, chunk, threads)
}

/// [`clean_table_file`] of the open `file` (`len` bytes, the records from `start`, the
/// first of them on line `first_line`) cut into `threads` byte ranges.
#[allow(clippy::too_many_arguments)]
fn clean_file_in(
    file: &std::fs::File,
    first_line: u64,
    start: u64,
    len: u64,
    width: usize,
    slots: &[usize],
    chunk: usize,
    threads: usize,
) -> Option<CleanTable> {
    let body = len.checked_sub(start)?;
    let threads = threads.max(1) as u64;
    let cuts: Vec<u64> = (0..=threads).map(|k| start + body * k / threads).collect();
    let piece =
        |k: usize| clean_file_range(file, cuts[k], cuts[k + 1], k == 0, width, slots, chunk);
    let parsed: Vec<Option<CleanPiece>> = if threads == 1 {
        vec![piece(0)]
    } else {
        std::thread::scope(|s| {
            let piece = &piece;
            let handles: Vec<_> = (1..threads as usize)
                .map(|k| s.spawn(move || piece(k)))
                .collect();
            let mut out = vec![piece(0)];
            out.extend(handles.into_iter().map(|h| h.join().ok().flatten()));
            out
        })
    };
    assemble(first_line, parsed.into_iter().collect::<Option<_>>()?)
}

/// The lines of `file` that belong to the byte range `[from, to)` of [`clean_table_file`]
/// (`whole`: `from` is a line start, the first range), parsed by a [`PieceParser`].
fn clean_file_range(
    file: &std::fs::File,
    from: u64,
    to: u64,
    whole: bool,
    width: usize,
    slots: &[usize],
    chunk: usize,
) -> Option<CleanPiece> {
    use std::os::unix::fs::FileExt;
    let mut parser = PieceParser::new(width, slots, usize::try_from(to - from).ok()?)?;
    let mut buf: Vec<u8> = Vec::with_capacity(2 * chunk.max(1));
    // File offset of buf[0]; whether the first line start has been found.
    let mut off = from;
    let mut started = whole;
    let mut eof = false;
    loop {
        // Top up the buffer (the unparsed tail of the last read stays at its front).
        let have = buf.len();
        buf.resize(have + chunk.max(1), 0);
        let n = loop {
            match file.read_at(&mut buf[have..], off + have as u64) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(_) => return None,
            }
        };
        buf.truncate(have + n);
        eof |= n == 0;
        let mut at = 0usize;
        if !started {
            // The first line start after the cut (a line starting at `from` itself, i.e. a
            // line end at from − 1, belongs to the range before, which reads up to the
            // first line end at or after `from`).
            match buf.iter().position(|&c| c == b'\n') {
                Some(p) => {
                    at = p + 1;
                    started = true;
                }
                None if eof => return Some(parser.done()),
                None => {
                    off += buf.len() as u64;
                    buf.clear();
                    continue;
                }
            }
        }
        // The range ends after the first line end at or after `to` (at `at` when that is
        // the line end just found: a range holding no line start).
        let end_in_buf = usize::try_from(to.saturating_sub(off)).ok()?;
        let stop = buf
            .get(end_in_buf..)
            .and_then(|tail| tail.iter().position(|&c| c == b'\n'))
            .map(|p| (end_in_buf + p + 1).max(at));
        let (upto, last) = match stop {
            Some(e) => (e, true),
            None if eof => (buf.len(), true),
            None => match buf[at..].iter().rposition(|&c| c == b'\n') {
                Some(p) => (at + p + 1, false),
                None => (at, false),
            },
        };
        let text = std::str::from_utf8(&buf[at..upto]).ok()?;
        parser.lines(text)?;
        if last {
            return Some(parser.done());
        }
        buf.drain(..upto);
        off += upto as u64;
    }
}

struct Reader<'a> {
    sel: &'a Selection,
    opts: ReadOptions,
    t: Table,
    bad: Vec<(usize, u64, String)>,
    run_label: Vec<String>,
    /// Rows left out for missing cells (`--missing split`, or `hold` before a first value):
    /// file, line, reason, under `hold`.
    missing: Vec<(usize, u64, String, bool)>,
    /// Inputs whose empty cells held a value (`--missing hold`): file and line of the first,
    /// column, count.
    held: Vec<(usize, String, u64, usize)>,
    /// The first file's units-row cell of each target (none without a units row).
    target_unit_cells: Vec<Option<String>>,
    /// The first file's time column (none with a sample interval) and its units-row cell.
    time_column: Option<(String, Option<String>)>,
    /// A time stamp was read in the time column.
    time_stamps: bool,
    /// Those stamps are clock or elapsed times (`h:mm:ss`).
    time_clock: bool,
    /// The time column taken for a missing [`DEFAULT_TIME_COLUMN`] (the first file's).
    time_taken: Option<String>,
    /// Rows whose time does not increase, for the hint of the bad-rows error (a restart, a
    /// log newest first).
    drops: Drops,
    /// The runs come from the data (a run column, or several files), not only from
    /// restarts ([`ReadOptions::runs_at_restarts`]).
    named_runs: bool,
    /// Title lines and units rows read as blank lines (file, line, what).
    skipped: Vec<(usize, u64, String)>,
    /// How a file was read where the log did not say it outright: (file, line, note).
    notes: Vec<(usize, u64, String)>,
    /// Kept rows that start a segment because missing rows were left out before them.
    forced: Vec<usize>,
    /// Run name of each file (its stem when not given): the sheets of one workbook.
    file_runs: &'a [String],
    /// Where the records come from when the text given to [`Reader::file`] is only the
    /// header line ([`read_csv_file`]); taken when read.
    source: Source<'a>,
    /// [`read_csv_file`] cannot read the file by [`clean_table_file`].
    declined: bool,
}

impl<'a> Reader<'a> {
    fn new(
        sel: &'a Selection,
        opts: ReadOptions,
        file_runs: &'a [String],
        source: Source<'a>,
    ) -> Self {
        Reader {
            sel,
            opts,
            t: Table::default(),
            bad: Vec::new(),
            run_label: Vec::new(),
            missing: Vec::new(),
            held: Vec::new(),
            target_unit_cells: Vec::new(),
            time_column: None,
            time_stamps: false,
            time_clock: false,
            time_taken: None,
            drops: Drops::default(),
            named_runs: false,
            skipped: Vec::new(),
            notes: Vec::new(),
            forced: Vec::new(),
            file_runs,
            source,
            declined: false,
        }
    }

    /// The table of one log whose header line is `head` and whose records come from the
    /// reader's source; None when the header is refused or the source declines (the
    /// caller then reads the text, whose messages are the ones a user sees).
    fn read_after_header(mut self, head: &str, name: &str) -> Option<Result<Table>> {
        self.t.files.push(name.to_string());
        if self.file(0, head, name, false).is_err() || self.declined {
            return None;
        }
        let opts = self.opts;
        Some(finish_read(self, &[name], opts))
    }
}

/// Reads one or several CSV files (`(text, name)` pairs) into one [`Table`]; with several
/// files, each file is a run named after the file (or `file:run` with a run column).
///
/// Every file must hold the same selected columns (by name; column order may differ).
pub fn read_runs(files: &[(&str, &str)], sel: &Selection, opts: ReadOptions) -> Result<Table> {
    read_named_runs(files, &[], sel, opts)
}

/// [`read_runs`] with the run name of each file given (`file_runs[k]` instead of file k's
/// stem; the sheets of a workbook share its file name).
pub(crate) fn read_named_runs(
    files: &[(&str, &str)],
    file_runs: &[String],
    sel: &Selection,
    opts: ReadOptions,
) -> Result<Table> {
    check_read_options(opts)?;
    if files.is_empty() {
        return Err(invalid("data", "no files", "at least one CSV file"));
    }
    let names: Vec<&str> = files.iter().map(|f| f.1).collect();
    // Several files without given run names: each its own run, named by its stem or, where
    // stems collide (`day1/log.csv day2/log.csv`), by as much of its path as tells it apart.
    let own_names;
    let file_runs = if file_runs.is_empty() && files.len() > 1 {
        own_names = file_run_names(&names)?;
        &own_names[..]
    } else {
        file_runs
    };
    let mut r = Reader::new(sel, opts, file_runs, Source::Text);
    for (fi, (text, name)) in files.iter().enumerate() {
        r.t.files.push(name.to_string());
        r.file(fi, text, name, files.len() > 1)?;
    }
    finish_read(r, &names, opts)
}

/// The run name of each of several files: its stem (`day 1.csv` → `day 1`), or, for files
/// whose stems are the same, the shortest ending of their paths that differs
/// (`a/log.csv`, `b/log.csv` → `a/log`, `b/log`; `x.csv`, `x.txt` → `x.csv`, `x.txt`).
///
/// # Errors
/// The same file named twice (`--data g.csv g.csv`: its rows would be one run twice over).
pub(crate) fn file_run_names(names: &[&str]) -> Result<Vec<String>> {
    use std::path::{Component, Path};
    // Each name's candidates, shortest first: the stem, then the parents before it, then
    // the same with the file name instead of the stem.
    let candidates: Vec<Vec<String>> = names
        .iter()
        .map(|name| {
            let path = Path::new(name);
            let parts: Vec<String> = path
                .parent()
                .into_iter()
                .flat_map(Path::components)
                .filter(|c| matches!(c, Component::Normal(_)))
                .map(|c| c.as_os_str().to_string_lossy().into_owned())
                .collect();
            let stem = path
                .file_stem()
                .map_or(name.to_string(), |s| s.to_string_lossy().into_owned());
            let file = path
                .file_name()
                .map_or(name.to_string(), |s| s.to_string_lossy().into_owned());
            let mut out = Vec::with_capacity(2 * parts.len() + 2);
            for last in [stem, file] {
                for k in 0..=parts.len() {
                    let mut v = parts[parts.len() - k..].to_vec();
                    v.push(last.clone());
                    out.push(v.join("/"));
                }
            }
            out.push(name.to_string());
            out
        })
        .collect();
    let mut level = vec![0usize; names.len()];
    loop {
        let current: Vec<&str> = (0..names.len())
            .map(|i| candidates[i][level[i]].as_str())
            .collect();
        let mut clash = false;
        for i in 0..names.len() {
            if current
                .iter()
                .enumerate()
                .any(|(j, c)| j != i && *c == current[i])
            {
                clash = true;
                if level[i] + 1 < candidates[i].len() {
                    level[i] += 1;
                } else {
                    return Err(invalid(
                        "--data",
                        names[i],
                        "each file once (it is named twice)",
                    ));
                }
            }
        }
        if !clash {
            return Ok(current.into_iter().map(str::to_string).collect());
        }
    }
}

/// Reads the CSV file at `path` as [`read_csv`] reads its text (`name` in messages), when
/// it is a clean single-run log (the case [`clean_table`] handles: every row complete,
/// finite, time increasing; comma delimited, a plain header): the records are read in
/// chunks and parsed as they come ([`clean_table_file`]), without the whole text in
/// memory. `None` for any other file, or any error (a missing column, an unreadable
/// file): the caller then reads the text and [`read_csv`] gives the table or the error
/// exactly as before. `Some` holds the same table (or error of the rows as a whole, e.g.
/// too few) as [`read_csv`] of the file's text.
pub fn read_csv_file(
    path: &std::path::Path,
    name: &str,
    sel: &Selection,
    opts: ReadOptions,
) -> Option<Result<Table>> {
    if check_read_options(opts).is_err() {
        return None;
    }
    let head = header_line(path)?;
    Reader::new(sel, opts, &[], Source::File(path)).read_after_header(&head, name)
}

/// The first control character of the first line of `text` that no text log holds (C0
/// other than tab and carriage return, DEL, C1: the bytes of a binary file read as text,
/// Windows-1252's five undefined bytes among them); `None` for a text line.
fn control_in_first_line(text: &str) -> Option<char> {
    let line = text.split('\n').next().unwrap_or_default();
    line.chars()
        .find(|&c| (c < ' ' && c != '\t' && c != '\r') || ('\u{7f}'..='\u{9f}').contains(&c))
}

/// Where [`Reader::file`] finds the records.
enum Source<'a> {
    /// In the text given.
    Text,
    /// In the file, after the header line given as the text ([`clean_table_file`]).
    File(&'a std::path::Path),
}

/// The first line of the file at `path` with its line end (at most 1 MiB), as text; `None`
/// for anything but a regular file (a pipe read here would lose what was read).
fn header_line(path: &std::path::Path) -> Option<String> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).ok()?;
    if !f.metadata().ok()?.is_file() {
        return None;
    }
    let mut head = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        let n = f.read(&mut chunk).ok()?;
        let part = chunk.get(..n)?;
        if let Some(p) = part.iter().position(|&c| c == b'\n') {
            head.extend_from_slice(&part[..=p]);
            return String::from_utf8(head).ok();
        }
        head.extend_from_slice(part);
        if n == 0 || head.len() > 1 << 20 {
            return None;
        }
    }
}

/// The checks of [`ReadOptions`] that do not depend on the data.
fn check_read_options(opts: ReadOptions) -> Result<()> {
    if !(opts.gap_factor.is_finite() && opts.gap_factor > 1.0) {
        return Err(invalid("gap_factor", opts.gap_factor, "a factor > 1"));
    }
    if let Some(dt) = opts.sample_interval_s {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(invalid(
                "--sample-interval-s",
                dt,
                "a sample interval > 0 s",
            ));
        }
    }
    Ok(())
}

/// Converts each target column to µm by its unit ([`crate::target_unit::resolve`]; `cells`:
/// its units-row cell), with a note first in the issues for each one converted.
fn to_micrometres(
    t: &mut Table,
    choice: crate::target_unit::TargetUnit,
    cells: &[Option<String>],
) -> Result<()> {
    use crate::target_unit::{resolve, LengthUnit};
    let mut notes = Vec::new();
    for (j, name) in t.target_names.iter().enumerate() {
        let (unit, from) = resolve(choice, name, cells.get(j).and_then(|c| c.as_deref()))?;
        if unit != LengthUnit::Um {
            let k = unit.um_per_unit();
            for v in &mut t.targets[j] {
                *v *= k;
            }
            notes.push(DataIssue::Unit {
                column: name.clone(),
                unit,
                from,
            });
        }
    }
    t.issues.splice(0..0, notes);
    Ok(())
}

/// Puts each run's rows together (runs in the order they first appear, each run's rows in
/// their order), when a run's rows come back after another run's; `forced` (rows that start
/// a segment) follows its rows. Returns the first row that came back (its file, line and
/// run) and the count of blocks of rows in the log, or None when every run's rows were
/// together.
fn regroup_runs(t: &mut Table, forced: &mut [usize]) -> Option<(usize, u64, usize, usize)> {
    let runs = t.runs.as_ref()?;
    let mut rank: Vec<Option<usize>> = vec![None; t.run_names.len()];
    let (mut blocks, mut next, mut first) = (0usize, 0usize, None);
    for (i, &r) in runs.iter().enumerate() {
        if i > 0 && runs[i - 1] == r {
            continue;
        }
        blocks += 1;
        match rank.get_mut(r) {
            Some(Some(_)) => {
                first.get_or_insert(i);
            }
            Some(slot) => {
                *slot = Some(next);
                next += 1;
            }
            None => return None,
        }
    }
    let i = first?;
    let key = |r: usize| rank.get(r).copied().flatten().unwrap_or(usize::MAX);
    let mut order: Vec<usize> = (0..runs.len()).collect();
    order.sort_by_key(|&k| key(runs[k]));
    let pick = |v: &[f64]| order.iter().map(|&k| v[k]).collect::<Vec<f64>>();
    let came_back = (t.file_of_row[i], t.lines[i], runs[i], blocks);
    t.time_s = pick(&t.time_s);
    for c in t.inputs.iter_mut().chain(t.targets.iter_mut()) {
        *c = pick(c);
    }
    t.runs = Some(order.iter().map(|&k| runs[k]).collect());
    t.lines = order.iter().map(|&k| t.lines[k]).collect();
    t.file_of_row = order.iter().map(|&k| t.file_of_row[k]).collect();
    let mut new_at = vec![0usize; order.len()];
    for (to, &from) in order.iter().enumerate() {
        new_at[from] = to;
    }
    for f in forced.iter_mut() {
        if let Some(&to) = new_at.get(*f) {
            *f = to;
        }
    }
    Some(came_back)
}

/// Rows whose time does not increase (within a run).
#[derive(Debug, Default)]
struct Drops {
    /// How many.
    count: usize,
    /// The first: file, line, the time before it, its time.
    first: Option<(usize, u64, f64, f64)>,
    /// The second: file, line.
    second: Option<(usize, u64)>,
}

/// What rows whose time does not increase suggest (`rows`: the data rows read): a log
/// written newest first (the time falls on nine rows in ten or more), or a time that
/// restarts (the time falls, and the next row is below the time before the fall too:
/// several runs in one file without a run column); with time stamps (`stamps`), a fall of
/// about an hour is the autumn's daylight-saving change of a local clock. One row out of
/// order suggests none of these.
fn time_drop_hint(
    drops: Drops,
    rows: usize,
    (stamps, clock): (bool, bool),
    run_column: Option<&str>,
    where_: &dyn Fn(usize, u64) -> String,
) -> String {
    let (n, Some((fi, line, prev, time))) = (drops.count, drops.first) else {
        return String::new();
    };
    if rows >= 3 && n * 10 >= (rows - 1) * 9 {
        return format!(
            "; the time falls on {n} of {rows} rows: the log seems to run newest first (sort it oldest first)"
        );
    }
    if time == prev {
        return format!(
            "; the time repeats at {}: time stamps written to the second (or coarser) while the logger samples faster? Write the stamps with their fraction (08:00:00.500), or keep the first row of each time with --skip-bad-rows",
            where_(fi, line)
        );
    }
    if clock && time < prev {
        return format!(
            "; the clock time falls at {}: a time of day past midnight, or an elapsed time that restarts? Give the date with the time (a date column and a time column: --time-column DATE+TIME; or stamps 2024-03-01 00:00:30), or name the runs (--run-column, --runs-at-restarts)",
            where_(fi, line)
        );
    }
    if stamps && (3000.0..=3600.0).contains(&(prev - time)) {
        return format!(
            "; local time stamps fall by about an hour at {}: a daylight-saving change? Write the stamps with their UTC offset (2024-10-27 02:30:00+02:00) or in UTC",
            where_(fi, line)
        );
    }
    if let (true, Some(column)) = (
        time < prev && drops.second == Some((fi, line + 1)),
        run_column,
    ) {
        // The run column is named: a label written again for a later run (R1, R2, R1) makes
        // one run of both, whose time then restarts.
        return format!(
            "; the time restarts at {} ({prev} → {time}) within one run of --run-column {column}: a label used again for a later run? The rows of a label are one run wherever they are; give each run its own label",
            where_(fi, line)
        );
    }
    if time < prev && drops.second == Some((fi, line + 1)) {
        return format!(
            "; the time restarts at {} ({prev} → {time}): several runs in one file? Name the run column with --run-column, read each restart as a new run with --runs-at-restarts, or give each run its own file (--data a.csv b.csv …)",
            where_(fi, line)
        );
    }
    String::new()
}

/// The least time (unit not named) read as Unix time in milliseconds: 1e11 (1973 in ms, the
/// year 5138 in s).
const EPOCH_MS_MIN: f64 = 1e11;

/// Converts a numeric time column to seconds by its unit ([`crate::time_unit::resolve`];
/// `cell`: its units-row cell; `stamps`: it held time stamps); the note when converted.
fn to_seconds(
    t: &mut Table,
    choice: crate::time_unit::TimeUnitChoice,
    column: &str,
    cell: Option<&str>,
    stamps: bool,
) -> Result<Option<DataIssue>> {
    let (mut unit, mut from) = crate::time_unit::resolve(choice, column, cell, stamps)?;
    // Nothing names the unit: a time of 1e11 or more is no count of seconds (that is the
    // year 5138 as Unix time, 3 000 years as a duration) but Unix time in milliseconds
    // (1e11 ms is 1973), as loggers and databases write it.
    let first = t.time_s.iter().copied().find(|v| v.is_finite());
    if from == crate::time_unit::FROM_DEFAULT && first.is_some_and(|v| v.abs() >= EPOCH_MS_MIN) {
        if first.is_some_and(|v| v.abs() >= EPOCH_MS_MIN * 1000.0) {
            return Err(invalid(
                &format!("time column {column}"),
                first.unwrap_or_default(),
                "seconds, or Unix time in milliseconds (below 1e14): a larger time is in µs or ns; convert it to seconds or milliseconds, or name the unit with --time-unit",
            ));
        }
        unit = crate::time_unit::TimeUnit::Ms;
        from = "its size: Unix time in milliseconds; as seconds it would lie past the year 5000";
    }
    if unit == crate::time_unit::TimeUnit::S {
        return Ok(None);
    }
    let k = unit.s_per_unit();
    for v in &mut t.time_s {
        *v *= k;
    }
    Ok(Some(DataIssue::TimeUnit {
        column: column.to_string(),
        unit,
        from,
    }))
}

/// The table of a [`Reader`] that has read every file (`names[k]`: file k in messages):
/// bad rows refused or listed, segments at runs and time gaps, the issues in line order.
fn finish_read(r: Reader<'_>, names: &[&str], opts: ReadOptions) -> Result<Table> {
    let Reader {
        mut t,
        bad,
        missing,
        held,
        target_unit_cells,
        time_column,
        time_stamps,
        time_clock,
        time_taken,
        drops,
        named_runs,
        skipped,
        notes,
        forced,
        sel,
        ..
    } = r;
    let many = names.len() > 1;
    let where_ = |fi: usize, line: u64| {
        if many {
            format!("{}: line {line}", names[fi])
        } else {
            format!("line {line}")
        }
    };
    if !bad.is_empty() && !opts.skip_bad_rows {
        let lines: Vec<String> = bad.iter().take(20).map(|b| b.1.to_string()).collect();
        let files_with: Vec<&str> = {
            let mut v: Vec<&str> = Vec::new();
            for b in &bad {
                if !v.contains(&names[b.0]) {
                    v.push(names[b.0]);
                }
            }
            v
        };
        return Err(IdentifyError::BadRows {
            path: files_with.join(", "),
            count: bad.len(),
            lines: if bad.len() > 20 {
                format!("{}, …", lines.join(", "))
            } else {
                lines.join(", ")
            },
            first_reason: format!(
                "{}{}",
                if many {
                    format!("{} ({})", bad[0].2, where_(bad[0].0, bad[0].1))
                } else {
                    bad[0].2.clone()
                },
                time_drop_hint(
                    drops,
                    t.time_s.len() + bad.len(),
                    (time_stamps, time_clock),
                    sel.run.as_deref(),
                    &where_
                )
            ),
        });
    }
    // One run found by restarts alone is no run: the log as without the option.
    if opts.runs_at_restarts && !named_runs && t.run_names.len() <= 1 {
        t.runs = None;
        t.run_names.clear();
    }
    let columns = t
        .input_names
        .iter()
        .zip(&t.inputs)
        .chain(t.target_names.iter().zip(&t.targets))
        .map(|(n, c)| (n.as_str(), c.as_slice()));
    let line_of = |i: usize| {
        where_(
            t.file_of_row.get(i).copied().unwrap_or(0),
            t.lines.get(i).copied().unwrap_or(0),
        )
    };
    crate::missing_code::check_columns(columns, &line_of, opts.keep_far_values)?;
    let time_note = match (opts.time_unit, &time_column) {
        (Some(choice), Some((column, cell))) => {
            to_seconds(&mut t, choice, column, cell.as_deref(), time_stamps)?
        }
        (Some(crate::time_unit::TimeUnitChoice::Given(u)), None) => {
            return Err(invalid(
                "--time-unit",
                u.symbol(),
                "no unit without a time column (--sample-interval-s is in seconds)",
            ))
        }
        _ => None,
    };
    let mut issues: Vec<(usize, u64, DataIssue)> = bad
        .into_iter()
        .map(|(fi, line, reason)| {
            let reason = if many {
                format!("{}: {reason}", names[fi])
            } else {
                reason
            };
            (fi, line, DataIssue::BadRow { line, reason })
        })
        .collect();
    issues.extend(missing.into_iter().map(|(fi, line, reason, hold)| {
        let reason = if many {
            format!("{}: {reason}", names[fi])
        } else {
            reason
        };
        (fi, line, DataIssue::Missing { line, reason, hold })
    }));
    issues.extend(held.into_iter().map(|(fi, column, line, cells)| {
        let column = if many {
            format!("{}: {column}", names[fi])
        } else {
            column
        };
        (
            fi,
            line,
            DataIssue::Held {
                line,
                column,
                cells,
            },
        )
    }));
    // A note of file `fi`, prefixed with the file's name when there are several.
    let of_file = |fi: usize, reason: String| {
        if many {
            format!("{}: {reason}", names[fi])
        } else {
            reason
        }
    };
    issues.extend(notes.into_iter().map(|(fi, line, reason)| {
        let reason = of_file(fi, reason);
        (fi, line, DataIssue::Note { line, reason })
    }));
    issues.extend(skipped.into_iter().map(|(fi, line, reason)| {
        let reason = of_file(fi, reason);
        (fi, line, DataIssue::Skipped { line, reason })
    }));
    // A run whose rows come back after another run's: each run's rows taken together.
    let mut forced = forced;
    if let Some((fi, line, run, blocks)) = regroup_runs(&mut t, &mut forced) {
        let reason = format!(
            "run {} comes back after another run's rows ({blocks} blocks of {} runs, as when two machines are logged row by row): each run's rows are taken together, in their order, so every filter, lag and delay runs through its run",
            t.run_names.get(run).map_or("?", String::as_str),
            t.run_names.len()
        );
        let reason = of_file(fi, reason);
        issues.push((fi, line, DataIssue::RunsTogether { line, reason }));
    }
    // Segments: a new run starts one; a gap (step > gap_factor × the median step within
    // runs) inside a run starts another.
    let n = t.time_s.len();
    let run_of = |i: usize| t.runs.as_ref().map_or(0, |r| r[i]);
    let mut run_start = vec![false; n];
    for (i, s) in run_start.iter_mut().enumerate() {
        *s = i == 0 || run_of(i) != run_of(i - 1) || t.file_of_row[i] != t.file_of_row[i - 1];
    }
    // Rows left out for missing cells split the run (`--missing split`).
    for &i in &forced {
        if let Some(s) = run_start.get_mut(i) {
            *s = true;
        }
    }
    let mut steps: Vec<f64> = (1..n)
        .filter(|&i| !run_start[i])
        .map(|i| t.time_s[i] - t.time_s[i - 1])
        .collect();
    let median = if steps.is_empty() {
        f64::INFINITY
    } else {
        // The element a full sort would put at len/2 (the same value), in linear time.
        let mid = steps.len() / 2;
        *steps.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    t.gap_after_s = Some(opts.gap_factor * median).filter(|g| g.is_finite() && *g > 0.0);
    t.segments.clear();
    for (i, &starts) in run_start.iter().enumerate() {
        if starts {
            t.segments.push(i);
        } else if t.time_s[i] - t.time_s[i - 1] > opts.gap_factor * median {
            t.segments.push(i);
            issues.push((
                t.file_of_row[i],
                t.lines[i],
                DataIssue::Gap {
                    line: t.lines[i],
                    from_s: t.time_s[i - 1],
                    to_s: t.time_s[i],
                },
            ));
        }
    }
    issues.sort_by_key(|i| (i.0, i.1));
    t.issues = issues.into_iter().map(|i| i.2).collect();
    if t.time_s.len() < 3 {
        return Err(IdentifyError::TooFewRows {
            what: format!("{}: valid rows", names.join(", ")),
            rows: t.time_s.len(),
            needed: 3,
        });
    }
    if t.runs.is_none() && names.len() > 1 {
        return Err(invalid("data", "several files", "one run per file"));
    }
    if let Some(choice) = opts.target_unit {
        to_micrometres(&mut t, choice, &target_unit_cells)?;
    }
    t.issues.splice(0..0, time_note);
    if let Some(column) = time_taken {
        t.issues.insert(0, DataIssue::TimeColumn { column });
    }
    for (name, y) in t.target_names.iter().zip(&t.targets) {
        if !y.iter().any(|v| v.is_finite()) {
            return Err(invalid(
                &format!("target {name}"),
                "empty or NaN on every row",
                "a target column with a measured value on at least some rows",
            ));
        }
    }
    Ok(t)
}

impl Reader<'_> {
    fn file(&mut self, fi: usize, text: &str, name: &str, many: bool) -> Result<()> {
        let sel = self.sel;
        let raw_len = text.len();
        let text = dialect::strip_bom(text);
        if text.trim().is_empty() {
            return Err(invalid(
                "--data",
                name,
                "a log with a header line and rows (the file is empty or blank)",
            ));
        }
        if let Some(c) = control_in_first_line(text) {
            // UTF-16 read as bytes: a NUL at every other character (odd places for little
            // endian, even for big endian), text between.
            let cs: Vec<char> = text
                .split('\n')
                .next()
                .unwrap_or_default()
                .chars()
                .take(256)
                .collect();
            let alternate = |nul_at: usize| {
                cs.len() >= 4
                    && cs
                        .iter()
                        .enumerate()
                        .all(|(i, &c)| (i % 2 == nul_at) == (c == '\0'))
            };
            let why = if alternate(0) || alternate(1) {
                "(UTF-16 text without a byte-order mark? save it as UTF-8, or UTF-16 with one)"
            } else {
                "(a binary file?)"
            };
            return Err(invalid(
                "--data",
                name,
                &format!(
                    "a text log (CSV or TSV, or a workbook .xlsx/.xls/.ods): its first line holds the control character U+{:04X} {why}",
                    u32::from(c)
                ),
            ));
        }
        // Excel's `sep=;` first line: its delimiter, and the line read as a blank one (line
        // numbers stay those of the file; the header is line 2).
        let hinted;
        let (text, hint) = match dialect::excel_sep_hint(text) {
            Some((d, rest)) => {
                hinted = format!("\n{rest}");
                (hinted.as_str(), Some(d))
            }
            None => (text, None),
        };
        // Title lines above the header and a units row under it: read as blank lines.
        let pre = match self.opts.no_header {
            true => None,
            false => crate::preamble::find(
                text,
                &crate::preamble::Wanted {
                    time: self
                        .opts
                        .sample_interval_s
                        .is_none()
                        .then_some(sel.time.as_str()),
                    run: sel.run.as_deref(),
                    inputs: &sel.inputs,
                    targets: &sel.targets,
                },
                self.opts.delimiter.or(hint),
            ),
        };
        if let Some(p) = &pre {
            self.skipped.extend(
                p.skipped
                    .iter()
                    .map(|(line, what)| (fi, *line, what.clone())),
            );
        }
        let text = pre.as_ref().map_or(text, |p| p.text.as_str());
        // A file read in chunks: only when the text given (its first line) is the file's
        // first bytes as they are, so that byte offsets are file offsets.
        let chunked = !matches!(self.source, Source::Text);
        if chunked && (text.len() != raw_len || hint.is_some() || pre.is_some()) {
            self.declined = true;
            return Ok(());
        }
        let delimiter = self
            .opts
            .delimiter
            .or(hint)
            .unwrap_or_else(|| dialect::detect_delimiter(text));
        let dialect = Dialect {
            delimiter,
            decimal_comma: self
                .opts
                .decimal_comma
                .unwrap_or_else(|| dialect::detect_decimal_comma(text, delimiter)),
        };
        if dialect.decimal_comma && delimiter == b',' {
            return Err(invalid(
                "--decimal-comma",
                name,
                "a log delimited by ';' or tab (with ',' as the delimiter, a comma cannot be the decimal separator; give --delimiter)",
            ));
        }
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(!self.opts.no_header)
            .delimiter(delimiter)
            .flexible(true)
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header: Vec<String> = rdr
            .headers()
            .map_err(|e| invalid("CSV header", name, &format!("a header row ({e})")))?
            .iter()
            .enumerate()
            .map(|(k, h)| match self.opts.no_header {
                true => positional_name(k),
                false => h.to_string(),
            })
            .collect();
        let hint = no_header_hint(name, &header, dialect.decimal_comma);
        // `DATE+TIME`: a date column and a time-of-day column (when no column has that name).
        let date_time = sel.time.split_once('+').filter(|(d, t)| {
            !header.contains(&sel.time)
                && header.iter().any(|h| h == d)
                && header.iter().any(|h| h == t)
        });
        let mut time2_idx = None;
        let time_idx = match self.opts.sample_interval_s {
            Some(dt) => {
                if header.contains(&sel.time) {
                    return Err(invalid(
                        "--sample-interval-s",
                        dt,
                        &format!(
                            "no sample interval: {name} has a time column {:?} (use it, or name another with --time-column)",
                            sel.time
                        ),
                    ));
                }
                None
            }
            None if date_time.is_some() => {
                let (d, t) = date_time.unwrap_or_default();
                time2_idx = header.iter().position(|h| h == t);
                header.iter().position(|h| h == d)
            }
            None => {
                let like: Vec<usize> = (0..header.len())
                    .filter(|&i| crate::time_unit::looks_like_time(&header[i]))
                    .collect();
                if !header.contains(&sel.time) && sel.time == DEFAULT_TIME_COLUMN && like.len() == 1
                {
                    // A time of day beside a date column (`Date`, `Datum`: Hioki, Siemens
                    // exports) is read with it, as `--time-column Date+Time` reads them.
                    let date = date_beside(&header, like[0], text, delimiter);
                    time2_idx = date.map(|_| like[0]);
                    if fi == 0 {
                        self.time_taken = Some(match date {
                            Some(d) => format!("{}+{}", header[d], header[like[0]]),
                            None => header[like[0]].clone(),
                        });
                    }
                    Some(date.unwrap_or(like[0]))
                } else if !header.contains(&sel.time) {
                    let like = like.first().map_or(String::new(), |&i| {
                        let h = &header[i];
                        format!(" ({h:?} looks like one: --time-column {h:?})")
                    });
                    return Err(invalid(
                        "--time-column",
                        &sel.time,
                        &format!(
                            "a column of {name} (columns: {}){like}; a log without a time column needs --sample-interval-s{hint}",
                            header.join(", ")
                        ),
                    ));
                } else {
                    Some(resolve(std::slice::from_ref(&sel.time), &header, &[])?[0])
                }
            }
        };
        let run_idx = match &sel.run {
            Some(r) => Some(resolve(std::slice::from_ref(r), &header, &[])?[0]),
            None => None,
        };
        let mut excl: Vec<usize> = time_idx
            .into_iter()
            .chain(time2_idx)
            .chain(run_idx)
            .collect();
        let with_hint = |e: IdentifyError| match e {
            IdentifyError::ColumnNotFound { pattern, available } => IdentifyError::ColumnNotFound {
                pattern,
                available: format!("{available}{hint}"),
            },
            e => e,
        };
        // Which option names the missing column (the defaults are FL_THERMAL's naming).
        let option = |what: &'static str| {
            move |e: IdentifyError| match e {
                IdentifyError::ColumnNotFound { pattern, available } => {
                    IdentifyError::ColumnNotFound {
                        pattern,
                        available: format!("{available} (name the {what})"),
                    }
                }
                e => e,
            }
        };
        // The default patterns (FL_THERMAL's naming) that match nothing: the columns whose
        // unit says what they are, in brackets in the name or in the units row.
        let units_row = pre.as_ref().map(|p| p.units.as_slice()).unwrap_or(&[]);
        // The header's line (the line ends before the first record).
        let header_line = usize::try_from(rdr.position().byte())
            .ok()
            .and_then(|end| text.get(..end))
            .map_or(1, |h| h.matches('\n').count().max(1) as u64);
        let mut by_unit = |pats: &[String],
                           default: &str,
                           kind: crate::quantity::Quantity,
                           excl: &[usize]| {
            let found = unit_columns(&header, units_row, kind, excl);
            let use_it = pats.len() == 1 && pats[0] == default && !found.is_empty();
            if use_it && fi == 0 {
                let names: Vec<&str> = found.iter().map(|&i| header[i].as_str()).collect();
                self.notes.push((
                    fi,
                    header_line,
                    format!(
                        "{}: {} by their unit ({}; no column matches the default {default}; name others with {})",
                        if kind == crate::quantity::Quantity::Temperature { "inputs" } else { "targets" },
                        names.join(", "),
                        kind.name(),
                        if kind == crate::quantity::Quantity::Temperature { "--inputs" } else { "--target" },
                    ),
                ));
            }
            use_it.then_some(found)
        };
        let mut target_idx = match resolve(&sel.targets, &header, &excl) {
            Err(e @ IdentifyError::ColumnNotFound { .. }) => {
                match by_unit(
                    &sel.targets,
                    "*_um",
                    crate::quantity::Quantity::Micrometres,
                    &excl,
                ) {
                    Some(v) => Ok(v),
                    None => Err(e),
                }
            }
            r => r,
        }
        .map_err(with_hint)
        .map_err(option("target columns with --target, default *_um"))?;
        excl.extend(target_idx.iter().copied());
        let mut input_idx: Vec<usize> = match resolve(&sel.inputs, &header, &excl) {
            Err(e @ IdentifyError::ColumnNotFound { .. }) => {
                match by_unit(
                    &sel.inputs,
                    "*_c",
                    crate::quantity::Quantity::Temperature,
                    &excl,
                ) {
                    Some(v) => Ok(v),
                    None => Err(e),
                }
            }
            r => r,
        }
        .map_err(with_hint)
        .map_err(option("temperature columns with --inputs, default *_c"))?
        .into_iter()
        .filter(|i| !excl.contains(i))
        .collect();
        if input_idx.is_empty() {
            return Err(invalid(
                "inputs",
                sel.inputs.join(","),
                "at least one input column that is not the time, the run or a target",
            ));
        }
        // A model names its channels by column: two used columns of one name are ambiguous.
        let used: Vec<usize> = excl.iter().chain(&input_idx).copied().collect();
        for &i in &used {
            if let Some(j) = (0..header.len()).find(|&j| j != i && header[j] == header[i]) {
                return Err(invalid(
                    &format!("columns of {name}"),
                    format!(
                        "{:?} twice (columns {} and {})",
                        header[i],
                        i.min(j) + 1,
                        i.max(j) + 1
                    ),
                    "one column per name: the model names its channels by column; rename one",
                ));
            }
        }
        let in_names: Vec<String> = input_idx.iter().map(|&i| header[i].clone()).collect();
        let tg_names: Vec<String> = target_idx.iter().map(|&i| header[i].clone()).collect();
        if fi == 0 {
            // DATE+TIME (two columns) is a time stamp, named as the user wrote it.
            self.time_column = time_idx.map(|i| {
                let cell = pre.as_ref().and_then(|p| p.units.get(i).cloned());
                let name = match time2_idx {
                    Some(t) => format!("{}+{}", header[i], header[t]),
                    None => header[i].clone(),
                };
                (name, cell)
            });
            self.time_stamps |= time2_idx.is_some();
            self.target_unit_cells = target_idx
                .iter()
                .map(|&i| pre.as_ref().and_then(|p| p.units.get(i).cloned()))
                .collect();
            self.t.input_names = in_names;
            self.t.target_names = tg_names;
            self.t.inputs = vec![Vec::new(); input_idx.len()];
            self.t.targets = vec![Vec::new(); target_idx.len()];
        } else if let (Some(i), Some(t)) = (
            same_names_in_order(&input_idx, &in_names, &self.t.input_names),
            same_names_in_order(&target_idx, &tg_names, &self.t.target_names),
        ) {
            // The same columns in another order (another export set-up of the same
            // machine): each read into the first file's column of its name.
            input_idx = i;
            target_idx = t;
        } else {
            return Err(invalid(
                &format!("columns of {name}"),
                format!(
                    "inputs {} / targets {}",
                    in_names.join(" "),
                    tg_names.join(" ")
                ),
                &format!(
                    "the columns of {}: inputs {} / targets {}",
                    self.t.files[0],
                    self.t.input_names.join(" "),
                    self.t.target_names.join(" ")
                ),
            ));
        }
        if many || run_idx.is_some() || self.opts.runs_at_restarts {
            self.t.runs.get_or_insert_with(Vec::new);
        }
        self.named_runs |= many || run_idx.is_some();
        let stem = match self.file_runs.get(fi) {
            Some(run) => run.clone(),
            None => std::path::Path::new(name)
                .file_stem()
                .map_or(name.to_string(), |s| s.to_string_lossy().into_owned()),
        };
        let time_name = match (time_idx, time2_idx) {
            (Some(ti), None) => header.get(ti).map_or(sel.time.clone(), |h| h.clone()),
            (Some(ti), Some(t2)) => format!("{}+{}", header[ti], header[t2]),
            _ => sel.time.clone(),
        };
        let c = Cols {
            header: &header,
            time_idx,
            time2_idx,
            run_idx,
            input_idx,
            target_idx,
            many,
            stem,
            dialect,
            time_name,
        };
        // Quote-free text (the usual sensor log) is split directly: the same records as the
        // csv crate's, several times faster on large logs; anything else goes through it.
        let start = match self.opts.no_header {
            true => 0,
            false => usize::try_from(rdr.position().byte()).unwrap_or(usize::MAX),
        };
        let mut st = RowState {
            last_line: 1,
            date_order: self.date_order(fi, (text, start), delimiter, c.time_idx, &c.time_name)?,
            ..RowState::default()
        };
        // A clean single-run log (every row complete, finite, time increasing) is parsed
        // on every core at once; any irregular line sends the file down the row-by-row path
        // below, which reports it exactly as before.
        if self.t.runs.is_none()
            && self.t.time_s.is_empty()
            && dialect == Dialect::PLAIN
            && self.opts.missing_codes.is_empty()
        {
            if let Some(ti) = c.time_idx {
                let slots: Vec<usize> = std::iter::once(ti)
                    .chain(c.input_idx.iter().copied())
                    .chain(c.target_idx.iter().copied())
                    .collect();
                let clean = match std::mem::replace(&mut self.source, Source::Text) {
                    Source::File(path) => {
                        clean_table_file(path, text, start, header.len(), &slots, FILE_CHUNK_BYTES)
                    }
                    Source::Text => clean_table(text, start, header.len(), &slots),
                };
                if let Some(clean) = clean {
                    let n_in = c.input_idx.len();
                    let mut cols = clean.cols.into_iter();
                    self.t.time_s = cols.next().unwrap_or_default();
                    self.t.inputs = cols.by_ref().take(n_in).collect();
                    self.t.targets = cols.collect();
                    self.t.file_of_row = vec![fi; clean.lines.len()];
                    self.t.lines = clean.lines;
                    return Ok(());
                }
            }
        }
        if chunked {
            self.declined = true;
            return Ok(());
        }
        if let Some(records) = plain_records(text, start) {
            let mut fields: Vec<&str> = Vec::with_capacity(header.len());
            for (line, l) in records {
                fields.clear();
                fields.extend(l.split(char::from(delimiter)).map(str::trim_ascii));
                self.row(fi, line, &fields, &c, &mut st);
            }
            return Ok(());
        }
        let mut rec = csv::StringRecord::new();
        // csv's own line count is one short on CRLF files (FL_THERMAL is one).
        let mut lines = gearcomp_core::textline::LineCounter::new(text);
        loop {
            match rdr.read_record(&mut rec) {
                Ok(false) => break,
                Ok(true) => {}
                Err(e) => {
                    let line = e
                        .position()
                        .map_or(st.last_line + 1, |p| lines.line_at(p.byte()));
                    self.bad
                        .push((fi, line, format!("unreadable CSV record ({e})")));
                    st.last_line = line;
                    st.ordinal += 1;
                    continue;
                }
            }
            let line = rec
                .position()
                .map_or(st.last_line + 1, |p| lines.line_at(p.byte()));
            st.last_line = line;
            let fields: Vec<&str> = rec.iter().collect();
            self.row(fi, line, &fields, &c, &mut st);
        }
        Ok(())
    }

    /// One record (`rec`: its trimmed fields) at source line `line` of file `fi`.
    /// The order of file `fi`'s slash dates: `--date-order`, else the one its dates that read
    /// only one way give (with a note naming the first), else none (an ambiguous date is then
    /// refused naming `--date-order`). Dates that read only day first beside dates that read
    /// only month first are refused: one file, one order.
    fn date_order(
        &mut self,
        fi: usize,
        (text, start): (&str, usize),
        delimiter: u8,
        time_idx: Option<usize>,
        column: &str,
    ) -> Result<Option<dialect::DateOrder>> {
        let (Some(ti), None) = (time_idx, self.opts.date_order) else {
            return Ok(self.opts.date_order);
        };
        let body = text.get(start..).unwrap_or("");
        let first_line = text
            .get(..start)
            .map_or(0, |h| h.matches('\n').count() as u64)
            + 1;
        // Only a log whose first time cell is a slash date is scanned.
        let mut cells = body
            .lines()
            .zip(first_line..)
            .filter_map(|(l, line)| l.split(char::from(delimiter)).nth(ti).map(|c| (line, c)));
        let first = cells.by_ref().find(|(_, c)| !c.trim().is_empty());
        if !first.is_some_and(|(_, c)| dialect::is_slash_date(c.trim().trim_matches('"'))) {
            return Ok(None);
        }
        match dialect::date_order_of(first.into_iter().chain(cells)) {
            dialect::DatesSay::Nothing => Ok(None),
            dialect::DatesSay::Order(order, line, cell) => {
                let (read, other) = match order {
                    dialect::DateOrder::DayFirst => ("day first (dd/mm/yyyy)", "mdy"),
                    dialect::DateOrder::MonthFirst => ("month first (mm/dd/yyyy)", "dmy"),
                };
                self.notes.push((
                    fi,
                    line,
                    format!(
                        "{column} = {cell:?} reads only {read}: every slash date of the file is read so (--date-order {other} would refuse it)"
                    ),
                ));
                Ok(Some(order))
            }
            dialect::DatesSay::Both((dl, dc), (ml, mc)) => Err(invalid(
                column,
                format!("{dc:?} at line {dl} and {mc:?} at line {ml}"),
                "slash dates in one order: the first reads only day first, the second only month first; correct the log (one logger, one order)",
            )),
        }
    }

    fn row(&mut self, fi: usize, line: u64, rec: &[&str], c: &Cols, st: &mut RowState) {
        if rec.iter().all(|f| f.is_empty()) {
            return;
        }
        // A delimiter after the last field (some loggers end every data line with one, not
        // the header) adds empty fields that hold nothing: they are no part of the row.
        let mut rec = rec;
        while rec.len() > c.header.len() && rec.last().is_some_and(|f| f.is_empty()) {
            rec = &rec[..rec.len() - 1];
        }
        if rec.len() != c.header.len() {
            let d = c.dialect;
            let other = [b',', b';', b'\t']
                .into_iter()
                .filter(|&o| o != d.delimiter && !(o == b',' && d.decimal_comma))
                .find(|&o| rec.iter().any(|f| f.as_bytes().contains(&o)));
            let hint = match other {
                Some(o) => format!(
                    " (the delimiter is {}, this row holds {}: force one with --delimiter)",
                    dialect::delimiter_name(d.delimiter),
                    dialect::delimiter_name(o)
                ),
                None => String::new(),
            };
            self.bad.push((
                fi,
                line,
                format!("{} fields, header has {}{hint}", rec.len(), c.header.len()),
            ));
            st.ordinal += 1;
            return;
        }
        if !self.opts.no_header && rec.iter().zip(c.header).all(|(f, h)| f == h) {
            self.bad.push((
                fi,
                line,
                "the header again (several exports appended to one file?)".to_string(),
            ));
            st.ordinal += 1;
            return;
        }
        // Run of this row.
        let run = match c.run_idx {
            Some(ri) => {
                let v = rec.get(ri).copied().unwrap_or("").to_string();
                if v.is_empty() {
                    self.bad
                        .push((fi, line, format!("{} (run) is empty", c.header[ri])));
                    st.ordinal += 1;
                    return;
                }
                v
            }
            None => String::new(),
        };
        if st.cur_run.as_deref() != Some(run.as_str()) {
            st.switch_run(&run);
        }
        // A numeric time below the last one starts the next run (`runs_at_restarts`), before
        // any cell is read, so that no held value crosses into it.
        if let (true, Some(ti), None, Some(prev)) = (
            self.opts.runs_at_restarts && st.stamps != Some(true),
            c.time_idx,
            c.time2_idx,
            st.prev_t,
        ) {
            let cell = rec.get(ti).copied().unwrap_or("");
            if dialect::parse_number(cell, "", c.dialect.decimal_comma).is_ok_and(|t| t < prev) {
                st.prev_t = None;
                st.held.clear();
                st.restarts += 1;
            }
        }
        let run = match (self.opts.runs_at_restarts, run.is_empty(), st.restarts) {
            (false, _, _) | (true, false, 0) => run,
            (true, true, k) => (k + 1).to_string(),
            (true, false, k) => format!("{run}/{}", k + 1),
        };
        let this_ordinal = st.ordinal;
        st.ordinal += 1;
        let dc = c.dialect.decimal_comma;
        // Every used cell: the first failure decides the reason (inputs, then targets). An
        // empty or NaN target cell is a target not measured on this row (a displacement
        // probed every few minutes in a log of temperatures every few seconds): the row is
        // kept with NaN there, and drives the filters and lags without being fitted or
        // scored (`Table::measured`).
        let mut vals = Vec::with_capacity(c.input_idx.len() + c.target_idx.len());
        let mut first: Option<CellError> = None;
        let mut first_bad: Option<String> = None;
        let n_in = c.input_idx.len();
        let hold = self.opts.missing == MissingCells::Hold;
        st.held.resize(n_in, None);
        let mut held_here: Vec<usize> = Vec::new();
        // Under hold: the inputs written on this row (they are held from here on even when
        // the row itself is left out for another input's empty cell).
        let mut written: Vec<Option<f64>> = vec![None; if hold { n_in } else { 0 }];
        for (k, i) in c.input_idx.iter().chain(&c.target_idx).enumerate() {
            let s = rec.get(*i).copied().unwrap_or("");
            let codes = &self.opts.missing_codes;
            let parsed = if codes.contains_text(s) {
                Err(CellError::Missing(format!(
                    "{} = {s:?} (a missing-value code, --missing-code)",
                    c.header[*i]
                )))
            } else {
                dialect::parse_number(s, &c.header[*i], dc)
            }
            .and_then(|v| {
                if codes.contains(v) {
                    Err(CellError::Missing(format!(
                        "{} = {s} (a missing-value code, --missing-code)",
                        c.header[*i]
                    )))
                } else {
                    Ok(v)
                }
            });
            match parsed {
                Ok(v) => {
                    if let Some(w) = written.get_mut(k) {
                        *w = Some(v);
                    }
                    vals.push(v)
                }
                Err(CellError::Missing(_)) if k >= n_in => vals.push(f64::NAN),
                Err(CellError::Missing(_)) if hold && st.held[k].is_some() => {
                    vals.push(st.held[k].unwrap_or(f64::NAN));
                    held_here.push(k);
                }
                Err(e) => {
                    if let (CellError::Bad(b), None) = (&e, &first_bad) {
                        first_bad = Some(b.clone());
                    }
                    first.get_or_insert(e);
                }
            }
        }
        let time_text: std::borrow::Cow<str> = match (c.time_idx, c.time2_idx) {
            (Some(ti), Some(t2)) => format!(
                "{} {}",
                rec.get(ti).copied().unwrap_or(""),
                rec.get(t2).copied().unwrap_or("")
            )
            .into(),
            (Some(ti), None) => rec.get(ti).copied().unwrap_or("").into(),
            _ => "".into(),
        };
        let time_name: &str = &c.time_name;
        let time = match (c.time_idx, self.opts.sample_interval_s) {
            (Some(_), _) => {
                let order = st.date_order;
                time_cell(time_text.trim(), time_name, dc, order, st)
            }
            (None, Some(dt)) => Ok(this_ordinal as f64 * dt),
            (None, None) => Err("no time".to_string()),
        };
        let split = matches!(self.opts.missing, MissingCells::Split | MissingCells::Hold);
        let cell_error = if split {
            first_bad
        } else {
            first.as_ref().map(|e| match e {
                CellError::Missing(m) => format!(
                    "{m} (a sensor dropout: --missing split leaves such rows out and splits the run there)"
                ),
                CellError::Bad(b) => b.clone(),
            })
        };
        let time = match (cell_error, time) {
            (None, Ok(t)) => t,
            (Some(reason), _) | (None, Err(reason)) => {
                self.bad.push((fi, line, reason));
                return;
            }
        };
        if let (true, Some(CellError::Missing(m))) = (split, first) {
            for (h, w) in st.held.iter_mut().zip(&written) {
                if w.is_some() {
                    *h = *w;
                }
            }
            self.missing.push((fi, line, m, hold));
            st.split_pending = true;
            return;
        }
        if let Some(prev) = st.prev_t {
            if time <= prev {
                let d = &mut self.drops;
                d.count += 1;
                if d.first.is_none() {
                    d.first = Some((fi, line, prev, time));
                } else if d.count == 2 {
                    d.second = Some((fi, line));
                }
                self.bad.push((
                    fi,
                    line,
                    format!(
                        "{} = {} does not increase (previous {prev}{}){}",
                        time_name,
                        // A time stamp: the text as written, and s since the run's first.
                        if st.stamps == Some(true) {
                            format!("{time_text:?} ({time} s after the run's first stamp)")
                        } else {
                            time.to_string()
                        },
                        if st.stamps == Some(true) { " s" } else { "" },
                        if c.run_idx.is_some() {
                            " within the run"
                        } else {
                            ""
                        }
                    ),
                ));
                return;
            }
        }
        st.prev_t = Some(time);
        if std::mem::take(&mut st.split_pending) {
            self.forced.push(self.t.time_s.len());
        }
        self.time_stamps |= st.stamps == Some(true);
        self.time_clock |= st.clock;
        self.t.time_s.push(time);
        for (c, v) in self.t.inputs.iter_mut().zip(&vals) {
            c.push(*v);
        }
        if hold {
            for (h, v) in st.held.iter_mut().zip(&vals) {
                *h = Some(*v);
            }
            for k in held_here {
                let name = &c.header[c.input_idx[k]];
                match self.held.iter_mut().find(|h| h.0 == fi && h.1 == *name) {
                    Some(h) => h.3 += 1,
                    None => self.held.push((fi, name.clone(), line, 1)),
                }
            }
        }
        for (c, v) in self.t.targets.iter_mut().zip(&vals[c.input_idx.len()..]) {
            c.push(*v);
        }
        if let Some(runs) = self.t.runs.as_mut() {
            let label = match (c.many, c.run_idx.is_some()) {
                (true, true) => format!("{}:{run}", c.stem),
                (true, false) if st.restarts > 0 => format!("{}/{}", c.stem, st.restarts + 1),
                (true, false) => c.stem.clone(),
                _ => run.clone(),
            };
            let k = match self.run_label.iter().position(|l| *l == label) {
                Some(k) => k,
                None => {
                    self.run_label.push(label.clone());
                    self.t.run_names.push(label);
                    self.run_label.len() - 1
                }
            };
            runs.push(k);
        }
        self.t.lines.push(line);
        self.t.file_of_row.push(fi);
    }
}

/// The time of a row from its time cell `s` (column `col`): seconds, or a time stamp
/// (decided at the file's first non-empty time cell) converted to seconds since the run's
/// first stamp. Stamps are instants when they carry an offset; a file may not mix stamps
/// with and without one.
fn time_cell(
    s: &str,
    col: &str,
    decimal_comma: bool,
    order: Option<dialect::DateOrder>,
    st: &mut RowState,
) -> std::result::Result<f64, String> {
    if st.stamps.is_none() && !s.is_empty() {
        st.stamps = Some(dialect::is_timestamp(s, decimal_comma));
        st.clock = dialect::parse_timestamp(s).is_none()
            && dialect::parse_clock(s, decimal_comma).is_some();
    }
    if st.stamps == Some(true) && st.clock {
        // Seconds since the run's first clock time, as for stamps (no unit, no date).
        let Some(secs) = dialect::parse_clock(s, decimal_comma) else {
            return Err(format!(
                "{col} = {s:?} is not a clock time h:mm:ss[.250] (the file's first time cell is one)"
            ));
        };
        let nanos = (secs * 1e9).round() as i64;
        let t0 = *st.t0.get_or_insert(nanos);
        return Ok(nanos.saturating_sub(t0) as f64 / 1e9);
    }
    if st.stamps != Some(true) {
        return dialect::parse_number(s, col, decimal_comma).map_err(|e| match e {
            // A time cell is never a missing-value code: no --missing-code hint here.
            CellError::Bad(b)
                if b.ends_with("is not a number") || b.ends_with("reads it as an empty cell)") =>
            {
                format!(
                    "{col} = {s:?} is not a number: expected {}",
                    dialect::TIMESTAMP_FORMS
                )
            }
            CellError::Missing(m) | CellError::Bad(m) => m,
        });
    }
    let Some(stamp) = dialect::parse_timestamp_in(s, order) else {
        if order.is_none() && dialect::is_ambiguous_slash_date(s) {
            return Err(format!(
                "{col} = {s:?} reads as day/month or as month/day: name the order with --date-order dmy (25/11/2026) or mdy (11/25/2026)"
            ));
        }
        return Err(format!(
            "{col} = {s:?} is not a time stamp: expected {}",
            dialect::TIMESTAMP_FORMS
        ));
    };
    let with = *st.has_offset.get_or_insert(stamp.has_offset);
    if with != stamp.has_offset {
        return Err(format!(
            "{col} = {s:?} {} a UTC offset, the file's first time stamp {}: a log must give every stamp as an instant (Z or ±hh:mm) or every one as wall time",
            if stamp.has_offset { "has" } else { "lacks" },
            if with { "has one" } else { "has none" }
        ));
    }
    let t0 = *st.t0.get_or_insert(stamp.nanos);
    Ok(stamp.nanos.saturating_sub(t0) as f64 / 1e9)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn sel(inputs: &[&str], targets: &[&str]) -> Selection {
        Selection {
            time: "time_s".into(),
            inputs: inputs.iter().map(|s| s.to_string()).collect(),
            targets: targets.iter().map(|s| s.to_string()).collect(),
            run: None,
        }
    }

    /// The quote-free fast path reads exactly what the csv crate reads: the same texts with
    /// the header's first name quoted (which sends them through the csv crate) give the same
    /// table, bad rows and line numbers, for LF and CRLF ends, blank and whitespace lines,
    /// wrong widths, empty and non-numeric cells, non-increasing time and runs.
    #[test]
    fn quote_free_fast_path_equals_the_csv_reader() {
        let bodies = [
            "0,1,2,r1,5\n15,1.5,2.5,r1,6\n\n30, 2 ,3,r1,7\n   \n0,4,5,r2,1\n15,x,5,r2,1\n30,5,6,r2\n45,5,,r2,2\n60,6,7,r2,3,9\n50,6,7,r2,3\n75,7,8,r2,4\n",
            "0,1,2,a,5\r\n15,1.5,2.5,a,6\r\n\r\n30,2,3,a,7\r\n45,inf,3,a,7\r\n60,3,4,,7\r\n",
            "0,1,2,a,5\n15,1.5,2.5,a,6\n30,2,3,a,7",
        ];
        for body in bodies {
            for run in [None, Some("run")] {
                let read = |quoted: bool| {
                    let head = if quoted { "\"time_s\"" } else { "time_s" };
                    let text = format!("{head},a_c,b_c,run,d_um\n{body}");
                    let sl = Selection {
                        run: run.map(String::from),
                        ..sel(&["*_c"], &["d_um"])
                    };
                    let opts = ReadOptions {
                        skip_bad_rows: true,
                        ..ReadOptions::default()
                    };
                    read_csv(&text, "f", &sl, opts).map_err(|e| e.to_string())
                };
                assert_eq!(read(false), read(true), "{body:?} run {run:?}");
            }
        }
    }

    /// Text of a random log: `rows` lines of `width` cells, each a number in one of several
    /// spellings, padded, with blank lines, CRLF ends and (rarely) an irregular cell or row.
    fn random_log(seed: u64, rows: usize, irregular: bool) -> String {
        let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let crlf = next() % 2 == 0;
        let end = if crlf { "\r\n" } else { "\n" };
        let mut s = format!("time_s,a_c,skip,b_c,d_um{end}");
        let mut t = 0.0;
        for _ in 0..rows {
            t += (1 + next() % 40) as f64 * 0.25;
            let mut cells = vec![format!("{t}")];
            for _ in 0..4 {
                let v = (next() % 2_000_001) as f64 / 1000.0 - 1000.0;
                cells.push(match next() % 7 {
                    0 => format!("{v:e}"),
                    1 => format!(" {v:.3} "),
                    2 => format!("{}", v.round()),
                    3 => format!("{v:+.17}"),
                    4 => format!("{:.2E}", v),
                    _ => format!("{v}"),
                });
            }
            if irregular {
                match next() % 60 {
                    0 => cells[1 + (next() % 4) as usize] = "x1".into(),
                    1 => cells[1 + (next() % 4) as usize] = String::new(),
                    2 => cells[(next() % 5) as usize] = "inf".into(),
                    3 => {
                        cells.pop();
                    }
                    4 => cells.push("7".into()),
                    5 => cells[0] = format!("{}", t - 1.0),
                    6 => cells = vec![String::new(); 5],
                    7 => cells[2] = "a\rb".into(),
                    _ => {}
                }
            }
            if next() % 25 == 0 {
                s.push_str(if next() % 2 == 0 { "   " } else { "" });
                s.push_str(end);
            }
            s.push_str(&cells.join(","));
            s.push_str(end);
        }
        if next() % 2 == 0 {
            let n = s.len() - end.len();
            s.truncate(n);
        }
        s
    }

    /// The clean-log path (cut into 1–4 pieces) gives exactly the table of the csv crate's
    /// row-by-row path (the same text with a quoted header), or declines the text, on
    /// random logs; on logs without irregular rows it never declines.
    #[test]
    fn clean_log_pieces_equal_the_row_by_row_reader() {
        let sl = sel(&["*_c"], &["d_um"]);
        for seed in 0..300u64 {
            let irregular = seed % 3 == 0;
            let text = random_log(seed, 3 + (seed as usize * 7) % 90, irregular);
            let quoted = text.replacen("time_s", "\"time_s\"", 1);
            let slow = read_csv(
                &quoted,
                "f",
                &sl,
                ReadOptions {
                    skip_bad_rows: true,
                    ..ReadOptions::default()
                },
            )
            .map_err(|e| e.to_string());
            let start = text.find('\n').unwrap() + 1;
            for threads in 1..=4 {
                match clean_table_in(&text, start, 5, &[0, 1, 3, 4], threads) {
                    Some(c) => {
                        let t = slow.as_ref().unwrap();
                        assert!(t.issues.iter().all(|i| matches!(i, DataIssue::Gap { .. })));
                        assert_eq!(c.cols[0], t.time_s, "seed {seed}");
                        assert_eq!(&c.cols[1..3], &t.inputs[..], "seed {seed}");
                        assert_eq!(&c.cols[3..], &t.targets[..], "seed {seed}");
                        assert_eq!(c.lines, t.lines, "seed {seed}");
                    }
                    None => assert!(
                        irregular,
                        "seed {seed}: a regular log declined ({threads} pieces)"
                    ),
                }
            }
            // Whatever path read_csv takes, it gives the csv crate's table and issues.
            let fast = read_csv(
                &text,
                "f",
                &sl,
                ReadOptions {
                    skip_bad_rows: true,
                    ..ReadOptions::default()
                },
            )
            .map_err(|e| e.to_string());
            // Debug text: an unmeasured target is NaN in both (NaN ≠ NaN for PartialEq).
            assert_eq!(format!("{fast:?}"), format!("{slow:?}"), "seed {seed}");
        }
    }

    /// A log file read in chunks ([`clean_table_file`]) gives exactly the table of its text
    /// read at once ([`clean_table_in`]), or declines where that declines, for chunks of 1
    /// byte up to more than the file and 1–4 byte ranges (a range may hold no line start);
    /// and [`read_csv_file`] gives what [`read_csv`] gives, or leaves the file to it.
    #[test]
    fn a_file_read_in_chunks_is_the_text_read_at_once() {
        let dir = std::env::temp_dir();
        let sl = sel(&["*_c"], &["d_um"]);
        let opts = ReadOptions {
            skip_bad_rows: true,
            ..ReadOptions::default()
        };
        for seed in 0..120u64 {
            let irregular = seed % 3 == 0;
            let text = random_log(seed, 1 + (seed as usize * 7) % 60, irregular);
            let mut bytes = text.clone().into_bytes();
            // Not UTF-8 in a record: declined (the text path reports it).
            let utf8 = seed % 10 != 1 || bytes.len() < 40;
            if !utf8 {
                let p = bytes.len() - 3;
                bytes[p] = 0xff;
            }
            let path = dir.join(format!("gearcomp-chunks-{}-{seed}.csv", std::process::id()));
            std::fs::write(&path, &bytes).unwrap();
            let start = text.find('\n').unwrap() + 1;
            let file = std::fs::File::open(&path).unwrap();
            let len = bytes.len() as u64;
            for threads in 1..=4 {
                let whole = clean_table_in(&text, start, 5, &[0, 1, 3, 4], threads);
                for chunk in [1, 2, 3, 7, 64, 4096] {
                    let slots = [0, 1, 3, 4];
                    let c = clean_file_in(&file, 2, start as u64, len, 5, &slots, chunk, threads);
                    match (&whole, c) {
                        (Some(w), Some(c)) if utf8 => {
                            assert_eq!(c.cols, w.cols, "seed {seed} {threads} {chunk}");
                            assert_eq!(c.lines, w.lines, "seed {seed} {threads} {chunk}");
                        }
                        (None, None) => {}
                        (_, None) if !utf8 => {}
                        (w, c) => panic!(
                            "seed {seed}, {threads} ranges, chunk {chunk}: text {}, file {}",
                            w.is_some(),
                            c.is_some()
                        ),
                    }
                }
            }
            let from_file = read_csv_file(&path, "f", &sl, opts);
            std::fs::remove_file(&path).unwrap();
            match from_file {
                Some(t) => {
                    assert!(utf8, "seed {seed}: a file that is not UTF-8 read");
                    let from_text = read_csv(&text, "f", &sl, opts);
                    assert_eq!(
                        t.map_err(|e| e.to_string()),
                        from_text.map_err(|e| e.to_string()),
                        "seed {seed}"
                    );
                }
                None => assert!(irregular || !utf8, "seed {seed}: a clean log declined"),
            }
        }
    }

    /// A quote anywhere in the records declines the clean path in every piece (no longer
    /// found by a scan of the whole text first): in a skipped field where the naive split
    /// would still see five clean fields (`2,1,"2,3,4`: the csv crate reads a quoted field
    /// running to the next quote), inside a field, or around a selected value.
    #[test]
    fn a_quote_in_the_records_declines_the_clean_path() {
        let log = |row: &str| {
            let mut text = String::from("time_s,a_c,skip,b_c,d_um\n");
            for k in 1..=400 {
                match k {
                    200 => text.push_str(&format!("{k},{row}\n")),
                    _ => text.push_str(&format!("{k},1,2,3,4\n")),
                }
            }
            text
        };
        let start = log("").find('\n').unwrap() + 1;
        for row in ["1,\"2,3,4", "1,x\"y,3,4", "\"1\",2,3,4", "1,2,3,4\""] {
            let text = log(row);
            for threads in 1..=4 {
                let c = clean_table_in(&text, start, 5, &[0, 1, 3, 4], threads);
                assert!(c.is_none(), "{row:?} read as clean ({threads} pieces)");
            }
        }
        let clean = clean_table_in(&log("1,2,3,4"), start, 5, &[0, 1, 3, 4], 2).unwrap();
        assert_eq!(clean.cols[0].len(), 400);
    }

    /// A number read by fast-float2 (when it reads a whole field, finite) is exactly what
    /// `str::parse` reads: random strings over the characters of numbers, and random decimal
    /// numbers with up to 25 digits, signs, exponents and the forms Rust prints.
    #[test]
    fn fast_parse_is_std_parse() {
        use proptest::prelude::*;
        let same = |s: &str| -> std::result::Result<(), TestCaseError> {
            if let Ok((v, n)) = fast_float2::parse_partial::<f64, _>(s) {
                if n == s.len() && v.is_finite() {
                    let std = s.parse::<f64>();
                    prop_assert!(std.is_ok(), "{s:?}: fast-float2 {v}, std refuses");
                    prop_assert_eq!(std.unwrap_or(f64::NAN).to_bits(), v.to_bits(), "{:?}", s);
                }
            }
            Ok(())
        };
        let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
            cases: 3000,
            ..ProptestConfig::default()
        });
        runner
            .run(&"[-+0-9.eE]{0,12}|[-+ .eEinfatyINFATY0-9_x]{0,10}", |s| {
                same(&s)
            })
            .unwrap();
        runner
            .run(
                &(
                    "[-+]?",
                    "[0-9]{0,25}",
                    proptest::option::of("[0-9]{0,25}"),
                    proptest::option::of(("[eE]", "[-+]?", "[0-9]{1,3}")),
                ),
                |(sign, int, frac, exp)| {
                    let mut s = format!("{sign}{int}");
                    if let Some(f) = frac {
                        s.push('.');
                        s.push_str(&f);
                    }
                    if let Some((e, es, ed)) = exp {
                        s.push_str(&format!("{e}{es}{ed}"));
                    }
                    same(&s)
                },
            )
            .unwrap();
        runner
            .run(&any::<f64>(), |v| {
                same(&format!("{v}"))?;
                same(&format!("{v:e}"))?;
                same(&format!("{v:.17}"))
            })
            .unwrap();
        // Fixed cases: the sensor-log forms, halfway and subnormal values, overlong digits.
        for s in [
            "0.37745278799999998",
            "26.190862338069099",
            "9007199254740993",
            "2.2250738585072011e-308",
            "4.9e-324",
            "1.7976931348623157e308",
            "0.1000000000000000055511151231257827021181583404541015625",
            "123456789012345678901234567890",
            ".5",
            "5.",
            "+1",
            "-0",
            "1e400",
        ] {
            same(s).unwrap();
        }
    }

    const GOOD: &str = "time_s,a_c,b_c,rpm,d_um\n0,1,2,0,5\n15,1.5,2.5,10,6\n30,2,3,10,7\n";

    #[test]
    fn selects_by_name_and_glob_excluding_targets() {
        let t = read_csv(GOOD, "g", &sel(&["*_c"], &["d_um"]), ReadOptions::default()).unwrap();
        assert_eq!(t.input_names, vec!["a_c", "b_c"]);
        assert_eq!(t.target_names, vec!["d_um"]);
        assert_eq!(t.inputs[1], vec![2.0, 2.5, 3.0]);
        assert_eq!(t.lines, vec![2, 3, 4]);
        let t = read_csv(
            GOOD,
            "g",
            &sel(&["rpm", "a_?"], &["*_um"]),
            ReadOptions::default(),
        )
        .unwrap();
        assert_eq!(t.input_names, vec!["rpm", "a_c"]);
        let e = read_csv(GOOD, "g", &sel(&["x*"], &[]), ReadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("\"x*\" not found"), "{e}");
    }

    /// A target cell left empty or NaN is a target not measured on that row: the row is kept
    /// (time and inputs as written, NaN in that target), splits nothing, is not a bad row,
    /// and `measured` / `measured_note` say so; an empty input cell is still a bad row; a
    /// target with no value on any row is refused, naming it.
    #[test]
    fn an_empty_target_cell_is_a_row_without_a_measurement() {
        let text = "time_s,a_c,b_c,d_um,e_um\n0,1,2,5,1\n15,1.5,2,,\n30,2,2.5,NaN,2\n45,2,3,7,3\n60,2.5,3,8,\n75,3,3.5,9,4\n";
        let t = read_csv(
            text,
            "log.csv",
            &sel(&["*_c"], &["*_um"]),
            ReadOptions::default(),
        )
        .unwrap();
        assert_eq!(t.time_s, [0.0, 15.0, 30.0, 45.0, 60.0, 75.0]);
        assert_eq!(t.inputs[0], [1.0, 1.5, 2.0, 2.0, 2.5, 3.0]);
        assert_eq!(t.segments, [0]);
        assert!(t.issues.is_empty(), "{:?}", t.issues);
        let nan = |v: &[f64]| v.iter().map(|x| x.is_nan()).collect::<Vec<_>>();
        assert_eq!(nan(&t.targets[0]), [false, true, true, false, false, false]);
        assert_eq!(nan(&t.targets[1]), [false, true, false, false, true, false]);
        assert_eq!(t.measured(), [true, false, false, true, false, true]);
        let note = t.measured_note().unwrap();
        assert!(note.contains("d_um on 4, e_um on 4 of 6 rows"), "{note}");
        assert!(note.contains("3 rows have every target"), "{note}");
        // One target: every row of it measured, no note.
        let one = read_csv(
            text,
            "log.csv",
            &sel(&["*_c"], &["d_um"]),
            ReadOptions::default(),
        )
        .unwrap();
        assert!(one.measured_note().is_some());
        let small = |body: &str| {
            let text = format!("time_s,a_c,d_um\n{body}");
            read_csv(
                &text,
                "f",
                &sel(&["a_c"], &["d_um"]),
                ReadOptions::default(),
            )
        };
        let f = small("0,1,5\n15,2,6\n30,3,7\n").unwrap();
        assert_eq!((f.measured(), f.measured_note()), (vec![true; 3], None));
        // An empty input is a sensor dropout, as before.
        let e = small("0,1,5\n15,,6\n30,3,7\n").unwrap_err().to_string();
        assert!(e.contains("line(s) 3") && e.contains("a_c is empty"), "{e}");
        // A target never measured is refused by name.
        let e = small("0,1,\n15,2,NaN\n30,3,\n").unwrap_err().to_string();
        assert!(e.contains("target d_um") && e.contains("every row"), "{e}");
    }

    /// CRLF line ends (the FL_THERMAL log has them) give the same line numbers as LF.
    #[test]
    fn bad_row_lines_are_the_same_for_crlf_files() {
        let lf = "time_s,a_c,d_um\n0,1,5\n15,oops,6\n30,2,7\n";
        for text in [lf.to_string(), lf.replace('\n', "\r\n")] {
            let e = read_csv(
                &text,
                "log.csv",
                &sel(&["a_c"], &["d_um"]),
                ReadOptions::default(),
            )
            .unwrap_err()
            .to_string();
            assert!(e.contains("1 bad row(s) at line(s) 3"), "{e}");
        }
    }

    #[test]
    fn bad_rows_are_listed_by_line_and_never_dropped_silently() {
        let text = "time_s,a_c,d_um\n0,1,5\n15,oops,6\n30,2\n45,,7\n20,3,8\n10,3,8\n60,NaN,8\n100,4,9\n115,4,9\n130,4,9\n";
        let e = read_csv(
            text,
            "log.csv",
            &sel(&["a_c"], &["d_um"]),
            ReadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("5 bad row(s) at line(s) 3, 4, 5, 7, 8"), "{e}");
        assert!(e.contains("a_c = \"oops\" is not a number"), "{e}");
        let opts = ReadOptions {
            skip_bad_rows: true,
            ..ReadOptions::default()
        };
        let t = read_csv(text, "log.csv", &sel(&["a_c"], &["d_um"]), opts).unwrap();
        assert_eq!(t.time_s, vec![0.0, 20.0, 100.0, 115.0, 130.0]);
        let lines: Vec<String> = t.issues.iter().map(|i| i.to_string()).collect();
        assert_eq!(t.issues.len(), 6, "{lines:?}");
        assert!(
            lines[1].starts_with("line 4: bad row: 2 fields"),
            "{lines:?}"
        );
        assert!(lines[3].contains("does not increase"), "{lines:?}");
        assert!(
            lines[5].starts_with("line 9: time gap of 80 s"),
            "{lines:?}"
        );
    }
}
