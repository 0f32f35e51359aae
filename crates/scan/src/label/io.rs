//! Files of the labelling: the input mesh and photo, the labelled mesh (binary PLY with an `int
//! label` per face), one plain mesh per label, the scene that gives each label a material, and a
//! label overlay image. Every file is written to a temporary name and renamed
//! (`render::image_io::write_atomic`).

use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use render::image_io::{write_atomic, Image};
use render::shape::mesh::TriangleMesh;

use super::{Labelled, Mesh, Photo};

/// Reads every mesh of an OBJ or PLY file (as the renderer reads them) into one mesh.
pub fn read_mesh(path: &Path) -> Result<Mesh> {
    let meshes = TriangleMesh::load(path)?;
    let mut out = Mesh::default();
    for (_, m) in meshes {
        let base = out.positions.len() as u32;
        out.positions.extend(m.positions.iter().map(|p| [p.x as f64, p.y as f64, p.z as f64]));
        out.triangles.extend(m.indices.iter().map(|t| t.map(|v| v + base)));
    }
    if out.triangles.is_empty() {
        bail!("{}: the mesh has no faces", path.display());
    }
    Ok(out)
}

/// Reads a photo (PNG decoded to linear with the sRGB curve, EXR, PFM or HDR as stored).
pub fn read_photo(path: &Path) -> Result<Photo> {
    let img = render::image_io::read_image(path)?;
    Ok(Photo { width: img.width as usize, height: img.height as usize, rgb: img.rgb })
}

fn header(vertices: usize, faces: usize, label: bool, normals: bool) -> String {
    let mut h = format!(
        "ply\nformat binary_little_endian 1.0\ncomment lucent scan label: camera coordinates (x right, y down, z forward), the calibration's length unit\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n"
    );
    if normals {
        h.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    h.push_str(&format!("element face {faces}\nproperty list uchar int vertex_indices\n"));
    if label {
        h.push_str("property int label\n");
    }
    h.push_str("end_header\n");
    h
}

/// Writes a binary little-endian PLY of `positions` and `triangles`, with `labels` (one per
/// triangle) as the face property `int label` when given.
pub fn write_ply(path: &Path, positions: &[[f64; 3]], triangles: &[[u32; 3]], labels: Option<&[i32]>) -> Result<()> {
    write_ply_normals(path, positions, None, triangles, labels)
}

/// [`write_ply`] with per-vertex shading normals (`float nx, ny, nz`) when `normals` is given
/// (one per position).
pub fn write_ply_normals(path: &Path, positions: &[[f64; 3]], normals: Option<&[[f64; 3]]>, triangles: &[[u32; 3]], labels: Option<&[i32]>) -> Result<()> {
    write_atomic(path, |tmp| {
        let file = std::fs::File::create(tmp).with_context(|| format!("{}: cannot create", tmp.display()))?;
        let mut out = std::io::BufWriter::new(file);
        out.write_all(header(positions.len(), triangles.len(), labels.is_some(), normals.is_some()).as_bytes())?;
        for (i, p) in positions.iter().enumerate() {
            for v in p {
                out.write_all(&(*v as f32).to_le_bytes())?;
            }
            if let Some(n) = normals {
                for v in n[i] {
                    out.write_all(&(v as f32).to_le_bytes())?;
                }
            }
        }
        for (f, t) in triangles.iter().enumerate() {
            out.write_all(&[3u8])?;
            for &v in t {
                out.write_all(&(v as i32).to_le_bytes())?;
            }
            if let Some(l) = labels {
                out.write_all(&l[f].to_le_bytes())?;
            }
        }
        out.flush().with_context(|| format!("{}: cannot write", tmp.display()))?;
        Ok(())
    })
    .with_context(|| format!("writing {}", path.display()))
}

/// The faces of label `k` as a mesh of their own (vertices renumbered).
pub fn label_mesh(l: &Labelled, k: i32) -> Mesh {
    label_mesh_indexed(l, k).0
}

/// [`label_mesh`] and, per vertex of it, its index in `l.mesh`.
pub fn label_mesh_indexed(l: &Labelled, k: i32) -> (Mesh, Vec<u32>) {
    let mut map = vec![u32::MAX; l.mesh.positions.len()];
    let mut from = Vec::new();
    let mut out = Mesh::default();
    for (t, &lab) in l.mesh.triangles.iter().zip(&l.face_label) {
        if lab != k {
            continue;
        }
        let t = t.map(|v| {
            if map[v as usize] == u32::MAX {
                map[v as usize] = out.positions.len() as u32;
                out.positions.push(l.mesh.positions[v as usize]);
                from.push(v);
            }
            map[v as usize]
        });
        out.triangles.push(t);
    }
    (out, from)
}

/// `<stem>_label<k>.ply` beside `labelled`.
pub fn label_path(labelled: &Path, k: usize) -> PathBuf {
    let stem = labelled.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "labelled".into());
    labelled.with_file_name(format!("{stem}_label{k}.ply"))
}

/// A path as written into a scene file in `dir`: relative to `dir` where `path` lies below it,
/// otherwise absolute.
pub fn scene_path(path: &Path, dir: &Path) -> Result<String> {
    let abs = |p: &Path| -> Result<PathBuf> {
        if p.is_absolute() {
            Ok(p.to_path_buf())
        } else {
            Ok(std::env::current_dir().context("current directory")?.join(p))
        }
    };
    let (p, d) = (abs(path)?, abs(dir)?);
    let p = std::fs::canonicalize(&p).unwrap_or(p);
    let d = std::fs::canonicalize(&d).unwrap_or(d);
    let shown = match p.strip_prefix(&d) {
        Ok(rel) => rel.to_path_buf(),
        Err(_) => p,
    };
    shown.to_str().map(str::to_string).with_context(|| format!("{}: path is not UTF-8", path.display()))
}

/// What the scene file of a labelling refers to.
pub struct SceneParts<'a> {
    /// The calibration file as written in the scene (see [`scene_path`]).
    pub calibration: &'a str,
    /// Per label with faces: (k, mesh path as written in the scene, start albedo in linear RGB).
    pub labels: &'a [(usize, String, [f64; 3])],
    /// The projector's image as written in the scene, when the projector is a light.
    pub projector_image: Option<&'a str>,
    /// Starting intensity of the projector's white (W·sr⁻¹·nm⁻¹ per pixel of value 1, flat).
    pub projector_intensity: f64,
    /// Starting ambient radiance (W·m⁻²·sr⁻¹·nm⁻¹, flat).
    pub ambient_radiance: f64,
    /// A camera-frame transform applied to every label's mesh (rows of a 4 × 4 matrix acting on
    /// column vectors), e.g. the move of a board from one capture's pose to another's
    /// ([`super::board::BoardPose::move_to`]); `None` leaves the meshes where they are.
    pub transform: Option<[[f64; 4]; 4]>,
    /// A comment line naming what the scene shows (written after the header), if any.
    pub note: Option<&'a str>,
}

fn num(x: f64) -> String {
    format!("{x:?}")
}

/// The TOML text of the labelled scene: the calibration's camera, one Lambertian material
/// `label<k>` and one object per label, the projector as a light, and a constant ambient
/// environment.
pub fn scene_toml(p: &SceneParts) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Labelled scan (lucent scan label): the camera frame of the calibration, in its length unit.");
    let _ = writeln!(s, "# Albedos are each label's mean photo colour (linear RGB), a starting guess for `lucent fit`.");
    if let Some(n) = p.note {
        let _ = writeln!(s, "# {n}");
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "[camera]\ncalibration = {:?}\n", p.calibration);
    let _ = writeln!(s, "[integrator]\ntype = \"path\"\nmax_depth = 3\n");
    for (k, _, rgb) in p.labels {
        let c = rgb.map(|v| v.clamp(0.0, 1.0));
        let _ = writeln!(s, "[materials.label{k}]\ntype = \"lambertian\"\nalbedo = {{ rgb = [{}, {}, {}] }}\n", num(c[0]), num(c[1]), num(c[2]));
    }
    for (k, mesh, _) in p.labels {
        let _ = write!(s, "[[objects]]\nname = \"label{k}\"\nmaterial = \"label{k}\"\nmesh = {mesh:?}\n");
        if let Some(m) = &p.transform {
            let rows: Vec<String> = m.iter().map(|r| format!("[{}]", r.iter().map(|&v| num(v)).collect::<Vec<_>>().join(", "))).collect();
            let _ = writeln!(s, "transform = {{ matrix = [{}] }}", rows.join(", "));
        }
        let _ = writeln!(s);
    }
    if let Some(img) = p.projector_image {
        let _ = writeln!(
            s,
            "[[lights]]\ntype = \"projector\"\nimage = {img:?}\nintensity = {}\ncamera = {{ calibration = {:?}, matrix_node = \"projector\" }}\n",
            num(p.projector_intensity),
            p.calibration
        );
    }
    let _ = writeln!(s, "[[lights]]\ntype = \"environment\"\nradiance = {}", num(p.ambient_radiance));
    s
}

/// A distinct display colour for label `k` (golden-angle hues).
pub fn label_colour(k: usize) -> [f32; 3] {
    let h = (k as f64 * 0.618_033_988_75).fract() * 6.0;
    let x = 1.0 - ((h % 2.0) - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r as f32, g as f32, b as f32]
}

/// The photo with each labelled micropolygon's pixel tinted by its label's colour (half and
/// half in linear RGB), watershed boundaries black; `scale` ≥ 1 shrinks it by that factor.
pub fn overlay(l: &Labelled, photo: &Photo, scale: usize) -> Image {
    let (w, h) = (photo.width, photo.height);
    let mut tint: Vec<Option<i32>> = vec![None; w * h];
    for (p, &lab) in l.face_pixel.iter().zip(&l.face_label) {
        if let (Some(i), true) = (p, lab >= 0) {
            tint[*i as usize] = Some(lab);
        }
    }
    let s = scale.max(1);
    let (ow, oh) = (w / s, h / s);
    let mut rgb = Vec::with_capacity(ow * oh);
    for y in 0..oh {
        for x in 0..ow {
            let mut acc = [0f32; 3];
            for yy in y * s..(y + 1) * s {
                for xx in x * s..(x + 1) * s {
                    let i = yy * w + xx;
                    let base = photo.rgb[i];
                    let v = if l.segmentation.region[i] == super::segment::BOUNDARY {
                        [0.0; 3]
                    } else if let Some(k) = tint[i] {
                        let c = label_colour(k as usize);
                        [0.5 * base[0] + 0.5 * c[0], 0.5 * base[1] + 0.5 * c[1], 0.5 * base[2] + 0.5 * c[2]]
                    } else {
                        base
                    };
                    for c in 0..3 {
                        acc[c] += v[c];
                    }
                }
            }
            let n = (s * s) as f32;
            rgb.push(acc.map(|v| v / n));
        }
    }
    Image { width: ow as u32, height: oh as u32, rgb }
}
