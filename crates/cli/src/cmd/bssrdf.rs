//! `lucent bssrdf`: total diffuse reflectance and radial profiles of the dipole BSSRDF models.

use super::format::sig;
use super::mie::finite_f64;
use anyhow::{bail, Context, Result};
use optics::bssrdf::{
    find_medium, jensen2001_media, narasimhan2006_media, DipoleModel, DirectionalDipole,
    DirectionalLineDipole, OpticalProperties, StandardDipole,
};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Dipole model: `standard` (Jensen et al. 2001), `directional` (Frisvad et al. 2014, as
    /// published) or `directional-corrected` (our variant: the same theory with the refracted
    /// ray integrated as a line of sources, `optics::bssrdf::DirectionalLineDipole`).
    #[arg(long, default_value = "standard")]
    model: String,
    /// Relative index of refraction η = n_medium / n_outside.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    eta: Option<f64>,
    /// Scattering coefficient σ_s in mm⁻¹.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    sigma_s_per_mm: Option<f64>,
    /// Absorption coefficient σ_a in mm⁻¹.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    sigma_a_per_mm: Option<f64>,
    /// Henyey–Greenstein asymmetry parameter g (default 0, or the preset's).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    g: Option<f64>,
    /// A measured medium (Jensen 2001 or Narasimhan 2006, e.g. "Apple", "Regular Milk") giving
    /// η, σ_s, σ_a and g for `--channel`; explicit flags override it.
    #[arg(long)]
    preset: Option<String>,
    /// Colour channel of the preset: r, g or b.
    #[arg(long, default_value = "r")]
    channel: String,
    /// Milk by content declaration: σ_s, σ_a and g from the Lorenz–Mie model of `optics::milk` at
    /// `--wavelength-nm` (η defaults to the host's real index there); explicit flags override them.
    #[arg(long)]
    milk: bool,
    /// Milk: fat content in weight percent.
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    fat_percent: Option<f64>,
    /// Milk: protein content in weight percent (default 3.4).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    protein_percent: Option<f64>,
    /// Milk: homogenization pressure in MPa (default 20; 0 = unhomogenized).
    #[arg(long, allow_hyphen_values = true, value_parser = finite_f64)]
    pressure_mpa: Option<f64>,
    /// Milk: vacuum wavelength in nm.
    #[arg(long = "wavelength-nm", alias = "lambda-nm", allow_hyphen_values = true, value_parser = finite_f64)]
    wavelength_nm: Option<f64>,
    /// List the preset media and exit.
    #[arg(long)]
    list_presets: bool,
    /// Print the total diffuse reflectance `rd` = π∫S_d dA of a flat half-space under normal
    /// incidence (without T12, T21), and the standard dipole's closed form `rd_closed_form`.
    #[arg(long)]
    rd: bool,
    /// Distances in mm (comma-separated) at which to print the profile R_d(r) = π S_d(r) in mm⁻².
    #[arg(long, value_name = "R1,R2,...", allow_hyphen_values = true)]
    profile_mm: Option<String>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// Largest distance of `--profile-mm` (1000 km): far beyond any measurable profile, and small
/// enough that r³ in the dipole formulas stays finite.
const MAX_PROFILE_MM: f64 = 1e9;

fn parse_list(text: &str, field: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            let v: f64 = s
                .parse()
                .map_err(|_| anyhow::anyhow!("{field}: '{s}' is not a number"))?;
            if !v.is_finite() || v < 0.0 {
                bail!("{field}: distance {s} must be finite and ≥ 0");
            }
            if v > MAX_PROFILE_MM {
                bail!("{field}: distance {s} is above the supported {MAX_PROFILE_MM:e} mm");
            }
            Ok(v)
        })
        .collect()
}

pub fn run(args: Args) -> Result<()> {
    if args.list_presets {
        for m in jensen2001_media().iter().chain(narasimhan2006_media()) {
            println!("{:<28} {}", m.name, m.source);
        }
        return Ok(());
    }
    let o = compute(&args)?;
    if args.json {
        println!("{}", serde_json::Value::Object(o));
    } else {
        let num = |k: &str| o.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
        let q = |k: &str| sig(num(k), 6);
        println!(
            "{} dipole: eta {}, sigma_s {} mm⁻¹, sigma_a {} mm⁻¹, g {}; alpha' {}, sigma_tr {} mm⁻¹, D {} mm, A {}",
            args.model,
            q("eta"),
            q("sigma_s_per_mm"),
            q("sigma_a_per_mm"),
            q("g"),
            q("alpha_prime"),
            q("sigma_tr_per_mm"),
            q("d_mm"),
            q("a")
        );
        if o.contains_key("rd") {
            println!("rd (numerical, pi * integral of S_d over the plane) = {}", q("rd"));
            println!("rd_closed_form (standard dipole)                   = {}", q("rd_closed_form"));
        }
        if let (Some(rs), Some(p)) = (o.get("profile_mm"), o.get("profile")) {
            println!("r_mm,rd_per_mm2");
            for (r, v) in rs
                .as_array()
                .into_iter()
                .flatten()
                .zip(p.as_array().into_iter().flatten())
            {
                println!("{},{}", sig(r.as_f64().unwrap_or(f64::NAN), 9), sig(v.as_f64().unwrap_or(f64::NAN), 9));
            }
        }
    }
    Ok(())
}

/// Evaluates the model; returns the JSON object (keys: model, eta, sigma_s_per_mm, sigma_a_per_mm,
/// g, alpha_prime, sigma_tr_per_mm, d_mm, a, rd, rd_closed_form, profile_mm, profile).
fn compute(args: &Args) -> Result<serde_json::Map<String, serde_json::Value>> {
    let model: DipoleModel = args.model.parse().context("--model")?;
    let (mut eta, mut sigma_s, mut sigma_a, mut g) = (None, None, None, None);
    if let Some(name) = &args.preset {
        let m = find_medium(name)
            .with_context(|| format!("--preset: unknown medium '{name}' (see --list-presets)"))?;
        let c = match args.channel.as_str() {
            "r" => 0,
            "g" => 1,
            "b" => 2,
            other => bail!("--channel: '{other}' is not one of r, g, b"),
        };
        eta = Some(m.eta);
        sigma_s = Some(m.sigma_s_per_m[c] * 1e-3);
        sigma_a = Some(m.sigma_a_per_m[c] * 1e-3);
        g = Some(m.g[c]);
    }
    if args.milk {
        if args.preset.is_some() {
            bail!("--milk and --preset exclude each other");
        }
        let fat = args
            .fat_percent
            .context("--fat-percent is required with --milk")?;
        let protein = args
            .protein_percent
            .unwrap_or(optics::milk::DEFAULT_PROTEIN_PERCENT);
        let pressure = args.pressure_mpa.unwrap_or(20.0);
        let lambda = args
            .wavelength_nm
            .context("--wavelength-nm is required with --milk")?;
        if !(lambda.is_finite() && lambda > 0.0) {
            bail!("--wavelength-nm must be a positive wavelength, got {}", optics::numfmt::short(lambda));
        }
        optics::milk::check_wavelengths(&[lambda]).context("--wavelength-nm")?;
        optics::milk::validate(fat, protein, pressure)?;
        let bulk = optics::milk::milk_properties_with(
            fat,
            protein,
            pressure,
            &[lambda],
            &optics::media::BulkOptions { phase_angles: 0 },
        )
        .context("--milk")?;
        let host = optics::milk::host_index(&optics::milk::inputs()?).eval(lambda);
        eta = Some(host.re);
        sigma_s = Some(bulk.sigma_s_per_m[0] * 1e-3);
        sigma_a = Some(bulk.sigma_a_per_m[0] * 1e-3);
        g = Some(bulk.g[0]);
    } else if args.fat_percent.is_some()
        || args.protein_percent.is_some()
        || args.pressure_mpa.is_some()
    {
        bail!("--fat-percent, --protein-percent and --pressure-mpa apply with --milk only");
    }
    let eta = args
        .eta
        .or(eta)
        .context("--eta is required (or give --preset)")?;
    let sigma_s = args
        .sigma_s_per_mm
        .or(sigma_s)
        .context("--sigma-s-per-mm is required (or give --preset)")?;
    let sigma_a = args
        .sigma_a_per_mm
        .or(sigma_a)
        .context("--sigma-a-per-mm is required (or give --preset)")?;
    let g = args.g.or(g).unwrap_or(0.0);
    let props = OpticalProperties {
        eta,
        sigma_s_per_m: sigma_s * 1e3,
        sigma_a_per_m: sigma_a * 1e3,
        g,
    };
    let derived = props
        .derive()
        .context("invalid medium (--eta, --sigma-s-per-mm, --sigma-a-per-mm, --g)")?;
    let profile_mm = match &args.profile_mm {
        Some(t) => {
            let r = parse_list(t, "--profile-mm")?;
            if r.is_empty() {
                bail!("--profile-mm: no distances given (a comma-separated list in mm)");
            }
            Some(r)
        }
        None => None,
    };
    let want_rd = args.rd || profile_mm.is_none();

    let standard = StandardDipole::new(&props)?;
    let directional = DirectionalDipole::new(&props)?;
    let line = DirectionalLineDipole::new(&props)?;
    let profile_fn = |r_mm: f64| -> f64 {
        let r_m = r_mm * 1e-3;
        1e-6 * match model {
            DipoleModel::Standard => standard.rd_profile(r_m),
            DipoleModel::Directional => directional.rd_profile(r_m),
            DipoleModel::DirectionalCorrected => line.rd_profile(r_m),
        }
    };
    let rd_closed = standard.rd_closed_form();
    let rd = if want_rd {
        match model {
            DipoleModel::Standard => standard.rd_numerical(),
            DipoleModel::Directional => directional.rd_numerical(),
            DipoleModel::DirectionalCorrected => line.rd_numerical(),
        }
    } else {
        f64::NAN
    };
    let profile: Option<Vec<f64>> = profile_mm
        .as_ref()
        .map(|rs| rs.iter().map(|&r| profile_fn(r)).collect());
    let a = match model {
        DipoleModel::Standard => standard.a,
        DipoleModel::Directional | DipoleModel::DirectionalCorrected => directional.a,
    };

    let mut o = serde_json::Map::new();
    o.insert("model".into(), args.model.clone().into());
    o.insert("eta".into(), eta.into());
    o.insert("sigma_s_per_mm".into(), sigma_s.into());
    o.insert("sigma_a_per_mm".into(), sigma_a.into());
    o.insert("g".into(), g.into());
    o.insert("alpha_prime".into(), derived.alpha_prime.into());
    o.insert(
        "sigma_tr_per_mm".into(),
        (derived.sigma_tr_per_m * 1e-3).into(),
    );
    o.insert("d_mm".into(), (derived.d_m * 1e3).into());
    o.insert("a".into(), a.into());
    if want_rd {
        o.insert("rd".into(), rd.into());
        o.insert("rd_closed_form".into(), rd_closed.into());
    }
    if let (Some(rs), Some(p)) = (&profile_mm, &profile) {
        o.insert("profile_mm".into(), serde_json::json!(rs));
        o.insert("profile".into(), serde_json::json!(p));
    }
    Ok(o)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn eval(argv: &[&str]) -> Result<serde_json::Map<String, serde_json::Value>> {
        let mut v = vec!["bssrdf"];
        v.extend_from_slice(argv);
        // As `lucent` reports it: clap's first line.
        let cli = Cli::try_parse_from(v).map_err(|e| anyhow::anyhow!("{}", e.to_string().lines().next().unwrap_or_default()))?;
        compute(&cli.args)
    }

    /// The JSON keys of `lucent bssrdf --rd --json`; for the standard dipole `rd` equals the closed form to 1e-4
    /// (Jensen 2001's apple, red channel: 0.85 published).
    #[test]
    fn json_contract_standard() {
        let o = eval(&[
            "--model",
            "standard",
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "2.29",
            "--sigma-a-per-mm",
            "0.003",
            "--rd",
            "--json",
        ])
        .unwrap();
        let rd = o["rd"].as_f64().unwrap();
        let cf = o["rd_closed_form"].as_f64().unwrap();
        assert!(
            (rd - cf).abs() < 1e-4 && (cf - 0.85).abs() < 0.005,
            "{rd} {cf}"
        );
        assert!(!o.contains_key("profile"));
    }

    /// `--model directional-corrected` (additive option): at α' = 1, η = 1 its rd is the line-source
    /// theory's C_φ A d_e/D + C_E over 4C_φ(1/η) (from the d'Eon–Irving fits at η = 1), i.e. about
    /// 1.037, where the published model gives 1.346; `--model directional` is unchanged.
    #[test]
    fn directional_corrected_option() {
        let run = |m: &str| {
            eval(&[
                "--model",
                m,
                "--eta",
                "1",
                "--sigma-s-per-mm",
                "1",
                "--sigma-a-per-mm",
                "0",
                "--rd",
                "--json",
            ])
            .unwrap()["rd"]
                .as_f64()
                .unwrap()
        };
        let (cp, ce) = (optics::bssrdf::c_phi(1.0), optics::bssrdf::c_e(1.0));
        let a = (1.0 - ce) / (2.0 * cp);
        let expected = (cp * a * 2.131 + ce) / (4.0 * optics::bssrdf::c_phi(1.0));
        let corrected = run("directional-corrected");
        assert!(
            (corrected - expected).abs() < 1e-4,
            "{corrected} vs {expected}"
        );
        assert!((run("directional") - 1.346).abs() < 2e-3);
    }

    /// `--profile-mm` gives R_d(r) in mm⁻²: the standard dipole at r = 0 equals
    /// α'/(4π)[(1 + σ_tr z_r)e^{−σ_tr z_r}/z_r² + (1 + σ_tr z_v)e^{−σ_tr z_v}/z_v²] evaluated here by hand.
    #[test]
    fn json_contract_profile() {
        let o = eval(&[
            "--model",
            "standard",
            "--eta",
            "1.0",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0",
            "--profile-mm",
            "0,1",
            "--json",
        ])
        .unwrap();
        let p: Vec<f64> = o["profile"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        assert_eq!(p.len(), 2);
        // σ_a = 0: σ_tr = 0, z_r = 1 mm, A(1) = (1 + F)/(1 − F) with F = Egan–Hilgeman(1) = 0.0016,
        // z_v = 1 + 4A/3 mm; R_d(0) = (1/4π)(1/z_r² + 1/z_v²).
        let f = -1.440 + 0.710 + 0.668 + 0.0636;
        let a = (1.0 + f) / (1.0 - f);
        let zv: f64 = 1.0 + 4.0 * a / 3.0;
        let expect = (1.0 + 1.0 / (zv * zv)) / (4.0 * std::f64::consts::PI);
        assert!((p[0] / expect - 1.0).abs() < 1e-12, "{} vs {expect}", p[0]);
        assert!(p[1] < p[0] && p[1] > 0.0);
        let o = eval(&[
            "--model",
            "directional",
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.01",
            "--rd",
            "--profile-mm",
            "0.5",
            "--json",
        ])
        .unwrap();
        assert!(o["rd"].as_f64().unwrap() > 0.0 && o["profile"][0].as_f64().unwrap() > 0.0);
    }

    #[test]
    fn bad_input_is_one_clear_error() {
        let msg = |argv: &[&str]| format!("{:#}", eval(argv).unwrap_err());
        assert!(msg(&[
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "-2"
        ])
        .contains("alpha'"));
        assert!(msg(&[
            "--eta",
            "0",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.1"
        ])
        .contains("eta"));
        assert!(msg(&[
            "--eta",
            "-1",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.1"
        ])
        .contains("eta"));
        assert!(msg(&[
            "--model",
            "dipolar",
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.1"
        ])
        .contains("--model"));
        assert!(msg(&[
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.1",
            "--profile-mm",
            "1,-2"
        ])
        .contains("--profile-mm"));
        assert!(msg(&["--sigma-s-per-mm", "1", "--sigma-a-per-mm", "0.1"]).contains("--eta"));
        assert!(msg(&["--preset", "nothing"]).contains("--preset"));
        let m = msg(&[
            "--eta",
            "NaN",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0.1",
        ]);
        assert!(m.contains("eta") && !m.contains('\n'), "{m}");
    }

    /// Milk from the Mie module: whole milk (3.5 % fat) at 550 nm is a strongly scattering,
    /// weakly absorbing medium with forward scattering; α' close to 1 and g in (0.5, 1).
    #[test]
    fn milk_by_content_declaration() {
        let o = eval(&[
            "--milk",
            "--fat-percent",
            "3.5",
            "--lambda-nm",
            "550",
            "--rd",
            "--json",
        ])
        .unwrap();
        let (ap, g, eta) = (
            o["alpha_prime"].as_f64().unwrap(),
            o["g"].as_f64().unwrap(),
            o["eta"].as_f64().unwrap(),
        );
        assert!(ap > 0.99 && ap <= 1.0, "{ap}");
        assert!(g > 0.5 && g < 1.0, "{g}");
        assert!((eta - 1.334).abs() < 0.01, "{eta}");
        assert!(o["rd"].as_f64().unwrap() > 0.5);
        assert!(eval(&["--milk", "--lambda-nm", "550"]).is_err());
        assert!(eval(&[
            "--fat-percent",
            "3.5",
            "--eta",
            "1.3",
            "--sigma-s-per-mm",
            "1",
            "--sigma-a-per-mm",
            "0"
        ])
        .is_err());
    }

    #[test]
    fn presets_fill_the_properties() {
        let o = eval(&["--preset", "Potato", "--channel", "b", "--rd"]).unwrap();
        assert!((o["rd"].as_f64().unwrap() - 0.21).abs() < 0.005);
        assert_eq!(o["eta"].as_f64().unwrap(), 1.3);
    }
}
