//! `gearcomp grind` (under construction by its capability's issue).

/// Options of `gearcomp grind`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp grind`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp grind is not built yet")
}
