//! Runs the engine against the simulator in closed loop and evaluates the result the way
//! an ISO 230-3 thermal test reports drift.

use crate::engine::{Engine, EngineStatus, Inputs, Reading};
use crate::error::{invalid, Result};
use crate::sim::Simulator;
use crate::units::s_to_h;

/// Drift figures of one error series, µm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriftStats {
    /// Largest |error|.
    pub max_abs_um: f64,
    /// Root mean square of the error.
    pub rms_um: f64,
    /// Drift range, max − min over the period (ISO 230-3 "total drift").
    pub range_um: f64,
}

/// ISO 230-3 style figures of an error series.
///
/// # Formula
/// max |e|;  RMS = √(Σe²/n);  range = max e − min e
/// # Source
/// ISO 230-3:2020 (drift range as total drift over the test period) [STANDARD; clause
/// numbers not checked against the standard's text]
pub fn drift_stats(errors_um: &[f64]) -> DriftStats {
    if errors_um.is_empty() {
        return DriftStats {
            max_abs_um: 0.0,
            rms_um: 0.0,
            range_um: 0.0,
        };
    }
    let (mut lo, mut hi, mut ss, mut ma) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0.0f64);
    for &e in errors_um {
        lo = lo.min(e);
        hi = hi.max(e);
        ss += e * e;
        ma = ma.max(e.abs());
    }
    DriftStats {
        max_abs_um: ma,
        rms_um: (ss / errors_um.len() as f64).sqrt(),
        range_um: hi - lo,
    }
}

/// Time series of a closed-loop run (first axis = the centre distance).
#[derive(Debug, Clone, Default)]
pub struct ClosedLoopRun {
    /// Time, h.
    pub time_h: Vec<f64>,
    /// Ambient temperature, °C.
    pub ambient_c: Vec<f64>,
    /// Sensor values (engineering units), one series per sensor.
    pub sensors: Vec<Vec<f64>>,
    /// Sensor names.
    pub sensor_names: Vec<String>,
    /// True drift = size error without compensation, µm.
    pub drift_um: Vec<f64>,
    /// Applied offset, µm.
    pub offset_um: Vec<f64>,
    /// Residual error with compensation = drift + offset, µm.
    pub residual_um: Vec<f64>,
    /// Cycles with an alarm.
    pub alarm_cycles: usize,
    /// Cycles with a stop request.
    pub stop_cycles: usize,
    /// Pulses issued in total (pulse application).
    pub pulse_total: i64,
}

impl ClosedLoopRun {
    /// Figures without compensation.
    pub fn uncompensated(&self) -> DriftStats {
        drift_stats(&self.drift_um)
    }

    /// Figures with compensation.
    pub fn compensated(&self) -> DriftStats {
        drift_stats(&self.residual_um)
    }
}

/// Simulates `hours` with the engine in the loop. `progress(fraction)` is called about
/// 20 times. Every simulator step is a cycle with the sample trigger set (the stroke
/// switch), and the load/unload interval is the safe point.
pub fn run_closed_loop(
    sim: &mut Simulator,
    engine: &mut Engine,
    hours: f64,
    mut progress: impl FnMut(f64),
) -> Result<ClosedLoopRun> {
    if !(hours.is_finite() && hours > 0.0 && hours <= 24.0 * 14.0) {
        return Err(invalid("hours", hours, "0 < hours ≤ 336"));
    }
    let names: Vec<String> = sim.spec().sensors.iter().map(|s| s.name.clone()).collect();
    // The engine reads its channels in its own order; map them to simulator sensors.
    let map: Vec<usize> = engine
        .channel_names()
        .iter()
        .map(|n| {
            names.iter().position(|s| s == n).ok_or_else(|| {
                invalid(
                    "channel",
                    n,
                    &format!("a simulator sensor: {}", names.join(", ")),
                )
            })
        })
        .collect::<Result<_>>()?;
    let steps = sim.steps_for_hours(hours);
    let mut run = ClosedLoopRun {
        sensor_names: names.clone(),
        sensors: vec![Vec::with_capacity(steps + 1); names.len()],
        ..Default::default()
    };
    let mut readings = vec![
        Reading {
            raw: 0.0,
            stamp_s: 0.0
        };
        map.len()
    ];
    let every = (steps / 20).max(1);
    for k in 0..=steps {
        let st = if k == 0 {
            sim.state().clone()
        } else {
            sim.advance().clone()
        };
        for (r, &s) in readings.iter_mut().zip(&map) {
            *r = Reading {
                raw: st.raw[s],
                stamp_s: st.time_s,
            };
        }
        let out = engine.step(&Inputs {
            time_s: st.time_s,
            readings: &readings,
            trigger: true,
            safe_point: !st.cutting,
            positions_mm: &[],
        });
        let offset = out.axes().first().map_or(0.0, |a| a.offset_um);
        run.pulse_total = out.axes().first().map_or(0, |a| a.pulse_total);
        match out.status {
            EngineStatus::Running => {}
            EngineStatus::Alarm => run.alarm_cycles += 1,
            EngineStatus::StopRequested => run.stop_cycles += 1,
        }
        run.time_h.push(s_to_h(st.time_s));
        run.ambient_c.push(st.ambient_c);
        for (series, v) in run.sensors.iter_mut().zip(&st.value) {
            series.push(*v);
        }
        run.drift_um.push(st.drift_um);
        run.offset_um.push(offset);
        run.residual_um.push(st.drift_um + offset);
        if k % every == 0 {
            progress(k as f64 / steps.max(1) as f64);
        }
    }
    Ok(run)
}
