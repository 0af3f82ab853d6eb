//! `gearcomp gear` (under construction by its capability's issue).

/// Options of `gearcomp gear`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp gear`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp gear is not built yet")
}
