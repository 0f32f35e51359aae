//! Triangle meshes and their loaders: Wavefront OBJ (via tobj), PLY (ASCII, binary little and
//! big endian, read by hand), each optionally gzip-compressed (`.obj.gz`, `.ply.gz`).
//!
//! Positions are in the file's length unit; the scene applies its unit and transform with
//! [`TriangleMesh::transform`].

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use anyhow::{bail, Context, Result};
use glam::{Mat3, Mat4, Vec3};
use std::io::Read;
use std::path::Path;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (same length as `positions`), if the file has them.
    pub normals: Option<Vec<Vec3>>,
    /// Triangles as indices into `positions`, counter-clockwise seen from the front.
    pub indices: Vec<[u32; 3]>,
}

impl TriangleMesh {
    /// Load every mesh in a file: `.obj` (one named mesh per group/object), `.ply`, and both
    /// gzip-compressed (`.gz`). Errors name the file and, where possible, the element or line.
    pub fn load(path: &Path) -> Result<Vec<(String, TriangleMesh)>> {
        let meshes = load_unchecked(path).with_context(|| format!("{}", path.display()))?;
        for (name, m) in &meshes {
            m.validate().with_context(|| format!("{}: mesh '{}'", path.display(), name))?;
        }
        Ok(meshes)
    }

    /// Apply an affine transform to positions (and the inverse transpose to normals).
    pub fn transform(&mut self, m: &Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let nm = Mat3::from_mat4(*m).inverse().transpose();
        if let Some(ns) = &mut self.normals {
            for n in ns.iter_mut() {
                *n = (nm * *n).normalize_or_zero();
            }
        }
        // A mirroring transform flips the winding; keep the front side where it was.
        if Mat3::from_mat4(*m).determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
    }

    /// Check that positions and normals are finite and indices in range.
    pub fn validate(&self) -> Result<()> {
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                bail!("vertex {i} has a non-finite position ({}, {}, {})", p.x, p.y, p.z);
            }
        }
        if let Some(ns) = &self.normals {
            if ns.len() != self.positions.len() {
                bail!("{} normals for {} vertices", ns.len(), self.positions.len());
            }
            for (i, n) in ns.iter().enumerate() {
                if !n.is_finite() {
                    bail!("vertex {i} has a non-finite normal ({}, {}, {})", n.x, n.y, n.z);
                }
            }
        }
        let nv = self.positions.len() as u64;
        for (f, t) in self.indices.iter().enumerate() {
            for &i in t {
                if i as u64 >= nv {
                    bail!("face {f} has vertex index {i} out of range (the mesh has {nv} vertices)");
                }
            }
        }
        Ok(())
    }

    /// Two triangles (c0, c1, c2) and (c0, c2, c3) for a planar quad given counter-clockwise.
    pub fn quad(corners: [Vec3; 4]) -> TriangleMesh {
        TriangleMesh { positions: corners.to_vec(), normals: None, indices: vec![[0, 1, 2], [0, 2, 3]] }
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        (0..self.indices.len()).map(|i| self.triangle_area(i)).sum()
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.triangle(i);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The three vertices of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let t = self.indices[i];
        [self.positions[t[0] as usize], self.positions[t[1] as usize], self.positions[t[2] as usize]]
    }
}

fn load_unchecked(path: &Path) -> Result<Vec<(String, TriangleMesh)>> {
    let name = path.file_name().map(|s| s.to_string_lossy().to_lowercase()).unwrap_or_default();
    let raw = std::fs::read(path).context("cannot read the mesh file")?;
    let (inner, bytes) = if let Some(stem) = name.strip_suffix(".gz") {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(&raw[..]).read_to_end(&mut out).context("gzip decompression failed")?;
        (stem.to_string(), out)
    } else {
        (name.clone(), raw)
    };
    let stem = Path::new(&inner).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    if inner.ends_with(".ply") {
        Ok(vec![(stem, parse_ply(&bytes)?)])
    } else if inner.ends_with(".obj") {
        parse_obj(&bytes, &stem)
    } else {
        bail!("unknown mesh format (expected .obj, .ply, .obj.gz or .ply.gz)")
    }
}

/// Parse OBJ text; each group/object becomes one named mesh.
pub fn parse_obj(bytes: &[u8], default_name: &str) -> Result<Vec<(String, TriangleMesh)>> {
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let mut reader = std::io::BufReader::new(bytes);
    let (models, _) = tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
        .map_err(|e| anyhow::anyhow!("OBJ: {e}"))?;
    let mut out = Vec::new();
    for (k, m) in models.into_iter().enumerate() {
        let mesh = m.mesh;
        if mesh.indices.is_empty() {
            continue;
        }
        let positions: Vec<Vec3> = mesh.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        let normals = if mesh.normals.len() == mesh.positions.len() && !mesh.normals.is_empty() {
            Some(mesh.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
        } else {
            None
        };
        let indices = mesh.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let name = if m.name.is_empty() || m.name == "unnamed_object" {
            if k == 0 { default_name.to_string() } else { format!("{default_name}_{k}") }
        } else {
            m.name
        };
        let tm = TriangleMesh { positions, normals, indices };
        tm.validate().with_context(|| format!("OBJ group '{name}'"))?;
        out.push((name, tm));
    }
    if out.is_empty() {
        bail!("OBJ has no faces");
    }
    Ok(out)
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for list properties.
    list: Option<Scalar>,
    ty: Scalar,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

/// A cursor over the body of a PLY file, ASCII tokens or binary values.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    line: usize,
}

impl<'a> Body<'a> {
    fn read(&mut self, ty: Scalar) -> Result<f64> {
        match self.format {
            Format::Ascii => {
                // Skip whitespace, counting lines.
                while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
                    if self.bytes[self.pos] == b'\n' {
                        self.line += 1;
                    }
                    self.pos += 1;
                }
                let start = self.pos;
                while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
                    self.pos += 1;
                }
                if start == self.pos {
                    bail!("unexpected end of file");
                }
                let tok = std::str::from_utf8(&self.bytes[start..self.pos]).unwrap_or("?");
                let v: f64 = tok.parse().map_err(|_| anyhow::anyhow!("cannot parse '{tok}' as a number"))?;
                Ok(v)
            }
            Format::BinaryLe | Format::BinaryBe => {
                let n = ty.size();
                if self.pos + n > self.bytes.len() {
                    bail!("unexpected end of file");
                }
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
                self.pos += n;
                if self.format == Format::BinaryBe {
                    b[..n].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }
}

/// Parse a PLY file (ASCII or binary, either endianness): vertex x, y, z (and nx, ny, nz if all
/// present), faces as index lists (`vertex_indices` or `vertex_index`), polygons fan-triangulated.
pub fn parse_ply(bytes: &[u8]) -> Result<TriangleMesh> {
    // Header: lines up to "end_header".
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut lines = Vec::new();
    loop {
        if pos >= bytes.len() {
            bail!("PLY header has no end_header line");
        }
        let end = bytes[pos..].iter().position(|&c| c == b'\n').map(|e| pos + e).unwrap_or(bytes.len());
        let line = std::str::from_utf8(&bytes[pos..end]).context("PLY header is not text")?.trim_end_matches('\r').trim().to_string();
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        if line == "end_header" {
            break;
        }
        lines.push((line_no, line));
        if line_no > 100_000 {
            bail!("PLY header too long");
        }
    }
    if lines.first().map(|l| l.1.as_str()) != Some("ply") {
        bail!("not a PLY file (first line is not 'ply')");
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (ln, line) in &lines[1..] {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match w.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    other => bail!("PLY header line {ln}: unknown format {other:?}"),
                })
            }
            Some("element") => {
                if w.len() != 3 {
                    bail!("PLY header line {ln}: malformed element line");
                }
                let count = w[2].parse().with_context(|| format!("PLY header line {ln}: bad element count '{}'", w[2]))?;
                elements.push(Element { name: w[1].to_string(), count, props: Vec::new() });
            }
            Some("property") => {
                let el = elements.last_mut().with_context(|| format!("PLY header line {ln}: property before any element"))?;
                let prop = if w.get(1) == Some(&"list") {
                    if w.len() != 5 {
                        bail!("PLY header line {ln}: malformed list property");
                    }
                    let ct = Scalar::parse(w[2]).with_context(|| format!("PLY header line {ln}: unknown type '{}'", w[2]))?;
                    let ty = Scalar::parse(w[3]).with_context(|| format!("PLY header line {ln}: unknown type '{}'", w[3]))?;
                    Property { name: w[4].to_string(), list: Some(ct), ty }
                } else {
                    if w.len() != 3 {
                        bail!("PLY header line {ln}: malformed property");
                    }
                    let ty = Scalar::parse(w[1]).with_context(|| format!("PLY header line {ln}: unknown type '{}'", w[1]))?;
                    Property { name: w[2].to_string(), list: None, ty }
                };
                el.props.push(prop);
            }
            Some(other) => bail!("PLY header line {ln}: unknown keyword '{other}'"),
        }
    }
    let format = format.context("PLY header has no format line")?;
    let mut body = Body { bytes, pos, format, line: line_no + 1 };
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    let mut have_vertex = false;
    for el in &elements {
        let idx = |n: &str| el.props.iter().position(|p| p.name == n && p.list.is_none());
        if el.name == "vertex" {
            have_vertex = true;
            let (ix, iy, iz) = match (idx("x"), idx("y"), idx("z")) {
                (Some(a), Some(b), Some(c)) => (a, b, c),
                _ => bail!("PLY vertex element lacks x, y or z"),
            };
            let nidx = match (idx("nx"), idx("ny"), idx("nz")) {
                (Some(a), Some(b), Some(c)) => Some((a, b, c)),
                _ => None,
            };
            mesh.positions.reserve(el.count);
            let mut vals = vec![0.0f64; el.props.len()];
            for v in 0..el.count {
                for (k, p) in el.props.iter().enumerate() {
                    if let Some(ct) = p.list {
                        let n = body.read(ct).with_context(|| ctx(&body, "vertex", v))? as usize;
                        for _ in 0..n {
                            body.read(p.ty).with_context(|| ctx(&body, "vertex", v))?;
                        }
                    } else {
                        vals[k] = body.read(p.ty).with_context(|| ctx(&body, "vertex", v))?;
                    }
                }
                let pnt = Vec3::new(vals[ix] as f32, vals[iy] as f32, vals[iz] as f32);
                if !pnt.is_finite() {
                    bail!("{}: non-finite position ({}, {}, {})", ctx(&body, "vertex", v), vals[ix], vals[iy], vals[iz]);
                }
                mesh.positions.push(pnt);
                if let Some((a, b, c)) = nidx {
                    normals.push(Vec3::new(vals[a] as f32, vals[b] as f32, vals[c] as f32));
                }
            }
        } else if el.name == "face" {
            let li = el
                .props
                .iter()
                .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
                .context("PLY face element lacks a vertex_indices list")?;
            mesh.indices.reserve(el.count);
            let mut poly: Vec<u32> = Vec::with_capacity(8);
            for f in 0..el.count {
                for (k, p) in el.props.iter().enumerate() {
                    if let Some(ct) = p.list {
                        let n = body.read(ct).with_context(|| ctx(&body, "face", f))?;
                        if !(n >= 0.0) || n > 1e6 {
                            bail!("{}: bad list length {n}", ctx(&body, "face", f));
                        }
                        poly.clear();
                        for _ in 0..n as usize {
                            let i = body.read(p.ty).with_context(|| ctx(&body, "face", f))?;
                            if k == li {
                                if !(i >= 0.0) || i >= u32::MAX as f64 || i.fract() != 0.0 {
                                    bail!("{}: bad vertex index {i}", ctx(&body, "face", f));
                                }
                                if have_vertex && i as usize >= mesh.positions.len() {
                                    bail!("{}: vertex index {i} out of range (the file has {} vertices)", ctx(&body, "face", f), mesh.positions.len());
                                }
                                poly.push(i as u32);
                            }
                        }
                    } else {
                        body.read(p.ty).with_context(|| ctx(&body, "face", f))?;
                    }
                }
                if poly.len() < 3 {
                    continue;
                }
                for j in 1..poly.len() - 1 {
                    mesh.indices.push([poly[0], poly[j], poly[j + 1]]);
                }
            }
        } else {
            // Skip other elements value by value.
            for e in 0..el.count {
                for p in &el.props {
                    if let Some(ct) = p.list {
                        let n = body.read(ct).with_context(|| ctx(&body, &el.name, e))? as usize;
                        for _ in 0..n {
                            body.read(p.ty).with_context(|| ctx(&body, &el.name, e))?;
                        }
                    } else {
                        body.read(p.ty).with_context(|| ctx(&body, &el.name, e))?;
                    }
                }
            }
        }
    }
    if !have_vertex {
        bail!("PLY file has no vertex element");
    }
    if !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    let nv = mesh.positions.len() as u64;
    for (f, t) in mesh.indices.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i as u64 >= nv) {
            bail!("PLY triangle {f}: vertex index {i} out of range (the file has {nv} vertices)");
        }
    }
    Ok(mesh)
}

fn ctx(body: &Body, element: &str, i: usize) -> String {
    if body.format == Format::Ascii {
        format!("PLY line {}: {element} {i}", body.line)
    } else {
        format!("PLY {element} {i} (byte {})", body.pos)
    }
}
