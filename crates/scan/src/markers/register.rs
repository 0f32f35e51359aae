//! Registration of a model's markers onto triangulated ones: Umeyama's closed form (IEEE TPAMI
//! 13(4), 1991) for a rotation, translation and optional uniform scale from known
//! correspondences, and RANSAC (Fischler & Bolles 1981) over correspondence hypotheses, since the
//! model's markers are unlabelled.
//!
//! Hypotheses: every triple of triangulated points (up to `max_triples`, drawn with a fixed seed
//! beyond that) against every ordered triple of model markers whose side lengths agree (within
//! the inlier distance, after the triple's own scale when scaling is allowed), each giving
//! Umeyama's transform of the three pairs (for a rigid fit the model pairs whose distance matches
//! the triple's first side are found by binary search). A hypothesis scores the model markers that
//! land within the inlier distance of a distinct triangulated point (nearest first); the best —
//! most inliers, then the least squared residual — is refitted on all its inliers until the
//! inlier set stops changing. The search ends early once a hypothesis places every marker, or
//! after [`MAX_HYPOTHESES`] scored hypotheses. Triangulated points left out are reported as outliers (wrong matches).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use anyhow::{bail, Result};
use nalgebra::{Matrix3, Vector3};

/// X′ = s·R·X + t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    /// Rotation (proper, det +1).
    pub rotation: Matrix3<f64>,
    /// Translation (target units).
    pub translation: Vector3<f64>,
    /// Uniform scale (target units per source unit; 1 for a rigid fit).
    pub scale: f64,
}

impl Similarity {
    /// Apply to a point.
    pub fn apply(&self, x: &Vector3<f64>) -> Vector3<f64> {
        self.rotation * x * self.scale + self.translation
    }
}

/// Largest ratio of the second to the first singular value of a centred point set that counts as
/// collinear.
const COLLINEAR: f64 = 1e-6;

/// Whether the points lie on one line (or one point).
pub fn collinear(p: &[Vector3<f64>]) -> bool {
    if p.len() < 3 {
        return true;
    }
    let mean = p.iter().sum::<Vector3<f64>>() / p.len() as f64;
    let cov = p.iter().fold(Matrix3::zeros(), |a, x| a + (x - mean) * (x - mean).transpose());
    let sv = cov.symmetric_eigenvalues();
    let mut s: Vec<f64> = sv.iter().map(|x| x.max(0.0).sqrt()).collect();
    s.sort_by(|a, b| b.total_cmp(a));
    !(s[0] > 0.0) || s[1] <= COLLINEAR * s[0]
}

/// Umeyama's least-squares similarity (or rigid transform, `with_scale` false) taking `src` onto
/// `dst`: minimises Σ|dst_i − (s·R·src_i + t)|². An error for fewer than 3 pairs, mismatched
/// lengths or collinear points.
pub fn umeyama(src: &[Vector3<f64>], dst: &[Vector3<f64>], with_scale: bool) -> Result<Similarity> {
    if src.len() != dst.len() {
        bail!("umeyama: {} source and {} target points", src.len(), dst.len());
    }
    if src.len() < 3 {
        bail!("too few correspondences: a rigid fit needs at least 3, got {}", src.len());
    }
    if collinear(src) || collinear(dst) {
        bail!("degenerate (collinear) markers: the points lie on one line, so a rotation about it is undetermined");
    }
    let n = src.len() as f64;
    let ms = src.iter().sum::<Vector3<f64>>() / n;
    let md = dst.iter().sum::<Vector3<f64>>() / n;
    let mut sigma = Matrix3::zeros();
    let mut var_s = 0.0;
    for (x, y) in src.iter().zip(dst) {
        let (a, b) = (x - ms, y - md);
        sigma += b * a.transpose();
        var_s += a.norm_squared();
    }
    sigma /= n;
    var_s /= n;
    let svd = sigma.svd(true, true);
    let (u, vt) = (svd.u.unwrap(), svd.v_t.unwrap());
    let mut d = Vector3::new(1.0, 1.0, 1.0);
    if (u.determinant() * vt.determinant()) < 0.0 {
        d[2] = -1.0;
    }
    let r = u * Matrix3::from_diagonal(&d) * vt;
    let scale = if with_scale { svd.singular_values.dot(&d) / var_s } else { 1.0 };
    let t = md - r * ms * scale;
    Ok(Similarity { rotation: r, translation: t, scale })
}

/// Most hypotheses [`register`] scores (each an Umeyama fit and an inlier count).
pub const MAX_HYPOTHESES: usize = 200_000;

/// Settings of [`register`].
#[derive(Clone, Copy, Debug)]
pub struct RegisterSettings {
    /// Fit a uniform scale as well (a similarity).
    pub with_scale: bool,
    /// Distance (target units) within which a transformed model marker counts as landing on a
    /// triangulated one; None: 2 % of the triangulated markers' extent ([`robust_extent`], which
    /// leaves far wrong matches out).
    pub inlier_distance: Option<f64>,
    /// Most triples of triangulated points tried.
    pub max_triples: usize,
    /// Seed of the triple draw when there are more than `max_triples`.
    pub seed: u64,
}

impl Default for RegisterSettings {
    fn default() -> Self {
        RegisterSettings { with_scale: false, inlier_distance: None, max_triples: 2000, seed: 15 }
    }
}

/// A registration.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    /// Model → target.
    pub transform: Similarity,
    /// RMS distance of the inliers after the fit (target units).
    pub rms: f64,
    /// (model index, target index, residual) of each inlier.
    pub pairs: Vec<(usize, usize, f64)>,
    /// Target points no model marker landed on.
    pub outliers: Vec<usize>,
    /// The inlier distance used (target units).
    pub inlier_distance: f64,
}

/// Inliers of a transform: model markers within `tau` of a distinct target point, nearest pairs
/// first. Returns the pairs and their squared-residual sum.
fn inliers(tr: &Similarity, model: &[Vector3<f64>], target: &[Vector3<f64>], tau: f64) -> (Vec<(usize, usize, f64)>, f64) {
    let moved: Vec<Vector3<f64>> = model.iter().map(|m| tr.apply(m)).collect();
    let mut all: Vec<(f64, usize, usize)> = Vec::new();
    for (i, m) in moved.iter().enumerate() {
        for (j, p) in target.iter().enumerate() {
            let d = (m - p).norm();
            if d <= tau {
                all.push((d, i, j));
            }
        }
    }
    all.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (mut um, mut ut) = (vec![false; model.len()], vec![false; target.len()]);
    let mut pairs = Vec::new();
    let mut ss = 0.0;
    for (d, i, j) in all {
        if !um[i] && !ut[j] {
            um[i] = true;
            ut[j] = true;
            pairs.push((i, j, d));
            ss += d * d;
        }
    }
    pairs.sort_by_key(|p| p.0);
    (pairs, ss)
}

/// The largest distance between the points that lie within 3 times the median distance of the
/// coordinate-wise median point from it: the extent of the markers without the few wrong matches
/// that triangulate far away (nearly parallel rays), which would otherwise set the inlier distance.
pub fn robust_extent(t: &[Vector3<f64>]) -> f64 {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let c = Vector3::new(median(t.iter().map(|p| p.x).collect()), median(t.iter().map(|p| p.y).collect()), median(t.iter().map(|p| p.z).collect()));
    let r = median(t.iter().map(|p| (p - c).norm()).collect());
    let core: Vec<&Vector3<f64>> = t.iter().filter(|p| (*p - c).norm() <= 3.0 * r).collect();
    core.iter().flat_map(|a| core.iter().map(move |b| (*a - *b).norm())).fold(0.0, f64::max)
}

/// Registers `model` (unlabelled marker positions) onto `target` (triangulated markers) by
/// RANSAC over correspondence triples (module documentation). Errors: fewer than 3 target points
/// ("too few matches"), fewer than 3 model markers, collinear model or target markers, or no
/// hypothesis with 3 inliers.
pub fn register(model: &[[f64; 3]], target: &[[f64; 3]], s: &RegisterSettings) -> Result<Registration> {
    let m: Vec<Vector3<f64>> = model.iter().map(|p| Vector3::from(*p)).collect();
    let t: Vec<Vector3<f64>> = target.iter().map(|p| Vector3::from(*p)).collect();
    if t.len() < 3 {
        bail!("too few matches: registration needs at least 3 markers triangulated in both views, got {}", t.len());
    }
    if m.len() < 3 {
        bail!("the model has {} markers; registration needs at least 3", m.len());
    }
    if collinear(&m) {
        bail!("degenerate (collinear) markers: the model's markers lie on one line");
    }
    if collinear(&t) {
        bail!("degenerate (collinear) markers: the triangulated markers lie on one line");
    }
    let tau = s.inlier_distance.unwrap_or_else(|| 0.02 * robust_extent(&t));
    if !(tau > 0.0) {
        bail!("inlier distance must be positive, got {tau}");
    }
    // Triples of target points.
    let nt = t.len();
    let mut triples: Vec<[usize; 3]> = Vec::new();
    for i in 0..nt {
        for j in i + 1..nt {
            for k in j + 1..nt {
                triples.push([i, j, k]);
            }
        }
    }
    if triples.len() > s.max_triples {
        let mut rng = render::math::sampling::Pcg32::new(s.seed, 0x6D61_726B);
        for i in 0..s.max_triples {
            let last = triples.len() - 1;
            let j = i + (rng.next_f64() * (triples.len() - i) as f64) as usize;
            triples.swap(i, j.min(last));
        }
        triples.truncate(s.max_triples);
    }
    let nm = m.len();
    let mut best: Option<(usize, f64, Similarity)> = None;
    let d = |a: &Vector3<f64>, b: &Vector3<f64>| (a - b).norm();
    // Ordered pairs of model markers by their distance: a rigid hypothesis's first side is looked
    // up among them instead of trying every ordered model triple.
    let mut model_pairs: Vec<(f64, usize, usize)> = (0..nm).flat_map(|a| (0..nm).filter(move |&b| b != a).map(move |b| (a, b))).map(|(a, b)| (d(&m[a], &m[b]), a, b)).collect();
    model_pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let all_in = nm.min(nt);
    let mut hypotheses = 0usize;
    'triples: for tri in &triples {
        let tp = [t[tri[0]], t[tri[1]], t[tri[2]]];
        if collinear(&tp) {
            continue;
        }
        let sides = [d(&tp[0], &tp[1]), d(&tp[1], &tp[2]), d(&tp[0], &tp[2])];
        let first: &[(f64, usize, usize)] = if s.with_scale {
            &model_pairs
        } else {
            let lo = model_pairs.partition_point(|p| p.0 < sides[0] - 2.0 * tau);
            let hi = model_pairs.partition_point(|p| p.0 <= sides[0] + 2.0 * tau);
            &model_pairs[lo..hi]
        };
        for &(_, a, b) in first {
            for c in 0..nm {
                if c == a || c == b {
                    continue;
                }
                let mp = [m[a], m[b], m[c]];
                let ms = [d(&mp[0], &mp[1]), d(&mp[1], &mp[2]), d(&mp[0], &mp[2])];
                let k = if s.with_scale { (sides[0] + sides[1] + sides[2]) / (ms[0] + ms[1] + ms[2]) } else { 1.0 };
                if !(k > 0.0) || (0..3).any(|q| (sides[q] - k * ms[q]).abs() > 2.0 * tau) {
                    continue;
                }
                let Ok(tr) = umeyama(&mp, &tp, s.with_scale) else { continue };
                let (pairs, ss) = inliers(&tr, &m, &t, tau);
                hypotheses += 1;
                let better = match &best {
                    None => true,
                    Some((n, e, _)) => pairs.len() > *n || (pairs.len() == *n && ss < *e),
                };
                if better {
                    best = Some((pairs.len(), ss, tr));
                }
                // Every marker placed: no hypothesis can do better than the refit below. A model
                // with many markers (a regular grid matches itself in many ways) stops after
                // `MAX_HYPOTHESES` scored hypotheses.
                if best.as_ref().is_some_and(|b| b.0 == all_in) || hypotheses >= MAX_HYPOTHESES {
                    break 'triples;
                }
            }
        }
    }
    let Some((n, _, mut tr)) = best else {
        bail!("no consistent registration: no triple of triangulated markers matches a triple of model markers within {tau:.4} (the inlier distance)");
    };
    if n < 3 {
        bail!("no consistent registration: the best hypothesis puts only {n} model markers within {tau:.4} of triangulated ones");
    }
    let (mut pairs, _) = inliers(&tr, &m, &t, tau);
    for _ in 0..10 {
        let src: Vec<Vector3<f64>> = pairs.iter().map(|p| m[p.0]).collect();
        let dst: Vec<Vector3<f64>> = pairs.iter().map(|p| t[p.1]).collect();
        tr = umeyama(&src, &dst, s.with_scale)?;
        let (next, _) = inliers(&tr, &m, &t, tau);
        let same = next.iter().map(|p| (p.0, p.1)).eq(pairs.iter().map(|p| (p.0, p.1)));
        pairs = next;
        if same || pairs.len() < 3 {
            break;
        }
    }
    if pairs.len() < 3 {
        bail!("no consistent registration: refitting left {} inliers", pairs.len());
    }
    let rms = (pairs.iter().map(|p| p.2 * p.2).sum::<f64>() / pairs.len() as f64).sqrt();
    let outliers = (0..nt).filter(|j| !pairs.iter().any(|p| p.1 == *j)).collect();
    Ok(Registration { transform: tr, rms, pairs, outliers, inlier_distance: tau })
}
