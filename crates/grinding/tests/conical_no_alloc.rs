//! The conical per-point paths allocate nothing: the analytic conical mapping, the diagonal
//! ratio, the envelope simulation into a preallocated flank and the cone-angle root search
//! run under a counting global allocator and must see zero allocations.
//!
//! The allocator counts every thread of the process, so this test runs without the libtest
//! harness (`harness = false` in Cargo.toml): no harness thread can allocate while the region
//! is open.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::System;
use std::hint::black_box;

use gearcomp_grinding::conical::{BeveloidGear, ConicalPair};
use gearcomp_grinding::conical_equalise::{equalise_worm_cone_angle, EqualiseSpec, WormLines};
use gearcomp_grinding::conical_sim::EnvelopeGrinder;
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::Uniform;
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, GroundFlank};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn conical_paths_do_not_allocate() {
    let a = 20f64.to_radians();
    let gear =
        InvoluteGear::asymmetric(31, 3.0, 25f64.to_radians(), a, 15f64.to_radians(), 0.0).unwrap();
    let w = InvoluteGear::worm(1, 3.0, a, 130.0, Hand::Right).unwrap();
    let worm = InvoluteGear::asymmetric(1, 3.0, 25f64.to_radians(), a, w.beta_rad, 0.0).unwrap();
    let wb = BeveloidGear::new(worm, 3f64.to_radians()).unwrap();
    let gb = BeveloidGear::new(gear, -2f64.to_radians()).unwrap();
    let pair = ConicalPair::reference(&wb, &gb, Flank::Right).unwrap();
    let cpl = FeedCoupling::linear(-0.877, 5.0).unwrap();
    let stock = Uniform { f_ft_mm: 0.01 };
    let grid = FlankGrid::new((11.0, 23.0), (-15.0, 15.0), 4, 5).unwrap();
    let mut out = GroundFlank::new(grid);
    let g = EnvelopeGrinder::new(&pair, &cpl, &stock, EnvelopeMode::RotationAndFeed);
    let spec = EqualiseSpec {
        worm,
        gear: BeveloidGear::cylindrical(gear),
        rho2_left_rad: -45f64.to_radians(),
        rho2_right_rad: 45f64.to_radians(),
        worm_lines: WormLines::Given {
            left_rad: -a,
            right_rad: a,
        },
        cone_range_rad: (-0.2, 0.2),
    };
    let region = Region::new(GLOBAL);
    let mut acc = 0.0;
    for i in 0..5_000 {
        let w2 = 11.0 + f64::from(i % 120) * 0.1;
        acc += pair
            .map_gear_point(&cpl, w2, -15.0 + f64::from(i % 31))
            .unwrap()
            .w1_mm;
        acc += pair
            .diagonal_ratio(0.35, 0.5 + f64::from(i % 7) * 0.1)
            .unwrap();
    }
    g.grind_flank(&mut out).unwrap();
    acc += g.grind_point(17.0, 3.0).unwrap().f_ft_mm;
    acc += equalise_worm_cone_angle(&spec).unwrap().cone1_rad;
    acc += f64::from(u8::from(g.grind_point(f64::NAN, 0.0).is_err()));
    let stats = region.change();
    black_box(acc);
    assert_eq!(stats.allocations, 0, "{stats:?}");
    assert_eq!(stats.reallocations, 0, "{stats:?}");
}

fn main() {
    conical_paths_do_not_allocate();
    println!("conical_no_alloc: conical mapping, simulation and T14 search, 0 allocations");
    println!("1 passed, 0 failed");
}
