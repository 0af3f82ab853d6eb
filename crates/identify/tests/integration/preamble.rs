//! Real exports have title lines above the header and a units row under it (issue 12 item
//! 1, "real test data as it comes"): random logs with random title lines (0–6, blank lines
//! among them), with or without a units row, in a random dialect, read into exactly the
//! table of the same log written plainly, every row keeping its line number in the file;
//! a bad cell after the preamble is named by its line in the file; title lines that name a
//! selected column's header are not mistaken for anything but the header.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, read_csv_file, DataIssue, ReadOptions, Selection, Table};
use proptest::prelude::*;

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[(self.next() % items.len() as u64) as usize]
    }
}

fn sel() -> Selection {
    Selection {
        time: "Zeit".into(),
        inputs: vec!["T*".into()],
        targets: vec!["Weg".into()],
        run: None,
    }
}

/// Rows of (time, T1, T2, Weg) and the plain log of them.
fn rows(seed: u64, n: usize) -> Vec<[f64; 4]> {
    let mut r = Rng(seed | 1);
    (0..n)
        .map(|k| {
            let u = |r: &mut Rng| (r.next() % 100_000) as f64 / 1000.0;
            [
                60.0 * k as f64,
                20.0 + u(&mut r),
                21.0 + u(&mut r),
                u(&mut r) - 50.0,
            ]
        })
        .collect()
}

fn write(rows: &[[f64; 4]], delim: char, comma: bool, eol: &str) -> Vec<String> {
    rows.iter()
        .map(|r| {
            let cells: Vec<String> = r
                .iter()
                .map(|v| {
                    let s = format!("{v}");
                    if comma {
                        s.replace('.', ",")
                    } else {
                        s
                    }
                })
                .collect();
            format!("{}{eol}", cells.join(&delim.to_string()))
        })
        .collect()
}

const TITLES: [&str; 8] = [
    "Maschine: LC 380",
    "Prüfung: Warmlauf 2024-05-01",
    "Operator; Meier",
    "Messstellen: 2",
    "Software, Version 4.2",
    "Kanal\tBeschreibung",
    "Bemerkung: keine",
    "",
];

fn same_values(a: &Table, b: &Table) -> bool {
    a.time_s == b.time_s && a.inputs == b.inputs && a.targets == b.targets
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn title_lines_and_units_rows_are_skipped_and_named(
        seed in any::<u64>(),
        n in 3usize..40,
        titles in 0usize..7,
        units in any::<bool>(),
        dialect in 0usize..3,
        crlf in any::<bool>(),
    ) {
        let (delim, comma) = [(',', false), (';', true), ('\t', false)][dialect];
        let eol = if crlf { "\r\n" } else { "\n" };
        let values = rows(seed, n);
        let body = write(&values, delim, comma, eol);
        let header = format!("Zeit{delim}T1{delim}T2{delim}Weg{eol}");
        let plain = format!("{header}{}", body.concat());
        let mut r = Rng(seed.rotate_left(17) | 1);
        let mut text = String::new();
        let mut title_lines = 0;
        for _ in 0..titles {
            text += r.pick(&TITLES);
            text += eol;
            title_lines += 1;
        }
        text += &header;
        if units {
            let u = r.pick(&["s", "[s]", "hh:mm:ss"]);
            let c = r.pick(&["°C", "degC", "[K]"]);
            text += &format!("{u}{delim}{c}{delim}{c}{delim}µm{eol}");
        }
        text += &body.concat();
        let opts = ReadOptions::default();
        let want = read_csv(&plain, "log.csv", &sel(), opts).unwrap();
        let got = read_csv(&text, "log.csv", &sel(), opts).unwrap();
        prop_assert!(same_values(&got, &want));
        // The time column not named: the log's one column that reads as a time axis (Zeit)
        // is taken, behind the same title lines and units row.
        let lone = Selection { time: "time_s".into(), ..sel() };
        let got_lone = read_csv(&text, "log.csv", &lone, opts).unwrap();
        prop_assert!(same_values(&got_lone, &want));
        prop_assert_eq!(&got_lone.lines, &got.lines);
        // Columns the log lacks: the error lists the log's own columns (the header found by
        // its shape over the data), never a title line's words.
        let absent = Selection { targets: vec!["*_um".into()], ..sel() };
        let e = read_csv(&text, "log.csv", &absent, opts).unwrap_err().to_string();
        prop_assert!(e.contains("available columns are Zeit, T1, T2, Weg"), "{}", e);
        // The file reader (chunked, for clean logs) gives the same table or leaves the file
        // to the text reader.
        let path = std::env::temp_dir().join(format!(
            "gearcomp-preamble-{}-{seed}.csv",
            std::process::id()
        ));
        std::fs::write(&path, &text).unwrap();
        let from_file = read_csv_file(&path, "log.csv", &sel(), opts);
        std::fs::remove_file(&path).unwrap();
        if let Some(f) = from_file {
            let f = f.unwrap();
            prop_assert!(same_values(&f, &got));
            prop_assert_eq!(&f.lines, &got.lines);
        }
        let shift = (title_lines + usize::from(units)) as u64;
        let moved: Vec<u64> = want.lines.iter().map(|l| l + shift).collect();
        prop_assert_eq!(&got.lines, &moved);
        let skipped: Vec<&DataIssue> = got
            .issues
            .iter()
            .filter(|i| matches!(i, DataIssue::Skipped { .. }))
            .collect();
        let nonblank_titles = text
            .lines()
            .take(title_lines)
            .filter(|l| !l.trim().is_empty())
            .count();
        prop_assert_eq!(
            skipped.len(),
            usize::from(nonblank_titles > 0) + usize::from(units),
            "{:?}", got.issues
        );
        if units {
            let unit_line = title_lines as u64 + 2;
            prop_assert!(
                skipped.iter().any(|i| i.to_string().starts_with(&format!("line {unit_line}: units row"))),
                "{:?}", skipped
            );
        }
        // A bad cell in a random data row is named by its line in the file.
        let k = (seed % n as u64) as usize;
        let mut bad_body = body.clone();
        bad_body[k] = bad_body[k].replacen(delim, &format!("{delim}x"), 2);
        let pre_len = text.len() - body.concat().len();
        let bad = format!("{}{}", &text[..pre_len], bad_body.concat());
        let e = read_csv(&bad, "log.csv", &sel(), opts).unwrap_err().to_string();
        let line = title_lines + usize::from(units) + 2 + k;
        prop_assert!(e.contains(&format!("line(s) {line}")) || e.contains(&format!("line {line}")), "{}", e);
    }
}

/// A title line that itself names every selected column is the header (the first line
/// that is): the reader does not look further, and says nothing was skipped.
#[test]
fn the_first_line_that_names_every_column_is_the_header() {
    let text = "Zeit,T1,T2,Weg\n0,1,2,3\n60,1,2,4\n120,2,3,5\n";
    let t = read_csv(text, "log.csv", &sel(), ReadOptions::default()).unwrap();
    assert_eq!(t.lines, [2, 3, 4]);
    assert!(t.issues.is_empty());
    // Without the header anywhere, the error names the missing column as before.
    let e = read_csv(
        "Messung 3\nZeit,T1,T2\n0,1,2\n",
        "log.csv",
        &sel(),
        ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("Weg") && e.contains("Zeit, T1, T2"), "{e}");
}

mod target_units {
    use gearcomp_identify::data::{read_csv, DataIssue, ReadOptions, Selection};
    use gearcomp_identify::target_unit::{LengthUnit, TargetUnit};
    use gearcomp_identify::{identify, IdentifyOptions, ModelKind, Split};
    use proptest::prelude::*;

    const UNITS: [LengthUnit; 5] = [
        LengthUnit::Um,
        LengthUnit::Mm,
        LengthUnit::Nm,
        LengthUnit::M,
        LengthUnit::Inch,
    ];

    fn sel(target: &str) -> Selection {
        Selection {
            targets: vec![target.into()],
            ..Selection::default()
        }
    }

    fn static_model(t: &gearcomp_identify::data::Table) -> Vec<f64> {
        let o = IdentifyOptions {
            model: ModelKind::Static,
            classes: Some(2),
            split: Split::None,
            ..IdentifyOptions::default()
        };
        let m = identify(t, &o).unwrap().targets[0].model.clone();
        std::iter::once(m.intercept)
            .chain(m.terms.iter().map(|t| t.coefficient))
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

        /// A displacement logged in mm, nm, m or inch (named by the units row, by the
        /// column name, or by --target-unit) reads as the same log written in µm: every
        /// target value to 1e-12 relative (the conversion factors are exact), the same static
        /// model to 1e-9, with one note naming the unit and where it came from; the library
        /// default (no target unit) reads the values as written.
        #[test]
        fn a_target_in_another_unit_reads_as_micrometres(seed in any::<u64>(), unit in 0usize..5, how in 0usize..3) {
            let unit = UNITS[unit];
            let mut s = seed | 1;
            let mut uni = move || {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64
            };
            let n = 40;
            let rows: Vec<(f64, f64, f64)> = (0..n)
                .map(|_| {
                    let a = 20.0 + 5.0 * uni();
                    let b = 22.0 + 5.0 * uni();
                    (a, b, 3.0 * a - 2.0 * b + 0.1 * uni())
                })
                .collect();
            let write = |name: &str, units_row: Option<&str>, k: f64| {
                let mut text = format!("time_s,a_c,b_c,{name}\n");
                if let Some(u) = units_row {
                    text += &format!("s,°C,°C,{u}\n");
                }
                for (i, r) in rows.iter().enumerate() {
                    text += &format!("{},{},{},{:e}\n", i * 60, r.0, r.1, r.2 / k);
                }
                text
            };
            let auto = ReadOptions { target_unit: Some(TargetUnit::Auto), ..ReadOptions::default() };
            let want = read_csv(&write("z", None, 1.0), "um.csv", &sel("z"), auto).unwrap();
            let k = unit.um_per_unit();
            let (text, name, opts) = match how {
                0 => (write("z", Some(unit.symbol()), k), "z", auto),
                1 if matches!(unit, LengthUnit::Mm | LengthUnit::Nm | LengthUnit::Um) =>
                    (write(&format!("z_{}", unit.symbol()), None, k), "z_*", auto),
                _ => (write("z", None, k), "z", ReadOptions { target_unit: Some(TargetUnit::Given(unit)), ..ReadOptions::default() }),
            };
            let got = read_csv(&text, "log.csv", &sel(name), opts).unwrap();
            for (g, w) in got.targets[0].iter().zip(&want.targets[0]) {
                prop_assert!((g - w).abs() <= 1e-12 * w.abs(), "{g} vs {w}");
            }
            let (a, b) = (static_model(&got), static_model(&want));
            for (x, y) in a.iter().zip(&b) {
                prop_assert!((x - y).abs() <= 1e-9 * (1.0 + y.abs()), "{a:?} vs {b:?}");
            }
            let notes: Vec<&DataIssue> = got.issues.iter().filter(|i| matches!(i, DataIssue::Unit { .. })).collect();
            if unit == LengthUnit::Um {
                prop_assert!(notes.is_empty());
            } else {
                prop_assert_eq!(notes.len(), 1);
                let note = notes[0].to_string();
                prop_assert!(note.contains(&format!("in {} (", unit.symbol())), "{note}");
            }
            // As written without a target unit.
            if unit != LengthUnit::Um {
                let raw = read_csv(&text, "log.csv", &sel(name), ReadOptions::default()).unwrap();
                prop_assert!((raw.targets[0][0] - want.targets[0][0] / k).abs() <= 1e-12 * want.targets[0][0].abs() / k);
            }
        }
    }

    /// A units-row cell that is no length unit is refused, naming the target, the cell and
    /// --target-unit; naming the unit reads it.
    #[test]
    fn a_units_row_without_a_length_is_refused() {
        let text = "time_s,a_c,z\ns,°C,V\n0,20,1\n60,21,2\n120,22,3\n";
        let auto = ReadOptions {
            target_unit: Some(TargetUnit::Auto),
            ..ReadOptions::default()
        };
        let e = read_csv(text, "log.csv", &sel("z"), auto)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unit of target z in the units row = «V»") && e.contains("--target-unit"),
            "{e}"
        );
        let given = ReadOptions {
            target_unit: Some(TargetUnit::Given(LengthUnit::Mm)),
            ..ReadOptions::default()
        };
        let t = read_csv(text, "log.csv", &sel("z"), given).unwrap();
        assert_eq!(t.targets[0], [1000.0, 2000.0, 3000.0]);
    }
}

/// A Graphtec-style export (GL-series CSV): title lines, `No.,Date&Time,ms,CH1,…`, a units
/// row with empty cells, year-first slash stamps and signed values. With only its inputs
/// and target named, it reads as the same log written plainly (the time from `Date&Time`,
/// the one column that reads as a time axis); without them, the error lists its columns.
#[test]
fn a_graphtec_export_reads_with_its_channels_named() {
    let mut plain = "time_s,CH1,CH2,CH3\n".to_string();
    let mut text = "Model,GL240\nTitle,\nTrigger Time,\"2026/03/10 23:59:00\"\n\nNo.,Date&Time,ms,CH1,CH2,CH3\n,,,degC,degC,um\n".to_string();
    for k in 0..30u32 {
        let s = 23 * 3600 + 59 * 60 + 30 * k;
        let (day, hms) = (10 + s / 86_400, s % 86_400);
        let (a, b, y) = (
            20.0 + f64::from(k) * 0.25,
            22.5 - f64::from(k) * 0.5,
            f64::from(k) - 3.5,
        );
        plain += &format!("{},{a},{b},{y}\n", 30 * k);
        text += &format!(
            "{},2026/03/{day:02} {:02}:{:02}:{:02},0,{a:+.2},{b:+.2},{y:+.3}\n",
            k + 1,
            hms / 3600,
            hms / 60 % 60,
            hms % 60
        );
    }
    let channels = Selection {
        time: "time_s".into(),
        inputs: vec!["CH1".into(), "CH2".into()],
        targets: vec!["CH3".into()],
        run: None,
    };
    let opts = ReadOptions::default();
    let want = read_csv(&plain, "plain.csv", &channels, opts).unwrap();
    let got = read_csv(&text, "gl240.csv", &channels, opts).unwrap();
    assert!(
        same_values(&got, &want),
        "{:?}\n{:?}",
        got.time_s,
        want.time_s
    );
    assert_eq!(got.lines, (7..37).collect::<Vec<u64>>());
    // With the default selection (time_s, *_c, *_um) alone: the channels by the units row
    // (degC: inputs; um: the target), with notes on the header's line.
    let defaults = Selection {
        time: "time_s".into(),
        inputs: vec!["*_c".into()],
        targets: vec!["*_um".into()],
        run: None,
    };
    let zero = read_csv(&text, "gl240.csv", &defaults, opts).unwrap();
    assert!(same_values(&zero, &want));
    assert_eq!(
        (zero.input_names, zero.target_names),
        (want.input_names, want.target_names)
    );
    let notes: Vec<String> = zero.issues.iter().map(ToString::to_string).collect();
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("line 5: inputs: CH1, CH2 by their unit"))
            && notes
                .iter()
                .any(|n| n.starts_with("line 5: targets: CH3 by their unit")),
        "{notes:?}"
    );
    let e = read_csv(
        &text,
        "gl240.csv",
        &Selection {
            time: "time_s".into(),
            ..sel()
        },
        opts,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("available columns are No., Date&Time, ms, CH1, CH2, CH3"),
        "{e}"
    );
}

/// Columns the default patterns (`*_c`, `*_um`) do not name are taken by the unit in their
/// name's brackets: °C/K inputs, a µm or nm target (a column in mm, an axis position far
/// more often than a thermal error, is not); the same table as with the columns named.
/// Where a default pattern matches, it alone selects; where no unit says, the refusal
/// stands.
#[test]
fn columns_are_taken_by_their_unit_when_the_defaults_match_none() {
    let mut text = "Zeit [s],Spindel [°C],Bett (degC),Pos X [mm],Weg [µm],Delta [K]\n".to_string();
    for k in 0..30u32 {
        let (a, b) = (20.0 + f64::from(k) * 0.1, 22.0 - f64::from(k % 7) * 0.2);
        text += &format!("{},{a},{b},{},{},{}\n", 60 * k, 100 + k, 1.5 * a - b, a - b);
    }
    let defaults = Selection {
        time: "time_s".into(),
        inputs: vec!["*_c".into()],
        targets: vec!["*_um".into()],
        run: None,
    };
    let named = Selection {
        time: "Zeit [s]".into(),
        inputs: vec![
            "Spindel [°C]".into(),
            "Bett (degC)".into(),
            "Delta [K]".into(),
        ],
        targets: vec!["Weg [µm]".into()],
        run: None,
    };
    let opts = ReadOptions::default();
    let want = read_csv(&text, "log.csv", &named, opts).unwrap();
    let got = read_csv(&text, "log.csv", &defaults, opts).unwrap();
    assert!(same_values(&got, &want));
    assert_eq!(got.input_names, want.input_names);
    assert_eq!(got.target_names, vec!["Weg [µm]"]);
    // A default pattern that matches selects alone.
    let with_c = text.replacen("Bett (degC)", "bett_c", 1);
    let t = read_csv(&with_c, "log.csv", &defaults, opts).unwrap();
    assert_eq!(t.input_names, vec!["bett_c"]);
    // No unit says: refused as before, naming the option.
    let bare = text.replacen("Weg [µm]", "Weg", 1);
    let e = read_csv(&bare, "log.csv", &defaults, opts)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("column \"*_um\" not found") && e.contains("--target"),
        "{e}"
    );
}
