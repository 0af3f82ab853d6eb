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

/// Three runs of random sinusoidal inputs and a known lagged linear truth
/// y = c0 + a·x1 + b·lag(x2, τ), the lag restarted in each run (built here, not by the crate).
fn lagged_runs(c0: f64, a: f64, b: f64, tau: f64, seed: u64) -> String {
    let mut s = String::from("run,time_s,x1_c,x2_c,x3_c,y_um\n");
    for r in 0..3u64 {
        let mut lag = f64::NAN;
        let ph = (seed + 3 * r) as f64;
        for i in 0..200 {
            let t = 60.0 * i as f64;
            let x1 = 20.0 + 3.0 * (t / (1100.0 + 37.0 * ph) + ph).sin();
            let x2 = 25.0 + 4.0 * (t / (2300.0 + 11.0 * ph) + 0.3 * ph).cos();
            let x3 = 22.0 + 2.0 * (t / 700.0 + 0.7 * ph).sin();
            lag = if i == 0 {
                x2
            } else {
                lag + (1.0 - (-60.0 / tau).exp()) * (x2 - lag)
            };
            s += &format!("{r},{t},{x1},{x2},{x3},{}\n", c0 + a * x1 + b * lag);
        }
    }
    s
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    #[test]
    fn default_recovers_a_random_lagged_truth_on_held_out_runs(
        c0 in -20.0..20.0f64, a in 0.5..5.0f64, b in 0.5..5.0f64,
        ti in 0usize..8, seed in 0u64..1000,
    ) {
        use gearcomp_identify::{identify, IdentifyOptions, Split};
        let tau = IdentifyOptions::default().taus_s[ti];
        let text = lagged_runs(c0, a, b, tau, seed);
        let sel = Selection { targets: vec!["y_um".into()], run: Some("run".into()), ..Selection::default() };
        let t = read_csv(&text, "lagged", &sel, ReadOptions::default()).unwrap();
        let id = identify(&t, &IdentifyOptions { split: Split::TestRuns(vec!["2".into()]), ..IdentifyOptions::default() }).unwrap();
        let m = &id.targets[0];
        prop_assert!(m.test_rmse.unwrap() < 1e-6 * (1.0 + b), "{} {:?}", m.family, m.test_rmse);
        prop_assert!(m.sensors.len() <= 3);
    }

    #[test]
    fn invalid_splits_and_inputs_give_clear_errors(
        which in 0usize..4, run in "[a-z]{1,4}", hours in 1.0e3..1.0e5f64, seed in 0u64..100,
    ) {
        use gearcomp_identify::{identify, IdentifyOptions, Split};
        let text = lagged_runs(1.0, 1.0, 1.0, 600.0, seed);
        let sel = Selection { targets: vec!["y_um".into()], run: Some("run".into()), ..Selection::default() };
        let t = read_csv(&text, "lagged", &sel, ReadOptions::default()).unwrap();
        let (split, expect) = match which {
            0 => (Split::TestRuns(vec![run.clone()]), "--test-runs"),
            1 => (Split::TimeBefore(hours * 3600.0), "--train-before-h"),
            2 => (Split::TestRuns(vec!["0".into(), "1".into(), "2".into()]), "training rows"),
            _ => (Split::None, "inputs"),
        };
        let mut t = t;
        if which == 3 {
            for x in &mut t.inputs { x.iter_mut().for_each(|v| *v = 21.0); }
        }
        let e = identify(&t, &IdentifyOptions { split, ..IdentifyOptions::default() }).unwrap_err();
        prop_assert!(e.to_string().contains(expect), "{e}");
    }
}
