//! Zhang's closed-form calibration (Z. Zhang, "A flexible new technique for camera calibration",
//! IEEE TPAMI 22(11), 2000, §3.1 and appendix B): each board-to-image homography H = λK[r1 r2 t]
//! gives two linear constraints h1ᵀBh2 = 0, h1ᵀBh1 = h2ᵀBh2 on B = K⁻ᵀK⁻¹; with ≥ 3 views (here
//! also the zero-skew row B12 = 0) B is the null vector of the stacked system, and K follows in
//! closed form. Pixel coordinates are first normalised (centred on the image, scaled by its size)
//! so that the system is well conditioned; K is mapped back afterwards.

use super::bundle::{Free, HOLD_PRINCIPAL_POINT};
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

/// The lens a calibration of a `width` × `height` device starts from without a guess: Zhang's
/// closed form ([`intrinsics`]). Where `free` holds the principal point, it is the image centre
/// ((w − 1)/2, (h − 1)/2, as OpenCV puts it) and the focal lengths come from [`focal_at`]; where it
/// holds the aspect ratio a = fx/fy (of its first device: [`Free::for_device`]), fx = f√a and
/// fy = f/√a keep the geometric mean f.
pub fn start(homographies: &[Matrix3<f64>], width: u32, height: u32, free: &Free) -> Result<Lens> {
    let centre = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
    let mut l = if free.held & HOLD_PRINCIPAL_POINT == HOLD_PRINCIPAL_POINT {
        focal_at(homographies, centre.0, centre.1)?
    } else {
        let mut l = intrinsics(homographies, width, height)?;
        if free.held & HOLD_PRINCIPAL_POINT & 0b100 != 0 {
            l.cx = centre.0;
        }
        if free.held & HOLD_PRINCIPAL_POINT & 0b1000 != 0 {
            l.cy = centre.1;
        }
        l
    };
    if let Some(a) = free.aspect_ratio[0] {
        if !(a > 0.0 && a.is_finite()) {
            bail!("the aspect ratio fx/fy must be positive, got {a}");
        }
        let f = (l.fx * l.fy).sqrt();
        (l.fx, l.fy) = (f * a.sqrt(), f / a.sqrt());
    }
    Ok(l)
}

/// Focal lengths for a known principal point (cx, cy), from ≥ 1 board homographies. With
/// H′ = T·H, T moving (cx, cy) to the origin, B = K′⁻ᵀK′⁻¹ = diag(1/fx², 1/fy², 1), so Zhang's
/// two constraints per view, h1ᵀBh2 = 0 and h1ᵀBh1 = h2ᵀBh2, are linear in 1/fx² and 1/fy²
/// (least squares over the views). OpenCV's initialisation (`initIntrinsicParams2D`, from
/// vanishing points) solves the same two unknowns with the image centre as principal point.
pub fn focal_at(homographies: &[Matrix3<f64>], cx: f64, cy: f64) -> Result<Lens> {
    let t = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
    // Unknowns u = (s/fx)², (s/fy)², of order 1 for focal lengths of 10² to 10⁴ pixels.
    let s = 1000.0;
    let mut a = DMatrix::<f64>::zeros(2 * homographies.len(), 2);
    let mut b = nalgebra::DVector::<f64>::zeros(2 * homographies.len());
    for (k, h) in homographies.iter().enumerate() {
        let h = t * h;
        let (h1, h2) = (h.column(0), h.column(1));
        let rows = [
            [h1[0] * h2[0] / (s * s), h1[1] * h2[1] / (s * s), h1[2] * h2[2]],
            [(h1[0] * h1[0] - h2[0] * h2[0]) / (s * s), (h1[1] * h1[1] - h2[1] * h2[1]) / (s * s), h1[2] * h1[2] - h2[2] * h2[2]],
        ];
        for (r, row) in rows.iter().enumerate() {
            let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 0.0 {
                a[(2 * k + r, 0)] = row[0] / norm;
                a[(2 * k + r, 1)] = row[1] / norm;
                b[2 * k + r] = -row[2] / norm;
            }
        }
    }
    let u = a.clone().svd(true, true).solve(&b, 1e-12).map_err(|e| anyhow::anyhow!("{e}"))?;
    if !(u[0] > 0.0 && u[1] > 0.0) {
        bail!("degenerate pose set: the board views give no real focal length for the principal point ({cx}, {cy})");
    }
    let lens = Lens::pinhole(s / u[0].sqrt(), s / u[1].sqrt(), cx, cy);
    if !lens.to_array().iter().all(|x| x.is_finite()) {
        bail!("degenerate pose set: the focal lengths are not finite");
    }
    Ok(lens)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn homography(k: &Matrix3<f64>, rvec: [f64; 3], t: [f64; 3]) -> Matrix3<f64> {
        let r = Pose { rvec: Vector3::from(rvec), t: Vector3::from(t) }.r();
        k * Matrix3::from_columns(&[r.column(0).into_owned(), r.column(1).into_owned(), Vector3::from(t)]) * 0.37
    }

    /// Exact homographies of a known camera give back its focal lengths, with the principal point
    /// given, to rounding; Zhang's full closed form agrees.
    #[test]
    fn focal_lengths_at_a_known_principal_point_are_exact() {
        let k = Matrix3::new(905.0, 0.0, 319.5, 0.0, 899.0, 239.5, 0.0, 0.0, 1.0);
        let hs = [
            homography(&k, [0.3, -0.1, 0.05], [-80.0, -60.0, 500.0]),
            homography(&k, [-0.25, 0.35, 0.1], [-90.0, -50.0, 560.0]),
            homography(&k, [0.1, 0.4, -0.2], [-70.0, -65.0, 610.0]),
        ];
        let l = focal_at(&hs, 319.5, 239.5).unwrap();
        assert!((l.fx - 905.0).abs() < 1e-8 && (l.fy - 899.0).abs() < 1e-8, "{l:?}");
        let z = intrinsics(&hs, 640, 480).unwrap();
        assert!((z.fx - 905.0).abs() < 1e-6 && (z.cx - 319.5).abs() < 1e-6, "{z:?}");
        // One view suffices for the two unknowns.
        let one = focal_at(&hs[..1], 319.5, 239.5).unwrap();
        assert!((one.fx - 905.0).abs() < 1e-8 && (one.fy - 899.0).abs() < 1e-8, "{one:?}");
    }
}
