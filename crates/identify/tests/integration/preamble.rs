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
