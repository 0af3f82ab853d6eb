//! `gearcomp demo` (under construction by its capability's issue).

/// Options of `gearcomp demo`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp demo`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp demo is not built yet")
}
