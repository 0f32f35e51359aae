//! Subdivision of a mesh into micropolygons: triangles whose projected edges are at most about a
//! pixel long (Cook, Carpenter & Catmull, "The Reyes image rendering architecture", SIGGRAPH
//! 1987, dice to micropolygons of about a pixel).
//!
//! Each triangle whose three corners project into the camera is diced uniformly: with L its
//! longest projected edge (pixels) and n = ⌈L / max_edge_px⌉, the barycentric grid
//! A + (B − A)·i/n + (C − A)·j/n, i + j ≤ n, gives n² triangles similar to the original, whose
//! projected edges are L/n for an affine projection; perspective and distortion stretch some of
//! them, so the diced edges are projected and n is raised until the longest is within
//! `max_edge_px` (at most four rounds; the edges of the grid's upright triangles are all the
//! edges there are). Corners keep
//! their vertex; the points on an edge are shared with the neighbouring triangle when it dices
//! that edge into the same number of pieces (the usual case on a mesh of even density), and where
//! the counts differ the two sides meet in a T-junction (the surface stays closed up to the
//! flatness of the edge; labels need no watertight mesh). Triangles with a corner that does not
//! project (behind the camera, or beyond the fold of the distortion polynomial) are kept whole:
//! they are not seen.

use std::collections::HashMap;

use anyhow::{bail, Result};
use rayon::prelude::*;

use crate::triangulate::Lens;

/// A triangle mesh in the camera frame (the calibration's length unit).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, camera coordinates (x right, y down, z forward; calibration units).
    pub positions: Vec<[f64; 3]>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// A subdivided mesh and, per micropolygon, the triangle of the input it came from.
#[derive(Clone, Debug, Default)]
pub struct Subdivided {
    /// The micropolygons.
    pub mesh: Mesh,
    /// Index of the input triangle of each micropolygon.
    pub source: Vec<u32>,
}

/// The most micropolygons [`subdivide`] makes before it refuses (memory guard).
pub const MAX_MICROPOLYGONS: u64 = 60_000_000;

/// The longest projected edge of the n-grid of triangle `c` (None where a grid point does not
/// project).
fn longest_diced_edge(c: [[f64; 3]; 3], n: u32, lens: &Lens) -> Option<f64> {
    let at = |i: u32, j: u32| -> Option<[f64; 2]> {
        let (s, r) = (i as f64 / n as f64, j as f64 / n as f64);
        lens.project_unfolded([0, 1, 2].map(|k| c[0][k] + (c[1][k] - c[0][k]) * s + (c[2][k] - c[0][k]) * r))
    };
    let d = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).hypot(u[1] - v[1]);
    let mut prev: Vec<[f64; 2]> = (0..=n).map(|i| at(i, 0)).collect::<Option<_>>()?;
    let mut longest = 0f64;
    for j in 1..=n {
        let row: Vec<[f64; 2]> = (0..=n - j).map(|i| at(i, j)).collect::<Option<_>>()?;
        for i in 0..=(n - j) as usize {
            // Edges of the upright triangle (i, j−1), (i+1, j−1), (i, j).
            longest = longest.max(d(prev[i], prev[i + 1])).max(d(prev[i + 1], row[i])).max(d(row[i], prev[i]));
        }
        prev = row;
    }
    Some(longest)
}

/// Dices every triangle of `mesh` until its projected edges are at most `max_edge_px` pixels
/// (module documentation).
pub(crate) fn subdivide(mesh: &Mesh, lens: &Lens, max_edge_px: f64) -> Result<Subdivided> {
    if !(max_edge_px > 0.0 && max_edge_px.is_finite()) {
        bail!("the largest micropolygon edge must be a positive number of pixels, got {max_edge_px}");
    }
    let projected: Vec<Option<[f64; 2]>> = mesh.positions.par_iter().map(|&p| lens.project_unfolded(p)).collect();
    let counts: Vec<u32> = mesh
        .triangles
        .par_iter()
        .map(|t| {
            let q = [projected[t[0] as usize], projected[t[1] as usize], projected[t[2] as usize]];
            match q {
                [Some(a), Some(b), Some(c)] => {
                    let d = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).hypot(u[1] - v[1]);
                    let l = d(a, b).max(d(b, c)).max(d(c, a));
                    let mut n = (l / max_edge_px).ceil().clamp(1.0, 1e4) as u32;
                    // Perspective and distortion make some pieces longer than L/n: check the
                    // diced edges and dice finer until they all fit (a few rounds at most).
                    let corners = t.map(|v| mesh.positions[v as usize]);
                    for _ in 0..4 {
                        if n == 1 {
                            break;
                        }
                        match longest_diced_edge(corners, n, lens) {
                            Some(e) if e > max_edge_px => n = ((n as f64 * e / max_edge_px).ceil() as u32).max(n + 1).min(10_000),
                            _ => break,
                        }
                    }
                    n
                }
                _ => 1,
            }
        })
        .collect();
    let total: u64 = counts.iter().map(|&n| n as u64 * n as u64).sum();
    if total > MAX_MICROPOLYGONS {
        bail!("subdividing to {max_edge_px} px would make {total} micropolygons (at most {MAX_MICROPOLYGONS}); the mesh is too close to the camera or too coarse");
    }
    let mut out = Subdivided { mesh: Mesh { positions: mesh.positions.clone(), triangles: Vec::with_capacity(total as usize) }, source: Vec::with_capacity(total as usize) };
    // Points on edges, keyed by (lower vertex, higher vertex, pieces, step from the lower one).
    let mut edge_points: HashMap<(u32, u32, u32, u32), u32> = HashMap::new();
    let mut grid: Vec<u32> = Vec::new();
    for (f, (t, &n)) in mesh.triangles.iter().zip(&counts).enumerate() {
        if n == 1 {
            out.mesh.triangles.push(*t);
            out.source.push(f as u32);
            continue;
        }
        let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
        // grid[(i, j)] for i + j ≤ n, row j holding n − j + 1 points.
        let row = |j: u32| -> usize { (j * (n + 1) - j * (j.saturating_sub(1)) / 2) as usize };
        let at = |i: u32, j: u32| -> usize { row(j) + i as usize };
        grid.clear();
        grid.resize(row(n) + 1, u32::MAX);
        let positions = &mut out.mesh.positions;
        let mut point = |i: u32, j: u32| -> u32 {
            let (s, r) = (i as f64 / n as f64, j as f64 / n as f64);
            let p = [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * s + (c[k] - a[k]) * r);
            positions.push(p);
            (positions.len() - 1) as u32
        };
        for j in 0..=n {
            for i in 0..=n - j {
                // Which edge (if any) the point lies on, as (from, to, step).
                let k = n - i - j;
                let id = if (i, j) == (0, 0) {
                    t[0]
                } else if (i, j) == (n, 0) {
                    t[1]
                } else if (i, j) == (0, n) {
                    t[2]
                } else {
                    let edge = if j == 0 {
                        Some((t[0], t[1], i))
                    } else if i == 0 {
                        Some((t[0], t[2], j))
                    } else if k == 0 {
                        Some((t[1], t[2], j))
                    } else {
                        None
                    };
                    match edge {
                        Some((u, v, s)) => {
                            let key = if u < v { (u, v, n, s) } else { (v, u, n, n - s) };
                            *edge_points.entry(key).or_insert_with(|| point(i, j))
                        }
                        None => point(i, j),
                    }
                };
                grid[at(i, j)] = id;
            }
        }
        for j in 0..n {
            for i in 0..n - j {
                // Upright (i, j), (i+1, j), (i, j+1) keeps the winding of (A, B, C).
                out.mesh.triangles.push([grid[at(i, j)], grid[at(i + 1, j)], grid[at(i, j + 1)]]);
                out.source.push(f as u32);
                if i + j + 1 < n {
                    out.mesh.triangles.push([grid[at(i + 1, j)], grid[at(i + 1, j + 1)], grid[at(i, j + 1)]]);
                    out.source.push(f as u32);
                }
            }
        }
    }
    Ok(out)
}
