//! Grinding simulation of the cylindrical chain (28): the [`Grinder`] (the envelope grinder of
//! [`crate::envelope`] on a [`WormGearPair`]) and the contact path fitted from the stored
//! feeds and worm points of its shortest cuts.
//!
//! The grinder itself and its grid and result types live in [`crate::envelope`]; they are
//! re-exported here under their former paths.

use nalgebra::{DMatrix, DVector};

use crate::contact::{ContactPath, WormGearPair};
use crate::error::{GrindError, Result};
use crate::kinematics::FeedCoupling;

pub use crate::envelope::{EnvelopeMode, FlankGrid, GroundFlank, GroundPoint};

/// The grinding simulation of one flank of a cylindrical worm and workpiece (chain (28)) with a
/// given worm and feed coupling: the envelope simulation of [`crate::envelope`] on a
/// [`WormGearPair`] (one algorithm for every chain).
pub type Grinder<'a> = crate::envelope::EnvelopeGrinder<'a, WormGearPair>;

/// Contact-path coefficients fitted from a simulation (A3 steps 5–7).
///
/// # Formula
/// Least squares over all ground points: z_F2 + z_V2* = C_Fw2·w_F2 + C_Fc2 (40);
/// w_F1* = a·w_F2 + b (R7); z_F1* + z_V1* = C_Fw1·w_F1* + C_Fc1 (39), where * marks the
/// stored state of each point's shortest cut.
/// # Source
/// JP6903407B2, (R6)/(R7) by simulation [SEED]; docs/grinding.md "Derivation: contact path fitted
/// from the simulation" [RECONSTRUCTED].
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
