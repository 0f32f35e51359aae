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
//! the depth) plus `depth_tolerance`·z (noise of a scanned surface). Where the winding of the
//! visible micropolygons is consistent (at least [`ORIENTED_SHARE`] of their area turned towards
//! the camera, as in a range-image mesh or a closed mesh wound outward; or as much turned away,
//! for one wound inward), the micropolygons turned the other way are hidden too: at an object's
//! outline the front and back faces meet at the same depth, and the depth test alone cannot
//! tell them apart.
//!
//! **Occlusion edges** ([`occlusion_edges`]): pixels on either side of a depth step of the
//! z-buffer are barriers of the watershed (the segmentation's gradient is raised to its maximum
//! there), so that regions end at the mesh's outlines, where a dark limb or a blurred edge of
//! the photo would otherwise let one region spill a few pixels over another object.
//!
//! **Label** ([`assign`]): a visible micropolygon takes the label at the pixel nearest its
//! projected centroid. Where that pixel is a watershed boundary, it takes the label of the pixel
//! nearest its projected centroid that lies inside a region and on its own surface (z-buffer
//! depth near its own), so that at an outline it takes its label from its own side; failing
//! that, the label of the nearest labelled pixel ([`super::segment::Segmentation::label_map`]).
//! Hidden micropolygons, and those whose centroid falls outside the image, get −1.

use std::sync::atomic::{AtomicU32, Ordering};

use rayon::prelude::*;

use super::subdivide::Mesh;
use crate::triangulate::Lens;

/// Per micropolygon: the pixel (row-major index) its centroid projects to, or None outside the
/// image, and whether it is visible there; and the z-buffer.
#[derive(Clone, Debug)]
pub struct Visibility {
    /// Pixel index y·width + x of the centroid's projection, if inside the image.
    pub pixel: Vec<Option<u32>>,
    /// Whether the micropolygon is the nearest surface at that pixel (module documentation).
    pub visible: Vec<bool>,
    /// Image position of each micropolygon's projected centroid (pixels, OpenCV convention).
    pub position: Vec<[f32; 2]>,
    /// Depth of each micropolygon's centroid (calibration units).
    pub depth: Vec<f32>,
    /// Each micropolygon's depth change per pixel on the image, capped at 5 % of its depth.
    pub slope: Vec<f32>,
    /// The z-buffer: nearest depth per pixel (∞ where nothing projects).
    pub zbuf: Vec<f32>,
    /// Image width (pixels).
    pub width: usize,
    /// Image height (pixels).
    pub height: usize,
    /// The relative depth tolerance the visibility was decided with.
    pub depth_tolerance: f64,
    /// Micropolygons that passed the depth test but were hidden as back faces.
    pub back_faces: usize,
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

/// Whether the triangle's winding normal (b − a) × (c − a) points towards the camera centre,
/// weighted by its area: (facing, twice the area).
fn facing(mesh: &Mesh, t: &[u32; 3]) -> (bool, f64) {
    let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
    let (u, v) = ([0, 1, 2].map(|k| b[k] - a[k]), [0, 1, 2].map(|k| c[k] - a[k]));
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let m = [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0);
    (n[0] * m[0] + n[1] * m[1] + n[2] * m[2] < 0.0, (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt())
}

/// Share of the visible area above which the mesh counts as consistently wound (module
/// documentation).
pub const ORIENTED_SHARE: f64 = 0.9;

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
    let per_face: Vec<(Option<u32>, bool, f32, f32)> = mesh
        .triangles
        .par_iter()
        .zip(&centres)
        .map(|(t, c)| {
            let zc = centroid(mesh, t)[2];
            let Some(i) = c.and_then(pixel_of) else { return (None, false, zc as f32, 0.0) };
            let Some((q, z)) = screen(mesh, &proj, t) else { return (Some(i as u32), false, zc as f32, 0.0) };
            let (x, y) = ((i % width) as f64, (i / width) as f64);
            let zmin = z.iter().copied().fold(f64::INFINITY, f64::min);
            let zmax = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let own = depth_at(&q, &z, [x, y]).map_or(zc, |(d, _)| d.clamp(zmin, zmax));
            let slope = depth_gradient(&q, &z).min(0.05 * zc);
            let slack = slope + depth_tolerance * zc;
            let front = f32::from_bits(zbuf[i].load(Ordering::Relaxed)) as f64;
            (Some(i as u32), own <= front + slack, zc as f32, slope as f32)
        })
        .collect();
    // Back faces: of a consistently wound mesh (a range-image mesh, a closed mesh wound outward
    // or inward), the faces turned away from the camera are hidden even where the depth test
    // cannot tell them from the front faces they meet at an outline.
    let winding: Vec<(bool, f64)> = mesh.triangles.par_iter().map(|t| facing(mesh, t)).collect();
    let (mut front, mut all) = (0.0, 0.0);
    for (f, w) in per_face.iter().zip(&winding) {
        if f.1 {
            all += w.1;
            if w.0 {
                front += w.1;
            }
        }
    }
    let cull = if all > 0.0 && front >= ORIENTED_SHARE * all {
        Some(true)
    } else if all > 0.0 && front <= (1.0 - ORIENTED_SHARE) * all {
        Some(false)
    } else {
        None
    };
    let back_faces = per_face.iter().zip(&winding).filter(|(f, w)| f.1 && cull.is_some_and(|c| w.0 != c)).count();
    Visibility {
        back_faces,
        pixel: per_face.iter().map(|f| f.0).collect(),
        position: centres.iter().map(|c| c.map_or([f32::NAN; 2], |p| [p[0] as f32, p[1] as f32])).collect(),
        visible: per_face.iter().zip(&winding).map(|(f, w)| f.1 && cull.is_none_or(|c| w.0 == c)).collect(),
        depth: per_face.iter().map(|f| f.2).collect(),
        slope: per_face.iter().map(|f| f.3).collect(),
        zbuf: zbuf.into_iter().map(|z| f32::from_bits(z.into_inner())).collect(),
        width,
        height,
        depth_tolerance,
    }
}

/// Relative depth step between neighbouring pixels of the z-buffer that counts as an occlusion
/// edge (a silhouette).
pub const SILHOUETTE_STEP: f32 = 0.03;
/// How far [`assign`] looks for a pixel of a micropolygon's own surface (pixels).
pub const SEARCH_PX: i64 = 4;

/// Occlusion edges: both pixels of each pair of 4-neighbouring covered pixels whose depths differ
/// by more than [`SILHOUETTE_STEP`] of the nearer (pixels where nothing projects make no edge, so
/// holes in a scan do not count). The segmentation treats them as watershed barriers.
pub fn occlusion_edges(zbuf: &[f32], w: usize, h: usize) -> Vec<bool> {
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let a = zbuf[i];
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                let b = zbuf[j];
                if a.is_finite() && b.is_finite() && (a - b).abs() > SILHOUETTE_STEP * a.min(b) {
                    edge[i] = true;
                    edge[j] = true;
                }
            }
        }
    }
    edge
}

/// The label of each micropolygon (module documentation): −1 where not visible; the label of
/// its pixel where that lies inside a region; on a watershed boundary, the label of the pixel
/// nearest its projected centroid (within [`SEARCH_PX`]) that is inside a region and on the
/// micropolygon's own surface (z-buffer depth within its slope times the distance plus the depth
/// tolerance), so that a micropolygon at an object's outline takes its label from its own side;
/// without such a pixel, the nearest labelled pixel's (`label_map`).
pub(crate) fn assign(vis: &Visibility, region: &[i32], region_label: &[usize], label_map: &[i32]) -> Vec<i32> {
    let (w, h) = (vis.width, vis.height);
    let mut offsets: Vec<(i64, i64)> = Vec::new();
    for dy in -SEARCH_PX..=SEARCH_PX {
        for dx in -SEARCH_PX..=SEARCH_PX {
            if dx * dx + dy * dy <= SEARCH_PX * SEARCH_PX {
                offsets.push((dx, dy));
            }
        }
    }
    (0..vis.pixel.len())
        .into_par_iter()
        .map(|f| {
            let (Some(i), true) = (vis.pixel[f], vis.visible[f]) else { return -1 };
            let i = i as usize;
            if region[i] > 0 {
                return region_label[region[i] as usize - 1] as i32;
            }
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let (z, slope) = (vis.depth[f], vis.slope[f]);
            let [px, py] = vis.position[f];
            // The nearest pixel centre to the projected centroid (not to its pixel's centre, so
            // that a micropolygon on a one-pixel boundary goes to the side it lies on).
            let mut best: Option<(f32, usize)> = None;
            for &(dx, dy) in &offsets {
                let (xx, yy) = (x + dx, y + dy);
                if xx < 0 || yy < 0 || xx >= w as i64 || yy >= h as i64 {
                    continue;
                }
                let j = yy as usize * w + xx as usize;
                if region[j] <= 0 {
                    continue;
                }
                let d2 = (xx as f32 - px).powi(2) + (yy as f32 - py).powi(2);
                if best.is_some_and(|b| b.0 <= d2) {
                    continue;
                }
                let allowed = (slope * (d2.sqrt() + 1.0)).min(0.1 * z) + vis.depth_tolerance as f32 * z;
                if (vis.zbuf[j] - z).abs() <= allowed {
                    best = Some((d2, j));
                }
            }
            match best {
                Some((_, j)) => region_label[region[j] as usize - 1] as i32,
                None => label_map[i],
            }
        })
        .collect()
}
