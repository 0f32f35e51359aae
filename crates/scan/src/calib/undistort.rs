//! Image undistortion as OpenCV's `undistort` (`initUndistortRectifyMap` with the calibration's
//! own camera matrix as the new one, then `remap` with bilinear interpolation and a constant black
//! border): each pixel of the output, a pinhole image with the same fx, fy, cx, cy, takes the
//! value of the photograph where the lens model puts the same ray.
//!
//! Pixel (u, v) of the output is the ray (x, y) = ((u − cx)/fx, (v − cy)/fy); the lens maps it to
//! the photograph's pixel (fx·x_d + cx, fy·y_d + cy) with (x_d, y_d) = distort(x, y) (OpenCV's
//! model, `render::camera::Distortion::distort`), where the four neighbouring pixels are blended
//! bilinearly, a neighbour outside the photograph counting as 0, as OpenCV's constant border does.
//! The values are interpolated as they are stored (8-bit codes), as OpenCV does; OpenCV quantises
//! the interpolation weights to 1/32 of a pixel, lucent does not, so the two differ by about a
//! code at steep edges.

use render::camera::{Distortion, Intrinsics};

/// For each output pixel (row-major), the photograph's pixel its ray comes from: the output is a
/// pinhole camera with the intrinsics `out` (OpenCV's `newCameraMatrix`; `k` itself by default),
/// the photograph's camera has `k` and `d`.
pub fn undistort_map(k: &Intrinsics, d: &Distortion, out: &Intrinsics, width: usize, height: usize) -> Vec<[f64; 2]> {
    let mut map = Vec::with_capacity(width * height);
    for v in 0..height {
        let y = (v as f64 - out.cy) / out.fy;
        for u in 0..width {
            let x = (u as f64 - out.cx) / out.fx;
            let (xd, yd) = d.distort(x, y);
            map.push([k.fx * xd + k.cx, k.fy * yd + k.cy]);
        }
    }
    map
}

/// `src` (row-major, `channels` interleaved 8-bit values per pixel, `width` × `height`) sampled at
/// `map` bilinearly with a black border, rounded to the nearest code.
pub fn remap_bilinear(src: &[u8], channels: usize, width: usize, height: usize, map: &[[f64; 2]]) -> Vec<u8> {
    let mut out = vec![0u8; map.len() * channels];
    let at = |x: i64, y: i64, c: usize| -> f64 {
        if x < 0 || y < 0 || x >= width as i64 || y >= height as i64 {
            0.0
        } else {
            src[(y as usize * width + x as usize) * channels + c] as f64
        }
    };
    for (i, &[sx, sy]) in map.iter().enumerate() {
        if !(sx.is_finite() && sy.is_finite()) || sx <= -1.0 || sy <= -1.0 || sx >= width as f64 || sy >= height as f64 {
            continue;
        }
        let (x0, y0) = (sx.floor(), sy.floor());
        let (ax, ay) = (sx - x0, sy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        for c in 0..channels {
            let top = (1.0 - ax) * at(x0, y0, c) + ax * at(x0 + 1, y0, c);
            let bottom = (1.0 - ax) * at(x0, y0 + 1, c) + ax * at(x0 + 1, y0 + 1, c);
            out[i * channels + c] = ((1.0 - ay) * top + ay * bottom).round().clamp(0.0, 255.0) as u8;
        }
    }
    out
}

/// `photo` (PNG or JPEG, 8-bit grey or colour) undistorted ([`undistort_map`] with `out` = `k`,
/// [`remap_bilinear`]) and written to `out_png` as PNG of the same kind (temporary name, then
/// renamed). `size`, when the calibration gives it, must be the photograph's (pixels). Errors are
/// one line naming the file.
pub fn undistort_photo(photo: &std::path::Path, k: &Intrinsics, d: &Distortion, size: Option<(u32, u32)>, out_png: &std::path::Path) -> anyhow::Result<()> {
    remap_photo(photo, size, out_png, |w, h| Ok(undistort_map(k, d, k, w, h)))
}

/// `photo` (PNG, JPEG, …; 8-bit grey or colour) remapped through `map(width, height)` (one
/// source pixel per output pixel, row-major; [`remap_bilinear`]) and written to `out_png` as PNG
/// of the same kind and size (temporary name, then renamed). `size`, when the calibration gives
/// it, must be the photograph's (pixels). Errors are one line naming the file.
pub fn remap_photo(photo: &std::path::Path, size: Option<(u32, u32)>, out_png: &std::path::Path, map: impl FnOnce(usize, usize) -> anyhow::Result<Vec<[f64; 2]>>) -> anyhow::Result<()> {
    use anyhow::{anyhow, bail, Context};
    let img = image::open(photo).map_err(|e| anyhow!("{}: cannot read the image ({e})", photo.display()))?;
    let (w, h) = (img.width(), img.height());
    if let Some((cw, ch)) = size {
        if (cw, ch) != (w, h) {
            bail!("{}: {w}x{h} pixels, but the camera was calibrated at {cw}x{ch}", photo.display());
        }
    }
    let grey = matches!(img.color(), image::ColorType::L8 | image::ColorType::L16 | image::ColorType::La8 | image::ColorType::La16);
    let (data, channels, kind) = if grey { (img.into_luma8().into_raw(), 1, image::ExtendedColorType::L8) } else { (img.into_rgb8().into_raw(), 3, image::ExtendedColorType::Rgb8) };
    let map = map(w as usize, h as usize).with_context(|| photo.display().to_string())?;
    let out = remap_bilinear(&data, channels, w as usize, h as usize, &map);
    render::image_io::write_atomic(out_png, |tmp| image::save_buffer_with_format(tmp, &out, w, h, kind, image::ImageFormat::Png).with_context(|| format!("writing {}", out_png.display())))
}
