//! Dry-hobbing workpiece shrink (CN105397560): the workpiece temperature model
//! Ta = a0 + Σ a_i·t_i and the radial offset δT that makes the cooled gear right, combined
//! with the machine error δM into one radial offset.

use crate::data::Table;
use crate::error::{invalid, Result};
use crate::fit::predict;
use gearcomp_core::model::{
    AxisModel, LinearModel, ReferenceRadius, ShrinkGear, ShrinkMethod, WorkpieceShrink,
};
use gearcomp_geometry::shrink::{
    shrink_offset_exact_um, shrink_offset_first_order_um, ShrinkInput, ShrinkReference,
};

/// Degrees (interfaces) to radians (internal), from the geometry crate's units module.
pub use gearcomp_geometry::units::deg_to_rad;

/// Radial offset δT in µm for a workpiece cut at `ta_c` (°C).
///
/// # Formula
/// r = m_n·z/(2·cos β), tan α_t = tan α_n / cos β, ΔT_w = Ta − Tb;
/// δT(ρ) = (r/tan α_t)·[inv α*_ρ − inv α_ρ] (exact) or r·λ·ΔT_w·tan α_ρ/tan α_t
/// (first order), ρ = r (pitch) or d_a/2 (tip)
/// # Units
/// m_n, d_a in mm; angles in degrees at this interface; Ta, Tb in °C; result in µm.
/// # Source
/// CN105397560, [0037]–[0049], eqs. (7)–(8) [DERIVED: docs/geometry.md, "Derivation:
/// workpiece-shrink δT"], evaluated by
/// `gearcomp_geometry::shrink`; helical gears in the transverse section [DERIVED]
pub fn shrink_offset_um(w: &WorkpieceShrink, ta_c: f64) -> Result<f64> {
    let g = &w.gear;
    if !(ta_c.is_finite()) {
        return Err(invalid(
            "workpiece temperature Ta (°C)",
            ta_c,
            "a finite temperature",
        ));
    }
    if g.teeth < 3 {
        return Err(invalid("gear.teeth", g.teeth, "z ≥ 3"));
    }
    let beta = deg_to_rad(g.helix_angle_deg);
    if beta.is_nan() || beta.abs() >= deg_to_rad(60.0) {
        return Err(invalid(
            "gear.helix_angle_deg",
            g.helix_angle_deg,
            "−60° < β < 60°",
        ));
    }
    let reference = match w.reference {
        ReferenceRadius::Pitch => ShrinkReference::Pitch,
        ReferenceRadius::Tip => {
            let da = g.tip_diameter_mm.ok_or_else(|| {
                invalid(
                    "gear.tip_diameter_mm",
                    "missing",
                    "a tip diameter in mm for reference = tip",
                )
            })?;
            ShrinkReference::Radius(da / 2.0)
        }
    };
    let input = ShrinkInput::for_gear(
        g.normal_module_mm,
        g.teeth,
        deg_to_rad(g.pressure_angle_deg),
        beta,
        w.expansion_per_k,
        ta_c - w.design_temp_c,
        reference,
    );
    Ok(match w.method {
        ShrinkMethod::Exact => shrink_offset_exact_um(&input)?,
        ShrinkMethod::FirstOrder => shrink_offset_first_order_um(&input)?,
    })
}

/// Builds and checks the workpiece part of an axis model.
pub fn workpiece_shrink(
    temperature: LinearModel,
    gear: ShrinkGear,
    design_temp_c: f64,
    expansion_per_k: f64,
    reference: ReferenceRadius,
    method: ShrinkMethod,
) -> Result<WorkpieceShrink> {
    let w = WorkpieceShrink {
        temperature,
        design_temp_c,
        expansion_per_k,
        gear,
        reference,
        method,
    };
    let probe = gearcomp_core::model::ModelFile {
        format: gearcomp_core::model::MODEL_FORMAT.into(),
        name: "check".into(),
        description: String::new(),
        restart_after_s: None,
        axes: vec![AxisModel {
            axis: "X".into(),
            target: String::new(),
            machine: LinearModel {
                intercept: 0.0,
                terms: Vec::new(),
            },
            workpiece: Some(w.clone()),
        }],
        provenance: None,
        envelopes: Vec::new(),
    };
    probe.validate()?;
    shrink_offset_um(&w, design_temp_c + 10.0)?;
    Ok(w)
}

/// Total radial offset δM + δT in µm at every row of `table`, as the engine computes it.
///
/// # Formula
/// offset = δM(t) + δT(Ta(t)),  Ta = a0 + Σ a_i·transform_i(t_i)
/// # Source
/// CN105397560, "total compensation δM + δT as an X offset" [SEED]
pub fn combined_offsets_um(table: &Table, axis: &AxisModel) -> Result<Vec<f64>> {
    let mut out = predict(table, &axis.machine)?;
    if let Some(w) = &axis.workpiece {
        let ta = predict(table, &w.temperature)?;
        for (o, t) in out.iter_mut().zip(ta) {
            *o += shrink_offset_um(w, t)?;
        }
    }
    Ok(out)
}
