//! A 16-channel, 3-axis engine using every law form and transform, shared by the
//! zero-allocation test and the cycle-time benchmark.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use gearcomp_core::model::ModelFile;
use gearcomp_thermal::sensor::{ntc_beta_resistance_ohm, rtd_resistance_ohm};
use gearcomp_thermal::{Engine, EngineConfig, Reading};

const MODEL: &str = r#"
format = "gearcomp-thermal-model/1"
name = "16ch"
[[axes]]
axis = "Y"
[axes.machine]
intercept = -3.0
[[axes.machine.terms]]
channel = "c00"
coefficient = 0.8
[[axes.machine.terms]]
channel = "c01"
coefficient = -1.1
transform = { kind = "first_order_lag", tau_s = 900.0 }
[[axes.machine.terms]]
channel = "c02"
coefficient = 0.5
transform = { kind = "delay", delay_s = 600.0 }
[[axes.machine.terms]]
channel = "c03"
coefficient = 40.0
transform = { kind = "rate", tau_s = 300.0 }
[[axes.machine.terms]]
channel = "c12"
coefficient = 0.3
[axes.workpiece]
design_temp_c = 20.0
expansion_per_k = 11.5e-6
[axes.workpiece.gear]
normal_module_mm = 3.0
pressure_angle_deg = 20.0
teeth = 40
[axes.workpiece.temperature]
intercept = 2.0
[[axes.workpiece.temperature.terms]]
channel = "c13"
coefficient = 0.9

# The training envelope of Y's machine model (issue 12): the warmed-up machine leaves
# c00's range after about 5 500 s of the `fill` ramp; the Mahalanobis bound is checked at
# every averaging instant.
[[envelopes]]
axis = "Y"
ranges = [
    { channel = "c00", min = 15.0, max = 25.5 },
    { channel = "c01", min = 15.0, max = 60.0 },
    { channel = "c02", min = 15.0, max = 60.0 },
    { channel = "c03", min = 15.0, max = 60.0 },
    { channel = "c12", min = 15.0, max = 60.0 },
]
feature_mean = [20.0, 20.0, 20.0, 0.0, 20.0]
whitening = [
    0.5, 0.0, 0.0, 0.0, 0.0,
    0.1, 0.5, 0.0, 0.0, 0.0,
    0.0, 0.1, 0.5, 0.0, 0.0,
    0.0, 0.0, 0.1, 100.0, 0.0,
    0.0, 0.0, 0.0, 0.1, 0.5,
]
max_d2 = 400.0
rows = 1000
"#;

/// The configuration: c00–c07 Pt100, c08–c11 NTC, c12–c14 °C, c15 displacement; N = 4.
pub fn config() -> EngineConfig {
    config_with_block(4)
}

/// The configuration with N samples per block average (N = 1: every cycle is an
/// averaging instant, the worst case for the cycle time).
pub fn config_with_block(n: usize) -> EngineConfig {
    let mut t = format!(
        "[sampling]\nsamples_per_average = {n}\ntime_filter = {{ kind = \"first_order\", tau_s = 60.0 }}\n",
    );
    for i in 0..16 {
        let sensor = match i {
            0..=7 => "{ kind = \"pt100\" }",
            8..=11 => "{ kind = \"ntc_beta\", r0_ohm = 10000.0, beta_k = 3950.0 }",
            12..=14 => "{ kind = \"celsius\" }",
            _ => "{ kind = \"displacement\", gain_um_per_unit = 100.0 }",
        };
        t.push_str(&format!(
            "[[channels]]\nname = \"c{i:02}\"\nsensor = {sensor}\nvalid_min = -10.0\nvalid_max = 500.0\n\
             limit_max = 400.0\nstale_timeout_s = 5.0\nstuck_timeout_s = 600.0\n"
        ));
    }
    t.push_str(
        r#"
[[axes]]
name = "X"
apply = { kind = "measuring_system" }
dead_band_um = 0.2
max_offset_um = 200.0
max_step_um = 0.5
[[axes.terms]]
kind = "difference"
a = "c04"
b = "c05"
kz_um_per_c = -3.75
[[axes.terms]]
kind = "component"
channel = "c15"
k_um_per_unit = 1.5
midpoint = 100.0
[[axes.terms]]
kind = "position"
channel = "c06"
t_ref_c = 20.0
offset_um = 1.0
offset_um_per_c = 0.4
slope_um_per_mm = 0.01
slope_um_per_mm_per_c = 0.001
p0_mm = 100.0

[[axes]]
name = "Y"
apply = { kind = "command" }
max_offset_um = 200.0
[[axes.terms]]
kind = "model"
file = "m.toml"
axis = "Y"

[[axes]]
name = "Z"
apply = { kind = "pulses", pulse_um = 0.1 }
dead_band_um = 0.5
max_offset_um = 200.0
max_step_um = 1.0
safe_points_only = true
[[axes.terms]]
kind = "linear"
channel = "c07"
kd_um_per_c = -2.0
alpha_um = 40.0
[[axes.terms]]
kind = "time_linear"
a = "c08"
kz_um_per_c = -3.75
b_c_per_h = 0.3
c_c = 20.0
[[axes.terms]]
kind = "time_sqrt"
b = "c09"
kz_prime_um_per_c = 3.75
k_um_per_sqrt_h = -1.2
sign = "minus"
"#,
    );
    let mut cfg = EngineConfig::from_toml_str(&t).unwrap();
    cfg.insert_model("m.toml", ModelFile::from_toml_str(MODEL).unwrap());
    cfg
}

/// The engine (N = 4).
pub fn engine() -> Engine {
    Engine::new(&config()).unwrap()
}

/// The engine with N samples per block average.
pub fn engine_with_block(n: usize) -> Engine {
    Engine::new(&config_with_block(n)).unwrap()
}

/// Fills the readings of cycle `k` (1 s cycles, warming machine) without allocating.
pub fn fill(readings: &mut [Reading; 16], k: u64) {
    let t = k as f64;
    for (i, r) in readings.iter_mut().enumerate() {
        let temp = 20.0 + 0.001 * t * (1.0 + i as f64 * 0.1) + 0.01 * ((t + i as f64) * 0.37).sin();
        let raw = match i {
            0..=7 => rtd_resistance_ohm(temp, 100.0),
            8..=11 => ntc_beta_resistance_ohm(temp, 10_000.0, 25.0, 3950.0),
            12..=14 => temp,
            _ => 1.0 + 5e-6 * t,
        };
        *r = Reading { raw, stamp_s: t };
    }
}
