//! One integration-test binary for the crate: each module was a test file of its own;
//! one binary links the dependencies once instead of once per file.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

mod common;

mod architecture;
mod demo_cli;
mod demo_props;
mod dress_cli;
mod dress_contact_point;
mod dress_limits;
mod dress_topological;
mod fit_cli;
mod gear_cli;
mod grind_cli;
mod grind_conical_cli;
mod grind_dressed;
mod grind_equalise;
mod grind_issue13;
mod input_errors;
mod long_values;
mod output_cli;
mod replay_cli;
mod replay_props;
mod serve_cli;
mod serve_many_cli;
mod shape_cli;
