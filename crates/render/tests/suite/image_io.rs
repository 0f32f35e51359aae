//! Image I/O: round trips (PFM and EXR bit-exact, PNG within quantisation), the PFM row order,
//! and atomic writes that never destroy an existing file.

use std::path::PathBuf;

use render::image_io::{read_image, srgb_decode, srgb_encode, write_atomic, write_image, Image};

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lucent-image-io-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A deterministic pseudo-random image with awkward values: tiny, large, negative, denormal.
fn test_image(width: u32, height: u32) -> Image {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut img = Image::new(width, height);
    for p in img.rgb.iter_mut() {
        for c in p.iter_mut() {
            // Arbitrary bit patterns of finite floats (including negative and subnormal ones).
            let v = f32::from_bits((next() >> 32) as u32);
            *c = if v.is_finite() { v } else { 0.25 };
        }
    }
    img.rgb[0] = [1e-42, -0.0, 3.0e38];
    img
}

fn assert_bit_exact(a: &Image, b: &Image) {
    assert_eq!((a.width, a.height), (b.width, b.height));
    for (i, (p, q)) in a.rgb.iter().zip(&b.rgb).enumerate() {
        for c in 0..3 {
            assert_eq!(p[c].to_bits(), q[c].to_bits(), "pixel {i} channel {c}: {} vs {}", p[c], q[c]);
        }
    }
}

#[test]
fn pfm_round_trip_is_bit_exact() {
    let dir = temp_dir("pfm");
    let img = test_image(37, 23);
    let path = dir.join("a.pfm");
    write_image(&path, &img, 0.0).unwrap();
    assert_bit_exact(&img, &read_image(&path).unwrap());
    // Exposure is a display setting: it must not scale the linear formats.
    write_image(&path, &img, 3.0).unwrap();
    assert_bit_exact(&img, &read_image(&path).unwrap());
}

#[test]
fn exr_round_trip_is_bit_exact() {
    let dir = temp_dir("exr");
    let img = test_image(41, 19);
    let path = dir.join("a.exr");
    write_image(&path, &img, 0.0).unwrap();
    assert_bit_exact(&img, &read_image(&path).unwrap());
    // The file declares its primaries and white: sRGB / D65.
    let meta = exr::meta::MetaData::read_from_file(&path, false).unwrap();
    let chroma = meta.headers[0].shared_attributes.chromaticities.expect("chromaticities attribute");
    assert_eq!((chroma.red.0, chroma.red.1), (0.64, 0.33));
    assert_eq!((chroma.green.0, chroma.green.1), (0.30, 0.60));
    assert_eq!((chroma.blue.0, chroma.blue.1), (0.15, 0.06));
    assert_eq!((chroma.white.0, chroma.white.1), (0.3127, 0.3290));
}

#[test]
fn png_round_trip_within_quantisation() {
    let dir = temp_dir("png");
    let (w, h) = (64u32, 16u32);
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let t = (y * w + x) as f32 / (w * h - 1) as f32;
            img.set(x, y, [t, t * t, 1.0 - t]);
        }
    }
    let path = dir.join("a.png");
    write_image(&path, &img, 0.0).unwrap();
    let back = read_image(&path).unwrap();
    assert_eq!((back.width, back.height), (w, h));
    for (p, q) in img.rgb.iter().zip(&back.rgb) {
        for c in 0..3 {
            // Half a code value in the encoded domain.
            let e = srgb_encode(p[c] as f64);
            let err = (srgb_encode(q[c] as f64) - e).abs();
            assert!(err <= 0.5 / 255.0 + 1e-6, "{} -> {} (encoded error {err})", p[c], q[c]);
        }
    }
    // Exposure: +1 stop doubles the linear value before encoding; clamping at 1.
    let mut grey = Image::new(2, 1);
    grey.rgb = vec![[0.2, 0.2, 0.2], [0.7, 0.7, 0.7]];
    write_image(&path, &grey, 1.0).unwrap();
    let back = read_image(&path).unwrap();
    let expected = srgb_decode((srgb_encode(0.4) * 255.0).round() / 255.0) as f32;
    assert_eq!(back.rgb[0][0], expected);
    assert_eq!(back.rgb[1], [1.0, 1.0, 1.0]);
}

#[test]
fn png_16_bit_decodes_to_linear() {
    let dir = temp_dir("png16");
    let path = dir.join("b.png");
    // Encoded values 0, 1/3, 1 at 16 bits.
    let raw: Vec<u16> = vec![0, 21845, 65535, 65535, 0, 32768];
    let buf = image::ImageBuffer::<image::Rgb<u16>, _>::from_raw(2, 1, raw).unwrap();
    buf.save_with_format(&path, image::ImageFormat::Png).unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!(img.rgb[0][0], 0.0);
    assert!((img.rgb[0][1] as f64 - srgb_decode(21845.0 / 65535.0)).abs() < 1e-7);
    assert_eq!(img.rgb[0][2], 1.0);
    assert!((img.rgb[1][2] as f64 - srgb_decode(32768.0 / 65535.0)).abs() < 1e-7);
}

#[test]
fn jpeg_photographs_decode_to_linear_and_are_never_written() {
    let dir = temp_dir("jpeg");
    let path = dir.join("photo.JPG");
    // Flat 8 × 8 blocks of one grey level each: a JPEG's DC term carries them exactly.
    let (w, h) = (16u32, 8u32);
    let raw: Vec<u8> = (0..w * h).map(|i| if i % w < 8 { 40 } else { 200 }).collect();
    let buf = image::GrayImage::from_raw(w, h, raw).unwrap();
    let mut bytes = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 100).encode_image(&buf).unwrap();
    std::fs::write(&path, &bytes).unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!((img.width, img.height), (w, h));
    let reference = image::load_from_memory(&bytes).unwrap().to_rgb8();
    for (p, q) in img.rgb.iter().zip(reference.pixels()) {
        for c in 0..3 {
            assert_eq!(p[c], srgb_decode(q[c] as f64 / 255.0) as f32);
        }
    }
    assert!((img.rgb[0][0] as f64 - srgb_decode(40.0 / 255.0)).abs() < 2e-3, "{:?}", img.rgb[0]);
    assert!((img.rgb[15][0] as f64 - srgb_decode(200.0 / 255.0)).abs() < 2e-2, "{:?}", img.rgb[15]);
    // lucent writes no lossy format: the extension is refused before anything is written.
    let out = dir.join("out.jpg");
    assert!(write_image(&out, &img, 0.0).is_err());
    assert!(!out.exists());
    // A file of another kind names the extensions that are read.
    let e = read_image(&dir.join("x.tif")).unwrap_err().to_string();
    assert!(e.contains(".jpg") && e.contains("x.tif"), "{e}");
}

#[test]
fn pfm_rows_are_stored_bottom_to_top_little_endian() {
    let dir = temp_dir("pfm-rows");
    let (w, h) = (3u32, 4u32);
    let mut img = Image::new(w, h);
    for y in 0..h {
        for x in 0..w {
            // Value encodes the row (top row y = 0) and column.
            img.set(x, y, [y as f32, x as f32, 10.0 * y as f32 + x as f32]);
        }
    }
    let path = dir.join("rows.pfm");
    write_image(&path, &img, 0.0).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let header = b"PF\n3 4\n-1.0\n";
    assert_eq!(&bytes[..header.len()], header);
    let data = &bytes[header.len()..];
    assert_eq!(data.len(), (w * h * 3 * 4) as usize);
    let f = |i: usize| f32::from_le_bytes([data[4 * i], data[4 * i + 1], data[4 * i + 2], data[4 * i + 3]]);
    // The first stored row is the bottom row of the image (y = h - 1).
    for file_row in 0..h as usize {
        let y = (h as usize - 1 - file_row) as f32;
        for x in 0..w as usize {
            let i = (file_row * w as usize + x) * 3;
            assert_eq!([f(i), f(i + 1), f(i + 2)], [y, x as f32, 10.0 * y + x as f32]);
        }
    }
}

#[test]
fn pfm_big_endian_and_grey_are_read() {
    let dir = temp_dir("pfm-be");
    let path = dir.join("be.pfm");
    // 2×2, big-endian (positive scale), rows bottom to top.
    let mut bytes = b"PF\n2 2\n1.0\n".to_vec();
    let bottom = [[1.0f32, 2.0, 3.0], [4.0, 5.0, 6.0]];
    let top = [[7.0f32, 8.0, 9.0], [10.0, 11.0, 12.0]];
    for p in bottom.iter().chain(top.iter()) {
        for c in p {
            bytes.extend_from_slice(&c.to_be_bytes());
        }
    }
    std::fs::write(&path, &bytes).unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!(img.rgb, vec![top[0], top[1], bottom[0], bottom[1]]);

    let grey = dir.join("grey.pfm");
    let mut bytes = b"Pf\n1 2\n-1.0\n".to_vec();
    bytes.extend_from_slice(&0.5f32.to_le_bytes()); // bottom
    bytes.extend_from_slice(&2.0f32.to_le_bytes()); // top
    std::fs::write(&grey, &bytes).unwrap();
    let img = read_image(&grey).unwrap();
    assert_eq!(img.rgb, vec![[2.0; 3], [0.5; 3]]);
}

#[test]
fn malformed_inputs_give_errors_naming_the_file() {
    let dir = temp_dir("bad");
    let truncated = dir.join("short.pfm");
    std::fs::write(&truncated, b"PF\n4 4\n-1.0\n\0\0\0\0").unwrap();
    let e = format!("{:#}", read_image(&truncated).unwrap_err());
    assert!(e.contains("short.pfm") && e.contains("truncated"), "{e}");

    let missing = dir.join("missing.exr");
    let e = format!("{:#}", read_image(&missing).unwrap_err());
    assert!(e.contains("missing.exr"), "{e}");

    let unknown = dir.join("picture.tiff");
    let e = format!("{:#}", write_image(&unknown, &Image::new(1, 1), 0.0).unwrap_err());
    assert!(e.contains("picture.tiff") && e.contains("extension"), "{e}");
    assert!(!unknown.exists());

    let not_png = dir.join("text.png");
    std::fs::write(&not_png, b"hello").unwrap();
    let e = format!("{:#}", read_image(&not_png).unwrap_err());
    assert!(e.contains("text.png"), "{e}");
}

#[test]
fn atomic_write_keeps_existing_file_when_writer_fails() {
    let dir = temp_dir("atomic");
    let path = dir.join("keep.png");
    let original = Image { width: 2, height: 1, rgb: vec![[0.5, 0.25, 1.0], [0.0, 1.0, 0.0]] };
    write_image(&path, &original, 0.0).unwrap();
    let before = std::fs::read(&path).unwrap();

    // A writer that produces part of a file, then fails.
    let err = write_atomic(&path, |tmp| {
        std::fs::write(tmp, b"partial garbage")?;
        anyhow::bail!("simulated failure")
    })
    .unwrap_err();
    assert!(format!("{err:#}").contains("simulated failure"));
    assert_eq!(std::fs::read(&path).unwrap(), before, "existing file was modified");
    // No temporary file is left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // An image with inconsistent dimensions fails before touching the file.
    let bad = Image { width: 3, height: 3, rgb: vec![[0.0; 3]; 2] };
    assert!(write_image(&path, &bad, 0.0).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), before);

    // A successful write replaces it, via the temporary name in the same directory.
    let mut seen_tmp = None;
    write_atomic(&path, |tmp| {
        seen_tmp = Some(tmp.to_path_buf());
        std::fs::write(tmp, b"new")?;
        Ok(())
    })
    .unwrap();
    let tmp = seen_tmp.unwrap();
    assert_eq!(tmp.parent(), path.parent());
    assert_eq!(tmp.file_name().unwrap().to_string_lossy(), format!("keep.png.tmp-{}", std::process::id()));
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
    assert!(!tmp.exists());
}

#[test]
fn exr_half_float_and_alpha_are_read() {
    use exr::prelude::*;
    let dir = temp_dir("exr-half");
    let path = dir.join("half.exr");
    // Half-float RGBA written by another tool's typical settings; values exactly representable.
    let values = [0.5f32, 0.25, 2.0, 1024.0, 0.0, 0.125];
    write_rgba_file(&path, 3, 2, |x, y| {
        let v = values[y * 3 + x];
        (f16::from_f32(v), f16::from_f32(v * 2.0), f16::from_f32(v / 4.0), f16::from_f32(1.0))
    })
    .unwrap();
    let img = read_image(&path).unwrap();
    assert_eq!((img.width, img.height), (3, 2));
    for y in 0..2 {
        for x in 0..3 {
            let v = values[(y * 3 + x) as usize];
            assert_eq!(img.get(x, y), [v, v * 2.0, v / 4.0]);
        }
    }
}
