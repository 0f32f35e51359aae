//! Image undistortion (`scan::calib::undistort`, OpenCV's `undistort`): a photograph made by a
//! known distorted camera of a known pattern, undistorted, gives the pattern's pinhole image.

use render::camera::{Distortion, Extrinsics, Intrinsics, OpenCv};
use scan::calib::undistort::{remap_bilinear, undistort_map};

/// The pattern on the normalised image plane of the pinhole camera: 8-bit levels varying with a
/// period of about 60 pixels, so that an error of 0.1 px in where a pixel samples moves its value
/// by about a level.
fn pattern(x: f64, y: f64) -> f64 {
    128.0 + 60.0 * (60.0 * x + 0.3).sin() + 40.0 * (55.0 * y - 0.2).cos()
}

/// A photograph (640 × 480, barrel distortion with tangential terms) of the pattern: each pixel
/// takes the pattern's value at its undistorted ray. Undistorting it gives back the pattern at
/// each output pixel's own ray within 1.2 levels (the photograph's and the output's rounding and
/// bilinear interpolation) and 0.34 on average (two roundings to a level: E|u₁ + u₂| = ⅓ for
/// independent uniform u on ±½; measured 1.03 and 0.29); output pixels whose ray the photograph
/// does not see (the corners under pincushion distortion) are black. Sampling the photograph at
/// the output pixels themselves (no undistortion) is off by tens of levels near the border.
#[test]
fn undistorting_a_distorted_photograph_gives_the_pinhole_image() {
    let (w, h) = (640usize, 480usize);
    let k = Intrinsics { fx: 600.0, fy: 598.0, cx: 322.5, cy: 236.0 };
    let d = Distortion::from_opencv(&[-0.25, 0.09, 0.001, -0.0008, -0.01]).unwrap();
    let id = Extrinsics::from_rt([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3]).unwrap();
    let cam = OpenCv::new(k, d, id, w as u32, h as u32).unwrap();
    let mut photo = vec![0u8; w * h];
    for v in 0..h {
        for u in 0..w {
            let (x, y, ok) = cam.undistort((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy);
            assert!(ok);
            photo[v * w + u] = pattern(x, y).round() as u8;
        }
    }
    let map = undistort_map(&k, &d, &k, w, h);
    let out = remap_bilinear(&photo, 1, w, h, &map);
    let (mut worst, mut sum, mut n, mut black) = (0.0f64, 0.0, 0usize, 0usize);
    for v in 0..h {
        for u in 0..w {
            let [sx, sy] = map[v * w + u];
            if sx < 0.0 || sy < 0.0 || sx > (w - 1) as f64 || sy > (h - 1) as f64 {
                // Outside the photograph (barrel distortion: the output's corners).
                if sx < -1.0 || sy < -1.0 || sx > w as f64 || sy > h as f64 {
                    assert_eq!(out[v * w + u], 0, "({u}, {v}) samples ({sx}, {sy})");
                    black += 1;
                }
                continue;
            }
            let (x, y) = ((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy);
            let e = (out[v * w + u] as f64 - pattern(x, y)).abs();
            worst = worst.max(e);
            sum += e;
            n += 1;
        }
    }
    assert!(worst <= 1.2 && sum / (n as f64) < 0.34, "worst {worst}, mean {}", sum / n as f64);
    // Barrel distortion crops the photograph's corners: every output pixel is seen. Pincushion
    // distortion leaves the output's corners unseen: black, as OpenCV's constant border.
    assert_eq!(black, 0);
    let pin = Distortion::from_opencv(&[0.3, 0.0, 0.0, 0.0]).unwrap();
    let cushion = remap_bilinear(&photo, 1, w, h, &undistort_map(&k, &pin, &k, w, h));
    assert!([0, w - 1, (h - 1) * w, h * w - 1].iter().all(|&i| cushion[i] == 0) && cushion[(h / 2) * w + w / 2] > 0);
    // Without undistortion the photograph is not the pinhole image.
    let raw_worst = (0..h).flat_map(|v| (0..w).map(move |u| (u, v))).map(|(u, v)| (photo[v * w + u] as f64 - pattern((u as f64 - k.cx) / k.fx, (v as f64 - k.cy) / k.fy)).abs()).fold(0.0f64, f64::max);
    assert!(raw_worst > 30.0, "{raw_worst}");
    // Colour: each channel alone, as the grey image.
    let rgb: Vec<u8> = photo.iter().flat_map(|&p| [p, 255 - p, p / 2]).collect();
    let out3 = remap_bilinear(&rgb, 3, w, h, &map);
    let again = remap_bilinear(&photo.iter().map(|&p| 255 - p).collect::<Vec<_>>(), 1, w, h, &map);
    assert!(out3.chunks(3).zip(&out).all(|(c, &g)| c[0] == g));
    assert!(out3.chunks(3).zip(&again).all(|(c, &g)| c[1] == g));
}
