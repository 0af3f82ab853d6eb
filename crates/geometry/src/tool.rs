//! Generating tools as involute helicoids: the hob / grinding worm (a ZI worm) and the
//! shaper cutter (an involute gear, helical with its lead).

use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::error::{check_angle, check_range, GeometryError, Result};
use crate::gear::{Gear, GearSpec, Hand, Mesh, MAX_SHIFT};
use crate::pair::centre_distance_for_shift_sum;

/// Specification of a hob or grinding worm with an involute-helicoid (ZI) thread.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WormSpec {
    /// Number of starts (threads) z0.
    pub starts: u32,
    /// Normal module m_n0 in mm (equals the gear's normal module).
    pub normal_module_mm: f64,
    /// Normal profile angle α_n0 in rad (equals the gear's normal pressure angle).
    pub normal_profile_angle_rad: f64,
    /// Reference (pitch) diameter d0 in mm.
    pub reference_diameter_mm: f64,
    /// Hand of the thread.
    pub hand: Hand,
}

/// Derived dimensions of a worm (lengths in mm, angles in rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct WormDimensions {
    /// Lead angle γ at the reference cylinder, sin γ = z0·m_n0/d0.
    pub lead_angle_rad: f64,
    /// Axial module m_x = m_n0 / cos γ.
    pub axial_module_mm: f64,
    /// Axial pitch p_x = π·m_x.
    pub axial_pitch_mm: f64,
    /// Lead p_z = z0·p_x.
    pub lead_mm: f64,
    /// Axial profile angle α_x, tan α_x = tan α_n0 / cos γ.
    pub axial_profile_angle_rad: f64,
    /// Profile angle in the worm's transverse plane α_t0, tan α_t0 = tan α_n0 / sin γ.
    pub transverse_profile_angle_rad: f64,
    /// Base cylinder diameter of the involute helicoid d_b0 = d0·cos α_t0.
    pub base_diameter_mm: f64,
    /// Lead angle on the base cylinder γ_b, cos γ_b = cos γ·cos α_n0.
    pub base_lead_angle_rad: f64,
    /// Normal base pitch p_bn = π·m_n0·cos α_n0 (equals the generated gear's).
    pub normal_base_pitch_mm: f64,
}

/// A validated hob or grinding worm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeneratingWorm {
    spec: WormSpec,
    dims: WormDimensions,
}

impl GeneratingWorm {
    /// Validates a worm and derives its helicoid.
    ///
    /// The ZI worm is the involute helical gear with z0 teeth and helix angle 90° − γ,
    /// which is why its base cylinder follows from the gear formulas.
    ///
    /// # Formula
    /// sin γ = z0·m_n0/d0; m_x = m_n0/cos γ; p_x = π·m_x; p_z = z0·p_x;
    /// tan α_x = tan α_n0/cos γ; tan α_t0 = tan α_n0/sin γ; d_b0 = d0·cos α_t0;
    /// cos γ_b = cos γ·cos α_n0 (and r_b0·tan γ_b = p_z/(2π))
    /// # Domain
    /// 1 ≤ z0 ≤ 50, 0 < α_n0 < 45°, γ ≤ 45° (d0 ≥ √2·z0·m_n0)
    /// # Source
    /// ISO 21771:2007, 4.2–4.3 applied with β = 90° − γ [DERIVED]; ZI worm base cylinder:
    /// F. L. Litvin, Gear Geometry and Applied Theory (2004), 19.4 [STANDARD]
    pub fn new(spec: WormSpec) -> Result<GeneratingWorm> {
        check_range("starts", f64::from(spec.starts), 1.0, 50.0, "", false)?;
        let m_n = check_range(
            "normal_module_mm",
            spec.normal_module_mm,
            0.0,
            1000.0,
            "mm",
            true,
        )?;
        let a_n = check_angle(
            "normal_profile_angle",
            spec.normal_profile_angle_rad,
            0.0,
            45.0,
            true,
        )?;
        let z0 = f64::from(spec.starts);
        let d_min = z0 * m_n * std::f64::consts::SQRT_2;
        let d0 = check_range(
            "reference_diameter_mm",
            spec.reference_diameter_mm,
            d_min,
            1e5,
            "mm",
            false,
        )?;
        let gamma = (z0 * m_n / d0).asin();
        let m_x = m_n / gamma.cos();
        let p_x = PI * m_x;
        let alpha_t0 = (a_n.tan() / gamma.sin()).atan();
        Ok(GeneratingWorm {
            spec,
            dims: WormDimensions {
                lead_angle_rad: gamma,
                axial_module_mm: m_x,
                axial_pitch_mm: p_x,
                lead_mm: z0 * p_x,
                axial_profile_angle_rad: (a_n.tan() / gamma.cos()).atan(),
                transverse_profile_angle_rad: alpha_t0,
                base_diameter_mm: d0 * alpha_t0.cos(),
                base_lead_angle_rad: (gamma.cos() * a_n.cos()).acos(),
                normal_base_pitch_mm: PI * m_n * a_n.cos(),
            },
        })
    }

    /// The specification.
    pub fn spec(&self) -> &WormSpec {
        &self.spec
    }

    /// The derived dimensions.
    pub fn dims(&self) -> &WormDimensions {
        &self.dims
    }

    /// Checks that the worm can generate `gear` (same normal module and profile angle).
    pub fn check_generates(&self, gear: &Gear) -> Result<()> {
        let g = gear.spec();
        let rel = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        if !rel(g.normal_module_mm, self.spec.normal_module_mm) {
            return Err(GeometryError::Mismatch {
                name: "normal_module_mm (worm vs gear)",
                value: self.spec.normal_module_mm,
                other: g.normal_module_mm,
            });
        }
        if !rel(
            g.normal_pressure_angle_rad,
            self.spec.normal_profile_angle_rad,
        ) {
            return Err(GeometryError::Mismatch {
                name: "normal profile angle in ° (worm vs gear)",
                value: self.spec.normal_profile_angle_rad.to_degrees(),
                other: g.normal_pressure_angle_rad.to_degrees(),
            });
        }
        if g.mesh == Mesh::Internal {
            return Err(GeometryError::OutOfRange {
                name: "mesh of the generated gear (a worm cuts external gears only)",
                value: -1.0,
                min: 1.0,
                max: 1.0,
                unit: "",
            });
        }
        Ok(())
    }

    /// Signed setting (swivel) angle of the worm axis against the gear's transverse plane.
    ///
    /// # Formula
    /// η = β_s − γ_s with signed angles (+ right hand): same hands subtract, opposite
    /// hands add, a spur gear gives η = −γ_s
    /// # Source
    /// DIN 3960 / hobbing practice, e.g. Bausch, Innovative Zahnradfertigung (2006), 4.2 [STANDARD]
    pub fn setting_angle_rad(&self, gear: &Gear) -> f64 {
        let signed = |a: f64, h: Hand| match h {
            Hand::Right => a,
            Hand::Left => -a,
        };
        signed(gear.spec().helix_angle_rad, gear.spec().hand)
            - signed(self.dims.lead_angle_rad, self.spec.hand)
    }
}

/// Setting of a shaper cutter against a workpiece at a generating profile shift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ShapingSetup {
    /// Cutting centre distance a_0 in mm.
    pub centre_distance_mm: f64,
    /// Root diameter the cutter's tip produces on the workpiece in mm.
    pub work_root_diameter_mm: f64,
}

/// A shaper cutter: an external involute gear (helical with its lead for helical work).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShaperCutter {
    gear: Gear,
}

impl ShaperCutter {
    /// Validates a cutter; its spec's rack addendum is the cutter's tooth addendum h_a0*
    /// (typically 1.25 so it cuts the DIN 867 root).
    pub fn new(spec: GearSpec) -> Result<ShaperCutter> {
        if spec.mesh != Mesh::External {
            return Err(GeometryError::OutOfRange {
                name: "mesh of the shaper cutter (must be external)",
                value: -1.0,
                min: 1.0,
                max: 1.0,
                unit: "",
            });
        }
        Ok(ShaperCutter {
            gear: Gear::new(spec)?,
        })
    }

    /// The cutter as an involute gear.
    pub fn gear(&self) -> &Gear {
        &self.gear
    }

    /// Lead of a helical cutter p_z0 = π·z0·m_n / sin β0 in mm (None for a spur cutter);
    /// the helical guide must turn the cutter once per this much stroke.
    ///
    /// # Formula
    /// p_z0 = π·d0 / tan β0 = π·z0·m_n / sin β0
    /// # Source
    /// ISO 21771:2007, 4.3.5 [STANDARD]
    pub fn lead_mm(&self) -> Option<f64> {
        self.gear.dims().lead_mm
    }

    /// Cutting centre distance and the workpiece root diameter when the cutter (profile
    /// shift x0) generates `work` at generating shift x_E: the zero-backlash mesh.
    ///
    /// # Formula
    /// a_0 from Σx = x0 + x_E (see [`centre_distance_for_shift_sum`]);
    /// d_f = 2·a_0 − d_a0 (external work), d_f = 2·a_0 + d_a0 (internal work)
    /// # Source
    /// DIN 3960:1987, 3.6.2 (generating with a pinion-type cutter) [STANDARD]
    pub fn cutting(&self, work: &Gear, generating_shift: f64) -> Result<ShapingSetup> {
        check_range(
            "generating profile shift x_E",
            generating_shift,
            -MAX_SHIFT,
            MAX_SHIFT,
            "",
            false,
        )?;
        let sum = self.gear.spec().profile_shift + generating_shift;
        let a0 = centre_distance_for_shift_sum(self.gear.spec(), work.spec(), sum)?;
        let d_a0 = self.gear.dims().tip_diameter_mm;
        let d_f = match work.spec().mesh {
            Mesh::External => 2.0 * a0 - d_a0,
            Mesh::Internal => 2.0 * a0 + d_a0,
        };
        Ok(ShapingSetup {
            centre_distance_mm: a0,
            work_root_diameter_mm: d_f,
        })
    }
}
