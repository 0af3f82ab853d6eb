//! Conical worm / workpiece: analytic conical mapping per point and the envelope simulation
//! per point, against the cylindrical analytic mapping of the same points as the baseline
//! (measured in the same run; report ratios), plus the two-flank cone-angle root search.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use gearcomp_grinding::conical::{BeveloidGear, ConicalPair};
use gearcomp_grinding::conical_equalise::{equalise_worm_cone_angle, EqualiseSpec, WormLines};
use gearcomp_grinding::conical_sim::EnvelopeGrinder;
use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::EnvelopeMode;

fn bench(c: &mut Criterion) {
    let a = 20f64.to_radians();
    let gear = InvoluteGear::new(31, 3.0, a, 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, a, 130.0, Hand::Right).unwrap();
    let cyl = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let wb = BeveloidGear::new(worm, 3f64.to_radians()).unwrap();
    let gb = BeveloidGear::new(gear, -2f64.to_radians()).unwrap();
    let cone = ConicalPair::reference(&wb, &gb, Flank::Right).unwrap();
    let cpl = FeedCoupling::linear(-0.877, 5.0).unwrap();
    let m = LineModification::new(
        a,
        cone.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4]),
        Poly(vec![]),
        Poly(vec![]),
    )
    .unwrap();
    let pts: Vec<(f64, f64)> = (0..100)
        .map(|i| (11.0 + 0.12 * f64::from(i), -15.0 + 0.3 * f64::from(i)))
        .collect();
    let mut g = c.benchmark_group("conical_per_100_points");
    g.bench_function("baseline_cylindrical_map", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| cyl.map_gear_point(&cpl, w, z).w1_mm)
                .sum::<f64>()
        })
    });
    g.bench_function("conical_map", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| cone.map_gear_point(&cpl, w, z).unwrap().w1_mm)
                .sum::<f64>()
        })
    });
    let grinder = EnvelopeGrinder::new(&cone, &cpl, &m, EnvelopeMode::RotationAndFeed);
    g.sample_size(10);
    g.bench_function("conical_envelope", |b| {
        b.iter(|| {
            pts.iter()
                .map(|&(w, z)| grinder.grind_point(w, z).unwrap().f_ft_mm)
                .sum::<f64>()
        })
    });
    g.finish();
    let spec = EqualiseSpec {
        worm: InvoluteGear::asymmetric(1, 3.0, 25f64.to_radians(), a, worm.beta_rad, 0.0).unwrap(),
        gear: BeveloidGear::cylindrical(
            InvoluteGear::asymmetric(31, 3.0, 25f64.to_radians(), a, 15f64.to_radians(), 0.0)
                .unwrap(),
        ),
        rho2_left_rad: -45f64.to_radians(),
        rho2_right_rad: 45f64.to_radians(),
        worm_lines: WormLines::Given {
            left_rad: -a,
            right_rad: a,
        },
        cone_range_rad: (-0.2, 0.2),
    };
    c.bench_function("equalise_worm_cone_angle", |b| {
        b.iter(|| {
            equalise_worm_cone_angle(black_box(&spec))
                .unwrap()
                .cone1_rad
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
