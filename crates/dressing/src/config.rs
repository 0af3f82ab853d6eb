//! The TOML file of `gearcomp dress` (`[worm]`, `[dresser]`, and `[solve]` or `[plan]`) as one
//! type, [`DressConfig`], parsed by [`DressConfig::from_toml_str`] and checked key by key: every
//! error names the table and key the user wrote, the value and the allowed range in the key's
//! unit (JP6903407B2, worm dressing). The CLI only reads the file, calls this module and prints.

use serde::Deserialize;

use crate::campaign::{Correction, PlanOptions, PlanSpec};
use crate::dresser::Dresser;
use crate::error::{DressError, Result};
use crate::request::{
    check_evaluable, check_key, min_worn_diameter_mm, DresserInput, Method, SolveInput, WormInput,
    DEFAULT_BUDGET_MM,
};
use crate::topological_request::TopologicalInput;
use crate::worm::{Flank, Worm};

/// The whole `gearcomp dress` file. Unknown tables and keys are refused by name.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DressConfig {
    /// `[worm]`: the new worm.
    pub worm: WormInput,
    /// `[dresser]`: the profile roller dresser.
    pub dresser: DresserInput,
    /// `[solve]`, needed by `dress solve`.
    pub solve: Option<SolveConfig>,
    /// `[plan]`, needed by `dress plan`.
    pub plan: Option<PlanConfig>,
}

/// `[solve]`: one dressing's axis corrections ΔK for a profile modification.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolveConfig {
    /// `flank` (default `right`).
    #[serde(default = "right")]
    pub flank: Flank,
    /// `method`: `three-point` or `four-point`.
    pub method: Method,
    /// `diameter_mm`: current worm diameter (mm; default: the new worm).
    pub diameter_mm: Option<f64>,
    /// `crowning_um`: profile crowning c on the worm (µm): targets (0, −c, 0) at 5/50/95 %
    /// of the active profile (3-point).
    pub crowning_um: Option<f64>,
    /// `points`: explicit targets [fraction of the active profile, f in µm] (3 or 4 of them).
    pub points: Option<Vec<[f64; 2]>>,
    /// `[solve.contact_point]`: worm point the contact line must pass through, ν_zS as fifth
    /// unknown (JP6903407B2 eqs. (14), (19)).
    pub contact_point: Option<ContactPointConfig>,
    /// `[solve.topological]`: topological program over the worm width (JP6903407B2
    /// eqs. (15)–(17), (22)).
    pub topological: Option<TopologicalInput>,
    /// `budget_mm`: clearance budget for the opposite-flank cut and the jacket depth (mm,
    /// default [`DEFAULT_BUDGET_MM`]), as in `[plan]`.
    #[serde(default = "budget")]
    pub budget_mm: f64,
    /// `accept_penetration`: output a solution beyond the budget (flagged) instead of refusing it.
    #[serde(default)]
    pub accept_penetration: bool,
}

/// `[solve.contact_point]`: worm point (w, b) of the contact line.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContactPointConfig {
    /// `w_fraction`: position as a fraction of the active profile.
    pub w_fraction: f64,
    /// `b_mm`: position along the worm width (mm).
    pub b_mm: f64,
}

/// `[plan]`: every dressing of the worm's life.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanConfig {
    /// `flank` (default `right`).
    #[serde(default = "right")]
    pub flank: Flank,
    /// `diameters_mm`: the worm diameter at each dressing (mm), 1 ..= 1000 of them.
    pub diameters_mm: Vec<f64>,
    /// `correction` (default `three-point`).
    #[serde(default = "three_point")]
    pub correction: Correction,
    /// `crowning_um`: profile crowning (µm, default 0, −50 ..= 50).
    #[serde(default)]
    pub crowning_um: f64,
    /// `budget_mm`: clearance budget (mm, default [`DEFAULT_BUDGET_MM`], 0 ..= 5).
    #[serde(default = "budget")]
    pub budget_mm: f64,
    /// `zero_stretch`: choose each dressing's worm profile angle so the profile stretching is
    /// zero (JP6903407B2 claim 2).
    #[serde(default)]
    pub zero_stretch: bool,
    /// `alpha_search_deg`: half-width of that profile-angle search (degrees, default 10,
    /// 0.01 ..= 20).
    #[serde(default = "alpha_search")]
    pub alpha_search_deg: f64,
}

fn right() -> Flank {
    Flank::Right
}

fn budget() -> f64 {
    DEFAULT_BUDGET_MM
}

fn three_point() -> Correction {
    Correction::ThreePoint
}

fn alpha_search() -> f64 {
    10.0
}

impl DressConfig {
    /// Parses the TOML text of a `gearcomp dress` file. A syntax error, a missing key, an
    /// unknown table or key is a [`DressError::Toml`] whose message names the key and its line.
    /// The values are checked by [`DressConfig::build`], [`PlanConfig::spec`] and the solve.
    pub fn from_toml_str(text: &str) -> Result<DressConfig> {
        toml::from_str(text).map_err(|e: toml::de::Error| DressError::Toml(e.to_string()))
    }

    /// The new worm and its dresser; the errors name the `[worm]` / `[dresser]` key and unit.
    pub fn build(&self) -> Result<(Worm, Dresser)> {
        let worm = self.worm.build()?;
        let dresser = self.dresser.build(&worm)?;
        Ok((worm, dresser))
    }
}

impl SolveConfig {
    /// The single (non-topological) solve request of this table.
    pub fn input(&self) -> SolveInput {
        SolveInput {
            flank: self.flank,
            method: self.method,
            diameter_mm: self.diameter_mm,
            crowning_um: self.crowning_um,
            points: self.points.clone(),
            budget_mm: self.budget_mm,
            accept_penetration: self.accept_penetration,
        }
    }

    /// `[solve.contact_point]` as (w fraction, b in mm).
    pub fn contact_point(&self) -> Option<(f64, f64)> {
        self.contact_point.map(|p| (p.w_fraction, p.b_mm))
    }
}

impl PlanConfig {
    /// The table checked key by key (units and ranges in the messages) as the plan's
    /// specification and options for `worm`: `crowning_um` in −50 ..= 50 µm, `budget_mm` in
    /// 0 ..= 5 mm, 1 ..= 1000 `diameters_mm` each between the smallest worn diameter (rounded
    /// up to 0.1 µm) and the new worm's, `alpha_search_deg` in 0.01 ..= 20.
    pub fn spec(&self, worm: &Worm) -> Result<(PlanSpec, PlanOptions)> {
        check_evaluable(worm)?;
        check_key("[plan] crowning_um", self.crowning_um, -50.0, 50.0, "µm")?;
        check_key("[plan] budget_mm", self.budget_mm, 0.0, 5.0, "mm")?;
        let n = self.diameters_mm.len();
        if n == 0 || n > 1000 {
            return Err(DressError::Input {
                key: "[plan] diameters_mm".to_string(),
                detail: format!("has {n} diameters, allowed 1 ..= 1000 (mm)"),
            });
        }
        let d_lo = (min_worn_diameter_mm(worm) * 1e4).ceil() / 1e4;
        for (i, d) in self.diameters_mm.iter().enumerate() {
            check_key(
                &format!("[plan] diameters_mm[{i}]"),
                *d,
                d_lo,
                worm.d_s0_mm,
                "mm",
            )?;
        }
        check_key(
            "[plan] alpha_search_deg",
            self.alpha_search_deg,
            0.01,
            20.0,
            "",
        )?;
        let spec = PlanSpec {
            flank: self.flank,
            diameters_mm: self.diameters_mm.clone(),
            correction: self.correction,
            crowning_mm: self.crowning_um * 1e-3,
            budget_mm: self.budget_mm,
        };
        let options = PlanOptions {
            zero_stretch: self.zero_stretch,
            alpha_search_rad: self.alpha_search_deg.to_radians(),
        };
        Ok((spec, options))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    const WORM_DRESSER: &str = "[worm]\nstarts = 1\ndiameter_mm = 280.0\n\
        normal_module_mm = 3.0\nprofile_angle_deg = 20.0\n\n\
        [dresser]\ndiameter_mm = 125.0\njacket_width_mm = 0.8\n";

    fn parse(extra: &str) -> Result<DressConfig> {
        DressConfig::from_toml_str(&format!("{WORM_DRESSER}{extra}"))
    }

    #[test]
    fn defaults_of_solve_and_plan() {
        let cfg = parse("[solve]\nmethod = \"three-point\"\ncrowning_um = 5.0\n").unwrap();
        assert_eq!(cfg.worm.starts, 1);
        assert_eq!(cfg.worm.diameter_mm, 280.0);
        assert_eq!(cfg.dresser.clearance_mm, 0.0);
        assert!(cfg.plan.is_none());
        let s = cfg.solve.unwrap();
        assert_eq!(s.flank, Flank::Right);
        assert_eq!(s.method, Method::ThreePoint);
        assert_eq!(s.budget_mm, 0.1);
        assert!(!s.accept_penetration);
        assert_eq!(s.crowning_um, Some(5.0));
        assert_eq!(s.diameter_mm, None);
        assert_eq!(s.contact_point(), None);

        let cfg = parse("[plan]\ndiameters_mm = [280.0, 270.0]\n").unwrap();
        let p = cfg.plan.unwrap();
        assert_eq!(p.flank, Flank::Right);
        assert_eq!(p.correction, Correction::ThreePoint);
        assert_eq!(p.crowning_um, 0.0);
        assert_eq!(p.budget_mm, 0.1);
        assert!(!p.zero_stretch);
        assert_eq!(p.alpha_search_deg, 10.0);
    }

    #[test]
    fn unknown_key_is_named() {
        let e = parse("[plan]\ndiameters_mm = [280.0]\ncrowning = 2.0\n").unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("unknown field `crowning`"), "{msg}");
        let e =
            parse("[solve]\nmethod = \"three-point\"\n[solve.contact_point]\nw = 0.5\nb_mm = 0\n")
                .unwrap_err();
        assert!(e.to_string().contains("unknown field `w`"), "{e}");
        let e = DressConfig::from_toml_str(&format!("{WORM_DRESSER}[dressing]\n")).unwrap_err();
        assert!(e.to_string().contains("unknown field `dressing`"), "{e}");
    }

    #[test]
    fn plan_ranges_name_key_value_and_range() {
        let cfg = parse("[plan]\ndiameters_mm = [280.0]\nalpha_search_deg = 50.0\n").unwrap();
        let (worm, _) = cfg.build().unwrap();
        let e = cfg.plan.unwrap().spec(&worm).unwrap_err();
        assert_eq!(
            e.to_string(),
            "[plan] alpha_search_deg = 50 is outside the allowed range 0.01 ..= 20"
        );

        let cfg = parse("[plan]\ndiameters_mm = [280.0]\ncrowning_um = 60.0\n").unwrap();
        let e = cfg.plan.unwrap().spec(&worm).unwrap_err();
        assert_eq!(
            e.to_string(),
            "[plan] crowning_um = 60 µm is outside the allowed range -50 ..= 50 µm"
        );

        let cfg = parse("[plan]\ndiameters_mm = []\n").unwrap();
        let e = cfg.plan.unwrap().spec(&worm).unwrap_err();
        assert_eq!(
            e.to_string(),
            "[plan] diameters_mm: has 0 diameters, allowed 1 ..= 1000 (mm)"
        );

        // A diameter above the new worm's 280 mm.
        let cfg = parse("[plan]\ndiameters_mm = [280.0, 281.5]\n").unwrap();
        let e = cfg.plan.unwrap().spec(&worm).unwrap_err().to_string();
        assert!(
            e.starts_with("[plan] diameters_mm[1] = 281.5 mm is outside the allowed range ")
                && e.ends_with(" ..= 280 mm"),
            "{e}"
        );
    }

    #[test]
    fn plan_spec_converts_units() {
        let cfg = parse(
            "[plan]\nflank = \"left\"\ndiameters_mm = [280.0]\ncrowning_um = 4.0\n\
             zero_stretch = true\nalpha_search_deg = 2.0\n",
        )
        .unwrap();
        let (worm, _) = cfg.build().unwrap();
        let (spec, options) = cfg.plan.unwrap().spec(&worm).unwrap();
        assert_eq!(spec.flank, Flank::Left);
        assert!((spec.crowning_mm - 0.004).abs() < 1e-15);
        assert!(options.zero_stretch);
        assert!((options.alpha_search_rad - 2.0 * std::f64::consts::PI / 180.0).abs() < 1e-15);
    }

    /// The file as `grind simulate --dress` reads it: `[dressing]` defaults to the uncorrected
    /// worm, `[solve]`/`[plan]` are skipped unread, other tables are refused by name, and a bad
    /// `[worm]` / `[dresser]` value is reported during that table.
    #[test]
    fn grind_dress_config_schema() {
        use crate::request::{DressingInput, GrindDressConfig};
        let cfg = GrindDressConfig::from_toml_str(&format!(
            "{WORM_DRESSER}[solve]\nanything = 1\n[plan]\nx = [1]\n"
        ))
        .unwrap();
        assert_eq!(cfg.dressing, DressingInput::default());
        assert_eq!(cfg.dresser.jacket_width_mm, 0.8);
        let (worm, _dresser) = cfg.design().unwrap();
        assert_eq!(worm.z_s, 1);
        assert_eq!(worm.d_s0_mm, 280.0);
        assert!((worm.alpha_n_rad - 20.0 * std::f64::consts::PI / 180.0).abs() < 1e-15);

        let e = GrindDressConfig::from_toml_str(&format!("{WORM_DRESSER}[foo]\n")).unwrap_err();
        assert!(e.to_string().contains("unknown field `foo`"), "{e}");
        let e =
            GrindDressConfig::from_toml_str(&format!("{WORM_DRESSER}[dressing]\ncrowning = 3\n"))
                .unwrap_err();
        assert!(e.to_string().contains("unknown field `crowning`"), "{e}");

        let cfg =
            GrindDressConfig::from_toml_str(&WORM_DRESSER.replace("starts = 1", "starts = 0"))
                .unwrap();
        // Checked as `gearcomp dress` checks it: the key as written, value and range.
        assert_eq!(
            cfg.design().unwrap_err().to_string(),
            "[worm] starts = 0 is outside the allowed range 1 ..= 20"
        );
        // Half the axial pitch of this worm is π·m_n/(2 cos γ) > 4.71 mm: 50 mm is refused.
        let cfg = GrindDressConfig::from_toml_str(
            &WORM_DRESSER.replace("jacket_width_mm = 0.8", "jacket_width_mm = 50"),
        )
        .unwrap();
        let e = cfg.design().unwrap_err().to_string();
        assert!(
            e.starts_with("[dresser] jacket_width_mm = 50 mm is outside the allowed range"),
            "{e}"
        );
    }
}
