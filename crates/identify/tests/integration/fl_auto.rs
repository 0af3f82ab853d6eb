//! FL_THERMAL with the default (every family, rolling-origin validation on the first 24 h):
//! every choice is made on the training rows only — scrambling the test rows leaves the
//! model file unchanged — and the figures measured are guarded.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::{identify, plain_least_squares, IdentifyOptions, Split};

fn table() -> Table {
    let text = gearcomp_datasets::fl_thermal_csv();
    let sel = Selection {
        targets: vec!["ch1_um".into(), "ch3_um".into(), "ch5_um".into()],
        ..Selection::default()
    };
    read_csv(text, "fl_thermal", &sel, ReadOptions::default()).unwrap()
}

#[test]
fn fl_thermal_default_uses_training_rows_only_and_at_most_8_sensors() {
    let t = table();
    let id = identify(&t, &IdentifyOptions::default()).unwrap();
    // Scramble every test row (inputs and targets): reverse, shift and add noise-like terms.
    let mut s = t.clone();
    let test: Vec<usize> = (0..s.time_s.len())
        .filter(|&i| s.time_s[i] >= 86_400.0)
        .collect();
    for col in s.inputs.iter_mut().chain(s.targets.iter_mut()) {
        let vals: Vec<f64> = test.iter().map(|&i| col[i]).collect();
        for (k, &i) in test.iter().enumerate() {
            col[i] = vals[vals.len() - 1 - k] * 1.3 + ((k * 7919) % 13) as f64;
        }
    }
    let id2 = identify(&s, &IdentifyOptions::default()).unwrap();
    for (a, b) in id.targets.iter().zip(&id2.targets) {
        assert_eq!(
            a.model, b.model,
            "{}: the model depends on test rows",
            a.target
        );
        assert_eq!(a.family, b.family);
        assert_eq!(a.cv_rmse, b.cv_rmse);
        assert_ne!(
            a.test_rmse, b.test_rmse,
            "the scramble must reach the test rows"
        );
    }
    let base = plain_least_squares(&t, &Split::TimeBefore(86_400.0)).unwrap();
    // The targets (2.0 / 3.7 / 3.5 µm) are NOT met without looking at the test
    // period (docs/identification.md gives the figures and the reason; not even by the best
    // family chosen by its test figure over nine validation layouts: ch1 2.122, ch3 4.404). Measured with the
    // nested selection: ch1 3.666, ch3 4.926, ch5 3.720 µm; plain LS on all 16 inputs
    // 3.937, 7.476, 16.471 µm (before the nested selection: 2.775, 9.403, 5.996 µm).
    // The stacked families (convex weights on the families' out-of-fold predictions,
    // validated with weights fitted on the other folds) validate worse here than lead-lag
    // (3.055 / 4.094 / 10.551 µm; ch5 was 10.760 before a member's k-step model became the
    // best-fitting of the k-step paths, `select::best_fitting`) and are not kept; with them
    // forced the test figures would be 3.900 / 7.296 / 3.720 µm (docs/identification.md,
    // variants table).
    let targets = [2.0, 3.7, 3.5];
    let measured = [3.666, 4.926, 3.720];
    let stack_val = [3.055, 4.094, 10.551];
    for (j, m) in id.targets.iter().enumerate() {
        let test = m.test_rmse.unwrap();
        let ls = base[j].1.unwrap();
        println!(
            "{}: {} {} sensors, validation {:.3}, test {test:.3} µm (target {}, plain LS {ls:.3})",
            m.target,
            m.family,
            m.sensors.len(),
            m.cv_rmse,
            targets[j],
        );
        assert!(m.sensors.len() <= 8, "{}", m.target);
        assert!(m.model.channels().len() <= 8, "{}", m.target);
        assert!(test < ls, "{}: {test} vs plain LS {ls}", m.target);
        assert!((test - measured[j]).abs() < 5e-3, "{}: {test}", m.target);
        assert!(m.fold_rmse.len() == 3 && m.fold_rmse.iter().all(|v| v.is_finite()));
        let st = m
            .comparison
            .iter()
            .find(|c| c.family.starts_with("stacked"))
            .unwrap();
        println!("{}: stack validation {:.3}", m.target, st.cv_rmse);
        assert!(st.sensors <= 8 && !st.kept, "{}: {st:?}", m.target);
        assert!(
            (st.cv_rmse - stack_val[j]).abs() < 5e-3,
            "{}: {st:?}",
            m.target
        );
        assert_eq!(st.fold_rmse.len(), 3);
    }
    assert!(id.method.contains("rolling origin"), "{}", id.method);

    // Extrapolation: no training row is outside the envelope; the 5000 rpm period
    // (24 h … 28 h, above the 3750 rpm of training) is flagged.
    for m in &id.targets {
        let (mut tr_out, mut hot, mut hot_out) = (0, 0, 0);
        for (i, &o) in m.outside.iter().enumerate() {
            let h = t.time_s[i] / 3600.0;
            if h < 24.0 && o {
                tr_out += 1;
            }
            if (24.0..28.0).contains(&h) {
                hot += 1;
                hot_out += usize::from(o);
            }
        }
        println!(
            "{}: outside on training {tr_out}, 5000 rpm {hot_out}/{hot}",
            m.target
        );
        assert_eq!(tr_out, 0, "{}", m.target);
        assert!(hot_out * 2 > hot, "{}: {hot_out}/{hot}", m.target);
        assert!(m.interval_um.iter().all(|v| v.is_finite() && *v > 0.0));
    }
}
