//! Grinding simulation: the envelope of the (modified) worm flank over the gear flank.
//!
//! Every gear grid point (w_F2, z_F2) carries a vector along its outward normal; the worm, at
//! every machine state (φ2, z_V2) with φ1 from the generating coupling and z_V1 from the feed
//! coupling, shortens it to where it meets the worm flank. The final length is the ground
//! normal deviation f_n2, and the worm point (w_F1, z_F1) and feed of the shortest cut are
//! stored with it. Instead of discrete time steps (which leave feed marks) the shortest cut is
//! found by minimising over rotation and feed directly ("exact-time" variant, digest §9.3 T1;
//! ERRATA §7). The contact path is then fitted from the stored feeds and worm points.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use crate::contact::{ContactPath, WormGearPair};
use crate::error::{check_range, GrindError, Result};
use crate::kinematics::FeedCoupling;
use crate::modification::FlankModification;

/// Over which machine states the shortest cut is searched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum EnvelopeMode {
    /// Rotation only, at the feed where the analytic contact path (40) passes the point (the
    /// restricted envelope of digest §9.3's "brute-force" numbers).
    RotationOnly,
    /// Rotation and feed (the true envelope, ERRATA §7).
    RotationAndFeed,
}

/// A uniform grid over the gear flank's (w, z) plane.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FlankGrid {
    /// First and last roll distance in mm.
    pub w_range_mm: (f64, f64),
    /// First and last width position in mm.
    pub z_range_mm: (f64, f64),
    /// Points along w (≥ 2).
    pub n_w: usize,
    /// Points along z (≥ 2).
    pub n_z: usize,
}

impl FlankGrid {
    /// A validated grid.
    pub fn new(
        w_range_mm: (f64, f64),
        z_range_mm: (f64, f64),
        n_w: usize,
        n_z: usize,
    ) -> Result<Self> {
        check_range("w_start_mm", w_range_mm.0, 1e-6, 1e6, "0 < w_start < w_end")?;
        check_range(
            "w_end_mm",
            w_range_mm.1,
            w_range_mm.0 + 1e-6,
            1e6,
            "w_end > w_start",
        )?;
        check_range(
            "z_start_mm",
            z_range_mm.0,
            -1e6,
            1e6,
            "finite, z_start < z_end",
        )?;
        check_range(
            "z_end_mm",
            z_range_mm.1,
            z_range_mm.0 + 1e-6,
            1e6,
            "z_end > z_start",
        )?;
        for (field, n) in [("n_w", n_w), ("n_z", n_z)] {
            if !(2..=10_000).contains(&n) {
                return Err(GrindError::BadData {
                    field,
                    got: n,
                    expected: "2 ..= 10000 grid points",
                });
            }
        }
        Ok(Self {
            w_range_mm,
            z_range_mm,
            n_w,
            n_z,
        })
    }
    /// Roll distance of column i.
    #[inline]
    pub fn w_mm(&self, i: usize) -> f64 {
        self.w_range_mm.0
            + (self.w_range_mm.1 - self.w_range_mm.0) * i as f64 / (self.n_w - 1) as f64
    }
    /// Width position of row j.
    #[inline]
    pub fn z_mm(&self, j: usize) -> f64 {
        self.z_range_mm.0
            + (self.z_range_mm.1 - self.z_range_mm.0) * j as f64 / (self.n_z - 1) as f64
    }
    /// Number of points.
    pub fn len(&self) -> usize {
        self.n_w * self.n_z
    }
    /// Always false for a validated grid.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Result of grinding one gear point.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct GroundPoint {
    /// Normal deviation f_n2 in mm (> 0 = material left).
    pub f_n_mm: f64,
    /// Transverse deviation f_Ft2 = f_n2/cos β_b2 in mm.
    pub f_ft_mm: f64,
    /// Worm roll distance of the shortest cut.
    pub w1_mm: f64,
    /// Worm width position of the shortest cut.
    pub z1_mm: f64,
    /// Workpiece feed of the shortest cut.
    pub z_v2_mm: f64,
    /// Workpiece rotation of the shortest cut.
    pub phi2_rad: f64,
}

/// A ground flank: one [`GroundPoint`] per grid point, index i_w·n_z + j_z.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GroundFlank {
    /// The grid.
    pub grid: FlankGrid,
    /// The points.
    pub points: Vec<GroundPoint>,
}

impl GroundFlank {
    /// Preallocates the result of a grid.
    pub fn new(grid: FlankGrid) -> Self {
        Self {
            grid,
            points: vec![GroundPoint::default(); grid.len()],
        }
    }
    /// Point at (i_w, j_z).
    pub fn at(&self, i: usize, j: usize) -> &GroundPoint {
        &self.points[i * self.grid.n_z + j]
    }
}

/// The grinding simulation of one flank with a given worm and feed coupling.
pub struct Grinder<'a> {
    pair: &'a WormGearPair,
    coupling: &'a FeedCoupling,
    worm_mod: &'a dyn FlankModification,
    mode: EnvelopeMode,
    /// Start offset (mm of gear rotation r_b2·Δφ2, mm of feed) from the analytic seed; used by
    /// tests to show that the minimum is found independently of the analytic mapping.
    seed_offset_mm: (f64, f64),
    ry: Matrix3<f64>,
}

const FD_STEP_MM: f64 = 0.01;

impl<'a> Grinder<'a> {
    /// A simulation of `pair` with worm modification `worm_mod` (worm f_Ft1 over (w_F1, z_F1)).
    pub fn new(
        pair: &'a WormGearPair,
        coupling: &'a FeedCoupling,
        worm_mod: &'a dyn FlankModification,
        mode: EnvelopeMode,
    ) -> Self {
        let (s, c) = pair.crossing_rad.sin_cos();
        Self {
            pair,
            coupling,
            worm_mod,
            mode,
            seed_offset_mm: (0.0, 0.0),
            ry: Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c),
        }
    }

    /// Starts every search this far (mm of r_b2·φ2, mm of z_V2) from the analytic seed.
    pub fn with_seed_offset(mut self, du_mm: f64, dv_mm: f64) -> Self {
        self.seed_offset_mm = (du_mm, dv_mm);
        self
    }

    /// Distance t along the gear normal from gear point P to the worm flank at machine state
    /// (φ2, z_V2); `guess` = (w1, z1, t) is updated in place (warm start).
    ///
    /// # Formula
    /// x_S = (0, d, 0) + R_y(γ)·(R_z(φ2)·P + z_V2·e_z); p1 = R_z(−φ1)·(x_S − z_V1·e_z)
    /// (chain (28)); solve E1(w1, z1) + cos β_b1·f_Ft1(w1, z1)·N1(w1, z1) = p1 + t·d1 by Newton.
    /// # Source
    /// Seed 004 E261–E264 (A3) [SEED]; Newton per digest §4.3 notes [RECONSTRUCTED].
    fn distance(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        phi2: f64,
        z_v2: f64,
        guess: &mut [f64; 3],
    ) -> Result<f64> {
        let z_v1 = self.coupling.z_v1_mm(z_v2);
        let phi1 = self.pair.phi1_rad(phi2, z_v1, z_v2);
        let (s2, c2) = phi2.sin_cos();
        let rp = Vector3::new(c2 * p.x - s2 * p.y, s2 * p.x + c2 * p.y, p.z + z_v2);
        let rn = Vector3::new(c2 * n.x - s2 * n.y, s2 * n.x + c2 * n.y, n.z);
        let xs = self.ry * rp + Vector3::new(0.0, self.pair.centre_distance_mm, -z_v1);
        let ds = self.ry * rn;
        let (s1, c1) = phi1.sin_cos();
        let p1 = Vector3::new(c1 * xs.x + s1 * xs.y, -s1 * xs.x + c1 * xs.y, xs.z);
        let d1 = Vector3::new(c1 * ds.x + s1 * ds.y, -s1 * ds.x + c1 * ds.y, ds.z);
        let worm = &self.pair.worm;
        let cb1 = worm.beta_b_rad.cos();
        let mut last = f64::INFINITY;
        for _ in 0..30 {
            let [e, nn, ew, ez, nw, nz] = worm.jet(guess[0], guess[1]);
            let f = cb1 * self.worm_mod.f_ft_mm(guess[0], guess[1]);
            let (gw, gz) = self.worm_mod.gradient(guess[0], guess[1]);
            let r = e + nn * f - p1 - d1 * guess[2];
            last = r.norm();
            let j = Matrix3::from_columns(&[
                ew + nw * f + nn * (cb1 * gw),
                ez + nz * f + nn * (cb1 * gz),
                -d1,
            ]);
            let step = j.lu().solve(&r).ok_or(GrindError::NoConvergence {
                what: "ray/worm intersection (singular Jacobian)",
                iterations: 0,
                residual_mm: last,
            })?;
            guess[0] -= step.x;
            guess[1] -= step.y;
            guess[2] -= step.z;
            if step.norm() < 1e-13 * (1.0 + guess[0].abs()) {
                return Ok(guess[2]);
            }
            if !guess.iter().all(|v| v.is_finite()) {
                break;
            }
        }
        Err(GrindError::NoConvergence {
            what: "ray/worm intersection",
            iterations: 30,
            residual_mm: last,
        })
    }

    /// Grinds one gear point: the shortest cut over the machine states.
    pub fn grind_point(&self, w2_mm: f64, z2_mm: f64) -> Result<GroundPoint> {
        check_range(
            "w2_mm",
            w2_mm,
            1e-6,
            1e6,
            "0 < w2 (outside the base circle)",
        )?;
        check_range("z2_mm", z2_mm, -1e6, 1e6, "finite")?;
        let gear = &self.pair.gear;
        let p = gear.point(w2_mm, z2_mm);
        let n = gear.normal(w2_mm, z2_mm);
        let seed = self.pair.map_gear_point(self.coupling, w2_mm, z2_mm);
        let rb2 = gear.r_b_mm;
        let mut guess = [seed.w1_mm, seed.z1_mm, 0.0];
        let mut u = self.seed_offset_mm.0;
        let mut v = match self.mode {
            EnvelopeMode::RotationOnly => 0.0,
            EnvelopeMode::RotationAndFeed => self.seed_offset_mm.1,
        };
        let two_d = self.mode == EnvelopeMode::RotationAndFeed;
        let eval = |u: f64, v: f64, g: &mut [f64; 3]| {
            self.distance(&p, &n, seed.phi2_rad + u / rb2, seed.z_v2_mm + v, g)
        };
        let h = FD_STEP_MM;
        let mut t0 = eval(u, v, &mut guess)?;
        let mut converged = false;
        for _ in 0..40 {
            let mut g = guess;
            let tup = eval(u + h, v, &mut g)?;
            let tum = eval(u - h, v, &mut g)?;
            let gu = (tup - tum) / (2.0 * h);
            let huu = (tup - 2.0 * t0 + tum) / (h * h);
            let (mut du, mut dv);
            if two_d {
                let tvp = eval(u, v + h, &mut g)?;
                let tvm = eval(u, v - h, &mut g)?;
                let tpp = eval(u + h, v + h, &mut g)?;
                let tmm = eval(u - h, v - h, &mut g)?;
                let gv = (tvp - tvm) / (2.0 * h);
                let hvv = (tvp - 2.0 * t0 + tvm) / (h * h);
                let huv = (tpp - tup - tvp + 2.0 * t0 - tum - tvm + tmm) / (2.0 * h * h);
                let det = huu * hvv - huv * huv;
                if huu > 0.0 && det > 0.0 {
                    du = -(hvv * gu - huv * gv) / det;
                    dv = -(huu * gv - huv * gu) / det;
                } else {
                    du = if huu > 0.0 {
                        -gu / huu
                    } else {
                        -gu.signum() * 0.1
                    };
                    dv = if hvv > 0.0 {
                        -gv / hvv
                    } else {
                        -gv.signum() * 0.1
                    };
                }
            } else {
                du = if huu > 0.0 {
                    -gu / huu
                } else {
                    -gu.signum() * 0.1
                };
                dv = 0.0;
            }
            du = du.clamp(-1.0, 1.0);
            dv = dv.clamp(-5.0, 5.0);
            // Accept the step if it does not increase t (a minimum is sought); else halve.
            let mut accepted = false;
            for _ in 0..30 {
                let mut g2 = guess;
                let t1 = eval(u + du, v + dv, &mut g2)?;
                if t1 <= t0 + 1e-15 {
                    u += du;
                    v += dv;
                    t0 = t1;
                    guess = g2;
                    accepted = true;
                    break;
                }
                du *= 0.5;
                dv *= 0.5;
            }
            if !accepted || du.abs().max(dv.abs()) < 1e-9 {
                converged = true;
                break;
            }
        }
        if !converged {
            return Err(GrindError::NoConvergence {
                what: "envelope minimisation over rotation and feed",
                iterations: 40,
                residual_mm: t0,
            });
        }
        let cb2 = gear.beta_b_rad.cos();
        Ok(GroundPoint {
            f_n_mm: t0,
            f_ft_mm: t0 / cb2,
            w1_mm: guess[0],
            z1_mm: guess[1],
            z_v2_mm: seed.z_v2_mm + v,
            phi2_rad: seed.phi2_rad + u / rb2,
        })
    }

    /// Grinds every point of `out.grid` into the preallocated `out` (no allocation).
    pub fn grind_flank(&self, out: &mut GroundFlank) -> Result<()> {
        let grid = out.grid;
        for i in 0..grid.n_w {
            let w = grid.w_mm(i);
            for j in 0..grid.n_z {
                out.points[i * grid.n_z + j] = self.grind_point(w, grid.z_mm(j))?;
            }
        }
        Ok(())
    }

    /// Feed coupling of this simulation.
    pub fn coupling(&self) -> &FeedCoupling {
        self.coupling
    }
}

/// Contact-path coefficients fitted from a simulation (A3 steps 5–7).
///
/// # Formula
/// Least squares over all ground points: z_F2 + z_V2* = C_Fw2·w_F2 + C_Fc2 (40);
/// w_F1* = a·w_F2 + b (R7); z_F1* + z_V1* = C_Fw1·w_F1* + C_Fc1 (39), where * marks the
/// stored state of each point's shortest cut.
/// # Source
/// Seed 004 E261–E264 [SEED]; digest §4.3 steps 5–7 [RECONSTRUCTED].
pub fn fit_contact_path(ground: &GroundFlank, coupling: &FeedCoupling) -> Result<ContactPath> {
    let g = ground.grid;
    let n = g.len();
    let mut x2 = Vec::with_capacity(n);
    let mut y2 = Vec::with_capacity(n);
    let mut y7 = Vec::with_capacity(n);
    let mut y1 = Vec::with_capacity(n);
    for i in 0..g.n_w {
        for j in 0..g.n_z {
            let p = ground.at(i, j);
            let (w2, z2) = (g.w_mm(i), g.z_mm(j));
            x2.push(w2);
            y2.push(z2 + p.z_v2_mm);
            y7.push(p.w1_mm);
            y1.push(p.z1_mm + coupling.z_v1_mm(p.z_v2_mm));
        }
    }
    let (c_w2, c_c2) = line_fit(&x2, &y2)?;
    let (a, b) = line_fit(&x2, &y7)?;
    let (c_w1, c_c1) = line_fit(&y7, &y1)?;
    // |C_Fw| = tan |β_b| gives cos β_b for the (R7) constant, taken at the middle of the grid.
    let cb1 = 1.0 / (1.0 + c_w1 * c_w1).sqrt();
    let cb2 = 1.0 / (1.0 + c_w2 * c_w2).sqrt();
    let w2m = 0.5 * (g.w_range_mm.0 + g.w_range_mm.1);
    Ok(ContactPath {
        c_w1,
        c_c1_mm: c_c1,
        c_w2,
        c_c2_mm: c_c2,
        a,
        b_mm: b,
        r7_sum_mm: (a * w2m + b) / cb1 + w2m / cb2,
    })
}

/// (slope, intercept) of the least-squares line y = slope·x + intercept, by QR on centred x.
fn line_fit(x: &[f64], y: &[f64]) -> Result<(f64, f64)> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n.max(1) as f64;
    let a = DMatrix::from_fn(n, 2, |i, k| if k == 0 { 1.0 } else { x[i] - mean });
    let rhs = DVector::from_column_slice(y);
    let qr = a.qr();
    let r = qr.r();
    if n < 3 || r[(1, 1)].is_nan() || r[(1, 1)].abs() <= 1e-9 * r[(0, 0)].abs() {
        return Err(GrindError::BadData {
            field: "grid (contact-path fit)",
            got: n,
            expected: "at least 3 points spread along w",
        });
    }
    let sol = r
        .solve_upper_triangular(&(qr.q().transpose() * rhs))
        .ok_or(GrindError::BadData {
            field: "grid (contact-path fit)",
            got: n,
            expected: "a regular fit",
        })?;
    Ok((sol[1], sol[0] - sol[1] * mean))
}
