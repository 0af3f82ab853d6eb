//! The engine configuration (TOML): channels, sampling, and one law per axis.
//!
//! Every struct denies unknown fields, so a misspelt key is an error naming it rather
//! than a silently ignored setting. Ranges are checked in [`crate::Engine::new`], which
//! names the field, the value and the allowed range.

use std::collections::BTreeMap;
use std::path::Path;

use gearcomp_core::model::ModelFile;
use serde::{Deserialize, Serialize};

use crate::error::{Result, ThermalError};
use crate::sensor::SensorKind;

/// The complete configuration of one engine.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EngineConfig {
    /// When samples are taken and how they are averaged.
    #[serde(default)]
    pub sampling: SamplingConfig,
    /// The sensor channels, in the order the engine's input slice has them.
    pub channels: Vec<ChannelConfig>,
    /// One compensated axis each.
    pub axes: Vec<AxisConfig>,
    /// Thermal model files referred to by `kind = "model"` terms, keyed by their `file`
    /// string; filled by [`EngineConfig::load`] or [`EngineConfig::insert_model`].
    #[serde(skip)]
    pub models: BTreeMap<String, ModelFile>,
}

/// Sampling trigger and averaging.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SamplingConfig {
    /// What makes the engine take a sample.
    #[serde(default)]
    pub trigger: Trigger,
    /// N samples averaged into one value (EP0138375: N readings at the stroke switch).
    #[serde(default = "one")]
    pub samples_per_average: usize,
    /// Time averaging of the N-sample averages.
    #[serde(default)]
    pub time_filter: TimeFilterConfig,
}

fn one() -> usize {
    1
}

impl Default for SamplingConfig {
    fn default() -> Self {
        Self {
            trigger: Trigger::EveryCycle {},
            samples_per_average: 1,
            time_filter: TimeFilterConfig::None {},
        }
    }
}

/// What makes the engine take a sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Trigger {
    /// Every call of `step`.
    EveryCycle {},
    /// Only when `Inputs::trigger` is set (stroke-position switch, spindle index).
    Input {},
    /// A clock: one sample every `period_s` seconds of input time.
    Clock {
        /// Sample period in s, > 0.
        period_s: f64,
    },
}

// Variants without data are written `Name {}` so that `deny_unknown_fields` also rejects
// stray keys next to their `kind` (serde ignores extra keys on unit variants).

impl Default for Trigger {
    fn default() -> Self {
        Trigger::EveryCycle {}
    }
}

impl Default for TimeFilterConfig {
    fn default() -> Self {
        TimeFilterConfig::None {}
    }
}

/// Time averaging of the N-sample averages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TimeFilterConfig {
    /// No time averaging.
    None {},
    /// First-order filter with time constant `tau_s`.
    FirstOrder {
        /// Time constant in s, > 0.
        tau_s: f64,
    },
    /// Mean of the last `averages` N-sample averages.
    MovingWindow {
        /// Window length in averages, 1…4096.
        averages: usize,
    },
}

/// One sensor channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelConfig {
    /// Unique name, used by laws and model files (e.g. "bed_c").
    pub name: String,
    /// Conversion from the raw reading.
    pub sensor: SensorKind,
    /// Lowest plausible value (°C or µm); below it the sensor is faulty.
    pub valid_min: f64,
    /// Highest plausible value (°C or µm); above it the sensor is faulty.
    pub valid_max: f64,
    /// Stop the machine when the averaged value falls below this (EP0138375 limits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_min: Option<f64>,
    /// Stop the machine when the averaged value rises above this.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit_max: Option<f64>,
    /// A reading older than this (input time − reading stamp) is stale, in s.
    pub stale_timeout_s: f64,
    /// A value unchanged (within `stuck_tolerance`) for this long is stuck, in s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stuck_timeout_s: Option<f64>,
    /// Largest change still counted as "unchanged" by the stuck check (°C or µm).
    #[serde(default)]
    pub stuck_tolerance: f64,
    /// Plausibility of single readings (rate of change, spikes); none by default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plausibility: Option<Plausibility>,
}

/// Checks of single readings inside the validity range: a reading that fails one is a
/// fault (alarm; the axes reading the channel hold their value) and is not averaged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Plausibility {
    /// Largest credible rate of change against the last accepted reading, in the
    /// channel's unit per s (°C/s or µm/s), > 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_rate_per_s: Option<f64>,
    /// Hampel test against the last readings.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spike: Option<SpikeTest>,
}

/// Hampel (median / MAD) test: a reading farther than `n_sigma`·1.4826·MAD from the
/// median of the previous `window` readings is a spike; MAD is floored at `min_mad`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpikeTest {
    /// Readings in the window, 3…31 (default 7).
    #[serde(default = "default_spike_window")]
    pub window: usize,
    /// Threshold in robust standard deviations, 1…100 (default 3).
    #[serde(default = "default_spike_sigma")]
    pub n_sigma: f64,
    /// Smallest MAD used, channel unit (°C or µm), ≥ 0 (default 0.1): keeps the
    /// quantisation of a steady sensor from counting as a spike.
    #[serde(default = "default_spike_min_mad")]
    pub min_mad: f64,
}

fn default_spike_window() -> usize {
    7
}
fn default_spike_sigma() -> f64 {
    3.0
}
fn default_spike_min_mad() -> f64 {
    0.1
}

/// One compensated axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisConfig {
    /// Axis name, e.g. "X" or "Z".
    pub name: String,
    /// Where the offset goes.
    pub apply: Application,
    /// Boundary constant D in µm: a new correction only when it differs from the running
    /// compensation by at least this (EP0138375 block 602).
    #[serde(default)]
    pub dead_band_um: f64,
    /// Largest |offset| in µm; larger law values are clamped and flagged.
    pub max_offset_um: f64,
    /// Largest change of the applied offset per cycle in µm (rate limit); none if absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_step_um: Option<f64>,
    /// Move the applied offset only while `Inputs::safe_point` is set (between cuts).
    #[serde(default)]
    pub safe_points_only: bool,
    /// The law: the signed sum of these terms, in µm.
    pub terms: Vec<TermConfig>,
}

/// Where an axis offset is applied.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Application {
    /// To the scale reading: D′ = D + Cz (JPH0761598B2, linear-scale machines).
    MeasuringSystem {},
    /// To the commanded position: Z′ = Z + Cz (JPH0761598B2, pulse-motor machines).
    Command {},
    /// As pulses to an infeed motor, the rounding remainder carried (EP0138375, 606–608).
    Pulses {
        /// Travel of one pulse in µm, > 0.
        pulse_um: f64,
    },
}

/// The sign of a term in the axis sum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sign {
    /// Added.
    #[default]
    Plus,
    /// Subtracted (e.g. EP0138375's base correction, the base being the mounting reference).
    Minus,
}

impl Sign {
    /// +1 or −1.
    pub fn factor(self) -> f64 {
        match self {
            Sign::Plus => 1.0,
            Sign::Minus => -1.0,
        }
    }
}

/// One term of an axis law; all results are in µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum TermConfig {
    /// Cz = Kd·T + α (JPH0761598B2, EDM).
    Linear {
        /// Temperature channel T.
        channel: String,
        /// Kd in µm/°C.
        kd_um_per_c: f64,
        /// α in µm.
        #[serde(default)]
        alpha_um: f64,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
    /// Cz = Kz·(A − B) (JPH0761598B2, surface grinder).
    Difference {
        /// Channel A (bed top).
        a: String,
        /// Channel B (wheel-drive case).
        b: String,
        /// Kz in µm/°C.
        kz_um_per_c: f64,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
    /// Cz = Kz·A − Kz·(b·t + c), B replaced by its linear rise (JPH0761598B2, f1(t)).
    TimeLinear {
        /// Channel A.
        a: String,
        /// Kz in µm/°C.
        kz_um_per_c: f64,
        /// b in °C/h.
        b_c_per_h: f64,
        /// c in °C.
        c_c: f64,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
    /// Cz = Kz′·B + K·√t, A replaced by its √t rise (JPH0761598B2, f2(t)).
    TimeSqrt {
        /// Channel B.
        b: String,
        /// Kz′ = −Kz in µm/°C.
        kz_prime_um_per_c: f64,
        /// K in µm/√h.
        k_um_per_sqrt_h: f64,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
    /// C = K·(value − midpoint) (EP0138375, subroutines 300/400/500).
    Component {
        /// Channel (temperature or displacement).
        channel: String,
        /// K in µm per channel unit (µm/°C, or the lever ratio µm/µm).
        k_um_per_unit: f64,
        /// Midpoint (thermal-equilibrium reading) in the channel's unit.
        midpoint: f64,
        /// Sign in the axis sum (the base is subtracted).
        #[serde(default)]
        sign: Sign,
    },
    /// ΔK = K0(T) + tanβ(T)·(P − P0), K0 and tanβ linear in T (SINUMERIK / TwinCAT).
    Position {
        /// Temperature channel T.
        channel: String,
        /// Temperature at which K0 = offset_um and tanβ = slope_um_per_mm, in °C.
        t_ref_c: f64,
        /// K0 at t_ref in µm.
        #[serde(default)]
        offset_um: f64,
        /// dK0/dT in µm/°C.
        #[serde(default)]
        offset_um_per_c: f64,
        /// tanβ at t_ref in µm/mm.
        #[serde(default)]
        slope_um_per_mm: f64,
        /// d(tanβ)/dT in µm/mm/°C.
        #[serde(default)]
        slope_um_per_mm_per_c: f64,
        /// Reference position P0 in mm.
        #[serde(default)]
        p0_mm: f64,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
    /// An identified model from a thermal model file (`gearcomp fit`).
    Model {
        /// The model file (relative to the configuration file).
        file: String,
        /// Which axis model of the file.
        axis: String,
        /// Sign in the axis sum.
        #[serde(default)]
        sign: Sign,
    },
}

impl EngineConfig {
    /// Parses a configuration; model files must then be supplied with
    /// [`EngineConfig::insert_model`] (or use [`EngineConfig::load`]).
    pub fn from_toml_str(text: &str) -> Result<Self> {
        Ok(toml::from_str(text)?)
    }

    /// Reads a configuration file and the model files its terms name (relative paths are
    /// taken from the configuration file's folder).
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| ThermalError::Io {
            action: "read",
            path: path.display().to_string(),
            source,
        })?;
        let mut cfg = Self::from_toml_str(&text)?;
        let dir = path.parent().unwrap_or_else(|| Path::new("."));
        let files: Vec<String> = cfg
            .axes
            .iter()
            .flat_map(|a| a.terms.iter())
            .filter_map(|t| match t {
                TermConfig::Model { file, .. } => Some(file.clone()),
                _ => None,
            })
            .collect();
        for f in files {
            if let std::collections::btree_map::Entry::Vacant(e) = cfg.models.entry(f) {
                let model = ModelFile::load(&dir.join(e.key()))?;
                e.insert(model);
            }
        }
        Ok(cfg)
    }

    /// Supplies the model that `kind = "model"` terms with `file = key` use.
    pub fn insert_model(&mut self, key: impl Into<String>, model: ModelFile) {
        self.models.insert(key.into(), model);
    }

    /// Serialises to TOML (model files are referred to, not embedded).
    pub fn to_toml_string(&self) -> std::result::Result<String, toml::ser::Error> {
        toml::to_string_pretty(self)
    }
}
