//! Thermal compensation for gear machines: the engine that turns live sensor readings into
//! the axis offset that cancels thermal drift, safely, and a lumped thermal machine
//! simulator to demonstrate and test it.
//!
//! * [`sensor`]: NTC (β, Steinhart–Hart), Pt100/Pt1000 (IEC 60751 Callendar–Van Dusen),
//!   ready °C and displacement transducers.
//! * [`filter`]: N-sample block average, first-order filter, moving window, delay line.
//! * [`law`]: the compensation forms of EP0138375 and JPH0761598B2 and the SINUMERIK/TwinCAT
//!   position-dependent form, one pure function each.
//! * [`config`]: the TOML configuration ([`EngineConfig`]).
//! * [`engine`]: [`Engine`], built once, then [`Engine::step`] per cycle (no allocation);
//!   identified models (`gearcomp_core::model::ModelFile`) run as `kind = "model"` terms.
//! * [`sim`]: lumped thermal network with presets for the machines of EP0138375, JPH0761598B2 and CN105397560.
//! * [`demo`]: the demo shift of `gearcomp demo` (a preset, optionally a model file) and its
//!   result as text, JSON and an HTML report.
//!
//! Offsets are in µm; a positive offset increases the centre distance (see
//! `docs/thermal.md` for every convention fixed here).
//!
//! ```
//! use gearcomp_thermal::{Engine, EngineConfig, Inputs, Reading};
//! let cfg = EngineConfig::from_toml_str(r#"
//! [[channels]]
//! name = "A"
//! sensor = { kind = "celsius" }
//! valid_min = -10.0
//! valid_max = 80.0
//! stale_timeout_s = 10.0
//! [[channels]]
//! name = "B"
//! sensor = { kind = "celsius" }
//! valid_min = -10.0
//! valid_max = 80.0
//! stale_timeout_s = 10.0
//! [[axes]]
//! name = "Z"
//! apply = { kind = "measuring_system" }
//! max_offset_um = 100.0
//! [[axes.terms]]
//! kind = "difference"
//! a = "A"
//! b = "B"
//! kz_um_per_c = -3.75
//! "#)?;
//! let mut engine = Engine::new(&cfg)?;
//! let readings = [Reading { raw: 24.0, stamp_s: 0.0 }, Reading { raw: 20.0, stamp_s: 0.0 }];
//! let out = engine.step(&Inputs { time_s: 0.0, readings: &readings, trigger: false,
//!                                 safe_point: true, positions_mm: &[] });
//! assert!((out.axes()[0].offset_um - -15.0).abs() < 1e-12);
//! # Ok::<(), gearcomp_thermal::ThermalError>(())
//! ```

pub mod config;
pub mod engine;
pub mod error;
pub mod filter;
pub mod law;
pub mod sensor;
pub mod units;

pub use config::{
    Application, AxisConfig, ChannelConfig, EngineConfig, Plausibility, SamplingConfig, Sign,
    SpikeTest, TermConfig, TimeFilterConfig, Trigger,
};
pub use engine::{
    Alarm, AxisOutput, AxisStatus, Engine, EngineStatus, Excursion, Fault, Inputs, Output, Reading,
    StopReason, MAX_AXES, MAX_CHANNELS,
};
pub use error::{Result, ThermalError};
pub use sensor::SensorKind;
pub mod closed_loop;
pub mod demo;
pub mod presets;
pub mod sim;

pub use closed_loop::{drift_stats, run_closed_loop, ClosedLoopRun, DriftStats};
pub use presets::Preset;
pub use sim::{MachineSpec, SimState, Simulator};
pub mod replay;
