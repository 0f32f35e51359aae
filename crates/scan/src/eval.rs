//! Scan results against known truth: a calibration against the true one, a sphere fitted to a
//! point cloud, and the distances of points to a true triangle mesh. Used by the synthetic
//! round trip (`scan::synth`) and usable on any data with a reference.

use crate::calib::{DeviceCalibration, ProcamCalibration};
use anyhow::{bail, Result};
use nalgebra::{Matrix3, Matrix4, Vector3, Vector4};
use serde::Serialize;

/// Errors of one device's intrinsics.
#[derive(Clone, Debug, Serialize)]
pub struct DeviceError {
    /// (fx − fx_true)/fx_true (dimensionless).
    pub fx_rel: f64,
    /// (fy − fy_true)/fy_true.
    pub fy_rel: f64,
    /// cx − cx_true (pixels).
    pub cx_px: f64,
    /// cy − cy_true (pixels).
    pub cy_px: f64,
}

/// Errors of a projector–camera calibration against the truth.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationError {
    /// The camera's intrinsics.
    pub camera: DeviceError,
    /// The projector's intrinsics.
    pub projector: DeviceError,
    /// Angle of R·R_trueᵀ (degrees).
    pub rotation_deg: f64,
    /// (|T| − |T_true|)/|T_true| (both in the same length unit).
    pub translation_rel: f64,
    /// Angle between T and T_true (degrees).
    pub translation_angle_deg: f64,
    /// The calibration's own stereo RMS reprojection error (pixels).
    pub rms_px: f64,
}

/// Tolerances a calibration must meet.
#[derive(Clone, Copy, Debug)]
pub struct CalibrationTargets {
    /// |fx, fy relative error| at most this.
    pub focal_rel: f64,
    /// |cx, cy error| at most this (pixels).
    pub principal_px: f64,
    /// Rotation error at most this (degrees).
    pub rotation_deg: f64,
    /// |relative error of |T|| at most this.
    pub translation_rel: f64,
    /// RMS reprojection error at most this (pixels).
    pub rms_px: f64,
}

impl Default for CalibrationTargets {
    /// fx, fy within 0.3 %, cx, cy within 2 px, rotation within 0.1°, |T| within 0.3 %, RMS ≤ 0.2 px.
    fn default() -> Self {
        CalibrationTargets { focal_rel: 0.003, principal_px: 2.0, rotation_deg: 0.1, translation_rel: 0.003, rms_px: 0.2 }
    }
}

fn device_error(est: &DeviceCalibration, truth: &DeviceCalibration) -> DeviceError {
    DeviceError {
        fx_rel: (est.fx - truth.fx) / truth.fx,
        fy_rel: (est.fy - truth.fy) / truth.fy,
        cx_px: est.cx - truth.cx,
        cy_px: est.cy - truth.cy,
    }
}

/// Rotation angle of a rotation matrix (radians), from sin and cos for accuracy near 0.
pub fn rotation_angle(r: &Matrix3<f64>) -> f64 {
    let s = 0.5 * Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]).norm();
    let c = 0.5 * (r.trace() - 1.0);
    s.atan2(c)
}

fn mat(r: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| r[i][j])
}

/// Compare `est` with `truth` (translations in the same length unit).
pub fn compare_calibration(est: &ProcamCalibration, truth: &ProcamCalibration) -> CalibrationError {
    let rel = mat(&est.rotation) * mat(&truth.rotation).transpose();
    let (t, t0) = (Vector3::from(est.translation), Vector3::from(truth.translation));
    CalibrationError {
        camera: device_error(&est.camera, &truth.camera),
        projector: device_error(&est.projector, &truth.projector),
        rotation_deg: rotation_angle(&rel).to_degrees(),
        translation_rel: (t.norm() - t0.norm()) / t0.norm(),
        translation_angle_deg: t.angle(&t0).to_degrees(),
        rms_px: est.rms_px,
    }
}

impl CalibrationError {
    /// One line per missed target (empty when all are met).
    pub fn failures(&self, k: &CalibrationTargets) -> Vec<String> {
        let mut out = Vec::new();
        for (dev, e) in [("camera", &self.camera), ("projector", &self.projector)] {
            for (what, v) in [("fx", e.fx_rel), ("fy", e.fy_rel)] {
                if !(v.abs() <= k.focal_rel) {
                    out.push(format!("{dev} {what} off by {:.3} % (target {:.3} %)", 100.0 * v, 100.0 * k.focal_rel));
                }
            }
            for (what, v) in [("cx", e.cx_px), ("cy", e.cy_px)] {
                if !(v.abs() <= k.principal_px) {
                    out.push(format!("{dev} {what} off by {v:.3} px (target {} px)", k.principal_px));
                }
            }
        }
        if !(self.rotation_deg <= k.rotation_deg) {
            out.push(format!("rotation off by {:.4}° (target {}°)", self.rotation_deg, k.rotation_deg));
        }
        if !(self.translation_rel.abs() <= k.translation_rel) {
            out.push(format!("|T| off by {:.3} % (target {:.3} %)", 100.0 * self.translation_rel, 100.0 * k.translation_rel));
        }
        if !(self.rms_px <= k.rms_px) {
            out.push(format!("RMS {:.3} px (target {} px)", self.rms_px, k.rms_px));
        }
        out
    }
}

/// A sphere fitted to points.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SphereFit {
    /// Centre (the points' length unit).
    pub centre: [f64; 3],
    /// Radius.
    pub radius: f64,
    /// RMS of the points' distances to the sphere (|p − c| − r).
    pub rms: f64,
    /// Number of points.
    pub points: usize,
}

/// Algebraic sphere fit: least squares of |p|² − 2c·p − d over (c, d), with r² = d + |c|²
/// (about the centroid, for conditioning). Needs four points not on one plane.
pub fn fit_sphere_algebraic(points: &[[f64; 3]]) -> Result<([f64; 3], f64)> {
    if points.len() < 4 {
        bail!("a sphere fit needs at least 4 points, got {}", points.len());
    }
    let m = points.iter().fold(Vector3::zeros(), |a, p| a + Vector3::from(*p)) / points.len() as f64;
    let (mut ata, mut atb) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
    for p in points {
        let q = Vector3::from(*p) - m;
        let row = Vector4::new(2.0 * q.x, 2.0 * q.y, 2.0 * q.z, 1.0);
        ata += row * row.transpose();
        atb += row * q.norm_squared();
    }
    let Some(x) = ata.lu().solve(&atb) else { bail!("the points do not determine a sphere (coplanar or repeated)") };
    let c = Vector3::new(x[0], x[1], x[2]);
    let r2 = x[3] + c.norm_squared();
    if !(r2 > 0.0) || !r2.is_finite() {
        bail!("the points do not determine a sphere");
    }
    let c = c + m;
    Ok(([c.x, c.y, c.z], r2.sqrt()))
}

/// Sphere fit: the algebraic fit, then Levenberg–Marquardt on the geometric residuals
/// |p − c| − r until the step is below 1e-12 of the radius.
pub fn fit_sphere(points: &[[f64; 3]]) -> Result<SphereFit> {
    let (c0, r0) = fit_sphere_algebraic(points)?;
    let mut x = Vector4::new(c0[0], c0[1], c0[2], r0);
    let cost = |x: &Vector4<f64>| -> f64 {
        let c = Vector3::new(x[0], x[1], x[2]);
        points.iter().map(|p| ((Vector3::from(*p) - c).norm() - x[3]).powi(2)).sum()
    };
    let mut e = cost(&x);
    let mut lambda = 1e-3;
    for _ in 0..100 {
        let c = Vector3::new(x[0], x[1], x[2]);
        let (mut jtj, mut jtr) = (Matrix4::<f64>::zeros(), Vector4::<f64>::zeros());
        for p in points {
            let d = Vector3::from(*p) - c;
            let n = d.norm();
            if n == 0.0 {
                continue;
            }
            let j = Vector4::new(-d.x / n, -d.y / n, -d.z / n, -1.0);
            jtj += j * j.transpose();
            jtr += j * (n - x[3]);
        }
        let done = loop {
            let mut a = jtj;
            for k in 0..4 {
                a[(k, k)] *= 1.0 + lambda;
            }
            let Some(step) = a.lu().solve(&(-jtr)) else { bail!("sphere fit: singular normal equations") };
            let xn = x + step;
            let en = cost(&xn);
            if en <= e {
                x = xn;
                e = en;
                lambda = (lambda * 0.1).max(1e-12);
                break step.norm() <= 1e-12 * x[3].abs();
            }
            lambda *= 10.0;
            if lambda > 1e12 {
                break true;
            }
        };
        if done {
            break;
        }
    }
    Ok(SphereFit { centre: [x[0], x[1], x[2]], radius: x[3], rms: (e / points.len() as f64).sqrt(), points: points.len() })
}

/// Closest point of triangle (a, b, c) to p ([`render::math::geometry::closest_point_on_triangle`]).
pub fn closest_point_on_triangle(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>) -> Vector3<f64> {
    let g = |v: Vector3<f64>| glam::DVec3::new(v.x, v.y, v.z);
    let q = render::math::geometry::closest_point_on_triangle(g(p), g(a), g(b), g(c));
    Vector3::new(q.x, q.y, q.z)
}

/// Distances from points to a triangle mesh: a uniform grid of triangle lists searched in
/// growing shells of cells around the query's cell (exact nearest triangle).
pub struct MeshDistance {
    tris: Vec<[Vector3<f64>; 3]>,
    lo: Vector3<f64>,
    cell: f64,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
    diagonal: f64,
}

impl MeshDistance {
    /// Index `triangles` (vertex positions in any length unit).
    pub fn new(triangles: Vec<[[f64; 3]; 3]>) -> Result<MeshDistance> {
        if triangles.is_empty() {
            bail!("the mesh has no triangles");
        }
        let tris: Vec<[Vector3<f64>; 3]> = triangles.iter().map(|t| t.map(Vector3::from)).collect();
        let (mut lo, mut hi) = (Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY));
        for t in &tris {
            for v in t {
                lo = lo.inf(v);
                hi = hi.sup(v);
            }
        }
        let diagonal = (hi - lo).norm();
        // Pad by 10 % of the diagonal so points near the surface fall inside the grid.
        let pad = Vector3::repeat(0.1 * diagonal.max(1e-300));
        let (lo, hi) = (lo - pad, hi + pad);
        let ext = hi - lo;
        let cell = (ext.x * ext.y * ext.z / tris.len() as f64).cbrt().max(ext.max() / 256.0);
        let dims = [0, 1, 2].map(|k| ((ext[k] / cell).ceil() as usize).clamp(1, 256));
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        for (i, t) in tris.iter().enumerate() {
            let (tlo, thi) = (t[0].inf(&t[1]).inf(&t[2]), t[0].sup(&t[1]).sup(&t[2]));
            let a = [0, 1, 2].map(|k| (((tlo[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1));
            let b = [0, 1, 2].map(|k| (((thi[k] - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1));
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        cells[(z * dims[1] + y) * dims[0] + x].push(i as u32);
                    }
                }
            }
        }
        Ok(MeshDistance { tris, lo, cell, dims, cells, diagonal })
    }

    /// The mesh in `path` (OBJ or PLY), placed by the affine `matrix` (rows acting on column vectors).
    pub fn from_file(path: &std::path::Path, matrix: &[[f64; 4]; 4]) -> Result<MeshDistance> {
        let meshes = render::shape::mesh::TriangleMesh::load(path)?;
        let tf = |q: [f64; 3]| [0, 1, 2].map(|r| matrix[r][0] * q[0] + matrix[r][1] * q[1] + matrix[r][2] * q[2] + matrix[r][3]);
        let mut tris = Vec::new();
        for (_, m) in &meshes {
            for t in &m.indices {
                tris.push(t.map(|i| {
                    let v = m.positions[i as usize];
                    tf([v.x as f64, v.y as f64, v.z as f64])
                }));
            }
        }
        MeshDistance::new(tris)
    }

    /// Diagonal of the mesh's bounding box.
    pub fn bbox_diagonal(&self) -> f64 {
        self.diagonal
    }

    /// Distance from `p` to the nearest triangle.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        let p = Vector3::from(p);
        let rel = (p - self.lo) / self.cell;
        let inside = (0..3).all(|k| rel[k] >= 0.0 && rel[k] < self.dims[k] as f64);
        if !inside {
            return self.tris.iter().map(|t| (closest_point_on_triangle(p, t[0], t[1], t[2]) - p).norm()).fold(f64::INFINITY, f64::min);
        }
        let c = [0, 1, 2].map(|k| (rel[k] as usize).min(self.dims[k] - 1));
        let mut best = f64::INFINITY;
        let kmax = *self.dims.iter().max().unwrap_or(&1);
        for k in 0..=kmax {
            let (k_i, c_i) = (k as isize, c.map(|x| x as isize));
            for z in (c_i[2] - k_i)..=(c_i[2] + k_i) {
                for y in (c_i[1] - k_i)..=(c_i[1] + k_i) {
                    for x in (c_i[0] - k_i)..=(c_i[0] + k_i) {
                        let on_shell = (x - c_i[0]).abs() == k_i || (y - c_i[1]).abs() == k_i || (z - c_i[2]).abs() == k_i;
                        if !on_shell || x < 0 || y < 0 || z < 0 {
                            continue;
                        }
                        let (x, y, z) = (x as usize, y as usize, z as usize);
                        if x >= self.dims[0] || y >= self.dims[1] || z >= self.dims[2] {
                            continue;
                        }
                        for &i in &self.cells[(z * self.dims[1] + y) * self.dims[0] + x] {
                            let t = &self.tris[i as usize];
                            best = best.min((closest_point_on_triangle(p, t[0], t[1], t[2]) - p).norm());
                        }
                    }
                }
            }
            // Every cell not yet visited is at least k cells away from the query's cell.
            if best <= k as f64 * self.cell {
                break;
            }
        }
        best
    }
}

/// Distances of points to a mesh, summarised.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MeshDistances {
    /// Median distance (the points' length unit).
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// RMS distance.
    pub rms: f64,
    /// The mesh's bounding-box diagonal.
    pub bbox_diagonal: f64,
    /// Number of points.
    pub points: usize,
}

/// Distances of `points` to `mesh`, in parallel.
pub fn mesh_distances(mesh: &MeshDistance, points: &[[f64; 3]]) -> Result<MeshDistances> {
    use rayon::prelude::*;
    if points.is_empty() {
        bail!("no points to compare with the mesh");
    }
    let mut d: Vec<f64> = points.par_iter().map(|p| mesh.distance(*p)).collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    d.sort_by(f64::total_cmp);
    let q = |f: f64| d[((d.len() - 1) as f64 * f).round() as usize];
    Ok(MeshDistances { median: q(0.5), p90: q(0.9), rms, bbox_diagonal: mesh.bbox_diagonal(), points: d.len() })
}
