//! `gearcomp shape`: the electronic helical guide for CNC gear shaping (Procedia CIRP 56 (2016) 173–177).
//!
//! `gearcomp shape run program.nc` parses the G83 cycle(s), checks feasibility, runs the whole
//! cut through the interpolator (exact coupling check), simulates the last strokes with the
//! servo models and prints the C2 tracking error and the helix slope deviation f_Hβ against
//! ISO 1328-1:2013. Degrees, rpm and µm appear here; the library works in rad, rad/s and mm.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use gearcomp_report::{Chart, HtmlReport, Series};
use gearcomp_shaping::coupling::{Hand, Mesh};
use gearcomp_shaping::gcode::{parse_program, G83Block, MachineData};
use gearcomp_shaping::interpolator::Interpolator;
use gearcomp_shaping::simulate::{execute_program, simulate, ExecutionSummary, SimulationResult};
use gearcomp_shaping::units::{mm_to_um, rad_s2_to_rev_s2, rad_s_to_rpm, rad_to_deg};
use gearcomp_shaping::ShapingError;
use serde::Serialize;

/// Options of `gearcomp shape`.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: ShapeCommand,
}

#[derive(Debug, clap::Subcommand)]
enum ShapeCommand {
    /// Runs the G83 cycle(s) of a part program in simulation and prints the result.
    Run(RunArgs),
}

#[derive(Debug, clap::Args)]
struct RunArgs {
    /// Part program with one or more G83 blocks, e.g.
    /// `G83 T40 L25 Q3 P15 R25 K200 S300 F0.5 U0.02 B40`.
    program: PathBuf,
    /// Machine data (TOML): cycle time, encoder resolutions, C2/X limits, servo loops.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Print the result as JSON instead of text.
    #[arg(long)]
    json: bool,
    /// Write an HTML report with stroke, velocity and C2-error plots.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Double strokes to simulate with the servo model (the last is evaluated).
    #[arg(long)]
    strokes: Option<u32>,
    /// Control cycle time in ms (0.25–4), overrides the machine data.
    #[arg(long)]
    cycle_ms: Option<f64>,
    /// ISO 1328-1:2013 flank tolerance class (1–11) for the f_Hβ verdict.
    #[arg(long)]
    class: Option<u8>,
    /// Model C1 and C2 as ideal drives (actual = command, no delay).
    #[arg(long)]
    ideal_servos: bool,
}

/// Runs `gearcomp shape`.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        ShapeCommand::Run(a) => run_program(a),
    }
}

#[derive(Debug, Serialize)]
struct CycleReport {
    line: usize,
    block: String,
    gear: GearSummary,
    execution: ExecutionSummary,
    simulation: SimSummary,
}

#[derive(Debug, Serialize)]
struct GearSummary {
    workpiece_teeth: u32,
    cutter_teeth: u32,
    #[serde(serialize_with = "variant_name")]
    mesh: Mesh,
    #[serde(serialize_with = "variant_name")]
    hand: Hand,
    normal_module_mm: f64,
    helix_deg: f64,
    delta_beta_deg: f64,
    cutter_lead_mm: f64,
    workpiece_lead_mm: f64,
    generating_ratio: String,
    c1_counts_per_stroke: i64,
    realised_circular_feed_mm: f64,
    crank_radius_mm: f64,
    rod_length_mm: f64,
    strokes_per_min: f64,
    v_z_peak_mm_s: f64,
    v_z_peak_theta_deg: f64,
    c2_speed_peak_rpm: f64,
    c2_speed_limit_rpm: f64,
    c2_accel_peak_rev_s2: f64,
    c2_accel_limit_rev_s2: f64,
}

#[derive(Debug, Serialize)]
struct SimSummary {
    strokes: u32,
    cycle_ms: f64,
    ideal_servos: bool,
    c2_error_max_urad: f64,
    c2_error_rms_urad: f64,
    c2_error_in_face_max_urad: f64,
    deviation_max_um: f64,
    /// None (null) for a spur gear: a straight tooth trace has no lead.
    design_lead_mm: Option<f64>,
    /// None (null) for a spur gear; its trace's residual slope is f_Hβ.
    simulated_lead_mm: Option<f64>,
    /// None (null) for a spur gear.
    lead_rel_error: Option<f64>,
    evaluation_length_mm: f64,
    f_h_beta_um: f64,
    f_h_beta_tolerance_um: f64,
    iso_class: u8,
    within_tolerance: bool,
}

/// Writes `External` / `Right` (the variant's name) into the JSON report, as this command
/// always has, while TOML elsewhere uses the lower-case names of the shared vocabulary.
fn variant_name<T: std::fmt::Debug, S: serde::Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
    s.collect_str(&format_args!("{v:?}"))
}

fn load_machine(a: &RunArgs) -> anyhow::Result<MachineData> {
    let mut m = match &a.machine {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read machine data {}", p.display()))?;
            toml::from_str::<MachineData>(&text)
                .with_context(|| format!("invalid machine data {}", p.display()))?
        }
        None => MachineData::default(),
    };
    if let Some(s) = a.strokes {
        m.strokes = s;
    }
    if let Some(c) = a.cycle_ms {
        m.cycle_ms = c;
    }
    if let Some(c) = a.class {
        m.iso_class = c;
    }
    if a.ideal_servos {
        m.c1.ideal = true;
        m.c2.ideal = true;
        m.delay_compensation_cycles = 0.0;
    }
    Ok(m)
}

fn located(path: &Path, e: ShapingError) -> anyhow::Error {
    match e {
        ShapingError::Parse {
            line,
            column,
            message,
        } => anyhow::anyhow!("{}:{line}:{column}: {message}", path.display()),
        other => anyhow::anyhow!("{}: {other}", path.display()),
    }
}

fn run_program(a: RunArgs) -> anyhow::Result<()> {
    use std::io::Write as _;
    let machine = load_machine(&a)?;
    let text = std::fs::read_to_string(&a.program)
        .with_context(|| format!("cannot read part program {}", a.program.display()))?;
    // At most MAX_G83_BLOCKS blocks (refused at parse time); every block is checked with its
    // line before any runs, then each result is printed as soon as it is computed.
    let program = parse_program(&text).map_err(|e| located(&a.program, e))?;
    let mut configs = Vec::with_capacity(program.cycles.len());
    for block in &program.cycles {
        configs.push(
            block
                .to_simulation(&machine)
                .map_err(|e| located(&a.program, e))?,
        );
    }
    let lines: Vec<&str> = text.lines().collect();
    let mut stdout = std::io::stdout().lock();
    let mut reports = Vec::new();
    let mut sims = Vec::new();
    if a.json {
        writeln!(stdout, "[")?;
    }
    for (i, (block, cfg)) in program.cycles.iter().zip(&configs).enumerate() {
        let at = |e: ShapingError| located(&a.program, block.locate(e));
        let ip = Interpolator::new(cfg.interp).map_err(at)?;
        let execution = execute_program(&cfg.interp).map_err(at)?;
        let sim = simulate(cfg).map_err(at)?;
        let source = lines
            .get(block.line - 1)
            .map_or("", |l| l.trim())
            .to_string();
        let report = summarise(block, source, &ip, &machine, execution, &sim);
        if a.json {
            let sep = if i + 1 < program.cycles.len() {
                ","
            } else {
                ""
            };
            writeln!(stdout, "{}{sep}", serde_json::to_string_pretty(&report)?)?;
        } else {
            print_text(&mut stdout, &report)?;
        }
        stdout.flush()?;
        if a.report.is_some() {
            reports.push(report);
            sims.push(sim);
        }
    }
    if a.json {
        writeln!(stdout, "]")?;
    }
    if let Some(path) = &a.report {
        write_report(path, &reports, &sims)?;
        if !a.json {
            writeln!(stdout, "report written to {}", path.display())?;
        }
    }
    Ok(())
}

fn summarise(
    block: &G83Block,
    source: String,
    ip: &Interpolator,
    m: &MachineData,
    execution: ExecutionSummary,
    sim: &SimulationResult,
) -> CycleReport {
    let cfg = ip.config();
    let cut = cfg.cut;
    let d = ip.demands();
    let rho = cut.generating_ratio();
    let l = sim.lead;
    let dev_max = sim
        .trace
        .iter()
        .map(|p| p.deviation_um.abs())
        .fold(0.0, f64::max);
    CycleReport {
        line: block.line,
        block: source,
        gear: GearSummary {
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
        },
        execution,
        simulation: SimSummary {
            strokes: m.strokes,
            cycle_ms: m.cycle_ms,
            ideal_servos: m.c1.ideal && m.c2.ideal,
            c2_error_max_urad: sim.c2_error_max_rad * 1e6,
            c2_error_rms_urad: sim.c2_error_rms_rad * 1e6,
            c2_error_in_face_max_urad: sim.c2_error_cutting_max_rad * 1e6,
            deviation_max_um: dev_max,
            design_lead_mm: l.design_lead_mm,
            simulated_lead_mm: l.measured_lead_mm,
            lead_rel_error: l.lead_rel_error,
            evaluation_length_mm: l.evaluation_length_mm,
            f_h_beta_um: l.f_h_beta_um,
            f_h_beta_tolerance_um: l.tolerance_um,
            iso_class: l.iso_class,
            within_tolerance: l.within_tolerance,
        },
    }
}

fn print_text(out: &mut impl std::io::Write, r: &CycleReport) -> std::io::Result<()> {
    let g = &r.gear;
    let e = &r.execution;
    let s = &r.simulation;
    writeln!(out, "G83 on line {}: {}", r.line, r.block)?;
    writeln!(
        out,
        "  gear      Z_C1 = {} ({:?}, {:?} hand), m_n = {} mm, beta = {} deg, delta beta = {} deg",
        g.workpiece_teeth, g.mesh, g.hand, g.normal_module_mm, g.helix_deg, g.delta_beta_deg
    )?;
    writeln!(
        out,
        "  cutter    Z_C2 = {}, lead P_z = {:.5} mm; workpiece lead {:.5} mm",
        g.cutter_teeth, g.cutter_lead_mm, g.workpiece_lead_mm
    )?;
    writeln!(
        out,
        "  coupling  C2/C1 = {} (exact), C1 {} counts/stroke (circular feed {:.5} mm)",
        g.generating_ratio, g.c1_counts_per_stroke, g.realised_circular_feed_mm
    )?;
    writeln!(
        out,
        "  stroke    R = {} mm, L = {} mm, S = {} /min, v_Z peak {:.3} mm/s at {:.2} deg",
        g.crank_radius_mm,
        g.rod_length_mm,
        g.strokes_per_min,
        g.v_z_peak_mm_s,
        g.v_z_peak_theta_deg
    )?;
    writeln!(
        out,
        "  C2 demand speed {:.3} rpm (limit {:.1}), acceleration {:.3} rev/s^2 (limit {:.1}): feasible",
        g.c2_speed_peak_rpm, g.c2_speed_limit_rpm, g.c2_accel_peak_rev_s2, g.c2_accel_limit_rev_s2
    )?;
    writeln!(
        out,
        "  program   {} double strokes, {} cycles, {:.1} s; X infeed {:.4} mm; C1 {:.4} rev; \
         coupling residual {} (exact: 0 = no drift)",
        e.strokes, e.cycles, e.cut_time_s, e.x_infeed_mm, e.c1_revolutions, e.coupling_residual
    )?;
    writeln!(
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
    )?;
    let lead = match (s.design_lead_mm, s.simulated_lead_mm, s.lead_rel_error) {
        (Some(d), Some(m), Some(r)) => {
            format!("design lead {d:.6} mm, simulated {m:.6} mm (relative {r:.3e})")
        }
        _ => "spur gear (straight tooth trace, no lead)".to_string(),
    };
    writeln!(
        out,
        "  helix     {lead}; f_Hb = {:.4} um over L_b = {:.2} mm; ISO 1328-1 class {} f_HbT = {} \
         um: {}",
        s.f_h_beta_um,
        s.evaluation_length_mm,
        s.iso_class,
        s.f_h_beta_tolerance_um,
        if s.within_tolerance {
            "OK"
        } else {
            "OUT OF TOLERANCE"
        }
    )?;
    Ok(())
}

fn write_report(
    path: &Path,
    reports: &[CycleReport],
    sims: &[SimulationResult],
) -> anyhow::Result<()> {
    let mut html = HtmlReport::new(
        "gearcomp shape: electronic helical guide (Procedia CIRP 56 (2016) 173–177)",
    );
    for (r, sim) in reports.iter().zip(sims) {
        html.heading(&format!("G83, line {}", r.line));
        html.preformatted(&r.block);
        let g = &r.gear;
        let s = &r.simulation;
        let row = |k: &str, v: String| vec![k.to_string(), v];
        html.table(
            &["quantity", "value"],
            &[
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
                        r.execution.strokes, r.execution.cut_time_s, r.execution.coupling_residual
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
                    format!(
                        "{:.4} um / {} um (class {}): {}",
                        s.f_h_beta_um,
                        s.f_h_beta_tolerance_um,
                        s.iso_class,
                        if s.within_tolerance {
                            "OK"
                        } else {
                            "out of tolerance"
                        }
                    ),
                ),
            ],
        );
        let pts = |f: &dyn Fn(&gearcomp_shaping::simulate::TracePoint) -> f64| -> Vec<(f64, f64)> {
            sim.trace
                .iter()
                .map(|p| (rad_to_deg(p.theta_rad), f(p)))
                .collect()
        };
        html.chart(
            &Chart::new("Stroke position", "crank angle / deg", "Z / mm")
                .with(Series::line("Z", pts(&|p| p.z_mm))),
        )?;
        html.chart(
            &Chart::new("Stroke velocity", "crank angle / deg", "v_Z / (mm/s)")
                .with(Series::line("v_Z", pts(&|p| p.v_z_mm_s))),
        )?;
        html.chart(
            &Chart::new(
                "C2 error against the ideal coupling",
                "crank angle / deg",
                "error / urad",
            )
            .with(Series::line("C2 error", pts(&|p| p.c2_error_rad * 1e6))),
        )?;
        html.chart(
            &Chart::new(
                "Transverse deviation at the workpiece base circle",
                "crank angle / deg",
                "deviation / um",
            )
            .with(Series::line("deviation", pts(&|p| p.deviation_um))),
        )?;
        html.chart(
            &Chart::new(
                "X: infeed and return-stroke lift-off",
                "crank angle / deg",
                "X / um",
            )
            .with(Series::line("X command", pts(&|p| mm_to_um(p.x_mm)))),
        )?;
    }
    html.write(path)
        .with_context(|| format!("cannot write report {}", path.display()))?;
    Ok(())
}
