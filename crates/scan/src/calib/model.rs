//! The device model of the calibration: OpenCV's pinhole with distortion k1, k2, p1, p2, k3, the
//! rational model's k4, k5, k6, the thin prism s1…s4 and the sensor tilt τx, τy (formula in
//! `render::camera::opencv`),
//! and rigid poses as Rodrigues vector + translation.

use super::homography::Point2;
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use render::camera::Distortion;

/// Intrinsics and distortion of one device (a camera, or a projector seen as an inverse camera).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// Focal lengths (pixels).
    pub fx: f64,
    /// Focal length along y (pixels).
    pub fy: f64,
    /// Principal point (pixels, OpenCV convention: integer coordinates at pixel centres).
    pub cx: f64,
    /// Principal point y (pixels).
    pub cy: f64,
    /// [k1, k2, p1, p2, k3] (dimensionless).
    pub dist: [f64; 5],
    /// [k4, k5, k6]: the denominator of OpenCV's rational model (0 unless it is fitted).
    pub rational: [f64; 3],
    /// [s1, s2, s3, s4]: OpenCV's thin prism terms (0 unless they are fitted).
    pub prism: [f64; 4],
    /// [τx, τy]: OpenCV's sensor tilt (radians; 0 unless fitted).
    pub tilt: [f64; 2],
}

impl Lens {
    /// A distortion-free lens.
    pub fn pinhole(fx: f64, fy: f64, cx: f64, cy: f64) -> Lens {
        Lens { fx, fy, cx, cy, dist: [0.0; 5], rational: [0.0; 3], prism: [0.0; 4], tilt: [0.0; 2] }
    }

    /// The camera matrix K.
    pub fn k(&self) -> Matrix3<f64> {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// The lens's distortion in the renderer's form.
    pub fn distortion(&self) -> Distortion {
        let [k1, k2, p1, p2, k3] = self.dist;
        let [k4, k5, k6] = self.rational;
        Distortion { k: [k1, k2, k3, k4, k5, k6], p: [p1, p2], s: self.prism, tau_rad: self.tilt }
    }

    /// Pixel position of a point in device coordinates (x right, y down, z forward).
    pub fn project(&self, x: &Vector3<f64>) -> Point2 {
        let (u, v) = self.distortion().distort(x[0] / x[2], x[1] / x[2]);
        [self.fx * u + self.cx, self.fy * v + self.cy]
    }

    /// The eighteen parameters in the order fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6, s1, s2,
    /// s3, s4, τx, τy.
    pub fn to_array(&self) -> [f64; 18] {
        let (d, q, s, t) = (self.dist, self.rational, self.prism, self.tilt);
        [self.fx, self.fy, self.cx, self.cy, d[0], d[1], d[2], d[3], d[4], q[0], q[1], q[2], s[0], s[1], s[2], s[3], t[0], t[1]]
    }

    /// Inverse of [`Lens::to_array`].
    pub fn from_slice(p: &[f64]) -> Lens {
        Lens { fx: p[0], fy: p[1], cx: p[2], cy: p[3], dist: [p[4], p[5], p[6], p[7], p[8]], rational: [p[9], p[10], p[11]], prism: [p[12], p[13], p[14], p[15]], tilt: [p[16], p[17]] }
    }

    /// From OpenCV's coefficient vector (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4[, τx,
    /// τy]]]]); terms not given are 0.
    pub fn from_opencv(fx: f64, fy: f64, cx: f64, cy: f64, d: &[f64]) -> Lens {
        let g = |i: usize| d.get(i).copied().unwrap_or(0.0);
        Lens { fx, fy, cx, cy, dist: [g(0), g(1), g(2), g(3), g(4)], rational: [g(5), g(6), g(7)], prism: [g(8), g(9), g(10), g(11)], tilt: [g(12), g(13)] }
    }
}

/// A rigid transform X′ = R·X + t, R as a Rodrigues vector (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Rotation vector (axis × angle, radians).
    pub rvec: Vector3<f64>,
    /// Translation (board square units).
    pub t: Vector3<f64>,
}

impl Pose {
    /// The identity.
    pub fn identity() -> Pose {
        Pose { rvec: Vector3::zeros(), t: Vector3::zeros() }
    }

    /// From a rotation matrix (orthonormalised first: the nearest rotation) and a translation.
    /// The rotation vector is exact to rounding at every angle: the unit quaternion by
    /// Shepperd's method, then the angle 2·atan2(|v|, w) (an arccosine of the trace or of w
    /// loses half the digits near 0 and π).
    pub fn from_rt(r: &Matrix3<f64>, t: Vector3<f64>) -> Pose {
        let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(nearest_rotation(r)));
        let (v, w) = (q.vector().into_owned(), q.scalar());
        let (v, w) = if w < 0.0 { (-v, -w) } else { (v, w) };
        let s = v.norm();
        let rvec = if s > 0.0 { v * (2.0 * s.atan2(w) / s) } else { Vector3::zeros() };
        Pose { rvec, t }
    }

    /// The rotation matrix.
    pub fn r(&self) -> Matrix3<f64> {
        *Rotation3::new(self.rvec).matrix()
    }

    /// Apply to a point.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.r() * x + self.t
    }

    /// The composition `self ∘ first` (first applied first).
    pub fn after(&self, first: &Pose) -> Pose {
        let r = self.r();
        Pose::from_rt(&(r * first.r()), r * first.t + self.t)
    }
}

/// The nearest rotation to `m` in the Frobenius norm (polar decomposition by SVD, det +1).
pub fn nearest_rotation(m: &Matrix3<f64>) -> Matrix3<f64> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    u * d * vt
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A rotation vector survives the round trip through its matrix to 10⁻¹⁴ rad at angles from
    /// 10⁻⁷ to π − 10⁻⁶, and a matrix scaled by 1.01 (not orthonormal) gives the same rotation.
    #[test]
    fn from_rt_inverts_the_rotation_matrix_at_every_angle() {
        for angle in [1e-7, 1e-3, 0.5, 1.5, 2.5, 3.0, std::f64::consts::PI - 1e-6] {
            let axis = Vector3::new(0.3, -0.8, 0.52).normalize();
            let v = axis * angle;
            let p = Pose::from_rt(Rotation3::new(v).matrix(), Vector3::zeros());
            assert!((p.rvec - v).norm() < 1e-14 * angle.max(1.0), "{angle}: {:?}", p.rvec - v);
            let q = Pose::from_rt(&(Rotation3::new(v).matrix() * 1.01), Vector3::zeros());
            assert!((q.rvec - v).norm() < 1e-13, "{angle}: {:?}", q.rvec - v);
        }
    }
}
