//! Render the standard synthetic structured-light set (`scan::synth`): six board poses, a
//! sphere and the bunny, as `graycode_NN.png` folders with `truth.json` and `calibration.json`.
//!
//! `cargo run --release -p scan --example synth_set -- OUT_DIR [SPP]`

use scan::synth::*;
use std::path::PathBuf;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(out) = args.next() else {
        eprintln!("usage: synth_set OUT_DIR [SPP]");
        std::process::exit(2);
    };
    let mut settings = RenderSettings::default();
    if let Some(spp) = args.next() {
        match spp.parse::<u32>() {
            Ok(n) if n > 0 => settings.spp = n,
            _ => {
                eprintln!("synth_set: SPP must be a positive integer, got {spp:?}");
                std::process::exit(2);
            }
        }
    }
    let mesh = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/bunny.ply");
    let run = || -> anyhow::Result<()> {
        let targets = standard_targets(&mesh)?;
        let caps = generate(&Rig::standard(), &Board::standard(), &targets, &settings, std::path::Path::new(&out))?;
        for c in &caps {
            println!("{}: {} frames, {:.2} s", c.name, c.frames.len(), c.render_seconds);
        }
        Ok(())
    };
    if let Err(e) = run() {
        eprintln!("synth_set: {e:#}");
        std::process::exit(1);
    }
}
