//! The per-call geometry functions allocate nothing: 10 000 calls under a counting global
//! allocator must see zero allocations. Runs without the libtest harness (Cargo.toml:
//! harness = false): under load libtest's own thread allocated while the counter was read
//! (4 allocations, 900 bytes, seen in about one run in three on a busy machine).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::alloc::System;
use std::hint::black_box;

use gearcomp_geometry::involute::{inv, inv_inverse};
use gearcomp_geometry::{Gear, GearPair, GearSpec, Hand};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    evaluation_functions_do_not_allocate();
    println!("no_alloc: 10 000 calls of each evaluation function, 0 allocations");
}

fn evaluation_functions_do_not_allocate() {
    let mut s = GearSpec::spur(3.5, 20f64.to_radians(), 31);
    s.helix_angle_rad = 21f64.to_radians();
    s.profile_shift = 0.3;
    let g = Gear::new(s).unwrap();
    let mut s2 = s;
    s2.teeth = 30;
    s2.hand = Hand::Left;
    s2.profile_shift = 0.35;
    let g2 = Gear::new(s2).unwrap();
    let pair = GearPair::new(&g, &g2, 116.5).unwrap();
    let region = Region::new(GLOBAL);
    let mut acc = 0.0;
    for i in 0..10_000 {
        let t = f64::from(i % 100) * 1e-3;
        acc += inv_inverse(inv(0.3 + t));
        acc += g.normal_thickness_at_mm(112.0 + t, 0.3).unwrap();
        acc += g.span(4, 0.3 - t).unwrap().span_mm;
        acc += g.ball_dimension(6.0 + t, 0.3).unwrap().dimension_mm;
        acc += g.generating_shift(-0.05 - t).unwrap();
        acc += pair.backlash(-0.05, -0.05 - t).unwrap().normal_mm;
        // Errors are Copy too: the error path must not allocate either.
        acc += f64::from(u8::from(g.span(0, 0.3).is_err()));
    }
    let stats = region.change();
    black_box(acc);
    assert_eq!(stats.allocations + stats.reallocations, 0, "{stats:?}");
    // Positive control: the counter does see an allocation.
    let region = Region::new(GLOBAL);
    black_box(Box::new(acc));
    assert!(region.change().allocations > 0);
}
