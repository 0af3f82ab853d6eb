//! Grinding simulation: the envelope of the (modified) worm flank over the gear flank.
//!
//! Every gear grid point (w_F2, z_F2) carries a vector along its outward normal; the worm, at
//! every machine state (φ2, z_V2) with φ1 from the generating coupling and z_V1 from the feed
//! coupling, shortens it to where it meets the worm flank. The final length is the ground
//! normal deviation f_n2, and the worm point (w_F1, z_F1) and feed of the shortest cut are
//! stored with it. Instead of discrete time steps (which leave feed marks) the shortest cut is
//! found by minimising over rotation and feed directly ("exact-time" variant, digest §9.3 T1;
//! ERRATA §7). The contact path is then fitted from the stored feeds and worm points.

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use crate::contact::{ContactPath, WormGearPair};
use crate::error::{check_range, GrindError, Result};
use crate::kinematics::FeedCoupling;

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
    /// Envelope and second-order model agree (within `conical_sim::SECOND_ORDER_ABS_MM` +
    /// `SECOND_ORDER_REL`·|second-order correction|), and the worm touches with its flank.
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

/// The grinding simulation of one flank of a cylindrical worm and workpiece (chain (28)) with a
/// given worm and feed coupling: the envelope simulation of [`crate::conical_sim`] on a
/// [`WormGearPair`] (one algorithm for every chain).
pub type Grinder<'a> = crate::conical_sim::EnvelopeGrinder<'a, WormGearPair>;

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
