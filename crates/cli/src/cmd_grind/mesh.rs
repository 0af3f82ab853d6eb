//! What `gearcomp grind` needs of a worm–workpiece mesh beyond the grinding crate's
//! kinematics: the cylindrical [`WormGearPair`] and the conical [`ConicalPair`] behind one
//! trait, so `simulate` and the report run the same code on both.

use super::*;

/// What `grind_and_report` needs of a worm–workpiece mesh beyond the simulation kinematics and
/// the analytic map (both in the grinding crate).
pub(super) trait GrindMesh: AnalyticTransfer {
    /// The mesh named in error messages.
    const NAME: &'static str;
    /// The contact path for the output.
    fn path_out(&self) -> PathReport;
    /// Default worm line direction ρ_F1 (rad): the axial-section estimate of the worm flank.
    fn rho1_default_rad(&self) -> f64;
    /// Reference roll distance of the worm flank (mm), where a worm modification is centred.
    fn worm_ref_mm(&self) -> f64;
    /// Reference roll distance of the gear flank (mm), where the wanted gear modification is
    /// centred.
    fn gear_ref_mm(&self) -> f64;
    /// K_ZV1 for a wanted gear line direction ρ_F2 (`--gear-rho-deg`) and, where it exists,
    /// the line map X_F1 = k·X_F2 + c0.
    fn gear_line_choice(
        &self,
        rho1_rad: f64,
        rho2_rad: f64,
        shift_offset_mm: f64,
    ) -> Result<(f64, Option<LineMap>)>;
}

impl GrindMesh for WormGearPair {
    const NAME: &'static str = "worm–gear pair";

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
        shift_offset_mm: f64,
    ) -> Result<(f64, Option<LineMap>)> {
        let lm = line_map(self, rho1_rad, rho2_rad, shift_offset_mm)
            .context("diagonal ratio for --gear-rho-deg")?;
        Ok((lm.k_zv1, Some(lm)))
    }

    fn path_out(&self) -> PathReport {
        PathReport::cylindrical(self)
    }
}

impl GrindMesh for ConicalPair {
    const NAME: &'static str = "conical pair";

    fn rho1_default_rad(&self) -> f64 {
        conical::rho1_estimate_rad(&self.worm)
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
        shift_offset_mm: f64,
    ) -> Result<(f64, Option<LineMap>)> {
        let k = self
            .diagonal_ratio(rho1_rad, rho2_rad)
            .context("diagonal ratio for --gear-rho-deg (conical)")?;
        // the line map exists wherever K does, except for profile lines on a chain whose
        // roll relation (86) depends on the feeds; then only K is reported
        let lm = conical_lines::conical_line_map(self, rho1_rad, rho2_rad, shift_offset_mm)
            .ok()
            .map(|m| m.line);
        Ok((k, lm))
    }

    fn path_out(&self) -> PathReport {
        PathReport::conical(self)
    }
}
