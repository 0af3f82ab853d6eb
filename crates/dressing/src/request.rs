//! A dressing request as the operator states it (the `gearcomp dress` TOML keys, in degrees,
//! mm and µm), validated key by key, solved, and checked against what the worm and the dresser
//! can carry: the same penetration check as the worm-life plan (opposite-flank cut and jacket
//! depth against the clearance budget), and, when a request cannot be produced, the producible
//! range at this geometry (the largest share of the modification, the worm diameters).
//!
//! Every error of this module names the TOML key the user wrote and its unit; the library's
//! own field names (radians, `_rad`, `z_s`, …) never reach the user from here.

use crate::campaign::{profile_stretch, StretchReference};
use crate::dresser::{Dresser, DresserSpec};
use crate::envelope::DressingSetup;
use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::simulation::{contact_line, fit_contact_line};
use crate::solve::{
    solve_four_point, solve_three_point, tip_association_radius_mm, FourPoint, NewtonOptions,
    Solution, ThreePoint,
};
use crate::worm::{Flank, Worm};
use gearcomp_geometry::units::fmt_value;
use serde::{Deserialize, Serialize};

/// `[worm]`: the new worm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WormInput {
    /// `starts`: number of threads z_S.
    pub starts: u32,
    /// `diameter_mm`: reference diameter of the new worm d_S0 (mm).
    pub diameter_mm: f64,
    /// `normal_module_mm` (mm).
    pub normal_module_mm: f64,
    /// `profile_angle_deg`: normal profile angle (degrees).
    pub profile_angle_deg: f64,
}

/// `[dresser]`: the profile roller dresser, designed for the new worm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DresserInput {
    /// `diameter_mm`: outer (jacket) diameter d_A (mm).
    pub diameter_mm: f64,
    /// `jacket_width_mm` (mm).
    pub jacket_width_mm: f64,
    /// `clearance_mm` per flank (mm, default 0).
    #[serde(default)]
    pub clearance_mm: f64,
}

/// `[dressing]`: how the worm is dressed before `gearcomp grind simulate --dress` grinds with
/// it: given ΔK (default: uncorrected), or the 3-point solve (`crowning_um` or `points`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DressingInput {
    /// `diameter_mm`: current worm diameter d_S in mm (default: the new worm, d_S0).
    pub diameter_mm: Option<f64>,
    /// `crowning_um`: 3-point crowning c in µm, targets [`ThreePoint::crowning_targets`].
    pub crowning_um: Option<f64>,
    /// `points`: explicit 3-point targets [fraction of the active profile, f in µm].
    pub points: Option<Vec<[f64; 2]>>,
    /// `dphi_s_rad`: Δφ_S in rad (as `gearcomp dress solve` prints it).
    pub dphi_s_rad: Option<f64>,
    /// `dgamma_deg`: Δγ in degrees.
    pub dgamma_deg: Option<f64>,
    /// `dd_mm`: Δd in mm.
    pub dd_mm: Option<f64>,
    /// `dnu_ya_mm`: Δν_yA in mm.
    pub dnu_ya_mm: Option<f64>,
    /// `table_points`: number of table points over the dressed profile (default 41).
    pub table_points: Option<usize>,
}

/// A `gearcomp dress` config file as `gearcomp grind simulate --dress` reads it: `[worm]`,
/// `[dresser]` and `[dressing]`; `[solve]` and `[plan]` may be present (they belong to
/// `gearcomp dress`) and are skipped unread. Any other table is refused.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GrindDressConfig {
    /// `[worm]`.
    pub worm: WormInput,
    /// `[dresser]`.
    pub dresser: DresserInput,
    /// `[dressing]` (default: the uncorrected worm).
    #[serde(default)]
    pub dressing: DressingInput,
    /// `[solve]`, skipped.
    #[allow(dead_code)]
    solve: Option<IgnoredTable>,
    /// `[plan]`, skipped.
    #[allow(dead_code)]
    plan: Option<IgnoredTable>,
}

/// How a [`DressingInput`] was dressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DressingKind {
    /// No correction (ΔK = 0).
    None,
    /// ΔK as given in the keys `dphi_s_rad`, `dgamma_deg`, `dd_mm`, `dnu_ya_mm`.
    Given,
    /// ΔK of the 3-point solve of `crowning_um` or `points`.
    ThreePoint,
}

impl DressingKind {
    /// `none`, `given` or `three-point`.
    pub fn name(self) -> &'static str {
        match self {
            DressingKind::None => "none",
            DressingKind::Given => "given",
            DressingKind::ThreePoint => "three-point",
        }
    }
}

/// The worm dressed as a [`DressingInput`] asks, tabulated over the dressed part of its flank.
#[derive(Debug, Clone, PartialEq)]
pub struct DressedWormTable {
    /// The worm at its current diameter.
    pub worm: Worm,
    /// How ΔK was found.
    pub kind: DressingKind,
    /// The axis correction ΔK dressed with.
    pub dk: AxisCorrection,
    /// Newton iterations of the 3-point solve (`None` for a given ΔK).
    pub iterations: Option<usize>,
    /// Roll distances w of the table (mm), evenly over [`Self::dressed_roll_range_mm`].
    pub roll_mm: Vec<f64>,
    /// Normal profile deviation f_nFS at each w (mm, > 0 = material left).
    pub f_mm: Vec<f64>,
    /// The dressed roll range [w_Nf(ΔK), w_Na] (mm).
    pub dressed_roll_range_mm: (f64, f64),
    /// Direction ρ_F1 of the fitted contact line on the worm (rad).
    pub contact_line_rad: f64,
}

/// Largest |ΔK component| a given correction may have, per key, in the key's unit.
const GIVEN_LIMITS: [(&str, f64); 4] = [
    ("[dressing] dphi_s_rad", 2.0),
    ("[dressing] dgamma_deg", 12.0),
    ("[dressing] dd_mm", 3.0),
    ("[dressing] dnu_ya_mm", 30.0),
];

impl DressingInput {
    /// Dresses `flank` of the worm `design` (the new worm, worn to `diameter_mm`) with
    /// `dresser` as this input asks, and tabulates the dressed profile at `table_points`
    /// roll distances over [w_Nf(ΔK), w_Na]: w_Na on the tip circle, w_Nf(ΔK) the roll
    /// distance the dresser's fillet/flank tangent point dresses under ΔK.
    ///
    /// The 3-point targets (`crowning_um` → [`ThreePoint::crowning_targets`], or `points`) are
    /// fractions of the current worm's active profile; as in `gearcomp dress solve`, the
    /// dresser radius that dresses the new worm's tip circle keeps dressing the tip circle.
    /// Every error names the `[dressing]` key (or the step) it comes from.
    pub fn dress(
        &self,
        design: &Worm,
        dresser: &Dresser,
        flank: Flank,
    ) -> Result<DressedWormTable> {
        let worm = match self.diameter_mm {
            Some(d) => design
                .worn(d)
                .map_err(|e| e.during("[dressing] diameter_mm"))?,
            None => *design,
        };
        let setup = DressingSetup::new(worm, dresser.clone());
        let (w_nf, w_na) = setup
            .active_profile(flank)
            .map_err(|e| e.during("active profile of the worm"))?;
        let explicit = self.dphi_s_rad.is_some()
            || self.dgamma_deg.is_some()
            || self.dd_mm.is_some()
            || self.dnu_ya_mm.is_some();
        let targets: Option<Vec<[f64; 2]>> = match (&self.points, self.crowning_um) {
            (Some(_), Some(_)) => {
                return Err(input_err(
                    "[dressing]",
                    "give either `points` or `crowning_um`, not both".into(),
                ))
            }
            (Some(p), None) => Some(p.clone()),
            (None, Some(c)) => {
                // The targets (0, −c, 0) hold f within the points' ±MAX_TARGET_UM.
                if !(c.is_finite() && c.abs() <= MAX_TARGET_UM) {
                    return Err(input_err(
                        "[dressing] crowning_um",
                        format!(
                            "= {c} µm is out of range: expected -{MAX_TARGET_UM} ..= \
                             {MAX_TARGET_UM} µm"
                        ),
                    ));
                }
                Some(ThreePoint::crowning_targets(c).to_vec())
            }
            (None, None) => None,
        };
        let k0 = AxisCorrection::default();
        let (dk, iterations, kind) = match targets {
            Some(_) if explicit => {
                return Err(input_err(
                    "[dressing]",
                    "give either axis corrections (dphi_s_rad, dgamma_deg, dd_mm, dnu_ya_mm) or \
                     3-point targets (crowning_um / points), not both"
                        .into(),
                ))
            }
            Some(p) => {
                if p.len() != 3 {
                    return Err(input_err(
                        "[dressing] points",
                        format!("got {}, expected 3", p.len()),
                    ));
                }
                for (i, q) in p.iter().enumerate() {
                    if !(0.0..=1.0).contains(&q[0])
                        || !q[1].is_finite()
                        || q[1].abs() > MAX_TARGET_UM
                    {
                        return Err(input_err(
                            "[dressing] points",
                            format!(
                                "row {i} = [{}, {}]: expected a fraction in 0 ..= 1 of the \
                                 active profile and f in -{MAX_TARGET_UM} ..= {MAX_TARGET_UM} µm",
                                q[0], q[1]
                            ),
                        ));
                    }
                }
                let r_tip = tip_association_radius_mm(design, &setup.dresser, flank)?;
                let problem =
                    ThreePoint::from_fractions(&setup, flank, &[p[0], p[1], p[2]], 1.0, r_tip)?;
                let sol = solve_three_point(&setup, &problem, k0, &NewtonOptions::default())
                    .map_err(|e| self.not_producible(e, design, dresser, flank, &p, worm.d_s_mm))?;
                (sol.dk, Some(sol.iterations), DressingKind::ThreePoint)
            }
            None => {
                let dk = AxisCorrection {
                    dphi_s_rad: self.dphi_s_rad.unwrap_or(0.0),
                    dgamma_rad: self.dgamma_deg.unwrap_or(0.0).to_radians(),
                    dd_mm: self.dd_mm.unwrap_or(0.0),
                    dnu_ya_mm: self.dnu_ya_mm.unwrap_or(0.0),
                };
                let values = [
                    dk.dphi_s_rad,
                    dk.dgamma_rad.to_degrees(),
                    dk.dd_mm,
                    dk.dnu_ya_mm,
                ];
                for ((key, lim), v) in GIVEN_LIMITS.into_iter().zip(values) {
                    if !(v.is_finite() && v.abs() <= lim) {
                        return Err(input_err(
                            key,
                            format!("= {v} is out of range: expected |value| ≤ {lim}"),
                        ));
                    }
                }
                let kind = if explicit {
                    DressingKind::Given
                } else {
                    DressingKind::None
                };
                (dk, None, kind)
            }
        };
        // Where the dresser dressed under ΔK: from its fillet/flank tangent point to the tip.
        let side = setup.dresser.side(flank);
        let r_t = setup.dresser.profile(side.u_tangent_mm * side.z_sign).0;
        let w_nf_dk = setup
            .roll_dressed_by(flank, r_t, &dk, w_nf)
            .map_err(|e| e.during("dressed range under ΔK"))?;
        if w_nf_dk.is_nan() || w_nf_dk >= w_na {
            return Err(DressError::DresserMissesFlank {
                w_nf_mm: w_nf_dk,
                w_na_mm: w_na,
            });
        }
        let n = self.table_points.unwrap_or(41);
        if !(5..=2001).contains(&n) {
            return Err(input_err(
                "[dressing] table_points",
                format!("= {n} is out of range: expected 5 ..= 2001"),
            ));
        }
        let ws: Vec<f64> = (0..n)
            .map(|i| w_nf_dk + (w_na - w_nf_dk) * i as f64 / (n - 1) as f64)
            .collect();
        let f = setup
            .profile(flank, &ws, &dk)
            .map_err(|e| e.during("dressed profile"))?;
        let (rho, _, _) = fit_contact_line(&contact_line(&setup, flank, &ws, &dk)?);
        Ok(DressedWormTable {
            worm,
            kind,
            dk,
            iterations,
            roll_mm: ws,
            f_mm: f,
            dressed_roll_range_mm: (w_nf_dk, w_na),
            contact_line_rad: rho,
        })
    }
}

impl DressingInput {
    /// The refusal of 3-point targets `points` that have no axis correction on the worm of
    /// diameter `d_s_mm`: names the key written (`crowning_um` or `points`) and the largest
    /// share of it that has one ([`largest_producible_scale`] without a depth budget, since
    /// `[dressing]` has none), the crowning rounded toward zero so that the stated value is
    /// itself producible.
    fn not_producible(
        &self,
        e: DressError,
        design: &Worm,
        dresser: &Dresser,
        flank: Flank,
        points: &[[f64; 2]],
        d_s_mm: f64,
    ) -> DressError {
        let scale = largest_producible_scale(
            design,
            dresser,
            flank,
            Method::ThreePoint,
            points,
            d_s_mm,
            f64::INFINITY,
        );
        let at = format!("at the worm diameter {d_s_mm:.3} mm");
        let key = if self.crowning_um.is_some() {
            "[dressing] crowning_um"
        } else {
            "[dressing] points"
        };
        let hint = match (scale, self.crowning_um) {
            (None, _) => format!("{at} not even the unmodified profile has one"),
            (Some(s), Some(c)) => format!(
                "{at} the largest crowning this worm and dresser carry is crowning_um = {} µm",
                fmt_value((s * c * 1e3).trunc() / 1e3)
            ),
            (Some(s), None) => format!(
                "{at} at most {} % of these points (every f scaled alike) has one",
                fmt_value((1e3 * s).trunc() / 10.0)
            ),
        };
        DressError::NotProducible {
            key: key.into(),
            detail: format!("the axis corrections have no root for these targets ({e}); {hint}"),
        }
    }
}

/// A table that is accepted and not read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct IgnoredTable;

impl<'de> Deserialize<'de> for IgnoredTable {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        serde::de::IgnoredAny::deserialize(d).map(|_| IgnoredTable)
    }
}

impl GrindDressConfig {
    /// Parses the TOML text of a `gearcomp dress` file as `grind simulate --dress` reads it.
    /// A syntax error, a missing key, an unknown table or key is a [`DressError::Toml`] whose
    /// message names the key and its line.
    pub fn from_toml_str(text: &str) -> Result<GrindDressConfig> {
        toml::from_str(text).map_err(|e: toml::de::Error| DressError::Toml(e.to_string()))
    }

    /// The new worm of `[worm]` and its dresser of `[dresser]`, every key checked first
    /// exactly as `gearcomp dress` checks them ([`WormInput::build`], [`DresserInput::build`]),
    /// so an error names the key the user wrote (`[worm] starts`), its value and range.
    pub fn design(&self) -> Result<(Worm, Dresser)> {
        let design = self.worm.build()?;
        let dresser = self.dresser.build(&design)?;
        Ok((design, dresser))
    }
}

/// Solve method of `[solve] method`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Three targets plus the radius association at the tip.
    ThreePoint,
    /// Four targets (minimum-norm correction).
    FourPoint,
}

/// `[solve]` (the single, non-topological solve).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolveInput {
    /// `flank`.
    pub flank: Flank,
    /// `method`.
    pub method: Method,
    /// `diameter_mm`: current worm diameter (mm); `None` = the new worm.
    pub diameter_mm: Option<f64>,
    /// `crowning_um`: targets (0, −c, 0) at 5/50/95 % of the active profile (3-point).
    pub crowning_um: Option<f64>,
    /// `points`: explicit targets [fraction of the active profile, f in µm].
    pub points: Option<Vec<[f64; 2]>>,
    /// `budget_mm`: clearance budget for the opposite-flank cut and the jacket depth (mm).
    pub budget_mm: f64,
    /// `accept_penetration`: return a solution beyond the budget (flagged) instead of an error.
    pub accept_penetration: bool,
}

/// Default `[solve] budget_mm`, the same as `[plan] budget_mm` (mm).
pub const DEFAULT_BUDGET_MM: f64 = 0.1;

/// Largest |crowning| / |target| accepted (µm).
pub const MAX_TARGET_UM: f64 = 1000.0;

fn input_err(key: &str, detail: String) -> DressError {
    DressError::Input {
        key: key.to_string(),
        detail,
    }
}

/// `lo ≤ v ≤ hi` (finite) for a TOML key, the message in the key's unit.
pub fn check_key(key: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(v)
    } else {
        let u = if unit.is_empty() {
            String::new()
        } else {
            format!(" {unit}")
        };
        Err(input_err(
            key,
            format!(
                "= {}{u} is outside the allowed range {} ..= {}{u}",
                fmt_value(v),
                fmt_value(lo),
                fmt_value(hi)
            ),
        ))
    }
}

/// Smallest worm diameter `[solve] diameter_mm` may take: tip and root 2.25 m_n above the
/// base circle, so the whole tooth depth stays on the involute (mm).
pub fn min_worn_diameter_mm(worm: &Worm) -> f64 {
    2.0 * (worm.r_b_mm + 2.25 * worm.m_n_mm)
}

/// A new worm whose dressing can be evaluated: its reference radius at least r_b + 2.25 m_n
/// ([`min_worn_diameter_mm`]), so the whole tooth depth of the new worm is on the involute.
/// `dress design` does not need it; `dress solve` and `dress plan` do. A worm with many starts
/// and a small diameter (z = 20, d = 90 mm, m_n = 3 mm: r_b = 39.5 mm > 45 − 6.75 mm) was
/// accepted and then refused with the empty range "[plan] diameters_mm[0] = 90 mm is outside
/// the allowed range 92.494 ..= 90 mm" or under `[solve] crowning_um`.
pub fn check_evaluable(worm: &Worm) -> Result<()> {
    let need_mm = worm.r_b_mm + 2.25 * worm.m_n_mm;
    if worm.d_s0_mm / 2.0 >= need_mm {
        return Ok(());
    }
    Err(input_err(
        "[worm] diameter_mm",
        format!(
            "= {} mm is too small to dress and evaluate this worm: its reference radius {} mm \
             must be at least the base radius {:.4} mm + 2.25 × normal_module_mm = {:.4} mm \
             (whole tooth depth on the involute); take a larger diameter_mm, fewer starts or \
             a larger profile_angle_deg",
            worm.d_s0_mm,
            worm.d_s0_mm / 2.0,
            worm.r_b_mm,
            need_mm
        ),
    ))
}

/// The worm at `[solve] diameter_mm` (the new worm when absent), the key checked.
pub fn current_worm(design: &Worm, diameter_mm: Option<f64>) -> Result<Worm> {
    check_evaluable(design)?;
    match diameter_mm {
        Some(d) => {
            let lo = (min_worn_diameter_mm(design) * 1e4).ceil() / 1e4;
            check_key("[solve] diameter_mm", d, lo, design.d_s0_mm, "mm")?;
            design.worn(d)
        }
        None => Ok(*design),
    }
}

impl WormInput {
    /// The new worm, every key checked first.
    pub fn build(&self) -> Result<Worm> {
        check_key("[worm] starts", f64::from(self.starts), 1.0, 20.0, "")?;
        check_key(
            "[worm] normal_module_mm",
            self.normal_module_mm,
            0.05,
            100.0,
            "mm",
        )?;
        check_key(
            "[worm] profile_angle_deg",
            self.profile_angle_deg,
            5.0,
            45.0,
            "degrees",
        )?;
        let d_min = f64::from(self.starts) * self.normal_module_mm * 1.0001;
        if !(self.diameter_mm.is_finite() && self.diameter_mm > d_min && self.diameter_mm <= 1e4) {
            return Err(input_err(
                "[worm] diameter_mm",
                format!(
                    "= {} mm is outside the allowed range {:.4} ..= 10000 mm (it must exceed \
                     starts × normal_module_mm = {} mm)",
                    self.diameter_mm,
                    d_min,
                    f64::from(self.starts) * self.normal_module_mm
                ),
            ));
        }
        Worm::design(
            self.starts,
            self.diameter_mm,
            self.normal_module_mm,
            self.profile_angle_deg.to_radians(),
        )
        .map_err(|e| input_err("[worm]", format!("no worm with these values: {e}")))
    }
}

impl DresserInput {
    /// The dresser for the new `worm`, every key checked first.
    pub fn build(&self, worm: &Worm) -> Result<Dresser> {
        check_key("[dresser] diameter_mm", self.diameter_mm, 5.0, 2000.0, "mm")?;
        // The dresser axis sits at d_0 = r_f + d_A/2 from the worm axis (its jacket on the root
        // circle); it must clear the tip circle r_a, so d_A > 2 (r_a − r_f) = 4.5 m_n
        // (docs/dressing.md "Dresser too small for the worm").
        let d_min_mm = 2.0 * (worm.r_a_mm - worm.r_f_mm);
        if self.diameter_mm <= d_min_mm {
            return Err(input_err(
                "[dresser] diameter_mm",
                format!(
                    "= {} mm is outside the admissible range > {d_min_mm:.4} ..= 2000 mm for this \
                     worm: the dresser axis sits at the root radius + diameter_mm/2 from the worm \
                     axis and must clear the tip circle, so diameter_mm must exceed twice the \
                     tooth depth (2 × 2.25 × normal_module_mm)",
                    self.diameter_mm
                ),
            ));
        }
        let half_pitch = worm.axial_pitch_mm() / 2.0;
        if !(self.jacket_width_mm.is_finite()
            && self.jacket_width_mm > 0.0
            && self.jacket_width_mm <= half_pitch)
        {
            return Err(input_err(
                "[dresser] jacket_width_mm",
                format!(
                    "= {} mm is outside the allowed range 0 < jacket_width_mm ..= {half_pitch:.4} mm \
                     (half the axial pitch); the jacket dresses the root and joins both flanks \
                     through the fillets, so it needs a width > 0",
                    self.jacket_width_mm
                ),
            ));
        }
        check_key(
            "[dresser] clearance_mm",
            self.clearance_mm,
            0.0,
            0.2 * worm.m_n_mm,
            "mm",
        )?;
        Dresser::design(
            worm,
            DresserSpec {
                d_a_mm: self.diameter_mm,
                jacket_width_mm: self.jacket_width_mm,
                clearance_mm: self.clearance_mm,
            },
        )
        .map_err(|e| match e {
            DressError::Geometry(g) => input_err("[dresser]", g),
            other => input_err("[dresser]", other.to_string()),
        })
    }
}

/// Opposite-flank cut and jacket depth of a solution against the clearance budget: the check
/// of `dress plan` (`PlanRow::penetration`, `PlanRow::undercut`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Checks {
    /// Largest cut into the opposite flank (mm, > 0 = below nominal).
    pub opposite_cut_mm: f64,
    /// Depth of the jacket below the root circle (mm, < 0 = root not reached).
    pub jacket_depth_mm: f64,
    /// The budget compared with (mm).
    pub budget_mm: f64,
    /// Opposite-flank cut beyond the budget.
    pub penetration: bool,
    /// Jacket deeper than the budget below the root.
    pub undercut: bool,
}

impl Checks {
    /// The checks of ΔK on `flank`.
    pub fn of(
        setup: &DressingSetup,
        flank: Flank,
        dk: &AxisCorrection,
        budget_mm: f64,
    ) -> Result<Self> {
        let opposite_cut_mm = setup.opposite_flank_cut(flank, dk)?;
        let jacket_depth_mm = setup.jacket_depth(dk);
        Ok(Self {
            opposite_cut_mm,
            jacket_depth_mm,
            budget_mm,
            penetration: opposite_cut_mm > budget_mm,
            undercut: jacket_depth_mm > budget_mm,
        })
    }

    /// Both within the budget.
    pub fn ok(&self) -> bool {
        !self.penetration && !self.undercut
    }

    /// "opposite-flank cut 904 µm and jacket 671 µm below the root" (only what exceeds).
    fn describe(&self) -> String {
        let mut parts = Vec::new();
        if self.penetration {
            parts.push(format!(
                "the dresser cuts {:.1} µm into the opposite flank",
                1e3 * self.opposite_cut_mm
            ));
        }
        if self.undercut {
            parts.push(format!(
                "its jacket reaches {:.1} µm below the worm root circle",
                1e3 * self.jacket_depth_mm
            ));
        }
        parts.join(" and ")
    }
}

/// The solved request.
#[derive(Debug, Clone)]
pub struct SolveOutcome {
    /// Worm as it is now, dresser and uncorrected setting.
    pub setup: DressingSetup,
    /// Active profile [w_Nf, w_Na] of the current worm (mm).
    pub active_mm: (f64, f64),
    /// Target roll distances (mm).
    pub target_w_mm: Vec<f64>,
    /// Targets f (mm).
    pub target_f_mm: Vec<f64>,
    /// The solve.
    pub solution: Solution,
    /// Penetration check.
    pub checks: Checks,
    /// Relative profile stretching P_FS against the new worm (1 = 100 %).
    pub stretch: f64,
}

/// The validated problem: targets (fraction, µm) and where they came from.
struct Targets {
    points: Vec<[f64; 2]>,
    /// The TOML key the targets were written with.
    key: &'static str,
}

fn targets(input: &SolveInput) -> Result<Targets> {
    let (points, key) = match (&input.points, input.crowning_um) {
        (Some(_), Some(_)) => {
            return Err(input_err(
                "[solve] crowning_um",
                "give either crowning_um or points, not both".into(),
            ))
        }
        (Some(p), None) => (p.clone(), "[solve] points"),
        (None, Some(c)) => {
            if input.method != Method::ThreePoint {
                return Err(input_err(
                    "[solve] crowning_um",
                    "crowning_um is for method = \"three-point\"; four-point needs `points`".into(),
                ));
            }
            check_key("[solve] crowning_um", c, -50.0, 50.0, "µm")?;
            (
                ThreePoint::crowning_targets(c).to_vec(),
                "[solve] crowning_um",
            )
        }
        (None, None) => return Err(input_err(
            "[solve]",
            "needs `points` (fraction, µm), or `crowning_um` (µm) with method = \"three-point\""
                .into(),
        )),
    };
    let need = match input.method {
        Method::ThreePoint => 3,
        Method::FourPoint => 4,
    };
    if points.len() != need {
        return Err(input_err(
            "[solve] points",
            format!(
                "method {:?} needs {need} points (fraction, µm), got {}",
                input.method,
                points.len()
            ),
        ));
    }
    for (i, p) in points.iter().enumerate() {
        if !(p[0].is_finite() && (0.0..=1.0).contains(&p[0])) {
            return Err(input_err(
                "[solve] points",
                format!(
                    "row {i}: fraction {} is outside the allowed range 0 ..= 1 (share of the \
                     active profile, no unit)",
                    p[0]
                ),
            ));
        }
        if !(p[1].is_finite() && p[1].abs() <= MAX_TARGET_UM) {
            return Err(input_err(
                "[solve] points",
                format!(
                    "row {i}: f = {} µm is outside the allowed range -{MAX_TARGET_UM} ..= {MAX_TARGET_UM} µm",
                    p[1]
                ),
            ));
        }
        for (j, q) in points.iter().enumerate().take(i) {
            if (q[0] - p[0]).abs() < 1e-3 {
                return Err(input_err(
                    "[solve] points",
                    format!(
                        "rows {j} and {i} have the same fraction {} (closer than 0.001 of the \
                         active profile): each target needs its own roll distance",
                        p[0]
                    ),
                ));
            }
        }
    }
    Ok(Targets { points, key })
}

/// Solves `targets` scaled by `scale` on the worm of diameter `d_s_mm`; `start` is the
/// continuation start. Returns (setup, active profile, target w, target f, solution).
type Solved = (DressingSetup, (f64, f64), Vec<f64>, Vec<f64>, Solution);

#[allow(clippy::too_many_arguments)]
fn solve_scaled(
    design: &Worm,
    dresser: &Dresser,
    flank: Flank,
    method: Method,
    points: &[[f64; 2]],
    scale: f64,
    d_s_mm: f64,
    start: AxisCorrection,
) -> Result<Solved> {
    let worm = design.worn(d_s_mm)?;
    let setup = DressingSetup::new(worm, dresser.clone());
    let (w_nf, w_na) = setup.active_profile(flank)?;
    let at = |q: f64| w_nf + q * (w_na - w_nf);
    let ws: Vec<f64> = points.iter().map(|p| at(p[0])).collect();
    let fs: Vec<f64> = points.iter().map(|p| scale * p[1] * 1e-3).collect();
    let opts = NewtonOptions::default();
    let k0 = AxisCorrection::default();
    let solve = |start: AxisCorrection| -> Result<Solution> {
        match method {
            Method::ThreePoint => {
                // The dresser radius that dresses the tip circle of the new worm keeps doing so.
                let r_tip = tip_association_radius_mm(design, dresser, flank)?;
                let p = ThreePoint {
                    flank,
                    w_mm: [ws[0], ws[1], ws[2]],
                    f_mm: [fs[0], fs[1], fs[2]],
                    w_assoc_mm: w_na,
                    r_a_mm: r_tip,
                };
                solve_three_point(&setup, &p, start, &opts)
            }
            Method::FourPoint => {
                let p = FourPoint {
                    flank,
                    w_mm: [ws[0], ws[1], ws[2], ws[3]],
                    f_mm: [fs[0], fs[1], fs[2], fs[3]],
                };
                solve_four_point(&setup, &p, start, &opts)
            }
        }
    };
    let sol = solve(start).or_else(|e| if start == k0 { Err(e) } else { solve(k0) })?;
    Ok((setup, (w_nf, w_na), ws, fs, sol))
}

/// Whether `scale` × the targets is producible within the budget at `d_s_mm`; the ΔK found
/// (for continuation) when it is.
#[allow(clippy::too_many_arguments)]
fn producible(
    design: &Worm,
    dresser: &Dresser,
    flank: Flank,
    method: Method,
    points: &[[f64; 2]],
    scale: f64,
    d_s_mm: f64,
    budget_mm: f64,
    start: AxisCorrection,
) -> Option<AxisCorrection> {
    let (setup, _, _, _, sol) =
        solve_scaled(design, dresser, flank, method, points, scale, d_s_mm, start).ok()?;
    let c = Checks::of(&setup, flank, &sol.dk, budget_mm).ok()?;
    c.ok().then_some(sol.dk)
}

/// Largest λ ∈ [0, 1] such that λ × the targets is producible within the budget at `d_s_mm`
/// (continuation from λ = 0, then bisection to 1e-3); `None` when not even λ = 0 (the
/// unmodified profile) is.
#[allow(clippy::too_many_arguments)]
pub fn largest_producible_scale(
    design: &Worm,
    dresser: &Dresser,
    flank: Flank,
    method: Method,
    points: &[[f64; 2]],
    d_s_mm: f64,
    budget_mm: f64,
) -> Option<f64> {
    let k0 = AxisCorrection::default();
    let mut k = producible(
        design, dresser, flank, method, points, 0.0, d_s_mm, budget_mm, k0,
    )?;
    let (mut lo, mut hi) = (0.0, 1.0);
    if producible(
        design, dresser, flank, method, points, 1.0, d_s_mm, budget_mm, k,
    )
    .is_some()
    {
        return Some(1.0);
    }
    while hi - lo > 1e-3 {
        let mid = 0.5 * (lo + hi);
        match producible(
            design, dresser, flank, method, points, mid, d_s_mm, budget_mm, k,
        ) {
            Some(km) => {
                lo = mid;
                k = km;
            }
            None => hi = mid,
        }
    }
    Some(lo)
}

/// Smallest worm diameter (mm, to 0.1 mm) at which the full targets are producible within the
/// budget, searched by bisection between `d_from_mm` (not producible) and the new worm;
/// `None` when the new worm cannot carry them either.
#[allow(clippy::too_many_arguments)]
pub fn smallest_producible_diameter(
    design: &Worm,
    dresser: &Dresser,
    flank: Flank,
    method: Method,
    points: &[[f64; 2]],
    d_from_mm: f64,
    budget_mm: f64,
) -> Option<f64> {
    let k0 = AxisCorrection::default();
    let mut k = producible(
        design,
        dresser,
        flank,
        method,
        points,
        1.0,
        design.d_s0_mm,
        budget_mm,
        k0,
    )?;
    let (mut lo, mut hi) = (d_from_mm, design.d_s0_mm);
    while hi - lo > 0.1 {
        let mid = 0.5 * (lo + hi);
        match producible(
            design, dresser, flank, method, points, 1.0, mid, budget_mm, k,
        ) {
            Some(km) => {
                hi = mid;
                k = km;
            }
            None => lo = mid,
        }
    }
    Some(hi)
}

/// "what is producible here": the largest share of the modification at this diameter and the
/// diameters at which the full modification is producible.
#[allow(clippy::too_many_arguments)]
fn producible_range(
    design: &Worm,
    dresser: &Dresser,
    input: &SolveInput,
    t: &Targets,
    d_s_mm: f64,
) -> String {
    let (fl, m, b) = (input.flank, input.method, input.budget_mm);
    let budget = format!("[solve] budget_mm = {b} mm");
    let scale = largest_producible_scale(design, dresser, fl, m, &t.points, d_s_mm, b);
    let share = match (scale, input.crowning_um) {
        (None, _) => format!(
            "at the worm diameter {d_s_mm:.3} mm not even the unmodified profile stays within \
             {budget}"
        ),
        (Some(s), Some(c)) => format!(
            "at the worm diameter {d_s_mm:.3} mm the largest crowning this worm and dresser carry \
             within {budget} is crowning_um = {:.3} µm",
            // Toward zero, so the stated value itself stays producible.
            (s * c * 1e3).trunc() / 1e3
        ),
        (Some(s), None) => format!(
            "at the worm diameter {d_s_mm:.3} mm at most {:.1} % of these points (every f scaled \
             alike) is producible within {budget}",
            (1e3 * s).trunc() / 10.0
        ),
    };
    let dia = if d_s_mm >= design.d_s0_mm {
        String::new()
    } else {
        match smallest_producible_diameter(design, dresser, fl, m, &t.points, d_s_mm, b) {
            Some(d) => format!(
                "; the requested modification ({}) is producible for [solve] diameter_mm from \
                 {d:.1} to {} mm",
                t.key, design.d_s0_mm
            ),
            None => format!(
                "; the requested modification ({}) is not producible at any worm diameter, not \
                 even on the new worm ({} mm)",
                t.key, design.d_s0_mm
            ),
        }
    };
    format!("{share}{dia}")
}

/// Validates and solves a `[solve]` request on the worm `design` (new) with `dresser`:
/// every input error names its TOML key and unit; a solution beyond the clearance budget is an
/// error (naming `budget_mm` and what is producible) unless `accept_penetration`; a request
/// with no root, or whose evaluation fails, is an error stating the producible range.
///
/// # Source
/// JP6903407B2, eq. (18) (3-point), eqs. (11), (12) (4-point) [SEED]; penetration check: JP6903407B2, section on the maximum producible profile modification and the choice of dresser and worm [SEED]
pub fn solve_request(design: &Worm, dresser: &Dresser, input: &SolveInput) -> Result<SolveOutcome> {
    check_key("[solve] budget_mm", input.budget_mm, 0.0, 5.0, "mm")?;
    let d_s = current_worm(design, input.diameter_mm)?.d_s_mm;
    let t = targets(input)?;
    let k0 = AxisCorrection::default();
    let solved = solve_scaled(
        design,
        dresser,
        input.flank,
        input.method,
        &t.points,
        1.0,
        d_s,
        k0,
    )
    .or_else(|_| {
        // Continuation: walk the targets up from the unmodified profile.
        let mut k = k0;
        let mut last = None;
        for i in 1..=8 {
            let s = f64::from(i) / 8.0;
            let r = solve_scaled(
                design,
                dresser,
                input.flank,
                input.method,
                &t.points,
                s,
                d_s,
                k,
            )?;
            k = r.4.dk;
            last = Some(r);
        }
        last.ok_or(DressError::NoConvergence {
            what: "continuation",
            detail: String::new(),
        })
    });
    let (setup, active, ws, fs, sol) = match solved {
        Ok(v) => v,
        Err(e) => {
            let why = match &e {
                DressError::NoRoot { .. } => {
                    format!("the axis corrections have no root for these targets ({e})")
                }
                _ => format!("the dressing of this worm cannot be evaluated ({e})"),
            };
            return Err(DressError::NotProducible {
                key: t.key.to_string(),
                detail: format!(
                    "{why}; {}",
                    producible_range(design, dresser, input, &t, d_s)
                ),
            });
        }
    };
    let checks = Checks::of(&setup, input.flank, &sol.dk, input.budget_mm).map_err(|e| {
        DressError::NotProducible {
            key: t.key.to_string(),
            detail: format!(
                "the cut into the opposite flank cannot be evaluated ({e}); {}",
                producible_range(design, dresser, input, &t, d_s)
            ),
        }
    })?;
    if !checks.ok() && !input.accept_penetration {
        return Err(DressError::NotProducible {
            key: t.key.to_string(),
            detail: format!(
                "{} beyond [solve] budget_mm = {} mm ({:.0} µm): the worm cannot carry this \
                 modification at the worm diameter {d_s:.3} mm; {}. Set [solve] accept_penetration = \
                 true to output the solution anyway (flagged)",
                checks.describe(),
                input.budget_mm,
                1e3 * input.budget_mm,
                producible_range(design, dresser, input, &t, d_s)
            ),
        });
    }
    let evaluation = |e: DressError| DressError::NotProducible {
        key: t.key.to_string(),
        detail: format!("the profile stretching of the solution cannot be evaluated ({e})"),
    };
    let reference = StretchReference::new(design, dresser, input.flank).map_err(evaluation)?;
    let stretch =
        profile_stretch(&setup, input.flank, &reference, &sol.dk, active).map_err(evaluation)?;
    Ok(SolveOutcome {
        setup,
        active_mm: active,
        target_w_mm: ws,
        target_f_mm: fs,
        solution: sol,
        checks,
        stretch,
    })
}
