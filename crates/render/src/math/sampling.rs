//! Random numbers and sample warps for Monte Carlo light transport.
//!
//! The generator is PCG32 (O'Neill 2014: 64-bit LCG state, XSH-RR output), seeded per
//! (seed, pass, pixel) through a SplitMix64-style mixer so every pixel's sample stream is
//! independent of the thread that computes it. Warps map uniform `[0,1)²` samples to
//! directions and points with known densities (per steradian or per unit area).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// PCG32 pseudo-random generator (64-bit state, 32-bit output).
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: a bijective 64-bit mixer used to derive seeds.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Pcg32 {
    /// Generator with initial state `seed` on stream `stream` (any two streams are independent).
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut r = Pcg32 { state: 0, inc: (stream << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(seed);
        r.next_u32();
        r
    }

    /// The generator for one pixel of one pass of a render with base `seed`.
    pub fn for_pixel(seed: u64, pass: u64, pixel: u64) -> Pcg32 {
        let s = mix64(seed ^ mix64(pass.wrapping_mul(0xD6E8_FEB8_6659_FD93) ^ mix64(pixel)));
        let stream = mix64(s ^ 0xA076_1D64_78BD_642F);
        Pcg32::new(s, stream)
    }

    /// Next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in [0, 1) (24 random mantissa bits, never 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform double in [0, 1) (53 random bits).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }

    /// Two uniform floats in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let a = self.next_f32();
        let b = self.next_f32();
        Vec2::new(a, b)
    }
}

/// Orthonormal frame (s, t, n) around a unit normal n (Duff et al. 2017, branchless).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// Normal (local +z).
    pub n: Vec3,
}

impl Frame {
    /// Frame whose local z axis is the unit vector `n`.
    #[inline]
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World vector → local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local coordinates → world vector.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Uniform point on the unit disk (Shirley–Chiu concentric map), density 1/π.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a * a > b * b {
        (a, (PI / 4.0) * (b / a))
    } else {
        (b, (PI / 2.0) - (PI / 4.0) * (a / b))
    };
    Vec2::new(r * phi.cos(), r * phi.sin())
}

/// Cosine-weighted direction on the hemisphere z > 0 (Malley's method), density cos θ / π per sr.
#[inline]
pub fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density per steradian of [`cosine_hemisphere`] for a direction with cos θ = `cos_theta`.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere, density 1/(4π) per sr.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density per steradian of [`uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone around +z with cos θ ≥ `cos_max`, density 1/(2π(1−cos_max)).
#[inline]
pub fn uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform barycentric coordinates (b1, b2) on a triangle (the point is (1−b1−b2)·p0 + b1·p1 + b2·p2).
/// Uses the low-distortion square-to-triangle map of Heitz (2019): density 1/area.
#[inline]
pub fn uniform_triangle(u: Vec2) -> Vec2 {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    // (b0, b1) weight p0 and p1; return the weights of p1 and p2.
    Vec2::new(b1, 1.0 - b0 - b1)
}

/// Power heuristic (β = 2) weight of a sample drawn from strategy f, `nf` samples of density `f_pdf`,
/// against strategy g with `ng` samples of density `g_pdf` (Veach 1997).
#[inline]
pub fn power_heuristic(nf: f32, f_pdf: f32, ng: f32, g_pdf: f32) -> f32 {
    let f = nf * f_pdf;
    let g = ng * g_pdf;
    if f.is_infinite() {
        return 1.0;
    }
    let ff = f * f;
    let d = ff + g * g;
    if d > 0.0 {
        ff / d
    } else {
        0.0
    }
}

/// Index into a discrete cumulative distribution `cdf` (non-decreasing, last entry = total) for
/// u ∈ [0,1); returns (index, u remapped to [0,1) within the chosen bin).
#[inline]
pub fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let total = *cdf.last().unwrap_or(&0.0);
    let x = u * total;
    // first index with cdf[i] > x
    let mut lo = 0usize;
    let mut hi = cdf.len();
    while lo < hi {
        let mid = (lo + hi) / 2;
        if cdf[mid] <= x {
            lo = mid + 1;
        } else {
            hi = mid;
        }
    }
    let i = lo.min(cdf.len().saturating_sub(1));
    let start = if i == 0 { 0.0 } else { cdf[i - 1] };
    let w = cdf[i] - start;
    let ur = if w > 0.0 { ((x - start) / w).clamp(0.0, 0.99999994) } else { 0.0 };
    (i, ur)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg_uniform_mean_and_variance() {
        let mut r = Pcg32::new(42, 54);
        let n = 200_000;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let x = r.next_f32() as f64;
            assert!((0.0..1.0).contains(&x));
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // mean of U(0,1): 1/2 with standard error sqrt(1/12/n) ≈ 6.5e-4
        assert!((mean - 0.5).abs() < 4.0 * (1.0f64 / 12.0 / n as f64).sqrt(), "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 2e-3, "var {var}");
    }

    #[test]
    fn pixel_streams_differ() {
        let a = Pcg32::for_pixel(1, 0, 0).next_u32();
        let b = Pcg32::for_pixel(1, 0, 1).next_u32();
        let c = Pcg32::for_pixel(1, 1, 0).next_u32();
        let d = Pcg32::for_pixel(2, 0, 0).next_u32();
        assert!(a != b && a != c && a != d && b != c);
        assert_eq!(a, Pcg32::for_pixel(1, 0, 0).next_u32());
    }

    #[test]
    fn frame_is_orthonormal() {
        let mut r = Pcg32::new(7, 1);
        for _ in 0..1000 {
            let n = uniform_sphere(r.next_2d());
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5);
            let v = uniform_sphere(r.next_2d());
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn cosine_hemisphere_moments() {
        // E[cos θ] under density cos θ/π is 2/3; E[cos² θ] = 1/2.
        let mut r = Pcg32::new(3, 3);
        let n = 100_000;
        let (mut m1, mut m2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let d = cosine_hemisphere(r.next_2d());
            assert!((d.length() - 1.0).abs() < 1e-4 && d.z >= 0.0);
            m1 += d.z as f64;
            m2 += (d.z * d.z) as f64;
        }
        let m1 = m1 / n as f64;
        let m2 = m2 / n as f64;
        // sd of cos θ is sqrt(1/2 − 4/9) ≈ 0.236 → se ≈ 7.5e-4
        assert!((m1 - 2.0 / 3.0).abs() < 3e-3, "{m1}");
        assert!((m2 - 0.5).abs() < 3e-3, "{m2}");
    }

    #[test]
    fn triangle_samples_are_uniform() {
        // Mean of uniform barycentrics is (1/3, 1/3); fraction in the sub-triangle b1+b2 < 1/2 is 1/4.
        let mut r = Pcg32::new(9, 2);
        let n = 100_000;
        let (mut s1, mut s2, mut inner) = (0.0f64, 0.0f64, 0usize);
        for _ in 0..n {
            let b = uniform_triangle(r.next_2d());
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            s1 += b.x as f64;
            s2 += b.y as f64;
            if b.x + b.y < 0.5 {
                inner += 1;
            }
        }
        assert!((s1 / n as f64 - 1.0 / 3.0).abs() < 3e-3);
        assert!((s2 / n as f64 - 1.0 / 3.0).abs() < 3e-3);
        let f = inner as f64 / n as f64;
        assert!((f - 0.25).abs() < 4.0 * (0.25f64 * 0.75 / n as f64).sqrt(), "{f}");
    }

    #[test]
    fn cdf_sampling_matches_weights() {
        let cdf = [1.0f32, 1.0, 4.0, 8.0]; // weights 1, 0, 3, 4
        let mut counts = [0usize; 4];
        let mut r = Pcg32::new(11, 5);
        let n = 80_000;
        for _ in 0..n {
            let (i, ur) = sample_cdf(&cdf, r.next_f32());
            assert!((0.0..1.0).contains(&ur));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        for (i, w) in [(0usize, 1.0f64), (2, 3.0), (3, 4.0)] {
            let p = w / 8.0;
            let f = counts[i] as f64 / n as f64;
            assert!((f - p).abs() < 4.0 * (p * (1.0 - p) / n as f64).sqrt());
        }
    }

    #[test]
    fn power_heuristic_sums_to_one() {
        let w1 = power_heuristic(1.0, 0.3, 1.0, 0.7);
        let w2 = power_heuristic(1.0, 0.7, 1.0, 0.3);
        assert!((w1 + w2 - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(1.0, 0.0, 1.0, 0.0), 0.0);
    }
}
