//! The HTML report of `gearcomp grind` (deviation maps and ISO 1328-1 traces).

use super::*;

/// SVG heat map of a (w, z) map: w to the right, z upwards (drawn by the report crate).
pub(super) fn heat_map_svg(title: &str, map: &MapReport, values: &[Vec<f64>]) -> String {
    let w = HeatAxis::new("w", "roll distance", "mm", map.w_mm.clone());
    let z = HeatAxis::new("z", "width", "mm", map.z_mm.clone());
    HeatMap {
        title,
        x: &w,
        y: &z,
        value_unit: "µm",
        cells: values,
    }
    .to_svg()
}

pub(super) fn write_report(out: &GrindReport, path: &std::path::Path) -> Result<()> {
    let mut r = HtmlReport::new(format!(
        "gearcomp grind {} — {} flank",
        out.mode, out.path.flank
    ));
    r.heading("Set-up and results")
        .preformatted(&out.to_table());
    r.paragraph(
        "Deviations are transverse (f_Ft, along the base tangent), in µm, positive = material \
         left on the gear. The ground flank is the envelope of the worm over rotation and feed; \
         the analytic map is the first-order worm→gear mapping along the contact path.",
    );
    r.heading("Ground flank over (w, z)");
    r.raw_svg(&heat_map_svg(
        "ground f_Ft2 / µm",
        &out.map,
        &out.map.ground_um,
    ));
    r.heading(&format!("Deviation from the {}", out.deviation_reference));
    r.raw_svg(&heat_map_svg(
        "deviation / µm",
        &out.map,
        &out.map.deviation_um,
    ));
    trace_charts(&mut r, out)?;
    iso_section(&mut r, &out.iso1328);
    r.write(path)
        .with_context(|| format!("writing report {}", path.display()))?;
    Ok(())
}

/// Profile and helix traces of the deviation map at the evaluation lines.
fn trace_charts(r: &mut HtmlReport, out: &GrindReport) -> Result<()> {
    let (e, map) = (&out.iso1328, &out.map);
    let jz = MapReport::nearest(&map.z_mm, e.profile_z_mm);
    let iw = MapReport::nearest(&map.w_mm, e.helix_w_mm);
    r.chart(
        &Chart::new(
            format!("Profile deviation at z = {:.2} mm", map.z_mm[jz]),
            "roll distance w / mm",
            "deviation / µm",
        )
        .with(Series::line(
            "deviation",
            map.profile_trace(&map.deviation_um, jz),
        ))
        .with(Series::line(
            "envelope − analytic map",
            map.envelope_minus_analytic_trace(jz),
        )),
    )?;
    r.chart(
        &Chart::new(
            format!("Helix deviation at w = {:.3} mm", map.w_mm[iw]),
            "width z / mm",
            "deviation / µm",
        )
        .with(Series::line(
            "deviation",
            map.helix_trace(&map.deviation_um, iw),
        )),
    )?;
    Ok(())
}

/// The ISO 1328-1 table and its ranges and verdict.
fn iso_section(r: &mut HtmlReport, e: &FlankEvaluation) {
    r.heading("ISO 1328-1:2013 evaluation");
    let rows: Vec<Vec<String>> = iso_rows(e)
        .into_iter()
        .map(|(n, v, t, ok)| {
            vec![
                n.to_string(),
                format!("{v:.3}"),
                t.map_or("–".into(), |t| format!("{t:.1}")),
                ok.map_or("–".into(), |ok| if ok { "yes".into() } else { "NO".into() }),
            ]
        })
        .collect();
    r.table(
        &["quantity", "value / µm", "tolerance / µm", "within"],
        &rows,
    );
    r.paragraph(&format!(
        "Class {}; profile evaluation range {:.3}…{:.3} mm of roll distance (95 % of the active \
         profile from its start), helix evaluation range {:.3}…{:.3} mm (face width less min(5 % b, \
         m_n) per end). Verdict: {}.",
        e.tolerances
            .map_or("–".to_string(), |t| t.class.to_string()),
        e.profile.range_mm.0,
        e.profile.range_mm.1,
        e.helix.range_mm.0,
        e.helix.range_mm.1,
        match e.within_tolerance {
            Some(true) => "within tolerance",
            Some(false) => "out of tolerance",
            None => OUT_OF_SCOPE,
        }
    ));
}
