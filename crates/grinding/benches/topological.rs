//! The topologically dressed worm (bicubic grid f_n(w, b)) against the analytic line
//! modification of the same size, per point: the worm lookup, the analytic worm → gear map and
//! the envelope grinding of one gear point, JP6903407B2, reference example, K(20°, 45°).
//!
//! Report each as a ratio to the line-modification baseline measured in the same run.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, predicted_gear_f_ft_mm};
use gearcomp_grinding::dressed_topology::{DressedTopology, TopologicalWorm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{FlankModification, LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, Grinder};

fn bench(c: &mut Criterion) {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let k = diagonal_ratio(&pair, 20f64.to_radians(), 45f64.to_radians()).unwrap();
    let cpl = FeedCoupling::linear(k, 5.0).unwrap();
    let line = LineModification::new(
        20f64.to_radians(),
        pair.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, 1e-5]),
        Poly(vec![-3e-5]),
    )
    .unwrap();
    // the same modification tabulated on a 41 × 81 grid of the used worm region
    let ws: Vec<f64> = (0..41)
        .map(|i| 125.0 + 10.0 * f64::from(i) / 40.0)
        .collect();
    let bs: Vec<f64> = (0..81).map(|j| -60.0 + 1.5 * f64::from(j)).collect();
    let cb = pair.worm.beta_b_rad.cos();
    let f = ws
        .iter()
        .flat_map(|&w| bs.iter().map(move |&b| (w, b)))
        .map(|(w, b)| line.f_ft_mm(w, b) * cb)
        .collect();
    let table = DressedTopology::new(
        Flank::Right,
        pair.worm.r_b_mm,
        pair.worm.beta_b_rad,
        (ws, bs),
        f,
        20f64.to_radians(),
    )
    .unwrap();
    let topo = TopologicalWorm::new(table, &pair.worm).unwrap();
    let pts: Vec<(f64, f64)> = (0..64)
        .map(|i| {
            (
                11.0 + 12.0 * f64::from(i % 8) / 7.0,
                -15.0 + 30.0 * f64::from(i / 8) / 7.0,
            )
        })
        .collect();
    let mut g = c.benchmark_group("topological");
    g.bench_function("lookup_line_baseline", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| line.gradient(black_box(125.0 + w / 3.0), z).0)
                .sum::<f64>()
        })
    });
    g.bench_function("lookup_topological", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| topo.gradient(black_box(125.0 + w / 3.0), z).0)
                .sum::<f64>()
        })
    });
    g.bench_function("map_line_baseline", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| predicted_gear_f_ft_mm(&pair, &cpl, &line, black_box(w), z))
                .sum::<f64>()
        })
    });
    g.bench_function("map_topological", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| predicted_gear_f_ft_mm(&pair, &cpl, &topo, black_box(w), z))
                .sum::<f64>()
        })
    });
    let gl = Grinder::new(&pair, &cpl, &line, EnvelopeMode::RotationAndFeed);
    let gt = Grinder::new(&pair, &cpl, &topo, EnvelopeMode::RotationAndFeed);
    g.bench_function("grind_line_baseline", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| gl.grind_point(black_box(w), z).unwrap().f_ft_mm)
                .sum::<f64>()
        })
    });
    g.bench_function("grind_topological", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| gt.grind_point(black_box(w), z).unwrap().f_ft_mm)
                .sum::<f64>()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
