//! Smooth shading normals and depth for a scanned surface.
//!
//! The micropolygons of a range-image mesh are about a pixel wide while the triangulated depth
//! scatters by a few tenths of a percent of the distance, so their facet normals scatter by tens
//! of degrees and a Lambertian render of them is speckled by cos θ. The shading normal of a
//! vertex is therefore its area-weighted facet normal diffused over the mesh: each of
//! `iterations` passes replaces a vertex's normal by the normalised sum of its own and its edge
//! neighbours' (a discrete heat flow on the mesh graph, spreading over about √iterations edges),
//! which keeps a plane's normal exactly and follows curvature at scales above that radius.
//!
//! The bumps themselves shadow their neighbours from a light beside the camera (a projector a few
//! degrees off axis sees slopes of tens of degrees at grazing angles), so the positions are
//! smoothed as well, along the smoothed normal only ([`smooth_depth`]): each pass moves a vertex
//! by the normal component of the mean of its neighbours minus itself (Laplacian smoothing
//! restricted to the normal, as in the normal-constrained filters of scanned surfaces, e.g.
//! Jones, Durand & Desbrun, SIGGRAPH 2003, §2), so outlines and the sampling do not drift.

use rayon::prelude::*;

use super::Mesh;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalise(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if n > 0.0 {
        v.map(|c| c / n)
    } else {
        [0.0; 3]
    }
}

/// Per-vertex shading normals of the faces of `mesh` for which `keep` is true (others take no
/// part; vertices of no kept face get the zero vector), turned towards the camera at the origin
/// (n · p < 0), after `iterations` passes of neighbour averaging (module documentation).
pub fn smooth_normals(mesh: &Mesh, keep: &[bool], iterations: usize) -> Vec<[f64; 3]> {
    let (start, nb) = neighbours(mesh, keep);
    let nv = mesh.positions.len();
    let mut n = vec![[0.0f64; 3]; nv];
    for (t, _) in mesh.triangles.iter().zip(keep).filter(|(_, &k)| k) {
        let p = t.map(|v| mesh.positions[v as usize]);
        // |a × b| is twice the area: the sum weights each facet normal by its area.
        let mut f = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        let c = [(p[0][0] + p[1][0] + p[2][0]) / 3.0, (p[0][1] + p[1][1] + p[2][1]) / 3.0, (p[0][2] + p[1][2] + p[2][2]) / 3.0];
        if f[0] * c[0] + f[1] * c[1] + f[2] * c[2] > 0.0 {
            f = f.map(|v| -v);
        }
        for &v in t {
            let s = &mut n[v as usize];
            for k in 0..3 {
                s[k] += f[k];
            }
        }
    }
    let mut cur: Vec<[f64; 3]> = n.iter().map(|&v| normalise(v)).collect();
    // Two buffers, swapped after each pass (a fresh vector per pass spent more time in page
    // faults than in the sums).
    let mut next = vec![[0.0f64; 3]; nv];
    for _ in 0..iterations {
        next.par_iter_mut().enumerate().with_min_len(4096).for_each(|(v, out)| {
            let mut s = cur[v];
            for &u in &nb[start[v]..start[v + 1]] {
                let q = cur[u as usize];
                for k in 0..3 {
                    s[k] += q[k];
                }
            }
            *out = normalise(s);
        });
        std::mem::swap(&mut cur, &mut next);
    }
    cur
}

/// Positions of `mesh` after `iterations` passes of Laplacian smoothing along `normals` (one
/// per vertex, e.g. from [`smooth_normals`]) over the faces for which `keep` is true: each pass
/// moves a vertex by ((mean of its edge neighbours) − p) · n along n. A plane is kept exactly;
/// vertices of no kept face stay.
pub fn smooth_depth(mesh: &Mesh, keep: &[bool], normals: &[[f64; 3]], iterations: usize) -> Vec<[f64; 3]> {
    let (start, nb) = neighbours(mesh, keep);
    let nv = mesh.positions.len();
    let mut cur = mesh.positions.clone();
    let mut next = vec![[0.0f64; 3]; nv];
    for _ in 0..iterations {
        next.par_iter_mut().enumerate().with_min_len(4096).for_each(|(v, out)| {
            let list = &nb[start[v]..start[v + 1]];
            let p = cur[v];
            if list.is_empty() {
                *out = p;
                return;
            }
            let mut m = [0.0; 3];
            for &u in list {
                let q = cur[u as usize];
                for k in 0..3 {
                    m[k] += q[k];
                }
            }
            let inv = 1.0 / list.len() as f64;
            let m = m.map(|x| x * inv);
            let n = normals[v];
            let d = (m[0] - p[0]) * n[0] + (m[1] - p[1]) * n[1] + (m[2] - p[2]) * n[2];
            *out = [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]];
        });
        std::mem::swap(&mut cur, &mut next);
    }
    cur
}

/// Edge neighbours of every vertex over the kept faces, as compressed rows (start, list); an
/// edge shared by two faces appears twice, which weights interior edges alike.
fn neighbours(mesh: &Mesh, keep: &[bool]) -> (Vec<usize>, Vec<u32>) {
    let nv = mesh.positions.len();
    let mut degree = vec![0u32; nv + 1];
    for (t, _) in mesh.triangles.iter().zip(keep).filter(|(_, &k)| k) {
        for &v in t {
            degree[v as usize] += 2;
        }
    }
    // Neighbour lists (compressed rows; an edge shared by two faces appears twice, which weights
    // interior edges alike).
    let mut start = vec![0usize; nv + 1];
    for v in 0..nv {
        start[v + 1] = start[v] + degree[v] as usize;
    }
    let mut fill = start.clone();
    let mut nb = vec![0u32; start[nv]];
    for (t, _) in mesh.triangles.iter().zip(keep).filter(|(_, &k)| k) {
        for j in 0..3 {
            let (a, b, c) = (t[j], t[(j + 1) % 3], t[(j + 2) % 3]);
            nb[fill[a as usize]] = b;
            nb[fill[a as usize] + 1] = c;
            fill[a as usize] += 2;
        }
    }
    (start, nb)
}
