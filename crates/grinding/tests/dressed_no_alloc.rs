//! Grinding with a dressed (tabulated) worm allocates nothing per point: the spline lookup, the
//! topological grid lookup, the analytic map and the envelope simulation run under a counting
//! global allocator.
//!
//! The allocator counts every thread of the process, so this test runs without the libtest
//! harness (`harness = false` in Cargo.toml): no harness thread can allocate while the region
//! is open, and one counted run is enough.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::System;
use std::hint::black_box;

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::predicted_gear_f_ft_mm;
use gearcomp_grinding::dressed::{DressedProfile, DressedWorm};
use gearcomp_grinding::dressed_topology::{DressedTopology, TopologicalWorm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::FlankModification;
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn dressed_worm_grinding_does_not_allocate() {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let ws: Vec<f64> = (0..41).map(|i| 126.0 + 7.0 * f64::from(i) / 40.0).collect();
    let f = ws.iter().map(|w| 2e-4 * (w - 129.9).powi(2)).collect();
    let table = DressedProfile::new(
        Flank::Right,
        pair.worm.r_b_mm,
        pair.worm.beta_b_rad,
        ws,
        f,
        (126.0, 133.0),
        0.35,
    )
    .unwrap();
    let dressed = DressedWorm::new(table, &pair.worm).unwrap();
    let cpl = FeedCoupling::linear(-0.5, 2.0).unwrap();
    let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 6, 7).unwrap();
    let mut out = GroundFlank::new(grid);
    let g = Grinder::new(&pair, &cpl, &dressed, EnvelopeMode::RotationAndFeed);
    // a topologically dressed worm (grid f_n(w, b)) ground diagonally
    let tw: Vec<f64> = (0..9).map(|i| 126.0 + 7.0 * f64::from(i) / 8.0).collect();
    let tb: Vec<f64> = (0..11).map(|j| -40.0 + 8.0 * f64::from(j)).collect();
    let tf = tw
        .iter()
        .flat_map(|&w| {
            tb.iter()
                .map(move |&b| 2e-4 * (w - 129.9).powi(2) * (1.0 + 0.01 * b))
        })
        .collect();
    let topo = TopologicalWorm::new(
        DressedTopology::new(
            Flank::Right,
            pair.worm.r_b_mm,
            pair.worm.beta_b_rad,
            (tw, tb),
            tf,
            0.35,
        )
        .unwrap(),
        &pair.worm,
    )
    .unwrap();
    let gt = Grinder::new(&pair, &cpl, &topo, EnvelopeMode::RotationAndFeed);
    let mut out_t = GroundFlank::new(grid);
    let mut acc = 0.0;
    let region = Region::new(GLOBAL);
    for i in 0..10_000 {
        let w = 11.0 + f64::from(i % 120) * 0.1;
        acc += predicted_gear_f_ft_mm(&pair, &cpl, &topo, w, -15.0 + f64::from(i % 31));
        acc += topo
            .gradient(120.0 + f64::from(i % 200) * 0.1, f64::from(i % 90) - 45.0)
            .1;
    }
    gt.grind_flank(&mut out_t).unwrap();
    acc += f64::from(u8::from(
        topo.check_covers(&pair, &cpl, (11.0, 23.0), (-15.0, 15.0))
            .is_ok(),
    ));
    for i in 0..10_000 {
        let w = 11.0 + f64::from(i % 120) * 0.1;
        acc += predicted_gear_f_ft_mm(&pair, &cpl, &dressed, w, -15.0 + f64::from(i % 31));
        acc += dressed.gradient(120.0 + f64::from(i % 200) * 0.1, 0.0).0;
    }
    g.grind_flank(&mut out).unwrap();
    acc += f64::from(u8::from(dressed.check_covers(&pair, (11.0, 23.0)).is_ok()));
    let stats = region.change();
    black_box(acc);
    assert_eq!(stats.allocations, 0, "{stats:?}");
    assert_eq!(stats.reallocations, 0, "{stats:?}");
}

fn main() {
    dressed_worm_grinding_does_not_allocate();
    println!("dressed_no_alloc: dressed and topological worm map and simulation, 0 allocations");
    println!("1 passed, 0 failed");
}
