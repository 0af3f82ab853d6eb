//! `gearcomp demo`: simulates a shift on a preset machine, runs the thermal compensation
//! engine in closed loop, prints the gear size error with and without compensation
//! (max, RMS and drift range as ISO 230-3 reports drift) and writes an HTML report.

use std::path::PathBuf;

use anyhow::Context;
use gearcomp_core::model::ModelFile;
use gearcomp_thermal::demo::{use_model_file, ShiftReport};
use gearcomp_thermal::presets::{self, Preset};
use gearcomp_thermal::{run_closed_loop, Engine, Simulator};

/// Options of `gearcomp demo`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Machine preset: grinder (JPH0761598B2), shaper (EP0138375) or hobbing (CN105397560, dry, model file).
    #[arg(long, default_value = "grinder")]
    pub preset: String,
    /// Shift length in hours (default: the preset's shift, 8 h).
    #[arg(long)]
    pub hours: Option<f64>,
    /// Seed of the sensor and probe noise (runs are reproducible).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A thermal model file (`gearcomp fit` output) to use instead of the preset's law;
    /// its channel names must be the preset's sensor names.
    #[arg(long, value_name = "FILE")]
    pub model: Option<PathBuf>,
    /// HTML report path.
    #[arg(long, default_value = "gearcomp-demo.html")]
    pub out: PathBuf,
    /// Print the figures as JSON on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `gearcomp demo`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let preset = Preset::from_name(&args.preset)?;
    let mut bundle = presets::bundle(preset);
    let hours = args.hours.unwrap_or(bundle.shift_h);
    if !(hours.is_finite() && hours > 0.0 && hours <= 336.0) {
        anyhow::bail!("invalid --hours = {hours}: expected 0 < hours ≤ 336");
    }
    let mut law = bundle.summary.clone();
    if let Some(path) = &args.model {
        let model = ModelFile::load(path)
            .with_context(|| format!("loading the model file {}", path.display()))?;
        law = use_model_file(&mut bundle, preset, &path.display().to_string(), model)
            .context("the model file has no axis")?;
    }
    let mut engine = Engine::new(&bundle.config).context("building the compensation engine")?;
    let mut sim = Simulator::new(bundle.machine.clone(), args.seed)?;
    // A progress line for a person at a terminal; a log file or a pipe gets one line at the
    // end instead of a hundred carriage returns.
    let interactive = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let run = run_closed_loop(&mut sim, &mut engine, hours, |f| {
        if interactive {
            eprint!(
                "\rgearcomp demo: simulating {hours} h on the {} preset {:>3.0} %",
                preset.name(),
                100.0 * f
            )
        }
    })?;
    if interactive {
        eprintln!();
    } else {
        eprintln!(
            "gearcomp demo: simulated {hours} h on the {} preset",
            preset.name()
        );
    }
    let shift = ShiftReport {
        preset: preset.name(),
        machine: &bundle.machine.description,
        law: &law,
        hours,
        seed: args.seed,
        run: &run,
    };
    let cfg_toml = bundle.config.to_toml_string().unwrap_or_default();
    shift
        .html(&cfg_toml)?
        .write(&args.out)
        .with_context(|| format!("writing the report {}", args.out.display()))?;
    if args.json {
        let v = shift.to_json(&args.out.display().to_string());
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print!("{}", shift.text());
        println!("report: {}", args.out.display());
    }
    Ok(())
}
