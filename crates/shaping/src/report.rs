//! The result of one G83 cycle in the units the user reads (degrees, rpm, rev/s², µm, µrad),
//! with its text lines and the HTML report of `gearcomp shape run`.
//!
//! [`CycleReport::new`] gathers the gear, the coupling demands of the [`Interpolator`], the
//! whole-cut [`ExecutionSummary`] and the servo [`SimulationResult`]; conversions from the
//! library's rad, rad/s and mm happen here only, through [`crate::units`].

use std::fmt::Write as _;

use gearcomp_report::{Chart, HtmlReport, Series};
use serde::Serialize;

use crate::coupling::{Hand, Mesh};
use crate::gcode::{G83Block, MachineData};
use crate::interpolator::Interpolator;
use crate::simulate::{ExecutionSummary, SimulationResult, TracePoint};
use crate::units::{mm_to_um, rad_s2_to_rev_s2, rad_s_to_rpm, rad_to_deg};

/// Microradians per radian.
const URAD_PER_RAD: f64 = 1e6;

/// One G83 cycle: its source line, the gear and coupling, the whole cut, the servo simulation.
#[derive(Debug, Clone, Serialize)]
pub struct CycleReport {
    /// 1-based line of the block in the part program.
    pub line: usize,
    /// The block as written (trimmed).
    pub block: String,
    /// Gear, cutter, coupling and stroke.
    pub gear: GearSummary,
    /// The whole cut through the interpolator.
    pub execution: ExecutionSummary,
    /// The evaluated strokes with the servo models.
    pub simulation: SimSummary,
}

/// Gear, cutter, exact coupling and the C2 demands of a cycle.
#[derive(Debug, Clone, Serialize)]
pub struct GearSummary {
    /// Workpiece teeth Z_C1.
    pub workpiece_teeth: u32,
    /// Cutter teeth Z_C2.
    pub cutter_teeth: u32,
    /// External or internal gear (JSON: the variant name, `External`).
    #[serde(serialize_with = "variant_name")]
    pub mesh: Mesh,
    /// Helix hand (JSON: the variant name, `Right`).
    #[serde(serialize_with = "variant_name")]
    pub hand: Hand,
    /// Normal module m_n (mm).
    pub normal_module_mm: f64,
    /// Helix angle β (deg, unsigned).
    pub helix_deg: f64,
    /// Helix correction Δβ (deg).
    pub delta_beta_deg: f64,
    /// Cutter lead P_z (mm).
    pub cutter_lead_mm: f64,
    /// Workpiece lead (mm).
    pub workpiece_lead_mm: f64,
    /// Exact generating ratio C2/C1 as "numerator/denominator".
    pub generating_ratio: String,
    /// C1 encoder counts per double stroke.
    pub c1_counts_per_stroke: i64,
    /// Circular feed realised by the integer counts (mm).
    pub realised_circular_feed_mm: f64,
    /// Crank radius R (mm).
    pub crank_radius_mm: f64,
    /// Connecting-rod length L (mm).
    pub rod_length_mm: f64,
    /// Double strokes per minute S.
    pub strokes_per_min: f64,
    /// Peak stroke velocity (mm/s).
    pub v_z_peak_mm_s: f64,
    /// Crank angle of the peak stroke velocity (deg).
    pub v_z_peak_theta_deg: f64,
    /// Peak C2 speed demand (rpm).
    pub c2_speed_peak_rpm: f64,
    /// C2 speed limit (rpm).
    pub c2_speed_limit_rpm: f64,
    /// Peak C2 acceleration demand (rev/s²).
    pub c2_accel_peak_rev_s2: f64,
    /// C2 acceleration limit (rev/s²).
    pub c2_accel_limit_rev_s2: f64,
}

/// The servo simulation of a cycle: C2 tracking and the helix slope deviation f_Hβ.
#[derive(Debug, Clone, Serialize)]
pub struct SimSummary {
    /// Double strokes simulated.
    pub strokes: u32,
    /// Control cycle (ms).
    pub cycle_ms: f64,
    /// C1 and C2 modelled as ideal drives.
    pub ideal_servos: bool,
    /// Largest C2 error (µrad).
    pub c2_error_max_urad: f64,
    /// RMS C2 error (µrad).
    pub c2_error_rms_urad: f64,
    /// Largest C2 error while the cutter is in the face (µrad).
    pub c2_error_in_face_max_urad: f64,
    /// Largest |transverse deviation| at the base circle (µm).
    pub deviation_max_um: f64,
    /// None (null) for a spur gear: a straight tooth trace has no lead.
    pub design_lead_mm: Option<f64>,
    /// None (null) for a spur gear; its trace's residual slope is f_Hβ.
    pub simulated_lead_mm: Option<f64>,
    /// None (null) for a spur gear.
    pub lead_rel_error: Option<f64>,
    /// Evaluation length L_β (mm).
    pub evaluation_length_mm: f64,
    /// Helix slope deviation f_Hβ (µm).
    pub f_h_beta_um: f64,
    /// ISO 1328-1:2013 tolerance f_HβT of the class (µm); None (null) when the gear is
    /// outside the standard's scope (5 ≤ d ≤ 15 000 mm, 0.5 ≤ m_n ≤ 70 mm).
    pub f_h_beta_tolerance_um: Option<f64>,
    /// ISO 1328-1 flank tolerance class.
    pub iso_class: u8,
    /// f_Hβ within f_HβT; None (null) outside the standard's scope.
    pub within_tolerance: Option<bool>,
}

/// What the reports say instead of a verdict for a gear outside ISO 1328-1:2013's scope.
const OUT_OF_ISO_SCOPE: &str = "no ISO 1328-1 tolerance (reference diameter or module \
     outside the standard's scope 5 <= d <= 15000 mm, 0.5 <= m_n <= 70 mm)";

/// Writes `External` / `Right` (the variant's name) into the JSON report, as this command
/// always has, while TOML elsewhere uses the lower-case names of the shared vocabulary.
fn variant_name<T: std::fmt::Debug, S: serde::Serializer>(
    v: &T,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    s.collect_str(&format_args!("{v:?}"))
}

impl CycleReport {
    /// The report of `block` (written as `source`) run with machine data `m`: `ip` its
    /// interpolator, `execution` the whole cut, `sim` the servo simulation.
    pub fn new(
        block: &G83Block,
        source: String,
        ip: &Interpolator,
        m: &MachineData,
        execution: ExecutionSummary,
        sim: &SimulationResult,
    ) -> Self {
        CycleReport {
            line: block.line,
            block: source,
            gear: GearSummary::new(block, ip),
            execution,
            simulation: SimSummary::new(m, sim),
        }
    }

    /// The text lines of the cycle: gear, cutter, coupling, stroke, C2 demand, program,
    /// tracking, helix and the ISO 1328-1 verdict.
    pub fn text(&self) -> String {
        let (g, e, s) = (&self.gear, &self.execution, &self.simulation);
        let mut out = String::new();
        let _ = writeln!(out, "G83 on line {}: {}", self.line, self.block);
        let _ = writeln!(
            out,
            "  gear      Z_C1 = {} ({:?}, {:?} hand), m_n = {} mm, beta = {} deg, delta beta = {} deg",
            g.workpiece_teeth, g.mesh, g.hand, g.normal_module_mm, g.helix_deg, g.delta_beta_deg
        );
        let _ = writeln!(
            out,
            "  cutter    Z_C2 = {}, lead P_z = {:.5} mm; workpiece lead {:.5} mm",
            g.cutter_teeth, g.cutter_lead_mm, g.workpiece_lead_mm
        );
        let _ = writeln!(
            out,
            "  coupling  C2/C1 = {} (exact), C1 {} counts/stroke (circular feed {:.5} mm)",
            g.generating_ratio, g.c1_counts_per_stroke, g.realised_circular_feed_mm
        );
        let _ = writeln!(
            out,
            "  stroke    R = {} mm, L = {} mm, S = {} /min, v_Z peak {:.3} mm/s at {:.2} deg",
            g.crank_radius_mm,
            g.rod_length_mm,
            g.strokes_per_min,
            g.v_z_peak_mm_s,
            g.v_z_peak_theta_deg
        );
        let _ = writeln!(
            out,
            "  C2 demand speed {:.3} rpm (limit {:.1}), acceleration {:.3} rev/s^2 (limit {:.1}): feasible",
            g.c2_speed_peak_rpm, g.c2_speed_limit_rpm, g.c2_accel_peak_rev_s2, g.c2_accel_limit_rev_s2
        );
        let _ = writeln!(
            out,
            "  program   {} double strokes, {} cycles, {:.1} s; X infeed {:.4} mm; C1 {:.4} rev; \
             coupling residual {} (exact: 0 = no drift)",
            e.strokes, e.cycles, e.cut_time_s, e.x_infeed_mm, e.c1_revolutions, e.coupling_residual
        );
        s.text_into(&mut out);
        out
    }

    /// The quantity/value table of the cycle in the HTML report.
    fn table_rows(&self) -> Vec<Vec<String>> {
        let (g, s, e) = (&self.gear, &self.simulation, &self.execution);
        let row = |k: &str, v: String| vec![k.to_string(), v];
        vec![
            row(
                "workpiece / cutter teeth",
                format!("{} / {}", g.workpiece_teeth, g.cutter_teeth),
            ),
            row("mesh, hand", format!("{:?}, {:?}", g.mesh, g.hand)),
            row(
                "m_n, beta, delta beta",
                format!(
                    "{} mm, {} deg, {} deg",
                    g.normal_module_mm, g.helix_deg, g.delta_beta_deg
                ),
            ),
            row("cutter lead P_z", format!("{:.5} mm", g.cutter_lead_mm)),
            row("generating ratio C2/C1 (exact)", g.generating_ratio.clone()),
            row(
                "peak C2 speed / limit",
                format!(
                    "{:.3} / {:.1} rpm",
                    g.c2_speed_peak_rpm, g.c2_speed_limit_rpm
                ),
            ),
            row(
                "peak C2 acceleration / limit",
                format!(
                    "{:.3} / {:.1} rev/s^2",
                    g.c2_accel_peak_rev_s2, g.c2_accel_limit_rev_s2
                ),
            ),
            row(
                "whole cut",
                format!(
                    "{} strokes, {:.1} s, coupling residual {}",
                    e.strokes, e.cut_time_s, e.coupling_residual
                ),
            ),
            row(
                "C2 error max / rms",
                format!(
                    "{:.3} / {:.3} urad",
                    s.c2_error_max_urad, s.c2_error_rms_urad
                ),
            ),
            row(
                "design / simulated lead",
                match (s.design_lead_mm, s.simulated_lead_mm) {
                    (Some(d), Some(m)) => format!("{d:.6} / {m:.6} mm"),
                    _ => "spur gear: no lead".to_string(),
                },
            ),
            row(
                "f_Hbeta / ISO 1328-1 tolerance",
                match (s.f_h_beta_tolerance_um, s.within_tolerance) {
                    (Some(t), Some(ok)) => format!(
                        "{:.4} um / {t} um (class {}): {}",
                        s.f_h_beta_um,
                        s.iso_class,
                        if ok { "OK" } else { "out of tolerance" }
                    ),
                    _ => format!("{:.4} um / {OUT_OF_ISO_SCOPE}", s.f_h_beta_um),
                },
            ),
        ]
    }
}

impl GearSummary {
    /// The gear and coupling of `block` as set up in `ip`.
    pub fn new(block: &G83Block, ip: &Interpolator) -> Self {
        let cfg = ip.config();
        let cut = cfg.cut;
        let d = ip.demands();
        let rho = cut.generating_ratio();
        GearSummary {
            workpiece_teeth: cut.z_c1(),
            cutter_teeth: cut.z_c2(),
            mesh: cut.mesh(),
            hand: cut.hand(),
            normal_module_mm: cut.m_n_mm(),
            helix_deg: block.params.helix_deg.abs(),
            delta_beta_deg: block.params.delta_beta_deg,
            cutter_lead_mm: cut.cutter_lead_mm(),
            workpiece_lead_mm: cut.workpiece_lead_mm(),
            generating_ratio: format!("{}/{}", rho.numer(), rho.denom()),
            c1_counts_per_stroke: ip.c1_counts_per_stroke(),
            realised_circular_feed_mm: d.realised_circular_feed_mm,
            crank_radius_mm: cfg.crank.crank_radius_mm(),
            rod_length_mm: cfg.crank.rod_length_mm(),
            strokes_per_min: cfg.strokes_per_min,
            v_z_peak_mm_s: d.v_z_peak_mm_s,
            v_z_peak_theta_deg: rad_to_deg(d.theta_peak_rad),
            c2_speed_peak_rpm: rad_s_to_rpm(d.c2_speed_rad_s),
            c2_speed_limit_rpm: rad_s_to_rpm(cfg.c2_limits.max_speed_rad_s),
            c2_accel_peak_rev_s2: rad_s2_to_rev_s2(d.c2_accel_rad_s2),
            c2_accel_limit_rev_s2: rad_s2_to_rev_s2(cfg.c2_limits.max_accel_rad_s2),
        }
    }
}

impl SimSummary {
    /// The simulation `sim` run with machine data `m`.
    pub fn new(m: &MachineData, sim: &SimulationResult) -> Self {
        let l = sim.lead;
        let dev_max = sim
            .trace
            .iter()
            .map(|p| p.deviation_um.abs())
            .fold(0.0, f64::max);
        SimSummary {
            strokes: m.strokes,
            cycle_ms: m.cycle_ms,
            ideal_servos: m.c1.ideal && m.c2.ideal,
            c2_error_max_urad: sim.c2_error_max_rad * URAD_PER_RAD,
            c2_error_rms_urad: sim.c2_error_rms_rad * URAD_PER_RAD,
            c2_error_in_face_max_urad: sim.c2_error_cutting_max_rad * URAD_PER_RAD,
            deviation_max_um: dev_max,
            design_lead_mm: l.design_lead_mm,
            simulated_lead_mm: l.measured_lead_mm,
            lead_rel_error: l.lead_rel_error,
            evaluation_length_mm: l.evaluation_length_mm,
            f_h_beta_um: l.f_h_beta_um,
            f_h_beta_tolerance_um: l.tolerance_um,
            iso_class: l.iso_class,
            within_tolerance: l.within_tolerance,
        }
    }

    /// The tracking and helix lines.
    fn text_into(&self, out: &mut String) {
        let s = self;
        let _ = writeln!(
            out,
            "  tracking  {} strokes at {} ms{}: C2 error max {:.3} urad, rms {:.3} urad, in face {:.3} \
             urad; deviation at base circle max {:.4} um",
            s.strokes,
            s.cycle_ms,
            if s.ideal_servos { " (ideal servos)" } else { "" },
            s.c2_error_max_urad,
            s.c2_error_rms_urad,
            s.c2_error_in_face_max_urad,
            s.deviation_max_um
        );
        let lead = match (s.design_lead_mm, s.simulated_lead_mm, s.lead_rel_error) {
            (Some(d), Some(m), Some(r)) => {
                format!("design lead {d:.6} mm, simulated {m:.6} mm (relative {r:.3e})")
            }
            _ => "spur gear (straight tooth trace, no lead)".to_string(),
        };
        let verdict = match (s.f_h_beta_tolerance_um, s.within_tolerance) {
            (Some(t), Some(ok)) => format!(
                "ISO 1328-1 class {} f_HbT = {t} um: {}",
                s.iso_class,
                if ok { "OK" } else { "OUT OF TOLERANCE" }
            ),
            _ => OUT_OF_ISO_SCOPE.to_string(),
        };
        let _ = writeln!(
            out,
            "  helix     {lead}; f_Hb = {:.4} um over L_b = {:.2} mm; {verdict}",
            s.f_h_beta_um, s.evaluation_length_mm,
        );
    }
}

/// The HTML report of a program: per cycle its block, the quantity table and the stroke,
/// velocity, C2 error, deviation and X charts over the crank angle (`reports` and `sims`
/// in the same order).
pub fn html_report(
    reports: &[CycleReport],
    sims: &[SimulationResult],
) -> gearcomp_report::Result<HtmlReport> {
    let mut html = HtmlReport::new(
        "gearcomp shape: electronic helical guide (Procedia CIRP 56 (2016) 173–177)",
    );
    for (r, sim) in reports.iter().zip(sims) {
        html.heading(&format!("G83, line {}", r.line));
        html.preformatted(&r.block);
        html.table(&["quantity", "value"], &r.table_rows());
        for chart in stroke_charts(sim) {
            html.chart(&chart)?;
        }
    }
    Ok(html)
}

/// The five charts of a simulated stroke over the crank angle (deg).
fn stroke_charts(sim: &SimulationResult) -> [Chart; 5] {
    let pts = |f: &dyn Fn(&TracePoint) -> f64| -> Vec<(f64, f64)> {
        sim.trace
            .iter()
            .map(|p| (rad_to_deg(p.theta_rad), f(p)))
            .collect()
    };
    let angle = "crank angle / deg";
    [
        Chart::new("Stroke position", angle, "Z / mm").with(Series::line("Z", pts(&|p| p.z_mm))),
        Chart::new("Stroke velocity", angle, "v_Z / (mm/s)")
            .with(Series::line("v_Z", pts(&|p| p.v_z_mm_s))),
        Chart::new("C2 error against the ideal coupling", angle, "error / urad").with(
            Series::line("C2 error", pts(&|p| p.c2_error_rad * URAD_PER_RAD)),
        ),
        Chart::new(
            "Transverse deviation at the workpiece base circle",
            angle,
            "deviation / um",
        )
        .with(Series::line("deviation", pts(&|p| p.deviation_um))),
        Chart::new("X: infeed and return-stroke lift-off", angle, "X / um")
            .with(Series::line("X command", pts(&|p| mm_to_um(p.x_mm)))),
    ]
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::gcode::parse_program;
    use crate::simulate::{execute_program, simulate};

    /// Runs the first block of `program` with 2 simulated strokes.
    fn run(program: &str, ideal: bool) -> (CycleReport, SimulationResult) {
        let mut m = MachineData {
            strokes: 2,
            ..MachineData::default()
        };
        if ideal {
            m.c1.ideal = true;
            m.c2.ideal = true;
            m.delay_compensation_cycles = 0.0;
        }
        let p = parse_program(program).unwrap();
        let block = &p.cycles[0];
        let cfg = block.to_simulation(&m).unwrap();
        let ip = Interpolator::new(cfg.interp).unwrap();
        let execution = execute_program(&cfg.interp).unwrap();
        let sim = simulate(&cfg).unwrap();
        let r = CycleReport::new(block, program.trim().to_string(), &ip, &m, execution, &sim);
        (r, sim)
    }

    #[test]
    fn helical_cycle_against_closed_forms() {
        // z = 40, m_n = 3 mm, β = 15°: workpiece lead p_z = π·m_n·z / sin β.
        let (r, sim) = run("G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40", true);
        let g = &r.gear;
        let lead = std::f64::consts::PI * 3.0 * 40.0 / 15f64.to_radians().sin();
        assert!(
            (g.workpiece_lead_mm - lead).abs() < 1e-9,
            "{}",
            g.workpiece_lead_mm
        );
        assert_eq!((g.workpiece_teeth, g.helix_deg), (40, 15.0));
        // S = 300 double strokes per minute, as written.
        assert_eq!(g.strokes_per_min, 300.0);
        // rpm = rad/s · 60 / 2π, rev/s² = rad/s² / 2π.
        let two_pi = 2.0 * std::f64::consts::PI;
        let cfg = parse_program("G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 B40")
            .unwrap()
            .cycles[0]
            .to_simulation(&MachineData::default())
            .unwrap();
        let ip = Interpolator::new(cfg.interp).unwrap();
        let d = ip.demands();
        assert!((g.c2_speed_peak_rpm - d.c2_speed_rad_s * 60.0 / two_pi).abs() < 1e-9);
        assert!((g.c2_accel_peak_rev_s2 - d.c2_accel_rad_s2 / two_pi).abs() < 1e-9);
        // The largest |deviation| of the trace, found here by a plain loop.
        let mut dev = 0.0f64;
        for p in &sim.trace {
            if p.deviation_um.abs() > dev {
                dev = p.deviation_um.abs();
            }
        }
        assert_eq!(r.simulation.deviation_max_um, dev);
        assert!((r.simulation.c2_error_max_urad - sim.c2_error_max_rad * 1e6).abs() < 1e-9);
        let text = r.text();
        assert_eq!(text.lines().count(), 9, "{text}");
        assert!(text.contains("(ideal servos)") && text.contains("design lead 1456.58"));
        let html = html_report(std::slice::from_ref(&r), std::slice::from_ref(&sim))
            .unwrap()
            .to_html();
        assert!(html.contains("G83, line 1") && html.contains("X: infeed and return-stroke"));
    }

    #[test]
    fn spur_cycle_has_no_lead() {
        let (r, _) = run("G83 T40 L25 Q3 P0 R25 K200 S300 F0.5 B40", false);
        assert!(r.simulation.design_lead_mm.is_none());
        let text = r.text();
        assert!(
            text.contains("spur gear (straight tooth trace, no lead)"),
            "{text}"
        );
        assert!(!text.contains("(ideal servos)"));
        assert_eq!(r.table_rows()[9][1], "spur gear: no lead");
    }
}
