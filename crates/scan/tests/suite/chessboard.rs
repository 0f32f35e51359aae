//! Chessboard corner detection on a synthesised anti-aliased image with known corners.

use nalgebra::Matrix3;
use scan::calib::chessboard::{find_chessboard, find_chessboard_named, GrayImage};
use scan::calib::homography::apply;

/// A 10 × 8-square board (9 × 7 inner corners, square 1) seen through homography `h`
/// (board → pixels, OpenCV convention), each pixel the mean of n × n samples (box filter),
/// black squares 30, white 200, white margin of one square, background 90.
fn render_board(h: &Matrix3<f64>, w: usize, ht: usize, n: usize) -> GrayImage {
    render_board_sized(h, w, ht, n, 9, 7)
}

/// [`render_board`] with `cols` × `rows` inner corners: squares from −1 to `cols` × −1 to
/// `rows`, the square outside inner corner (0, 0) black.
fn render_board_sized(h: &Matrix3<f64>, w: usize, ht: usize, n: usize, cols: usize, rows: usize) -> GrayImage {
    render_board_cut(h, w, ht, n, cols, rows, 1.0)
}

/// [`render_board_sized`] with the outer ring of squares only `outer` squares wide (a print cut
/// short by its edge), then the white margin.
fn render_board_cut(h: &Matrix3<f64>, w: usize, ht: usize, n: usize, cols: usize, rows: usize, outer: f64) -> GrayImage {
    let hi = h.try_inverse().unwrap();
    let (cw, rw) = (cols as f64, rows as f64);
    let mut data = vec![0f32; w * ht];
    for y in 0..ht {
        for x in 0..w {
            let mut s = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let px = x as f64 - 0.5 + (i as f64 + 0.5) / n as f64;
                    let py = y as f64 - 0.5 + (j as f64 + 0.5) / n as f64;
                    let b = apply(&hi, [px, py]);
                    let (lo, hx, hy) = (-outer, cw - 1.0 + outer, rw - 1.0 + outer);
                    let v = if b[0] < lo - 1.0 || b[0] > hx + 1.0 || b[1] < lo - 1.0 || b[1] > hy + 1.0 {
                        90.0
                    } else if b[0] < lo || b[0] > hx || b[1] < lo || b[1] > hy {
                        200.0
                    } else if (b[0].floor() as i64 + b[1].floor() as i64).rem_euclid(2) == 0 {
                        30.0
                    } else {
                        200.0
                    };
                    s += v;
                }
            }
            data[y * w + x] = (s / (n * n) as f64) as f32;
        }
    }
    GrayImage { width: w, height: ht, data }
}

/// A board turned by `deg` about the point (cx, cy) of the image, with a little perspective:
/// board (0, 0) at the centre minus half the board, `sq` pixels a square.
fn turned(deg: f64, sq: f64, cx: f64, cy: f64, cols: usize, rows: usize) -> Matrix3<f64> {
    let (s, c) = deg.to_radians().sin_cos();
    let centre = Matrix3::new(1.0, 0.0, -(cols as f64 - 1.0) / 2.0, 0.0, 1.0, -(rows as f64 - 1.0) / 2.0, 0.0, 0.0, 1.0);
    let persp = Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.015, -0.01, 1.0);
    Matrix3::new(c * sq, -s * sq, cx, s * sq, c * sq, cy, 0.0, 0.0, 1.0) * persp * centre
}

#[test]
fn corners_of_a_rendered_perspective_board_are_found_to_a_twentieth_of_a_pixel() {
    // A board of 40 px squares in perspective (tilted ~25°, rotated ~8°), 640 × 480.
    let h = Matrix3::new(41.0, -4.5, 150.0, 6.0, 37.0, 110.0, 0.012, -0.006, 1.0);
    let img = render_board(&h, 640, 480, 12);
    let found = find_chessboard(&img, 9, 7).expect("board found");
    assert_eq!(found.len(), 63);
    let truth: Vec<[f64; 2]> = (0..63).map(|k| apply(&h, [(k % 9) as f64, (k / 9) as f64])).collect();
    // The origin rule: corner 0 is the extreme corner nearest the image's top-left; with this
    // pose that is board corner (0, 0), and the labeling is then the board's own.
    let mut worst: f64 = 0.0;
    let mut mean = 0.0;
    for (f, t) in found.iter().zip(&truth) {
        let e = ((f[0] - t[0]).powi(2) + (f[1] - t[1]).powi(2)).sqrt();
        worst = worst.max(e);
        mean += e / 63.0;
    }
    eprintln!("corner error: mean {mean:.4} px, worst {worst:.4} px");
    assert!(worst <= 0.05, "worst corner error {worst:.4} px");
    // The same board turned by 180° in the image gives the same labeling rule (corner 0 top-left).
    let rot = Matrix3::new(-1.0, 0.0, 639.0, 0.0, -1.0, 479.0, 0.0, 0.0, 1.0) * h;
    let img2 = render_board(&rot, 640, 480, 6);
    let f2 = find_chessboard(&img2, 9, 7).expect("board found");
    let t2 = apply(&rot, [8.0, 6.0]);
    assert!(((f2[0][0] - t2[0]).powi(2) + (f2[0][1] - t2[1]).powi(2)).sqrt() < 0.1, "{:?} vs {t2:?}", f2[0]);
}

#[test]
fn a_blank_image_is_a_clean_board_not_found() {
    let img = GrayImage { width: 320, height: 240, data: vec![128.0; 320 * 240] };
    let e = find_chessboard_named(&img, 9, 7, "capture_9").unwrap_err().to_string();
    assert!(e.starts_with("board not found (capture capture_9)"), "{e}");
    // A board with other corner counts than asked is not taken for the asked one.
    let h = Matrix3::new(30.0, 0.0, 100.0, 0.0, 30.0, 80.0, 0.0, 0.0, 1.0);
    assert!(find_chessboard(&render_board(&h, 480, 400, 4), 8, 7).is_none());
}

/// OpenCV's labeling, whatever the board's turn in the image: rows run so that
/// (p[cols−1] − p[0]) × (p[cols] − p[cols−1]) > 0 (the same for every view of the board's
/// front, so two cameras label the same physical corners alike); on a 9 × 6 board, whose ends
/// differ in colour, corner 0 is always the corner at the black outer square, board (0, 0), as
/// OpenCV returns it; on the 9 × 7 board, which looks the same turned by 180°, corner 0 is the end
/// nearer the image's top-left. Turns of 0° to 330° in steps of 30°, each within 0.1 px.
#[test]
fn corner_order_follows_opencv_at_every_turn_of_the_board() {
    for (cols, rows) in [(9usize, 6usize), (9, 7)] {
        for k in 0..12 {
            let deg = 30.0 * k as f64 + 7.0;
            let h = turned(deg, 34.0, 320.0, 240.0, cols, rows);
            let img = render_board_sized(&h, 640, 480, 4, cols, rows);
            let f = find_chessboard(&img, cols, rows).unwrap_or_else(|| panic!("{cols}×{rows} at {deg}°: not found"));
            let (p0, p1, p2) = (f[0], f[cols - 1], f[cols]);
            let cross = (p1[0] - p0[0]) * (p2[1] - p1[1]) - (p1[1] - p0[1]) * (p2[0] - p1[0]);
            assert!(cross > 0.0, "{cols}×{rows} at {deg}°: handedness {cross}");
            // Which board corner is corner 0, and is the labeling the board's own or turned 180°?
            let own: Vec<[f64; 2]> = (0..cols * rows).map(|i| apply(&h, [(i % cols) as f64, (i / cols) as f64])).collect();
            let turned180: Vec<[f64; 2]> = own.iter().rev().copied().collect();
            let err = |t: &[[f64; 2]]| f.iter().zip(t).map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()).fold(0.0, f64::max);
            let (e_own, e_turned) = (err(&own), err(&turned180));
            if (cols + rows) % 2 == 1 {
                assert!(e_own < 0.1, "{cols}×{rows} at {deg}°: corner 0 is not the black-square corner (own {e_own}, turned {e_turned})");
            } else {
                let start = |t: &[[f64; 2]]| t[0][0] + t[0][1];
                let want = if start(&own) < start(&turned180) { &own } else { &turned180 };
                assert!(err(want) < 0.1, "{cols}×{rows} at {deg}°: corner 0 not the end nearer the top-left");
            }
        }
    }
}

/// A print whose outer squares are cut to 0.4 of a square by its edge (as in OpenCV's
/// samples/data left07, left08, right08): corner 0 is still the corner at the black outer
/// square, at every turn (the colour is read next to the corner, not in the square's middle).
#[test]
fn corner_order_holds_when_the_outer_squares_are_cut_short() {
    let (cols, rows) = (9usize, 6usize);
    for k in 0..12 {
        let deg = 30.0 * k as f64 + 7.0;
        let h = turned(deg, 34.0, 320.0, 240.0, cols, rows);
        let img = render_board_cut(&h, 640, 480, 4, cols, rows, 0.4);
        let f = find_chessboard(&img, cols, rows).unwrap_or_else(|| panic!("at {deg}°: not found"));
        let own: Vec<[f64; 2]> = (0..cols * rows).map(|i| apply(&h, [(i % cols) as f64, (i / cols) as f64])).collect();
        // (The corners next to the cut squares refine to within half a pixel; a reversed order
        // would put every corner a board's length away.)
        let e = f.iter().zip(&own).map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()).fold(0.0, f64::max);
        assert!(e < 1.0, "at {deg}°: corner 0 is not the black-square corner (max distance {e} px)");
    }
}

/// A 9 × 6 board of 150-pixel squares with edges blurred by σ = 5 px in a 2000 × 1500 image
/// (the scale of a 5-Mpixel photograph) is found, through the half-resolution levels, and its
/// corners refined in the full image lie within 0.2 px of the truth.
#[test]
fn a_board_of_large_soft_squares_is_found_at_a_coarser_level() {
    let h = turned(12.0, 150.0, 1000.0, 750.0, 9, 6);
    let img = render_board_sized(&h, 2000, 1500, 1, 9, 6).blur(5.0);
    let f = find_chessboard(&img, 9, 6).expect("board found");
    let worst = (0..54)
        .map(|i| {
            let t = apply(&h, [(i % 9) as f64, (i / 9) as f64]);
            ((f[i][0] - t[0]).powi(2) + (f[i][1] - t[1]).powi(2)).sqrt()
        })
        .fold(0.0, f64::max);
    assert!(worst < 0.2, "worst corner error {worst} px");
}

/// The separable blur's vectorised interior gives the same bits as summing each pixel's taps
/// with clamped indices (the centre tap, then the symmetric pairs at ±d, d = 1…r), on images
/// wider and narrower than the kernel.
#[test]
fn blur_equals_the_clamped_tap_sum_bit_for_bit() {
    let mut state = 12345u64;
    let mut rnd = || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((state >> 40) % 256) as f32
    };
    for &(w, h, sigma) in &[(37usize, 23usize, 2.0f64), (5, 9, 2.0), (64, 3, 1.0), (13, 13, 1.0)] {
        let img = GrayImage { width: w, height: h, data: (0..w * h).map(|_| rnd()).collect() };
        let r = (3.0 * sigma).ceil() as isize;
        let k: Vec<f32> = (-r..=r).map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp() as f32).collect();
        let sum: f32 = k.iter().sum();
        let k: Vec<f32> = k.iter().map(|v| v / sum).collect();
        let at = |x: isize, y: isize| img.data[y.clamp(0, h as isize - 1) as usize * w + x.clamp(0, w as isize - 1) as usize];
        let out = img.blur(sigma);
        let c = r as usize;
        let row = |x: isize, y: isize| {
            let mut s = k[c] * at(x, y);
            for d in 1..=r {
                s += k[c + d as usize] * (at(x - d, y) + at(x + d, y));
            }
            s
        };
        for y in 0..h as isize {
            for x in 0..w as isize {
                let mut v = k[c] * row(x, y);
                for d in 1..=r {
                    v += k[c + d as usize] * (row(x, y - d) + row(x, y + d));
                }
                assert_eq!(out.data[y as usize * w + x as usize].to_bits(), v.to_bits(), "{w}×{h} σ {sigma} at ({x}, {y})");
            }
        }
    }
}

/// Refining a few corners (each in a crop around it) gives what refining them in the whole
/// blurred image gives (the same corners repeated until their windows cover the image), to
/// 1e-9 px, near the border too.
#[test]
fn corner_subpix_in_crops_is_exact() {
    let h = turned(7.0, 120.0, 1000.0, 740.0, 9, 6);
    let img = render_board_sized(&h, 2000, 1500, 4, 9, 6).blur(1.5);
    let truth: Vec<[f64; 2]> = (0..6).flat_map(|r| (0..9).map(move |c| [c as f64, r as f64])).map(|b| apply(&h, b)).collect();
    // Starts off by up to 1.7 px; one corner near the image's edge (its crop reaches beyond it).
    let mut few: Vec<[f64; 2]> = truth.iter().step_by(7).enumerate().map(|(i, p)| [p[0] + 1.7 * ((i % 3) as f64 - 1.0), p[1] - 1.1 * ((i % 2) as f64)]).collect();
    few.push([3.0, 5.0]);
    let half = 11;
    let side = 2 * (3 * half + 6) + 1;
    let copies = (2000 * 1500) / (few.len() * side * side) + 1;
    let mut many: Vec<[f64; 2]> = (0..copies).flat_map(|_| few.iter().copied()).collect();
    assert!(many.len() * side * side >= 2000 * 1500);
    scan::calib::chessboard::corner_subpix(&img, &mut few, half, 40, 1e-3);
    scan::calib::chessboard::corner_subpix(&img, &mut many, half, 40, 1e-3);
    for (i, (a, b)) in few.iter().zip(&many).enumerate() {
        assert!((a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9, "corner {i}: crop {a:?}, whole image {b:?}");
    }
    // And the refinement did its work: the board's corners within 0.05 px of the truth.
    for (a, t) in few.iter().zip(truth.iter().step_by(7)) {
        assert!(((a[0] - t[0]).powi(2) + (a[1] - t[1]).powi(2)).sqrt() < 0.05, "{a:?} against {t:?}");
    }
}

/// The white frame of the shared capture_0 (a 9 × 7 board of 71-px squares) blurred by σ = 15 px,
/// where OpenCV's finder finds no board: lucent's finder either finds none or finds the board's
/// corners, within 5 px of those in the sharp frame. Refined onto the wrong place at the full
/// scale, they were up to 22 px off: such a lattice is not smooth, and the half-scale search
/// finds the board instead.
#[test]
fn a_defocused_board_gives_its_corners_or_none() {
    let path = crate::common::sample_capture(0).join("graycode_40.png");
    let sharp = GrayImage::load(&path).unwrap();
    let truth = find_chessboard(&sharp, 9, 7).expect("the sharp board");
    let blurred = sharp.blur(15.0);
    if let Some(c) = find_chessboard(&blurred, 9, 7) {
        let worst = c.iter().zip(&truth).map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()).fold(0.0, f64::max);
        assert!(worst < 5.0, "corners up to {worst} px off");
    }
}
