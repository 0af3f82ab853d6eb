//! The config file of `gearcomp grind equalise` (TOML tables `[gear]`, `[worm]`,
//! `[equalise]`, interface units: degrees, mm) and its conversion into the search input
//! [`EqualiseSpec`] of [`crate::conical_equalise`].
//!
//! Every error names the table or key it comes from (`[gear]`, `[worm] hand`, …); the cause
//! (a [`GrindError`]) is the error's source.

use serde::Deserialize;

use crate::conical::BeveloidGear;
use crate::conical::MAX_CONE_ANGLE_RAD;
use crate::conical_equalise::{EqualiseSpec, WormLines};
use crate::flank::Hand;
use crate::setup::{
    gear_from_input, grinding_worm, worm_module_range_mm, GearInputNames, MAX_WORM_HELIX_DEG,
};
use crate::GrindError;
use gearcomp_geometry::units::{deg_to_rad, fmt_value, rad_to_deg};

/// A `grind equalise` config: gear and worm bodies (cone angles included) and the search.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EqualiseConfig {
    /// `[gear]`.
    pub gear: GearInput,
    /// `[worm]`.
    pub worm: WormInput,
    /// `[equalise]`.
    pub equalise: EqualiseInput,
}

/// `[gear]` of an equalise config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearInput {
    /// Number of teeth z2.
    pub teeth: u32,
    /// Normal module m_n in mm (the worm's too).
    pub module_mm: f64,
    /// Right flank (both flanks if `pressure_angle_left_deg` is absent).
    pub pressure_angle_deg: f64,
    /// Left flank normal pressure angle in degrees.
    pub pressure_angle_left_deg: Option<f64>,
    /// Helix angle β2 in degrees (signed, + right hand).
    pub helix_angle_deg: f64,
    /// Workpiece cone angle ϑ2 (0 = cylindrical gear, chain (28)/(29)).
    #[serde(default)]
    pub cone_angle_deg: f64,
}

/// `[worm]` of an equalise config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WormInput {
    /// Number of starts z1.
    pub starts: u32,
    /// Reference radius r1 in mm.
    pub radius_mm: f64,
    /// "right" or "left".
    #[serde(default = "default_hand")]
    pub hand: String,
    /// The worm's present cone angle ϑ1; `equalise` reports both flanks' K at it, next to the
    /// equalising ϑ1 it searches (0 = cylindrical worm).
    #[serde(default)]
    pub cone_angle_deg: f64,
}

fn default_hand() -> String {
    "right".to_owned()
}

/// `[equalise]` of an equalise config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EqualiseInput {
    /// Wanted modification direction ρ_r2 on the gear's right flank.
    pub gear_rho_right_deg: f64,
    /// ρ_l2 (raw flank convention: a mirror-symmetric modification has ρ_l2 = −ρ_r2).
    pub gear_rho_left_deg: f64,
    /// Worm line directions ρ_r1/ρ_l1 (dresser contact lines, eq. (37)); both or neither
    /// (neither = the axial-section estimate of each conical worm flank).
    pub worm_rho_right_deg: Option<f64>,
    /// ρ_l1, see `worm_rho_right_deg`.
    pub worm_rho_left_deg: Option<f64>,
    /// Lower end of the searched ϑ1 in degrees [default: −15].
    #[serde(default = "default_cone_min")]
    pub cone_min_deg: f64,
    /// Upper end of the searched ϑ1 in degrees [default: 15].
    #[serde(default = "default_cone_max")]
    pub cone_max_deg: f64,
}

fn default_cone_min() -> f64 {
    -15.0
}

fn default_cone_max() -> f64 {
    15.0
}

/// An equalise config that does not describe a search.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RequestError {
    /// A table or key whose values the grinding crate refuses (the cause is the source).
    #[error("{key}")]
    Key {
        /// The table or key (`[gear]`, `[gear] cone_angle_deg`, `[worm]`).
        key: &'static str,
        /// Why.
        #[source]
        source: GrindError,
    },
    /// A key's value is outside its range (the value as written, the range in the key's unit).
    #[error("{key} = {v} is out of range: expected {expected}", v = gearcomp_geometry::units::fmt_value(*value))]
    OutOfRange {
        /// The table and key (`[equalise] gear_rho_right_deg`).
        key: &'static str,
        /// The value as written.
        value: f64,
        /// The allowed range in the key's unit.
        expected: String,
    },
    /// `[worm] hand` is neither "right" nor "left".
    #[error("[worm] hand = {0:?} is not allowed: expected \"right\" or \"left\"")]
    Hand(String),
    /// Only one of `[equalise] worm_rho_left_deg` / `worm_rho_right_deg` is given.
    #[error(
        "[equalise] worm_rho_left_deg / worm_rho_right_deg: give both (dresser contact lines) \
         or neither (axial-section estimate)"
    )]
    OneWormLine,
}

fn key(key: &'static str) -> impl FnOnce(GrindError) -> RequestError {
    move |source| RequestError::Key { key, source }
}

/// `lo ..= hi` (finite) for a key, in the key's unit.
fn check_key(key: &'static str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, RequestError> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(RequestError::OutOfRange {
            key,
            value: v,
            expected: format!("{} ..= {} {unit}", fmt_value(lo), fmt_value(hi)),
        })
    }
}

/// A [`check_gear_input`] or [`grinding_worm`] range error as a key error: its field is
/// already the key, its value as written.
fn range_key(e: GrindError, fallback: &'static str) -> RequestError {
    match e {
        GrindError::OutOfRange {
            field,
            value,
            expected,
        } if field.starts_with('[') => RequestError::OutOfRange {
            key: field,
            value,
            expected: expected.to_string(),
        },
        source => RequestError::Key {
            key: fallback,
            source,
        },
    }
}

/// The [gear] keys, for the gear-body range errors.
const GEAR_KEYS: GearInputNames = GearInputNames {
    teeth: "[gear] teeth",
    module: "[gear] module_mm",
    pressure_angle: "[gear] pressure_angle_deg",
    pressure_angle_left: "[gear] pressure_angle_left_deg",
    helix_angle: "[gear] helix_angle_deg",
};

impl EqualiseConfig {
    /// The T14 search input: the gear as a beveloid, the worm with the gear's α_n per flank
    /// (eq. (93): equal normal base pitch per flank with equal m_n), angles in rad.
    ///
    /// # Errors
    /// [`RequestError`] naming the table or key.
    pub fn spec(&self) -> Result<EqualiseSpec, RequestError> {
        let g = &self.gear;
        // every key is checked here, in the unit and under the name the user wrote, before
        // the library sees it in rad under its own names
        let gear = gear_from_input(
            &GEAR_KEYS,
            g.teeth,
            g.module_mm,
            g.pressure_angle_deg,
            g.pressure_angle_left_deg,
            g.helix_angle_deg,
            0.0,
        )
        .map_err(|e| range_key(e, "[gear]"))?;
        let alpha_r = deg_to_rad(g.pressure_angle_deg);
        let alpha_l = deg_to_rad(g.pressure_angle_left_deg.unwrap_or(g.pressure_angle_deg));
        let max_cone = rad_to_deg(MAX_CONE_ANGLE_RAD);
        let cone = |key, v| check_key(key, v, -max_cone, max_cone, "°");
        cone("[gear] cone_angle_deg", g.cone_angle_deg)?;
        let gear = BeveloidGear::new(gear, deg_to_rad(g.cone_angle_deg))
            .map_err(key("[gear] cone_angle_deg"))?;
        let hand = match self.worm.hand.as_str() {
            "right" => Hand::Right,
            "left" => Hand::Left,
            other => return Err(RequestError::Hand(other.to_owned())),
        };
        let w = &self.worm;
        cone("[worm] cone_angle_deg", w.cone_angle_deg)?;
        if w.starts == 0 || w.starts > 100_000 {
            return Err(RequestError::OutOfRange {
                key: "[worm] starts",
                value: f64::from(w.starts),
                expected: "1 ..= 100000".into(),
            });
        }
        let (m_lo, m_hi) = worm_module_range_mm(w.starts, w.radius_mm);
        let lead_ok = w.radius_mm.is_finite()
            && w.radius_mm > 0.0
            && g.module_mm >= m_lo
            && g.module_mm < m_hi;
        if !lead_ok {
            let (r_lo, r_hi) = (
                f64::from(w.starts) * g.module_mm / 1.8,
                f64::from(w.starts) * g.module_mm / (2.0 * MAX_WORM_HELIX_DEG.to_radians().cos()),
            );
            return Err(RequestError::OutOfRange {
                key: "[worm] radius_mm",
                value: w.radius_mm,
                expected: format!(
                    "above {} and at most {} mm for starts = {} and [gear] module_mm = {} \
                     (worm lead angle 0.03° ..= 64°)",
                    fmt_value(r_lo),
                    fmt_value(r_hi),
                    w.starts,
                    fmt_value(g.module_mm)
                ),
            });
        }
        let worm = grinding_worm(w.starts, g.module_mm, alpha_r, alpha_l, w.radius_mm, hand)
            .map_err(key("[worm]"))?;
        let e = &self.equalise;
        let rho = |key, v| check_key(key, v, -180.0, 180.0, "°");
        rho("[equalise] gear_rho_right_deg", e.gear_rho_right_deg)?;
        rho("[equalise] gear_rho_left_deg", e.gear_rho_left_deg)?;
        let worm_lines = match (e.worm_rho_left_deg, e.worm_rho_right_deg) {
            (Some(l), Some(r)) => {
                rho("[equalise] worm_rho_right_deg", r)?;
                rho("[equalise] worm_rho_left_deg", l)?;
                WormLines::Given {
                    left_rad: deg_to_rad(l),
                    right_rad: deg_to_rad(r),
                }
            }
            (None, None) => WormLines::AxialSection,
            _ => return Err(RequestError::OneWormLine),
        };
        cone("[equalise] cone_min_deg", e.cone_min_deg)?;
        cone("[equalise] cone_max_deg", e.cone_max_deg)?;
        if e.cone_min_deg >= e.cone_max_deg {
            return Err(RequestError::OutOfRange {
                key: "[equalise] cone_min_deg",
                value: e.cone_min_deg,
                expected: format!(
                    "below [equalise] cone_max_deg = {} °",
                    fmt_value(e.cone_max_deg)
                ),
            });
        }
        Ok(EqualiseSpec {
            worm,
            gear,
            rho2_left_rad: deg_to_rad(e.gear_rho_left_deg),
            rho2_right_rad: deg_to_rad(e.gear_rho_right_deg),
            worm_lines,
            cone_range_rad: (deg_to_rad(e.cone_min_deg), deg_to_rad(e.cone_max_deg)),
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    fn config() -> EqualiseConfig {
        EqualiseConfig {
            gear: GearInput {
                teeth: 31,
                module_mm: 3.0,
                pressure_angle_deg: 20.0,
                pressure_angle_left_deg: Some(22.0),
                helix_angle_deg: 15.0,
                cone_angle_deg: 3.0,
            },
            worm: WormInput {
                starts: 1,
                radius_mm: 50.0,
                hand: "left".into(),
                cone_angle_deg: 0.0,
            },
            equalise: EqualiseInput {
                gear_rho_right_deg: 30.0,
                gear_rho_left_deg: -30.0,
                worm_rho_right_deg: None,
                worm_rho_left_deg: None,
                cone_min_deg: -15.0,
                cone_max_deg: 15.0,
            },
        }
    }

    #[test]
    fn spec_in_radians_with_the_gear_angles_on_the_worm() {
        let s = config().spec().unwrap();
        let r = |d: f64| d.to_radians();
        assert_eq!(s.worm.alpha_n_right_rad, r(20.0));
        assert_eq!(s.worm.alpha_n_left_rad, r(22.0));
        // left-hand worm: cos β1 = z1·m_n/(2·r1) = 0.03, β1 < 0
        assert!((s.worm.beta_rad + 0.03f64.acos()).abs() < 1e-15);
        assert_eq!((s.rho2_left_rad, s.rho2_right_rad), (r(-30.0), r(30.0)));
        assert_eq!(s.cone_range_rad, (r(-15.0), r(15.0)));
        assert_eq!(s.worm_lines, WormLines::AxialSection);
    }

    #[test]
    fn errors_name_the_key() {
        let mut c = config();
        c.worm.hand = "up".into();
        assert_eq!(
            c.spec().unwrap_err().to_string(),
            "[worm] hand = \"up\" is not allowed: expected \"right\" or \"left\""
        );
        let mut c = config();
        c.equalise.worm_rho_left_deg = Some(10.0);
        assert_eq!(c.spec().unwrap_err(), RequestError::OneWormLine);
        let mut c = config();
        c.gear.module_mm = -1.0;
        let e = c.spec().unwrap_err();
        assert_eq!(
            e.to_string(),
            "[gear] module_mm = -1 is out of range: expected 0.01 ..= 1000 mm"
        );
        let mut c = config();
        c.equalise.gear_rho_right_deg = 1000.0;
        assert_eq!(
            c.spec().unwrap_err().to_string(),
            "[equalise] gear_rho_right_deg = 1000 is out of range: expected -180 ..= 180 °"
        );
    }
}
