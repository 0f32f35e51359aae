//! The library calls of every fuzz target, in one place.
//!
//! Shared by the fuzz targets (through `lucent_fuzz`, `fuzz/src/lib.rs`) and by the corpus
//! replay test `crates/render/tests/suite/fuzz_corpus.rs` (through `#[path]`), so both run exactly the
//! same code. When the library's modules move, only this file changes.
//!
//! Each function takes one input, returns nothing and must never panic, abort or hang: an input
//! the library refuses is fine (`Err` is ignored), a panic is a finding. Work is bounded: inputs
//! are capped at [`MAX_INPUT`] bytes and nothing is rendered.

use std::path::Path;

/// Inputs longer than this are ignored (libFuzzer is run with `-max_len` at most this).
pub const MAX_INPUT: usize = 64 * 1024;

/// The targets, by the name of their folder under `fuzz/corpus/` and `fuzz/regressions/`.
pub const TARGETS: &[&str] = &["scene", "obj", "ply", "medium", "checkpoint", "image", "vol", "calibration"];

/// Run target `name` on `data`; `repo` is the repository root. Panics on an unknown name.
pub fn run(name: &str, data: &[u8], repo: &Path) {
    match name {
        "scene" => scene(data, &repo.join("scenes")),
        "obj" => obj(data),
        "ply" => ply(data),
        "medium" => medium(data),
        "checkpoint" => checkpoint(data),
        "image" => image(data),
        "vol" => vol(data),
        "calibration" => calibration(data),
        other => panic!("unknown fuzz target {other}"),
    }
}

/// Scene TOML: parse and build (meshes, spectra, media, BVH), relative files resolved against
/// `scenes_dir` (the repository's `scenes/`, so that the seeds' meshes and CSVs load).
pub fn scene(data: &[u8], scenes_dir: &Path) {
    let Some(text) = text(data) else { return };
    // A scene names files to read: keep the fuzzer off device files and the like (`/dev/zero`,
    // `/proc/…`, `/sys/…` would read forever or block) and off TOML escapes that could spell them.
    let lower = text.to_ascii_lowercase();
    if ["dev", "proc", "sys", "\\u"].iter().any(|s| lower.contains(s)) {
        return;
    }
    if let Ok(mut scene) = render::scene::Scene::from_toml_str(text, "fuzz.toml", scenes_dir) {
        let _ = scene.content_hash();
        let (w, h) = scene.resolution();
        scene.set_resolution(w.clamp(1, 16), h.clamp(1, 16));
    }
}

/// OBJ text: parse every group/object, validate, sum the area.
pub fn obj(data: &[u8]) {
    if data.len() > MAX_INPUT {
        return;
    }
    if let Ok(meshes) = render::shape::mesh::parse_obj(data, "fuzz") {
        for (_, m) in &meshes {
            if m.validate().is_ok() {
                let _ = m.area();
            }
        }
    }
}

/// PLY (ASCII or binary): parse, validate, sum the area.
pub fn ply(data: &[u8]) {
    if data.len() > MAX_INPUT {
        return;
    }
    if let Ok(m) = render::shape::mesh::parse_ply(data) {
        if m.validate().is_ok() {
            let _ = m.area();
        }
    }
}

/// Medium recipe TOML: parse, wavelengths, components (size distributions discretised) and,
/// where the Mie work is small, bulk properties at up to three of the recipe's wavelengths.
pub fn medium(data: &[u8]) {
    let Some(text) = text(data) else { return };
    let Ok(mut recipe) = optics::media::Recipe::from_toml(text) else { return };
    let Ok(lambdas) = recipe.wavelengths_nm() else { return };
    let Ok((host, comps)) = recipe.components() else { return };
    // Up to three wavelengths: first, middle and last of the recipe's.
    let mut coarse = vec![lambdas[0], lambdas[lambdas.len() / 2], lambdas[lambdas.len() - 1]];
    coarse.dedup();
    // Cost of the Mie series ~ bins × (max(|m x|, |x|) + phase angles): skip large work (known
    // unbounded before the library bounded it) rather than time out on it.
    let angles = recipe.phase_angles.min(181);
    let mut cost = 0.0f64;
    for c in &comps {
        for &l in &coarse {
            let k0 = 2.0 * std::f64::consts::PI / (l * 1e-9);
            let n = host.eval(l).norm().max(c.index.eval(l).norm());
            for &r in &c.bins.radius_m {
                cost += (k0 * r * n).abs() + 30.0 + angles as f64 * (k0 * r * n).abs().min(1e6);
            }
        }
    }
    if !(cost.is_finite() && cost < 3e6) {
        return;
    }
    recipe.phase_angles = angles;
    let _ = recipe.bulk_properties(Some(&coarse));
}

/// Checkpoint bytes: parse as given, and again with the trailing checksum recomputed (so that
/// mutations get past it to the fields); a parsed one is resumed and merged with a copy.
pub fn checkpoint(data: &[u8]) {
    use render::checkpoint::{Checkpoint, Fnv1a64, Merger};
    if data.len() > MAX_INPUT {
        return;
    }
    let _ = Checkpoint::from_bytes(data);
    if data.len() < 8 {
        return;
    }
    let mut fixed = data.to_vec();
    let body = fixed.len() - 8;
    let mut h = Fnv1a64::new();
    h.write(&fixed[..body]);
    fixed[body..].copy_from_slice(&h.finish().to_le_bytes());
    if let Ok(c) = Checkpoint::from_bytes(&fixed) {
        let path = Path::new("fuzz.ckpt");
        let _ = c.resume_point(path);
        let _ = c.check_matches(path, &c.identity);
        let _ = c.check_layout(path, c.film.layout());
        let _ = c.film.extra_channels();
        let mut other = c.clone();
        for run in &mut other.runs {
            run.seed = run.seed.wrapping_add(1);
        }
        let mut m = Merger::new();
        if m.add(path, c.clone()).is_ok() && m.add(Path::new("other.ckpt"), other).is_ok() {
            if let Ok(merged) = m.finish() {
                let _ = merged.to_bytes();
            }
        }
        let _ = c.to_bytes();
    }
}

/// Image bytes: decoded as PNG, OpenEXR and PFM in turn.
pub fn image(data: &[u8]) {
    use render::image_io::{decode_image, Format};
    if data.len() > MAX_INPUT {
        return;
    }
    for format in [Format::Png, Format::Exr, Format::Pfm] {
        let _ = decode_image(data, format);
    }
}

/// Mitsuba volume file: parse, build the density grid on the file's box, and trace rays through
/// it (from outside and inside, along the axes, a diagonal and a direction taken from the data):
/// the exact integral, its inversion and a flight to a surface.
pub fn vol(data: &[u8]) {
    use glam::Vec3;
    use render::medium::grid::DensityGrid;
    if data.len() > MAX_INPUT {
        return;
    }
    let Ok(v) = DensityGrid::read_vol(data) else { return };
    if v.channels == 3 {
        // A grid of RGB albedos: uplift (a few colours, each fitted directly) and look up.
        if v.values.len() > 3 * 64 {
            return;
        }
        let colours: Vec<[f32; 3]> = v.values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let Ok(a) = render::medium::albedo::AlbedoGrid::rgb(v.n, &colours, v.min, v.max) else { return };
        for u in [0.0f32, 0.3, 0.99] {
            let wl = render::math::spectral::SampledWavelengths::sample(u);
            for k in 0..8 {
                let t = k as f32 / 7.0;
                let q = Vec3::new(v.min[0] as f32, v.min[1] as f32, v.min[2] as f32).lerp(Vec3::new(v.max[0] as f32, v.max[1] as f32, v.max[2] as f32), 1.5 * t - 0.25);
                let x = a.at(q, &wl);
                assert!(x.is_finite() && x.cmpge(glam::Vec4::ZERO).all() && x.cmple(glam::Vec4::ONE).all(), "albedo {x} outside [0, 1]");
            }
        }
        return;
    }
    let Ok(g) = DensityGrid::new(v.n, v.values, v.min, v.max) else { return };
    let _ = g.max_density();
    let (lo, hi) = g.bounds_m();
    let p = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
    let (lo, hi) = (p(lo), p(hi));
    let centre = 0.5 * (lo + hi);
    let outside = lo - (hi - lo);
    let tail = &data[data.len().saturating_sub(12)..];
    let from_data = Vec3::new(
        tail.first().copied().unwrap_or(1) as f32 - 127.5,
        tail.get(5).copied().unwrap_or(2) as f32 - 127.5,
        tail.get(10).copied().unwrap_or(3) as f32 - 127.5,
    )
    .normalize_or(Vec3::X);
    let reach = (hi - lo).length() * 3.0;
    for o in [centre, outside, lo, hi] {
        for d in [Vec3::X, -Vec3::Y, Vec3::Z, Vec3::ONE.normalize(), from_data] {
            let _ = g.density(o);
            let tau = g.depth(o, d, reach);
            let _ = g.depth(o, d, f32::INFINITY);
            let _ = g.distance_at_depth(o, d, 0.5 * tau);
            let _ = g.flight(o, d, 0.5 * tau, 0.75 * reach);
        }
    }
}

/// Camera calibration text (lucent's JSON, a procam pair's JSON, OpenCV FileStorage YAML or XML):
/// parsed with the default node names, procam-calibration's (`cam_int`, `proj_int`), `cam_K` and
/// lucent's projector node, then made the camera of a 64 × 48 pinhole scene, whose rays through
/// the corners and centre are traced back to the film.
pub fn calibration(data: &[u8]) {
    use render::load::calibration::{parse_calibration, CalibrationNodes};
    let Some(text) = text(data) else { return };
    let Ok(base) = render::camera::Camera::look_at(glam::Vec3::ZERO, glam::Vec3::Z, glam::Vec3::Y, 40.0, 64, 48) else { return };
    let nodes = [
        CalibrationNodes::default(),
        CalibrationNodes { matrix: "cam_int".into(), dist: "cam_dist".into() },
        CalibrationNodes { matrix: "cam_K".into(), dist: "cam_D".into() },
        CalibrationNodes { matrix: "proj_int".into(), dist: "proj_dist".into() },
        CalibrationNodes { matrix: "projector".into(), dist: "distortion_coefficients".into() },
    ];
    for n in &nodes {
        let Ok(cal) = parse_calibration(text, "fuzz.yml", n) else { continue };
        let Ok(camera) = render::load::camera::calibrated_camera(&cal, &base, 1e-3) else { continue };
        let (w, h) = (camera.width, camera.height);
        for (i, j) in [(0, 0), (w - 1, 0), (0, h - 1), (w - 1, h - 1), (w / 2, h / 2)] {
            let ray = camera.generate_ray(i, j, glam::Vec2::new(0.5, 0.5));
            let _ = camera.project(ray.o + ray.d);
        }
    }
}

fn text(data: &[u8]) -> Option<&str> {
    if data.len() > MAX_INPUT {
        return None;
    }
    std::str::from_utf8(data).ok()
}
