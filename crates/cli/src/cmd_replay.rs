//! `gearcomp replay` (under construction by its capability's issue).

/// Options of `gearcomp replay`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp replay`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp replay is not built yet")
}
