//! CN105397560 clustering / regression / shrink test vector (docs/identification.md,
//! "CN105397560 as implemented", test vector: n = 8, c = 5).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_core::model::{
    LinearModel, ReferenceRadius, ShrinkGear, ShrinkMethod, Term, Transform,
};
use gearcomp_identify::cluster::{
    correlation_matrix, lambda_cut, pearson, transitive_closure, Dendrogram,
};
use gearcomp_identify::regress::ols;
use gearcomp_identify::workpiece::{shrink_offset_um, workpiece_shrink};
use nalgebra::DMatrix;

const T: [[f64; 5]; 8] = [
    [20.0, 22.0, 21.0, 24.0, 20.1],
    [21.0, 25.0, 23.1, 24.6, 20.8],
    [22.0, 27.5, 25.2, 25.5, 21.9],
    [21.5, 29.0, 26.7, 26.9, 21.6],
    [20.5, 30.1, 27.9, 28.0, 20.9],
    [20.0, 30.8, 28.4, 29.4, 20.3],
    [21.0, 31.2, 29.0, 30.5, 21.0],
    [22.5, 31.5, 29.3, 31.2, 22.2],
];
const TA: [f64; 8] = [38.0, 41.9, 45.6, 48.8, 50.3, 51.2, 52.9, 54.6];

fn columns() -> Vec<Vec<f64>> {
    (0..5).map(|j| T.iter().map(|r| r[j]).collect()).collect()
}

fn names() -> Vec<String> {
    (1..=5).map(|i| format!("T{i}")).collect()
}

fn corr() -> DMatrix<f64> {
    let cols = columns();
    let refs: Vec<&[f64]> = cols.iter().map(|c| c.as_slice()).collect();
    correlation_matrix(&refs, &names()).unwrap()
}

#[test]
fn seed003_correlation_rows_and_target_correlation() {
    let r = corr();
    // Published to 4 decimals: tolerance half a unit of the last digit.
    let rows = [
        [1.0, 0.3374, 0.3156, 0.2675, 0.9765],
        [0.3374, 1.0, 0.9969, 0.9195, 0.4473],
        [0.3156, 0.9969, 1.0, 0.9438, 0.4229],
        [0.2675, 0.9195, 0.9438, 1.0, 0.3266],
        [0.9765, 0.4473, 0.4229, 0.3266, 1.0],
    ];
    for i in 0..5 {
        for j in 0..5 {
            assert!(
                (r[(i, j)] - rows[i][j]).abs() <= 5e-5,
                "r[{i}][{j}] = {}",
                r[(i, j)]
            );
        }
    }
    let rta = [0.3776, 0.9901, 0.9956, 0.9561, 0.4741];
    for (j, c) in columns().iter().enumerate() {
        let v = pearson(c, &TA, "r").unwrap();
        assert!((v - rta[j]).abs() <= 5e-5, "r_TTa[{j}] = {v}");
    }
}

#[test]
fn seed003_closure_levels_classes_and_dendrogram() {
    let absr = corr().map(f64::abs);
    let (t, squarings) = transitive_closure(&absr);
    assert!(
        squarings <= 3,
        "closure after {squarings} squarings (seed: 3)"
    );
    let d = Dendrogram::single_linkage(&absr);
    let levels: Vec<f64> = d.merges.iter().map(|m| m.level).collect();
    let expect = [0.9969, 0.9765, 0.9438, 0.4473];
    for (l, e) in levels.iter().zip(expect) {
        assert!((l - e).abs() <= 5e-5, "{levels:?}");
    }
    // Classes at each λ (0-based indices: T1 = 0 … T5 = 4).
    let cases: [(f64, Vec<Vec<usize>>); 4] = [
        (0.9969, vec![vec![0], vec![1, 2], vec![3], vec![4]]),
        (0.9765, vec![vec![0, 4], vec![1, 2], vec![3]]),
        (0.9438, vec![vec![0, 4], vec![1, 2, 3]]),
        (0.4473, vec![vec![0, 1, 2, 3, 4]]),
    ];
    for (k, (lambda, classes)) in cases.iter().enumerate() {
        // The published levels are rounded; cut just below them.
        assert_eq!(&lambda_cut(&t, lambda - 5e-5), classes, "λ = {lambda}");
        assert_eq!(&d.classes(4 - k).unwrap(), classes, "{} classes", 4 - k);
    }
}

#[test]
fn seed003_regression_t1_t3_t4_and_shrink_chain() {
    let cols = columns();
    let f = ols(&[&cols[0], &cols[2], &cols[3]], &TA, &names()).unwrap();
    let a = [-12.531724, 0.479769, 1.535764, 0.360204];
    for (x, e) in f.coefficients.iter().zip(a) {
        // Published to 6 decimals.
        assert!((x - e).abs() <= 5e-7, "{:?}", f.coefficients);
    }
    assert!((f.sse - 0.248499).abs() <= 5e-7, "Q = {}", f.sse);
    let fitted = [
        37.960, 41.881, 45.910, 48.478, 50.237, 51.269, 53.067, 54.499,
    ];
    for (k, e) in fitted.iter().enumerate() {
        assert!((TA[k] - f.residuals[k] - e).abs() <= 5e-4);
    }
    // Max-|r| representative T5 instead of T1 (the seed's alternative row).
    let g = ols(&[&cols[4], &cols[2], &cols[3]], &TA, &names()).unwrap();
    let b = [-15.584842, 0.632666, 1.454367, 0.431145];
    for (x, e) in g.coefficients.iter().zip(b) {
        assert!((x - e).abs() <= 5e-7, "{:?}", g.coefficients);
    }
    assert!((g.sse - 0.222309).abs() <= 5e-7);

    // Chain: t = (21.0, 29.0, 30.5) → Ta = 53.0668 °C → δT_p = 22.8488, δT_a = 31.2764 µm.
    let temperature = LinearModel {
        intercept: f.coefficients[0],
        terms: ["T1", "T3", "T4"]
            .iter()
            .zip(&f.coefficients[1..])
            .map(|(c, &k)| Term {
                channel: c.to_string(),
                coefficient: k,
                transform: Transform::Value,
            })
            .collect(),
    };
    let ta = f.predict(&[21.0, 29.0, 30.5]);
    assert!((ta - 53.0668).abs() < 5e-5, "Ta = {ta}");
    let gear = ShrinkGear {
        normal_module_mm: 3.0,
        pressure_angle_deg: 20.0,
        teeth: 40,
        helix_angle_deg: 0.0,
        tip_diameter_mm: Some(126.0),
    };
    let mut w = workpiece_shrink(
        temperature,
        gear,
        20.0,
        11.5e-6,
        ReferenceRadius::Pitch,
        ShrinkMethod::Exact,
    )
    .unwrap();
    assert!((shrink_offset_um(&w, ta).unwrap() - 22.8488).abs() < 2e-4);
    w.reference = ReferenceRadius::Tip;
    assert!((shrink_offset_um(&w, ta).unwrap() - 31.2764).abs() < 2e-4);
    // The δT vectors at ΔT_w = 30 K: pitch 20.7269, tip 28.3736, first order r·ε = 20.7000.
    assert!((shrink_offset_um(&w, 50.0).unwrap() - 28.3736).abs() < 6e-5);
    w.reference = ReferenceRadius::Pitch;
    assert!((shrink_offset_um(&w, 50.0).unwrap() - 20.7269).abs() < 6e-5);
    w.method = ShrinkMethod::FirstOrder;
    assert!((shrink_offset_um(&w, 50.0).unwrap() - 20.7000).abs() < 6e-5);
}
