//! Film and checkpoints with the real tracer (`render_pass`) on tiny images of the Cornell box:
//! resuming is bit-exact whatever the thread count, a seed's disjoint pass ranges merge into the
//! uninterrupted run, and checkpoints of another scene are refused.

use std::path::Path;

use render::checkpoint::{Checkpoint, RenderIdentity, Run};
use render::film::Film;
use render::integrator::{render_pass, IntegratorSettings};
use render::load::CORNELL_BOX_TOML;
use render::scene::Scene;

fn tiny_box() -> Scene {
    let mut s = Scene::cornell_box();
    s.set_resolution(12, 10);
    s
}

/// Passes `passes` of `seed` added to `film`, on a pool of `threads` threads.
fn render(scene: &Scene, film: &mut Film, seed: u64, passes: std::ops::Range<u64>, threads: usize) {
    let settings = IntegratorSettings::default();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let mut buf = vec![[0.0f32; 3]; film.pixel_count()];
    pool.install(|| {
        for p in passes {
            render_pass(scene, &settings, seed, p, &mut buf);
            film.add_pass(&buf);
        }
    });
}

#[test]
fn resume_from_a_checkpoint_is_bit_exact_across_thread_counts() {
    let scene = tiny_box();
    let id = RenderIdentity::of_scene(&scene, &IntegratorSettings::default());
    let mut straight = Film::new(12, 10);
    render(&scene, &mut straight, 11, 0..6, 2);

    let mut first = Film::new(12, 10);
    render(&scene, &mut first, 11, 0..3, 1);
    let bytes = Checkpoint::single_run(id.clone(), 11, Some(6), first).to_bytes();
    let back = Checkpoint::from_bytes(&bytes).unwrap();
    back.check_matches(Path::new("t.ckpt"), &id).unwrap();
    let (seed, next) = back.resume_point(Path::new("t.ckpt")).unwrap();
    assert_eq!((seed, next), (11, 3));
    let mut resumed = back.film;
    render(&scene, &mut resumed, seed, next..6, 2);
    assert_eq!(resumed, straight, "resumed film differs from the uninterrupted one");
    assert!(straight.sums().iter().any(|s| s[1] > 0.0), "the box should not render black");
}

#[test]
fn disjoint_passes_of_one_seed_merge_into_the_whole_run() {
    let scene = tiny_box();
    let id = RenderIdentity::of_scene(&scene, &IntegratorSettings::default());
    let mut whole = Film::new(12, 10);
    render(&scene, &mut whole, 4, 0..8, 2);
    let mut a = Film::new(12, 10);
    render(&scene, &mut a, 4, 0..5, 2);
    let mut b = Film::new(12, 10);
    render(&scene, &mut b, 4, 5..8, 2);
    let ca = Checkpoint::single_run(id.clone(), 4, None, a);
    let mut cb = Checkpoint::single_run(id, 4, None, b);
    cb.runs = vec![Run { seed: 4, first_pass: 5, passes: 3 }];
    let m = Checkpoint::merge(&[("a".into(), ca.clone()), ("b".into(), cb)]).unwrap();
    assert_eq!(m.film.samples_per_pixel(), 8);
    for (x, y) in m.film.sums().iter().zip(whole.sums()) {
        for k in 0..3 {
            // Same samples, summed in another order: equal to rounding.
            assert!((x[k] - y[k]).abs() <= 1e-9 * y[k].abs().max(1e-6), "{x:?} vs {y:?}");
        }
    }
    // The same passes twice would count samples twice: refused.
    assert!(Checkpoint::merge(&[("a".into(), ca.clone()), ("a2".into(), ca)]).is_err());
}

#[test]
fn checkpoint_of_another_scene_is_refused() {
    let scene = tiny_box();
    let settings = IntegratorSettings::default();
    let id = RenderIdentity::of_scene(&scene, &settings);
    let mut film = Film::new(12, 10);
    render(&scene, &mut film, 1, 0..1, 2);
    let ck = Checkpoint::single_run(id.clone(), 1, None, film);
    // The same box seen from 10 cm closer is another scene.
    let closer = CORNELL_BOX_TOML.replace("eye = [278.0, 273.0, -800.0]", "eye = [278.0, 273.0, -700.0]");
    assert_ne!(closer, CORNELL_BOX_TOML);
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut other = Scene::from_toml_str(&closer, "edited.toml", &base).unwrap();
    other.set_resolution(12, 10);
    let other_id = RenderIdentity::of_scene(&other, &settings);
    let err = ck.check_matches(Path::new("runs/box.ckpt"), &other_id).unwrap_err().to_string();
    assert!(err.contains("runs/box.ckpt") && err.contains("another scene"), "{err}");
    // Same scene at another resolution: refused too.
    let mut bigger = tiny_box();
    bigger.set_resolution(24, 20);
    assert!(ck.check_matches(Path::new("b.ckpt"), &RenderIdentity::of_scene(&bigger, &settings)).is_err());
    assert!(ck.check_matches(Path::new("b.ckpt"), &id).is_ok());
}

/// Fuzz reproducers (`fuzz/regressions/checkpoint/`): counters and sizes that overflow u64 are
/// refused with a message, not wrapped (release) or panicked on (debug).
#[test]
fn overflowing_counters_and_sizes_are_refused() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/checkpoint");
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    for (name, expect) in [
        ("runs-passes-sum-overflows-u64.ckpt", "overflow"),
        ("resolution-4294967295-squared-overflows-byte-count.ckpt", "too many pixels"),
        ("run-first-pass-plus-passes-overflows-u64.ckpt", "overflow"),
    ] {
        let err = Checkpoint::from_bytes(&read(name)).expect_err(name);
        assert!(format!("{err:#}").contains(expect), "{name}: {err:#}");
    }
    // 2^63 samples per pixel parses; merged with a second such run the count would overflow.
    let c = Checkpoint::from_bytes(&read("merge-samples-per-pixel-overflows-u64.ckpt")).unwrap();
    let mut other = c.clone();
    other.runs[0].seed += 1;
    let err = Checkpoint::merge(&[("a.ckpt".into(), c), ("b.ckpt".into(), other)]).unwrap_err();
    assert!(format!("{err:#}").contains("overflow"), "{err:#}");
}
