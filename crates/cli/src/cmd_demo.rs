//! `gearcomp demo`: simulates a shift on a preset machine, runs the thermal compensation
//! engine in closed loop, prints the gear size error with and without compensation
//! (max, RMS and drift range as ISO 230-3 reports drift) and writes an HTML report.

use std::path::PathBuf;

use anyhow::Context;
use gearcomp_core::model::ModelFile;
use gearcomp_report::{Chart, HtmlReport, Series};
use gearcomp_thermal::presets::{self, Preset};
use gearcomp_thermal::{
    run_closed_loop, ClosedLoopRun, DriftStats, Engine, Sign, Simulator, TermConfig,
};

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

fn stats_json(s: &DriftStats) -> serde_json::Value {
    serde_json::json!({ "max_abs_um": s.max_abs_um, "rms_um": s.rms_um, "range_um": s.range_um })
}

/// Keeps at most `n` evenly spaced points so the report stays small.
fn thin(x: &[f64], y: &[f64], n: usize) -> Vec<(f64, f64)> {
    let step = (x.len() / n.max(1)).max(1);
    x.iter()
        .zip(y)
        .step_by(step)
        .map(|(a, b)| (*a, *b))
        .collect()
}

fn report(
    run: &ClosedLoopRun,
    title: &str,
    lines: &[String],
    cfg_toml: &str,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    let (u, c) = (run.uncompensated(), run.compensated());
    let mut r = HtmlReport::new(title);
    r.heading("Result");
    for l in lines {
        r.paragraph(l);
    }
    let row = |name: &str, s: &DriftStats| {
        vec![
            name.to_string(),
            format!("{:.2}", s.max_abs_um),
            format!("{:.2}", s.rms_um),
            format!("{:.2}", s.range_um),
        ]
    };
    r.table(
        &[
            "gear size error (centre distance)",
            "max |e| / µm",
            "RMS / µm",
            "drift range / µm",
        ],
        &[
            row("without compensation", &u),
            row("with compensation", &c),
        ],
    );
    let n = 900;
    let mut temps = Chart::new(
        "Sensor temperatures and ambient",
        "time / h",
        "temperature / °C",
    );
    let mut disp = Chart::new("Displacement sensors", "time / h", "reading / µm");
    for (name, s) in run.sensor_names.iter().zip(&run.sensors) {
        let series = Series::line(name.clone(), thin(&run.time_h, s, n));
        if name.ends_with("_um") {
            disp.series.push(series);
        } else {
            temps.series.push(series);
        }
    }
    temps.series.push(Series::line(
        "ambient",
        thin(&run.time_h, &run.ambient_c, n),
    ));
    r.heading("Temperatures");
    r.chart(&temps)?;
    if !disp.series.is_empty() {
        r.chart(&disp)?;
    }
    r.heading("Drift, offset and residual");
    r.chart(
        &Chart::new(
            "Centre-distance drift: without and with compensation",
            "time / h",
            "size error / µm",
        )
        .with(Series::line(
            "without compensation (true drift)",
            thin(&run.time_h, &run.drift_um, n),
        ))
        .with(Series::line(
            "with compensation (residual)",
            thin(&run.time_h, &run.residual_um, n),
        )),
    )?;
    r.chart(
        &Chart::new("Applied offset", "time / h", "offset / µm").with(Series::line(
            "applied offset",
            thin(&run.time_h, &run.offset_um, n),
        )),
    )?;
    r.chart(
        &Chart::new(
            "Residual error with compensation",
            "time / h",
            "residual / µm",
        )
        .with(Series::line(
            "residual",
            thin(&run.time_h, &run.residual_um, n),
        )),
    )?;
    r.heading("Engine configuration");
    r.preformatted(cfg_toml);
    r.paragraph(
        "Sign convention: a positive offset increases the centre distance; the residual is drift + offset. \
         Drift range is max − min over the shift (ISO 230-3 total drift). The machine is simulated by a \
         lumped thermal network with illustrative constants tuned to the magnitudes of EP0138375, JPH0761598B2 and CN105397560.",
    );
    r.write(out)
        .with_context(|| format!("writing the report {}", out.display()))?;
    Ok(())
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
        let axis = &mut bundle.config.axes[0];
        let model_axis = model
            .axes
            .iter()
            .find(|a| a.axis == axis.name)
            .or(model.axes.first())
            .map(|a| a.axis.clone())
            .context("the model file has no axis")?;
        let key = path.display().to_string();
        axis.terms = vec![TermConfig::Model {
            file: key.clone(),
            axis: model_axis.clone(),
            sign: Sign::Plus,
        }];
        law = format!(
            "model file {key} (\"{}\", axis {model_axis}) on the {} preset",
            model.name,
            preset.name()
        );
        bundle.config.insert_model(key, model);
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
    let (u, c) = (run.uncompensated(), run.compensated());
    let cfg_toml = bundle.config.to_toml_string().unwrap_or_default();
    let title = format!(
        "gearcomp demo: {} ({hours} h, seed {})",
        bundle.machine.description, args.seed
    );
    let lines = vec![
        format!("Law: {law}."),
        format!(
            "Without compensation the size error reaches {:.1} µm (drift range {:.1} µm); with compensation {:.1} µm (range {:.1} µm).",
            u.max_abs_um, u.range_um, c.max_abs_um, c.range_um
        ),
        format!("Alarm cycles: {}, stop-request cycles: {}, infeed pulses issued: {}.", run.alarm_cycles, run.stop_cycles, run.pulse_total),
    ];
    report(&run, &title, &lines, &cfg_toml, &args.out)?;
    if args.json {
        let v = serde_json::json!({
            "preset": preset.name(),
            "machine": bundle.machine.description,
            "law": law,
            "hours": hours,
            "seed": args.seed,
            "uncompensated": stats_json(&u),
            "compensated": stats_json(&c),
            "alarm_cycles": run.alarm_cycles,
            "stop_cycles": run.stop_cycles,
            "pulse_total": run.pulse_total,
            "report": args.out.display().to_string(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!("{title}");
        println!("law: {law}");
        println!("gear size error (centre distance)   max |e| / µm   RMS / µm   drift range / µm");
        println!(
            "  without compensation              {:>12.2} {:>10.2} {:>18.2}",
            u.max_abs_um, u.rms_um, u.range_um
        );
        println!(
            "  with compensation                 {:>12.2} {:>10.2} {:>18.2}",
            c.max_abs_um, c.rms_um, c.range_um
        );
        if c.max_abs_um > 0.0 {
            println!(
                "max |e| reduced {:.1}×; alarms {}, stops {}, pulses {}",
                u.max_abs_um / c.max_abs_um,
                run.alarm_cycles,
                run.stop_cycles,
                run.pulse_total
            );
        }
        println!("report: {}", args.out.display());
    }
    Ok(())
}
