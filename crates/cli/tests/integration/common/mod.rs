//! Helpers shared by the CLI integration tests: a per-test temp folder, a config file in it,
//! the `gearcomp` binary run with arguments, and the check of JPH0761598B2's law on a record.
#![allow(dead_code, clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty `<tmp>/gearcomp-<tag>-<pid>-<name>` folder.
pub fn temp_dir(tag: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("gearcomp-{tag}-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The `gearcomp` binary built for these tests, as a command to add arguments to.
pub fn gearcomp_cmd() -> Command {
    Command::new(env!("CARGO_BIN_EXE_gearcomp"))
}

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
    gearcomp_cmd().args(args).output().unwrap()
}

/// Runs `gearcomp` with `args` and `--json`, asserts success, and parses its stdout.
pub fn gearcomp_json(args: &[&str]) -> serde_json::Value {
    let out = gearcomp_cmd().args(args).arg("--json").output().unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// Independent check of a grinder record: the preset is JPH0761598B2's Cz = Kz·(A − B) with
/// Kz = −3.75 µm/°C, on the averaged values of the same cycle, for every offset whose law was
/// evaluated in that cycle (more than 10 of them). A frozen axis (stale channel, which a
/// loaded machine can cause at high speed-up) keeps its last law value, so it is skipped.
pub fn assert_grinder_law(db: &Path) {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mut st = conn
        .prepare(
            "SELECT o.law_um, a.value, b.value FROM offsets o \
             JOIN averages a ON a.time_s = o.time_s AND a.channel = 0 \
             JOIN averages b ON b.time_s = o.time_s AND b.channel = 1 \
             WHERE o.law_um IS NOT NULL \
             AND o.status NOT IN ('frozen', 'stopped', 'starting')",
        )
        .unwrap();
    let rows: Vec<(f64, f64, f64)> = st
        .query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?)))
        .unwrap()
        .map(|r| r.unwrap())
        .collect();
    assert!(rows.len() > 10, "{}", rows.len());
    for (law, a, b) in rows {
        assert!((law - -3.75 * (a - b)).abs() < 1e-9, "{law} vs {a} {b}");
    }
}

/// The worm and feeds of the line-to-line example (JP6903407B2 diagonal generating;
/// docs/grinding.md "Topologically dressed worm") for `gearcomp grind simulate`: ρ_F1 = 20°, K for
/// ρ_F2 = 45°, z_V01 = 5 mm, worm modification C = (0, 0.1, 0.02), L = (0, 0.01), Q = −0.03.
pub const T8_WORM_ARGS: [&str; 12] = [
    "--worm-rho-deg",
    "20",
    "--gear-rho-deg",
    "45",
    "--shift-offset-mm",
    "5",
    "--worm-c",
    "0,0.1,0.02",
    "--worm-l",
    "0,0.01",
    "--worm-q",
    "-0.03",
];

/// Two proptest runners for one property: a fixed seed (the same cases on every run, so CI
/// is reproducible) and a fresh random seed (new cases each run). `seed` tells the properties
/// of the suite apart; failures are not persisted (the printed case is the reproduction).
pub fn prop_runners(cases: u32, seed: u64) -> [proptest::test_runner::TestRunner; 2] {
    use proptest::test_runner::{Config, RngSeed, TestRunner};
    let fixed = Config {
        cases,
        rng_seed: RngSeed::Fixed(seed),
        failure_persistence: None,
        ..Config::default()
    };
    let fresh = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    [TestRunner::new(fixed), TestRunner::new(fresh)]
}

/// Every number in a JSON value is finite; serde_json writes NaN and ±inf as `null`, so a
/// `null` counts as not finite.
pub fn all_finite(v: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Null => false,
        serde_json::Value::Number(n) => n.as_f64().is_some_and(f64::is_finite),
        serde_json::Value::Array(a) => a.iter().all(all_finite),
        serde_json::Value::Object(o) => o.values().all(all_finite),
        _ => true,
    }
}
