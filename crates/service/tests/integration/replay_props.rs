//! The running service on random logs: a CSV replay input fed through `serve` stores, row for
//! row, the offsets of the law evaluated here from the held readings (an empty cell keeps the
//! channel's last value) through the documented chain law → clamp → D → rate limit
//! (`docs/thermal.md`, engine steps 5–6), the offsets of the offline replay
//! (`gearcomp_thermal::replay`), and one sample per non-empty cell — for random channel
//! counts, irregular time steps, empty cells ("no new reading"), boundary constants and rate
//! limits. A fixed seed (reproducible) and a fresh one.
//!
//! Every row of such a log is one the engine accepts: the service refuses, before it starts,
//! a log whose time does not increase (a logger clock restart, a repeated stamp; see
//! `sources::replay` tests), and its cycle never hands the engine a time that does not
//! increase, so no ignored row can replace a held reading (the flaw d9573fb fixed in
//! `gearcomp replay`).

use crate::common::{replay_to_end, stored_offsets};
use gearcomp_thermal::{Engine, EngineConfig};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestRunner};
use std::fmt::Write as _;

#[derive(Debug, Clone)]
struct Case {
    channels: usize,
    kz: f64,
    dead_band_um: f64,
    max_step_um: f64,
    /// (time step s, one cell per channel: None = empty cell).
    rows: Vec<(f64, Vec<Option<f64>>)>,
}

fn case() -> impl Strategy<Value = Case> {
    (2usize..=4).prop_flat_map(|channels| {
        (
            Just(channels),
            -5.0f64..5.0,
            prop_oneof![Just(0.0), 0.0f64..2.0],
            0.05f64..3.0,
            proptest::collection::vec(
                (
                    1.0f64..20.0,
                    proptest::collection::vec(
                        prop_oneof![4 => (0.0f64..60.0).prop_map(Some), 1 => Just(None)],
                        channels,
                    ),
                ),
                2..80,
            ),
        )
            .prop_map(|(channels, kz, dead_band_um, max_step_um, mut rows)| {
                // The first row carries every channel, so every law has a value from row 1.
                for c in rows[0].1.iter_mut() {
                    c.get_or_insert(20.0);
                }
                Case {
                    channels,
                    kz,
                    dead_band_um,
                    max_step_um,
                    rows,
                }
            })
    })
}

/// Cz = Kz·(t0 − t1) + 0.5·t_last (JPH0761598B2's two forms on one axis).
fn engine_text(c: &Case) -> String {
    let mut s = String::new();
    for i in 0..c.channels {
        write!(
            s,
            "[[channels]]\nname = \"t{i}_c\"\nsensor = {{ kind = \"celsius\" }}\n\
             valid_min = -20.0\nvalid_max = 90.0\nstale_timeout_s = 100000.0\n"
        )
        .unwrap();
    }
    write!(
        s,
        "[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\nmax_offset_um = 500.0\n\
         dead_band_um = {:?}\nmax_step_um = {:?}\n\
         [[axes.terms]]\nkind = \"difference\"\na = \"t0_c\"\nb = \"t1_c\"\nkz_um_per_c = {:?}\n\
         [[axes.terms]]\nkind = \"linear\"\nchannel = \"t{}_c\"\nkd_um_per_c = 0.5\nalpha_um = 0.0\n",
        c.dead_band_um,
        c.max_step_um,
        c.kz,
        c.channels - 1
    )
    .unwrap();
    s
}

fn log_text(c: &Case) -> String {
    let mut s = String::from("time_s");
    for i in 0..c.channels {
        write!(s, ",t{i}_c").unwrap();
    }
    s.push('\n');
    let mut t = 0.0;
    for (dt, cells) in &c.rows {
        write!(s, "{t:?}").unwrap();
        for v in cells {
            match v {
                Some(v) => write!(s, ",{v:?}").unwrap(),
                None => s.push(','),
            }
        }
        s.push('\n');
        t += dt;
    }
    s
}

/// The documented chain, written from `docs/thermal.md` and not from the engine's code:
/// each channel holds the value of its last non-empty cell; law = Kz·(t0 − t1) + 0.5·t_last,
/// clamped to ±500 µm; the running compensation RC (from 0) takes the law only when
/// |law − RC| ≥ D; the applied offset moves towards RC by at most the rate limit per row.
fn expected_offsets(c: &Case) -> Vec<f64> {
    let mut held = vec![f64::NAN; c.channels];
    let (mut rc, mut applied) = (0.0f64, 0.0f64);
    let mut out = Vec::new();
    for (_, cells) in &c.rows {
        for (h, v) in held.iter_mut().zip(cells) {
            if let Some(v) = v {
                *h = *v;
            }
        }
        let law = c.kz * (held[0] - held[1]) + 0.5 * held[c.channels - 1];
        let law = law.clamp(-500.0, 500.0);
        if (law - rc).abs() >= c.dead_band_um {
            rc = law;
        }
        applied += (rc - applied).clamp(-c.max_step_um, c.max_step_um);
        out.push(applied);
    }
    out
}

fn run_case(c: &Case) -> Result<(), TestCaseError> {
    let dir = tempfile::tempdir().unwrap();
    let log = log_text(c);
    let engine = engine_text(c);
    std::fs::write(dir.path().join("log.csv"), &log).unwrap();
    std::fs::write(dir.path().join("engine.toml"), &engine).unwrap();

    let offline = gearcomp_thermal::replay::replay_csv(
        &mut Engine::new(&EngineConfig::from_toml_str(&engine).unwrap()).unwrap(),
        &log,
    )
    .unwrap();
    prop_assert!(offline.bad_rows.is_empty());

    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let (db, committed) = rt.block_on(async {
        let (run, _) = replay_to_end(dir.path(), "1e5", 60.0).await;
        let db = run.db.clone();
        let n = run.stop().await.unwrap();
        (db, n)
    });
    let cells = c
        .rows
        .iter()
        .map(|(_, r)| r.iter().filter(|v| v.is_some()).count() as u64)
        .sum::<u64>();
    prop_assert_eq!(committed, cells, "one stored sample per non-empty cell");
    let live = stored_offsets(&db);
    prop_assert_eq!(live.len(), offline.rows.len(), "one stored offset per row");
    let law = expected_offsets(c);
    prop_assert_eq!(live.len(), law.len());
    for (k, ((y, row), w)) in live.iter().zip(&offline.rows).zip(&law).enumerate() {
        prop_assert!(
            (y - row.offset_um[0]).abs() <= 1e-9,
            "row {k}: live {y} vs offline {}",
            row.offset_um[0]
        );
        prop_assert!(
            (y - w).abs() <= 1e-9 * (1.0 + w.abs()),
            "row {k}: live {y} vs the law on the held readings {w}"
        );
    }
    Ok(())
}

#[test]
fn live_replay_equals_offline_replay_on_random_logs() {
    let fixed = Config {
        cases: 4,
        rng_seed: RngSeed::Fixed(0x5e7e_0001),
        failure_persistence: None,
        ..Config::default()
    };
    let fresh = Config {
        cases: 4,
        failure_persistence: None,
        ..Config::default()
    };
    for cfg in [fixed, fresh] {
        TestRunner::new(cfg).run(&case(), |c| run_case(&c)).unwrap();
    }
}
