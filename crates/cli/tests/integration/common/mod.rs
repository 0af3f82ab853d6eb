//! Helpers shared by the CLI integration tests: a config file in a per-test temp folder and
//! the `gearcomp` binary run with arguments.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// Writes `text` to `<tmp>/gearcomp-<tag>-<pid>-<name>/<file>` and returns the path; the
/// folder is per test, so reports written beside the config do not collide.
pub fn write_config(tag: &str, name: &str, file: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("gearcomp-{tag}-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(file);
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs the `gearcomp` binary built for these tests.
pub fn gearcomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
        .args(args)
        .output()
        .unwrap()
}
