//! EP0138375 (Fellows gear shaper) worked example of docs/thermal.md, run through
//! the whole engine: N = 8 samples at the stroke switch, K·(value − midpoint) components
//! with the base subtracted, boundary constant D, pulses with the remainder carried, and
//! the averaged proximity reading above its limit stopping the machine.
//!
//! The example is in inches and °F; the configuration is written in µm and °C, converted
//! here by hand (1 in = 25 400 µm, 1 °C = 1.8 °F), so the test also checks the units.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_thermal::units::{f_to_c, inch_to_um, um_to_inch};
use gearcomp_thermal::{AxisStatus, Engine, EngineConfig, EngineStatus, Inputs, Reading};

// K_P = 1.5, X = 0.0500 in = 1270 µm; K_B = 0.00008 in/°F = 3.6576 µm/°C, Y = 70 °F;
// K_S = 0.00010 in/°F = 4.572 µm/°C, Z = 70 °F = 21.1111 °C; D = 0.0002 in = 5.08 µm;
// pulse = 0.0001 in = 2.54 µm; P ∈ [0.040, 0.060] in = [1016, 1524] µm;
// B, S ∈ [50, 100] °F = [10, 37.7778] °C.
const CONFIG: &str = r#"
[sampling]
trigger = { kind = "input" }
samples_per_average = 8

[[channels]]
name = "proximity"
sensor = { kind = "displacement", gain_um_per_unit = 25400.0 }
valid_min = 0.0
valid_max = 5000.0
limit_min = 1016.0
limit_max = 1524.0
stale_timeout_s = 5.0

[[channels]]
name = "base"
sensor = { kind = "celsius" }
valid_min = -20.0
valid_max = 80.0
limit_min = 10.0
limit_max = 37.77777777777778
stale_timeout_s = 5.0

[[channels]]
name = "sub_base"
sensor = { kind = "celsius" }
valid_min = -20.0
valid_max = 80.0
limit_min = 10.0
limit_max = 37.77777777777778
stale_timeout_s = 5.0

[[axes]]
name = "X"
apply = { kind = "pulses", pulse_um = 2.54 }
dead_band_um = 5.08
max_offset_um = 500.0

[[axes.terms]]
kind = "component"
channel = "proximity"
k_um_per_unit = 1.5
midpoint = 1270.0

[[axes.terms]]
kind = "component"
channel = "sub_base"
k_um_per_unit = 4.572
midpoint = 21.11111111111111

[[axes.terms]]
kind = "component"
channel = "base"
k_um_per_unit = 3.6576
midpoint = 21.11111111111111
sign = "minus"
"#;

/// Runs one EP0138375 cycle: 8 stroke-switch samples whose means are the given averages
/// (P in inches, B and S in °F), spread ±3 steps so the average is really computed.
fn cycle(
    engine: &mut Engine,
    t0_s: f64,
    p_in: f64,
    b_f: f64,
    s_f: f64,
) -> gearcomp_thermal::Output {
    let spread = [-3.0, 3.0, -1.0, 1.0, -2.0, 2.0, -0.5, 0.5];
    let mut last = None;
    for (k, d) in spread.iter().enumerate() {
        let t = t0_s + k as f64;
        let r = [
            Reading {
                raw: p_in + d * 1e-5,
                stamp_s: t,
            },
            Reading {
                raw: f_to_c(b_f) + d * 0.01,
                stamp_s: t,
            },
            Reading {
                raw: f_to_c(s_f) + d * 0.01,
                stamp_s: t,
            },
        ];
        let out = engine.step(&Inputs {
            time_s: t,
            readings: &r,
            trigger: true,
            safe_point: true,
            positions_mm: &[],
        });
        if k < 7 {
            assert!(!out.averaged, "no average before the 8th sample");
            assert_eq!(out.axes()[0].pulses, 0);
        }
        last = Some(out);
    }
    last.unwrap()
}

#[test]
fn seed000_worked_example_pulses_dead_band_and_stop() {
    let cfg = EngineConfig::from_toml_str(CONFIG).unwrap();
    let mut engine = Engine::new(&cfg).unwrap();

    // Cycle 1: P̄ = 0.0520 in, B̄ = 74 °F, S̄ = 78 °F → C_P = 0.00300, C_B = 0.00032,
    // C_S = 0.00080, TC = 0.00348 in → +35 pulses (34.8 rounded, remainder −0.2 carried).
    let out = cycle(&mut engine, 0.0, 0.0520, 74.0, 78.0);
    let x = out.axes()[0];
    assert!(out.averaged);
    assert_eq!(out.status, EngineStatus::Running);
    assert!(
        (um_to_inch(x.law_um) - 0.00348).abs() < 1e-9,
        "TC = {} in",
        um_to_inch(x.law_um)
    );
    assert!(
        (um_to_inch(x.target_um) - 0.00348).abs() < 1e-9,
        "RC updated"
    );
    assert_eq!(x.pulses, 35);
    assert_eq!(x.status, AxisStatus::Updated);
    // The remainder: 35 pulses issued for 34.8 pulses of correction.
    let issued_um = x.pulse_total as f64 * inch_to_um(0.0001);
    assert!(((issued_um - x.offset_um) / inch_to_um(0.0001) - 0.2).abs() < 1e-9);

    // Cycle 2: TC = 0.00360 in (S̄ = 79.2 °F); |0.00360 − 0.00348| = 0.00012 < D → no update.
    let out = cycle(&mut engine, 100.0, 0.0520, 74.0, 79.2);
    let x = out.axes()[0];
    assert!((um_to_inch(x.law_um) - 0.00360).abs() < 1e-9);
    assert_eq!(x.status, AxisStatus::Held);
    assert!(
        (um_to_inch(x.target_um) - 0.00348).abs() < 1e-9,
        "running compensation kept"
    );
    assert_eq!(x.pulses, 0);
    assert_eq!(x.pulse_total, 35);

    // Cycle 3: P̄ = 0.0650 in > P_hi = 0.060 in → stop request, no correction.
    let out = cycle(&mut engine, 200.0, 0.0650, 74.0, 78.0);
    assert_eq!(out.status, EngineStatus::StopRequested);
    let stop = out.stop.expect("stop reason");
    assert_eq!(stop.channel, 0, "the proximity channel");
    assert!((um_to_inch(stop.value) - 0.0650).abs() < 1e-9);
    assert!((um_to_inch(stop.limit_max) - 0.060).abs() < 1e-12);
    let x = out.axes()[0];
    assert_eq!(x.status, AxisStatus::Stopped);
    assert_eq!(x.pulses, 0);
    assert_eq!(x.pulse_total, 35);

    // The stop is latched: good readings do not restart compensation until acknowledged.
    let out = cycle(&mut engine, 300.0, 0.0520, 74.0, 78.0);
    assert_eq!(out.status, EngineStatus::StopRequested);
    engine.acknowledge_stop();
    let out = cycle(&mut engine, 400.0, 0.0520, 74.0, 78.0);
    assert_eq!(out.status, EngineStatus::Running);
}

/// The remainder is carried, not dropped: three corrections of 34.8 pulses each give
/// 35 (r = −0.2), 35 (r = −0.4), 34 (r = +0.4) → 104 pulses for 104.4, where rounding
/// each correction alone would give 105.
#[test]
fn pulse_remainder_is_carried() {
    let cfg = EngineConfig::from_toml_str(CONFIG).unwrap();
    let mut engine = Engine::new(&cfg).unwrap();
    let mut totals = Vec::new();
    // Each step raises TC by 0.00348 in through the proximity channel alone:
    // ΔP = 0.00348/1.5 in; B̄ = S̄ = 70 °F so C_B = C_S = 0.
    for k in 1..=3 {
        let p_in = 0.0500 + k as f64 * 0.00348 / 1.5;
        let out = cycle(&mut engine, k as f64 * 100.0, p_in, 70.0, 70.0);
        totals.push(out.axes()[0].pulse_total);
    }
    assert_eq!(totals, vec![35, 70, 104]);
}
