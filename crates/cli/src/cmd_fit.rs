//! `gearcomp fit` (under construction by its capability's issue).

/// Options of `gearcomp fit`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp fit`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp fit is not built yet")
}
