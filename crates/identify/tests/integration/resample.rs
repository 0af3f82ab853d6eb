//! Bin means of long high-rate logs (`Table::resample`, `resample::search_step_s`).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, read_runs, ReadOptions, Selection, Table};
use gearcomp_identify::pipeline::DYNAMIC_SEARCH_BUDGET;
use gearcomp_identify::resample::{search_step_s, BINS_PER_TAU};
use gearcomp_identify::IdentifyOptions;
use proptest::prelude::*;
use std::collections::BTreeMap;

fn uni(s: &mut u64) -> f64 {
    *s ^= *s << 13;
    *s ^= *s >> 7;
    *s ^= *s << 17;
    (*s >> 11) as f64 / (1u64 << 53) as f64
}

/// A log of 1–3 runs (files) with irregular steps, a gap or two, and a target measured on
/// some rows only.
fn log(seed: u64, rows: usize) -> Table {
    let mut s = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    let files = 1 + (uni(&mut s) * 3.0) as usize;
    let texts: Vec<(String, String)> = (0..files)
        .map(|f| {
            let mut text = String::from("time_s,a_c,b_c,y_um\n");
            let mut t = 100.0 * uni(&mut s);
            for _ in 0..rows {
                t += if uni(&mut s) < 0.01 {
                    900.0
                } else {
                    0.5 + 3.0 * uni(&mut s)
                };
                let y = if uni(&mut s) < 0.3 {
                    String::new()
                } else {
                    format!("{}", 10.0 * uni(&mut s))
                };
                text += &format!("{t},{},{},{y}\n", 20.0 + uni(&mut s), 30.0 + uni(&mut s));
            }
            (text, format!("run{f}.csv"))
        })
        .collect();
    let refs: Vec<(&str, &str)> = texts
        .iter()
        .map(|(t, n)| (t.as_str(), n.as_str()))
        .collect();
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    if files == 1 {
        read_csv(refs[0].0, refs[0].1, &sel, ReadOptions::default()).unwrap()
    } else {
        read_runs(&refs, &sel, ReadOptions::default()).unwrap()
    }
}

proptest! {
    /// Every bin of the resampled table is the mean of the rows of one segment whose
    /// (time − segment start) / step has the same integer part, on one side of the cut,
    /// at the time, line and run of its last row; built here by grouping rows in a map.
    #[test]
    fn bins_are_the_means_of_their_rows(seed in any::<u64>(), rows in 20usize..400, step in 0.5f64..40.0, cut_frac in prop::option::of(0.0f64..1.0)) {
        let t = log(seed, rows);
        let n = t.time_s.len();
        let cut = cut_frac.map(|f| t.time_s[0] + f * (t.time_s[n - 1] - t.time_s[0]));
        let r = t.resample(step, cut).unwrap();
        // Reference: key (segment, bin index, after the cut) → rows, in row order.
        let mut seg_of = vec![0usize; n];
        for (k, &(s, e)) in t.segment_ranges().iter().enumerate() {
            for x in &mut seg_of[s..e] {
                *x = k;
            }
        }
        let seg_start: Vec<f64> = t.segment_ranges().iter().map(|&(s, _)| t.time_s[s]).collect();
        let mut groups: BTreeMap<(usize, i64, bool), Vec<usize>> = BTreeMap::new();
        for (i, (&g, &ti)) in seg_of.iter().zip(&t.time_s).enumerate() {
            let j = ((ti - seg_start[g]) / step).floor() as i64;
            groups.entry((g, j, cut.is_some_and(|c| ti >= c))).or_default().push(i);
        }
        // Bins in time order within a segment: the cut only splits a bin in two.
        let mut bins: Vec<Vec<usize>> = groups.into_values().collect();
        bins.sort_by_key(|b| b[0]);
        prop_assert_eq!(r.time_s.len(), bins.len());
        let mean = |v: &[f64], b: &[usize]| {
            let m: Vec<f64> = b.iter().map(|&i| v[i]).filter(|x| x.is_finite()).collect();
            if m.is_empty() { f64::NAN } else { m.iter().sum::<f64>() / m.len() as f64 }
        };
        let close = |a: f64, b: f64| (a.is_nan() && b.is_nan()) || (a - b).abs() <= 1e-12 * (1.0 + b.abs());
        for (k, b) in bins.iter().enumerate() {
            let last = *b.last().unwrap();
            prop_assert_eq!(r.time_s[k], t.time_s[last]);
            prop_assert_eq!(r.lines[k], t.lines[last]);
            prop_assert_eq!(r.file_of_row[k], t.file_of_row[last]);
            if let (Some(rr), Some(tr)) = (&r.runs, &t.runs) {
                prop_assert_eq!(rr[k], tr[last]);
            }
            for c in 0..2 {
                prop_assert!(close(r.inputs[c][k], mean(&t.inputs[c], b)), "input {c} bin {k}");
            }
            prop_assert!(close(r.targets[0][k], mean(&t.targets[0], b)), "target bin {k}");
        }
        // A segment starts at the first bin of each old segment.
        let firsts: Vec<usize> = bins.iter().enumerate()
            .filter(|(k, b)| *k == 0 || seg_of[b[0]] != seg_of[bins[k - 1][0]])
            .map(|(k, _)| k).collect();
        prop_assert_eq!(&r.segments, &firsts);
        prop_assert_eq!(&r.issues, &t.issues);
        prop_assert_eq!(&r.run_names, &t.run_names);
    }
}

/// The default's step: none within the budget; else the smallest multiple of the median
/// step (with a 10 % margin) that fits; none when named families, or when it would pass a
/// tenth of the shortest τ or delay; a bad step is refused naming --resample-s.
#[test]
fn the_default_step_fits_the_budget_and_the_shortest_tau() {
    let sel = Selection {
        targets: vec!["y_um".into()],
        ..Selection::default()
    };
    let mut text = String::from("time_s,a_c,b_c,c_c,y_um\n");
    for i in 0..200 {
        text += &format!("{},{},{},{},{}\n", i, i % 7, i % 5, i % 3, i % 11);
    }
    let t = read_csv(&text, "f", &sel, ReadOptions::default()).unwrap();
    let o = IdentifyOptions::default();
    let cols = 3.0 * (1 + o.taus_s.len() + o.delays_s.len()) as f64;
    // Training rows for which the cost is just within / 4.5 × over the budget.
    let within = (DYNAMIC_SEARCH_BUDGET / (cols * cols)).floor() as usize;
    assert_eq!(search_step_s(&t, within, &o), None);
    let over = (4.5 * DYNAMIC_SEARCH_BUDGET / (cols * cols)) as usize;
    let k = (1.1 * over as f64 * cols * cols / DYNAMIC_SEARCH_BUDGET).ceil();
    assert_eq!(search_step_s(&t, over, &o), Some(k * 1.0));
    assert!(over as f64 / k * cols * cols <= DYNAMIC_SEARCH_BUDGET / 1.1);
    // Beyond a tenth of the shortest τ (300 s): no step.
    let far = (25.0 * DYNAMIC_SEARCH_BUDGET / (cols * cols)) as usize;
    assert!(search_step_s(&t, far, &o).unwrap() * BINS_PER_TAU <= 300.0);
    let too_far = (400.0 * DYNAMIC_SEARCH_BUDGET / (cols * cols)) as usize;
    assert_eq!(search_step_s(&t, too_far, &o), None);
    let named = IdentifyOptions {
        families: vec![gearcomp_identify::select::Family::Static],
        ..IdentifyOptions::default()
    };
    assert_eq!(search_step_s(&t, over, &named), None);
    for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let e = t.resample(bad, None).unwrap_err().to_string();
        assert!(e.contains("--resample-s"), "{e}");
    }
}

/// `resample::for_fit`: nothing to do within the budget; an explicit step gives the bin
/// means and the note; a step leaving fewer than 10 training rows is refused naming
/// `--resample-s`; a bad split is named as before.
#[test]
fn for_fit_resamples_or_refuses_naming_the_option() {
    use gearcomp_identify::resample::for_fit;
    use gearcomp_identify::Split;
    let t = log(11, 300);
    let o = IdentifyOptions::default();
    let none = Split::None;
    assert!(for_fit(&t, &none, &o, None).unwrap().is_none());
    let (r, note) = for_fit(&t, &none, &o, Some(20.0)).unwrap().unwrap();
    // Debug text: a bin without a measured target is NaN in both.
    assert_eq!(
        format!("{r:?}"),
        format!("{:?}", t.resample(20.0, None).unwrap())
    );
    assert!(
        note.starts_with(&format!(
            "{} rows resampled to {} bin means of 20 s (--resample-s)",
            t.time_s.len(),
            r.time_s.len()
        )),
        "{note}"
    );
    let e = for_fit(&t, &none, &o, Some(1e9)).unwrap_err().to_string();
    assert!(
        e.contains("--resample-s = 1000000000 s") && e.contains("10 training rows"),
        "{e}"
    );
    let e = for_fit(&t, &Split::TestRuns(vec!["nope".into()]), &o, Some(20.0))
        .unwrap_err()
        .to_string();
    assert!(e.contains("--test-runs"), "{e}");
}
