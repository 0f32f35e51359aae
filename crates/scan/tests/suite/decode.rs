//! Decoding: ideal patterns exactly, area-sampled views with sub-pixel accuracy, real captures,
//! bad capture folders.

use scan::decode::{decode, read_capture, DecodeSettings};
use scan::graycode::{Frame, PatternSet};

use crate::common::{ideal_capture, sample_capture, scratch, write_capture};

/// Camera = projector image: every pixel decodes to its own projector coordinate, exactly, for
/// step 1; with a step, pixels inside bracketed blocks are exact and the first and last block
/// (no edge on one side) sit at the block centre.
#[test]
fn ideal_patterns_decode_exactly_for_every_projector_pixel() {
    for &(w, h, step) in &[(1024u32, 768u32, 1u32), (37, 29, 1), (600, 5, 1), (100, 77, 3), (64, 48, 4), (50, 33, 7)] {
        let p = PatternSet::new(w, h, step).unwrap();
        let (map, stats) = decode(&ideal_capture(&p), &p, &DecodeSettings::default()).unwrap();
        assert_eq!(stats.valid_pixels, (w * h) as usize, "{w}x{h} step {step}");
        let exact = |x: u32, codes: u32, size: u32, centre: f64| {
            let c = x / step;
            if step == 1 || (c > 0 && c + 1 < codes) {
                x as f64
            } else {
                let _ = size;
                centre
            }
        };
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let want_c = exact(x, p.column_codes(), w, p.column_centre(x / step));
                let want_r = exact(y, p.row_codes(), h, p.row_centre(y / step));
                assert_eq!(map.col[i] as f64, want_c, "{w}x{h} step {step}: column at ({x}, {y})");
                assert_eq!(map.row[i] as f64, want_r, "{w}x{h} step {step}: row at ({x}, {y})");
            }
        }
        // Without refinement every pixel sits at its block's centre.
        let settings = DecodeSettings { refine: false, ..DecodeSettings::default() };
        let (map, _) = decode(&ideal_capture(&p), &p, &settings).unwrap();
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                assert_eq!(map.col[i] as f64, p.column_centre(x / step));
                assert_eq!(map.row[i] as f64, p.row_centre(y / step));
            }
        }
    }
}

/// Fraction of [a, b] (projector coordinate, pixel edges at half-integers) lit in `frame` along
/// one axis: the exact box-filtered view of a stripe pattern.
fn lit_fraction(p: &PatternSet, frame: Frame, a: f64, b: f64, column: bool) -> f64 {
    let mut lit = 0.0;
    let lo = (a + 0.5).floor() as i64;
    let hi = (b + 0.5).floor() as i64;
    for k in lo..=hi {
        let (pa, pb) = ((k as f64 - 0.5).max(a), (k as f64 + 0.5).min(b));
        if pb <= pa || k < 0 {
            continue;
        }
        let k = k as u32;
        let on = if column { p.lit(frame, k, 0) } else { p.lit(frame, 0, k) };
        if on {
            lit += pb - pa;
        }
    }
    lit / (b - a)
}

/// A camera seeing the projector magnified 2.7× with box-filtered pixels, an offset, 20 % ambient
/// light and a contrast of 200 grey levels: refined coordinates are much closer to the truth than
/// the integer decoding (uniform quantisation: RMS 1/√12 ≈ 0.289 px).
#[test]
fn refinement_beats_integer_decoding_on_an_area_sampled_magnified_view() {
    let p = PatternSet::new(128, 96, 1).unwrap();
    let (w, h) = (300usize, 200usize);
    let scale = 1.0 / 2.7; // projector pixels per camera pixel
    let (u0, v0) = (7.3, 11.85);
    let truth = |x: usize, y: usize| (u0 + scale * x as f64, v0 + scale * y as f64);
    let frames: Vec<Vec<u8>> = (0..p.len())
        .map(|i| {
            let frame = p.frame(i).unwrap();
            let mut img = vec![0u8; w * h];
            for y in 0..h {
                for x in 0..w {
                    let (u, v) = truth(x, y);
                    let f = match frame {
                        Frame::Column { .. } => lit_fraction(&p, frame, u - scale / 2.0, u + scale / 2.0, true),
                        Frame::Row { .. } => lit_fraction(&p, frame, v - scale / 2.0, v + scale / 2.0, false),
                        Frame::White => 1.0,
                        Frame::Black => 0.0,
                    };
                    img[y * w + x] = (30.0 + 200.0 * f).round() as u8;
                }
            }
            img
        })
        .collect();
    let capture = scan::decode::Capture { width: w, height: h, frames };
    let rms = |refine: bool| {
        let (map, stats) = decode(&capture, &p, &DecodeSettings { refine, ..DecodeSettings::default() }).unwrap();
        let (mut sc, mut sr, mut n) = (0.0, 0.0, 0usize);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                if !map.col[i].is_finite() {
                    continue;
                }
                let (u, v) = truth(x, y);
                sc += (map.col[i] as f64 - u).powi(2);
                sr += (map.row[i] as f64 - v).powi(2);
                n += 1;
            }
        }
        (stats, (sc / n as f64).sqrt(), (sr / n as f64).sqrt())
    };
    let (s0, c0, r0) = rms(false);
    let (s1, c1, r1) = rms(true);
    eprintln!("integer RMS col {c0:.4} row {r0:.4}; refined RMS col {c1:.4} row {r1:.4}; valid {} refined {} / {}", s1.valid_pixels, s1.refined_columns, s1.refined_rows);
    // Pixels whose footprint straddles a stripe edge with pattern ≈ inverse are undecided.
    assert!(s0.valid_pixels > w * h * 8 / 10, "{s0:?}");
    assert!((c0 - 0.289).abs() < 0.03 && (r0 - 0.289).abs() < 0.03, "integer decoding {c0} {r0}");
    assert!(c1 < 0.06 && r1 < 0.06, "refined {c1} {r1}");
    assert!(s1.refined_columns > s1.valid_pixels * 9 / 10);
}

#[test]
fn real_captures_cover_the_lit_board_and_decode_monotone_coordinates() {
    let p = PatternSet::new(1024, 768, 1).unwrap();
    for k in 0..3 {
        let dir = sample_capture(k);
        let capture = read_capture(&dir, &p, &|| {}).unwrap();
        assert_eq!((capture.width, capture.height), (1280, 1024));
        let (map, stats) = decode(&capture, &p, &DecodeSettings::default()).unwrap();
        let frac = map.valid_fraction();
        eprintln!("capture_{k}: valid {:.4}, refined columns {:.3}, rows {:.3}", frac, stats.refined_columns as f64 / stats.valid_pixels as f64, stats.refined_rows as f64 / stats.valid_pixels as f64);
        assert!(frac > 0.38, "capture_{k}: valid fraction {frac}");
        // Along camera rows the projector column increases, along camera columns the projector
        // row increases (camera and projector side by side, neither mirrored): count decreasing
        // steps between valid neighbours.
        let (w, h) = (map.width, map.height);
        let (mut up, mut down) = (0usize, 0usize);
        let (mut rup, mut rdown) = (0usize, 0usize);
        for y in 0..h {
            for x in 0..w - 1 {
                let (i, j) = (y * w + x, y * w + x + 1);
                if map.is_valid(x, y) && map.is_valid(x + 1, y) {
                    let d = map.col[j] - map.col[i];
                    if d > 0.0 { up += 1 } else if d < -1.0 { down += 1 }
                }
            }
        }
        for y in 0..h - 1 {
            for x in 0..w {
                let (i, j) = (y * w + x, (y + 1) * w + x);
                if map.is_valid(x, y) && map.is_valid(x, y + 1) {
                    let d = map.row[j] - map.row[i];
                    if d > 0.0 { rup += 1 } else if d < -1.0 { rdown += 1 }
                }
            }
        }
        eprintln!("capture_{k}: column steps up {up} down {down}; row steps up {rup} down {rdown}");
        assert!(down * 200 < up, "capture_{k}: columns not monotone ({up} up, {down} down)");
        assert!(rdown * 200 < rup, "capture_{k}: rows not monotone ({rup} up, {rdown} down)");
        // The projector coordinate is smooth over the board and the wall: the second difference
        // of the column along camera rows (and of the row along camera columns) measures decoding
        // noise. Integer decoding: median |·| of 1 projector pixel, RMS about 1 (quantisation; 0.71
        // for independent uniform errors). Refined: the median must drop below a quarter of the
        // integer one. (The RMS is dominated by gross misreads, jumps of many codes that no
        // refinement repairs, and is only printed.)
        let (int_map, _) = decode(&capture, &p, &DecodeSettings { refine: false, ..DecodeSettings::default() }).unwrap();
        let d2 = |m: &scan::decode::DecodeMap| {
            let (mut c, mut r) = (Vec::new(), Vec::new());
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let i = y * w + x;
                    let e = (m.col[i + 1] - 2.0 * m.col[i] + m.col[i - 1]) as f64;
                    if e.is_finite() {
                        c.push(e);
                    }
                    let e = (m.row[i + w] - 2.0 * m.row[i] + m.row[i - w]) as f64;
                    if e.is_finite() {
                        r.push(e);
                    }
                }
            }
            let stats = |v: &mut Vec<f64>| {
                let rms = (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt();
                v.iter_mut().for_each(|e| *e = e.abs());
                v.sort_by(f64::total_cmp);
                (rms, v[v.len() / 2])
            };
            (stats(&mut c), stats(&mut r))
        };
        let (ints, refs) = (d2(&int_map), d2(&map));
        eprintln!("capture_{k}: second difference (RMS, median |.|): integer col {:.3?} row {:.3?}; refined col {:.3?} row {:.3?}", ints.0, ints.1, refs.0, refs.1);
        for (what, i, r) in [("columns", ints.0, refs.0), ("rows", ints.1, refs.1)] {
            assert!(r.1 < 0.25 * i.1, "capture_{k}: refinement does not smooth the {what} (RMS {} → {}, median {} → {})", i.0, r.0, i.1, r.1);
        }
    }
}

#[test]
fn bad_capture_folders_name_the_file() {
    let p = PatternSet::new(16, 8, 1).unwrap();
    let good = ideal_capture(&p);
    let err = |dir: &std::path::Path| format!("{:#}", read_capture(dir, &p, &|| {}).unwrap_err());

    let dir = scratch("missing");
    write_capture(&dir, &good);
    std::fs::remove_file(dir.join("graycode_05.png")).unwrap();
    let e = err(&dir);
    assert!(e.contains("graycode_05.png") && e.contains("missing"), "{e}");

    let dir = scratch("extra");
    write_capture(&dir, &good);
    std::fs::copy(dir.join("graycode_00.png"), dir.join(format!("graycode_{}.png", p.len()))).unwrap();
    let e = err(&dir);
    assert!(e.contains(&format!("graycode_{}.png", p.len())) && e.contains("extra"), "{e}");

    let dir = scratch("twice");
    write_capture(&dir, &good);
    std::fs::copy(dir.join("graycode_03.png"), dir.join("graycode_03.jpg")).unwrap();
    let e = err(&dir);
    assert!(e.contains("graycode_03"), "{e}");

    let dir = scratch("size");
    write_capture(&dir, &good);
    image::GrayImage::new(16, 9).save(dir.join("graycode_07.png")).unwrap();
    let e = err(&dir);
    assert!(e.contains("graycode_07.png") && e.contains("16x9"), "{e}");

    let dir = scratch("corrupt");
    write_capture(&dir, &good);
    std::fs::write(dir.join("graycode_02.png"), b"not a png").unwrap();
    let e = err(&dir);
    assert!(e.contains("graycode_02.png"), "{e}");

    // Another projector size needs another frame count: a 1024x768 capture read as 2048x768.
    let e = format!("{:#}", read_capture(&sample_capture(0), &PatternSet::new(2048, 768, 1).unwrap(), &|| {}).unwrap_err());
    assert!(e.contains("graycode_42.png") && e.contains("missing"), "{e}");
    let e = format!("{:#}", read_capture(&sample_capture(0), &PatternSet::new(512, 768, 1).unwrap(), &|| {}).unwrap_err());
    assert!(e.contains("graycode_4") && e.contains("extra"), "{e}");

    let e = err(&scratch("empty").join("nope"));
    assert!(e.contains("nope"), "{e}");
    // A folder without any frame says so (not that frame 0 is missing).
    let empty = scratch("no-frames");
    let e = err(&empty);
    assert!(e.contains("no frames in the folder"), "{e}");
}

/// A folder named the way other capture tools write theirs (`img_1.png` … `img_N.png`, unpadded,
/// so that byte order would put `img_10` before `img_2`) is read in natural order and decodes to
/// exactly the map of the same frames named `graycode_NN.png`; a wrong number of such files is
/// one error naming the folder and both counts.
#[test]
fn other_frame_names_are_read_in_natural_order() {
    use scan::decode::natural_cmp;
    use std::cmp::Ordering::*;
    assert_eq!(natural_cmp("img_2.png", "img_10.png"), Less);
    assert_eq!(natural_cmp("img_10.png", "img_9.png"), Greater);
    assert_eq!(natural_cmp("a007.png", "a7.png"), Greater);
    assert_eq!(natural_cmp("a7.png", "a7.png"), Equal);
    assert_eq!(natural_cmp("b1.png", "a2.png"), Greater);

    let p = PatternSet::new(40, 24, 1).unwrap();
    let good = ideal_capture(&p);
    let reference = scratch("natural-ref");
    write_capture(&reference, &good);
    let dir = scratch("natural");
    // Written in reverse so that the directory's own order is no help.
    for i in (0..p.len()).rev() {
        std::fs::copy(reference.join(format!("graycode_{i:02}.png")), dir.join(format!("img_{}.png", i + 1))).unwrap();
    }
    std::fs::write(dir.join("notes.txt"), b"not a frame").unwrap();
    let a = read_capture(&reference, &p, &|| {}).unwrap();
    let b = read_capture(&dir, &p, &|| {}).unwrap();
    assert!(a.frames == b.frames, "frames read in another order");
    let (ma, _) = decode(&a, &p, &DecodeSettings::default()).unwrap();
    let (mb, _) = decode(&b, &p, &DecodeSettings::default()).unwrap();
    assert_eq!(ma.col, mb.col);
    assert_eq!(ma.row, mb.row);

    std::fs::remove_file(dir.join("img_7.png")).unwrap();
    let e = format!("{:#}", read_capture(&dir, &p, &|| {}).unwrap_err());
    assert!(e.contains("natural") && e.contains(&format!("{} PNG/JPEG", p.len() - 1)) && e.contains(&format!("has {} frames", p.len())), "{e}");
}

/// Hole filling against a known map: camera pixels see a plane whose projector coordinates are
/// affine in the pixel (col = 3 + 0.8 x + 0.1 y, row = 5 − 0.05 x + 0.9 y) left of x = 40 and
/// jump by 200 projector pixels right of it (a depth step). With 30 % of the pixels undecided at
/// random, every filled pixel left of the step is exact (affine data, affine fit), no pixel whose
/// window straddles the step is filled (the fit's residual is far above 1 px), and nothing
/// beyond the decoded area's outline (the border band left undecided) is filled.
#[test]
fn fill_holes_restores_an_affine_map_and_stops_at_steps_and_outlines() {
    use scan::decode::{fill_holes, DecodeMap};
    let (w, h) = (80usize, 60usize);
    let truth = |x: usize, y: usize| -> (f32, f32) {
        let (fx, fy) = (x as f64, y as f64);
        let jump = if x >= 40 { 200.0 } else { 0.0 };
        ((3.0 + 0.8 * fx + 0.1 * fy + jump) as f32, (5.0 - 0.05 * fx + 0.9 * fy) as f32)
    };
    let mut rng = crate::common::Pcg::new(3);
    let mut map = DecodeMap { width: w, height: h, col: vec![f32::NAN; w * h], row: vec![f32::NAN; w * h], white: vec![200.0; w * h], black: vec![5.0; w * h] };
    let border = |x: usize, y: usize| x < 6 || y < 6 || x >= w - 6 || y >= h - 6;
    for y in 0..h {
        for x in 0..w {
            if !border(x, y) && rng.uniform() > 0.3 {
                let (c, r) = truth(x, y);
                map.col[y * w + x] = c;
                map.row[y * w + x] = r;
            }
        }
    }
    let (filled, n) = fill_holes(&map, 3, 0.25, 1.0);
    assert!(n > 300, "{n} filled");
    let mut exact = 0;
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if map.col[i].is_finite() {
                assert_eq!((filled.col[i], filled.row[i]), (map.col[i], map.row[i]));
                continue;
            }
            if !filled.col[i].is_finite() {
                continue;
            }
            assert!(!border(x, y), "filled beyond the outline at ({x}, {y})");
            assert!(!(x + 3 >= 40 && x < 43), "filled across the step at ({x}, {y})");
            let (c, r) = truth(x, y);
            assert!((filled.col[i] - c).abs() < 1e-3 && (filled.row[i] - r).abs() < 1e-3, "({x}, {y}): {} {} vs {c} {r}", filled.col[i], filled.row[i]);
            exact += 1;
        }
    }
    assert_eq!(exact, n);
}

/// A colour frame becomes grey with OpenCV's `cvtColor` luma in 14-bit fixed point: pure red,
/// green and blue at 255 give 76, 150 and 29 (what `cv2.cvtColor(…, COLOR_RGB2GRAY)` returns),
/// white 255, a mixed colour the rounded weighted sum; a grey PNG is read as it is.
#[test]
fn colour_frames_are_grey_as_opencv_makes_them() {
    let dir = scratch("grey-opencv");
    let rgb: Vec<u8> = [[255u8, 0, 0], [0, 255, 0], [0, 0, 255], [255, 255, 255], [10, 200, 90], [0, 0, 0]].concat();
    image::RgbImage::from_raw(6, 1, rgb).unwrap().save(dir.join("c.png")).unwrap();
    let (w, h, g) = scan::decode::read_grey(&dir.join("c.png")).unwrap();
    assert_eq!((w, h), (6, 1));
    let mixed = ((0.299 * 10.0 + 0.587 * 200.0 + 0.114 * 90.0) as f64).round() as u8;
    assert_eq!(g, vec![76, 150, 29, 255, mixed, 0]);
    image::GrayImage::from_raw(3, 1, vec![7, 128, 254]).unwrap().save(dir.join("g.png")).unwrap();
    assert_eq!(scan::decode::read_grey(&dir.join("g.png")).unwrap().2, vec![7, 128, 254]);
    std::fs::write(dir.join("bad.png"), b"not a png").unwrap();
    let e = format!("{:#}", scan::decode::read_grey(&dir.join("bad.png")).unwrap_err());
    assert!(e.contains("bad.png") && e.matches("signature").count() <= 1, "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A capture in OpenCV's order (patterns, then white and black) gives no order warning; the same
/// frames with white and black first (as some capture tools save them) give one that says so, and
/// decode with `white_black_first` to the very same map (bit for bit), without a warning; read
/// in the wrong order, fewer than half the pixels decode.
#[test]
fn white_and_black_first_is_warned_and_decoded() {
    let p = PatternSet::new(64, 48, 1).unwrap();
    let c = ideal_capture(&p);
    assert!(c.order_warning(false).is_none());
    let mut frames = c.frames.clone();
    frames.rotate_right(2);
    let moved = scan::decode::Capture { width: c.width, height: c.height, frames };
    let w = moved.order_warning(false).expect("a warning");
    assert!(w.contains("white and black frames were taken to come last") && w.contains("darker") && w.contains("--white-black first"), "{w}");
    assert!(moved.order_warning(true).is_none());
    assert!(c.order_warning(true).is_some());
    let first = DecodeSettings { white_black_first: true, ..DecodeSettings::default() };
    let (want, want_stats) = decode(&c, &p, &DecodeSettings::default()).unwrap();
    let (got, got_stats) = decode(&moved, &p, &first).unwrap();
    assert_eq!(want_stats, got_stats);
    assert_eq!(want_stats.valid_pixels, 64 * 48);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
    assert_eq!((bits(&got.col), bits(&got.row), &got.white, &got.black), (bits(&want.col), bits(&want.row), &want.white, &want.black));
    let (wrong, _) = decode(&moved, &p, &DecodeSettings::default()).unwrap();
    assert!(wrong.valid_pixels() < 64 * 48 / 2, "{} valid pixels in the wrong order", wrong.valid_pixels());
}
