//! `[integrator]`: type (named by [`crate::integrator::settings`]), max_depth, rr_depth, ao_distance,
//! refraction_guiding, refraction_splits, emitter_samples, bsdf_samples.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::integrator::settings::{DirectSamples, IntegratorKind, IntegratorSettings};
use crate::load::desc::SceneDesc;
use crate::load::error::{quote, Cx};
use anyhow::Result;

/// Default of `refraction_guiding`: the largest fraction of `volpath`'s medium vertices near a
/// smooth dielectric boundary whose direction is aimed at the lights beyond it.
pub const DEFAULT_REFRACTION_GUIDING: f32 = 0.3;

/// Default of `refraction_splits`: the expected number of extra phase-function samples at a
/// `volpath` medium vertex on a smooth dielectric boundary (fewer further in).
pub const DEFAULT_REFRACTION_SPLITS: f32 = 4.0;

/// What `[integrator]` sets.
pub(crate) struct IntegratorParams {
    pub(crate) settings: IntegratorSettings,
    /// Ambient-occlusion distance in metres (infinite by default).
    pub(crate) ao_distance_m: f32,
    /// Refraction-guiding fraction (0: off).
    pub(crate) guiding: f32,
    /// Refraction splits (0: none).
    pub(crate) splits: f32,
    /// Samples per technique of `direct`.
    pub(crate) direct: DirectSamples,
}

/// Reads `[integrator]`; errors name the field.
pub(crate) fn integrator(cx: &Cx, desc: &SceneDesc, unit_m: f64) -> Result<IntegratorParams> {
    let to_m = |x: f64| (x * unit_m) as f32;
    let mut integrator = IntegratorSettings::default();
    let mut ao_distance_m = f32::INFINITY;
    let mut guiding = DEFAULT_REFRACTION_GUIDING;
    let mut splits = DEFAULT_REFRACTION_SPLITS;
    let mut direct = DirectSamples::default();
    if let Some(i) = &desc.integrator {
        let span = i.span();
        let i = i.get_ref();
        if let Some(k) = &i.kind {
            integrator.kind = match IntegratorKind::from_name(k) {
                Some(kind) => kind,
                None => return Err(cx.err(&span, "integrator.type", format!("unknown integrator {} ({})", quote(k), IntegratorKind::names(", ")))),
            };
        }
        if let Some(d) = i.max_depth {
            if d == 0 {
                return Err(cx.err(&span, "integrator.max_depth", "must be at least 1"));
            }
            integrator.max_depth = d;
        }
        if let Some(d) = i.rr_depth {
            integrator.rr_depth = d;
        }
        if let Some(d) = i.ao_distance {
            if !(d > 0.0) {
                return Err(cx.err(&span, "integrator.ao_distance", format!("must be positive, got {d}")));
            }
            ao_distance_m = to_m(d);
        }
        if let Some(g) = i.refraction_guiding {
            if !(0.0..0.95).contains(&g) {
                return Err(cx.err(&span, "integrator.refraction_guiding", format!("must be in [0, 0.95), got {g}")));
            }
            guiding = g as f32;
        }
        if let Some(k) = i.refraction_splits {
            if !(0.0..=64.0).contains(&k) {
                return Err(cx.err(&span, "integrator.refraction_splits", format!("must be in [0, 64], got {k}")));
            }
            splits = k as f32;
        }
        for (field, value, slot) in [("emitter_samples", i.emitter_samples, &mut direct.emitter), ("bsdf_samples", i.bsdf_samples, &mut direct.bsdf)] {
            if let Some(n) = value {
                if n > 1024 {
                    return Err(cx.err(&span, &format!("integrator.{field}"), format!("must be in [0, 1024], got {n}")));
                }
                *slot = n;
            }
        }
        if direct.emitter + direct.bsdf == 0 {
            return Err(cx.err(&span, "integrator.emitter_samples", "emitter_samples and bsdf_samples cannot both be 0"));
        }
    }
    Ok(IntegratorParams { settings: integrator, ao_distance_m, guiding, splits, direct })
}
