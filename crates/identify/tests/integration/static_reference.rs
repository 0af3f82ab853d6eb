//! The CN105397560 static pipeline (`gearcomp fit --model static --classes k`) on random
//! tables against an independent construction written here: Pearson |r| by the two-pass
//! definition, k classes by single linkage (Kruskal on |r|, strongest first), each class's
//! representative by the largest |r| with the target, least squares by nalgebra's SVD (not
//! a QR), validation by contiguous time blocks fitted afresh, the floor (plain least
//! squares on every input) by SVD, and the envelope's test rows outside by the Mahalanobis
//! distance from the inverse of the centred cross-product matrix. Fixed seeds, then fresh
//! ones (proptest); invalid class counts and fold counts are refused naming the option.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::data::Table;
use gearcomp_identify::pipeline::identify_with_floor;
use gearcomp_identify::{IdentifyOptions, ModelKind, Split};
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;

use crate::common::uniform;

struct Case {
    table: Table,
    split_s: f64,
    classes: usize,
}

/// A random table: 4–14 temperatures that drift together in 2–4 groups with their own
/// noise, 1–3 targets linear in a few of them plus noise, one row a minute.
fn random_case(seed: u64) -> Case {
    let mut u = uniform(seed);
    let mut int = |a: usize, b: usize| a + ((u() * (b - a + 1) as f64) as usize).min(b - a);
    let n = int(200, 1500);
    let c = int(4, 14);
    let groups = int(2, 4);
    let k = int(2, c - 1);
    let targets = int(1, 3);
    let mut u = uniform(seed ^ 0x5eed);
    let mut walks = vec![0.0f64; groups];
    let mut drift = vec![Vec::with_capacity(n); groups];
    for _ in 0..n {
        for (g, w) in walks.iter_mut().enumerate() {
            *w += 0.1 * (u() - 0.5);
            drift[g].push(*w);
        }
    }
    let inputs: Vec<Vec<f64>> = (0..c)
        .map(|j| {
            let g = j % groups;
            let gain = 0.5 + 2.0 * u();
            let noise = 0.02 + 0.3 * u();
            (0..n)
                .map(|i| 20.0 + j as f64 + gain * drift[g][i] + noise * (u() - 0.5))
                .collect()
        })
        .collect();
    let ys: Vec<Vec<f64>> = (0..targets)
        .map(|_| {
            let b: Vec<f64> = (0..c)
                .map(|_| if u() < 0.4 { 6.0 * (u() - 0.5) } else { 0.0 })
                .collect();
            (0..n)
                .map(|i| 2.0 + (0..c).map(|j| b[j] * inputs[j][i]).sum::<f64>() + (u() - 0.5))
                .collect()
        })
        .collect();
    let table = Table {
        time_s: (0..n).map(|i| 60.0 * i as f64).collect(),
        input_names: (0..c).map(|j| format!("t{j}_c")).collect(),
        inputs,
        target_names: (0..targets).map(|j| format!("y{j}_um")).collect(),
        targets: ys,
        segments: vec![0],
        ..Table::default()
    };
    Case {
        table,
        split_s: 60.0 * (n * 2 / 3) as f64,
        classes: k,
    }
}

fn pearson_abs(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let syy: f64 = y.iter().map(|b| (b - my).powi(2)).sum();
    (sxy / (sxx * syy).sqrt()).abs()
}

/// Single linkage into `k` classes: edges by |r| from the strongest, joined until `k`
/// components remain (Kruskal), each class sorted, classes by their first member.
fn single_linkage(cols: &[Vec<f64>], k: usize) -> Vec<Vec<usize>> {
    let c = cols.len();
    let mut edges: Vec<(f64, usize, usize)> = Vec::new();
    for i in 0..c {
        for j in i + 1..c {
            edges.push((pearson_abs(&cols[i], &cols[j]), i, j));
        }
    }
    edges.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut comp: Vec<usize> = (0..c).collect();
    let mut count = c;
    for (_, i, j) in edges {
        if count == k {
            break;
        }
        let (a, b) = (comp[i], comp[j]);
        if a != b {
            for x in comp.iter_mut() {
                if *x == b {
                    *x = a;
                }
            }
            count -= 1;
        }
    }
    let mut classes: Vec<Vec<usize>> = Vec::new();
    for i in 0..c {
        match classes.iter_mut().find(|cl| comp[cl[0]] == comp[i]) {
            Some(cl) => cl.push(i),
            None => classes.push(vec![i]),
        }
    }
    classes
}

/// Least squares with intercept by SVD (faer's, through `gearcomp_linalg`; the static
/// pipeline solves by Householder QR): the coefficients (intercept first). nalgebra's own SVD
/// was the reference once and missed the optimum by 1e-4 relative in an intercept on a fresh
/// seed (its factors can miss A by 1e-2, dimforge/nalgebra#1172).
fn lstsq(cols: &[&[f64]], y: &[f64]) -> Vec<f64> {
    let n = y.len();
    let a = DMatrix::from_fn(
        n,
        cols.len() + 1,
        |i, j| if j == 0 { 1.0 } else { cols[j - 1][i] },
    );
    let svd = gearcomp_linalg::Svd::new(&a).unwrap();
    let eps = 1e-12 * svd.singular_values[0];
    svd.solve(&DVector::from_column_slice(y), eps)
        .iter()
        .copied()
        .collect()
}

fn predict(b: &[f64], cols: &[&[f64]], i: usize) -> f64 {
    b[0] + cols
        .iter()
        .zip(&b[1..])
        .map(|(x, bj)| x[i] * bj)
        .sum::<f64>()
}

fn rows(x: &[f64], mask: &[bool]) -> Vec<f64> {
    x.iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(v, _)| *v)
        .collect()
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

fn check(seed: u64) -> Result<(), String> {
    let case = random_case(seed);
    let t = &case.table;
    let folds = 3;
    let opts = IdentifyOptions {
        model: ModelKind::Static,
        classes: Some(case.classes),
        folds,
        split: Split::TimeBefore(case.split_s),
        ..IdentifyOptions::default()
    };
    let (id, floor) = identify_with_floor(t, &opts).map_err(|e| format!("seed {seed}: {e}"))?;
    let n = t.time_s.len();
    let train: Vec<bool> = t.time_s.iter().map(|&s| s < case.split_s).collect();
    let tr_inputs: Vec<Vec<f64>> = t.inputs.iter().map(|x| rows(x, &train)).collect();
    let classes = single_linkage(&tr_inputs, case.classes);
    // Contiguous blocks of equal time span over the training period.
    let ttr = rows(&t.time_s, &train);
    let (t0, t1) = (ttr[0], ttr[ttr.len() - 1]);
    let span = (t1 - t0) / folds as f64;
    let block: Vec<usize> = ttr
        .iter()
        .map(|&s| (((s - t0) / span).floor() as usize).min(folds - 1))
        .collect();
    let all: Vec<&[f64]> = t.inputs.iter().map(|x| x.as_slice()).collect();
    for (j, m) in id.targets.iter().enumerate() {
        let y = &t.targets[j];
        let ytr = rows(y, &train);
        let mut want_classes = classes.clone();
        let mut got_classes = m.classes.clone();
        for cl in want_classes.iter_mut().chain(got_classes.iter_mut()) {
            cl.sort_unstable();
        }
        want_classes.sort();
        got_classes.sort();
        if want_classes != got_classes {
            return Err(format!(
                "seed {seed} {}: classes {got_classes:?} vs {want_classes:?}",
                m.target
            ));
        }
        let mut reps: Vec<usize> = classes
            .iter()
            .map(|cl| {
                *cl.iter()
                    .max_by(|&&a, &&b| {
                        pearson_abs(&tr_inputs[a], &ytr)
                            .total_cmp(&pearson_abs(&tr_inputs[b], &ytr))
                    })
                    .unwrap()
            })
            .collect();
        reps.sort_unstable();
        let mut got = m.sensors.clone();
        got.sort_unstable();
        if got != reps {
            return Err(format!(
                "seed {seed} {}: sensors {got:?} vs {reps:?}",
                m.target
            ));
        }
        // The model, term by term (the sensor order of the model is the kept one).
        let cols: Vec<&[f64]> = m.sensors.iter().map(|&s| tr_inputs[s].as_slice()).collect();
        let b = lstsq(&cols, &ytr);
        let scale = ytr.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if !close(m.model.intercept, b[0], 1e-6) {
            return Err(format!(
                "seed {seed}: intercept {} vs {}",
                m.model.intercept, b[0]
            ));
        }
        for (term, want) in m.model.terms.iter().zip(&b[1..]) {
            if !close(term.coefficient, *want, 1e-6) {
                return Err(format!(
                    "seed {seed}: {} {} vs {want}",
                    term.channel, term.coefficient
                ));
            }
        }
        // Test RMSE from the reference coefficients.
        let full: Vec<&[f64]> = m.sensors.iter().map(|&s| t.inputs[s].as_slice()).collect();
        let test_sse: f64 = (0..n)
            .filter(|&i| !train[i])
            .map(|i| (y[i] - predict(&b, &full, i)).powi(2))
            .sum();
        let test_rmse = (test_sse / (n - ytr.len()) as f64).sqrt();
        if !close(m.test_rmse.unwrap(), test_rmse, 1e-7 * (1.0 + scale)) {
            return Err(format!(
                "seed {seed}: test {:?} vs {test_rmse}",
                m.test_rmse
            ));
        }
        // Validation: each block predicted by a fit on the other blocks.
        let mut sse_all = 0.0;
        for f in 0..folds {
            let fit_rows: Vec<bool> = block.iter().map(|&g| g != f).collect();
            let fc: Vec<Vec<f64>> = cols.iter().map(|x| rows(x, &fit_rows)).collect();
            let fr: Vec<&[f64]> = fc.iter().map(|v| v.as_slice()).collect();
            let bf = lstsq(&fr, &rows(&ytr, &fit_rows));
            let (mut sse, mut cnt) = (0.0, 0usize);
            for i in (0..ytr.len()).filter(|&i| block[i] == f) {
                sse += (ytr[i] - predict(&bf, &cols, i)).powi(2);
                cnt += 1;
            }
            sse_all += sse;
            let fold_rmse = (sse / cnt.max(1) as f64).sqrt();
            if !close(m.fold_rmse[f], fold_rmse, 1e-6) {
                return Err(format!(
                    "seed {seed}: fold {f} {} vs {fold_rmse}",
                    m.fold_rmse[f]
                ));
            }
        }
        let cv = (sse_all / ytr.len() as f64).sqrt();
        if !close(m.cv_rmse, cv, 1e-6) {
            return Err(format!("seed {seed}: validation {} vs {cv}", m.cv_rmse));
        }
        // The floor: least squares on every input.
        let tr_all: Vec<&[f64]> = tr_inputs.iter().map(|v| v.as_slice()).collect();
        let bl = lstsq(&tr_all, &ytr);
        let (mut s_tr, mut s_te) = (0.0, 0.0);
        for i in 0..n {
            let e2 = (y[i] - predict(&bl, &all, i)).powi(2);
            if train[i] {
                s_tr += e2;
            } else {
                s_te += e2;
            }
        }
        let (f_tr, f_te) = (
            (s_tr / ytr.len() as f64).sqrt(),
            (s_te / (n - ytr.len()) as f64).sqrt(),
        );
        if !close(floor[j].0, f_tr, 1e-6) || !close(floor[j].1.unwrap(), f_te, 1e-6) {
            return Err(format!(
                "seed {seed}: floor {:?} vs ({f_tr}, {f_te})",
                floor[j]
            ));
        }
        // Envelope: a test row is outside when a sensor leaves its training range or its
        // Mahalanobis distance exceeds every training row's.
        let p = m.sensors.len();
        let mean: Vec<f64> = cols
            .iter()
            .map(|x| x.iter().sum::<f64>() / x.len() as f64)
            .collect();
        let xc = DMatrix::from_fn(ytr.len(), p, |i, q| cols[q][i] - mean[q]);
        let s_inv = (xc.transpose() * &xc).try_inverse().unwrap();
        let d2 = |i: usize| {
            let v = DVector::from_fn(p, |q, _| full[q][i] - mean[q]);
            (ytr.len() - 1) as f64 * (v.transpose() * &s_inv * &v)[(0, 0)]
        };
        let bound = (0..n).filter(|&i| train[i]).map(d2).fold(0.0, f64::max);
        for i in (0..n).filter(|&i| !train[i]) {
            let out_range = (0..p).any(|q| {
                let (lo, hi) = cols[q]
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |a, &v| {
                        (a.0.min(v), a.1.max(v))
                    });
                full[q][i] < lo || full[q][i] > hi
            });
            let di = d2(i);
            let want = out_range || di > bound;
            // A row within rounding of the bound may go either way.
            if m.outside[i] != want && (di - bound).abs() > 1e-7 * bound {
                return Err(format!(
                    "seed {seed}: row {i} outside {} vs {want} (d² {di}, bound {bound})",
                    m.outside[i]
                ));
            }
        }
    }
    Ok(())
}

#[test]
fn static_pipeline_matches_an_independent_construction_on_fixed_seeds() {
    // The last one is a fresh seed that once caught the reference itself (nalgebra's SVD,
    // 1e-4 off in the intercept).
    for seed in (0..16).chain([11_945_249_032_071_792_889]) {
        check(seed).unwrap();
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Fresh seeds each run (proptest's own), the same check.
    #[test]
    fn static_pipeline_matches_an_independent_construction_on_fresh_seeds(seed in 0u64..u64::MAX) {
        prop_assert!(check(seed).is_ok(), "{}", check(seed).unwrap_err());
    }

    /// A class count outside 1 … inputs, or fewer than two folds, is refused naming it.
    #[test]
    fn invalid_class_and_fold_counts_are_refused_by_name(seed in 0u64..1000, which in 0usize..3) {
        let case = random_case(seed);
        let c = case.table.inputs.len();
        let (classes, folds, name) = match which {
            0 => (Some(0), 3, "classes"),
            1 => (Some(c + 1 + seed as usize % 5), 3, "classes"),
            _ => (Some(case.classes), seed as usize % 2, "folds"),
        };
        let opts = IdentifyOptions {
            model: ModelKind::Static,
            classes,
            folds,
            split: Split::TimeBefore(case.split_s),
            ..IdentifyOptions::default()
        };
        let e = identify_with_floor(&case.table, &opts).map(|_| ()).unwrap_err().to_string();
        prop_assert!(e.contains(name), "{e}");
    }
}
