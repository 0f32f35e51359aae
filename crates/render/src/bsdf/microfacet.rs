//! Microfacet normal distributions (Trowbridge–Reitz/GGX and Beckmann) with Smith
//! masking–shadowing and visible-normal sampling.
//!
//! Local frame: z is the macroscopic surface normal; both distributions may be anisotropic (αx
//! along local x, αy along local y) and are normalised so that ∫ D(m) cos θm dm = 1. With
//! e(m) = tan²θm (cos²φm/αx² + sin²φm/αy²) and α(φ)² = αx² cos²φ + αy² sin²φ:
//! * GGX: D(m) = 1 / (π αx αy cos⁴θm (1 + e)²) (Trowbridge & Reitz 1975; Walter et al. 2007);
//!   Λ(w) = (√(1 + α(φ)² tan²θ) − 1)/2.
//! * Beckmann: D(m) = e^{−e} / (π αx αy cos⁴θm) (Beckmann & Spizzichino 1963; Walter et al. 2007);
//!   Λ(w) = (e^{−a²}/(a√π) − erfc a)/2 with a = 1/(α(φ) tan θ), the exact Smith term (Walter et
//!   al. 2007 eq. 27 before its rational approximation, which Mitsuba 3 uses for G1).
//! * G1(w) = 1/(1 + Λ(w)); height-correlated G2(wo, wi) = 1/(1 + Λ(wo) + Λ(wi)) (Heitz 2014).
//! * Distribution of visible normals D_w(m) = G1(w) max(0, w·m) D(m) / |cos θ_w| (Heitz 2014),
//!   sampled exactly: GGX with Heitz 2018, "Sampling the GGX distribution of visible normals"
//!   (JCGT 7(4)); Beckmann by stretching to α = 1 and inverting the visible-slope distribution
//!   (Heitz & d'Eon 2014): the slope along the view's azimuth has the marginal density
//!   ∝ (cos θ − x sin θ) e^{−x²} on x < cot θ, whose CDF cos θ (1 + erf x)/2 + sin θ e^{−x²}/(2√π)
//!   is inverted by safeguarded Newton steps; the other slope is Gaussian, e^{−y²}/√π.
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

/// The shape of the distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Distribution {
    /// Trowbridge–Reitz (GGX): long tails (pbrt-v4's only distribution).
    #[default]
    Ggx,
    /// Beckmann: Gaussian slopes, short tails (Mitsuba 3's default).
    Beckmann,
}

impl Distribution {
    /// The distribution named in scene files: `"ggx"` or `"beckmann"` (Mitsuba 3's names).
    pub fn from_name(name: &str) -> Option<Distribution> {
        match name {
            "ggx" => Some(Distribution::Ggx),
            "beckmann" => Some(Distribution::Beckmann),
            _ => None,
        }
    }
}

/// A microfacet distribution, possibly anisotropic (αx along local x, αy along local y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// Roughness α along local x (dimensionless, > 0).
    pub alpha_x: f32,
    /// Roughness α along local y (dimensionless, > 0).
    pub alpha_y: f32,
    /// Form of the masking–shadowing term [`Microfacet::g`].
    pub masking: Masking,
    /// Shape of D and its Smith Λ.
    pub distribution: Distribution,
}

#[inline]
fn cos2_phi(w: Vec3, sin2_theta: f32) -> f32 {
    if sin2_theta <= 0.0 {
        1.0
    } else {
        (w.x * w.x / sin2_theta).clamp(0.0, 1.0)
    }
}

const SQRT_PI: f64 = 1.772_453_850_905_516;

/// Smith Λ of the unit-roughness Beckmann distribution at a = 1/(α tan θ) > 0:
/// (e^{−a²}/(a√π) − erfc a)/2 (0 beyond a = 8, where it is below 1e-30).
#[inline]
fn beckmann_lambda(a: f64) -> f64 {
    if a >= 8.0 {
        return 0.0;
    }
    0.5 * ((-a * a).exp() / (a * SQRT_PI) - libm::erfc(a))
}

/// The x with F(x) = target for an increasing F on [lo, hi], by Newton steps kept inside a
/// shrinking bracket (bisection when a step leaves it); `f` returns (F(x), F′(x)).
fn invert_increasing(f: impl Fn(f64) -> (f64, f64), target: f64, mut lo: f64, mut hi: f64, x0: f64) -> f64 {
    let mut x = x0.clamp(lo, hi);
    for _ in 0..60 {
        let (v, dv) = f(x);
        let r = v - target;
        if r.abs() <= 1e-13 * target.abs().max(1e-300) {
            break;
        }
        if r < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        let step = if dv > 0.0 { x - r / dv } else { f64::NAN };
        x = if step > lo && step < hi { step } else { 0.5 * (lo + hi) };
        if hi - lo < 1e-12 {
            break;
        }
    }
    x
}

/// Slopes (x, y) of a unit-roughness Beckmann microfacet visible from a direction of polar
/// angle θ (cos θ, sin θ) and azimuth 0, from u ∈ [0, 1)²; its normal is (−x, −y, 1)/|…|.
fn beckmann_visible_slopes(cos_t: f64, sin_t: f64, u: Vec2) -> (f64, f64) {
    // Marginal of x: ∝ (cos θ − x sin θ) e^{−x²}/√π on x < cot θ, with the CDF
    // F(x) = cos θ (1 + erf x)/2 + sin θ e^{−x²}/(2√π).
    let top = if sin_t > 1e-12 { (cos_t / sin_t).min(8.0) } else { 8.0 };
    let cdf = |x: f64| {
        let g = (-x * x).exp() / SQRT_PI;
        (cos_t * 0.5 * (1.0 + libm::erf(x)) + 0.5 * sin_t * g, (cos_t - x * sin_t) * g)
    };
    let total = cdf(top).0;
    let target = (u.x as f64).clamp(1e-9, 1.0 - 1e-9) * total;
    let x = invert_increasing(cdf, target, -8.0, top, 0.0);
    // y: e^{−y²}/√π, i.e. erf y = 2u − 1.
    let t = (2.0 * u.y as f64 - 1.0).clamp(-1.0 + 1e-12, 1.0 - 1e-12);
    let y = invert_increasing(|y| (libm::erf(y), 2.0 * (-y * y).exp() / SQRT_PI), t, -8.0, 8.0, 0.0);
    (x, y)
}

impl Microfacet {
    /// Isotropic GGX distribution with roughness `alpha`.
    pub fn isotropic(alpha: f32) -> Microfacet {
        Microfacet {
            alpha_x: alpha,
            alpha_y: alpha,
            masking: Masking::HeightCorrelated,
            distribution: Distribution::Ggx,
        }
    }

    /// The same distribution with masking–shadowing term `masking`.
    pub fn with_masking(self, masking: Masking) -> Microfacet {
        Microfacet { masking, ..self }
    }

    /// The same roughness and masking with the distribution's shape `distribution`.
    pub fn with_distribution(self, distribution: Distribution) -> Microfacet {
        Microfacet { distribution, ..self }
    }

    /// The same masking and shape with isotropic roughness `alpha`.
    pub fn with_alpha(self, alpha: f32) -> Microfacet {
        Microfacet { alpha_x: alpha, alpha_y: alpha, ..self }
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
        match self.distribution {
            Distribution::Ggx => 1.0 / (PI * self.alpha_x * self.alpha_y * cos2 * cos2 * (1.0 + e) * (1.0 + e)),
            Distribution::Beckmann => (-e).exp() / (PI * self.alpha_x * self.alpha_y * cos2 * cos2),
        }
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
        match self.distribution {
            Distribution::Ggx => 0.5 * ((1.0 + a2 * tan2).sqrt() - 1.0),
            Distribution::Beckmann => {
                let at2 = a2 as f64 * tan2 as f64;
                if at2 <= 0.0 {
                    return 0.0;
                }
                beckmann_lambda(1.0 / at2.sqrt()) as f32
            }
        }
    }

    /// Smith masking G1(w) = 1/(1 + Λ(w)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Masking–shadowing G2(wo, wi): 1/(1 + Λ(wo) + Λ(wi)) (height-correlated) or G1(wo) G1(wi)
    /// (separable), as [`Microfacet::masking`] says.
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
    /// upper side if below), from u ∈ [0,1)²; its density is [`Microfacet::d_visible`].
    #[inline]
    pub fn sample_visible_normal(&self, w: Vec3, u: Vec2) -> Vec3 {
        let w = if w.z < 0.0 { -w } else { w };
        // Stretch the view direction to the configuration of unit roughness.
        let vh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize();
        if self.distribution == Distribution::Beckmann {
            return self.sample_visible_normal_beckmann(vh, u);
        }
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

    /// Beckmann's visible normal for the stretched (unit-roughness) view direction `vh`.
    fn sample_visible_normal_beckmann(&self, vh: Vec3, u: Vec2) -> Vec3 {
        let (vx, vy, vz) = (vh.x as f64, vh.y as f64, vh.z as f64);
        let sin_t = (vx * vx + vy * vy).sqrt();
        let (cos_p, sin_p) = if sin_t > 1e-12 { (vx / sin_t, vy / sin_t) } else { (1.0, 0.0) };
        let (sx, sy) = beckmann_visible_slopes(vz, sin_t, u);
        // Rotate the slopes to the view's azimuth, then unstretch them.
        let x = (cos_p * sx - sin_p * sy) * self.alpha_x as f64;
        let y = (sin_p * sx + cos_p * sy) * self.alpha_y as f64;
        let n = 1.0 / (1.0 + x * x + y * y).sqrt();
        Vec3::new((-x * n) as f32, (-y * n) as f32, n as f32)
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
        for (ax, ay, distribution) in [(0.1f32, 0.1f32), (0.5, 0.5), (0.2, 0.7), (1.0, 1.0)]
            .into_iter()
            .flat_map(|(ax, ay)| [(ax, ay, Distribution::Ggx), (ax, ay, Distribution::Beckmann)])
        {
            let d = Microfacet {
                alpha_x: ax,
                alpha_y: ay,
                masking: Masking::HeightCorrelated,
                distribution,
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
            assert!((sum - 1.0).abs() < 3e-3, "{distribution:?} ({ax},{ay}): {sum}");
        }
    }

    /// Smith's Λ is consistent with D: the projected area of the visible microsurface equals that
    /// of the macrosurface, ∫ G1(w) max(0, w·m) D(m) dm = cos θ_w (Heitz 2014 eq. 18), by quadrature.
    #[test]
    fn visible_projected_area_is_cos_theta() {
        for (ax, ay, distribution) in [(0.2f32, 0.2f32), (0.6, 0.6), (0.15, 0.5), (1.0, 1.0)]
            .into_iter()
            .flat_map(|(ax, ay)| [(ax, ay, Distribution::Ggx), (ax, ay, Distribution::Beckmann)])
        {
            let d = Microfacet {
                alpha_x: ax,
                alpha_y: ay,
                masking: Masking::HeightCorrelated,
                distribution,
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
                assert!((v - w.z as f64).abs() < 3e-3, "{distribution:?} ({ax},{ay}) w {w}: {v} vs {}", w.z);
            }
        }
    }

    /// Beckmann's exact Smith G1 against Walter et al. 2007's rational approximation (their
    /// eq. 27: (3.535a + 2.181a²)/(1 + 2.276a + 2.577a²) for a < 1.6, else 1), which they give as
    /// accurate to better than 0.35 %.
    #[test]
    fn beckmann_g1_matches_walters_approximation() {
        let d = Microfacet::isotropic(0.3).with_distribution(Distribution::Beckmann);
        for deg in [5.0f32, 30.0, 60.0, 75.0, 80.0, 85.0, 88.0, 89.5] {
            let t = deg.to_radians();
            let w = Vec3::new(t.sin(), 0.0, t.cos());
            let a = 1.0 / (0.3 * t.tan()) as f64;
            let approx = if a < 1.6 { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) } else { 1.0 };
            let g1 = d.g1(w) as f64;
            assert!((g1 / approx - 1.0).abs() < 3.5e-3, "θ {deg}°: exact {g1}, approximation {approx}");
        }
    }

    /// Sampled visible normals follow D_w: histogram of (tan θm, φm) cells against the density
    /// integrated over each cell (anisotropic Beckmann, four view directions, 200 000 samples each).
    #[test]
    fn beckmann_visible_normals_follow_their_density() {
        let d = Microfacet { alpha_x: 0.25, alpha_y: 0.5, masking: Masking::HeightCorrelated, distribution: Distribution::Beckmann };
        let (nt, np) = (12usize, 16usize);
        let tmax = 2.5f64; // tan θm beyond which a cell collects the rest
        for (k, w) in [Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.3, 0.8, 0.2), Vec3::new(0.98, 0.1, 0.05)].into_iter().enumerate() {
            let w = w.normalize();
            let n = 200_000usize;
            let mut hist = vec![0f64; nt * np + 1];
            let mut r = Pcg32::new(17, k as u64);
            for _ in 0..n {
                let m = d.sample_visible_normal(w, r.next_2d());
                let t = ((1.0 - m.z * m.z).max(0.0).sqrt() / m.z) as f64;
                let ph = (m.y as f64).atan2(m.x as f64).rem_euclid(std::f64::consts::TAU);
                let cell = if t >= tmax { nt * np } else { (t / tmax * nt as f64) as usize * np + ((ph / std::f64::consts::TAU * np as f64) as usize).min(np - 1) };
                hist[cell] += 1.0;
            }
            // Expected counts by a 12 × 12 midpoint rule inside each cell (dω = sinθ dθ dφ).
            let mut expect = vec![0f64; nt * np + 1];
            let sub = 12usize;
            for i in 0..nt {
                for j in 0..np {
                    let mut e = 0.0;
                    for a in 0..sub {
                        let t = tmax * (i as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64;
                        let dt = tmax / (nt * sub) as f64;
                        let th = t.atan();
                        let dth = dt / (1.0 + t * t);
                        for b in 0..sub {
                            let ph = std::f64::consts::TAU * (j as f64 + (b as f64 + 0.5) / sub as f64) / np as f64;
                            let m = Vec3::new((th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, th.cos() as f32);
                            e += d.d_visible(w, m) as f64 * th.sin() * dth * std::f64::consts::TAU / (np * sub) as f64;
                        }
                    }
                    expect[i * np + j] = e * n as f64;
                }
            }
            expect[nt * np] = n as f64 - expect[..nt * np].iter().sum::<f64>();
            // Pearson χ² over cells expecting at least 20 samples; the rest are pooled.
            let (mut chi2, mut dof, mut pool_o, mut pool_e) = (0.0, 0usize, 0.0, 0.0);
            for (o, e) in hist.iter().zip(&expect) {
                if *e >= 20.0 {
                    chi2 += (o - e) * (o - e) / e;
                    dof += 1;
                } else {
                    pool_o += o;
                    pool_e += e;
                }
            }
            if pool_e > 0.0 {
                chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1.0);
                dof += 1;
            }
            // χ² with ν ≈ dof − 1 degrees of freedom: mean ν, sd √(2ν); 6 sd is p ≈ 1e-6.
            let nu = (dof - 1) as f64;
            assert!(chi2 < nu + 6.0 * (2.0 * nu).sqrt(), "w {w}: χ² {chi2} over {dof} cells");
        }
    }

    /// Sampled visible normals are unit, on the upper side and never back-facing to w.
    #[test]
    fn visible_normals_face_the_viewer() {
        for distribution in [Distribution::Ggx, Distribution::Beckmann] {
            let d = Microfacet {
                alpha_x: 0.3,
                alpha_y: 0.6,
                masking: Masking::HeightCorrelated,
                distribution,
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
