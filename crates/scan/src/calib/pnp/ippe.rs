//! Infinitesimal plane-based pose estimation (OpenCV's `SOLVEPNP_IPPE` and
//! `SOLVEPNP_IPPE_SQUARE`; Collins & Bartoli, "Infinitesimal plane-based pose estimation",
//! IJCV 109(3), 2014).
//!
//! The points are moved into their plane's frame (centroid at the origin, z = 0), the homography
//! H from that plane to the normalised image is fitted (the Hartley-normalised direct linear
//! transform of `calib::homography`; OpenCV fits Harker and O'Leary's, which agrees on exact
//! data), and the pose is solved exactly for H's first-order behaviour at the origin: with v
//! the origin's image and J the 2 × 2 Jacobian of H there, R_v the rotation taking the optical
//! axis onto v's line of sight, B = [I₂ | −v] R_v's first two columns, and A = B⁻¹J, the first two
//! columns of the rotation (in R_v's frame) are [A/γ; bᵀ] with γ A's largest singular value and
//! b completing them to orthonormal columns, up to the sign of b: the two poses of a plane that
//! IPPE returns. Each rotation's translation is the linear least-squares one of the image
//! equations (x (r₃ᵀX + t₃) = r₁ᵀX + t₁, likewise for y). Both poses are returned; the caller
//! orders them by reprojection error.

use nalgebra::{Matrix2, Matrix3, Vector3};

use super::plane_frame;
use crate::calib::homography::{fit_homography, Point2};

/// The two poses (R, t) of the coplanar object points `x` seen at normalised coordinates `m`;
/// None when the homography or the Jacobian is degenerate.
pub(super) fn ippe(x: &[Vector3<f64>], m: &[Point2]) -> Option<Vec<(Matrix3<f64>, Vector3<f64>)>> {
    let (c, frame) = plane_frame(x)?;
    let q: Vec<Point2> = x.iter().map(|p| frame.transpose() * (p - c)).map(|v| [v[0], v[1]]).collect();
    let h = fit_homography(&q, m)?;
    let h = h / h[(2, 2)];
    if h.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // The origin's image and the Jacobian of H there.
    let (p, qv) = (h[(0, 2)], h[(1, 2)]);
    let j = Matrix2::new(h[(0, 0)] - h[(2, 0)] * p, h[(0, 1)] - h[(2, 1)] * p, h[(1, 0)] - h[(2, 0)] * qv, h[(1, 1)] - h[(2, 1)] * qv);
    let rv = rotation_to(&Vector3::new(p, qv, 1.0).normalize());
    let b = Matrix2::new(rv[(0, 0)] - p * rv[(2, 0)], rv[(0, 1)] - p * rv[(2, 1)], rv[(1, 0)] - qv * rv[(2, 0)], rv[(1, 1)] - qv * rv[(2, 1)]);
    let a = b.try_inverse()? * j;
    let gamma = a.svd(false, false).singular_values.max();
    if !(gamma > 0.0) {
        return None;
    }
    let r22 = a / gamma;
    let (c0, c1) = (r22.column(0).into_owned(), r22.column(1).into_owned());
    let b0 = (1.0 - c0.norm_squared()).max(0.0).sqrt();
    let mut b1 = (1.0 - c1.norm_squared()).max(0.0).sqrt();
    if c0.dot(&c1) > 0.0 {
        b1 = -b1;
    }
    let mut out = Vec::with_capacity(2);
    for sign in [1.0, -1.0] {
        let col0 = Vector3::new(c0[0], c0[1], sign * b0);
        let col1 = Vector3::new(c1[0], c1[1], sign * b1);
        let r_plane = rv * Matrix3::from_columns(&[col0, col1, col0.cross(&col1)]);
        let r_plane = crate::calib::model::nearest_rotation(&r_plane);
        let t_plane = translation(&r_plane, &q, m)?;
        // Back to the object's frame: X_plane = Fᵀ(X − c).
        let r = r_plane * frame.transpose();
        out.push((r, t_plane - r * c));
    }
    Some(out)
}

/// The rotation that takes the optical axis (0, 0, 1) onto the unit vector `t` (about their
/// common perpendicular).
fn rotation_to(t: &Vector3<f64>) -> Matrix3<f64> {
    let axis = Vector3::new(-t[1], t[0], 0.0);
    let s = axis.norm();
    if s < 1e-300 {
        return Matrix3::identity();
    }
    let k = (axis / s).cross_matrix();
    Matrix3::identity() + k * s + k * k * (1.0 - t[2])
}

/// The translation minimising Σ (x (r₃ᵀX + t₃) − r₁ᵀX − t₁)² + (y (r₃ᵀX + t₃) − r₂ᵀX − t₂)²
/// over the plane points `q` (z = 0).
fn translation(r: &Matrix3<f64>, q: &[Point2], m: &[Point2]) -> Option<Vector3<f64>> {
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for (p, u) in q.iter().zip(m) {
        let rx = r * Vector3::new(p[0], p[1], 0.0);
        for (row, coord) in [(Vector3::new(1.0, 0.0, -u[0]), 0), (Vector3::new(0.0, 1.0, -u[1]), 1)] {
            // row · t = u rx₃ − rx_coord.
            let rhs = [u[0], u[1]][coord] * rx[2] - rx[coord];
            ata += row * row.transpose();
            atb += row * rhs;
        }
    }
    ata.try_inverse().map(|inv| inv * atb)
}
