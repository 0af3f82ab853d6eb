//! The dressed worm as a grinding worm: a tabulated profile modification f_nFS(w) of the worm
//! flank (as the dressing module computes it for constant axis corrections ΔK) turned into the
//! transverse worm modification f_Ft1(w1, z1) that the grinding simulation and the analytic
//! map use.
//!
//! The table type lives here so that this crate does not depend on `gearcomp-dressing`; the
//! glue (dress, tabulate, fit the contact line) is in `gearcomp grind` (`cmd_grind.rs`).
//! Conventions (`docs/grinding.md`, "Dressed worm"):
//! - roll distance: the same w = √(r² − r_b²) on both sides (same helicoid, same r_b);
//! - width: the dressing crate's axial coordinate b of a flank point is the grinding crate's
//!   z1 (both measure along the worm axis; the angular origins η differ, which does not matter
//!   for a constant-ΔK profile because it is invariant under the worm's screw motion);
//! - flank: for a right-hand worm the dressing crate's `Right` (outward normal towards +z) is
//!   this crate's `Right` (s = +1, N·e_z = sin β_b > 0);
//! - sign: both measure along the outward normal, > 0 = material left;
//! - size: the dressing crate gives f_nFS in mm (normal), this crate uses f_Ft1 in mm
//!   (transverse): f_Ft1 = f_nFS / cos β_b1 (eq. (38)).

use serde::{Deserialize, Serialize};

use crate::contact::WormGearPair;
use crate::error::{check_range, GrindError, Result};
use crate::flank::{Flank, InvoluteFlank};
use crate::modification::FlankModification;

/// A worm flank's profile modification tabulated over roll distance, as dressed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DressedProfile {
    /// Flank of the worm the table belongs to.
    pub flank: Flank,
    /// Base radius r_b1 of the helicoid the profile was dressed on (mm).
    pub r_b_mm: f64,
    /// Base helix angle β_b1 of that helicoid (rad, signed, > 0 right hand).
    pub beta_b_rad: f64,
    /// Roll distances of the table, strictly increasing (mm).
    pub w_mm: Vec<f64>,
    /// Normal profile modification f_nFS at each roll distance (mm, > 0 = material left).
    pub f_n_mm: Vec<f64>,
    /// Roll-distance range that the dresser actually dressed, [w_Nf, w_Na] (mm).
    pub dressed_range_mm: (f64, f64),
    /// Direction ρ_F1 of the dresser contact line on the worm, eq. (37) (rad).
    pub rho_f1_rad: f64,
}

impl DressedProfile {
    /// A validated table.
    ///
    /// # Domain
    /// At least 4 points, w strictly increasing and ≥ 0, |f_n| ≤ 1 mm, the dressed range inside
    /// the table, r_b > 0, |β_b| < 90°.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        flank: Flank,
        r_b_mm: f64,
        beta_b_rad: f64,
        w_mm: Vec<f64>,
        f_n_mm: Vec<f64>,
        dressed_range_mm: (f64, f64),
        rho_f1_rad: f64,
    ) -> Result<Self> {
        check_range("dressed r_b_mm", r_b_mm, 1e-6, 1e6, "0 < r_b ≤ 1e6 mm")?;
        let right_angle = std::f64::consts::FRAC_PI_2 - 1e-6;
        check_range(
            "dressed beta_b_rad",
            beta_b_rad,
            -right_angle,
            right_angle,
            "|β_b| < 90°",
        )?;
        check_range("rho_f1_rad", rho_f1_rad, -3.2, 3.2, "-π ..= π")?;
        if w_mm.len() < 4 || w_mm.len() != f_n_mm.len() {
            return Err(GrindError::BadData {
                field: "dressed profile table",
                got: w_mm.len().min(f_n_mm.len()),
                expected: "at least 4 (w, f_n) pairs of equal length",
            });
        }
        for (i, (&w, &f)) in w_mm.iter().zip(&f_n_mm).enumerate() {
            check_range("dressed profile w_mm", w, 0.0, 1e6, "0 ≤ w ≤ 1e6 mm")?;
            check_range("dressed profile f_n_mm", f, -1.0, 1.0, "|f_n| ≤ 1 mm")?;
            if i > 0 && w <= w_mm[i - 1] {
                return Err(GrindError::OutOfRange {
                    field: "dressed profile w_mm",
                    value: w,
                    expected: "strictly increasing roll distances",
                });
            }
        }
        let (lo, hi) = (w_mm[0], w_mm[w_mm.len() - 1]);
        check_range(
            "dressed_range start (w_Nf)",
            dressed_range_mm.0,
            lo,
            hi,
            "inside the tabulated roll distances",
        )?;
        check_range(
            "dressed_range end (w_Na)",
            dressed_range_mm.1,
            dressed_range_mm.0,
            hi,
            "w_Nf ≤ w_Na ≤ last tabulated roll distance",
        )?;
        Ok(Self {
            flank,
            r_b_mm,
            beta_b_rad,
            w_mm,
            f_n_mm,
            dressed_range_mm,
            rho_f1_rad,
        })
    }

    /// Radius range [r_Nf, r_Na] that the dresser dressed (mm), r = √(r_b² + w²).
    pub fn dressed_radius_range_mm(&self) -> (f64, f64) {
        let r = |w: f64| (self.r_b_mm * self.r_b_mm + w * w).sqrt();
        (r(self.dressed_range_mm.0), r(self.dressed_range_mm.1))
    }
}

/// A natural cubic spline through (x_i, y_i), extended linearly beyond the ends (C¹).
#[derive(Debug, Clone, PartialEq)]
struct Spline {
    x: Vec<f64>,
    y: Vec<f64>,
    /// Second derivatives at the knots.
    m: Vec<f64>,
}

impl Spline {
    /// Natural spline (m_0 = m_{n−1} = 0) by the tridiagonal (Thomas) algorithm.
    ///
    /// # Formula
    /// h_{i−1}·m_{i−1} + 2(h_{i−1} + h_i)·m_i + h_i·m_{i+1} = 6·(Δy_i/h_i − Δy_{i−1}/h_{i−1})
    /// # Source
    /// Standard natural cubic spline (de Boor, A Practical Guide to Splines, ch. IV) [STANDARD].
    fn natural(x: &[f64], y: &[f64]) -> Self {
        let n = x.len();
        let mut m = vec![0.0; n];
        if n > 2 {
            let mut c = vec![0.0; n];
            let mut d = vec![0.0; n];
            for i in 1..n - 1 {
                let h0 = x[i] - x[i - 1];
                let h1 = x[i + 1] - x[i];
                let a = h0;
                let b = 2.0 * (h0 + h1);
                let r = 6.0 * ((y[i + 1] - y[i]) / h1 - (y[i] - y[i - 1]) / h0);
                let denom = b - a * c[i - 1];
                c[i] = h1 / denom;
                d[i] = (r - a * d[i - 1]) / denom;
            }
            for i in (1..n - 1).rev() {
                m[i] = d[i] - c[i] * m[i + 1];
            }
        }
        Self {
            x: x.to_vec(),
            y: y.to_vec(),
            m,
        }
    }

    /// (value, first derivative) at t; no allocation.
    #[inline]
    fn eval(&self, t: f64) -> (f64, f64) {
        let n = self.x.len();
        let (x0, xn) = (self.x[0], self.x[n - 1]);
        if t <= x0 {
            let (_, d) = self.segment(0, x0);
            return (self.y[0] + d * (t - x0), d);
        }
        if t >= xn {
            let (_, d) = self.segment(n - 2, xn);
            return (self.y[n - 1] + d * (t - xn), d);
        }
        let i = self.x.partition_point(|&v| v <= t).clamp(1, n - 1) - 1;
        self.segment(i, t)
    }

    #[inline]
    fn segment(&self, i: usize, t: f64) -> (f64, f64) {
        let h = self.x[i + 1] - self.x[i];
        let a = (self.x[i + 1] - t) / h;
        let b = (t - self.x[i]) / h;
        let (m0, m1) = (self.m[i], self.m[i + 1]);
        let v = a * self.y[i]
            + b * self.y[i + 1]
            + ((a * a * a - a) * m0 + (b * b * b - b) * m1) * h * h / 6.0;
        let d = (self.y[i + 1] - self.y[i]) / h
            + (-(3.0 * a * a - 1.0) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
        (v, d)
    }
}

/// Refuses a dressed table whose helicoid is not the grinding worm's: the flank must be the
/// same and r_b, β_b must agree to 1e-9 relative (a table dressed on another worm would be
/// mapped onto the wrong flank geometry). `fields` names flank, r_b and β_b in the error.
pub(crate) fn check_same_helicoid(
    fields: [&'static str; 3],
    (flank, r_b_mm, beta_b_rad): (Flank, f64, f64),
    worm: &InvoluteFlank,
) -> Result<()> {
    if flank != worm.flank {
        return Err(GrindError::OutOfRange {
            field: fields[0],
            value: flank.sign(),
            expected: "the flank being ground (+1 right, −1 left)",
        });
    }
    let rel = |a: f64, b: f64| ((a - b) / b).abs();
    if rel(r_b_mm, worm.r_b_mm) > 1e-9 {
        return Err(GrindError::OutOfRange {
            field: fields[1],
            value: r_b_mm,
            expected: "the grinding worm's base radius (same helicoid, 1e-9 relative)",
        });
    }
    if rel(beta_b_rad, worm.beta_b_rad) > 1e-9 {
        return Err(GrindError::OutOfRange {
            field: fields[2],
            value: beta_b_rad,
            expected: "the grinding worm's base helix angle (same helicoid, 1e-9 relative)",
        });
    }
    Ok(())
}

/// A dressed worm flank used as a grinding worm: f_Ft1(w1, z1) = f_nFS(w1)/cos β_b1, the same
/// on every thread and at every width position (constant ΔK).
#[derive(Debug, Clone, PartialEq)]
pub struct DressedWorm {
    profile: DressedProfile,
    spline: Spline,
    inv_cos_beta_b: f64,
}

impl DressedWorm {
    /// The dressed profile `profile` on the grinding worm flank `worm`.
    ///
    /// The table must have been dressed on the same helicoid: r_b and β_b must agree to
    /// 1e-9 relative, and the flank must be the same.
    pub fn new(profile: DressedProfile, worm: &InvoluteFlank) -> Result<Self> {
        check_same_helicoid(
            [
                "dressed profile flank",
                "dressed r_b_mm",
                "dressed beta_b_rad",
            ],
            (profile.flank, profile.r_b_mm, profile.beta_b_rad),
            worm,
        )?;
        let spline = Spline::natural(&profile.w_mm, &profile.f_n_mm);
        Ok(Self {
            inv_cos_beta_b: 1.0 / worm.beta_b_rad.cos(),
            profile,
            spline,
        })
    }

    /// The table this worm was built from.
    pub fn profile(&self) -> &DressedProfile {
        &self.profile
    }

    /// Normal modification f_n1 = f_nFS(w1) in mm (interpolated).
    pub fn f_n_mm(&self, w1_mm: f64) -> f64 {
        self.spline.eval(w1_mm).0
    }

    /// Direction ρ_F1 of the dresser contact line (37), the worm line direction for the
    /// diagonal-ratio computations.
    pub fn rho_f1_rad(&self) -> f64 {
        self.profile.rho_f1_rad
    }

    /// Worm roll distances [w1_min, w1_max] that grind gear roll distances `w2_range_mm` on
    /// `pair`, from (R7) w1 = a·w2 + b.
    ///
    /// # Source
    /// JP6903407B2 (45); docs/grinding.md "Derivation: contact path and roll-distance relation"
    /// [RECONSTRUCTED, VERIFIED].
    pub fn used_roll_range_mm(pair: &WormGearPair, w2_range_mm: (f64, f64)) -> (f64, f64) {
        let a = pair.path.a * w2_range_mm.0 + pair.path.b_mm;
        let b = pair.path.a * w2_range_mm.1 + pair.path.b_mm;
        (a.min(b), a.max(b))
    }

    /// Checks that the worm roll distances used for gear roll distances `w2_range_mm` lie where
    /// the dresser dressed ([w_Nf, w_Na], with 1e-6 mm slack).
    pub fn check_covers(&self, pair: &WormGearPair, w2_range_mm: (f64, f64)) -> Result<()> {
        let (lo, hi) = Self::used_roll_range_mm(pair, w2_range_mm);
        let (nf, na) = self.profile.dressed_range_mm;
        let expected = "inside the dressed worm profile [w_Nf, w_Na] (shorten the gear's roll \
                        range or use a larger worm)";
        if lo < nf - 1e-6 {
            return Err(GrindError::OutOfRange {
                field: "worm roll distance used (w1 at the gear's roll end)",
                value: lo,
                expected,
            });
        }
        if hi > na + 1e-6 {
            return Err(GrindError::OutOfRange {
                field: "worm roll distance used (w1 at the gear's roll start)",
                value: hi,
                expected,
            });
        }
        Ok(())
    }
}

impl FlankModification for DressedWorm {
    /// # Formula
    /// f_Ft1(w1, z1) = f_nFS(w1)/cos β_b1 (38); independent of z1 for constant ΔK.
    /// # Source
    /// JP6903407B2, eq. (38) [SEED]; JP6903407B2 part 1, dressed worm profile [SEED].
    #[inline]
    fn f_ft_mm(&self, w_mm: f64, _z_mm: f64) -> f64 {
        self.spline.eval(w_mm).0 * self.inv_cos_beta_b
    }

    #[inline]
    fn gradient(&self, w_mm: f64, _z_mm: f64) -> (f64, f64) {
        (self.spline.eval(w_mm).1 * self.inv_cos_beta_b, 0.0)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::flank::{Hand, InvoluteGear};
    use proptest::prelude::*;

    fn worm_flank() -> InvoluteFlank {
        InvoluteGear::worm(1, 3.0, 20f64.to_radians(), 130.0, Hand::Right)
            .unwrap()
            .flank(Flank::Right)
    }

    fn table(f: impl Fn(f64) -> f64, n: usize) -> DressedProfile {
        let wf = worm_flank();
        let w: Vec<f64> = (0..n)
            .map(|i| 126.0 + 7.0 * i as f64 / (n - 1) as f64)
            .collect();
        let y = w.iter().map(|&x| f(x)).collect();
        DressedProfile::new(
            Flank::Right,
            wf.r_b_mm,
            wf.beta_b_rad,
            w,
            y,
            (126.5, 132.9),
            0.35,
        )
        .unwrap()
    }

    /// A natural cubic spline reproduces a straight line exactly (its second derivatives
    /// vanish), and a cubic to O(h⁴) away from the ends.
    #[test]
    fn spline_reproduces_lines_and_converges_on_smooth_data() {
        let wf = worm_flank();
        let line = DressedWorm::new(table(|w| 1e-3 * (w - 129.0), 5), &wf).unwrap();
        for w in [125.0, 126.3, 129.7, 133.0, 134.0] {
            assert!((line.f_n_mm(w) - 1e-3 * (w - 129.0)).abs() < 1e-15);
        }
        let c = |w: f64| 2e-4 * (w - 129.5).powi(2);
        let coarse = DressedWorm::new(table(c, 15), &wf).unwrap();
        let fine = DressedWorm::new(table(c, 57), &wf).unwrap();
        let err = |d: &DressedWorm| {
            (0..50)
                .map(|i| 128.0 + 3.0 * i as f64 / 49.0)
                .map(|w| (d.f_n_mm(w) - c(w)).abs())
                .fold(0.0, f64::max)
        };
        assert!(err(&fine) < 1e-8 && err(&fine) < err(&coarse) / 50.0);
    }

    /// (38): the transverse value is the normal one over cos β_b1 (0.342192 for the reference
    /// worm, docs/grinding.md "Independent reference: reference example"), the gradient along w is
    /// the spline slope, none along z.
    #[test]
    fn normal_to_transverse_38() {
        let wf = worm_flank();
        let d = DressedWorm::new(table(|_| 1.4095e-3, 6), &wf).unwrap();
        assert!((d.f_ft_mm(129.0, 7.0) - 1.4095e-3 / 0.342192).abs() < 1e-8);
        let s = DressedWorm::new(table(|w| 1e-3 * w, 6), &wf).unwrap();
        let (gw, gz) = s.gradient(130.0, -3.0);
        assert!((gw - 1e-3 / wf.beta_b_rad.cos()).abs() < 1e-14 && gz == 0.0);
    }

    #[test]
    fn bad_tables_are_rejected() {
        let wf = worm_flank();
        let ok = table(|_| 0.0, 5);
        let mut t = ok.clone();
        t.w_mm.swap(1, 2);
        assert!(DressedProfile::new(
            t.flank,
            t.r_b_mm,
            t.beta_b_rad,
            t.w_mm,
            t.f_n_mm,
            t.dressed_range_mm,
            0.0
        )
        .is_err());
        assert!(DressedProfile::new(
            Flank::Right,
            wf.r_b_mm,
            wf.beta_b_rad,
            vec![1.0, 2.0, 3.0],
            vec![0.0; 3],
            (1.0, 3.0),
            0.0
        )
        .is_err());
        let mut other = ok.clone();
        other.r_b_mm *= 1.001;
        assert!(DressedWorm::new(other, &wf).is_err());
        let mut left = ok;
        left.flank = Flank::Left;
        assert!(DressedWorm::new(left, &wf).is_err());
    }

    proptest! {
        /// No panic and a finite value anywhere, including far outside the table.
        #[test]
        fn evaluation_is_total(w in -1e4f64..1e4, a in -1e-2f64..1e-2, b in -1e-3f64..1e-3) {
            let wf = worm_flank();
            let d = DressedWorm::new(table(|x| a + b * (x - 129.0).powi(2), 9), &wf).unwrap();
            prop_assert!(d.f_ft_mm(w, 0.0).is_finite());
            prop_assert!(d.gradient(w, 0.0).0.is_finite());
        }
    }
}
