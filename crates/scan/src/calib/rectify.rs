//! Stereo rectification and new camera matrices in OpenCV's conventions, so that their results
//! stand in for OpenCV's: `stereoRectify` (Bouguet's algorithm as OpenCV implements it: each
//! camera turned by half the relative rotation, then both by the rotation that puts the baseline
//! on the x axis, or the y axis for a vertical pair; Bradski & Kaehler, *Learning OpenCV*, 2008,
//! ch. 12), `getOptimalNewCameraMatrix` and `initUndistortRectifyMap`.
//!
//! The choices OpenCV makes, and lucent with it: the new focal length of a rectified pair is the
//! mean of the two cameras' (fy for a horizontal pair); each principal point centres the
//! undistorted, rotated image corners; the free scaling α ∈ [0, 1] interpolates between the
//! scale at which every output pixel is valid (0) and the one at which every source pixel is kept
//! (1), measured on a 9 × 9 grid over the image (`undistort_rectangles`). lucent undistorts those
//! points exactly (Newton's method to 10⁻⁹ px, `render::camera::OpenCv::undistort`), where OpenCV
//! stops after five fixed-point iterations; with strong distortion the two differ at the image
//! corners, and so do their scales.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::nonminimal_bool)]

use anyhow::{bail, Result};
use nalgebra::{Matrix3, Matrix3x4, Matrix4, Rotation3, Vector3};
use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};

/// A rectangle in pixels (x, y of its top-left corner, width, height).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x: f64,
    /// Top edge.
    pub y: f64,
    /// Width.
    pub width: f64,
    /// Height.
    pub height: f64,
}

/// An integer pixel rectangle (OpenCV's `Rect`: x, y, width, height), empty as all zeros.
pub type Roi = [i32; 4];

fn camera(k: &Intrinsics, d: &Distortion) -> Result<OpenCv> {
    OpenCv::unchecked(*k, *d, Extrinsics::from_rvec([0.0; 3], [0.0; 3])?)
}

/// Pixel (u, v) of the camera `cam`, undistorted, turned by `r` and projected by `p` (the left
/// 3 × 3 of a projection matrix; normalised coordinates when None), as OpenCV's
/// `undistortPoints(…, R, P)`.
fn undistort_point(cam: &OpenCv, r: &Matrix3<f64>, p: Option<&Matrix3<f64>>, u: f64, v: f64) -> (f64, f64) {
    let k = cam.intrinsics;
    let (x, y, _) = cam.undistort((u - k.cx) / k.fx, (v - k.cy) / k.fy);
    let q = r * Vector3::new(x, y, 1.0);
    let q = match p {
        Some(p) => p * (q / q.z),
        None => q,
    };
    (q.x / q.z, q.y / q.z)
}

/// The largest rectangle inside, and the smallest around, the image of a `width` × `height`
/// camera's 9 × 9 grid of points over its pixels ((0, 0) to (w − 1, h − 1)), undistorted,
/// turned by `r` and projected by `p` (OpenCV's `getUndistortRectangles`; inner: the grid's
/// border columns and rows, so it holds for rotations up to about 45°).
pub fn undistort_rectangles(k: &Intrinsics, d: &Distortion, r: &Matrix3<f64>, p: Option<&Matrix3<f64>>, width: u32, height: u32) -> Result<(Rect, Rect)> {
    const N: usize = 9;
    let cam = camera(k, d)?;
    let (mut ix0, mut ix1, mut iy0, mut iy1) = (f64::MIN, f64::MAX, f64::MIN, f64::MAX);
    let (mut ox0, mut ox1, mut oy0, mut oy1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for yi in 0..N {
        for xi in 0..N {
            let u = xi as f64 * (width as f64 - 1.0) / (N - 1) as f64;
            let v = yi as f64 * (height as f64 - 1.0) / (N - 1) as f64;
            let (x, y) = undistort_point(&cam, r, p, u, v);
            (ox0, ox1, oy0, oy1) = (ox0.min(x), ox1.max(x), oy0.min(y), oy1.max(y));
            if xi == 0 {
                ix0 = ix0.max(x);
            }
            if xi == N - 1 {
                ix1 = ix1.min(x);
            }
            if yi == 0 {
                iy0 = iy0.max(y);
            }
            if yi == N - 1 {
                iy1 = iy1.min(y);
            }
        }
    }
    let rect = |x0: f64, y0: f64, x1: f64, y1: f64| Rect { x: x0, y: y0, width: x1 - x0, height: y1 - y0 };
    let (inner, outer) = (rect(ix0, iy0, ix1, iy1), rect(ox0, oy0, ox1, oy1));
    if ![inner.x, inner.y, inner.width, inner.height, outer.x, outer.y, outer.width, outer.height].iter().all(|v| v.is_finite()) || !(outer.width > 0.0 && outer.height > 0.0) {
        bail!("the lens model maps the image to no finite rectangle");
    }
    Ok((inner, outer))
}

/// The intersection of `r` and the image [0, w) × [0, h) (empty: all zeros).
fn clip(r: Roi, w: u32, h: u32) -> Roi {
    let (x0, y0) = (r[0].max(0), r[1].max(0));
    let (x1, y1) = ((r[0] + r[2]).min(w as i32), (r[1] + r[3]).min(h as i32));
    if x1 > x0 && y1 > y0 { [x0, y0, x1 - x0, y1 - y0] } else { [0; 4] }
}

/// OpenCV's `getOptimalNewCameraMatrix` (principal point not forced to the centre): the pinhole
/// camera of `new_size` pixels that shows, after undistortion, only valid pixels (`alpha` 0),
/// every source pixel (1), or in between; and the rectangle of valid pixels in it.
pub fn optimal_new_camera_matrix(k: &Intrinsics, d: &Distortion, size: (u32, u32), alpha: f64, new_size: (u32, u32)) -> Result<(Intrinsics, Roi)> {
    let (inner, outer) = undistort_rectangles(k, d, &Matrix3::identity(), None, size.0, size.1)?;
    let (nw, nh) = (new_size.0 as f64, new_size.1 as f64);
    let fit = |r: &Rect| {
        let (fx, fy) = ((nw - 1.0) / r.width, (nh - 1.0) / r.height);
        (fx, fy, -fx * r.x, -fy * r.y)
    };
    let (a, b) = (fit(&inner), fit(&outer));
    let mix = |p: f64, q: f64| p * (1.0 - alpha) + q * alpha;
    let m = Intrinsics { fx: mix(a.0, b.0), fy: mix(a.1, b.1), cx: mix(a.2, b.2), cy: mix(a.3, b.3) };
    if !(m.fx > 0.0 && m.fy > 0.0) || ![m.cx, m.cy].iter().all(|v| v.is_finite()) {
        bail!("no new camera matrix: the undistorted image has no extent");
    }
    let p = Matrix3::new(m.fx, 0.0, m.cx, 0.0, m.fy, m.cy, 0.0, 0.0, 1.0);
    let (inner, _) = undistort_rectangles(k, d, &Matrix3::identity(), Some(&p), size.0, size.1)?;
    // OpenCV rounds each of x, y, width and height to the nearest integer, ties to even.
    let roi = [inner.x, inner.y, inner.width, inner.height].map(|v| v.round_ties_even() as i32);
    Ok((m, clip(roi, new_size.0, new_size.1)))
}

/// The result of [`stereo_rectify`], as OpenCV's `stereoRectify` returns it.
#[derive(Clone, Debug)]
pub struct Rectification {
    /// Rotation of each camera into its rectified frame.
    pub r: [Matrix3<f64>; 2],
    /// Projection matrices of the rectified cameras (in the first rectified camera's frame).
    pub p: [Matrix3x4<f64>; 2],
    /// Disparity-to-depth matrix: Q·(u, v, disparity, 1) is the point in homogeneous coordinates
    /// of the first rectified camera.
    pub q: Matrix4<f64>,
    /// The valid pixels of each rectified image.
    pub roi: [Roi; 2],
}

/// The rectifying rotations of a pair with X₂ = R·X₁ + T (Bouguet's, as OpenCV computes them):
/// each camera turned by half the relative rotation in opposite senses, then both by the
/// rotation that puts the baseline on the x axis, or, with `allow_vertical` and a baseline
/// more vertical than horizontal, on the y axis (the axis index is returned).
pub(crate) fn rectifying_rotations(r: &Matrix3<f64>, t: &Vector3<f64>, allow_vertical: bool) -> Result<(Matrix3<f64>, Matrix3<f64>, usize)> {
    if r.iter().chain(t.iter()).any(|v| !v.is_finite()) {
        bail!("R and T must be finite");
    }
    let om = super::model::Pose::from_rt(r, Vector3::zeros()).rvec;
    let r_half = *Rotation3::new(-0.5 * om).matrix();
    let th = r_half * t;
    let idx = if allow_vertical && th.x.abs() <= th.y.abs() { 1 } else { 0 };
    let (c, nt) = (th[idx], th.norm());
    if !(nt > 0.0) {
        bail!("the two cameras share a centre (T = 0): a pair without a baseline cannot be rectified");
    }
    let mut uu = Vector3::zeros();
    uu[idx] = if c > 0.0 { 1.0 } else { -1.0 };
    // The rotation that puts the baseline on the chosen axis.
    let ww = th.cross(&uu);
    let nw = ww.norm();
    let ww = if nw > 0.0 { ww * ((c.abs() / nt).clamp(-1.0, 1.0).acos() / nw) } else { ww };
    let wr = *Rotation3::new(ww).matrix();
    Ok((wr * r_half.transpose(), wr * r_half, idx))
}

/// OpenCV's `stereoRectify` for two cameras (`k`, `d` each) of `size` pixels with
/// X₂ = R·X₁ + T: with `zero_disparity` the two principal points coincide
/// (`CALIB_ZERO_DISPARITY`, OpenCV's default); `alpha` < 0 keeps the default scale, 0…1 as in
/// [`optimal_new_camera_matrix`]; `new_size` the rectified images' size.
#[allow(clippy::too_many_arguments)]
pub fn stereo_rectify(k: [&Intrinsics; 2], d: [&Distortion; 2], size: (u32, u32), r: &Matrix3<f64>, t: &Vector3<f64>, zero_disparity: bool, alpha: f64, new_size: (u32, u32)) -> Result<Rectification> {
    let (r1, r2, idx) = rectifying_rotations(r, t, true)?;
    let t2 = r2 * t;
    let (w, h) = (size.0 as f64, size.1 as f64);
    let new_size = if new_size.0 * new_size.1 != 0 { new_size } else { size };
    let ratio = if idx == 1 { new_size.0 as f64 / w / 2.0 } else { new_size.1 as f64 / h / 2.0 };
    let f_of = |k: &Intrinsics| if idx == 1 { k.fx } else { k.fy };
    let mut fc = (f_of(k[0]) + f_of(k[1])) * ratio;
    // Principal points that centre the undistorted, turned image corners.
    let mut cc = [[0.0f64; 2]; 2];
    for i in 0..2 {
        let cam = camera(k[i], d[i])?;
        let ri = if i == 0 { &r1 } else { &r2 };
        let (mut sx, mut sy) = (0.0, 0.0);
        for (u, v) in [(0.0, 0.0), (w - 1.0, 0.0), (0.0, h - 1.0), (w - 1.0, h - 1.0)] {
            let (x, y) = undistort_point(&cam, ri, None, u, v);
            (sx, sy) = (sx + fc * x, sy + fc * y);
        }
        cc[i] = [(w - 1.0) / 2.0 - sx / 4.0, (h - 1.0) / 2.0 - sy / 4.0];
    }
    // The coordinate across the baseline is shared, and with `zero_disparity` the other too.
    let shared: &[usize] = if zero_disparity { &[0, 1] } else if idx == 0 { &[1] } else { &[0] };
    for &a in shared {
        let m = (cc[0][a] + cc[1][a]) / 2.0;
        (cc[0][a], cc[1][a]) = (m, m);
    }
    let proj = |f: f64, c: [f64; 2]| Matrix3::new(f, 0.0, c[0], 0.0, f, c[1], 0.0, 0.0, 1.0);
    let (inner1, outer1) = undistort_rectangles(k[0], d[0], &r1, Some(&proj(fc, cc[0])), size.0, size.1)?;
    let (inner2, outer2) = undistort_rectangles(k[1], d[1], &r2, Some(&proj(fc, cc[1])), size.0, size.1)?;
    let (nw, nh) = (new_size.0 as f64, new_size.1 as f64);
    let c0 = cc;
    let cn = [[nw * c0[0][0] / w, nh * c0[0][1] / h], [nw * c0[1][0] / w, nh * c0[1][1] / h]];
    let mut s = 1.0;
    let alpha = alpha.min(1.0);
    if alpha >= 0.0 {
        let scales = |r: &Rect, i: usize| {
            [cn[i][0] / (c0[i][0] - r.x), cn[i][1] / (c0[i][1] - r.y), (nw - 1.0 - cn[i][0]) / (r.x + r.width - c0[i][0]), (nh - 1.0 - cn[i][1]) / (r.y + r.height - c0[i][1])]
        };
        let s0 = scales(&inner1, 0).into_iter().chain(scales(&inner2, 1)).fold(f64::MIN, f64::max);
        let s1 = scales(&outer1, 0).into_iter().chain(scales(&outer2, 1)).fold(f64::MAX, f64::min);
        s = s0 * (1.0 - alpha) + s1 * alpha;
    }
    fc *= s;
    let mut p1 = Matrix3x4::zeros();
    let mut p2 = Matrix3x4::zeros();
    for (p, c) in [(&mut p1, cn[0]), (&mut p2, cn[1])] {
        (p[(0, 0)], p[(1, 1)], p[(0, 2)], p[(1, 2)], p[(2, 2)]) = (fc, fc, c[0], c[1], 1.0);
    }
    p2[(idx, 3)] = t2[idx] * fc;
    let roi = |r: &Rect, i: usize| {
        let x = ((r.x - c0[i][0]) * s + cn[i][0]).ceil() as i32;
        let y = ((r.y - c0[i][1]) * s + cn[i][1]).ceil() as i32;
        clip([x, y, (r.width * s).floor() as i32, (r.height * s).floor() as i32], new_size.0, new_size.1)
    };
    let t_idx = t2[idx];
    let shift = if idx == 0 { cn[0][0] - cn[1][0] } else { cn[0][1] - cn[1][1] };
    #[rustfmt::skip]
    let q = Matrix4::new(
        1.0, 0.0, 0.0, -cn[0][0],
        0.0, 1.0, 0.0, -cn[0][1],
        0.0, 0.0, 0.0, fc,
        0.0, 0.0, -1.0 / t_idx, shift / t_idx,
    );
    if ![fc, cn[0][0], cn[0][1], cn[1][0], cn[1][1]].iter().all(|v| v.is_finite()) || !(fc > 0.0) {
        bail!("the rectified cameras are not finite");
    }
    Ok(Rectification { r: [r1, r2], p: [p1, p2], q, roi: [roi(&inner1, 0), roi(&inner2, 1)] })
}

/// R1, R2, P1, P2 and Q of a rectification, each as its rows, under OpenCV's names.
pub fn matrix_rows(r: &[Matrix3<f64>; 2], p: &[Matrix3x4<f64>; 2], q: &Matrix4<f64>) -> [(&'static str, Vec<Vec<f64>>); 5] {
    let rows = |m: &[f64], n: usize| m.chunks(n).map(|r| r.to_vec()).collect::<Vec<_>>();
    [("R1", rows(r[0].transpose().as_slice(), 3)), ("R2", rows(r[1].transpose().as_slice(), 3)), ("P1", rows(p[0].transpose().as_slice(), 4)), ("P2", rows(p[1].transpose().as_slice(), 4)), ("Q", rows(q.transpose().as_slice(), 4))]
}

/// [`stereo_rectify`] of a two-camera calibration (`scan calibrate-stereo`'s: the first camera in
/// `camera`, the second in `projector`, X₂ = R·X₁ + T), at the cameras' common size; and each
/// camera's lens.
pub fn rectify_calibration(c: &super::ProcamCalibration, zero_disparity: bool, alpha: f64) -> Result<(Rectification, [(Intrinsics, Distortion); 2])> {
    let (a, b) = (&c.camera, &c.projector);
    if (a.width, a.height) != (b.width, b.height) {
        bail!("the two devices are {}x{} and {}x{}; rectification takes two images of one size", a.width, a.height, b.width, b.height);
    }
    let lens = |d: &super::DeviceCalibration| -> Result<(Intrinsics, Distortion)> {
        Ok((Intrinsics { fx: d.fx, fy: d.fy, cx: d.cx, cy: d.cy }, Distortion::from_opencv(&d.distortion)?))
    };
    let lenses = [lens(a)?, lens(b)?];
    let r = Matrix3::from_fn(|i, j| c.rotation[i][j]);
    let size = (a.width, a.height);
    let rect = stereo_rectify([&lenses[0].0, &lenses[1].0], [&lenses[0].1, &lenses[1].1], size, &r, &Vector3::from(c.translation), zero_disparity, alpha, size)?;
    Ok((rect, lenses))
}

/// For each pixel of a `width` × `height` output (row-major), the source pixel its ray comes from
/// (OpenCV's `initUndistortRectifyMap`): the output is the pinhole camera `p` (the left 3 × 3 of
/// a projection matrix) turned by `r` from the source camera `k`, `d`.
pub fn undistort_rectify_map(k: &Intrinsics, d: &Distortion, r: &Matrix3<f64>, p: &Matrix3<f64>, width: usize, height: usize) -> Result<Vec<[f64; 2]>> {
    let Some(inv) = (p * r).try_inverse() else { bail!("the new camera matrix times R is singular") };
    let mut map = Vec::with_capacity(width * height);
    for v in 0..height {
        for u in 0..width {
            let q = inv * Vector3::new(u as f64, v as f64, 1.0);
            let (xd, yd) = d.distort(q.x / q.z, q.y / q.z);
            map.push([k.fx * xd + k.cx, k.fy * yd + k.cy]);
        }
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lens(fx: f64, fy: f64, cx: f64, cy: f64) -> Intrinsics {
        Intrinsics { fx, fy, cx, cy }
    }

    /// After rectification a point seen by both cameras lies on the same row of the two images,
    /// and Q maps (u, v, disparity) back to the point in the first rectified camera's frame; a
    /// vertical pair shares columns instead.
    #[test]
    fn rectified_rows_agree_and_q_reprojects() {
        let k = [lens(905.0, 899.0, 322.5, 241.0), lens(870.0, 866.0, 330.0, 236.0)];
        let d = [Distortion::from_opencv(&[-0.12, 0.05, 0.001, -0.0007, 0.0]).unwrap(), Distortion::from_opencv(&[-0.08, 0.02, 0.0, 0.0005, 0.0]).unwrap()];
        let rot = *Rotation3::new(Vector3::new(0.02, -0.05, 0.01)).matrix();
        for (t, across) in [(Vector3::new(-120.0, 3.0, 5.0), 1), (Vector3::new(4.0, -110.0, -6.0), 0)] {
            let rect = stereo_rectify([&k[0], &k[1]], [&d[0], &d[1]], (640, 480), &rot, &t, true, -1.0, (0, 0)).unwrap();
            for x in [Vector3::new(30.0, -20.0, 900.0), Vector3::new(-80.0, 60.0, 1400.0), Vector3::new(5.0, 5.0, 600.0)] {
                // The point in each rectified camera, projected by its P.
                let x1 = rect.r[0] * x;
                let x2 = rect.r[1] * (rot * x + t);
                let pix = |p: &Matrix3x4<f64>, xr: &Vector3<f64>, first: bool| {
                    // P₂'s last column holds the baseline in the first rectified frame.
                    let h = if first { p * xr.push(1.0) } else { p.fixed_view::<3, 3>(0, 0) * xr };
                    [h.x / h.z, h.y / h.z]
                };
                let (a, b) = (pix(&rect.p[0], &x1, true), pix(&rect.p[1], &x2, false));
                assert!((a[across] - b[across]).abs() < 1e-9, "{a:?} {b:?}");
                // The second camera's centre lies at −P₂[idx,3]/f along the axis in the first
                // rectified frame, so P₂ applied to x₁ gives the same pixel.
                let b1 = pix(&rect.p[1], &x1, true);
                assert!((b1[0] - b[0]).abs() < 1e-9 && (b1[1] - b[1]).abs() < 1e-9, "{b1:?} {b:?}");
                let disparity = a[1 - across] - b[1 - across];
                let h = rect.q * nalgebra::Vector4::new(a[0], a[1], disparity, 1.0);
                let back = h.xyz() / h.w;
                assert!((back - x1).norm() < 1e-9 * x1.norm(), "{back:?} {x1:?}");
            }
            // The rotations are rotations.
            for r in rect.r {
                assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-12 && (r.determinant() - 1.0).abs() < 1e-12);
            }
        }
    }

    /// The map of `undistort_rectify_map` sends each output pixel to the source pixel that sees
    /// the same ray: projecting the ray through the distorted camera gives the map's pixel.
    #[test]
    fn the_map_inverts_the_rectified_projection() {
        let k = lens(905.0, 899.0, 322.5, 241.0);
        let d = Distortion::from_opencv(&[-0.12, 0.05, 0.001, -0.0007, 0.0]).unwrap();
        let r = *Rotation3::new(Vector3::new(0.01, 0.03, -0.02)).matrix();
        let p = Matrix3::new(800.0, 0.0, 300.0, 0.0, 800.0, 250.0, 0.0, 0.0, 1.0);
        let map = undistort_rectify_map(&k, &d, &r, &p, 64, 48).unwrap();
        let cam = camera(&k, &d).unwrap();
        for (i, m) in map.iter().enumerate().step_by(97) {
            let (u, v) = ((i % 64) as f64, (i / 64) as f64);
            // Undistorting the source pixel and rectifying it lands on the output pixel.
            let (x, y) = undistort_point(&cam, &r, Some(&p), m[0], m[1]);
            assert!((x - u).abs() < 1e-7 && (y - v).abs() < 1e-7, "({u}, {v}) → {m:?} → ({x}, {y})");
        }
    }
}
