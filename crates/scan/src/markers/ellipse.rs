//! Conics: the direct least-squares ellipse fit of Fitzgibbon, Pilu & Fisher (IEEE TPAMI 21(5),
//! 1999) in the numerically stable form of Halíř & Flusser (WSCG 1998), the ellipse's centre,
//! axes and angle, and the geometry of the image of a 3-D circle: the two possible plane normals
//! (the circular sections of the cone of rays, e.g. Chen, Wu & Wada, ECCV 2004) and the image of
//! the circle's centre, which is the pole of the plane's vanishing line with respect to the image
//! conic — not the ellipse's centre under perspective.
//!
//! A conic is the symmetric 3 × 3 matrix Q with xᵀQx = 0 for x = (u, v, 1) on it.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector3};

/// An ellipse in image coordinates (pixels, or normalised camera coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipse {
    /// Centre (x, y).
    pub centre: [f64; 2],
    /// Semi-major axis.
    pub semi_major: f64,
    /// Semi-minor axis.
    pub semi_minor: f64,
    /// Angle of the major axis from the x axis towards y (radians, in (−π/2, π/2]).
    pub angle_rad: f64,
}

/// The conic through `points` by Fitzgibbon's direct ellipse-specific least squares (Halíř &
/// Flusser's formulation, on points centred and scaled to unit RMS radius for conditioning).
/// None for fewer than 6 points or when no ellipse fits (collinear points, a hyperbola).
pub fn fit_conic(points: &[[f64; 2]]) -> Option<Matrix3<f64>> {
    let n = points.len();
    if n < 6 {
        return None;
    }
    let (mx, my) = points.iter().fold((0.0, 0.0), |a, p| (a.0 + p[0], a.1 + p[1]));
    let (mx, my) = (mx / n as f64, my / n as f64);
    let rms = (points.iter().map(|p| (p[0] - mx).powi(2) + (p[1] - my).powi(2)).sum::<f64>() / n as f64).sqrt();
    if !(rms > 0.0) || !rms.is_finite() {
        return None;
    }
    let sc = 1.0 / rms;
    // Scatter blocks: D1 = [x², xy, y²], D2 = [x, y, 1].
    let (mut s1, mut s2, mut s3) = (Matrix3::zeros(), Matrix3::zeros(), Matrix3::zeros());
    for p in points {
        let (x, y) = ((p[0] - mx) * sc, (p[1] - my) * sc);
        let d1 = Vector3::new(x * x, x * y, y * y);
        let d2 = Vector3::new(x, y, 1.0);
        s1 += d1 * d1.transpose();
        s2 += d1 * d2.transpose();
        s3 += d2 * d2.transpose();
    }
    let t = -(s3.try_inverse()? * s2.transpose());
    let m = s1 + s2 * t;
    // Premultiply by the inverse of the constraint matrix [[0, 0, 2], [0, −1, 0], [2, 0, 0]].
    let m = Matrix3::from_rows(&[(m.row(2) * 0.5), -m.row(1), (m.row(0) * 0.5)]);
    let schur = nalgebra::Schur::new(m);
    let eig = schur.eigenvalues()?;
    let mut best: Option<(f64, Vector3<f64>)> = None;
    for &lambda in eig.iter() {
        let Some(a1) = null_vector(&(m - Matrix3::identity() * lambda)) else { continue };
        let cond = 4.0 * a1[0] * a1[2] - a1[1] * a1[1];
        if cond > 0.0 && best.as_ref().is_none_or(|b| cond / a1.norm_squared() > b.0) {
            best = Some((cond / a1.norm_squared(), a1));
        }
    }
    let a1 = best?.1;
    let a2 = t * a1;
    let (a, b, c, d, e, f) = (a1[0], a1[1], a1[2], a2[0], a2[1], a2[2]);
    let qn = Matrix3::new(a, b / 2.0, d / 2.0, b / 2.0, c, e / 2.0, d / 2.0, e / 2.0, f);
    // x_n = H x with H = [[sc, 0, −sc·mx], [0, sc, −sc·my], [0, 0, 1]]; Q = Hᵀ Q_n H.
    let h = Matrix3::new(sc, 0.0, -sc * mx, 0.0, sc, -sc * my, 0.0, 0.0, 1.0);
    let q = h.transpose() * qn * h;
    let norm = q.norm();
    (norm > 0.0 && norm.is_finite()).then(|| q / norm)
}

/// A unit vector spanning the (numerical) null space of a rank-2 matrix: the largest cross product
/// of two of its rows.
fn null_vector(m: &Matrix3<f64>) -> Option<Vector3<f64>> {
    let r: [Vector3<f64>; 3] = [m.row(0).transpose(), m.row(1).transpose(), m.row(2).transpose()];
    let c = [r[0].cross(&r[1]), r[0].cross(&r[2]), r[1].cross(&r[2])];
    let best = c.iter().max_by(|a, b| a.norm_squared().total_cmp(&b.norm_squared()))?;
    let n = best.norm();
    (n > 0.0 && n.is_finite()).then(|| best / n)
}

/// Centre, axes and angle of an ellipse conic; None if `q` is not a real ellipse.
pub fn ellipse_of(q: &Matrix3<f64>) -> Option<Ellipse> {
    let m2 = Matrix2::new(q[(0, 0)], q[(0, 1)], q[(1, 0)], q[(1, 1)]);
    let c = m2.try_inverse()? * -nalgebra::Vector2::new(q[(0, 2)], q[(1, 2)]);
    let xc = Vector3::new(c[0], c[1], 1.0);
    let k = -(xc.transpose() * q * xc)[0];
    let eig = SymmetricEigen::new(m2);
    let (mut i0, mut i1) = (0, 1);
    if eig.eigenvalues[0] / k < eig.eigenvalues[1] / k {
        // i0: the smaller curvature (longer axis).
    } else {
        (i0, i1) = (1, 0);
    }
    let (l0, l1) = (eig.eigenvalues[i0] / k, eig.eigenvalues[i1] / k);
    if !(l0 > 0.0 && l1 > 0.0) {
        return None;
    }
    let v = eig.eigenvectors.column(i0);
    let mut angle = v[1].atan2(v[0]);
    if angle <= -std::f64::consts::FRAC_PI_2 {
        angle += std::f64::consts::PI;
    } else if angle > std::f64::consts::FRAC_PI_2 {
        angle -= std::f64::consts::PI;
    }
    Some(Ellipse { centre: [c[0], c[1]], semi_major: 1.0 / l0.sqrt(), semi_minor: 1.0 / l1.sqrt(), angle_rad: angle })
}

/// First-order (Sampson) distance of `p` from the conic: (xᵀQx) / |∇(xᵀQx)|, in the units of `p`.
pub fn sampson_distance(q: &Matrix3<f64>, p: [f64; 2]) -> f64 {
    let x = Vector3::new(p[0], p[1], 1.0);
    let qx = q * x;
    let g = 2.0 * qx[0].hypot(qx[1]);
    x.dot(&qx) / g
}

/// Distance from the ellipse's centre to the ellipse along the unit direction `u`.
pub fn radius_along(q: &Matrix3<f64>, e: &Ellipse, u: [f64; 2]) -> f64 {
    let xc = Vector3::new(e.centre[0], e.centre[1], 1.0);
    let k = -(xc.transpose() * q * xc)[0];
    let quad = q[(0, 0)] * u[0] * u[0] + 2.0 * q[(0, 1)] * u[0] * u[1] + q[(1, 1)] * u[1] * u[1];
    (k / quad).sqrt()
}

/// The two unit normals of the planes whose intersection with the cone of rays through the conic
/// `q` (normalised camera coordinates) is a circle, each oriented towards the camera (n·x < 0 at
/// the circle). With eigenvalues λ₁ ≥ λ₂ > 0 > λ₃ of ±Q and eigenvectors e₁, e₃, the normals are
/// √(λ₁ − λ₂)·e₁ ± √(λ₂ − λ₃)·e₃; they coincide for a circle seen face-on. None if the conic
/// is not the image of a circle in front of the camera (not one negative and two positive
/// eigenvalues).
pub fn circle_normals(q: &Matrix3<f64>) -> Option<[Vector3<f64>; 2]> {
    let eig = SymmetricEigen::new(*q);
    let pos = eig.eigenvalues.iter().filter(|&&l| l > 0.0).count();
    let s = match pos {
        2 => 1.0,
        1 => -1.0,
        _ => return None,
    };
    let mut idx = [0usize, 1, 2];
    idx.sort_by(|&a, &b| (s * eig.eigenvalues[b]).total_cmp(&(s * eig.eigenvalues[a])));
    let l: Vec<f64> = idx.iter().map(|&i| s * eig.eigenvalues[i]).collect();
    if !(l[1] > 0.0 && l[2] < 0.0) {
        return None;
    }
    let (e1, e3) = (eig.eigenvectors.column(idx[0]).into_owned(), eig.eigenvectors.column(idx[2]).into_owned());
    let (a, b) = ((l[0] - l[1]).max(0.0).sqrt(), (l[1] - l[2]).sqrt());
    let qi = q.try_inverse()?;
    let orient = |n: Vector3<f64>| {
        let n = n.normalize();
        let c = centre_direction(&qi, &n);
        if n.dot(&c) > 0.0 {
            -n
        } else {
            n
        }
    };
    Some([orient(e1 * a + e3 * b), orient(e1 * a - e3 * b)])
}

/// The direction (z > 0) towards the image of the centre of a circle with plane normal `n`
/// imaged as the conic with inverse `q_inv`: the pole Q⁻¹n of the vanishing line n.
fn centre_direction(q_inv: &Matrix3<f64>, n: &Vector3<f64>) -> Vector3<f64> {
    let c = q_inv * n;
    if c[2] < 0.0 {
        -c
    } else {
        c
    }
}

/// The image (normalised camera coordinates) of the centre of a circle with plane normal `n`
/// whose image is the conic `q`; None for a degenerate conic or a centre at infinity.
pub fn circle_centre_image(q: &Matrix3<f64>, n: &Vector3<f64>) -> Option<[f64; 2]> {
    let c = centre_direction(&q.try_inverse()?, n);
    (c[2].abs() > 1e-300).then(|| [c[0] / c[2], c[1] / c[2]])
}
