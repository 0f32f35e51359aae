//! `lucent fit …`: inverse problems (to be written).

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// Analysis by synthesis: fit scene parameters to a reference photograph.
    Scene(super::fit_scene::Args),
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which {
        Which::Scene(a) => super::fit_scene::run(a),
    }
}
