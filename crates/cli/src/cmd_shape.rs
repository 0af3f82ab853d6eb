//! `gearcomp shape`: the electronic helical guide for CNC gear shaping (Procedia CIRP 56 (2016) 173–177).
//!
//! `gearcomp shape run program.nc` parses the G83 cycle(s), checks feasibility, runs the whole
//! cut through the interpolator (exact coupling check), simulates the last strokes with the
//! servo models and prints the C2 tracking error and the helix slope deviation f_Hβ against
//! ISO 1328-1:2013. Degrees, rpm and µm appear here; the library works in rad, rad/s and mm.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use gearcomp_shaping::gcode::{parse_program, MachineData};
use gearcomp_shaping::interpolator::Interpolator;
use gearcomp_shaping::report::{html_report, CycleReport};
use gearcomp_shaping::simulate::{execute_program, simulate};
use gearcomp_shaping::ShapingError;

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
    let configs = program
        .cycles
        .iter()
        .map(|block| block.to_simulation(&machine))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| located(&a.program, e))?;
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
        let report = CycleReport::new(block, source, &ip, &machine, execution, &sim);
        if a.json {
            let last = i + 1 == program.cycles.len();
            let sep = if last { "" } else { "," };
            writeln!(stdout, "{}{sep}", serde_json::to_string_pretty(&report)?)?;
        } else {
            write!(stdout, "{}", report.text())?;
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
        html_report(&reports, &sims)?
            .write(path)
            .with_context(|| format!("cannot write report {}", path.display()))?;
        if !a.json {
            writeln!(stdout, "report written to {}", path.display())?;
        }
    }
    Ok(())
}
