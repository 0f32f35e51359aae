//! Area lights seen through one smooth refracting plane: a direction proposal for a point inside
//! a dense medium whose boundary is a smooth dielectric.
//!
//! Inside such a medium next-event estimation is blocked by the boundary, so light is found only
//! by phase-sampled directions that happen to leave through the boundary towards a light. For a
//! point `p` near the boundary, this proposal treats the boundary as the plane tangent where a
//! probe ray leaves (point `e`, outward normal `n`, index inside / outside `η`): it picks a point
//! `y` on an area light (uniformly by area on its triangles) and returns the inside direction
//! from `p` towards the refraction point `s` on that plane that Snell's law joins to `y` (the
//! root of a monotonic function of the distance along the plane, Newton's method with bisection).
//! `volpath` mixes it with phase sampling (defensive mixture, Hesterberg 1995) and then traces
//! the actual boundary, so the plane is only a guess of where the light goes: the estimate stays
//! unbiased whatever the real boundary's shape, and only its variance depends on the guess.
//!
//! Density of the proposed direction per steradian at `p`: for each light point `y` that the
//! direction reaches through the plane, (choice of light) / area / (dω₁/dA_y), with the
//! generalised geometry term of one planar refraction (d₁, d₂ the distances of `p` and `y` from
//! the plane, θ₁, θ₂ the angles from its normal inside and outside, θ_y the angle at the light):
//!
//! ```text
//! dω₁/dA_y = |cos θ_y| / [ cos θ₂ · (d₁/cos θ₁ + η d₂/cos θ₂) · (d₁/cos² θ₁ + η d₂ cos θ₁/cos³ θ₂) ]
//! ```
//!
//! (from ρ = d₁ tan θ₁ + d₂ tan θ₂ with sin θ₂ = η sin θ₁ over the circle of radius ρ; for
//! η = 1 it is |cos θ_y|/r²). Tests: the closed form against finite differences of the map
//! y ↦ ω₁, the density integrating to the probability that a sample exists, and sampling and
//! evaluation agreeing (`refracted::tests`).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::light::{Emitter, Light};
use crate::math::sampling::{sample_cdf, uniform_triangle};
use glam::{DVec3, Vec2, Vec3};

/// Most triangles an area light may have to take part (the density sums over all of them).
pub const MAX_TRIANGLES: usize = 64;

/// The plane a proposal refracts through.
#[derive(Clone, Copy, Debug)]
pub struct RefractingPlane {
    /// A point of the plane (m).
    pub point: Vec3,
    /// Unit normal pointing out of the medium, towards the lights.
    pub normal: Vec3,
    /// Refractive index on the medium's side divided by the index on the lights' side.
    pub eta: f32,
}

impl RefractingPlane {
    /// Where the inside direction `w` (unit) from `p` meets the plane and leaves it: the normal,
    /// the distance d₁ (m) of `p` from the plane, cos θ₁ = w·n, the crossing point and the
    /// refracted direction; `None` when `w` does not head out through it or is totally reflected.
    #[inline]
    fn crossing(&self, p: Vec3, w: Vec3) -> Option<(Vec3, f32, f32, Vec3, Vec3)> {
        let n = self.normal;
        let c1 = w.dot(n);
        let d1 = n.dot(self.point - p);
        if !(c1 > 0.0) || !(d1 > 0.0) {
            return None;
        }
        let w2 = refract_out(w, n, self.eta)?;
        Some((n, d1, c1, p + w * (d1 / c1), w2))
    }
}

#[derive(Clone, Debug)]
struct Entry {
    /// Each triangle as (p0, p1 − p0, p2 − p0, unit normal), as [`Emitter::Triangles`] stores it.
    tris: Vec<[Vec3; 4]>,
    /// Cumulative triangle areas (m²).
    cdf: Vec<f32>,
    /// Total area (m²).
    area_m2: f32,
}

/// The area lights a refracted proposal aims at, with the probabilities of choosing them.
#[derive(Clone, Debug)]
pub struct RefractedLights {
    /// Largest probability with which a medium vertex uses the proposal instead of phase sampling
    /// (`volpath` lowers it with the distance to the boundary); in (0, 1).
    pub alpha_max: f32,
    /// Expected number of extra phase-function samples at a medium vertex on the boundary
    /// (`volpath` lowers it with the distance as it does `alpha_max`); 0: none.
    pub splits: f32,
    entries: Vec<Entry>,
    /// Probability of each entry.
    prob: Vec<f32>,
    /// Cumulative of `prob`.
    cdf: Vec<f32>,
    /// The area-weighted centre of the most probable light (m): probe rays aim at it.
    pub target: Vec3,
}

impl RefractedLights {
    /// The triangle-mesh area lights of at most [`MAX_TRIANGLES`] triangles, chosen in proportion
    /// to their next-event probabilities `light_pmf`, with `splits` extra phase samples at the
    /// boundary ([`Self::splits`]); `None` when there is none or `alpha_max` is not in (0, 1).
    pub fn new(lights: &[Light], light_pmf: &[f32], alpha_max: f32, splits: f32) -> Option<RefractedLights> {
        if !(alpha_max > 0.0 && alpha_max < 1.0) {
            return None;
        }
        let mut entries = Vec::new();
        let mut weights = Vec::new();
        let mut target = Vec3::ZERO;
        let mut best = 0.0f32;
        for (l, &pmf) in lights.iter().zip(light_pmf) {
            let Light::Area { emitter: Emitter::Triangles { tris, cdf, .. }, .. } = l else { continue };
            let area = *cdf.last().unwrap_or(&0.0);
            if tris.len() > MAX_TRIANGLES || !(area > 0.0) || !(pmf > 0.0) {
                continue;
            }
            if pmf > best {
                best = pmf;
                let mut c = Vec3::ZERO;
                let mut prev = 0.0;
                for (t, &a) in tris.iter().zip(cdf) {
                    c += (t[0] + (t[1] + t[2]) / 3.0) * (a - prev);
                    prev = a;
                }
                target = c / area;
            }
            entries.push(Entry { tris: tris.clone(), cdf: cdf.clone(), area_m2: area });
            weights.push(pmf);
        }
        if entries.is_empty() {
            return None;
        }
        let total: f32 = weights.iter().sum();
        let prob: Vec<f32> = weights.iter().map(|w| w / total).collect();
        let mut acc = 0.0;
        let cdf = prob.iter().map(|p| {
            acc += p;
            acc
        }).collect();
        Some(RefractedLights { alpha_max, splits, entries, prob, cdf, target })
    }

    /// A direction from `p` (inside, below `plane`) proposed towards a uniformly chosen point of
    /// a light refracted through `plane`, and its density per steradian ([`Self::pdf`]). `None`
    /// when the light point is not above the plane (the proposal then has no sample).
    pub fn sample(&self, plane: &RefractingPlane, p: Vec3, u_pick: f32, u: Vec2) -> Option<(Vec3, f32)> {
        let (i, ur) = if self.cdf.len() == 1 { (0, u_pick) } else { sample_cdf(&self.cdf, u_pick) };
        let e = &self.entries[i];
        let (k, ur) = if e.cdf.len() == 1 { (0, ur) } else { sample_cdf(&e.cdf, ur) };
        let t = &e.tris[k];
        let b = uniform_triangle(Vec2::new(ur, u.y));
        let y = t[0] + t[1] * b.x + t[2] * b.y;
        let s = refraction_point(plane, p, y)?;
        let w = (s - p).normalize_or_zero();
        if w == Vec3::ZERO {
            return None;
        }
        let pdf = self.pdf(plane, p, w);
        (pdf > 0.0 && pdf.is_finite()).then_some((w, pdf))
    }

    /// Whether the inside direction `w` (unit) from `p`, refracted at the plane, meets one of
    /// the lights (single precision; a cheap test that needs no ray cast), and if so the distance
    /// (m) from `p` to the plane along `w`.
    pub fn reaches(&self, plane: &RefractingPlane, p: Vec3, w: Vec3) -> Option<f32> {
        let (_, d1, c1, s, w2) = plane.crossing(p, w)?;
        self.entries.iter().any(|e| e.tris.iter().any(|tri| hits_triangle(s, w2, tri))).then_some(d1 / c1)
    }

    /// Density per steradian with which [`Self::sample`] proposes the inside direction `w` (unit)
    /// from `p`: the sum over the lights' points that `w`, refracted at the plane, reaches.
    pub fn pdf(&self, plane: &RefractingPlane, p: Vec3, w: Vec3) -> f32 {
        let Some((n, d1, c1, s, w2)) = plane.crossing(p, w) else { return 0.0 };
        let mut pdf = 0.0;
        for (e, &pr) in self.entries.iter().zip(&self.prob) {
            for t in &e.tris {
                let Some(dist) = ray_triangle(s, w2, t) else { continue };
                let j = geometry_term(plane.eta, d1, c1, dist * w2.dot(n), w2.dot(n), w2.dot(t[3]).abs());
                if j > 0.0 {
                    pdf += pr / (e.area_m2 * j);
                }
            }
        }
        pdf
    }
}

/// Direction after refraction out through a plane with outward normal `n` (index ratio
/// inside / outside `eta`) of the inside direction `w` (unit, w·n > 0); `None` at total internal
/// reflection.
pub fn refract_out(w: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let c1 = w.dot(n);
    let sin2 = eta * eta * (1.0 - c1 * c1).max(0.0);
    if sin2 >= 1.0 {
        return None;
    }
    let c2 = (1.0 - sin2).sqrt();
    Some((eta * (w - n * c1) + n * c2).normalize())
}

/// The generalised geometry term dω₁/dA_y (m⁻²) of one planar refraction (module
/// documentation): `d1`, `d2` the distances (m) of the inside point and the light point from
/// the plane, `c1`, `c2` the cosines of the inside and outside directions with its normal,
/// `cos_y` the cosine at the light point.
pub fn geometry_term(eta: f32, d1: f32, c1: f32, d2: f32, c2: f32, cos_y: f32) -> f32 {
    let (eta, d1, c1, d2, c2) = (eta as f64, d1 as f64, c1 as f64, d2 as f64, c2 as f64);
    let a = d1 / c1 + eta * d2 / c2;
    let b = d1 / (c1 * c1) + eta * d2 * c1 / (c2 * c2 * c2);
    let den = c2 * a * b;
    if !(den > 0.0) {
        return 0.0;
    }
    (cos_y as f64 / den) as f32
}

/// The point on `plane` where a path from `p` (inside, below it) to `y` (outside, above it)
/// refracts by Snell's law; `None` when `p` or `y` is on the wrong side.
pub fn refraction_point(plane: &RefractingPlane, p: Vec3, y: Vec3) -> Option<Vec3> {
    refraction_point_f64(plane.eta as f64, plane.normal.as_dvec3(), plane.point.as_dvec3(), p.as_dvec3(), y.as_dvec3()).map(|s| s.as_vec3())
}

/// [`refraction_point`] in double precision: plane through `e` with unit normal `n`.
fn refraction_point_f64(eta: f64, n: DVec3, e: DVec3, pd: DVec3, yd: DVec3) -> Option<DVec3> {
    let d1 = n.dot(e - pd);
    let d2 = n.dot(yd - e);
    if !(d1 > 0.0) || !(d2 > 0.0) {
        return None;
    }
    let h = (yd - pd) - n * n.dot(yd - pd);
    let l = h.length();
    let foot = pd + n * d1;
    if !(l > 1e-12 * (d1 + d2)) {
        return Some(foot);
    }
    let u = h / l;
    let x = snell_offset(eta, d1, d2, l);
    Some(foot + u * x)
}

/// The distance x ∈ (0, l) along the plane from the foot of the inside point at which
/// η x/√(x² + d₁²) = (l − x)/√((l − x)² + d₂²) (Snell's law; the left side minus the right is
/// increasing in x, so the root is unique): Newton's method kept inside a shrinking bracket.
fn snell_offset(eta: f64, d1: f64, d2: f64, l: f64) -> f64 {
    let f = |x: f64| {
        let r1 = (x * x + d1 * d1).sqrt();
        let r2 = ((l - x) * (l - x) + d2 * d2).sqrt();
        let v = eta * x / r1 - (l - x) / r2;
        let dv = eta * d1 * d1 / (r1 * r1 * r1) + d2 * d2 / (r2 * r2 * r2);
        (v, dv)
    };
    let (mut lo, mut hi) = (0.0, l);
    // Start where the path would be straight (η = 1), then Newton steps, bisecting whenever a
    // step leaves the bracket.
    let mut x = l * d1 / (d1 + d2);
    for _ in 0..64 {
        let (v, dv) = f(x);
        if v > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let mut next = x - v / dv;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - x).abs() <= 1e-13 * l.max(d1) {
            return next;
        }
        x = next;
    }
    x
}

/// Whether the ray (o, d) meets triangle `t` (p0, e1, e2, n) in front (single precision).
#[inline]
fn hits_triangle(o: Vec3, d: Vec3, t: &[Vec3; 4]) -> bool {
    let pv = d.cross(t[2]);
    let det = t[1].dot(pv);
    if det == 0.0 {
        return false;
    }
    let inv = 1.0 / det;
    let tv = o - t[0];
    let bu = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&bu) {
        return false;
    }
    let qv = tv.cross(t[1]);
    let bv = d.dot(qv) * inv;
    bv >= 0.0 && bu + bv <= 1.0 && t[2].dot(qv) * inv > 0.0
}

/// Distance along the ray (o, d) to triangle `t` (p0, e1, e2, n), if it hits it in front.
fn ray_triangle(o: Vec3, d: Vec3, t: &[Vec3; 4]) -> Option<f32> {
    let (p0, e1, e2) = (t[0].as_dvec3(), t[1].as_dvec3(), t[2].as_dvec3());
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - p0;
    let bu = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&bu) {
        return None;
    }
    let qv = tv.cross(e1);
    let bv = d.dot(qv) * inv;
    if bv < 0.0 || bu + bv > 1.0 {
        return None;
    }
    let dist = e2.dot(qv) * inv;
    (dist > 0.0).then_some(dist as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    fn plane(eta: f32) -> RefractingPlane {
        RefractingPlane { point: Vec3::new(0.0, 0.0, 0.0), normal: Vec3::Z, eta }
    }

    /// A 0.4 m × 0.3 m quad light 0.5 m above the plane, tilted, facing down-ish.
    fn quad_light() -> (Light, Vec<[Vec3; 3]>) {
        let c = Vec3::new(0.15, -0.05, 0.5);
        let a = Vec3::new(0.4, 0.0, 0.05);
        let b = Vec3::new(0.0, 0.3, 0.1);
        let tris = vec![[c, c + a, c + a + b], [c, c + a + b, c + b]];
        let e = Emitter::triangles(tris.clone()).unwrap();
        let area = e.area_m2();
        (
            Light::Area { object: 0, emitter: e, area_m2: area, radiance: crate::texture::SpectrumTexture::Constant(optics::spectrum::DenseSpectrum::from_fn(|_| 1.0)), two_sided: true },
            tris,
        )
    }

    /// `reaches` (single precision, volpath's split-sample test) and `pdf` (double-precision
    /// triangle hits) agree on which directions meet the light, except within rounding of its
    /// edges; the distance it returns is the one to the plane; every proposed direction reaches.
    #[test]
    fn reaches_agrees_with_the_density_support() {
        let (light, _) = quad_light();
        let rl = RefractedLights::new(&[light], &[1.0], 0.5, 4.0).unwrap();
        let pl = plane(1.35);
        let p = Vec3::new(0.02, -0.01, -0.004);
        let mut rng = Pcg32::new(11, 5);
        let (mut hits, mut disagree) = (0u32, 0u32);
        for _ in 0..100_000 {
            let u = rng.next_2d();
            let z = 2.0 * u.x - 1.0;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            let w = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let reach = rl.reaches(&pl, p, w);
            if let Some(t) = reach {
                hits += 1;
                assert!(((p + w * t).z).abs() < 1e-6, "distance {t} does not end on the plane");
            }
            if reach.is_some() != (rl.pdf(&pl, p, w) > 0.0) {
                disagree += 1;
            }
        }
        assert!(hits > 500, "only {hits} of 100000 directions reach the light");
        assert!(disagree <= 2, "{disagree} directions disagree between reaches and pdf");
        for k in 0..500 {
            let (w, _) = rl.sample(&pl, p, rng.next_f32(), rng.next_2d()).unwrap_or_else(|| panic!("sample {k}"));
            assert!(rl.reaches(&pl, p, w).is_some(), "proposed direction {w} does not reach the light");
        }
    }

    #[test]
    fn refraction_point_obeys_snell() {
        let pl = plane(1.35);
        let p = Vec3::new(0.01, 0.02, -0.003);
        let y = Vec3::new(0.3, -0.2, 0.45);
        let s = refraction_point(&pl, p, y).unwrap();
        assert!(s.z.abs() < 1e-7);
        let w1 = (s - p).normalize();
        let w2 = (y - s).normalize();
        let sin1 = (1.0 - w1.z * w1.z).sqrt();
        let sin2 = (1.0 - w2.z * w2.z).sqrt();
        assert!((1.35 * sin1 - sin2).abs() < 1e-5, "{} vs {}", 1.35 * sin1, sin2);
        // coplanar with the normal
        assert!(w1.cross(Vec3::Z).normalize().dot(w2.cross(Vec3::Z).normalize()) > 0.99999);
        assert!((refract_out(w1, Vec3::Z, 1.35).unwrap() - w2).length() < 1e-5);
    }

    #[test]
    fn geometry_term_matches_finite_differences_and_inverse_square_law() {
        for &(eta, d1) in &[(1.35f32, 0.002f32), (1.5, 0.02), (1.0, 0.01), (0.75, 0.005)] {
            let pl = plane(eta);
            let p = Vec3::new(-0.01, 0.005, -d1);
            let y = Vec3::new(0.25, 0.1, 0.4);
            let ny = Vec3::new(0.1, -0.2, -1.0).normalize();
            // Two tangents of the light's surface at y.
            let t1 = ny.any_orthonormal_vector();
            let t2 = ny.cross(t1);
            let h = 1e-5f64;
            let dir = |q: DVec3| (refraction_point_f64(eta as f64, DVec3::Z, DVec3::ZERO, p.as_dvec3(), q).unwrap() - p.as_dvec3()).normalize();
            let yd = y.as_dvec3();
            let (a, b) = (t1.as_dvec3() * h, t2.as_dvec3() * h);
            // Central differences: the solid angle of the image of a small square on the light.
            let numeric = (dir(yd + a) - dir(yd - a)).cross(dir(yd + b) - dir(yd - b)).length() / (4.0 * h * h);
            let s = refraction_point(&pl, p, y).unwrap();
            let w1 = (s - p).normalize();
            let w2 = (y - s).normalize();
            let j = geometry_term(eta, d1, w1.z, y.z, w2.z, w2.dot(ny).abs()) as f64;
            assert!((j / numeric - 1.0).abs() < 1e-4, "η {eta}: closed form {j} vs finite differences {numeric}");
            if eta == 1.0 {
                let r = (y - p).length() as f64;
                assert!((j * r * r / w2.dot(ny).abs() as f64 - 1.0).abs() < 1e-4);
            }
        }
    }

    /// The density integrates over the sphere to the probability that a sample exists (here 1:
    /// the whole light is above the plane), by Monte Carlo over uniform directions; and the
    /// density a sample reports is the one its light point implies.
    #[test]
    fn density_is_normalised_and_agrees_with_sampling() {
        let (light, tris) = quad_light();
        let rl = RefractedLights::new(&[light], &[1.0], 0.5, 0.0).unwrap();
        let pl = plane(1.35);
        let p = Vec3::new(0.02, -0.01, -0.004);
        let mut rng = Pcg32::new(7, 3);
        // Directions within the critical cone (cos θ ≥ √(1 − 1/η²)), sampled uniformly: the only
        // ones that leave.
        let cos_c = (1.0 - 1.0 / (1.35f64 * 1.35)).sqrt();
        let n = 400_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let u = rng.next_2d();
            let z = 1.0 - u.x as f64 * (1.0 - cos_c);
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f64::consts::PI * u.y as f64;
            let w = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
            let f = rl.pdf(&pl, p, w) as f64 * 2.0 * std::f64::consts::PI * (1.0 - cos_c);
            sum += f;
            sum2 += f * f;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!((mean - 1.0).abs() < 4.0 * se + 1e-3, "∫ pdf = {mean} ± {se}");
        // Sample → the density of its own light point.
        let area: f32 = tris.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).sum();
        for k in 0..200 {
            let (w, pdf) = rl.sample(&pl, p, rng.next_f32(), rng.next_2d()).unwrap_or_else(|| panic!("sample {k}"));
            let s = p + w * ((0.0 - p.z) / w.z);
            let w2 = refract_out(w, Vec3::Z, 1.35).unwrap();
            let ny = (tris[0][1] - tris[0][0]).cross(tris[0][2] - tris[0][0]).normalize();
            // Distance to the light's plane along w2.
            let t = (tris[0][0] - s).dot(ny) / w2.dot(ny);
            let y = s + w2 * t;
            let j = geometry_term(1.35, -p.z, w.z, y.z, w2.z, w2.dot(ny).abs());
            assert!((pdf * area * j - 1.0).abs() < 1e-3, "sample {k}: {pdf} vs {}", 1.0 / (area * j));
        }
    }
}
