//! Density grids: a medium whose coefficients are σ(λ) · ρ(x), ρ a dimensionless density
//! sampled on a regular grid over a box and interpolated trilinearly.
//!
//! Conventions follow Mitsuba 3's `gridvolume` (and its file format, "VOL" version 3): value
//! (x, y, z) of an nx × ny × nz grid sits at the centre of its cell, ((x + ½)/nx, (y + ½)/ny,
//! (z + ½)/nz) of the unit cube that the box is; between centres the density is trilinear,
//! beyond the outermost centres it is clamped to the nearest one (Mitsuba's default
//! `wrap_mode = "clamp"`), so it is defined everywhere.
//!
//! Along a ray the trilinear density is a polynomial of degree ≤ 3 between the points where any
//! axis crosses a plane of cell centres (on one side of those planes the clamped axis is
//! constant): within a piece each axis's interpolation weight is linear in the ray parameter,
//! so the blend of the cell's eight values is a product of three linear factors.
//! [`DensityGrid::depth`] integrates that cubic exactly piece by piece, and
//! [`DensityGrid::distance_at_depth`] inverts the integral (Newton's method on the piece's
//! quartic, kept in its bracket). So a medium with σ(λ, x) = σ(λ) ρ(x)
//! needs no null collisions: its transmittance at every wavelength is e^{−σ(λ) τ} with the
//! density-weighted length τ = ∫ρ ds, exactly as a homogeneous medium's is e^{−σ(λ) t}, and free
//! flights are drawn in τ with the hero wavelength's σ_t and mapped back to distance.
//! (Trilinear interpolation as in Mitsuba 3 and pbrt-v4's `GridMedium`; the exact integral
//! instead of their delta and ratio tracking is this module's choice: unbiased, and shadow rays
//! get the transmittance without noise.)

use anyhow::{bail, Context, Result};
use glam::Vec3;

/// The contents of a Mitsuba volume file ([`DensityGrid::read_vol`]).
#[derive(Clone, Debug, PartialEq)]
pub struct VolFile {
    /// Cells along x, y, z.
    pub n: [usize; 3],
    /// Values per cell: 1 (a density or grey albedo) or 3 (an RGB albedo).
    pub channels: usize,
    /// Values, channels fastest, then x: `values[((z · ny + y) · nx + x) · channels + c]`.
    pub values: Vec<f32>,
    /// The box stored in the file (in the file's units): its minimum …
    pub min: [f64; 3],
    /// … and maximum corner.
    pub max: [f64; 3],
}

/// A density grid over an axis-aligned box (metres).
#[derive(Clone, Debug)]
pub struct DensityGrid {
    /// Cells along x, y, z.
    n: [usize; 3],
    /// Densities (dimensionless, ≥ 0), x fastest: `values[(z · ny + y) · nx + x]`.
    values: Vec<f32>,
    /// The box the unit cube maps to, m.
    min_m: [f64; 3],
    /// Its size per axis, m.
    size_m: [f64; 3],
}

/// One piece of a ray's density: between ray parameters `s0` and `s1` (m) the density is the
/// cubic c0 + c1 u + c2 u² + c3 u³ of u = (s − s0)/(s1 − s0) ∈ [0, 1]; a piece reaching to
/// infinity is the constant c0.
struct Piece {
    s0: f64,
    s1: f64,
    c: [f64; 4],
}

impl Piece {
    /// ∫ρ ds over the piece (m).
    fn integral(&self) -> f64 {
        let h = self.s1 - self.s0;
        let [c0, c1, c2, c3] = self.c;
        if h.is_infinite() {
            return if c0 > 0.0 { f64::INFINITY } else { 0.0 };
        }
        h * (c0 + c1 / 2.0 + c2 / 3.0 + c3 / 4.0)
    }

    /// The ray parameter s in the piece where ∫_{s0}^{s} ρ = `target` (0 ≤ target ≤ the
    /// piece's integral).
    fn invert(&self, target: f64) -> f64 {
        let h = self.s1 - self.s0;
        let [c0, c1, c2, c3] = self.c;
        if h.is_infinite() {
            // A constant (clamped) piece to infinity.
            return self.s0 + target / c0;
        }
        let g = |u: f64| h * u * (c0 + u * (c1 / 2.0 + u * (c2 / 3.0 + u * c3 / 4.0)));
        let rho = |u: f64| (c0 + u * (c1 + u * (c2 + u * c3))).max(0.0);
        let total = self.integral();
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        let mut u = if total > 0.0 { (target / total).clamp(0.0, 1.0) } else { 0.0 };
        for _ in 0..60 {
            let e = g(u) - target;
            if e > 0.0 {
                hi = u;
            } else {
                lo = u;
            }
            if (hi - lo) < 1e-12 || e.abs() <= 1e-13 * total.max(f64::MIN_POSITIVE) {
                break;
            }
            let d = h * rho(u);
            let next = if d > 0.0 { u - e / d } else { f64::NAN };
            u = if next > lo && next < hi { next } else { 0.5 * (lo + hi) };
        }
        self.s0 + u * h
    }
}

impl DensityGrid {
    /// A grid of `n` = [nx, ny, nz] cells (values x fastest) over the box `min_m`–`max_m`
    /// (metres); values must be finite and ≥ 0.
    pub fn new(n: [usize; 3], values: Vec<f32>, min_m: [f64; 3], max_m: [f64; 3]) -> Result<DensityGrid> {
        if n.contains(&0) {
            bail!("the grid needs at least one cell along each axis, got {}×{}×{}", n[0], n[1], n[2]);
        }
        let count = n[0].checked_mul(n[1]).and_then(|a| a.checked_mul(n[2])).context("too many cells")?;
        if values.len() != count {
            bail!("{}×{}×{} cells need {count} values, got {}", n[0], n[1], n[2], values.len());
        }
        if let Some((i, v)) = values.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
            bail!("density {v} at cell {i} (x fastest): densities must be finite and ≥ 0");
        }
        let mut size_m = [0.0; 3];
        for a in 0..3 {
            size_m[a] = max_m[a] - min_m[a];
            if !(min_m[a].is_finite() && max_m[a].is_finite() && size_m[a] > 0.0) {
                bail!("the box must have max > min on every axis, got min {min_m:?}, max {max_m:?}");
            }
        }
        Ok(DensityGrid { n, values, min_m, size_m })
    }

    /// Cells along x, y, z.
    pub fn resolution(&self) -> [usize; 3] {
        self.n
    }

    /// The box (min, max), m.
    pub fn bounds_m(&self) -> ([f64; 3], [f64; 3]) {
        (self.min_m, [0, 1, 2].map(|a| self.min_m[a] + self.size_m[a]))
    }

    /// The largest density.
    pub fn max_density(&self) -> f32 {
        self.values.iter().cloned().fold(0.0, f32::max)
    }

    /// Density at point `p` (m).
    pub fn density(&self, p: Vec3) -> f32 {
        self.density_c(self.to_cells([p.x as f64, p.y as f64, p.z as f64])) as f32
    }

    /// The eight cells whose values the trilinear interpolation at `p` (m) blends, and their
    /// weights (summing to 1); cells repeat along an axis of one cell. Grids of other values
    /// over the same cells (an RGB albedo) interpolate with these.
    pub fn corners(&self, p: Vec3) -> ([usize; 8], [f32; 8]) {
        let c = self.to_cells([p.x as f64, p.y as f64, p.z as f64]);
        let (i0, w) = self.base_cell(c);
        let [nx, ny, _] = self.n;
        let step = |a: usize| usize::from(self.n[a] > 1);
        let mut idx = [0usize; 8];
        let mut wt = [0f32; 8];
        for k in 0..8 {
            let (bx, by, bz) = (k & 1, (k >> 1) & 1, (k >> 2) & 1);
            let (x, y, z) = (i0[0] + bx * step(0), i0[1] + by * step(1), i0[2] + bz * step(2));
            idx[k] = (z * ny + y) * nx + x;
            let f = |b: usize, t: f64| if b == 1 { t } else { 1.0 - t };
            wt[k] = (f(bx, w[0]) * f(by, w[1]) * f(bz, w[2])) as f32;
        }
        (idx, wt)
    }

    /// The cell (lower corner index per axis) and the interpolation weight of the upper one,
    /// at cell-centre coordinates `c` (clamped to the outer centres).
    #[inline]
    fn base_cell(&self, c: [f64; 3]) -> ([usize; 3], [f64; 3]) {
        let mut i0 = [0usize; 3];
        let mut w = [0f64; 3];
        for a in 0..3 {
            let n = self.n[a];
            if n == 1 {
                continue;
            }
            let x = c[a].clamp(0.0, (n - 1) as f64);
            let i = (x.floor() as usize).min(n - 2);
            i0[a] = i;
            w[a] = x - i as f64;
        }
        (i0, w)
    }

    /// Cell-centre coordinates of a point: c = u·n − ½ (u in the unit cube), so value i sits
    /// at c = i.
    #[inline]
    fn to_cells(&self, p: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|a| (p[a] - self.min_m[a]) / self.size_m[a] * self.n[a] as f64 - 0.5)
    }

    /// The trilinear density at cell-centre coordinates `c` (clamped to the outer centres).
    fn density_c(&self, c: [f64; 3]) -> f64 {
        let (i0, w) = self.base_cell(c);
        let [nx, ny, _] = self.n;
        let at = |x: usize, y: usize, z: usize| self.values[(z * ny + y) * nx + x] as f64;
        let step = |a: usize| usize::from(self.n[a] > 1);
        let (x0, y0, z0) = (i0[0], i0[1], i0[2]);
        let (x1, y1, z1) = (x0 + step(0), y0 + step(1), z0 + step(2));
        let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
        let c00 = lerp(at(x0, y0, z0), at(x1, y0, z0), w[0]);
        let c10 = lerp(at(x0, y1, z0), at(x1, y1, z0), w[0]);
        let c01 = lerp(at(x0, y0, z1), at(x1, y0, z1), w[0]);
        let c11 = lerp(at(x0, y1, z1), at(x1, y1, z1), w[0]);
        lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2])
    }

    /// The density along cell-centre coordinates a + b·s for s = s0 + u·h, u ∈ [0, 1], as the
    /// cubic's coefficients in u, for a piece that no plane of cell centres crosses: each axis's
    /// interpolation weight is linear in u (or constant where it is clamped), so the trilinear
    /// blend of the cell's eight values is a product of three linear factors.
    fn cell_cubic(&self, a: [f64; 3], b: [f64; 3], s0: f64, h: f64) -> [f64; 4] {
        let mut i0 = [0usize; 3];
        let mut w = [[0f64; 2]; 3];
        for k in 0..3 {
            let n = self.n[k];
            if n == 1 {
                continue;
            }
            let (start, slope) = (a[k] + b[k] * s0, b[k] * h);
            let mid = start + 0.5 * slope;
            let last = (n - 1) as f64;
            (i0[k], w[k]) = if mid <= 0.0 {
                (0, [0.0, 0.0])
            } else if mid >= last {
                (n - 2, [1.0, 0.0])
            } else {
                let i = (mid.floor() as usize).min(n - 2);
                (i, [start - i as f64, slope])
            };
        }
        let [nx, ny, _] = self.n;
        let step = |k: usize| usize::from(self.n[k] > 1);
        // The cell's eight values: offsets along x, y, z from its first corner.
        let base = (i0[2] * ny + i0[1]) * nx + i0[0];
        let (dx, dy, dz) = (step(0), step(1) * nx, step(2) * nx * ny);
        let v = &self.values[base..=base + dx + dy + dz];
        let at = |x: usize, y: usize, z: usize| v[x * dx + y * dy + z * dz] as f64;
        // a + (b − a)·w for polynomials a, b of degree < 3 and w linear.
        let lerp = |p: [f64; 4], q: [f64; 4], w: [f64; 2]| -> [f64; 4] {
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2], q[3] - p[3]];
            [p[0] + d[0] * w[0], p[1] + d[1] * w[0] + d[0] * w[1], p[2] + d[2] * w[0] + d[1] * w[1], p[3] + d[3] * w[0] + d[2] * w[1]]
        };
        let c = |v: f64| [v, 0.0, 0.0, 0.0];
        let along_x = |y: usize, z: usize| lerp(c(at(0, y, z)), c(at(1, y, z)), w[0]);
        let along_y = |z: usize| lerp(along_x(0, z), along_x(1, z), w[1]);
        lerp(along_y(0), along_y(1), w[2])
    }

    /// Calls `visit` with the pieces of the ray o + s·d, s ∈ [0, t_max] (m), in order, until it
    /// returns false; the last piece may reach to infinity (a clamped, constant density).
    fn pieces(&self, o: Vec3, d: Vec3, t_max: f64, mut visit: impl FnMut(&Piece) -> bool) {
        let a = self.to_cells([o.x as f64, o.y as f64, o.z as f64]);
        let b: [f64; 3] = [0, 1, 2].map(|k| [d.x, d.y, d.z][k] as f64 / self.size_m[k] * self.n[k] as f64);
        // Per axis: the next plane of centres (an integer c in [0, n − 1]) the ray crosses
        // after s, as the ray parameter; infinity when there is none.
        let next = |k: usize, s: f64| -> f64 {
            let n = self.n[k];
            if b[k] == 0.0 || n == 1 {
                return f64::INFINITY;
            }
            let c = a[k] + b[k] * s;
            let plane = if b[k] > 0.0 { (c.floor() + 1.0).max(0.0) } else { (c.ceil() - 1.0).min((n - 1) as f64) };
            if plane < 0.0 || plane > (n - 1) as f64 {
                return f64::INFINITY;
            }
            let t = (plane - a[k]) / b[k];
            // Rounding may put the crossing at or before s: step one plane further.
            if t <= s {
                let plane = plane + b[k].signum();
                if plane < 0.0 || plane > (n - 1) as f64 {
                    return f64::INFINITY;
                }
                return (plane - a[k]) / b[k];
            }
            t
        };
        let mut s = 0.0f64;
        let mut guard = 0usize;
        let limit = 4 * (self.n[0] + self.n[1] + self.n[2]) + 16;
        while s < t_max && guard < limit {
            guard += 1;
            let s1 = next(0, s).min(next(1, s)).min(next(2, s)).min(t_max);
            // Beyond the last plane every axis is clamped or parallel to its planes: constant.
            let piece = if s1.is_infinite() {
                Piece { s0: s, s1, c: [self.cell_cubic(a, b, s, 1.0)[0], 0.0, 0.0, 0.0] }
            } else {
                Piece { s0: s, s1, c: self.cell_cubic(a, b, s, s1 - s) }
            };
            if !visit(&piece) {
                return;
            }
            s = s1;
        }
    }

    /// The density-weighted length τ = ∫ρ ds (m) of the ray o + s·d over s ∈ [0, t_max]
    /// (`d` a unit vector; t_max may be infinite).
    pub fn depth(&self, o: Vec3, d: Vec3, t_max: f32) -> f32 {
        let mut total = 0.0f64;
        self.pieces(o, d, t_max as f64, |p| {
            total += p.integral();
            total.is_finite()
        });
        total as f32
    }

    /// The distance s (m) along o + s·d at which the density-weighted length reaches `tau` (m),
    /// or `None` when it stays below `tau` all the way to infinity.
    pub fn distance_at_depth(&self, o: Vec3, d: Vec3, tau: f32) -> Option<f32> {
        self.flight(o, d, tau, f32::INFINITY).ok()
    }

    /// A free flight along o + s·d that ends where the density-weighted length reaches `tau`
    /// (m), if that is before `t_max` (m): `Ok(s)`; else `Err(τ over [0, t_max])`. One
    /// traversal for what [`Self::distance_at_depth`] and [`Self::depth`] give together.
    pub fn flight(&self, o: Vec3, d: Vec3, tau: f32, t_max: f32) -> Result<f32, f32> {
        let target = tau as f64;
        let mut acc = 0.0f64;
        let mut found = None;
        self.pieces(o, d, t_max as f64, |p| {
            let i = p.integral();
            if acc + i >= target && i > 0.0 {
                found = Some(p.invert(target - acc) as f32);
                return false;
            }
            acc += i;
            true
        });
        match found {
            Some(s) if s < t_max => Ok(s),
            _ => Err(acc as f32),
        }
    }

    /// Reads Mitsuba's volume format ("VOL", version 3, float32, 1 channel), little-endian:
    /// the grid and the box stored in the file (in the file's units).
    pub fn read_vol(bytes: &[u8]) -> Result<VolFile> {
        if bytes.len() < 48 || &bytes[0..3] != b"VOL" {
            bail!("not a Mitsuba volume file (it must start with \"VOL\" and a 48-byte header)");
        }
        if bytes[3] != 3 {
            bail!("volume file version {} (only version 3 is read)", bytes[3]);
        }
        let int = |i: usize| i32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
        let float = |i: usize| f32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
        let encoding = int(4);
        if encoding != 1 {
            bail!("volume encoding {encoding} (only 1, float32, is read)");
        }
        let (nx, ny, nz, channels) = (int(8), int(12), int(16), int(20));
        if nx <= 0 || ny <= 0 || nz <= 0 {
            bail!("volume size {nx}×{ny}×{nz}: every axis needs at least one cell");
        }
        if channels != 1 && channels != 3 {
            bail!("{channels} channels per cell (lucent reads 1, a density or grey albedo, or 3, an RGB albedo)");
        }
        let n = [nx as usize, ny as usize, nz as usize];
        let count = n[0].checked_mul(n[1]).and_then(|a| a.checked_mul(n[2])).context("too many cells")?;
        let expected = count.checked_mul(4 * channels as usize).and_then(|b| b.checked_add(48)).context("too many cells")?;
        if bytes.len() != expected {
            bail!("{}×{}×{} float32 cells of {channels} channel(s) need {expected} bytes, the file has {}", n[0], n[1], n[2], bytes.len());
        }
        let min = [float(24) as f64, float(28) as f64, float(32) as f64];
        let max = [float(36) as f64, float(40) as f64, float(44) as f64];
        let values = bytes[48..].chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect();
        Ok(VolFile { n, channels: channels as usize, values, min, max })
    }

    /// Mitsuba's volume format of a grid (version 3, float32, 1 channel), with the box `min`–`max`.
    pub fn write_vol(n: [usize; 3], values: &[f32], min: [f32; 3], max: [f32; 3]) -> Vec<u8> {
        Self::write_vol_channels(n, 1, values, min, max)
    }

    /// [`Self::write_vol`] of `channels` values per cell (channels fastest).
    pub fn write_vol_channels(n: [usize; 3], channels: usize, values: &[f32], min: [f32; 3], max: [f32; 3]) -> Vec<u8> {
        let mut out = Vec::with_capacity(48 + 4 * values.len());
        out.extend_from_slice(b"VOL");
        out.push(3);
        for v in [1i32, n[0] as i32, n[1] as i32, n[2] as i32, channels as i32] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in min.iter().chain(max.iter()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        for v in values {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::sampling::Pcg32;

    fn random_grid(seed: u64, n: [usize; 3]) -> DensityGrid {
        let mut rng = Pcg32::new(seed, 3);
        let values = (0..n[0] * n[1] * n[2]).map(|_| rng.next_f32() * 2.0).collect();
        DensityGrid::new(n, values, [-0.1, 0.2, -0.3], [0.3, 0.5, 0.2]).unwrap()
    }

    /// The exact piecewise integral against a fine midpoint sum of the trilinear density: two
    /// independent methods, on random rays through, into and past a random grid.
    #[test]
    fn depth_matches_a_fine_midpoint_sum() {
        let g = random_grid(1, [5, 4, 7]);
        let mut rng = Pcg32::new(9, 1);
        for _ in 0..40 {
            let o = Vec3::new(rng.next_f32() * 0.8 - 0.3, rng.next_f32() * 0.6 + 0.05, rng.next_f32() * 0.9 - 0.55);
            let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let t_max = 0.05 + rng.next_f32() * 0.9;
            let exact = g.depth(o, d, t_max) as f64;
            let steps = 200_000;
            let h = t_max as f64 / steps as f64;
            let sum: f64 = (0..steps).map(|i| g.density(o + d * ((i as f64 + 0.5) * h) as f32) as f64 * h).sum();
            assert!((exact - sum).abs() <= 2e-5 * sum.max(1e-3), "τ {exact} against the midpoint sum {sum}");
        }
    }

    /// Density at the cell centres is the stored value; halfway between two centres it is their
    /// mean; beyond the outer centres it is clamped.
    #[test]
    fn centres_interpolation_and_clamping() {
        let values = vec![1.0, 3.0, 5.0, 7.0];
        let g = DensityGrid::new([4, 1, 1], values, [0.0; 3], [4.0, 1.0, 1.0]).unwrap();
        for (x, want) in [(0.5, 1.0), (1.5, 3.0), (3.5, 7.0), (1.0, 2.0), (2.25, 4.5), (0.1, 1.0), (3.9, 7.0), (-5.0, 1.0), (9.0, 7.0)] {
            let v = g.density(Vec3::new(x, 0.3, 0.7));
            assert!((v - want).abs() < 1e-6, "x = {x}: {v} against {want}");
        }
        // Along the ramp from centre 0 to centre 3: τ = ∫ (2x) dx in cell units of 1 m.
        let tau = g.depth(Vec3::new(0.5, 0.5, 0.5), Vec3::X, 3.0);
        assert!((tau - 12.0).abs() < 1e-5, "{tau}");
    }

    /// distance_at_depth inverts depth: τ(s(τ)) = τ, over pieces of every kind, including the
    /// clamped density outside the box to infinity.
    #[test]
    fn distance_at_depth_inverts_depth() {
        let g = random_grid(2, [6, 3, 5]);
        let mut rng = Pcg32::new(4, 2);
        for _ in 0..200 {
            let o = Vec3::new(rng.next_f32() * 0.6 - 0.2, rng.next_f32() * 0.4 + 0.15, rng.next_f32() * 0.7 - 0.4);
            let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let tau = rng.next_f32() * 0.8;
            let s = g.distance_at_depth(o, d, tau).expect("the clamped density is positive everywhere");
            let back = g.depth(o, d, s);
            assert!((back - tau).abs() <= 2e-5 * tau.max(1e-3), "τ {tau} → s {s} → τ {back}");
        }
        // A grid that is zero at its border: beyond the box the depth stops growing.
        let mut values = vec![0.0; 27];
        values[13] = 1.0;
        let g = DensityGrid::new([3, 3, 3], values, [0.0; 3], [3.0; 3]).unwrap();
        let total = g.depth(Vec3::new(-1.0, 1.5, 1.5), Vec3::X, f32::INFINITY);
        assert!((total - 1.0).abs() < 1e-6, "{total}");
        assert_eq!(g.distance_at_depth(Vec3::new(-1.0, 1.5, 1.5), Vec3::X, 1.01), None);
    }

    /// Rays along the axes, in a plane of cell centres, starting on one, and grids with a
    /// single cell along an axis: the exact integral still equals the midpoint sum.
    #[test]
    fn degenerate_rays_and_grids() {
        for n in [[5, 4, 7], [1, 3, 2], [1, 1, 1], [4, 1, 1]] {
            let g = random_grid(7, n);
            // Cell centres of the grid's box lie at min + (i + ½)·size/n.
            let centre = |a: usize, i: f32| [-0.1f32, 0.2, -0.3][a] + (i + 0.5) * [0.4f32, 0.3, 0.5][a] / n[a] as f32;
            let rays = [
                (Vec3::new(-0.2, 0.3, 0.0), Vec3::X),
                (Vec3::new(0.5, 0.3, 0.0), -Vec3::X),
                (Vec3::new(0.1, 0.1, 0.0), Vec3::Y),
                (Vec3::new(0.1, 0.3, -0.5), Vec3::Z),
                (Vec3::new(centre(0, 1.0), centre(1, 0.0), -0.5), Vec3::new(0.0, 0.6, 0.8)),
                (Vec3::new(centre(0, 0.0), centre(1, 1.0), centre(2, 1.0)), Vec3::new(0.6, 0.0, -0.8)),
            ];
            for (o, d) in rays {
                let t_max = 0.9;
                let exact = g.depth(o, d, t_max) as f64;
                let steps = 100_000;
                let h = t_max as f64 / steps as f64;
                let sum: f64 = (0..steps).map(|i| g.density(o + d * ((i as f64 + 0.5) * h) as f32) as f64 * h).sum();
                assert!((exact - sum).abs() <= 3e-5 * sum.max(1e-3), "{n:?}, {o} + s·{d}: τ {exact} against {sum}");
                let s = g.distance_at_depth(o, d, 0.5 * exact as f32).unwrap();
                assert!((g.depth(o, d, s) as f64 - 0.5 * exact).abs() <= 3e-5 * exact, "{n:?}: inversion at half depth");
            }
        }
    }

    /// `flight` agrees with `distance_at_depth` where the flight ends before t_max, and with
    /// `depth` where it does not.
    #[test]
    fn flight_is_distance_or_depth() {
        let g = random_grid(3, [4, 5, 3]);
        let mut rng = Pcg32::new(8, 2);
        let (mut ended, mut through) = (0, 0);
        for _ in 0..300 {
            let o = Vec3::new(rng.next_f32() * 0.4 - 0.1, rng.next_f32() * 0.3 + 0.2, rng.next_f32() * 0.5 - 0.3);
            let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize();
            let (tau, t_max) = (rng.next_f32() * 0.4, rng.next_f32() * 0.5);
            match g.flight(o, d, tau, t_max) {
                Ok(s) => {
                    ended += 1;
                    let want = g.distance_at_depth(o, d, tau).unwrap();
                    assert!((s - want).abs() <= 1e-6 * want.max(1e-3) && s < t_max, "{s} against {want}");
                }
                Err(depth) => {
                    through += 1;
                    let want = g.depth(o, d, t_max);
                    assert!((depth - want).abs() <= 1e-6 * want.max(1e-3) && want <= tau * (1.0 + 1e-6), "{depth} against {want}, τ {tau}");
                }
            }
        }
        assert!(ended > 50 && through > 50, "{ended} flights ended, {through} passed");
    }

    #[test]
    fn vol_files_round_trip_and_bad_ones_are_refused() {
        let values: Vec<f32> = (0..24).map(|i| i as f32 * 0.5).collect();
        let bytes = DensityGrid::write_vol([2, 3, 4], &values, [-1.0, 0.0, 2.0], [1.0, 3.0, 6.0]);
        let v = DensityGrid::read_vol(&bytes).unwrap();
        assert_eq!(v, VolFile { n: [2, 3, 4], channels: 1, values: values.clone(), min: [-1.0, 0.0, 2.0], max: [1.0, 3.0, 6.0] });
        let err = |b: &[u8]| format!("{:#}", DensityGrid::read_vol(b).unwrap_err());
        assert!(err(&bytes[..60]).contains("need 144 bytes"), "{}", err(&bytes[..60]));
        assert!(err(b"PLY").contains("not a Mitsuba volume"));
        let mut v2 = bytes.clone();
        v2[20] = 2;
        assert!(err(&v2).contains("2 channels"));
        // Three channels: the same bytes are a third as many cells' colours, and a file of that
        // size reads back with its channels.
        v2[20] = 3;
        assert!(err(&v2).contains("need 336 bytes"), "{}", err(&v2));
        let rgb = DensityGrid::write_vol_channels([2, 1, 4], 3, &values, [0.0; 3], [1.0; 3]);
        let v = DensityGrid::read_vol(&rgb).unwrap();
        assert_eq!((v.n, v.channels, v.values.as_slice()), ([2, 1, 4], 3, values.as_slice()));
        let mut v3 = bytes.clone();
        v3[3] = 2;
        assert!(err(&v3).contains("version 2"));
        assert!(format!("{:#}", DensityGrid::new([2, 1, 1], vec![1.0, -1.0], [0.0; 3], [1.0; 3]).unwrap_err()).contains("≥ 0"));
        assert!(format!("{:#}", DensityGrid::new([2, 1, 1], vec![1.0, 1.0], [0.0; 3], [1.0, 0.0, 1.0]).unwrap_err()).contains("max > min"));
    }
}
