//! Workpiece thermal-shrink compensation for dry cutting (CN105397560, eq. (7)).
//!
//! A gear cut hot (temperature Ta) shrinks when it cools to the design temperature Tb.
//! The hob's rack and the generating ratio are not scaled by the hot workpiece, so the hot
//! gear is generated with the cold base circle; a radial hob offset X changes the
//! generated transverse tooth thickness by 2·X·tan α_t. Requiring the cooled tooth
//! thickness at the reference radius ρ to equal the design value gives δT.
//!
//! Convention: δT > 0 withdraws the hob (increases the centre distance), so the hot tooth
//! is cut thicker and is right after cooling.

/// Radius at which the cooled tooth thickness is made right.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShrinkReference {
    /// The reference (pitch) circle, ρ = r.
    Pitch,
    /// A given radius, e.g. the tip radius r_a (the literal CN105397560 eq. (7)).
    Radius(f64),
}

/// Inputs of the shrink offset.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShrinkInput {
    /// Reference radius r = m_n·z/(2 cos β) in mm.
    pub reference_radius_mm: f64,
    /// Transverse pressure angle α_t in rad.
    pub transverse_pressure_angle_rad: f64,
    /// Linear expansion coefficient λ in 1/K.
    pub expansion_per_k: f64,
    /// Temperature drop ΔT_w = Ta − Tb in K (positive when the workpiece is hot).
    pub delta_temp_k: f64,
    /// Where the thickness is made right.
    pub reference: ShrinkReference,
}

impl ShrinkInput {
    /// The input for a cylindrical gear given by its normal module m_n (mm), tooth count z,
    /// normal pressure angle α_n and helix angle β (rad): r = m_n·z/(2 cos β) and
    /// tan α_t = tan α_n / cos β. This is the one place the gear data of a workpiece-shrink
    /// configuration become shrink inputs.
    pub fn for_gear(
        normal_module_mm: f64,
        teeth: u32,
        normal_pressure_angle_rad: f64,
        helix_angle_rad: f64,
        expansion_per_k: f64,
        delta_temp_k: f64,
        reference: ShrinkReference,
    ) -> Self {
        ShrinkInput {
            reference_radius_mm: normal_module_mm * f64::from(teeth)
                / (2.0 * helix_angle_rad.cos()),
            transverse_pressure_angle_rad: crate::gear::transverse_pressure_angle_rad(
                normal_pressure_angle_rad,
                helix_angle_rad,
            ),
            expansion_per_k,
            delta_temp_k,
            reference,
        }
    }
}

/// Why a shrink offset cannot be computed.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ShrinkError {
    /// An input is outside its range.
    #[error("invalid {field} = {value}: expected {expected}")]
    InvalidInput {
        /// The input's name.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// The allowed range.
        expected: &'static str,
    },
}

fn check(input: &ShrinkInput) -> Result<f64, ShrinkError> {
    let bad = |field, value, expected| {
        Err(ShrinkError::InvalidInput {
            field,
            value,
            expected,
        })
    };
    let r = input.reference_radius_mm;
    let a = input.transverse_pressure_angle_rad;
    if !(r.is_finite() && r > 0.0) {
        return bad("reference_radius_mm", r, "r > 0 mm");
    }
    if !(a.is_finite() && a > 0.0 && a < std::f64::consts::FRAC_PI_2) {
        return bad("transverse_pressure_angle_rad", a, "0 < α_t < π/2 rad");
    }
    let lam = input.expansion_per_k;
    if !(lam.is_finite() && lam > 0.0 && lam < 1e-3) {
        return bad("expansion_per_k", lam, "0 < λ < 1e-3 1/K");
    }
    let dt = input.delta_temp_k;
    if !(dt.is_finite() && dt.abs() <= 500.0) {
        return bad("delta_temp_k", dt, "|ΔT_w| ≤ 500 K");
    }
    let rho = match input.reference {
        ShrinkReference::Pitch => r,
        ShrinkReference::Radius(rho) => rho,
    };
    let rb = r * a.cos();
    if !(rho.is_finite() && rho >= rb) {
        return bad("reference radius ρ", rho, "ρ ≥ base radius r·cos α_t (mm)");
    }
    Ok(rho)
}

/// Exact radial offset δT in µm that makes the cooled tooth thickness right at ρ.
///
/// # Formula
/// δT(ρ) = (r / tan α_t)·[inv α*_ρ − inv α_ρ],
/// cos α_ρ = r·cos α_t / ρ,  cos α*_ρ = r·cos α_t / (ρ·(1 + λ·ΔT_w))
/// # Units
/// r, ρ in mm; result in µm.
/// # Source
/// CN105397560, eq. (7) [DERIVED: docs/geometry.md "Derivation: workpiece-shrink δT", checked
/// there against a rack-generation envelope to 1e-8 mm]; transverse section for helical gears [DERIVED]
pub fn shrink_offset_exact_um(input: &ShrinkInput) -> Result<f64, ShrinkError> {
    let rho = check(input)?;
    let r = input.reference_radius_mm;
    let a = input.transverse_pressure_angle_rad;
    let eps = input.expansion_per_k * input.delta_temp_k;
    let rb = r * a.cos();
    let a_rho = (rb / rho).clamp(-1.0, 1.0).acos();
    let c_star = rb / (rho * (1.0 + eps));
    if c_star > 1.0 {
        return Err(ShrinkError::InvalidInput {
            field: "delta_temp_k",
            value: input.delta_temp_k,
            expected: "a cooling that keeps the hot reference radius outside the base circle",
        });
    }
    let a_star = c_star.acos();
    Ok(1000.0 * r / a.tan() * (crate::involute::inv(a_star) - crate::involute::inv(a_rho)))
}

/// First-order radial offset δT in µm (linear in λ·ΔT_w).
///
/// # Formula
/// δT ≈ r·λ·ΔT_w·tan α_ρ / tan α_t  (at the pitch circle: r·λ·ΔT_w)
/// # Source
/// CN105397560, eq. (7), first-order form [DERIVED: docs/geometry.md "Derivation:
/// workpiece-shrink δT"]
pub fn shrink_offset_first_order_um(input: &ShrinkInput) -> Result<f64, ShrinkError> {
    let rho = check(input)?;
    let r = input.reference_radius_mm;
    let a = input.transverse_pressure_angle_rad;
    let a_rho = (r * a.cos() / rho).clamp(-1.0, 1.0).acos();
    let eps = input.expansion_per_k * input.delta_temp_k;
    Ok(1000.0 * r * eps * a_rho.tan() / a.tan())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// Gear G1 of docs/dressing.md (m_n 3, z 40, α_n 20°, β 15°), hand calculation with
    /// ISO 21771: r = 62.11657 mm, α_t = 20.64690°; the other inputs pass through.
    #[test]
    fn for_gear_builds_radius_and_transverse_angle() {
        let i = ShrinkInput::for_gear(
            3.0,
            40,
            20f64.to_radians(),
            15f64.to_radians(),
            11.5e-6,
            25.0,
            ShrinkReference::Radius(65.0),
        );
        assert!((i.reference_radius_mm - 62.11657).abs() < 1e-5);
        assert!((i.transverse_pressure_angle_rad.to_degrees() - 20.64690).abs() < 1e-5);
        assert_eq!(i.expansion_per_k, 11.5e-6);
        assert_eq!(i.delta_temp_k, 25.0);
        assert_eq!(i.reference, ShrinkReference::Radius(65.0));
        // A spur gear: r = m·z/2, α_t = α_n.
        let spur = ShrinkInput::for_gear(2.0, 25, 0.35, 0.0, 1e-5, 1.0, ShrinkReference::Pitch);
        assert_eq!(spur.reference_radius_mm, 25.0);
        assert!((spur.transverse_pressure_angle_rad - 0.35).abs() < 1e-15);
    }

    fn input(m: f64, z: f64, ra: Option<f64>, dt: f64) -> ShrinkInput {
        ShrinkInput {
            reference_radius_mm: m * z / 2.0,
            transverse_pressure_angle_rad: 20f64.to_radians(),
            expansion_per_k: 11.5e-6,
            delta_temp_k: dt,
            reference: ra.map_or(ShrinkReference::Pitch, ShrinkReference::Radius),
        }
    }

    /// Test vectors of docs/geometry.md "Derivation: workpiece-shrink δT" (CN105397560), checked
    /// against an independent rack-generation envelope simulation.
    #[test]
    fn seed003_vectors_pitch_and_tip() {
        let rows = [
            (3.0, 40.0, 63.0, 10.0, 6.9030, 6.9000, 9.4535),
            (3.0, 40.0, 63.0, 30.0, 20.7269, 20.7000, 28.3736),
            (3.0, 40.0, 63.0, 50.0, 34.5747, 34.5000, 47.3112),
            (2.0, 30.0, 32.0, 30.0, 10.3635, 10.3500, 15.2830),
            (4.0, 57.0, 118.0, 30.0, 39.3812, 39.3300, 49.9511),
        ];
        for (m, z, ra, dt, pitch, first, tip) in rows {
            let p = shrink_offset_exact_um(&input(m, z, None, dt)).unwrap();
            let f = shrink_offset_first_order_um(&input(m, z, None, dt)).unwrap();
            let t = shrink_offset_exact_um(&input(m, z, Some(ra), dt)).unwrap();
            assert!((p - pitch).abs() < 6e-5, "m={m} z={z} dT={dt}: pitch {p}");
            assert!((f - first).abs() < 6e-5, "first order {f}");
            assert!((t - tip).abs() < 6e-5, "m={m} z={z} dT={dt}: tip {t}");
        }
    }

    #[test]
    fn chain_vector_of_seed003() {
        // Ta = 53.0668 °C, Tb = 20 °C → δT_p = 22.8488 µm, δT_a = 31.2764 µm.
        let dt = 53.066_8 - 20.0;
        let p = shrink_offset_exact_um(&input(3.0, 40.0, None, dt)).unwrap();
        let t = shrink_offset_exact_um(&input(3.0, 40.0, Some(63.0), dt)).unwrap();
        assert!((p - 22.8488).abs() < 2e-4, "{p}");
        assert!((t - 31.2764).abs() < 2e-4, "{t}");
    }

    #[test]
    fn bad_inputs_name_the_field() {
        let mut i = input(3.0, 40.0, Some(50.0), 30.0);
        let e = shrink_offset_exact_um(&i).unwrap_err().to_string();
        assert!(e.contains("reference radius") && e.contains("50"), "{e}");
        i.reference = ShrinkReference::Pitch;
        i.expansion_per_k = -1.0;
        assert!(shrink_offset_exact_um(&i)
            .unwrap_err()
            .to_string()
            .contains("expansion_per_k"));
        i.expansion_per_k = f64::NAN;
        assert!(shrink_offset_first_order_um(&i).is_err());
    }
}
