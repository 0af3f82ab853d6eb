//! Reading thermal-test logs: a time column, input (temperature) columns and target columns,
//! selected by name or glob pattern. Bad rows and time gaps are reported with their line
//! numbers; bad rows are an error unless the caller asks to skip them, and skipped rows are
//! still listed in [`Table::issues`].

use crate::error::{invalid, IdentifyError, Result};
use globset::Glob;

/// Which columns to read.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// Name of the time column (seconds).
    pub time: String,
    /// Input columns: names or glob patterns (`t*_c`), in order; repeats are dropped.
    pub inputs: Vec<String>,
    /// Target columns: names or glob patterns.
    pub targets: Vec<String>,
    /// Optional column holding a run number (for validation by run).
    pub run: Option<String>,
}

impl Default for Selection {
    /// `time_s`, every `*_c` column (°C by the naming convention) as input, no target.
    fn default() -> Self {
        Self {
            time: "time_s".into(),
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
    /// A time step larger than this multiple of the median step is reported as a gap.
    pub gap_factor: f64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            skip_bad_rows: false,
            gap_factor: 3.0,
        }
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
    /// A time step much larger than the median step (kept: the filters handle any step).
    Gap {
        /// Line of the row after the gap.
        line: u64,
        /// Time before the gap in s.
        from_s: f64,
        /// Time after the gap in s.
        to_s: f64,
    },
}

impl std::fmt::Display for DataIssue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DataIssue::BadRow { line, reason } => write!(f, "line {line}: bad row: {reason}"),
            DataIssue::Gap { line, from_s, to_s } => write!(
                f,
                "line {line}: time gap of {:.0} s ({from_s} s → {to_s} s)",
                to_s - from_s
            ),
        }
    }
}

/// A column-major table of the selected columns.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Table {
    /// Time stamps in s, strictly increasing.
    pub time_s: Vec<f64>,
    /// Names of the input columns.
    pub input_names: Vec<String>,
    /// Input columns, each `time_s.len()` long.
    pub inputs: Vec<Vec<f64>>,
    /// Names of the target columns.
    pub target_names: Vec<String>,
    /// Target columns.
    pub targets: Vec<Vec<f64>>,
    /// Run number of each row, when a run column was selected.
    pub runs: Option<Vec<f64>>,
    /// Source line of each kept row.
    pub lines: Vec<u64>,
    /// Bad rows and gaps, in file order.
    pub issues: Vec<DataIssue>,
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
/// increase strictly; rows breaking that are listed by line and, unless
/// [`ReadOptions::skip_bad_rows`], make the read fail.
pub fn read_csv(text: &str, name: &str, sel: &Selection, opts: ReadOptions) -> Result<Table> {
    if !(opts.gap_factor.is_finite() && opts.gap_factor > 1.0) {
        return Err(invalid("gap_factor", opts.gap_factor, "a factor > 1"));
    }
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(true)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let header: Vec<String> = rdr
        .headers()
        .map_err(|e| invalid("CSV header", name, &format!("a header row ({e})")))?
        .iter()
        .map(str::to_string)
        .collect();
    let time_idx = resolve(std::slice::from_ref(&sel.time), &header, &[])?[0];
    let target_idx = resolve(&sel.targets, &header, &[time_idx])?;
    let run_idx = match &sel.run {
        Some(r) => Some(resolve(std::slice::from_ref(r), &header, &[])?[0]),
        None => None,
    };
    let mut excl = target_idx.clone();
    excl.push(time_idx);
    excl.extend(run_idx);
    let input_idx: Vec<usize> = resolve(&sel.inputs, &header, &excl)?
        .into_iter()
        .filter(|i| !excl.contains(i))
        .collect();
    if input_idx.is_empty() {
        return Err(invalid(
            "inputs",
            sel.inputs.join(","),
            "at least one input column that is not the time or a target",
        ));
    }
    let mut t = Table {
        input_names: input_idx.iter().map(|&i| header[i].clone()).collect(),
        inputs: vec![Vec::new(); input_idx.len()],
        target_names: target_idx.iter().map(|&i| header[i].clone()).collect(),
        targets: vec![Vec::new(); target_idx.len()],
        ..Table::default()
    };
    let mut bad: Vec<(u64, String)> = Vec::new();
    let mut rec = csv::StringRecord::new();
    // csv's own line count is one short on CRLF files (FL_THERMAL is one).
    let mut lines = gearcomp_core::textline::LineCounter::new(text);
    let mut last_line = 1u64;
    loop {
        match rdr.read_record(&mut rec) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e
                    .position()
                    .map_or(last_line + 1, |p| lines.line_at(p.byte()));
                bad.push((line, format!("unreadable CSV record ({e})")));
                last_line = line;
                continue;
            }
        }
        let line = rec
            .position()
            .map_or(last_line + 1, |p| lines.line_at(p.byte()));
        last_line = line;
        if rec.iter().all(str::is_empty) {
            continue;
        }
        if rec.len() != header.len() {
            bad.push((
                line,
                format!("{} fields, header has {}", rec.len(), header.len()),
            ));
            continue;
        }
        let cell = |i: usize| -> std::result::Result<f64, String> {
            let s = rec.get(i).unwrap_or("");
            match s.parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                Ok(v) => Err(format!("{} = {v} is not finite", header[i])),
                Err(_) if s.is_empty() => Err(format!("{} is empty", header[i])),
                Err(_) => Err(format!("{} = {s:?} is not a number", header[i])),
            }
        };
        let parsed: std::result::Result<Vec<f64>, String> = std::iter::once(time_idx)
            .chain(input_idx.iter().copied())
            .chain(target_idx.iter().copied())
            .chain(run_idx)
            .map(cell)
            .collect();
        let vals = match parsed {
            Ok(v) => v,
            Err(reason) => {
                bad.push((line, reason));
                continue;
            }
        };
        if let Some(&prev) = t.time_s.last() {
            if vals[0] <= prev {
                bad.push((
                    line,
                    format!(
                        "{} = {} does not increase (previous {prev})",
                        sel.time, vals[0]
                    ),
                ));
                continue;
            }
        }
        t.time_s.push(vals[0]);
        for (c, v) in t.inputs.iter_mut().zip(&vals[1..]) {
            c.push(*v);
        }
        for (c, v) in t.targets.iter_mut().zip(&vals[1 + input_idx.len()..]) {
            c.push(*v);
        }
        if run_idx.is_some() {
            t.runs
                .get_or_insert_with(Vec::new)
                .push(vals[vals.len() - 1]);
        }
        t.lines.push(line);
    }
    if !bad.is_empty() && !opts.skip_bad_rows {
        let lines: Vec<String> = bad.iter().take(20).map(|b| b.0.to_string()).collect();
        return Err(IdentifyError::BadRows {
            path: name.to_string(),
            count: bad.len(),
            lines: if bad.len() > 20 {
                format!("{}, …", lines.join(", "))
            } else {
                lines.join(", ")
            },
            first_reason: bad[0].1.clone(),
        });
    }
    let mut issues: Vec<(u64, DataIssue)> = bad
        .into_iter()
        .map(|(line, reason)| (line, DataIssue::BadRow { line, reason }))
        .collect();
    let mut steps: Vec<f64> = t.time_s.windows(2).map(|w| w[1] - w[0]).collect();
    if !steps.is_empty() {
        steps.sort_by(f64::total_cmp);
        let median = steps[steps.len() / 2];
        for k in 1..t.time_s.len() {
            if t.time_s[k] - t.time_s[k - 1] > opts.gap_factor * median {
                issues.push((
                    t.lines[k],
                    DataIssue::Gap {
                        line: t.lines[k],
                        from_s: t.time_s[k - 1],
                        to_s: t.time_s[k],
                    },
                ));
            }
        }
    }
    issues.sort_by_key(|i| i.0);
    t.issues = issues.into_iter().map(|i| i.1).collect();
    if t.time_s.len() < 3 {
        return Err(IdentifyError::TooFewRows {
            what: format!("{name}: valid rows"),
            rows: t.time_s.len(),
            needed: 3,
        });
    }
    Ok(t)
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
        let text = "time_s,a_c,d_um\n0,1,5\n15,oops,6\n30,2\n45,2,\n20,3,8\n10,3,8\n60,3,NaN\n100,4,9\n115,4,9\n130,4,9\n";
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
