//! The built-in simulator as an input: the lumped thermal machine of a gearcomp-thermal
//! preset, advanced in step with the service clock (sped up if asked).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::sync::Arc;
use std::time::Duration;

use gearcomp_thermal::Simulator;

use crate::cycle::{Clock, InputMsg};
use crate::error::{invalid, Result};

/// Maps engine channels to simulator sensors by name.
pub fn channel_map(sim: &Simulator, engine_channels: &[String]) -> Result<Vec<usize>> {
    let names: Vec<&str> = sim.spec().sensors.iter().map(|s| s.name.as_str()).collect();
    engine_channels
        .iter()
        .map(|n| {
            names.iter().position(|s| s == n).ok_or_else(|| {
                invalid(
                    "engine channel",
                    n,
                    format!("a sensor of the simulated machine: {}", names.join(", ")),
                )
            })
        })
        .collect()
}

/// Runs the simulator until `shutdown`: each step's readings are sent when the service
/// clock reaches the step's time, followed by the probe's measured drift (target 0).
pub fn run(
    mut sim: Simulator,
    map: Vec<usize>,
    clock: Clock,
    tx: SyncSender<InputMsg>,
    shutdown: Arc<AtomicBool>,
) {
    let origin = clock.origin_s();
    let mut first = true;
    loop {
        let st = if first {
            first = false;
            sim.state()
        } else {
            sim.advance()
        };
        let stamp_s = origin + st.time_s;
        loop {
            if shutdown.load(Ordering::Acquire) {
                return;
            }
            let now = clock.now_s();
            if now >= stamp_s {
                break;
            }
            std::thread::sleep(clock.wall(stamp_s - now).min(Duration::from_millis(20)));
        }
        let mut ok = tx
            .send(InputMsg::MachineState {
                safe_point: !st.cutting,
            })
            .is_ok();
        for (c, &s) in map.iter().enumerate() {
            ok &= tx
                .send(InputMsg::Sample {
                    channel: c as u16,
                    raw: st.raw[s],
                    stamp_s,
                })
                .is_ok();
        }
        ok &= tx
            .send(InputMsg::Target {
                target: 0,
                value: st.measured_drift_um,
                stamp_s,
            })
            .is_ok();
        if !ok {
            return;
        }
    }
}
