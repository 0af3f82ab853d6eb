//! Every model family's building block (transforms restarted per run, deployment
//! validation, OLS / ridge / PCR) against the independent numpy implementation
//! `tests/golden/families.py` (output committed as `tests/golden/families.json`), to 1e-9
//! relative. Regenerate: `gunzip -c crates/datasets/data/fl_thermal.csv.gz > fl.csv;
//! python3 crates/identify/tests/golden/families.py fl.csv > crates/identify/tests/golden/families.json`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_core::model::Transform;
use gearcomp_identify::data::{read_csv, ReadOptions, Selection, Table};
use gearcomp_identify::select::{evaluate_fixed, FitSpec, FixedTerm};
use gearcomp_identify::{train_mask, Split};

fn table(runs: bool) -> Table {
    let text = gearcomp_datasets::fl_thermal_csv();
    let sel = Selection {
        targets: vec!["ch3_um".into()],
        run: runs.then(|| "run".to_string()),
        ..Selection::default()
    };
    if !runs {
        return read_csv(text, "fl", &sel, ReadOptions::default()).unwrap();
    }
    let mut out = String::new();
    for (i, l) in text.lines().enumerate() {
        if i == 0 {
            out += &format!("run,{l}\n");
        } else {
            let t: f64 = l.split(',').next().unwrap().parse().unwrap();
            out += &format!("{},{l}\n", (t / 28_800.0).floor() as usize);
        }
    }
    read_csv(&out, "fl runs", &sel, ReadOptions::default()).unwrap()
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1e-12)
}

#[test]
fn every_family_matches_numpy() {
    let g: serde_json::Value =
        serde_json::from_str(include_str!("../golden/families.json")).unwrap();
    let cases = g["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 16);
    for runs in [false, true] {
        let t = table(runs);
        assert_eq!(t.target_names, vec!["ch3_um"]);
        let train = if runs {
            let last = t.run_names.last().unwrap().clone();
            train_mask(&t, &Split::TestRuns(vec![last])).unwrap()
        } else {
            train_mask(&t, &Split::TimeBefore(86_400.0)).unwrap()
        };
        let scheme = if runs { "runs" } else { "rolling" };
        let mine: Vec<&serde_json::Value> =
            cases.iter().filter(|c| c["scheme"] == scheme).collect();
        assert_eq!(mine.len(), 8, "{scheme}");
        for c in mine {
            let terms: Vec<FixedTerm> = c["terms"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| {
                    let p = v[3].as_f64().unwrap();
                    FixedTerm {
                        sensor: v[0].as_u64().unwrap() as usize,
                        minus: v[1].as_u64().map(|m| m as usize),
                        transform: match v[2].as_str().unwrap() {
                            "value" => Transform::Value,
                            "lag" => Transform::FirstOrderLag { tau_s: p },
                            "delay" => Transform::Delay { delay_s: p },
                            k => panic!("{k}"),
                        },
                    }
                })
                .collect();
            let fit = match c["fit"][0].as_str().unwrap() {
                "ols" => FitSpec::Ols,
                "ridge" => FitSpec::Ridge(c["fit"][1].as_f64().unwrap()),
                "pcr" => FitSpec::Pcr(c["fit"][1].as_u64().unwrap() as usize),
                k => panic!("{k}"),
            };
            let r = evaluate_fixed(&t, &train, 3, 0, &terms, fit).unwrap();
            let name = format!("{scheme}/{}", c["family"]);
            let folds: Vec<f64> = c["fold_rmse_um"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            assert_eq!(r.fold_rmse.len(), folds.len(), "{name}");
            for (a, b) in r.fold_rmse.iter().zip(&folds) {
                assert!(close(*a, *b), "{name}: fold {a} vs numpy {b}");
            }
            assert!(
                close(r.cv_rmse, c["cv_rmse_um"].as_f64().unwrap()),
                "{name}"
            );
            let coef = c["coefficients"].as_array().unwrap();
            assert_eq!(coef.len(), r.fit.coefficients.len(), "{name}");
            for (a, b) in r.fit.coefficients.iter().zip(coef) {
                let b = b.as_f64().unwrap();
                assert!(close(*a, b), "{name}: coefficient {a} vs numpy {b}");
            }
        }
    }
}

/// The classes family (CN105397560 inside the comparison) against the numpy reference,
/// whose classes come from the max–min transitive closure (not single linkage): the
/// representatives of every fold and of all training rows equal, fold and pooled RMSE and
/// coefficients to 1e-9 relative.
#[test]
fn classes_family_matches_numpy() {
    use gearcomp_identify::select::evaluate_classes;
    use gearcomp_identify::IdentifyOptions;
    let g: serde_json::Value =
        serde_json::from_str(include_str!("../golden/families.json")).unwrap();
    let cases = g["classes_cases"].as_array().unwrap();
    assert_eq!(cases.len(), 6);
    let list = |v: &serde_json::Value| -> Vec<usize> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as usize)
            .collect()
    };
    for runs in [false, true] {
        let t = table(runs);
        let train = if runs {
            let last = t.run_names.last().unwrap().clone();
            train_mask(&t, &Split::TestRuns(vec![last])).unwrap()
        } else {
            train_mask(&t, &Split::TimeBefore(86_400.0)).unwrap()
        };
        let scheme = if runs { "runs" } else { "rolling" };
        for c in cases.iter().filter(|c| c["scheme"] == scheme) {
            let k = c["classes"].as_u64().unwrap() as usize;
            let fit = match c["fit"][0].as_str().unwrap() {
                "ols" => FitSpec::Ols,
                "ridge" => FitSpec::Ridge(c["fit"][1].as_f64().unwrap()),
                f => panic!("{f}"),
            };
            let r =
                evaluate_classes(&t, &train, 3, 0, k, &IdentifyOptions::default(), fit).unwrap();
            let name = format!("{scheme}/{k} classes");
            assert_eq!(r.representatives, list(&c["representatives"]), "{name}");
            let folds: Vec<Vec<usize>> = c["fold_representatives"]
                .as_array()
                .unwrap()
                .iter()
                .map(list)
                .collect();
            assert_eq!(r.fold_representatives, folds, "{name}");
            for (a, b) in r
                .result
                .fold_rmse
                .iter()
                .zip(c["fold_rmse_um"].as_array().unwrap())
            {
                assert!(
                    close(*a, b.as_f64().unwrap()),
                    "{name}: fold {a} vs numpy {b}"
                );
            }
            assert!(
                close(r.result.cv_rmse, c["cv_rmse_um"].as_f64().unwrap()),
                "{name}"
            );
            let coef = c["coefficients"].as_array().unwrap();
            assert_eq!(coef.len(), r.result.fit.coefficients.len(), "{name}");
            for (a, b) in r.result.fit.coefficients.iter().zip(coef) {
                let b = b.as_f64().unwrap();
                assert!(close(*a, b), "{name}: coefficient {a} vs numpy {b}");
            }
        }
    }
}
