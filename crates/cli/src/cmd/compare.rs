//! `lucent compare RENDER PHOTO [--mask MASK.png] [--out ERROR.png] [--color-correct [matrix|affine]]
//! [--saturation LEVEL] [--json]`: pixelwise comparison of a render with a photograph
//! (`analysis::compare`; docs/inverse.md).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use analysis::compare::{compare_with, error_image, ColorFitOptions, ColorModel, Mask, Metrics, DEFAULT_SATURATION};
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
    /// Fit a colour transform render → photo in linear RGB (robust: saturated pixels left out,
    /// outliers down-weighted) and apply it before the metrics: `matrix` (3×3, the default when the
    /// flag is given bare) or `affine` (3×3 and an offset).
    #[arg(long, value_name = "MODEL", num_args = 0..=1, default_missing_value = "matrix", value_parser = parse_model)]
    pub color_correct: Option<ColorModel>,
    /// Pixels with a channel at or above this linear level in either image are left out of the
    /// colour fit (clipped); `inf` keeps every pixel.
    #[arg(long, default_value_t = DEFAULT_SATURATION, value_name = "LEVEL")]
    pub saturation: f64,
    /// Print the metrics as JSON on stdout (keys rmse, rel_mse, psnr_db, ssim, delta_e2000_mean,
    /// pixels; with a colour correction also color_matrix, color_model, color_offset,
    /// color_residual_rms, color_robust_sigma, color_pixels_used, color_pixels_saturated,
    /// color_pixels_nonfinite, color_pixels_downweighted, color_iterations).
    #[arg(long)]
    pub json: bool,
    /// ΔE2000 shown at the top (yellow) of the error image's colour map.
    #[arg(long, default_value_t = 10.0, value_name = "DELTA_E")]
    pub error_scale: f64,
}

fn parse_model(s: &str) -> Result<ColorModel, String> {
    ColorModel::from_name(s).ok_or_else(|| {
        let names: Vec<_> = ColorModel::ALL.iter().map(|m| m.name()).collect();
        format!("unknown colour model `{s}` (expected {})", names.join(" or "))
    })
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
    if let Some(f) = &m.color_fit {
        v["color_model"] = serde_json::json!(f.model.name());
        v["color_offset"] = serde_json::json!(f.offset);
        v["color_residual_rms"] = serde_json::json!(f.rms_residual);
        v["color_robust_sigma"] = serde_json::json!(f.robust_sigma);
        v["color_pixels_used"] = serde_json::json!(f.pixels_used);
        v["color_pixels_saturated"] = serde_json::json!(f.excluded_saturated);
        v["color_pixels_nonfinite"] = serde_json::json!(f.excluded_nonfinite);
        v["color_pixels_downweighted"] = serde_json::json!(f.downweighted);
        v["color_iterations"] = serde_json::json!(f.iterations);
    }
    v
}

/// Runs `lucent compare`.
pub fn run(args: Args) -> Result<()> {
    if !(args.error_scale.is_finite() && args.error_scale > 0.0) {
        bail!("--error-scale must be a positive number, got {}", args.error_scale);
    }
    if !(args.saturation > 0.0) {
        bail!("--saturation must be a positive level (or inf), got {}", args.saturation);
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
    let color = args.color_correct.map(|model| ColorFitOptions { model, saturation: args.saturation });
    let comparison = compare_with(&render, &photo, mask.as_ref(), color.as_ref())
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
        if let Some(f) = &m.color_fit {
            let (cm, o) = (f.matrix, f.offset);
            let affine = f.model == ColorModel::Affine;
            for (r, row) in cm.iter().enumerate() {
                let label = if r == 0 { "colour matrix" } else { "" };
                let offset = if affine { format!(" + {:.6}", o[r]) } else { String::new() };
                println!("{label:<18}[{:.5}, {:.5}, {:.5}]{offset}", row[0], row[1], row[2]);
            }
            println!("colour fit        {} (robust, linear RGB), residual RMS {:.6}, σ {:.6}", f.model.name(), f.rms_residual, f.robust_sigma);
            println!(
                "                  {} pixels used, {} saturated (≥ {}) and {} non-finite left out, {} down-weighted, {} iterations",
                f.pixels_used, f.excluded_saturated, args.saturation, f.excluded_nonfinite, f.downweighted, f.iterations
            );
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
    use analysis::compare::compare;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn parse(argv: &[&str]) -> Result<Args, clap::Error> {
        Cli::try_parse_from(std::iter::once("compare").chain(argv.iter().copied())).map(|c| c.args)
    }

    #[test]
    fn color_correct_flag_takes_an_optional_model() {
        assert_eq!(parse(&["r.exr", "p.exr"]).unwrap().color_correct, None);
        assert_eq!(parse(&["r.exr", "p.exr", "--color-correct"]).unwrap().color_correct, Some(ColorModel::Matrix));
        let a = parse(&["r.exr", "p.exr", "--color-correct", "--json"]).unwrap();
        assert_eq!((a.color_correct, a.json), (Some(ColorModel::Matrix), true));
        assert_eq!(parse(&["r.exr", "p.exr", "--color-correct", "matrix"]).unwrap().color_correct, Some(ColorModel::Matrix));
        assert_eq!(parse(&["r.exr", "p.exr", "--color-correct", "affine"]).unwrap().color_correct, Some(ColorModel::Affine));
        assert_eq!(parse(&["r.exr", "p.exr", "--color-correct=affine"]).unwrap().color_correct, Some(ColorModel::Affine));
        let e = parse(&["r.exr", "p.exr", "--color-correct", "cubic"]).err().unwrap().to_string();
        assert!(e.contains("cubic") && e.contains("affine"), "{e}");
        assert_eq!(parse(&["r.exr", "p.exr"]).unwrap().saturation, DEFAULT_SATURATION);
        assert!(parse(&["r.exr", "p.exr", "--saturation", "inf"]).unwrap().saturation.is_infinite());
    }

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
            color_correct: None,
            saturation: DEFAULT_SATURATION,
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
        assert_eq!(v["color_model"], "matrix");
        assert_eq!(v["color_offset"], serde_json::json!([0.0, 0.0, 0.0]));
        for k in ["color_residual_rms", "color_robust_sigma"] {
            assert!(v[k].as_f64().is_some_and(|x| x >= 0.0), "{k}: {v}");
        }
        for k in ["color_pixels_used", "color_pixels_saturated", "color_pixels_nonfinite", "color_pixels_downweighted", "color_iterations"] {
            assert!(v[k].is_u64(), "{k}: {v}");
        }
        assert_eq!(v["color_pixels_used"].as_u64().unwrap() + v["color_pixels_saturated"].as_u64().unwrap(), 16);
    }

    #[test]
    fn affine_correction_and_fit_report_through_the_command() {
        let d = dir("affine");
        let mut rgb = Vec::new();
        for i in 0..64u32 {
            rgb.push([(i % 8) as f32 / 9.0, (i / 8) as f32 / 9.0, ((i * 5) % 7) as f32 / 8.0]);
        }
        let render = Image { width: 8, height: 8, rgb };
        let photo = analysis::compare::apply_color_transform(&render, &[[0.8, 0.1, 0.0], [0.0, 0.7, 0.1], [0.05, 0.0, 0.6]], &[0.02, 0.01, 0.03]);
        let (r, p) = (d.join("render.pfm"), d.join("photo.pfm"));
        write_image(&r, &render, 0.0).unwrap();
        write_image(&p, &photo, 0.0).unwrap();
        let mut a = args(&r, &p);
        a.color_correct = Some(ColorModel::Affine);
        run(a).unwrap();
        let mut a = args(&r, &p);
        a.saturation = -1.0;
        a.color_correct = Some(ColorModel::Matrix);
        assert!(format!("{:#}", run(a).unwrap_err()).contains("--saturation"));
    }
}
