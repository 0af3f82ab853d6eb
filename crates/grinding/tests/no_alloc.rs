//! The per-point paths allocate nothing: the analytic mapping and the grinding simulation
//! into a preallocated flank run under a counting global allocator and must see zero
//! allocations.
//!
//! The allocator counts every thread of the process, so this test runs without the libtest
//! harness (`harness = false` in Cargo.toml): no harness thread can allocate while the region
//! is open.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::System;
use std::hint::black_box;

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::predicted_gear_f_ft_mm;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::{LineModification, Poly};
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn mapping_and_simulation_do_not_allocate() {
    let gear = InvoluteGear::new(31, 3.0, 20f64.to_radians(), 15f64.to_radians()).unwrap();
    let worm = InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right).unwrap();
    let pair = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
    let cpl = FeedCoupling::linear(-0.877178, 5.0).unwrap();
    let m = LineModification::new(
        20f64.to_radians(),
        pair.worm.w_ref_mm,
        Poly(vec![0.0, 1e-4, 2e-5]),
        Poly(vec![0.0, 1e-5]),
        Poly(vec![-3e-5]),
    )
    .unwrap();
    let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 6, 7).unwrap();
    let mut out = GroundFlank::new(grid);
    let g = Grinder::new(&pair, &cpl, &m, EnvelopeMode::RotationAndFeed);
    let region = Region::new(GLOBAL);
    let mut acc = 0.0;
    for i in 0..10_000 {
        let w = 11.0 + f64::from(i % 120) * 0.1;
        acc += predicted_gear_f_ft_mm(&pair, &cpl, &m, w, -15.0 + f64::from(i % 31));
        acc += pair.map_gear_point(&cpl, w, 0.0).w1_mm;
    }
    g.grind_flank(&mut out).unwrap();
    acc += g.grind_point(17.0, 3.0).unwrap().f_ft_mm;
    // the error path must not allocate either
    acc += f64::from(u8::from(g.grind_point(f64::NAN, 0.0).is_err()));
    let stats = region.change();
    black_box(acc);
    assert_eq!(stats.allocations, 0, "{stats:?}");
    assert_eq!(stats.reallocations, 0, "{stats:?}");
}

fn main() {
    mapping_and_simulation_do_not_allocate();
    println!("no_alloc: mapping and simulation, 0 allocations");
    println!("1 passed, 0 failed");
}
