//! `Engine::step_into` (caller-owned output) against `Engine::step` (by value), and the
//! conversion cache of a raw value that repeats bit for bit.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use gearcomp_thermal::sensor::rtd_resistance_ohm;
use gearcomp_thermal::{Alarm, Engine, EngineConfig, Fault, Inputs, Output, Reading};

fn one_axis_engine() -> Engine {
    let cfg = "[[channels]]\nname = \"a\"\nsensor = { kind = \"celsius\" }\nvalid_min = -10.0\n\
               valid_max = 80.0\nstale_timeout_s = 10.0\n[[axes]]\nname = \"Z\"\n\
               apply = { kind = \"command\" }\nmax_offset_um = 100.0\n[[axes.terms]]\n\
               kind = \"linear\"\nchannel = \"a\"\nkd_um_per_c = -2.0\nalpha_um = 40.0\n";
    Engine::new(&EngineConfig::from_toml_str(cfg).unwrap()).unwrap()
}

/// An output last filled by a 1-axis engine, then reused by the 16-channel, 3-axis engine:
/// every cycle (NaN burst and stale channel included) equals what `step` returns.
#[test]
fn step_into_with_a_reused_output_equals_step() {
    let mut out = Output::EMPTY;
    let mut small = one_axis_engine();
    small.step_into(
        &Inputs {
            time_s: 0.0,
            readings: &[Reading {
                raw: 23.0,
                stamp_s: 0.0,
            }],
            trigger: true,
            safe_point: true,
            positions_mm: &[],
        },
        &mut out,
    );
    // Linear law Kd·T + α = −2·23 + 40 = −6 µm (JPH0761598B2).
    assert_eq!(out.axes().len(), 1);
    assert!((out.axes()[0].law_um + 6.0).abs() < 1e-12);

    let (mut by_value, mut into) = (common::engine_with_block(2), common::engine_with_block(2));
    let mut readings = [Reading {
        raw: 0.0,
        stamp_s: 0.0,
    }; 16];
    let positions = [250.0, 0.0, 0.0];
    let mut alarms = 0;
    for k in 0..2_000u64 {
        common::fill(&mut readings, k);
        if (500..505).contains(&k) {
            readings[9].raw = f64::NAN;
        }
        if (900..915).contains(&k) {
            readings[2].stamp_s = 890.0;
        }
        let inputs = Inputs {
            time_s: k as f64,
            readings: &readings,
            trigger: true,
            safe_point: k % 7 < 3,
            positions_mm: &positions,
        };
        let expected = by_value.step(&inputs);
        into.step_into(&inputs, &mut out);
        // `Debug` prints every f64 so that it reads back to the same bits (and NaN as NaN,
        // which `==` never equals): equal text is a bit-identical output.
        assert_eq!(format!("{out:?}"), format!("{expected:?}"), "cycle {k}");
        alarms += usize::from(out.alarm.is_some());
    }
    assert!(alarms >= 5, "the fault paths were taken: {alarms}");
}

/// Readings held bit for bit (every conversion after the first comes from the cache) give
/// the IEC 60751 temperature of the held resistance, and still go stuck once the stuck
/// timeout (600 s) has passed since the value last changed.
#[test]
fn held_raw_values_convert_from_the_cache_and_still_go_stuck() {
    let mut engine = common::engine_with_block(1);
    let mut readings = [Reading {
        raw: 0.0,
        stamp_s: 0.0,
    }; 16];
    common::fill(&mut readings, 0);
    // Channel 0 is a Pt100: 20 °C ↔ 107.79 Ω in the IEC 60751 table.
    readings[0].raw = rtd_resistance_ohm(20.0, 100.0);
    assert!((readings[0].raw - 107.79).abs() < 0.005);
    let positions = [250.0, 0.0, 0.0];
    let mut out = Output::EMPTY;
    for k in 0..=601u64 {
        for r in &mut readings {
            r.stamp_s = k as f64;
        }
        engine.step_into(
            &Inputs {
                time_s: k as f64,
                readings: &readings,
                trigger: true,
                safe_point: true,
                positions_mm: &positions,
            },
            &mut out,
        );
        if k <= 600 {
            assert_eq!(out.alarm, None, "cycle {k}");
            // A constant input through the first-order filter stays that constant.
            assert!((engine.channel_value(0) - 20.0).abs() < 1e-9);
            // Displacement: gain 100 µm per unit × 1.0.
            assert_eq!(engine.channel_value(15), 100.0);
        }
    }
    assert_eq!(
        out.alarm,
        Some(Alarm::Channel {
            channel: 0,
            fault: Fault::Stuck
        })
    );
    assert_eq!(out.alarm_count, 16);
    assert!(out
        .axes()
        .iter()
        .all(|a| a.status == gearcomp_thermal::AxisStatus::Frozen));
}
