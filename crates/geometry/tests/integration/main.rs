//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod bad_input;
mod construct;
mod independent_checks;
mod involute;
mod issue2_vectors;
mod pair_warnings;
mod properties;
mod recommended_ball;
mod span_contact;
