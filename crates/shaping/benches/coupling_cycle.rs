//! Cost of one interpolator cycle of the electronic helical guide.
//!
//! Budget: the control cycle is 0.25–4 ms, so a cycle should cost well under a microsecond.
//! The baseline is a trivial per-cycle loop body (encoder unwrap and one multiply) measured in
//! the same run, so the figure to quote is the ratio interpolator / baseline.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use gearcomp_shaping::coupling::{GearCut, Hand, Mesh};
use gearcomp_shaping::crank::SliderCrank;
use gearcomp_shaping::interpolator::{
    Interpolator, InterpolatorConfig, LinearLimits, RotaryLimits,
};
use gearcomp_shaping::servo::{LoopParams, ServoAxis, ServoModel};
use gearcomp_shaping::units::rpm_to_rad_s;

const CPR: u32 = 3_600_000;
const STEP: u32 = 18_000; // 300 strokes/min at 1 ms

fn config() -> InterpolatorConfig {
    let cut = GearCut::new(
        40,
        25,
        3.0,
        15f64.to_radians(),
        0.0,
        Hand::Right,
        Mesh::External,
    )
    .unwrap();
    InterpolatorConfig {
        cut,
        crank: SliderCrank::new(25.0, 200.0).unwrap(),
        strokes_per_min: 300.0,
        cycle_s: 1e-3,
        crank_cpr: CPR,
        c1_cpr: CPR,
        c2_cpr: CPR,
        circular_feed_mm: 0.5,
        radial_feed_mm: 0.02,
        depth_mm: 6.75,
        lift_off_mm: 0.2,
        c2_limits: RotaryLimits {
            max_speed_rad_s: rpm_to_rad_s(150.0),
            max_accel_rad_s2: 628.0,
        },
        x_limits: LinearLimits {
            max_speed_mm_s: 200.0,
            max_accel_mm_s2: 20_000.0,
        },
        delay_compensation_cycles: 1.0,
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("shaping-cycle");
    g.throughput(Throughput::Elements(1));

    // Baseline: unwrap the encoder and scale it, nothing else.
    let mut raw = 0u32;
    let mut prev = 0u32;
    let mut n = 0i64;
    g.bench_function(BenchmarkId::new("baseline-unwrap-scale", "1cycle"), |b| {
        b.iter(|| {
            raw = (raw + STEP) % CPR;
            let mut d = i64::from(raw) - i64::from(prev);
            if 2 * d > i64::from(CPR) {
                d -= i64::from(CPR);
            }
            prev = raw;
            n += d;
            black_box(n as f64 * 1.7e-6)
        })
    });

    let mut ip = Interpolator::new(config()).unwrap();
    let mut raw = 0u32;
    g.bench_function(BenchmarkId::new("interpolator", "1cycle"), |b| {
        b.iter(|| {
            raw = (raw + STEP) % CPR;
            black_box(ip.cycle(black_box(raw)))
        })
    });

    let mut ip = Interpolator::new(config()).unwrap();
    let model = ServoModel::Loop(LoopParams {
        kv_per_s: 30.0,
        velocity_time_constant_s: 2e-3,
        feed_forward: 1.0,
        accel_feed_forward: 1.0,
        quantum: std::f64::consts::TAU / f64::from(CPR),
        delay_cycles: 1,
        substeps: 8,
    });
    let mut c2 = ServoAxis::new(model, 0.0, 0.0);
    let scale = std::f64::consts::TAU / f64::from(CPR);
    let mut raw = 0u32;
    g.bench_function(BenchmarkId::new("interpolator+c2-servo", "1cycle"), |b| {
        b.iter(|| {
            raw = (raw + STEP) % CPR;
            let out = ip.cycle(black_box(raw));
            black_box(c2.step(
                out.c2_counts() * scale,
                out.c2_vel_rad_s,
                out.c2_acc_rad_s2,
                1e-3,
            ))
        })
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2))
        .sample_size(30);
    targets = bench
}
criterion_main!(benches);
