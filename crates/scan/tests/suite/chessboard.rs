//! Chessboard corner detection on a synthesised anti-aliased image with known corners.

use nalgebra::Matrix3;
use scan::calib::chessboard::{find_chessboard, find_chessboard_named, GrayImage};
use scan::calib::homography::apply;

/// A 10 × 8-square board (9 × 7 inner corners, square 1) seen through homography `h`
/// (board → pixels, OpenCV convention), each pixel the mean of n × n samples (box filter),
/// black squares 30, white 200, white margin of one square, background 90.
fn render_board(h: &Matrix3<f64>, w: usize, ht: usize, n: usize) -> GrayImage {
    let hi = h.try_inverse().unwrap();
    let mut data = vec![0f32; w * ht];
    for y in 0..ht {
        for x in 0..w {
            let mut s = 0.0;
            for j in 0..n {
                for i in 0..n {
                    let px = x as f64 - 0.5 + (i as f64 + 0.5) / n as f64;
                    let py = y as f64 - 0.5 + (j as f64 + 0.5) / n as f64;
                    let b = apply(&hi, [px, py]);
                    // Board coordinates: inner corner (0, 0) at the origin, squares from −1 to 9 × −1 to 7.
                    let v = if b[0] < -2.0 || b[0] > 10.0 || b[1] < -2.0 || b[1] > 8.0 {
                        90.0
                    } else if b[0] < -1.0 || b[0] > 9.0 || b[1] < -1.0 || b[1] > 7.0 {
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
