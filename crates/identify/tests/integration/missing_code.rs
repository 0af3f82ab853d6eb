//! A data logger's code for a missing sample (−9999, 32767 …) written as a number: refused
//! when it lies far outside its column's other values, read as an empty cell when named
//! with `--missing-code` (then the missing-cell rules apply).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::uniform;
use gearcomp_identify::data::{read_csv, MissingCells, ReadOptions, Selection};
use gearcomp_identify::missing_code::{MissingCodes, LOGGER_CODES};
use gearcomp_identify::select::Family;
use gearcomp_identify::{identify, predict, IdentifyOptions, Split};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// y = c₀ + a·x₁ + b·x₂ exactly, with logger codes in random input cells (any code)
    /// and target cells (|code| ≥ 999, far outside y's range): read as written, the log
    /// is refused naming the first coded column and --missing-code; with the codes named
    /// and `--missing split`, the rows with a coded input are left out, the coded target
    /// cells are rows without a measurement, and static least squares recovers the law at
    /// every measured row to 1e-9 µm (the closed form is the reference).
    #[test]
    fn logger_codes_are_refused_or_read_as_empty_cells(
        seed in any::<u64>(),
        n in 80usize..200,
        in_codes in 1usize..5,
        tg_codes in 0usize..10,
    ) {
        let mut uni = uniform(seed);
        let (c0, a, b) = (-5.0 + 10.0 * uni(), -1.0 + 2.0 * uni(), -1.0 + 2.0 * uni());
        let x: Vec<[f64; 2]> = (0..n).map(|_| [15.0 + 20.0 * uni(), 15.0 + 20.0 * uni()]).collect();
        let mut cells: Vec<[String; 3]> = x
            .iter()
            .map(|r| [format!("{}", r[0]), format!("{}", r[1]), format!("{}", c0 + a * r[0] + b * r[1])])
            .collect();
        let pick = |u: f64, k: usize| ((u * k as f64) as usize).min(k - 1);
        let mut used: Vec<f64> = Vec::new();
        let mut coded_in = vec![false; n];
        let mut coded_tg = vec![false; n];
        for _ in 0..in_codes {
            let (r, col, code) = (pick(uni(), n), pick(uni(), 2), LOGGER_CODES[pick(uni(), 10)]);
            cells[r][col] = format!("{code}");
            coded_in[r] = true;
            used.push(code);
        }
        let far: Vec<f64> = LOGGER_CODES.iter().copied().filter(|c| c.abs() >= 999.0).collect();
        for _ in 0..tg_codes {
            let (r, code) = (pick(uni(), n), far[pick(uni(), far.len())]);
            cells[r][2] = format!("{code}");
            coded_tg[r] = true;
            used.push(code);
        }
        used.sort_by(f64::total_cmp);
        used.dedup();
        // Keep at least a dozen rows with every value measured.
        let kept = (0..n).filter(|&i| !coded_in[i] && !coded_tg[i]).count();
        prop_assume!(kept >= 12 && used.len() <= MissingCodes::MAX);
        let mut text = String::from("time_s,x1_c,x2_c,y_um\n");
        for (i, c) in cells.iter().enumerate() {
            text += &format!("{},{},{},{}\n", i * 60, c[0], c[1], c[2]);
        }
        let sel = Selection { targets: vec!["y_um".into()], ..Selection::default() };
        let e = read_csv(&text, "log.csv", &sel, ReadOptions::default()).unwrap_err().to_string();
        prop_assert!(e.contains("--missing-code") && (e.contains("x1_c") || e.contains("x2_c")), "{e}");
        let opts = ReadOptions {
            missing: MissingCells::Split,
            missing_codes: MissingCodes::new(&used).unwrap(),
            ..ReadOptions::default()
        };
        let t = read_csv(&text, "log.csv", &sel, opts).unwrap();
        prop_assert_eq!(t.time_s.len(), n - coded_in.iter().filter(|&&c| c).count());
        let rows: Vec<usize> = (0..n).filter(|&i| !coded_in[i]).collect();
        for (k, &i) in rows.iter().enumerate() {
            prop_assert_eq!(t.targets[0][k].is_nan(), coded_tg[i]);
        }
        let o = IdentifyOptions { split: Split::None, families: vec![Family::Static], ..IdentifyOptions::default() };
        let id = identify(&t, &o).unwrap();
        let p = predict(&t, &id.targets[0].model).unwrap();
        for (k, &i) in rows.iter().enumerate() {
            let want = c0 + a * x[i][0] + b * x[i][1];
            prop_assert!((p[k] - want).abs() < 1e-9, "row {i}: {} vs {want}", p[k]);
        }
    }
}

/// A code inside its column's range is a value like any other (a displacement that reads
/// −99 µm among −150 … 120 µm); a column of temperatures with −99 far below them is refused.
#[test]
fn a_code_inside_the_range_is_a_value() {
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    let inside = "time_s,a_c,y_um\n0,20,-150\n60,21,-99\n120,22,120\n180,23,0\n";
    let t = read_csv(inside, "log.csv", &sel, ReadOptions::default()).unwrap();
    assert_eq!(t.targets[0], [-150.0, -99.0, 120.0, 0.0]);
    let far = "time_s,a_c,y_um\n0,20,1\n60,-99,2\n120,22,3\n180,23,4\n";
    let e = read_csv(far, "log.csv", &sel, ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("a_c = -99 on 1 row(s) (line 3)")
            && e.contains("(20 … 23)")
            && e.contains("--missing-code -99"),
        "{e}"
    );
}

/// Texts a logger or a spreadsheet writes for a missing sample (`#N/A`, `OVF`, `---`,
/// `n/a`): refused as written, each with the hint naming `--missing-code`; named (in any
/// ASCII case) with `--missing-code` and `--missing` split or hold, the table read is the
/// table of the same log with those cells empty (the reference). Random cells and marks.
#[test]
fn text_marks_are_refused_with_a_hint_or_read_as_empty_cells() {
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    let marks = ["#N/A", "OVF", "---", "n/a", "Err"];
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()))
    };
    for seed in [1u64, 2, 3, 4, 5, 6, 7, 8, rand_seed()] {
        let mut uni = uniform(seed);
        let n = 60 + (uni() * 60.0) as usize;
        let mut marked = String::from("time_s,a_c,b_c,y_um\n");
        let mut empty = marked.clone();
        let mut first: Option<&str> = None;
        for i in 0..n {
            let mut cells = [
                format!("{:.3}", 20.0 + 3.0 * uni()),
                format!("{:.3}", 22.0 + 2.0 * uni()),
                format!("{:.3}", 5.0 * uni()),
            ];
            let mut blank = cells.clone();
            // Rows 0–2 and every row with a mark in an input stay out of the comparison
            // only through the missing-cell rule, the same for both logs.
            if i > 2 && uni() < 0.15 {
                let col = ((uni() * 3.0) as usize).min(2);
                let mark = marks[((uni() * marks.len() as f64) as usize).min(marks.len() - 1)];
                cells[col] = if uni() < 0.5 {
                    mark.to_string()
                } else {
                    mark.to_lowercase()
                };
                blank[col] = String::new();
                first.get_or_insert(mark);
            }
            marked += &format!("{},{}\n", i * 60, cells.join(","));
            empty += &format!("{},{}\n", i * 60, blank.join(","));
        }
        let Some(_) = first else { continue };
        let e = read_csv(&marked, "log.csv", &sel, ReadOptions::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("is not a number (a logger's mark for a missing sample? --missing-code="),
            "{e}"
        );
        for missing in [MissingCells::Split, MissingCells::Hold] {
            let named = ReadOptions {
                missing,
                missing_codes: MissingCodes::parse(&marks.map(String::from)).unwrap(),
                ..ReadOptions::default()
            };
            let plain = ReadOptions {
                missing,
                ..ReadOptions::default()
            };
            let got = read_csv(&marked, "log.csv", &sel, named).unwrap();
            let want = read_csv(&empty, "log.csv", &sel, plain).unwrap();
            assert!(same(&got.time_s, &want.time_s), "seed {seed}");
            for k in 0..2 {
                assert!(
                    same(&got.inputs[k], &want.inputs[k]),
                    "seed {seed} input {k}"
                );
            }
            assert!(same(&got.targets[0], &want.targets[0]), "seed {seed}");
        }
    }
}

/// A fresh seed per run (printed on failure through the assertion messages).
fn rand_seed() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(9)
}
