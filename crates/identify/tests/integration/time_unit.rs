//! A log whose time column counts milliseconds, minutes or hours: every time constant, delay
//! and split of the fit is in seconds, so the reader converts the column (named by the units
//! row, by the column name or by `--time-unit`) and the law of the log comes back with its
//! time constant in seconds. Read as seconds, the same log gives a wrong model. Also the
//! other ways a real log's time axis and columns go wrong, each refused saying what it
//! suggests: columns named otherwise than FL_THERMAL, a time that falls (a log newest
//! first, a time that restarts), a name used twice, the header repeated.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::{lag_rk4, uniform};
use gearcomp_identify::data::{read_csv, DataIssue, MissingCells, ReadOptions, Selection};
use gearcomp_identify::select::Family;
use gearcomp_identify::time_unit::{TimeUnit, TimeUnitChoice};
use gearcomp_identify::{identify, predict, IdentifyOptions, Split};
use proptest::prelude::*;

const UNITS: [(TimeUnit, &str, f64); 4] = [
    (TimeUnit::S, "s", 1.0),
    (TimeUnit::Ms, "ms", 1e-3),
    (TimeUnit::Min, "min", 60.0),
    (TimeUnit::H, "h", 3600.0),
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// y = c₀ + a·x₁ + b·lag(x₂, τ) on irregular steps of 20–120 s, the time column written
    /// in s, ms, min or h (to full precision) and its unit named by the units row, the
    /// column name or the option: the lead-lag family with τ in seconds recovers the law at
    /// every row to 1e-6 µm (the RK4 lag above is the reference), the times read back are
    /// the seconds to 1e-12 relative, and one note names the unit and where it came from.
    /// The library default (no time unit) reads the numbers as seconds: for min and h the
    /// fit then misses the law by more than 1000×.
    #[test]
    fn a_time_column_in_another_unit_reads_as_seconds(
        seed in any::<u64>(),
        unit in 0usize..4,
        how in 0usize..3,
        tau_s in prop::sample::select(vec![600.0, 1200.0, 1800.0]),
    ) {
        let (unit, symbol, s_per) = UNITS[unit];
        let mut uni = uniform(seed);
        let n = 400;
        let mut t_s = vec![0.0];
        for _ in 1..n {
            let last = *t_s.last().unwrap();
            t_s.push(last + 20.0 + (100.0 * uni()).round());
        }
        let x: [Vec<f64>; 2] = std::array::from_fn(|k| {
            let (rise, tr, amp, w) = (
                3.0 + 8.0 * uni(),
                1800.0 + 6000.0 * uni(),
                0.5 + 2.0 * uni(),
                2.0 * std::f64::consts::PI / (3600.0 + 7200.0 * uni()),
            );
            t_s.iter()
                .map(|&t| 20.0 + k as f64 + rise * (1.0 - (-t / tr).exp()) + amp * (w * t).sin())
                .collect()
        });
        let (c0, a, b) = (-40.0 + 80.0 * uni(), -3.0 + 6.0 * uni(), 2.0 + 6.0 * uni());
        let lag = lag_rk4(&t_s, &x[1], tau_s);
        let y: Vec<f64> = (0..n).map(|i| c0 + a * x[0][i] + b * lag[i]).collect();

        // The log, its time column in `unit`.
        let (name, units_row, opt) = match how {
            0 => ("time", Some(symbol), TimeUnitChoice::Auto),
            1 => (["time_s", "time_ms", "time_min", "Zeit [h]"][UNITS.iter().position(|u| u.0 == unit).unwrap()], None, TimeUnitChoice::Auto),
            _ => ("time", None, TimeUnitChoice::Given(unit)),
        };
        let mut text = format!("{name},a_c,b_c,y_um\n");
        if let Some(u) = units_row {
            text += &format!("{u},°C,°C,µm\n");
        }
        for i in 0..n {
            text += &format!("{:e},{},{},{}\n", t_s[i] / s_per, x[0][i], x[1][i], y[i]);
        }
        let sel = Selection { time: name.into(), targets: vec!["y_um".into()], ..Selection::default() };
        let read = |time_unit| read_csv(&text, "log.csv", &sel, ReadOptions { time_unit, ..ReadOptions::default() }).unwrap();
        let t = read(Some(opt));
        for (g, w) in t.time_s.iter().zip(&t_s) {
            prop_assert!((g - w).abs() <= 1e-12 * w.abs().max(1.0), "{g} vs {w}");
        }
        let notes: Vec<String> = t.issues.iter().filter(|i| matches!(i, DataIssue::TimeUnit { .. })).map(|i| i.to_string()).collect();
        if unit == TimeUnit::S {
            prop_assert!(notes.is_empty(), "{notes:?}");
        } else {
            prop_assert_eq!(notes.len(), 1);
            let from = ["the units row", "the column name", "--time-unit"][how.min(2)];
            prop_assert!(notes[0].contains(&format!("in {symbol} ({from})")) && notes[0].contains("read as seconds"), "{}", notes[0]);
        }
        let o = IdentifyOptions { split: Split::None, families: vec![Family::LeadLag], taus_s: vec![tau_s], ..IdentifyOptions::default() };
        let max_err = |tab: &gearcomp_identify::data::Table| {
            let id = identify(tab, &o).unwrap();
            let p = predict(tab, &id.targets[0].model).unwrap();
            p.iter().zip(&y).map(|(p, y)| (p - y).abs()).fold(0.0, f64::max)
        };
        let err = max_err(&t);
        prop_assert!(err < 1e-6, "max error {err:e} µm");
        if matches!(unit, TimeUnit::Min | TimeUnit::H) {
            let raw = read(None);
            let err_raw = max_err(&raw);
            prop_assert!(err_raw > 1e3 * err.max(1e-9), "read as seconds {err_raw:e}, converted {err:e}");
        }
    }
}

/// A units-row cell of a numeric time column that names no time unit is refused, naming the
/// column, the cell and --time-unit; naming the unit reads it. Time stamps have no unit:
/// a units-row cell under them is no error, --time-unit with them is refused.
#[test]
fn a_time_unit_that_is_none_is_refused() {
    let sel = |time: &str| Selection {
        time: time.into(),
        targets: vec!["z_um".into()],
        ..Selection::default()
    };
    let auto = ReadOptions {
        time_unit: Some(TimeUnitChoice::Auto),
        ..ReadOptions::default()
    };
    let text = "t,a_c,z_um\nV,°C,µm\n0,20,1\n1,21,2\n2,22,3\n";
    let e = read_csv(text, "log.csv", &sel("t"), auto)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unit of the time column t in the units row = «V»") && e.contains("--time-unit"),
        "{e}"
    );
    let given = ReadOptions {
        time_unit: Some(TimeUnitChoice::Given(TimeUnit::Min)),
        ..ReadOptions::default()
    };
    let t = read_csv(text, "log.csv", &sel("t"), given).unwrap();
    assert_eq!(t.time_s, [0.0, 60.0, 120.0]);
    // A sample interval is in seconds: --time-unit has nothing to convert.
    let no_time = "a_c,z_um\n20,1\n21,2\n22,3\n";
    let interval = ReadOptions {
        sample_interval_s: Some(60.0),
        ..given
    };
    let e = read_csv(no_time, "log.csv", &sel("time_s"), interval)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--time-unit") && e.contains("--sample-interval-s"),
        "{e}"
    );
    let t = read_csv(
        no_time,
        "log.csv",
        &sel("time_s"),
        ReadOptions {
            time_unit: Some(TimeUnitChoice::Auto),
            ..interval
        },
    )
    .unwrap();
    assert_eq!(t.time_s, [0.0, 60.0, 120.0]);
    let stamps = "stamp,a_c,z_um\nhh:mm:ss,°C,µm\n2024-03-01 08:00:00,20,1\n2024-03-01 08:01:00,21,2\n2024-03-01 08:02:00,22,3\n";
    let t = read_csv(stamps, "log.csv", &sel("stamp"), auto).unwrap();
    assert_eq!(t.time_s, [0.0, 60.0, 120.0]);
    assert!(!t
        .issues
        .iter()
        .any(|i| matches!(i, DataIssue::TimeUnit { .. })));
    let e = read_csv(stamps, "log.csv", &sel("stamp"), given)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("--time-unit") && e.contains("time stamps"),
        "{e}"
    );
    // A gap is found on the converted times and printed in seconds.
    let gap = "time_min,a_c,z_um\n0,20,1\n1,21,2\n2,22,3\n3,21,2\n30,20,1\n31,21,2\n";
    let t = read_csv(gap, "log.csv", &sel("time_min"), auto).unwrap();
    assert_eq!(t.segments, [0, 4]);
    let g = t
        .issues
        .iter()
        .find(|i| matches!(i, DataIssue::Gap { .. }))
        .unwrap()
        .to_string();
    assert!(g.contains("time gap of 1620 s (180 s → 1800 s)"), "{g}");
}

/// A log named otherwise than FL_THERMAL (`time`, `t1`, `disp`): each missing default
/// column is refused naming the option that names it; without `time_s`, two columns that
/// read as a time axis are refused with the first offered for `--time-column` (one alone is
/// taken: `a_lone_time_axis_is_taken_with_a_note`).
#[test]
fn columns_named_otherwise_are_refused_naming_the_option() {
    let text = "Zeit [min],program,t1,t2,disp\n0,P1,20,21,1\n1,P1,21,22,2\n2,P2,22,23,3\n";
    let read = |sel: &Selection| {
        read_csv(text, "log.csv", sel, ReadOptions::default())
            .unwrap_err()
            .to_string()
    };
    let two = "Zeit [min],elapsed,t1,t2,disp\n0,0,20,21,1\n1,60,21,22,2\n2,120,22,23,3\n";
    let e = read_csv(
        two,
        "log.csv",
        &Selection {
            targets: vec!["disp".into()],
            ..Selection::default()
        },
        ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("--time-column = time_s")
            && e.contains("\"Zeit [min]\" looks like one: --time-column \"Zeit [min]\""),
        "{e}"
    );
    // One time axis alone is taken: the first error is then the inputs'.
    let e = read(&Selection {
        targets: vec!["disp".into()],
        ..Selection::default()
    });
    assert!(e.contains("\"*_c\" not found"), "{e}");
    let e = read(&Selection {
        time: "Zeit [min]".into(),
        targets: vec!["disp".into()],
        ..Selection::default()
    });
    assert!(
        e.contains("\"*_c\" not found") && e.contains("--inputs"),
        "{e}"
    );
    let e = read(&Selection {
        time: "Zeit [min]".into(),
        inputs: vec!["t?".into()],
        targets: vec!["*_um".into()],
        ..Selection::default()
    });
    assert!(
        e.contains("\"*_um\" not found") && e.contains("--target"),
        "{e}"
    );
    let t = read_csv(
        text,
        "log.csv",
        &Selection {
            time: "Zeit [min]".into(),
            inputs: vec!["t?".into()],
            targets: vec!["disp".into()],
            ..Selection::default()
        },
        ReadOptions {
            time_unit: Some(TimeUnitChoice::Auto),
            ..ReadOptions::default()
        },
    )
    .unwrap();
    assert_eq!(t.time_s, [0.0, 60.0, 120.0]);
    assert_eq!(t.input_names, ["t1", "t2"]);
}

/// A time that falls is a bad row, as before; the refusal now says what the falls suggest:
/// a log written newest first (the time falls on nine rows in ten or more), or a time that
/// restarts (several runs in one file without a run column, named by its line), a local
/// clock set back an hour, or stamps that repeat (written to the second, sampled faster);
/// one row out of order suggests none of them.
#[test]
fn a_falling_time_is_explained() {
    let rows: Vec<String> = (0..60)
        .map(|i| format!("{},{},{}", i * 60, 20.0 + (i as f64 / 7.0).sin(), i % 5))
        .collect();
    let sel = Selection {
        targets: vec!["z_um".into()],
        ..Selection::default()
    };
    let read = |body: Vec<String>| {
        let text = format!("time_s,a_c,z_um\n{}\n", body.join("\n"));
        read_csv(&text, "log.csv", &sel, ReadOptions::default())
            .unwrap_err()
            .to_string()
    };
    let e = read(rows.iter().rev().cloned().collect());
    assert!(
        e.contains("59 bad row(s)")
            && e.contains("the time falls on 59 of 60 rows: the log seems to run newest first"),
        "{e}"
    );
    // Three runs of 20 rows, each restarting at 0: line 22 is the first of the second.
    let restarts: Vec<String> = (0..3).flat_map(|_| rows[..20].to_vec()).collect();
    let e = read(restarts);
    assert!(
        e.contains("the time restarts at line 22 (1140 → 0)") && e.contains("--run-column"),
        "{e}"
    );
    // A local clock set back an hour (the autumn's daylight-saving change), every 10 min.
    let stamps: Vec<String> = (0..30)
        .map(|i| {
            let m = 60 + 10 * i - if i >= 12 { 60 } else { 0 };
            format!(
                "2024-10-27 {:02}:{:02}:00,{},{}",
                m / 60,
                m % 60,
                20 + i % 3,
                i % 4
            )
        })
        .collect();
    let text = format!("stamp,a_c,z_um\n{}\n", stamps.join("\n"));
    let dst = Selection {
        time: "stamp".into(),
        targets: vec!["z_um".into()],
        ..Selection::default()
    };
    let e = read_csv(&text, "log.csv", &dst, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("local time stamps fall by about an hour at line 14")
            && e.contains("daylight-saving"),
        "{e}"
    );
    // Stamps to the second, sampled every 0.5 s: every second row repeats its time.
    let halves: Vec<String> = (0..40)
        .map(|i| format!("2024-03-01 08:00:{:02},{},{}", i / 2, 20 + i % 3, i % 4))
        .collect();
    let text = format!("stamp,a_c,z_um\n{}\n", halves.join("\n"));
    let e = read_csv(&text, "log.csv", &dst, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("20 bad row(s)")
            && e.contains("the time repeats at line 3: time stamps written to the second")
            && e.contains("--skip-bad-rows"),
        "{e}"
    );
    let mut swapped = rows.clone();
    swapped.swap(30, 31);
    let e = read(swapped);
    assert!(
        e.contains("1 bad row(s)") && !e.contains("restarts") && !e.contains("newest first"),
        "{e}"
    );
}

/// Two used columns of one name are refused (the model names its channels by column), and
/// a line that repeats the header is a bad row saying so (several exports in one file).
#[test]
fn a_repeated_name_or_header_is_refused_saying_so() {
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    let dup = "time_s,a_c,b_c,a_c,y_um\n0,20,21,22,1\n60,21,22,23,2\n120,22,23,20,3\n";
    let e = read_csv(dup, "log.csv", &sel, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("columns of log.csv = \"a_c\" twice (columns 2 and 4)")
            && e.contains("rename one"),
        "{e}"
    );
    // An unused column may repeat a name.
    let note = "time_s,a_c,note,note,y_um\n0,20,x,y,1\n60,21,x,y,2\n120,22,x,y,3\n";
    assert!(read_csv(note, "log.csv", &sel, ReadOptions::default()).is_ok());
    let again = "time_s,a_c,y_um\n0,20,1\n60,21,2\ntime_s,a_c,y_um\n120,22,3\n180,23,4\n";
    let e = read_csv(again, "log.csv", &sel, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line(s) 4: the header again (several exports appended to one file?)"),
        "{e}"
    );
    let skip = ReadOptions {
        skip_bad_rows: true,
        ..ReadOptions::default()
    };
    let t = read_csv(again, "log.csv", &sel, skip).unwrap();
    assert_eq!(t.time_s, [0.0, 60.0, 120.0, 180.0]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Runs logged one after the other in one file, the time restarting in each: with
    /// `runs_at_restarts` the log reads as the same log with a run column (the reference:
    /// the run-column reader), under every missing-cell rule: the same times, values,
    /// segments and runs (named 1 … N), no value held across a restart. Without restarts the
    /// option changes nothing.
    #[test]
    fn restarts_read_as_runs(
        seed in any::<u64>(),
        runs in 1usize..5,
        hold in any::<bool>(),
    ) {
        let mut uni = uniform(seed);
        let mut body = Vec::new();
        let mut last_end = f64::INFINITY;
        for r in 0..runs {
            let len = 5 + (uni() * 40.0) as usize;
            // Each run starts below the last one's end (a restart).
            let mut t = (uni() * 100.0).round().min(last_end - 1.0).max(0.0);
            for _ in 0..len {
                let a = if hold && uni() < 0.2 { String::new() } else { format!("{}", 20.0 + uni()) };
                body.push((r, format!("{t},{a},{},{}", 21.0 + uni(), uni())));
                // The last time written: the next run starts below it (it was the next
                // step's time less 1 s, which let a run start after the last row).
                last_end = t;
                t += 10.0 + (uni() * 50.0).round();
            }
        }
        let plain = format!("time_s,a_c,b_c,z_um\n{}\n", body.iter().map(|b| b.1.clone()).collect::<Vec<_>>().join("\n"));
        let named = format!(
            "run,time_s,a_c,b_c,z_um\n{}\n",
            body.iter().map(|(r, l)| format!("{},{l}", r + 1)).collect::<Vec<_>>().join("\n")
        );
        let missing = if hold { MissingCells::Hold } else { MissingCells::Error };
        let sel = Selection { targets: vec!["z_um".into()], ..Selection::default() };
        let got = read_csv(&plain, "log.csv", &sel, ReadOptions { runs_at_restarts: true, missing, ..ReadOptions::default() }).unwrap();
        let want = if runs > 1 {
            let sel_run = Selection { run: Some("run".into()), ..sel.clone() };
            read_csv(&named, "log.csv", &sel_run, ReadOptions { missing, ..ReadOptions::default() }).unwrap()
        } else {
            read_csv(&plain, "log.csv", &sel, ReadOptions { missing, ..ReadOptions::default() }).unwrap()
        };
        prop_assert_eq!(&got.time_s, &want.time_s);
        prop_assert_eq!(&got.inputs, &want.inputs);
        prop_assert_eq!(&got.targets, &want.targets);
        prop_assert_eq!(&got.segments, &want.segments);
        prop_assert_eq!(&got.runs, &want.runs);
        prop_assert_eq!(&got.run_names, &want.run_names);
    }
}

/// Restart runs inside a named run and inside each of several files are named after it.
#[test]
fn restart_runs_are_named_after_their_run_or_file() {
    let text =
        "run,time_s,a_c,z_um\nA,0,20,1\nA,60,21,2\nA,0,22,3\nA,60,23,4\nB,0,20,1\nB,60,21,2\n";
    let sel = Selection {
        targets: vec!["z_um".into()],
        run: Some("run".into()),
        ..Selection::default()
    };
    let opts = ReadOptions {
        runs_at_restarts: true,
        ..ReadOptions::default()
    };
    let t = read_csv(text, "log.csv", &sel, opts).unwrap();
    assert_eq!(t.run_names, ["A", "A/2", "B"]);
    assert_eq!(t.segments, [0, 2, 4]);
    let f = "time_s,a_c,z_um\n0,20,1\n60,21,2\n0,22,3\n60,23,4\n";
    let sel = Selection {
        targets: vec!["z_um".into()],
        ..Selection::default()
    };
    let t =
        gearcomp_identify::data::read_runs(&[(f, "d1.csv"), (f, "d2.csv")], &sel, opts).unwrap();
    assert_eq!(t.run_names, ["d1", "d1/2", "d2", "d2/2"]);
}

/// Without a `time_s` column, the one column that reads as a time axis is the time, with a
/// note, in the unit its name or units row gives: every table equals the table of the same
/// log with the time written in seconds under `time_s` (the reference). A name given
/// otherwise than the default, and two time-like columns, are refused.
#[test]
fn a_lone_time_axis_is_taken_with_a_note() {
    let mut uni = uniform(7);
    let n = 40;
    let t_s: Vec<f64> = (0..n)
        .map(|i| 30.0 * i as f64 + (uni() * 10.0).floor())
        .collect();
    let body = |scale: f64| -> String {
        (0..n)
            .map(|i| {
                format!(
                    "{},{},{}\n",
                    t_s[i] / scale,
                    20.0 + i as f64 * 0.1,
                    i as f64 * 0.5
                )
            })
            .collect()
    };
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    let want = read_csv(
        &format!("time_s,a_c,y_um\n{}", body(1.0)),
        "log.csv",
        &sel,
        ReadOptions::default(),
    )
    .unwrap();
    for (name, scale) in [
        ("time", 1.0),
        ("Time", 1.0),
        ("Zeit [s]", 1.0),
        ("elapsed", 1.0),
        ("t", 1.0),
        ("time_ms", 0.001),
        ("Zeit [min]", 60.0),
        ("time_h", 3600.0),
    ] {
        let text = format!("{name},a_c,y_um\n{}", body(scale));
        let auto = ReadOptions {
            time_unit: Some(TimeUnitChoice::Auto),
            ..ReadOptions::default()
        };
        let t = read_csv(&text, "log.csv", &sel, auto).unwrap();
        assert_eq!(t.time_s.len(), n, "{name}");
        for (a, b) in t.time_s.iter().zip(&want.time_s) {
            assert!(
                (a - b).abs() <= 1e-9 * b.abs().max(1.0),
                "{name}: {a} vs {b}"
            );
        }
        assert_eq!(t.inputs, want.inputs, "{name}");
        let note = t
            .issues
            .iter()
            .find(|i| matches!(i, DataIssue::TimeColumn { .. }))
            .unwrap()
            .to_string();
        assert!(
            note.contains(&format!("time column: {name:?}")) && note.contains("--time-column"),
            "{note}"
        );
    }
    // A name the user gave is not replaced.
    let text = format!("time,a_c,y_um\n{}", body(1.0));
    let e = read_csv(
        &text,
        "log.csv",
        &Selection {
            time: "clock".into(),
            ..sel.clone()
        },
        ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--time-column = clock"), "{e}");
    // A bad time cell names the column the log has.
    let text = format!("time,a_c,y_um\n{}x,20,1\n", body(1.0));
    let e = read_csv(&text, "log.csv", &sel, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("time = \"x\" is not a number"), "{e}");
}

/// Unix time in milliseconds in a column whose name and units row say nothing (`timestamp`)
/// reads as seconds × 0.001, with a note: the same table as the log in Unix seconds (it was
/// read as seconds: a 5 h log taken for 208 days). A name or `--time-unit` that says
/// seconds is taken as said; µs or ns are refused naming `--time-unit`.
#[test]
fn unix_milliseconds_are_read_as_such_when_nothing_names_the_unit() {
    let log = |name: &str, scale: f64| -> String {
        let mut s = format!("{name},a_c,z_um\n");
        for i in 0..50u32 {
            let t = (1_732_500_000.0 + 30.0 * f64::from(i)) * scale;
            s += &format!("{t},{},{}\n", 20 + i % 7, i % 5);
        }
        s
    };
    let read = |text: &str, time: &str, unit: TimeUnitChoice| {
        let sel = Selection {
            time: time.into(),
            targets: vec!["z_um".into()],
            ..Selection::default()
        };
        let opts = ReadOptions {
            time_unit: Some(unit),
            ..ReadOptions::default()
        };
        read_csv(text, "log.csv", &sel, opts).map_err(|e| e.to_string())
    };
    let auto = TimeUnitChoice::Auto;
    let want = read(&log("stamp", 1.0), "stamp", auto).unwrap();
    let got = read(&log("stamp", 1000.0), "stamp", auto).unwrap();
    assert_eq!(got.time_s, want.time_s);
    assert_eq!(got.segments, want.segments);
    let notes: Vec<String> = got.issues.iter().map(ToString::to_string).collect();
    assert!(
        notes
            .iter()
            .any(|n| n.contains("in ms (its size: Unix time in milliseconds")),
        "{notes:?}"
    );
    // Seconds said by the name or by the option: taken as said.
    let named = read(&log("time_s", 1000.0), "time_s", auto).unwrap();
    assert_eq!(named.time_s[1] - named.time_s[0], 30_000.0);
    let given = read(
        &log("stamp", 1000.0),
        "stamp",
        TimeUnitChoice::Given(TimeUnit::S),
    )
    .unwrap();
    assert_eq!(given.time_s[1] - given.time_s[0], 30_000.0);
    // Microseconds: refused naming the option.
    let e = read(&log("stamp", 1e6), "stamp", auto).unwrap_err();
    assert!(
        e.contains("time column stamp") && e.contains("--time-unit"),
        "{e}"
    );
}
