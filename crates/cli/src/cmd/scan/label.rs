//! `lucent scan label MESH.ply PHOTO --calibration CALIB.json --out LABELLED.ply [--scene
//! SCENE.toml] [--labels K] [--json]`: micropolygon labelling of a scanned mesh with the regions
//! of a photograph (scan::label; docs/labelling.md).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use scan::calib::ProcamCalibration;
use scan::label::io::{label_mesh_indexed, label_path, write_ply_normals, overlay, read_mesh, read_photo, scene_path, scene_toml, write_ply, SceneParts};
use scan::label::board::{keep_near_plane, BoardPose};
use scan::label::normals::{smooth_depth, smooth_normals};
use scan::label::{label, LabelOptions, SegmentOptions};

/// Arguments of `lucent scan label`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The scanned mesh in the calibration's camera frame (PLY or OBJ, e.g. from `lucent scan
    /// reconstruct --mesh`).
    pub mesh: PathBuf,
    /// The photograph to label from (the camera's image, e.g. a capture's white frame).
    pub photo: PathBuf,
    /// Calibration JSON as `lucent scan calibrate` writes it, or OpenCV FileStorage XML/YAML as
    /// procam-calibration's calibrate.py writes it (then with --projector).
    #[arg(long, value_name = "CALIB.json")]
    pub calibration: PathBuf,
    /// Projector resolution WIDTHxHEIGHT (pixels): needed with an OpenCV FileStorage
    /// calibration (procam-calibration's calibration_result.xml), which does not give it.
    #[arg(long, value_name = "WxH", value_parser = super::parse_size)]
    pub projector: Option<(u32, u32)>,
    /// The labelled micropolygon mesh (PLY with an `int label` per face, −1 = not visible);
    /// the faces of label k also go to `<stem>_label<k>.ply` beside it.
    #[arg(long, value_name = "LABELLED.ply")]
    pub out: PathBuf,
    /// Also write a scene: the calibration's camera, one Lambertian material `label<k>` per label
    /// (albedo = the label's mean photo colour), the projector as a light, an ambient term.
    #[arg(long, value_name = "SCENE.toml")]
    pub scene: Option<PathBuf>,
    /// The projector's image in the scene (default: an all-white image of the projector's size,
    /// written beside the scene as `<scene stem>_projector.png`).
    #[arg(long, value_name = "PNG")]
    pub projector_pattern: Option<PathBuf>,
    /// The capture of the calibration that the mesh and photo are of (`captures[I]`, its board
    /// pose): only the micropolygons within --board-distance of that board's plane are labelled
    /// (the print and what is taped to it, not the wall behind).
    #[arg(long, value_name = "I")]
    pub board_capture: Option<usize>,
    /// Largest distance from the board's plane of a labelled micropolygon with --board-capture
    /// (the calibration's length unit; default 0.2 % of the board's distance from the camera).
    #[arg(long, value_name = "D")]
    pub board_distance: Option<f64>,
    /// Also write the scene of another capture J of the calibration: the same labels and
    /// materials, each label's mesh moved from --board-capture's board pose to capture J's
    /// (`J,SCENE.toml`; repeatable; needs --board-capture).
    #[arg(long = "scene-for-capture", value_name = "J,SCENE.toml")]
    pub scene_for_capture: Vec<String>,
    /// Passes of smoothing of the label meshes: depth along the normal, then shading normals
    /// (a scanned surface's facets scatter and shadow each other; each pass spreads over about
    /// one more edge, so N passes smooth over about √N micropolygons); 0 writes the raw
    /// micropolygons without normals (the default: exact meshes, e.g. a registered model, need
    /// none, and 100 passes over a 1-M-micropolygon scan cost about 12 CPU-s). The labelled mesh
    /// (--out) keeps the raw positions.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub surface_smoothing: usize,
    /// Number of colour labels K (default: chosen, the smallest K whose RMS colour spread within
    /// the labels is at most --spread-de).
    #[arg(long, value_name = "K")]
    pub labels: Option<usize>,
    /// Longest projected micropolygon edge (pixels).
    #[arg(long, default_value_t = 1.5, value_name = "PX")]
    pub max_edge_px: f64,
    /// Gaussian smoothing before the gradient (pixels).
    #[arg(long, default_value_t = 1.5, value_name = "PX")]
    pub smoothing_px: f64,
    /// Watershed markers: flat where the gradient is below this fraction of its 99th percentile.
    #[arg(long, default_value_t = 0.15, value_name = "F")]
    pub marker_fraction: f64,
    /// Erosion of the flat mask before its components become markers (pixels).
    #[arg(long, default_value_t = 1, value_name = "PX")]
    pub erosion_px: usize,
    /// Smallest marker (pixels).
    #[arg(long, default_value_t = 4, value_name = "PX")]
    pub min_marker_px: usize,
    /// Largest K tried when K is chosen.
    #[arg(long, default_value_t = 8, value_name = "K")]
    pub max_labels: usize,
    /// RMS colour spread within a label (ΔE*ab) below which K is chosen.
    #[arg(long, default_value_t = 3.0, value_name = "DE")]
    pub spread_de: f64,
    /// Also write the photo tinted by the labels (PNG), shrunk by --overlay-scale.
    #[arg(long, value_name = "PNG")]
    pub overlay: Option<PathBuf>,
    /// Integer shrink factor of the overlay image.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub overlay_scale: usize,
    /// Print a JSON summary on stdout (labels, faces, micropolygons, per_label [{label, faces,
    /// pixels, mean_rgb}], image_regions).
    #[arg(long)]
    pub json: bool,
}

/// The numeric flags' ranges, and the projector pattern's presence, before any work.
fn check_flags(args: &Args) -> Result<()> {
    if !(args.max_edge_px >= 0.05 && args.max_edge_px <= 1000.0) {
        bail!("--max-edge-px: the longest projected micropolygon edge must lie in 0.05…1000 pixels, got {}", args.max_edge_px);
    }
    if !(args.smoothing_px >= 0.0 && args.smoothing_px <= 100.0) {
        bail!("--smoothing-px: a Gaussian's σ in 0…100 pixels, got {}", args.smoothing_px);
    }
    if !(args.marker_fraction > 0.0 && args.marker_fraction < 1.0) {
        bail!("--marker-fraction: a fraction of the gradient's 99th percentile in (0, 1), got {}", args.marker_fraction);
    }
    if !(args.spread_de > 0.0 && args.spread_de.is_finite()) {
        bail!("--spread-de: a positive colour difference ΔE*ab, got {}", args.spread_de);
    }
    if args.max_labels == 0 || args.labels == Some(0) {
        bail!("--labels, --max-labels: at least 1 label");
    }
    if args.overlay_scale == 0 {
        bail!("--overlay-scale: a shrink factor of at least 1");
    }
    if args.surface_smoothing > 10_000 {
        bail!("--surface-smoothing: at most 10000 passes, got {}", args.surface_smoothing);
    }
    if let Some(d) = args.board_distance {
        if !(d > 0.0 && d.is_finite()) {
            bail!("--board-distance: a positive distance, got {d}");
        }
    }
    if let Some(p) = &args.projector_pattern {
        if args.scene.is_none() {
            bail!("--projector-pattern: the projector's image of the scene; give --scene too");
        }
        render::image_io::read_image(p).with_context(|| format!("--projector-pattern {}", p.display()))?;
    }
    Ok(())
}

fn check_ext(path: &Path, ext: &str, what: &str) -> Result<()> {
    if !path.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext)) {
        bail!("{}: {what} is written as .{ext}", path.display());
    }
    render::image_io::check_writable(path)
}

pub fn run(args: Args) -> Result<()> {
    check_ext(&args.out, "ply", "the labelled mesh")?;
    if let Some(s) = &args.scene {
        check_ext(s, "toml", "the scene")?;
    }
    if let Some(o) = &args.overlay {
        check_ext(o, "png", "the overlay")?;
    }
    check_flags(&args)?;
    let t0 = Instant::now();
    let calib = ProcamCalibration::read(&args.calibration, args.projector)?;
    for w in calib.lens_warnings() {
        eprintln!("lucent: warning: {}: {w}", args.calibration.display());
    }
    let capture_pose = |i: usize, flag: &str| -> Result<BoardPose> {
        match calib.captures.get(i) {
            Some(c) => Ok(BoardPose::from_capture(c)),
            None if calib.captures.is_empty() => bail!("{flag} {i}: {} has no board poses (an OpenCV FileStorage calibration carries none: use the JSON of `lucent scan calibrate`)", args.calibration.display()),
            None => bail!("{flag} {i}: {} has {} board poses (captures 0…{})", args.calibration.display(), calib.captures.len(), calib.captures.len() - 1),
        }
    };
    let board = args.board_capture.map(|i| capture_pose(i, "--board-capture")).transpose()?;
    if board.is_none() && args.board_distance.is_some() {
        bail!("--board-distance needs --board-capture (the capture whose board plane it measures from)");
    }
    let mut other_scenes = Vec::new();
    for spec in &args.scene_for_capture {
        let Some(from) = board else { bail!("--scene-for-capture {spec}: needs --board-capture (the capture the mesh is of)") };
        let Some((j, path)) = spec.split_once(',') else { bail!("--scene-for-capture {spec}: expected J,SCENE.toml") };
        let j: usize = j.trim().parse().map_err(|_| anyhow::anyhow!("--scene-for-capture {spec}: J must be a capture index"))?;
        let path = PathBuf::from(path);
        check_ext(&path, "toml", "the scene")?;
        if args.scene.is_none() {
            bail!("--scene-for-capture {spec}: needs --scene (the scene of capture {} itself)", args.board_capture.unwrap_or(0));
        }
        other_scenes.push((j, path, from.move_to(&capture_pose(j, "--scene-for-capture")?)));
    }
    if let Some(d) = args.board_distance {
        if !(d.is_finite() && d > 0.0) {
            bail!("--board-distance {d}: must be a positive length");
        }
    }
    let mesh = read_mesh(&args.mesh)?;
    let photo = read_photo(&args.photo)?;
    if (photo.width as u64, photo.height as u64) != (calib.camera.width as u64, calib.camera.height as u64) {
        bail!(
            "{} is {}x{} pixels but {} calibrates a {}x{} camera (a calibration from another resolution)",
            args.photo.display(),
            photo.width,
            photo.height,
            args.calibration.display(),
            calib.camera.width,
            calib.camera.height
        );
    }
    if args.overlay.is_some() && args.overlay_scale > photo.width.min(photo.height) {
        bail!("--overlay-scale {}: shrinks the {}x{} photo to nothing (at most {})", args.overlay_scale, photo.width, photo.height, photo.width.min(photo.height));
    }
    let t_read = t0.elapsed().as_secs_f64();
    let opts = LabelOptions {
        max_edge_px: args.max_edge_px,
        segment: SegmentOptions {
            smoothing_px: args.smoothing_px,
            marker_fraction: args.marker_fraction,
            erosion_px: args.erosion_px,
            min_marker_px: args.min_marker_px,
            labels: args.labels,
            max_labels: args.max_labels,
            spread_de: args.spread_de,
        },
        ..LabelOptions::default()
    };
    let t1 = Instant::now();
    let mut l = label(&mesh, &photo, &calib.camera, &opts).with_context(|| format!("{} in {}", args.mesh.display(), args.photo.display()))?;
    // The smoothed surface of the labelled (visible) micropolygons: the label meshes are written
    // with it, and the board plane test uses it (the raw depth scatters by more than the
    // distance from the board to the wall).
    let smoothed = (args.surface_smoothing > 0).then(|| {
        let keep: Vec<bool> = l.face_label.iter().map(|&k| k >= 0).collect();
        let n = args.surface_smoothing;
        let first = smooth_normals(&l.mesh, &keep, n);
        let positions = smooth_depth(&l.mesh, &keep, &first, n);
        let mesh = scan::label::Mesh { positions, triangles: l.mesh.triangles.clone() };
        let normals = smooth_normals(&mesh, &keep, n);
        (mesh.positions, normals)
    });
    let off_board = match &board {
        Some(b) => {
            let d = args.board_distance.unwrap_or(0.002 * b.t.norm());
            let positions = smoothed.as_ref().map(|(p, _)| p.clone());
            let n = keep_near_plane(&mut l, positions.as_deref(), b, d);
            if l.face_label.iter().all(|&k| k < 0) {
                bail!("{}: no labelled micropolygon lies within {d} of the board plane of capture {} in {} (another capture's mesh?)", args.mesh.display(), args.board_capture.unwrap_or(0), args.calibration.display());
            }
            Some((n, d))
        }
        None => None,
    };
    let t_label = t1.elapsed().as_secs_f64();
    let t2 = Instant::now();
    // Each output is written under a temporary name and renamed; the overlay, a diagnostic,
    // goes first, so that a failure writing it leaves the earlier outputs of a run as they were.
    if let Some(o) = &args.overlay {
        render::image_io::write_image(o, &overlay(&l, &photo, args.overlay_scale), 0.0)?;
    }
    write_ply(&args.out, &l.mesh.positions, &l.mesh.triangles, Some(&l.face_label))?;
    let faces = l.faces_per_label();
    let seg = &l.segmentation;
    // With the board plane, a label's starting colour is the mean photo colour at its kept
    // micropolygons (its image regions may reach onto the wall).
    let mut start_rgb: Vec<[f64; 3]> = seg.label_rgb.clone();
    if off_board.is_some() {
        let mut acc = vec![([0.0f64; 3], 0usize); seg.labels];
        for (p, &k) in l.face_pixel.iter().zip(&l.face_label) {
            if let (Some(i), true) = (p, k >= 0) {
                let c = photo.rgb[*i as usize];
                let a = &mut acc[k as usize];
                for ch in 0..3 {
                    a.0[ch] += c[ch] as f64;
                }
                a.1 += 1;
            }
        }
        for (k, (sum, n)) in acc.iter().enumerate() {
            if *n > 0 {
                start_rgb[k] = sum.map(|v| v / *n as f64);
            }
        }
    }
    let mut written = Vec::new();
    for (k, &n) in faces.iter().enumerate() {
        if n == 0 {
            continue;
        }
        let (mut m, from) = label_mesh_indexed(&l, k as i32);
        let path = label_path(&args.out, k);
        let vn: Option<Vec<[f64; 3]>> = smoothed.as_ref().map(|(pos, all)| {
            m.positions = from.iter().map(|&v| pos[v as usize]).collect();
            from.iter().map(|&v| all[v as usize]).collect()
        });
        write_ply_normals(&path, &m.positions, vn.as_deref(), &m.triangles, None)?;
        written.push((k, path));
    }
    if let Some(scene) = &args.scene {
        // A Lambertian surface of albedo ρ facing a projector of intensity π·z² at distance z
        // has radiance ρ: the albedos (mean photo colours) then start near the photo.
        let mut depths: Vec<f64> = l
            .mesh
            .triangles
            .iter()
            .zip(&l.face_label)
            .filter(|(_, &lab)| lab >= 0)
            .map(|(t, _)| t.iter().map(|&v| l.mesh.positions[v as usize][2]).sum::<f64>() / 3.0)
            .collect();
        let mid = depths.len() / 2;
        let z = if depths.is_empty() { 1.0 } else { *depths.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1 };
        let write_scene = |scene: &Path, transform: Option<[[f64; 4]; 4]>, note: Option<&str>| -> Result<()> {
            let dir = scene.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
            let calibration = scene_path(&args.calibration, dir)?;
            let mut labels = Vec::new();
            for (k, path) in &written {
                labels.push((*k, scene_path(path, dir)?, start_rgb[*k]));
            }
            let image = match &args.projector_pattern {
                Some(p) => scene_path(p, dir)?,
                None => {
                    let stem = scene.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "scene".into());
                    let p = scene.with_file_name(format!("{stem}_projector.png"));
                    let (w, h) = (calib.projector.width, calib.projector.height);
                    let white = render::image_io::Image { width: w, height: h, rgb: vec![[1.0; 3]; w as usize * h as usize] };
                    render::image_io::write_image(&p, &white, 0.0)?;
                    scene_path(&p, dir)?
                }
            };
            let text = scene_toml(&SceneParts {
                calibration: &calibration,
                labels: &labels,
                projector_image: Some(&image),
                projector_intensity: std::f64::consts::PI * z * z,
                ambient_radiance: 0.02,
                transform,
                note,
            });
            render::image_io::write_atomic(scene, |tmp| std::fs::write(tmp, &text).with_context(|| format!("{}: cannot write", tmp.display())))
                .with_context(|| format!("writing {}", scene.display()))
        };
        let name = |i: usize| calib.captures[i].name.clone();
        let own = args.board_capture.map(|i| format!("capture {i} ({}): the labels on its board plane", name(i)));
        write_scene(scene, None, own.as_deref())?;
        for (j, path, m) in &other_scenes {
            let rows: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]));
            let i = args.board_capture.unwrap_or(0);
            let note = format!("capture {j} ({}): the labels of capture {i} ({}) moved by the boards' relative pose", name(*j), name(i));
            write_scene(path, Some(rows), Some(&note))?;
        }
    }
    let t_write = t2.elapsed().as_secs_f64();
    if args.json {
        let per_label: Vec<serde_json::Value> = (0..seg.labels)
            .map(|k| serde_json::json!({ "label": k, "faces": faces[k], "pixels": seg.label_pixels[k], "mean_rgb": seg.label_rgb[k] }))
            .collect();
        let v = serde_json::json!({
            "labels": seg.labels,
            "faces": mesh.triangles.len(),
            "micropolygons": l.mesh.triangles.len(),
            "labelled_micropolygons": faces.iter().sum::<usize>(),
            "unlabelled": { "outside": l.outside, "occluded": l.occluded, "back_faces": l.back_faces, "off_board": off_board.map(|(n, _)| n) },
            "board_distance": off_board.map(|(_, d)| d),
            "per_label": per_label,
            "image_regions": seg.regions,
            "marker_threshold": seg.marker_threshold,
            "seconds": { "read": t_read, "label": t_label, "write": t_write },
        });
        println!("{v}");
    } else {
        println!(
            "{}: {} faces → {} micropolygons, {} labelled; {} image regions in {} labels ({:.2} s labelling)",
            args.mesh.display(),
            mesh.triangles.len(),
            l.mesh.triangles.len(),
            faces.iter().sum::<usize>(),
            seg.regions,
            seg.labels,
            t_label
        );
        for k in 0..seg.labels {
            let c = seg.label_rgb[k];
            println!("  label{k}: {} micropolygons, {} pixels, mean linear RGB [{:.3}, {:.3}, {:.3}]", faces[k], seg.label_pixels[k], c[0], c[1], c[2]);
        }
        println!("wrote {}", args.out.display());
        if let Some((n, d)) = off_board {
            println!("  {n} micropolygons farther than {d:.3} from the board plane left unlabelled");
        }
        if let Some(s) = &args.scene {
            println!("wrote {}", s.display());
        }
        for (_, p, _) in &other_scenes {
            println!("wrote {}", p.display());
        }
    }
    Ok(())
}
