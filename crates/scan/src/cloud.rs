//! Point clouds and meshes from a [`RangeImage`]: normals from range-image neighbours, the
//! range-image mesh, summary figures and binary PLY files.
//!
//! Continuity: two neighbouring camera pixels are joined (for normals and mesh edges) when their
//! points are closer than `max_edge_pixels` footprints of a camera pixel at their mean depth,
//! |P₁ − P₂| ≤ k·z̄/f (f the camera focal length in pixels). A surface seen at incidence θ has
//! neighbour spacing about z/(f·cos θ), so k = 20 joins surfaces up to about 87° and splits at
//! depth steps (occlusion edges, shadows).
//!
//! Normals: tangents along camera x and y from the joined neighbours (central differences, or
//! one-sided where only one side is joined), n = t_y × t_x normalised, which faces the camera for
//! a surface seen from the front (camera axes x right, y down, z forward). A point with no joined
//! neighbour along one axis gets the zero normal.

use std::io::Write;
use std::path::Path;

use anyhow::{Context, Result};
use rayon::prelude::*;
use render::image_io::write_atomic;

use crate::triangulate::RangeImage;

/// Default continuity limit (camera-pixel footprints).
pub const DEFAULT_MAX_EDGE_PIXELS: f64 = 20.0;

/// The valid points of a range image with normals and colours, in camera-pixel order.
#[derive(Clone, Debug, Default)]
pub struct PointCloud {
    /// Points, camera coordinates (square units).
    pub points: Vec<[f64; 3]>,
    /// Unit normals facing the camera (zero where no neighbour is joined).
    pub normals: Vec<[f64; 3]>,
    /// White-frame grey level per point (8-bit).
    pub grey: Vec<u8>,
    /// Ray gap per point (square units).
    pub ray_gap: Vec<f64>,
    /// Camera pixel (x, y) of each point.
    pub pixel: Vec<(u32, u32)>,
    /// Triangles (indices into `points`), facing the camera.
    pub triangles: Vec<[u32; 3]>,
}

/// Summary figures of a cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CloudSummary {
    /// Number of points.
    pub points: usize,
    /// Bounding box minimum (square units).
    pub bbox_min: [f64; 3],
    /// Bounding box maximum (square units).
    pub bbox_max: [f64; 3],
    /// Median ray gap (square units); NaN without points.
    pub median_ray_gap: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

impl RangeImage {
    fn at(&self, x: usize, y: usize) -> Option<[f64; 3]> {
        self.points[y * self.width + x].map(|t| t.point)
    }

    /// Whether two points are joined under the continuity limit (module documentation).
    pub fn joined(&self, a: [f64; 3], b: [f64; 3], max_edge_pixels: f64) -> bool {
        let z = 0.5 * (a[2] + b[2]);
        norm(sub(a, b)) <= max_edge_pixels * z / self.focal_px
    }

    /// The tangent along one image axis at (x, y) from joined neighbours.
    fn tangent(&self, x: usize, y: usize, dx: usize, dy: usize, k: f64) -> Option<[f64; 3]> {
        let p = self.at(x, y)?;
        let prev = if (dx == 1 && x > 0) || (dy == 1 && y > 0) { self.at(x - dx, y - dy).filter(|&q| self.joined(p, q, k)) } else { None };
        let next = if x + dx < self.width && y + dy < self.height { self.at(x + dx, y + dy).filter(|&q| self.joined(p, q, k)) } else { None };
        match (prev, next) {
            (Some(a), Some(b)) => Some(sub(b, a)),
            (None, Some(b)) => Some(sub(b, p)),
            (Some(a), None) => Some(sub(p, a)),
            (None, None) => None,
        }
    }

    /// The cloud of valid points with normals, the white frame's grey level as colour, and,
    /// when `mesh`, the range-image triangles: each 2×2 block of pixels gives up to two
    /// triangles whose three edges are all joined.
    pub fn cloud(&self, white: &[f32], max_edge_pixels: f64, mesh: bool) -> PointCloud {
        let (w, h) = (self.width, self.height);
        let k = max_edge_pixels;
        let mut index = vec![u32::MAX; w * h];
        let mut cloud = PointCloud::default();
        for (i, p) in self.points.iter().enumerate() {
            if let Some(t) = p {
                index[i] = cloud.points.len() as u32;
                cloud.points.push(t.point);
                cloud.ray_gap.push(t.ray_gap);
                cloud.pixel.push(((i % w) as u32, (i / w) as u32));
                cloud.grey.push(white.get(i).map_or(0, |&g| g.round().clamp(0.0, 255.0) as u8));
            }
        }
        cloud.normals = cloud
            .pixel
            .par_iter()
            .map(|&(x, y)| {
                let (x, y) = (x as usize, y as usize);
                match (self.tangent(x, y, 1, 0, k), self.tangent(x, y, 0, 1, k)) {
                    (Some(tx), Some(ty)) => {
                        let n = cross(ty, tx);
                        let l = norm(n);
                        if l > 0.0 {
                            [n[0] / l, n[1] / l, n[2] / l]
                        } else {
                            [0.0; 3]
                        }
                    }
                    _ => [0.0; 3],
                }
            })
            .collect();
        if mesh && w >= 2 && h >= 2 {
            let rows: Vec<Vec<[u32; 3]>> = (0..h - 1)
                .into_par_iter()
                .map(|y| {
                    let mut tris = Vec::new();
                    for x in 0..w - 1 {
                        let ids = [index[y * w + x], index[y * w + x + 1], index[(y + 1) * w + x], index[(y + 1) * w + x + 1]];
                        // a = (x, y), b = (x+1, y), c = (x, y+1), d = (x+1, y+1); (a, c, b) and
                        // (b, c, d) wind so that their normals face the camera.
                        for tri in [[ids[0], ids[2], ids[1]], [ids[1], ids[2], ids[3]]] {
                            if tri.iter().any(|&v| v == u32::MAX) {
                                continue;
                            }
                            let p = tri.map(|v| cloud.points[v as usize]);
                            if self.joined(p[0], p[1], k) && self.joined(p[1], p[2], k) && self.joined(p[2], p[0], k) {
                                tris.push(tri);
                            }
                        }
                    }
                    tris
                })
                .collect();
            cloud.triangles = rows.concat();
        }
        cloud
    }
}

impl PointCloud {
    /// Point count, bounding box and median ray gap.
    pub fn summary(&self) -> CloudSummary {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in &self.points {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let median = if self.ray_gap.is_empty() {
            f64::NAN
        } else {
            let mut g = self.ray_gap.clone();
            let mid = g.len() / 2;
            let (_, m, _) = g.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
            let upper = *m;
            if g.len() % 2 == 1 {
                upper
            } else {
                let lower = g[..mid].iter().copied().fold(f64::NEG_INFINITY, f64::max);
                0.5 * (lower + upper)
            }
        };
        CloudSummary { points: self.points.len(), bbox_min: lo, bbox_max: hi, median_ray_gap: median }
    }

    /// Writes a binary little-endian PLY (Turk, "The PLY Polygon File Format", 1994) atomically:
    /// vertices with float x, y, z, nx, ny, nz and uchar red, green, blue (the grey level), and
    /// with `faces` the triangles as `list uchar int vertex_indices`.
    pub fn write_ply(&self, path: &Path, faces: bool) -> Result<()> {
        write_atomic(path, |tmp| {
            let file = std::fs::File::create(tmp).with_context(|| format!("{}: cannot create", tmp.display()))?;
            let mut out = std::io::BufWriter::new(file);
            let mut header = format!(
                "ply\nformat binary_little_endian 1.0\ncomment lucent scan: camera coordinates (x right, y down, z forward), square units\nelement vertex {}\n\
                 property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                 property uchar red\nproperty uchar green\nproperty uchar blue\n",
                self.points.len()
            );
            if faces {
                header.push_str(&format!("element face {}\nproperty list uchar int vertex_indices\n", self.triangles.len()));
            }
            header.push_str("end_header\n");
            out.write_all(header.as_bytes())?;
            for ((p, n), &g) in self.points.iter().zip(&self.normals).zip(&self.grey) {
                for v in p.iter().chain(n.iter()) {
                    out.write_all(&(*v as f32).to_le_bytes())?;
                }
                out.write_all(&[g, g, g])?;
            }
            if faces {
                for t in &self.triangles {
                    out.write_all(&[3u8])?;
                    for &v in t {
                        out.write_all(&(v as i32).to_le_bytes())?;
                    }
                }
            }
            out.flush().with_context(|| format!("{}: cannot write", tmp.display()))?;
            Ok(())
        })
        .with_context(|| format!("writing {}", path.display()))
    }
}
