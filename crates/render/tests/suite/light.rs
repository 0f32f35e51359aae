//! Light sampling densities: E[1/pdf] over light samples is the solid angle the light subtends
//! (closed forms for a rectangle on its axis and a sphere), and `pdf_li` of a sampled direction
//! equals the density `sample_li` reported.

use glam::{Vec2, Vec3};
use render::light::{smooth_falloff, Emitter, Light};
use render::math::sampling::Pcg32;
use render::math::spectral::SampledWavelengths;
use optics::spectrum::DenseSpectrum;

fn area_light(emitter: Emitter, two_sided: bool) -> Light {
    let area_m2 = emitter.area_m2();
    Light::Area { object: 0, emitter, area_m2, radiance: DenseSpectrum::from_fn(|_| 1.0).into(), two_sided }
}

/// Mean and standard error of 1/pdf over `n` samples from point `p`.
fn solid_angle_estimate(light: &Light, p: Vec3, n: usize, seed: u64) -> (f64, f64) {
    let wl = SampledWavelengths::fixed([450.0, 500.0, 550.0, 600.0]);
    let mut rng = Pcg32::new(seed, 1);
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let v = match light.sample_li(p, rng.next_2d(), &wl) {
            Some(ls) => {
                assert!(ls.pdf > 0.0 && (ls.wi.length() - 1.0).abs() < 1e-4);
                // pdf_li for the point the sample reached agrees with the sample's density.
                let q = p + ls.wi * ls.dist;
                let ng = match light {
                    Light::Area { emitter: Emitter::Sphere { center, .. }, .. } => (q - *center).normalize(),
                    _ => Vec3::NEG_Y,
                };
                let pdf2 = light.pdf_li(p, ls.wi, q, ng);
                assert!((pdf2 / ls.pdf - 1.0).abs() < 2e-3, "pdf_li {pdf2} vs sample pdf {}", ls.pdf);
                1.0 / ls.pdf as f64
            }
            None => 0.0,
        };
        s += v;
        s2 += v * v;
    }
    let m = s / n as f64;
    (m, ((s2 / n as f64 - m * m).max(0.0) / n as f64).sqrt())
}

#[test]
fn rectangle_area_sampling_integrates_to_its_solid_angle() {
    // Rectangle 2a × 2b at height h, facing down, seen from the point below its centre:
    // Ω = 4 arcsin(ab / √((a² + h²)(b² + h²))).
    let (a, b, h) = (0.3f32, 0.2f32, 0.25f32);
    let tris = vec![
        [Vec3::new(a, h, b), Vec3::new(-a, h, b), Vec3::new(-a, h, -b)],
        [Vec3::new(a, h, b), Vec3::new(-a, h, -b), Vec3::new(a, h, -b)],
    ];
    let light = area_light(Emitter::triangles(tris).unwrap(), false);
    let (a, b, h) = (a as f64, b as f64, h as f64);
    let omega = 4.0 * (a * b / ((a * a + h * h) * (b * b + h * h)).sqrt()).asin();
    let (m, se) = solid_angle_estimate(&light, Vec3::ZERO, 200_000, 3);
    assert!((m - omega).abs() < 4.5 * se, "{m} ± {se} vs {omega}");
    // From above, a one-sided emitter facing down sends nothing.
    let wl = SampledWavelengths::fixed([450.0, 500.0, 550.0, 600.0]);
    assert!(light.sample_li(Vec3::new(0.0, 1.0, 0.0), Vec2::new(0.3, 0.6), &wl).is_none());
}

#[test]
fn sphere_sampling_integrates_to_its_solid_angle() {
    // From outside: Ω = 2π(1 − √(1 − r²/d²)), sampled exactly (every sample has 1/pdf = Ω).
    let (r, d) = (0.5f32, 2.0f32);
    let light = area_light(Emitter::Sphere { center: Vec3::new(0.0, 0.0, d), radius: r }, false);
    let omega = 2.0 * std::f64::consts::PI * (1.0 - (1.0 - (r * r / (d * d)) as f64).sqrt());
    let (m, se) = solid_angle_estimate(&light, Vec3::ZERO, 10_000, 4);
    assert!((m - omega).abs() < 1e-4 * omega && se < 1e-4 * omega, "{m} vs {omega}");
    // From inside a two-sided sphere: the whole sphere of directions, 4π.
    let light = area_light(Emitter::Sphere { center: Vec3::ZERO, radius: 1.0 }, true);
    let (m, se) = solid_angle_estimate(&light, Vec3::new(0.2, -0.3, 0.1), 200_000, 5);
    assert!((m - 4.0 * std::f64::consts::PI).abs() < 4.5 * se, "{m} ± {se}");
}

#[test]
fn zero_area_emitters_are_rejected() {
    let p = Vec3::new(1.0, 2.0, 3.0);
    assert!(Emitter::triangles(vec![[p, p, p]]).is_err());
    assert!(Emitter::triangles(vec![]).is_err());
    assert!(Emitter::triangles(vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0]]).is_err());
}

#[test]
fn spot_falloff_is_smooth_and_bounded() {
    let (ct, cs) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
    assert_eq!(smooth_falloff(1.0, ct, cs), 1.0);
    assert_eq!(smooth_falloff(cs, ct, cs), 1.0);
    assert_eq!(smooth_falloff(ct, ct, cs), 0.0);
    let mid = smooth_falloff(25f32.to_radians().cos(), ct, cs);
    assert!(mid > 0.0 && mid < 1.0);
    let mut prev = 0.0;
    for k in 0..=100 {
        let c = ct + (cs - ct) * k as f32 / 100.0;
        let f = smooth_falloff(c, ct, cs);
        assert!(f >= prev - 1e-6);
        prev = f;
    }
}

#[test]
fn spot_falloffs_integrate_to_their_closed_forms() {
    use render::light::SpotFalloff;
    // ∫ falloff dω by a midpoint rule in θ (2π sin θ dθ, 200 000 steps) against
    // `SpotFalloff::solid_angle`, and the linear falloff's value halfway in angle (Mitsuba 3's
    // spot: (γ − θ)/(γ − β)) against the smoothstep's halfway in cosine.
    for (cone, start) in [(30.0f64, 22.5f64), (60.0, 10.0), (90.0, 0.0), (20.0, 20.0)] {
        let (ct, cs) = (cone.to_radians().cos() as f32, start.to_radians().cos() as f32);
        for f in [SpotFalloff::Smoothstep, SpotFalloff::Linear] {
            let n = 200_000;
            let h = std::f64::consts::PI / n as f64;
            let numeric: f64 = (0..n)
                .map(|i| {
                    let th = (i as f64 + 0.5) * h;
                    2.0 * std::f64::consts::PI * th.sin() * h * f.eval(th.cos() as f32, ct, cs) as f64
                })
                .sum();
            let closed = f.solid_angle(ct, cs) as f64;
            assert!((numeric / closed - 1.0).abs() < 1e-4, "{f:?} cone {cone} start {start}: {numeric} vs {closed}");
        }
        if cone > start {
            let mid = (0.5 * (cone + start)).to_radians().cos() as f32;
            let v = SpotFalloff::Linear.eval(mid, ct, cs);
            assert!((v - 0.5).abs() < 1e-4, "linear halfway in angle: {v}");
            let mid_cos = 0.5 * (ct + cs);
            let v = SpotFalloff::Smoothstep.eval(mid_cos, ct, cs);
            assert!((v - 0.5).abs() < 1e-6, "smoothstep halfway in cosine: {v}");
        }
    }
    assert_eq!(SpotFalloff::from_name("linear"), Some(SpotFalloff::Linear));
    assert_eq!(SpotFalloff::from_name("cubic"), None);
}
