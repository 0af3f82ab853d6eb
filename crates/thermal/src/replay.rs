//! Replaying a recorded log through the engine (`gearcomp replay`).
//!
//! The log is CSV with a header: `time_s` (s, strictly increasing), one column per
//! configured channel (named as the channel, raw units), and optionally `trigger` and
//! `safe_point` (0/1; both default to 1), and `ack_stop` (0/1, default 0: a 1 acknowledges
//! a latched stop request before the row is stepped, as an operator would, so one spike
//! past a limit does not stop the compensation for the rest of the log), and
//! `position_<axis>_mm` (the axis position for a position-dependent law, mm; an empty
//! cell keeps the last one, an axis without the column has no position). An empty cell
//! in a channel column means "no new reading": the
//! channel keeps its last value and stamp, so a long gap shows as a stale channel. A cell
//! that is not a number is reported with its line and fed to the engine as NaN (the
//! engine then raises its NaN alarm); a row with the wrong number of fields is reported
//! and skipped. No row is dropped silently.

use crate::engine::{Alarm, AxisStatus, Engine, EngineStatus, Excursion, Inputs, Reading};
use crate::error::{invalid, Result};

/// A problem with one row of the log.
#[derive(Debug, Clone, PartialEq)]
pub struct BadRow {
    /// 1-based line number in the file (the header is line 1).
    pub line: u64,
    /// What is wrong, naming the column and the text.
    pub message: String,
}

/// One replayed row.
#[derive(Debug, Clone, PartialEq)]
pub struct ReplayRow {
    /// Line number in the log.
    pub line: u64,
    /// Time, s.
    pub time_s: f64,
    /// Applied offset per axis, µm.
    pub offset_um: Vec<f64>,
    /// Running compensation per axis, µm.
    pub target_um: Vec<f64>,
    /// Axis status per axis.
    pub axis_status: Vec<AxisStatus>,
    /// Pulses issued this row per axis.
    pub pulses: Vec<i64>,
    /// Engine status.
    pub status: EngineStatus,
    /// The alarm, described ("" if none).
    pub alarm: String,
    /// The warning (the model is extrapolating), described ("" if none).
    pub warning: String,
    /// The stop request, described ("" if none).
    pub stop: String,
}

/// The result of a replay.
#[derive(Debug, Clone, Default)]
pub struct Replay {
    /// Axis names.
    pub axes: Vec<String>,
    /// One row per log row that had the right shape.
    pub rows: Vec<ReplayRow>,
    /// Rows with problems (reported, never silently dropped).
    pub bad_rows: Vec<BadRow>,
}

/// Describes an alarm for people (not for the control cycle).
pub fn describe_alarm(a: &Alarm, channel_names: &[String], axis_names: &[String]) -> String {
    let ch = |i: u16| {
        channel_names
            .get(i as usize)
            .map_or("?", String::as_str)
            .to_string()
    };
    let ax = |i: u8| {
        axis_names
            .get(i as usize)
            .map_or("?", String::as_str)
            .to_string()
    };
    match a {
        Alarm::Channel { channel, fault } => format!("channel {}: {fault:?}", ch(*channel)),
        Alarm::TimeOutOfOrder { time_s, previous_s } => {
            format!("time {time_s} s not after {previous_s} s: cycle ignored")
        }
        Alarm::InputCount { got, expected } => format!("{got} readings for {expected} channels"),
        Alarm::PositionMissing { axis } => format!("axis {}: no position", ax(*axis)),
        Alarm::LawNotFinite { axis } => format!("axis {}: law not finite", ax(*axis)),
        Alarm::Envelope { axis, excursion } => {
            let what = match *excursion {
                Excursion::Range {
                    channel,
                    value,
                    min,
                    max,
                    celsius,
                } => {
                    let unit = if celsius { "°C" } else { "µm" };
                    format!(
                        "channel {} = {value:.3} {unit} outside its training range {min:.3} … {max:.3} {unit}",
                        ch(channel)
                    )
                }
                Excursion::Leverage {
                    leverage,
                    bound,
                    d2,
                    max_d2,
                } => format!(
                    "leverage {leverage:.5} above the training bound {bound:.5} (Mahalanobis d² {d2:.2} > {max_d2:.2})"
                ),
            };
            format!(
                "axis {}: warning, model extrapolating (inputs outside its training envelope; compensation goes on): {what}",
                ax(*axis)
            )
        }
    }
}

fn parse_flag(text: &str) -> Option<bool> {
    match text.trim() {
        "" | "1" | "true" => Some(true),
        "0" | "false" => Some(false),
        _ => None,
    }
}

/// The field delimiter of a log: `,` when its header line holds one, else a tab or `;`
/// when it holds that (the exports of spreadsheets in decimal-comma locales), else `,`.
fn log_delimiter(text: &str) -> u8 {
    let header = text.lines().next().unwrap_or("");
    if header.contains(',') {
        b','
    } else if header.contains('\t') {
        b'\t'
    } else if header.contains(';') {
        b';'
    } else {
        b','
    }
}

/// Runs `engine` over the CSV `text` (comma, tab or `;` separated; with a tab or `;`,
/// numbers may have a decimal comma).
pub fn replay_csv(engine: &mut Engine, text: &str) -> Result<Replay> {
    // A byte-order mark (Excel's UTF-8 CSV) is no part of the first column's name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let delimiter = log_delimiter(text);
    // A log separated by `;` or tabs (a spreadsheet's export in a decimal-comma locale) may
    // write its numbers with a decimal comma.
    let decimal_comma = delimiter != b',';
    let number = |cell: &str| -> std::result::Result<f64, std::num::ParseFloatError> {
        match cell.parse::<f64>() {
            Err(_) if decimal_comma && cell.contains(',') && !cell.contains('.') => {
                cell.replacen(',', ".", 1).parse::<f64>()
            }
            r => r,
        }
    };
    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delimiter)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let headers = rdr
        .headers()
        .map_err(|e| invalid("log header", e, "a CSV header line"))?
        .clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let time_col = col("time_s").ok_or_else(|| {
        invalid(
            "log header",
            headers.iter().collect::<Vec<_>>().join(","),
            "a time_s column",
        )
    })?;
    let names = engine.channel_names().to_vec();
    let axes = engine.axis_names().to_vec();
    // A channel named like one of the log's own columns would read that column (the time
    // as a temperature): refused, naming the channel.
    for (i, n) in names.iter().enumerate() {
        let reserved = ["time_s", "trigger", "safe_point", "ack_stop"].contains(&n.as_str())
            || axes.iter().any(|a| *n == format!("position_{a}_mm"));
        if reserved {
            return Err(invalid(
                format!("channels[{i}].name"),
                format!("{n:?}"),
                "a name other than the log's own columns time_s, trigger, safe_point, \
                 ack_stop and position_<axis>_mm",
            ));
        }
    }
    let mut channel_cols = Vec::with_capacity(names.len());
    for n in &names {
        channel_cols.push(col(n).ok_or_else(|| {
            invalid(
                "log header",
                headers.iter().collect::<Vec<_>>().join(","),
                &format!("a column for channel {n:?}"),
            )
        })?);
    }
    let (trig_col, safe_col) = (col("trigger"), col("safe_point"));
    let ack_col = col("ack_stop");
    let position_cols: Vec<(usize, usize)> = axes
        .iter()
        .enumerate()
        .filter_map(|(i, a)| Some((col(&format!("position_{a}_mm"))?, i)))
        .collect();
    // NaN until a row gives one: the engine freezes an axis whose law needs it.
    let mut positions_mm = vec![f64::NAN; axes.len()];
    let mut out = Replay {
        axes: axes.clone(),
        ..Default::default()
    };
    let mut readings = vec![
        Reading {
            raw: f64::NAN,
            stamp_s: f64::NEG_INFINITY
        };
        names.len()
    ];
    // `readings` and `positions_mm` hold what the last accepted row left. A row whose time does not
    // increase is a cycle the engine ignores (`Alarm::TimeOutOfOrder`): it is stepped with its
    // own cells on a scratch copy and leaves these untouched, so a later empty cell holds the
    // last *accepted* reading, not one stamped before it (that was an `OutOfOrder` fault and
    // a frozen axis on a good row after a restart or a repeated time stamp).
    let mut accepted_time_s = f64::NEG_INFINITY;
    let mut row_readings = readings.clone();
    let mut row_positions_mm = positions_mm.clone();
    // csv's own line count is one short on CRLF files (FL_THERMAL is one).
    let mut lines = gearcomp_core::textline::LineCounter::new(text);
    let mut record = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut record) {
            Ok(false) => break,
            Ok(true) => {}
            Err(e) => {
                let line = e.position().map_or(0, |p| lines.line_at(p.byte()));
                out.bad_rows.push(BadRow {
                    line,
                    message: format!("unreadable row: {e}"),
                });
                continue;
            }
        }
        let line = record.position().map_or(0, |p| lines.line_at(p.byte()));
        if record.len() != headers.len() {
            out.bad_rows.push(BadRow {
                line,
                message: format!(
                    "{} fields, the header has {}: row skipped",
                    record.len(),
                    headers.len()
                ),
            });
            continue;
        }
        let time_s = match number(&record[time_col]) {
            Ok(t) if t.is_finite() => t,
            _ => {
                out.bad_rows.push(BadRow {
                    line,
                    message: format!(
                        "time_s {:?} is not a finite number: row skipped",
                        &record[time_col]
                    ),
                });
                continue;
            }
        };
        row_readings.copy_from_slice(&readings);
        row_positions_mm.copy_from_slice(&positions_mm);
        for (k, &c) in channel_cols.iter().enumerate() {
            let cell = &record[c];
            if cell.is_empty() {
                continue;
            }
            let raw = number(cell).unwrap_or_else(|_| {
                out.bad_rows.push(BadRow {
                    line,
                    message: format!("column {}: {cell:?} is not a number (fed as NaN)", names[k]),
                });
                f64::NAN
            });
            row_readings[k] = Reading {
                raw,
                stamp_s: time_s,
            };
        }
        for &(c, i) in &position_cols {
            let cell = &record[c];
            if cell.is_empty() {
                continue;
            }
            row_positions_mm[i] = match number(cell) {
                Ok(p) if p.is_finite() => p,
                _ => {
                    out.bad_rows.push(BadRow {
                        line,
                        message: format!(
                            "column position_{}_mm: {cell:?} is not a position in mm (fed as unknown: the axis freezes)",
                            axes[i]
                        ),
                    });
                    f64::NAN
                }
            };
        }
        let mut flag = |c: Option<usize>, what: &str| {
            c.is_none_or(|c| {
                parse_flag(&record[c]).unwrap_or_else(|| {
                    out.bad_rows.push(BadRow {
                        line,
                        message: format!("column {what}: {:?} is not 0/1 (taken as 1)", &record[c]),
                    });
                    true
                })
            })
        };
        let trigger = flag(trig_col, "trigger");
        let safe_point = flag(safe_col, "safe_point");
        if let Some(c) = ack_col {
            match record[c].trim() {
                "" | "0" | "false" => {}
                "1" | "true" => engine.acknowledge_stop(),
                other => out.bad_rows.push(BadRow {
                    line,
                    message: format!("column ack_stop: {other:?} is not 0/1 (taken as 0)"),
                }),
            }
        }
        let o = engine.step(&Inputs {
            time_s,
            readings: &row_readings,
            trigger,
            safe_point,
            positions_mm: if position_cols.is_empty() {
                &[]
            } else {
                &row_positions_mm
            },
        });
        if time_s > accepted_time_s {
            accepted_time_s = time_s;
            readings.copy_from_slice(&row_readings);
            positions_mm.copy_from_slice(&row_positions_mm);
        }
        let ax = o.axes();
        out.rows.push(ReplayRow {
            line,
            time_s,
            offset_um: ax.iter().map(|a| a.offset_um).collect(),
            target_um: ax.iter().map(|a| a.target_um).collect(),
            axis_status: ax.iter().map(|a| a.status).collect(),
            pulses: ax.iter().map(|a| a.pulses).collect(),
            status: o.status,
            alarm: o
                .alarm
                .map_or(String::new(), |a| describe_alarm(&a, &names, &axes)),
            warning: o
                .warning
                .map_or(String::new(), |a| describe_alarm(&a, &names, &axes)),
            stop: o.stop.map_or(String::new(), |s| {
                format!(
                    "channel {} = {} outside [{}, {}]",
                    names.get(s.channel as usize).map_or("?", String::as_str),
                    s.value,
                    s.limit_min,
                    s.limit_max
                )
            }),
        });
    }
    Ok(out)
}

impl Replay {
    /// The offsets and alarms as CSV text: `line,time_s,<axis>_offset_um,<axis>_target_um,
    /// <axis>_pulses,<axis>_status…,status,alarm,stop,warning`.
    pub fn to_csv(&self) -> Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header = vec!["line".to_string(), "time_s".to_string()];
        for a in &self.axes {
            header.extend([
                format!("{a}_offset_um"),
                format!("{a}_target_um"),
                format!("{a}_pulses"),
                format!("{a}_status"),
            ]);
        }
        header.extend([
            "status".into(),
            "alarm".into(),
            "stop".into(),
            "warning".into(),
        ]);
        let err = |e: csv::Error| invalid("output", e, "writable CSV");
        w.write_record(&header).map_err(err)?;
        for r in &self.rows {
            let mut rec = vec![r.line.to_string(), r.time_s.to_string()];
            for i in 0..self.axes.len() {
                rec.extend([
                    format!("{:.4}", r.offset_um[i]),
                    format!("{:.4}", r.target_um[i]),
                    r.pulses[i].to_string(),
                    format!("{:?}", r.axis_status[i]),
                ]);
            }
            rec.extend([
                format!("{:?}", r.status),
                r.alarm.clone(),
                r.stop.clone(),
                r.warning.clone(),
            ]);
            w.write_record(&rec).map_err(err)?;
        }
        let bytes = w
            .into_inner()
            .map_err(|e| invalid("output", e, "writable CSV"))?;
        String::from_utf8(bytes).map_err(|e| invalid("output", e, "UTF-8 text"))
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use crate::EngineConfig;

    const CONFIG: &str = r#"
[[channels]]
name = "A"
sensor = { kind = "celsius" }
valid_min = -10.0
valid_max = 80.0
stale_timeout_s = 5.0

[[axes]]
name = "Z"
apply = { kind = "measuring_system" }
max_offset_um = 100.0

[[axes.terms]]
kind = "linear"
channel = "A"
kd_um_per_c = 2.0
alpha_um = 0.0
"#;

    /// Issue 14 item 9: the `position_Z_mm` column reaches the SINUMERIK/TwinCAT position
    /// law K0(T) + tanβ(T)·(P − P0) (K0 = 2 + 0.5·(T − 20) µm, tanβ = 0.25 + 0.0625·(T −
    /// 20) µm/mm, P0 = 100 mm); by hand at T = 24 °C: K0 = 4, tanβ = 0.5, so 140 mm →
    /// 24 µm, an empty cell keeps 140 mm, 60 mm → −16 µm, and a bad cell freezes the axis
    /// with a reported row. Without the column the axis has no position and freezes.
    #[test]
    fn position_column_reaches_the_position_law() {
        let cfg = EngineConfig::from_toml_str(
            "[[channels]]\nname = \"A\"\nsensor = { kind = \"celsius\" }\n\
             valid_min = -10.0\nvalid_max = 80.0\nstale_timeout_s = 1000.0\n\
             [[axes]]\nname = \"Z\"\napply = { kind = \"measuring_system\" }\n\
             max_offset_um = 100.0\n[[axes.terms]]\nkind = \"position\"\nchannel = \"A\"\n\
             t_ref_c = 20.0\noffset_um = 2.0\noffset_um_per_c = 0.5\nslope_um_per_mm = 0.25\n\
             slope_um_per_mm_per_c = 0.0625\np0_mm = 100.0\n",
        )
        .unwrap();
        let law =
            |t: f64, p: f64| (2.0 + 0.5 * (t - 20.0)) + (0.25 + 0.0625 * (t - 20.0)) * (p - 100.0);
        let mut e = Engine::new(&cfg).unwrap();
        let r = replay_csv(
            &mut e,
            "time_s,A,position_Z_mm\n0,24,140\n1,24,\n2,24,60\n3,24,far\n4,24,\n",
        )
        .unwrap();
        let ys: Vec<f64> = r.rows.iter().map(|r| r.offset_um[0]).collect();
        assert_eq!(ys, vec![24.0, 24.0, -16.0, -16.0, -16.0]);
        assert_eq!(ys[0], law(24.0, 140.0));
        assert_eq!(ys[2], law(24.0, 60.0));
        assert_eq!(r.rows[3].axis_status[0], AxisStatus::Frozen);
        assert_eq!(r.bad_rows.len(), 1);
        assert_eq!(r.bad_rows[0].line, 5);
        assert!(
            r.bad_rows[0].message.contains("position_Z_mm"),
            "{:?}",
            r.bad_rows
        );
        let mut e = Engine::new(&cfg).unwrap();
        let r = replay_csv(&mut e, "time_s,A\n0,24\n").unwrap();
        assert_eq!(r.rows[0].axis_status[0], AxisStatus::Frozen);
    }

    /// Issue 14 item 10: one reading past the stop limit (A ≤ 30 °C) stops the
    /// compensation for the rest of the log; an `ack_stop` row resumes it, and from
    /// there the offset is the law again, 2·A µm (by hand).
    #[test]
    fn ack_stop_column_resumes_after_one_spike() {
        let cfg = EngineConfig::from_toml_str(&CONFIG.replace(
            "stale_timeout_s = 5.0",
            "stale_timeout_s = 5.0\nlimit_max = 30.0",
        ))
        .unwrap();
        let log = |ack: &str| {
            format!(
                "time_s,A{}\n0,20{}\n1,21{}\n2,45{}\n3,22{}\n4,23{}\n5,24{}\n",
                if ack.is_empty() { "" } else { ",ack_stop" },
                if ack.is_empty() { "" } else { "," },
                if ack.is_empty() { "" } else { "," },
                if ack.is_empty() { "" } else { "," },
                if ack.is_empty() { "" } else { "," },
                if ack.is_empty() { "" } else { ",1" },
                if ack.is_empty() { "" } else { "," },
            )
        };
        let mut e = Engine::new(&cfg).unwrap();
        let without = replay_csv(&mut e, &log("")).unwrap();
        let stopped: Vec<bool> = without.rows.iter().map(|r| !r.stop.is_empty()).collect();
        assert_eq!(stopped, vec![false, false, true, true, true, true]);
        let mut e = Engine::new(&cfg).unwrap();
        let with = replay_csv(&mut e, &log("ack")).unwrap();
        assert!(with.bad_rows.is_empty(), "{:?}", with.bad_rows);
        let stopped: Vec<bool> = with.rows.iter().map(|r| !r.stop.is_empty()).collect();
        assert_eq!(stopped, vec![false, false, true, true, false, false]);
        // Stopped rows hold 42 µm (the last offset before the spike); then 2·23, 2·24.
        let y: Vec<f64> = with.rows.iter().map(|r| r.offset_um[0]).collect();
        assert_eq!(y, vec![40.0, 42.0, 42.0, 42.0, 46.0, 48.0]);
        // A cell that is not 0/1 is reported, not skipped silently.
        let mut e = Engine::new(&cfg).unwrap();
        let bad = replay_csv(&mut e, "time_s,A,ack_stop\n0,20,yes\n").unwrap();
        assert!(
            bad.bad_rows[0].message.contains("ack_stop"),
            "{:?}",
            bad.bad_rows
        );
    }

    /// The bad cell is on line 4 of the file (header = line 1) whatever the line ends.
    #[test]
    fn bad_row_lines_are_file_lines_for_lf_and_crlf() {
        let lf = "time_s,A\n0,20\n1,21\n2,hot\n3,22\n";
        let crlf = lf.replace('\n', "\r\n");
        for text in [lf.to_string(), crlf] {
            let cfg = EngineConfig::from_toml_str(CONFIG).unwrap();
            let mut engine = Engine::new(&cfg).unwrap();
            let r = replay_csv(&mut engine, &text).unwrap();
            assert_eq!(r.bad_rows.len(), 1, "{:?}", r.bad_rows);
            assert_eq!(r.bad_rows[0].line, 4, "{:?}", r.bad_rows);
            let lines: Vec<u64> = r.rows.iter().map(|row| row.line).collect();
            assert_eq!(lines, vec![2, 3, 4, 5]);
        }
    }
}
