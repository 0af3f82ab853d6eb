//! Integration tests of gearcomp-identify in one test binary (one link instead of seven):
//! FL_THERMAL with the default and the fixed kinds, the numpy goldens, multi-run data, runs
//! and segments, property tests, and the CN105397560 test vector.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;
mod dialects;
mod far_values;
mod fl_auto;
mod fl_thermal;
mod generalise;
mod golden_families;
mod missing_code;
mod multirun;
mod preamble;
mod properties;
mod resample;
mod runs;
mod seed003;
mod shapes;
mod sparse_targets;
mod spreadsheets;
mod stack;
mod static_reference;
mod time_unit;
