//! Values standing far apart from their column's others (an open Pt100 at 850 °C, an int16
//! overflow written as 3276.7, a probe off its surface): refused as a sensor fault, fitted
//! as written with `keep_far_values`, read as empty cells when named with `--missing-code`.
//! The reference is the construction: a group injected with a gap of more than 30 spans of
//! the column's other values must be refused, one with a gap of at most 7.5 spans (half the
//! rule's 15) never is, whatever the column's shape.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use crate::common::uniform;
use gearcomp_identify::data::{read_csv, MissingCells, ReadOptions, Selection, Table};
use gearcomp_identify::missing_code::MissingCodes;
use gearcomp_identify::select::Family;
use gearcomp_identify::{identify, predict, IdentifyOptions, Split};
use proptest::prelude::*;

/// Smooth inputs and an exact static law: rows of (x1, x2, y).
fn law_rows(uni: &mut impl FnMut() -> f64, n: usize) -> (Vec<[f64; 3]>, [f64; 3]) {
    let (c0, a, b) = (-5.0 + 10.0 * uni(), -1.0 + 2.0 * uni(), -1.0 + 2.0 * uni());
    let (w1, w2) = (0.01 + 0.1 * uni(), 0.01 + 0.1 * uni());
    let (p1, p2) = (6.3 * uni(), 6.3 * uni());
    let (d1, d2) = (-0.01 + 0.02 * uni(), -0.01 + 0.02 * uni());
    let rows = (0..n)
        .map(|i| {
            let t = i as f64;
            let x1 = 20.0 + 3.0 * (w1 * t + p1).sin() + d1 * t;
            let x2 = 25.0 + 2.0 * (w2 * t + p2).cos() + d2 * t;
            [x1, x2, c0 + a * x1 + b * x2]
        })
        .collect();
    (rows, [c0, a, b])
}

fn text_of(cells: &[[String; 3]]) -> String {
    let mut text = String::from("time_s,x1_c,x2_c,y_um\n");
    for (i, c) in cells.iter().enumerate() {
        text += &format!("{},{},{},{}\n", i * 60, c[0], c[1], c[2]);
    }
    text
}

fn sel() -> Selection {
    Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    }
}

const NAMES: [&str; 3] = ["x1_c", "x2_c", "y_um"];

/// A group of `g` values written into column `col` at `gap_spans` spans of the column's
/// values beyond its greatest (`up`) or least value, spread over a tenth of a span: the
/// cells, the rows and the distinct values written.
fn inject(
    uni: &mut impl FnMut() -> f64,
    rows: &[[f64; 3]],
    col: usize,
    g: usize,
    gap_spans: f64,
    up: bool,
) -> (Vec<[String; 3]>, Vec<usize>, Vec<f64>) {
    let n = rows.len();
    let (lo, hi) = rows
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), r| {
            (l.min(r[col]), h.max(r[col]))
        });
    let span = hi - lo;
    let mut cells: Vec<[String; 3]> = rows
        .iter()
        .map(|r| [0, 1, 2].map(|k| format!("{}", r[k])))
        .collect();
    let mut at: Vec<usize> = Vec::new();
    while at.len() < g {
        let r = ((uni() * n as f64) as usize).min(n - 1);
        if !at.contains(&r) {
            at.push(r);
        }
    }
    at.sort_unstable();
    let mut values = Vec::new();
    for &r in &at {
        // Rounded to 0.1: a fault reads as few distinct values (an overflow, a range end).
        let off = ((gap_spans + 0.1 * uni()) * span * 10.0).round() / 10.0;
        let v = if up { hi + off } else { lo - off };
        cells[r][col] = format!("{v}");
        values.push(v);
    }
    values.sort_by(f64::total_cmp);
    values.dedup();
    (cells, at, values)
}

fn fits_the_law(
    t: &Table,
    law: [f64; 3],
    x: &[[f64; 3]],
    kept: &[usize],
) -> Result<(), TestCaseError> {
    let o = IdentifyOptions {
        split: Split::None,
        families: vec![Family::Static],
        ..IdentifyOptions::default()
    };
    let id = identify(t, &o).unwrap();
    let p = predict(t, &id.targets[0].model).unwrap();
    for (k, &i) in kept.iter().enumerate() {
        let want = law[0] + law[1] * x[i][0] + law[2] * x[i][1];
        prop_assert!((p[k] - want).abs() < 1e-9, "row {i}: {} vs {want}", p[k]);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// A group of at most 1 % of a column (input or target) at 30–300 spans beyond the
    /// others: refused, naming the column, the first value and both ways on; kept as
    /// written with `keep_far_values`; named with `--missing-code` and `--missing split`,
    /// the rows with a far input are left out, the far target cells are rows without a
    /// measurement, and the law is recovered at every kept row to 1e-9 µm. The same group
    /// at 1–7.5 spans is read as written without a word.
    #[test]
    fn far_values_are_refused_kept_or_read_as_empty_cells(
        seed in any::<u64>(),
        n in 100usize..500,
        col in 0usize..3,
        up in any::<bool>(),
        gap in 30.0f64..300.0,
        near in 1.0f64..7.5,
    ) {
        let mut uni = uniform(seed);
        let (x, law) = law_rows(&mut uni, n);
        let g = 1 + ((uni() * (n / 100) as f64) as usize).min(n / 100 - 1);
        let (cells, at, values) = inject(&mut uni, &x, col, g, gap, up);
        prop_assume!(values.len() <= MissingCodes::MAX);
        let text = text_of(&cells);
        let e = read_csv(&text, "log.csv", &sel(), ReadOptions::default()).unwrap_err().to_string();
        prop_assert!(
            e.contains(NAMES[col]) && e.contains("--keep-far-values") && e.contains("--missing-code")
                && e.contains(&format!("{}", values[0])) && e.contains(&format!("on {g} row(s)")),
            "{e}"
        );
        let keep = ReadOptions { keep_far_values: true, ..ReadOptions::default() };
        let t = read_csv(&text, "log.csv", &sel(), keep).unwrap();
        let read = |t: &Table, i: usize| if col < 2 { t.inputs[col][i] } else { t.targets[0][i] };
        for &r in &at {
            prop_assert_eq!(format!("{}", read(&t, r)), cells[r][col].clone());
        }
        let named = ReadOptions {
            missing: MissingCells::Split,
            missing_codes: MissingCodes::new(&values).unwrap(),
            ..ReadOptions::default()
        };
        let t = read_csv(&text, "log.csv", &sel(), named).unwrap();
        let kept: Vec<usize> = (0..n).filter(|i| col == 2 || !at.contains(i)).collect();
        prop_assert_eq!(t.time_s.len(), kept.len());
        if col == 2 {
            for &r in &at {
                prop_assert!(t.targets[0][r].is_nan());
            }
        }
        fits_the_law(&t, law, &x, &kept)?;

        // Not far: the same group at 1–7.5 spans is a value like any other.
        let (cells, _, _) = inject(&mut uni, &x, col, g, near, up);
        prop_assert!(read_csv(&text_of(&cells), "log.csv", &sel(), ReadOptions::default()).is_ok());
    }
}

/// A sensor constant but for one real excursion (a step to another level and back) is not
/// judged: its other values have no span to compare the gap with. A control signal with
/// three levels, the highest on fewer than 1 % of the rows far above the others (a short
/// run at a speed the log otherwise never reaches), is refused, and read as written with
/// `keep_far_values`.
#[test]
fn a_step_is_a_value_and_a_rare_far_level_needs_keeping() {
    let n = 600;
    let mut text = String::from("time_s,x1_c,x2_c,y_um\n");
    for i in 0..n {
        let step = if (300..303).contains(&i) { 25.0 } else { 20.0 };
        let x2 = 22.0 + (i as f64 / 40.0).sin();
        text += &format!("{},{step},{x2},{}\n", i * 60, 2.0 * step - x2);
    }
    let t = read_csv(&text, "log.csv", &sel(), ReadOptions::default()).unwrap();
    assert_eq!(t.inputs[0][301], 25.0);

    let mut text = String::from("time_s,rpm_c,x2_c,y_um\n");
    for i in 0..n {
        let rpm = match i {
            0..=199 => 0.0,
            200..=299 | 305..=599 => 100.0,
            _ => 5000.0,
        };
        let x2 = 22.0 + (i as f64 / 40.0).sin();
        text += &format!("{},{rpm},{x2},{}\n", i * 60, 0.001 * rpm - x2);
    }
    let e = read_csv(&text, "log.csv", &sel(), ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("rpm_c = 5000 on 5 row(s)")
            && e.contains("(0 … 100)")
            && e.contains("--keep-far-values"),
        "{e}"
    );
    let keep = ReadOptions {
        keep_far_values: true,
        ..ReadOptions::default()
    };
    let t = read_csv(&text, "log.csv", &sel(), keep).unwrap();
    assert_eq!(t.inputs[0][302], 5000.0);
}
