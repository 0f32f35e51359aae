//! `lucent fit photo` on bad input: one line naming the file or option, exit status ≠ 0.

use super::common::{run, Scratch};
use render::image_io::{write_image, Image};

const SCENE: &str = r#"
[camera]
eye = [0, 0, 0]
look_at = [0, 0, 1]
vfov_deg = 40
width = 16
height = 12

[materials.label0]
type = "lambertian"
albedo = 0.5

[[objects]]
name = "wall"
material = "label0"
quad = [[-2, -2, 3], [2, -2, 3], [2, 2, 3], [-2, 2, 3]]

[[lights]]
type = "environment"
radiance = 0.2
"#;

fn setup(photo_w: u32, photo_h: u32) -> Scratch {
    let dir = Scratch::new("fit-photo");
    std::fs::write(dir.path("scene.toml"), SCENE).unwrap();
    std::fs::write(dir.path("nolabel.toml"), SCENE.replace("label0", "paint")).unwrap();
    let img = Image { width: photo_w, height: photo_h, rgb: vec![[0.1; 3]; (photo_w * photo_h) as usize] };
    write_image(&dir.path("photo.png"), &img, 0.0).unwrap();
    dir
}

fn fails_with(dir: &Scratch, args: &[&str], needle: &str) {
    let out = run(&dir.0, args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert_eq!(err.trim().lines().count(), 1, "not one line: {err}");
    assert!(err.contains(needle), "{args:?}: {err} lacks `{needle}`");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn fit_photo_refuses_bad_input_with_one_line() {
    let dir = setup(32, 24);
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "-q"], "calibrated for 16×12");
    let dir = setup(16, 12);
    fails_with(&dir, &["fit", "photo", "nolabel.toml", "--photo", "photo.png", "-q"], "no material named label*");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--hold", "colour", "-q"], "--hold colour: unknown");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--hold", "gain", "-q"], "the fit needs a scale");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--width", "5", "-q"], "not an integer multiple");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--pattern", "photo.png", "-q"], "the scene has no projector");
    fails_with(&dir, &["fit", "photo", "scene.toml", "-q"], "no photograph");
    // The gamma from complementary frames needs a capture and its patterns, and excludes --gamma.
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--gamma-from-pairs", "-q"], "not provided: --capture <DIR>, --patterns <DIR>");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--capture", ".", "--patterns", ".", "--gamma", "2", "--gamma-from-pairs", "-q"], "cannot be used with");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--repeat", "photo.png", "--repeat", "photo.png", "-q"], "2 --repeat for 1 --photo");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--edge-px", "-1", "-q"], "--edge-px must be a whole number");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--max-background", "2", "-q"], "--max-background must lie in [0, 1]");
    fails_with(&dir, &["fit", "photo", "scene.toml", "--photo", "photo.png", "--fit-roughness", "-q"], "--fit-roughness: no label is `plastic`");
    // A capture needs its patterns, and its frames must run without a gap (frame k pairs with
    // pattern k).
    fails_with(&dir, &["fit", "photo", "scene.toml", "--capture", ".", "-q"], "--patterns");
    std::fs::create_dir_all(dir.path("cap")).unwrap();
    for k in [0, 1, 3] {
        std::fs::copy(dir.path("photo.png"), dir.path(&format!("cap/graycode_{k:02}.png"))).unwrap();
    }
    fails_with(&dir, &["fit", "photo", "scene.toml", "--capture", "cap", "--patterns", "cap", "-q"], "frame 2 is missing");
}
