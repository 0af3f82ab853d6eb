//! Axis corrections as a function of the worm's axial position: ΔK(ν_zS) for topological
//! (width-dependent) dressing. A constant [`AxisCorrection`] is the trivial schedule; a
//! polynomial or a dressing program (spline through solved nodes) varies over the width.
//! Read by the full simulation ([`crate::simulation::simulate_scheduled`]) and built by the
//! topological solves ([`crate::topology`]).
//!
//! # Source
//! JP6903407B2, eqs. (15)–(17), Fig. 2 [SEED]; docs/dressing.md "Derivation: topological
//! programs" [RECONSTRUCTED]

use crate::error::{DressError, Result};
use crate::kinematics::AxisCorrection;
use crate::spline::Spline;
use serde::{Deserialize, Serialize};

/// Axis corrections as a function of the worm's axial position ν_zS (mm).
pub trait CorrectionSchedule {
    /// ΔK at the uncorrected axial position ν_zS = p·t.
    fn at(&self, nu_zs_mm: f64) -> AxisCorrection;
    /// True when ΔK does not depend on ν_zS (the dressing motion is then a screw).
    fn is_constant(&self) -> bool {
        false
    }
}

impl CorrectionSchedule for AxisCorrection {
    fn at(&self, _nu_zs_mm: f64) -> AxisCorrection {
        *self
    }
    fn is_constant(&self) -> bool {
        true
    }
}

/// ΔK(ν_zS) = Σ_k c_k ν_zS^k, componentwise (c_k in rad/mm^k or mm/mm^k).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolynomialSchedule {
    /// Coefficients c_0, c_1, … (c_0 is ΔK at ν_zS = 0).
    pub coeffs: Vec<AxisCorrection>,
}

impl PolynomialSchedule {
    /// ΔK(ν) = c_0 + c_1·ν: a correction varying linearly over the worm width.
    pub fn linear(at_zero: AxisCorrection, per_mm: AxisCorrection) -> Self {
        Self {
            coeffs: vec![at_zero, per_mm],
        }
    }
}

impl CorrectionSchedule for PolynomialSchedule {
    /// # Formula
    /// ΔK(ν) = Σ_k c_k ν^k (Horner, per component)
    fn at(&self, nu_zs_mm: f64) -> AxisCorrection {
        let mut acc = [0.0; 4];
        for c in self.coeffs.iter().rev() {
            let a = c.to_array();
            for (x, ck) in acc.iter_mut().zip(a.iter()) {
                *x = *x * nu_zs_mm + ck;
            }
        }
        AxisCorrection::from_array(acc)
    }
    fn is_constant(&self) -> bool {
        self.coeffs.len() <= 1
    }
}

/// ΔK(ν_zS) through solved nodes (a dressing program): natural cubic spline per component,
/// held constant beyond the first and last node (the machine keeps the end values).
#[derive(Debug, Clone, PartialEq)]
pub struct TabulatedSchedule {
    nu_mm: Vec<f64>,
    nodes: Vec<AxisCorrection>,
    splines: [Spline; 4],
}

impl TabulatedSchedule {
    /// Schedule through (ν_k, ΔK_k); at least 2 nodes with distinct ν (any order); two nodes
    /// give the straight line through them.
    pub fn new(nodes: &[(f64, AxisCorrection)]) -> Result<Self> {
        if nodes.len() < 2 {
            return Err(DressError::OutOfRange {
                field: "schedule nodes (count)",
                value: nodes.len() as f64,
                min: 2.0,
                max: f64::INFINITY,
            });
        }
        let mut sorted = nodes.to_vec();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        // A natural spline through three collinear knots is that line: two nodes get their
        // midpoint added (for the splines only; `nodes()` returns what was given).
        let mut knots = sorted.clone();
        if knots.len() == 2 {
            let (a, b) = (knots[0], knots[1]);
            let mid: Vec<f64> =
                a.1.to_array()
                    .iter()
                    .zip(b.1.to_array().iter())
                    .map(|(x, y)| 0.5 * (x + y))
                    .collect();
            knots.insert(
                1,
                (
                    0.5 * (a.0 + b.0),
                    AxisCorrection::from_array([mid[0], mid[1], mid[2], mid[3]]),
                ),
            );
        }
        let nu: Vec<f64> = sorted.iter().map(|n| n.0).collect();
        let knot_nu: Vec<f64> = knots.iter().map(|n| n.0).collect();
        let comp = |j: usize| -> Result<Spline> {
            Spline::new(
                knot_nu.clone(),
                knots.iter().map(|n| n.1.to_array()[j]).collect(),
            )
            .map_err(|_| {
                DressError::Geometry(
                    "schedule nodes need distinct, finite axial positions ν_zS".into(),
                )
            })
        };
        Ok(Self {
            splines: [comp(0)?, comp(1)?, comp(2)?, comp(3)?],
            nodes: sorted.iter().map(|n| n.1).collect(),
            nu_mm: nu,
        })
    }

    /// The nodes (ν_zS mm, ΔK), sorted by ν_zS.
    pub fn nodes(&self) -> Vec<(f64, AxisCorrection)> {
        self.nu_mm
            .iter()
            .copied()
            .zip(self.nodes.iter().copied())
            .collect()
    }
}

impl CorrectionSchedule for TabulatedSchedule {
    fn at(&self, nu_zs_mm: f64) -> AxisCorrection {
        let lo = self.nu_mm[0];
        let hi = self.nu_mm[self.nu_mm.len() - 1];
        let x = nu_zs_mm.clamp(lo, hi);
        AxisCorrection::from_array([
            self.splines[0].eval(x).0,
            self.splines[1].eval(x).0,
            self.splines[2].eval(x).0,
            self.splines[3].eval(x).0,
        ])
    }
}
