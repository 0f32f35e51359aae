//! `lucent compare RENDER PHOTO [--mask MASK.png] [--out ERROR.png] [--color-correct] [--json]`:
//! pixelwise comparison of a render with a photograph (`analysis::compare`; docs/inverse.md).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use analysis::compare::{compare, error_image, Mask, Metrics};
use render::image_io::{read_image, write_image, Image};

/// Arguments of `lucent compare`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The render (PNG, EXR or PFM; linear sRGB primaries, PNG decoded with the sRGB curve).
    pub render: PathBuf,
    /// The reference photograph, same size (PNG, EXR or PFM).
    pub photo: PathBuf,
    /// Only pixels where this image is white (mean channel > 0.5) are compared.
    #[arg(long, value_name = "MASK.png")]
    pub mask: Option<PathBuf>,
    /// Write the false-colour per-pixel ΔE2000 image here (.png, .exr or .pfm).
    #[arg(long, value_name = "ERROR.png")]
    pub out: Option<PathBuf>,
    /// Fit a 3×3 colour matrix (least squares, render → photo) and apply it before the metrics.
    #[arg(long)]
    pub color_correct: bool,
    /// Print the metrics as JSON on stdout (keys rmse, rel_mse, psnr_db, ssim, delta_e2000_mean, color_matrix).
    #[arg(long)]
    pub json: bool,
    /// ΔE2000 shown at the top (yellow) of the error image's colour map.
    #[arg(long, default_value_t = 10.0, value_name = "DELTA_E")]
    pub error_scale: f64,
}

fn size(img: &Image) -> String {
    format!("{}×{}", img.width, img.height)
}

fn check_finite(img: &Image, path: &Path) -> Result<()> {
    if let Some(i) = img.rgb.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        let w = img.width.max(1) as usize;
        bail!("{}: non-finite value (NaN or infinity) at pixel ({}, {})", path.display(), i % w, i / w);
    }
    Ok(())
}

/// Metrics as the JSON object of `--json` (PSNR of identical images, +∞, is written as null).
pub fn metrics_json(m: &Metrics) -> serde_json::Value {
    let mut v = serde_json::json!({
        "rmse": m.rmse,
        "rel_mse": m.rel_mse,
        "psnr_db": if m.psnr_db.is_finite() { serde_json::json!(m.psnr_db) } else { serde_json::Value::Null },
        "ssim": m.ssim,
        "delta_e2000_mean": m.delta_e2000_mean,
        "pixels": m.pixels,
    });
    if let Some(cm) = m.color_matrix {
        v["color_matrix"] = serde_json::json!(cm);
    }
    v
}

/// Runs `lucent compare`.
pub fn run(args: Args) -> Result<()> {
    if !(args.error_scale.is_finite() && args.error_scale > 0.0) {
        bail!("--error-scale must be a positive number, got {}", args.error_scale);
    }
    if let Some(out) = &args.out {
        // Fail on a bad output name before the work.
        render::image_io::Format::from_path(out).context("--out")?;
    }
    let render = read_image(&args.render)?;
    let photo = read_image(&args.photo)?;
    if (render.width, render.height) != (photo.width, photo.height) {
        bail!(
            "{}: image is {} but the render {} is {}",
            args.photo.display(),
            size(&photo),
            args.render.display(),
            size(&render)
        );
    }
    check_finite(&render, &args.render)?;
    check_finite(&photo, &args.photo)?;
    let mask = match &args.mask {
        Some(path) => {
            let img = read_image(path)?;
            if (img.width, img.height) != (photo.width, photo.height) {
                bail!("{}: mask is {} but the images are {}", path.display(), size(&img), size(&photo));
            }
            let mask = Mask::from_image(&img);
            if mask.count() == 0 {
                bail!("{}: the mask selects no pixels (none has mean channel > 0.5)", path.display());
            }
            Some(mask)
        }
        None => None,
    };
    let comparison = compare(&render, &photo, mask.as_ref(), args.color_correct)
        .with_context(|| format!("comparing {} with {}", args.render.display(), args.photo.display()))?;
    let m = &comparison.metrics;

    if args.json {
        println!("{}", serde_json::to_string_pretty(&metrics_json(m))?);
    } else {
        println!("pixels compared   {}", m.pixels);
        println!("RMSE              {:.6}", m.rmse);
        println!("relative MSE      {:.6}", m.rel_mse);
        if m.psnr_db.is_finite() {
            println!("PSNR              {:.3} dB (peak 1)", m.psnr_db);
        } else {
            println!("PSNR              ∞ (identical)");
        }
        println!("SSIM              {:.6}", m.ssim);
        println!("mean ΔE2000       {:.4}", m.delta_e2000_mean);
        if let Some(cm) = m.color_matrix {
            println!("colour matrix     [{:.5}, {:.5}, {:.5}]", cm[0][0], cm[0][1], cm[0][2]);
            println!("                  [{:.5}, {:.5}, {:.5}]", cm[1][0], cm[1][1], cm[1][2]);
            println!("                  [{:.5}, {:.5}, {:.5}]", cm[2][0], cm[2][1], cm[2][2]);
        }
    }
    if let Some(out) = &args.out {
        write_image(out, &error_image(&comparison, args.error_scale), 0.0)?;
        let note = format!("wrote {} (ΔE2000 0 → {} mapped dark violet → yellow)", out.display(), args.error_scale);
        if args.json {
            eprintln!("{note}");
        } else {
            println!("{note}");
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("lucent-cmd-compare-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn args(render: &Path, photo: &Path) -> Args {
        Args {
            render: render.into(),
            photo: photo.into(),
            mask: None,
            out: None,
            color_correct: false,
            json: true,
            error_scale: 10.0,
        }
    }

    fn grey(w: u32, h: u32, v: f32) -> Image {
        Image { width: w, height: h, rgb: vec![[v; 3]; (w * h) as usize] }
    }

    #[test]
    fn writes_error_image_and_names_bad_files() {
        let d = dir("cli");
        let (r, p) = (d.join("render.exr"), d.join("photo.pfm"));
        write_image(&r, &grey(6, 4, 0.5), 0.0).unwrap();
        write_image(&p, &grey(6, 4, 0.4), 0.0).unwrap();
        let out = d.join("err.png");
        let mut a = args(&r, &p);
        a.out = Some(out.clone());
        run(a).unwrap();
        let e = read_image(&out).unwrap();
        assert_eq!((e.width, e.height), (6, 4));

        // Photo of another size: the error names the photo.
        let p2 = d.join("small.pfm");
        write_image(&p2, &grey(5, 4, 0.4), 0.0).unwrap();
        let msg = format!("{:#}", run(args(&r, &p2)).unwrap_err());
        assert!(msg.contains("small.pfm") && msg.contains("5×4"), "{msg}");

        // Missing file.
        let msg = format!("{:#}", run(args(&d.join("nope.exr"), &p)).unwrap_err());
        assert!(msg.contains("nope.exr"), "{msg}");

        // Mask of another size.
        let m = d.join("mask.png");
        write_image(&m, &grey(3, 3, 1.0), 0.0).unwrap();
        let mut a = args(&r, &p);
        a.mask = Some(m);
        let msg = format!("{:#}", run(a).unwrap_err());
        assert!(msg.contains("mask.png") && msg.contains("3×3"), "{msg}");

        // NaN in the render.
        let mut bad = grey(6, 4, 0.5);
        bad.rgb[7][0] = f32::NAN;
        let rn = d.join("nan.pfm");
        write_image(&rn, &bad, 0.0).unwrap();
        let msg = format!("{:#}", run(args(&rn, &p)).unwrap_err());
        assert!(msg.contains("nan.pfm") && msg.contains("(1, 1)"), "{msg}");
    }

    #[test]
    fn json_has_the_contract_keys() {
        let photo = grey(4, 4, 0.3);
        let mut render = photo.clone();
        render.rgb[0] = [0.6, 0.2, 0.1];
        let c = compare(&render, &photo, None, false).unwrap();
        let v = metrics_json(&c.metrics);
        for k in ["rmse", "rel_mse", "psnr_db", "ssim", "delta_e2000_mean"] {
            assert!(v[k].is_number(), "{k}: {v}");
        }
        assert!(v.get("color_matrix").is_none());
        let mut rgb = Vec::new();
        for i in 0..16 {
            rgb.push([(i % 4) as f32 / 4.0, (i / 4) as f32 / 4.0, ((i * 7) % 5) as f32 / 5.0]);
        }
        let r = Image { width: 4, height: 4, rgb };
        let c = compare(&r, &photo, None, true).unwrap();
        let v = metrics_json(&c.metrics);
        let cm = v["color_matrix"].as_array().unwrap();
        assert_eq!(cm.len(), 3);
        assert!(cm.iter().all(|row| row.as_array().unwrap().len() == 3));
    }
}
