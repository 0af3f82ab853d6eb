//! Envelope grinding simulation for any worm–workpiece chain ((28)–(31)), and the contact path
//! (76)/(77)/(86) fitted from simulations at two or more feed couplings.
//!
//! The algorithm is that of [`crate::simulate`] (shortest cut along each gear normal, minimised
//! over rotation and feed, worm point of the minimum stored), written against the relative pose
//! K_R of a [`MeshKinematics`] so that conical chains use it unchanged. For a cylindrical
//! [`WormGearPair`] it reproduces [`crate::simulate::Grinder`].

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Point3, Vector3};

use crate::conical::{ConicalPair, ConicalPath};
use crate::contact::{MappedPoint, WormGearPair};
use crate::error::{check_range, GrindError, Result};
use crate::flank::InvoluteFlank;
use crate::kinematics::{chain_cyl_cyl, FeedCoupling};
use crate::modification::FlankModification;
use crate::simulate::{EnvelopeMode, GroundFlank, GroundPoint};

/// A worm–workpiece mesh as the simulation needs it: two flanks, the relative pose with the
/// generating coupling applied, and an analytic first guess.
pub trait MeshKinematics {
    /// Worm flank (index 1).
    fn worm_flank(&self) -> &InvoluteFlank;
    /// Workpiece flank (index 2).
    fn gear_flank(&self) -> &InvoluteFlank;
    /// K_R (workpiece body → worm body) at φ2 and feeds, φ1 from the generating coupling.
    fn relative_pose(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> Isometry3<f64>;
    /// Analytic worm point and machine state for a gear point (search seed).
    fn seed_point(&self, coupling: &FeedCoupling, w2_mm: f64, z2_mm: f64) -> Result<MappedPoint>;
}

impl MeshKinematics for WormGearPair {
    fn worm_flank(&self) -> &InvoluteFlank {
        &self.worm
    }
    fn gear_flank(&self) -> &InvoluteFlank {
        &self.gear
    }
    fn relative_pose(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> Isometry3<f64> {
        let phi1 = self.phi1_rad(phi2_rad, z_v1_mm, z_v2_mm);
        chain_cyl_cyl(
            phi1,
            z_v1_mm,
            self.centre_distance_mm,
            self.crossing_rad,
            z_v2_mm,
            phi2_rad,
        )
    }
    fn seed_point(&self, coupling: &FeedCoupling, w2_mm: f64, z2_mm: f64) -> Result<MappedPoint> {
        Ok(self.map_gear_point(coupling, w2_mm, z2_mm))
    }
}

impl MeshKinematics for ConicalPair {
    fn worm_flank(&self) -> &InvoluteFlank {
        &self.worm
    }
    fn gear_flank(&self) -> &InvoluteFlank {
        &self.gear
    }
    fn relative_pose(&self, phi2_rad: f64, z_v1_mm: f64, z_v2_mm: f64) -> Isometry3<f64> {
        self.pose(phi2_rad, z_v1_mm, z_v2_mm)
    }
    fn seed_point(&self, coupling: &FeedCoupling, w2_mm: f64, z2_mm: f64) -> Result<MappedPoint> {
        self.map_gear_point(coupling, w2_mm, z2_mm)
    }
}

/// Envelope grinding simulation of one flank for any [`MeshKinematics`].
pub struct EnvelopeGrinder<'a, M: MeshKinematics + ?Sized> {
    mesh: &'a M,
    coupling: &'a FeedCoupling,
    worm_mod: &'a dyn FlankModification,
    mode: EnvelopeMode,
    seed_offset_mm: (f64, f64),
}

const FD_STEP_MM: f64 = 0.01;

impl<'a, M: MeshKinematics + ?Sized> EnvelopeGrinder<'a, M> {
    /// A simulation of `mesh` with worm modification `worm_mod` (worm f_Ft1 over (w_F1, z_F1)).
    pub fn new(
        mesh: &'a M,
        coupling: &'a FeedCoupling,
        worm_mod: &'a dyn FlankModification,
        mode: EnvelopeMode,
    ) -> Self {
        Self {
            mesh,
            coupling,
            worm_mod,
            mode,
            seed_offset_mm: (0.0, 0.0),
        }
    }

    /// Starts every search this far (mm of r_b2·φ2, mm of z_V2) from the analytic seed.
    pub fn with_seed_offset(mut self, du_mm: f64, dv_mm: f64) -> Self {
        self.seed_offset_mm = (du_mm, dv_mm);
        self
    }

    /// Distance t along the gear normal from gear point P to the worm flank at (φ2, z_V2).
    ///
    /// # Formula
    /// p1 = K_R·P, d1 = K_R·N (chains (28)–(31), φ1 from (R4), z_V1 = F_ZV1(z_V2)); solve
    /// E1(w1, z1) + cos β_b1·f_Ft1(w1, z1)·N1(w1, z1) = p1 + t·d1 by Newton.
    /// # Source
    /// Seed 004 E261–E264 (A3) [SEED]; digest §4.3 notes [RECONSTRUCTED].
    fn distance(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        phi2: f64,
        z_v2: f64,
        guess: &mut [f64; 3],
    ) -> Result<f64> {
        let z_v1 = self.coupling.z_v1_mm(z_v2);
        let pose = self.mesh.relative_pose(phi2, z_v1, z_v2);
        let p1 = pose.transform_point(&Point3::from(*p)).coords;
        let d1 = pose.rotation * n;
        let worm = self.mesh.worm_flank();
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
        let gear = self.mesh.gear_flank();
        let p = gear.point(w2_mm, z2_mm);
        let n = gear.normal(w2_mm, z2_mm);
        let seed = self.mesh.seed_point(self.coupling, w2_mm, z2_mm)?;
        let rb2 = gear.r_b_mm;
        let mut guess = [seed.w1_mm, seed.z1_mm, 0.0];
        let two_d = self.mode == EnvelopeMode::RotationAndFeed;
        let mut u = self.seed_offset_mm.0;
        let mut v = if two_d { self.seed_offset_mm.1 } else { 0.0 };
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
            let newton_1d = |grad: f64, curv: f64| {
                if curv > 0.0 {
                    -grad / curv
                } else {
                    -grad.signum() * 0.1
                }
            };
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
                    du = newton_1d(gu, huu);
                    dv = newton_1d(gv, hvv);
                }
            } else {
                du = newton_1d(gu, huu);
                dv = 0.0;
            }
            du = du.clamp(-1.0, 1.0);
            dv = dv.clamp(-5.0, 5.0);
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
        Ok(GroundPoint {
            f_n_mm: t0,
            f_ft_mm: t0 / gear.beta_b_rad.cos(),
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

/// Contact-path coefficients of any chain fitted from simulations (A3 step 8).
///
/// # Formula
/// Least squares (QR) over all ground points of all runs, with z_V1* = F_ZV1(z_V2*) of each
/// run: z_F2 = C_Fw2·w_F2 + C_FzV12·z_V1* + C_FzV22·z_V2* + C_Fc2 (77);
/// w_F1* = a·w_F2 + b_zv1·z_V1* + b_zv2·z_V2* + b (86);
/// z_F1* = C_Fw1·w_F1* + C_FzV11·z_V1* + C_FzV21·z_V2* + C_Fc1 (76).
/// # Domain
/// One coupling makes z_V1 a function of z_V2, so at least two runs whose couplings differ
/// (e.g. two z_V01) are needed: "at least two different z_V1" (E264).
/// # Source
/// Seed 004 E261–E264 [SEED]; digest §4.3 steps 5–8 [RECONSTRUCTED].
pub fn fit_conical_path(runs: &[(&GroundFlank, &FeedCoupling)]) -> Result<ConicalPath> {
    let n: usize = runs.iter().map(|(g, _)| g.grid.len()).sum();
    let mut a2 = DMatrix::zeros(n, 4);
    let mut a1 = DMatrix::zeros(n, 4);
    let mut y_z2 = DVector::zeros(n);
    let mut y_w1 = DVector::zeros(n);
    let mut y_z1 = DVector::zeros(n);
    let mut row = 0;
    for (ground, coupling) in runs {
        let g = ground.grid;
        for i in 0..g.n_w {
            for j in 0..g.n_z {
                let p = ground.at(i, j);
                let zv1 = coupling.z_v1_mm(p.z_v2_mm);
                for (c, v) in [g.w_mm(i), zv1, p.z_v2_mm, 1.0].into_iter().enumerate() {
                    a2[(row, c)] = v;
                }
                for (c, v) in [p.w1_mm, zv1, p.z_v2_mm, 1.0].into_iter().enumerate() {
                    a1[(row, c)] = v;
                }
                y_z2[row] = g.z_mm(j);
                y_w1[row] = p.w1_mm;
                y_z1[row] = p.z1_mm;
                row += 1;
            }
        }
    }
    let gear = lsq(&a2, &y_z2)?;
    let r7 = lsq(&a2, &y_w1)?;
    let worm = lsq(&a1, &y_z1)?;
    Ok(ConicalPath {
        c_w1: worm[0],
        c_zv11: worm[1],
        c_zv21: worm[2],
        c_c1_mm: worm[3],
        c_w2: gear[0],
        c_zv12: gear[1],
        c_zv22: gear[2],
        c_c2_mm: gear[3],
        a: r7[0],
        b_zv1: r7[1],
        b_zv2: r7[2],
        b_mm: r7[3],
    })
}

/// Least squares by QR with column scaling; rank-deficient designs are an error.
fn lsq(a: &DMatrix<f64>, y: &DVector<f64>) -> Result<DVector<f64>> {
    let bad = GrindError::BadData {
        field: "simulation runs (conical contact-path fit)",
        got: a.nrows(),
        expected: "at least 4 points from two or more runs with different feed couplings",
    };
    if a.nrows() < a.ncols() {
        return Err(bad);
    }
    let scale: Vec<f64> = a.column_iter().map(|c| c.amax().max(1e-300)).collect();
    let mut s = a.clone();
    for (j, mut c) in s.column_iter_mut().enumerate() {
        c /= scale[j];
    }
    let qr = s.qr();
    let r = qr.r();
    let d0 = r[(0, 0)].abs();
    if d0.is_nan() || (0..r.ncols()).any(|k| r[(k, k)].is_nan() || r[(k, k)].abs() <= 1e-9 * d0) {
        return Err(bad);
    }
    let sol = r
        .solve_upper_triangular(&(qr.q().transpose() * y))
        .ok_or(bad)?;
    Ok(DVector::from_iterator(
        sol.len(),
        sol.iter().zip(&scale).map(|(v, s)| v / s),
    ))
}
