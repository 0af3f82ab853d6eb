//! One trait over the cylindrical [`WormGearPair`] and the conical [`ConicalPair`] for what a
//! grinding run needs beyond the envelope kinematics ([`crate::envelope::MeshKinematics`])
//! and the analytic map ([`AnalyticTransfer`]): the default worm line direction, the
//! reference roll distances a modification is centred on, the diagonal ratio for a wanted
//! gear line direction, and the contact path for the report. `gearcomp grind` is generic over
//! it, so `simulate` and `solve` run the same code on both chains.

use crate::conical::{self, ConicalPair};
use crate::conical_lines::conical_line_map;
use crate::contact::WormGearPair;
use crate::diagonal::{line_map, rho1_estimate_rad, LineMap};
use crate::envelope::AnalyticTransfer;
use crate::report::PathReport;
use crate::Result;

/// A worm–workpiece mesh a grinding run can use (cylindrical chain (28) or conical chains
/// (29)–(31)).
pub trait GrindingMesh: AnalyticTransfer {
    /// The mesh named in error messages.
    const NAME: &'static str;
    /// The chain is conical (its diagonal ratio and line map are those of (76)/(77)/(86)).
    const CONICAL: bool;
    /// The contact path for the report.
    fn path_report(&self) -> PathReport;
    /// Default worm line direction ρ_F1 (rad): the axial-section estimate of the worm flank,
    /// tan ρ_F1 ≈ s/tan β_bF1.
    fn rho1_default_rad(&self) -> f64;
    /// Reference roll distance of the worm flank (mm), where a worm modification is centred.
    fn worm_ref_mm(&self) -> f64;
    /// Reference roll distance of the gear flank (mm), where the wanted gear modification is
    /// centred.
    fn gear_ref_mm(&self) -> f64;
    /// K_ZV1 that maps worm lines of direction ρ_F1 onto gear lines of direction ρ_F2 and,
    /// where it exists, the line map X_F1 = k·X_F2 + c0 at the shift offset z_V01.
    ///
    /// # Errors
    /// The diagonal ratio's error (e.g. ρ_F2 = ρ_KF, singular).
    fn gear_line_choice(
        &self,
        rho1_rad: f64,
        rho2_rad: f64,
        z_v01_mm: f64,
    ) -> Result<(f64, Option<LineMap>)>;
}

impl GrindingMesh for WormGearPair {
    const NAME: &'static str = "worm–gear pair";
    const CONICAL: bool = false;

    fn path_report(&self) -> PathReport {
        PathReport::cylindrical(self)
    }

    fn rho1_default_rad(&self) -> f64 {
        rho1_estimate_rad(self)
    }

    fn worm_ref_mm(&self) -> f64 {
        self.worm.w_ref_mm
    }

    fn gear_ref_mm(&self) -> f64 {
        self.gear.w_ref_mm
    }

    fn gear_line_choice(
        &self,
        rho1_rad: f64,
        rho2_rad: f64,
        z_v01_mm: f64,
    ) -> Result<(f64, Option<LineMap>)> {
        let lm = line_map(self, rho1_rad, rho2_rad, z_v01_mm)?;
        Ok((lm.k_zv1, Some(lm)))
    }
}

impl GrindingMesh for ConicalPair {
    const NAME: &'static str = "conical pair";
    const CONICAL: bool = true;

    fn path_report(&self) -> PathReport {
        PathReport::conical(self)
    }

    fn rho1_default_rad(&self) -> f64 {
        conical::rho1_estimate_rad(&self.worm)
    }

    fn worm_ref_mm(&self) -> f64 {
        self.worm.w_ref_mm
    }

    fn gear_ref_mm(&self) -> f64 {
        self.gear.w_ref_mm
    }

    /// The line map exists wherever K does, except for profile lines on a chain whose roll
    /// relation (86) depends on the feeds; then only K is returned.
    fn gear_line_choice(
        &self,
        rho1_rad: f64,
        rho2_rad: f64,
        z_v01_mm: f64,
    ) -> Result<(f64, Option<LineMap>)> {
        let k = self.diagonal_ratio(rho1_rad, rho2_rad)?;
        let lm = conical_line_map(self, rho1_rad, rho2_rad, z_v01_mm)
            .ok()
            .map(|m| m.line);
        Ok((k, lm))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::conical::BeveloidGear;
    use crate::flank::{Flank, Hand, InvoluteGear};

    fn pairs() -> (WormGearPair, ConicalPair) {
        let (a, b) = (20f64.to_radians(), 15f64.to_radians());
        let gear = InvoluteGear::new(31, 3.0, a, b).unwrap();
        let worm = InvoluteGear::worm(1, 3.0, a, 50.0, Hand::Right).unwrap();
        let cyl = WormGearPair::reference(&worm, &gear, Flank::Right).unwrap();
        let bev1 = BeveloidGear::new(worm, 0.0).unwrap();
        let bev2 = BeveloidGear::new(gear, 0.0).unwrap();
        let con = ConicalPair::reference(&bev1, &bev2, Flank::Right).unwrap();
        (cyl, con)
    }

    /// With both cone angles 0 the conical chain is the cylindrical one: the two
    /// implementations, written over different chains, agree.
    #[test]
    fn zero_cones_agree_with_the_cylindrical_chain() {
        let (cyl, con) = pairs();
        close(cyl.rho1_default_rad(), con.rho1_default_rad(), 1e-12);
        close(cyl.worm_ref_mm(), con.worm_ref_mm(), 1e-9);
        close(cyl.gear_ref_mm(), con.gear_ref_mm(), 1e-9);
        let (r1, r2) = (cyl.rho1_default_rad(), 30f64.to_radians());
        let (k_cyl, lm_cyl) = cyl.gear_line_choice(r1, r2, 0.0).unwrap();
        let (k_con, _) = con.gear_line_choice(r1, r2, 0.0).unwrap();
        close(k_cyl, k_con, 1e-6 * k_cyl.abs().max(1.0));
        assert!(lm_cyl.is_some());
        let (pc, pk) = (cyl.path_report(), con.path_report());
        close(pc.centre_distance_mm, pk.centre_distance_mm, 1e-9);
        assert!(pc.conical.is_none() && pk.conical.is_some());
        const { assert!(!WormGearPair::CONICAL && ConicalPair::CONICAL) };
    }

    /// tan ρ_F1 = s/tan β_bF1 (axial-section estimate), written out.
    #[test]
    fn default_worm_line_is_the_axial_section_estimate() {
        let (cyl, _) = pairs();
        let s = cyl.worm.s();
        close(
            cyl.rho1_default_rad().tan(),
            s / cyl.worm.beta_b_rad.tan(),
            1e-12,
        );
    }

    fn close(a: f64, b: f64, tol: f64) {
        assert!((a - b).abs() <= tol, "{a} vs {b} (tol {tol})");
    }
}
