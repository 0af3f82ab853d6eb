//! The cylindrical involute gear (ISO 21771 / DIN 3960): specification, validation and its
//! diameters, pitches and limits.
//!
//! Convention (see docs/geometry.md): the tooth count `teeth` and every diameter are
//! positive magnitudes; an internal gear is marked by [`Mesh::Internal`], not by a negative
//! z. The profile shift coefficient x keeps the ISO 21771 sense for both kinds: x > 0
//! moves the profile towards the tooth tips and makes the tooth thicker, so for an
//! internal gear it makes the tip (inner) diameter smaller.

use std::f64::consts::{FRAC_PI_2, PI};

use serde::{Deserialize, Serialize};

use crate::error::{check_angle, check_range, GeometryError, Result};
use crate::involute::inv;

/// Largest |x| accepted anywhere; beyond it no practical gear exists.
pub(crate) const MAX_SHIFT: f64 = 10.0;

/// Smallest normal module accepted, in mm (below it no gear is cut or measured; it also
/// keeps every length far from the floating-point underflow range).
pub const MIN_MODULE_MM: f64 = 0.01;

/// Largest normal module accepted, in mm.
pub const MAX_MODULE_MM: f64 = 1000.0;

/// Normal pressure angles α_n are accepted strictly between 0° and this, in degrees.
pub const MAX_PRESSURE_ANGLE_DEG: f64 = 45.0;

/// Largest basic-rack dedendum coefficient h_fP* accepted (in m_n).
pub const MAX_DEDENDUM_COEFF: f64 = 3.0;

/// The largest normal pressure angle (exclusive, in degrees) the basic rack admits: above it
/// the tool tooth, of tip width π/2 − 2·h_fP*·tan α_n, is pointed; and never 45° or more.
/// 32.14° for DIN 867 (h_fP* = 1.25).
///
/// # Formula
/// α_n,max = min(atan(π/(4·h_fP*)), 45°)
/// # Source
/// geometry of the basic rack, ISO 53:1998, 4 [DERIVED]
pub fn max_pressure_angle_deg(rack: &BasicRack) -> f64 {
    (PI / (4.0 * rack.dedendum_coeff))
        .atan()
        .to_degrees()
        .min(MAX_PRESSURE_ANGLE_DEG)
}

/// Helix angles |β| are accepted strictly below this, in degrees.
pub const MAX_HELIX_ANGLE_DEG: f64 = 60.0;

/// Smallest number of teeth accepted.
pub const MIN_TEETH: u32 = 3;

/// Largest number of teeth accepted.
pub const MAX_TEETH: u32 = 10_000;

/// External teeth (on the outside of a blank) or internal teeth (a ring gear).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mesh {
    /// Teeth on the outside of the blank.
    #[default]
    External,
    /// Teeth on the inside of a ring.
    Internal,
}

impl Mesh {
    /// +1 for external, −1 for internal: the sign ISO 21771 gives z for internal gears.
    #[inline]
    pub fn sign(self) -> f64 {
        match self {
            Mesh::External => 1.0,
            Mesh::Internal => -1.0,
        }
    }
}

/// Hand of the helix (ISO 21771: right hand ⇔ β > 0). Ignored for spur gears.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Hand {
    /// Right-hand helix (β > 0 in ISO 21771).
    #[default]
    Right,
    /// Left-hand helix (β < 0 in ISO 21771).
    Left,
}

impl Hand {
    /// The other hand.
    pub fn opposite(self) -> Hand {
        match self {
            Hand::Right => Hand::Left,
            Hand::Left => Hand::Right,
        }
    }
    /// The sign of the signed helix angle: +1 right hand, −1 left hand.
    #[inline]
    pub fn sign(self) -> f64 {
        match self {
            Hand::Right => 1.0,
            Hand::Left => -1.0,
        }
    }
    /// Lower-case name, as written in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Hand::Right => "right",
            Hand::Left => "left",
        }
    }
}

/// Which flank of a tooth (or of a worm thread).
///
/// Convention (docs/grinding.md "Derivation: flank and chain conventions"): seen from the +z
/// end face with the tooth tip up, the right flank is on the right; its outward normal points
/// clockwise, and its flank sign is s = +1. The left flank has s = −1.
///
/// For the right-hand grinding worm of the dressing crate this is the same flank as the one
/// whose outward normal points towards +z along the worm axis (docs/dressing.md), so dressing
/// and grinding share this type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Flank {
    /// s = +1.
    Right,
    /// s = −1.
    Left,
}

impl Flank {
    /// The flank sign s_F (+1 right, −1 left).
    #[inline]
    pub fn sign(self) -> f64 {
        match self {
            Flank::Right => 1.0,
            Flank::Left => -1.0,
        }
    }
    /// Lower-case name, as written in TOML and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Flank::Right => "right",
            Flank::Left => "left",
        }
    }
    /// The other flank of the same tooth (or gap).
    pub fn opposite(self) -> Flank {
        match self {
            Flank::Right => Flank::Left,
            Flank::Left => Flank::Right,
        }
    }
}

/// Command-line values `right` / `left` (feature `clap`; no per-value help, so `--help` lists
/// only the names).
#[cfg(feature = "clap")]
mod clap_values {
    use super::{Flank, Hand};
    use clap::builder::PossibleValue;

    impl clap::ValueEnum for Hand {
        fn value_variants<'a>() -> &'a [Self] {
            &[Hand::Right, Hand::Left]
        }
        fn to_possible_value(&self) -> Option<PossibleValue> {
            Some(PossibleValue::new(self.name()))
        }
    }

    impl clap::ValueEnum for Flank {
        fn value_variants<'a>() -> &'a [Self] {
            &[Flank::Right, Flank::Left]
        }
        fn to_possible_value(&self) -> Option<PossibleValue> {
            Some(PossibleValue::new(self.name()))
        }
    }
}

/// Transverse pressure angle α_t from the normal pressure angle α_n and the helix angle β
/// (both in rad; β signed or a magnitude, the result does not depend on its sign).
///
/// # Formula
/// tan α_t = tan α_n / cos β
/// # Source
/// ISO 21771:2007, 4.3 (transverse section of a helical gear) [STANDARD]
#[inline]
pub fn transverse_pressure_angle_rad(normal_pressure_angle_rad: f64, helix_angle_rad: f64) -> f64 {
    (normal_pressure_angle_rad.tan() / helix_angle_rad.cos()).atan()
}

/// Basic rack profile of the generating tool, as coefficients of the normal module.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BasicRack {
    /// Addendum of the gear's basic rack h_aP* (tip height above the datum line), in m_n.
    pub addendum_coeff: f64,
    /// Dedendum of the gear's basic rack h_fP* (= tool addendum), in m_n.
    pub dedendum_coeff: f64,
    /// Root fillet radius of the basic rack ρ_fP* (= tool tip radius), in m_n.
    pub root_radius_coeff: f64,
}

impl BasicRack {
    /// DIN 867 basic rack: h_aP* = 1, h_fP* = 1.25, ρ_fP* = 0.25.
    ///
    /// # Source
    /// DIN 867:1986 [STANDARD]; reproduces d_Ff = 18.8003 mm and x_Emin = −0.0843 of the
    /// MESYS vector TV1 (docs/geometry.md "Published test vectors").
    pub const DIN_867: BasicRack = BasicRack {
        addendum_coeff: 1.0,
        dedendum_coeff: 1.25,
        root_radius_coeff: 0.25,
    };
}

impl BasicRack {
    /// The largest root fillet radius ρ_fP* (in m_n) this rack's addendum and dedendum admit
    /// at the normal pressure angle `alpha_n_rad`: the full-radius tool tip, and no longer
    /// than the dedendum's straight part allows.
    ///
    /// # Formula
    /// s_tip = π/2 − 2·h_fP*·tan α_n;  ρ_max* = min(s_tip·cos α_n / (2·(1 − sin α_n)),
    /// h_fP* / (1 − sin α_n))
    /// # Source
    /// geometry of the basic rack, ISO 53:1998, 4 [DERIVED]
    pub fn max_root_radius_coeff(&self, alpha_n_rad: f64) -> f64 {
        let s_tip = FRAC_PI_2 - 2.0 * self.dedendum_coeff * alpha_n_rad.tan();
        let full = s_tip * alpha_n_rad.cos() / (2.0 * (1.0 - alpha_n_rad.sin()));
        full.min(self.dedendum_coeff / (1.0 - alpha_n_rad.sin()))
    }

    /// The DIN 867 rack for the pressure angle `alpha_n_rad`: DIN 867 is drawn for 20°; at a
    /// pressure angle whose narrower rack tip cannot carry ρ_fP* = 0.25 (above about 25°)
    /// the root radius is the largest it can carry (a full-radius tool tip).
    pub fn din_867_at(alpha_n_rad: f64) -> BasicRack {
        BasicRack::DIN_867.root_radius_carried_at(alpha_n_rad)
    }

    /// This rack with its root radius reduced, where the tip is too narrow for it at the
    /// normal pressure angle `alpha_n_rad`, to the largest the tip carries (a full-radius
    /// tool tip); unchanged where it fits, and where no radius fits (a pointed tool tooth,
    /// which the gear's rack check then names).
    pub fn root_radius_carried_at(self, alpha_n_rad: f64) -> BasicRack {
        let rho_max = self.max_root_radius_coeff(alpha_n_rad);
        if !(rho_max.is_finite() && rho_max >= 0.0) {
            return self;
        }
        BasicRack {
            root_radius_coeff: self.root_radius_coeff.min(rho_max),
            ..self
        }
    }
}

impl Default for BasicRack {
    fn default() -> Self {
        BasicRack::DIN_867
    }
}

/// Everything that defines a cylindrical involute gear.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GearSpec {
    /// Normal module m_n in mm.
    pub normal_module_mm: f64,
    /// Normal pressure angle α_n in rad (0 < α_n < 45°).
    pub normal_pressure_angle_rad: f64,
    /// Helix angle β at the reference circle in rad, a magnitude (0 ≤ β < 60°).
    pub helix_angle_rad: f64,
    /// Hand of the helix.
    pub hand: Hand,
    /// Number of teeth z (a positive count, also for internal gears).
    pub teeth: u32,
    /// External or internal teeth.
    pub mesh: Mesh,
    /// Nominal profile shift coefficient x (ISO 21771 sense: x > 0 thickens the tooth).
    pub profile_shift: f64,
    /// Face width b in mm, if known.
    pub face_width_mm: Option<f64>,
    /// Basic rack of the generating tool.
    pub rack: BasicRack,
}

impl GearSpec {
    /// An external spur gear with x = 0 on the DIN 867 rack.
    pub fn spur(normal_module_mm: f64, normal_pressure_angle_rad: f64, teeth: u32) -> Self {
        GearSpec {
            normal_module_mm,
            normal_pressure_angle_rad,
            helix_angle_rad: 0.0,
            hand: Hand::Right,
            teeth,
            mesh: Mesh::External,
            profile_shift: 0.0,
            face_width_mm: None,
            rack: BasicRack::DIN_867,
        }
    }
}

/// Derived dimensions of a gear at its nominal profile shift (lengths in mm, angles in rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GearDimensions {
    /// Transverse module m_t = m_n / cos β.
    pub transverse_module_mm: f64,
    /// Transverse pressure angle α_t, tan α_t = tan α_n / cos β.
    pub transverse_pressure_angle_rad: f64,
    /// Base helix angle β_b, tan β_b = tan β·cos α_t.
    pub base_helix_angle_rad: f64,
    /// Lead p_z = π·d / tan β (None for spur gears).
    pub lead_mm: Option<f64>,
    /// Reference diameter d = z·m_t.
    pub reference_diameter_mm: f64,
    /// Base diameter d_b = d·cos α_t.
    pub base_diameter_mm: f64,
    /// Tip diameter d_a = d ± 2·m_n·(h_aP* + x) (+ external, − internal).
    pub tip_diameter_mm: f64,
    /// Root diameter d_f = d ∓ 2·m_n·(h_fP* − x) at the nominal shift.
    pub root_diameter_mm: f64,
    /// Root form diameter d_Ff from rack generation at the nominal shift (external only).
    pub root_form_diameter_mm: Option<f64>,
    /// Normal pitch p_n = π·m_n.
    pub normal_pitch_mm: f64,
    /// Transverse pitch p_t = π·m_t.
    pub transverse_pitch_mm: f64,
    /// Normal base pitch p_bn = π·m_n·cos α_n.
    pub normal_base_pitch_mm: f64,
    /// Transverse base pitch p_bt = π·m_t·cos α_t.
    pub transverse_base_pitch_mm: f64,
    /// Smallest profile shift without undercut by the rack (external only).
    pub min_shift_undercut: Option<f64>,
    /// Overlap ratio of the gear alone ε_β = b·sin β / (π·m_n) (needs the face width).
    pub overlap_ratio: Option<f64>,
}

/// A validated cylindrical involute gear.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gear {
    spec: GearSpec,
    dims: GearDimensions,
    pub(crate) inv_alpha_t: f64,
    pub(crate) tan_alpha_n: f64,
}

impl Gear {
    /// Validates a specification and computes the gear's dimensions.
    ///
    /// Rejects: module outside [0.01, 1000] mm, α_n outside (0°, 45°), β outside [0°, 60°),
    /// z outside 3…10 000, |x| > 10, face width outside (0, 10 000] mm, a basic rack whose
    /// tool tooth has no room for its tip radius, a pointed tooth (s_an ≤ 0) and an internal
    /// tip circle inside the base circle. Undercut is computed, not refused: see
    /// [`Gear::undercut`].
    ///
    /// # Formula
    /// m_t = m_n / cos β; tan α_t = tan α_n / cos β; tan β_b = tan β·cos α_t;
    /// d = z·m_t; d_b = d·cos α_t; p_z = π·d / tan β;
    /// external: d_a = d + 2·m_n·(h_aP* + x), d_f = d − 2·m_n·(h_fP* − x);
    /// internal: d_a = d − 2·m_n·(h_aP* + x), d_f = d + 2·m_n·(h_fP* − x)
    /// # Source
    /// ISO 21771:2007, 4.2–4.4 and 5.2 (internal gears with z < 0 rewritten with positive
    /// magnitudes) [STANDARD]
    pub fn new(spec: GearSpec) -> Result<Gear> {
        let TransverseBasics {
            m_n,
            beta,
            m_t,
            alpha_t,
        } = transverse_basics(&spec)?;
        let z_f = f64::from(spec.teeth);
        let x = check_range(
            "profile_shift",
            spec.profile_shift,
            -MAX_SHIFT,
            MAX_SHIFT,
            "",
            false,
        )?;
        if let Some(b) = spec.face_width_mm {
            check_range("face_width_mm", b, 0.0, 10_000.0, "mm", true)?;
        }
        let alpha_n = spec.normal_pressure_angle_rad;
        check_rack(&spec.rack, alpha_n)?;

        let beta_b = (beta.tan() * alpha_t.cos()).atan();
        let d = z_f * m_t;
        let d_b = d * alpha_t.cos();
        let sigma = spec.mesh.sign();
        let r = &spec.rack;
        let d_a = d + sigma * 2.0 * m_n * (r.addendum_coeff + x);
        let d_f = d - sigma * 2.0 * m_n * (r.dedendum_coeff - x);
        let lead_mm = (beta > 0.0).then(|| PI * d / beta.tan());
        let mut gear = Gear {
            spec,
            dims: GearDimensions {
                transverse_module_mm: m_t,
                transverse_pressure_angle_rad: alpha_t,
                base_helix_angle_rad: beta_b,
                lead_mm,
                reference_diameter_mm: d,
                base_diameter_mm: d_b,
                tip_diameter_mm: d_a,
                root_diameter_mm: d_f,
                root_form_diameter_mm: None,
                normal_pitch_mm: PI * m_n,
                transverse_pitch_mm: PI * m_t,
                normal_base_pitch_mm: PI * m_n * alpha_n.cos(),
                transverse_base_pitch_mm: PI * m_t * alpha_t.cos(),
                min_shift_undercut: None,
                overlap_ratio: spec.face_width_mm.map(|b| b * beta.sin() / (PI * m_n)),
            },
            inv_alpha_t: inv(alpha_t),
            tan_alpha_n: alpha_n.tan(),
        };
        if spec.mesh == Mesh::External {
            gear.dims.min_shift_undercut = Some(gear.min_shift_undercut_ext());
            gear.dims.root_form_diameter_mm = gear.root_form_diameter_mm(x);
        } else if d_a <= d_b {
            return Err(GeometryError::OutOfRange {
                name: "tip diameter d_a (internal gear; reduce profile_shift)",
                value: d_a,
                min: d_b,
                max: d,
                unit: "mm",
            });
        }
        if d_f <= 0.0 {
            return Err(GeometryError::OutOfRange {
                name: "root diameter d_f (too few teeth for this rack)",
                value: d_f,
                min: 0.0,
                max: d,
                unit: "mm",
            });
        }
        gear.check_shift("profile_shift", x)?;
        Ok(gear)
    }

    /// The specification the gear was built from.
    pub fn spec(&self) -> &GearSpec {
        &self.spec
    }

    /// The derived dimensions at the nominal profile shift.
    pub fn dims(&self) -> &GearDimensions {
        &self.dims
    }

    /// +1 for an external, −1 for an internal gear.
    #[inline]
    pub(crate) fn sigma(&self) -> f64 {
        self.spec.mesh.sign()
    }

    /// Reference radius r = d/2 in mm.
    #[inline]
    pub(crate) fn r(&self) -> f64 {
        0.5 * self.dims.reference_diameter_mm
    }

    /// Base radius r_b = d_b/2 in mm.
    #[inline]
    pub(crate) fn r_b(&self) -> f64 {
        0.5 * self.dims.base_diameter_mm
    }

    /// Height of the straight part of the rack dedendum, h_FfP = h_fP − ρ_fP·(1 − sin α_n), in mm.
    fn h_ffp_mm(&self) -> f64 {
        let r = &self.spec.rack;
        let a = self.spec.normal_pressure_angle_rad;
        self.spec.normal_module_mm * (r.dedendum_coeff - r.root_radius_coeff * (1.0 - a.sin()))
    }

    /// Smallest profile shift without undercut of an external gear by the rack.
    ///
    /// # Formula
    /// x_min = h_FfP/m_n − z·sin²α_t / (2·cos β),  h_FfP = h_fP − ρ_fP·(1 − sin α_n)
    /// # Source
    /// DIN 3960:1987, 3.6.3 (end of the straight rack flank on the line of action) [STANDARD];
    /// TV1 of docs/geometry.md "Published test vectors" (MESYS): x_Emin = −0.0843 [PUBLISHED]
    fn min_shift_undercut_ext(&self) -> f64 {
        let m_n = self.spec.normal_module_mm;
        let s = self.dims.transverse_pressure_angle_rad.sin();
        self.h_ffp_mm() / m_n
            - f64::from(self.spec.teeth) * s * s / (2.0 * self.spec.helix_angle_rad.cos())
    }

    /// Smallest number of teeth without undercut at profile shift x (external gears).
    ///
    /// # Formula
    /// z_min = 2·cos β·(h_FfP/m_n − x) / sin²α_t
    /// # Source
    /// DIN 3960:1987, 3.6.3 [STANDARD]
    pub fn min_teeth_undercut(&self, shift: f64) -> f64 {
        let s = self.dims.transverse_pressure_angle_rad.sin();
        2.0 * self.spec.helix_angle_rad.cos()
            * (self.h_ffp_mm() / self.spec.normal_module_mm - shift)
            / (s * s)
    }

    /// Root form diameter d_Ff where the rack-generated involute starts (external gears),
    /// None for internal gears or an undercut gear.
    ///
    /// # Formula
    /// d_Ff = 2·√(r_b² + (r·sin α_t − (h_FfP − x·m_n)/sin α_t)²)
    /// # Source
    /// ISO 21771:2007, 5.4.5, rack generation [STANDARD]; TV1: d_Ff = 18.8003 mm [PUBLISHED]
    pub fn root_form_diameter_mm(&self, shift: f64) -> Option<f64> {
        if self.spec.mesh == Mesh::Internal || !shift.is_finite() {
            return None;
        }
        let s = self.dims.transverse_pressure_angle_rad.sin();
        let l = self.r() * s - (self.h_ffp_mm() - shift * self.spec.normal_module_mm) / s;
        (l >= 0.0).then(|| 2.0 * (self.r_b() * self.r_b() + l * l).sqrt())
    }

    /// Root diameter in mm for a generating profile shift x_E.
    ///
    /// # Formula
    /// d_f = d − 2·m_n·(h_fP* − x_E) (external), d + 2·m_n·(h_fP* − x_E) (internal)
    /// # Source
    /// ISO 21771:2007, 5.2.4 [STANDARD]; TV2: d_f = 27.3352/27.4176 mm [PUBLISHED]
    pub fn root_diameter_mm(&self, shift: f64) -> f64 {
        self.dims.reference_diameter_mm
            - self.sigma()
                * 2.0
                * self.spec.normal_module_mm
                * (self.spec.rack.dedendum_coeff - shift)
    }

    /// Lowest and highest diameter of the usable involute flank for generating shift x_E:
    /// external [max(d_Ff, d_b), d_a], internal [d_a, d_f].
    ///
    /// Internal gears: the root form circle depends on the shaper cutter, so the root
    /// circle stands in for it (a documented approximation).
    pub fn flank_range_mm(&self, shift: f64) -> (f64, f64) {
        let d_b = self.dims.base_diameter_mm;
        match self.spec.mesh {
            Mesh::External => (
                self.root_form_diameter_mm(shift).unwrap_or(d_b).max(d_b),
                self.dims.tip_diameter_mm,
            ),
            Mesh::Internal => (self.dims.tip_diameter_mm, self.root_diameter_mm(shift)),
        }
    }

    /// Normal tooth thickness at the reference circle for profile shift x, in mm.
    ///
    /// # Formula
    /// s_n = m_n·(π/2 + 2·x·tan α_n) (external and internal teeth)
    /// # Source
    /// ISO 21771:2007, 5.3.1 [STANDARD]
    #[inline]
    pub fn normal_thickness_at_reference_mm(&self, shift: f64) -> f64 {
        self.spec.normal_module_mm * (FRAC_PI_2 + 2.0 * shift * self.tan_alpha_n)
    }

    /// Profile shift x that gives a normal tooth thickness s_n at the reference circle.
    ///
    /// # Formula
    /// x = (s_n/m_n − π/2) / (2·tan α_n)
    /// # Source
    /// inverse of ISO 21771:2007, 5.3.1 [DERIVED]
    #[inline]
    pub fn shift_from_normal_thickness(&self, normal_thickness_mm: f64) -> f64 {
        (normal_thickness_mm / self.spec.normal_module_mm - FRAC_PI_2) / (2.0 * self.tan_alpha_n)
    }

    /// Generating profile shift x_E for a normal tooth-thickness allowance A_sn in mm
    /// (A_sn < 0 thins the tooth), checked for a pointed tooth (undercut: [`Gear::undercut`]).
    ///
    /// # Formula
    /// x_E = x + A_sn / (2·m_n·tan α_n)
    /// # Domain
    /// |A_sn| ≤ 0.5·m_n
    /// # Source
    /// DIN 3960:1987, 3.6.1 (generating profile shift) [STANDARD]; TV2: A_sn = −0.06/−0.03 mm
    /// → x_E = −0.0824/−0.0412 [PUBLISHED]
    pub fn generating_shift(&self, allowance_mm: f64) -> Result<f64> {
        let m_n = self.spec.normal_module_mm;
        check_range(
            "thickness_allowance_mm",
            allowance_mm,
            -0.5 * m_n,
            0.5 * m_n,
            "mm",
            false,
        )?;
        let x_e = self.spec.profile_shift + allowance_mm / (2.0 * m_n * self.tan_alpha_n);
        self.check_shift("generating profile shift x_E", x_e)?;
        Ok(x_e)
    }

    /// Normal tooth-thickness allowance A_sn in mm that a generating shift x_E means.
    ///
    /// # Formula
    /// A_sn = 2·m_n·tan α_n·(x_E − x)
    /// # Source
    /// inverse of DIN 3960:1987, 3.6.1 [DERIVED]
    pub fn allowance_from_shift(&self, generating_shift: f64) -> f64 {
        2.0 * self.spec.normal_module_mm
            * self.tan_alpha_n
            * (generating_shift - self.spec.profile_shift)
    }

    /// The undercut of an external gear cut by the rack at profile shift x, as the
    /// [`GeometryError::Undercut`] that describes it (x, x_min, z_min), or None.
    ///
    /// Undercut is not an error: the gear exists and its numbers are computed; the rack tip
    /// removes part of the involute above the base circle, so the usable flank starts higher
    /// than the base circle (not computed here: the flank range then begins at d_b) and the
    /// tooth root is weakened. Callers warn with this value's message.
    ///
    /// # Source
    /// DIN 3960:1987, 3.6.3 [STANDARD]
    pub fn undercut(&self, name: &'static str, shift: f64) -> Option<GeometryError> {
        let x_min = self.dims.min_shift_undercut?;
        // A margin of 1e-12 keeps a gear designed exactly at x_min free of undercut.
        (shift < x_min - 1e-12).then(|| GeometryError::Undercut {
            name,
            value: shift,
            min: x_min,
            teeth: self.spec.teeth,
            min_teeth: self.min_teeth_undercut(shift),
        })
    }

    /// Checks a (generating) profile shift for a pointed tooth (undercut is reported by
    /// [`Gear::undercut`], not refused).
    pub fn check_shift(&self, name: &'static str, shift: f64) -> Result<()> {
        check_range(name, shift, -MAX_SHIFT, MAX_SHIFT, "", false)?;
        let s_an = self.tip_normal_thickness_mm(shift)?;
        if s_an.is_nan() || s_an <= 0.0 {
            return Err(GeometryError::PointedTooth {
                name,
                shift,
                value_mm: s_an,
                min_mm: 0.0,
            });
        }
        Ok(())
    }
}

/// Validated module, helix angle and the transverse module and pressure angle of a spec.
pub(crate) struct TransverseBasics {
    /// Normal module m_n in mm.
    pub m_n: f64,
    /// Helix angle β in rad.
    pub beta: f64,
    /// Transverse module m_t in mm.
    pub m_t: f64,
    /// Transverse pressure angle α_t in rad.
    pub alpha_t: f64,
}

/// Checks m_n, α_n, β and z of a spec and derives m_t = m_n/cos β, tan α_t = tan α_n/cos β.
///
/// # Source
/// ISO 21771:2007, 4.2 [STANDARD]
pub(crate) fn transverse_basics(spec: &GearSpec) -> Result<TransverseBasics> {
    let m_n = spec.normal_module_mm;
    if !(m_n.is_finite() && (MIN_MODULE_MM..=MAX_MODULE_MM).contains(&m_n)) {
        return Err(GeometryError::OutOfRange {
            name: "normal_module_mm",
            value: m_n,
            min: MIN_MODULE_MM,
            max: MAX_MODULE_MM,
            unit: "mm",
        });
    }
    let alpha_n = check_angle(
        "normal_pressure_angle",
        spec.normal_pressure_angle_rad,
        0.0,
        MAX_PRESSURE_ANGLE_DEG,
        true,
    )?;
    let beta = check_angle(
        "helix_angle",
        spec.helix_angle_rad,
        0.0,
        MAX_HELIX_ANGLE_DEG,
        false,
    )?;
    check_range(
        "teeth",
        f64::from(spec.teeth),
        f64::from(MIN_TEETH),
        f64::from(MAX_TEETH),
        "",
        false,
    )?;
    let m_t = m_n / beta.cos();
    let alpha_t = transverse_pressure_angle_rad(alpha_n, beta);
    Ok(TransverseBasics {
        m_n,
        beta,
        m_t,
        alpha_t,
    })
}

/// Checks the basic rack: positive heights and room for the tool's tip radius.
///
/// # Formula
/// tool tip width s_tip = π/2 − 2·h_fP*·tan α_n > 0;
/// ρ_fP* ≤ ρ_max* = s_tip·cos α_n / (2·(1 − sin α_n))  (full-radius tip)
/// # Source
/// geometry of the basic rack, ISO 53:1998, 4 [DERIVED]
fn check_rack(rack: &BasicRack, alpha_n: f64) -> Result<()> {
    check_range("addendum_coeff", rack.addendum_coeff, 0.0, 3.0, "", true)?;
    let (h_a, h_f) = (rack.addendum_coeff, rack.dedendum_coeff);
    // The tool tooth is pointed from h_fP* = π/(4·tan α_n) on.
    let pointed = FRAC_PI_2 / (2.0 * alpha_n.tan());
    if !(h_f.is_finite() && h_f > h_a && h_f <= MAX_DEDENDUM_COEFF) {
        let max_pointed = pointed > h_a && pointed <= MAX_DEDENDUM_COEFF;
        return Err(GeometryError::DedendumRange {
            name: "dedendum_coeff",
            value: h_f,
            addendum_coeff: h_a,
            max: if max_pointed {
                pointed
            } else {
                MAX_DEDENDUM_COEFF
            },
            max_pointed,
        });
    }
    if h_f >= pointed {
        return Err(GeometryError::PointedTool {
            name: "normal_pressure_angle",
            alpha_n_deg: (alpha_n.to_degrees() * 1e10).round() / 1e10,
            dedendum_coeff: h_f,
            addendum_coeff: h_a,
            max_alpha_n_deg: max_pressure_angle_deg(rack),
            max_dedendum_coeff: pointed,
        });
    }
    let rho_max = rack.max_root_radius_coeff(alpha_n);
    check_range(
        "root_radius_coeff",
        rack.root_radius_coeff,
        0.0,
        rho_max,
        "",
        false,
    )?;
    Ok(())
}
