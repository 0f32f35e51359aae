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

/// Stratified values for the first dimensions of a pixel's samples, one per pass: the wavelength
/// number and the position on the film. Pass k of a pixel takes point k of the base-2 van der
/// Corput sequence for the wavelength and of the two-dimensional Sobol' sequence for the film,
/// each randomised by a hash-based nested uniform (Owen) scramble with its own seed per
/// (render seed, pixel, dimension) (Burley 2020, "Practical hash-based Owen scrambling",
/// JCGT 9(4); pbrt-v4's Sobol' samplers randomise the same way). Every value is exactly uniform
/// over the seeds, so estimates stay unbiased, and the first 2^m passes of a pixel put one
/// wavelength number in each stratum [k/2^m, (k+1)/2^m) and one film point in each elementary
/// interval of area 2^−m (tests below). With four hero wavelengths a quarter of the CDF apart,
/// the top two bits choose the quarter of the spectrum the hero lies in, so the passes of a
/// pixel share the hero equally between blue, green, yellow and red.
#[derive(Clone, Copy, Debug)]
pub struct PixelStrata {
    seeds: [u32; 3],
}

impl PixelStrata {
    /// The scramble seeds of pixel `pixel` (row-major index) in a render with base `seed`.
    pub fn for_pixel(seed: u64, pixel: u64) -> PixelStrata {
        let a = mix64(seed ^ 0x6A09_E667_F3BC_C908 ^ mix64(pixel.wrapping_add(0x3C6E_F372_FE94_F82B)));
        let b = mix64(a ^ 0xBB67_AE85_84CA_A73B);
        PixelStrata { seeds: [a as u32, (a >> 32) as u32, b as u32] }
    }

    /// The wavelength number of pass `pass`, uniform in [0, 1).
    #[inline]
    pub fn wavelength(&self, pass: u64) -> f32 {
        unit_f32(owen_scramble((pass as u32).reverse_bits(), self.seeds[0]))
    }

    /// The film position in the pixel of pass `pass`, uniform in [0, 1)².
    #[inline]
    pub fn film(&self, pass: u64) -> Vec2 {
        let i = pass as u32;
        Vec2::new(unit_f32(owen_scramble(i.reverse_bits(), self.seeds[1])), unit_f32(owen_scramble(sobol_second(i), self.seeds[2])))
    }

    /// Both, for pass `pass`: (wavelength number, film position).
    #[inline]
    pub fn first(&self, pass: u64) -> (f32, Vec2) {
        (self.wavelength(pass), self.film(pass))
    }
}

/// The top 24 bits of `v` as a float in [0, 1).
#[inline]
fn unit_f32(v: u32) -> f32 {
    (v >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Point `i` of the second dimension of the Sobol' sequence (primitive polynomial x + 1:
/// direction numbers v₀ = 2³¹, v_k = v_{k−1} ⊕ v_{k−1}/2), as 32 fraction bits.
#[inline]
fn sobol_second(mut i: u32) -> u32 {
    let (mut v, mut x) = (1u32 << 31, 0u32);
    while i != 0 {
        if i & 1 != 0 {
            x ^= v;
        }
        i >>= 1;
        v ^= v >> 1;
    }
    x
}

/// Nested uniform scramble of the fraction bits `v` (most significant digit first) with `seed`:
/// Burley's (2020) Laine–Karras-style hash on the reversed bits, where every step is a bijection
/// whose bit k depends only on bits 0..=k, so each digit is permuted as a function of the digits
/// before it.
#[inline]
fn owen_scramble(v: u32, seed: u32) -> u32 {
    let mut x = v.reverse_bits();
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x.reverse_bits()
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
    fn pixel_strata_put_one_sample_in_every_stratum() {
        for (seed, pixel) in [(1u64, 0u64), (1, 1), (7, 12_345), (99, 1 << 40), (3, 77)] {
            let st = PixelStrata::for_pixel(seed, pixel);
            for m in [2u32, 4, 6, 8] {
                let n = 1u64 << m;
                // The first 2^m passes and the next 2^m (any aligned block is a net too).
                for first in [0, n] {
                    let mut seen = vec![false; n as usize];
                    for pass in first..first + n {
                        let k = (st.wavelength(pass) * n as f32) as usize;
                        assert!(!seen[k], "seed {seed} pixel {pixel}: two wavelength numbers in stratum {k} of {n}");
                        seen[k] = true;
                    }
                }
                // Film: every elementary interval 2^-a × 2^-b with a + b = m holds one point.
                for a in 0..=m {
                    let b = m - a;
                    let mut seen = vec![false; n as usize];
                    for pass in 0..n {
                        let f = st.film(pass);
                        let cell = ((f.x * (1u64 << a) as f32) as usize) * (1usize << b) + (f.y * (1u64 << b) as f32) as usize;
                        assert!(!seen[cell], "seed {seed} pixel {pixel}: two film points in a {a}:{b} interval of {n}");
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn pixel_strata_are_uniform_and_independent_across_pixels() {
        // At a fixed pass, the values of 2^18 pixels: uniform (mean, 16-bin χ²) and uncorrelated
        // between the three dimensions; bounds at 4 standard errors and χ²₁₅ at p = 10⁻⁴.
        let n = 1usize << 18;
        for pass in [0u64, 5, 1000] {
            let mut sums = [0f64; 3];
            let mut cross = [0f64; 3];
            let mut hist = [[0usize; 16]; 3];
            for pixel in 0..n as u64 {
                let st = PixelStrata::for_pixel(42, pixel);
                let f = st.film(pass);
                let v = [st.wavelength(pass) as f64, f.x as f64, f.y as f64];
                for d in 0..3 {
                    assert!((0.0..1.0).contains(&v[d]));
                    sums[d] += v[d];
                    hist[d][(v[d] * 16.0) as usize] += 1;
                    cross[d] += (v[d] - 0.5) * (v[(d + 1) % 3] - 0.5);
                }
            }
            let se_mean = (1.0 / 12.0 / n as f64).sqrt();
            let se_cross = (1.0 / 144.0 / n as f64).sqrt();
            for d in 0..3 {
                let mean = sums[d] / n as f64;
                assert!((mean - 0.5).abs() < 4.0 * se_mean, "pass {pass} dim {d}: mean {mean}");
                let c = cross[d] / n as f64;
                assert!(c.abs() < 4.0 * se_cross, "pass {pass} dims {d},{}: covariance {c}", (d + 1) % 3);
                let e = n as f64 / 16.0;
                let chi2: f64 = hist[d].iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
                assert!(chi2 < 42.0, "pass {pass} dim {d}: chi2 {chi2}");
            }
        }
    }

    #[test]
    fn stratified_wavelengths_estimate_luminance_without_bias_and_with_less_variance() {
        use crate::math::spectral::{cmf, SampledWavelengths};
        // Y of a band spectrum (1 over 600-650 nm) from 16 hero-wavelength samples per pixel:
        // the mean over pixels matches the quadrature, and the spread of the per-pixel means is
        // below that of independent wavelength numbers (same generator for the rest).
        let band = |l: f32| if (600.0..650.0).contains(&l) { 1.0f32 } else { 0.0 };
        let (mut num, mut den) = (0f64, 0f64);
        for k in 0..47_000 {
            let l = 360.0 + (k as f32 + 0.5) * 0.01;
            num += (band(l) * cmf(l)[1]) as f64;
            den += cmf(l)[1] as f64;
        }
        let exact = num / den;
        let (pixels, spp) = (20_000u64, 16u64);
        let mut stats = [(0f64, 0f64); 2];
        for pixel in 0..pixels {
            let st = PixelStrata::for_pixel(5, pixel);
            for (mode, s) in stats.iter_mut().enumerate() {
                let mut y = 0f64;
                for pass in 0..spp {
                    let u = if mode == 0 { st.wavelength(pass) } else { Pcg32::for_pixel(5, pass, pixel).next_f32() };
                    let wl = SampledWavelengths::sample(u);
                    let l = glam::Vec4::from_array(wl.lambda_nm.map(band));
                    y += wl.to_xyz(l)[1] as f64;
                }
                y /= spp as f64;
                s.0 += y;
                s.1 += y * y;
            }
        }
        let var = |s: (f64, f64)| s.1 / pixels as f64 - (s.0 / pixels as f64).powi(2);
        let (v_strat, v_indep) = (var(stats[0]), var(stats[1]));
        for (mode, s) in stats.iter().enumerate() {
            let mean = s.0 / pixels as f64;
            let se = (var(*s) / pixels as f64).sqrt();
            assert!((mean - exact).abs() < 4.0 * se, "mode {mode}: mean {mean} against {exact} (se {se})");
        }
        assert!(v_strat < 0.5 * v_indep, "variance of 16-sample means: stratified {v_strat}, independent {v_indep}");
    }

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
