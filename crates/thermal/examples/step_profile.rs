//! Runs the 16-channel, 3-axis engine of the benchmark for many cycles, for profiling
//! `Engine::step_into` under callgrind or perf (`N` from the first argument, default 1;
//! cycles from the second, default 100 000; a third argument `step` profiles the
//! by-value `Engine::step` instead).
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)]

#[path = "../tests/common/mod.rs"]
mod common;

use gearcomp_thermal::{Inputs, Output, Reading};

fn main() {
    let n: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(1);
    let cycles: u64 = std::env::args()
        .nth(2)
        .and_then(|a| a.parse().ok())
        .unwrap_or(100_000);
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
    let by_value = std::env::args().nth(3).as_deref() == Some("step");
    let positions = [250.0, 0.0, 0.0];
    let mut out = Output::EMPTY;
    let mut engine = common::engine_with_block(n);
    // A hash of every output bit, to check that an optimisation changes no result.
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut mix = |x: u64| hash = (hash ^ x).wrapping_mul(0x0000_0100_0000_01b3);
    for k in 0..cycles {
        let mut r = table[(k % 1024) as usize];
        let t = k as f64;
        for x in &mut r {
            x.stamp_s = t;
        }
        let inputs = Inputs {
            time_s: t,
            readings: std::hint::black_box(&r),
            trigger: true,
            safe_point: true,
            positions_mm: &positions,
        };
        if by_value {
            out = engine.step(&inputs);
        } else {
            engine.step_into(&inputs, &mut out);
        }
        mix(out.averaged as u64 | (out.alarm_count as u64) << 1);
        for b in format!("{:?}{:?}{:?}", out.status, out.alarm, out.stop).bytes() {
            mix(u64::from(b));
        }
        for a in out.axes() {
            for v in [a.offset_um, a.target_um, a.law_um] {
                mix(v.to_bits());
            }
            mix(a.pulses as u64 ^ (a.pulse_total as u64).rotate_left(17));
            mix(a.status as u64);
        }
        for c in 0..16 {
            mix(engine.channel_value(c).to_bits());
        }
    }
    println!("{cycles} cycles, N = {n}, output hash {hash:016x}");
}
