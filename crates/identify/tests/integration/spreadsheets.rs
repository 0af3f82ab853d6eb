//! Workbooks as logs (issue 12 item 1, `identify::spreadsheet`): the workbooks are written by
//! independent writers (rust_xlsxwriter here; openpyxl and pandas/odfpy for the committed
//! fixtures of `tests/data/workbooks/make_workbooks.py`, with the CSV logs of the same
//! values), and every reading is compared with the CSV reading of the same values, or with
//! values computed here.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::path::PathBuf;

use gearcomp_identify::data::{
    read_csv, read_runs, DataIssue, MissingCells, ReadOptions, Selection, Table,
};
use gearcomp_identify::spreadsheet::{read_paths, read_paths_with_targets, SheetChoice};
use gearcomp_identify::{identify, IdentifyError, IdentifyOptions, ModelKind, Split};
use proptest::prelude::*;
use rust_xlsxwriter::Workbook;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/workbooks")
        .join(name)
}

fn cli_fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../cli/tests/fixtures")
        .join(name)
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-spreadsheets-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// The three CSV days of the CLI fixtures read as one file per run (the reference table).
fn csv_days(s: &Selection) -> Table {
    let texts: Vec<(String, String)> = (1..=3)
        .map(|d| {
            let n = format!("day {d}.csv");
            (std::fs::read_to_string(cli_fixture(&n)).unwrap(), n)
        })
        .collect();
    let refs: Vec<(&str, &str)> = texts
        .iter()
        .map(|(t, n)| (t.as_str(), n.as_str()))
        .collect();
    read_runs(&refs, s, ReadOptions::default()).unwrap()
}

fn sel(time: &str, inputs: &[&str], targets: &[&str]) -> Selection {
    Selection {
        time: time.into(),
        inputs: inputs.iter().map(|s| s.to_string()).collect(),
        targets: targets.iter().map(|s| s.to_string()).collect(),
        run: None,
    }
}

fn sheets(names: &[&str], all: bool) -> SheetChoice {
    SheetChoice {
        sheets: names.iter().map(|s| s.to_string()).collect(),
        all,
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// The same data to the last bit: times, values, lines, segments and runs (not the file
/// names, nor the column names when `names` is false).
fn assert_same_data(a: &Table, b: &Table, names: bool) {
    assert_eq!(bits(&a.time_s), bits(&b.time_s));
    assert_eq!(a.inputs.len(), b.inputs.len());
    for (x, y) in a
        .inputs
        .iter()
        .zip(&b.inputs)
        .chain(a.targets.iter().zip(&b.targets))
    {
        assert_eq!(bits(x), bits(y));
    }
    assert_eq!(a.targets.len(), b.targets.len());
    if names {
        assert_eq!(a.input_names, b.input_names);
        assert_eq!(a.target_names, b.target_names);
    }
    assert_eq!(a.lines, b.lines);
    assert_eq!(a.segments, b.segments);
    assert_eq!(a.runs, b.runs);
    assert_eq!(a.run_names, b.run_names);
}

/// xorshift: reproducible values with every mantissa bit used.
fn values(seed: u64, n: usize) -> Vec<f64> {
    let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 * 40.0 - 5.0
        })
        .collect()
}

/// A random log of `rows` rows (time, five inputs, two targets) as a CSV text (numbers in
/// exponent form, `{:e}`) and as a workbook written by rust_xlsxwriter.
fn random_log(seed: u64, rows: usize, book: &PathBuf) -> String {
    let header = ["time_s", "a_c", "b_c", "c_c", "d_c", "e_c", "x_um", "y_um"];
    let v = values(seed, rows * header.len());
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    let mut csv = header.join(",") + "\n";
    for (c, h) in header.iter().enumerate() {
        ws.write_string(0, c as u16, *h).unwrap();
    }
    for r in 0..rows {
        let mut cells = Vec::new();
        for c in 0..header.len() {
            let x = if c == 0 {
                r as f64 * 60.0 + v[r * header.len()].abs()
            } else {
                v[r * header.len() + c]
            };
            ws.write_number(r as u32 + 1, c as u16, x).unwrap();
            cells.push(format!("{x:e}"));
        }
        csv += &(cells.join(",") + "\n");
    }
    wb.save(book).unwrap();
    csv
}

/// A workbook of random values reads to the CSV's table to the last bit, and the static fit
/// on it equals the CSV's.
#[test]
fn workbook_of_random_values_equals_the_csv_to_the_last_bit() {
    let book = tmp("random.xlsx");
    let csv = random_log(7, 120, &book);
    let s = sel("time_s", &["*_c"], &["*_um"]);
    let want = read_csv(&csv, "random.csv", &s, ReadOptions::default()).unwrap();
    let got = read_paths(
        std::slice::from_ref(&book),
        &s,
        ReadOptions::default(),
        &SheetChoice::default(),
    )
    .unwrap();
    assert_same_data(&got, &want, true);
    assert_eq!(got.files, vec![book.display().to_string()]);
    let opts = IdentifyOptions {
        model: ModelKind::Static,
        classes: Some(3),
        split: Split::None,
        ..Default::default()
    };
    let a = identify(&got, &opts).unwrap();
    let b = identify(&want, &opts).unwrap();
    assert_eq!(format!("{:?}", a.targets), format!("{:?}", b.targets));
}

/// Date-time cells are the time column in seconds since the run's first stamp, with the
/// 1900 and the 1904 epoch (the same instants written by openpyxl both ways, and by xlwt
/// in a 1904 .xls), across
/// midnight into a leap day; the values equal the CSV of ISO stamps written by the same
/// script.
#[test]
fn excel_serial_dates_of_both_epochs_are_seconds() {
    let s = sel("stamp", &["*_c"], &["d_um"]);
    let csv_text = std::fs::read_to_string(fixture("dates.csv")).unwrap();
    let want = read_csv(&csv_text, "dates.csv", &s, ReadOptions::default()).unwrap();
    let expected: Vec<f64> = (0..8).map(|k| k as f64 * 37.25).collect();
    assert_eq!(want.time_s, expected);
    for book in ["dates.xlsx", "dates_1904.xlsx", "dates_1904.xls"] {
        let got = read_paths(
            &[fixture(book)],
            &s,
            ReadOptions::default(),
            &SheetChoice::default(),
        )
        .unwrap();
        assert_eq!(got.time_s, expected, "{book}");
        assert_same_data(&got, &want, true);
        // The absolute date, shown by a stamp read as a number: the epoch is the workbook's.
        let e = read_paths(
            &[fixture(book)],
            &sel("t", &["stamp", "a_c"], &["d_um"]),
            ReadOptions {
                sample_interval_s: Some(1.0),
                ..ReadOptions::default()
            },
            &SheetChoice::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains(
                "8 bad row(s) at line(s) 2, 3, 4, 5, 6, 7, 8, 9: Sheet 'log' cell A2: stamp = \"2024-02-28 23:58:00.000\" is not a number"
            ),
            "{book}: {e}"
        );
    }
}

/// The OpenDocument file pandas/odfpy wrote, and the Excel 97-2003 file xlwt wrote, equal
/// the CSV of the same day.
#[test]
fn ods_and_xls_workbooks_equal_their_csv() {
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let csv = std::fs::read_to_string(cli_fixture("day 1.csv")).unwrap();
    let want = read_csv(&csv, "day 1.csv", &s, ReadOptions::default()).unwrap();
    for book in ["day 1.ods", "day 1.xls"] {
        let got = read_paths(
            &[cli_fixture(book)],
            &s,
            ReadOptions::default(),
            &SheetChoice::default(),
        )
        .unwrap();
        assert_same_data(&got, &want, true);
    }
}

/// Error, empty and text cells are named by sheet and cell; a number written as text is a
/// number; an empty target cell is a row without a measurement (kept, NaN there).
#[test]
fn bad_cells_name_the_sheet_and_the_cell() {
    let path = fixture("cells.xlsx");
    let s = sel("time_s", &["a_c", "b_c"], &["d_um"]);
    let read = |opts: ReadOptions| {
        read_paths(
            std::slice::from_ref(&path),
            &s,
            opts,
            &SheetChoice::default(),
        )
    };
    let e = read(ReadOptions::default()).unwrap_err().to_string();
    assert!(
        e.starts_with(&format!(
            "{}: 2 bad row(s) at line(s) 10, 17: Sheet 'day 3' cell B10: a_c is empty",
            path.display()
        )),
        "{e}"
    );
    assert!(e.ends_with("(the cell holds the error #DIV/0!)"), "{e}");
    let t = read(ReadOptions {
        skip_bad_rows: true,
        ..ReadOptions::default()
    })
    .unwrap();
    let issues: Vec<String> = t.issues.iter().map(|i| i.to_string()).collect();
    assert_eq!(issues.len(), 2, "{issues:?}");
    let row12 = t.lines.iter().position(|&l| l == 12).unwrap();
    assert!(t.targets[0][row12].is_nan());
    assert_eq!(t.measured().iter().filter(|&&m| !m).count(), 1);
    assert_eq!(
        issues[1],
        "line 17: bad row: Sheet 'day 3' cell C17: b_c = \"oops\" is not a number (a logger's mark for a missing sample? --missing-code=\"oops\" reads it as an empty cell)"
    );
    // Row 5's b_c is the text "21.5"; the value of row k (sheet row k + 2) is 21 + 0.05 k².
    let row5 = t.lines.iter().position(|&l| l == 5).unwrap();
    assert_eq!(t.inputs[1][row5], 21.5);
    assert_eq!(t.inputs[1][0], 21.0);
    assert_eq!(t.time_s.len(), 18);
    // --missing split: the error cell of an input splits the run; the text cell is still a
    // bad row.
    let e = read(ReadOptions {
        missing: MissingCells::Split,
        ..ReadOptions::default()
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.ends_with(
            "1 bad row(s) at line(s) 17: Sheet 'day 3' cell C17: b_c = \"oops\" is not a number (a logger's mark for a missing sample? --missing-code=\"oops\" reads it as an empty cell)"
        ),
        "{e}"
    );
    let t = read(ReadOptions {
        missing: MissingCells::Split,
        skip_bad_rows: true,
        ..ReadOptions::default()
    })
    .unwrap();
    let missing: Vec<String> = t
        .issues
        .iter()
        .filter(|i| matches!(i, DataIssue::Missing { .. }))
        .map(|i| i.to_string())
        .collect();
    assert_eq!(missing.len(), 1, "{missing:?}");
    assert!(missing[0].starts_with("line 10: left out (Sheet 'day 3' cell B10: a_c is empty (the cell holds the error #DIV/0!);"), "{missing:?}");
}

/// `--no-header`: a header-less CSV and a header-less sheet read as the CSV with a header,
/// columns named c1 … c5; `c*` as inputs leaves out the time and the target. Without
/// `--no-header`, an unmatched column says the file seems to have no header row.
#[test]
fn header_less_logs_are_read_by_position() {
    let with = sel("time_s", &["*_c"], &["d_um"]);
    let csv = std::fs::read_to_string(cli_fixture("day 1.csv")).unwrap();
    let want = read_csv(&csv, "day 1.csv", &with, ReadOptions::default()).unwrap();
    let bare = sel("c1", &["c*"], &["c5"]);
    let no_header = ReadOptions {
        no_header: true,
        ..ReadOptions::default()
    };
    let text = std::fs::read_to_string(cli_fixture("day 1 noheader.csv")).unwrap();
    let got = read_csv(&text, "day 1 noheader.csv", &bare, no_header).unwrap();
    assert_eq!(got.input_names, vec!["c2", "c3", "c4"]);
    assert_eq!(got.target_names, vec!["c5"]);
    assert_eq!(bits(&got.time_s), bits(&want.time_s));
    // One line less (no header line): the same rows.
    assert_eq!(
        got.lines,
        want.lines.iter().map(|l| l - 1).collect::<Vec<_>>()
    );
    for (a, b) in got.inputs.iter().zip(&want.inputs) {
        assert_eq!(bits(a), bits(b));
    }
    let book = read_paths(
        &[cli_fixture("days_noheader.xlsx")],
        &bare,
        no_header,
        &sheets(&["day 1"], false),
    )
    .unwrap();
    assert_same_data(&book, &got, true);
    // Without --no-header: the hint.
    let e = read_csv(
        &text,
        "day 1 noheader.csv",
        &sel("c1", &["c*"], &["c5"]),
        ReadOptions {
            sample_interval_s: None,
            ..ReadOptions::default()
        },
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("seems to have no header row; read it with --no-header"),
        "{e}"
    );
    let e = read_paths(
        &[cli_fixture("days_noheader.xlsx")],
        &sel("time_s", &["*_c"], &["d_um"]),
        ReadOptions::default(),
        &sheets(&["day 1"], false),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--no-header"), "{e}");
    let e = read_csv(
        "time_s,a_c,d_um\n0,1,2\n",
        "x.csv",
        &sel("time_s", &["q_c"], &["d_um"]),
        ReadOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(!e.contains("--no-header"), "{e}");
}

/// Every sheet a run equals one CSV file per run (run names, segments, values); a sheet by
/// number; a workbook of several sheets with data needs a choice; a sheet without the
/// columns is named.
#[test]
fn sheets_as_runs_equal_one_file_per_run() {
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let want = csv_days(&s);
    assert_eq!(want.run_names, vec!["day 1", "day 2", "day 3"]);
    let book = cli_fixture("days.xlsx");
    let got = read_paths(
        std::slice::from_ref(&book),
        &s,
        ReadOptions::default(),
        &sheets(&["day 1", "day 2", "4"], true),
    )
    .unwrap();
    assert_same_data(&got, &want, true);
    // The header-less workbook holds the same three days as its only sheets.
    let bare = read_paths(
        &[cli_fixture("days_noheader.xlsx")],
        &sel("c1", &["c*"], &["c5"]),
        ReadOptions {
            no_header: true,
            ..ReadOptions::default()
        },
        &sheets(&[], true),
    )
    .unwrap();
    assert_eq!(bare.run_names, want.run_names);
    assert_eq!(bits(&bare.targets[0]), bits(&want.targets[0]));
    // No choice on a workbook of four sheets with data: refused, listing them.
    let e = read_paths(
        std::slice::from_ref(&book),
        &s,
        ReadOptions::default(),
        &SheetChoice::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("has 4 sheets with data ('notes', 'day 1', 'day 2', 'day 3'); name one or several with --sheet"),
        "{e}"
    );
    // Every sheet: the notes sheet has no time column, and is named.
    let e = read_paths(
        std::slice::from_ref(&book),
        &s,
        ReadOptions::default(),
        &sheets(&[], true),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("sheet 'notes' (columns: machine, test rig 2)"),
        "{e}"
    );
    let e = read_paths(
        std::slice::from_ref(&book),
        &s,
        ReadOptions::default(),
        &sheets(&["day 9"], false),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("--sheet = day 9: expected a sheet name or number of")
            && e.contains("1 'notes', 2 'day 1', 3 'day 2', 4 'day 3'"),
        "{e}"
    );
    // A CSV log has no sheets; CSV logs and workbooks are not mixed.
    let csv_path = cli_fixture("day 1.csv");
    let e = read_paths(
        std::slice::from_ref(&csv_path),
        &s,
        ReadOptions::default(),
        &sheets(&["1"], false),
    )
    .unwrap_err();
    assert!(e.to_string().contains("--sheet"), "{e}");
    let e = read_paths(
        &[csv_path, book],
        &s,
        ReadOptions::default(),
        &SheetChoice::default(),
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("either CSV logs or workbooks"),
        "{e}"
    );
}

/// A random table (values, empty cells, a time that may go back) as `(csv, book)`: the
/// CSV with numbers in exponent form, the workbook by rust_xlsxwriter (empty cells not
/// written). Returns also the grid (None = empty) for the expected cell names.
fn random_table(
    seed: u64,
    rows: usize,
    holes: u32,
    path: &PathBuf,
) -> (String, Vec<Vec<Option<f64>>>) {
    let v = values(seed, rows * 5);
    let mut grid = Vec::new();
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    let header = ["time_s", "a_c", "b_c", "d_um"];
    for (c, h) in header.iter().enumerate() {
        ws.write_string(0, c as u16, *h).unwrap();
    }
    let mut csv = header.join(",") + "\n";
    for r in 0..rows {
        let mut row = Vec::new();
        for c in 0..4 {
            let u = v[r * 5 + c];
            let x = if c == 0 {
                // Usually increasing; now and then back in time.
                if (v[r * 5 + 4] * 1000.0) as i64 % 17 == 0 {
                    r as f64 * 10.0 - 25.0
                } else {
                    r as f64 * 10.0 + u.abs() / 4.0
                }
            } else {
                u
            };
            let hole = ((v[r * 5 + 4] * 1e6) as i64 + c as i64 * 7) % 100 < holes as i64;
            row.push(if hole { None } else { Some(x) });
        }
        let cells: Vec<String> = row
            .iter()
            .map(|x| x.map_or(String::new(), |x| format!("{x:e}")))
            .collect();
        csv += &(cells.join(",") + "\n");
        for (c, x) in row.iter().enumerate() {
            if let Some(x) = x {
                ws.write_number(r as u32 + 1, c as u16, *x).unwrap();
            }
        }
        grid.push(row);
    }
    wb.save(path).unwrap();
    (csv, grid)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Random tables with empty cells, written both as CSV and as a workbook: the same
    /// table, or the same bad rows, the workbook's first reason being the CSV's with the
    /// cell named (the first empty input cell of the first bad row, else the time cell: an
    /// empty target cell is a row without a measurement).
    #[test]
    fn csv_and_workbook_read_alike(seed in any::<u64>(), rows in 4usize..40, holes in 0u32..12,
                                   split in any::<bool>(), skip in any::<bool>()) {
        let path = tmp(&format!("prop-{seed}.xlsx"));
        let (csv, grid) = random_table(seed, rows, holes, &path);
        let s = sel("time_s", &["a_c", "b_c"], &["d_um"]);
        let opts = ReadOptions {
            missing: if split { MissingCells::Split } else { MissingCells::Error },
            skip_bad_rows: skip,
            ..ReadOptions::default()
        };
        let want = read_csv(&csv, "t.csv", &s, opts);
        let got = read_paths(std::slice::from_ref(&path), &s, opts, &SheetChoice::default());
        std::fs::remove_file(&path).ok();
        match (got, want) {
            (Ok(g), Ok(w)) => {
                assert_same_data(&g, &w, true);
                prop_assert_eq!(g.issues.len(), w.issues.len());
                for (a, b) in g.issues.iter().zip(&w.issues) {
                    let (a, b) = (a.to_string(), b.to_string());
                    if a == b {
                        // A gap: no cell to name.
                        continue;
                    }
                    // `line N: bad row: ` / `line N: left out (` then the located reason.
                    let cut = b.find(": bad row: ").map(|p| p + 11).or_else(|| b.find(" (").map(|p| p + 2));
                    if let Some(p) = cut {
                        prop_assert!(a.starts_with(&b[..p]), "{} / {}", a, b);
                        prop_assert!(a[p..].starts_with("Sheet 'Sheet1' "), "{} / {}", a, b);
                        prop_assert!(a.ends_with(&b[p..]) || b[p..].contains("(a sensor"), "{} / {}", a, b);
                    } else {
                        prop_assert_eq!(a, b);
                    }
                }
            }
            (Err(IdentifyError::BadRows { count, lines, first_reason, .. }),
             Err(IdentifyError::BadRows { count: wc, lines: wl, first_reason: wr, .. })) => {
                prop_assert_eq!(count, wc);
                prop_assert_eq!(&lines, &wl);
                let line: usize = lines.split(", ").next().unwrap().parse().unwrap();
                let row = &grid[line - 2];
                // The first empty input cell (under --missing split an empty cell is no
                // bad row; an empty target cell is a row without a measurement, never a bad
                // one), else the time cell.
                let col = if split { None } else { [1usize, 2].into_iter().find(|&c| row[c].is_none()) };
                let letter = match col { Some(1) => "B", Some(2) => "C", _ => "A" };
                prop_assert_eq!(
                    first_reason,
                    format!("Sheet 'Sheet1' cell {letter}{line}: {wr}")
                );
            }
            // Other errors: the same message, the file named as it was given.
            (g, w) => prop_assert_eq!(
                g.map(|_| ())
                    .map_err(|e| e.to_string().replace(&path.display().to_string(), "t.csv")),
                w.map(|_| ()).map_err(|e| e.to_string())
            ),
        }
    }
}

/// The rows of a CSV fixture (header first) as cells: text for the header, numbers below.
fn csv_cells(name: &str) -> Vec<Vec<String>> {
    std::fs::read_to_string(cli_fixture(name))
        .unwrap()
        .lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

/// Writes `cells` to `ws` from row `r0`, column `c0` (0-based): the first row as text, the
/// others as numbers (a cell "x" as text).
fn put(ws: &mut rust_xlsxwriter::Worksheet, cells: &[Vec<String>], r0: u32, c0: u16) {
    for (r, row) in cells.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            let (r, c) = (r0 + r as u32, c0 + c as u16);
            match v.parse::<f64>() {
                Ok(x) if r > r0 => ws.write_number(r, c, x).unwrap(),
                _ => ws.write_string(r, c, v).unwrap(),
            };
        }
    }
}

/// `--target-data`: temperatures in one workbook (sheets 'day 1' … 'day 3' from A1), the
/// drift in another (sheets 'd1' … 'd3', paired by place, from B3): the table of the three
/// CSV days; a row count that differs, a bad target cell, a CSV log are named.
#[test]
fn targets_in_a_second_workbook_join_row_by_row() {
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let want = csv_days(&s);
    let write = |short_row: Option<usize>, bad: Option<(usize, u32)>| {
        let mut inputs = Workbook::new();
        let mut targets = Workbook::new();
        for d in 1..=3 {
            let cells = csv_cells(&format!("day {d}.csv"));
            let left: Vec<Vec<String>> = cells.iter().map(|r| r[..4].to_vec()).collect();
            let mut right: Vec<Vec<String>> = cells.iter().map(|r| r[4..].to_vec()).collect();
            if short_row == Some(d) {
                right.pop();
            }
            if let Some((_, row)) = bad.filter(|b| b.0 == d) {
                right[row as usize][0] = "x".into();
            }
            let ws = inputs.add_worksheet();
            ws.set_name(format!("day {d}")).unwrap();
            put(ws, &left, 0, 0);
            let ws = targets.add_worksheet();
            ws.set_name(format!("d{d}")).unwrap();
            put(ws, &right, 2, 1);
        }
        let (a, b) = (tmp("temps.xlsx"), tmp("drift.xlsx"));
        inputs.save(&a).unwrap();
        targets.save(&b).unwrap();
        (a, b)
    };
    let all = sheets(&[], true);
    let (a, b) = write(None, None);
    let got = read_paths_with_targets(
        std::slice::from_ref(&a),
        std::slice::from_ref(&b),
        &s,
        ReadOptions::default(),
        &all,
    )
    .unwrap();
    assert_same_data(&got, &want, true);
    // Row 5 of the data (its 4th row after the header) beside row 7 of the target sheet.
    let (a, b) = write(None, Some((2, 4)));
    let e = read_paths_with_targets(
        std::slice::from_ref(&a),
        std::slice::from_ref(&b),
        &s,
        ReadOptions::default(),
        &all,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(&format!(
            "{}: Sheet 'd2' cell B7: d_um = \"x\" is not a number",
            b.display()
        )),
        "{e}"
    );
    assert!(e.contains("1 bad row(s) at line(s) 5"), "{e}");
    // The target cell is named in its own workbook only.
    assert!(
        !e.contains(&format!("{}: {}", a.display(), b.display())),
        "{e}"
    );
    let (a, b) = write(Some(3), None);
    let e = read_paths_with_targets(
        std::slice::from_ref(&a),
        std::slice::from_ref(&b),
        &s,
        ReadOptions::default(),
        &all,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("sheet 'd3' of")
            && e.contains("has 40 row(s) with data, sheet 'day 3' of")
            && e.ends_with("has 41"),
        "{e}"
    );
    let e = read_paths_with_targets(
        &[cli_fixture("day 1.csv")],
        &[cli_fixture("day 2.csv")],
        &s,
        ReadOptions::default(),
        &SheetChoice::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("CSV logs are not joined"), "{e}");
    let e = read_paths_with_targets(
        std::slice::from_ref(&a),
        &[b.clone(), b],
        &s,
        ReadOptions::default(),
        &all,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("2 file(s) for 1"), "{e}");
}

/// A chart sheet beside the data sheet (engineers plot their test) is no sheet with data:
/// the workbook reads as its one data sheet.
#[test]
fn a_chart_sheet_is_not_a_sheet_with_data() {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    ws.set_name("day 1").unwrap();
    put(ws, &csv_cells("day 1.csv"), 0, 0);
    let mut chart = rust_xlsxwriter::Chart::new(rust_xlsxwriter::ChartType::Line);
    chart.add_series().set_values("='day 1'!$E$2:$E$41");
    wb.add_chartsheet().insert_chart(0, 0, &chart).unwrap();
    let path = tmp("charted.xlsx");
    wb.save(&path).unwrap();
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let csv = std::fs::read_to_string(cli_fixture("day 1.csv")).unwrap();
    let want = read_csv(&csv, "day 1.csv", &s, ReadOptions::default()).unwrap();
    for choice in [SheetChoice::default(), sheets(&[], true)] {
        let got = read_paths(
            std::slice::from_ref(&path),
            &s,
            ReadOptions::default(),
            &choice,
        )
        .unwrap();
        assert_same_data(&got, &want, true);
    }
}

/// Numbers written as text with a decimal comma (a German export pasted into Excel) read as
/// the same values as the `;` CSV of that text, detected or forced; `20.5` as text among
/// them is refused as in a decimal-comma CSV; `--delimiter` is refused for workbooks.
#[test]
fn decimal_comma_text_cells_read_as_the_csv() {
    let rows = [
        ["0", "20,125", "1,5E-3", "7"],
        ["60", "20,5", "-0,25", "8,75"],
        ["120", "21", "0,5", "9,0"],
        ["180", "21,75", "1,25", "10,5"],
    ];
    let write = |rows: &[[&str; 4]], name: &str| {
        let mut wb = Workbook::new();
        let ws = wb.add_worksheet();
        for (c, h) in ["time_s", "a_c", "b_c", "d_um"].iter().enumerate() {
            ws.write_string(0, c as u16, *h).unwrap();
        }
        for (r, row) in rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                // The time as a number, the rest as text.
                if c == 0 {
                    ws.write_number(r as u32 + 1, 0, v.parse::<f64>().unwrap())
                        .unwrap();
                } else {
                    ws.write_string(r as u32 + 1, c as u16, *v).unwrap();
                }
            }
        }
        let p = tmp(name);
        wb.save(&p).unwrap();
        p
    };
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let mut csv = String::from("time_s;a_c;b_c;d_um\n");
    for r in &rows {
        csv += &(r.join(";") + "\n");
    }
    let want = read_csv(&csv, "de.csv", &s, ReadOptions::default()).unwrap();
    assert_eq!(want.inputs[1], vec![1.5e-3, -0.25, 0.5, 1.25]);
    let book = write(&rows, "de.xlsx");
    for dc in [None, Some(true)] {
        let got = read_paths(
            std::slice::from_ref(&book),
            &s,
            ReadOptions {
                decimal_comma: dc,
                ..ReadOptions::default()
            },
            &SheetChoice::default(),
        )
        .unwrap();
        assert_same_data(&got, &want, true);
    }
    let mut mixed = rows;
    mixed[2][1] = "20.5";
    let e = read_paths(
        &[write(&mixed, "mixed.xlsx")],
        &s,
        ReadOptions::default(),
        &SheetChoice::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("Sheet 'Sheet1' cell B4: a_c = \"20.5\" is not a number with a decimal comma"),
        "{e}"
    );
    let e = read_paths(
        &[book],
        &s,
        ReadOptions {
            delimiter: Some(b';'),
            ..ReadOptions::default()
        },
        &SheetChoice::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--delimiter"), "{e}");
}

/// A time of day without a date (`hh:mm:ss.000`) and a duration (`[h]:mm:ss`) are seconds:
/// 08:00:00 + k · 15.5 s is 28 800 + 15.5 k, an elapsed time of k · 90 s is 90 k.
#[test]
fn times_of_day_and_durations_are_seconds() {
    let mut wb = Workbook::new();
    let ws = wb.add_worksheet();
    let clock = rust_xlsxwriter::Format::new().set_num_format("hh:mm:ss.000");
    let elapsed = rust_xlsxwriter::Format::new().set_num_format("[h]:mm:ss");
    for (c, h) in ["clock", "elapsed", "a_c", "d_um"].iter().enumerate() {
        ws.write_string(0, c as u16, *h).unwrap();
    }
    for k in 0..6u32 {
        let r = k + 1;
        // The serial of a time of day: the fraction of the day.
        let t = (8.0 * 3600.0 + f64::from(k) * 15.5) / 86_400.0;
        ws.write_number_with_format(r, 0, t, &clock).unwrap();
        ws.write_number_with_format(r, 1, f64::from(k) * 90.0 / 86_400.0, &elapsed)
            .unwrap();
        ws.write_number(r, 2, 20.0 + f64::from(k)).unwrap();
        ws.write_number(r, 3, f64::from(k * k)).unwrap();
    }
    let path = tmp("clock.xlsx");
    wb.save(&path).unwrap();
    let read = |time: &str| {
        read_paths(
            std::slice::from_ref(&path),
            &sel(time, &["a_c"], &["d_um"]),
            ReadOptions::default(),
            &SheetChoice::default(),
        )
        .unwrap()
        .time_s
    };
    let want: Vec<f64> = (0..6).map(|k| 28_800.0 + f64::from(k) * 15.5).collect();
    assert_eq!(read("clock"), want);
    let want: Vec<f64> = (0..6).map(|k| f64::from(k) * 90.0).collect();
    assert_eq!(read("elapsed"), want);
}

/// Several workbooks of several sheets: runs named `book:sheet`; a workbook giving one sheet
/// is a run named after the workbook.
#[test]
fn runs_of_several_workbooks_are_named_book_and_sheet() {
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let book = |name: &str, days: &[usize]| {
        let mut wb = Workbook::new();
        for d in days {
            let ws = wb.add_worksheet();
            ws.set_name(format!("day {d}")).unwrap();
            put(ws, &csv_cells(&format!("day {d}.csv")), 0, 0);
        }
        let p = tmp(name);
        wb.save(&p).unwrap();
        p
    };
    let (a, b) = (book("week1.xlsx", &[1, 2]), book("week2.xlsx", &[3]));
    let t = read_paths(&[a, b], &s, ReadOptions::default(), &sheets(&[], true)).unwrap();
    assert_eq!(t.run_names, vec!["week1:day 1", "week1:day 2", "week2"]);
    assert_eq!(t.segments, vec![0, 40, 80]);
}

/// A sheet as data loggers write it: title rows above the header and a units row under
/// it read as the CSV day without them; both are noted by their row.
#[test]
fn title_rows_and_a_units_row_of_a_sheet_are_skipped() {
    let s = sel("time_s", &["*_c"], &["d_um"]);
    let cells = csv_cells("day 1.csv");
    let text = std::fs::read_to_string(cli_fixture("day 1.csv")).unwrap();
    let want = read_runs(&[(text.as_str(), "day 1.csv")], &s, ReadOptions::default()).unwrap();
    let mut book = Workbook::new();
    let ws = book.add_worksheet().set_name("Messung").unwrap();
    ws.write_string(0, 0, "Prüfstand LC 380, Warmlauf").unwrap();
    ws.write_string(1, 0, "Bediener: Meier").unwrap();
    put(ws, &cells[..1], 3, 0);
    for (c, name) in cells[0].iter().enumerate() {
        let unit = match c {
            0 => "s",
            _ if name.ends_with("_um") => "µm",
            _ => "°C",
        };
        ws.write_string(4, c as u16, unit).unwrap();
    }
    put(ws, &cells[1..], 5, 0);
    let p = tmp("titles.xlsx");
    book.save(&p).unwrap();
    let got = read_paths(&[p], &s, ReadOptions::default(), &sheets(&[], false)).unwrap();
    assert_eq!(bits(&got.time_s), bits(&want.time_s));
    for (x, y) in got.inputs.iter().zip(&want.inputs) {
        assert_eq!(bits(x), bits(y));
    }
    assert_eq!(bits(&got.targets[0]), bits(&want.targets[0]));
    let notes: Vec<String> = got.issues.iter().map(|i| i.to_string()).collect();
    assert!(
        notes
            .iter()
            .any(|n| n.starts_with("line 1: 2 title line(s) above the header (line 4)")),
        "{notes:?}"
    );
    assert!(
        notes.iter().any(|n| n.starts_with("line 5: units row")),
        "{notes:?}"
    );
}
