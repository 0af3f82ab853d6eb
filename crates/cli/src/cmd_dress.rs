//! `gearcomp dress` (under construction by its capability's issue).

/// Options of `gearcomp dress`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp dress`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp dress is not built yet")
}
