//! The contact path (76)/(77)/(86) of any worm–workpiece chain ((28)–(31)), fitted from
//! envelope simulations ([`crate::envelope`]) at two or more feed couplings.
//!
//! The envelope grinder and the mesh trait are re-exported here under their former paths.

use nalgebra::{DMatrix, DVector};

use crate::conical::ConicalPath;
use crate::envelope::GroundFlank;
use crate::error::{GrindError, Result};
use crate::kinematics::FeedCoupling;

pub use crate::envelope::{EnvelopeGrinder, MeshKinematics, SECOND_ORDER_ABS_MM, SECOND_ORDER_REL};

/// Contact-path coefficients of any chain fitted from simulations (A3 step 8).
///
/// # Formula
/// Least squares (QR) over all ground points of all runs, with z_V1* = F_ZV1(z_V2*) of each
/// run: z_F2 = C_Fw2·w_F2 + C_FzV12·z_V1* + C_FzV22·z_V2* + C_Fc2 (77);
/// w_F1* = a·w_F2 + b_zv1·z_V1* + b_zv2·z_V2* + b (86);
/// z_F1* = C_Fw1·w_F1* + C_FzV11·z_V1* + C_FzV21·z_V2* + C_Fc1 (76).
/// # Domain
/// One coupling makes z_V1 a function of z_V2, so at least two runs whose couplings differ
/// (e.g. two z_V01) are needed: "at least two different z_V1" (JP6903407B2, text to eqs. (50),
/// (51), (58)).
/// # Source
/// JP6903407B2, (R6)/(R7) by simulation [SEED]; docs/grinding.md "Derivation: contact path fitted
/// from the simulation" [RECONSTRUCTED].
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
