//! Grinding with a dressed (tabulated) worm allocates nothing per point: the spline lookup, the
//! analytic map and the envelope simulation run under a counting global allocator (the only
//! test in this binary, so nothing else runs while it counts).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::System;
use std::hint::black_box;

use gearcomp_grinding::contact::WormGearPair;
use gearcomp_grinding::diagonal::predicted_gear_f_ft_mm;
use gearcomp_grinding::dressed::{DressedProfile, DressedWorm};
use gearcomp_grinding::flank::{Flank, Hand, InvoluteGear};
use gearcomp_grinding::kinematics::FeedCoupling;
use gearcomp_grinding::modification::FlankModification;
use gearcomp_grinding::simulate::{EnvelopeMode, FlankGrid, Grinder, GroundFlank};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

#[test]
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
    // The counter is global: a rare allocation by the test harness's own thread while the
    // region is open would count too. An allocation in the code under test shows up in every
    // attempt, so the least count over three attempts must be zero.
    let mut least = usize::MAX;
    let mut acc = 0.0;
    for _ in 0..3 {
        let region = Region::new(GLOBAL);
        for i in 0..10_000 {
            let w = 11.0 + f64::from(i % 120) * 0.1;
            acc += predicted_gear_f_ft_mm(&pair, &cpl, &dressed, w, -15.0 + f64::from(i % 31));
            acc += dressed.gradient(120.0 + f64::from(i % 200) * 0.1, 0.0).0;
        }
        g.grind_flank(&mut out).unwrap();
        acc += f64::from(u8::from(dressed.check_covers(&pair, (11.0, 23.0)).is_ok()));
        let stats = region.change();
        least = least.min(stats.allocations + stats.reallocations);
    }
    black_box(acc);
    assert_eq!(least, 0);
}
