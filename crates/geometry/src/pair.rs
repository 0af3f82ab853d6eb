//! A gear pair at a given centre distance: working pressure angle, sum of profile shifts,
//! contact ratios, base pitch and backlash from tooth-thickness allowances.

use serde::Serialize;

use crate::error::{check_range, GeometryError, Result};
use crate::gear::{transverse_basics, Gear, GearSpec, Mesh};
use crate::involute::{inv, inv_inverse};

/// Largest working pressure angle accepted (beyond it the pair is not a practical gear set).
const MAX_WORKING_ANGLE_DEG: f64 = 60.0;

/// Dimensions of a pair at its centre distance (lengths in mm, angles in rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PairGeometry {
    /// Gear ratio u = z2/z1.
    pub gear_ratio: f64,
    /// Reference centre distance a = m_t·(z2 ± z1)/2 (− for an internal gear 2).
    pub reference_centre_distance_mm: f64,
    /// Working centre distance a_w.
    pub centre_distance_mm: f64,
    /// Working transverse pressure angle α_wt.
    pub working_pressure_angle_rad: f64,
    /// Sum of profile shifts x1 + x2 for zero backlash at a_w.
    pub shift_sum: f64,
    /// Sum of the gears' nominal profile shifts (equals shift_sum for a consistent design).
    pub nominal_shift_sum: f64,
    /// Working (pitch) diameter of gear 1, d_w1 = d_b1 / cos α_wt.
    pub working_diameter_1_mm: f64,
    /// Working (pitch) diameter of gear 2, d_w2 = d_b2 / cos α_wt.
    pub working_diameter_2_mm: f64,
    /// Transverse contact ratio ε_α.
    pub transverse_contact_ratio: f64,
    /// Overlap ratio ε_β over the common face width (None without a face width).
    pub overlap_ratio: Option<f64>,
    /// Total contact ratio ε_γ = ε_α + ε_β (None without a face width).
    pub total_contact_ratio: Option<f64>,
    /// Transverse base pitch p_bt.
    pub transverse_base_pitch_mm: f64,
    /// Normal base pitch p_bn.
    pub normal_base_pitch_mm: f64,
    /// Active root diameter of gear 1 d_Nf1 (None: the mate's tip reaches past the base circle).
    pub active_root_diameter_1_mm: Option<f64>,
    /// Active root diameter of gear 2 d_Nf2 (None: the mate's tip reaches past the base circle).
    pub active_root_diameter_2_mm: Option<f64>,
}

/// Backlash of a pair from the gears' tooth-thickness allowances.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Backlash {
    /// Generating profile shift of gear 1 x_E1.
    pub generating_shift_1: f64,
    /// Generating profile shift of gear 2 x_E2.
    pub generating_shift_2: f64,
    /// Circumferential backlash on the working circle j_wt in mm.
    pub circumferential_mm: f64,
    /// Normal backlash (along the line of action, normal to the flanks) j_bn in mm.
    pub normal_mm: f64,
}

/// Two gears in mesh at a centre distance: gear 1 external, gear 2 external or internal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GearPair {
    gear1: Gear,
    gear2: Gear,
    geometry: PairGeometry,
}

/// Things of a pair that do not depend on the centre distance.
struct Kinematics {
    /// z1 + s·z2 (s = −1 for an internal gear 2): signed, negative for internal pairs.
    z_sum: f64,
    /// m_t·|z_sum|/2.
    a_ref: f64,
    alpha_t: f64,
    tan_alpha_n: f64,
}

fn kinematics(s1: &GearSpec, s2: &GearSpec) -> Result<Kinematics> {
    let b1 = transverse_basics(s1)?;
    transverse_basics(s2)?;
    if s1.mesh != Mesh::External {
        return Err(GeometryError::OutOfRange {
            name: "mesh of gear 1 (must be external; put the internal gear second)",
            value: -1.0,
            min: 1.0,
            max: 1.0,
            unit: "",
        });
    }
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs()).max(1e-300);
    if !same(s1.normal_module_mm, s2.normal_module_mm) {
        return Err(GeometryError::Mismatch {
            name: "normal_module_mm",
            value: s1.normal_module_mm,
            other: s2.normal_module_mm,
        });
    }
    if !same(s1.normal_pressure_angle_rad, s2.normal_pressure_angle_rad) {
        return Err(GeometryError::Mismatch {
            name: "normal pressure angle in °",
            value: s1.normal_pressure_angle_rad.to_degrees(),
            other: s2.normal_pressure_angle_rad.to_degrees(),
        });
    }
    let internal = s2.mesh == Mesh::Internal;
    let signed = |g: &GearSpec| {
        let b = g.helix_angle_rad.to_degrees();
        match g.hand {
            crate::gear::Hand::Right => b,
            crate::gear::Hand::Left => -b,
        }
    };
    // External pairs need opposite hands, internal pairs the same hand.
    let want2 = if internal { signed(s1) } else { -signed(s1) };
    let have2 = signed(s2);
    if !(same(want2, have2) || (s1.helix_angle_rad == 0.0 && s2.helix_angle_rad == 0.0)) {
        return Err(GeometryError::Mismatch {
            name: "signed helix angle of gear 2 in ° (+ right hand; external pairs need β2 = −β1, internal β2 = β1)",
            value: want2,
            other: have2,
        });
    }
    let (z1, z2) = (f64::from(s1.teeth), f64::from(s2.teeth));
    if internal && z2 <= z1 {
        return Err(GeometryError::OutOfRange {
            name: "teeth of the internal gear 2",
            value: z2,
            min: z1 + 1.0,
            max: 10_000.0,
            unit: "",
        });
    }
    let z_sum = if internal { z1 - z2 } else { z1 + z2 };
    Ok(Kinematics {
        z_sum,
        a_ref: b1.m_t * z_sum.abs() / 2.0,
        alpha_t: b1.alpha_t,
        tan_alpha_n: s1.normal_pressure_angle_rad.tan(),
    })
}

impl Kinematics {
    /// α_wt from a_w, checked.
    fn working_angle(&self, centre_distance_mm: f64) -> Result<f64> {
        let c = self.a_ref * self.alpha_t.cos();
        let max = c / MAX_WORKING_ANGLE_DEG.to_radians().cos();
        check_range("centre_distance_mm", centre_distance_mm, c, max, "mm", true)?;
        Ok((c / centre_distance_mm).acos())
    }

    /// Σx for zero backlash at α_wt.
    fn shift_sum(&self, alpha_wt: f64) -> f64 {
        self.z_sum * (inv(alpha_wt) - inv(self.alpha_t)) / (2.0 * self.tan_alpha_n)
    }
}

/// Sum of profile shifts x1 + x2 that gives zero backlash at centre distance a_w.
///
/// # Formula
/// cos α_wt = a·cos α_t / a_w, a = m_t·|z1 ± z2|/2;
/// x1 + x2 = (z1 ± z2)·(inv α_wt − inv α_t) / (2·tan α_n)  (− for an internal gear 2)
/// # Source
/// ISO 21771:2007, 6.2 (internal gears with z2 < 0 rewritten) [STANDARD]; TV3:
/// a = 114.3447 mm, α_t = 21.2991°, α_wt = 23.8708°, Σx = 0.651877 [PUBLISHED]
///
/// Takes specifications, not gears, because only m_n, α_n, β, the hands and the tooth
/// counts matter: a mate's profile shift can be chosen from the result.
pub fn shift_sum_for_centre_distance(
    spec1: &GearSpec,
    spec2: &GearSpec,
    centre_distance_mm: f64,
) -> Result<f64> {
    let k = kinematics(spec1, spec2)?;
    let alpha_wt = k.working_angle(centre_distance_mm)?;
    Ok(k.shift_sum(alpha_wt))
}

/// Centre distance a_w at which a sum of profile shifts x1 + x2 gives zero backlash.
///
/// # Formula
/// inv α_wt = inv α_t + 2·tan α_n·(x1 + x2)/(z1 ± z2);  a_w = a·cos α_t / cos α_wt
/// # Source
/// ISO 21771:2007, 6.2 [STANDARD]
pub fn centre_distance_for_shift_sum(
    spec1: &GearSpec,
    spec2: &GearSpec,
    shift_sum: f64,
) -> Result<f64> {
    let k = kinematics(spec1, spec2)?;
    check_range("shift_sum", shift_sum, -20.0, 20.0, "", false)?;
    let v = inv(k.alpha_t) + 2.0 * k.tan_alpha_n * shift_sum / k.z_sum;
    let alpha_wt = inv_inverse(v);
    let max_deg = MAX_WORKING_ANGLE_DEG;
    if !(alpha_wt.is_finite() && alpha_wt > 0.0 && alpha_wt.to_degrees() < max_deg) {
        // The allowed Σx range follows from 0 < α_wt < 60°.
        let lim_hi = k.z_sum * (inv(max_deg.to_radians()) - inv(k.alpha_t)) / (2.0 * k.tan_alpha_n);
        let lim_lo = -k.z_sum * inv(k.alpha_t) / (2.0 * k.tan_alpha_n);
        return Err(GeometryError::OutOfRange {
            name: "shift_sum",
            value: shift_sum,
            min: lim_lo.min(lim_hi),
            max: lim_lo.max(lim_hi),
            unit: "",
        });
    }
    Ok(k.a_ref * k.alpha_t.cos() / alpha_wt.cos())
}

impl GearPair {
    /// Puts gear 1 (external) and gear 2 (external or internal) in mesh at centre distance a_w.
    ///
    /// # Formula
    /// α_wt, Σx: see [`shift_sum_for_centre_distance`]; d_w = d_b / cos α_wt;
    /// ε_α = [√(r_a1² − r_b1²) + s·√(r_a2² − r_b2²) − s·a_w·sin α_wt] / p_bt (s = +1
    /// external, −1 internal gear 2); ε_β = b·sin β / (π·m_n); ε_γ = ε_α + ε_β;
    /// d_Nf1 = 2·√(r_b1² + (s·(a_w·sin α_wt − √(r_a2² − r_b2²)))²),
    /// d_Nf2 = 2·√(r_b2² + (a_w·sin α_wt − s·√(r_a1² − r_b1²))²)
    /// # Source
    /// ISO 21771:2007, 6.3–6.5 [STANDARD]; active root diameters [DERIVED]
    pub fn new(gear1: &Gear, gear2: &Gear, centre_distance_mm: f64) -> Result<GearPair> {
        let k = kinematics(gear1.spec(), gear2.spec())?;
        let alpha_wt = k.working_angle(centre_distance_mm)?;
        let s = gear2.spec().mesh.sign();
        let (d1, d2) = (gear1.dims(), gear2.dims());
        let half = |d: f64| 0.5 * d;
        let t1 = (half(d1.tip_diameter_mm).powi(2) - half(d1.base_diameter_mm).powi(2)).sqrt();
        let t2 = (half(d2.tip_diameter_mm).powi(2) - half(d2.base_diameter_mm).powi(2)).sqrt();
        let g_w = centre_distance_mm * alpha_wt.sin();
        let p_bt = d1.transverse_base_pitch_mm;
        let eps_alpha = (t1 + s * t2 - s * g_w) / p_bt;
        let width = match (gear1.spec().face_width_mm, gear2.spec().face_width_mm) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        let m_n = gear1.spec().normal_module_mm;
        let eps_beta =
            width.map(|b| b * gear1.spec().helix_angle_rad.sin() / (std::f64::consts::PI * m_n));
        let l1 = s * (g_w - t2);
        let l2 = g_w - s * t1;
        let active = |r_b: f64, l: f64| (l >= 0.0).then(|| 2.0 * (r_b * r_b + l * l).sqrt());
        let geometry = PairGeometry {
            gear_ratio: f64::from(gear2.spec().teeth) / f64::from(gear1.spec().teeth),
            reference_centre_distance_mm: k.a_ref,
            centre_distance_mm,
            working_pressure_angle_rad: alpha_wt,
            shift_sum: k.shift_sum(alpha_wt),
            nominal_shift_sum: gear1.spec().profile_shift + gear2.spec().profile_shift,
            working_diameter_1_mm: d1.base_diameter_mm / alpha_wt.cos(),
            working_diameter_2_mm: d2.base_diameter_mm / alpha_wt.cos(),
            transverse_contact_ratio: eps_alpha,
            overlap_ratio: eps_beta,
            total_contact_ratio: eps_beta.map(|e| e + eps_alpha),
            transverse_base_pitch_mm: p_bt,
            normal_base_pitch_mm: d1.normal_base_pitch_mm,
            active_root_diameter_1_mm: active(half(d1.base_diameter_mm), l1),
            active_root_diameter_2_mm: active(half(d2.base_diameter_mm), l2),
        };
        Ok(GearPair {
            gear1: *gear1,
            gear2: *gear2,
            geometry,
        })
    }

    /// Gear 1 (external).
    pub fn gear1(&self) -> &Gear {
        &self.gear1
    }

    /// Gear 2 (external or internal).
    pub fn gear2(&self) -> &Gear {
        &self.gear2
    }

    /// The pair's dimensions.
    pub fn geometry(&self) -> &PairGeometry {
        &self.geometry
    }

    /// Backlash from the normal tooth-thickness allowances A_sn1, A_sn2 in mm (negative
    /// thins the tooth), including any mismatch between the nominal shifts and a_w.
    ///
    /// # Formula
    /// x_Ei = x_i + A_sni/(2·m_n·tan α_n);
    /// j_wt = 2·tan α_n·(Σx_w − x_E1 − x_E2)·m_t·cos α_t / cos α_wt
    ///      (= −(A_st1 + A_st2)·cos α_t / cos α_wt when x1 + x2 = Σx_w);
    /// j_bn = j_wt·cos α_wt·cos β_b = 2·m_n·sin α_n·(Σx_w − x_E1 − x_E2)
    /// # Source
    /// DIN 3967:1978, 2.2 / ISO 21771:2007, 6.6 [STANDARD]; exact involute relation
    /// [DERIVED]; TV3: j_n = 0.03 mm ↔ Σx_E = 0.639347 [PUBLISHED]
    pub fn backlash(&self, allowance_1_mm: f64, allowance_2_mm: f64) -> Result<Backlash> {
        let x_e1 = self.gear1.generating_shift(allowance_1_mm)?;
        let x_e2 = self.gear2.generating_shift(allowance_2_mm)?;
        let g = &self.geometry;
        let d1 = self.gear1.dims();
        let tan_a = self.gear1.spec().normal_pressure_angle_rad.tan();
        let dx = g.shift_sum - x_e1 - x_e2;
        let j_wt =
            2.0 * tan_a * dx * d1.transverse_module_mm * d1.transverse_pressure_angle_rad.cos()
                / g.working_pressure_angle_rad.cos();
        let j_bn = j_wt * g.working_pressure_angle_rad.cos() * d1.base_helix_angle_rad.cos();
        Ok(Backlash {
            generating_shift_1: x_e1,
            generating_shift_2: x_e2,
            circumferential_mm: j_wt,
            normal_mm: j_bn,
        })
    }

    /// Sum of generating profile shifts x_E1 + x_E2 that gives a normal backlash j_bn.
    ///
    /// # Formula
    /// x_E1 + x_E2 = Σx_w − j_bn / (2·m_n·sin α_n)
    /// # Source
    /// inverse of [`GearPair::backlash`] [DERIVED]; TV3 method 2: 0.639347 [PUBLISHED]
    pub fn generating_shift_sum_for_backlash(&self, normal_backlash_mm: f64) -> Result<f64> {
        let m_n = self.gear1.spec().normal_module_mm;
        check_range(
            "normal_backlash_mm",
            normal_backlash_mm,
            -m_n,
            m_n,
            "mm",
            false,
        )?;
        let a_n = self.gear1.spec().normal_pressure_angle_rad;
        Ok(self.geometry.shift_sum - normal_backlash_mm / (2.0 * m_n * a_n.sin()))
    }
}
