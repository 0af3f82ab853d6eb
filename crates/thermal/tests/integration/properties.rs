//! Property tests: conversions round-trip, the boundary constant and the rate limit hold
//! for any input sequence, and no input makes `step` panic.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use gearcomp_thermal::sensor::{
    ntc_beta_resistance_ohm, ntc_beta_temperature_c, rtd_resistance_ohm, rtd_temperature_c,
};
use gearcomp_thermal::{AxisStatus, Engine, EngineConfig, Inputs, Reading};
use proptest::prelude::*;

fn engine(dead_band_um: f64, max_step_um: f64, safe_only: bool) -> Engine {
    let cfg = format!(
        r#"
[[channels]]
name = "T"
sensor = {{ kind = "celsius" }}
valid_min = -50.0
valid_max = 150.0
stale_timeout_s = 1000.0
[[axes]]
name = "Z"
apply = {{ kind = "pulses", pulse_um = 0.7 }}
dead_band_um = {dead_band_um}
max_offset_um = 100.0
max_step_um = {max_step_um}
safe_points_only = {safe_only}
[[axes.terms]]
kind = "linear"
channel = "T"
kd_um_per_c = -2.0
alpha_um = 40.0
"#
    );
    Engine::new(&EngineConfig::from_toml_str(&cfg).unwrap()).unwrap()
}

proptest! {
    #[test]
    fn rtd_round_trip(t in -200.0f64..850.0) {
        let r = rtd_resistance_ohm(t, 100.0);
        prop_assert!((rtd_temperature_c(r, 100.0).unwrap() - t).abs() < 1e-9);
    }

    #[test]
    fn ntc_round_trip(t in -40.0f64..150.0, beta in 2000.0f64..5000.0) {
        let r = ntc_beta_resistance_ohm(t, 10_000.0, 25.0, beta);
        prop_assert!((ntc_beta_temperature_c(r, 10_000.0, 25.0, beta).unwrap() - t).abs() < 1e-9);
    }

    /// Any temperature sequence: the offset never moves more than the rate limit per
    /// cycle, never exceeds the maximum, the target changes only by ≥ D, and the pulses
    /// issued track the applied offset within half a pulse (the remainder is carried).
    #[test]
    fn dead_band_rate_limit_and_pulses_hold(
        temps in proptest::collection::vec(-40.0f64..140.0, 1..200),
        dead_band in 0.0f64..5.0,
        max_step in 0.1f64..10.0,
        safe in proptest::collection::vec(any::<bool>(), 200),
        safe_only in any::<bool>(),
    ) {
        let mut e = engine(dead_band, max_step, safe_only);
        let (mut prev_off, mut prev_target) = (0.0f64, 0.0f64);
        for (k, t) in temps.iter().enumerate() {
            let r = [Reading { raw: *t, stamp_s: k as f64 }];
            let out = e.step(&Inputs { time_s: k as f64, readings: &r, trigger: true, safe_point: safe[k], positions_mm: &[] });
            let z = out.axes()[0];
            prop_assert!((z.offset_um - prev_off).abs() <= max_step + 1e-9);
            prop_assert!(z.offset_um.abs() <= 100.0 + 1e-9);
            if z.target_um != prev_target {
                prop_assert!((z.target_um - prev_target).abs() >= dead_band - 1e-9);
            }
            if safe_only && !safe[k] {
                prop_assert_eq!(z.offset_um, prev_off);
            }
            prop_assert!((z.pulse_total as f64 * 0.7 - z.offset_um).abs() <= 0.35 + 1e-9);
            if z.status == AxisStatus::Held {
                prop_assert_eq!(z.target_um, prev_target);
            }
            prev_off = z.offset_um;
            prev_target = z.target_um;
        }
    }

    /// Wide, hostile input: any raw value, stamp and time; `step` never panics and the
    /// offset stays finite and bounded.
    #[test]
    fn step_never_panics(
        cycles in proptest::collection::vec(
            (prop_oneof![any::<f64>(), -1e6f64..1e6], prop_oneof![any::<f64>(), 0.0f64..1e4], any::<f64>(), any::<bool>()),
            1..100),
    ) {
        let mut e = engine(0.5, 1.0, false);
        for (raw, stamp, time, trig) in cycles {
            let r = [Reading { raw, stamp_s: stamp }];
            let out = e.step(&Inputs { time_s: time, readings: &r, trigger: trig, safe_point: trig, positions_mm: &[] });
            let z = out.axes()[0];
            prop_assert!(z.offset_um.is_finite() && z.offset_um.abs() <= 100.0);
        }
    }
}
