//! `lucent fit …`: inverse problems — optical properties from spatially resolved diffuse
//! reflectance (`reflectance`), oblique incidence reflectometry (`oblique`), milk composition from
//! optical property spectra (`particles`), the Monte Carlo table behind `--model montecarlo`
//! (`mc-table`), and analysis by synthesis (`scene`).

use super::format::sig;
use super::mie::finite_f64;
use anyhow::{bail, Context, Result};
use optics::fitting::{fit_milk, MilkSpectra};
use optics::reflectometry::{
    fit_oblique, fit_reflectance, read_reflectance_csv, Estimate, FitOptions, MonteCarloTable, ReflectanceFit,
    ReflectanceModel,
};
use optics::slab::{simulate, Layer, RadialGrid, SlabSettings};
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub which: Which,
}

#[derive(clap::Subcommand, Debug)]
pub enum Which {
    /// Fit σ_a and σ'_s to a spatially resolved diffuse reflectance profile R(r).
    Reflectance(ReflectanceArgs),
    /// Oblique incidence reflectometry: σ'_s and σ_a from the shift of the diffuse centre.
    Oblique(ObliqueArgs),
    /// Infer a product's composition (milk: fat content, homogenization pressure) from spectra.
    Particles(ParticlesArgs),
    /// Build the Monte Carlo R(r) table used by `fit reflectance --model montecarlo`.
    McTable(McTableArgs),
    /// Analysis by synthesis: fit scene parameters to a reference photograph.
    Scene(super::fit_scene::Args),
    /// Appearance fit on photographs: per-label albedos, lights and the camera response.
    Photo(super::fit_photo::Args),
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModelName {
    /// Standard dipole (Farrell, Patterson & Wilson 1992).
    Dipole,
    /// Directional dipole (Frisvad et al. 2014) at normal incidence.
    Directional,
    /// Tabulated Monte Carlo (`lucent slab` runs).
    Montecarlo,
}

#[derive(clap::Args, Debug)]
pub struct ReflectanceArgs {
    /// CSV with columns r_mm and reflectance (mm⁻², absolute) or relative (shape only); optional
    /// wavelength_nm (one fit per wavelength) and stderr columns. `lucent slab --radial-csv`
    /// output (rd_per_mm2, rd_per_mm2_stderr) is accepted as is.
    data: PathBuf,
    /// Relative refractive index of the medium (n_medium / n_outside).
    #[arg(long, value_parser = finite_f64)]
    eta: f64,
    /// Forward model.
    #[arg(long, value_enum, default_value_t = ModelName::Dipole)]
    model: ModelName,
    /// Monte Carlo table (CSV from `lucent fit mc-table`); default: the bundled one for --eta.
    #[arg(long)]
    table: Option<PathBuf>,
    /// Use only points at r ≥ this (mm). Diffusion models fail within ~2 transport lengths of
    /// the source: leave that out for the dipoles (e.g. 1 mm for milk), or use montecarlo.
    #[arg(long, value_parser = finite_f64, default_value_t = 0.0)]
    r_min_mm: f64,
    /// Use only points at r ≤ this (mm).
    #[arg(long, value_parser = finite_f64)]
    r_max_mm: Option<f64>,
    /// Relative noise of each point (added in quadrature to the stderr column).
    #[arg(long, value_parser = finite_f64, default_value_t = 0.01)]
    noise: f64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ObliqueArgs {
    /// CSV with columns x_mm and reflectance (or rd_per_mm2 as printed by `lucent slab
    /// --line-bins`): the diffuse reflectance along the plane of incidence.
    data: PathBuf,
    /// Relative refractive index of the medium.
    #[arg(long, value_parser = finite_f64)]
    eta: f64,
    /// Angle of incidence from the normal, degrees (the beam travels towards +x).
    #[arg(long, value_parser = finite_f64)]
    incidence_deg: f64,
    /// Ignore points within this distance of the peak (mm), where diffusion theory fails.
    #[arg(long, value_parser = finite_f64, default_value_t = 1.0)]
    exclude_mm: f64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub struct ParticlesArgs {
    /// CSV with columns wavelength_nm and sigma_s_prime_per_mm, optional sigma_a_per_mm.
    spectra: PathBuf,
    /// The product model: `milk` (Frisvad et al. 2007: fat content and homogenization pressure),
    /// or a medium recipe TOML (see docs/media.md) with --particle NAME (mean radius and volume
    /// fraction of that particle type).
    #[arg(long)]
    medium: String,
    /// With a recipe: the particle type whose mean radius and volume fraction are fitted.
    #[arg(long)]
    particle: Option<String>,
    /// Protein content, wt-% (milk).
    #[arg(long, value_parser = finite_f64, default_value_t = optics::milk::DEFAULT_PROTEIN_PERCENT)]
    protein_percent: f64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
pub struct McTableArgs {
    /// Relative refractive index of the medium.
    #[arg(long, value_parser = finite_f64)]
    eta: f64,
    /// Henyey–Greenstein anisotropy of the simulations.
    #[arg(long, value_parser = finite_f64, default_value_t = 0.0)]
    g: f64,
    /// Photon packets per albedo.
    #[arg(long, default_value_t = 200_000)]
    photons: u64,
    /// Largest scaled radius σ'_t r.
    #[arg(long, value_parser = finite_f64, default_value_t = 20.0)]
    rho_max: f64,
    /// Radial bins.
    #[arg(long, default_value_t = 100)]
    bins: usize,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Replace each row beyond this scaled radius by the dipole matched over the 3 units before.
    #[arg(long, value_parser = finite_f64)]
    diffusion_tail_rho: Option<f64>,
    /// Output CSV.
    #[arg(long)]
    out: PathBuf,
}

pub fn run(args: Args) -> Result<()> {
    match args.which {
        Which::Reflectance(a) => run_reflectance(a),
        Which::Oblique(a) => run_oblique(a),
        Which::Particles(a) => run_particles(a),
        Which::McTable(a) => run_mc_table(a),
        Which::Scene(a) => super::fit_scene::run(a),
        Which::Photo(a) => super::fit_photo::run(a),
    }
}

fn read_text(path: &Path) -> Result<String> {
    std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))
}

fn est_json(e: Option<Estimate>) -> (Value, Value) {
    match e {
        Some(e) => (json!(e.value), json!(e.ci95)),
        None => (Value::Null, Value::Null),
    }
}

/// The model for `--model`, loading a table for montecarlo.
fn load_model(model: ModelName, table: Option<&Path>, eta: f64) -> Result<ReflectanceModel> {
    Ok(match model {
        ModelName::Dipole => ReflectanceModel::Dipole,
        ModelName::Directional => ReflectanceModel::Directional,
        ModelName::Montecarlo => {
            let t = match table {
                Some(p) => MonteCarloTable::from_csv(&read_text(p)?, &p.display().to_string())?,
                None => optics::reflectometry::bundled_table(eta)?.with_context(|| {
                    format!("no bundled Monte Carlo table for --eta {eta} (bundled: {}); build one with `lucent fit mc-table --eta {eta} --out TABLE.csv` and pass --table TABLE.csv",
                        optics::reflectometry::BUNDLED_TABLE_ETAS.map(|e| e.to_string()).join(", "))
                })?,
            };
            if (t.eta - eta).abs() > 1e-6 {
                bail!("the Monte Carlo table was built for eta {} but --eta is {eta}", t.eta);
            }
            ReflectanceModel::MonteCarlo(t)
        }
    })
}

fn run_reflectance(a: ReflectanceArgs) -> Result<()> {
    if !(a.eta.is_finite() && a.eta > 0.0) {
        bail!("--eta must be finite and > 0, got {}", a.eta);
    }
    if !(a.noise.is_finite() && a.noise > 0.0) {
        bail!("--noise must be finite and > 0, got {}", a.noise);
    }
    if a.r_min_mm < 0.0 {
        bail!("--r-min-mm must be ≥ 0, got {}", a.r_min_mm);
    }
    if let Some(r) = a.r_max_mm {
        if r <= a.r_min_mm {
            bail!("--r-max-mm ({r}) must be greater than --r-min-mm ({})", a.r_min_mm);
        }
    }
    let name = a.data.display().to_string();
    let profiles = read_reflectance_csv(&read_text(&a.data)?, &name)?;
    let model = load_model(a.model, a.table.as_deref(), a.eta)?;
    let mut fits: Vec<ReflectanceFit> = vec![];
    for p in &profiles {
        // Histogram data (bin centres Δ/2, 3Δ/2, …): compare annulus averages of the model.
        let bin = optics::reflectometry::detect_bins(&p.r_mm);
        let options = FitOptions {
            r_min_mm: a.r_min_mm,
            r_max_mm: a.r_max_mm.unwrap_or(f64::INFINITY),
            relative_noise: a.noise,
            bin_width_mm: bin,
        };
        let f = fit_reflectance(p, &model, a.eta, &options).with_context(|| match p.lambda_nm {
            Some(l) => format!("{name}: wavelength_nm {l}"),
            None => name.clone(),
        })?;
        let mut f = f;
        if let Some(h) = bin {
            f.notes.push(format!("r_mm are centres of {} mm bins: the model is averaged over each annulus", sig(h, 6)));
        }
        fits.push(f);
    }
    let relative = profiles[0].relative;
    if a.json {
        let one = |f: &ReflectanceFit| {
            let (sa, sa_ci) = est_json(f.sigma_a_per_mm);
            let (ss, ss_ci) = est_json(f.sigma_s_prime_per_mm);
            let (me, me_ci) = est_json(f.mu_eff_per_mm);
            let (ra, ra_ci) = est_json(f.sigma_s_prime_over_sigma_a);
            [
                ("sigma_a_per_mm", sa),
                ("sigma_s_prime_per_mm", ss),
                ("sigma_a_ci_per_mm", sa_ci),
                ("sigma_s_prime_ci_per_mm", ss_ci),
                ("mu_eff_per_mm", me),
                ("mu_eff_ci_per_mm", me_ci),
                ("sigma_s_prime_over_sigma_a", ra),
                ("sigma_s_prime_over_sigma_a_ci", ra_ci),
                ("residual_rms", json!(f.residual_rms)),
                ("relative_rms", json!(f.relative_rms)),
                ("points", json!(f.points)),
            ]
        };
        let mut out = serde_json::Map::new();
        out.insert("model".into(), json!(model.name()));
        out.insert("eta".into(), json!(a.eta));
        out.insert("relative".into(), json!(relative));
        if fits.len() == 1 && fits[0].lambda_nm.is_none() {
            for (k, v) in one(&fits[0]) {
                out.insert(k.into(), v);
            }
        } else {
            out.insert("wavelength_nm".into(), json!(fits.iter().map(|f| f.lambda_nm).collect::<Vec<_>>()));
            let rows: Vec<_> = fits.iter().map(one).collect();
            for (i, (k, _)) in rows[0].iter().enumerate() {
                out.insert((*k).into(), Value::Array(rows.iter().map(|r| r[i].1.clone()).collect()));
            }
        }
        let notes: Vec<String> = fits.iter().flat_map(|f| {
            f.notes.iter().map(move |n| match f.lambda_nm { Some(l) => format!("{l} nm: {n}"), None => n.clone() })
        }).collect();
        out.insert("notes".into(), json!(notes));
        println!("{}", serde_json::to_string_pretty(&Value::Object(out))?);
    } else {
        println!("model {}  eta {}  ({} data)", model.name(), sig(a.eta, 6), if relative { "relative" } else { "absolute" });
        let show = |e: Option<Estimate>| match e {
            Some(e) => format!("{} [{}, {}]", sig(e.value, 5), sig(e.ci95[0], 5), sig(e.ci95[1], 5)),
            None => "not determined".into(),
        };
        for f in &fits {
            if let Some(l) = f.lambda_nm {
                println!("wavelength {} nm", sig(l, 6));
            }
            println!("  sigma_a        {} mm⁻¹", show(f.sigma_a_per_mm));
            println!("  sigma_s'       {} mm⁻¹", show(f.sigma_s_prime_per_mm));
            println!("  mu_eff         {} mm⁻¹", show(f.mu_eff_per_mm));
            println!("  sigma_s'/sigma_a {}", show(f.sigma_s_prime_over_sigma_a));
            println!("  residual rms   {} (weighted), {} (relative), {} points", sig(f.residual_rms, 4), sig(f.relative_rms, 4), f.points);
            for n in &f.notes {
                println!("  note: {n}");
            }
        }
    }
    Ok(())
}

/// Read x_mm and reflectance (or rd_per_mm2) columns; x must increase.
#[allow(clippy::type_complexity)]
fn read_line_csv(text: &str, file: &str) -> Result<(Vec<f64>, Vec<f64>, Option<Vec<f64>>)> {
    // Reuse the radial reader by renaming the position column.
    let mut lines = text.lines().enumerate();
    let mut rebuilt = String::new();
    let mut col = None;
    for (_, l) in lines.by_ref() {
        if l.trim().is_empty() || l.trim_start().starts_with('#') {
            rebuilt.push('\n');
            continue;
        }
        let h: Vec<&str> = l.split(',').map(str::trim).collect();
        let Some(i) = h.iter().position(|c| *c == "x_mm") else {
            bail!("{file}: missing column x_mm (header: {l})");
        };
        rebuilt.push_str(&h.iter().map(|c| if *c == "x_mm" { "r_mm" } else { c }).collect::<Vec<_>>().join(","));
        rebuilt.push('\n');
        col = Some(i);
        break;
    }
    let Some(col) = col else {
        bail!("{file}: empty file (expected a header x_mm,reflectance)");
    };
    // Positions may be negative, and the radial reader takes distances ≥ 0: check x here (finite,
    // increasing, in the file's own numbers), then shift the column so that its smallest value is
    // 1 mm for the reader, and back.
    let rows: Vec<(usize, &str)> = lines.collect();
    let mut xs: Vec<f64> = Vec::new();
    for (i, row) in &rows {
        if row.trim().is_empty() || row.trim_start().starts_with('#') {
            continue;
        }
        let cell = row.split(',').nth(col).map(str::trim).unwrap_or("");
        let x: f64 = cell.parse().map_err(|_| anyhow::anyhow!("{file}: line {}: column x_mm: `{cell}` is not a number", i + 1))?;
        if !x.is_finite() || x.abs() > 1e6 {
            bail!("{file}: line {}: column x_mm: {x} mm is not a position on a sample", i + 1);
        }
        if let Some(&prev) = xs.last() {
            if x <= prev {
                bail!("{file}: line {}: column x_mm: {x} does not increase (previous {prev})", i + 1);
            }
        }
        xs.push(x);
    }
    let shift = 1.0 - xs.first().copied().unwrap_or(0.0);
    for (_, row) in rows {
        let mut f: Vec<String> = row.split(',').map(|s| s.trim().to_string()).collect();
        if !row.trim().is_empty() && !row.trim_start().starts_with('#') {
            if let Some(Ok(x)) = f.get(col).map(|c| c.parse::<f64>()) {
                f[col] = format!("{}", x + shift);
            }
        }
        rebuilt.push_str(&f.join(","));
        rebuilt.push('\n');
    }
    let p = read_reflectance_csv(&rebuilt, file).map_err(|e| anyhow::anyhow!(e.to_string().replace("r_mm", "x_mm")))?;
    if p.len() != 1 {
        bail!("{file}: one profile expected (no wavelength_nm column)");
    }
    let p = &p[0];
    Ok((p.r_mm.iter().map(|x| x - shift).collect(), p.value.clone(), p.stderr.clone()))
}

fn run_oblique(a: ObliqueArgs) -> Result<()> {
    if !(a.exclude_mm >= 0.0 && a.exclude_mm.is_finite()) {
        bail!("--exclude-mm: a distance ≥ 0 around the entry point, got {}", optics::numfmt::short(a.exclude_mm));
    }
    let name = a.data.display().to_string();
    let text = read_text(&a.data)?;
    let (x, v, se) = read_line_csv(&text, &name)?;
    let f = fit_oblique(&x, &v, se.as_deref(), a.incidence_deg, a.eta, a.exclude_mm).with_context(|| name.clone())?;
    if a.json {
        let j = json!({
            "delta_x_mm": f.delta_x_mm.value, "delta_x_ci_mm": f.delta_x_mm.ci95,
            "mu_eff_per_mm": f.mu_eff_per_mm.value, "mu_eff_ci_per_mm": f.mu_eff_per_mm.ci95,
            "diffusion_mm": f.diffusion_mm.value, "diffusion_ci_mm": f.diffusion_mm.ci95,
            "sigma_a_per_mm": f.sigma_a_per_mm.value, "sigma_a_ci_per_mm": f.sigma_a_per_mm.ci95,
            "sigma_s_prime_per_mm": f.sigma_s_prime_per_mm.value, "sigma_s_prime_ci_per_mm": f.sigma_s_prime_per_mm.ci95,
            "residual_rms": f.residual_rms, "points": f.points,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        let s = |e: Estimate| format!("{} [{}, {}]", sig(e.value, 5), sig(e.ci95[0], 5), sig(e.ci95[1], 5));
        println!("diffuse centre shift  {} mm", s(f.delta_x_mm));
        println!("mu_eff                {} mm⁻¹", s(f.mu_eff_per_mm));
        println!("D                     {} mm", s(f.diffusion_mm));
        println!("sigma_a               {} mm⁻¹", s(f.sigma_a_per_mm));
        println!("sigma_s'              {} mm⁻¹", s(f.sigma_s_prime_per_mm));
        println!("residual rms          {} ({} points)", sig(f.residual_rms, 4), f.points);
    }
    Ok(())
}

/// Read wavelength_nm, sigma_s_prime_per_mm and optional sigma_a_per_mm.
fn read_spectra_csv(text: &str, file: &str) -> Result<MilkSpectra> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
    let (_, header) = lines.next().with_context(|| format!("{file}: empty file (expected a header wavelength_nm,sigma_s_prime_per_mm)"))?;
    let names: Vec<&str> = header.split(',').map(str::trim).collect();
    let col = |n: &str| names.iter().position(|c| *c == n);
    let lc = col("wavelength_nm").with_context(|| format!("{file}: missing column wavelength_nm (header: {header})"))?;
    let sc = col("sigma_s_prime_per_mm").with_context(|| format!("{file}: missing column sigma_s_prime_per_mm (header: {header})"))?;
    let ac = col("sigma_a_per_mm");
    let mut s = MilkSpectra { lambda_nm: vec![], sigma_s_prime_per_mm: vec![], sigma_a_per_mm: ac.map(|_| vec![]) };
    for (i, line) in lines {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |c: usize| -> Result<f64> {
            let t = f.get(c).with_context(|| format!("{file}: line {}: missing column {}", i + 1, names[c]))?;
            let v: f64 = t.parse().map_err(|_| anyhow::anyhow!("{file}: line {}: column {}: {t:?} is not a number", i + 1, names[c]))?;
            if !v.is_finite() || v < 0.0 {
                bail!("{file}: line {}: column {}: {t} must be finite and ≥ 0", i + 1, names[c]);
            }
            Ok(v)
        };
        let l = get(lc)?;
        if let Some(&last) = s.lambda_nm.last() {
            if l <= last {
                bail!("{file}: line {}: column wavelength_nm: {l} does not increase", i + 1);
            }
        }
        let sp = get(sc)?;
        if sp <= 0.0 {
            bail!("{file}: line {}: column sigma_s_prime_per_mm must be > 0", i + 1);
        }
        s.lambda_nm.push(l);
        s.sigma_s_prime_per_mm.push(sp);
        if let (Some(v), Some(c)) = (s.sigma_a_per_mm.as_mut(), ac) {
            v.push(get(c)?);
        }
    }
    if s.lambda_nm.is_empty() {
        bail!("{file}: no data rows");
    }
    Ok(s)
}

fn run_particles(a: ParticlesArgs) -> Result<()> {
    let name = a.spectra.display().to_string();
    let spectra = read_spectra_csv(&read_text(&a.spectra)?, &name)?;
    if !(a.protein_percent.is_finite() && (0.0..100.0).contains(&a.protein_percent)) {
        bail!("--protein-percent must lie in [0, 100), got {}", a.protein_percent);
    }
    if a.medium != "milk" {
        let path = Path::new(&a.medium);
        let recipe = optics::media::Recipe::load(path).with_context(|| format!("--medium {}", path.display()))?;
        let particle = a.particle.as_deref().context("--particle NAME is needed with a recipe --medium")?;
        if !recipe.particles.iter().any(|p| p.name == particle) {
            let names: Vec<String> = recipe.particles.iter().map(|p| format!("{:?}", p.name)).collect();
            bail!("--particle: recipe {} has no particle named {particle:?} (it has: {})", path.display(), if names.is_empty() { "none".into() } else { names.join(", ") });
        }
        // The recipe must evaluate at the data's wavelengths on its own: its errors name the recipe.
        recipe
            .bulk_properties(Some(&spectra.lambda_nm))
            .with_context(|| format!("--medium {} at the wavelengths of {name}", path.display()))?;
        let f = optics::fitting::fit_recipe_particle(&recipe, particle, &spectra)
            .with_context(|| format!("fitting particle {particle:?} of {} to {name}", path.display()))?;
        if a.json {
            let j = json!({
                "medium": a.medium, "particle": particle,
                "radius_um": f.radius_um, "radius_um_ci": f.radius_um_ci,
                "volume_fraction": f.volume_fraction, "volume_fraction_ci": f.volume_fraction_ci,
                "residual_rms": f.residual_rms,
            });
            println!("{}", serde_json::to_string_pretty(&j)?);
        } else {
            println!("{particle}: mean radius     {} µm [{}, {}]", sig(f.radius_um, 4), sig(f.radius_um_ci[0], 4), sig(f.radius_um_ci[1], 4));
            println!("{particle}: volume fraction {} [{}, {}]", sig(f.volume_fraction, 4), sig(f.volume_fraction_ci[0], 4), sig(f.volume_fraction_ci[1], 4));
            println!("residual rms      {} (relative)", sig(f.residual_rms, 4));
        }
        return Ok(());
    }
    let f = fit_milk(&spectra, a.protein_percent).with_context(|| name.clone())?;
    if a.json {
        let j = json!({
            "medium": "milk",
            "protein_percent": a.protein_percent,
            "fat_percent": f.fat_percent, "fat_percent_ci": f.fat_percent_ci,
            "pressure_mpa": f.pressure_mpa, "pressure_mpa_ci": f.pressure_mpa_ci,
            "residual_rms": f.residual_rms,
            "fat_r_vs_um": f.fat_r_vs_um, "fat_volume_fraction": f.fat_volume_fraction,
        });
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        println!("fat content       {} wt-% [{}, {}]", sig(f.fat_percent, 4), sig(f.fat_percent_ci[0], 4), sig(f.fat_percent_ci[1], 4));
        println!("pressure          {} MPa [{}, {}]", sig(f.pressure_mpa, 4), sig(f.pressure_mpa_ci[0], 4), sig(f.pressure_mpa_ci[1], 4));
        println!("fat globules r_vs {} µm, volume fraction {}", sig(f.fat_r_vs_um, 4), sig(f.fat_volume_fraction, 4));
        println!("residual rms      {} (relative)", sig(f.residual_rms, 4));
    }
    Ok(())
}

/// Reduced albedos of the Monte Carlo table.
pub const TABLE_ALBEDOS: [f64; 17] = [
    0.5, 0.7, 0.8, 0.9, 0.95, 0.97, 0.98, 0.99, 0.995, 0.997, 0.998, 0.999, 0.9995, 0.9997, 0.9998, 0.9999, 0.99995,
];

/// Simulate R(r)/σ'_t² at one reduced albedo with σ'_t = 1 mm⁻¹; far bins whose relative standard
/// error exceeds 3 % are replaced by the dipole's shape matched to the last reliable bins.
pub fn table_row(albedo: f64, eta: f64, g: f64, photons: u64, seed: u64, rho_max: f64, bins: usize) -> Result<Vec<f64>> {
    let layer = Layer { mua_per_mm: 1.0 - albedo, mus_per_mm: albedo / (1.0 - g), g, n: eta, thickness_mm: f64::INFINITY };
    let s = SlabSettings { photons, seed, radial: Some(RadialGrid { bins, max_mm: rho_max }), ..SlabSettings::new(vec![layer]) };
    let r = simulate(&s)?;
    let rad = r.radial.context("no radial tally")?;
    let mut v = rad.rd_per_mm2.clone();
    let cut = (0..bins).find(|&k| !(v[k] > 0.0 && rad.rd_per_mm2_stderr[k] <= 0.03 * v[k])).unwrap_or(bins);
    if cut < 3 {
        bail!("albedo {albedo}: too few photons ({photons}) for a usable R(r)");
    }
    if cut < bins {
        let dip = |k: usize| optics::reflectometry::dipole_rd_per_mm2(rad.r_mm[k], 1.0 - albedo, albedo, eta);
        let from = cut.saturating_sub(5).max(1);
        let ratio = (from..cut).map(|k| (v[k] / dip(k)).ln()).sum::<f64>() / (cut - from) as f64;
        for k in cut..bins {
            v[k] = ratio.exp() * dip(k);
        }
    }
    Ok(v)
}

fn run_mc_table(a: McTableArgs) -> Result<()> {
    if !(a.eta.is_finite() && a.eta > 0.0) {
        bail!("--eta must be finite and > 0, got {}", a.eta);
    }
    if !(a.g > -1.0 && a.g < 1.0) {
        bail!("--g must lie in (-1, 1), got {}", a.g);
    }
    if !(a.rho_max.is_finite() && a.rho_max > 0.0) || a.bins < 2 {
        bail!("--rho-max must be > 0 and --bins ≥ 2");
    }
    let mut rows = vec![];
    for (i, &alb) in TABLE_ALBEDOS.iter().enumerate() {
        let row = table_row(alb, a.eta, a.g, a.photons, a.seed + i as u64, a.rho_max, a.bins)?;
        eprintln!("albedo {alb}: done");
        rows.push(row);
    }
    let d = a.rho_max / a.bins as f64;
    let mut t = MonteCarloTable {
        eta: a.eta,
        g: a.g,
        albedo: TABLE_ALBEDOS.to_vec(),
        rho: (0..a.bins).map(|k| (k as f64 + 0.5) * d).collect(),
        r_scaled: rows,
    };
    t.validate()?;
    if let Some(rho) = a.diffusion_tail_rho {
        t.join_diffusion_tail(rho);
    }
    render::image_io::write_atomic(&a.out, |tmp| Ok(std::fs::write(tmp, t.to_csv())?))
        .with_context(|| format!("--out {}", a.out.display()))?;
    Ok(())
}
