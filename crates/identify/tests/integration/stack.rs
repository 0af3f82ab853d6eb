//! Stacked generalisation (`gearcomp_identify::stack`): the convex weights against an
//! independent construction written here (projected gradient onto the simplex, the
//! projection by sorting, Duchi et al. 2008), a closed form, and the sensor cap against a
//! brute force over the admissible supports.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use gearcomp_identify::stack::{convex_weights, held_out_sse};
use proptest::prelude::*;

/// Euclidean projection of `v` onto {w ≥ 0, Σ w = 1} (sort-based).
fn project_simplex(v: &[f64]) -> Vec<f64> {
    let mut u = v.to_vec();
    u.sort_by(|a, b| b.total_cmp(a));
    let mut css = 0.0;
    let mut theta = 0.0;
    for (k, &x) in u.iter().enumerate() {
        css += x;
        let t = (css - 1.0) / (k + 1) as f64;
        if x - t > 0.0 {
            theta = t;
        }
    }
    v.iter().map(|x| (x - theta).max(0.0)).collect()
}

/// min ‖y − P w‖² over the simplex of the members `support`, by projected gradient.
fn projected_gradient(preds: &[Vec<f64>], y: &[f64], support: &[usize]) -> (Vec<f64>, f64) {
    let m = support.len();
    let n = y.len();
    let sse = |w: &[f64]| -> f64 {
        (0..n)
            .map(|i| {
                let p: f64 = support.iter().zip(w).map(|(&k, w)| w * preds[k][i]).sum();
                (y[i] - p).powi(2)
            })
            .sum()
    };
    // Step 1/L with L = 2·‖P‖_F² ≥ the gradient's Lipschitz constant.
    let l: f64 = 2.0
        * support
            .iter()
            .map(|&k| preds[k].iter().map(|v| v * v).sum::<f64>())
            .sum::<f64>();
    let mut w = vec![1.0 / m as f64; m];
    for _ in 0..200_000 {
        let r: Vec<f64> = (0..n)
            .map(|i| {
                support
                    .iter()
                    .zip(&w)
                    .map(|(&k, w)| w * preds[k][i])
                    .sum::<f64>()
                    - y[i]
            })
            .collect();
        let g: Vec<f64> = support
            .iter()
            .map(|&k| 2.0 * (0..n).map(|i| preds[k][i] * r[i]).sum::<f64>())
            .collect();
        let step: Vec<f64> = w.iter().zip(&g).map(|(w, g)| w - g / l).collect();
        w = project_simplex(&step);
    }
    let s = sse(&w);
    (w, s)
}

fn data(seed: u64, m: usize, n: usize) -> (Vec<Vec<f64>>, Vec<f64>) {
    // A small deterministic generator (xorshift) so cases are reproducible.
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let y: Vec<f64> = (0..n).map(|i| (i as f64 * 0.3).sin() + next()).collect();
    let preds = (0..m)
        .map(|k| {
            y.iter()
                .map(|v| v * (0.5 + 0.3 * k as f64) + next() * (1.0 + k as f64))
                .collect()
        })
        .collect();
    (preds, y)
}

#[test]
fn exact_convex_combination_is_recovered() {
    let p1: Vec<f64> = (0..20).map(|i| (i as f64).sin()).collect();
    let p2: Vec<f64> = (0..20).map(|i| (i as f64 * 0.7).cos()).collect();
    let p3: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
    let y: Vec<f64> = p1.iter().zip(&p2).map(|(a, b)| 0.3 * a + 0.7 * b).collect();
    let rows: Vec<usize> = (0..20).collect();
    let groups = vec![vec![0], vec![1], vec![2]];
    let (w, sse) = convex_weights(&[p1, p2, p3], &y, &rows, &groups, 8).unwrap();
    assert!((w[0] - 0.3).abs() < 1e-12 && (w[1] - 0.7).abs() < 1e-12 && w[2] == 0.0);
    assert!(sse < 1e-24, "{sse}");
}

#[test]
fn held_out_folds_use_weights_from_the_other_folds() {
    // y equals member 0 on every row: every fold's weights are (1, 0), held-out SSE 0.
    let (mut preds, _) = data(3, 2, 30);
    let y = preds[0].clone();
    preds[1][5] += 1.0;
    let fold: Vec<usize> = (0..30).map(|i| i / 10).collect();
    let sse = held_out_sse(&preds, &y, &fold, 3, &[vec![0], vec![1]], 8).unwrap();
    assert_eq!(sse.len(), 3);
    assert!(sse.iter().all(|&s| s < 1e-20), "{sse:?}");
    // Weights fitted on folds 1 and 2 only, in closed form for two members:
    // a = Σ (y − p₁)(p₀ − p₁) / Σ (p₀ − p₁)², clamped to [0, 1]; they predict fold 0.
    let (preds, y) = data(11, 2, 30);
    let sse = held_out_sse(&preds, &y, &fold, 3, &[vec![0], vec![1]], 8).unwrap();
    let fit_sse = |a: f64, rows: &mut dyn Iterator<Item = usize>| -> f64 {
        rows.map(|i| (y[i] - a * preds[0][i] - (1.0 - a) * preds[1][i]).powi(2))
            .sum()
    };
    let d = |i: usize| preds[0][i] - preds[1][i];
    let num: f64 = (10..30).map(|i| (y[i] - preds[1][i]) * d(i)).sum();
    let den: f64 = (10..30).map(|i| d(i) * d(i)).sum();
    let a = (num / den).clamp(0.0, 1.0);
    assert!(a > 0.0 && a < 1.0, "{a}");
    let expect = fit_sse(a, &mut (0..10));
    assert!(
        (sse[0] - expect).abs() <= 1e-9 * expect,
        "{} vs {expect}",
        sse[0]
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Without a binding cap the weights are the simplex least squares (projected gradient).
    #[test]
    fn convex_weights_match_projected_gradient(seed in 1u64..u64::MAX, m in 2usize..5) {
        let (preds, y) = data(seed, m, 25);
        let rows: Vec<usize> = (0..25).collect();
        let groups: Vec<Vec<usize>> = (0..m).map(|k| vec![k]).collect();
        let (w, sse) = convex_weights(&preds, &y, &rows, &groups, m).unwrap();
        let all: Vec<usize> = (0..m).collect();
        let (wr, sr) = projected_gradient(&preds, &y, &all);
        prop_assert!(w.iter().all(|&v| v >= 0.0));
        prop_assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        prop_assert!((sse - sr).abs() <= 1e-9 * sr.max(1e-12), "{sse} vs {sr}");
        for (a, b) in w.iter().zip(&wr) {
            prop_assert!((a - b).abs() < 1e-5, "{w:?} vs {wr:?}");
        }
    }

    /// With the cap: the best over every admissible support (each by projected gradient).
    #[test]
    fn sensor_cap_is_the_best_admissible_support(seed in 1u64..u64::MAX) {
        let (preds, y) = data(seed, 4, 25);
        let rows: Vec<usize> = (0..25).collect();
        // Sensors read by each member; at most 3 sensors together.
        let groups = vec![vec![0, 1], vec![1, 2], vec![3], vec![0, 4]];
        let cap = 3;
        let (w, sse) = convex_weights(&preds, &y, &rows, &groups, cap).unwrap();
        let mut used: Vec<usize> = (0..4)
            .filter(|&k| w[k] > 0.0)
            .flat_map(|k| groups[k].clone())
            .collect();
        used.sort_unstable();
        used.dedup();
        prop_assert!(used.len() <= cap, "{w:?}");
        let mut best = f64::INFINITY;
        for s in 1u32..16 {
            let support: Vec<usize> = (0..4).filter(|k| s & (1 << k) != 0).collect();
            let mut u: Vec<usize> = support.iter().flat_map(|&k| groups[k].clone()).collect();
            u.sort_unstable();
            u.dedup();
            if u.len() <= cap {
                best = best.min(projected_gradient(&preds, &y, &support).1);
            }
        }
        prop_assert!((sse - best).abs() <= 1e-9 * best, "{sse} vs {best}");
    }
}
