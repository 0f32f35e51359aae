//! `volpath`: volumetric path tracing through participating media, homogeneous or scaled by a
//! density grid.
//!
//! Media fill closed objects (`ObjectInfo::interior_medium`; the front face of the boundary is its
//! outside) and, optionally, all remaining space (`Scene::global_medium`). A path tracks the medium
//! it is in: a transmission through a medium-bounding object's surface enters its medium from the
//! front and returns to the global medium from the back; objects without a medium leave the
//! current medium unchanged. Index-matched boundaries (`interface` material: a dielectric of
//! relative index 1) are crossed without counting a bounce.
//!
//! Free-flight sampling with spectral MIS (Wilkie et al. 2014; pbrt-v4's `VolPathIntegrator`):
//! distances are sampled with the hero wavelength's extinction σ_t(λ₀), density
//! σ_t(λ₀) e^{−σ_t(λ₀) t}, or passed through to the next surface with probability e^{−σ_t(λ₀) t}.
//! Every wavelength i keeps its path throughput f_i/p₀ in `beta` and the ratio of the path
//! density had wavelength j been the hero to the actual one, p_j/p₀, in `r_u`; the estimate is
//! f_i / ((1/4) Σ_j p_j) = beta_i / mean(r_u) — the balance heuristic over the four choices of hero
//! (the carried wavelengths are a rotation-symmetric set, so each of them is equally likely to be
//! the hero). It stays unbiased and bounded when σ_t differs by orders of magnitude between the
//! carried wavelengths: a wavelength whose own free flights would rarely end where the hero's do
//! is down-weighted, not blown up. Real collisions always scatter, weighted by σ_s/σ_t (no
//! absorption events: better for albedo near 1); Russian roulette on the throughput (pbrt-v4's
//! rule: continue with probability min(1, max throughput)) ends paths.
//! Common factors of `beta` and `r_u` cancel, so after each event both are divided by mean(r_u)
//! (no overflow for e^{(σ₀−σ_i)t}). Once a dispersive interface has terminated the secondary
//! wavelengths, the hero alone is estimated: divisor r_u₀ instead of the mean. Phase functions
//! that vary with wavelength (Mie tables, spectral HG g) enter `r_u` too: after sampling μ from the
//! hero's p₀, lane j's weight and its density ratio are both multiplied by p_j(μ)/p₀(μ), so each
//! lane's estimate stays bounded by N_λ × its own path throughput (without this the weights of
//! the other lanes are products of thousands of phase ratios in dense media such as milk: still
//! unbiased, but with a heavy-tailed spread). Surface direction pdfs do not depend on the
//! wavelength (dispersion terminates the secondary wavelengths instead).
//!
//! Event-count roulette: in dense, high-albedo media the throughput stays near 1 for thousands of
//! collisions, so throughput roulette rarely ends a path, yet the few paths that wander deep
//! cost most of the time (whole milk: 10 % of the paths, those with more than 2000 collisions,
//! took ~80 % of the collisions and brought ~5 % of the light). After `EVENT_RR_START` real
//! collisions, and again after 4×, 16×, … as many, a path survives with probability ½ and its
//! throughput is doubled (unbiased; survivors of k rounds carry 2^k, growing as √events, the
//! weight that balances a roughly constant expected contribution against a cost growing with the
//! events, as in efficiency-aware roulette).
//!
//! Free flights that end closer to their origin than the medium's free-distance bound
//! (`Scene::medium_grids`, a conservative distance-to-any-surface grid over the medium's bounding
//! objects) skip the ray cast: no surface can lie in between, so the result is bit-for-bit the same.
//! Collisions deeper than the guide's reach after a flight that the grid or a path's surface-free
//! ball (below) proves free of surfaces run in a short inner loop, the deep walk, with the same
//! arithmetic and random numbers (bit-for-bit the same result, tested).
//!
//! Media that do not scatter at any wavelength (pure absorbers) are not sampled at all: the
//! Beer–Lambert transmittance e^{−σ_a t} multiplies the throughput deterministically.
//!
//! A medium with a density grid (σ(λ, x) = σ(λ) ρ(x), `medium::grid`) is the homogeneous case in
//! the density-weighted length τ = ∫ρ ds, which the grid integrates exactly along a ray: flights
//! are drawn in τ with the hero's σ_t and mapped back to distance, transmittances are
//! e^{−σ_t τ}, and a collision's ρ(x) is a factor common to every lane's σ_s, σ_t and density,
//! so the lane weights are the homogeneous ones with τ for t. The deep walk and refraction
//! guiding are for homogeneous media only.
//!
//! Refraction guiding: inside a medium whose boundary is a smooth dielectric, next-event
//! estimation is blocked, and light is found only by directions that leave towards a light by
//! chance. At a collision near the boundary a second, short *refracted branch* is played with
//! probability α = α_max e^{−σ_t d₀} (d₀: the larger of the medium's free-distance bound and the
//! path's surface-free ball, both lower bounds of the distance to the boundary; α_max is the
//! scene's `refraction_guiding`, 0 turns it off). A probe
//! ray towards the lights finds where the boundary is left; the branch's direction comes from
//! [`crate::light::refracted`]'s proposal — towards a point on an area light, refracted through
//! the tangent plane there — and it follows what the main path would do from there (free
//! flight, weighted by its probability of no collision instead of drawn; the real boundary's
//! Fresnel choices; pass-through interfaces) up to the first other surface, counting any
//! emission it meets. The main path continues with its phase-sampled
//! direction as before. Both count the same paths, so each is weighted by the balance heuristic
//! over the 2 × 4 techniques (phase or branch, each lane the hero; the branch's density per lane
//! is α_j q): the main path's emission reached along the branch's chain gets
//! mean(r_u)/mean(r_u + r_l α q), the probe being cast again only then. The plane only shapes
//! the variance; the expected image is unchanged (tests in `tests/suite/volpath.rs`).
//!
//! Split phase samples (`refraction_splits`, K): at a vertex where the branch may play, s_j =
//! K g_j² e^{−σ_j d₀} more directions (g_j the phase function's mean cosine at λ_j; none where
//! g_j ≤ 0, [`split_share`]) are drawn from the hero's phase function (in expectation: the
//! integer part and a Bernoulli draw), and those that the branch's tangent plane refracts onto a
//! light (T(w) = 1, [`crate::light::refracted::RefractedLights::reaches`], no ray cast) are traced
//! like the branch. Every technique's density then includes p_j s_j T(w), so the main path's
//! emission along the chain gets mean(r_u)/mean(r_u (1 + s T) + r_l α q): the forward lobe of a
//! peaked phase function meets the lights in many small contributions instead of rare large ones.
//!
//! Russian roulette leaves out the radiance scaling 1/η² of refractions (pbrt-v4's `etaScale`):
//! a path is not ended on entering a denser medium for a factor its way out gives back.
//!
//! Next-event estimation at surface and medium vertices: one light sample; the shadow ray passes
//! index-matched boundaries, switching media and accumulating the transmittance of every medium
//! it crosses; any other surface (including dielectric boundaries, as in pbrt) blocks it. From
//! inside a medium whose boundary is not index-matched NEE is skipped (it could only be blocked by
//! the boundary; emitters found by phase sampling then get MIS weight 1). Light sampling and
//! BSDF/phase sampling are combined with the power heuristic on the hero wavelength's direction
//! densities. Phase functions that vary with wavelength are sampled at the hero wavelength and
//! the others weighted by p(λᵢ)/p(λ₀).

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::math::fastexp::exp4;
use crate::math::geometry::Ray;
use crate::integrator::nee::{self, environment_emission};
use crate::integrator::settings::IntegratorSettings;
use crate::interaction::{offset_origin, shadow_t_max};
use crate::material::Material;
use crate::medium::{scattered, FreeFlightGrid, Medium, MediumLanes};
use crate::interaction::Shading;
use crate::light::refracted::{RefractedLights, RefractingPlane};
use crate::math::sampling::{power_heuristic, Frame, Pcg32};
use crate::scene::Scene;
use crate::math::spectral::{SampledSpectrum, SampledWavelengths};
use glam::{Vec3, Vec4};

/// Most consecutive index-matched crossings before a path is abandoned (guards against loops).
const MAX_CROSSINGS: u32 = 256;

/// Real collisions after which a path first plays the event-count roulette (see the module
/// documentation); then again after 4×, 16×, … as many.
pub const EVENT_RR_START: u32 = 256;

/// Tuning of [`li_volpath_with`] (all choices keep the estimate unbiased).
#[derive(Clone, Copy, Debug)]
pub struct VolpathOptions {
    /// Real collisions at which the event-count roulette starts (`u32::MAX`: never).
    pub event_rr_start: u32,
    /// Skip the ray cast of a free flight that ends within the medium's free-distance bound
    /// ([`crate::medium::FreeFlightGrid`]; same result, less time).
    pub free_flight_grid: bool,
    /// Run the collisions deep inside the medium, after flights that provably cross no surface,
    /// in a short inner loop (the same
    /// arithmetic and random numbers as the general loop, so the same result, less time; needs
    /// `free_flight_grid`).
    pub deep_walk: bool,
}

impl Default for VolpathOptions {
    fn default() -> Self {
        VolpathOptions { event_rr_start: EVENT_RR_START, free_flight_grid: true, deep_walk: true }
    }
}


/// Whether a material is an index-matched (pass-through) boundary.
#[inline]
pub fn index_matched(m: &Material) -> bool {
    match m {
        Material::Dielectric { ior, .. } => ior.samples().iter().all(|&x| x == 1.0),
        Material::Lambertian { .. } | Material::DiffuseTransmitter { .. } | Material::Black | Material::ThinDielectric { .. } | Material::Conductor { .. } | Material::Plastic { .. } | Material::Translucent(_) | Material::Blend { .. } => false,
    }
}

/// Transmittance e^{−σ t} per lane (t may be infinite: 1 where σ = 0, else 0).
#[inline]
fn transmittance(sigma_t: Vec4, t: f32) -> Vec4 {
    if t.is_finite() {
        exp4(-sigma_t * t)
    } else {
        Vec4::select(sigma_t.cmpeq(Vec4::ZERO), Vec4::ONE, Vec4::ZERO)
    }
}

/// e^{−(σ_i − σ_min) t}: the transmittance up to a factor common to all lanes.
#[inline]
fn relative_transmittance(sigma_t: Vec4, t: f32) -> Vec4 {
    let m = sigma_t.min_element();
    if t.is_finite() {
        exp4(-(sigma_t - Vec4::splat(m)) * t)
    } else {
        Vec4::select(sigma_t.cmpeq(Vec4::splat(m)), Vec4::ONE, Vec4::ZERO)
    }
}

/// The divisor of the spectral-MIS estimate: mean of `r_u`, or its hero entry once the
/// secondary wavelengths are terminated.
#[inline]
fn mis_divisor(r_u: Vec4, wl: &SampledWavelengths) -> f32 {
    if wl.secondary_terminated() {
        r_u.x
    } else {
        0.25 * (r_u.x + r_u.y + r_u.z + r_u.w)
    }
}

/// Weight of an emitter reached by phase sampling at a medium vertex that also sampled a light
/// (light pdf `light_pdf` per sr for this direction): the balance heuristic over light and phase
/// sampling with every wavelength as the hero, mean(r_u) / mean(r_u + light_pdf · r_l).
#[inline]
fn spectral_balance(r_u: Vec4, r_l: Vec4, light_pdf: f32, wl: &SampledWavelengths) -> f32 {
    spectral_balance_lanes(r_u, r_l, Vec4::splat(light_pdf), wl)
}

/// [`spectral_balance`] with a light-technique density that differs between the lanes (had lane
/// j been the hero, the technique would have had density `lp[j]`).
#[inline]
fn spectral_balance_lanes(r_u: Vec4, r_l: Vec4, lp: Vec4, wl: &SampledWavelengths) -> f32 {
    let d = mis_divisor(r_u + r_l * lp, wl);
    if !(d > 0.0) || !d.is_finite() {
        return 0.0;
    }
    mis_divisor(r_u, wl) / d
}

/// Divide `beta` and `r_u` by the MIS divisor (so `beta` is the effective throughput); false when
/// the path can no longer contribute.
#[inline]
fn renormalize(beta: &mut Vec4, r_u: &mut Vec4, r_l: &mut Vec4, wl: &SampledWavelengths) -> bool {
    let d = mis_divisor(*r_u, wl);
    if !(d > 0.0) || !d.is_finite() {
        return false;
    }
    *beta /= d;
    *r_u /= d;
    *r_l /= d;
    *beta != Vec4::ZERO && beta.is_finite()
}

/// Medium on the other side of object `object`'s surface for a ray crossing it from the front
/// (`front`) or back, coming from `current`.
#[inline]
fn cross(scene: &Scene, object: u32, front: bool, current: Option<u32>) -> Option<u32> {
    match scene.objects[object as usize].interior_medium {
        Some(m) => {
            if front {
                Some(m)
            } else {
                scene.global_medium
            }
        }
        None => current,
    }
}

/// Bit m set when next-event estimation can reach outside from within medium m (clear when it is
/// bounded by a non-index-matched surface, which would block every shadow ray); media beyond the
/// 64th always try.
fn nee_possible(scene: &Scene) -> u64 {
    let mut v = u64::MAX;
    for o in &scene.objects {
        if let Some(i) = o.interior_medium {
            if i < 64 && !index_matched(&scene.materials[o.material as usize]) {
                v &= !(1u64 << i);
            }
        }
    }
    if let Some(g) = scene.global_medium {
        if g < 64 {
            v |= 1u64 << g;
        }
    }
    v
}

/// Transmittance along a shadow ray from `o` (already offset off any surface) in direction `d`
/// over `dist` (m), starting in `medium`; `None` when a surface other than an index-matched
/// boundary blocks it.
fn shadow_transmittance(scene: &Scene, mut o: Vec3, d: Vec3, dist: f32, mut medium: Option<u32>, wl: &SampledWavelengths) -> Option<Vec4> {
    let mut tr = Vec4::ONE;
    let mut remaining = dist;
    for _ in 0..MAX_CROSSINGS {
        if !(remaining > 0.0) {
            return Some(tr);
        }
        let ray = Ray { o, d, t_min: 0.0, t_max: remaining };
        let hit = scene.intersect(&ray);
        let seg = hit.map(|h| h.t).unwrap_or(remaining);
        if let Some(m) = medium {
            let mm = &scene.media[m as usize];
            let (_, sigma_t) = mm.coefficients(wl);
            tr *= transmittance(sigma_t, mm.depth(o, d, seg));
            if tr == Vec4::ZERO {
                return None;
            }
        }
        let Some(h) = hit else { return Some(tr) };
        let obj = &scene.objects[h.object as usize];
        if !index_matched(&scene.materials[obj.material as usize]) {
            return None;
        }
        let sp = scene.accel.surface_point(&ray, &h);
        let front = sp.ng.dot(d) < 0.0;
        medium = cross(scene, h.object, front, medium);
        o = offset_origin(sp.p, sp.ng, d, scene.ray_epsilon_m);
        remaining -= seg + scene.ray_epsilon_m;
    }
    None
}

/// A ball that no surface of the scene meets, found by an exact distance query
/// ([`crate::accel::Accel::distance`]) where the medium's free-flight grid gives no guarantee:
/// a free flight that starts and ends inside it crosses no surface (the ball is convex), so
/// `volpath` skips its ray cast, and a collision inside it is at least its distance to the
/// sphere from every surface. A random walk near a wall, with a mean free path much shorter
/// than its distance to the wall, makes many flights in one ball.
#[derive(Clone, Copy, Default)]
struct FreeBall {
    centre: Vec3,
    /// Radius (m), shrunk against rounding; 0: no ball yet.
    radius: f32,
    /// Flights left before the next query: after a ball under two mean free paths wide
    /// (a walk at the wall), a few flights go straight to the ray cast.
    wait: u8,
}

impl FreeBall {
    /// Whether the segment from `a` to `b` lies in the ball, after moving the ball to `a` when
    /// `b` is outside the present one.
    fn contains(&mut self, scene: &Scene, grid: &FreeFlightGrid, a: Vec3, b: Vec3, mean_free_path: f32) -> bool {
        if self.inside(a) && self.inside(b) {
            return true;
        }
        if self.wait > 0 {
            self.wait -= 1;
            return false;
        }
        // A convex boundary gives the distance by its planes; else the BVH's distance query.
        let dist = match grid.convex() {
            Some(c) => c.distance(a).max(0.0),
            None => scene.accel.distance(a, f32::INFINITY),
        };
        let r = dist * (1.0 - 1e-4) - scene.ray_epsilon_m;
        let wait = if r < 2.0 * mean_free_path { 3 } else { 0 };
        *self = FreeBall { centre: a, radius: r.max(0.0), wait };
        self.inside(b)
    }

    /// Whether `p` lies in the ball (as [`Self::contains`] tests its ends).
    fn inside(&self, p: Vec3) -> bool {
        (p - self.centre).length() < self.radius
    }

    /// A lower bound (m) of the distance from `p` to every surface (0 outside the ball).
    fn bound(&self, p: Vec3) -> f32 {
        (self.radius - (p - self.centre).length()).max(0.0)
    }
}

/// Optical depth (in the carried wavelengths' smallest extinction) within which a medium vertex
/// aims part of its directions at the lights beyond a smooth dielectric boundary.
const GUIDE_REACH: f32 = 6.0;

/// The share of `refraction_splits` a medium vertex draws, per lane: g², g the phase function's
/// mean cosine at that lane's wavelength (0 for g ≤ 0). Split samples are phase-function samples;
/// they add to the branch's light samples only where the phase function is forward-peaked. On
/// the milk close-ups (docs/milk-glass.md) all K splits cost skim milk (g ≈ 0.2) a third more CPU
/// at unchanged noise, while whole milk (g ≈ 0.86) needs them.
#[inline]
fn split_share(g: Vec4) -> Vec4 {
    let g = g.max(Vec4::ZERO);
    g * g
}

/// Probability per lane (had that lane been the hero) that a vertex at `p` in `medium`
/// (extinction `sigma_t` per lane, m⁻¹) plays the refracted branch: α_max e^{−σ_t d}, d the
/// larger of the medium's free-distance bound at `p` and `ball_bound` (the path's
/// [`FreeBall::bound`]; both lower bounds of the distance to its boundary); `None`
/// beyond [`GUIDE_REACH`] optical depths (in the smallest extinction, the same for every hero).
fn guide_probability(scene: &Scene, rl: &RefractedLights, p: Vec3, medium: Option<u32>, sigma_t: Vec4, ball_bound: f32) -> Option<Vec4> {
    let s_min = sigma_t.min_element();
    if !(s_min > 0.0) {
        return None;
    }
    let d = match scene.medium_grid(medium) {
        Some(g) => g.free_distance(p).max(ball_bound).max(0.0),
        None => 0.0,
    };
    if d * s_min > GUIDE_REACH {
        return None;
    }
    Some(rl.alpha_max * exp4(-sigma_t * d))
}

/// The plane through which the refracted proposal aims from `p` (extinction `sigma_t` per lane,
/// m⁻¹): a probe ray towards the lights' target finds where it leaves the medium; that surface's
/// tangent plane, if it is a smooth dielectric within [`GUIDE_REACH`] optical depths. The same
/// whichever lane is the hero, as spectral MIS requires. `hint` is the path's last exit facet
/// of a convex boundary ([`crate::medium::convex::ConvexBoundary::exit_near`]).
fn exit_plane(scene: &Scene, rl: &RefractedLights, p: Vec3, medium: Option<u32>, sigma_t: Vec4, hint: &mut u32) -> Option<RefractingPlane> {
    let s_min = sigma_t.min_element();
    if !(s_min > 0.0) {
        return None;
    }
    let d = (rl.target - p).normalize_or_zero();
    if d == Vec3::ZERO {
        return None;
    }
    let probe = Ray { o: p, d, t_min: 0.0, t_max: GUIDE_REACH / s_min };
    // Inside a medium's closed convex boundary the first surface is where the probe leaves it
    // (`medium::convex`); else the BVH finds it.
    let convex = scene.medium_grid(medium).and_then(|g| g.convex());
    let exit = convex.and_then(|c| c.exit_near(p, d, hint).map(|e| (c.object(), e)));
    let (object, point, ng) = match exit {
        Some((object, (t, n))) => {
            if !(t <= probe.t_max) {
                return None;
            }
            (object, p + d * t, n)
        }
        None => {
            let h = scene.accel.intersect(&probe)?;
            let sp = scene.accel.surface_point(&probe, &h);
            (h.object, sp.p, sp.ng)
        }
    };
    let obj = &scene.objects[object as usize];
    let Material::Dielectric { ior, distrib, roughness: None, .. } = &scene.materials[obj.material as usize] else { return None };
    if !distrib.effectively_smooth() {
        return None;
    }
    // Leaving the object through its back face: index inside / outside is its ior; entering
    // another object through its front: the inverse.
    let leaving = ng.dot(d) > 0.0;
    let normal = if leaving { ng } else { -ng };
    let ior = ior.eval(GUIDE_LAMBDA_NM);
    let eta = if leaving { ior } else { 1.0 / ior };
    if !(normal.dot(point - p) > 0.0) || !(eta > 0.0) || !eta.is_finite() {
        return None;
    }
    Some(RefractingPlane { point, normal, eta })
}

/// A medium vertex whose phase-sampled direction `w` competes with a refracted branch: what the
/// main path needs to weigh emission it reaches along the branch's chain.
#[derive(Clone, Copy)]
struct GuidedVertex<'a> {
    rl: &'a RefractedLights,
    p: Vec3,
    medium: Option<u32>,
    /// The plane the vertex's probe found, if it probed (a branch or split was drawn).
    plane: Option<Option<RefractingPlane>>,
    w: Vec3,
    alpha: Vec4,
    splits: Vec4,
    sigma_t: Vec4,
}

impl GuidedVertex<'_> {
    /// The main path's balance-heuristic weight for emission reached along the branch's chain,
    /// mean(r_u) / mean(r_u (1 + s_j T(w)) + r_l α_j q(w)): against the branch (density α_j q)
    /// and the split phase samples (s_j more samples of the phase function, counted where
    /// T(w) = 1, i.e. where `w` refracted through the plane reaches a light). The plane is the
    /// one the vertex used, or, where it drew neither, the probe ray is cast only now.
    fn weight(&self, scene: &Scene, r_u: Vec4, r_l: Vec4, wl: &SampledWavelengths) -> f32 {
        let plane = match self.plane {
            Some(plane) => plane,
            None => exit_plane(scene, self.rl, self.p, self.medium, self.sigma_t, &mut 0),
        };
        let Some(plane) = plane else { return 1.0 };
        let q = self.rl.pdf(&plane, self.p, self.w);
        let t = if self.rl.reaches(&plane, self.p, self.w).is_some() { 1.0 } else { 0.0 };
        if !(q > 0.0) && t == 0.0 {
            return 1.0;
        }
        let d = mis_divisor(r_u * (Vec4::ONE + self.splits * t) + r_l * self.alpha * q, wl);
        if !(d > 0.0) || !d.is_finite() {
            return 0.0;
        }
        mis_divisor(r_u, wl) / d
    }
}

/// Wavelength (nm) at which the refracted proposal takes the boundary's index (the proposal's
/// plane must not depend on which lane is the hero).
const GUIDE_LAMBDA_NM: f32 = 550.0;

/// Radiance along `ray` by volumetric path tracing (see the module documentation). `wl` may lose
/// its secondary wavelengths (dispersion): convert the result with `wl` as it is on return.
pub fn li_volpath(scene: &Scene, settings: &IntegratorSettings, ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    li_volpath_with(scene, settings, &VolpathOptions::default(), ray, wl, rng)
}

/// [`li_volpath`] with explicit [`VolpathOptions`].
pub fn li_volpath_with(scene: &Scene, settings: &IntegratorSettings, options: &VolpathOptions, mut ray: Ray, wl: &mut SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let nee_ok = if scene.media.is_empty() { 0 } else { nee_possible(scene) };
    let mut l = Vec4::ZERO;
    let mut beta = Vec4::ONE;
    let mut r_u = Vec4::ONE;
    // After a phase-sampled direction at a medium vertex that also sampled a light: the path
    // densities had that direction come from light sampling, per unit light pdf, relative to the
    // actual one (pbrt-v4's r_l); `prev_medium_mis` says it is in use.
    let mut r_l = Vec4::ZERO;
    let mut prev_medium_mis = false;
    let mut medium = scene.global_medium;
    let mut depth = 0u32;
    let mut prev_pdf = 0.0f32;
    let mut prev_no_mis = true; // camera ray, delta bounce, or no light sample at the last vertex
    let mut prev_p = ray.o;
    let mut crossings = 0u32;
    // The current medium's data at this path's wavelengths (computed on entering it).
    let mut lanes: (u32, MediumLanes) = (u32::MAX, MediumLanes::default());
    // Its phase functions on the shared cos θ grid, interpolated between wavelengths once
    // (`Medium::lane_table`; empty: evaluated per event instead).
    let mut lane_buf: Vec<Vec4> = Vec::new();
    // Real collisions so far, and the count at which the next event-count roulette is played.
    let mut events = 0u32;
    let mut next_event_rr = options.event_rr_start;
    // After a phase-sampled direction at a vertex that also played a refracted branch: the
    // branch's direction density per lane (α_j q), while the path stays on the branch's chain of
    // pass-throughs and delta interfaces (at most `GUIDE_STEPS` surfaces).
    let mut guide_at: Option<GuidedVertex> = None;
    let mut guide_steps = 0u32;
    let mut free = FreeBall::default();
    // Product of the squared relative indices of the refractions so far: `beta` carries their
    // radiance scaling 1/η², which roulette leaves out (pbrt-v4's etaScale), so that a path is
    // not ended on entering a denser medium for a factor its way out gives back.
    let mut eta_scale = 1.0f32;
    // A free flight (m) the deep walk drew but did not take: the next flight in the same medium.
    let mut pending_flight: Option<f32> = None;
    // The facet of the medium's convex boundary where the last guide probe left it.
    let mut exit_hint = 0u32;
    'path: loop {
        // Free flight in the current medium.
        let med: Option<(&Medium, Vec4, Vec4)> = medium.map(|m| {
            let mm = &scene.media[m as usize];
            if lanes.0 != m {
                lanes = (m, mm.lanes(wl));
                mm.lane_table(&lanes.1, &mut lane_buf);
            }
            (mm, lanes.1.sigma_s, lanes.1.sigma_t)
        });
        let lane_table = (!lane_buf.is_empty()).then_some(lane_buf.as_slice());
        let mut t_coll = f32::INFINITY;
        // The density-weighted length of the flight (`Medium::depth`): t_coll itself in a
        // homogeneous medium; in a density grid the flight is drawn in it and mapped to distance.
        let mut depth_coll = f32::INFINITY;
        // In a density grid the flight is traced to the first surface at once: that surface
        // (`Some(None)`: none) and, when the flight passes it, the density-weighted length to it.
        let mut grid_hit = None;
        let mut through_depth = None;
        if let Some((mm, _, sigma_t)) = med {
            if !mm.pure_absorber && sigma_t.x > 0.0 {
                match (pending_flight.take(), &mm.density) {
                    (Some(t), _) => (t_coll, depth_coll) = (t, t),
                    (None, None) => {
                        t_coll = free_flight(sigma_t.x, rng);
                        depth_coll = t_coll;
                    }
                    (None, Some(g)) => {
                        depth_coll = free_flight(sigma_t.x, rng);
                        (t_coll, through_depth, grid_hit) = grid_flight(scene, g, &ray, depth_coll);
                    }
                }
            }
        }
        ray.t_max = t_coll;
        // No surface within the free-distance bound around the origin: the collision is real
        // without a ray cast.
        let grid = scene.medium_grid(medium).filter(|_| options.free_flight_grid);
        let surely_inside = t_coll.is_finite()
            && grid.is_some_and(|g| t_coll < g.free_distance(ray.o) * (1.0 - 1e-4) - scene.ray_epsilon_m || free.contains(scene, g, ray.o, ray.o + ray.d * t_coll, med.map_or(0.0, |m| 1.0 / m.2.x)));
        let hit = match grid_hit {
            Some(h) => h,
            None if surely_inside => None,
            None => scene.intersect(&ray),
        };
        if let Some((mm, sigma_s, sigma_t)) = med {
            if hit.is_none() && t_coll.is_finite() {
                // Real collision: scatter with weight σ_s/σ_t (spectral MIS via r_u). The
                // vertex's light estimates take the throughput and density ratios after the
                // collision (`bv`, `rv`); the path's own go on only after the phase sample, with
                // one renormalisation for both (as the deep walk does, bit for bit).
                let a = relative_transmittance(sigma_t, depth_coll);
                let (mut bv, mut rv, mut lv) = (beta * a * sigma_s, r_u * a * sigma_t, r_l);
                if !renormalize(&mut bv, &mut rv, &mut lv, wl) {
                    break;
                }
                let p = ray.o + ray.d * t_coll;
                // A density grid's albedo factor a(p, λ): σ_s(p) = a σ_s, σ_t unchanged, so each
                // lane's scattering weight takes its factor and the densities do not.
                let albedo = mm.albedo.as_ref().map(|g| g.at(p, wl));
                if let Some(k) = albedo {
                    bv *= k;
                }
                depth += 1;
                events += 1;
                if depth >= settings.max_depth {
                    break;
                }
                let scheduled = next_event_rr;
                if !event_roulette(events, &mut next_event_rr, &mut beta, rng) {
                    break;
                }
                if next_event_rr != scheduled {
                    // The roulette was played, and the survivor's throughput doubled.
                    bv *= 2.0;
                }
                let mi = medium.unwrap_or(0);
                let can_nee = mi >= 64 || nee_ok & (1u64 << mi) != 0;
                if can_nee {
                    l += bv * medium_light_sample(scene, mm, p, ray.d, medium, rv, wl, rng);
                }
                // The refracted branch (module documentation): played with probability α_j, which
                // depends only on the vertex (not on the plane a probe ray finds), so the main
                // path finds its own MIS weight by probing only if it reaches an emitter.
                // (Not in a density grid: the branch's proposal assumes a homogeneous medium.)
                let guide = if can_nee || mm.density.is_some() { None } else { scene.refracted_lights.as_ref().and_then(|rl| guide_probability(scene, rl, p, medium, sigma_t, free.bound(p)).map(|alpha| (rl, alpha))) };
                // Split phase samples (s_j = K g_j² e^{−σ_j d}, K = `refraction_splits`): more
                // directions from the phase function, traced along the branch's chain only where
                // the plane refracts them onto a light, so that the forward-peaked lobe meets
                // the lights in many small contributions instead of the main path's rare hits.
                let splits = guide.map_or(Vec4::ZERO, |(rl, alpha)| alpha * (rl.splits / rl.alpha_max) * split_share(lanes.1.g));
                let mut probed = None;
                if let Some((rl, alpha)) = guide {
                    let play = rng.next_f32() < alpha.x;
                    let n_split = if splits.x > 0.0 {
                        let whole = splits.x.floor();
                        whole as u32 + u32::from(rng.next_f32() < splits.x - whole)
                    } else {
                        0
                    };
                    let plane = if play || n_split > 0 { exit_plane(scene, rl, p, medium, sigma_t, &mut exit_hint) } else { None };
                    if play || n_split > 0 {
                        probed = Some(plane);
                    }
                    if let Some(plane) = plane {
                        if play {
                            let (uc, u2) = (rng.next_f32(), rng.next_2d());
                            if let Some((w, q)) = rl.sample(&plane, p, uc, u2) {
                                let f = mm.phase_eval(wl, ray.d.dot(w));
                                let t = if rl.reaches(&plane, p, w).is_some() { 1.0 } else { 0.0 };
                                l += bv * refracted_branch(scene, p, w, medium, f, rv, alpha * q + f * (splits * t), 1.0, wl, rng);
                            }
                        }
                        let frame = Frame::from_normal(ray.d);
                        for _ in 0..n_split {
                            let (uc, u2) = (rng.next_f32(), rng.next_2d());
                            let (mu, seg) = mm.phase_sample_cos(&lanes.1, uc, u2.x);
                            let w = scattered(&frame, mu, u2.y);
                            let Some(t_plane) = rl.reaches(&plane, p, w) else { continue };
                            // Roulette before any ray cast on the straight line's transmittance to
                            // the plane; the branch continues it on the segment's true one.
                            let pre = ((-sigma_t.x * t_plane).exp() / BRANCH_ROULETTE_T).min(1.0);
                            if pre < 1.0 && rng.next_f32() >= pre {
                                continue;
                            }
                            let f = mm.phase_lanes_at(&lanes.1, lane_table, mu, seg);
                            if !(f.x > 0.0) {
                                continue;
                            }
                            let q = rl.pdf(&plane, p, w);
                            l += bv * refracted_branch(scene, p, w, medium, f, rv, alpha * q + f * splits, pre, wl, rng);
                        }
                    }
                }
                let uc = rng.next_f32();
                let Some(ps) = mm.phase_sample_lanes(&lanes.1, lane_table, ray.d, uc, rng.next_2d()) else { break };
                // The phase functions differ between the carried wavelengths: p_j(μ)/p₀(μ) is
                // both lane j's weight and the ratio of the direction densities had λ_j been the
                // hero (so spectral MIS keeps every lane's estimate bounded, see the module docs).
                r_l = if can_nee || guide.is_some() { r_u * a * sigma_t / ps.pdf } else { Vec4::ZERO };
                guide_at = guide.map(|(rl, alpha)| GuidedVertex { rl, p, medium, plane: probed, w: ps.wi, alpha, splits, sigma_t });
                guide_steps = 0;
                let aw = a * ps.weight;
                beta *= aw * sigma_s;
                if let Some(k) = albedo {
                    beta *= k;
                }
                r_u *= aw * sigma_t;
                let (wi, pdf) = (ps.wi, ps.pdf);
                if !renormalize(&mut beta, &mut r_u, &mut r_l, wl) {
                    break;
                }
                prev_pdf = pdf;
                prev_no_mis = !can_nee;
                prev_medium_mis = can_nee;
                prev_p = p;
                ray = Ray { o: p, d: wi, t_min: 0.0, t_max: f32::INFINITY };
                crossings = 0;
                if !roulette(&mut beta, eta_scale, depth, settings, wl, rng) {
                    break;
                }
                // Deep walk: while the flights provably cross no surface (by the free-flight
                // grid or the path's surface-free ball) and end deeper than the guide's reach,
                // nothing but the free flight, the lane weights and the phase sample happens at
                // the collisions (no ray cast, no light sample, no branch), so they run here,
                // each exactly as the general loop would run it; the first flight that does not
                // qualify goes back to the general loop, already drawn.
                if let (true, false, None, Some(g), false, true) = (options.deep_walk && mm.density.is_none(), can_nee, guide, grid, mm.pure_absorber, sigma_t.x > 0.0) {
                    let s_min = sigma_t.min_element();
                    // Without refracted lights no vertex plays a branch: any depth will do.
                    let reach = if scene.refracted_lights.is_some() { GUIDE_REACH } else { 0.0 };
                    guide_at = None;
                    r_l = Vec4::ZERO;
                    prev_no_mis = true;
                    // Distance from the ball's centre to the flight's start (the ball does not move
                    // during the deep walk).
                    let mut o_dist = (ray.o - free.centre).length();
                    loop {
                        let t = free_flight(sigma_t.x, rng);
                        let q = ray.o + ray.d * t;
                        let q_dist = (q - free.centre).length();
                        // The general loop's two tests, without their side effects: the flight
                        // crosses no surface (by the grid's bound at its start, or inside the
                        // ball, which the general loop would leave where it is), and its end
                        // lies beyond the guide's reach (`guide_probability`'s distance).
                        let o_inside = o_dist < free.radius;
                        let q_bound = (free.radius - q_dist).max(0.0);
                        let deep = if o_inside && q_bound * s_min > reach {
                            true
                        } else {
                            let free_flight_ok = t < g.free_distance(ray.o) * (1.0 - 1e-4) - scene.ray_epsilon_m || (o_inside && q_dist < free.radius);
                            free_flight_ok && g.free_distance(q).max(q_bound).max(0.0) * s_min > reach
                        };
                        if !deep {
                            pending_flight = Some(t);
                            break;
                        }
                        depth += 1;
                        events += 1;
                        if depth >= settings.max_depth {
                            break 'path;
                        }
                        if !event_roulette(events, &mut next_event_rr, &mut beta, rng) {
                            break 'path;
                        }
                        let uc = rng.next_f32();
                        let Some(ps) = mm.phase_sample_lanes(&lanes.1, lane_table, ray.d, uc, rng.next_2d()) else { break 'path };
                        // The collision's weights (σ_s and the relative transmittance) and the phase
                        // sample's in one renormalisation: the MIS divisor is a common factor of both.
                        let a = relative_transmittance(sigma_t, t) * ps.weight;
                        beta *= a * sigma_s;
                        r_u *= a * sigma_t;
                        if !renormalize(&mut beta, &mut r_u, &mut r_l, wl) {
                            break 'path;
                        }
                        prev_pdf = ps.pdf;
                        prev_p = q;
                        ray = Ray { o: q, d: ps.wi, t_min: 0.0, t_max: f32::INFINITY };
                        o_dist = q_dist;
                        if !roulette(&mut beta, eta_scale, depth, settings, wl, rng) {
                            break 'path;
                        }
                    }
                }
                continue;
            }
            // No collision before the surface (or escape).
            let seg = through_depth.unwrap_or_else(|| mm.depth(ray.o, ray.d, hit.map(|h| h.t).unwrap_or(f32::INFINITY)));
            if mm.pure_absorber {
                beta *= transmittance(sigma_t, seg);
            } else {
                let a = relative_transmittance(sigma_t, seg);
                beta *= a;
                r_u *= a;
                r_l *= a;
                if !renormalize(&mut beta, &mut r_u, &mut r_l, wl) {
                    break;
                }
            }
            if beta == Vec4::ZERO {
                break;
            }
        }
        depth += 1;
        let Some(hit) = hit else {
            if let Some(g) = &guide_at {
                l += environment_emission(scene, &ray, beta, prev_p, prev_pdf, true, wl) * g.weight(scene, r_u, r_l, wl);
            } else if prev_medium_mis {
                let e = environment_emission(scene, &ray, beta, prev_p, prev_pdf, true, wl);
                if let Some(ei) = scene.environment {
                    let lp = nee::environment_light_pdf(scene, ei, prev_p, ray.d);
                    l += e * spectral_balance(r_u, r_l, lp, wl);
                }
            } else {
                l += environment_emission(scene, &ray, beta, prev_p, prev_pdf, prev_no_mis, wl);
            }
            break;
        };
        ray.t_max = f32::INFINITY;
        let sp = Shading::at(scene, &ray, &hit);
        // The side the ray arrives from (the BSDF's and the medium crossing's), and the shading
        // frame on that side.
        let front = sp.ng_raw.dot(ray.d) < 0.0;
        let (ng, frame) = (sp.ng, sp.frame);
        let wo = -ray.d;
        let obj = &scene.objects[sp.object as usize];
        if guide_at.is_some() {
            guide_steps += 1;
            if guide_steps > GUIDE_STEPS {
                guide_at = None;
            }
        }
        if let Some(li_idx) = obj.light {
            let light = &scene.lights[li_idx as usize];
            let le = light.le(sp.ng_raw, wo, || sp.uv(scene), wl);
            if le != Vec4::ZERO {
                let w = if let Some(g) = &guide_at {
                    g.weight(scene, r_u, r_l, wl)
                } else if prev_medium_mis {
                    let lp = nee::area_light_pdf(scene, li_idx, prev_p, ray.d, sp.p, sp.ng_raw);
                    spectral_balance(r_u, r_l, lp, wl)
                } else if prev_no_mis {
                    1.0
                } else {
                    let lp = nee::area_light_pdf(scene, li_idx, prev_p, ray.d, sp.p, sp.ng_raw);
                    power_heuristic(1.0, prev_pdf, 1.0, lp)
                };
                l += beta * le * w;
            }
        }
        let material = scene.materials[obj.material as usize].select(|| sp.selector(wo), || sp.uv(scene));
        if index_matched(material) {
            // Pass-through boundary: change medium, keep going in the same direction.
            depth -= 1;
            crossings += 1;
            if crossings > MAX_CROSSINGS {
                break;
            }
            medium = cross(scene, sp.object, front, medium);
            ray = Ray { o: sp.p - ng * scene.ray_epsilon_m, d: ray.d, t_min: 0.0, t_max: f32::INFINITY };
            continue;
        }
        crossings = 0;
        if depth >= settings.max_depth {
            break;
        }
        let terminated = wl.secondary_terminated();
        let bsdf = if scene.black_behind(obj.material, front) { crate::bsdf::Bsdf::Black } else { material.bsdf_at(wl, front, || sp.uv(scene)) };
        if !bsdf.is_delta() || wl.secondary_terminated() != terminated {
            // Off the refracted branch's chain (see `refracted_branch`).
            guide_at = None;
        }
        if !renormalize(&mut beta, &mut r_u, &mut r_l, wl) {
            break;
        }
        if bsdf.is_black() {
            break;
        }
        let wo_l = frame.to_local(wo);
        let mut did_nee = false;
        if !bsdf.is_delta() {
            did_nee = true;
            if let Some(c) = nee::sample_light(scene, sp.p, wl, rng) {
                let ls = &c.ls;
                let wi_l = frame.to_local(ls.wi);
                let f = bsdf.eval(wo_l, wi_l) * sp.terminator(ls.wi);
                if f != Vec4::ZERO && (ls.wi.dot(ng) <= 0.0) == (wi_l.z <= 0.0) {
                    // The shadow ray starts in the medium on the side it leaves to.
                    let m_side = if (ls.wi.dot(ng) >= 0.0) == (wo.dot(ng) >= 0.0) { medium } else { cross(scene, sp.object, front, medium) };
                    let dist = shadow_t_max(ls.dist, scene.ray_epsilon_m, true);
                    if let Some(tr) = shadow_transmittance(scene, offset_origin(sp.p, ng, ls.wi, scene.ray_epsilon_m), ls.wi, dist, m_side, wl) {
                        let w = c.mis_weight(bsdf.pdf(wo_l, wi_l));
                        l += beta * f * ls.li * tr * (wi_l.z.abs() * w / c.pdf());
                    }
                }
            }
        }
        let uc = rng.next_f32();
        let Some(bs) = bsdf.sample(wo_l, uc, rng.next_2d()) else { break };
        let wi = frame.to_world(bs.wi);
        if (wi.dot(ng) > 0.0) == bs.transmission {
            break;
        }
        beta *= bs.f * (bs.wi.z.abs() * sp.terminator(wi) / bs.pdf);
        if bs.terminate_secondary && !wl.secondary_terminated() {
            wl.terminate_secondary();
            if !renormalize(&mut beta, &mut r_u, &mut r_l, wl) {
                break;
            }
        }
        if bs.transmission {
            medium = cross(scene, sp.object, front, medium);
            eta_scale *= bs.eta * bs.eta;
        }
        prev_pdf = bs.pdf;
        prev_no_mis = bs.delta || !did_nee;
        prev_medium_mis = false;
        prev_p = sp.p;
        ray = Ray { o: offset_origin(sp.p, ng, wi, scene.ray_epsilon_m), d: wi, t_min: 0.0, t_max: f32::INFINITY };
        if !roulette(&mut beta, eta_scale, depth, settings, wl, rng) {
            break;
        }
    }
    l
}

/// A free flight of density-weighted length `tau` (m) along `ray` in a density grid, traced to the
/// first surface: (the collision distance or infinity, the density-weighted length to the
/// surface when the flight passes it, the surface: `Some(None)` where there is none).
#[inline(never)]
fn grid_flight(scene: &Scene, g: &crate::medium::grid::DensityGrid, ray: &Ray, tau: f32) -> (f32, Option<f32>, Option<Option<crate::accel::Hit>>) {
    let h = scene.intersect(&Ray { t_max: f32::INFINITY, ..*ray });
    match g.flight(ray.o, ray.d, tau, h.map_or(f32::INFINITY, |h| h.t)) {
        Ok(s) => (s, None, Some(None)),
        Err(depth) => (f32::INFINITY, Some(depth), Some(h)),
    }
}

/// The event-count roulette (module documentation) after `events` real collisions: at the
/// scheduled count the path survives with probability ½ and its throughput doubles, and the
/// next round is scheduled 4× later; false when the path ends.
#[inline(always)]
fn event_roulette(events: u32, next: &mut u32, beta: &mut Vec4, rng: &mut Pcg32) -> bool {
    if events != *next {
        return true;
    }
    *next = next.saturating_mul(4);
    if rng.next_f32() < 0.5 {
        return false;
    }
    *beta *= 2.0;
    true
}

/// A free-flight distance (m) drawn from the density σ e^{−σ t}.
#[inline]
fn free_flight(sigma_per_m: f32, rng: &mut Pcg32) -> f32 {
    -(1.0 - rng.next_f32()).ln() / sigma_per_m
}

/// Russian roulette on the effective throughput once the path has `rr_depth` segments, as in
/// pbrt-v4: a path whose largest throughput m (times `eta_scale`, the product of the squared
/// relative indices it has been refracted through) is below 1 continues with probability m
/// (and is divided by it); paths with m ≥ 1 always continue, so dense media with albedo near 1
/// are not cut short by roulette (only by `max_depth`).
#[inline]
fn roulette(beta: &mut Vec4, eta_scale: f32, depth: u32, settings: &IntegratorSettings, wl: &SampledWavelengths, rng: &mut Pcg32) -> bool {
    if depth < settings.rr_depth {
        return true;
    }
    let m = eta_scale * if wl.secondary_terminated() { beta.x } else { beta.max_element() };
    if m >= 1.0 {
        return true;
    }
    if !(rng.next_f32() < m) {
        return false;
    }
    *beta /= m;
    true
}

/// One light sample at a medium vertex `p` (ray travelling along `d`), MIS-weighted against phase
/// sampling; returns phase × transmittance × radiance / pdf (to be multiplied by the throughput).
fn medium_light_sample(scene: &Scene, mm: &Medium, p: Vec3, d: Vec3, medium: Option<u32>, r_u: Vec4, wl: &SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let Some(c) = nee::sample_light(scene, p, wl, rng) else { return Vec4::ZERO };
    let ls = &c.ls;
    let mu = d.dot(ls.wi);
    let f = mm.phase_eval(wl, mu);
    if f == Vec4::ZERO {
        return Vec4::ZERO;
    }
    let dist = shadow_t_max(ls.dist, scene.ray_epsilon_m, false);
    let Some(tr) = shadow_transmittance(scene, p, ls.wi, dist, medium, wl) else { return Vec4::ZERO };
    let light_pdf = c.pdf();
    // Balance heuristic over the 2 × 4 techniques (light or phase sampling, each wavelength the
    // hero): divide by the mean over wavelengths of (prefix density ratio) × (light pdf + p_j(μ)).
    let denom = if ls.delta { light_pdf * mis_divisor(r_u, wl) } else { mis_divisor(r_u * (Vec4::splat(light_pdf) + f), wl) };
    if !(denom > 0.0) {
        return Vec4::ZERO;
    }
    f * ls.li * tr / denom
}

/// Most surfaces a refracted branch follows; the main path weights emission against the branch
/// only up to as many surfaces after the vertex.
const GUIDE_STEPS: u32 = 16;

/// Below this hero transmittance of a segment the refracted branch goes on only with
/// probability T / BRANCH_ROULETTE_T (weighted by its inverse).
const BRANCH_ROULETTE_T: f32 = 0.25;

/// The refracted branch from medium vertex `p` in direction `w` (drawn from the refracted
/// proposal): the continuation the main path would follow — free flight in the current medium
/// (weighted by the probability of no collision), pass-through boundaries, smooth non-dispersive interfaces
/// sampled as the main path samples them — up to the first surface that is neither, at most
/// `GUIDE_STEPS` surfaces. Emission it meets (area lights, the environment) is counted with the
/// balance heuristic against the main path's phase sampling over the 2 × 4 techniques: with
/// `f` the phase function per lane at `w`, `r_u` the prefix density ratios and `lp` the branch's
/// density per lane (α_j q), it returns f · (downstream weights) · L_e / mean(r_u · D · (f + lp)),
/// D the downstream density ratios (to be multiplied by the path throughput). The main path
/// gives the same paths the complementary weight (`guide_at` in [`li_volpath_with`]).
#[allow(clippy::too_many_arguments)]
fn refracted_branch(scene: &Scene, p: Vec3, w: Vec3, mut medium: Option<u32>, f: Vec4, r_u: Vec4, lp: Vec4, mut pre: f32, wl: &SampledWavelengths, rng: &mut Pcg32) -> SampledSpectrum {
    let mut num = f / pre;
    let mut den = r_u * (f + lp);
    let mut l = Vec4::ZERO;
    let mut ray = Ray { o: p, d: w, t_min: 0.0, t_max: f32::INFINITY };
    let mut steps = 0u32;
    let add = |l: &mut Vec4, num: Vec4, den: Vec4, le: Vec4| {
        let d = mis_divisor(den, wl);
        if d > 0.0 && d.is_finite() {
            *l += num * le / d;
        }
    };
    loop {
        let coeffs = medium.map(|m| {
            let mm = &scene.media[m as usize];
            (mm.pure_absorber, mm.coefficients(wl).1, mm)
        });
        ray.t_max = f32::INFINITY;
        let hit = scene.intersect(&ray);
        if let Some((pure, sigma_t, mm)) = coeffs {
            let seg = mm.depth(ray.o, ray.d, hit.map(|h| h.t).unwrap_or(f32::INFINITY));
            if pure {
                num *= transmittance(sigma_t, seg);
            } else {
                // The main path crosses the segment without a collision with probability
                // T_hero = e^{−σ_hero t}; the branch takes that probability as a factor instead of
                // drawing the collision (its expected value: same MIS weights, no branch lost to
                // a collision), and plays Russian roulette only below BRANCH_ROULETTE_T.
                let t_hero = transmittance(sigma_t, seg).x;
                let a = relative_transmittance(sigma_t, seg);
                num *= a * t_hero;
                den *= a;
                // A roulette already played (`pre`, the probability the branch survived it) counts
                // towards this one: overall the branch survives with min(1, T_hero / threshold).
                let q = ((t_hero / BRANCH_ROULETTE_T).min(1.0) / pre).min(1.0);
                pre = 1.0;
                if q < 1.0 {
                    if rng.next_f32() >= q {
                        return l;
                    }
                    num /= q;
                }
            }
            if num == Vec4::ZERO {
                return l;
            }
        }
        let Some(hit) = hit else {
            if let Some(ei) = scene.environment {
                let le = scene.lights[ei as usize].le(Vec3::ZERO, -ray.d, || glam::Vec2::ZERO, wl);
                add(&mut l, num, den, le);
            }
            return l;
        };
        steps += 1;
        if steps > GUIDE_STEPS {
            return l;
        }
        ray.t_max = f32::INFINITY;
        let sp = Shading::at(scene, &ray, &hit);
        let front = sp.ng_raw.dot(ray.d) < 0.0;
        let (ng, frame) = (sp.ng, sp.frame);
        let wo = -ray.d;
        let obj = &scene.objects[sp.object as usize];
        if let Some(li_idx) = obj.light {
            let le = scene.lights[li_idx as usize].le(sp.ng_raw, wo, || sp.uv(scene), wl);
            if le != Vec4::ZERO {
                add(&mut l, num, den, le);
            }
        }
        let material = scene.materials[obj.material as usize].select(|| sp.selector(wo), || sp.uv(scene));
        if index_matched(material) {
            medium = cross(scene, sp.object, front, medium);
            ray = Ray { o: sp.p - ng * scene.ray_epsilon_m, d: ray.d, t_min: 0.0, t_max: f32::INFINITY };
            continue;
        }
        let b = material.bsdf_with(wl, || sp.uv(scene));
        if !b.is_delta() || b.is_black() || b.terminates_secondary() || scene.black_behind(obj.material, front) {
            return l;
        }
        let bsdf = if front { b } else { b.from_inside() };
        let uc = rng.next_f32();
        let Some(bs) = bsdf.sample(frame.to_local(wo), uc, rng.next_2d()) else { return l };
        let wi = frame.to_world(bs.wi);
        if (wi.dot(ng) > 0.0) == bs.transmission || bs.terminate_secondary {
            return l;
        }
        num *= bs.f * (bs.wi.z.abs() * sp.terminator(wi) / bs.pdf);
        if bs.transmission {
            medium = cross(scene, sp.object, front, medium);
        }
        ray = Ray { o: offset_origin(sp.p, ng, wi, scene.ray_epsilon_m), d: wi, t_min: 0.0, t_max: f32::INFINITY };
    }
}
