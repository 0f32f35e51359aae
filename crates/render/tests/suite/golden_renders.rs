//! Renders of every example scene (`scenes/*.toml`) at a small size and fixed seed hash to the
//! values stored in `tests/data/golden_render_hashes.txt`: a refactor that moves code must not
//! change a single bit of any image. A deliberate change of the numerics regenerates the file
//! with `LUCENT_BLESS=1 cargo test -p render --test suite golden` and says why in its commit.

#[allow(unused_imports)]
use crate::common::*;

use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use std::path::{Path, PathBuf};


/// FNV-1a over the bit patterns of every XYZ value of every pass.
fn render_hash(scene: &Scene, settings: &IntegratorSettings, passes: u64) -> u64 {
    let (w, h) = scene.resolution();
    let mut buf = vec![[0f32; 3]; (w * h) as usize];
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for pass in 0..passes {
        render_pass(scene, settings, 3, pass, &mut buf);
        for px in &buf {
            for c in px {
                for b in c.to_bits().to_le_bytes() {
                    hash ^= b as u64;
                    hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
                }
            }
        }
    }
    hash
}

fn cases() -> Vec<(String, u64)> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(repo().join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let mut out = Vec::new();
    for f in files {
        let mut scene = Scene::load(&f).unwrap();
        scene.set_resolution(12, 9);
        let mut settings = scene.integrator.clone();
        // Deep volumetric paths are slow at opt-level 3 too; 64 segments keep every kind of event.
        settings.max_depth = settings.max_depth.min(64);
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        out.push((format!("{name} {:?}", settings.kind), render_hash(&scene, &settings, 2)));
    }
    let mut cornell = Scene::cornell_box();
    cornell.set_resolution(12, 9);
    for kind in [IntegratorKind::Path, IntegratorKind::Direct, IntegratorKind::Ao, IntegratorKind::Volpath] {
        let settings = IntegratorSettings { kind, max_depth: 8, rr_depth: 5 };
        out.push((format!("built-in {kind:?}"), render_hash(&cornell, &settings, 2)));
    }
    out
}

#[test]
fn example_scene_renders_are_bit_identical_to_the_stored_hashes() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/golden_render_hashes.txt");
    let got = cases();
    let text: String = got.iter().map(|(k, h)| format!("{k}\t{h:016x}\n")).collect();
    if std::env::var_os("LUCENT_BLESS").is_some() {
        std::fs::write(&path, &text).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    let mut bad = Vec::new();
    for (line_got, line_want) in text.lines().zip(want.lines()) {
        if line_got != line_want {
            bad.push(format!("got {line_got}, stored {line_want}"));
        }
    }
    assert_eq!(text.lines().count(), want.lines().count(), "scene list changed:\n{text}");
    assert!(bad.is_empty(), "renders changed:\n{}", bad.join("\n"));
}
