//! Triangle meshes and their loaders: Wavefront OBJ (via tobj), PLY (ASCII, binary little and
//! big endian, read by hand), each optionally gzip-compressed (`.obj.gz`, `.ply.gz`).
//!
//! Positions are in the file's length unit; the scene applies its unit and transform with
//! [`TriangleMesh::transform`].
//!
//! Texture coordinates (u, v) follow the OBJ / pbrt-v4 / Mitsuba 3 convention: u runs left to
//! right across an image and v bottom to top (v = 0 is the image's bottom row). OBJ gives them
//! as `vt u v`, PLY as the vertex properties `u, v`, `s, t`, `texture_u, texture_v` or
//! `texture_s, texture_t`; a quad's corners 0, 1, 2, 3 get (0, 0), (1, 0), (1, 1), (0, 1).

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(a < b)` is deliberate: it is true for NaN.

use anyhow::{bail, Context, Result};
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::io::Read;
use std::path::Path;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (same length as `positions`), if the file has them.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (same length as `positions`; u left to right, v bottom
    /// to top of an image), if the file has them.
    pub uvs: Option<Vec<Vec2>>,
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
        if let Some(uv) = &self.uvs {
            if uv.len() != self.positions.len() {
                bail!("{} texture coordinates for {} vertices", uv.len(), self.positions.len());
            }
            for (i, t) in uv.iter().enumerate() {
                if !t.is_finite() {
                    bail!("vertex {i} has non-finite texture coordinates ({}, {})", t.x, t.y);
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

    /// Two triangles (c0, c1, c2) and (c0, c2, c3) for a planar quad given counter-clockwise,
    /// with texture coordinates (0, 0), (1, 0), (1, 1), (0, 1) at c0, c1, c2, c3.
    pub fn quad(corners: [Vec3; 4]) -> TriangleMesh {
        let uvs = vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)];
        TriangleMesh { positions: corners.to_vec(), normals: None, uvs: Some(uvs), indices: vec![[0, 1, 2], [0, 2, 3]] }
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
    check_obj(bytes)?;
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
        // With a single index per vertex, tobj gives one (u, v) per vertex when the faces name texture coordinates.
        let uvs = if !mesh.texcoords.is_empty() && mesh.texcoords.len() / 2 == positions.len() {
            Some(mesh.texcoords.chunks_exact(2).map(|c| Vec2::new(c[0], c[1])).collect())
        } else {
            None
        };
        let indices = mesh.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let name = if m.name.is_empty() || m.name == "unnamed_object" {
            if k == 0 { default_name.to_string() } else { format!("{default_name}_{k}") }
        } else {
            m.name
        };
        let tm = TriangleMesh { positions, normals, uvs, indices };
        tm.validate().with_context(|| format!("OBJ group '{name}'"))?;
        out.push((name, tm));
    }
    if out.is_empty() {
        bail!("OBJ has no faces");
    }
    Ok(out)
}

/// Check what tobj does not report by line: every line is text; vertex positions (`v`, after the
/// optional w divides them) and normals (`vn`) are finite in f32; every face (`f`) has at least
/// three corners whose position, texture and normal indices refer to elements defined above
/// the face, as the OBJ format numbers them (1-based, or negative counting back from the
/// face; Wavefront, "Advanced Visualizer" manual, appendix B1). Errors name the line.
fn check_obj(bytes: &[u8]) -> Result<()> {
    let mut counts = [0usize; 3]; // v, vt, vn defined so far
    for (k, raw) in bytes.split(|&c| c == b'\n').enumerate() {
        let ln = k + 1;
        let line = std::str::from_utf8(raw).map_err(|_| anyhow::anyhow!("OBJ line {ln}: not UTF-8 text"))?;
        let mut w = line.split_whitespace();
        let finite = |tok: Option<&str>, what: &str| -> Result<f32> {
            let tok = tok.with_context(|| format!("OBJ line {ln}: {what} needs 3 coordinates"))?;
            let v: f32 = tok.parse().map_err(|_| anyhow::anyhow!("OBJ line {ln}: {what} coordinate '{}' is not a number", shorten(tok)))?;
            if !v.is_finite() {
                bail!("OBJ line {ln}: {what} coordinate '{}' is not a finite number (in f32)", shorten(tok));
            }
            Ok(v)
        };
        match w.next() {
            Some("v") => {
                let what = format!("vertex {}", counts[0] + 1);
                let xyz = [finite(w.next(), &what)?, finite(w.next(), &what)?, finite(w.next(), &what)?];
                let rest: Vec<&str> = w.collect();
                if rest.len() == 1 {
                    // x y z w: homogeneous coordinates, divided by w.
                    let h: f32 = rest[0].parse().map_err(|_| anyhow::anyhow!("OBJ line {ln}: {what}: w '{}' is not a number", shorten(rest[0])))?;
                    if !(h != 0.0 && xyz.iter().all(|c| (c / h).is_finite())) {
                        bail!("OBJ line {ln}: {what}: w = {h} gives a non-finite position");
                    }
                }
                counts[0] += 1;
            }
            Some("vt") => {
                // vt u v [w]: the OBJ reader needs u and v (w is ignored).
                let what = format!("texture coordinate {}", counts[1] + 1);
                let tok: Vec<&str> = w.collect();
                if tok.len() < 2 || tok.len() > 3 {
                    bail!("OBJ line {ln}: {what} needs u and v (2 or 3 numbers), got {}", tok.len());
                }
                for t in tok {
                    finite(Some(t), &what)?;
                }
                counts[1] += 1;
            }
            Some("vn") => {
                let what = format!("normal {}", counts[2] + 1);
                for _ in 0..3 {
                    finite(w.next(), &what)?;
                }
                counts[2] += 1;
            }
            Some("f") => {
                let mut corners = 0usize;
                for corner in w {
                    corners += 1;
                    for (slot, part) in corner.split('/').enumerate() {
                        let (what, defined) = match slot {
                            0 => ("vertex", counts[0]),
                            1 => ("texture coordinate", counts[1]),
                            2 => ("normal", counts[2]),
                            _ => bail!("OBJ line {ln}: face corner '{}' has more than 3 indices", shorten(corner)),
                        };
                        if part.is_empty() && slot > 0 {
                            continue;
                        }
                        let i: i64 = part.parse().map_err(|_| anyhow::anyhow!("OBJ line {ln}: face corner '{}': {what} index is not an integer", shorten(corner)))?;
                        let ok = if i > 0 { i as u64 <= defined as u64 } else { i != 0 && i.unsigned_abs() <= defined as u64 };
                        if !ok {
                            bail!("OBJ line {ln}: face {what} index {i} out of range ({defined} defined above the face)");
                        }
                    }
                }
                if corners < 3 {
                    bail!("OBJ line {ln}: a face needs at least 3 corners, got {corners}");
                }
            }
            _ => {}
        }
    }
    Ok(())
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
    fn name(self) -> &'static str {
        match self {
            Scalar::I8 => "char",
            Scalar::U8 => "uchar",
            Scalar::I16 => "short",
            Scalar::U16 => "ushort",
            Scalar::I32 => "int",
            Scalar::U32 => "uint",
            Scalar::F32 => "float",
            Scalar::F64 => "double",
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
    /// Whether the integer `v` lies in this type's range.
    fn holds(self, v: i64) -> bool {
        let (lo, hi) = match self {
            Scalar::I8 => (i8::MIN as i64, i8::MAX as i64),
            Scalar::U8 => (0, u8::MAX as i64),
            Scalar::I16 => (i16::MIN as i64, i16::MAX as i64),
            Scalar::U16 => (0, u16::MAX as i64),
            Scalar::I32 => (i32::MIN as i64, i32::MAX as i64),
            Scalar::U32 => (0, u32::MAX as i64),
            Scalar::F32 | Scalar::F64 => (i64::MIN, i64::MAX),
        };
        (lo..=hi).contains(&v)
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

/// A cursor over the body of a PLY file: one element at a time, between [`Body::begin`] and
/// [`Body::end`].
///
/// ASCII bodies are read line by line, as the PLY format defines them (Greg Turk, "The PLY
/// Polygon File Format", 1994): each element instance on its own line holding exactly its
/// properties' values, so a line with a value too many or too few is refused instead of
/// shifting everything after it. Blank lines are skipped. Binary bodies hold the elements
/// back to back. In both, nothing but whitespace may follow the last element.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    /// ASCII: the line of the current element (1-based, counted from the start of the file).
    line: usize,
    /// ASCII: the values of the current element's line not yet read.
    tokens: Option<std::str::SplitAsciiWhitespace<'a>>,
}

impl<'a> Body<'a> {
    /// Start the next element instance (ASCII: take its line).
    fn begin(&mut self) -> Result<()> {
        if self.format != Format::Ascii {
            return Ok(());
        }
        loop {
            if self.pos >= self.bytes.len() {
                bail!("unexpected end of file");
            }
            let end = self.bytes[self.pos..].iter().position(|&c| c == b'\n').map_or(self.bytes.len(), |e| self.pos + e);
            self.line += 1;
            let text = std::str::from_utf8(&self.bytes[self.pos..end]).map_err(|_| anyhow::anyhow!("the line is not text"))?;
            self.pos = (end + 1).min(self.bytes.len());
            if !text.trim_ascii().is_empty() {
                self.tokens = Some(text.split_ascii_whitespace());
                return Ok(());
            }
        }
    }

    /// Finish the current element instance (ASCII: its line must hold no more values).
    fn end(&mut self, props: usize) -> Result<()> {
        if let Some(rest) = self.tokens.take() {
            let extra = rest.count();
            if extra > 0 {
                bail!("{extra} value(s) too many on the line for the element's {props} propert{}", if props == 1 { "y" } else { "ies" });
            }
        }
        Ok(())
    }

    /// Bytes not yet read.
    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    /// An upper bound on how many instances of `el` the rest of the body can hold, for
    /// reserving memory: header counts are not trusted before the data proves them.
    fn max_instances(&self, el: &Element) -> usize {
        let min_bytes = match self.format {
            // Each value takes a character and a separator (space or newline).
            Format::Ascii => 2 * el.props.len(),
            Format::BinaryLe | Format::BinaryBe => el.props.iter().map(|p| p.list.unwrap_or(p.ty).size()).sum(),
        };
        el.count.min(self.remaining() / min_bytes.max(1) + 1)
    }

    /// After the last element: only whitespace may follow.
    fn finish(&self) -> Result<()> {
        let rest = &self.bytes[self.pos..];
        if let Some(k) = rest.iter().position(|c| !c.is_ascii_whitespace()) {
            if self.format == Format::Ascii {
                let line = self.line + 1 + rest[..k].iter().filter(|&&c| c == b'\n').count();
                bail!("PLY line {line}: data after the last element the header declares");
            }
            bail!("PLY byte {}: {} byte(s) after the last element the header declares", self.pos + k, rest.len());
        }
        Ok(())
    }

    fn read(&mut self, ty: Scalar) -> Result<f64> {
        match self.format {
            Format::Ascii => {
                let tok = self.tokens.as_mut().and_then(|t| t.next()).context("too few values on the line")?;
                let bad = || anyhow::anyhow!("cannot parse '{}' as {}", shorten(tok), ty.name());
                if ty.is_integer() {
                    let v: i64 = tok.parse().map_err(|_| bad())?;
                    if !ty.holds(v) {
                        bail!("{v} does not fit in {}", ty.name());
                    }
                    Ok(v as f64)
                } else {
                    tok.parse().map_err(|_| bad())
                }
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

    /// A list's length: a count that the rest of the body can hold.
    fn read_len(&mut self, ty: Scalar, item: Scalar) -> Result<usize> {
        let n = self.read(ty)?;
        // Integer types only (the header parser allows any); a float count must be integral.
        if !(n >= 0.0) || n.fract() != 0.0 {
            bail!("bad list length {n}");
        }
        if self.format == Format::Ascii {
            let room = self.tokens.clone().map_or(0, |t| t.count());
            if n > room as f64 {
                bail!("list length {n} exceeds the {room} value(s) left on the line");
            }
        } else if n > (self.remaining() / item.size()) as f64 {
            bail!("unexpected end of file: list length {n} needs {} bytes, {} left", n * item.size() as f64, self.remaining());
        }
        Ok(n as usize)
    }
}

/// A user string for an error message: at most 40 characters, escaped.
fn shorten(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect::<String>().escape_debug().collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    out
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
                    Some(other) => bail!("PLY header line {ln}: unknown format '{}' (ascii, binary_little_endian or binary_big_endian)", shorten(other)),
                    None => bail!("PLY header line {ln}: format names none (ascii, binary_little_endian or binary_big_endian)"),
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
    for el in &elements {
        if el.count > 0 && el.props.is_empty() {
            bail!("PLY element '{}' has {} instances but no properties", shorten(&el.name), el.count);
        }
    }
    let mut body = Body { bytes, pos, format, line: line_no, tokens: None };
    let mut mesh = TriangleMesh::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut have_vertex = false;
    for el in &elements {
        let idx = |n: &str| el.props.iter().position(|p| p.name == n && p.list.is_none());
        let nprops = el.props.len();
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
            // Texture coordinates under any of their common names (the first pair present).
            let tidx = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")]
                .iter()
                .find_map(|(a, b)| Some((idx(a)?, idx(b)?)));
            mesh.positions.reserve(body.max_instances(el));
            if nidx.is_some() {
                normals.reserve(body.max_instances(el));
            }
            if tidx.is_some() {
                uvs.reserve(body.max_instances(el));
            }
            let mut vals = vec![0.0f64; nprops];
            for v in 0..el.count {
                let c = |body: &Body| ctx(body, "vertex", v, el.count);
                body.begin().with_context(|| c(&body))?;
                for (k, p) in el.props.iter().enumerate() {
                    if let Some(ct) = p.list {
                        let n = body.read_len(ct, p.ty).with_context(|| c(&body))?;
                        for _ in 0..n {
                            body.read(p.ty).with_context(|| c(&body))?;
                        }
                    } else {
                        vals[k] = body.read(p.ty).with_context(|| c(&body))?;
                    }
                }
                body.end(nprops).with_context(|| c(&body))?;
                let pnt = Vec3::new(vals[ix] as f32, vals[iy] as f32, vals[iz] as f32);
                if !pnt.is_finite() {
                    bail!("{}: non-finite position ({}, {}, {})", c(&body), vals[ix], vals[iy], vals[iz]);
                }
                mesh.positions.push(pnt);
                if let Some((a, b, cz)) = nidx {
                    let n = Vec3::new(vals[a] as f32, vals[b] as f32, vals[cz] as f32);
                    if !n.is_finite() {
                        bail!("{}: non-finite normal ({}, {}, {})", c(&body), vals[a], vals[b], vals[cz]);
                    }
                    normals.push(n);
                }
                if let Some((a, b)) = tidx {
                    let t = Vec2::new(vals[a] as f32, vals[b] as f32);
                    if !t.is_finite() {
                        bail!("{}: non-finite texture coordinates ({}, {})", c(&body), vals[a], vals[b]);
                    }
                    uvs.push(t);
                }
            }
        } else if el.name == "face" {
            let li = el
                .props
                .iter()
                .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
                .context("PLY face element lacks a vertex_indices list")?;
            // Every face yields at least one triangle.
            mesh.indices.reserve(body.max_instances(el));
            let mut poly: Vec<u32> = Vec::with_capacity(8);
            for f in 0..el.count {
                let c = |body: &Body| ctx(body, "face", f, el.count);
                body.begin().with_context(|| c(&body))?;
                for (k, p) in el.props.iter().enumerate() {
                    if let Some(ct) = p.list {
                        let n = body.read_len(ct, p.ty).with_context(|| c(&body))?;
                        if k == li {
                            if n < 3 {
                                bail!("{}: {n} vertex indices (a face needs at least 3)", c(&body));
                            }
                            poly.clear();
                        }
                        for _ in 0..n {
                            let i = body.read(p.ty).with_context(|| c(&body))?;
                            if k == li {
                                if !(i >= 0.0) || i >= u32::MAX as f64 || i.fract() != 0.0 {
                                    bail!("{}: bad vertex index {i}", c(&body));
                                }
                                if have_vertex && i as usize >= mesh.positions.len() {
                                    bail!("{}: vertex index {i} out of range (the file has {} vertices)", c(&body), mesh.positions.len());
                                }
                                poly.push(i as u32);
                            }
                        }
                    } else {
                        body.read(p.ty).with_context(|| c(&body))?;
                    }
                }
                body.end(nprops).with_context(|| c(&body))?;
                for j in 1..poly.len() - 1 {
                    mesh.indices.push([poly[0], poly[j], poly[j + 1]]);
                }
            }
        } else {
            // Skip other elements value by value.
            for e in 0..el.count {
                let c = |body: &Body| ctx(body, &el.name, e, el.count);
                body.begin().with_context(|| c(&body))?;
                for p in &el.props {
                    if let Some(ct) = p.list {
                        let n = body.read_len(ct, p.ty).with_context(|| c(&body))?;
                        for _ in 0..n {
                            body.read(p.ty).with_context(|| c(&body))?;
                        }
                    } else {
                        body.read(p.ty).with_context(|| c(&body))?;
                    }
                }
                body.end(nprops).with_context(|| c(&body))?;
            }
        }
    }
    body.finish()?;
    if !have_vertex {
        bail!("PLY file has no vertex element");
    }
    if !normals.is_empty() {
        mesh.normals = Some(normals);
    }
    if !uvs.is_empty() {
        mesh.uvs = Some(uvs);
    }
    let nv = mesh.positions.len() as u64;
    for (f, t) in mesh.indices.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i as u64 >= nv) {
            bail!("PLY triangle {f}: vertex index {i} out of range (the file has {nv} vertices)");
        }
    }
    Ok(mesh)
}

/// Where an element instance is: "PLY line L: vertex i of n" (ASCII) or "PLY vertex i of n
/// (byte B)" (binary; B is the offset reached).
fn ctx(body: &Body, element: &str, i: usize, count: usize) -> String {
    let element = shorten(element);
    if body.format == Format::Ascii {
        format!("PLY line {}: {element} {i} of {count}", body.line)
    } else {
        format!("PLY {element} {i} of {count} (byte {})", body.pos)
    }
}
