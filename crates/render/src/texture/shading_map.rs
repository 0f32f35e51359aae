//! Normal and bump maps: textures that tilt the shading normal (Mitsuba 3's `normalmap` and
//! `bumpmap` BSDFs, pbrt-v4's `normalmap` and `displacement`).
//!
//! Both work in the frame of the unperturbed shading normal n and the surface's position
//! derivatives ∂p/∂u, ∂p/∂v ([`crate::accel::Accel::position_derivatives`]), with the tangent
//! s = ∂p/∂u made orthogonal to n and t = n × s, as Mitsuba 3's shading frame:
//!
//! * **normal map**: an RGB image (read linearly) whose texel c stores the tangent-space normal
//!   2c − 1; the shading normal is normalize(s x + t y + n z) of the bilinearly interpolated texel.
//! * **bump map**: a height image h(u, v) (one channel: the luminance of RGB texels), times
//!   `height_m` metres per unit value; the surface p + h n has the derivatives
//!   ∂p/∂u + n (∂h/∂u − n·∂p/∂u) and likewise in v (Mitsuba 3's construction, which replaces
//!   each derivative's normal component by the height's slope), and its normal is their cross
//!   product, turned to the side of the geometric normal. ∂h/∂u is the exact derivative of the
//!   bilinear interpolation.
//!
//! The perturbed normal replaces the shading normal for every BSDF evaluation and sample
//! ([`crate::interaction::Shading::at`]); the integrators' test that a direction lies on the
//! same side of the geometric surface as of the shading frame then keeps light from leaking
//! through the surface, as Mitsuba 3's test against the unperturbed frame does.

use super::{footprint, Filter, Wrap};
use crate::image_io::Image;
use glam::{Vec2, Vec3};

/// A texture that tilts the shading normal.
#[derive(Clone, Debug)]
pub enum ShadingMap {
    /// Tangent-space normals.
    Normal(NormalMap),
    /// A height field.
    Bump(BumpMap),
}

/// Tangent-space normals stored as RGB = (n + 1)/2.
#[derive(Clone, Debug)]
pub struct NormalMap {
    width: usize,
    height: usize,
    wrap: Wrap,
    filter: Filter,
    uv_scale: Vec2,
    /// Per texel, 2c − 1 (not normalised: the interpolation is normalised after filtering).
    normals: Vec<Vec3>,
}

/// Heights over the surface.
#[derive(Clone, Debug)]
pub struct BumpMap {
    width: usize,
    height: usize,
    wrap: Wrap,
    uv_scale: Vec2,
    /// Per texel, the height in metres (the texel's value times the map's `height_m`).
    heights_m: Vec<f32>,
}

impl NormalMap {
    /// The normal map of an image whose linear RGB texels are (n + 1)/2.
    pub fn new(img: &Image, wrap: Wrap, uv_scale: Vec2, filter: Filter) -> NormalMap {
        let normals = img.rgb.iter().map(|p| Vec3::new(2.0 * p[0] - 1.0, 2.0 * p[1] - 1.0, 2.0 * p[2] - 1.0)).collect();
        NormalMap { width: img.width as usize, height: img.height as usize, wrap, filter, uv_scale, normals }
    }

    /// The tangent-space normal at `uv` (unit; +z where the filtered texels cancel).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let (idx, w) = footprint(uv, self.uv_scale, self.width, self.height, self.wrap, self.filter);
        let n: Vec3 = (0..4).map(|k| w[k] * self.normals[idx[k]]).sum();
        let n = n.normalize_or_zero();
        if n == Vec3::ZERO {
            Vec3::Z
        } else {
            n
        }
    }
}

impl BumpMap {
    /// The bump map of an image: heights `height_m` × (the texel's luminance, Rec. 709 / sRGB
    /// weights, the value itself for a grey image).
    pub fn new(img: &Image, wrap: Wrap, uv_scale: Vec2, height_m: f32) -> BumpMap {
        let heights_m = img.rgb.iter().map(|p| height_m * (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])).collect();
        BumpMap { width: img.width as usize, height: img.height as usize, wrap, uv_scale, heights_m }
    }

    /// Height (m) at `uv`, bilinearly interpolated.
    #[inline]
    pub fn eval(&self, uv: Vec2) -> f32 {
        let (idx, w) = footprint(uv, self.uv_scale, self.width, self.height, self.wrap, Filter::Bilinear);
        (0..4).map(|k| w[k] * self.heights_m[idx[k]]).sum()
    }

    /// (∂h/∂u, ∂h/∂v) in metres per unit of texture coordinate: the exact derivative of the
    /// bilinear interpolation of [`BumpMap::eval`] (constant between texel centres).
    #[inline]
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        let (idx, w) = footprint(uv, self.uv_scale, self.width, self.height, self.wrap, Filter::Bilinear);
        // The footprint's weights are ((1 − fx)(1 − fy), fx (1 − fy), (1 − fx) fy, fx fy).
        let (fx, fy) = (w[1] + w[3], w[2] + w[3]);
        let h = idx.map(|i| self.heights_m[i]);
        let d_fx = (1.0 - fy) * (h[1] - h[0]) + fy * (h[3] - h[2]);
        let d_fy = (1.0 - fx) * (h[2] - h[0]) + fx * (h[3] - h[1]);
        // x = u·su·W − ½ and y = (1 − v·sv)·H − ½ (`footprint`).
        Vec2::new(d_fx * self.uv_scale.x * self.width as f32, -d_fy * self.uv_scale.y * self.height as f32)
    }
}

impl ShadingMap {
    /// The perturbed shading normal at texture coordinates `uv`, given the unperturbed unit
    /// shading normal `n`, the position derivatives `dpdu`, `dpdv` (m per unit of u and v) and
    /// the geometric normal `ng` (on the same side as `n`). Returns `n` where the result is not
    /// a finite unit vector.
    #[inline]
    pub fn perturb(&self, uv: Vec2, n: Vec3, dpdu: Vec3, dpdv: Vec3, ng: Vec3) -> Vec3 {
        let out = match self {
            ShadingMap::Normal(m) => {
                let s = (dpdu - n * n.dot(dpdu)).normalize_or_zero();
                if s == Vec3::ZERO {
                    return n;
                }
                let t = n.cross(s);
                let l = m.eval(uv);
                (s * l.x + t * l.y + n * l.z).normalize_or_zero()
            }
            ShadingMap::Bump(m) => {
                let g = m.gradient(uv);
                let du = dpdu + n * (g.x - n.dot(dpdu));
                let dv = dpdv + n * (g.y - n.dot(dpdv));
                let nb = du.cross(dv).normalize_or_zero();
                if nb.dot(ng) < 0.0 {
                    -nb
                } else {
                    nb
                }
            }
        };
        if out == Vec3::ZERO || !out.is_finite() {
            n
        } else {
            out
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 3]) -> Image {
        let rgb = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Image::from_rgb(w, h, rgb).unwrap()
    }

    #[test]
    fn bump_gradient_is_the_derivative_of_the_interpolation() {
        // A random height field: central differences of `eval` against `gradient` away from
        // texel centres (where the bilinear interpolation's derivative jumps).
        let mut s = 12345u32;
        let mut next = || {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            (s >> 8) as f32 / (1u32 << 24) as f32
        };
        let values: Vec<f32> = (0..35).map(|_| next()).collect();
        let img = image(7, 5, |x, y| {
            let v = values[(y * 7 + x) as usize];
            [v, v, v]
        });
        let m = BumpMap::new(&img, Wrap::Repeat, Vec2::new(1.5, 0.75), 0.01);
        let mut checked = 0;
        for i in 0..40 {
            for j in 0..40 {
                let uv = Vec2::new((i as f32 + 0.37) / 40.0, (j as f32 + 0.61) / 40.0);
                let e = 1e-4;
                let du = (m.eval(uv + Vec2::new(e, 0.0)) - m.eval(uv - Vec2::new(e, 0.0))) / (2.0 * e);
                let dv = (m.eval(uv + Vec2::new(0.0, e)) - m.eval(uv - Vec2::new(0.0, e))) / (2.0 * e);
                // Skip points within e of a texel-centre line (x or y crossing a half-integer).
                let x = uv.x * 1.5 * 7.0 - 0.5;
                let y = (1.0 - uv.y * 0.75) * 5.0 - 0.5;
                let near = |a: f32, step: f32| (a - a.round()).abs() < 2.0 * e * step;
                if near(x, 1.5 * 7.0) || near(y, 0.75 * 5.0) {
                    continue;
                }
                let g = m.gradient(uv);
                assert!((g.x - du).abs() < 2e-3 * (1.0 + du.abs()), "du at {uv}: {} vs {du}", g.x);
                assert!((g.y - dv).abs() < 2e-3 * (1.0 + dv.abs()), "dv at {uv}: {} vs {dv}", g.y);
                checked += 1;
            }
        }
        assert!(checked > 1400);
    }

    #[test]
    fn a_ramp_tilts_the_normal_by_its_slope() {
        // h = a·u on a plane p = (u L, v L, 0): the bumped surface (uL, vL, a u) has the normal
        // (−a/L, 0, 1)/‖…‖, exactly, for a linear ramp (bilinear interpolation is exact).
        let (w, a, l) = (16u32, 0.02f32, 0.5f32);
        // Texel i's centre is at u = (i + ½)/w: its value (i + ½)/w gives h = a·u with height_m = a.
        let img = image(w, 4, |x, _| {
            let v = (x as f32 + 0.5) / w as f32;
            [v, v, v]
        });
        let m = ShadingMap::Bump(BumpMap::new(&img, Wrap::Clamp, Vec2::ONE, a));
        let n = Vec3::Z;
        for &u in &[0.1f32, 0.33, 0.5, 0.87] {
            let nb = m.perturb(Vec2::new(u, 0.4), n, Vec3::new(l, 0.0, 0.0), Vec3::new(0.0, l, 0.0), n);
            let want = Vec3::new(-a / l, 0.0, 1.0).normalize();
            assert!((nb - want).length() < 1e-5, "{nb} vs {want}");
        }
        // The same tilt on the other side of the plane stays on the side of its normal.
        let nb = m.perturb(Vec2::new(0.5, 0.4), -n, Vec3::new(l, 0.0, 0.0), Vec3::new(0.0, l, 0.0), -n);
        assert!(nb.z < 0.0);
    }

    #[test]
    fn normal_map_texels_map_to_the_tangent_frame() {
        // A flat map (½, ½, 1) leaves the normal; a tilted texel (n + 1)/2 gives n in (s, t, n).
        let flat = ShadingMap::Normal(NormalMap::new(&image(2, 2, |_, _| [0.5, 0.5, 1.0]), Wrap::Repeat, Vec2::ONE, Filter::Bilinear));
        let n = Vec3::new(0.0, 1.0, 0.0);
        let (dpdu, dpdv) = (Vec3::new(2.0, 0.3, 0.0), Vec3::new(0.0, 0.0, -2.0));
        assert!((flat.perturb(Vec2::new(0.3, 0.3), n, dpdu, dpdv, n) - n).length() < 1e-6);
        let t = Vec3::new(0.6, -0.0, 0.8);
        let tilted = ShadingMap::Normal(NormalMap::new(&image(2, 2, |_, _| [(t.x + 1.0) / 2.0, (t.y + 1.0) / 2.0, (t.z + 1.0) / 2.0]), Wrap::Repeat, Vec2::ONE, Filter::Bilinear));
        let p = tilted.perturb(Vec2::new(0.7, 0.2), n, dpdu, dpdv, n);
        // s = ∂p/∂u without its normal part = +x; n = +y.
        let want = (Vec3::X * t.x + n * t.z).normalize();
        assert!((p - want).length() < 1e-6, "{p} vs {want}");
    }
}
