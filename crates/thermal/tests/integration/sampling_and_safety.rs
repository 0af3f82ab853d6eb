//! Sampling triggers, time averaging, and the per-axis safety chain (clamp, rate limit,
//! safe points), plus the SINUMERIK-style position term, with hand-computed sequences.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_thermal::{Alarm, AxisStatus, Engine, EngineConfig, Inputs, Output, Reading};

fn engine(sampling: &str, axis: &str, terms: &str) -> Engine {
    let cfg = format!(
        "{sampling}\n[[channels]]\nname = \"T\"\nsensor = {{ kind = \"celsius\" }}\nvalid_min = -50.0\nvalid_max = 150.0\nstale_timeout_s = 100.0\n\
         [[axes]]\nname = \"Z\"\n{axis}\n[[axes.terms]]\n{terms}\n"
    );
    Engine::new(&EngineConfig::from_toml_str(&cfg).unwrap()).unwrap()
}

fn step(e: &mut Engine, t: f64, temp: f64, safe: bool, pos: &[f64]) -> Output {
    let r = [Reading {
        raw: temp,
        stamp_s: t,
    }];
    e.step(&Inputs {
        time_s: t,
        readings: &r,
        trigger: false,
        safe_point: safe,
        positions_mm: pos,
    })
}

const LINEAR: &str = "kind = \"linear\"\nchannel = \"T\"\nkd_um_per_c = 1.0";
const COMMAND: &str = "apply = { kind = \"command\" }\nmax_offset_um = 100.0";

/// A 10 s clock with 1 s cycles and N = 2: samples at t = 0, 10, 20, 30 → averages at
/// t = 10 (of T(0), T(10)) and t = 30 (of T(20), T(30)); T = t °C.
#[test]
fn clock_trigger_and_block_average() {
    let mut e = engine(
        "[sampling]\ntrigger = { kind = \"clock\", period_s = 10.0 }\nsamples_per_average = 2",
        COMMAND,
        LINEAR,
    );
    let mut averaged_at = Vec::new();
    for k in 0..=35 {
        let out = step(&mut e, k as f64, k as f64, true, &[]);
        if out.averaged {
            averaged_at.push((k, out.axes()[0].law_um));
        }
    }
    assert_eq!(averaged_at, vec![(10, 5.0), (30, 25.0)]);
}

/// Moving window of M = 3 averages: T = 0, 3, 6, 9 → 0, 1.5, 3, 6.
#[test]
fn moving_window_time_average() {
    let mut e = engine(
        "[sampling]\ntime_filter = { kind = \"moving_window\", averages = 3 }",
        COMMAND,
        LINEAR,
    );
    let laws: Vec<f64> = (0..4)
        .map(|k| step(&mut e, k as f64, 3.0 * k as f64, true, &[]).axes()[0].law_um)
        .collect();
    assert_eq!(laws, vec![0.0, 1.5, 3.0, 6.0]);
}

/// Target 10 µm, rate limit 3 µm/cycle, applied only at safe points: 0 (not safe), 3, 6,
/// (not safe: hold 6), 9, 10. Then a law of 120 µm is clamped to the 100 µm maximum.
#[test]
fn rate_limit_safe_points_and_clamp() {
    let mut e = engine(
        "",
        "apply = { kind = \"measuring_system\" }\nmax_offset_um = 100.0\nmax_step_um = 3.0\nsafe_points_only = true",
        LINEAR,
    );
    let safe = [false, true, true, false, true, true];
    let mut seq = Vec::new();
    for (k, s) in safe.iter().enumerate() {
        let out = step(&mut e, k as f64, 10.0, *s, &[]);
        seq.push((out.axes()[0].offset_um, out.axes()[0].status));
    }
    use AxisStatus::*;
    assert_eq!(
        seq,
        vec![
            (0.0, WaitingSafePoint),
            (3.0, Ramping),
            (6.0, Ramping),
            (6.0, WaitingSafePoint),
            (9.0, Ramping),
            (10.0, Updated)
        ]
    );
    let out = step(&mut e, 10.0, 120.0, true, &[]);
    assert_eq!(out.axes()[0].status, Clamped);
    assert_eq!(out.axes()[0].target_um, 100.0);
    assert_eq!(out.axes()[0].offset_um, 13.0);
}

/// ΔK = K0(T) + tanβ(T)·(P − P0): K0 = 5 + 0.5·(T − 20) µm, tanβ = 0.01 + 0.001·(T − 20)
/// µm/mm, P0 = 100 mm; at T = 24 °C, P = 500 mm: 7 + 0.014·400 = 12.6 µm.
#[test]
fn position_dependent_term_and_missing_position() {
    let terms = "kind = \"position\"\nchannel = \"T\"\nt_ref_c = 20.0\noffset_um = 5.0\noffset_um_per_c = 0.5\n\
                 slope_um_per_mm = 0.01\nslope_um_per_mm_per_c = 0.001\np0_mm = 100.0";
    let mut e = engine("", COMMAND, terms);
    let out = step(&mut e, 0.0, 24.0, true, &[500.0]);
    assert!((out.axes()[0].offset_um - 12.6).abs() < 1e-12);
    let out = step(&mut e, 1.0, 24.0, true, &[300.0]);
    assert!((out.axes()[0].offset_um - (7.0 + 0.014 * 200.0)).abs() < 1e-12);
    let out = step(&mut e, 2.0, 24.0, true, &[]);
    assert_eq!(out.alarm, Some(Alarm::PositionMissing { axis: 0 }));
    assert_eq!(out.axes()[0].status, AxisStatus::Frozen);
    assert!((out.axes()[0].offset_um - 9.8).abs() < 1e-12);
}

#[test]
fn config_rejects_unknown_keys_and_names_bad_values() {
    let good = "[[channels]]\nname = \"T\"\nsensor = { kind = \"celsius\" }\nvalid_min = 0.0\nvalid_max = 1.0\nstale_timeout_s = 1.0\n\
                [[axes]]\nname = \"Z\"\napply = { kind = \"command\" }\nmax_offset_um = 1.0\n[[axes.terms]]\nkind = \"linear\"\nchannel = \"T\"\nkd_um_per_c = 1.0\n";
    assert!(Engine::new(&EngineConfig::from_toml_str(good).unwrap()).is_ok());
    for (bad, needle) in [
        (
            good.replace("stale_timeout_s", "stale_timout_s"),
            "stale_timout_s",
        ),
        (good.replace("kd_um_per_c", "kd_um_per_k"), "kd_um_per_k"),
        (
            good.replace("{ kind = \"command\" }", "{ kind = \"command\", gain = 2 }"),
            "gain",
        ),
    ] {
        let e = EngineConfig::from_toml_str(&bad).unwrap_err().to_string();
        assert!(e.contains(needle), "{e}");
    }
    let e = Engine::new(
        &EngineConfig::from_toml_str(&good.replace("max_offset_um = 1.0", "max_offset_um = -5.0"))
            .unwrap(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("axes[0].max_offset_um = -5") && e.contains("0 < max offset"),
        "{e}"
    );
    let e = Engine::new(
        &EngineConfig::from_toml_str(&good.replace("channel = \"T\"", "channel = \"U\"")).unwrap(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("axes[0].terms[0].channel") && e.contains("\"U\"") && e.contains("T"),
        "{e}"
    );
}
