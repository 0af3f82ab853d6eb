//! Sensor conversions: raw reading → engineering value (°C or µm).
//!
//! Every conversion is a pure, allocation-free function usable in the control cycle. A raw
//! value the conversion cannot map (negative resistance, NaN) returns `None`; the engine
//! turns that into a channel fault, never a panic.

use serde::{Deserialize, Serialize};

/// 0 °C in kelvin.
pub const ZERO_C_IN_K: f64 = 273.15;

/// IEC 60751 Callendar–Van Dusen coefficient A in 1/°C.
pub const CVD_A: f64 = 3.9083e-3;
/// IEC 60751 Callendar–Van Dusen coefficient B in 1/°C².
pub const CVD_B: f64 = -5.775e-7;
/// IEC 60751 Callendar–Van Dusen coefficient C in 1/°C⁴ (used below 0 °C only).
pub const CVD_C: f64 = -4.183e-12;

/// How a channel's raw value becomes an engineering value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SensorKind {
    /// The raw value already is a temperature in °C.
    Celsius {},
    /// Platinum RTD with R0 = 100 Ω (IEC 60751); raw value in Ω.
    Pt100 {},
    /// Platinum RTD with R0 = 1000 Ω (IEC 60751); raw value in Ω.
    Pt1000 {},
    /// NTC thermistor, β model; raw value in Ω.
    NtcBeta {
        /// Resistance at the reference temperature, in Ω.
        r0_ohm: f64,
        /// Reference temperature in °C (usually 25).
        #[serde(default = "default_ntc_t0_c")]
        t0_c: f64,
        /// β constant in K.
        beta_k: f64,
    },
    /// NTC thermistor, Steinhart–Hart equation; raw value in Ω.
    NtcSteinhartHart {
        /// Coefficient A in 1/K.
        a: f64,
        /// Coefficient B in 1/K.
        b: f64,
        /// Coefficient C in 1/K.
        c: f64,
    },
    /// Proximity / eddy-current displacement transducer: value_um = gain·raw + offset.
    Displacement {
        /// Gain in µm per raw unit (e.g. µm/V).
        gain_um_per_unit: f64,
        /// Offset in µm.
        #[serde(default)]
        offset_um: f64,
    },
}

fn default_ntc_t0_c() -> f64 {
    25.0
}

/// Which way a resistive sensor's resistance moves with temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Resistive {
    /// Not a resistive sensor.
    No,
    /// Resistance rises with temperature (RTD): an open circuit reads hot.
    PositiveCoefficient,
    /// Resistance falls with temperature (NTC): an open circuit reads cold.
    NegativeCoefficient,
}

impl SensorKind {
    /// Converts a raw reading to °C (temperature kinds) or µm (displacement).
    ///
    /// # Domain
    /// Resistances must be finite and > 0 Ω; otherwise `None`.
    pub fn convert(&self, raw: f64) -> Option<f64> {
        if !raw.is_finite() {
            return None;
        }
        let v = match *self {
            SensorKind::Celsius {} => raw,
            SensorKind::Pt100 {} => rtd_temperature_c(raw, 100.0)?,
            SensorKind::Pt1000 {} => rtd_temperature_c(raw, 1000.0)?,
            SensorKind::NtcBeta {
                r0_ohm,
                t0_c,
                beta_k,
            } => ntc_beta_temperature_c(raw, r0_ohm, t0_c, beta_k)?,
            SensorKind::NtcSteinhartHart { a, b, c } => steinhart_hart_temperature_c(raw, a, b, c)?,
            SensorKind::Displacement {
                gain_um_per_unit,
                offset_um,
            } => gain_um_per_unit * raw + offset_um,
        };
        v.is_finite().then_some(v)
    }

    /// The direction of a resistive sensor, used to name open and short circuits.
    pub fn resistive(&self) -> Resistive {
        match self {
            SensorKind::Pt100 {} | SensorKind::Pt1000 {} => Resistive::PositiveCoefficient,
            SensorKind::NtcBeta { .. } | SensorKind::NtcSteinhartHart { .. } => {
                Resistive::NegativeCoefficient
            }
            SensorKind::Celsius {} | SensorKind::Displacement { .. } => Resistive::No,
        }
    }

    /// True for temperature sensors (value in °C), false for displacement (µm).
    pub fn is_temperature(&self) -> bool {
        !matches!(self, SensorKind::Displacement { .. })
    }
}

/// Platinum RTD resistance at a temperature (Callendar–Van Dusen).
///
/// # Formula
/// R(T) = R0·[1 + A·T + B·T² + C·(T − 100)·T³], with C = 0 for T ≥ 0 °C
/// # Units
/// T in °C, R and R0 in Ω.
/// # Domain
/// −200 °C ≤ T ≤ 850 °C (the range of the standard).
/// # Source
/// IEC 60751:2008, 5.1.2 [STANDARD]
#[inline]
pub fn rtd_resistance_ohm(temp_c: f64, r0_ohm: f64) -> f64 {
    let c = if temp_c < 0.0 { CVD_C } else { 0.0 };
    r0_ohm
        * (1.0 + CVD_A * temp_c + CVD_B * temp_c * temp_c + c * (temp_c - 100.0) * temp_c.powi(3))
}

/// Platinum RTD temperature from its resistance (inverse Callendar–Van Dusen).
///
/// # Formula
/// R ≥ R0: T = (−A + √(A² − 4B·(1 − R/R0))) / (2B)  (closed form of the quadratic);
/// R < R0: Newton on R(T) − R = 0 from the quadratic's root, 8 fixed iterations
/// (converges to < 1e-10 °C over −200…0 °C, the quartic term being small).
/// # Units
/// R and R0 in Ω; result in °C.
/// # Domain
/// R > 0; outside the IEC range the result is extrapolated and the channel's validity
/// range rejects it. Returns `None` for R ≤ 0 or non-finite input.
/// # Source
/// IEC 60751:2008, 5.1.2 [STANDARD]; inversion [DERIVED]
#[inline]
pub fn rtd_temperature_c(r_ohm: f64, r0_ohm: f64) -> Option<f64> {
    if !(r_ohm.is_finite() && r_ohm > 0.0 && r0_ohm > 0.0) {
        return None;
    }
    let t = rtd_temperature_positive_c(r_ohm, r0_ohm);
    t.is_finite().then_some(t)
}

/// [`rtd_temperature_c`] for an R the caller has checked finite and > 0 and R0 > 0 (the
/// engine checks R per sample and R0 at build time); NaN where the quadratic has no real
/// root. The same operations as [`rtd_temperature_c`], which calls it.
///
/// # Formula
/// T = (−A + √(A² − 4B·(1 − R/R0))) / (2B), Newton on the full curve below 0 °C
/// # Source
/// IEC 60751:2008, 5.1.2 [STANDARD]; inversion [DERIVED]
#[inline]
pub(crate) fn rtd_temperature_positive_c(r_ohm: f64, r0_ohm: f64) -> f64 {
    let ratio = r_ohm / r0_ohm;
    let disc = CVD_A * CVD_A - 4.0 * CVD_B * (1.0 - ratio);
    if disc < 0.0 {
        return f64::NAN;
    }
    let mut t = (-CVD_A + disc.sqrt()) / (2.0 * CVD_B);
    if ratio < 1.0 {
        for _ in 0..8 {
            let f = rtd_resistance_ohm(t, r0_ohm) - r_ohm;
            let df = r0_ohm * (CVD_A + 2.0 * CVD_B * t + CVD_C * (4.0 * t.powi(3) - 300.0 * t * t));
            t -= f / df;
        }
    }
    t
}

/// NTC thermistor temperature, β model.
///
/// # Formula
/// 1/T = 1/T0 + (1/β)·ln(R/R0)
/// # Units
/// T, T0 in K inside the formula (°C at the interface); R, R0 in Ω; β in K.
/// # Domain
/// R > 0, R0 > 0, β > 0; `None` otherwise or when 1/T ≤ 0 (an absurdly low resistance).
/// # Source
/// Standard thermistor β equation (e.g. Vishay NTC application note) [STANDARD]
pub fn ntc_beta_temperature_c(r_ohm: f64, r0_ohm: f64, t0_c: f64, beta_k: f64) -> Option<f64> {
    if !(r_ohm.is_finite() && r_ohm > 0.0 && r0_ohm > 0.0 && beta_k > 0.0) {
        return None;
    }
    ntc_beta_temperature_from_inv_t0_c(r_ohm, r0_ohm, 1.0 / (t0_c + ZERO_C_IN_K), beta_k)
}

/// [`ntc_beta_temperature_c`] with 1/T0 precomputed (the engine computes it once per
/// channel at build time instead of once per sample; the result is bit-identical).
///
/// # Formula
/// 1/T = 1/T0 + (1/β)·ln(R/R0)
/// # Units
/// `inv_t0_per_k` = 1/T0 in 1/K; R, R0 in Ω; β in K; result in °C.
/// # Domain
/// The caller has checked R > 0, R0 > 0, β > 0; `None` when 1/T ≤ 0.
/// # Source
/// Standard thermistor β equation (e.g. Vishay NTC application note) [STANDARD]
#[inline]
pub(crate) fn ntc_beta_temperature_from_inv_t0_c(
    r_ohm: f64,
    r0_ohm: f64,
    inv_t0_per_k: f64,
    beta_k: f64,
) -> Option<f64> {
    let inv_t = inv_t0_per_k + (r_ohm / r0_ohm).ln() / beta_k;
    (inv_t > 0.0).then(|| 1.0 / inv_t - ZERO_C_IN_K)
}

/// NTC thermistor resistance at a temperature, β model (inverse of
/// [`ntc_beta_temperature_c`]).
///
/// # Formula
/// R = R0·exp(β·(1/T − 1/T0))
/// # Units
/// °C at the interface, K inside; Ω.
/// # Source
/// Standard thermistor β equation [STANDARD]
pub fn ntc_beta_resistance_ohm(temp_c: f64, r0_ohm: f64, t0_c: f64, beta_k: f64) -> f64 {
    r0_ohm * (beta_k * (1.0 / (temp_c + ZERO_C_IN_K) - 1.0 / (t0_c + ZERO_C_IN_K))).exp()
}

/// NTC thermistor temperature, Steinhart–Hart equation.
///
/// # Formula
/// 1/T = A + B·ln R + C·(ln R)³
/// # Units
/// T in K inside (°C returned), R in Ω.
/// # Domain
/// R > 0; `None` when 1/T ≤ 0.
/// # Source
/// Steinhart & Hart, Deep-Sea Research 15 (1968) 497 [STANDARD]
#[inline]
pub fn steinhart_hart_temperature_c(r_ohm: f64, a: f64, b: f64, c: f64) -> Option<f64> {
    if !(r_ohm.is_finite() && r_ohm > 0.0) {
        return None;
    }
    let ln_r = r_ohm.ln();
    let inv_t = a + b * ln_r + c * ln_r * ln_r * ln_r;
    (inv_t > 0.0).then(|| 1.0 / inv_t - ZERO_C_IN_K)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// IEC 60751 Pt100 table, resistances in Ω rounded to 0.01 Ω as published.
    /// Tolerance 0.006 Ω: half the table's last digit plus margin.
    const IEC60751_PT100: [(f64, f64); 13] = [
        (-200.0, 18.52),
        (-100.0, 60.26),
        (-50.0, 80.31),
        (-20.0, 92.16),
        (0.0, 100.00),
        (20.0, 107.79),
        (25.0, 109.73),
        (50.0, 119.40),
        (100.0, 138.51),
        (200.0, 175.86),
        (300.0, 212.05),
        (500.0, 280.98),
        (850.0, 390.48),
    ];

    #[test]
    fn pt100_matches_iec60751_table_both_ways() {
        for (t, r) in IEC60751_PT100 {
            assert!((rtd_resistance_ohm(t, 100.0) - r).abs() < 0.006, "R({t})");
            // 0.01 Ω is ≈ 0.026 °C near 0 °C and ≈ 0.03 °C at 850 °C: inverse within 0.02 °C.
            let back = rtd_temperature_c(r, 100.0).unwrap();
            assert!((back - t).abs() < 0.02, "T({r}) = {back}, table {t}");
        }
    }

    #[test]
    fn pt1000_is_ten_times_pt100() {
        for (t, r) in IEC60751_PT100 {
            assert!((rtd_resistance_ohm(t, 1000.0) - 10.0 * r).abs() < 0.06);
            let k = SensorKind::Pt1000 {}.convert(10.0 * r).unwrap();
            assert!((k - t).abs() < 0.02);
        }
    }

    /// A 10 kΩ / β = 3950 K NTC: the β law gives R(0 °C) = 10 kΩ·exp(3950·(1/273.15 −
    /// 1/298.15)) = 33 620.6 Ω (hand calculation) and R(25 °C) = R0 exactly.
    #[test]
    fn ntc_beta_hand_values() {
        let t0 = ntc_beta_temperature_c(10_000.0, 10_000.0, 25.0, 3950.0).unwrap();
        assert!((t0 - 25.0).abs() < 1e-9);
        let t = ntc_beta_temperature_c(33_620.6, 10_000.0, 25.0, 3950.0).unwrap();
        assert!(t.abs() < 1e-3, "{t}");
        assert!((ntc_beta_resistance_ohm(0.0, 10_000.0, 25.0, 3950.0) - 33_620.6).abs() < 0.5);
    }

    /// Steinhart–Hart coefficients solved (by nalgebra LU, an independent path) from three
    /// points of the β curve must reproduce those points exactly and the curve closely
    /// between them (β and S–H differ by < 0.05 °C over 0…50 °C for this part).
    #[test]
    fn steinhart_hart_through_three_points() {
        let pts =
            [0.0, 25.0, 50.0].map(|t| (t, ntc_beta_resistance_ohm(t, 10_000.0, 25.0, 3950.0)));
        let m = nalgebra::Matrix3::from_fn(|i, j| pts[i].1.ln().powi([0, 1, 3][j]));
        let rhs = nalgebra::Vector3::from_fn(|i, _| 1.0 / (pts[i].0 + ZERO_C_IN_K));
        let abc = m.lu().solve(&rhs).unwrap();
        for (t, r) in pts {
            let back = steinhart_hart_temperature_c(r, abc[0], abc[1], abc[2]).unwrap();
            assert!((back - t).abs() < 1e-6);
        }
        let r = ntc_beta_resistance_ohm(37.0, 10_000.0, 25.0, 3950.0);
        let sh = steinhart_hart_temperature_c(r, abc[0], abc[1], abc[2]).unwrap();
        assert!((sh - 37.0).abs() < 0.05, "{sh}");
    }

    #[test]
    fn bad_raw_values_are_none_not_panics() {
        for raw in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            assert!(SensorKind::Pt100 {}.convert(raw).is_none());
            let ntc = SensorKind::NtcBeta {
                r0_ohm: 1e4,
                t0_c: 25.0,
                beta_k: 3950.0,
            };
            assert!(ntc.convert(raw).is_none());
        }
        let d = SensorKind::Displacement {
            gain_um_per_unit: 50.0,
            offset_um: -3.0,
        };
        assert_eq!(d.convert(2.0), Some(97.0));
    }
}
