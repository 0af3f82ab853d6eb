//! The report of one gear (and optionally its mating gear): what `gearcomp gear` prints.
//!
//! [`GearReport::compute`] takes a [`GearRequest`] (a [`GearSpec`], thickness allowances,
//! measurement settings, diameters of interest and an optional [`MateRequest`]) and returns
//! the gear's dimensions, the tooth thickness and span / ball measurements for the nominal
//! shift and each allowance, thickness at the requested diameters, the pair with its backlash
//! cases, and the warnings (undercut, ball inside the tip, thin tip, jamming, ε_α < 1,
//! interference). [`GearReport::to_table`] renders it as the text table; the same structure
//! serialises to the JSON of `gearcomp gear --json`.
//!
//! The report is an interface record: angles are in degrees (converted by [`crate::units`]),
//! lengths in mm. All formulas are those of the crate ([`Gear`], [`GearPair`]); this module
//! only chooses what to evaluate. Rules (docs/geometry.md):
//! - allowances give the generating shift x_E (DIN 3967 via [`Gear::generating_shift`]);
//! - the span k and the ball default to the recommended ones at the nominal shift;
//! - gear 1 of a pair is the external gear; an external pair has opposite hands, an internal
//!   pair the same hand; the mate's shift defaults to the rest of Σx for zero backlash at the
//!   given centre distance, else 0;
//! - backlash cases: "nominal" (no allowances), "max" (both lower allowances), "min" (both
//!   upper), the last two only when allowances are given;
//! - tip thickness guideline s_an ≥ 0.2·m_n (DIN 3960).

use std::fmt::Write as _;

use serde::Serialize;

use crate::units::rad_to_deg as deg;
use crate::{
    centre_distance_for_shift_sum, shift_sum_for_centre_distance, BallMeasurement, Gear,
    GearDimensions, GearPair, GearSpec, GeometryError, Mesh, PairGeometry, Span,
};

/// What to compute for one gear.
#[derive(Debug, Clone, PartialEq)]
pub struct GearRequest {
    /// The gear (radians, mm).
    pub spec: GearSpec,
    /// Name of the profile shift as the user wrote it, used in the undercut warning
    /// (e.g. `--shift`).
    pub shift_name: &'static str,
    /// Normal tooth-thickness allowances A_sn (lower, upper) in mm; `None` = nominal only.
    pub allowances_mm: Option<(f64, f64)>,
    /// Teeth spanned for W_k [default: recommended at the nominal shift].
    pub span_k: Option<u32>,
    /// Ball diameter D_M in mm [default: recommended at the nominal shift].
    pub ball_mm: Option<f64>,
    /// Diameters in mm at which to report the thickness (nominal shift).
    pub at_diameters_mm: Vec<f64>,
    /// The mating gear, if any.
    pub mate: Option<MateRequest>,
}

/// The mating gear of a [`GearRequest`]: module, pressure angle, helix angle and rack are
/// the gear's; it is always external.
#[derive(Debug, Clone, PartialEq)]
pub struct MateRequest {
    /// Number of teeth z2.
    pub teeth: u32,
    /// Name of the mate's profile shift as the user wrote it (undercut warning).
    pub shift_name: &'static str,
    /// Profile shift x2 [default: the rest of Σx for zero backlash at the centre distance,
    /// else 0].
    pub profile_shift: Option<f64>,
    /// Normal tooth-thickness allowances (lower, upper) in mm [default: 0].
    pub allowances_mm: Option<(f64, f64)>,
    /// Face width in mm [default: the gear's].
    pub face_width_mm: Option<f64>,
    /// Working centre distance a_w in mm [default: zero backlash at x + x2].
    pub centre_distance_mm: Option<f64>,
}

/// Why a report could not be computed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ReportError {
    /// A geometry error while computing `what` (for the mating gear if `mate`).
    #[error("{what}: {source}")]
    Step {
        /// What was being computed ("the gear", "span W_k, lower thickness", ...).
        what: String,
        /// The error came from the mating gear's own parameters.
        mate: bool,
        /// The library's error (it names the parameter).
        source: GeometryError,
    },
    /// A geometry error of a quantity every valid gear has.
    #[error(transparent)]
    Geometry(#[from] GeometryError),
    /// No span k fits the gear (face width too small for any k, or no k on the flank).
    #[error("no span measurement W_k fits this gear: {0}")]
    NoSpan(GeometryError),
    /// A requested diameter is not on the tooth.
    #[error(
        "thickness at diameter: {diameter_mm} mm is outside the tooth: allowed \
         {lo_mm:.4} … {hi_mm:.4} mm ({})",
        tooth_extent(*mesh)
    )]
    OutsideTooth {
        /// The requested diameter in mm.
        diameter_mm: f64,
        /// Smallest diameter of the tooth in mm.
        lo_mm: f64,
        /// Largest diameter of the tooth in mm.
        hi_mm: f64,
        /// External or internal gear (which circles bound the tooth).
        mesh: Mesh,
    },
}

/// The circles that bound the tooth radially, for [`ReportError::OutsideTooth`].
pub fn tooth_extent(mesh: Mesh) -> &'static str {
    match mesh {
        Mesh::External => "base circle d_b to tip circle d_a",
        Mesh::Internal => "tip circle d_a to root circle d_f",
    }
}

fn step(what: impl Into<String>) -> impl FnOnce(GeometryError) -> ReportError {
    let what = what.into();
    move |source| ReportError::Step {
        what,
        mate: false,
        source,
    }
}

/// The gear's data and dimensions (angles in degrees).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GearSummary {
    /// External or internal.
    pub mesh: Mesh,
    /// "right", "left" or "spur".
    pub hand: &'static str,
    /// Number of teeth z.
    pub teeth: u32,
    /// m_n.
    pub normal_module_mm: f64,
    /// α_n.
    pub normal_pressure_angle_deg: f64,
    /// Signed: + right hand, − left hand.
    pub helix_angle_deg: f64,
    /// x.
    pub profile_shift: f64,
    /// b.
    pub face_width_mm: Option<f64>,
    /// m_t.
    pub transverse_module_mm: f64,
    /// α_t.
    pub transverse_pressure_angle_deg: f64,
    /// β_b.
    pub base_helix_angle_deg: f64,
    /// p_z (helical gears).
    pub lead_mm: Option<f64>,
    /// d.
    pub reference_diameter_mm: f64,
    /// d_b.
    pub base_diameter_mm: f64,
    /// d_a.
    pub tip_diameter_mm: f64,
    /// d_f.
    pub root_diameter_mm: f64,
    /// d_Ff.
    pub root_form_diameter_mm: Option<f64>,
    /// p_n.
    pub normal_pitch_mm: f64,
    /// p_t.
    pub transverse_pitch_mm: f64,
    /// p_bn.
    pub normal_base_pitch_mm: f64,
    /// p_bt.
    pub transverse_base_pitch_mm: f64,
    /// x_min without undercut (external gears).
    pub min_shift_undercut: Option<f64>,
    /// ε_β (with a face width).
    pub overlap_ratio: Option<f64>,
}

impl GearSummary {
    /// The summary of a gear.
    pub fn new(g: &Gear) -> GearSummary {
        let s = g.spec();
        let d: &GearDimensions = g.dims();
        let spur = s.helix_angle_rad == 0.0;
        GearSummary {
            mesh: s.mesh,
            hand: if spur { "spur" } else { s.hand.name() },
            teeth: s.teeth,
            normal_module_mm: s.normal_module_mm,
            normal_pressure_angle_deg: deg(s.normal_pressure_angle_rad),
            helix_angle_deg: s.hand.sign() * deg(s.helix_angle_rad),
            profile_shift: s.profile_shift,
            face_width_mm: s.face_width_mm,
            transverse_module_mm: d.transverse_module_mm,
            transverse_pressure_angle_deg: deg(d.transverse_pressure_angle_rad),
            base_helix_angle_deg: deg(d.base_helix_angle_rad),
            lead_mm: d.lead_mm,
            reference_diameter_mm: d.reference_diameter_mm,
            base_diameter_mm: d.base_diameter_mm,
            tip_diameter_mm: d.tip_diameter_mm,
            root_diameter_mm: d.root_diameter_mm,
            root_form_diameter_mm: d.root_form_diameter_mm,
            normal_pitch_mm: d.normal_pitch_mm,
            transverse_pitch_mm: d.transverse_pitch_mm,
            normal_base_pitch_mm: d.normal_base_pitch_mm,
            transverse_base_pitch_mm: d.transverse_base_pitch_mm,
            min_shift_undercut: d.min_shift_undercut,
            overlap_ratio: d.overlap_ratio,
        }
    }
}

/// The tooth at one generating profile shift (nominal or an allowance).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ToothReport {
    /// "nominal", "lower" or "upper".
    pub case: &'static str,
    /// A_sn.
    pub allowance_mm: f64,
    /// x_E.
    pub generating_shift: f64,
    /// s_n at the reference circle.
    pub normal_thickness_mm: f64,
    /// s_t at the reference circle.
    pub transverse_thickness_mm: f64,
    /// e_t at the reference circle.
    pub transverse_space_width_mm: f64,
    /// s_an.
    pub tip_normal_thickness_mm: f64,
    /// d_f at x_E.
    pub root_diameter_mm: f64,
    /// d_Ff at x_E.
    pub root_form_diameter_mm: Option<f64>,
    /// W_k.
    pub span: Span,
    /// M_dK.
    pub ball: BallMeasurement,
}

/// Thickness at a requested diameter (nominal shift).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AtDiameter {
    /// d_y.
    pub diameter_mm: f64,
    /// s_yt.
    pub transverse_thickness_mm: f64,
    /// s_yn.
    pub normal_thickness_mm: f64,
    /// e_yt.
    pub transverse_space_width_mm: f64,
}

/// Backlash of the pair for one combination of allowances.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BacklashCase {
    /// "max" (both lower allowances), "min" (both upper) or "nominal".
    pub case: &'static str,
    /// A_sn of gear 1.
    pub allowance_1_mm: f64,
    /// A_sn of gear 2.
    pub allowance_2_mm: f64,
    /// x_E1.
    pub generating_shift_1: f64,
    /// x_E2.
    pub generating_shift_2: f64,
    /// j_wt.
    pub circumferential_mm: f64,
    /// j_bn.
    pub normal_mm: f64,
}

/// The pair.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PairReport {
    /// Which gear is gear 1 (the external one): "this" or "mate".
    pub gear_1: &'static str,
    /// The mating gear.
    pub mate: GearSummary,
    /// u.
    pub gear_ratio: f64,
    /// a.
    pub reference_centre_distance_mm: f64,
    /// a_w.
    pub centre_distance_mm: f64,
    /// α_wt.
    pub working_pressure_angle_deg: f64,
    /// Σx for zero backlash at a_w.
    pub shift_sum: f64,
    /// x1 + x2.
    pub nominal_shift_sum: f64,
    /// d_w1.
    pub working_diameter_1_mm: f64,
    /// d_w2.
    pub working_diameter_2_mm: f64,
    /// ε_α.
    pub transverse_contact_ratio: f64,
    /// ε_β.
    pub overlap_ratio: Option<f64>,
    /// ε_γ.
    pub total_contact_ratio: Option<f64>,
    /// p_bt.
    pub transverse_base_pitch_mm: f64,
    /// p_bn.
    pub normal_base_pitch_mm: f64,
    /// d_Nf1.
    pub active_root_diameter_1_mm: Option<f64>,
    /// d_Nf2.
    pub active_root_diameter_2_mm: Option<f64>,
    /// Backlash cases.
    pub backlash: Vec<BacklashCase>,
}

/// Recommended measurement settings at the nominal shift.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recommended {
    /// k.
    pub span_k: u32,
    /// D_M touching at d + 2·x·m_n (or, when that circle is off the usable flank, at the
    /// middle of the usable flank: see `ball_at_target`).
    pub ball_mm: f64,
    /// Diameter where the recommended ball really touches the flanks, in mm.
    pub ball_contact_diameter_mm: f64,
    /// The circle d + 2·σ·x·m_n in mm.
    pub ball_target_diameter_mm: f64,
    /// Whether the ball touches on d + 2·σ·x·m_n (false: that circle lies off the usable
    /// flank, and the ball touches at the middle of the usable flank instead).
    pub ball_at_target: bool,
}

/// The whole report of a gear (and its mate).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GearReport {
    /// The gear.
    pub gear: GearSummary,
    /// Recommended k and ball.
    pub recommended: Recommended,
    /// Nominal, then lower and upper allowance.
    pub tooth: Vec<ToothReport>,
    /// Thickness at the requested diameters.
    pub at_diameter: Vec<AtDiameter>,
    /// The pair, with a mate.
    pub pair: Option<PairReport>,
    /// Warnings, in the order found.
    pub warnings: Vec<String>,
}

impl GearReport {
    /// Computes the report.
    ///
    /// # Errors
    /// [`ReportError::Step`] naming what was computed and carrying the geometry error (which
    /// names the parameter); [`ReportError::NoSpan`], [`ReportError::OutsideTooth`].
    pub fn compute(req: &GearRequest) -> Result<GearReport, ReportError> {
        let gear = Gear::new(req.spec).map_err(step("the gear"))?;
        let x = req.spec.profile_shift;
        let mut warnings = Vec::new();
        if let Some(u) = gear.undercut(req.shift_name, x) {
            warnings.push(u.to_string());
        }
        let cases = shift_cases(&gear, req.allowances_mm)?;
        let (recommended, k, ball) = measurement_settings(&gear, req, &cases)?;
        let mut tooth = Vec::new();
        for &(case, allowance, x_e) in &cases {
            tooth.push(tooth_case(
                &gear,
                req,
                case,
                allowance,
                x_e,
                (k, ball),
                &mut warnings,
            )?);
        }
        let at_diameter = at_diameters(&gear, &req.at_diameters_mm)?;
        let pair = match &req.mate {
            None => None,
            Some(m) => Some(pair_report(&gear, req.allowances_mm, m, &mut warnings)?),
        };
        Ok(GearReport {
            gear: GearSummary::new(&gear),
            recommended,
            tooth,
            at_diameter,
            pair,
            warnings,
        })
    }
}

/// (case, allowance, generating shift): nominal, then lower and upper.
fn shift_cases(
    gear: &Gear,
    allowances_mm: Option<(f64, f64)>,
) -> Result<Vec<(&'static str, f64, f64)>, ReportError> {
    let mut cases = vec![("nominal", 0.0, gear.spec().profile_shift)];
    if let Some((lower, upper)) = allowances_mm {
        for (case, allowance) in [("lower", lower), ("upper", upper)] {
            let x_e = gear
                .generating_shift(allowance)
                .map_err(step(format!("{case} thickness allowance")))?;
            cases.push((case, allowance, x_e));
        }
    }
    Ok(cases)
}

/// The recommended k and ball, and the ones to use (given or recommended).
fn measurement_settings(
    gear: &Gear,
    req: &GearRequest,
    cases: &[(&'static str, f64, f64)],
) -> Result<(Recommended, u32, f64), ReportError> {
    let x = req.spec.profile_shift;
    let shifts: Vec<f64> = cases.iter().map(|c| c.2).collect();
    // A k the user gave is checked first, so its own error is the one reported.
    if let Some(k) = req.span_k {
        for (case, _, x_e) in cases {
            gear.span(k, *x_e)
                .map_err(step(format!("span W_k, {case} thickness")))?;
        }
    }
    let rec_k = gear
        .recommended_span_k_for(x, &shifts)
        .map_err(ReportError::NoSpan)?;
    let rec = gear.recommended_ball(x).map_err(step("recommended ball"))?;
    let rec_ball = rec.ball_mm;
    let recommended = Recommended {
        span_k: rec_k,
        ball_mm: rec_ball,
        ball_contact_diameter_mm: rec.contact_diameter_mm,
        ball_target_diameter_mm: rec.target_diameter_mm,
        ball_at_target: rec.at_target,
    };
    Ok((
        recommended,
        req.span_k.unwrap_or(rec_k),
        req.ball_mm.unwrap_or(rec_ball),
    ))
}

/// The tooth at one generating shift, with its warnings.
fn tooth_case(
    gear: &Gear,
    req: &GearRequest,
    case: &'static str,
    allowance_mm: f64,
    x_e: f64,
    (k, ball): (u32, f64),
    warnings: &mut Vec<String>,
) -> Result<ToothReport, ReportError> {
    let m_n = req.spec.normal_module_mm;
    if case != "nominal" {
        if let Some(u) = gear.undercut("generating shift x_E", x_e) {
            if gear
                .undercut(req.shift_name, req.spec.profile_shift)
                .is_none()
            {
                warnings.push(format!("{case}: {u}"));
            }
        }
    }
    let d = gear.dims().reference_diameter_mm;
    let span = gear
        .span(k, x_e)
        .map_err(step(format!("span W_k, {case} thickness")))?;
    let ball_m = gear
        .ball_dimension(ball, x_e)
        .map_err(step(format!("dimension over balls, {case} thickness")))?;
    if !ball_m.protrudes_beyond_tip {
        warnings.push(format!(
            "{case}: the {ball} mm ball does not stand out beyond the tip circle; M_dK cannot be taken with flat anvils"
        ));
    }
    let s_an = gear.tip_normal_thickness_mm(x_e)?;
    if s_an < 0.2 * m_n {
        warnings.push(format!(
            "{case}: tip thickness s_an = {s_an:.4} mm is below 0.2·m_n = {:.4} mm (DIN 3960 guideline)",
            0.2 * m_n
        ));
    }
    Ok(ToothReport {
        case,
        allowance_mm,
        generating_shift: x_e,
        normal_thickness_mm: gear.normal_thickness_at_reference_mm(x_e),
        transverse_thickness_mm: gear.transverse_thickness_at_mm(d, x_e)?,
        transverse_space_width_mm: gear.space_width_at_mm(d, x_e)?,
        tip_normal_thickness_mm: s_an,
        root_diameter_mm: gear.root_diameter_mm(x_e),
        root_form_diameter_mm: gear.root_form_diameter_mm(x_e),
        span,
        ball: ball_m,
    })
}

/// Thickness at each requested diameter (nominal shift), checked to lie on the tooth.
fn at_diameters(gear: &Gear, diameters_mm: &[f64]) -> Result<Vec<AtDiameter>, ReportError> {
    let x = gear.spec().profile_shift;
    let mesh = gear.spec().mesh;
    // The tooth exists between the base circle (external; inside it there is no involute)
    // or the tip circle (internal) and the tip (external) or root (internal) circle.
    let (lo_mm, hi_mm) = match mesh {
        Mesh::External => (gear.dims().base_diameter_mm, gear.dims().tip_diameter_mm),
        Mesh::Internal => (gear.dims().tip_diameter_mm, gear.dims().root_diameter_mm),
    };
    let mut out = Vec::new();
    for &d_y in diameters_mm {
        if !(d_y.is_finite() && d_y >= lo_mm - 1e-9 && d_y <= hi_mm + 1e-9) {
            return Err(ReportError::OutsideTooth {
                diameter_mm: d_y,
                lo_mm,
                hi_mm,
                mesh,
            });
        }
        let what = "thickness at diameter";
        out.push(AtDiameter {
            diameter_mm: d_y,
            transverse_thickness_mm: gear
                .transverse_thickness_at_mm(d_y, x)
                .map_err(step(what))?,
            normal_thickness_mm: gear.normal_thickness_at_mm(d_y, x).map_err(step(what))?,
            transverse_space_width_mm: gear.space_width_at_mm(d_y, x).map_err(step(what))?,
        });
    }
    Ok(out)
}

/// The mating gear's spec: the gear's module, angles and rack; external; the hand opposite
/// (external pair) or equal (internal pair); shift x2 given, else the rest of Σx for zero
/// backlash at a_w, else 0.
fn mate_spec(spec: &GearSpec, m: &MateRequest) -> Result<GearSpec, ReportError> {
    let internal = spec.mesh == Mesh::Internal;
    let mut mate = *spec;
    mate.teeth = m.teeth;
    mate.mesh = Mesh::External;
    mate.face_width_mm = m.face_width_mm.or(spec.face_width_mm);
    mate.hand = if internal {
        spec.hand
    } else {
        spec.hand.opposite()
    };
    mate.profile_shift = match (m.profile_shift, m.centre_distance_mm) {
        (Some(x2), _) => x2,
        (None, Some(a_w)) => {
            // gear 1 is the external gear: the mate when this gear is internal
            let (s1, s2) = if internal {
                (&mate, spec)
            } else {
                (spec, &mate)
            };
            let sum = shift_sum_for_centre_distance(s1, s2, a_w).map_err(step("the pair"))?;
            sum - spec.profile_shift
        }
        (None, None) => 0.0,
    };
    Ok(mate)
}

/// The pair of `gear` and its mate, with the backlash cases and the pair's warnings.
fn pair_report(
    gear: &Gear,
    allowances_mm: Option<(f64, f64)>,
    m: &MateRequest,
    warnings: &mut Vec<String>,
) -> Result<PairReport, ReportError> {
    let internal = gear.spec().mesh == Mesh::Internal;
    let spec = mate_spec(gear.spec(), m)?;
    let mate = Gear::new(spec).map_err(|source| ReportError::Step {
        what: "the mating gear".into(),
        mate: true,
        source,
    })?;
    if let Some(u) = mate.undercut(m.shift_name, spec.profile_shift) {
        warnings.push(format!("mating gear: {u}"));
    }
    let (g1, g2) = if internal {
        (&mate, gear)
    } else {
        (gear, &mate)
    };
    let a_w = match m.centre_distance_mm {
        Some(a) => a,
        None => {
            let sum = g1.spec().profile_shift + g2.spec().profile_shift;
            centre_distance_for_shift_sum(g1.spec(), g2.spec(), sum).map_err(step("the pair"))?
        }
    };
    let pair = GearPair::new(g1, g2, a_w).map_err(step("the pair"))?;
    // The mate's allowances are checked on the mate first, so their errors are the mate's
    // (the backlash below checks both gears' allowances under one name).
    if let Some((lower, upper)) = m.allowances_mm {
        for (case, allowance) in [("lower", lower), ("upper", upper)] {
            mate.generating_shift(allowance)
                .map_err(|source| ReportError::Step {
                    what: format!("mating gear, {case} thickness allowance"),
                    mate: true,
                    source,
                })?;
        }
    }
    let backlash = backlash_cases(&pair, internal, allowances_mm, m.allowances_mm, warnings)?;
    let p: &PairGeometry = pair.geometry();
    if p.transverse_contact_ratio < 1.0 {
        warnings.push(format!(
            "transverse contact ratio ε_α = {:.4} < 1",
            p.transverse_contact_ratio
        ));
    }
    interference_warnings(g1, g2, p, internal, warnings);
    Ok(PairReport {
        gear_1: if internal { "mate" } else { "this" },
        mate: GearSummary::new(&mate),
        gear_ratio: p.gear_ratio,
        reference_centre_distance_mm: p.reference_centre_distance_mm,
        centre_distance_mm: p.centre_distance_mm,
        working_pressure_angle_deg: deg(p.working_pressure_angle_rad),
        shift_sum: p.shift_sum,
        nominal_shift_sum: p.nominal_shift_sum,
        working_diameter_1_mm: p.working_diameter_1_mm,
        working_diameter_2_mm: p.working_diameter_2_mm,
        transverse_contact_ratio: p.transverse_contact_ratio,
        overlap_ratio: p.overlap_ratio,
        total_contact_ratio: p.total_contact_ratio,
        transverse_base_pitch_mm: p.transverse_base_pitch_mm,
        normal_base_pitch_mm: p.normal_base_pitch_mm,
        active_root_diameter_1_mm: p.active_root_diameter_1_mm,
        active_root_diameter_2_mm: p.active_root_diameter_2_mm,
        backlash,
    })
}

/// Backlash for no allowances, both lower ("max") and both upper ("min") allowances; a
/// missing allowance is 0.
fn backlash_cases(
    pair: &GearPair,
    internal: bool,
    this: Option<(f64, f64)>,
    mate: Option<(f64, f64)>,
    warnings: &mut Vec<String>,
) -> Result<Vec<BacklashCase>, ReportError> {
    let mut combos = vec![("nominal", 0.0, 0.0)];
    if this.is_some() || mate.is_some() {
        let (t, m) = (this.unwrap_or((0.0, 0.0)), mate.unwrap_or((0.0, 0.0)));
        combos.push(("max", t.0, m.0));
        combos.push(("min", t.1, m.1));
    }
    let a_w = pair.geometry().centre_distance_mm;
    let mut out = Vec::new();
    for (case, a_this, a_mate) in combos {
        let (a1, a2) = if internal {
            (a_mate, a_this)
        } else {
            (a_this, a_mate)
        };
        let b = pair
            .backlash(a1, a2)
            .map_err(step(format!("backlash, {case}")))?;
        if b.normal_mm < -1e-9 {
            warnings.push(format!(
                "{case} backlash j_bn = {:.4} mm is negative: the teeth would jam at a_w = {a_w} mm",
                b.normal_mm
            ));
        }
        out.push(BacklashCase {
            case,
            allowance_1_mm: a1,
            allowance_2_mm: a2,
            generating_shift_1: b.generating_shift_1,
            generating_shift_2: b.generating_shift_2,
            circumferential_mm: b.circumferential_mm,
            normal_mm: b.normal_mm,
        });
    }
    Ok(out)
}

/// A warning for each gear whose active root circle lies off its usable involute.
fn interference_warnings(
    g1: &Gear,
    g2: &Gear,
    p: &PairGeometry,
    internal: bool,
    warnings: &mut Vec<String>,
) {
    for (i, g, d_nf) in [
        (1, g1, p.active_root_diameter_1_mm),
        (2, g2, p.active_root_diameter_2_mm),
    ] {
        let (lo, hi) = g.flank_range_mm(g.spec().profile_shift);
        let ok = d_nf.is_some_and(|d| {
            if i == 1 || !internal {
                d >= lo
            } else {
                d <= hi
            }
        });
        if !ok {
            warnings.push(interference_warning(i, d_nf, lo, hi));
        }
    }
}

/// The interference warning of gear `i`: its active root diameter d_Nf (`None` when the
/// mate's tip circle cuts the line of action beyond gear i's tangent point T_i, i.e. the
/// mate's tip would have to reach inside gear i's base circle) against its usable flank.
fn interference_warning(i: u32, d_nf: Option<f64>, lo: f64, hi: f64) -> String {
    let root = match d_nf {
        Some(d) => format!("active root diameter d_Nf{i} = {d:.4} mm"),
        None => format!(
            "no active root diameter d_Nf{i}: the mate's tip circle passes the tangent point \
             T{i} of the line of action, inside the base circle"
        ),
    };
    format!(
        "gear {i}: the mate's tip reaches outside the usable involute ({root}; usable flank \
         {lo:.4} … {hi:.4} mm): interference"
    )
}

/// The text table, one row per quantity: description, symbol, value, unit.
struct Table(String);

impl Table {
    fn row(&mut self, label: &str, symbol: &str, value: &str, unit: &str) {
        let _ = writeln!(self.0, "  {label:<42} {symbol:<6} {value:>12} {unit}");
    }

    /// A value with `places` decimals.
    fn num(&mut self, label: &str, symbol: &str, v: f64, places: usize, unit: &str) {
        self.row(label, symbol, &format!("{v:.places$}"), unit);
    }

    /// An optional value with `places` decimals, "–" when absent.
    fn opt(&mut self, label: &str, symbol: &str, v: Option<f64>, places: usize, unit: &str) {
        let text = v.map_or_else(|| "–".to_string(), |v| format!("{v:.places$}"));
        self.row(label, symbol, &text, unit);
    }

    fn line(&mut self, text: &str) {
        let _ = writeln!(self.0, "{text}");
    }

    fn gear(&mut self, g: &GearSummary) {
        let mesh = format!("{:?}", g.mesh).to_lowercase();
        self.row("mesh", "", &mesh, "");
        self.row("number of teeth", "z", &g.teeth.to_string(), "");
        self.num("normal module", "m_n", g.normal_module_mm, 4, "mm");
        let alpha_n = g.normal_pressure_angle_deg;
        self.num("normal pressure angle", "α_n", alpha_n, 4, "°");
        let hand = format!("° ({})", g.hand);
        self.num("helix angle", "β", g.helix_angle_deg.abs(), 4, &hand);
        self.num("profile shift coefficient", "x", g.profile_shift, 4, "");
        self.opt("face width", "b", g.face_width_mm, 3, "mm");
        self.num("transverse module", "m_t", g.transverse_module_mm, 4, "mm");
        let alpha_t = g.transverse_pressure_angle_deg;
        self.num("transverse pressure angle", "α_t", alpha_t, 4, "°");
        self.num("base helix angle", "β_b", g.base_helix_angle_deg, 4, "°");
        self.opt("lead", "p_z", g.lead_mm, 3, "mm");
        self.num("reference diameter", "d", g.reference_diameter_mm, 4, "mm");
        self.num("base diameter", "d_b", g.base_diameter_mm, 4, "mm");
        self.num("tip diameter", "d_a", g.tip_diameter_mm, 4, "mm");
        self.num("root diameter", "d_f", g.root_diameter_mm, 4, "mm");
        self.opt(
            "root form diameter",
            "d_Ff",
            g.root_form_diameter_mm,
            4,
            "mm",
        );
        self.num("normal base pitch", "p_bn", g.normal_base_pitch_mm, 4, "mm");
        let p_bt = g.transverse_base_pitch_mm;
        self.num("transverse base pitch", "p_bt", p_bt, 4, "mm");
        let x_min = g.min_shift_undercut;
        self.opt("smallest shift without undercut", "x_min", x_min, 4, "");
        self.opt("overlap ratio", "ε_β", g.overlap_ratio, 4, "");
    }

    fn tooth(&mut self, t: &ToothReport) {
        self.line(&format!(" [{}] A_sn = {:+.4} mm", t.case, t.allowance_mm));
        self.num("generating profile shift", "x_E", t.generating_shift, 4, "");
        self.num(
            "normal tooth thickness",
            "s_n",
            t.normal_thickness_mm,
            4,
            "mm",
        );
        let s_t = t.transverse_thickness_mm;
        self.num("transverse tooth thickness", "s_t", s_t, 4, "mm");
        let e_t = t.transverse_space_width_mm;
        self.num("transverse space width", "e_t", e_t, 4, "mm");
        let s_an = t.tip_normal_thickness_mm;
        self.num("normal tip thickness", "s_an", s_an, 4, "mm");
        self.num("root diameter", "d_f", t.root_diameter_mm, 4, "mm");
        self.opt(
            "root form diameter",
            "d_Ff",
            t.root_form_diameter_mm,
            4,
            "mm",
        );
        let (s, b) = (&t.span, &t.ball);
        let span = format!(
            "span over k = {} (contact d_M {:.3})",
            s.k, s.contact_diameter_mm
        );
        self.num(&span, "W_k", s.span_mm, 4, "mm");
        let ball = format!(
            "over balls D_M = {:.4} (contact {:.3})",
            b.ball_mm, b.contact_diameter_mm
        );
        self.num(&ball, "M_dK", b.dimension_mm, 4, "mm");
    }

    fn at_diameter(&mut self, a: &AtDiameter) {
        let label = format!("at d_y = {}", a.diameter_mm);
        self.num(&label, "s_yt", a.transverse_thickness_mm, 4, "mm");
        self.num("", "s_yn", a.normal_thickness_mm, 4, "mm");
        self.num("", "e_yt", a.transverse_space_width_mm, 4, "mm");
    }

    fn pair(&mut self, p: &PairReport) {
        self.num("gear ratio", "u", p.gear_ratio, 4, "");
        let a = p.reference_centre_distance_mm;
        self.num("reference centre distance", "a", a, 4, "mm");
        self.num(
            "working centre distance",
            "a_w",
            p.centre_distance_mm,
            4,
            "mm",
        );
        let alpha_wt = p.working_pressure_angle_deg;
        self.num("working pressure angle", "α_wt", alpha_wt, 4, "°");
        self.num("sum of shifts for zero backlash", "Σx", p.shift_sum, 6, "");
        self.num("sum of nominal shifts", "x1+x2", p.nominal_shift_sum, 6, "");
        let d_w1 = p.working_diameter_1_mm;
        self.num("working diameter gear 1", "d_w1", d_w1, 4, "mm");
        let d_w2 = p.working_diameter_2_mm;
        self.num("working diameter gear 2", "d_w2", d_w2, 4, "mm");
        let eps_a = p.transverse_contact_ratio;
        self.num("transverse contact ratio", "ε_α", eps_a, 4, "");
        self.opt("overlap ratio", "ε_β", p.overlap_ratio, 4, "");
        self.opt("total contact ratio", "ε_γ", p.total_contact_ratio, 4, "");
        let d_nf1 = p.active_root_diameter_1_mm;
        self.opt("active root diameter gear 1", "d_Nf1", d_nf1, 4, "mm");
        let d_nf2 = p.active_root_diameter_2_mm;
        self.opt("active root diameter gear 2", "d_Nf2", d_nf2, 4, "mm");
        for b in &p.backlash {
            let label = format!(
                "backlash {} (A_sn {:+.3}/{:+.3})",
                b.case, b.allowance_1_mm, b.allowance_2_mm
            );
            self.num(&label, "j_bn", b.normal_mm, 4, "mm");
            self.num("", "j_wt", b.circumferential_mm, 4, "mm");
        }
    }
}

impl GearReport {
    /// The report as the text table of `gearcomp gear`: gear, tooth cases, thickness at
    /// diameters, mating gear and pair, then the warnings.
    pub fn to_table(&self) -> String {
        let mut t = Table(String::new());
        t.line("Gear (ISO 21771 / DIN 3960)");
        t.gear(&self.gear);
        t.line("\nTooth thickness and measurement");
        for tooth in &self.tooth {
            t.tooth(tooth);
        }
        let r = &self.recommended;
        let touching = if r.ball_at_target {
            format!(
                "touching at d + 2·x·m_n = {:.4} mm",
                r.ball_contact_diameter_mm
            )
        } else {
            format!(
                "touching at {:.4} mm, the middle of the usable flank: d + 2·x·m_n = {:.4} mm \
                 lies off the usable flank",
                r.ball_contact_diameter_mm, r.ball_target_diameter_mm
            )
        };
        t.line(&format!(
            " recommended: k = {}, ball D_M = {:.4} mm ({touching})",
            r.span_k, r.ball_mm
        ));
        if !self.at_diameter.is_empty() {
            t.line("\nThickness at diameter (nominal shift)");
            for a in &self.at_diameter {
                t.at_diameter(a);
            }
        }
        if let Some(p) = &self.pair {
            let which = if p.gear_1 == "this" { "this" } else { "mating" };
            t.line(&format!("\nMating gear (gear 1 = {which} gear)"));
            t.gear(&p.mate);
            t.line("\nPair");
            t.pair(p);
        }
        for w in &self.warnings {
            t.line(&format!("warning: {w}"));
        }
        t.0
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::units::deg_to_rad;
    use crate::Hand;

    fn request(spec: GearSpec) -> GearRequest {
        GearRequest {
            spec,
            shift_name: "x",
            allowances_mm: None,
            span_k: None,
            ball_mm: None,
            at_diameters_mm: vec![],
            mate: None,
        }
    }

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
    }

    /// inv α = tan α − α, written out here independently of `crate::involute`.
    fn inv(a: f64) -> f64 {
        a.tan() - a
    }

    #[test]
    fn spur_gear_against_closed_forms() {
        // m = 1, α = 20°, z = 20, x = 0: d = 20, d_b = 20·cos 20°, d_a = 22, d_f = 17.5,
        // W_k = m·cos α·[(k − 0.5)π + z·inv α] (DIN 3960), s_n = π·m/2.
        let a = deg_to_rad(20.0);
        let mut req = request(GearSpec::spur(1.0, a, 20));
        req.span_k = Some(2);
        let r = GearReport::compute(&req).unwrap();
        close(r.gear.reference_diameter_mm, 20.0, 1e-12);
        close(r.gear.base_diameter_mm, 20.0 * a.cos(), 1e-12);
        close(r.gear.tip_diameter_mm, 22.0, 1e-12);
        close(r.gear.root_diameter_mm, 17.5, 1e-12);
        close(r.gear.normal_pressure_angle_deg, 20.0, 1e-12);
        assert_eq!(r.gear.hand, "spur");
        let t = &r.tooth[0];
        assert_eq!((t.case, r.tooth.len()), ("nominal", 1));
        close(t.normal_thickness_mm, std::f64::consts::FRAC_PI_2, 1e-12);
        let w2 = a.cos() * (1.5 * std::f64::consts::PI + 20.0 * inv(a));
        close(t.span.span_mm, w2, 1e-9);
        // the doc example of the crate: W_2 = 4.7083, M_dK(1.7) = 22.2941 (hand values)
        close(t.span.span_mm, 4.7083, 5e-5);
        assert!(r.pair.is_none() && r.at_diameter.is_empty());
    }

    #[test]
    fn allowances_give_lower_and_upper_tooth() {
        // s_n = m·(π/2 + 2·x·tan α) (DIN 3960), so x_E = x + A_sn/(2·m·tan α) (DIN 3967).
        let a = deg_to_rad(20.0);
        let mut req = request(GearSpec::spur(2.0, a, 30));
        req.allowances_mm = Some((-0.06, -0.03));
        let r = GearReport::compute(&req).unwrap();
        let cases: Vec<_> = r.tooth.iter().map(|t| t.case).collect();
        assert_eq!(cases, ["nominal", "lower", "upper"]);
        for (t, a_sn) in r.tooth[1..].iter().zip([-0.06, -0.03]) {
            close(t.allowance_mm, a_sn, 0.0);
            close(t.generating_shift, a_sn / (2.0 * 2.0 * a.tan()), 1e-12);
            close(t.normal_thickness_mm, std::f64::consts::PI + a_sn, 1e-12);
        }
    }

    #[test]
    fn at_diameter_on_the_reference_circle_and_outside_the_tooth() {
        let a = deg_to_rad(20.0);
        let mut req = request(GearSpec::spur(1.0, a, 20));
        req.at_diameters_mm = vec![20.0];
        let r = GearReport::compute(&req).unwrap();
        // at d: s_t = e_t = p/2 for x = 0
        close(
            r.at_diameter[0].transverse_thickness_mm,
            0.5 * std::f64::consts::PI,
            1e-12,
        );
        close(
            r.at_diameter[0].transverse_space_width_mm,
            0.5 * std::f64::consts::PI,
            1e-12,
        );
        req.at_diameters_mm = vec![30.0];
        let e = GearReport::compute(&req).unwrap_err();
        assert!(matches!(e, ReportError::OutsideTooth { diameter_mm, .. } if diameter_mm == 30.0));
        let text = e.to_string();
        assert!(text.contains("18.7939 … 22.0000 mm"), "{text}");
    }

    #[test]
    fn pair_backlash_against_din_3967() {
        // Zero-backlash centre distance for x1 + x2 = 0 is a = m·(z1 + z2)/2; with allowances
        // the normal backlash is j_bn = −(A_sn1 + A_sn2)·cos α_n (DIN 3967, spur).
        let a = deg_to_rad(20.0);
        let mut req = request(GearSpec::spur(2.0, a, 20));
        req.allowances_mm = Some((-0.08, -0.04));
        req.mate = Some(MateRequest {
            teeth: 40,
            shift_name: "x2",
            profile_shift: None,
            allowances_mm: Some((-0.10, -0.05)),
            face_width_mm: None,
            centre_distance_mm: None,
        });
        let r = GearReport::compute(&req).unwrap();
        let p = r.pair.as_ref().unwrap();
        assert_eq!(p.gear_1, "this");
        close(p.centre_distance_mm, 60.0, 1e-12);
        close(p.gear_ratio, 2.0, 1e-12);
        close(p.working_pressure_angle_deg, 20.0, 1e-9);
        let cases: Vec<_> = p.backlash.iter().map(|b| b.case).collect();
        assert_eq!(cases, ["nominal", "max", "min"]);
        for (b, sum) in p.backlash.iter().zip([0.0, -0.18, -0.09]) {
            close(b.normal_mm, -sum * a.cos(), 1e-9);
        }
        // ε_α of z = 20/40, m = 2, spur, x = 0 (closed form with r_a, r_b, a_w)
        let (rb1, rb2) = (20.0 * a.cos(), 40.0 * a.cos());
        let g_a = (22.0f64.powi(2) - rb1 * rb1).sqrt() + (42.0f64.powi(2) - rb2 * rb2).sqrt()
            - 60.0 * a.sin();
        close(
            p.transverse_contact_ratio,
            g_a / (std::f64::consts::PI * 2.0 * a.cos()),
            1e-9,
        );
        assert_eq!(p.mate.hand, "spur");
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
    }

    #[test]
    fn helical_mate_has_the_opposite_hand_and_shift_from_centre_distance() {
        let mut spec = GearSpec::spur(3.5, deg_to_rad(20.0), 31);
        spec.helix_angle_rad = deg_to_rad(21.0);
        spec.hand = Hand::Right;
        let mut req = request(spec);
        let a_w = 116.5;
        req.mate = Some(MateRequest {
            teeth: 30,
            shift_name: "x2",
            profile_shift: None,
            allowances_mm: None,
            face_width_mm: None,
            centre_distance_mm: Some(a_w),
        });
        let r = GearReport::compute(&req).unwrap();
        let p = r.pair.unwrap();
        assert_eq!((r.gear.hand, p.mate.hand), ("right", "left"));
        close(p.mate.helix_angle_deg, -21.0, 1e-12);
        close(p.centre_distance_mm, a_w, 0.0);
        // zero backlash at a_w: Σx from inv α_wt = inv α_t + 2·Σx·tan α_n/(z1 + z2)
        let (an, b) = (deg_to_rad(20.0), deg_to_rad(21.0));
        let at = (an.tan() / b.cos()).atan();
        let a0 = 3.5 * 61.0 / (2.0 * b.cos());
        let awt = (a0 * at.cos() / a_w).acos();
        let sum = (inv(awt) - inv(at)) * 61.0 / (2.0 * an.tan());
        close(p.shift_sum, sum, 1e-9);
        close(p.mate.profile_shift, sum, 1e-9);
        close(p.backlash[0].normal_mm, 0.0, 1e-9);
    }

    #[test]
    fn table_prints_the_rows_with_units() {
        let mut req = request(GearSpec::spur(1.0, deg_to_rad(20.0), 20));
        req.span_k = Some(2);
        req.ball_mm = Some(1.7);
        let t = GearReport::compute(&req).unwrap().to_table();
        let base = format!(
            "  {:<42} {:<6} {:>12} mm",
            "base diameter", "d_b", "18.7939"
        );
        assert!(t.contains(&base), "{t}");
        assert!(t.contains(" [nominal] A_sn = +0.0000 mm"), "{t}");
        assert!(
            t.lines().any(|l| l.contains("W_k") && l.contains("4.7083")),
            "{t}"
        );
        assert!(
            t.lines()
                .any(|l| l.contains("M_dK") && l.contains("22.2941")),
            "{t}"
        );
        assert!(t.contains("  face width"), "{t}");
        assert!(t
            .lines()
            .any(|l| l.starts_with("  face width") && l.contains("–")));
        assert!(!t.contains("Pair") && !t.contains("warning"));
    }

    #[test]
    fn mating_gear_errors_are_marked_as_the_mate() {
        let mut req = request(GearSpec::spur(1.0, deg_to_rad(20.0), 20));
        req.mate = Some(MateRequest {
            teeth: 1,
            shift_name: "x2",
            profile_shift: None,
            allowances_mm: None,
            face_width_mm: None,
            centre_distance_mm: None,
        });
        match GearReport::compute(&req).unwrap_err() {
            ReportError::Step { what, mate, .. } => {
                assert_eq!((what.as_str(), mate), ("the mating gear", true));
            }
            e => panic!("{e}"),
        }
    }
}
