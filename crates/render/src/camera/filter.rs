//! Pixel reconstruction filters, applied by importance sampling the film position (pbrt-v4's
//! filter sampling, Pharr, Jakob and Humphreys, *Physically Based Rendering*, 4th ed., §8.8):
//! pixel (i, j)'s samples are drawn around its centre with density f(x) f(y) / (∫f)², so the
//! pixel's expected value is the filter-weighted average ∫∫ f(x) f(y) L(centre + (x, y)) / (∫f)²,
//! the same as that of a renderer that splats uniformly placed samples into every pixel within
//! the filter's radius and divides by the summed weights (Mitsuba 3's `ImageBlock`). Each sample
//! stays in its own pixel with weight 1, so neighbouring pixels' noise is not correlated (unlike
//! splatting) and the film is unchanged. All filters here are positive and separable.
//!
//! * `box`: one pixel, f = 1 on [−½, ½] (the default; Mitsuba 3's `box`, pbrt-v4's `box` with
//!   radius ½): the sample position is the uniform number itself.
//! * `tent`: f = max(0, 1 − |x|/r), radius r pixels (Mitsuba 3's `tent`, r = 1; pbrt-v4's
//!   `triangle`, r = 2), inverted in closed form.
//! * `gaussian`: f = max(0, e^{−x²/(2σ²)} − e^{−r²/(2σ²)}), the windowed Gaussian of Mitsuba 3's
//!   default `gaussian` filter (σ = 0.5 px, r = 4σ) and pbrt-v4's `gaussian` (σ = 0.5,
//!   r = 1.5); inverted exactly (to f64 rounding) from a tabulated CDF and Newton steps on the
//!   exact density (`camera::filter` tests: sampled moments and CDF against independent
//!   quadrature; `tests/suite/camera.rs`: a rendered edge is the filter's integral).
//!
//! The wavelength, lens and path numbers are drawn as for the box, so a scene renders with the
//! same random numbers whatever its filter.

use glam::Vec2;
use std::sync::Arc;

/// A separable pixel reconstruction filter (module documentation).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum PixelFilter {
    /// One pixel, uniform.
    #[default]
    Box,
    /// Triangle of half-width `radius_px` pixels.
    Tent {
        /// Radius (pixels), > 0.
        radius_px: f64,
    },
    /// Windowed Gaussian.
    Gaussian(GaussianFilter),
}

/// Nodes of the tabulated CDF of the windowed Gaussian (cells of 2r/1024).
const NODES: usize = 1024;

/// The windowed Gaussian max(0, e^{−x²/(2σ²)} − e^{−r²/(2σ²)}) on [−r, r], with its CDF tabulated.
#[derive(Clone, Debug)]
pub struct GaussianFilter {
    stddev_px: f64,
    radius_px: f64,
    /// e^{−r²/(2σ²)}, the window's offset.
    bias: f64,
    /// ∫ f over [−r, x_k], x_k = −r + 2r k / NODES, k = 0..=NODES.
    cdf: Arc<[f64]>,
}

impl PartialEq for GaussianFilter {
    fn eq(&self, o: &Self) -> bool {
        self.stddev_px == o.stddev_px && self.radius_px == o.radius_px
    }
}

/// Five-point Gauss–Legendre rule on [a, b].
fn gauss_legendre5(f: impl Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const X: [f64; 5] = [0.0, -0.538_469_310_105_683_1, 0.538_469_310_105_683_1, -0.906_179_845_938_664, 0.906_179_845_938_664];
    const W: [f64; 5] = [0.568_888_888_888_888_9, 0.478_628_670_499_366_5, 0.478_628_670_499_366_5, 0.236_926_885_056_189_1, 0.236_926_885_056_189_1];
    let (m, h) = (0.5 * (a + b), 0.5 * (b - a));
    h * X.iter().zip(W).map(|(x, w)| w * f(m + h * x)).sum::<f64>()
}

impl GaussianFilter {
    /// A windowed Gaussian of standard deviation `stddev_px` cut off at `radius_px` (both in
    /// pixels); errors unless both are finite and positive.
    pub fn new(stddev_px: f64, radius_px: f64) -> anyhow::Result<GaussianFilter> {
        if !(stddev_px > 0.0 && stddev_px.is_finite()) {
            anyhow::bail!("stddev_px must be positive and finite, got {stddev_px}");
        }
        if !(radius_px > 0.0 && radius_px.is_finite()) {
            anyhow::bail!("radius_px must be positive and finite, got {radius_px}");
        }
        let bias = (-radius_px * radius_px / (2.0 * stddev_px * stddev_px)).exp();
        let mut g = GaussianFilter { stddev_px, radius_px, bias, cdf: Arc::from(Vec::new()) };
        let h = 2.0 * radius_px / NODES as f64;
        let mut cdf = Vec::with_capacity(NODES + 1);
        let mut acc = 0.0;
        cdf.push(0.0);
        for k in 0..NODES {
            let a = -radius_px + h * k as f64;
            acc += gauss_legendre5(|x| g.eval(x), a, a + h);
            cdf.push(acc);
        }
        g.cdf = Arc::from(cdf);
        Ok(g)
    }

    /// Standard deviation (pixels).
    pub fn stddev_px(&self) -> f64 {
        self.stddev_px
    }

    /// Radius (pixels).
    pub fn radius_px(&self) -> f64 {
        self.radius_px
    }

    /// The 1-D profile f(x) (unnormalised; x in pixels).
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        if x.abs() >= self.radius_px {
            return 0.0;
        }
        ((-x * x / (2.0 * self.stddev_px * self.stddev_px)).exp() - self.bias).max(0.0)
    }

    /// ∫ f over [−r, r].
    pub fn integral(&self) -> f64 {
        self.cdf[NODES]
    }

    /// The offset x ∈ [−r, r] (pixels) whose normalised CDF is `u` ∈ [0, 1].
    pub fn sample(&self, u: f64) -> f64 {
        let r = self.radius_px;
        let target = u.clamp(0.0, 1.0) * self.integral();
        // The cell [x_k, x_{k+1}] holding the target, then Newton steps on the exact density
        // inside it, kept in the cell by bisection, from the CDF's linear interpolation in the cell.
        let k = (self.cdf.partition_point(|&c| c <= target).saturating_sub(1)).min(NODES - 1);
        let h = 2.0 * r / NODES as f64;
        let (mut lo, mut hi) = (-r + h * k as f64, -r + h * (k + 1) as f64);
        let base = self.cdf[k];
        let x0 = lo;
        let mass = self.cdf[k + 1] - base;
        let mut x = if mass > 0.0 { lo + h * ((target - base) / mass).clamp(0.0, 1.0) } else { 0.5 * (lo + hi) };
        for _ in 0..40 {
            let fx = base + gauss_legendre5(|t| self.eval(t), x0, x) - target;
            if fx > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            let d = self.eval(x);
            let newton = if d > 0.0 { x - fx / d } else { f64::NAN };
            let next = if newton > lo && newton < hi { newton } else { 0.5 * (lo + hi) };
            if (next - x).abs() <= 1e-13 * r {
                x = next;
                break;
            }
            x = next;
        }
        x.clamp(-r, r)
    }
}

impl PixelFilter {
    /// Radius (pixels) beyond which a pixel's samples do not fall.
    pub fn radius_px(&self) -> f64 {
        match self {
            PixelFilter::Box => 0.5,
            PixelFilter::Tent { radius_px } => *radius_px,
            PixelFilter::Gaussian(g) => g.radius_px,
        }
    }

    /// The 1-D profile f(x) (unnormalised; x in pixels from the pixel centre).
    pub fn eval(&self, x: f64) -> f64 {
        match self {
            PixelFilter::Box => {
                if x.abs() <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            PixelFilter::Tent { radius_px } => (1.0 - x.abs() / radius_px).max(0.0),
            PixelFilter::Gaussian(g) => g.eval(x),
        }
    }

    /// Offset (pixels, from the pixel centre) with density f / ∫f for a uniform number `u`.
    pub fn sample_1d(&self, u: f64) -> f64 {
        match self {
            PixelFilter::Box => u - 0.5,
            PixelFilter::Tent { radius_px: r } => {
                // Inverse of the triangle's CDF, each half in closed form.
                if u < 0.5 {
                    -r + r * (2.0 * u).max(0.0).sqrt()
                } else {
                    r - r * (2.0 * (1.0 - u)).max(0.0).sqrt()
                }
            }
            PixelFilter::Gaussian(g) => g.sample(u),
        }
    }

    /// The film offset for a pixel sample: `u` ∈ [0,1)² uniform in, position relative to the
    /// pixel's corner out (the pixel covers [0, 1)²; other filters reach into the neighbours).
    /// The box returns `u` itself.
    #[inline]
    pub fn film_offset(&self, u: Vec2) -> Vec2 {
        match self {
            PixelFilter::Box => u,
            _ => Vec2::new((0.5 + self.sample_1d(u.x as f64)) as f32, (0.5 + self.sample_1d(u.y as f64)) as f32),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ g over [a, b] by composite Simpson with `n` intervals (independent of the Gauss–Legendre
    /// table the sampler uses).
    fn simpson(g: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
        let h = (b - a) / n as f64;
        let mut s = g(a) + g(b);
        for k in 1..n {
            s += g(a + h * k as f64) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        s * h / 3.0
    }

    fn filters() -> Vec<PixelFilter> {
        vec![
            PixelFilter::Box,
            PixelFilter::Tent { radius_px: 1.0 },
            PixelFilter::Tent { radius_px: 2.0 },
            PixelFilter::Gaussian(GaussianFilter::new(0.5, 2.0).unwrap()),
            PixelFilter::Gaussian(GaussianFilter::new(0.5, 1.5).unwrap()),
            PixelFilter::Gaussian(GaussianFilter::new(1.3, 2.0).unwrap()),
        ]
    }

    /// Stratified uniform numbers mapped through the sampler reproduce the filter's normalised
    /// CDF (at 41 points, to the strata's 1/M) and its second moment ∫x²f/∫f (by Simpson on the
    /// profile, independent of the sampler's table) to 1e-6; the map is monotone and stays
    /// within the radius.
    #[test]
    fn sampled_offsets_follow_the_filter_profile() {
        let m = 200_000;
        for f in filters() {
            let r = f.radius_px();
            let xs: Vec<f64> = (0..m).map(|k| f.sample_1d((k as f64 + 0.5) / m as f64)).collect();
            assert!(xs.windows(2).all(|w| w[0] <= w[1]), "{f:?}: not monotone");
            assert!(xs.iter().all(|x| x.abs() <= r), "{f:?}: beyond the radius");
            let z = simpson(|x| f.eval(x), -r, r, 200_000);
            for t in 0..=40 {
                let x = -r + 2.0 * r * t as f64 / 40.0;
                let want = simpson(|y| f.eval(y), -r, x, 200_000) / z;
                let got = xs.partition_point(|&v| v <= x) as f64 / m as f64;
                assert!((got - want).abs() < 2.0 / m as f64 + 1e-9, "{f:?}: CDF at {x}: {got} against {want}");
            }
            let m2 = xs.iter().map(|x| x * x).sum::<f64>() / m as f64;
            let want = simpson(|x| x * x * f.eval(x), -r, r, 200_000) / z;
            assert!((m2 - want).abs() < 1e-6, "{f:?}: E[x²] {m2} against {want}");
        }
    }

    /// Closed forms: the box's and tent's second moments (1/12, r²/6), and a window far out
    /// (r = 8σ) leaves the Gaussian's σ² and its integral σ√(2π).
    #[test]
    fn second_moments_match_closed_forms() {
        let m = 400_000;
        let moment = |f: &PixelFilter| (0..m).map(|k| f.sample_1d((k as f64 + 0.5) / m as f64).powi(2)).sum::<f64>() / m as f64;
        assert!((moment(&PixelFilter::Box) - 1.0 / 12.0).abs() < 1e-9);
        for r in [0.5, 1.0, 2.0] {
            assert!((moment(&PixelFilter::Tent { radius_px: r }) - r * r / 6.0).abs() < 1e-6 * r * r);
        }
        let g = GaussianFilter::new(0.4, 3.2).unwrap();
        assert!((moment(&PixelFilter::Gaussian(g.clone())) - 0.16).abs() < 1e-5);
        assert!((g.integral() - 0.4 * (2.0 * std::f64::consts::PI).sqrt()).abs() < 1e-9);
    }

    #[test]
    fn bad_parameters_are_refused() {
        assert!(GaussianFilter::new(0.0, 2.0).is_err());
        assert!(GaussianFilter::new(0.5, -1.0).is_err());
        assert!(GaussianFilter::new(f64::NAN, 1.0).is_err());
    }
}
