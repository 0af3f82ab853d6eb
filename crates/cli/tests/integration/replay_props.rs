//! `gearcomp replay` over random valid and invalid inputs, through the binary.
//!
//! Valid: random Celsius channels (1–4), a random law of seed JPH0761598B2's forms
//! (Cz = Kd·T + α, Cz = Kz·(A − B)), random boundary constant D (EP0138375 blocks 602/604),
//! maximum offset and rate limit, and a random log. Every row's target and offset are
//! recomputed here from the CSV text by an independent evaluation of the documented chain
//! (law → clamp → D → rate limit; `docs/thermal.md`, engine steps 5–6) and compared with the
//! written CSV (4 decimals).
//!
//! Invalid: a random key of the configuration set out of range, or a random cell of the log
//! made not-a-number: the error (or the bad-row report) names the key (or the line and the
//! column) the user wrote, and nothing is silently dropped.
//!
//! Each property runs on a fixed seed (reproducible in CI) and on a fresh one.

use crate::common::{gearcomp_cmd, prop_runners, temp_dir};
use proptest::prelude::*;
use std::fmt::Write as _;

#[derive(Debug, Clone)]
enum Term {
    Linear { ch: usize, kd: f64, alpha: f64 },
    Difference { a: usize, b: usize, kz: f64 },
}

#[derive(Debug, Clone)]
struct Case {
    channels: usize,
    terms: Vec<Term>,
    dead_band_um: f64,
    max_offset_um: f64,
    max_step_um: Option<f64>,
    /// Rows: time step (s) and one temperature per channel.
    rows: Vec<(f64, Vec<f64>)>,
}

fn term(channels: usize) -> impl Strategy<Value = Term> {
    prop_oneof![
        (0..channels, -5.0f64..5.0, -50.0f64..50.0).prop_map(|(ch, kd, alpha)| Term::Linear {
            ch,
            kd,
            alpha
        }),
        (0..channels, 0..channels, -5.0f64..5.0).prop_map(|(a, b, kz)| Term::Difference {
            a,
            b,
            kz
        }),
    ]
}

fn case() -> impl Strategy<Value = Case> {
    (1usize..=4).prop_flat_map(|channels| {
        (
            Just(channels),
            proptest::collection::vec(term(channels), 1..4),
            prop_oneof![Just(0.0), 0.0f64..1.0],
            1.0f64..80.0,
            proptest::option::of(0.05f64..5.0),
            proptest::collection::vec(
                (
                    0.5f64..30.0,
                    proptest::collection::vec(-5.0f64..60.0, channels),
                ),
                1..60,
            ),
        )
            .prop_map(
                // A valid dead band lies in 0 ..= max_offset_um (the engine refuses a
                // larger one): drawn as a fraction of min(3 µm, max_offset_um).
                |(channels, terms, dead_band_frac, max_offset_um, max_step_um, rows)| Case {
                    channels,
                    terms,
                    dead_band_um: dead_band_frac * max_offset_um.min(3.0),
                    max_offset_um,
                    max_step_um,
                    rows,
                },
            )
    })
}

fn config_text(c: &Case) -> String {
    let mut s = String::new();
    for i in 0..c.channels {
        write!(
            s,
            "[[channels]]\nname = \"t{i}_c\"\nsensor = {{ kind = \"celsius\" }}\n\
             valid_min = -20.0\nvalid_max = 90.0\nstale_timeout_s = 1000.0\n"
        )
        .unwrap();
    }
    write!(
        s,
        "[[axes]]\nname = \"X\"\napply = {{ kind = \"command\" }}\ndead_band_um = {:?}\n\
         max_offset_um = {:?}\n",
        c.dead_band_um, c.max_offset_um
    )
    .unwrap();
    if let Some(step) = c.max_step_um {
        writeln!(s, "max_step_um = {step:?}").unwrap();
    }
    for t in &c.terms {
        match t {
            Term::Linear { ch, kd, alpha } => write!(
                s,
                "[[axes.terms]]\nkind = \"linear\"\nchannel = \"t{ch}_c\"\n\
                 kd_um_per_c = {kd:?}\nalpha_um = {alpha:?}\n"
            ),
            Term::Difference { a, b, kz } => write!(
                s,
                "[[axes.terms]]\nkind = \"difference\"\na = \"t{a}_c\"\nb = \"t{b}_c\"\n\
                 kz_um_per_c = {kz:?}\n"
            ),
        }
        .unwrap();
    }
    s
}

fn log_text(c: &Case) -> String {
    let mut s = String::from("time_s");
    for i in 0..c.channels {
        write!(s, ",t{i}_c").unwrap();
    }
    s.push('\n');
    let mut t = 0.0;
    for (dt, temps) in &c.rows {
        t += dt;
        write!(s, "{t:?}").unwrap();
        for v in temps {
            write!(s, ",{v:?}").unwrap();
        }
        s.push('\n');
    }
    s
}

/// The documented chain, written from `docs/thermal.md` and not from the engine's code:
/// law = Σ terms; clamp to ±max; the running compensation RC (from 0) takes the law only when
/// |law − RC| ≥ D; the applied offset moves towards RC by at most the rate limit per row.
fn expected(c: &Case) -> Vec<(f64, f64)> {
    let (mut rc, mut applied) = (0.0f64, 0.0f64);
    let mut out = Vec::new();
    for (_, temps) in &c.rows {
        let law: f64 = c
            .terms
            .iter()
            .map(|t| match *t {
                Term::Linear { ch, kd, alpha } => kd * temps[ch] + alpha,
                Term::Difference { a, b, kz } => kz * (temps[a] - temps[b]),
            })
            .sum();
        let law = law.clamp(-c.max_offset_um, c.max_offset_um);
        if (law - rc).abs() >= c.dead_band_um {
            rc = law;
        }
        applied = match c.max_step_um {
            Some(step) => applied + (rc - applied).clamp(-step, step),
            None => rc,
        };
        out.push((rc, applied));
    }
    out
}

fn run_case(c: &Case, tag: &str) -> Result<(), TestCaseError> {
    let dir = temp_dir("replay-props", tag);
    let cfg = dir.join("cfg.toml");
    let log = dir.join("log.csv");
    std::fs::write(&cfg, config_text(c)).unwrap();
    std::fs::write(&log, log_text(c)).unwrap();
    let o = gearcomp_cmd()
        .args(["replay", "--config"])
        .arg(&cfg)
        .arg("--data")
        .arg(&log)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    prop_assert!(o.status.success(), "{stderr}\n{}", config_text(c));
    prop_assert!(
        stderr.contains(&format!("{} rows, 0 bad rows", c.rows.len())),
        "{stderr}"
    );
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (ioff, itgt) = (col("X_offset_um"), col("X_target_um"));
    let want = expected(c);
    let rows: Vec<&str> = lines.collect();
    prop_assert_eq!(rows.len(), want.len());
    for (k, (row, (rc, applied))) in rows.iter().zip(&want).enumerate() {
        let f: Vec<&str> = row.split(',').collect();
        let off: f64 = f[ioff].parse().unwrap();
        let tgt: f64 = f[itgt].parse().unwrap();
        prop_assert!(off.is_finite() && tgt.is_finite());
        // Written with 4 decimals.
        prop_assert!((tgt - rc).abs() <= 5.1e-5, "row {k}: target {tgt} vs {rc}");
        prop_assert!(
            (off - applied).abs() <= 5.1e-5,
            "row {k}: offset {off} vs {applied}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
    Ok(())
}

#[test]
fn replay_matches_the_documented_chain_on_random_logs() {
    for (i, mut runner) in prop_runners(12, 0x6ea2_c0b1).into_iter().enumerate() {
        runner
            .run(&case(), |c| run_case(&c, &format!("valid{i}")))
            .unwrap();
    }
}

/// One configuration key set out of its range: (key as the user writes it, TOML line).
fn bad_key() -> impl Strategy<Value = (&'static str, String)> {
    prop_oneof![
        (-10.0f64..-0.001).prop_map(|v| ("dead_band_um", format!("dead_band_um = {v:?}"))),
        (-10.0f64..=0.0).prop_map(|v| ("max_offset_um", format!("max_offset_um = {v:?}"))),
        (-10.0f64..=0.0).prop_map(|v| ("max_step_um", format!("max_step_um = {v:?}"))),
        Just(("dead_band_um", "dead_band_um = nan".to_owned())),
        Just(("max_offset_um", "max_offset_um = inf".to_owned())),
    ]
}

#[test]
fn replay_names_the_key_of_a_random_bad_configuration() {
    for (i, mut runner) in prop_runners(8, 0x6ea2_c0b1).into_iter().enumerate() {
        runner
            .run(&(case(), bad_key()), |(c, (key, line))| {
                let dir = temp_dir("replay-props", &format!("badcfg{i}"));
                let mut text = config_text(&c);
                // Replace the key's line (or add it to the axis) with the bad value.
                let kept: Vec<&str> = text
                    .lines()
                    .filter(|l| !l.starts_with(&format!("{key} =")))
                    .collect();
                text = kept.join("\n");
                text = text.replacen(
                    "apply = { kind = \"command\" }",
                    &format!("apply = {{ kind = \"command\" }}\n{line}"),
                    1,
                );
                let cfg = dir.join("cfg.toml");
                let log = dir.join("log.csv");
                std::fs::write(&cfg, &text).unwrap();
                std::fs::write(&log, log_text(&c)).unwrap();
                let o = gearcomp_cmd()
                    .args(["replay", "--config"])
                    .arg(&cfg)
                    .arg("--data")
                    .arg(&log)
                    .output()
                    .unwrap();
                let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
                prop_assert!(!o.status.success(), "accepted {line}");
                prop_assert!(stderr.contains(key), "{line}: {stderr}");
                prop_assert!(!stderr.contains("panicked"), "{stderr}");
                prop_assert!(o.stdout.is_empty());
                std::fs::remove_dir_all(&dir).ok();
                Ok(())
            })
            .unwrap();
    }
}

#[test]
fn replay_reports_every_random_bad_cell_with_its_line() {
    for (i, mut runner) in prop_runners(8, 0x6ea2_c0b1).into_iter().enumerate() {
        runner
            .run(&(case(), any::<prop::sample::Index>()), |(c, pick)| {
                let dir = temp_dir("replay-props", &format!("badcell{i}"));
                let cfg = dir.join("cfg.toml");
                let log = dir.join("log.csv");
                std::fs::write(&cfg, config_text(&c)).unwrap();
                let text = log_text(&c);
                let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
                let row = 1 + pick.index(c.rows.len());
                let ch = pick.index(c.channels);
                let mut cells: Vec<String> = lines[row].split(',').map(str::to_owned).collect();
                cells[1 + ch] = "n/a".into();
                lines[row] = cells.join(",");
                std::fs::write(&log, lines.join("\n") + "\n").unwrap();
                let o = gearcomp_cmd()
                    .args(["replay", "--config"])
                    .arg(&cfg)
                    .arg("--data")
                    .arg(&log)
                    .output()
                    .unwrap();
                let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
                prop_assert!(!stderr.contains("panicked"), "{stderr}");
                // The line number counts the header as line 1.
                let want = format!("log.csv:{}: column t{ch}_c", row + 1);
                prop_assert!(stderr.contains(&want), "{want}: {stderr}");
                // Nothing dropped: one output row per log row.
                let out_rows = String::from_utf8_lossy(&o.stdout).lines().count();
                prop_assert_eq!(out_rows, c.rows.len() + 1);
                std::fs::remove_dir_all(&dir).ok();
                Ok(())
            })
            .unwrap();
    }
}
