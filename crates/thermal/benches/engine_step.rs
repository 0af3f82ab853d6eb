//! Cycle time of one engine step: 16 channels (Pt100, NTC, °C, displacement), N = 4
//! block average, first-order filter, 3 axes using every law form, model transforms and
//! the workpiece shrink. Budget: the IPO cycle is milliseconds; a step must cost well
//! under 1 µs. The baseline in the same run is a plain dot product of 16 values, so the
//! figure is reported as a ratio that does not depend on the machine.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

#[path = "../tests/common/mod.rs"]
mod common;

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use gearcomp_thermal::{Inputs, Output, Reading};

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("engine_step");
    let coef: [f64; 16] = std::array::from_fn(|i| 0.1 * i as f64 - 0.7);
    let x: [f64; 16] = std::array::from_fn(|i| 20.0 + i as f64 * 0.3);
    g.bench_function(BenchmarkId::new("baseline_dot", "16"), |b| {
        b.iter(|| {
            let x = black_box(&x);
            let mut s = 0.0;
            for i in 0..16 {
                s += coef[i] * x[i];
            }
            s
        })
    });

    // Readings are prepared outside the timed loop; only `step` is timed. Cycle k uses the
    // readings of k mod 1024 with a monotonic time, so every step does full work.
    let mut table = vec![
        [Reading {
            raw: 0.0,
            stamp_s: 0.0
        }; 16];
        1024
    ];
    for (k, r) in table.iter_mut().enumerate() {
        common::fill(r, k as u64);
    }
    let positions = [250.0, 0.0, 0.0];
    // N = 4: the configured engine (laws re-evaluated at averaging instants, every 4th
    // cycle, and every cycle for time/position terms); N = 1: every cycle averages and
    // re-evaluates every law, transform and the workpiece shrink (worst case).
    // `step_into` writes into a caller-owned output (how a control loop keeps it);
    // `step` returns the output by value (the wrapper the service and CLI call).
    for (label, n) in [("16ch-3axes-N4", 4usize), ("16ch-3axes-N1-worst", 1)] {
        for by_value in [false, true] {
            let mut engine = common::engine_with_block(n);
            let mut out = Output::EMPTY;
            let mut k: u64 = 0;
            let name = if by_value { "step" } else { "step_into" };
            g.bench_function(BenchmarkId::new(name, label), |b| {
                b.iter(|| {
                    let mut r = table[(k % 1024) as usize];
                    let t = k as f64;
                    for x in &mut r {
                        x.stamp_s = t;
                    }
                    k += 1;
                    let inputs = Inputs {
                        time_s: t,
                        readings: black_box(&r),
                        trigger: true,
                        safe_point: true,
                        positions_mm: &positions,
                    };
                    if by_value {
                        out = engine.step(&inputs);
                    } else {
                        engine.step_into(&inputs, &mut out);
                    }
                    black_box(out.axes()[0].offset_um)
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
