//! CSV replay as a live input: a recorded log (`time_s` and one column per engine channel,
//! the layout `gearcomp fit` reads and `gearcomp serve --export-csv` writes) is fed to the
//! cycle paced by its time column, sped up by `speedup`, optionally looping.
//!
//! The whole file is checked before the service starts: a row with the wrong number of
//! fields, a time that is not a finite number or does not increase, or a cell that is not
//! a number is an error naming the file, the line and the column; nothing is skipped.
//! Each row steps the engine at the row's own time (mapped onto the service clock, see
//! [`ReplayPlan::service_time_s`]), so the live replay gives the offsets an offline
//! `gearcomp replay` of the same log gives.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::sync::Arc;
use std::time::Duration;

use crate::cycle::{Clock, InputMsg};
use crate::error::{Result, ServiceError};

pub use super::replay_config::ReplayInput;

/// One parsed row: the time and the cells of the mapped columns (NaN = empty cell).
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// 1-based line in the file (the header is line 1).
    pub line: u64,
    /// Log time, s.
    pub time_s: f64,
    /// Per engine channel: raw reading, NaN when the cell is empty (no new reading).
    pub channels: Vec<f64>,
    /// Per target: value, NaN when empty.
    pub targets: Vec<f64>,
    /// The `safe_point` column (absent: every row is a safe point).
    pub safe_point: bool,
    /// The `ack_stop` column: 1 acknowledges a latched stop request before the row
    /// (absent or empty: 0).
    pub ack_stop: bool,
    /// Per `position_<axis>_mm` column: the axis position, mm, NaN when empty (the last
    /// one holds).
    pub positions_mm: Vec<f64>,
}

/// A checked log: where each column is, how many rows, which times.
#[derive(Debug, Clone)]
pub struct ReplayPlan {
    path: PathBuf,
    n_fields: usize,
    time_col: usize,
    channel_cols: Vec<(usize, String)>,
    target_cols: Vec<(usize, String)>,
    safe_col: Option<usize>,
    ack_col: Option<usize>,
    /// `position_<axis>_mm` columns: (column, axis index, header).
    position_cols: Vec<(usize, u8, String)>,
    /// Data rows.
    pub rows: u64,
    /// Time of the first row, s.
    pub first_time_s: f64,
    /// Time of the last row, s.
    pub last_time_s: f64,
    /// Service seconds from one pass's first row to the next pass's first row.
    pub loop_period_s: f64,
}

fn row_error(path: &Path, line: u64, column: &str, value: &str, expected: &str) -> ServiceError {
    ServiceError::Replay {
        path: path.display().to_string(),
        line,
        column: column.to_string(),
        value: crate::error::shorten_message(&format!("{value:?}")),
        expected: expected.to_string(),
    }
}

fn open_reader(path: &Path) -> Result<csv::Reader<std::fs::File>> {
    let file = std::fs::File::open(path).map_err(|source| ServiceError::Io {
        action: "open",
        path: path.display().to_string(),
        source,
    })?;
    // Rows end at '\n' only (a CRLF row's '\r' is trimmed with the last field): the csv
    // crate's own CRLF handling reports data rows one line early.
    Ok(csv::ReaderBuilder::new()
        .flexible(true)
        .trim(csv::Trim::All)
        .terminator(csv::Terminator::Any(b'\n'))
        .from_reader(file))
}

fn parse_cell(
    path: &Path,
    line: u64,
    column: &str,
    cell: &str,
    what: &str,
) -> std::result::Result<f64, ServiceError> {
    if cell.is_empty() {
        return Ok(f64::NAN);
    }
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(row_error(path, line, column, cell, what)),
    }
}

impl ReplayPlan {
    /// Reads the header, maps `time_s`, every engine channel, the targets and an optional
    /// `safe_point` column, and checks every row; the first problem is an error naming
    /// the line and the column.
    pub fn open(cfg: &ReplayInput, channels: &[String]) -> Result<Self> {
        Self::open_with_axes(cfg, channels, &[])
    }

    /// As [`ReplayPlan::open`], also mapping a `position_<axis>_mm` column per engine axis
    /// that has one (the axis position for position-dependent laws, mm).
    pub fn open_with_axes(cfg: &ReplayInput, channels: &[String], axes: &[String]) -> Result<Self> {
        let path = cfg.path.clone();
        // At start the file is the configuration's: the error names the key.
        if path.is_dir() {
            return Err(crate::error::invalid(
                "input.path",
                format!("{:?}", path.display().to_string()),
                "a CSV log file, not a folder",
            ));
        }
        let mut rdr = open_reader(&path).map_err(|e| match e {
            ServiceError::Io { path, source, .. } => ServiceError::Io {
                action: "open input.path =",
                path,
                source,
            },
            other => other,
        })?;
        let headers = rdr
            .headers()
            .map_err(|e| row_error(&path, 1, "(header)", &e.to_string(), "a CSV header"))?
            .clone();
        let shown: String = headers.iter().collect::<Vec<_>>().join(",");
        let col = |name: &str| -> Result<usize> {
            headers.iter().position(|h| h == name).ok_or_else(|| {
                row_error(
                    &path,
                    1,
                    name,
                    &shown,
                    &format!("a column named {name:?} in the header"),
                )
            })
        };
        let time_col = col("time_s")?;
        let channel_cols = channels
            .iter()
            .map(|c| Ok((col(c)?, c.clone())))
            .collect::<Result<Vec<_>>>()?;
        let target_cols = cfg
            .targets
            .iter()
            .map(|c| Ok((col(c)?, c.clone())))
            .collect::<Result<Vec<_>>>()?;
        let safe_col = headers.iter().position(|h| h == "safe_point");
        let ack_col = headers.iter().position(|h| h == "ack_stop");
        let position_cols = axes
            .iter()
            .enumerate()
            .take(gearcomp_thermal::MAX_AXES)
            .filter_map(|(i, a)| {
                let name = format!("position_{a}_mm");
                let c = headers.iter().position(|h| h == name)?;
                Some((c, i as u8, name))
            })
            .collect();
        let mut plan = Self {
            path: path.clone(),
            n_fields: headers.len(),
            time_col,
            channel_cols,
            target_cols,
            safe_col,
            ack_col,
            position_cols,
            rows: 0,
            first_time_s: f64::NAN,
            last_time_s: f64::NAN,
            loop_period_s: f64::NAN,
        };
        let mut record = csv::StringRecord::new();
        let mut row = plan.empty_row();
        let mut prev = f64::NEG_INFINITY;
        let mut second = f64::NAN;
        while plan.next_row(&mut rdr, &mut record, &mut row, prev)? {
            if plan.rows == 0 {
                plan.first_time_s = row.time_s;
            } else if plan.rows == 1 {
                second = row.time_s;
            }
            prev = row.time_s;
            plan.rows += 1;
        }
        if plan.rows == 0 {
            return Err(row_error(
                &path,
                2,
                "(row)",
                "end of file",
                "at least one row",
            ));
        }
        plan.last_time_s = prev;
        // The next pass starts one row interval (the first one of the log) after the last
        // row, so time keeps increasing and the seam looks like any other row step.
        let step = if second.is_finite() {
            second - plan.first_time_s
        } else {
            1.0
        };
        plan.loop_period_s = plan.last_time_s - plan.first_time_s + step;
        Ok(plan)
    }

    /// A row buffer of the right size.
    pub fn empty_row(&self) -> Row {
        Row {
            line: 0,
            time_s: f64::NAN,
            channels: vec![f64::NAN; self.channel_cols.len()],
            targets: vec![f64::NAN; self.target_cols.len()],
            safe_point: true,
            ack_stop: false,
            positions_mm: vec![f64::NAN; self.position_cols.len()],
        }
    }

    /// Reads the next row into `row`; false at the end of the file. `prev_s` is the
    /// previous row's time (the time must increase strictly).
    fn next_row<R: std::io::Read>(
        &self,
        rdr: &mut csv::Reader<R>,
        record: &mut csv::StringRecord,
        row: &mut Row,
        prev_s: f64,
    ) -> Result<bool> {
        let path = &self.path;
        match rdr.read_record(record) {
            Ok(false) => return Ok(false),
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                return Err(row_error(path, line, "(row)", &e.to_string(), "a CSV row"));
            }
        }
        let line = record.position().map_or(0, |p| p.line());
        row.line = line;
        if record.len() != self.n_fields {
            return Err(row_error(
                path,
                line,
                "(row)",
                &format!("{} fields", record.len()),
                &format!("{} fields, as the header", self.n_fields),
            ));
        }
        let t = &record[self.time_col];
        row.time_s = match t.parse::<f64>() {
            Ok(v) if v.is_finite() && v > prev_s => v,
            Ok(v) if v.is_finite() => {
                return Err(row_error(
                    path,
                    line,
                    "time_s",
                    t,
                    &format!("a time after the previous row's {prev_s} s"),
                ))
            }
            _ => {
                return Err(row_error(
                    path,
                    line,
                    "time_s",
                    t,
                    "a finite number of seconds",
                ))
            }
        };
        for (slot, (c, name)) in row.channels.iter_mut().zip(&self.channel_cols) {
            *slot = parse_cell(
                path,
                line,
                name,
                &record[*c],
                "a finite number in the channel's raw unit, or empty (no new reading)",
            )?;
        }
        for (slot, (c, name)) in row.targets.iter_mut().zip(&self.target_cols) {
            *slot = parse_cell(path, line, name, &record[*c], "a finite number, or empty")?;
        }
        for (slot, (c, _, name)) in row.positions_mm.iter_mut().zip(&self.position_cols) {
            *slot = parse_cell(
                path,
                line,
                name,
                &record[*c],
                "the axis position in mm, or empty (the last one holds)",
            )?;
        }
        if let Some(c) = self.safe_col {
            row.safe_point = match &record[c] {
                "" | "1" | "true" => true,
                "0" | "false" => false,
                other => {
                    return Err(row_error(
                        path,
                        line,
                        "safe_point",
                        other,
                        "0, 1, true, false or empty (= 1)",
                    ))
                }
            };
        }
        if let Some(c) = self.ack_col {
            row.ack_stop = match &record[c] {
                "1" | "true" => true,
                "" | "0" | "false" => false,
                other => {
                    return Err(row_error(
                        path,
                        line,
                        "ack_stop",
                        other,
                        "0, 1, true, false or empty (= 0)",
                    ))
                }
            };
        }
        Ok(true)
    }

    /// The service time of a row in pass `pass` (0 = first).
    ///
    /// # Formula
    /// t = origin + pass·loop_period + (t_row − t_first),
    /// loop_period = (t_last − t_first) + (t_second − t_first)  (1 s for a one-row log)
    /// # Source
    /// [CONVENTION, docs/service.md: the replay keeps the log's time steps, continues the
    /// record's clock and keeps time increasing across passes]
    pub fn service_time_s(&self, origin_s: f64, pass: u64, row_time_s: f64) -> f64 {
        origin_s + pass as f64 * self.loop_period_s + (row_time_s - self.first_time_s)
    }

    /// The log file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Target column names, in order.
    pub fn target_names(&self) -> Vec<String> {
        self.target_cols.iter().map(|(_, n)| n.clone()).collect()
    }
}

/// Everything the replay thread needs.
pub struct ReplayParts {
    /// The checked log.
    pub plan: ReplayPlan,
    /// Start again after the last row.
    pub looping: bool,
    /// The service clock (running at the replay's speed-up).
    pub clock: Clock,
    /// To the cycle.
    pub tx: SyncSender<InputMsg>,
    /// Set when the service stops.
    pub shutdown: Arc<AtomicBool>,
}

/// Waits until the clock reaches `t_s`; false if the service is stopping.
fn wait_until(clock: &Clock, t_s: f64, shutdown: &AtomicBool) -> bool {
    loop {
        if shutdown.load(Ordering::Acquire) {
            return false;
        }
        let now = clock.now_s();
        if now >= t_s {
            return true;
        }
        std::thread::sleep(clock.wall(t_s - now).min(Duration::from_millis(20)));
    }
}

/// Replays the log until its end (or for ever when looping) or until the service stops.
///
/// Per row: the row's service time ([`InputMsg::ScanTime`]), the machine state, one
/// sample per non-empty channel cell, the targets, and the end of the scan. At the end of
/// a non-looping replay the alarm `replay.ended` says the inputs no longer change.
pub fn run(p: ReplayParts) {
    let ReplayParts {
        plan,
        looping,
        clock,
        tx,
        shutdown,
    } = p;
    let origin = clock.origin_s();
    let mut row = plan.empty_row();
    let mut record = csv::StringRecord::new();
    let mut last_line = 0;
    let mut pass = 0u64;
    let fail = |message: String| {
        let _ = tx.send(InputMsg::RaiseAlarm {
            key: "replay.file".into(),
            message,
        });
    };
    loop {
        let mut rdr = match open_reader(plan.path()) {
            Ok(r) => r,
            Err(e) => return fail(format!("CSV replay stopped: {e}")),
        };
        let mut prev = f64::NEG_INFINITY;
        loop {
            match plan.next_row(&mut rdr, &mut record, &mut row, prev) {
                Ok(true) => {}
                Ok(false) => break,
                // The file was checked at start; it changed since.
                Err(e) => return fail(format!("CSV replay stopped (file changed?): {e}")),
            }
            prev = row.time_s;
            last_line = row.line;
            let t = plan.service_time_s(origin, pass, row.time_s);
            if !wait_until(&clock, t, &shutdown) {
                return;
            }
            let mut ok = true;
            if row.ack_stop {
                // As an operator would: the stop request latched by an earlier row is
                // acknowledged before this row is stepped.
                ok &= tx.send(InputMsg::AckStop).is_ok();
            }
            ok &= tx.send(InputMsg::ScanTime { time_s: t }).is_ok();
            ok &= tx
                .send(InputMsg::MachineState {
                    safe_point: row.safe_point,
                })
                .is_ok();
            // Positions before the readings, so the row steps with them.
            for (&position_mm, (_, axis, _)) in row.positions_mm.iter().zip(&plan.position_cols) {
                if !position_mm.is_nan() {
                    ok &= tx
                        .send(InputMsg::Position {
                            axis: *axis,
                            position_mm,
                        })
                        .is_ok();
                }
            }
            for (c, &raw) in row.channels.iter().enumerate() {
                if !raw.is_nan() {
                    ok &= tx
                        .send(InputMsg::Sample {
                            channel: c as u16,
                            raw,
                            stamp_s: t,
                        })
                        .is_ok();
                }
            }
            for (k, &value) in row.targets.iter().enumerate() {
                if !value.is_nan() {
                    ok &= tx
                        .send(InputMsg::Target {
                            target: k as u16,
                            value,
                            stamp_s: t,
                        })
                        .is_ok();
                }
            }
            ok &= tx.send(InputMsg::ScanEnd).is_ok();
            if !ok {
                return;
            }
        }
        if !looping {
            let _ = tx.send(InputMsg::RaiseAlarm {
                key: "replay.ended".into(),
                message: format!(
                    "CSV replay of {} ended at line {last_line} ({} rows, log time {} s); \
                     the inputs no longer change and the offset holds its last value",
                    plan.path().display(),
                    plan.rows,
                    plan.last_time_s
                ),
            });
            return;
        }
        pass += 1;
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use proptest::prelude::*;

    fn plan_of(text: &str, channels: &[&str], targets: &[&str]) -> Result<ReplayPlan> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("log.csv");
        std::fs::write(&p, text).unwrap();
        let cfg = ReplayInput {
            path: p,
            speedup: 1.0,
            looping: false,
            targets: targets.iter().map(|s| s.to_string()).collect(),
        };
        let ch: Vec<String> = channels.iter().map(|s| s.to_string()).collect();
        ReplayPlan::open(&cfg, &ch)
    }

    #[test]
    fn bad_rows_name_line_and_column() {
        let e = |text: &str| plan_of(text, &["A", "B"], &[]).unwrap_err().to_string();
        let m = e("time_s,A,B\n0,1,2\n1,x,2\n");
        assert!(
            m.contains("line 3") && m.contains("column A") && m.contains("\"x\""),
            "{m}"
        );
        let m = e("time_s,A,B\n0,1,2\n1,1\n");
        assert!(
            m.contains("line 3") && m.contains("2 fields") && m.contains("3 fields"),
            "{m}"
        );
        let m = e("time_s,A,B\n5,1,2\n5,1,2\n");
        assert!(
            m.contains("line 3") && m.contains("column time_s") && m.contains("after"),
            "{m}"
        );
        // A logger clock restart (time falls) is refused like a repeated stamp: the
        // service never replays a row the engine would ignore.
        let m = e("time_s,A,B\n5,1,2\n6,,2\n3,7,\n");
        assert!(
            m.contains("line 4") && m.contains("column time_s") && m.contains("after"),
            "{m}"
        );
        let m = e("time_s,A,B\n0,1,2\nnan,1,2\n");
        assert!(m.contains("line 3") && m.contains("time_s"), "{m}");
        let m = e("time_s,A,B\n0,1,inf\n");
        assert!(m.contains("line 2") && m.contains("column B"), "{m}");
        let m = e("time_s,A\n0,1\n");
        assert!(m.contains("line 1") && m.contains("\"B\""), "{m}");
        let m = e("time_s,A,B\n");
        assert!(m.contains("at least one row"), "{m}");
        let m = e("time_s,A,B,safe_point\n0,1,2,maybe\n");
        assert!(m.contains("column safe_point"), "{m}");
    }

    /// A log that is not there (or a folder) is refused at start naming the key the user
    /// wrote, the path and the system's reason.
    #[test]
    fn a_missing_log_names_input_path() {
        let dir = tempfile::tempdir().unwrap();
        let open = |p: &Path| {
            let cfg = ReplayInput {
                path: p.to_path_buf(),
                speedup: 1.0,
                looping: false,
                targets: vec![],
            };
            ReplayPlan::open(&cfg, &["A".to_string()])
                .unwrap_err()
                .to_string()
        };
        let p = dir.path().join("nowhere.csv");
        let e = open(&p);
        assert!(
            e.starts_with(&format!("cannot open input.path = {}: ", p.display())),
            "{e}"
        );
        let e = open(dir.path());
        assert_eq!(
            e,
            format!(
                "invalid input.path = {:?}: expected a CSV log file, not a folder",
                dir.path().display().to_string()
            )
        );
    }

    #[test]
    fn crlf_lines_are_counted_like_lf() {
        for nl in ["\n", "\r\n"] {
            let text = ["time_s,A", "0,1", "1,2", "2,x", ""].join(nl);
            let m = plan_of(&text, &["A"], &[]).unwrap_err().to_string();
            assert!(m.contains("line 4, column A"), "{nl:?}: {m}");
        }
    }

    #[test]
    fn export_layout_with_empty_cells_and_extra_columns() {
        // The export's layout: channels, a target, an offset column (ignored).
        let p = plan_of(
            "time_s,A,B,measured_drift_um,Z_offset_um\n0,20,21,1.5,0\n15,,21.5,,-1\n30,22,23,2,-2\n",
            &["A", "B"],
            &["measured_drift_um"],
        )
        .unwrap();
        assert_eq!(p.rows, 3);
        assert_eq!((p.first_time_s, p.last_time_s), (0.0, 30.0));
        // Next pass starts one first interval (15 s) after the last row.
        assert_eq!(p.loop_period_s, 45.0);
        assert_eq!(p.service_time_s(100.0, 0, 15.0), 115.0);
        assert_eq!(p.service_time_s(100.0, 2, 0.0), 190.0);
        assert_eq!(p.target_names(), vec!["measured_drift_um".to_string()]);
    }

    #[test]
    fn config_checks() {
        let mut c = ReplayInput {
            path: "log.csv".into(),
            speedup: 0.0,
            looping: true,
            targets: vec![],
        };
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("input.speedup"));
        c.speedup = 10.0;
        c.targets = vec!["d".into(), "d".into()];
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("input.targets[1]"));
    }

    proptest! {
        #[test]
        fn never_panics_on_any_log(text in "[0-9a-z,.\\-\\n\" ]{0,200}") {
            let _ = plan_of(&format!("time_s,A\n{text}"), &["A"], &[]);
        }
    }
}
