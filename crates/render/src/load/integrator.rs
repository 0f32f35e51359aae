//! `[integrator]`: type (named by [`crate::integrator::settings`]), max_depth, rr_depth, ao_distance.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::type_complexity)]

use crate::integrator::settings::{IntegratorKind, IntegratorSettings};
use crate::load::desc::SceneDesc;
use crate::load::error::{quote, Cx};
use anyhow::Result;

/// The integrator settings and the ambient-occlusion distance in metres (infinite by default).
pub(crate) fn integrator(cx: &Cx, desc: &SceneDesc, unit_m: f64) -> Result<(IntegratorSettings, f32)> {
    let to_m = |x: f64| (x * unit_m) as f32;
    let mut integrator = IntegratorSettings::default();
    let mut ao_distance_m = f32::INFINITY;
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
    }
    Ok((integrator, ao_distance_m))
}
