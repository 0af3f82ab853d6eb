//! The thermal model file: the contract between identification (`gearcomp fit`) and the
//! compensation engine (`gearcomp-thermal`, `gearcomp replay`, `gearcomp serve`).
//!
//! # Format
//! A TOML (or JSON) document, `format = "gearcomp-thermal-model/1"`. It holds one
//! [`AxisModel`] per compensated axis. Each axis offset is
//!
//! ```text
//! offset_um = δM + δT
//! δM = intercept + Σ coefficient_i · transform_i(channel_i)          (machine error)
//! δT = shrink(Ta − Tb),  Ta = intercept + Σ a_i · transform_i(t_i)    (workpiece, optional)
//! ```
//!
//! The machine part is a multiple linear regression (CN105397560 eqs. (3)–(5); JPH0761598B2's
//! Cz = Kd·T + α and Cz = Kz·(A − B) are special cases of it). The workpiece part is the
//! dry-hobbing thermal shrink of CN105397560 eq. (7), exact form (7*) of
//! `docs/conventions.md`.
//!
//! # Conventions fixed by the project
//! * Offsets are in µm. A positive offset **increases** the centre distance between tool
//!   and workpiece (hob withdrawn): it is what the engine adds to the axis command
//!   (Z′ = Z + Cz) or to the scale reading (D′ = D + Cz), per axis configuration.
//! * Channels are referred to by name; the engine maps names to its sensor channels.
//! * Transforms run at the engine's sample instants:
//!   - [`Transform::Value`]: the channel's current (averaged) value;
//!   - [`Transform::FirstOrderLag`]: y ← y + (1 − e^(−Δt/τ))·(u − y), started at the first
//!     sample (exact discretisation of τ·ẏ + y = u for a piecewise-constant input);
//!   - [`Transform::Delay`]: the value `delay_s` ago, linearly interpolated between samples;
//!     until that much history exists, the oldest value held.
//!   - [`Transform::Rate`]: the time derivative of the channel in unit/s, estimated as the
//!     difference of the first-order-lagged value over `tau_s` (a filtered derivative:
//!     (u − y_lag)/τ), which captures heating versus cooling direction.

use crate::error::{CoreError, Result};
use serde::{Deserialize, Serialize};

/// The `format` string this build reads and writes.
pub const MODEL_FORMAT: &str = "gearcomp-thermal-model/1";

/// A complete thermal model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Always [`MODEL_FORMAT`].
    pub format: String,
    /// Short name of the model, shown in reports and the dashboard.
    pub name: String,
    /// Free text: machine, test, date.
    #[serde(default)]
    pub description: String,
    /// Longest time step (s) between two values of a channel over which the model's lag,
    /// rate and delay states carry on; after a longer one (a gap in the log, the service
    /// or a sensor down) they start afresh at the next value, as the fit restarted them
    /// at the gaps of its data (`gearcomp fit` writes 3 × the training data's median
    /// step). Absent: they always carry on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub restart_after_s: Option<f64>,
    /// One model per compensated axis.
    pub axes: Vec<AxisModel>,
    /// How the model was made (data, split, errors), for the record.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
    /// Training envelope of each axis's machine model (optional): live inputs outside it
    /// mean the model is extrapolating (a warning, not a stop).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub envelopes: Vec<Envelope>,
}

/// The inputs a machine model was identified on (issue 12): per-channel ranges and a
/// leverage bound on the model's regressors (its terms, transformed, in term order).
///
/// # Formula
/// d² = ‖W·(x − x̄)‖²; leverage h = 1/n + d²/(n − 1). For a least-squares model
/// W = √(n − 1)·R⁻ᵀ with R the QR factor of the centred training regressors (so
/// d² = (x − x̄)ᵀ S⁻¹ (x − x̄), S the sample covariance); a ridge or principal-component
/// model stores the leverage of its own fit (a full W; `gearcomp_identify::envelope`).
/// Outside: a channel below `min` or above `max`, or d² > `max_d2`.
/// # Source
/// Mahalanobis distance / hat-matrix leverage of least squares (Hoaglin & Welsch 1978),
/// the ridge hat matrix (Walker & Birch 1988) [STANDARD]; the stored form is this
/// project's [PROJECT CONVENTION].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Envelope {
    /// The axis whose machine model this envelope belongs to.
    pub axis: String,
    /// Range of each channel the model reads over the training rows.
    pub ranges: Vec<ChannelRange>,
    /// Mean of each term's regressor over the training rows (term order).
    #[serde(default)]
    pub feature_mean: Vec<f64>,
    /// W, row-major, p × p (p = number of terms); empty: no Mahalanobis bound.
    #[serde(default)]
    pub whitening: Vec<f64>,
    /// Largest d² over the training rows.
    #[serde(default)]
    pub max_d2: f64,
    /// Number of training rows.
    #[serde(default)]
    pub rows: u64,
}

/// The range of one channel over the training rows, in the channel's unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChannelRange {
    /// Channel name.
    pub channel: String,
    /// Smallest training value.
    pub min: f64,
    /// Largest training value.
    pub max: f64,
}

/// Why live inputs are outside an [`Envelope`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Outside {
    /// The channel (index into `ranges`) is outside its training range.
    Range {
        /// Index into [`Envelope::ranges`].
        channel: usize,
        /// The live value.
        value: f64,
    },
    /// The regressors are farther from the training mean than any training row.
    Mahalanobis {
        /// The live d².
        d2: f64,
    },
}

impl Envelope {
    /// d² of a regressor vector (term order); 0 without a Mahalanobis bound.
    pub fn d2(&self, features: &[f64]) -> f64 {
        let p = self.feature_mean.len();
        if p == 0 || self.whitening.len() != p * p || features.len() != p {
            return 0.0;
        }
        // No temporary for x − mean: called per row and per live scan.
        let dx = || features.iter().zip(&self.feature_mean).map(|(x, m)| x - m);
        self.whitening
            .chunks(p)
            .map(|row| {
                row.iter()
                    .zip(dx())
                    .map(|(w, d)| w * d)
                    .sum::<f64>()
                    .powi(2)
            })
            .sum()
    }

    /// Leverage h = 1/n + d²/(n − 1) of a regressor vector.
    pub fn leverage(&self, features: &[f64]) -> f64 {
        self.leverage_of_d2(self.d2(features))
    }

    fn leverage_of_d2(&self, d2: f64) -> f64 {
        let n = self.rows.max(2) as f64;
        1.0 / n + d2 / (n - 1.0)
    }

    /// The first reason live inputs are outside: `channels` are the values of
    /// [`Envelope::ranges`]' channels in that order, `features` the model's regressors.
    pub fn check(&self, channels: &[f64], features: &[f64]) -> Option<Outside> {
        self.check_d2(channels, || self.d2(features))
    }

    /// [`Envelope::check`] and [`Envelope::leverage`] of one row from one d².
    pub fn check_and_leverage(&self, channels: &[f64], features: &[f64]) -> (Option<Outside>, f64) {
        let d2 = self.d2(features);
        (self.check_d2(channels, || d2), self.leverage_of_d2(d2))
    }

    fn check_d2(&self, channels: &[f64], d2: impl FnOnce() -> f64) -> Option<Outside> {
        for (k, (r, &v)) in self.ranges.iter().zip(channels).enumerate() {
            if v < r.min || v > r.max {
                return Some(Outside::Range {
                    channel: k,
                    value: v,
                });
            }
        }
        let d2 = d2();
        (d2 > self.max_d2 && !self.whitening.is_empty()).then_some(Outside::Mahalanobis { d2 })
    }

    /// Checks sizes and finiteness against the axis model's `terms` count.
    pub fn validate(&self, path: &str, terms: usize) -> Result<()> {
        for (i, r) in self.ranges.iter().enumerate() {
            finite(format!("{path}.ranges[{i}].min"), r.min)?;
            finite(format!("{path}.ranges[{i}].max"), r.max)?;
            if r.min > r.max {
                return Err(invalid(
                    format!("{path}.ranges[{i}]"),
                    format!("{} … {}", r.min, r.max),
                    "min ≤ max",
                ));
            }
        }
        let p = self.feature_mean.len();
        if p != 0 && (p != terms || self.whitening.len() != p * p) {
            return Err(invalid(
                format!("{path}.whitening"),
                format!("{} mean(s), {} entries", p, self.whitening.len()),
                &format!("{terms} means and {terms}×{terms} entries (one per term)"),
            ));
        }
        for (i, v) in self.feature_mean.iter().chain(&self.whitening).enumerate() {
            finite(format!("{path}.feature_mean/whitening[{i}]"), *v)?;
        }
        if !(self.max_d2.is_finite() && self.max_d2 >= 0.0) {
            return Err(invalid(format!("{path}.max_d2"), self.max_d2, "d² ≥ 0"));
        }
        Ok(())
    }
}

/// The offset model of one axis: machine error plus optional workpiece shrink.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisModel {
    /// Axis the offset is applied to, e.g. "X" (radial infeed / centre distance).
    pub axis: String,
    /// Name of the measured quantity the model predicts, e.g. "ch5_um".
    #[serde(default)]
    pub target: String,
    /// The machine's thermal error δM in µm.
    pub machine: LinearModel,
    /// The workpiece thermal shrink δT (dry cutting), if compensated.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub workpiece: Option<WorkpieceShrink>,
}

/// y = intercept + Σ coefficient·transform(channel).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearModel {
    /// Constant term, in the output unit (µm for δM, °C for a temperature model).
    pub intercept: f64,
    /// The regression terms.
    #[serde(default)]
    pub terms: Vec<Term>,
}

/// One regression term.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Term {
    /// Channel name as the engine and the data files know it, e.g. "t3_c".
    pub channel: String,
    /// Output unit per unit of the transformed input (e.g. µm/°C).
    pub coefficient: f64,
    /// How the channel is turned into the regressor.
    #[serde(default)]
    pub transform: Transform,
}

/// How a channel's samples become a regressor (see the module docs for exact semantics).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Transform {
    /// The current averaged value.
    #[default]
    Value,
    /// First-order lag with time constant `tau_s` (s).
    FirstOrderLag {
        /// Time constant in seconds, > 0.
        tau_s: f64,
    },
    /// The value `delay_s` seconds ago.
    Delay {
        /// Delay in seconds, ≥ 0.
        delay_s: f64,
    },
    /// Filtered time derivative (u − lag_τ(u))/τ in unit per second.
    Rate {
        /// Filter time constant in seconds, > 0.
        tau_s: f64,
    },
}

/// Workpiece thermal-shrink compensation for dry cutting (CN105397560, eq. (7)).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkpieceShrink {
    /// Workpiece temperature right after cutting, Ta in °C (CN105397560 regression).
    pub temperature: LinearModel,
    /// Design (measuring-room) temperature Tb in °C.
    pub design_temp_c: f64,
    /// Linear expansion coefficient of the workpiece material in 1/K (steel ≈ 11.5e-6).
    pub expansion_per_k: f64,
    /// The gear being cut.
    pub gear: ShrinkGear,
    /// Radius at which the cooled tooth thickness is made right.
    #[serde(default)]
    pub reference: ReferenceRadius,
    /// Exact involute form or its first-order approximation.
    #[serde(default)]
    pub method: ShrinkMethod,
}

/// Gear data needed by the shrink formula; degrees at this interface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShrinkGear {
    /// Normal module m_n in mm.
    pub normal_module_mm: f64,
    /// Normal pressure angle α_n in degrees.
    pub pressure_angle_deg: f64,
    /// Number of teeth z.
    pub teeth: u32,
    /// Helix angle β in degrees (0 for spur).
    #[serde(default)]
    pub helix_angle_deg: f64,
    /// Tip diameter d_a in mm (needed for [`ReferenceRadius::Tip`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tip_diameter_mm: Option<f64>,
}

/// Reference radius of the shrink compensation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceRadius {
    /// Reference (pitch) circle: what span and tooth-thickness measurements see.
    #[default]
    Pitch,
    /// Tip circle (the literal reading of CN105397560 eq. (7)).
    Tip,
}

/// Exact or linearised shrink formula.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShrinkMethod {
    /// δT(ρ) = (r/tan α)·[inv α*_ρ − inv α_ρ].
    #[default]
    Exact,
    /// δT ≈ r·λ·ΔT·tan α_ρ / tan α.
    FirstOrder,
}

/// Where a model came from.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Provenance {
    /// Data file(s) used.
    #[serde(default)]
    pub data: String,
    /// Tool and version that wrote the file.
    #[serde(default)]
    pub created_by: String,
    /// Method summary (selection, model kind).
    #[serde(default)]
    pub method: String,
    /// Train RMSE per axis target in µm.
    #[serde(default)]
    pub train_rmse_um: Vec<f64>,
    /// Test RMSE per axis target in µm.
    #[serde(default)]
    pub test_rmse_um: Vec<f64>,
}

fn invalid(field: String, value: impl ToString, expected: &str) -> CoreError {
    CoreError::InvalidField {
        field,
        value: value.to_string(),
        expected: expected.to_string(),
    }
}

fn finite(field: String, v: f64) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(invalid(field, v, "a finite number"))
    }
}

impl LinearModel {
    /// Checks every number is finite and every transform parameter in range.
    pub fn validate(&self, path: &str) -> Result<()> {
        finite(format!("{path}.intercept"), self.intercept)?;
        for (i, t) in self.terms.iter().enumerate() {
            let p = format!("{path}.terms[{i}]");
            if t.channel.trim().is_empty() {
                return Err(invalid(format!("{p}.channel"), "\"\"", "a channel name"));
            }
            finite(format!("{p}.coefficient"), t.coefficient)?;
            match t.transform {
                Transform::Value => {}
                Transform::FirstOrderLag { tau_s } | Transform::Rate { tau_s } => {
                    if !(tau_s.is_finite() && tau_s > 0.0) {
                        return Err(invalid(
                            format!("{p}.transform.tau_s"),
                            tau_s,
                            "a time constant > 0 s",
                        ));
                    }
                }
                Transform::Delay { delay_s } => {
                    if !(delay_s.is_finite() && delay_s >= 0.0) {
                        return Err(invalid(
                            format!("{p}.transform.delay_s"),
                            delay_s,
                            "a delay ≥ 0 s",
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Names of the channels this model reads, in term order, without repeats.
    pub fn channels(&self) -> Vec<&str> {
        let mut out: Vec<&str> = Vec::new();
        for t in &self.terms {
            if !out.contains(&t.channel.as_str()) {
                out.push(&t.channel);
            }
        }
        out
    }
}

impl ModelFile {
    /// Checks the format tag and every field's range.
    pub fn validate(&self) -> Result<()> {
        if self.format != MODEL_FORMAT {
            return Err(CoreError::UnsupportedFormat {
                found: self.format.clone(),
                expected: MODEL_FORMAT.into(),
            });
        }
        if self.axes.is_empty() {
            return Err(invalid("axes".into(), "[]", "at least one axis model"));
        }
        if let Some(g) = self.restart_after_s {
            if !(g.is_finite() && g > 0.0) {
                return Err(invalid("restart_after_s".into(), g, "a time step > 0 s"));
            }
        }
        for (k, e) in self.envelopes.iter().enumerate() {
            if !self.axes.iter().any(|a| a.axis == e.axis) {
                return Err(invalid(
                    format!("envelopes[{k}].axis"),
                    &e.axis,
                    "the name of an axis of this file",
                ));
            }
        }
        for (i, a) in self.axes.iter().enumerate() {
            let p = format!("axes[{i}]");
            if a.axis.trim().is_empty() {
                return Err(invalid(format!("{p}.axis"), "\"\"", "an axis name"));
            }
            a.machine.validate(&format!("{p}.machine"))?;
            for (k, e) in self.envelopes.iter().enumerate() {
                if e.axis == a.axis {
                    e.validate(&format!("envelopes[{k}]"), a.machine.terms.len())?;
                }
            }
            if let Some(w) = &a.workpiece {
                let p = format!("{p}.workpiece");
                w.temperature.validate(&format!("{p}.temperature"))?;
                finite(format!("{p}.design_temp_c"), w.design_temp_c)?;
                if !(w.expansion_per_k.is_finite()
                    && w.expansion_per_k > 0.0
                    && w.expansion_per_k < 1e-3)
                {
                    return Err(invalid(
                        format!("{p}.expansion_per_k"),
                        w.expansion_per_k,
                        "0 < λ < 1e-3 1/K",
                    ));
                }
                let g = &w.gear;
                if !(g.normal_module_mm.is_finite() && g.normal_module_mm > 0.0) {
                    return Err(invalid(
                        format!("{p}.gear.normal_module_mm"),
                        g.normal_module_mm,
                        "> 0 mm",
                    ));
                }
                if !(g.pressure_angle_deg > 0.0 && g.pressure_angle_deg < 45.0) {
                    return Err(invalid(
                        format!("{p}.gear.pressure_angle_deg"),
                        g.pressure_angle_deg,
                        "0° < α_n < 45°",
                    ));
                }
                if !(g.helix_angle_deg > -60.0 && g.helix_angle_deg < 60.0) {
                    return Err(invalid(
                        format!("{p}.gear.helix_angle_deg"),
                        g.helix_angle_deg,
                        "−60° < β < 60°",
                    ));
                }
                if g.teeth < 3 {
                    return Err(invalid(format!("{p}.gear.teeth"), g.teeth, "z ≥ 3"));
                }
                if w.reference == ReferenceRadius::Tip && g.tip_diameter_mm.is_none() {
                    return Err(invalid(
                        format!("{p}.gear.tip_diameter_mm"),
                        "missing",
                        "a tip diameter in mm when reference = \"tip\"",
                    ));
                }
            }
        }
        Ok(())
    }

    /// Parses and validates a TOML model file.
    pub fn from_toml_str(text: &str) -> Result<Self> {
        let m: ModelFile = toml::from_str(text)?;
        m.validate()?;
        Ok(m)
    }

    /// Parses and validates a JSON model file.
    pub fn from_json_str(text: &str) -> Result<Self> {
        let m: ModelFile = serde_json::from_str(text)?;
        m.validate()?;
        Ok(m)
    }

    /// Reads a model file; `.json` is read as JSON, anything else as TOML.
    pub fn load(path: &std::path::Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(|source| CoreError::Io {
            action: "read",
            path: path.display().to_string(),
            source,
        })?;
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            Self::from_json_str(&text)
        } else {
            Self::from_toml_str(&text)
        }
    }

    /// Serialises to TOML.
    pub fn to_toml_string(&self) -> Result<String> {
        Ok(toml::to_string_pretty(self)?)
    }

    /// Refuses a model-file path whose extension is neither `.toml` nor `.json` (the format
    /// is chosen by it: `m.yaml` would hold TOML, and `load` would read it as TOML too).
    ///
    /// # Errors
    /// [`CoreError::InvalidField`] naming the path.
    pub fn check_path(path: &std::path::Path) -> Result<()> {
        let known = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml") || e.eq_ignore_ascii_case("json"));
        if known {
            Ok(())
        } else {
            Err(CoreError::InvalidField {
                field: "model file".into(),
                value: path.display().to_string(),
                expected: "a .toml or .json file name (the extension chooses the format)".into(),
            })
        }
    }

    /// Validates, then writes the file atomically (TOML, or JSON for a `.json` path).
    ///
    /// # Errors
    /// [`Self::check_path`]'s, [`Self::validate`]'s, or the write's.
    pub fn save(&self, path: &std::path::Path) -> Result<()> {
        Self::check_path(path)?;
        self.validate()?;
        let text = if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            serde_json::to_string_pretty(self)?
        } else {
            self.to_toml_string()?
        };
        crate::fsio::write_atomic(path, text.as_bytes())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"
format = "gearcomp-thermal-model/1"
name = "grinder Z, JPH0761598B2"

[[axes]]
axis = "Z"
target = "z_drift_um"
[axes.machine]
intercept = 0.0
[[axes.machine.terms]]
channel = "bed_c"
coefficient = -3.75
[[axes.machine.terms]]
channel = "wheelhead_c"
coefficient = 3.75
transform = { kind = "first_order_lag", tau_s = 600.0 }
"#;

    #[test]
    fn envelope_checks_ranges_and_the_mahalanobis_bound() {
        let mut m = ModelFile::from_toml_str(EXAMPLE).unwrap();
        // W = diag(2, 0.5) with an off-diagonal 1: d² = (2·a)² + (1·a + 0.5·b)² by hand.
        let e = Envelope {
            axis: "Z".into(),
            ranges: vec![ChannelRange {
                channel: "bed_c".into(),
                min: 18.0,
                max: 25.0,
            }],
            feature_mean: vec![20.0, 21.0],
            whitening: vec![2.0, 0.0, 1.0, 0.5],
            max_d2: 4.0,
            rows: 101,
        };
        let (a, b) = (0.5, -2.0);
        let d2 = e.d2(&[20.0 + a, 21.0 + b]);
        assert!((d2 - ((2.0 * a).powi(2) + (a + 0.5 * b).powi(2))).abs() < 1e-12);
        assert!((e.leverage(&[20.0 + a, 21.0 + b]) - (1.0 / 101.0 + d2 / 100.0)).abs() < 1e-15);
        assert_eq!(e.check(&[20.0], &[20.5, 19.0]), None);
        assert_eq!(
            e.check(&[25.5], &[20.0, 21.0]),
            Some(Outside::Range {
                channel: 0,
                value: 25.5
            })
        );
        assert_eq!(
            e.check(&[20.0], &[21.5, 21.0]),
            Some(Outside::Mahalanobis { d2: 11.25 })
        );
        m.envelopes.push(e.clone());
        let back = ModelFile::from_toml_str(&m.to_toml_string().unwrap()).unwrap();
        assert_eq!(back.envelopes, vec![e.clone()]);
        let mut bad = m.clone();
        bad.envelopes[0].whitening.pop();
        let err = bad.validate().unwrap_err().to_string();
        assert!(err.contains("envelopes[0].whitening"), "{err}");
        let mut bad = m;
        bad.envelopes[0].axis = "Q".into();
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("envelopes[0].axis"));
    }

    #[test]
    fn parses_round_trips_and_lists_channels() {
        let m = ModelFile::from_toml_str(EXAMPLE).unwrap();
        assert_eq!(m.axes[0].machine.channels(), vec!["bed_c", "wheelhead_c"]);
        assert_eq!(
            m.axes[0].machine.terms[1].transform,
            Transform::FirstOrderLag { tau_s: 600.0 }
        );
        let back = ModelFile::from_toml_str(&m.to_toml_string().unwrap()).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn rejects_wrong_format_unknown_keys_and_bad_tau() {
        let wrong = EXAMPLE.replace("model/1", "model/9");
        assert!(matches!(
            ModelFile::from_toml_str(&wrong),
            Err(CoreError::UnsupportedFormat { .. })
        ));
        let unknown = EXAMPLE.replace("name =", "colour = \"red\"\nname =");
        assert!(ModelFile::from_toml_str(&unknown).is_err());
        let bad = EXAMPLE.replace("tau_s = 600.0", "tau_s = -1.0");
        let e = ModelFile::from_toml_str(&bad).unwrap_err().to_string();
        assert!(
            e.contains("axes[0].machine.terms[1].transform.tau_s"),
            "{e}"
        );
        assert!(e.contains("-1"), "{e}");
    }
}
