//! The set-up of a grinding run: the worm body for a gear, the worm–gear pair at its
//! setting (profile-shifted gear, redressed worm), the worm's default root and tip radii, and
//! the usable roll range of the gear flank with what bounds each end.
//!
//! Lengths mm, angles rad. What `gearcomp grind` builds from its options before it simulates;
//! the options' ranges are checked by the caller, the geometry here.

use std::fmt;

use crate::conical::ConicalPair;
use crate::contact::WormGearPair;
use crate::flank::{Flank, Hand, InvoluteFlank, InvoluteGear};
use crate::GrindError;

/// What the user called the gear-body quantities (CLI options or TOML keys): the range errors
/// of [`check_gear_input`] name them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GearInputNames {
    /// Number of teeth (`--teeth`, `[gear] teeth`).
    pub teeth: &'static str,
    /// Normal module in mm.
    pub module: &'static str,
    /// Normal pressure angle of the right flank (of both if no left one is given), degrees.
    pub pressure_angle: &'static str,
    /// Normal pressure angle of the left flank, degrees.
    pub pressure_angle_left: &'static str,
    /// Helix angle, degrees.
    pub helix_angle: &'static str,
}

/// Allowed number of teeth of the gear body (the geometry crate's gear; the one statement of it).
pub const TEETH_RANGE: &str = "3 ..= 10000";
/// Allowed normal module of the gear body.
pub const MODULE_RANGE: &str = "0.01 ..= 1000 mm";
/// Allowed normal pressure angle of the gear body: the geometry crate's 0 < α_n < 45°,
/// narrowed by the DIN 867 rack it is cut with (dedendum 1.25·m_n ≤ π·m_n/(4·tan α_n), the
/// rack tip keeps a width: α_n ≤ atan(π/5) = 32.1419°).
pub const PRESSURE_ANGLE_RANGE: &str =
    "above 0 and at most 32.1419 ° (atan(π/5): above it the DIN 867 rack's dedendum 1.25·m_n \
     leaves the tool tip no width)";
/// Allowed helix angle of the gear body (signed; both ends excluded).
pub const HELIX_ANGLE_RANGE: &str = "above -60 and below 60 °";

/// Checks the gear-body inputs as the user wrote them (angles in degrees) against the ranges
/// the body must meet — those of the geometry crate, which [`checked_gear`] builds on, narrower
/// than [`InvoluteGear::asymmetric`]'s (which also takes worms) — so that each quantity has one
/// range, stated once ([`TEETH_RANGE`], …), in the user's unit and under the user's name.
///
/// # Errors
/// [`GrindError::OutOfRange`] whose field is the name in `names` and whose value is as written.
pub fn check_gear_input(
    names: &GearInputNames,
    teeth: u32,
    m_n_mm: f64,
    alpha_n_deg: f64,
    alpha_n_left_deg: Option<f64>,
    beta_deg: f64,
) -> Result<(), GrindError> {
    use gearcomp_geometry::gear::{
        max_pressure_angle_deg, MAX_HELIX_ANGLE_DEG, MAX_MODULE_MM, MAX_TEETH, MIN_MODULE_MM,
        MIN_TEETH,
    };
    use gearcomp_geometry::BasicRack;
    let out = |field, value, expected| GrindError::OutOfRange {
        field,
        value,
        expected,
    };
    if !(MIN_TEETH..=MAX_TEETH).contains(&teeth) {
        return Err(out(names.teeth, f64::from(teeth), TEETH_RANGE));
    }
    if !(m_n_mm.is_finite() && (MIN_MODULE_MM..=MAX_MODULE_MM).contains(&m_n_mm)) {
        return Err(out(names.module, m_n_mm, MODULE_RANGE));
    }
    let angles = [
        (names.pressure_angle, Some(alpha_n_deg)),
        (names.pressure_angle_left, alpha_n_left_deg),
    ];
    // The geometry crate's limit for the rack the body is cut with (below 45°, and below the
    // pointed tool tooth of DIN 867).
    let alpha_max = max_pressure_angle_deg(&BasicRack::DIN_867);
    for (name, alpha) in angles {
        if let Some(a) = alpha {
            if !(a.is_finite() && a > 0.0 && a < alpha_max) {
                return Err(out(name, a, PRESSURE_ANGLE_RANGE));
            }
        }
    }
    if !(beta_deg.is_finite() && beta_deg.abs() < MAX_HELIX_ANGLE_DEG) {
        return Err(out(names.helix_angle, beta_deg, HELIX_ANGLE_RANGE));
    }
    Ok(())
}

/// [`check_gear_input`], then [`checked_gear`] on the angles in rad.
///
/// # Errors
/// Those of [`check_gear_input`] and [`checked_gear`].
pub fn gear_from_input(
    names: &GearInputNames,
    teeth: u32,
    m_n_mm: f64,
    alpha_n_deg: f64,
    alpha_n_left_deg: Option<f64>,
    beta_deg: f64,
    x_shift: f64,
) -> Result<InvoluteGear, GrindError> {
    check_gear_input(
        names,
        teeth,
        m_n_mm,
        alpha_n_deg,
        alpha_n_left_deg,
        beta_deg,
    )?;
    let rad = gearcomp_geometry::units::deg_to_rad;
    checked_gear(
        teeth,
        m_n_mm,
        rad(alpha_n_deg),
        rad(alpha_n_left_deg.unwrap_or(alpha_n_deg)),
        rad(beta_deg),
        x_shift,
    )
}

/// A gear body that is a gear as the geometry crate defines one (3 ≤ z, no pointed tooth,
/// root above 0, …) on both flanks.
///
/// # Errors
/// The [`InvoluteGear::asymmetric`] range errors, or the geometry error of
/// [`InvoluteGear::flank_limits`] of the first flank that has none.
pub fn checked_gear(
    teeth: u32,
    m_n_mm: f64,
    alpha_n_right_rad: f64,
    alpha_n_left_rad: f64,
    beta_rad: f64,
    x_shift: f64,
) -> Result<InvoluteGear, GrindError> {
    let gear = InvoluteGear::asymmetric(
        teeth,
        m_n_mm,
        alpha_n_right_rad,
        alpha_n_left_rad,
        beta_rad,
        x_shift,
    )?;
    for f in [Flank::Right, Flank::Left] {
        gear.flank_limits(f)?;
    }
    Ok(gear)
}

/// Largest worm helix angle |β1| accepted, degrees (lead angle at least 0.03°): the limit of
/// [`InvoluteGear::asymmetric`].
pub const MAX_WORM_HELIX_DEG: f64 = 89.97;

/// The normal modules m_n a worm of `starts` starts at reference radius `radius_mm` accepts:
/// `(min, max)`, min included, max excluded, in mm.
///
/// # Formula
/// cos β1 = z1·m_n/(2·r1) must lie in [cos 89.97°, 0.9) ([`InvoluteGear::worm`] and the helix
/// limit of [`InvoluteGear::asymmetric`]): 2·r1·cos 89.97°/z1 ≤ m_n < 1.8·r1/z1.
pub fn worm_module_range_mm(starts: u32, radius_mm: f64) -> (f64, f64) {
    let z = f64::from(starts.max(1));
    let cos_max = MAX_WORM_HELIX_DEG.to_radians().cos();
    (2.0 * radius_mm * cos_max / z, 1.8 * radius_mm / z)
}

/// The grinding worm for a gear: z1 starts at reference radius r1 with the gear's module, and
/// per flank the gear's normal pressure angle.
///
/// # Formula
/// cos β1 = z1·m_n/(2·r1) ([`InvoluteGear::worm`]); α_n of each worm flank = α_n of the gear
/// flank it grinds: equal normal base pitch p_bn = π·m_n·cos α_n with equal m_n (eq. (93)).
/// # Source
/// JP6903407B2 eq. (93) [SEED]; ISO 21771:2007 reference diameter [STANDARD].
pub fn grinding_worm(
    starts: u32,
    m_n_mm: f64,
    alpha_n_right_rad: f64,
    alpha_n_left_rad: f64,
    reference_radius_mm: f64,
    hand: Hand,
) -> Result<InvoluteGear, GrindError> {
    let w = InvoluteGear::worm(starts, m_n_mm, alpha_n_right_rad, reference_radius_mm, hand)?;
    InvoluteGear::asymmetric(
        w.teeth,
        w.m_n_mm,
        alpha_n_right_rad,
        alpha_n_left_rad,
        w.beta_rad,
        0.0,
    )
}

/// The cylindrical worm–gear pair at the reference setting of a profile-shifted gear.
///
/// # Formula
/// d = r1 + r2 + x·m_n (the shifted gear's rack datum lies x·m_n outside its reference
/// circle), γ = −(β1 + β2); for x = 0 this is [`WormGearPair::reference`].
/// # Source
/// JP6903407B2 (R3) [SEED]; profile shift, ISO 21771:2007 5.2 [STANDARD].
pub fn shifted_pair(
    worm: &InvoluteGear,
    gear: &InvoluteGear,
    flank: Flank,
) -> Result<WormGearPair, GrindError> {
    if gear.x_shift == 0.0 {
        return WormGearPair::reference(worm, gear, flank);
    }
    WormGearPair::new(
        worm,
        gear,
        flank,
        worm.reference_radius_mm() + gear.reference_radius_mm() + gear.x_shift * gear.m_n_mm,
        -(worm.beta_rad + gear.beta_rad),
    )
}

/// The pair of a (re)dressed worm at its present radius `r_mm` with the gear.
///
/// `design` is the worm built at its design radius `r0_mm` = d_S0/2 (its reference radius,
/// given as it was built, so no rounding enters the ratio): the helicoid (r_b, β_b) stays that
/// of the design over the worm's life, so the redressed worm's helix angle at r follows the
/// same helicoid.
/// # Formula
/// tan β1(r) = tan β1(r0)·r/r0; d = r + r2 + x·m_n; γ = −(β1(r) + β2).
/// # Source
/// Helicoid of constant lead, ISO 21771:2007 (tan β ∝ r) [STANDARD]; (R3) of JP6903407B2
/// [SEED]; docs/grinding.md "Dressed worm".
pub fn redressed_pair(
    design: &InvoluteGear,
    r0_mm: f64,
    r_mm: f64,
    gear: &InvoluteGear,
    flank: Flank,
) -> Result<WormGearPair, GrindError> {
    let beta1 = (design.beta_rad.tan() * r_mm / r0_mm).atan();
    WormGearPair::new(
        design,
        gear,
        flank,
        r_mm + gear.reference_radius_mm() + gear.x_shift * gear.m_n_mm,
        -(beta1 + gear.beta_rad),
    )
}

/// Default worm root and tip radii in mm around the reference radius r1: r1 ∓ 1.25·m_n
/// (dedendum of the ISO 53 basic rack on both sides).
pub fn default_worm_radii_mm(r1_mm: f64, m_n_mm: f64) -> (f64, f64) {
    (r1_mm - 1.25 * m_n_mm, r1_mm + 1.25 * m_n_mm)
}

/// The root or the tip of the worm thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WormEnd {
    /// The worm's root radius.
    Root,
    /// The worm's tip radius.
    Tip,
}

impl fmt::Display for WormEnd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WormEnd::Root => "worm root",
            WormEnd::Tip => "worm tip",
        })
    }
}

/// What bounds one end of the usable roll range of the gear flank.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RollBound {
    /// The gear's root form circle d_Ff (mm).
    RootForm(f64),
    /// The gear's base circle (the gear is undercut: no root form circle above it).
    BaseCircle,
    /// The gear's tip circle d_a (mm).
    Tip(f64),
    /// The gear roll distance the worm reaches with its root or tip (radius in mm).
    WormReach(WormEnd, f64),
    /// The root form circle of a beveloid body at z = 0.
    RootFormAtZ0,
    /// The tip circle d_a of a beveloid body at z = 0 (mm).
    TipAtZ0(f64),
}

impl fmt::Display for RollBound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RollBound::RootForm(d) => write!(f, "the root form circle d_Ff = {d:.4} mm"),
            RollBound::BaseCircle => f.write_str("the base circle (undercut)"),
            RollBound::Tip(d) => write!(f, "the tip circle d_a = {d:.4} mm"),
            RollBound::WormReach(end, r) => write!(f, "the reach of the {end} (r = {r:.4} mm)"),
            RollBound::RootFormAtZ0 => f.write_str("the root form circle at z = 0"),
            RollBound::TipAtZ0(d) => write!(f, "the tip circle d_a = {d:.4} mm at z = 0"),
        }
    }
}

/// Why there is no usable roll range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RollRangeError {
    /// The gear itself is invalid.
    #[error(transparent)]
    Gear(#[from] GrindError),
    /// The worm reaches below the gear's base circle: it would undercut the involute, which
    /// the envelope simulation does not model.
    #[error(
        "the {end} (r = {radius_mm:.4} mm) reaches below the gear's base circle: it undercuts \
         the involute, which the envelope simulation does not model"
    )]
    BelowBaseCircle {
        /// The worm end that reaches lowest on the gear.
        end: WormEnd,
        /// Its radius in mm.
        radius_mm: f64,
    },
    /// The worm's reach and the gear flank do not overlap.
    #[error("the worm does not reach the gear flank between {lo} and {hi}")]
    NoOverlap {
        /// Lower bound of the range.
        lo: RollBound,
        /// Upper bound of the range.
        hi: RollBound,
    },
}

/// The usable roll range [lo, hi] of the gear flank in mm and what bounds each end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollLimits {
    /// Lowest usable roll distance (≥ 1e-6 mm).
    pub lo_mm: f64,
    /// Highest usable roll distance.
    pub hi_mm: f64,
    /// What bounds the lower end.
    pub lo: RollBound,
    /// What bounds the upper end.
    pub hi: RollBound,
    /// Cap of the default roll end (below `hi_mm` on a conical gear: the narrow end's tip).
    pub default_hi_mm: f64,
}

impl RollLimits {
    /// Usable roll range of the gear flank on a cylindrical chain: the gear's root form and
    /// tip circles, and the gear roll distances the worm thread reaches between its root and
    /// tip.
    ///
    /// # Formula
    /// w1(r) = √(r² − r_b1²); (R7) w1 = a·w2 + b, exact on the cylindrical chain, so the worm
    /// end at radius r reaches w2 = (w1(r) − b)/a; lo = max(w(d_Ff), reach of the lower worm
    /// end), hi = min(w(d_a), reach of the upper worm end).
    /// # Source
    /// JP6903407B2 (R7) [SEED]; d_Ff, d_a: ISO 21771:2007 5.2, 5.4.5 [STANDARD].
    /// # Errors
    /// [`RollRangeError::BelowBaseCircle`], [`RollRangeError::NoOverlap`], or the gear's
    /// error from [`InvoluteGear::flank_limits`].
    pub fn cylindrical(
        gear: &InvoluteGear,
        flank: Flank,
        pair: &WormGearPair,
        worm_radii_mm: (f64, f64),
    ) -> Result<RollLimits, RollRangeError> {
        let lim = gear.flank_limits(flank)?;
        let rb1 = pair.worm.r_b_mm;
        let reach = |r: f64| ((r * r - rb1 * rb1).max(0.0).sqrt() - pair.path.b_mm) / pair.path.a;
        let root = (reach(worm_radii_mm.0), WormEnd::Root, worm_radii_mm.0);
        let tip = (reach(worm_radii_mm.1), WormEnd::Tip, worm_radii_mm.1);
        let (low, high) = if tip.0 < root.0 {
            (tip, root)
        } else {
            (root, tip)
        };
        if low.0.is_nan() || low.0 <= 0.0 {
            return Err(RollRangeError::BelowBaseCircle {
                end: low.1,
                radius_mm: low.2,
            });
        }
        let (lo, lo_bound) = if lim.w_root_form_mm >= low.0 {
            let bound = lim
                .root_form_diameter_mm
                .map_or(RollBound::BaseCircle, RollBound::RootForm);
            (lim.w_root_form_mm, bound)
        } else {
            (low.0, RollBound::WormReach(low.1, low.2))
        };
        let (hi, hi_bound) = if lim.w_tip_mm <= high.0 {
            (lim.w_tip_mm, RollBound::Tip(lim.tip_diameter_mm))
        } else {
            (high.0, RollBound::WormReach(high.1, high.2))
        };
        if !(hi > lo && lo.is_finite()) {
            return Err(RollRangeError::NoOverlap {
                lo: lo_bound,
                hi: hi_bound,
            });
        }
        Ok(RollLimits {
            lo_mm: lo.max(1e-6),
            hi_mm: hi,
            lo: lo_bound,
            hi: hi_bound,
            default_hi_mm: hi,
        })
    }

    /// Usable roll range of a beveloid gear on a conical chain: the root form and tip circles
    /// of the body at z = 0 bound the range; the default end stays on the flank over the
    /// whole face width b (the tip at the narrow end).
    ///
    /// # Formula
    /// r_a,min = r + m_n·(1 + x) − (b/2)·|tan ϑ2| (tip cone parallel to the reference cone:
    /// addendum m_n over the local profile shift x(z) = z·tan ϑ2/m_n);
    /// default end √(r_a,min² − r_bF²) with r_bF of the pair's gear flank; the root form and
    /// tip circles at z = 0 as roll distances on that flank, √(r² − r_bF²) (not on the
    /// cylinder's base circle: mixing the two refused valid gears with "w_end > w_start").
    /// # Source
    /// Beveloid local profile shift, docs/grinding.md "Conical tool and workpiece"
    /// [RECONSTRUCTED]; addendum h_a = m_n, ISO 53 basic rack [STANDARD].
    /// # Errors
    /// The body's error from [`InvoluteGear::flank_limits`].
    pub fn conical(
        body: &InvoluteGear,
        flank: Flank,
        pair: &ConicalPair,
        face_width_mm: f64,
        gear_cone_rad: f64,
    ) -> Result<RollLimits, GrindError> {
        let r_tip = narrow_tip_radius_mm(body, face_width_mm, gear_cone_rad);
        let rb = pair.gear.r_b_mm;
        let lim = body.flank_limits(flank)?;
        // The body's roll distances are on the cylinder's base circle; the grid is on the
        // beveloid flank, whose base radius r_bF differs (about 2 % at ϑ2 = 4°, β = 26°):
        // carry the root form and tip circles over as radii.
        let rb_body = body.flank(flank).r_b_mm;
        let roll = |w_body: f64| {
            let r_sq = w_body * w_body + rb_body * rb_body;
            (r_sq - rb * rb).max(0.0).sqrt()
        };
        Ok(RollLimits {
            lo_mm: roll(lim.w_root_form_mm).max(1e-6),
            hi_mm: roll(lim.w_tip_mm),
            lo: RollBound::RootFormAtZ0,
            hi: RollBound::TipAtZ0(lim.tip_diameter_mm),
            default_hi_mm: (r_tip * r_tip - rb * rb).max(0.0).sqrt(),
        })
    }

    /// The largest face width b (mm) at which the default roll end of [`RollLimits::conical`]
    /// (the tip circle at the narrow end, z = ±b/2) still lies beyond the roll distance `w_mm`
    /// on the pair's gear flank: b < 2·(r + m_n·(1 + x) − √(w² + r_bF²))/|tan ϑ2|. `None` on
    /// a cylinder (ϑ2 = 0: the face width does not move the tip) or when not even b = 0 does.
    pub fn conical_max_face_width_mm(
        body: &InvoluteGear,
        pair: &ConicalPair,
        gear_cone_rad: f64,
        w_mm: f64,
    ) -> Option<f64> {
        let t = gear_cone_rad.tan().abs();
        let rb = pair.gear.r_b_mm;
        let room = narrow_tip_radius_mm(body, 0.0, gear_cone_rad) - w_mm.hypot(rb);
        (t > 0.0 && room > 0.0).then(|| 2.0 * room / t)
    }

    /// The default roll range of the flank `f2` (mm): two modules either side of the
    /// reference circle, not below 10 % of its roll distance, inside the usable range (the
    /// end capped by `default_hi_mm`).
    pub fn default_range_mm(&self, f2: &InvoluteFlank, m_n_mm: f64) -> (f64, f64) {
        let start = (f2.w_ref_mm - 2.0 * m_n_mm)
            .max(0.1 * f2.w_ref_mm)
            .max(self.lo_mm);
        let end = (f2.w_ref_mm + 2.0 * m_n_mm).min(self.default_hi_mm);
        (start, end)
    }
}

/// Tip radius at the narrow end (z = ±b/2) of a beveloid gear of face width b: the tip cone
/// parallel to the reference cone, r_a,min = r + m_n·(1 + x) − (b/2)·|tan ϑ2|.
fn narrow_tip_radius_mm(body: &InvoluteGear, face_width_mm: f64, gear_cone_rad: f64) -> f64 {
    body.reference_radius_mm() + body.m_n_mm * (1.0 + body.x_shift)
        - 0.5 * face_width_mm * gear_cone_rad.tan().abs()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    /// The stated ranges are the geometry crate's constants (one range per quantity).
    #[test]
    fn stated_gear_ranges_are_the_geometry_limits() {
        use gearcomp_geometry::gear::*;
        use gearcomp_geometry::BasicRack;
        assert_eq!(TEETH_RANGE, format!("{MIN_TEETH} ..= {MAX_TEETH}"));
        assert_eq!(
            MODULE_RANGE,
            format!("{MIN_MODULE_MM} ..= {MAX_MODULE_MM} mm")
        );
        let rack_max = (std::f64::consts::FRAC_PI_2 / (2.0 * BasicRack::DIN_867.dedendum_coeff))
            .atan()
            .to_degrees();
        assert!(rack_max < MAX_PRESSURE_ANGLE_DEG && (rack_max - 32.1419).abs() < 1e-4);
        assert!(PRESSURE_ANGLE_RANGE.starts_with("above 0 and at most 32.1419 °"));
        assert!((32.1419..32.14191).contains(&rack_max));
        assert_eq!(
            HELIX_ANGLE_RANGE,
            format!("above -{MAX_HELIX_ANGLE_DEG} and below {MAX_HELIX_ANGLE_DEG} °")
        );
    }

    fn rad(d: f64) -> f64 {
        d.to_radians()
    }

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
    }

    #[test]
    fn grinding_worm_takes_the_gear_flank_angles() {
        // cos β1 = z1·m_n/(2·r1) = 1·3/(2·50) = 0.03
        let w = grinding_worm(1, 3.0, rad(20.0), rad(22.0), 50.0, Hand::Left).unwrap();
        close(w.beta_rad, -(0.03f64).acos(), 1e-15);
        close(w.alpha_n_right_rad, rad(20.0), 0.0);
        close(w.alpha_n_left_rad, rad(22.0), 0.0);
        close(w.reference_radius_mm(), 50.0, 1e-12);
        assert_eq!((w.teeth, w.x_shift), (1, 0.0));
    }

    #[test]
    fn shifted_pair_moves_the_centre_distance_by_x_mn() {
        let worm = grinding_worm(1, 3.0, rad(20.0), rad(20.0), 50.0, Hand::Right).unwrap();
        let g0 = checked_gear(31, 3.0, rad(20.0), rad(20.0), rad(15.0), 0.0).unwrap();
        let g1 = checked_gear(31, 3.0, rad(20.0), rad(20.0), rad(15.0), 0.3).unwrap();
        let p0 = shifted_pair(&worm, &g0, Flank::Right).unwrap();
        let p1 = shifted_pair(&worm, &g1, Flank::Right).unwrap();
        // r2 = z·m_n/(2 cos β)
        let r2 = 31.0 * 3.0 / (2.0 * rad(15.0).cos());
        close(p0.centre_distance_mm, 50.0 + r2, 1e-9);
        close(
            p1.centre_distance_mm - p0.centre_distance_mm,
            0.3 * 3.0,
            1e-9,
        );
        close(p1.crossing_rad, -(worm.beta_rad + rad(15.0)), 1e-15);
    }

    #[test]
    fn redressed_pair_follows_the_helicoid() {
        let design = grinding_worm(1, 3.0, rad(20.0), rad(20.0), 50.0, Hand::Right).unwrap();
        let gear = checked_gear(31, 3.0, rad(20.0), rad(20.0), rad(15.0), 0.0).unwrap();
        // at the design radius it is the reference pair
        let same = redressed_pair(&design, 50.0, 50.0, &gear, Flank::Right).unwrap();
        let reference = WormGearPair::reference(&design, &gear, Flank::Right).unwrap();
        close(same.centre_distance_mm, reference.centre_distance_mm, 1e-9);
        close(same.crossing_rad, reference.crossing_rad, 1e-12);
        // redressed to r = 45: lead p_z = 2π·r/tan β constant → tan β(45) = tan β(50)·45/50
        let p = redressed_pair(&design, 50.0, 45.0, &gear, Flank::Right).unwrap();
        let beta45 = (design.beta_rad.tan() * 0.9).atan();
        close(p.crossing_rad, -(beta45 + gear.beta_rad), 1e-12);
        close(
            reference.centre_distance_mm - p.centre_distance_mm,
            5.0,
            1e-9,
        );
    }

    #[test]
    fn default_radii_are_a_dedendum_either_side() {
        assert_eq!(default_worm_radii_mm(50.0, 2.0), (47.5, 52.5));
    }

    #[test]
    fn cylindrical_limits_from_the_gear_circles_with_a_deep_worm() {
        let worm = grinding_worm(1, 3.0, rad(20.0), rad(20.0), 50.0, Hand::Right).unwrap();
        let gear = checked_gear(31, 3.0, rad(20.0), rad(20.0), rad(15.0), 0.0).unwrap();
        let pair = shifted_pair(&worm, &gear, Flank::Right).unwrap();
        // a worm far deeper than the gear's tooth: the gear circles bound both ends
        let lim = RollLimits::cylindrical(&gear, Flank::Right, &pair, (44.0, 54.5)).unwrap();
        let f2 = gear.flank(Flank::Right);
        let w = |d: f64| (0.25 * d * d - f2.r_b_mm * f2.r_b_mm).sqrt();
        // d_a = d + 2·m_n (x = 0)
        let d = 2.0 * gear.reference_radius_mm();
        close(lim.hi_mm, w(d + 6.0), 1e-9);
        let RollBound::Tip(d_a) = lim.hi else {
            panic!("{:?}", lim.hi)
        };
        close(d_a, d + 6.0, 1e-9);
        let RollBound::RootForm(d_ff) = lim.lo else {
            panic!("{:?}", lim.lo)
        };
        close(lim.lo_mm, w(d_ff), 1e-9);
        assert!(d_ff > 2.0 * f2.r_b_mm && d_ff < d);
        assert_eq!(lim.default_hi_mm, lim.hi_mm);
        // default range: w_P ∓ 2·m_n inside [lo, hi]
        let (s, e) = lim.default_range_mm(&f2, 3.0);
        close(s, (f2.w_ref_mm - 6.0).max(lim.lo_mm), 1e-12);
        close(e, (f2.w_ref_mm + 6.0).min(lim.hi_mm), 1e-12);
    }

    #[test]
    fn cylindrical_limits_from_a_shallow_worm_and_errors() {
        let worm = grinding_worm(1, 3.0, rad(20.0), rad(20.0), 50.0, Hand::Right).unwrap();
        let gear = checked_gear(31, 3.0, rad(20.0), rad(20.0), rad(15.0), 0.0).unwrap();
        let pair = shifted_pair(&worm, &gear, Flank::Right).unwrap();
        // a worm with a shallow thread reaches less than the gear circles; its reach follows
        // (R7): w2 = (√(r² − r_b1²) − b)/a, written out here
        let (root, tip) = (48.5, 51.0);
        let lim = RollLimits::cylindrical(&gear, Flank::Right, &pair, (root, tip)).unwrap();
        let rb1 = pair.worm.r_b_mm;
        let reach = |r: f64| ((r * r - rb1 * rb1).sqrt() - pair.path.b_mm) / pair.path.a;
        let (a, b) = (reach(root), reach(tip));
        close(lim.lo_mm, a.min(b), 1e-9);
        close(lim.hi_mm, a.max(b), 1e-9);
        assert!(matches!(lim.lo, RollBound::WormReach(_, _)));
        assert!(matches!(lim.hi, RollBound::WormReach(_, _)));
        // a worm root at the worm's axis reaches below the gear's base circle (w2 < 0)
        let e = RollLimits::cylindrical(&gear, Flank::Right, &pair, (0.0, 80.0)).unwrap_err();
        assert!(matches!(e, RollRangeError::BelowBaseCircle { .. }), "{e}");
    }

    #[test]
    fn bounds_read_as_before() {
        assert_eq!(
            RollBound::WormReach(WormEnd::Tip, 52.5).to_string(),
            "the reach of the worm tip (r = 52.5000 mm)"
        );
        assert_eq!(
            RollBound::TipAtZ0(99.0).to_string(),
            "the tip circle d_a = 99.0000 mm at z = 0"
        );
        assert_eq!(
            RollBound::BaseCircle.to_string(),
            "the base circle (undercut)"
        );
    }
}
