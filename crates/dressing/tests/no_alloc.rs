//! The per-point hot path (envelope of one flank point, 3-point residual) allocates nothing
//! (counting global allocator `stats_alloc`, since the workspace forbids our own `unsafe`).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use gearcomp_dressing::kinematics::AxisCorrection;
use gearcomp_dressing::worm::Flank;
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

#[test]
fn dress_point_allocates_nothing() {
    let s = common::g1_z5();
    let (a, b) = s.active_profile(Flank::Right).unwrap();
    let dk = AxisCorrection::from_array([6e-4, 0.0097, -0.0245, -1.04]);
    let region = Region::new(GLOBAL);
    let mut sum = 0.0;
    for i in 0..1000 {
        let w = a + (b - a) * f64::from(i % 100) / 99.0;
        let d = s.dress_point(Flank::Right, w, &dk).unwrap();
        sum += d.f_mm + d.r_a_mm;
    }
    let change = region.change();
    assert!(sum.is_finite());
    assert_eq!(change.allocations, 0, "{change:?}");
    assert_eq!(change.reallocations, 0);
}
