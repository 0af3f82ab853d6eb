//! A topologically dressed worm as a grinding worm: the width-dependent normal modification
//! f_nFS(w, b) of one worm flank (a grid, as the dressing module's `WormTopology` holds it)
//! turned into the transverse worm modification f_Ft1(w1, z1) for diagonal generating grinding,
//! where the contact path sweeps the worm width as the feeds move.
//!
//! Conventions (`docs/grinding.md`, "Topologically dressed worm"):
//! - w ↔ w1 (same helicoid, same roll distance), b ↔ z1 (both the axial coordinate of the flank
//!   point from the same axial datum on the worm; the angular origin is set by the thread, so a
//!   different η of the two crates is a rotation of the worm's body frame, not a shift of the
//!   topology);
//! - f_Ft1(w1, z1) = f_nFS(w1, z1)/cos β_b1 (38); mm, > 0 = material left.
//!
//! The interpolation is a piecewise bicubic Hermite surface whose node derivatives are the
//! three-point differences of the grid: C¹ (the envelope simulation's Newton solves use the
//! gradient) and exact for any function quadratic in w and quadratic in b.

use serde::{Deserialize, Serialize};

use crate::contact::WormGearPair;
use crate::error::{check_range, GrindError, Result};
use crate::flank::{Flank, InvoluteFlank};
use crate::kinematics::FeedCoupling;
use crate::modification::FlankModification;

/// A worm flank's topological modification f_nFS(w, b) on a grid, as dressed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DressedTopology {
    /// Flank of the worm the grid belongs to.
    pub flank: Flank,
    /// Base radius r_b1 of the helicoid the worm was dressed on (mm).
    pub r_b_mm: f64,
    /// Base helix angle β_b1 of that helicoid (rad, signed, > 0 right hand).
    pub beta_b_rad: f64,
    /// Roll distances of the rows, strictly increasing (mm).
    pub w_mm: Vec<f64>,
    /// Width (axial) positions of the columns, strictly increasing (mm).
    pub b_mm: Vec<f64>,
    /// f_nFS per node, row-major [i_w·n_b + i_b] (mm, > 0 = material left).
    pub f_n_mm: Vec<f64>,
    /// Direction ρ_F1 of the dresser contact line on the worm, eq. (37) (rad).
    pub rho_f1_rad: f64,
}

fn check_axis(field: &'static str, v: &[f64]) -> Result<()> {
    if v.len() < 3 {
        return Err(GrindError::BadData {
            field,
            got: v.len(),
            expected: "at least 3 grid positions",
        });
    }
    for (i, &x) in v.iter().enumerate() {
        check_range(field, x, -1e6, 1e6, "finite, |value| ≤ 1e6 mm")?;
        if i > 0 && x <= v[i - 1] {
            return Err(GrindError::OutOfRange {
                field,
                value: x,
                expected: "strictly increasing grid positions",
            });
        }
    }
    Ok(())
}

impl DressedTopology {
    /// A validated grid.
    ///
    /// # Domain
    /// At least 3 × 3 nodes, both axes strictly increasing, w ≥ 0, |f_n| ≤ 1 mm,
    /// n_w·n_b values, r_b > 0, |β_b| < 90°.
    pub fn new(
        flank: Flank,
        r_b_mm: f64,
        beta_b_rad: f64,
        (w_mm, b_mm): (Vec<f64>, Vec<f64>),
        f_n_mm: Vec<f64>,
        rho_f1_rad: f64,
    ) -> Result<Self> {
        check_range("topology r_b_mm", r_b_mm, 1e-6, 1e6, "0 < r_b ≤ 1e6 mm")?;
        let right_angle = std::f64::consts::FRAC_PI_2 - 1e-6;
        check_range(
            "topology beta_b_rad",
            beta_b_rad,
            -right_angle,
            right_angle,
            "|β_b| < 90°",
        )?;
        check_range("rho_f1_rad", rho_f1_rad, -3.2, 3.2, "-π ..= π")?;
        check_axis("topology w_mm", &w_mm)?;
        check_axis("topology b_mm", &b_mm)?;
        check_range("topology w_mm (first)", w_mm[0], 0.0, 1e6, "w ≥ 0")?;
        if f_n_mm.len() != w_mm.len() * b_mm.len() {
            return Err(GrindError::BadData {
                field: "topology f_n_mm",
                got: f_n_mm.len(),
                expected: "n_w·n_b values, row-major (one row per roll distance)",
            });
        }
        for &f in &f_n_mm {
            check_range("topology f_n_mm", f, -1.0, 1.0, "|f_n| ≤ 1 mm")?;
        }
        Ok(Self {
            flank,
            r_b_mm,
            beta_b_rad,
            w_mm,
            b_mm,
            f_n_mm,
            rho_f1_rad,
        })
    }
}

/// Three-point derivative weights at node i of the strictly increasing knots x (n ≥ 3): the
/// derivative of the parabola through the node and its two neighbours (one-sided at the ends).
///
/// # Formula
/// interior, h0 = x_i − x_{i−1}, h1 = x_{i+1} − x_i:
/// f′ = −h1/(h0(h0+h1))·f_{i−1} + (h1−h0)/(h0h1)·f_i + h0/(h1(h0+h1))·f_{i+1};
/// the ends use the same parabola through the first (last) three nodes.
/// # Source
/// Lagrange three-point differentiation on a non-uniform grid (Fornberg, Math. Comp. 51
/// (1988)) [STANDARD].
fn three_point(x: &[f64], i: usize) -> ([usize; 3], [f64; 3]) {
    let n = x.len();
    let c = i.clamp(1, n - 2);
    let (x0, x1, x2) = (x[c - 1], x[c], x[c + 1]);
    let t = x[i];
    // derivative of the Lagrange basis polynomials at t
    let l0 = ((t - x1) + (t - x2)) / ((x0 - x1) * (x0 - x2));
    let l1 = ((t - x0) + (t - x2)) / ((x1 - x0) * (x1 - x2));
    let l2 = ((t - x0) + (t - x1)) / ((x2 - x0) * (x2 - x1));
    ([c - 1, c, c + 1], [l0, l1, l2])
}

/// Hermite basis (h00, h10, h01, h11) and their derivatives at t ∈ [0, 1].
#[inline]
fn hermite(t: f64) -> ([f64; 4], [f64; 4]) {
    let t2 = t * t;
    let t3 = t2 * t;
    (
        [
            2.0 * t3 - 3.0 * t2 + 1.0,
            t3 - 2.0 * t2 + t,
            -2.0 * t3 + 3.0 * t2,
            t3 - t2,
        ],
        [
            6.0 * t2 - 6.0 * t,
            3.0 * t2 - 4.0 * t + 1.0,
            -6.0 * t2 + 6.0 * t,
            3.0 * t2 - 2.0 * t,
        ],
    )
}

/// Cell index and clamped position of x in the knots.
#[inline]
fn locate(x: &[f64], t: f64) -> (usize, f64) {
    let n = x.len();
    let tc = t.clamp(x[0], x[n - 1]);
    let i = x.partition_point(|&v| v <= tc).clamp(1, n - 1) - 1;
    (i, tc)
}

/// A topologically dressed worm flank used as a grinding worm:
/// f_Ft1(w1, z1) = f_nFS(w1, b = z1)/cos β_b1.
#[derive(Debug, Clone, PartialEq)]
pub struct TopologicalWorm {
    table: DressedTopology,
    /// ∂f/∂w, ∂f/∂b and ∂²f/∂w∂b at the nodes (three-point differences), row-major.
    f_w: Vec<f64>,
    f_b: Vec<f64>,
    f_wb: Vec<f64>,
    inv_cos_beta_b: f64,
}

impl TopologicalWorm {
    /// The dressed topology `table` on the grinding worm flank `worm`.
    ///
    /// The grid must have been dressed on the same helicoid: r_b and β_b must agree to 1e-9
    /// relative, and the flank must be the same.
    pub fn new(table: DressedTopology, worm: &InvoluteFlank) -> Result<Self> {
        crate::dressed::check_same_helicoid(
            ["topology flank", "topology r_b_mm", "topology beta_b_rad"],
            (table.flank, table.r_b_mm, table.beta_b_rad),
            worm,
        )?;
        let (nw, nb) = (table.w_mm.len(), table.b_mm.len());
        let f = &table.f_n_mm;
        let mut f_w = vec![0.0; nw * nb];
        let mut f_b = vec![0.0; nw * nb];
        for i in 0..nw {
            let (iw, cw) = three_point(&table.w_mm, i);
            for j in 0..nb {
                let (ib, cb) = three_point(&table.b_mm, j);
                f_w[i * nb + j] = (0..3).map(|k| cw[k] * f[iw[k] * nb + j]).sum();
                f_b[i * nb + j] = (0..3).map(|k| cb[k] * f[i * nb + ib[k]]).sum();
            }
        }
        let mut f_wb = vec![0.0; nw * nb];
        for i in 0..nw {
            for j in 0..nb {
                let (ib, cb) = three_point(&table.b_mm, j);
                f_wb[i * nb + j] = (0..3).map(|k| cb[k] * f_w[i * nb + ib[k]]).sum();
            }
        }
        Ok(Self {
            inv_cos_beta_b: 1.0 / worm.beta_b_rad.cos(),
            table,
            f_w,
            f_b,
            f_wb,
        })
    }

    /// The grid this worm was built from.
    pub fn table(&self) -> &DressedTopology {
        &self.table
    }

    /// Direction ρ_F1 of the dresser contact line (37).
    pub fn rho_f1_rad(&self) -> f64 {
        self.table.rho_f1_rad
    }

    /// Normal modification f_n1(w1, b) in mm and its gradient (∂/∂w, ∂/∂b); no allocation.
    ///
    /// # Formula
    /// In the cell [w_i, w_i+1] × [b_j, b_j+1], u = (w − w_i)/h_w, v = (b − b_j)/h_b:
    /// f = Σ_corners [H0(u)H0(v)·f + h_w·H1(u)H0(v)·f_w + h_b·H0(u)H1(v)·f_b
    ///     + h_w·h_b·H1(u)H1(v)·f_wb] with the cubic Hermite basis H; node derivatives by
    /// three-point differences (exact for quadratics). Outside the grid: the value at the
    /// nearest boundary point plus its gradient times the offset (C¹ linear extension).
    /// # Source
    /// Bicubic Hermite interpolation (de Boor, A Practical Guide to Splines, ch. XVII)
    /// [STANDARD].
    #[inline]
    pub fn f_n_and_gradient(&self, w_mm: f64, b_mm: f64) -> (f64, f64, f64) {
        let t = &self.table;
        let nb = t.b_mm.len();
        let (i, wc) = locate(&t.w_mm, w_mm);
        let (j, bc) = locate(&t.b_mm, b_mm);
        let hw = t.w_mm[i + 1] - t.w_mm[i];
        let hb = t.b_mm[j + 1] - t.b_mm[j];
        let (pu, du) = hermite((wc - t.w_mm[i]) / hw);
        let (pv, dv) = hermite((bc - t.b_mm[j]) / hb);
        let (mut f, mut gw, mut gb) = (0.0, 0.0, 0.0);
        for a in 0..2 {
            // value and slope basis of this corner along u: (h00, h10) for a = 0, (h01, h11)
            let (u0, u1, du0, du1) = (pu[2 * a], pu[2 * a + 1], du[2 * a], du[2 * a + 1]);
            for c in 0..2 {
                let (v0, v1, dv0, dv1) = (pv[2 * c], pv[2 * c + 1], dv[2 * c], dv[2 * c + 1]);
                let k = (i + a) * nb + j + c;
                let (fv, fw, fb, fwb) = (t.f_n_mm[k], self.f_w[k], self.f_b[k], self.f_wb[k]);
                f += u0 * v0 * fv + hw * u1 * v0 * fw + hb * u0 * v1 * fb + hw * hb * u1 * v1 * fwb;
                gw += (du0 * v0 * fv
                    + hw * du1 * v0 * fw
                    + hb * du0 * v1 * fb
                    + hw * hb * du1 * v1 * fwb)
                    / hw;
                gb += (u0 * dv0 * fv
                    + hw * u1 * dv0 * fw
                    + hb * u0 * dv1 * fb
                    + hw * hb * u1 * dv1 * fwb)
                    / hb;
            }
        }
        (f + gw * (w_mm - wc) + gb * (b_mm - bc), gw, gb)
    }

    /// Normal modification f_n1(w1, b) in mm (interpolated).
    pub fn f_n_mm(&self, w_mm: f64, b_mm: f64) -> f64 {
        self.f_n_and_gradient(w_mm, b_mm).0
    }

    /// Worm region [w1_min, w1_max] × [z1_min, z1_max] that grinds the gear region
    /// `w2_range_mm` × `z2_range_mm` under `coupling` (analytic map at the four corners and
    /// mid-edges; for a constant diagonal ratio the map is affine, so the corners bound it).
    ///
    /// # Source
    /// docs/grinding.md "Derivation: diagonal ratio and line map" [RECONSTRUCTED].
    pub fn used_region_mm(
        pair: &WormGearPair,
        coupling: &FeedCoupling,
        w2_range_mm: (f64, f64),
        z2_range_mm: (f64, f64),
    ) -> ((f64, f64), (f64, f64)) {
        let mut w = (f64::INFINITY, f64::NEG_INFINITY);
        let mut z = (f64::INFINITY, f64::NEG_INFINITY);
        for p in 0..3 {
            for q in 0..3 {
                let w2 = w2_range_mm.0 + 0.5 * f64::from(p) * (w2_range_mm.1 - w2_range_mm.0);
                let z2 = z2_range_mm.0 + 0.5 * f64::from(q) * (z2_range_mm.1 - z2_range_mm.0);
                let m = pair.map_gear_point(coupling, w2, z2);
                w = (w.0.min(m.w1_mm), w.1.max(m.w1_mm));
                z = (z.0.min(m.z1_mm), z.1.max(m.z1_mm));
            }
        }
        (w, z)
    }

    /// Checks that the worm region used for the gear region lies inside the dressed grid
    /// (1e-6 mm slack): the roll distances for the profile, the width positions for the
    /// diagonal shift (z_V01 selects where on the worm).
    pub fn check_covers(
        &self,
        pair: &WormGearPair,
        coupling: &FeedCoupling,
        w2_range_mm: (f64, f64),
        z2_range_mm: (f64, f64),
    ) -> Result<()> {
        let ((wl, wh), (zl, zh)) = Self::used_region_mm(pair, coupling, w2_range_mm, z2_range_mm);
        let t = &self.table;
        let (w0, w1) = (t.w_mm[0], t.w_mm[t.w_mm.len() - 1]);
        let (b0, b1) = (t.b_mm[0], t.b_mm[t.b_mm.len() - 1]);
        for (field, v, ok) in [
            ("worm roll distance used (w1 min)", wl, wl >= w0 - 1e-6),
            ("worm roll distance used (w1 max)", wh, wh <= w1 + 1e-6),
            ("worm width position used (z1 min)", zl, zl >= b0 - 1e-6),
            ("worm width position used (z1 max)", zh, zh <= b1 + 1e-6),
        ] {
            if !ok {
                return Err(GrindError::OutOfRange {
                    field,
                    value: v,
                    expected: "inside the dressed worm topology grid (shorten the gear region, \
                               change the shift offset z_V01 or dress a wider worm region)",
                });
            }
        }
        Ok(())
    }
}

impl FlankModification for TopologicalWorm {
    /// # Formula
    /// f_Ft1(w1, z1) = f_nFS(w1, b = z1)/cos β_b1 (38).
    /// # Source
    /// JP6903407B2, eq. (38) [SEED]; JP6903407B2 part 1, topological modifications [SEED].
    #[inline]
    fn f_ft_mm(&self, w_mm: f64, z_mm: f64) -> f64 {
        self.f_n_and_gradient(w_mm, z_mm).0 * self.inv_cos_beta_b
    }

    #[inline]
    fn gradient(&self, w_mm: f64, z_mm: f64) -> (f64, f64) {
        let (_, gw, gb) = self.f_n_and_gradient(w_mm, z_mm);
        (gw * self.inv_cos_beta_b, gb * self.inv_cos_beta_b)
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

    /// Non-uniform grid over w ∈ [126, 133], b ∈ [−20, 20] of f.
    fn grid(f: impl Fn(f64, f64) -> f64) -> TopologicalWorm {
        let wf = worm_flank();
        let w: Vec<f64> = [0.0, 0.8, 2.1, 3.0, 4.6, 5.5, 7.0]
            .iter()
            .map(|d| 126.0 + d)
            .collect();
        let b: Vec<f64> = [-20.0, -13.0, -4.0, 0.0, 9.0, 20.0].to_vec();
        let v = w
            .iter()
            .flat_map(|&x| b.iter().map(move |&y| (x, y)))
            .map(|(x, y)| f(x, y))
            .collect();
        let t =
            DressedTopology::new(Flank::Right, wf.r_b_mm, wf.beta_b_rad, (w, b), v, 0.35).unwrap();
        TopologicalWorm::new(t, &wf).unwrap()
    }

    fn biquad(w: f64, b: f64) -> f64 {
        let (x, y) = (w - 129.5, b - 2.0);
        1e-3 * (0.5 + 0.2 * x - 0.3 * x * x + 0.01 * y + 0.002 * y * y + 0.03 * x * y
            - 0.004 * x * x * y
            + 1e-4 * x * x * y * y)
    }

    fn biquad_grad(w: f64, b: f64) -> (f64, f64) {
        let (x, y) = (w - 129.5, b - 2.0);
        (
            1e-3 * (0.2 - 0.6 * x + 0.03 * y - 0.008 * x * y + 2e-4 * x * y * y),
            1e-3 * (0.01 + 0.004 * y + 0.03 * x - 0.004 * x * x + 2e-4 * x * x * y),
        )
    }

    /// Closed form: the interpolant reproduces any biquadratic (quadratic in w times quadratic
    /// in b) on a non-uniform grid exactly, value and gradient, inside the grid.
    #[test]
    fn biquadratic_is_reproduced_exactly() {
        let t = grid(biquad);
        for i in 0..29 {
            for j in 0..23 {
                let (w, b) = (
                    126.0 + 0.25 * f64::from(i),
                    -20.0 + 40.0 * f64::from(j) / 22.0,
                );
                let (f, gw, gb) = t.f_n_and_gradient(w, b);
                let (ew, eb) = biquad_grad(w, b);
                assert!((f - biquad(w, b)).abs() < 1e-15, "{w} {b}");
                assert!(
                    (gw - ew).abs() < 1e-13 && (gb - eb).abs() < 1e-13,
                    "{w} {b}"
                );
            }
        }
    }

    /// (38) and the b ↔ z1 identification: f_Ft1(w1, z1) = f_n(w1, z1)/cos β_b1 with
    /// cos β_b1 = 0.342192 (docs/grinding.md "Independent reference: reference example").
    #[test]
    fn transverse_value_is_normal_over_cos_beta_b() {
        let t = grid(biquad);
        let (w, z) = (128.3, 5.5);
        assert!((t.f_ft_mm(w, z) - biquad(w, z) / 0.342192).abs() < 1e-8);
        let (gw, gz) = t.gradient(w, z);
        let (ew, ez) = biquad_grad(w, z);
        assert!((gw - ew / 0.342192).abs() < 1e-8 && (gz - ez / 0.342192).abs() < 1e-8);
    }

    /// A smooth non-polynomial surface: C¹ across cell borders (value and gradient agree
    /// from both sides) and convergent (error shrinks by ≳ 8 when the grid is halved).
    #[test]
    fn smooth_surface_is_c1_and_converges() {
        let g = |w: f64, b: f64| 1e-3 * ((w - 126.0) * 0.7).sin() * (b * 0.08).cos();
        let wf = worm_flank();
        let make = |n: usize| {
            let w: Vec<f64> = (0..n)
                .map(|i| 126.0 + 7.0 * i as f64 / (n - 1) as f64)
                .collect();
            let b: Vec<f64> = (0..n)
                .map(|i| -20.0 + 40.0 * i as f64 / (n - 1) as f64)
                .collect();
            let v = w
                .iter()
                .flat_map(|&x| b.iter().map(move |&y| g(x, y)))
                .collect();
            let t = DressedTopology::new(Flank::Right, wf.r_b_mm, wf.beta_b_rad, (w, b), v, 0.3)
                .unwrap();
            TopologicalWorm::new(t, &wf).unwrap()
        };
        let err = |t: &TopologicalWorm| {
            (0..40)
                .flat_map(|i| (0..40).map(move |j| (i, j)))
                .map(|(i, j)| {
                    let (w, b) = (126.1 + 0.17 * f64::from(i), -19.5 + f64::from(j));
                    (t.f_n_mm(w, b) - g(w, b)).abs()
                })
                .fold(0.0, f64::max)
        };
        let (coarse, fine) = (make(9), make(17));
        assert!(
            err(&fine) < err(&coarse) / 8.0,
            "{} {}",
            err(&coarse),
            err(&fine)
        );
        // cell border of the coarse grid at w = 126 + 7·3/8, b = −20 + 40·5/8
        let (wb, bb) = (126.0 + 7.0 * 3.0 / 8.0, 5.0);
        let e = 1e-9;
        let l = coarse.f_n_and_gradient(wb - e, bb - e);
        let r = coarse.f_n_and_gradient(wb + e, bb + e);
        assert!(
            (l.0 - r.0).abs() < 1e-11 && (l.1 - r.1).abs() < 1e-10 && (l.2 - r.2).abs() < 1e-10
        );
    }

    /// Outside the grid the surface continues linearly with the boundary gradient.
    #[test]
    fn extension_outside_the_grid_is_linear() {
        let t = grid(biquad);
        let (f0, gw, gb) = t.f_n_and_gradient(133.0, 20.0);
        let (f, gw1, gb1) = t.f_n_and_gradient(134.0, 22.0);
        assert!((f - (f0 + gw + 2.0 * gb)).abs() < 1e-15);
        assert!(gw1 == gw && gb1 == gb);
    }

    #[test]
    fn bad_grids_are_rejected() {
        let wf = worm_flank();
        let mk = |w: Vec<f64>, b: Vec<f64>, n: usize| {
            DressedTopology::new(
                Flank::Right,
                wf.r_b_mm,
                wf.beta_b_rad,
                (w, b),
                vec![0.0; n],
                0.3,
            )
        };
        assert!(mk(vec![1.0, 2.0, 3.0], vec![0.0, 1.0, 2.0], 9).is_ok());
        assert!(mk(vec![1.0, 2.0], vec![0.0, 1.0, 2.0], 6).is_err());
        assert!(mk(vec![1.0, 3.0, 2.0], vec![0.0, 1.0, 2.0], 9).is_err());
        assert!(mk(vec![1.0, 2.0, 3.0], vec![0.0, 1.0, 2.0], 8).is_err());
        assert!(mk(vec![-1.0, 2.0, 3.0], vec![0.0, 1.0, 2.0], 9).is_err());
        let mut t = mk(vec![1.0, 2.0, 3.0], vec![0.0, 1.0, 2.0], 9).unwrap();
        t.flank = Flank::Left;
        assert!(TopologicalWorm::new(t.clone(), &wf).is_err());
        t.flank = Flank::Right;
        t.r_b_mm *= 1.001;
        assert!(TopologicalWorm::new(t, &wf).is_err());
    }

    proptest! {
        /// No panic and finite values anywhere, far outside the grid included.
        #[test]
        fn evaluation_is_total(w in -1e4f64..1e4, b in -1e4f64..1e4) {
            let t = grid(biquad);
            let (f, gw, gb) = t.f_n_and_gradient(w, b);
            prop_assert!(f.is_finite() && gw.is_finite() && gb.is_finite());
        }
    }
}
