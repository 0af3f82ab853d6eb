//! Issue 13 item 7: F0 refused, every range error with its line, no lead for a spur gear,
//! the block cap; and random G83 blocks against the slider-crank and EGB closed forms.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::{PI, TAU};

use gearcomp_shaping::gcode::{parse_program, MachineData, MAX_G83_BLOCKS};
use gearcomp_shaping::interpolator::Interpolator;
use gearcomp_shaping::servo::ServoModel;
use gearcomp_shaping::simulate::simulate;
use gearcomp_shaping::ShapingError;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn block_err(text: &str) -> (usize, usize, String) {
    let p = match parse_program(text) {
        Ok(p) => p,
        Err(ShapingError::Parse {
            line,
            column,
            message,
        }) => return (line, column, message),
        Err(e) => panic!("{e}"),
    };
    let m = MachineData {
        strokes: 2,
        ..MachineData::default()
    };
    for b in &p.cycles {
        match b.to_simulation(&m) {
            Ok(_) => {}
            Err(ShapingError::Parse {
                line,
                column,
                message,
            }) => return (line, column, message),
            Err(e) => panic!("not located: {e}"),
        }
    }
    panic!("{text:?} was accepted")
}

/// `G83 T40 L25 Q3 P15 R25 K200 S300 F0 B40` "cut" with 0 C1 counts per stroke.
#[test]
fn zero_circular_feed_is_refused_with_line_and_range() {
    let (line, col, msg) = block_err("%\nN10 G83 T40 L25 Q3 P15 R25 K200 S300 F0 B40\n");
    assert_eq!((line, col), (2, 38), "{msg}");
    assert!(
        msg.contains("circular feed F") && msg.contains("= 0 mm") && msg.contains("..= 10 mm"),
        "{msg}"
    );
}

/// Range errors of S, B, U, X, E, F (and the other words) carry the line and the column
/// of the word.
#[test]
fn every_range_error_has_its_line_and_word() {
    let base = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40";
    for (word, needle) in [
        ("S0", "strokes per minute S"),
        ("S4000", "strokes per minute S"),
        ("B1", "facewidth B"),
        ("B49", "facewidth B"),
        ("U2", "radial feed U"),
        ("X150", "radial depth X"),
        ("E11", "lift-off E"),
        ("F11", "circular feed F"),
        ("F0", "circular feed F"),
        ("Q0.05", "normal module Q"),
        ("P50", "helix angle P"),
        ("R0.01", "crank radius R"),
        ("K20", "rod length K"),
        ("T0", "T (workpiece teeth)"),
        ("L2000", "L (cutter teeth)"),
    ] {
        let letter = &word[..1];
        let block: Vec<&str> = base
            .split(' ')
            .map(|w| if w.starts_with(letter) { word } else { w })
            .collect();
        let block = block.join(" ");
        let col = block.find(word).unwrap() + 1;
        let text = format!("%\n(first block is fine)\n{base}\n{block}\nM30\n");
        let (line, column, msg) = block_err(&text);
        assert_eq!(line, 4, "{word}: {msg}");
        assert_eq!(column, col, "{word}: {msg}");
        assert!(msg.contains(needle), "{word}: {msg}");
    }
}

/// A spur gear has no lead: none designed, none measured (4.89e20 mm was printed).
#[test]
fn spur_gear_has_no_lead() {
    let p = parse_program("G83 T40 L25 Q3 P0 R25 K200 S300 F0.5 B40").unwrap();
    let m = MachineData {
        strokes: 2,
        ..MachineData::default()
    };
    let cfg = p.cycles[0].to_simulation(&m).unwrap();
    let r = simulate(&cfg).unwrap();
    assert_eq!(r.lead.design_lead_mm, None);
    assert_eq!(r.lead.measured_lead_mm, None);
    assert_eq!(r.lead.lead_rel_error, None);
    assert!(r.lead.f_h_beta_um.is_finite());
    // A helical gear still has both.
    let p = parse_program("G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40").unwrap();
    let r = simulate(&p.cycles[0].to_simulation(&m).unwrap()).unwrap();
    let design = PI * 3.0 * 40.0 / 15f64.to_radians().sin();
    assert!((r.lead.design_lead_mm.unwrap() - design).abs() < 1e-9 * design);
    assert!(r.lead.measured_lead_mm.unwrap().is_finite());
}

/// A program of more than MAX_G83_BLOCKS G83 blocks is refused at parse time, at the first
/// block too many.
#[test]
fn too_many_blocks_are_refused_at_parse_time() {
    let line = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40\n";
    let ok = line.repeat(MAX_G83_BLOCKS);
    assert_eq!(parse_program(&ok).unwrap().cycles.len(), MAX_G83_BLOCKS);
    let t = std::time::Instant::now();
    let big = line.repeat(250_000);
    match parse_program(&big).unwrap_err() {
        ShapingError::Parse { line, message, .. } => {
            assert_eq!(line, MAX_G83_BLOCKS + 1);
            assert!(message.contains("at most 100"), "{message}");
        }
        e => panic!("{e}"),
    }
    // Refused while reading the first blocks, not after all 250 000.
    assert!(t.elapsed().as_secs_f64() < 5.0);
}

/// Closed forms written here: slider-crank stroke position and velocity (Procedia CIRP 56 (2016) eqs.
/// (2)–(3)), and the EGB law of Procedia CIRP 56 (2016) eq. (1),
/// n_C2 = ρ·n_C1 + σ·sin β'/(π·m_n·Z_C2)·v_Z, ρ = ∓Z_C1/Z_C2, in rad/s:
/// ω_C2 = ρ·ω_C1 + σ·2·sin β'/(m_n·Z_C2)·v_Z, and its position form
/// C2 = ρ·C1 + σ·2·sin β'/(m_n·Z_C2)·(Z − Z_0).
#[test]
fn random_g83_blocks_follow_the_crank_and_egb_closed_forms() {
    let strategy = (
        (10u32..150, 12u32..80, 0.5..8.0f64, -40.0..40.0f64),
        (prop::bool::ANY, 10.0..60.0f64, 4.0..10.0f64, 20.0..200.0f64),
        (
            0.2..2.0f64,
            0.0..1.0f64,
            prop::collection::vec(0u32..3_600_000, 20),
        ),
    );
    type Block = (
        (u32, u32, f64, f64),
        (bool, f64, f64, f64),
        (f64, f64, Vec<u32>),
    );
    let checked = std::cell::Cell::new(0u32);
    let check = |((z1, z2, m_n, beta), (internal, r, lam, s), (f, bfrac, raws)): Block| {
        let z1 = if internal { z1.max(z2 + 10) } else { z1 };
        let k = r * lam;
        let b = 4.0 + bfrac * (2.0 * r - 2.0 - 4.0);
        let text = format!(
            "G83 T{z1} L{z2} Q{m_n} P{beta} I{} R{r} K{k} S{s} F{f} B{b}",
            u8::from(internal)
        );
        let p = parse_program(&text).unwrap();
        let m = MachineData {
            delay_compensation_cycles: 0.0,
            ..MachineData::default()
        };
        let cfg = match p.cycles[0].to_simulation(&m) {
            Ok(c) => c,
            Err(ShapingError::Parse { message, line, .. }) => {
                // Only an infeasible set-up (axis limits) may be refused, with its line.
                prop_assert!(
                    line == 1 && message.contains("infeasible"),
                    "{text}: {message}"
                );
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(format!("{text}: {e}"))),
        };
        let mut ip = Interpolator::new(cfg.interp).unwrap();
        checked.set(checked.get() + 1);
        let cpr = f64::from(m.crank_counts_per_rev);
        let rho = if internal { 1.0 } else { -1.0 } * f64::from(z1) / f64::from(z2);
        let right = beta >= 0.0;
        let sigma = if right != internal { 1.0 } else { -1.0 };
        let beta_r = beta.abs().to_radians();
        let k_h = sigma * 2.0 * beta_r.sin() / (m_n * f64::from(z2));
        // C1 per stroke: F on the pitch circle r_C1 = m_n·Z_C1/(2 cos β), whole counts.
        let r_c1 = m_n * f64::from(z1) / (2.0 * beta_r.cos());
        let c1_counts = (f / r_c1 * f64::from(m.c1_counts_per_rev) / TAU).round();
        prop_assert_eq!(ip.c1_counts_per_stroke() as f64, c1_counts);
        let z_of = |th: f64| (k * k - r * r * th.sin().powi(2)).sqrt() - r * th.cos() - (k - r);
        let dz_of = |th: f64| {
            r * th.sin() - r * r * th.sin() * th.cos() / (k * k - r * r * th.sin().powi(2)).sqrt()
        };
        let z0 = z_of(0.0);
        // Steady crank: successive readings one cycle apart (the speed estimate then equals
        // the nominal speed exactly), starting from count 0.
        let step = (cpr * s / 60.0 * m.cycle_ms * 1e-3).round() as u32;
        // The crank speed the encoder shows: whole counts per cycle.
        let omega = TAU * f64::from(step) / (cpr * m.cycle_ms * 1e-3);
        let mut raw = 0u32;
        let mut n_abs = 0u64;
        let mut outs = vec![(0u64, ip.cycle(0))];
        let stops: Vec<u64> = raws.iter().map(|&x| u64::from(x)).collect();
        let mut stop_i = 0;
        let total = u64::from(m.crank_counts_per_rev) + u64::from(m.crank_counts_per_rev) / 3;
        while n_abs + u64::from(step) <= total && stop_i < stops.len() {
            n_abs += u64::from(step);
            raw = (raw + step) % m.crank_counts_per_rev;
            let o = ip.cycle(raw);
            if n_abs % u64::from(m.crank_counts_per_rev) >= stops[stop_i] / 2 {
                outs.push((n_abs, o));
                stop_i += 1;
            }
        }
        for (n, o) in outs.iter().skip(1) {
            let th = TAU * (*n % u64::from(m.crank_counts_per_rev)) as f64 / cpr;
            let z = z_of(th);
            prop_assert!(
                (o.z_mm - z).abs() < 1e-9 * (1.0 + r),
                "{text}: Z {} vs {z}",
                o.z_mm
            );
            let v = omega * dz_of(th);
            prop_assert!(
                (o.v_z_mm_s - v).abs() < 1e-6 * (1.0 + v.abs()),
                "{text}: v {} vs {v}",
                o.v_z_mm_s
            );
            // EGB velocity law.
            let w_c1 = c1_counts / f64::from(m.c1_counts_per_rev) * omega;
            prop_assert!((o.c1_vel_rad_s - w_c1).abs() < 1e-9 * (1.0 + w_c1.abs()));
            let w_c2 = rho * w_c1 + k_h * v;
            prop_assert!(
                (o.c2_vel_rad_s - w_c2).abs() < 1e-6 * (1.0 + w_c2.abs()),
                "{text}: ω_C2 {} vs {w_c2}",
                o.c2_vel_rad_s
            );
            // EGB position law (exact C1 from whole strokes plus the fraction).
            let c1 = c1_counts * (*n as f64) / cpr;
            prop_assert!(
                (o.c1_counts.to_f64() - c1).abs() < 1e-6,
                "{} vs {c1}",
                o.c1_counts.to_f64()
            );
            let c1_rad = c1 / f64::from(m.c1_counts_per_rev) * TAU;
            let c2_rad = rho * c1_rad + k_h * (z - z0);
            let c2_cmd = o.c2_counts() / f64::from(m.c2_counts_per_rev) * TAU;
            prop_assert!(
                (c2_cmd - c2_rad).abs() < 1e-9 * (1.0 + c2_rad.abs()),
                "{text}: C2 {c2_cmd} vs {c2_rad}"
            );
        }
        Ok(())
    };
    let cfg = Config {
        cases: 48,
        failure_persistence: None,
        ..Config::default()
    };
    for seed in [[1u8; 32], [2u8; 32]] {
        let mut r =
            TestRunner::new_with_rng(cfg.clone(), TestRng::from_seed(RngAlgorithm::ChaCha, &seed));
        r.run(&strategy, check).unwrap();
    }
    TestRunner::new(cfg).run(&strategy, check).unwrap();
    // Not vacuous: most random blocks are feasible and were compared.
    assert!(checked.get() > 72, "only {} blocks compared", checked.get());
}

/// Random invalid values of random words: a parse error with the line of the block and the
/// column of the word, never a panic or an unlocated error.
#[test]
fn random_invalid_words_name_line_and_word() {
    let bad = prop_oneof![
        (-100.0..0.9f64).prop_map(|v| ('S', v)),
        (3001.0..1e6f64).prop_map(|v| ('S', v)),
        (-10.0..3.9f64).prop_map(|v| ('B', v)),
        (48.5..1e4f64).prop_map(|v| ('B', v)),
        (1.01..100.0f64).prop_map(|v| ('U', v)),
        (-50.0..-0.01f64).prop_map(|v| ('U', v)),
        (100.1..1e5f64).prop_map(|v| ('X', v)),
        (10.1..1e3f64).prop_map(|v| ('E', v)),
        (-5.0..-0.01f64).prop_map(|v| ('E', v)),
        (-5.0..0.00005f64).prop_map(|v| ('F', v)),
        (10.01..1e3f64).prop_map(|v| ('F', v)),
        (25.1..1e3f64).prop_map(|v| ('Q', v)),
        (45.5..89.0f64).prop_map(|v| ('P', v)),
        (-2000.0..0.0f64).prop_map(|v| ('L', v.round())),
    ];
    let check = |((letter, value), pre): ((char, f64), usize)| {
        let base = "G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 X6.75 E0.2 B40";
        let word = format!("{letter}{value}");
        let block: Vec<String> = base
            .split(' ')
            .map(|w| {
                if w.starts_with(letter) {
                    word.clone()
                } else {
                    w.to_string()
                }
            })
            .collect();
        let block = block.join(" ");
        let col = block.find(&word).unwrap() + 1;
        let text = format!("{}{block}\n", format!("{base}\n").repeat(pre));
        let (line, column, msg) = block_err(&text);
        prop_assert_eq!(line, pre + 1, "{}: {}", block, msg);
        prop_assert_eq!(column, col, "{}: {}", block, msg);
        prop_assert!(msg.contains(letter), "{block}: {msg}");
        Ok(())
    };
    let cfg = Config {
        cases: 64,
        failure_persistence: None,
        ..Config::default()
    };
    let strategy = (bad, 0usize..3);
    let mut r = TestRunner::new_with_rng(
        cfg.clone(),
        TestRng::from_seed(RngAlgorithm::ChaCha, &[4u8; 32]),
    );
    r.run(&strategy, check).unwrap();
    TestRunner::new(cfg).run(&strategy, check).unwrap();
}

#[allow(dead_code)]
fn _servo_is_public(_: ServoModel) {}
