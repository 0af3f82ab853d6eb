//! `gearcomp shape` (under construction by its capability's issue).

/// Options of `gearcomp shape`.
#[derive(Debug, clap::Args)]
pub struct Args {}

/// Runs `gearcomp shape`.
pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("gearcomp shape is not built yet")
}
