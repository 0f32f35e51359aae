//! Spectral rendering: hero-wavelength sampling and the film's XYZ estimator.
//!
//! Every camera path carries [`N_LAMBDA`] = 4 wavelengths (Wilkie et al. 2014, "hero wavelength"
//! sampling; pbrt-v4 `SampledWavelengths`): one is drawn from a density p(λ) proportional to
//! x̄ + ȳ + z̄ on 360–830 nm and the others are rotated copies u + i/4 (mod 1) of its uniform
//! sample, so each is marginally distributed with p. The pixel estimate of the CIE XYZ
//! tristimulus value (pbrt-v4/Mitsuba 3 convention, XYZ = ∫S·(x̄,ȳ,z̄)dλ / ∫ȳdλ) is
//! (1/4) Σᵢ L(λᵢ)·(x̄,ȳ,z̄)(λᵢ) / (p(λᵢ)·∫ȳdλ), so spectral radiance 1 everywhere gives Y = 1.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

use glam::Vec4;
use optics::spectrum::DenseSpectrum;
use std::sync::OnceLock;

/// Wavelengths carried by one path.
pub const N_LAMBDA: usize = 4;
/// Shortest wavelength sampled, nm.
pub const LAMBDA_MIN_NM: f32 = 360.0;
/// Longest wavelength sampled, nm.
pub const LAMBDA_MAX_NM: f32 = 830.0;
const N_BINS: usize = 470; // 1-nm bins of the sampling density
const GUIDE: usize = 1024; // entries of the guide table for inverting the CDF

/// A value per carried wavelength (radiance, throughput, reflectance…), SIMD-friendly.
pub type SampledSpectrum = Vec4;

/// The wavelengths (nm) of one path and their sampling densities (per nm).
#[derive(Clone, Copy, Debug)]
pub struct SampledWavelengths {
    /// Wavelengths in nm.
    pub lambda_nm: [f32; N_LAMBDA],
    /// Sampling density of each wavelength, per nm (0 for a terminated secondary wavelength).
    pub pdf_per_nm: Vec4,
    /// Index of the 1-nm sample at or below each wavelength (0..=469), for fast table lookups.
    index: [u16; N_LAMBDA],
    /// Interpolation weight of the sample above.
    frac: Vec4,
}

struct Tables {
    /// x̄, ȳ, z̄ at 1-nm spacing from 360 to 830 nm (471 samples each).
    cmf: [Vec<f32>; 3],
    /// (x̄, ȳ, z̄, 0) per 1-nm sample, for the film's inner loop.
    cmf4: Vec<Vec4>,
    /// First bin whose upper CDF value exceeds k/GUIDE (a guide table for inversion).
    guide: Vec<u16>,
    /// Sampling density per nm in each 1-nm bin.
    pdf: Vec<f32>,
    /// Cumulative distribution at the bin ends (471 entries, first 0, last 1).
    cdf: Vec<f32>,
    /// 1/∫ȳ dλ in nm⁻¹.
    inv_y_integral: f32,
    /// Linear-sRGB contribution per nm of a unit reflectance lit by D65 normalised to Y = 1, at
    /// 1-nm spacing (471 entries; (r, g, b, 0)).
    srgb_d65: Vec<Vec4>,
}

fn tables() -> &'static Tables {
    static T: OnceLock<Tables> = OnceLock::new();
    T.get_or_init(|| {
        let n = N_BINS + 1;
        let mut cmf = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
        for i in 0..n {
            let xyz = optics::color::cie_1931_xyz_bar(360.0 + i as f64);
            for c in 0..3 {
                cmf[c][i] = xyz[c] as f32;
            }
        }
        let w: Vec<f64> = (0..N_BINS)
            .map(|k| {
                let a = (cmf[0][k] + cmf[1][k] + cmf[2][k]) as f64;
                let b = (cmf[0][k + 1] + cmf[1][k + 1] + cmf[2][k + 1]) as f64;
                0.5 * (a + b) + 1e-4
            })
            .collect();
        let total: f64 = w.iter().sum();
        let pdf: Vec<f32> = w.iter().map(|x| (x / total) as f32).collect();
        let mut cdf = Vec::with_capacity(n);
        let mut acc = 0.0f64;
        cdf.push(0.0f32);
        for x in &w {
            acc += x / total;
            cdf.push(acc as f32);
        }
        cdf[N_BINS] = 1.0;
        let cmf4 = (0..n).map(|i| Vec4::new(cmf[0][i], cmf[1][i], cmf[2][i], 0.0)).collect();
        let guide = (0..GUIDE)
            .map(|k| {
                let u = k as f32 / GUIDE as f32;
                // first bin k with cdf[k + 1] > u
                let mut b = 0usize;
                while b + 1 < N_BINS && cdf[b + 1] <= u {
                    b += 1;
                }
                b as u16
            })
            .collect();
        let srgb_d65 = (0..n)
            .map(|i| {
                let l = LAMBDA_MIN_NM as f64 + i as f64;
                let s = optics::spectrum::d65_normalized(l) / optics::color::CIE_Y_INTEGRAL;
                let c = optics::color::xyz_to_linear_srgb([cmf[0][i] as f64 * s, cmf[1][i] as f64 * s, cmf[2][i] as f64 * s]);
                Vec4::new(c[0] as f32, c[1] as f32, c[2] as f32, 0.0)
            })
            .collect();
        Tables { cmf, cmf4, guide, pdf, cdf, inv_y_integral: (1.0 / optics::color::CIE_Y_INTEGRAL) as f32, srgb_d65 }
    })
}

/// Colour-matching functions (x̄, ȳ, z̄) at `lambda_nm`, linear between 1-nm samples, 0 outside 360–830 nm.
#[inline]
pub fn cmf(lambda_nm: f32) -> [f32; 3] {
    let t = tables();
    let x = lambda_nm - LAMBDA_MIN_NM;
    if !(x >= 0.0 && x <= N_BINS as f32) {
        return [0.0; 3];
    }
    let i = (x as usize).min(N_BINS - 1);
    let f = x - i as f32;
    let l = |c: usize| t.cmf[c][i] + f * (t.cmf[c][i + 1] - t.cmf[c][i]);
    [l(0), l(1), l(2)]
}

/// Density per nm with which [`SampledWavelengths::sample`] draws each wavelength.
#[inline]
pub fn wavelength_pdf(lambda_nm: f32) -> f32 {
    let x = lambda_nm - LAMBDA_MIN_NM;
    if !(x >= 0.0 && x <= N_BINS as f32) {
        return 0.0;
    }
    tables().pdf[(x as usize).min(N_BINS - 1)]
}

/// Wavelength (nm) and its 1-nm bin for a uniform `u`, by inverting the CDF with a guide table.
#[inline]
fn sample_one(t: &Tables, u: f32) -> (f32, usize) {
    let cdf = &t.cdf;
    let mut k = t.guide[((u * GUIDE as f32) as usize).min(GUIDE - 1)] as usize;
    while k + 1 < N_BINS && cdf[k + 1] <= u {
        k += 1;
    }
    let w = cdf[k + 1] - cdf[k];
    let f = if w > 0.0 { ((u - cdf[k]) / w).clamp(0.0, 0.999_999) } else { 0.5 };
    (LAMBDA_MIN_NM + k as f32 + f, k)
}

impl SampledWavelengths {
    /// Hero-wavelength sample from one uniform number `u` ∈ [0,1).
    #[inline]
    pub fn sample(u: f32) -> SampledWavelengths {
        let t = tables();
        let mut lambda_nm = [0f32; N_LAMBDA];
        let mut pdf = [0f32; N_LAMBDA];
        let mut index = [0u16; N_LAMBDA];
        let mut frac = [0f32; N_LAMBDA];
        for i in 0..N_LAMBDA {
            let mut ui = u + i as f32 / N_LAMBDA as f32;
            if ui >= 1.0 {
                ui -= 1.0;
            }
            let (l, k) = sample_one(t, ui);
            lambda_nm[i] = l;
            pdf[i] = t.pdf[k];
            index[i] = k as u16;
            frac[i] = l - (LAMBDA_MIN_NM + k as f32);
        }
        SampledWavelengths { lambda_nm, pdf_per_nm: Vec4::from_array(pdf), index, frac: Vec4::from_array(frac) }
    }

    /// A fixed set of wavelengths (nm, within 360–830) with unit densities (for tests and
    /// deterministic evaluation).
    pub fn fixed(lambda_nm: [f32; N_LAMBDA]) -> SampledWavelengths {
        let mut index = [0u16; N_LAMBDA];
        let mut frac = [0f32; N_LAMBDA];
        for i in 0..N_LAMBDA {
            let x = (lambda_nm[i] - LAMBDA_MIN_NM).clamp(0.0, N_BINS as f32);
            let k = (x as usize).min(N_BINS - 1);
            index[i] = k as u16;
            frac[i] = x - k as f32;
        }
        SampledWavelengths { lambda_nm, pdf_per_nm: Vec4::ONE, index, frac: Vec4::from_array(frac) }
    }

    /// Keep only the hero wavelength (after a wavelength-dependent event such as dispersion).
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        self.pdf_per_nm = Vec4::new(self.pdf_per_nm.x / N_LAMBDA as f32, 0.0, 0.0, 0.0);
    }

    /// Whether only the hero wavelength is still carried.
    pub fn secondary_terminated(&self) -> bool {
        self.pdf_per_nm.y == 0.0 && self.pdf_per_nm.z == 0.0 && self.pdf_per_nm.w == 0.0
    }

    /// Evaluate a dense spectrum at the carried wavelengths (linear between its 1-nm samples).
    #[inline]
    pub fn eval(&self, s: &DenseSpectrum) -> SampledSpectrum {
        let v = s.samples();
        if v.len() != N_BINS + 1 {
            return Vec4::new(s.eval(self.lambda_nm[0]), s.eval(self.lambda_nm[1]), s.eval(self.lambda_nm[2]), s.eval(self.lambda_nm[3]));
        }
        let k = self.index.map(|k| k as usize);
        let lo = Vec4::new(v[k[0]], v[k[1]], v[k[2]], v[k[3]]);
        let hi = Vec4::new(v[k[0] + 1], v[k[1] + 1], v[k[2] + 1], v[k[3] + 1]);
        lo + (hi - lo) * self.frac
    }

    /// CIE XYZ estimate (Y = 1 for spectral radiance 1) of spectral radiance `l` at these wavelengths.
    #[inline]
    pub fn to_xyz(&self, l: SampledSpectrum) -> [f32; 3] {
        let t = tables();
        // Terminated secondary wavelengths have density 0 and contribute nothing.
        let w = Vec4::select(self.pdf_per_nm.cmpgt(Vec4::ZERO), l / self.pdf_per_nm, Vec4::ZERO);
        let w = w.to_array();
        let f = self.frac.to_array();
        let mut acc = Vec4::ZERO;
        for i in 0..N_LAMBDA {
            if w[i] != 0.0 {
                let k = self.index[i] as usize;
                let (a, b) = (t.cmf4[k], t.cmf4[k + 1]);
                acc += (a + (b - a) * f[i]) * w[i];
            }
        }
        let acc = acc * (t.inv_y_integral / N_LAMBDA as f32);
        [acc.x, acc.y, acc.z]
    }
}

impl SampledWavelengths {
    /// Per carried wavelength, the weight L(λᵢ) / (p(λᵢ) · 4) of radiance `l` in a Monte Carlo
    /// integral over wavelength (0 for terminated secondary wavelengths): Σᵢ wᵢ·g(λᵢ) estimates
    /// ∫ L(λ) g(λ) dλ for any g, e.g. g = 1 on a wavelength bin or g = x̄/∫ȳ (then the sum is
    /// [`SampledWavelengths::to_xyz`]).
    #[inline]
    pub fn integral_weights(&self, l: SampledSpectrum) -> [f32; N_LAMBDA] {
        let w = Vec4::select(self.pdf_per_nm.cmpgt(Vec4::ZERO), l / self.pdf_per_nm, Vec4::ZERO);
        (w / N_LAMBDA as f32).to_array()
    }

    /// Linear sRGB estimate of a reflectance `rho` (given at these wavelengths) lit by D65 with
    /// Y = 1, so that ρ = 1 gives (1, 1, 1) in expectation; the mean over many wavelength samples
    /// converges to `optics::spectrum::reflectance_to_linear_srgb` of the spectrum.
    #[inline]
    pub fn reflectance_to_srgb(&self, rho: SampledSpectrum) -> [f32; 3] {
        let t = tables();
        let w = self.integral_weights(rho);
        let f = self.frac.to_array();
        let mut acc = Vec4::ZERO;
        for i in 0..N_LAMBDA {
            if w[i] != 0.0 {
                let k = self.index[i] as usize;
                let (a, b) = (t.srgb_d65[k], t.srgb_d65[k + 1]);
                acc += (a + (b - a) * f[i]) * w[i];
            }
        }
        [acc.x, acc.y, acc.z]
    }
}

/// Wavelength bins of a spectral image: `count` bins of `width_nm` from `start_nm`, within the
/// sampled range 360–830 nm. Each bin's value is the mean spectral radiance over the bin,
/// (1/Δλ) ∫_bin L(λ) dλ, in the scene's radiance unit per nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralBins {
    /// Short edge of the first bin, nm.
    pub start_nm: f32,
    /// Width of every bin, nm.
    pub width_nm: f32,
    /// Number of bins.
    pub count: u32,
}

/// Most bins a spectral image may have (1-nm bins over 360–830 nm give 470).
pub const MAX_SPECTRAL_BINS: u32 = 4700;

impl SpectralBins {
    /// Bins from `start_nm` to `end_nm` in steps of `width_nm`; the range must lie within
    /// 360–830 nm and hold a whole number of bins.
    pub fn new(start_nm: f64, end_nm: f64, width_nm: f64) -> Result<SpectralBins, String> {
        if !(start_nm.is_finite() && end_nm.is_finite() && width_nm.is_finite()) {
            return Err(format!("bins {start_nm}:{end_nm}:{width_nm} nm are not finite numbers"));
        }
        let (lo, hi) = (LAMBDA_MIN_NM as f64, LAMBDA_MAX_NM as f64);
        if start_nm < lo || end_nm > hi {
            return Err(format!("bins {start_nm}–{end_nm} nm reach outside the rendered range {lo}–{hi} nm"));
        }
        if !(width_nm > 0.0) {
            return Err(format!("bin width must be > 0 nm, got {width_nm}"));
        }
        if !(end_nm > start_nm) {
            return Err(format!("bins must end after they start, got {start_nm}–{end_nm} nm"));
        }
        let n = (end_nm - start_nm) / width_nm;
        let count = n.round();
        if (n - count).abs() > 1e-6 * n.max(1.0) || count < 1.0 {
            return Err(format!("{start_nm}–{end_nm} nm is not a whole number of {width_nm}-nm bins ({n:.4})"));
        }
        if count > MAX_SPECTRAL_BINS as f64 {
            return Err(format!("{count} bins is more than {MAX_SPECTRAL_BINS}"));
        }
        Ok(SpectralBins { start_nm: start_nm as f32, width_nm: width_nm as f32, count: count as u32 })
    }

    /// Parse `START:END:WIDTH` in nm (e.g. `400:700:10`).
    pub fn parse(text: &str) -> Result<SpectralBins, String> {
        let parts: Vec<&str> = text.split(':').map(str::trim).collect();
        let [a, b, w] = parts.as_slice() else {
            return Err(format!("expected START:END:WIDTH in nm (e.g. 400:700:10), got `{text}`"));
        };
        let num = |s: &str| s.parse::<f64>().map_err(|_| format!("expected START:END:WIDTH in nm (e.g. 400:700:10), got `{text}`"));
        SpectralBins::new(num(a)?, num(b)?, num(w)?)
    }

    /// Long edge of the last bin, nm.
    pub fn end_nm(&self) -> f32 {
        self.start_nm + self.width_nm * self.count as f32
    }

    /// Edges (nm) of bin `k`.
    pub fn edges_nm(&self, k: u32) -> (f32, f32) {
        (self.start_nm + self.width_nm * k as f32, self.start_nm + self.width_nm * (k + 1) as f32)
    }

    /// The bin holding `lambda_nm` (bins are closed below, open above), if any.
    #[inline]
    pub fn index_of(&self, lambda_nm: f32) -> Option<usize> {
        let x = (lambda_nm - self.start_nm) / self.width_nm;
        if x >= 0.0 && x < self.count as f32 {
            Some((x as usize).min(self.count as usize - 1))
        } else {
            None
        }
    }

    /// EXR channel name of bin `k`: its centre wavelength in the spectral layout of Fichet,
    /// Pacanowski & Wilkie 2021 (JCGT 10(3), used by pbrt-v4's spectral film), `S0.` + the
    /// wavelength with a decimal comma + `nm`, e.g. `S0.405nm`, `S0.402,5nm`.
    pub fn channel_name(&self, k: u32) -> String {
        let (a, b) = self.edges_nm(k);
        let c = 0.5 * (a as f64 + b as f64);
        let text = format!("{:.3}", c);
        let text = text.trim_end_matches('0').trim_end_matches('.');
        format!("S0.{}nm", text.replace('.', ","))
    }
}

/// Exact CIE XYZ (Y = 1 for radiance 1) of a spectrum by summing it at 1-nm spacing over 360–830 nm
/// with the renderer's own colour-matching tables (reference for tests).
pub fn xyz_of(f: impl Fn(f32) -> f32) -> [f64; 3] {
    let t = tables();
    let mut xyz = [0f64; 3];
    for i in 0..=N_BINS {
        let v = f(LAMBDA_MIN_NM + i as f32) as f64;
        for c in 0..3 {
            xyz[c] += v * t.cmf[c][i] as f64;
        }
    }
    let k = t.inv_y_integral as f64;
    [xyz[0] * k, xyz[1] * k, xyz[2] * k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    #[test]
    fn pdf_integrates_to_one() {
        let s: f64 = (0..N_BINS).map(|k| wavelength_pdf(360.5 + k as f32) as f64).sum();
        assert!((s - 1.0).abs() < 1e-4, "{s}");
        assert_eq!(wavelength_pdf(359.0), 0.0);
        assert_eq!(wavelength_pdf(831.0), 0.0);
    }

    #[test]
    fn unit_radiance_gives_y_one() {
        // Monte Carlo estimate of the XYZ of a constant spectrum 1: Y → 1, X → ∫x̄/∫ȳ, Z → ∫z̄/∫ȳ.
        let reference = xyz_of(|_| 1.0);
        assert!((reference[1] - 1.0).abs() < 2e-3, "{reference:?}");
        let mut r = Pcg32::new(5, 5);
        let n = 100_000;
        let mut acc = [0f64; 3];
        let mut acc2 = [0f64; 3];
        for _ in 0..n {
            let wl = SampledWavelengths::sample(r.next_f32());
            let xyz = wl.to_xyz(Vec4::ONE);
            for c in 0..3 {
                acc[c] += xyz[c] as f64;
                acc2[c] += (xyz[c] as f64).powi(2);
            }
        }
        for c in 0..3 {
            let m = acc[c] / n as f64;
            let se = ((acc2[c] / n as f64 - m * m) / n as f64).sqrt();
            assert!((m - reference[c]).abs() < 4.0 * se + 1e-4, "c {c}: {m} vs {} (se {se})", reference[c]);
        }
    }

    #[test]
    fn wavelengths_follow_pdf() {
        // Fraction of wavelengths below 500 nm equals the integral of the density there.
        let expect: f64 = (0..140).map(|k| wavelength_pdf(360.5 + k as f32) as f64).sum();
        let mut r = Pcg32::new(8, 1);
        let n = 50_000;
        let mut below = 0usize;
        for _ in 0..n {
            let wl = SampledWavelengths::sample(r.next_f32());
            for l in wl.lambda_nm {
                assert!((LAMBDA_MIN_NM..=LAMBDA_MAX_NM).contains(&l));
            }
            if wl.lambda_nm[0] < 500.0 {
                below += 1;
            }
        }
        let f = below as f64 / n as f64;
        assert!((f - expect).abs() < 4.0 * (expect * (1.0 - expect) / n as f64).sqrt(), "{f} vs {expect}");
    }

    #[test]
    fn fast_lookups_match_the_dense_spectrum_and_cmf() {
        let d = DenseSpectrum::from_fn(|l| (l / 100.0).sin() + 1.5);
        let mut r = Pcg32::new(2, 9);
        for _ in 0..2000 {
            let wl = SampledWavelengths::sample(r.next_f32());
            let v = wl.eval(&d).to_array();
            for i in 0..N_LAMBDA {
                assert!((v[i] - d.eval(wl.lambda_nm[i])).abs() < 1e-5);
            }
            // to_xyz equals the direct formula.
            let l = Vec4::new(0.3, 1.0, 2.0, 0.5);
            let got = wl.to_xyz(l);
            let mut expect = [0f64; 3];
            for i in 0..N_LAMBDA {
                let c = cmf(wl.lambda_nm[i]);
                for k in 0..3 {
                    expect[k] += (l[i] * c[k] / wl.pdf_per_nm[i]) as f64 / optics::color::CIE_Y_INTEGRAL / 4.0;
                }
            }
            for k in 0..3 {
                assert!((got[k] as f64 - expect[k]).abs() < 1e-4 * expect[k].abs().max(1.0));
            }
            let f = SampledWavelengths::fixed(wl.lambda_nm);
            assert!((f.eval(&d) - wl.eval(&d)).abs().max_element() < 1e-5);
        }
    }
}
