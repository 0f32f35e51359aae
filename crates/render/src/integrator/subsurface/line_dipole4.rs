//! The line-source directional dipole ([`optics::bssrdf::DirectionalLineDipole`]) evaluated for
//! the four wavelengths of a path at once, in single precision.
//!
//! The point-cloud method evaluates S_d hundreds of times per shading point, and at 512×512 (the
//! size of `lucent bench bssrdf`) the queries are most of a BSSRDF render's time. The reference model in `optics` is
//! written for clarity, one wavelength at a time in f64 with `exp` from libm: 4 lanes × 6 nodes ×
//! (real + virtual) = 48 exponentials per cloud point. Here the geometry shared by the lanes (the
//! modified tangent plane, the mirrored direction and their dot products) is computed once, the
//! refracted direction is computed once per cloud point (by the caller), and each quadrature node
//! evaluates its real and virtual monopoles for the four lanes with `glam::Vec4` arithmetic and a
//! vectorised exponential ([`crate::math::fastexp::exp4`]). The terms are those of the reference, in the same order; a test
//! checks the result against it (relative 1e-4 of the lane's value, absolute 1e-6 of the
//! configuration's largest lane).

use crate::math::fastexp::exp4;
use glam::{Vec3, Vec4};
use optics::bssrdf::{DirectionalLineDipole, LINE_SOURCE_NODES};

/// Lane-wise square root (one `sqrtps` after optimisation).
#[inline(always)]
fn sqrt4(x: Vec4) -> Vec4 {
    Vec4::from_array(x.to_array().map(f32::sqrt))
}

/// The line-source directional dipole of four wavelength lanes, single precision. Lanes whose
/// model is missing (α' = 0, nothing diffuses) evaluate to 0.
#[derive(Clone, Copy, Debug)]
pub struct LineDipole4 {
    /// σ_tr per lane (m⁻¹).
    sigma_tr: Vec4,
    /// C_φ/D per lane (m⁻¹).
    c_phi_over_d: Vec4,
    /// C_E per lane.
    c_e: Vec4,
    /// Normalisation 1/(4C_φ(1/η)) · 1/(4π²), 0 on missing lanes.
    norm: Vec4,
    /// Offset 2 A d_e of the virtual source along the modified normal (m).
    virtual_offset_m: Vec4,
    /// Squared smoothing length (1/(3σ_t))² of back-lit exit points (m²).
    back_eps2_m2: Vec4,
    /// Smallest squared distance to a real node, (10⁻³/σ'_t)² (m²).
    min_d2_m2: Vec4,
    /// Node distances t_k along the refracted ray (m), per lane.
    t_m: [Vec4; LINE_SOURCE_NODES],
    /// Node weights (Σ = α'), per lane; 0 on missing lanes.
    w: [Vec4; LINE_SOURCE_NODES],
}

impl LineDipole4 {
    /// Packs the lanes' reference models (`None`: a lane where nothing diffuses).
    pub fn new(lanes: [Option<&DirectionalLineDipole>; 4]) -> LineDipole4 {
        let get = |f: &dyn Fn(&DirectionalLineDipole) -> f64, missing: f32| {
            Vec4::from_array(lanes.map(|l| l.map_or(missing, |m| f(m) as f32)))
        };
        let mut t_m = [Vec4::ONE; LINE_SOURCE_NODES];
        let mut w = [Vec4::ZERO; LINE_SOURCE_NODES];
        for k in 0..LINE_SOURCE_NODES {
            t_m[k] = get(&|m| m.nodes[k].0, 1.0);
            w[k] = get(&|m| m.nodes[k].1, 0.0);
        }
        LineDipole4 {
            sigma_tr: get(&|m| m.base.props.sigma_tr_per_m, 1.0),
            c_phi_over_d: get(&|m| m.base.c_phi / m.base.props.d_m, 0.0),
            c_e: get(&|m| m.base.c_e, 0.0),
            norm: get(&|m| m.base.norm, 0.0),
            virtual_offset_m: get(&|m| 2.0 * m.base.a * m.base.d_e_m, 1.0),
            back_eps2_m2: get(&|m| (1.0 / (3.0 * m.base.props.sigma_t_per_m)).powi(2), 0.0),
            min_d2_m2: get(&|m| (1e-3 / m.base.props.sigma_t_prime_per_m).powi(2), 1e-30),
            t_m,
            w,
        }
    }

    /// Real minus virtual monopole term of every lane for squared distances `d2` and the offsets'
    /// components `h` along the exit normal.
    #[inline(always)]
    fn monopole(&self, d2: Vec4, h: Vec4) -> Vec4 {
        let d = sqrt4(d2);
        let std = self.sigma_tr * d;
        exp4(-std) / (d2 * d) * (self.c_phi_over_d * d2 + self.c_e * (Vec4::ONE + std) * h)
    }

    /// S_d(xᵢ, ω₁₂; xₒ) (m⁻² sr⁻¹) of the four lanes, clamped at 0: `w12` is the refracted
    /// direction into the medium (unit), `ni`, `no` the outward unit normals at the incidence
    /// point `xi` and the exit point `xo` (m). Same terms as
    /// [`DirectionalLineDipole::sd_refracted`].
    #[inline]
    pub fn sd_refracted(&self, xi: Vec3, ni: Vec3, w12: Vec3, xo: Vec3, no: Vec3) -> Vec4 {
        let x = xo - xi;
        let r2 = x.dot(x);
        let mu0 = -no.dot(w12);
        let eps2 = if mu0 > 0.0 {
            Vec4::ZERO
        } else {
            self.back_eps2_m2
        };
        // Modified tangent plane: normal nᵢ* = (x/|x|) × (nᵢ × x)/|nᵢ × x|.
        let t = ni.cross(x);
        let tl2 = t.dot(t);
        let ni_star = if r2 < 1e-30 || tl2 <= 1e-30 * r2 {
            ni
        } else {
            (x * r2.sqrt().recip()).cross(t * tl2.sqrt().recip())
        };
        let wv = w12 - 2.0 * w12.dot(ni_star) * ni_star;
        let (xw, xn, wn) = (x.dot(w12), x.dot(no), w12.dot(no));
        let (xs, xwv, sw, sn, wvn) = (
            x.dot(ni_star),
            x.dot(wv),
            ni_star.dot(wv),
            ni_star.dot(no),
            wv.dot(no),
        );
        // Virtual source at xᵢ + o nᵢ*: xₒ − x_v = x − o nᵢ*.
        let o = self.virtual_offset_m;
        let v2 = Vec4::splat(r2) - o * (2.0 * xs) + o * o;
        let vw = Vec4::splat(xwv) - o * sw;
        let vn = Vec4::splat(xn) - o * sn;
        let (r2v, xwv4, xnv, wnv, wvnv) = (
            Vec4::splat(r2),
            Vec4::splat(2.0 * xw),
            Vec4::splat(xn),
            Vec4::splat(wn),
            Vec4::splat(wvn),
        );
        let two_vw = vw * 2.0;
        let mut s = Vec4::ZERO;
        for k in 0..LINE_SOURCE_NODES {
            let tk = self.t_m[k];
            let d2r = (r2v + tk * (tk - xwv4)).max(self.min_d2_m2) + eps2;
            let real = self.monopole(d2r, xnv - tk * wnv);
            let d2v = (v2 + tk * (tk - two_vw)).max(Vec4::splat(f32::MIN_POSITIVE));
            let virt = self.monopole(d2v, vn - tk * wvnv);
            s += self.w[k] * (real - virt);
        }
        (s * self.norm).max(Vec4::ZERO)
    }
}

/// Refracted direction ω₁₂ into a medium of relative index `eta` for the direction `wi` towards
/// the light (unit, on the side of the outward unit normal `ni`); as
/// [`optics::bssrdf::DirectionalDipole::refract_in`].
pub fn refract_in(wi: Vec3, ni: Vec3, eta: f32) -> Vec3 {
    let inv = 1.0 / eta;
    let c = wi.dot(ni);
    let k = (1.0 - inv * inv * (1.0 - c * c)).max(0.0).sqrt();
    inv * (c * ni - wi) - k * ni
}

#[cfg(test)]
mod tests {
    use super::*;
    use optics::bssrdf::OpticalProperties;

    /// The packed evaluator against the reference f64 model, lane by lane, over random
    /// configurations on a sphere and a plane (front- and back-lit, near and far).
    #[test]
    fn packed_line_dipole_matches_reference_model() {
        // Four lanes of different media (potato-, marble-, skim-milk-like and a strong absorber).
        let props = [
            (1.3, 700.0, 9.0, 0.0),
            (1.5, 2620.0, 4.1, 0.0),
            (1.35, 1300.0, 1.5, 0.2),
            (1.5, 500.0, 300.0, 0.5),
        ];
        let eta = 1.4f64;
        let models: Vec<DirectionalLineDipole> = props
            .iter()
            .map(|&(_, s, a, g)| {
                DirectionalLineDipole::new(&OpticalProperties {
                    eta,
                    sigma_s_per_m: s,
                    sigma_a_per_m: a,
                    g,
                })
                .unwrap()
            })
            .collect();
        let packed = LineDipole4::new([
            Some(&models[0]),
            Some(&models[1]),
            Some(&models[2]),
            Some(&models[3]),
        ]);
        let mut rng = crate::math::sampling::Pcg32::new(7, 11);
        let radius = 0.02f32;
        let on_sphere = |u: glam::Vec2| {
            let z = 1.0 - 2.0 * u.x;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * u.y;
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        };
        let (mut checked, mut nonzero) = (0, 0);
        for case in 0..4000 {
            let (xi, ni, xo, no) = if case % 2 == 0 {
                let ni = on_sphere(rng.next_2d());
                // Exit points concentrated near the entry (the values that matter).
                let mut no = (ni + 0.3 * on_sphere(rng.next_2d()) * rng.next_f32()).normalize();
                if case % 8 == 0 {
                    no = on_sphere(rng.next_2d());
                }
                (ni * radius, ni, no * radius, no)
            } else {
                let n = Vec3::Z;
                let r = 0.01 * rng.next_f32().powi(3);
                let phi = std::f32::consts::TAU * rng.next_f32();
                (Vec3::ZERO, n, Vec3::new(r * phi.cos(), r * phi.sin(), 0.0), n)
            };
            // Direction towards the light: cosine-like over the hemisphere of ni.
            let mut wi = on_sphere(rng.next_2d());
            if wi.dot(ni) < 0.0 {
                wi = -wi;
            }
            let w12 = refract_in(wi, ni, eta as f32);
            let got = packed.sd_refracted(xi, ni, w12, xo, no);
            let c = |v: Vec3| [v.x as f64, v.y as f64, v.z as f64];
            let want: Vec<f64> = models
                .iter()
                .map(|m| m.sd_refracted(c(xi), c(ni), c(w12), c(xo), c(no)))
                .collect();
            let big = want.iter().cloned().fold(0.0, f64::max);
            for k in 0..4 {
                let err = (got[k] as f64 - want[k]).abs();
                assert!(
                    err <= 1e-4 * want[k] + 1e-6 * big + 1e-30,
                    "case {case} lane {k}: packed {} vs reference {} (xi {xi}, xo {xo}, ni {ni}, no {no}, w12 {w12})",
                    got[k],
                    want[k]
                );
                checked += 1;
                nonzero += (want[k] > 0.0) as usize;
            }
        }
        assert!(nonzero > checked / 2, "{nonzero} of {checked} values non-zero");
        // A missing lane is 0 and does not disturb the others.
        let part = LineDipole4::new([Some(&models[0]), None, Some(&models[2]), None]);
        let (xi, xo, n) = (Vec3::ZERO, Vec3::new(0.002, 0.0, 0.0), Vec3::Z);
        let full = packed.sd_refracted(xi, n, -n, xo, n);
        let got = part.sd_refracted(xi, n, -n, xo, n);
        assert_eq!((got[0], got[1], got[2], got[3]), (full[0], 0.0, full[2], 0.0));
    }
}
