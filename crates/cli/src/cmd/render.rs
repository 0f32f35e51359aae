//! `lucent render` (to be written).

#[derive(clap::Args, Debug, Default)]
pub struct Args {}

impl Args {
    /// What `lucent` with no arguments does: the built-in Cornell box to `lucent.png`.
    pub fn default_scene() -> Args {
        Args::default()
    }
}

pub fn run(_args: Args) -> anyhow::Result<()> {
    anyhow::bail!("`lucent render` is not implemented yet")
}
