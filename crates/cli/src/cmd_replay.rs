//! `gearcomp replay`: runs the compensation engine on a recorded log and writes the
//! offsets and alarms it would have made (CSV, written atomically).

use std::path::PathBuf;

use anyhow::Context;
use gearcomp_thermal::replay::replay_csv;
use gearcomp_thermal::{Engine, EngineConfig, EngineStatus};

/// Options of `gearcomp replay`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Engine configuration (TOML: channels, sampling, axes and their laws).
    #[arg(long, value_name = "FILE")]
    pub config: PathBuf,
    /// Recorded log (CSV with `time_s` and one column per channel; optional `trigger`,
    /// `safe_point`, `ack_stop` and `position_<axis>_mm` columns).
    #[arg(long, value_name = "FILE")]
    pub data: PathBuf,
    /// Output CSV of offsets and alarms (default: stdout).
    #[arg(long, value_name = "FILE")]
    pub out: Option<PathBuf>,
    /// Fail (exit 2) when the log has bad rows instead of reporting them and going on.
    #[arg(long)]
    pub strict: bool,
}

/// The log's text, decoded when it is not UTF-8 (with a note on stderr).
fn read_log(path: &std::path::Path) -> anyhow::Result<String> {
    let log = gearcomp_identify::encoding::read_log_text(path)
        .with_context(|| format!("reading {}", path.display()))?;
    if let Some(enc) = log.encoding {
        eprintln!(
            "gearcomp replay: {}: not UTF-8, read as {enc}",
            path.display()
        );
    }
    Ok(log.text)
}

/// Runs `gearcomp replay`.
pub fn run(args: Args) -> anyhow::Result<()> {
    let cfg = EngineConfig::load(&args.config)
        .with_context(|| format!("configuration {}", args.config.display()))?;
    let mut engine =
        Engine::new(&cfg).with_context(|| format!("configuration {}", args.config.display()))?;
    let replay = replay_csv(&mut engine, &read_log(&args.data)?)
        .with_context(|| format!("log {}", args.data.display()))?;
    for b in &replay.bad_rows {
        eprintln!(
            "gearcomp replay: {}:{}: {}",
            args.data.display(),
            b.line,
            b.message
        );
    }
    // --strict fails before any output: no offsets file (or stdout) from a refused log.
    if args.strict && !replay.bad_rows.is_empty() {
        anyhow::bail!(
            "--strict: {} bad rows in {} (see above); nothing written",
            replay.bad_rows.len(),
            args.data.display()
        );
    }
    let csv = replay.to_csv()?;
    match &args.out {
        Some(p) => gearcomp_core::fsio::write_atomic(p, csv.as_bytes())
            .with_context(|| format!("writing {}", p.display()))?,
        None => {
            use std::io::Write;
            std::io::stdout().lock().write_all(csv.as_bytes())?;
        }
    }
    let alarms = replay
        .rows
        .iter()
        .filter(|r| r.status == EngineStatus::Alarm)
        .count();
    let stops = replay
        .rows
        .iter()
        .filter(|r| r.status == EngineStatus::StopRequested)
        .count();
    let warnings = replay.rows.iter().filter(|r| !r.warning.is_empty()).count();
    eprintln!(
        "gearcomp replay: {} rows, {} bad rows, {} rows with alarms, {} with a stop request, {} with a warning (model extrapolating){}",
        replay.rows.len(),
        replay.bad_rows.len(),
        alarms,
        stops,
        warnings,
        args.out.as_ref().map_or(String::new(), |p| format!(
            "; offsets written to {}",
            p.display()
        ))
    );
    Ok(())
}
