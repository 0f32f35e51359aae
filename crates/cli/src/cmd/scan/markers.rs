//! `lucent scan markers IMAGE… [--calibration CALIB.json] [--model MODEL.json [--scale]] [--json]`:
//! circular markers with sub-pixel centres in each image; with a two-view calibration and two
//! images, their matches and 3-D positions; with a model, its registration onto them
//! (scan::markers; docs/markers.md).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use scan::calib::ProcamCalibration;
use scan::markers::hough::HoughSettings;
use scan::markers::register::{register, RegisterSettings};
use scan::markers::stereo::{match_markers, MatchSettings, TwoViews};
use scan::markers::{detect, DetectSettings, Image, Marker};
use serde_json::json;

/// Arguments of `lucent scan markers`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Photographs (PNG, JPEG, EXR, PFM; colour is averaged to grey). With --calibration exactly
    /// two: the first seen by the calibration's `camera`, the second by its `projector` entry (a
    /// second camera).
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// Two-view calibration (the JSON of `lucent scan calibrate`: `camera`, `projector`,
    /// `rotation`, `translation` with X_B = R·X_A + T; or OpenCV FileStorage as procam-calibration's
    /// calibrate.py writes it, with --projector); matches and triangulates the markers.
    #[arg(long, value_name = "CALIB.json")]
    pub calibration: Option<PathBuf>,
    /// Projector resolution WIDTHxHEIGHT (pixels): needed with an OpenCV FileStorage
    /// calibration (procam-calibration's calibration_result.xml), which does not give it.
    #[arg(long, value_name = "WxH", value_parser = super::parse_size)]
    pub projector: Option<(u32, u32)>,
    /// Marker model to register onto the triangulated markers: {"markers": [[x, y, z], …]} in
    /// scene units (the calibration's length unit unless --scale).
    #[arg(long, value_name = "MODEL.json", requires = "calibration")]
    pub model: Option<PathBuf>,
    /// Fit a uniform scale too (a similarity instead of a rigid transform).
    #[arg(long, requires = "model")]
    pub scale: bool,
    /// The model's surface (PLY or OBJ, in the marker model's frame and units) to move by the
    /// registration and write to --registered, in view A's frame.
    #[arg(long, value_name = "MESH.ply", requires_all = ["model", "registered"])]
    pub model_mesh: Option<PathBuf>,
    /// Where the registered model mesh is written (binary PLY, view A's frame, calibration units).
    #[arg(long, value_name = "REGISTERED.ply", requires = "model_mesh")]
    pub registered: Option<PathBuf>,
    /// Radius range of the markers looked for (pixels).
    #[arg(long, default_value = "3:60", value_name = "MIN:MAX", value_parser = parse_range)]
    pub radius_px: (f64, f64),
    /// Half-width of the window in which an edge is located (pixels; at least the blur plus 1).
    #[arg(long, default_value_t = 2.0, value_name = "PX")]
    pub edge_halfwidth_px: f64,
    /// Largest epipolar distance of a match (pixels).
    #[arg(long, default_value_t = 2.0, value_name = "PX")]
    pub max_epipolar_px: f64,
    /// Distance within which a registered model marker lands on a triangulated one (calibration
    /// units; default 2 % of the triangulated markers' extent).
    #[arg(long, value_name = "DIST")]
    pub inlier: Option<f64>,
    /// Print the result as JSON on stdout (keys images, matches, unmatched, points, transform,
    /// rms, inliers, outliers, inlier_distance).
    #[arg(long)]
    pub json: bool,
}

fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let bad = || format!("`{s}` is not a radius range MIN:MAX in pixels (e.g. 3:60)");
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let (a, b): (f64, f64) = (a.trim().parse().map_err(|_| bad())?, b.trim().parse().map_err(|_| bad())?);
    if !(a >= 2.0 && b > a && b.is_finite()) {
        return Err(format!("radius range {s}: need 2 ≤ MIN < MAX pixels"));
    }
    Ok((a, b))
}

fn marker_json(m: &Marker) -> serde_json::Value {
    let e = &m.ellipse;
    json!({
        "x": m.x,
        "y": m.y,
        "radius_px": m.radius_px,
        "polarity": if m.dark { "dark" } else { "light" },
        "support": m.support,
        "rms_px": m.rms_px,
        "ellipse": { "centre": e.centre, "semi_axes_px": [e.semi_major, e.semi_minor], "angle_rad": e.angle_rad },
    })
}

fn read_model(path: &Path) -> Result<Vec<[f64; 3]>> {
    #[derive(serde::Deserialize)]
    struct Model {
        markers: Vec<[f64; 3]>,
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let m: Model = serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: not a marker model ({{\"markers\": [[x, y, z], …]}}): {e}", path.display()))?;
    if let Some(i) = m.markers.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        bail!("{}: markers[{i}] is not a finite point", path.display());
    }
    Ok(m.markers)
}

pub fn run(args: Args) -> Result<()> {
    if !(args.edge_halfwidth_px >= 1.0 && args.edge_halfwidth_px.is_finite()) {
        bail!("--edge-halfwidth-px must be at least 1 pixel, got {}", args.edge_halfwidth_px);
    }
    if !(args.max_epipolar_px > 0.0 && args.max_epipolar_px.is_finite()) {
        bail!("--max-epipolar-px must be a positive number of pixels, got {}", args.max_epipolar_px);
    }
    if let Some(d) = args.inlier {
        if !(d > 0.0 && d.is_finite()) {
            bail!("--inlier must be a positive distance, got {d}");
        }
    }
    let views = match &args.calibration {
        Some(c) => {
            if args.images.len() != 2 {
                bail!("--calibration matches markers between exactly two images, got {}", args.images.len());
            }
            let calib = ProcamCalibration::read(c, args.projector)?;
            for w in calib.lens_warnings() {
                eprintln!("lucent: warning: {}: {w}", c.display());
            }
            Some(TwoViews::new(&calib).with_context(|| format!("{}", c.display()))?)
        }
        None => None,
    };
    let model = args.model.as_deref().map(read_model).transpose()?;
    if let Some(out) = &args.registered {
        if out.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()) != Some("ply".into()) {
            bail!("--registered {}: the registered mesh is written as PLY (.ply)", out.display());
        }
    }
    // Read before any detection, so that a bad mesh fails fast.
    let model_mesh = args.model_mesh.as_deref().map(scan::label::io::read_mesh).transpose()?;
    let settings = DetectSettings {
        hough: HoughSettings { radius_min_px: args.radius_px.0, radius_max_px: args.radius_px.1, ..Default::default() },
        edge_halfwidth_px: args.edge_halfwidth_px,
        ..Default::default()
    };
    let mut found = Vec::new();
    for (k, path) in args.images.iter().enumerate() {
        let img = Image::read(path)?;
        if let Some(v) = &views {
            v.check_size(k, (img.width, img.height), &path.display().to_string())?;
        }
        let ms = detect(&img, &settings);
        if ms.is_empty() {
            bail!("{}: no markers found (radius {}–{} px)", path.display(), args.radius_px.0, args.radius_px.1);
        }
        found.push((img.width, img.height, ms));
    }
    let mut out = json!({
        "images": args.images.iter().zip(&found).map(|(p, (w, h, ms))| json!({
            "path": p.display().to_string(), "width": w, "height": h,
            "markers": ms.iter().map(marker_json).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    });
    let mut text = Vec::new();
    for (p, (_, _, ms)) in args.images.iter().zip(&found) {
        text.push(format!("{}: {} markers", p.display(), ms.len()));
        for m in ms {
            text.push(format!("  ({:.3}, {:.3}) px, radius {:.2} px, {}", m.x, m.y, m.radius_px, if m.dark { "dark" } else { "light" }));
        }
    }
    if let Some(v) = &views {
        let st = match_markers(v, &found[0].2, &found[1].2, &MatchSettings { max_epipolar_px: args.max_epipolar_px });
        if st.matches.is_empty() {
            bail!("too few matches: no marker of {} lies within {} px of the epipolar line of one in {}", args.images[0].display(), args.max_epipolar_px, args.images[1].display());
        }
        out["matches"] = json!(st
            .matches
            .iter()
            .map(|m| json!({
                "a": m.a, "b": m.b, "epipolar_px": m.epipolar_px, "alternatives": m.alternatives,
                "centre_a": m.centre_a, "centre_b": m.centre_b, "corrected": m.corrected,
                "normal": m.normal, "ray_gap": m.ray_gap,
            }))
            .collect::<Vec<_>>());
        out["unmatched"] = json!({ "a": st.unmatched[0], "b": st.unmatched[1] });
        let points: Vec<[f64; 3]> = st.matches.iter().map(|m| m.point).collect();
        out["points"] = json!(points);
        text.push(format!("{} matches ({} and {} unmatched):", st.matches.len(), st.unmatched[0].len(), st.unmatched[1].len()));
        for m in &st.matches {
            text.push(format!("  {} ↔ {}: epipolar {:.3} px, point [{:.4}, {:.4}, {:.4}]", m.a, m.b, m.epipolar_px, m.point[0], m.point[1], m.point[2]));
        }
        if let Some(model) = &model {
            let reg = register(model, &points, &RegisterSettings { with_scale: args.scale, inlier_distance: args.inlier, ..Default::default() })
                .with_context(|| format!("registering {}", args.model.as_ref().unwrap().display()))?;
            let r = reg.transform.rotation;
            let t = reg.transform.translation;
            out["transform"] = json!({
                "rotation": [[r[(0, 0)], r[(0, 1)], r[(0, 2)]], [r[(1, 0)], r[(1, 1)], r[(1, 2)]], [r[(2, 0)], r[(2, 1)], r[(2, 2)]]],
                "translation": [t[0], t[1], t[2]],
                "scale": reg.transform.scale,
            });
            out["rms"] = json!(reg.rms);
            out["inliers"] = json!(reg.pairs.iter().map(|p| json!({ "model": p.0, "point": p.1, "residual": p.2 })).collect::<Vec<_>>());
            out["outliers"] = json!(reg.outliers);
            out["inlier_distance"] = json!(reg.inlier_distance);
            if let (Some(mesh), Some(path)) = (&model_mesh, &args.registered) {
                let (s, r) = (reg.transform.scale, reg.transform.rotation);
                let moved: Vec<[f64; 3]> = mesh
                    .positions
                    .iter()
                    .map(|p| std::array::from_fn(|i| s * (r[(i, 0)] * p[0] + r[(i, 1)] * p[1] + r[(i, 2)] * p[2]) + t[i]))
                    .collect();
                scan::label::io::write_ply(path, &moved, &mesh.triangles, None).with_context(|| format!("writing {}", path.display()))?;
                out["registered"] = json!({ "path": path.display().to_string(), "vertices": moved.len(), "faces": mesh.triangles.len() });
                text.push(format!("wrote {} ({} faces, the model mesh in view A's frame)", path.display(), mesh.triangles.len()));
            }
            text.push(format!(
                "registration: {} inliers, rms {:.4}, scale {:.6}, translation [{:.4}, {:.4}, {:.4}]",
                reg.pairs.len(),
                reg.rms,
                reg.transform.scale,
                t[0],
                t[1],
                t[2]
            ));
        }
    }
    if args.json {
        println!("{out}");
    } else {
        println!("{}", text.join("\n"));
    }
    Ok(())
}
