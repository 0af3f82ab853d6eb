//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

#[path = "../common/mod.rs"]
mod common;

mod analytic;
mod campaign;
mod dresser_scale;
mod dresser_too_small;
mod dressing;
mod geometry;
mod kinematics;
mod request_props;
mod request_repro;
mod solvers;
mod topology;
mod worm_evaluable;
