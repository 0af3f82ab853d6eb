//! FL_THERMAL (real 46 h spindle test): train on time_s < 86400, test on the rest.
//! The identified model must beat plain least squares on all 16 temperatures on every
//! channel with fewer sensors; the plain-LS floor is reproduced here too. Coefficients are
//! compared with the independent numpy implementation (bench/identify/reference.py, output
//! committed in tests/data/numpy_reference.json).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_core::model::Transform;
use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::regress::ols;
use gearcomp_identify::transform::transform_series;
use gearcomp_identify::{identify, plain_least_squares, IdentifyOptions, Split};

fn table() -> Table {
    let text = gearcomp_datasets::fl_thermal_csv();
    let sel = Selection {
        targets: vec!["ch*_um".into()],
        ..Selection::default()
    };
    read_csv(text, "fl_thermal", &sel, ReadOptions::default()).unwrap()
}

fn golden() -> serde_json::Value {
    serde_json::from_str(include_str!("../data/numpy_reference.json")).unwrap()
}

fn rel_close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * b.abs().max(1e-300)
}

#[test]
fn fl_thermal_identified_model_beats_plain_least_squares_with_fewer_sensors() {
    let t = table();
    assert_eq!(t.input_names.len(), 16);
    assert_eq!(
        t.target_names,
        vec!["ch1_um", "ch2_um", "ch3_um", "ch4_um", "ch5_um"]
    );
    // Plain LS on all 16 temperatures: the data README's figures for time_s < 86400.
    let base = plain_least_squares(&t, &Split::TimeBefore(86_400.0)).unwrap();
    let readme = [3.937, 3.738, 7.476, 7.103, 16.471];
    for (b, r) in base.iter().zip(readme) {
        assert!(
            (b.1.unwrap() - r).abs() < 5e-4,
            "baseline {b:?} vs README {r}"
        );
    }
    let id = identify(&t, &dynamic()).unwrap();
    // The issue's thresholds for ch1, ch3, ch5 and the README floor for all five.
    let issue = [3.95, f64::NAN, 7.54, f64::NAN, 16.6];
    for (j, m) in id.targets.iter().enumerate() {
        let test = m.test_rmse.unwrap();
        assert!(
            test < readme[j],
            "{}: test RMSE {test} ≥ plain LS {}",
            m.target,
            readme[j]
        );
        if issue[j].is_finite() {
            assert!(test < issue[j]);
        }
        assert!(
            m.sensors.len() < 16,
            "{}: {} sensors",
            m.target,
            m.sensors.len()
        );
        assert!(
            m.train_rmse < 1.5,
            "{}: train RMSE {}",
            m.target,
            m.train_rmse
        );
    }
}

#[test]
fn fl_thermal_selection_and_coefficients_match_numpy_reference() {
    let t = table();
    let g = golden();
    let id = identify(&t, &dynamic()).unwrap();
    for (j, m) in id.targets.iter().enumerate() {
        let r = &g["channels"][j];
        let sensors: Vec<usize> = r["sensors"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(m.sensors, sensors, "{}", m.target);
        assert_eq!(m.tau_s, r["tau_s"].as_f64());
        assert_eq!(m.classes.len(), r["classes"].as_u64().unwrap() as usize);
        // CV by QR reduction here, by direct lstsq per fold in numpy.
        assert!(rel_close(
            m.cv_rmse,
            r["cv_rmse_um"].as_f64().unwrap(),
            1e-9
        ));
        let coef: Vec<f64> = r["coefficients"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(coef.len(), m.fit.coefficients.len());
        for (a, b) in m.fit.coefficients.iter().zip(&coef) {
            assert!(rel_close(*a, *b, 1e-9), "{}: {a} vs numpy {b}", m.target);
        }
        assert!(rel_close(
            m.test_rmse.unwrap(),
            r["test_rmse_um"].as_f64().unwrap(),
            1e-9
        ));
        assert!(rel_close(
            m.train_rmse,
            r["train_rmse_um"].as_f64().unwrap(),
            1e-9
        ));
    }
}

#[test]
fn ols_coefficients_match_numpy_for_seed_vector_and_a_fixed_fl_thermal_case() {
    let g = golden();
    let s = &g["seed003"];
    let tt = [
        [20.0, 21.0, 24.0],
        [21.0, 23.1, 24.6],
        [22.0, 25.2, 25.5],
        [21.5, 26.7, 26.9],
        [20.5, 27.9, 28.0],
        [20.0, 28.4, 29.4],
        [21.0, 29.0, 30.5],
        [22.5, 29.3, 31.2],
    ];
    let ta = [38.0, 41.9, 45.6, 48.8, 50.3, 51.2, 52.9, 54.6];
    let cols: Vec<Vec<f64>> = (0..3).map(|j| tt.iter().map(|r| r[j]).collect()).collect();
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    let f = ols(&refs, &ta, &[]).unwrap();
    for (a, b) in f
        .coefficients
        .iter()
        .zip(s["coefficients"].as_array().unwrap())
    {
        assert!(rel_close(*a, b.as_f64().unwrap(), 1e-9), "{a} vs {b}");
    }
    assert!(rel_close(f.sse, s["q"].as_f64().unwrap(), 1e-9));

    // ch1 on numpy's chosen sensors, value + rate(τ), built here without the pipeline.
    let t = table();
    let r = &g["channels"][0];
    let tau_s = r["tau_s"].as_f64().unwrap();
    let train: Vec<usize> = (0..t.time_s.len())
        .filter(|&i| t.time_s[i] < 86_400.0)
        .collect();
    let mut cols = Vec::new();
    for s in r["sensors"].as_array().unwrap() {
        let x = &t.inputs[s.as_u64().unwrap() as usize];
        let rate = transform_series(&t.time_s, x, Transform::Rate { tau_s }).unwrap();
        cols.push(train.iter().map(|&i| x[i]).collect::<Vec<f64>>());
        cols.push(train.iter().map(|&i| rate[i]).collect::<Vec<f64>>());
    }
    let y: Vec<f64> = train.iter().map(|&i| t.targets[0][i]).collect();
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    let f = ols(&refs, &y, &[]).unwrap();
    for (a, b) in f
        .coefficients
        .iter()
        .zip(r["coefficients"].as_array().unwrap())
    {
        assert!(rel_close(*a, b.as_f64().unwrap(), 1e-9), "{a} vs {b}");
    }
}

/// The lead–lag family with the 3-block cross-validation the numpy reference implements.
fn dynamic() -> IdentifyOptions {
    IdentifyOptions {
        model: gearcomp_identify::ModelKind::Dynamic,
        ..IdentifyOptions::default()
    }
}
