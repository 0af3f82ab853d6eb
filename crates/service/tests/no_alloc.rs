//! The cycle's per-sample and per-step path allocates nothing once running (counted with
//! an instrumented global allocator). No libtest harness (`harness = false`): the harness's
//! own thread would share the process-wide counter, so this binary runs only `main`.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

use std::alloc::System;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::sync_channel;
use std::sync::{Arc, Mutex};

use gearcomp_service::cycle::{Clock, Cycle, CycleParts, InputMsg, Live, OffsetOut};
use gearcomp_thermal::{Engine, EngineConfig};
use stats_alloc::{Region, StatsAlloc, INSTRUMENTED_SYSTEM};

#[global_allocator]
static GLOBAL: &StatsAlloc<System> = &INSTRUMENTED_SYSTEM;

fn main() {
    let cfg = EngineConfig::from_toml_str(&common::engine_ab(60.0)).unwrap();
    let engine = Engine::new(&cfg).unwrap();
    let (rec_tx, rec_rx) = sync_channel(1 << 16);
    let (off_tx, off_rx) = tokio::sync::watch::channel(OffsetOut::default());
    let live = Arc::new(Mutex::new(Live::new(
        engine.channel_names(),
        engine.axis_names(),
    )));
    let clock = Clock::new(0.0, 1.0);
    let mut cycle = Cycle::new(CycleParts {
        engine,
        config: cfg,
        clock,
        period_s: 1.0,
        bumpless_step_um: 0.5,
        records: rec_tx,
        live: live.clone(),
        offsets: off_tx,
        shutdown: Arc::new(AtomicBool::new(false)),
    });
    let mut scan = |k: usize| {
        let a = 24.0 + (k % 7) as f64 * 0.1;
        // An axis position with every scan, as the OPC UA input sends it.
        assert!(cycle.handle(InputMsg::Position {
            axis: 0,
            position_mm: 100.0 + k as f64,
        }));
        for (c, raw) in [(0u16, a), (1u16, 20.0)] {
            assert!(cycle.handle(InputMsg::Sample {
                channel: c,
                raw,
                stamp_s: clock.now_s(),
            }));
        }
        cycle.step();
    };
    for k in 0..20 {
        scan(k);
    }
    let region = Region::new(GLOBAL);
    let mut k = 20;
    for _ in 0..1000 {
        scan(k);
        k += 1;
    }
    let stats = region.change();
    assert!(
        stats.allocations == 0 && stats.reallocations == 0,
        "1000 scans allocated: {stats:?}"
    );
    // The work was done: every scan's 2 samples plus offsets went to the store.
    let n = rec_rx.try_iter().count();
    assert!(n >= k * 2, "{n}");
    let last = k - 1;
    let o = *off_rx.borrow();
    assert!((o.offsets_um[0] - -3.75 * (24.0 + (last % 7) as f64 * 0.1 - 20.0)).abs() < 1e-9);
    assert_eq!(live.lock().unwrap().cycles, 2 * k as u64);
    println!("no_alloc: 1000 scans (position + 2 samples + step each), 0 allocations");
}
