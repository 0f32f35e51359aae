//! Render the standard synthetic structured-light set (`scan::synth`): ten board poses, a
//! sphere and the bunny, as `graycode_NN.png` folders with `truth.json` and `calibration.json`.
//!
//! `cargo run --release -p scan --example synth_set -- OUT_DIR [SPP] [--ambient-spp N] [--full] [--only NAME,…]`
//!
//! `--full` renders at the size of the shared real captures (1280 × 1024 camera, 1024 × 768
//! projector, 42 images; `Rig::full`), else 320 × 256 and 256 × 192 (34 images;
//! `Rig::standard`). `--only` renders only the named targets (the truth still lists all).

use scan::synth::*;
use std::path::PathBuf;

fn main() {
    let mut out = None;
    let mut settings = RenderSettings::default();
    let mut rig = Rig::standard();
    let mut only: Option<Vec<String>> = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--full" => rig = Rig::full(),
            "--only" => only = args.next().map(|l| l.split(',').map(str::to_string).collect()),
            "--ambient-spp" => match args.next().and_then(|n| n.parse::<u32>().ok()) {
                Some(n) if n > 0 => settings.ambient_spp = n,
                _ => {
                    eprintln!("synth_set: --ambient-spp needs a positive integer");
                    std::process::exit(2);
                }
            },
            _ if out.is_none() => out = Some(a),
            _ => match a.parse::<u32>() {
                Ok(n) if n > 0 => settings.spp = n,
                _ => {
                    eprintln!("synth_set: SPP must be a positive integer, got {a:?}");
                    std::process::exit(2);
                }
            },
        }
    }
    let Some(out) = out else {
        eprintln!("usage: synth_set OUT_DIR [SPP] [--ambient-spp N] [--full] [--only NAME,…]");
        std::process::exit(2);
    };
    let mesh = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../data/meshes/bunny.ply");
    let run = || -> anyhow::Result<()> {
        let targets = standard_targets(&mesh)?;
        let caps = generate_only(&rig, &Board::standard(), &targets, &settings, std::path::Path::new(&out), only.as_deref())?;
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
