//! Trowbridge–Reitz (GGX) microfacet distribution with Smith masking–shadowing and
//! visible-normal sampling.
//!
//! Local frame: z is the macroscopic surface normal. Formulas:
//! * D(m) = 1 / (π αx αy cos⁴θm (1 + tan²θm (cos²φm/αx² + sin²φm/αy²))²)  (Trowbridge & Reitz 1975;
//!   Walter et al. 2007), normalised so that ∫ D(m) cos θm dm = 1.
//! * Smith Λ(w) = (√(1 + α(φ)² tan²θ) − 1)/2 with α(φ)² = αx² cos²φ + αy² sin²φ;
//!   G1(w) = 1/(1 + Λ(w)); height-correlated G2(wo, wi) = 1/(1 + Λ(wo) + Λ(wi)) (Heitz 2014).
//! * Distribution of visible normals D_w(m) = G1(w) max(0, w·m) D(m) / |cos θ_w| (Heitz 2014),
//!   sampled exactly with Heitz 2018, "Sampling the GGX distribution of visible normals" (JCGT 7(4)).
//!
//! Roughness mapping: scene files give a perceptual `roughness` r ∈ [0, 1] and α = r²
//! (Burley 2012); [`roughness_to_alpha`] states it. An α below [`SMOOTH_ALPHA`] is treated as a
//! perfectly smooth (delta) interface by the materials.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this α the materials use the smooth (delta) lobe instead of the microfacet one.
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// α = roughness² (Burley 2012's perceptual mapping); `roughness` is clamped to [0, 1].
#[inline]
pub fn roughness_to_alpha(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    r * r
}

/// How the Smith masking–shadowing term of a pair of directions is formed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Masking {
    /// G2 = 1/(1 + Λ(ωo) + Λ(ωi)): masking and shadowing correlated through the microsurface's
    /// heights (Heitz 2014, the more accurate form; pbrt-v4's).
    #[default]
    HeightCorrelated,
    /// G2 = G1(ωo) G1(ωi), never larger (Mitsuba 3's).
    Separable,
}

impl Masking {
    /// The form named in scene files: `"height-correlated"` or `"separable"`.
    pub fn from_name(name: &str) -> Option<Masking> {
        match name {
            "height-correlated" => Some(Masking::HeightCorrelated),
            "separable" => Some(Masking::Separable),
            _ => None,
        }
    }
}

/// Trowbridge–Reitz (GGX) distribution, possibly anisotropic (αx along local x, αy along local y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrowbridgeReitz {
    /// Roughness α along local x (dimensionless, > 0).
    pub alpha_x: f32,
    /// Roughness α along local y (dimensionless, > 0).
    pub alpha_y: f32,
    /// Form of the masking–shadowing term [`TrowbridgeReitz::g`].
    pub masking: Masking,
}

#[inline]
fn cos2_phi(w: Vec3, sin2_theta: f32) -> f32 {
    if sin2_theta <= 0.0 {
        1.0
    } else {
        (w.x * w.x / sin2_theta).clamp(0.0, 1.0)
    }
}

impl TrowbridgeReitz {
    /// Isotropic distribution with roughness `alpha`.
    pub fn isotropic(alpha: f32) -> TrowbridgeReitz {
        TrowbridgeReitz {
            alpha_x: alpha,
            alpha_y: alpha,
            masking: Masking::HeightCorrelated,
        }
    }

    /// The same distribution with masking–shadowing term `masking`.
    pub fn with_masking(self, masking: Masking) -> TrowbridgeReitz {
        TrowbridgeReitz { masking, ..self }
    }

    /// True when both α are below [`SMOOTH_ALPHA`] (use the delta lobe).
    #[inline]
    pub fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// Microfacet normal density D(m) per steradian of m (projected-area normalised).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        let cos2 = m.z * m.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 <= 0.0 {
            return 0.0;
        }
        let tan2 = sin2 / cos2;
        let c2 = cos2_phi(m, sin2);
        let s2 = 1.0 - c2;
        let e = tan2 * (c2 / (self.alpha_x * self.alpha_x) + s2 / (self.alpha_y * self.alpha_y));
        1.0 / (PI * self.alpha_x * self.alpha_y * cos2 * cos2 * (1.0 + e) * (1.0 + e))
    }

    /// Smith Λ(w) for this distribution (∞ at grazing).
    #[inline]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        let sin2 = (1.0 - cos2).max(0.0);
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = sin2 / cos2;
        let c2 = cos2_phi(w, sin2);
        let a2 = self.alpha_x * self.alpha_x * c2 + self.alpha_y * self.alpha_y * (1.0 - c2);
        0.5 * ((1.0 + a2 * tan2).sqrt() - 1.0)
    }

    /// Smith masking G1(w) = 1/(1 + Λ(w)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking–shadowing G2(wo, wi): 1/(1 + Λ(wo) + Λ(wi)) (height-correlated) or G1(wo) G1(wi)
    /// (separable), as [`TrowbridgeReitz::masking`] says.
    #[inline]
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self.masking {
            Masking::HeightCorrelated => 1.0 / (1.0 + self.lambda(wo) + self.lambda(wi)),
            Masking::Separable => self.g1(wo) * self.g1(wi),
        }
    }

    /// Density per steradian of visible normals D_w(m) = G1(w)·max(0, w·m)·D(m)/|cos θ_w|, with w
    /// taken on the upper side (w is flipped when w.z < 0; m must be on the upper side).
    #[inline]
    pub fn d_visible(&self, w: Vec3, m: Vec3) -> f32 {
        let w = if w.z < 0.0 { -w } else { w };
        if w.z <= 0.0 {
            return 0.0;
        }
        let wm = w.dot(m);
        if wm <= 0.0 {
            return 0.0;
        }
        self.g1(w) * wm * self.d(m) / w.z
    }

    /// Sample a visible microfacet normal (upper hemisphere) for direction `w` (flipped to the
    /// upper side if below), from u ∈ [0,1)²; its density is [`TrowbridgeReitz::d_visible`].
    #[inline]
    pub fn sample_visible_normal(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        // Stretch the view direction to the configuration of a unit-roughness hemisphere.
        let vh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        // Orthonormal basis around vh (t1 horizontal).
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 1e-14 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // Uniform point on the unit disk, then squash the half of it hidden by the projected
        // hemisphere towards the visible half (scale by (1 + vh.z)/2 along t2).
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let mut p2 = r * phi.sin();
        let s = 0.5 * (1.0 + vh.z);
        p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        // Lift to the hemisphere, then unstretch.
        let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

/// Mirror reflection of `w` about the unit normal `n`: 2(w·n)n − w.
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// Refraction of `wi` (pointing away from the surface) through the interface with unit normal `n`
/// and relative index `eta` = n_(side opposite to n)/n_(side of n). Handles `wi` on either side.
/// Returns (wt, etap) with etap the ratio n_t/n_i actually crossed, or `None` under total
/// internal reflection.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let mut cos_i = n.dot(wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wi / eta + (cos_i / eta - cos_t) * n, eta))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    /// ∫ D(m) cos θm dm = 1 (projected area of the microsurface equals the macro area), by quadrature.
    #[test]
    fn projected_area_is_one() {
        for (ax, ay) in [(0.1f32, 0.1f32), (0.5, 0.5), (0.2, 0.7), (1.0, 1.0)] {
            let d = TrowbridgeReitz {
                alpha_x: ax,
                alpha_y: ay,
                masking: Masking::HeightCorrelated,
            };
            // substitute t = tan θ to resolve the narrow peak: dω = sinθ dθ dφ, θ = atan t
            let (nt, np) = (4000, 256);
            let tmax = 2000.0f64;
            let mut sum = 0.0f64;
            for i in 0..nt {
                // t = tmax·s²: dense near 0
                let s = (i as f64 + 0.5) / nt as f64;
                let t = tmax * s * s;
                let dt = tmax * 2.0 * s / nt as f64;
                let th = t.atan();
                let dth = dt / (1.0 + t * t);
                for j in 0..np {
                    let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                    let m = Vec3::new(
                        (th.sin() * ph.cos()) as f32,
                        (th.sin() * ph.sin()) as f32,
                        th.cos() as f32,
                    );
                    sum += d.d(m) as f64 * th.cos() * th.sin() * dth * 2.0 * std::f64::consts::PI / np as f64;
                }
            }
            assert!((sum - 1.0).abs() < 3e-3, "({ax},{ay}): {sum}");
        }
    }

    /// Smith's Λ is consistent with D: the projected area of the visible microsurface equals that
    /// of the macrosurface, ∫ G1(w) max(0, w·m) D(m) dm = cos θ_w (Heitz 2014 eq. 18), by quadrature.
    #[test]
    fn visible_projected_area_is_cos_theta() {
        for (ax, ay) in [(0.2f32, 0.2f32), (0.6, 0.6), (0.15, 0.5), (1.0, 1.0)] {
            let d = TrowbridgeReitz {
                alpha_x: ax,
                alpha_y: ay,
                masking: Masking::HeightCorrelated,
            };
            for w in [
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(0.6, 0.0, 0.8),
                Vec3::new(0.3, 0.8, 0.3),
                Vec3::new(-0.9, 0.3, 0.15),
            ] {
                let w = w.normalize();
                let (nt, np) = (3000, 512);
                let tmax = 1000.0f64;
                let mut sum = 0.0f64;
                for i in 0..nt {
                    let s = (i as f64 + 0.5) / nt as f64;
                    let t = tmax * s * s;
                    let dth = tmax * 2.0 * s / nt as f64 / (1.0 + t * t);
                    let th = t.atan();
                    for j in 0..np {
                        let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                        let m = Vec3::new(
                            (th.sin() * ph.cos()) as f32,
                            (th.sin() * ph.sin()) as f32,
                            th.cos() as f32,
                        );
                        let wm = w.dot(m).max(0.0) as f64;
                        sum += d.d(m) as f64 * wm * th.sin() * dth * 2.0 * std::f64::consts::PI / np as f64;
                    }
                }
                let v = sum * d.g1(w) as f64;
                assert!((v - w.z as f64).abs() < 3e-3, "({ax},{ay}) w {w}: {v} vs {}", w.z);
            }
        }
    }

    /// Sampled visible normals are unit, on the upper side and never back-facing to w.
    #[test]
    fn visible_normals_face_the_viewer() {
        let d = TrowbridgeReitz {
            alpha_x: 0.3,
            alpha_y: 0.6,
            masking: Masking::HeightCorrelated,
        };
        let mut r = Pcg32::new(3, 4);
        for _ in 0..10_000 {
            let w = crate::math::sampling::uniform_sphere(r.next_2d());
            let m = d.sample_visible_normal(w, r.next_2d());
            assert!((m.length() - 1.0).abs() < 1e-4 && m.z > 0.0);
            let wu = if w.z < 0.0 { -w } else { w };
            assert!(wu.dot(m) > -1e-4, "{w} {m}");
        }
    }

    #[test]
    fn refract_obeys_snell() {
        let n = Vec3::Z;
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (wt, etap) = refract(wi, n, 1.5).unwrap();
        assert_eq!(etap, 1.5);
        // sin θt = sin θi / 1.5
        assert!((wt.x.abs() - 0.6 / 1.5).abs() < 1e-6 && wt.z < 0.0 && (wt.length() - 1.0).abs() < 1e-6);
        // Reversible: refracting wt (below) back gives wi, crossing 1/1.5.
        let (wb, e2) = refract(wt, n, 1.5).unwrap();
        assert!((e2 - 1.0 / 1.5).abs() < 1e-6 && (wb - wi).length() < 1e-5, "{wb}");
        // TIR from inside beyond the critical angle (sin θc = 1/1.5).
        assert!(refract(Vec3::new(0.8, 0.0, -0.6), n, 1.5).is_none());
    }
}
