//! One interpolator cycle and one servo step allocate nothing (counting global allocator,
//! `stats_alloc`, since the workspace forbids our own `unsafe`).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_shaping::coupling::{GearCut, Hand, Mesh};
use gearcomp_shaping::crank::SliderCrank;
use gearcomp_shaping::interpolator::{
    Interpolator, InterpolatorConfig, LinearLimits, RotaryLimits,
};
use gearcomp_shaping::servo::{LoopParams, ServoAxis, ServoModel};
use gearcomp_shaping::units::rpm_to_rad_s;
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};
use std::alloc::System;

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

include!("support/setup.rs");

// Runs without the libtest harness (Cargo.toml: harness = false) so that no other thread
// allocates while the global counter is being read.
fn main() {
    cycle_and_servo_step_allocate_nothing();
    println!("no_alloc: 10 000 interpolator cycles + servo steps, 0 allocations");
}

fn cycle_and_servo_step_allocate_nothing() {
    let mut cfg = seed_config(300.0, 24_000.0);
    cfg.delay_compensation_cycles = 1.0;
    let mut ip = Interpolator::new(cfg).unwrap();
    let model = ServoModel::Loop(LoopParams {
        kv_per_s: 30.0,
        velocity_time_constant_s: 2e-3,
        feed_forward: 1.0,
        accel_feed_forward: 1.0,
        quantum: 1e-6,
        delay_cycles: 2,
        substeps: 8,
    });
    let mut c2 = ServoAxis::new(model, 0.0, 0.0);
    let region = Region::new(GLOBAL);
    let mut sum = 0.0;
    for k in 0..10_000u32 {
        let raw = (k * 18_000) % 3_600_000;
        let out = ip.cycle(raw);
        sum += c2.step(
            out.c2_counts() * 1e-6,
            out.c2_vel_rad_s,
            out.c2_acc_rad_s2,
            1e-3,
        );
    }
    let change = region.change();
    assert!(sum.is_finite());
    assert_eq!(
        change.allocations + change.reallocations,
        0,
        "allocations in 10 000 cycles"
    );
}
