//! Zhang's closed-form calibration (Z. Zhang, "A flexible new technique for camera calibration",
//! IEEE TPAMI 22(11), 2000, §3.1 and appendix B): each board-to-image homography H = λK[r1 r2 t]
//! gives two linear constraints h1ᵀBh2 = 0, h1ᵀBh1 = h2ᵀBh2 on B = K⁻ᵀK⁻¹; with ≥ 3 views (here
//! also the zero-skew row B12 = 0) B is the null vector of the stacked system, and K follows in
//! closed form. Pixel coordinates are first normalised (centred on the image, scaled by its size)
//! so that the system is well conditioned; K is mapped back afterwards.

use super::homography::Point2;
use super::model::{nearest_rotation, Lens, Pose};
use anyhow::{bail, Result};
use nalgebra::{DMatrix, Matrix3, SymmetricEigen, Vector3};

fn v_ij(h: &Matrix3<f64>, i: usize, j: usize) -> [f64; 6] {
    let (a, b) = (h.column(i), h.column(j));
    [a[0] * b[0], a[0] * b[1] + a[1] * b[0], a[1] * b[1], a[2] * b[0] + a[0] * b[2], a[2] * b[1] + a[1] * b[2], a[2] * b[2]]
}

/// Intrinsics (fx, fy, cx, cy; zero skew, no distortion) from ≥ 3 board homographies of an image
/// of `width` × `height` pixels. Errors when the views are degenerate (B not positive definite,
/// e.g. all boards parallel).
pub fn intrinsics(homographies: &[Matrix3<f64>], width: u32, height: u32) -> Result<Lens> {
    if homographies.len() < 3 {
        bail!("Zhang's method needs at least 3 views, got {}", homographies.len());
    }
    let s = 2.0 / (width as f64 + height as f64);
    let (ox, oy) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
    let n = Matrix3::new(s, 0.0, -s * ox, 0.0, s, -s * oy, 0.0, 0.0, 1.0);
    let rows = 2 * homographies.len() + 1;
    let mut v = DMatrix::<f64>::zeros(rows, 6);
    for (k, h) in homographies.iter().enumerate() {
        let h = n * h;
        // The constraints use h1 and h2 only: scale them to unit norm (the board's length unit drops out).
        let h = h / (h.column(0).norm_squared() + h.column(1).norm_squared()).sqrt();
        let v12 = v_ij(&h, 0, 1);
        let v11 = v_ij(&h, 0, 0);
        let v22 = v_ij(&h, 1, 1);
        for c in 0..6 {
            v[(2 * k, c)] = v12[c];
            v[(2 * k + 1, c)] = v11[c] - v22[c];
        }
    }
    // Zero skew: B12 = 0.
    v[(rows - 1, 1)] = 1.0;
    let vtv = v.transpose() * &v;
    let eig = SymmetricEigen::new(vtv);
    let mut order: Vec<usize> = (0..6).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    if !(eig.eigenvalues[order[1]] > 1e-10 * eig.eigenvalues[order[5]]) {
        bail!("degenerate pose set: the board views do not determine the intrinsics (Zhang's system has a null space of dimension > 1)");
    }
    let mut b: Vec<f64> = eig.eigenvectors.column(order[0]).iter().copied().collect();
    if b[0] < 0.0 {
        b.iter_mut().for_each(|x| *x = -*x);
    }
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let den = b11 * b22 - b12 * b12;
    let v0 = (b12 * b13 - b11 * b23) / den;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    let alpha2 = lambda / b11;
    let beta2 = lambda * b11 / den;
    if !(den > 0.0 && alpha2 > 0.0 && beta2 > 0.0) {
        bail!("degenerate pose set: Zhang's closed form gives no real focal length (B is not positive definite)");
    }
    let (alpha, beta) = (alpha2.sqrt(), beta2.sqrt());
    let gamma = -b12 * alpha * alpha * beta / lambda;
    let u0 = gamma * v0 / beta - b13 * alpha * alpha / lambda;
    let kn = Matrix3::new(alpha, gamma, u0, 0.0, beta, v0, 0.0, 0.0, 1.0);
    let k = n.try_inverse().unwrap() * kn;
    let lens = Lens::pinhole(k[(0, 0)], k[(1, 1)], k[(0, 2)], k[(1, 2)]);
    if !lens.to_array().iter().all(|x| x.is_finite()) {
        bail!("degenerate pose set: Zhang's closed form is not finite");
    }
    Ok(lens)
}

/// The board pose (board → device) from a homography and the intrinsics (Zhang 2000, §3.1):
/// r1 = λK⁻¹h1, r2 = λK⁻¹h2, r3 = r1 × r2, t = λK⁻¹h3, λ = 1/‖K⁻¹h1‖, then the nearest rotation.
/// The sign is chosen so that the board lies in front of the device (t_z > 0).
pub fn pose_from_homography(h: &Matrix3<f64>, k: &Matrix3<f64>) -> Option<Pose> {
    let kinv = k.try_inverse()?;
    let m = kinv * h;
    let (c1, c2, c3) = (m.column(0).into_owned(), m.column(1).into_owned(), m.column(2).into_owned());
    let mut lam = 2.0 / (c1.norm() + c2.norm());
    if c3[2] * lam < 0.0 {
        lam = -lam;
    }
    let r1 = c1 * lam;
    let r2 = c2 * lam;
    let r3 = r1.cross(&r2);
    let r = nearest_rotation(&Matrix3::from_columns(&[r1, r2, r3]));
    let t: Vector3<f64> = c3 * lam;
    t.iter().all(|x| x.is_finite()).then(|| Pose::from_rt(&r, t))
}

/// Object points of a board with `cols` × `rows` inner corners and square `square`, row-major
/// (corner k at (k mod cols, k div cols) × square, z = 0), as OpenCV's calibration samples build them.
pub fn board_points(cols: usize, rows: usize, square: f64) -> Vec<Point2> {
    (0..rows * cols).map(|k| [(k % cols) as f64 * square, (k / cols) as f64 * square]).collect()
}
