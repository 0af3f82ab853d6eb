//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../common/mod.rs"]
mod common;

mod envelope;
mod ep0138375_worked_example;
mod faults;
mod jph0761598b2_and_presets;
mod model_file;
mod properties;
mod replay_fuzz;
mod sampling_and_safety;
mod step_into;
