//! `lucent bssrdf`: total diffuse reflectance and radial profiles of the dipole BSSRDF models.

use anyhow::{bail, Context, Result};
use optics::bssrdf::{
    find_medium, jensen2001_media, narasimhan2006_media, DipoleModel, DirectionalDipole, OpticalProperties,
    StandardDipole,
};

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Dipole model: `standard` (Jensen et al. 2001) or `directional` (Frisvad et al. 2014).
    #[arg(long, default_value = "standard")]
    model: String,
    /// Relative index of refraction η = n_medium / n_outside.
    #[arg(long, allow_hyphen_values = true)]
    eta: Option<f64>,
    /// Scattering coefficient σ_s in mm⁻¹.
    #[arg(long, allow_hyphen_values = true)]
    sigma_s_per_mm: Option<f64>,
    /// Absorption coefficient σ_a in mm⁻¹.
    #[arg(long, allow_hyphen_values = true)]
    sigma_a_per_mm: Option<f64>,
    /// Henyey–Greenstein asymmetry parameter g (default 0, or the preset's).
    #[arg(long, allow_hyphen_values = true)]
    g: Option<f64>,
    /// A measured medium (Jensen 2001 or Narasimhan 2006, e.g. "Apple", "Regular Milk") giving
    /// η, σ_s, σ_a and g for `--channel`; explicit flags override it.
    #[arg(long)]
    preset: Option<String>,
    /// Colour channel of the preset: r, g or b.
    #[arg(long, default_value = "r")]
    channel: String,
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

fn parse_list(text: &str, field: &str) -> Result<Vec<f64>> {
    text.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| {
            let v: f64 = s.parse().map_err(|_| anyhow::anyhow!("{field}: '{s}' is not a number"))?;
            if !v.is_finite() || v < 0.0 {
                bail!("{field}: distance {s} must be finite and >= 0");
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
    let eta = args.eta.or(eta).context("--eta is required (or give --preset)")?;
    let sigma_s = args.sigma_s_per_mm.or(sigma_s).context("--sigma-s-per-mm is required (or give --preset)")?;
    let sigma_a = args.sigma_a_per_mm.or(sigma_a).context("--sigma-a-per-mm is required (or give --preset)")?;
    let g = args.g.or(g).unwrap_or(0.0);
    let props = OpticalProperties { eta, sigma_s_per_m: sigma_s * 1e3, sigma_a_per_m: sigma_a * 1e3, g };
    let derived = props
        .derive()
        .context("invalid medium (--eta, --sigma-s-per-mm, --sigma-a-per-mm, --g)")?;
    let profile_mm = match &args.profile_mm {
        Some(t) => Some(parse_list(t, "--profile-mm")?),
        None => None,
    };
    let want_rd = args.rd || profile_mm.is_none();

    let standard = StandardDipole::new(&props)?;
    let directional = DirectionalDipole::new(&props)?;
    let profile_fn = |r_mm: f64| -> f64 {
        let r_m = r_mm * 1e-3;
        1e-6 * match model {
            DipoleModel::Standard => standard.rd_profile(r_m),
            DipoleModel::Directional => directional.rd_profile(r_m),
        }
    };
    let rd_closed = standard.rd_closed_form();
    let rd = match model {
        DipoleModel::Standard => standard.rd_numerical(),
        DipoleModel::Directional => directional.rd_numerical(),
    };
    let profile: Option<Vec<f64>> = profile_mm.as_ref().map(|rs| rs.iter().map(|&r| profile_fn(r)).collect());
    let a = match model {
        DipoleModel::Standard => standard.a,
        DipoleModel::Directional => directional.a,
    };

    if args.json {
        let mut o = serde_json::Map::new();
        o.insert("model".into(), args.model.clone().into());
        o.insert("eta".into(), eta.into());
        o.insert("sigma_s_per_mm".into(), sigma_s.into());
        o.insert("sigma_a_per_mm".into(), sigma_a.into());
        o.insert("g".into(), g.into());
        o.insert("alpha_prime".into(), derived.alpha_prime.into());
        o.insert("sigma_tr_per_mm".into(), (derived.sigma_tr_per_m * 1e-3).into());
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
        println!("{}", serde_json::Value::Object(o));
    } else {
        println!(
            "{} dipole: eta {eta}, sigma_s {sigma_s} /mm, sigma_a {sigma_a} /mm, g {g}; alpha' {:.6}, sigma_tr {:.6} /mm, D {:.6} mm, A {:.6}",
            args.model,
            derived.alpha_prime,
            derived.sigma_tr_per_m * 1e-3,
            derived.d_m * 1e3,
            a
        );
        if want_rd {
            println!("rd (numerical, pi * integral of S_d over the plane) = {rd:.6}");
            println!("rd_closed_form (standard dipole)                   = {rd_closed:.6}");
        }
        if let (Some(rs), Some(p)) = (&profile_mm, &profile) {
            println!("r_mm,rd_per_mm2");
            for (r, v) in rs.iter().zip(p) {
                println!("{r},{v:.9e}");
            }
        }
    }
    Ok(())
}
