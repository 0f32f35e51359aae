//! `lucent`: predict how a material looks from what it is made of, render it, check it.
//! Thin: parses arguments and calls the `optics` and `render` libraries.

use clap::{Parser, Subcommand};

mod cmd;
#[cfg(feature = "denoise")]
mod denoise;
mod preview;

#[derive(Parser)]
#[command(name = "lucent", version, about = "Predict, render and validate material appearance")]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene (the built-in Cornell box when no scene is given).
    Render(cmd::render::Args),
    /// Merge checkpoints of independent runs of the same scene.
    Merge(cmd::merge::Args),
    /// Benchmarks: rays, path tracing, Mie (`lucent bench mie`).
    Bench(cmd::bench::Args),
    /// Lorenz-Mie theory for one sphere.
    Mie(cmd::mie::Args),
    /// Bulk optical properties of a medium (milk by content declaration, or a recipe file).
    Medium(cmd::medium::Args),
    /// Monte Carlo photon transport in a stack of plane-parallel layers.
    Slab(cmd::slab::Args),
    /// Dipole BSSRDF models.
    Bssrdf(cmd::bssrdf::Args),
    /// Compare a render with a photograph pixel by pixel.
    Compare(cmd::compare::Args),
    /// Inverse problems: optical properties from reflectance, particles from spectra, scene parameters from photos.
    Fit(cmd::fit::Args),
    /// Structured-light scanning: Gray-code patterns, decoding, calibration, reconstruction.
    Scan(cmd::scan::Args),
}

/// Standard output that cannot be written (a closed pipe, as in `lucent mie … | head -1`, or a
/// full disk) makes `println!` panic; this hook turns that into the exit of a command whose
/// output was cut: silently with status 141 (128 + SIGPIPE, as a process the pipe's signal ends)
/// for a closed pipe, with one line and status 1 otherwise. Other panics keep the default report.
fn exit_quietly_when_stdout_fails() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let msg = payload.downcast_ref::<String>().map(String::as_str).or_else(|| payload.downcast_ref::<&str>().copied()).unwrap_or("");
        if let Some(reason) = msg.strip_prefix("failed printing to stdout: ") {
            if reason.contains("Broken pipe") {
                std::process::exit(141);
            }
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "lucent: error: writing to standard output: {reason}");
            std::process::exit(1);
        }
        default(info);
    }));
}

/// Every option that takes a value accepts a negative number as that value (`--square -75` is
/// then checked by the command, not taken for a flag `-7`), in every subcommand.
fn negative_numbers(cmd: clap::Command) -> clap::Command {
    cmd.mut_args(|a| if a.get_action().takes_values() { a.allow_negative_numbers(true) } else { a }).mut_subcommands(negative_numbers)
}

fn main() {
    exit_quietly_when_stdout_fails();
    let cli = match negative_numbers(<Cli as clap::CommandFactory>::command()).try_get_matches().and_then(|m| <Cli as clap::FromArgMatches>::from_arg_matches(&m)) {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand) {
                e.exit();
            }
            // One line, as for every other error: clap's first line without its own prefix, and
            // its tips ("a similar subcommand exists: 'render'") joined on.
            let text = e.to_string();
            let first = text.lines().next().unwrap_or("invalid arguments");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            // A first line that ends in a colon lists what it means on the indented lines after
            // it ("the following required arguments were not provided:\n  --patterns <DIR>").
            let listed: Vec<&str> = if first.ends_with(':') {
                text.lines().skip(1).take_while(|l| l.starts_with(' ') && !l.trim().is_empty()).map(str::trim).collect()
            } else {
                vec![]
            };
            let first = if listed.is_empty() { first.to_string() } else { format!("{first} {}", listed.join(", ")) };
            let tips: Vec<&str> = text.lines().filter_map(|l| l.trim_start().strip_prefix("tip: ")).collect();
            let tips: String = tips.iter().map(|t| format!("; {t}")).collect();
            eprintln!("lucent: error: {first}{tips} (see `lucent --help`)");
            std::process::exit(2);
        }
    };
    let result = match cli.command {
        None => cmd::render::run(cmd::render::Args::default_scene()),
        Some(Command::Render(a)) => cmd::render::run(a),
        Some(Command::Merge(a)) => cmd::merge::run(a),
        Some(Command::Bench(a)) => cmd::bench::run(a),
        Some(Command::Mie(a)) => cmd::mie::run(a),
        Some(Command::Medium(a)) => cmd::medium::run(a),
        Some(Command::Slab(a)) => cmd::slab::run(a),
        Some(Command::Bssrdf(a)) => cmd::bssrdf::run(a),
        Some(Command::Compare(a)) => cmd::compare::run(a),
        Some(Command::Fit(a)) => cmd::fit::run(a),
        Some(Command::Scan(a)) => cmd::scan::run(a),
    };
    if let Err(e) = result {
        // One line: the chain of contexts joined, as scripts and people read it.
        eprintln!("lucent: error: {e:#}");
        std::process::exit(1);
    }
}
