//! Cost of the per-call geometry functions against a baseline measured in the same run.
//!
//! Budget: the IPO cycle is a few milliseconds; a thickness or measurement evaluation
//! must cost well under a microsecond and allocate nothing (tests/no_alloc.rs proves the
//! latter). Baseline: `f64::tan` on the same angle, the cheapest transcendental any
//! involute evaluation needs.

// criterion_group! generates an undocumented pub fn.
#![allow(missing_docs)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use gearcomp_geometry::involute::{inv, inv_inverse};
use gearcomp_geometry::{Gear, GearSpec, Hand};

fn helical() -> Option<Gear> {
    let mut s = GearSpec::spur(3.5, 20f64.to_radians(), 31);
    s.helix_angle_rad = 21f64.to_radians();
    s.hand = Hand::Right;
    s.profile_shift = 0.3;
    Gear::new(s).ok()
}

fn bench(c: &mut Criterion) {
    let Some(g) = helical() else {
        return;
    };
    let alpha = 0.4_f64;
    let v = inv(alpha);
    let mut grp = c.benchmark_group("geometry-z31-mn3.5-beta21");
    grp.bench_function("baseline-tan", |b| {
        b.iter(|| black_box(black_box(alpha).tan()))
    });
    grp.bench_function("inv", |b| b.iter(|| inv(black_box(alpha))));
    grp.bench_function("inv_inverse", |b| b.iter(|| inv_inverse(black_box(v))));
    grp.bench_function("normal_thickness_at", |b| {
        b.iter(|| g.normal_thickness_at_mm(black_box(115.0), black_box(0.3)))
    });
    grp.bench_function("span_k4", |b| {
        b.iter(|| g.span(black_box(4), black_box(0.3)))
    });
    grp.bench_function("ball_dimension", |b| {
        b.iter(|| g.ball_dimension(black_box(6.0), black_box(0.3)))
    });
    grp.bench_function("generating_shift", |b| {
        b.iter(|| g.generating_shift(black_box(-0.05)))
    });
    grp.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
