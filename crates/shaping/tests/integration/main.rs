//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file. `tests/no_alloc.rs`
//! stays a binary of its own (no libtest harness: it counts allocations).
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod coupling;
mod crank;
mod fuzz_regressions;
mod gcode_g83;
mod interpolator;
mod issue13;
mod simulate_lead;
