//! Machine presets for the simulator, each with the compensation its publication describes.
//!
//! | preset | publication | sensors | law |
//! |---|---|---|---|
//! | `grinder` | JPH0761598B2 | Pt100 bed top A, wheel-drive case B | Cz = Kz·(A − B), Kz = −3.75 µm/°C, D′ = D + Cz |
//! | `shaper` | EP0138375 | proximity P, NTC sub-base S, NTC base B | TC = K_P(P̄−X) + K_S(S̄−Z) − K_B(B̄−Y), pulses of 0.0001 in, D = 0.0002 in |
//! | `hobbing` | CN105397560 (dry) | °C on bed, column, hob head, table | a thermal model file (value and first-order-lag terms) |
//!
//! The thermal constants are illustrative; they are tuned so the uncompensated drift has
//! the magnitudes those publications report (see `docs/thermal.md`).

use gearcomp_core::model::{AxisModel, LinearModel, ModelFile, Term, Transform, MODEL_FORMAT};

use crate::config::{
    Application, AxisConfig, ChannelConfig, EngineConfig, SamplingConfig, Sign, TermConfig,
    TimeFilterConfig, Trigger,
};
use crate::error::{invalid, Result};
use crate::sensor::SensorKind;
use crate::sim::{HeatSpec, MachineSpec, NodeSpec, SensorSignal, SimSensor};
use crate::units::{f_to_c, inch_to_um, per_f_to_per_c};

/// The machines the simulator knows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    /// Surface / form grinder with a hydraulic table (JPH0761598B2).
    Grinder,
    /// Hydromechanical gear shaper (EP0138375).
    Shaper,
    /// Dry hobbing machine (CN105397560 setting).
    Hobbing,
}

impl Preset {
    /// All presets.
    pub const ALL: [Preset; 3] = [Preset::Grinder, Preset::Shaper, Preset::Hobbing];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            Preset::Grinder => "grinder",
            Preset::Shaper => "shaper",
            Preset::Hobbing => "hobbing",
        }
    }

    /// Parses a CLI name.
    pub fn from_name(name: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| invalid("preset", name, "one of grinder, shaper, hobbing"))
    }
}

/// A preset machine with its compensation.
#[derive(Debug, Clone)]
pub struct PresetBundle {
    /// The simulated machine.
    pub machine: MachineSpec,
    /// The engine configuration that compensates it.
    pub config: EngineConfig,
    /// Default shift length, h.
    pub shift_h: f64,
    /// Which seed and law the preset shows.
    pub summary: String,
}

fn node(name: &str, c: f64, g_amb: f64, g_ch: f64) -> NodeSpec {
    NodeSpec {
        name: name.into(),
        capacity_j_per_k: c,
        g_ambient_w_per_k: g_amb,
        g_chiller_w_per_k: g_ch,
    }
}

fn heat(node: usize, running_w: f64, w_per_krpm: f64, cutting_w: f64) -> HeatSpec {
    HeatSpec {
        node,
        running_w,
        w_per_krpm,
        cutting_w,
    }
}

fn sensor(name: &str, signal: SensorSignal, noise_sd: f64) -> SimSensor {
    SimSensor {
        name: name.into(),
        signal,
        noise_sd,
    }
}

fn channel(name: &str, sensor: SensorKind, valid: (f64, f64), limits: (f64, f64)) -> ChannelConfig {
    ChannelConfig {
        name: name.into(),
        sensor,
        valid_min: valid.0,
        valid_max: valid.1,
        limit_min: Some(limits.0),
        limit_max: Some(limits.1),
        stale_timeout_s: 60.0,
        stuck_timeout_s: Some(1800.0),
        stuck_tolerance: 0.0,
        plausibility: None,
    }
}

/// JPH0761598B2's surface grinder: −20 µm after about 6 h, compensated by Kz·(A − B).
pub fn grinder() -> PresetBundle {
    // Nodes: 0 hydraulic oil, 1 bed top (A), 2 wheel head (B), 3 column, 4 coolant.
    let machine = MachineSpec {
        name: "grinder".into(),
        description: "surface grinder with hydraulic Z table (JPH0761598B2)".into(),
        nodes: vec![
            node("oil", 1.2e6, 25.0, 0.0),
            node("bed_top", 2.5e6, 30.0, 0.0),
            node("wheel_head", 0.25e6, 30.0, 0.0),
            node("column", 8.0e6, 50.0, 0.0),
            node("coolant", 0.4e6, 10.0, 150.0),
        ],
        couplings: vec![(0, 1, 40.0), (1, 3, 20.0), (2, 3, 10.0), (2, 4, 8.0)],
        heat: vec![heat(0, 250.0, 0.0, 0.0), heat(2, 0.0, 120.0, 60.0)],
        ambient_mean_c: 20.0,
        ambient_amplitude_k: 1.5,
        ambient_max_at_h: 15.0,
        shift_start_h: 6.0,
        chiller_c: 20.0,
        spindle_rpm: 1500.0,
        cut_s: 300.0,
        load_s: 60.0,
        // True Z error: the bed-top/wheel-head difference of JPH0761598B2 (3.75 µm/K) plus
        // a column term the two sensors do not see.
        drift_um_per_k: vec![0.0, 3.75, -3.75, -0.6, 0.0],
        drift_noise_um: 0.3,
        sensors: vec![
            sensor("bed_top_c", SensorSignal::Pt100 { node: 1 }, 0.03),
            sensor("wheel_head_c", SensorSignal::Pt100 { node: 2 }, 0.03),
            sensor("column_c", SensorSignal::Celsius { node: 3 }, 0.03),
            sensor("oil_c", SensorSignal::Celsius { node: 0 }, 0.03),
        ],
        dt_s: 10.0,
    };
    let pt = |n: &str| channel(n, SensorKind::Pt100 {}, (-20.0, 80.0), (5.0, 45.0));
    let cel = |n: &str| channel(n, SensorKind::Celsius {}, (-20.0, 80.0), (5.0, 60.0));
    let config = EngineConfig {
        sampling: SamplingConfig {
            trigger: Trigger::EveryCycle {},
            samples_per_average: 6,
            time_filter: TimeFilterConfig::FirstOrder { tau_s: 300.0 },
        },
        channels: vec![
            pt("bed_top_c"),
            pt("wheel_head_c"),
            cel("column_c"),
            cel("oil_c"),
        ],
        axes: vec![AxisConfig {
            name: "Z".into(),
            apply: Application::MeasuringSystem {},
            dead_band_um: 0.5,
            max_offset_um: 60.0,
            max_step_um: Some(0.5),
            safe_points_only: false,
            terms: vec![TermConfig::Difference {
                a: "bed_top_c".into(),
                b: "wheel_head_c".into(),
                kz_um_per_c: -3.75,
                sign: Sign::Plus,
            }],
        }],
        models: Default::default(),
    };
    PresetBundle {
        machine,
        config,
        shift_h: 8.0,
        summary: "JPH0761598B2 surface grinder: Cz = Kz·(A − B), Kz = −3.75 µm/°C, applied to the scale (D′ = D + Cz)".into(),
    }
}

/// EP0138375's hydromechanical gear shaper: ≈ 76 µm over a run, pulses to the infeed.
pub fn shaper() -> PresetBundle {
    // Nodes: 0 base, 1 sub-base, 2 cutter-spindle housing, 3 hydraulic oil, 4 table.
    let mut machine = MachineSpec {
        name: "shaper".into(),
        description: "hydromechanical gear shaper (EP0138375)".into(),
        nodes: vec![
            node("base", 10.0e6, 60.0, 0.0),
            node("sub_base", 2.5e6, 25.0, 0.0),
            node("spindle_housing", 0.4e6, 30.0, 0.0),
            node("oil", 1.0e6, 30.0, 0.0),
            node("table", 1.5e6, 25.0, 0.0),
        ],
        couplings: vec![
            (0, 1, 30.0),
            (1, 3, 45.0),
            (2, 3, 25.0),
            (1, 4, 20.0),
            (1, 2, 10.0),
        ],
        heat: vec![heat(3, 450.0, 0.0, 0.0), heat(2, 0.0, 80.0, 40.0)],
        ambient_mean_c: 20.0,
        ambient_amplitude_k: 1.0,
        ambient_max_at_h: 15.0,
        shift_start_h: 6.0,
        chiller_c: 20.0,
        spindle_rpm: 600.0,
        cut_s: 900.0,
        load_s: 120.0,
        drift_um_per_k: vec![0.0; 5],
        drift_noise_um: 0.5,
        sensors: vec![],
        dt_s: 10.0,
    };
    let t0_c = machine.ambient_c(0.0);
    // EP0138375 example constants (docs/thermal.md "EP0138375 worked example"), converted
    // once here.
    let k_p = 1.5;
    let proximity_um_per_k = 12.0;
    let x_mid_um = inch_to_um(0.0500);
    let k_s_um_per_c = per_f_to_per_c(inch_to_um(0.00010));
    let k_b_um_per_c = per_f_to_per_c(inch_to_um(0.00008));
    // Rising temperature reduces the centre distance (EP0138375): the drift is the negative
    // of the seed's total correction, plus a table term no sensor sees.
    machine.drift_um_per_k = vec![
        k_b_um_per_c,
        -k_s_um_per_c,
        -k_p * proximity_um_per_k,
        0.0,
        -0.6,
    ];
    let ntc = |node| SensorSignal::Ntc {
        node,
        r0_ohm: 10_000.0,
        beta_k: 3950.0,
    };
    machine.sensors = vec![
        sensor(
            "proximity_um",
            SensorSignal::Displacement {
                node: 2,
                um_per_k: proximity_um_per_k,
                mid_um: x_mid_um,
            },
            0.2,
        ),
        sensor("sub_base_c", ntc(1), 0.03),
        sensor("base_c", ntc(0), 0.03),
    ];
    let ntc_kind = SensorKind::NtcBeta {
        r0_ohm: 10_000.0,
        t0_c: 25.0,
        beta_k: 3950.0,
    };
    let temp_limits = (f_to_c(50.0), f_to_c(100.0));
    let config = EngineConfig {
        sampling: SamplingConfig {
            trigger: Trigger::Input {},
            samples_per_average: 8,
            time_filter: TimeFilterConfig::None {},
        },
        channels: vec![
            channel(
                "proximity_um",
                SensorKind::Displacement {
                    gain_um_per_unit: 1.0,
                    offset_um: 0.0,
                },
                (0.0, inch_to_um(0.1)),
                (inch_to_um(0.040), inch_to_um(0.060)),
            ),
            channel("sub_base_c", ntc_kind, (-20.0, 80.0), temp_limits),
            channel("base_c", ntc_kind, (-20.0, 80.0), temp_limits),
        ],
        axes: vec![AxisConfig {
            name: "X".into(),
            apply: Application::Pulses {
                pulse_um: inch_to_um(0.0001),
            },
            dead_band_um: inch_to_um(0.0002),
            max_offset_um: 250.0,
            max_step_um: None,
            safe_points_only: true,
            terms: vec![
                TermConfig::Component {
                    channel: "proximity_um".into(),
                    k_um_per_unit: k_p,
                    midpoint: x_mid_um,
                    sign: Sign::Plus,
                },
                TermConfig::Component {
                    channel: "sub_base_c".into(),
                    k_um_per_unit: k_s_um_per_c,
                    midpoint: t0_c,
                    sign: Sign::Plus,
                },
                TermConfig::Component {
                    channel: "base_c".into(),
                    k_um_per_unit: k_b_um_per_c,
                    midpoint: t0_c,
                    sign: Sign::Minus,
                },
            ],
        }],
        models: Default::default(),
    };
    PresetBundle {
        machine,
        config,
        shift_h: 8.0,
        summary: "EP0138375 gear shaper: TC = K_P(P̄ − X) + K_S(S̄ − Z) − K_B(B̄ − Y), N = 8 samples at the stroke switch, pulses of 0.0001 in, D = 0.0002 in, applied between cuts".into(),
    }
}

/// The model file key the hobbing preset's configuration refers to.
pub const HOBBING_MODEL_KEY: &str = "preset:hobbing";

/// The dry hobbing machine's thermal model, as `gearcomp fit` would write it.
pub fn hobbing_model(t0_c: f64) -> ModelFile {
    // Offset = −drift. The column core lags the column surface with τ = C/(G_c + G_amb)
    // = 1.5e6/45 s, and follows it with the gain 40/45; the ambient share is not measured.
    let tau_s = 1.5e6 / 45.0;
    let terms = vec![
        Term {
            channel: "hob_head_c".into(),
            coefficient: 2.5,
            transform: Transform::Value,
        },
        Term {
            channel: "column_c".into(),
            coefficient: 4.0 * 40.0 / 45.0,
            transform: Transform::FirstOrderLag { tau_s },
        },
        Term {
            channel: "bed_c".into(),
            coefficient: -1.5,
            transform: Transform::Value,
        },
        Term {
            channel: "table_c".into(),
            coefficient: 1.0,
            transform: Transform::Value,
        },
    ];
    let intercept = -terms.iter().map(|t| t.coefficient).sum::<f64>() * t0_c;
    ModelFile {
        format: MODEL_FORMAT.into(),
        name: "dry hobbing machine X (preset)".into(),
        description: "simulator preset model: hob head, lagged column, bed, table".into(),
        restart_after_s: None,
        axes: vec![AxisModel {
            axis: "X".into(),
            target: "x_drift_um".into(),
            machine: LinearModel { intercept, terms },
            workpiece: None,
        }],
        provenance: None,
        envelopes: Vec::new(),
    }
}

/// A dry hobbing machine: hot chips heat bed and table; compensated by a model file.
pub fn hobbing() -> PresetBundle {
    // Nodes: 0 bed, 1 column, 2 column core (no sensor), 3 hob head, 4 table.
    let machine = MachineSpec {
        name: "hobbing".into(),
        description: "dry hobbing machine (CN105397560 setting)".into(),
        nodes: vec![
            node("bed", 8.0e6, 50.0, 0.0),
            node("column", 5.0e6, 40.0, 0.0),
            node("column_core", 1.5e6, 5.0, 0.0),
            node("hob_head", 0.3e6, 30.0, 0.0),
            node("table", 1.0e6, 20.0, 0.0),
        ],
        couplings: vec![(0, 1, 30.0), (1, 2, 40.0), (1, 3, 15.0), (0, 4, 30.0)],
        heat: vec![
            heat(0, 0.0, 0.0, 400.0),
            heat(3, 0.0, 150.0, 150.0),
            heat(4, 0.0, 0.0, 200.0),
        ],
        ambient_mean_c: 20.0,
        ambient_amplitude_k: 1.5,
        ambient_max_at_h: 15.0,
        shift_start_h: 6.0,
        chiller_c: 20.0,
        spindle_rpm: 1000.0,
        cut_s: 240.0,
        load_s: 40.0,
        drift_um_per_k: vec![1.5, 0.0, -4.0, -2.5, -1.0],
        drift_noise_um: 0.3,
        sensors: vec![
            sensor("bed_c", SensorSignal::Celsius { node: 0 }, 0.03),
            sensor("column_c", SensorSignal::Celsius { node: 1 }, 0.03),
            sensor("hob_head_c", SensorSignal::Celsius { node: 3 }, 0.03),
            sensor("table_c", SensorSignal::Celsius { node: 4 }, 0.03),
        ],
        dt_s: 10.0,
    };
    let t0_c = machine.ambient_c(0.0);
    let cel = |n: &str| channel(n, SensorKind::Celsius {}, (-20.0, 90.0), (5.0, 70.0));
    let mut config = EngineConfig {
        sampling: SamplingConfig {
            trigger: Trigger::Clock { period_s: 10.0 },
            samples_per_average: 3,
            time_filter: TimeFilterConfig::FirstOrder { tau_s: 120.0 },
        },
        channels: vec![
            cel("bed_c"),
            cel("column_c"),
            cel("hob_head_c"),
            cel("table_c"),
        ],
        axes: vec![AxisConfig {
            name: "X".into(),
            apply: Application::Command {},
            dead_band_um: 0.5,
            max_offset_um: 80.0,
            max_step_um: Some(0.5),
            safe_points_only: true,
            terms: vec![TermConfig::Model {
                file: HOBBING_MODEL_KEY.into(),
                axis: "X".into(),
                sign: Sign::Plus,
            }],
        }],
        models: Default::default(),
    };
    config.insert_model(HOBBING_MODEL_KEY, hobbing_model(t0_c));
    PresetBundle {
        machine,
        config,
        shift_h: 8.0,
        summary: "dry hobbing machine: identified linear model (thermal model file) on hob head, lagged column, bed and table, applied to the X command between parts".into(),
    }
}

/// The bundle of a preset.
pub fn bundle(p: Preset) -> PresetBundle {
    match p {
        Preset::Grinder => grinder(),
        Preset::Shaper => shaper(),
        Preset::Hobbing => hobbing(),
    }
}
