//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod brute_envelope;
mod conical;
mod conical_envelope;
mod conical_equalise;
mod conical_lines;
mod dressed_worm;
mod envelope;
mod issue13;
mod prop_grind;
mod topological_worm;
