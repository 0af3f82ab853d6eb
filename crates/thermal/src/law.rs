//! The compensation laws, one pure function per form, all in µm.
//!
//! The engine resolves channel names to indices once and calls these per cycle; they are
//! allocation-free and exposed so their arithmetic can be tested against the seeds.
//!
//! Sign convention (project-wide): a positive result increases the centre distance
//! between tool and workpiece; it is added to the scale reading (D′ = D + Cz) or to the
//! command (Z′ = Z + Cz).

use crate::units::{s_to_h, um_to_mm};

/// Cz = Kd·T + α.
///
/// # Formula
/// Cz = Kd·T + α
/// # Units
/// Kd in µm/°C, T in °C, α and Cz in µm.
/// # Source
/// JPH0761598B2, EDM embodiment, Cz = Kd·T + α [SEED]
pub fn linear_um(kd_um_per_c: f64, temp_c: f64, alpha_um: f64) -> f64 {
    kd_um_per_c * temp_c + alpha_um
}

/// Cz = Kz·(A − B).
///
/// # Formula
/// Cz = Kz·(A − B)
/// # Units
/// Kz in µm/°C, A and B in °C, Cz in µm.
/// # Source
/// JPH0761598B2, surface-grinder embodiment (the text's "K_g" is Kz) [SEED]
pub fn difference_um(kz_um_per_c: f64, a_c: f64, b_c: f64) -> f64 {
    kz_um_per_c * (a_c - b_c)
}

/// Cz = Kz·A − Kz·(b·t + c): B replaced by its near-linear rise after 2–3 h.
///
/// # Formula
/// Cz = Kz·A + f1(t),  f1(t) = −Kz·(b·t + c)
/// # Units
/// Kz in µm/°C, A in °C, b in °C/h, t in s (converted to h here), c in °C.
/// # Source
/// JPH0761598B2, approximation B = b·t + c [SEED]
pub fn time_linear_um(kz_um_per_c: f64, a_c: f64, b_c_per_h: f64, c_c: f64, t_s: f64) -> f64 {
    kz_um_per_c * a_c - kz_um_per_c * (b_c_per_h * s_to_h(t_s) + c_c)
}

/// Cz = Kz′·B + K·√t: A replaced by its √t rise.
///
/// # Formula
/// Cz = Kz′·B + f2(t),  f2(t) = K·√t,  Kz′ = −Kz
/// # Units
/// Kz′ in µm/°C, B in °C, K in µm/√h, t in s (converted to h here).
/// # Domain
/// t ≥ 0 (t < 0 is taken as 0).
/// # Source
/// JPH0761598B2, approximation A ∝ √t [SEED]
pub fn time_sqrt_um(kz_prime_um_per_c: f64, b_c: f64, k_um_per_sqrt_h: f64, t_s: f64) -> f64 {
    kz_prime_um_per_c * b_c + k_um_per_sqrt_h * s_to_h(t_s.max(0.0)).sqrt()
}

/// C = K·(value − midpoint): one component of EP0138375's total correction.
///
/// # Formula
/// C_P = K_P·(P̄ − X), C_B = K_B·(B̄ − Y), C_S = K_S·(S̄ − Z);  TC = C_P + C_S − C_B
/// # Units
/// K in µm per channel unit (µm/°C for thermistors; the lever ratio µm/µm for the
/// proximity transducer); value and midpoint in the channel unit.
/// # Source
/// EP0138375, Figs. 6–9 blocks 300/400/500/601 [RECONSTRUCTED: docs/thermal.md "Derivation:
/// EP0138375 Figs. 6–9 as implemented"]
pub fn component_um(k_um_per_unit: f64, value: f64, midpoint: f64) -> f64 {
    k_um_per_unit * (value - midpoint)
}

/// ΔK = K0(T) + tanβ(T)·(P − P0) with K0 and tanβ linear in T.
///
/// # Formula
/// K0(T) = K0_ref + dK0/dT·(T − T_ref),  tanβ(T) = tanβ_ref + dtanβ/dT·(T − T_ref),
/// ΔK = K0(T) + tanβ(T)·(P − P0)
/// # Units
/// K0 in µm, tanβ in µm/mm, T in °C, P and P0 in mm.
/// # Source
/// SINUMERIK 840D sl FM "Extended Functions" K3 §4.2 (SD43900/43910/43920); TwinCAT
/// CNC axis parameters P-AXIS-00272…00274 (temp_comp_position_0, _offset_0, _coefficient)
/// [VENDOR MANUAL]
#[allow(clippy::too_many_arguments)]
pub fn position_um(
    offset_um: f64,
    offset_um_per_c: f64,
    slope_um_per_mm: f64,
    slope_um_per_mm_per_c: f64,
    t_ref_c: f64,
    temp_c: f64,
    p_mm: f64,
    p0_mm: f64,
) -> f64 {
    let dt_k = temp_c - t_ref_c;
    (offset_um + offset_um_per_c * dt_k)
        + (slope_um_per_mm + slope_um_per_mm_per_c * dt_k) * (p_mm - p0_mm)
}

/// The corrected scale reading D′ = D + Cz.
///
/// # Formula
/// D′ = D + Cz
/// # Units
/// D, D′ in mm; Cz in µm.
/// # Source
/// JPH0761598B2, claim 1 [SEED]
pub fn measuring_system_reading_mm(d_mm: f64, cz_um: f64) -> f64 {
    d_mm + um_to_mm(cz_um)
}

/// The corrected command Z′ = Z + Cz.
///
/// # Formula
/// Z′ = Z + Cz
/// # Units
/// Z, Z′ in mm; Cz in µm.
/// # Source
/// JPH0761598B2, EDM embodiment [SEED]
pub fn command_position_mm(z_mm: f64, cz_um: f64) -> f64 {
    z_mm + um_to_mm(cz_um)
}

/// Pulses for a change of offset, carrying the rounding remainder.
///
/// # Formula
/// x = Δ/p + r;  n = round(x);  r ← x − n   (|r| ≤ ½ pulse, so Σn·p tracks ΣΔ within ½ p)
/// # Units
/// Δ and p in µm; r in pulses.
/// # Source
/// EP0138375, Fig. 9 blocks 606–608 [SEED]; remainder carry [RECONSTRUCTED: docs/thermal.md
/// "Derivation: EP0138375 Figs. 6–9 as implemented"]
pub fn pulses_with_carry(delta_um: f64, pulse_um: f64, carry_pulses: &mut f64) -> i64 {
    let x = delta_um / pulse_um + *carry_pulses;
    let n = x.round();
    *carry_pulses = x - n;
    // An offset is bounded by max_offset_um, so n fits i64 by a wide margin.
    n as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// docs/thermal.md "JPH0761598B2 arithmetic".
    #[test]
    fn seed001_arithmetic() {
        let cz = difference_um(-3.75, 24.0, 20.0);
        assert!((cz - -15.0).abs() < 1e-12);
        assert!((measuring_system_reading_mm(100.000, cz) - 99.985).abs() < 1e-12);
        let cz = linear_um(-2.0, 23.0, 40.0);
        assert!((cz - -6.0).abs() < 1e-12);
        assert!((command_position_mm(-5.000, cz) - -5.006).abs() < 1e-12);
    }

    /// With B = b·t + c exactly, the f1(t) form equals the two-sensor law; with
    /// A = A0 + a·√t exactly and Kz′ = −Kz, the f2(t) form equals it up to Kz·A0.
    #[test]
    fn seed001_time_forms_reduce_to_two_sensor_law() {
        let (kz, b, c) = (-3.75, 0.4, 21.0);
        for t_h in [0.0, 2.5, 6.0, 12.0] {
            let t_s = t_h * 3600.0;
            let a = 20.0 + 0.7 * t_h;
            let b_temp = b * t_h + c;
            let two = difference_um(kz, a, b_temp);
            assert!((time_linear_um(kz, a, b, c, t_s) - two).abs() < 1e-9);
            let a_sqrt = 20.0 + 1.3 * t_h.sqrt();
            let two = difference_um(kz, a_sqrt, b_temp);
            let f2 = time_sqrt_um(-kz, b_temp, kz * 1.3, t_s) + kz * 20.0;
            assert!((f2 - two).abs() < 1e-9);
        }
    }

    #[test]
    fn position_term_is_sinumerik_error_line() {
        // K0 = 5 µm + 0.5 µm/°C·(T − 20); tanβ = 10 µm/m = 0.01 µm/mm at 20 °C.
        let v = position_um(5.0, 0.5, 0.01, 0.0, 20.0, 24.0, 500.0, 100.0);
        assert!((v - (7.0 + 4.0)).abs() < 1e-12);
    }
}
