//! Back-projection of micropolygons into the labelled photograph.
//!
//! Each vertex is projected through the calibrated camera (OpenCV's model, distortion included;
//! points behind the camera or beyond the fold of the distortion polynomial do not project).
//!
//! **Visibility** by a z-buffer of the mesh at the photo's resolution: every triangle whose
//! corners project writes, at each pixel centre it covers (OpenCV convention: integer pixel
//! coordinates are pixel centres), its depth there (1/z interpolated linearly on the image, exact
//! for a plane seen by a pinhole), and also its centroid's depth at the centroid's pixel, so that
//! micropolygons smaller than a pixel that cover no pixel centre still occlude; each pixel keeps
//! the nearest depth. A micropolygon is visible when its depth at its centroid's pixel, from the
//! plane through its projected corners, is at most the z-buffer's there plus `|∇z|·1 px` (the
//! depth change of the surface over the pixel, from neighbours' centroid writes; at most 5 % of
//! the depth) plus `depth_tolerance`·z (noise of a scanned surface).
//!
//! **Label**: a visible micropolygon takes the label at the pixel nearest its projected centroid;
//! watershed boundary pixels carry the label of the nearest labelled pixel
//! ([`super::segment::Segmentation::label_map`]). Hidden micropolygons, and those whose centroid
//! falls outside the image, get −1.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::subdivide::Mesh;
use crate::triangulate::Lens;

/// Per micropolygon: the pixel (row-major index) its centroid projects to, or None outside the
/// image, and whether it is visible there.
#[derive(Clone, Debug)]
pub struct Visibility {
    /// Pixel index y·width + x of the centroid's projection, if inside the image.
    pub pixel: Vec<Option<u32>>,
    /// Whether the micropolygon is the nearest surface at that pixel (module documentation).
    pub visible: Vec<bool>,
}

/// Screen geometry of one triangle: projected corners and their depths.
fn screen(mesh: &Mesh, proj: &[Option<[f64; 2]>], t: &[u32; 3]) -> Option<([[f64; 2]; 3], [f64; 3])> {
    let q = [proj[t[0] as usize]?, proj[t[1] as usize]?, proj[t[2] as usize]?];
    let z = t.map(|v| mesh.positions[v as usize][2]);
    Some((q, z))
}

/// Depth of the plane through the projected corners at image position `p`, 1/z interpolated by
/// the barycentric coordinates; None for a triangle of zero image area.
fn depth_at(q: &[[f64; 2]; 3], z: &[f64; 3], p: [f64; 2]) -> Option<(f64, [f64; 3])> {
    let area = (q[1][0] - q[0][0]) * (q[2][1] - q[0][1]) - (q[2][0] - q[0][0]) * (q[1][1] - q[0][1]);
    if !(area.abs() > 1e-12) {
        return None;
    }
    let edge = |a: [f64; 2], b: [f64; 2]| (b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1]);
    let b = [edge(q[1], q[2]) / area, edge(q[2], q[0]) / area, edge(q[0], q[1]) / area];
    let inv = b[0] / z[0] + b[1] / z[1] + b[2] / z[2];
    Some((1.0 / inv, b))
}

/// Magnitude of the image-space gradient of depth over a triangle (depth per pixel).
fn depth_gradient(q: &[[f64; 2]; 3], z: &[f64; 3]) -> f64 {
    let (ux, uy) = (q[1][0] - q[0][0], q[1][1] - q[0][1]);
    let (vx, vy) = (q[2][0] - q[0][0], q[2][1] - q[0][1]);
    let det = ux * vy - vx * uy;
    if !(det.abs() > 1e-12) {
        return f64::INFINITY;
    }
    let (dz1, dz2) = (z[1] - z[0], z[2] - z[0]);
    let gx = (dz1 * vy - dz2 * uy) / det;
    let gy = (ux * dz2 - vx * dz1) / det;
    gx.hypot(gy)
}

fn centroid(mesh: &Mesh, t: &[u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
    [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
}

/// Projects every micropolygon of `mesh` into a `width` × `height` image and decides its
/// visibility (module documentation).
pub(crate) fn visibility(mesh: &Mesh, lens: &Lens, width: usize, height: usize, depth_tolerance: f64) -> Visibility {
    let proj: Vec<Option<[f64; 2]>> = mesh.positions.par_iter().map(|&p| lens.project_unfolded(p)).collect();
    let zbuf: Vec<AtomicU32> = (0..width * height).map(|_| AtomicU32::new(f32::INFINITY.to_bits())).collect();
    // Positive floats order as their bit patterns.
    let write = |i: usize, z: f64| {
        if z > 0.0 {
            zbuf[i].fetch_min((z as f32).to_bits(), Ordering::Relaxed);
        }
    };
    let pixel_of = |p: [f64; 2]| -> Option<usize> {
        let (x, y) = (p[0].round(), p[1].round());
        (x >= 0.0 && y >= 0.0 && x < width as f64 && y < height as f64).then(|| y as usize * width + x as usize)
    };
    let centres: Vec<Option<[f64; 2]>> = mesh.triangles.par_iter().map(|t| lens.project_unfolded(centroid(mesh, t))).collect();
    mesh.triangles.par_iter().zip(&centres).for_each(|(t, c)| {
        let Some((q, z)) = screen(mesh, &proj, t) else { return };
        if let Some(i) = c.and_then(pixel_of) {
            write(i, centroid(mesh, t)[2]);
        }
        let x0 = q.iter().map(|p| p[0]).fold(f64::INFINITY, f64::min).ceil().max(0.0);
        let x1 = q.iter().map(|p| p[0]).fold(f64::NEG_INFINITY, f64::max).floor().min(width as f64 - 1.0);
        let y0 = q.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min).ceil().max(0.0);
        let y1 = q.iter().map(|p| p[1]).fold(f64::NEG_INFINITY, f64::max).floor().min(height as f64 - 1.0);
        if !(x0 <= x1 && y0 <= y1) || (x1 - x0 + 1.0) * (y1 - y0 + 1.0) > 4.0e6 {
            return;
        }
        for y in y0 as usize..=y1 as usize {
            for x in x0 as usize..=x1 as usize {
                if let Some((d, b)) = depth_at(&q, &z, [x as f64, y as f64]) {
                    if b.iter().all(|&v| v >= -1e-9) {
                        write(y * width + x, d);
                    }
                }
            }
        }
    });
    let (pixel, visible): (Vec<Option<u32>>, Vec<bool>) = mesh
        .triangles
        .par_iter()
        .zip(&centres)
        .map(|(t, c)| {
            let Some(i) = c.and_then(pixel_of) else { return (None, false) };
            let Some((q, z)) = screen(mesh, &proj, t) else { return (Some(i as u32), false) };
            let zc = centroid(mesh, t)[2];
            let (x, y) = ((i % width) as f64, (i / width) as f64);
            let zmin = z.iter().copied().fold(f64::INFINITY, f64::min);
            let zmax = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let own = depth_at(&q, &z, [x, y]).map_or(zc, |(d, _)| d.clamp(zmin, zmax));
            let slack = (depth_gradient(&q, &z) * 1.0).min(0.05 * zc) + depth_tolerance * zc;
            let front = f32::from_bits(zbuf[i].load(Ordering::Relaxed)) as f64;
            (Some(i as u32), own <= front + slack)
        })
        .unzip();
    Visibility { pixel, visible }
}
