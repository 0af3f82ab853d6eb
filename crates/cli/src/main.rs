//! The `gearcomp` command: one binary, one subcommand per capability.
//!
//! Each subcommand lives in its own module (`cmd_*.rs`) with its clap `Args` and a `run`
//! function; `main` only parses, dispatches and maps errors to the exit code.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod cmd_demo;
mod cmd_dress;
mod cmd_fit;
mod cmd_gear;
mod cmd_grind;
mod cmd_replay;
mod cmd_serve;
mod cmd_shape;

/// Thermal compensation, electronic helical guide, worm dressing and exact involute gear
/// geometry for gear-cutting and gear-grinding machines.
#[derive(Debug, Parser)]
#[command(name = "gearcomp", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Cylindrical involute gear geometry (ISO 21771 / DIN 3960): dimensions, tooth
    /// thickness, span and ball measurement, gear pairs.
    Gear(cmd_gear::Args),
    /// Simulates a shift on a preset machine with and without thermal compensation and
    /// writes an HTML report (the main job; runs on its embedded default).
    Demo(cmd_demo::Args),
    /// Runs the compensation engine on a recorded log and writes the offsets and alarms.
    Replay(cmd_replay::Args),
    /// Identifies a thermal model from measured data (sensor selection, regression,
    /// validation) and writes the model file and a report.
    Fit(cmd_fit::Args),
    /// Electronic helical guide for CNC gear shaping: G83 cycle, kinematics, servo
    /// simulation.
    Shape(cmd_shape::Args),
    /// Grinding-worm dressing: dresser design, axis corrections, worm life plan.
    Dress(cmd_dress::Args),
    /// Generating grinding with a dressed worm: contact path, worm-to-gear mapping,
    /// diagonal generating, ISO 1328 flank evaluation.
    Grind(cmd_grind::Args),
    /// The compensation service: sensors in (simulator, MQTT, Modbus TCP), offsets out,
    /// every sample kept in SQLite, HTTP API and dashboard.
    Serve(cmd_serve::Args),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Gear(a) => cmd_gear::run(a),
        Command::Demo(a) => cmd_demo::run(a),
        Command::Replay(a) => cmd_replay::run(a),
        Command::Fit(a) => cmd_fit::run(a),
        Command::Shape(a) => cmd_shape::run(a),
        Command::Dress(a) => cmd_dress::run(a),
        Command::Grind(a) => cmd_grind::run(a),
        Command::Serve(a) => cmd_serve::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if is_broken_pipe(&e) {
                return ExitCode::SUCCESS;
            }
            eprintln!("gearcomp: error: {e:#}");
            ExitCode::from(2)
        }
    }
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
