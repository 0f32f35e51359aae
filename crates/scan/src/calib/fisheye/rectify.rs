//! Undistortion and stereo rectification of fisheye cameras in OpenCV's conventions, so that
//! their results stand in for OpenCV's: `fisheye::estimateNewCameraMatrixForUndistortRectify`,
//! `fisheye::stereoRectify` and `fisheye::initUndistortRectifyMap`.
//!
//! - **New camera matrix.** The rays of the four edge midpoints (w/2, 0), (w, h/2), (w/2, h),
//!   (0, h/2) (integer halves) are undistorted and turned by R; their mean is the new principal
//!   direction, and the focal length that fits them into the image runs from the largest
//!   (`balance` 0: no midpoint outside the image) to the smallest (1: every one inside), divided
//!   by `fov_scale`; K's aspect ratio is kept and `new_size` rescales the result.
//! - **Stereo rectification.** The rotations are the pinhole pair's (`super::super::rectify`:
//!   each camera turned by half the relative rotation, then both by the rotation that puts the
//!   baseline on the x axis; OpenCV's fisheye version always takes the x axis). Each rectified
//!   camera gets the new camera matrix of its turned view; the pair shares the smaller of the two
//!   vertical focal lengths (for both axes) and the mean principal point (both coordinates with
//!   `zero_disparity`, the vertical one otherwise).
//!
//! Where lucent differs from OpenCV, by choice and as in the rest of the fisheye model
//! (`render::camera::fisheye`): the skew is read from K, and a midpoint whose ray lies beyond
//! the range where θ_d increases is an error instead of a point at (−10⁶, −10⁶).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

use anyhow::{bail, Result};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, Vector3};
use render::camera::Intrinsics;

use super::FisheyeLens;
use crate::calib::rectify::rectifying_rotations;

/// The undistorted ray of pixel (u, v), turned by `r`, as (x/z, y/z); None where the lens has no
/// ray for the pixel or the turned ray lies at or behind the plane z = 0.
pub fn undistort_turned(
    lens: &FisheyeLens,
    theta_max: f64,
    r: &Matrix3<f64>,
    u: f64,
    v: f64,
) -> Option<(f64, f64)> {
    let (xd, yd) = lens.normalise(u, v);
    let (x, y) = lens.undistort(xd, yd, theta_max)?;
    let q = r * Vector3::new(x, y, 1.0);
    (q.z > 0.0).then(|| (q.x / q.z, q.y / q.z))
}

/// OpenCV's `fisheye::estimateNewCameraMatrixForUndistortRectify` (module documentation): the
/// pinhole camera through which the fisheye camera `lens` (`size` pixels), turned by `r`, is
/// shown undistorted. `balance` is clamped to [0, 1]; `new_size` (0 × 0: `size`) rescales it;
/// `fov_scale` > 0 divides the focal length.
pub fn new_camera_matrix(
    lens: &FisheyeLens,
    size: (u32, u32),
    r: &Matrix3<f64>,
    balance: f64,
    new_size: (u32, u32),
    fov_scale: f64,
) -> Result<Intrinsics> {
    let (w, h) = size;
    if w == 0 || h == 0 {
        bail!("image size must be at least 1×1, got {w}×{h}");
    }
    if !balance.is_finite() || !fov_scale.is_finite() {
        bail!("balance and fov_scale must be finite, got {balance} and {fov_scale}");
    }
    let balance = balance.clamp(0.0, 1.0);
    let tm = lens.theta_max();
    let (wf, hf) = (f64::from(w), f64::from(h));
    let mid = [
        (f64::from(w / 2), 0.0),
        (wf, f64::from(h / 2)),
        (f64::from(w / 2), hf),
        (0.0, f64::from(h / 2)),
    ];
    let aspect = lens.fx / lens.fy;
    let mut p = [[0.0; 2]; 4];
    for (o, &(u, v)) in p.iter_mut().zip(&mid) {
        let Some((x, y)) = undistort_turned(lens, tm, r, u, v) else {
            bail!("the image's edge midpoint ({u}, {v}) has no ray in front of the turned camera (beyond the range where θ_d increases, or turned behind it)");
        };
        *o = [x, y * aspect];
    }
    let cn = [
        p.iter().map(|q| q[0]).sum::<f64>() / 4.0,
        p.iter().map(|q| q[1]).sum::<f64>() / 4.0,
    ];
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for q in &p {
        (x0, x1, y0, y1) = (x0.min(q[0]), x1.max(q[0]), y0.min(q[1]), y1.max(q[1]));
    }
    let fs = [
        wf * 0.5 / (cn[0] - x0),
        wf * 0.5 / (x1 - cn[0]),
        hf * 0.5 * aspect / (cn[1] - y0),
        hf * 0.5 * aspect / (y1 - cn[1]),
    ];
    let (fmin, fmax) = (
        fs.iter().copied().fold(f64::MAX, f64::min),
        fs.iter().copied().fold(f64::MIN, f64::max),
    );
    let mut f = balance * fmin + (1.0 - balance) * fmax;
    if fov_scale > 0.0 {
        f /= fov_scale;
    }
    let (cx, cy) = (-cn[0] * f + wf * 0.5, -cn[1] * f + hf * aspect * 0.5);
    let mut k = Intrinsics {
        fx: f,
        fy: f / aspect,
        cx,
        cy: cy / aspect,
    };
    if new_size.0 > 0 && new_size.1 > 0 {
        let (rx, ry) = (f64::from(new_size.0) / wf, f64::from(new_size.1) / hf);
        k = Intrinsics {
            fx: k.fx * rx,
            fy: k.fy * ry,
            cx: k.cx * rx,
            cy: k.cy * ry,
        };
    }
    if !(k.fx > 0.0 && k.fy > 0.0) || !k.cx.is_finite() || !k.cy.is_finite() {
        bail!("no new camera matrix: the undistorted edge midpoints span no extent (fx = {}, fy = {})", k.fx, k.fy);
    }
    Ok(k)
}

/// The result of [`stereo_rectify_fisheye`], as OpenCV's `fisheye::stereoRectify` returns it.
#[derive(Clone, Debug)]
pub struct FisheyeRectification {
    /// Rotation of each camera into its rectified frame.
    pub r: [Matrix3<f64>; 2],
    /// Projection matrices of the rectified cameras (in the first rectified camera's frame; the
    /// second's last column holds the baseline times the focal length).
    pub p: [Matrix3x4<f64>; 2],
    /// Disparity-to-depth matrix: Q·(u, v, disparity, 1) is the point in homogeneous coordinates
    /// of the first rectified camera.
    pub q: Matrix4<f64>,
}

/// OpenCV's `fisheye::stereoRectify` (module documentation) for two fisheye cameras of `size`
/// pixels with X₂ = R·X₁ + T: `zero_disparity` (`CALIB_ZERO_DISPARITY`) shares both coordinates
/// of the principal point, otherwise only the vertical one; `new_size` (0 × 0: `size`),
/// `balance` and `fov_scale` as in [`new_camera_matrix`].
#[allow(clippy::too_many_arguments)]
pub fn stereo_rectify_fisheye(
    lens: [&FisheyeLens; 2],
    size: (u32, u32),
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    zero_disparity: bool,
    new_size: (u32, u32),
    balance: f64,
    fov_scale: f64,
) -> Result<FisheyeRectification> {
    let (r1, r2, _) = rectifying_rotations(r, t, false)?;
    let t2 = r2 * t;
    let k1 = new_camera_matrix(lens[0], size, &r1, balance, new_size, fov_scale)
        .map_err(|e| anyhow::anyhow!("first camera: {e}"))?;
    let k2 = new_camera_matrix(lens[1], size, &r2, balance, new_size, fov_scale)
        .map_err(|e| anyhow::anyhow!("second camera: {e}"))?;
    let fc = k1.fy.min(k2.fy);
    let mut cc = [[k1.cx, k1.cy], [k2.cx, k2.cy]];
    let shared: &[usize] = if zero_disparity { &[0, 1] } else { &[1] };
    for &a in shared {
        let m = 0.5 * (cc[0][a] + cc[1][a]);
        (cc[0][a], cc[1][a]) = (m, m);
    }
    if !(t2.x.abs() > 0.0) {
        bail!("the baseline has no component along the rectified rows");
    }
    let mut p = [Matrix3x4::zeros(), Matrix3x4::zeros()];
    for (m, c) in p.iter_mut().zip(&cc) {
        (m[(0, 0)], m[(1, 1)], m[(0, 2)], m[(1, 2)], m[(2, 2)]) = (fc, fc, c[0], c[1], 1.0);
    }
    p[1][(0, 3)] = t2.x * fc;
    #[rustfmt::skip]
    let q = Matrix4::new(
        1.0, 0.0, 0.0, -cc[0][0],
        0.0, 1.0, 0.0, -cc[0][1],
        0.0, 0.0, 0.0, fc,
        0.0, 0.0, -1.0 / t2.x, (cc[0][0] - cc[1][0]) / t2.x,
    );
    Ok(FisheyeRectification { r: [r1, r2], p, q })
}

/// For each pixel of a `width` × `height` output (row-major), the fisheye pixel its ray comes
/// from (OpenCV's `fisheye::initUndistortRectifyMap`): the output is the pinhole camera `p` (the
/// left 3 × 3 of a projection matrix) turned by `r` from the fisheye camera `lens`; NaN where the
/// output pixel's ray lies at or behind the fisheye camera's plane.
pub fn undistort_rectify_map_fisheye(
    lens: &FisheyeLens,
    r: &Matrix3<f64>,
    p: &Matrix3<f64>,
    width: usize,
    height: usize,
) -> Result<Vec<[f64; 2]>> {
    let Some(inv) = (p * r).try_inverse() else {
        bail!("the new camera matrix times R is singular")
    };
    let mut map = Vec::with_capacity(width * height);
    for v in 0..height {
        for u in 0..width {
            let q = inv * Vector3::new(u as f64, v as f64, 1.0);
            map.push(if q.z > 0.0 {
                lens.project([q.x, q.y, q.z])
            } else {
                [f64::NAN; 2]
            });
        }
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn lenses() -> [FisheyeLens; 2] {
        [
            FisheyeLens {
                fx: 312.0,
                fy: 309.0,
                cx: 321.5,
                cy: 238.0,
                skew: 0.0,
                k: [-0.031, 0.012, -0.004, 0.0006],
            },
            FisheyeLens {
                fx: 305.0,
                fy: 306.5,
                cx: 317.0,
                cy: 243.5,
                skew: 0.0,
                k: [-0.027, 0.009, -0.003, 0.0004],
            },
        ]
    }

    /// After rectification a point seen by both cameras lies on the same row of the two
    /// rectified images, P₂ applied in the first rectified frame gives the second camera's pixel,
    /// and Q maps (u, v, disparity) back to the point.
    #[test]
    fn rectified_rows_agree_and_q_reprojects() {
        let l = lenses();
        let rot = *Rotation3::new(Vector3::new(0.03, -0.08, 0.02)).matrix();
        for (t, zero) in [
            (Vector3::new(-0.12, 0.004, 0.006), true),
            (Vector3::new(0.1, -0.01, 0.003), false),
        ] {
            let rect = stereo_rectify_fisheye(
                [&l[0], &l[1]],
                (640, 480),
                &rot,
                &t,
                zero,
                (0, 0),
                0.3,
                1.0,
            )
            .unwrap();
            for x in [
                Vector3::new(0.3, -0.2, 0.9),
                Vector3::new(-0.8, 0.6, 1.4),
                Vector3::new(0.05, 0.05, 0.6),
            ] {
                let x1 = rect.r[0] * x;
                let x2 = rect.r[1] * (rot * x + t);
                let a = rect.p[0] * x1.push(1.0);
                let b = rect.p[1].fixed_view::<3, 3>(0, 0) * x2;
                let b1 = rect.p[1] * x1.push(1.0);
                let (a, b, b1) = (
                    [a.x / a.z, a.y / a.z],
                    [b.x / b.z, b.y / b.z],
                    [b1.x / b1.z, b1.y / b1.z],
                );
                assert!((a[1] - b[1]).abs() < 1e-9, "{a:?} {b:?}");
                assert!(
                    (b1[0] - b[0]).abs() < 1e-9 && (b1[1] - b[1]).abs() < 1e-9,
                    "{b1:?} {b:?}"
                );
                let h = rect.q * nalgebra::Vector4::new(a[0], a[1], a[0] - b[0], 1.0);
                assert!((h.xyz() / h.w - x1).norm() < 1e-9 * x1.norm());
            }
            for r in rect.r {
                assert!(
                    (r * r.transpose() - Matrix3::identity()).norm() < 1e-12
                        && (r.determinant() - 1.0).abs() < 1e-12
                );
            }
            let (p1, p2) = (&rect.p[0], &rect.p[1]);
            assert_eq!(p1[(1, 2)], p2[(1, 2)]);
            assert_eq!(p1[(0, 2)] == p2[(0, 2)], zero);
        }
    }

    /// The new camera matrix puts the undistorted edge midpoints where its definition says: with
    /// balance 0 the two midpoints of one axis nearest the centre land exactly on the image edge
    /// (the larger of the fitting focal lengths), with balance 1 all four lie inside and one on
    /// the edge; the map sends each output pixel to the fisheye pixel of its ray. (fx = fy here:
    /// with another aspect ratio OpenCV's rule, which lucent keeps, scales the vertical offsets
    /// from the mean by fy and the mean by fx.)
    #[test]
    fn new_camera_matrix_fits_the_edge_midpoints_and_the_map_inverts_it() {
        let l = &FisheyeLens {
            fy: 312.0,
            ..lenses()[0]
        };
        let (w, h) = (640u32, 480u32);
        let r = *Rotation3::new(Vector3::new(0.02, 0.05, -0.01)).matrix();
        let tm = l.theta_max();
        let mid = [(320.0, 0.0), (640.0, 240.0), (320.0, 480.0), (0.0, 240.0)];
        for balance in [0.0, 1.0] {
            let k = new_camera_matrix(l, (w, h), &r, balance, (0, 0), 1.0).unwrap();
            let px: Vec<[f64; 2]> = mid
                .iter()
                .map(|&(u, v)| {
                    let (x, y) = undistort_turned(l, tm, &r, u, v).unwrap();
                    [k.fx * x + k.cx, k.fy * y + k.cy]
                })
                .collect();
            // How far each midpoint lies inside its own edge (pixels; negative outside).
            let inside = [
                px[0][1],
                f64::from(w) - px[1][0],
                f64::from(h) - px[2][1],
                px[3][0],
            ];
            let least = inside.iter().copied().fold(f64::MAX, f64::min);
            let most = inside.iter().copied().fold(f64::MIN, f64::max);
            if balance == 0.0 {
                assert!(most.abs() < 1e-9 && least <= 1e-9, "{inside:?}");
            } else {
                assert!(least.abs() < 1e-9, "{inside:?}");
            }
            let map = undistort_rectify_map_fisheye(
                l,
                &r,
                &Matrix3::new(k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0),
                64,
                48,
            )
            .unwrap();
            for (i, m) in map.iter().enumerate().step_by(37) {
                let (u, v) = ((i % 64) as f64, (i / 64) as f64);
                let (x, y) = undistort_turned(l, tm, &r, m[0], m[1]).unwrap();
                assert!((k.fx * x + k.cx - u).abs() < 1e-7 && (k.fy * y + k.cy - v).abs() < 1e-7);
            }
        }
    }
}
