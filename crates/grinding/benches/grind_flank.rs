//! Grinding simulation of one flank on a 100 × 200 grid (envelope over rotation and feed)
//! against the first-order analytic mapping of the same points, JP6903407B2, reference example,
//! T8 worm modification, diagonal ratio K(20°, 45°).
//!
//! Budget: the simulation is an off-line planning step (seconds are fine); the analytic map
//! is the per-point inner loop of planning and of the inverse solve (microseconds or less).
//! Report the ratio simulation-per-point / analytic-per-point, measured in the same run.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::{diagonal_ratio, predicted_gear_f_ft_mm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};

fn setup() -> (WormGearPair, FeedCoupling, LineModification, FlankGrid) {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let k = diagonal_ratio(&pair, 20f64.to_radians(), 45f64.to_radians()).unwrap();
    let cpl = FeedCoupling::linear(k, 5.0).unwrap();
    let m = LineModification::new(
        20f64.to_radians(),
        pair.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, 1e-5]),
        Poly(vec![-3e-5]),
    )
    .unwrap();
    let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 100, 200).unwrap();
    (pair, cpl, m, grid)
}

fn bench(c: &mut Criterion) {
    let (pair, cpl, m, grid) = setup();
    let mut group = c.benchmark_group("grind");
    group.sample_size(10);
    let mut out = GroundFlank::new(grid);
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed);
    group.bench_function(BenchmarkId::new("envelope-simulation", "100x200"), |b| {
        b.iter(|| g.grind_flank(black_box(&mut out)).unwrap())
    });
    group.bench_function(BenchmarkId::new("analytic-map", "100x200"), |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for i in 0..grid.n_w {
                for j in 0..grid.n_z {
                    acc += predicted_gear_f_ft_mm(&pair, &cpl, &m, grid.w_mm(i), grid.z_mm(j));
                }
            }
            black_box(acc)
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
