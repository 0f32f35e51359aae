//! `lucent bench` (rays and path tracing) and `lucent bench mie`.

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Option<Which>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// Lorenz-Mie and milk-spectrum timings.
    Mie(super::bench_mie::Args),
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which {
        Some(Which::Mie(a)) => super::bench_mie::run(a),
        None => anyhow::bail!("`lucent bench` is not implemented yet"),
    }
}
