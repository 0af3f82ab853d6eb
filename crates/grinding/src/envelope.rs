//! The envelope grinder: grinding one gear flank with a (modified) worm over any
//! worm–workpiece chain ((28)–(31)), written against the relative pose K_R of a
//! [`MeshKinematics`] so that cylindrical and conical chains run the same algorithm.
//!
//! Every gear grid point (w_F2, z_F2) carries a vector along its outward normal; the worm, at
//! every machine state (φ2, z_V2) with φ1 from the generating coupling and z_V1 from the feed
//! coupling, shortens it to where it meets the worm flank. The final length is the ground
//! normal deviation f_n2, and the worm point (w_F1, z_F1) and feed of the shortest cut are
//! stored with it. Instead of discrete time steps (which leave feed marks) the shortest cut is
//! found by minimising over rotation and feed directly ("exact-time" variant, docs/grinding.md
//! "Independent reference: brute-force envelope").
//!
//! The contact-path fits built on its results live in [`crate::simulate`] (cylindrical chain)
//! and [`crate::conical_sim`] (any chain, two or more feed couplings).

use nalgebra::{Isometry3, Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};

use crate::conical::ConicalPair;
use crate::contact::{MappedPoint, WormGearPair};
use crate::error::{check_range, GrindError, Result};
use crate::flank::InvoluteFlank;
use crate::kinematics::{chain_cyl_cyl, FeedCoupling};
use crate::modification::FlankModification;

/// Over which machine states the shortest cut is searched.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum EnvelopeMode {
    /// Rotation only, at the feed where the analytic contact path (40) passes the point (the
    /// restricted envelope: the rotation-only numbers of docs/grinding.md "Independent reference:
    /// brute-force envelope").
    RotationOnly,
    /// Rotation and feed (the true envelope, docs/grinding.md "Independent reference: brute-force
    /// envelope").
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

/// Least span of a [`FlankGrid`] in w and in z (mm).
pub const MIN_ROLL_SPAN_MM: f64 = 1e-6;

impl FlankGrid {
    /// A validated grid: each span at least [`MIN_ROLL_SPAN_MM`].
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
            w_range_mm.0 + MIN_ROLL_SPAN_MM,
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
            z_range_mm.0 + MIN_ROLL_SPAN_MM,
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
    /// State of the shortest cut as offsets from the analytic seed: rotation (mm of
    /// r_b2·φ2) and feed (mm).
    pub offset_mm: (f64, f64),
    /// First-order analytic f_Ft2 in mm: −(cos β_b1/cos β_b2)·f_Ft1 at the mapped worm point.
    pub analytic_f_ft_mm: f64,
    /// Second-order model of the envelope in mm: the cut at the analytic state plus the drop
    /// −½·gᵀH⁻¹g of its quadratic model over rotation and feed (None if that model has no
    /// minimum).
    pub second_order_f_ft_mm: Option<f64>,
    /// The worm touches with its tip or root edge (the shortest cut lies on the bound of the
    /// worm's radii).
    pub worm_edge: bool,
    /// Envelope and second-order model agree (within [`SECOND_ORDER_ABS_MM`] +
    /// [`SECOND_ORDER_REL`]·|second-order correction|), and the worm touches with its flank.
    pub explained: bool,
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
    /// Number of worm starts z1 (thread turns repeat every normal base pitch / z1).
    fn worm_starts(&self) -> u32;
}

/// Envelope and second-order model may differ by this much (mm, normal) plus
/// [`SECOND_ORDER_REL`] of the second-order correction before a point is marked.
pub const SECOND_ORDER_ABS_MM: f64 = 2e-5;
/// Relative part of the second-order consistency bound.
pub const SECOND_ORDER_REL: f64 = 0.5;

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
    fn worm_starts(&self) -> u32 {
        self.worm_starts
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
    fn worm_starts(&self) -> u32 {
        self.worm_starts
    }
}

/// The first-order analytic worm → gear map of a mesh: the gear modification that a worm
/// modification grinds at a gear point, to compare with the envelope of [`EnvelopeGrinder`].
///
/// # Formula
/// f_Ft2(w_F2, z_F2) = −(cos β_bF1/cos β_bF2)·f_Ft1(w_F1, z_F1) at the worm point that grinds
/// (w_F2, z_F2) under the feed coupling (eq. (38)).
/// # Source
/// JP6903407B2 eq. (38); cylindrical chain [`crate::diagonal::predicted_gear_f_ft_mm`],
/// conical chains [`crate::conical_lines::predicted_gear_f_ft_mm`].
pub trait AnalyticTransfer: MeshKinematics {
    /// Gear f_Ft2 in mm that the analytic pointwise map predicts at (w2, z2).
    fn predicted_gear_f_ft_mm(
        &self,
        coupling: &FeedCoupling,
        worm_mod: &dyn FlankModification,
        w2_mm: f64,
        z2_mm: f64,
    ) -> Result<f64>;
}

impl AnalyticTransfer for WormGearPair {
    fn predicted_gear_f_ft_mm(
        &self,
        coupling: &FeedCoupling,
        worm_mod: &dyn FlankModification,
        w2_mm: f64,
        z2_mm: f64,
    ) -> Result<f64> {
        Ok(crate::diagonal::predicted_gear_f_ft_mm(
            self, coupling, worm_mod, w2_mm, z2_mm,
        ))
    }
}

impl AnalyticTransfer for ConicalPair {
    fn predicted_gear_f_ft_mm(
        &self,
        coupling: &FeedCoupling,
        worm_mod: &dyn FlankModification,
        w2_mm: f64,
        z2_mm: f64,
    ) -> Result<f64> {
        crate::conical_lines::predicted_gear_f_ft_mm(self, coupling, worm_mod, w2_mm, z2_mm)
    }
}

/// Envelope grinding simulation of one flank for any [`MeshKinematics`].
///
/// The worm is bounded: a ray/worm intersection counts only where the worm thread exists
/// (roll distance between the worm's root and tip radii, [`Self::with_worm_radii`]) and on the
/// thread turn the search started on (|f_n| below 0.45 of the worm's normal base pitch), so the
/// minimiser cannot find minima where no worm exists (issue 13 item 2).
pub struct EnvelopeGrinder<'a, M: MeshKinematics + ?Sized> {
    mesh: &'a M,
    coupling: &'a FeedCoupling,
    worm_mod: &'a dyn FlankModification,
    mode: EnvelopeMode,
    seed_offset_mm: (f64, f64),
    w1_bounds_mm: (f64, f64),
    t_cap_mm: f64,
}

const FD_STEP_MM: f64 = 0.01;

/// Largest Newton step of the state search: rotation (mm of r_b2·φ2) and feed (mm).
const MAX_STEP_MM: (f64, f64) = (1.0, 5.0);

/// Worm roll distances closer than this to a bound count as contact at the worm's edge.
const EDGE_MM: f64 = 1e-4;

/// A machine state of the search: offsets from the analytic seed and the ray hit there.
#[derive(Debug, Clone, Copy)]
struct State {
    u: f64,
    v: f64,
    t: f64,
    guess: [f64; 3],
}

/// Quadratic model of t(u, v) at a state: gradient and Hessian by central differences.
#[derive(Debug, Clone, Copy)]
struct Model {
    g: [f64; 2],
    h: [f64; 3],
}

impl Model {
    /// −½·gᵀH⁻¹g (the drop to the minimum of the quadratic), None if H is not positive
    /// definite.
    fn drop_to_minimum(&self) -> Option<f64> {
        let [huu, huv, hvv] = self.h;
        let det = huu * hvv - huv * huv;
        if !(huu > 0.0 && det > 0.0) {
            return None;
        }
        let [gu, gv] = self.g;
        Some(-0.5 * (hvv * gu * gu - 2.0 * huv * gu * gv + huu * gv * gv) / det)
    }
}

impl<'a, M: MeshKinematics + ?Sized> EnvelopeGrinder<'a, M> {
    /// A simulation of `mesh` with worm modification `worm_mod` (worm f_Ft1 over (w_F1, z_F1)).
    /// The worm is unbounded radially until [`Self::with_worm_radii`] is called (the turn
    /// bound applies always).
    pub fn new(
        mesh: &'a M,
        coupling: &'a FeedCoupling,
        worm_mod: &'a dyn FlankModification,
        mode: EnvelopeMode,
    ) -> Self {
        let wf = mesh.worm_flank();
        // normal base pitch of the worm: 2π·r_b1·cos β_b1/z1 (the thread turns' spacing
        // along the flank normal)
        let p_bn = 2.0 * std::f64::consts::PI * wf.r_b_mm * wf.beta_b_rad.cos()
            / f64::from(mesh.worm_starts().max(1));
        Self {
            mesh,
            coupling,
            worm_mod,
            mode,
            seed_offset_mm: (0.0, 0.0),
            w1_bounds_mm: (0.0, f64::INFINITY),
            t_cap_mm: 0.45 * p_bn,
        }
    }

    /// Bounds the worm thread to its real radial extent: root radius r_f1 and tip radius
    /// r_a1 in mm (converted to roll distances w = √(r² − r_b1²); a root inside the base
    /// cylinder starts at w = 0).
    pub fn with_worm_radii(mut self, root_radius_mm: f64, tip_radius_mm: f64) -> Result<Self> {
        let rb = self.mesh.worm_flank().r_b_mm;
        check_range(
            "worm_root_radius_mm",
            root_radius_mm,
            0.0,
            1e6,
            "0 ≤ root radius < tip radius",
        )?;
        check_range(
            "worm_tip_radius_mm",
            tip_radius_mm,
            (root_radius_mm + 1e-6).max(rb + 1e-6),
            1e6,
            "tip radius > root radius and > worm base radius",
        )?;
        let w = |r: f64| (r * r - rb * rb).max(0.0).sqrt();
        self.w1_bounds_mm = (w(root_radius_mm), w(tip_radius_mm));
        Ok(self)
    }

    /// Worm roll-distance range that may grind (mm).
    pub fn worm_roll_bounds_mm(&self) -> (f64, f64) {
        self.w1_bounds_mm
    }

    /// Starts every search this far (mm of r_b2·φ2, mm of z_V2) from the analytic seed.
    pub fn with_seed_offset(mut self, du_mm: f64, dv_mm: f64) -> Self {
        self.seed_offset_mm = (du_mm, dv_mm);
        self
    }

    /// Distance t along the gear normal from gear point P to the worm flank at (φ2, z_V2);
    /// None where the ray meets no worm (outside the worm's radii or on another thread turn)
    /// or the intersection does not converge.
    ///
    /// # Formula
    /// p1 = K_R·P, d1 = K_R·N (chains (28)–(31), φ1 from (R4), z_V1 = F_ZV1(z_V2)); solve
    /// E1(w1, z1) + cos β_b1·f_Ft1(w1, z1)·N1(w1, z1) = p1 + t·d1 by Newton.
    /// # Source
    /// JP6903407B2, (R6)/(R7) by simulation [SEED]; docs/grinding.md "Derivation: contact path
    /// fitted from the simulation" [RECONSTRUCTED].
    fn distance(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        phi2: f64,
        z_v2: f64,
        guess: &mut [f64; 3],
    ) -> Option<f64> {
        let z_v1 = self.coupling.z_v1_mm(z_v2);
        let pose = self.mesh.relative_pose(phi2, z_v1, z_v2);
        let p1 = pose.transform_point(&Point3::from(*p)).coords;
        let d1 = pose.rotation * n;
        let worm = self.mesh.worm_flank();
        let cb1 = worm.beta_b_rad.cos();
        for _ in 0..30 {
            let [e, nn, ew, ez, nw, nz] = worm.jet(guess[0], guess[1]);
            let f = cb1 * self.worm_mod.f_ft_mm(guess[0], guess[1]);
            let (gw, gz) = self.worm_mod.gradient(guess[0], guess[1]);
            let r = e + nn * f - p1 - d1 * guess[2];
            let j = Matrix3::from_columns(&[
                ew + nw * f + nn * (cb1 * gw),
                ez + nz * f + nn * (cb1 * gz),
                -d1,
            ]);
            let step = j.lu().solve(&r)?;
            guess[0] -= step.x;
            guess[1] -= step.y;
            guess[2] -= step.z;
            if !guess.iter().all(|v| v.is_finite()) {
                return None;
            }
            if step.norm() < 1e-13 * (1.0 + guess[0].abs()) {
                let on_worm = guess[0] >= self.w1_bounds_mm.0 && guess[0] <= self.w1_bounds_mm.1;
                return (on_worm && guess[2].abs() <= self.t_cap_mm).then_some(guess[2]);
            }
        }
        None
    }

    /// The ray hit at state offsets (u, v) from the seed, starting the intersection from
    /// `guess`.
    #[allow(clippy::too_many_arguments)]
    fn state(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        seed: &MappedPoint,
        u: f64,
        v: f64,
        guess: [f64; 3],
    ) -> Option<State> {
        let mut g = guess;
        let rb2 = self.mesh.gear_flank().r_b_mm;
        let t = self.distance(p, n, seed.phi2_rad + u / rb2, seed.z_v2_mm + v, &mut g)?;
        Some(State { u, v, t, guess: g })
    }

    /// Central-difference model at a state (None if a neighbour has no worm contact).
    fn model(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        seed: &MappedPoint,
        s: &State,
    ) -> Option<Model> {
        let h = FD_STEP_MM;
        let t = |du: f64, dv: f64| {
            self.state(p, n, seed, s.u + du, s.v + dv, s.guess)
                .map(|x| x.t)
        };
        let (tup, tum) = (t(h, 0.0)?, t(-h, 0.0)?);
        let gu = (tup - tum) / (2.0 * h);
        let huu = (tup - 2.0 * s.t + tum) / (h * h);
        if self.mode == EnvelopeMode::RotationOnly {
            return Some(Model {
                g: [gu, 0.0],
                h: [huu, 0.0, 1.0],
            });
        }
        let (tvp, tvm) = (t(0.0, h)?, t(0.0, -h)?);
        let (tpp, tmm) = (t(h, h)?, t(-h, -h)?);
        let gv = (tvp - tvm) / (2.0 * h);
        let hvv = (tvp - 2.0 * s.t + tvm) / (h * h);
        let huv = (tpp - tup - tvp + 2.0 * s.t - tum - tvm + tmm) / (2.0 * h * h);
        Some(Model {
            g: [gu, gv],
            h: [huu, huv, hvv],
        })
    }

    /// Damped Newton on t(u, v): Hessian shifted to positive definite where it is not, step
    /// limited to [`MAX_STEP_MM`], backtracking until t decreases; states without worm contact
    /// are rejected like increases. Returns the last state and whether it converged in the
    /// interior (gradient ≈ 0 with all difference neighbours on the worm).
    fn newton(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        seed: &MappedPoint,
        mut s: State,
    ) -> (State, bool) {
        let two_d = self.mode == EnvelopeMode::RotationAndFeed;
        for _ in 0..60 {
            let Some(m) = self.model(p, n, seed, &s) else {
                return (s, false);
            };
            let [gu, gv] = m.g;
            let [huu, huv, hvv] = m.h;
            let (du, dv) = if two_d {
                // smallest eigenvalue of H; shift it to a positive value (Levenberg)
                let tr = huu + hvv;
                let disc = (0.25 * (huu - hvv).powi(2) + huv * huv).sqrt();
                let lmin = 0.5 * tr - disc;
                let scale = huu.abs() + hvv.abs() + 1e-12;
                let mu = if lmin > 1e-6 * scale {
                    0.0
                } else {
                    1e-3 * scale - lmin
                };
                let (a, b, c) = (huu + mu, huv, hvv + mu);
                let det = a * c - b * b;
                (-(c * gu - b * gv) / det, -(a * gv - b * gu) / det)
            } else if huu > 0.0 {
                (-gu / huu, 0.0)
            } else {
                (-gu.signum() * 0.1, 0.0)
            };
            // limit the step (keep its direction)
            let shrink = (MAX_STEP_MM.0 / du.abs().max(1e-300))
                .min(MAX_STEP_MM.1 / dv.abs().max(1e-300))
                .min(1.0);
            let (mut du, mut dv) = (du * shrink, dv * shrink);
            if !(du.is_finite() && dv.is_finite()) {
                return (s, false);
            }
            let mut accepted = false;
            for _ in 0..40 {
                if let Some(s1) = self.state(p, n, seed, s.u + du, s.v + dv, s.guess) {
                    // a jump of more than a quarter of the turn bound is another surface
                    if s1.t <= s.t + 1e-15 && (s1.t - s.t).abs() < 0.25 * self.t_cap_mm {
                        s = s1;
                        accepted = true;
                        break;
                    }
                }
                du *= 0.5;
                dv *= 0.5;
            }
            let gnorm = gu.abs().max(gv.abs());
            if !accepted || du.abs().max(dv.abs()) < 1e-9 {
                return (s, gnorm < 1e-6);
            }
        }
        (s, false)
    }

    /// Derivative-free compass search from `s` (robust at the worm's edge and where Newton
    /// stalls): moves of ±δ along u and v, δ halved when none improves, down to 1e-9 mm.
    fn compass(
        &self,
        p: &Vector3<f64>,
        n: &Vector3<f64>,
        seed: &MappedPoint,
        mut s: State,
    ) -> State {
        let dirs: [(f64, f64); 4] = if self.mode == EnvelopeMode::RotationAndFeed {
            [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)]
        } else {
            [(1.0, 0.0), (-1.0, 0.0), (1.0, 0.0), (-1.0, 0.0)]
        };
        let mut delta = 0.05;
        let mut evals = 0;
        while delta > 1e-9 && evals < 4000 {
            let mut improved = false;
            for (a, b) in dirs {
                evals += 1;
                if let Some(s1) = self.state(p, n, seed, s.u + a * delta, s.v + b * delta, s.guess)
                {
                    if s1.t < s.t && (s1.t - s.t).abs() < 0.25 * self.t_cap_mm {
                        s = s1;
                        improved = true;
                        break;
                    }
                }
            }
            if !improved {
                delta *= 0.5;
            }
        }
        s
    }

    /// Grinds one gear point: the shortest cut over the machine states, searched from the
    /// analytic seed (shifted by [`Self::with_seed_offset`]).
    pub fn grind_point(&self, w2_mm: f64, z2_mm: f64) -> Result<GroundPoint> {
        self.grind_point_from(w2_mm, z2_mm, None)
    }

    /// Grinds one gear point, also trying `warm` = (rotation mm, feed mm) offsets from the
    /// analytic seed (e.g. the neighbouring grid point's solution) as a start.
    ///
    /// The result carries the first-order analytic value and its second-order correction at
    /// the seed (−½·gᵀH⁻¹g of the quadratic model of the cut over rotation and feed), and is
    /// marked when the two disagree beyond what that explains or when the worm touches with
    /// its tip or root edge.
    pub fn grind_point_from(
        &self,
        w2_mm: f64,
        z2_mm: f64,
        warm: Option<(f64, f64)>,
    ) -> Result<GroundPoint> {
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
        let two_d = self.mode == EnvelopeMode::RotationAndFeed;
        let g0 = [seed.w1_mm, seed.z1_mm, 0.0];
        let at_seed = self.state(&p, &n, &seed, 0.0, 0.0, g0);
        // candidate starts: the seed (with the configured offset) and the warm start
        let mut start: Option<State> = None;
        let off = (
            self.seed_offset_mm.0,
            if two_d { self.seed_offset_mm.1 } else { 0.0 },
        );
        let mut consider = |s: Option<State>| {
            if let Some(s) = s {
                if start.is_none_or(|b| s.t < b.t) {
                    start = Some(s);
                }
            }
        };
        if off == (0.0, 0.0) {
            consider(at_seed);
        } else {
            consider(self.state(&p, &n, &seed, off.0, off.1, g0));
        }
        if let Some((u, v)) = warm {
            let v = if two_d { v } else { 0.0 };
            let g = at_seed.map_or(g0, |s| s.guess);
            consider(self.state(&p, &n, &seed, u, v, g));
        }
        let Some(start) = start else {
            return Err(GrindError::NoWormContact {
                w2_mm,
                z2_mm,
                w1_mm: seed.w1_mm,
                w1_min_mm: self.w1_bounds_mm.0,
                w1_max_mm: self.w1_bounds_mm.1,
            });
        };
        let (mut best, interior) = self.newton(&p, &n, &seed, start);
        if !interior {
            best = self.compass(&p, &n, &seed, best);
        }
        if !best.t.is_finite() {
            return Err(GrindError::EnvelopeFailed { w2_mm, z2_mm });
        }
        let w1 = best.guess[0];
        let worm_edge = (w1 - self.w1_bounds_mm.0).abs() < EDGE_MM
            || (w1 - self.w1_bounds_mm.1).abs() < EDGE_MM;
        let wf = self.mesh.worm_flank();
        let analytic = -wf.beta_b_rad.cos() * self.worm_mod.f_ft_mm(seed.w1_mm, seed.z1_mm);
        let second = at_seed.and_then(|s| {
            let m = self.model(&p, &n, &seed, &s)?;
            Some(s.t + m.drop_to_minimum()?)
        });
        let explained = !worm_edge
            && second.is_some_and(|m2| {
                (best.t - m2).abs()
                    <= SECOND_ORDER_ABS_MM + SECOND_ORDER_REL * (m2 - analytic).abs()
            });
        let cb2 = gear.beta_b_rad.cos();
        Ok(GroundPoint {
            f_n_mm: best.t,
            f_ft_mm: best.t / cb2,
            w1_mm: w1,
            z1_mm: best.guess[1],
            z_v2_mm: seed.z_v2_mm + best.v,
            phi2_rad: seed.phi2_rad + best.u / gear.r_b_mm,
            offset_mm: (best.u, best.v),
            analytic_f_ft_mm: analytic / cb2,
            second_order_f_ft_mm: second.map(|v| v / cb2),
            worm_edge,
            explained,
        })
    }

    /// Grinds every point of `out.grid` into the preallocated `out` (no allocation); each
    /// search also starts from the neighbouring point's solution.
    pub fn grind_flank(&self, out: &mut GroundFlank) -> Result<()> {
        let grid = out.grid;
        let mut column_start: Option<(f64, f64)> = None;
        for i in 0..grid.n_w {
            let w = grid.w_mm(i);
            let mut warm = column_start;
            for j in 0..grid.n_z {
                let pt = self.grind_point_from(w, grid.z_mm(j), warm)?;
                warm = Some(pt.offset_mm);
                if j == 0 {
                    column_start = warm;
                }
                out.points[i * grid.n_z + j] = pt;
            }
        }
        Ok(())
    }

    /// Feed coupling of this simulation.
    pub fn coupling(&self) -> &FeedCoupling {
        self.coupling
    }
}
