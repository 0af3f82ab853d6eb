//! The control cycle allocates nothing: 20 000 cycles of a 16-channel, 3-axis engine
//! (every law form, every model transform, workpiece shrink, a model's training envelope
//! and its warning, pulses, faults and a stop)
//! under a counting global allocator.
//!
//! The allocator counts every thread of the process, so this test runs without the libtest
//! harness (`harness = false`): no harness thread can allocate while the region is open.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::alloc::System;

use gearcomp_thermal::{EngineStatus, Inputs, Reading};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn engine_step_allocates_nothing() {
    let mut engine = common::engine();
    let mut readings = [Reading {
        raw: 0.0,
        stamp_s: 0.0,
    }; 16];
    let positions = [250.0, 0.0, 0.0];
    let mut statuses = [0usize; 3];
    let mut warnings = 0usize;
    let region = Region::new(GLOBAL);
    for k in 0..20_000u64 {
        common::fill(&mut readings, k);
        // Exercise the fault paths: a NaN burst, a stale channel and a limit violation.
        if (5_000..5_010).contains(&k) {
            readings[3].raw = f64::NAN;
        }
        if (8_000..8_020).contains(&k) {
            readings[12].stamp_s = 7_990.0;
        }
        if (15_000..15_400).contains(&k) {
            // Above limit_max = 400 °C (inside the validity range): after the block average
            // and the 60 s filter this raises a stop request.
            for r in &mut readings[12..15] {
                r.raw = 499.0;
            }
        }
        let out = engine.step(&Inputs {
            time_s: k as f64,
            readings: &readings,
            trigger: true,
            safe_point: k % 60 < 10,
            positions_mm: &positions,
        });
        warnings += usize::from(out.warning.is_some());
        statuses[match out.status {
            EngineStatus::Running => 0,
            EngineStatus::Alarm => 1,
            EngineStatus::StopRequested => 2,
        }] += 1;
    }
    let stats = region.change();
    assert_eq!(stats.allocations, 0, "{stats:?}");
    assert_eq!(stats.reallocations, 0, "{stats:?}");
    assert_eq!(stats.deallocations, 0, "{stats:?}");
    // The paths were really taken (the envelope warning of axis Y included).
    assert!(warnings > 1_000, "{warnings}");
    assert!(
        statuses[0] > 10_000 && statuses[1] >= 20 && statuses[2] > 0,
        "{statuses:?}"
    );
}

fn main() {
    engine_step_allocates_nothing();
    println!("no_alloc: 20000 engine cycles, 0 allocations");
    println!("1 passed, 0 failed");
}
