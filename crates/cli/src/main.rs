//! The `gearcomp` command: one binary, one subcommand per capability.
//!
//! Each subcommand lives in its own module (`cmd_*.rs`) with its clap `Args` and a `run`
//! function; `main` only parses, dispatches and maps errors to the exit code.

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

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
    Fit(Box<cmd_fit::Args>),
    /// Electronic helical guide for CNC gear shaping: G83 cycle, kinematics, servo
    /// simulation.
    Shape(cmd_shape::Args),
    /// Grinding-worm dressing: dresser design, axis corrections, worm life plan.
    Dress(cmd_dress::Args),
    /// Generating grinding with a dressed worm: contact path, worm-to-gear mapping,
    /// diagonal generating, ISO 1328 flank evaluation.
    Grind(cmd_grind::Args),
    /// The compensation service: sensors in (simulator, CSV replay, MQTT, Modbus TCP,
    /// OPC UA), offsets out (MQTT, Modbus TCP, OPC UA), every sample kept in SQLite or
    /// PostgreSQL, HTTP(S) API and dashboard; one machine or several per process.
    Serve(cmd_serve::Args),
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    let matches = accept_negative_values(Cli::command()).get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        Command::Gear(a) => cmd_gear::run(a),
        Command::Demo(a) => cmd_demo::run(a),
        Command::Replay(a) => cmd_replay::run(a),
        Command::Fit(a) => cmd_fit::run(*a),
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
            // A long value the user wrote (a 5000-character TOML value or CSV cell) is shown
            // by its start and length, in every command's message.
            let message = gearcomp_core::shorten::shorten_values(&chain_message(&e));
            eprintln!("gearcomp: error: {message}");
            ExitCode::from(2)
        }
    }
}

/// The error and its causes joined by ": " (as `{e:#}`), leaving out a cause whose text the
/// message already holds: an error that shows its source in its own text ("create a temporary
/// file in /x: No such file or directory") would otherwise repeat it.
fn chain_message(e: &anyhow::Error) -> String {
    let mut message = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if message.contains(&text) {
            continue;
        }
        if !message.is_empty() {
            message.push_str(": ");
        }
        message.push_str(&text);
    }
    message
}

fn is_broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Lets every option that takes a value accept a negative one as the next word
/// (`--helix -30`, `--worm-l -13.4,0.25`), not only as `--helix=-30`.
///
/// A single value accepts a word that is a number (`-30`, `-1.5e-3`); clap then never reads it
/// as a short flag. A comma-separated list accepts any word starting with a hyphen, so that
/// `-13.4,0.25` is a value; a missing value (`--worm-l --json`) then fails as "invalid value
/// '--json' for '--worm-l'" instead of being taken for the next option, which names the option
/// all the same. Applied to every subcommand, so a new option gets it without a word of its own.
fn accept_negative_values(cmd: clap::Command) -> clap::Command {
    let cmd = cmd.mut_args(|arg| {
        if arg.is_positional() || !arg.get_action().takes_values() {
            arg
        } else if arg.get_value_delimiter().is_some() {
            arg.allow_hyphen_values(true)
        } else {
            arg.allow_negative_numbers(true)
        }
    });
    let names: Vec<String> = cmd
        .get_subcommands()
        .map(|sub| sub.get_name().to_owned())
        .collect();
    names.into_iter().fold(cmd, |cmd, name| {
        cmd.mut_subcommand(name, accept_negative_values)
    })
}

/// A reader that closes the pipe early (`gearcomp grind simulate --json | head -1`, `| true`)
/// ends the program quietly, as it ends `cat` or `grep`.
///
/// Rust ignores SIGPIPE, so `println!` to a closed pipe panics with "failed printing to stdout:
/// Broken pipe" (exit 101 and a panic message). Output written with `write!` already returns the
/// error, which `main` maps to exit 0 (`is_broken_pipe`); for `print!`/`println!` this hook ends
/// the process with exit 0 instead of the panic report. Every other panic keeps the default
/// report.
fn quiet_on_closed_stdout() {
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        // std's message: "failed printing to stdout: Broken pipe (os error 32)".
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default_hook(info);
    }));
}
