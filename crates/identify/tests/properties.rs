//! Property tests: exact recovery (fit ∘ generate = identity), no panic on wide input.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_core::model::Transform;
use gearcomp_identify::cluster::{lambda_cut, transitive_closure, Dendrogram};
use gearcomp_identify::data::{read_csv, ReadOptions, Selection};
use gearcomp_identify::regress::ols;
use gearcomp_identify::transform::transform_series;
use nalgebra::DMatrix;
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn ols_recovers_noiseless_coefficients(b0 in -50.0..50.0f64, b1 in -5.0..5.0f64, b2 in -5.0..5.0f64, seed in 0u64..1000) {
        let n = 40;
        let x1: Vec<f64> = (0..n).map(|k| 20.0 + ((k as f64 + seed as f64) * 0.37).sin() * 3.0).collect();
        let x2: Vec<f64> = (0..n).map(|k| 25.0 + ((k as f64) * 0.11 + seed as f64).cos() * 2.0).collect();
        let y: Vec<f64> = (0..n).map(|k| b0 + b1 * x1[k] + b2 * x2[k]).collect();
        let f = ols(&[&x1, &x2], &y, &[]).unwrap();
        prop_assert!((f.coefficients[0] - b0).abs() < 1e-7 * (1.0 + b0.abs()));
        prop_assert!((f.coefficients[1] - b1).abs() < 1e-8 * (1.0 + b1.abs()));
        prop_assert!((f.coefficients[2] - b2).abs() < 1e-8 * (1.0 + b2.abs()));
    }

    #[test]
    fn csv_reader_never_panics(text in "[0-9a-z_,.\\-\\n eE]{0,200}") {
        let sel = Selection { inputs: vec!["*".into()], ..Selection::default() };
        let _ = read_csv(&text, "fuzz", &sel, ReadOptions::default());
        let _ = read_csv(&format!("time_s,a_c,b_um\n{text}"), "fuzz",
            &Selection { targets: vec!["b_um".into()], ..Selection::default() },
            ReadOptions { skip_bad_rows: true, ..ReadOptions::default() });
    }

    #[test]
    fn rate_of_a_constant_is_zero_and_lag_stays_in_range(c in -100.0..100.0f64, tau in 1.0..1e4f64,
            u in proptest::collection::vec(-50.0..50.0f64, 2..40)) {
        let t: Vec<f64> = (0..u.len()).map(|k| 15.0 * k as f64).collect();
        let r = transform_series(&t, &vec![c; u.len()], Transform::Rate { tau_s: tau }).unwrap();
        prop_assert!(r.iter().all(|v| v.abs() < 1e-12 * (1.0 + c.abs())));
        let l = transform_series(&t, &u, Transform::FirstOrderLag { tau_s: tau }).unwrap();
        let (lo, hi) = u.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| (a.0.min(v), a.1.max(v)));
        prop_assert!(l.iter().all(|v| *v >= lo - 1e-9 && *v <= hi + 1e-9));
    }

    #[test]
    fn dendrogram_cuts_are_closure_lambda_cuts(vals in proptest::collection::vec(0.0..1.0f64, 15)) {
        let c = 6;
        let mut r = DMatrix::identity(c, c);
        let mut k = 0;
        for i in 0..c { for j in i + 1..c { r[(i, j)] = vals[k]; r[(j, i)] = vals[k]; k += 1; } }
        let (t, _) = transitive_closure(&r);
        let d = Dendrogram::single_linkage(&r);
        for (m, merge) in d.merges.iter().enumerate() {
            let classes = d.classes(c - m - 1).unwrap();
            prop_assert_eq!(classes.iter().map(Vec::len).sum::<usize>(), c);
            // Equal levels can merge several classes at one λ; compare only strict levels.
            if d.merges.get(m + 1).is_none_or(|n| n.level < merge.level) {
                prop_assert_eq!(lambda_cut(&t, merge.level), classes);
            }
        }
    }
}
