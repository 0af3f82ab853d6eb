//! Logs as plants export them (issue 12 item 1): random valid logs written in random
//! dialects (delimiter, decimal comma, BOM, CRLF, quoting, time stamps in every accepted form
//! with mixed UTC offsets) read into exactly the table of the same log written plainly, and
//! the same fitted model; random invalid logs (bad time stamps, a row with another
//! delimiter, text in a numeric cell) refused naming the column, value and line; missing
//! cells left out and splitting the run (`MissingCells::Split`), checked against a table
//! built directly from the generated values.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use chrono::DateTime;
use gearcomp_identify::data::{read_csv, DataIssue, MissingCells, ReadOptions, Selection, Table};
use gearcomp_identify::{identify, IdentifyOptions, ModelKind, Split};
use proptest::prelude::*;

/// xorshift64: the generated log's content.
struct Rng(u64);
impl Rng {
    fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1)
    }
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// A number in [lo, hi) with all 53 bits random.
    fn real(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// The generated values: time in s since the first row (steps of 0.25 s), two inputs and a
/// target.
struct Log {
    t: Vec<f64>,
    a: Vec<f64>,
    b: Vec<f64>,
    d: Vec<f64>,
}

fn random_log(seed: u64, rows: usize, fixed_step: bool) -> Log {
    let mut r = Rng::new(seed);
    let mut log = Log {
        t: Vec::new(),
        a: Vec::new(),
        b: Vec::new(),
        d: Vec::new(),
    };
    let mut t = 0.0;
    for k in 0..rows {
        if k > 0 {
            t += if fixed_step {
                60.0
            } else {
                (1 + r.next() % 40) as f64 * 0.25
            };
        }
        let a = 20.0 + 5.0 * (t / 300.0).sin() + r.real(-0.5, 0.5);
        let b = 22.0 + 3.0 * (t / 700.0).cos() + r.real(-0.5, 0.5);
        log.t.push(t);
        log.a.push(a);
        log.b.push(b);
        log.d.push(1.5 * a - 0.75 * b + r.real(-0.1, 0.1));
    }
    log
}

/// The log written plainly: comma, decimal point, seconds; `note` is an unused text column.
fn plain(log: &Log) -> String {
    let mut s = String::from("time_s,a_c,note,b_c,d_um\n");
    for k in 0..log.t.len() {
        s += &format!("{},{},n,{},{}\n", log.t[k], log.a[k], log.b[k], log.d[k]);
    }
    s
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum TimeForm {
    Seconds,
    IsoSpace,
    IsoT,
    Zulu,
    /// `T` and a random `±hh:mm` offset on every row (the same instants).
    MixedOffsets,
    DayFirst,
    /// `01/03/2024 08:00:00.250` (day first; `--date-order dmy`).
    SlashDayFirst,
    /// `03/01/2024 08:00:00.250 AM` (month first, 12-hour clock; `--date-order mdy`).
    SlashMonthFirst12h,
    /// Elapsed time since the start `h:mm:ss.250` (hours beyond 24 too).
    Elapsed,
}

#[derive(Debug, Clone, Copy)]
struct Dialect {
    delim: char,
    decimal_comma: bool,
    bom: bool,
    crlf: bool,
    /// 0: no quotes, 1: some cells quoted, 2: every cell quoted.
    quoting: u8,
    time: TimeForm,
    /// Instant of the first row, s since 1970.
    start_s: i64,
}

fn dialect_strategy() -> impl Strategy<Value = Dialect> {
    (
        prop_oneof![Just(','), Just(';'), Just('\t')],
        any::<bool>(),
        any::<bool>(),
        any::<bool>(),
        0u8..3,
        prop_oneof![
            Just(TimeForm::Seconds),
            Just(TimeForm::IsoSpace),
            Just(TimeForm::IsoT),
            Just(TimeForm::Zulu),
            Just(TimeForm::MixedOffsets),
            Just(TimeForm::DayFirst),
            Just(TimeForm::Elapsed),
        ],
        // 2001 … 2037, any second.
        978_307_200i64..2_100_000_000,
    )
        .prop_map(|(delim, dc, bom, crlf, quoting, time, start_s)| Dialect {
            delim,
            decimal_comma: dc && delim != ',',
            bom,
            crlf,
            quoting,
            time,
            start_s,
        })
}

/// The time cell of a row at `t` s after the first, in form `d.time`.
fn time_text(d: &Dialect, t: f64, r: &mut Rng) -> String {
    let num = |v: f64| {
        let s = format!("{v}");
        if d.decimal_comma {
            s.replace('.', ",")
        } else {
            s
        }
    };
    if d.time == TimeForm::Seconds {
        return num(t);
    }
    let ms = (t * 1000.0).round() as i64;
    if d.time == TimeForm::Elapsed {
        let (h, m, sec, f) = (ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000);
        let point = if d.decimal_comma { ',' } else { '.' };
        return format!("{h}:{m:02}:{sec:02}{point}{f:03}");
    }
    // Wall-clock offset of this row in minutes (instants stay the same).
    let off_min: i64 = match d.time {
        TimeForm::MixedOffsets => (r.next() % 105) as i64 * 15 - 720,
        _ => 0,
    };
    let wall_ms = d.start_s * 1000 + ms + off_min * 60_000;
    let wall = DateTime::from_timestamp_millis(wall_ms)
        .unwrap()
        .naive_utc();
    let offset = || {
        let m = off_min.abs();
        format!(
            "{}{:02}:{:02}",
            if off_min < 0 { '-' } else { '+' },
            m / 60,
            m % 60
        )
    };
    match d.time {
        TimeForm::IsoSpace => wall.format("%Y-%m-%d %H:%M:%S%.3f").to_string(),
        TimeForm::IsoT => wall.format("%Y-%m-%dT%H:%M:%S%.3f").to_string(),
        TimeForm::Zulu => wall.format("%Y-%m-%dT%H:%M:%S%.3fZ").to_string(),
        TimeForm::MixedOffsets => format!("{}{}", wall.format("%Y-%m-%dT%H:%M:%S%.3f"), offset()),
        TimeForm::DayFirst => {
            let s = wall.format("%d.%m.%Y %H:%M:%S%.3f").to_string();
            if d.decimal_comma {
                // 01.03.2024 08:00:00,250
                let p = s.rfind('.').unwrap();
                format!("{},{}", &s[..p], &s[p + 1..])
            } else {
                s
            }
        }
        TimeForm::SlashDayFirst => {
            let s = wall.format("%d/%m/%Y %H:%M:%S%.3f").to_string();
            if d.decimal_comma {
                let p = s.rfind('.').unwrap();
                format!("{},{}", &s[..p], &s[p + 1..])
            } else {
                s
            }
        }
        TimeForm::SlashMonthFirst12h => wall.format("%m/%d/%Y %I:%M:%S%.3f %p").to_string(),
        TimeForm::Seconds | TimeForm::Elapsed => unreachable!(),
    }
}

/// The log written in dialect `d` (cell content and quoting from `seed`).
fn written(log: &Log, d: &Dialect, seed: u64) -> String {
    let mut r = Rng::new(seed ^ 0x5555);
    let end = if d.crlf { "\r\n" } else { "\n" };
    let sep = d.delim.to_string();
    let quote = |s: String, r: &mut Rng| -> String {
        let q = match d.quoting {
            0 => false,
            1 => r.next().is_multiple_of(3),
            _ => true,
        };
        if q {
            format!("\"{s}\"")
        } else {
            s
        }
    };
    let num = |v: f64| {
        let s = format!("{v}");
        if d.decimal_comma {
            s.replace('.', ",")
        } else {
            s
        }
    };
    let mut out = String::new();
    if d.bom {
        out.push('\u{feff}');
    }
    let header: Vec<String> = ["time_s", "a_c", "note", "b_c", "d_um"]
        .iter()
        .map(|h| quote(h.to_string(), &mut r))
        .collect();
    out += &header.join(&sep);
    out += end;
    for k in 0..log.t.len() {
        let time = time_text(d, log.t[k], &mut r);
        // The unused column: text holding the delimiter (quoted), empty, or NaN.
        let note = match r.next() % 4 {
            0 if d.quoting > 0 => format!("\"op{sep}x \"\"y\"\"\""),
            1 => String::new(),
            2 => "NaN".to_string(),
            _ => "text".to_string(),
        };
        let cells = [
            quote(time, &mut r),
            quote(num(log.a[k]), &mut r),
            note,
            quote(num(log.b[k]), &mut r),
            quote(num(log.d[k]), &mut r),
        ];
        out += &cells.join(&sep);
        out += end;
    }
    out
}

fn sel() -> Selection {
    Selection {
        time: "time_s".into(),
        inputs: vec!["*_c".into()],
        targets: vec!["d_um".into()],
        run: None,
    }
}

fn read(text: &str, opts: ReadOptions) -> Result<Table, String> {
    read_csv(text, "log.csv", &sel(), opts).map_err(|e| e.to_string())
}

/// Intercept and coefficients of the static model of `t`.
fn fitted(t: &Table) -> Vec<f64> {
    let opts = IdentifyOptions {
        model: ModelKind::Static,
        classes: Some(2),
        split: Split::None,
        ..Default::default()
    };
    let id = identify(t, &opts).unwrap();
    let m = &id.targets[0].model;
    std::iter::once(m.intercept)
        .chain(m.terms.iter().map(|c| c.coefficient))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Any dialect gives the plain log's table (times, values, lines, segments) exactly,
    /// and so the same fitted model.
    #[test]
    fn every_dialect_reads_as_the_plain_log(d in dialect_strategy(), seed in any::<u64>(), rows in 5usize..80) {
        let log = random_log(seed, rows, false);
        let want = read(&plain(&log), ReadOptions::default()).unwrap();
        let text = written(&log, &d, seed);
        let got = read(&text, ReadOptions::default());
        prop_assert_eq!(got.as_ref(), Ok(&want), "{:?}\n{}", d, text);
        // Forcing the dialect that detection found changes nothing.
        let forced = read(&text, ReadOptions {
            delimiter: Some(d.delim as u8),
            decimal_comma: d.decimal_comma.then_some(true),
            ..ReadOptions::default()
        });
        prop_assert_eq!(forced.as_ref(), Ok(&want));
        if rows >= 20 && seed % 4 == 0 {
            let (p, q) = (fitted(&want), fitted(got.as_ref().unwrap()));
            for (x, y) in p.iter().zip(&q) {
                prop_assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{p:?} {q:?}");
            }
        }
    }

    /// Broken logs are refused with the column, the value and the line.
    #[test]
    fn invalid_logs_name_the_line(d in dialect_strategy(), seed in any::<u64>(), rows in 5usize..40, kind in 0u8..3, pick in any::<u64>()) {
        let log = random_log(seed, rows, false);
        let text = written(&log, &d, seed);
        let mut lines: Vec<String> = text.split_inclusive('\n').map(String::from).collect();
        // Data row r (not the first, which decides the time form) on line r + 2.
        let r = 1 + (pick % (rows as u64 - 1)) as usize;
        let end = if d.crlf { "\r\n" } else { "\n" };
        let sep = d.delim.to_string();
        let num = |v: f64| if d.decimal_comma { format!("{v}").replace('.', ",") } else { format!("{v}") };
        let mut rng = Rng::new(pick);
        let (bad_cell, expect): (String, String) = match kind {
            0 => {
                let garbage = ["2024-13-01 08:00:00", "2024-02-30 10:00:00", "31.02.2024 08:00:00",
                    "08:00:00", "2024-03-01 08:00:00+25:00", "soon", "2024/13/01 08:00:00", "1.5.3"];
                let g = garbage[(pick % garbage.len() as u64) as usize];
                // In an elapsed-time log 08:00:00 is a time: a minute of 60 is not.
                let g = if d.time == TimeForm::Elapsed && g == "08:00:00" { "08:60:00" } else { g };
                let expect = match d.time {
                    TimeForm::Seconds => format!("time_s = \"{g}\" is not a number"),
                    TimeForm::Elapsed => format!("time_s = \"{g}\" is not a clock time"),
                    _ => format!("time_s = \"{g}\" is not a time stamp"),
                };
                (format!("{g}{sep}{}{sep}n{sep}{}{sep}{}", num(log.a[r]), num(log.b[r]), num(log.d[r])), expect)
            }
            1 => {
                // The row written with another delimiter.
                let other = if d.delim == ';' { "\t" } else { ";" };
                let t = time_text(&d, log.t[r], &mut rng);
                (format!("{t}{other}{}{other}n{other}{}{other}{}", num(log.a[r]), num(log.b[r]), num(log.d[r])),
                    "1 fields, header has 5".to_string())
            }
            _ => {
                let words = ["abc", "12a", "--5", "1e", "0x10"];
                let w = words[(pick % words.len() as u64) as usize];
                let t = time_text(&d, log.t[r], &mut rng);
                (format!("{t}{sep}{}{sep}n{sep}{w}{sep}{}", num(log.a[r]), num(log.d[r])),
                    format!("b_c = \"{w}\" is not a number"))
            }
        };
        lines[r + 1] = format!("{bad_cell}{end}");
        let text: String = lines.concat();
        let e = read(&text, ReadOptions::default()).unwrap_err();
        prop_assert!(e.contains(&format!("1 bad row(s) at line(s) {}:", r + 2)), "{e}\n{text}");
        prop_assert!(e.contains(&expect), "{e}\nexpected {expect}");
    }

    /// Rows with an empty or NaN used cell: an error naming `--missing split` by default;
    /// with `MissingCells::Split`, left out, listed, and the run split after each, exactly
    /// the table built here from the generated values. Empty or NaN cells of the unused
    /// column never matter.
    #[test]
    fn missing_cells_split_the_run(seed in any::<u64>(), rows in 8usize..60, holes in proptest::collection::vec((any::<u64>(), 0u8..4), 1..6)) {
        let log = random_log(seed, rows, true);
        let mut cells: Vec<Vec<String>> = (0..rows).map(|k| vec![
            format!("{}", log.t[k]), format!("{}", log.a[k]), "NaN".into(), format!("{}", log.b[k]), format!("{}", log.d[k]),
        ]).collect();
        // A hole in an input (a_c, b_c) is a sensor dropout; one in the target (d_um) is a
        // row without a measurement, kept with NaN there.
        let mut left_out: Vec<usize> = Vec::new();
        let mut unmeasured: Vec<usize> = Vec::new();
        for (p, how) in &holes {
            let k = (p % rows as u64) as usize;
            let col = [1, 3, 4][(p >> 32) as usize % 3];
            cells[k][col] = if how % 2 == 0 { String::new() } else { "NaN".into() };
            if how >= &2 {
                cells[k][2] = String::new();
            }
            let list = if col == 4 { &mut unmeasured } else { &mut left_out };
            if !list.contains(&k) {
                list.push(k);
            }
        }
        left_out.sort_unstable();
        unmeasured.retain(|k| !left_out.contains(k));
        let text = format!("time_s,a_c,note,b_c,d_um\n{}",
            cells.iter().map(|c| c.join(",") + "\n").collect::<String>());
        let kept: Vec<usize> = (0..rows).filter(|k| !left_out.contains(k)).collect();
        let any_measured = kept.iter().any(|k| !unmeasured.contains(k));
        let plain = read(&text, ReadOptions::default());
        if left_out.is_empty() {
            // Only targets missing: every row is read, nothing split.
            prop_assert_eq!(plain.is_ok(), any_measured, "{:?}", plain.as_ref().err());
        } else {
            let e = plain.unwrap_err();
            prop_assert!(e.contains("--missing split"), "{e}");
            let sep = if left_out.len() > 1 { "," } else { ":" };
            prop_assert!(e.contains(&format!("at line(s) {}{sep}", left_out[0] + 2)), "{e}");
        }
        let got = read(&text, ReadOptions { missing: MissingCells::Split, ..ReadOptions::default() });
        if kept.len() < 3 || !any_measured {
            prop_assert!(got.is_err());
            return Ok(());
        }
        let t = got.unwrap();
        prop_assert_eq!(&t.time_s, &kept.iter().map(|&k| log.t[k]).collect::<Vec<_>>());
        prop_assert_eq!(&t.inputs[0], &kept.iter().map(|&k| log.a[k]).collect::<Vec<_>>());
        prop_assert_eq!(&t.inputs[1], &kept.iter().map(|&k| log.b[k]).collect::<Vec<_>>());
        let want_d: Vec<Option<f64>> = kept.iter().map(|&k| (!unmeasured.contains(&k)).then_some(log.d[k])).collect();
        let got_d: Vec<Option<f64>> = t.targets[0].iter().map(|&v| v.is_finite().then_some(v)).collect();
        prop_assert_eq!(&got_d, &want_d);
        prop_assert_eq!(&t.lines, &kept.iter().map(|&k| k as u64 + 2).collect::<Vec<_>>());
        // A segment starts at the first kept row and at every kept row after a hole.
        let segments: Vec<usize> = (0..kept.len()).filter(|&j| j == 0 || kept[j - 1] + 1 != kept[j]).collect();
        prop_assert_eq!(&t.segments, &segments);
        let listed: Vec<u64> = t.issues.iter().filter_map(|i| match i {
            DataIssue::Missing { line, .. } => Some(*line),
            _ => None,
        }).collect();
        prop_assert_eq!(&listed, &left_out.iter().map(|&k| k as u64 + 2).collect::<Vec<_>>());
        prop_assert_eq!(t.rows_left_out().0, left_out.len());
    }
}

proptest! {
    /// `MissingCells::Hold` (channels logged at different rates, merged with empty cells):
    /// each empty or NaN input cell takes the column's last value written before it, the
    /// table built here by a forward fill of the generated values; rows before a column's
    /// first value are left out and listed (`--missing hold`), each held column is counted in
    /// one note at its first held cell, and nothing is split.
    #[test]
    fn missing_hold_is_a_forward_fill(seed in any::<u64>(), rows in 4usize..60, density in 0.05f64..0.7) {
        let log = random_log(seed, rows, false);
        let mut r = Rng::new(seed ^ 0x5eed);
        // Which input cells are written: each blank with probability `density`.
        let written: Vec<[bool; 2]> = (0..rows)
            .map(|_| [r.real(0.0, 1.0) >= density, r.real(0.0, 1.0) >= density])
            .collect();
        let mut text = String::from("time_s,a_c,note,b_c,d_um\n");
        for (k, w) in written.iter().enumerate() {
            let cell = |w: bool, v: f64, nan: bool| match (w, nan) {
                (true, _) => format!("{v}"),
                (false, true) => "NaN".to_string(),
                (false, false) => String::new(),
            };
            text += &format!(
                "{},{},,{},{}\n",
                log.t[k],
                cell(w[0], log.a[k], k % 3 == 0),
                cell(w[1], log.b[k], k % 3 == 1),
                log.d[k]
            );
        }
        // Independent reference: forward fill; a row is kept once both inputs have a value.
        let mut last = [None::<f64>; 2];
        let (mut kept, mut left, mut held) = (Vec::new(), Vec::new(), [(0usize, None::<u64>); 2]);
        for (k, w) in written.iter().enumerate() {
            let vals = [log.a[k], log.b[k]];
            for c in 0..2 {
                if w[c] {
                    last[c] = Some(vals[c]);
                }
            }
            if last.iter().all(Option::is_some) {
                kept.push((k, last[0].unwrap(), last[1].unwrap()));
                for c in 0..2 {
                    if !w[c] {
                        held[c].0 += 1;
                        held[c].1.get_or_insert(k as u64 + 2);
                    }
                }
            } else {
                left.push(k as u64 + 2);
            }
        }
        let got = read(&text, ReadOptions { missing: MissingCells::Hold, ..ReadOptions::default() });
        if kept.len() < 3 {
            prop_assert!(got.is_err());
            return Ok(());
        }
        let t = got.unwrap();
        prop_assert_eq!(&t.time_s, &kept.iter().map(|&(k, ..)| log.t[k]).collect::<Vec<_>>());
        prop_assert_eq!(&t.inputs[0], &kept.iter().map(|&(_, a, _)| a).collect::<Vec<_>>());
        prop_assert_eq!(&t.inputs[1], &kept.iter().map(|&(.., b)| b).collect::<Vec<_>>());
        prop_assert_eq!(&t.targets[0], &kept.iter().map(|&(k, ..)| log.d[k]).collect::<Vec<_>>());
        prop_assert_eq!(t.segments.len(), 1 + t.issues.iter().filter(|i| matches!(i, DataIssue::Gap { .. })).count());
        let listed: Vec<u64> = t.issues.iter().filter_map(|i| match i {
            DataIssue::Missing { line, hold: true, .. } => Some(*line),
            _ => None,
        }).collect();
        prop_assert_eq!(&listed, &left);
        prop_assert_eq!(t.rows_left_out().0, left.len());
        for (c, name) in ["a_c", "b_c"].iter().enumerate() {
            let note = t.issues.iter().find_map(|i| match i {
                DataIssue::Held { line, column, cells } if column == name => Some((*cells, Some(*line))),
                _ => None,
            });
            match held[c] {
                (0, _) => prop_assert!(note.is_none()),
                (n, first) => prop_assert_eq!(note, Some((n, first))),
            }
        }
        // The default still refuses the log naming the option, unless nothing is blank.
        if written.iter().any(|w| !w[0] || !w[1]) {
            let e = read(&text, ReadOptions::default()).unwrap_err();
            prop_assert!(e.contains("--missing split"), "{e}");
        }
    }
}

/// `--missing hold` never carries a value across runs: a run's first rows without a value
/// of an input are left out, even when the run before ended with one.
#[test]
fn missing_hold_restarts_at_each_run() {
    let text = "run,time_s,a_c,b_c,d_um\nr1,0,1,2,3\nr1,10,,2.5,4\nr1,20,1.5,,5\nr2,0,,3,6\nr2,10,2,,7\nr2,20,2.5,3.5,8\nr2,30,,4,9\n";
    let s = Selection {
        run: Some("run".into()),
        ..sel()
    };
    let opts = ReadOptions {
        missing: MissingCells::Hold,
        ..ReadOptions::default()
    };
    let t = read_csv(text, "log.csv", &s, opts).unwrap();
    assert_eq!(t.run_names, ["r1", "r2"]);
    assert_eq!(t.time_s, [0.0, 10.0, 20.0, 10.0, 20.0, 30.0]);
    assert_eq!(t.inputs[0], [1.0, 1.0, 1.5, 2.0, 2.5, 2.5]);
    assert_eq!(t.inputs[1], [2.0, 2.5, 2.5, 3.0, 3.5, 4.0]);
    let issues: Vec<String> = t.issues.iter().map(|i| i.to_string()).collect();
    assert!(
        issues[0].starts_with("line 3: a_c: 2 empty or NaN cell(s)"),
        "{issues:?}"
    );
    assert!(
        issues.iter().any(|i| i
            == "line 5: left out (a_c is empty, with no earlier value in its run to hold; --missing hold)"),
        "{issues:?}"
    );
    assert_eq!(t.rows_left_out(), (1, vec![5]));
}

/// Local wall time without an offset going back (the DST fall-back hour, or a repeated row)
/// is a bad row naming its line, as any time that does not increase; with offsets the same
/// wall times are distinct instants and read fine.
#[test]
fn dst_fall_back_is_refused_without_offsets_and_read_with_them() {
    let rows = [
        ("2024-10-27 02:30:00", "+02:00"),
        ("2024-10-27 02:45:00", "+02:00"),
        ("2024-10-27 02:00:00", "+01:00"),
        ("2024-10-27 02:15:00", "+01:00"),
    ];
    let body = |with: bool| {
        rows.iter()
            .enumerate()
            .map(|(k, (w, o))| {
                format!(
                    "{w}{},{},{}\n",
                    if with { o } else { &"" },
                    20.0 + k as f64,
                    k
                )
            })
            .collect::<String>()
    };
    let s = Selection {
        targets: vec!["d_um".into()],
        ..sel()
    };
    let head = "time_s,a_c,d_um\n";
    let e = read_csv(
        &format!("{head}{}", body(false)),
        "log.csv",
        &s,
        ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("line(s) 4") && e.contains("does not increase"),
        "{e}"
    );
    let t = read_csv(
        &format!("{head}{}", body(true)),
        "log.csv",
        &s,
        ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(t.time_s, vec![0.0, 900.0, 1800.0, 2700.0]);
    // Mixing stamps with and without an offset is refused.
    let mixed = format!(
        "{head}2024-10-27T00:00:00Z,1,1\n2024-10-27T00:01:00,1,1\n2024-10-27T00:02:00Z,1,1\n2024-10-27T00:03:00Z,1,1\n"
    );
    let e = read_csv(&mixed, "log.csv", &s, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("line(s) 3") && e.contains("UTC offset"), "{e}");
}

/// Runs restart their clock: with a run column, each run's time stamps count from its own
/// first row.
#[test]
fn time_stamps_restart_per_run() {
    let text = "run;time_s;a_c;d_um\n1;01.03.2024 08:00:00;20,5;1\n1;01.03.2024 08:01:00;21;2\n2;02.03.2024 09:00:00;20;1\n2;02.03.2024 09:00:30;21,25;2\n";
    let s = Selection {
        run: Some("run".into()),
        ..sel()
    };
    let t = read_csv(text, "log.csv", &s, ReadOptions::default()).unwrap();
    assert_eq!(t.time_s, vec![0.0, 60.0, 0.0, 30.0]);
    assert_eq!(t.inputs[0], vec![20.5, 21.0, 20.0, 21.25]);
    assert_eq!(t.segments, vec![0, 2]);
}

/// Excel's `sep=;` first line names the delimiter; line numbers stay the file's (header on
/// line 2, so the first data row is line 3).
#[test]
fn excel_sep_line_names_the_delimiter() {
    let body = "time_s;a_c;d_um\r\n0;20,5;1\r\n60;21;2\r\n120;x;3\r\n180;22;4\r\n";
    let s = Selection {
        targets: vec!["d_um".into()],
        ..sel()
    };
    let text = format!("\u{feff}sep=;\r\n{body}");
    let e = read_csv(&text, "log.csv", &s, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("at line(s) 5: a_c = \"x\""), "{e}");
    let t = read_csv(
        &text,
        "log.csv",
        &s,
        ReadOptions {
            skip_bad_rows: true,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(t.time_s, vec![0.0, 60.0, 180.0]);
    assert_eq!(t.inputs[0], vec![20.5, 21.0, 22.0]);
    assert_eq!(t.lines, vec![3, 4, 6]);
}

/// A date column and a time-of-day column (`--time-column Datum+Uhrzeit`, as Siemens and
/// Heidenhain exports write them) are one time stamp; neither is taken as an input.
#[test]
fn date_and_time_columns_make_one_stamp() {
    let text = "Datum;Uhrzeit;a_c;d_um\n29.02.2024;23:59:00;20,5;1\n01.03.2024;00:00:30;21;2\n01.03.2024;00:01:30;22;3\n01.03.2024;00:01:30;23;4\n";
    let s = Selection {
        time: "Datum+Uhrzeit".into(),
        inputs: vec!["*".into()],
        targets: vec!["d_um".into()],
        run: None,
    };
    let e = read_csv(text, "log.csv", &s, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("at line(s) 5: Datum+Uhrzeit = \"01.03.2024 00:01:30\" (150 s after the run's first stamp) does not increase (previous 150 s)"),
        "{e}"
    );
    let t = read_csv(
        text,
        "log.csv",
        &s,
        ReadOptions {
            skip_bad_rows: true,
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(t.input_names, vec!["a_c"]);
    assert_eq!(t.time_s, vec![0.0, 90.0, 150.0]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Slash-date stamps (day first 24 h; month first 12 h with AM/PM) in any dialect read
    /// as the plain log with the order named (`--date-order`); without it, a log whose
    /// dates all tell day from month by themselves reads the same, and any other is refused
    /// naming `--date-order`; with the wrong order the log is refused or reads other times.
    #[test]
    fn slash_dates_read_as_the_plain_log_with_their_order(
        d in dialect_strategy(),
        seed in any::<u64>(),
        rows in 5usize..60,
        month_first in any::<bool>(),
    ) {
        use gearcomp_identify::dialect::{is_ambiguous_slash_date, DateOrder};
        let d = Dialect {
            time: if month_first { TimeForm::SlashMonthFirst12h } else { TimeForm::SlashDayFirst },
            ..d
        };
        let (order, wrong) = if month_first {
            (DateOrder::MonthFirst, DateOrder::DayFirst)
        } else {
            (DateOrder::DayFirst, DateOrder::MonthFirst)
        };
        let log = random_log(seed, rows, false);
        let want = read(&plain(&log), ReadOptions::default()).unwrap();
        let text = written(&log, &d, seed);
        let with = |o: Option<DateOrder>| read(&text, ReadOptions { date_order: o, ..ReadOptions::default() });
        let got = with(Some(order));
        prop_assert_eq!(got.as_ref(), Ok(&want), "{:?}\n{}", d, text);
        let ambiguous = text.lines().skip(1).any(|l| {
            let cell = l.trim_start_matches('\u{feff}').split(d.delim).next().unwrap_or("");
            is_ambiguous_slash_date(cell.trim_matches('"'))
        });
        // A date that reads only one way (day or month over 12) names the order of the whole
        // file; without one, an ambiguous date is refused.
        let decides = text.lines().skip(1).any(|l| {
            let cell = l.trim_start_matches('\u{feff}').split(d.delim).next().unwrap_or("");
            let mut f = cell.trim_matches('"').split('/').map(|x| x.trim().parse::<u32>());
            match (f.next(), f.next()) {
                (Some(Ok(a)), Some(Ok(b))) => (a > 12 && b <= 12) || (b > 12 && a <= 12),
                _ => false,
            }
        });
        match with(None) {
            Ok(mut t) => {
                let notes = t.issues.len();
                t.issues.retain(|i| !matches!(i, gearcomp_identify::data::DataIssue::Note { .. }));
                prop_assert_eq!(notes - t.issues.len(), usize::from(decides));
                prop_assert!((decides || !ambiguous) && t == want, "{}", text)
            }
            Err(e) => prop_assert!(ambiguous && !decides && e.contains("--date-order"), "{e}"),
        }
        if let Ok(t) = with(Some(wrong)) {
            // Read the wrong way round, the times (from the first stamp) differ when the log
            // spans two dates of which one has day ≠ month.
            let dates: Vec<&str> = text
                .lines()
                .skip(1)
                .filter_map(|l| l.split(d.delim).next())
                .map(|c| c.trim_start_matches('\u{feff}').trim_matches('"').get(..10).unwrap_or(""))
                .collect();
            let spans = dates.iter().any(|x| *x != dates[0]);
            let swaps = dates.iter().any(|x| x.get(..2) != x.get(3..5));
            prop_assert!(t.time_s != want.time_s || !(spans && swaps), "{}", text);
        }
    }
}

/// A log that starts on the 1st–12th of a month has ambiguous slash dates on its first rows
/// only: its first date with a day (or month) over 12 names the order of every row, with a
/// note on that line. The times are those of the same log written in ISO 8601; Japanese
/// loggers' year-first slash dates read as ISO too. Dates that read only day first beside
/// dates that read only month first are refused naming both lines.
#[test]
fn a_file_names_its_date_order_by_its_later_dates() {
    let s = Selection {
        time: "stamp".into(),
        inputs: vec!["a_c".into()],
        targets: vec!["d_um".into()],
        run: None,
    };
    // Every 7 h from 2026-03-10 06:00 to 2026-03-15 (day 13 first at line 12).
    let stamps: Vec<(u32, u32, u32)> = (0..20u32)
        .map(|k| {
            let h = 6 + 7 * k;
            (3, 10 + h / 24, h % 24)
        })
        .collect();
    let log = |f: &dyn Fn(u32, u32, u32) -> String| -> String {
        let mut text = "stamp,a_c,d_um\n".to_string();
        for (k, &(m, d, h)) in stamps.iter().enumerate() {
            text += &format!("{},{},{}\n", f(m, d, h), 20 + k, k % 3);
        }
        text
    };
    let iso = log(&|m, d, h| format!("2026-{m:02}-{d:02} {h:02}:00:00"));
    let want = read_csv(&iso, "log.csv", &s, ReadOptions::default()).unwrap();
    assert_eq!(want.time_s[1], 7.0 * 3600.0);
    let dmy = log(&|m, d, h| format!("{d:02}/{m:02}/2026 {h:02}:00"));
    let mdy = log(&|m, d, h| {
        let (h12, p) = match h {
            0 => (12, "AM"),
            1..=11 => (h, "AM"),
            12 => (12, "PM"),
            _ => (h - 12, "PM"),
        };
        format!("{m}/{d}/2026 {h12}:00:00 {p}")
    });
    let ymd = log(&|m, d, h| format!("2026/{m:02}/{d:02} {h:02}:00:00"));
    for (text, note) in [
        (
            &dmy,
            Some("line 12: stamp = \"13/03/2026 04:00\" reads only day first"),
        ),
        (
            &mdy,
            Some("line 12: stamp = \"3/13/2026 4:00:00 AM\" reads only month first"),
        ),
        (&ymd, None),
    ] {
        let mut t = read_csv(text, "log.csv", &s, ReadOptions::default()).unwrap();
        assert_eq!(t.time_s, want.time_s, "{text}");
        let notes: Vec<String> = t.issues.iter().map(|i| i.to_string()).collect();
        match note {
            Some(n) => assert!(notes.len() == 1 && notes[0].starts_with(n), "{notes:?}"),
            None => assert!(notes.is_empty(), "{notes:?}"),
        }
        t.issues.clear();
        assert_eq!(t, want);
    }
    // Only the first rows (10–12 March): ambiguous, refused naming --date-order.
    let short: String = dmy.lines().take(8).map(|l| format!("{l}\n")).collect();
    let e = read_csv(&short, "log.csv", &s, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("--date-order dmy"), "{e}");
    // One month-first date among day-first ones.
    let mixed = dmy.replacen("14/03/2026 08:00", "03/14/2026 08:00", 1);
    assert_ne!(mixed, dmy);
    let e = read_csv(&mixed, "log.csv", &s, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("\"13/03/2026 04:00\" at line 12")
            && e.contains("\"03/14/2026 08:00\" at line 16"),
        "{e}"
    );
    // The order named by the user is taken as given, without a note.
    let t = read_csv(
        &dmy,
        "log.csv",
        &s,
        ReadOptions {
            date_order: Some(gearcomp_identify::dialect::DateOrder::DayFirst),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(t, want);
}

/// A time of day alone that passes midnight falls from 23:59 to 00:00: refused with the way
/// on (a date with the time, or runs), never read as a jump back.
#[test]
fn a_clock_time_past_midnight_is_refused_with_the_way_on() {
    let mut text = "time_s,a_c,d_um\n".to_string();
    for k in 0..10u32 {
        let m = 23 * 60 + 55 + k;
        text += &format!("{:02}:{:02}:00,{},{}\n", (m / 60) % 24, m % 60, 20 + k, k);
    }
    let e = read(&text, ReadOptions::default()).unwrap_err();
    assert!(
        e.contains("5 bad row(s) at line(s) 7, 8, 9, 10, 11")
            && e.contains("the clock time falls at line 7: a time of day past midnight")
            && e.contains("--time-column DATE+TIME"),
        "{e}"
    );
    let t = read(
        &text[..text.find("00:00:00").unwrap()],
        ReadOptions::default(),
    )
    .unwrap();
    assert_eq!(t.time_s, vec![0.0, 60.0, 120.0, 180.0, 240.0]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// Data lines that end with one or more delimiters (the header without) read as the
    /// plain log; an extra field that holds something is still a bad row naming its line.
    #[test]
    fn trailing_delimiters_on_data_lines_are_no_fields(
        seed in any::<u64>(),
        rows in 5usize..60,
        delim in prop_oneof![Just(','), Just(';'), Just('\t')],
        pick in any::<u64>(),
    ) {
        let log = random_log(seed, rows, false);
        let want = read(&plain(&log), ReadOptions::default()).unwrap();
        let mut r = Rng::new(seed ^ 0xA5A5);
        let mut text = plain(&log).replace(',', &delim.to_string());
        let lines: Vec<String> = text.lines().map(String::from).collect();
        text = lines[0].clone() + "\n";
        for l in &lines[1..] {
            let extra = 1 + (r.next() % 3) as usize;
            text += &format!("{l}{}\n", delim.to_string().repeat(extra));
        }
        let opts = ReadOptions { delimiter: Some(delim as u8), ..ReadOptions::default() };
        prop_assert_eq!(read(&text, opts), Ok(want));
        let k = 1 + (pick % (rows as u64 - 1)) as usize;
        let mut bad: Vec<String> = text.lines().map(String::from).collect();
        bad[k] = format!("{}x", bad[k]);
        let e = read(&(bad.join("\n") + "\n"), opts).unwrap_err();
        prop_assert!(e.contains(&format!("line(s) {}:", k + 1)) && e.contains("fields, header has 5"), "{}", e);
    }
}

/// A date column and a time-of-day column (Hioki, Siemens exports: `"Date","Time",…`) with
/// no time column named are read together, as `--time-column Date+Time` reads them: across
/// midnight, the times of the same log in ISO 8601. A `Time` column of seconds beside a
/// `Date` column is the time alone.
#[test]
fn a_date_and_a_clock_column_are_one_time_without_options() {
    let s = Selection {
        time: "time_s".into(),
        inputs: vec!["a_c".into()],
        targets: vec!["z_um".into()],
        run: None,
    };
    let (mut iso, mut split, mut secs) = (
        "time_s,a_c,z_um\n".to_string(),
        "\"Date\",\"Time\",\"a_c\",\"z_um\"\n".to_string(),
        "Date,Time,a_c,z_um\n".to_string(),
    );
    for k in 0..40u32 {
        let m = 23 * 60 + 40 + 5 * k;
        let (day, h, min) = (9 + m / 1440, (m / 60) % 24, m % 60);
        let v = format!("{},{}", 20 + k % 5, k % 3);
        iso += &format!("{},{v}\n", 300 * k);
        split += &format!("\"2026/03/{day:02}\",\"{h:02}:{min:02}:00\",{v}\n");
        secs += &format!("2026-03-{day:02},{},{v}\n", 300 * k);
    }
    let want = read_csv(&iso, "log.csv", &s, ReadOptions::default()).unwrap();
    let got = read_csv(&split, "log.csv", &s, ReadOptions::default()).unwrap();
    assert_eq!(got.time_s, want.time_s);
    assert_eq!((&got.inputs, &got.targets), (&want.inputs, &want.targets));
    let notes: Vec<String> = got.issues.iter().map(ToString::to_string).collect();
    assert!(
        notes
            .iter()
            .any(|n| n.contains("time column: \"Date+Time\"")),
        "{notes:?}"
    );
    let alone = read_csv(&secs, "log.csv", &s, ReadOptions::default()).unwrap();
    assert_eq!(alone.time_s, want.time_s);
}
