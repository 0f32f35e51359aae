//! `lucent mie`: Lorenz–Mie theory for one sphere, by size parameter and relative index
//! (`--x X --m RE+IMi`) or by radius, wavelength and the two indices. Also holds the small
//! hand-written SVG plotting used by `lucent mie` and `lucent medium` (`--plot FILE.svg`).

use super::format::sig;
use anyhow::{anyhow, bail, Context, Result};
use optics::mie::{self, Complex64, MieWorkspace};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// Size parameter x = 2πr n_medium/λ (non-absorbing host).
    #[arg(long = "x", allow_hyphen_values = true)]
    pub x: Option<String>,
    /// Relative refractive index m = n_particle/n_medium, `RE` or `RE+IMi` (imaginary part ≥ 0 absorbs).
    #[arg(long = "m", allow_hyphen_values = true)]
    pub m: Option<String>,
    /// Sphere radius in µm (with --wavelength-nm, --n-particle, --n-medium).
    #[arg(long = "radius-um", allow_hyphen_values = true)]
    pub radius_um: Option<String>,
    /// Vacuum wavelength in nm.
    #[arg(long = "wavelength-nm", alias = "lambda-nm", allow_hyphen_values = true)]
    pub wavelength_nm: Option<String>,
    /// Particle refractive index `RE` or `RE+IMi`.
    #[arg(long = "n-particle", allow_hyphen_values = true)]
    pub n_particle: Option<String>,
    /// Host refractive index `RE` or `RE+IMi` (imaginary part ≥ 0: absorbing host, Frisvad et al. 2007). Default 1.
    #[arg(long = "n-medium", allow_hyphen_values = true)]
    pub n_medium: Option<String>,
    /// Scattering angles in degrees: `a,b,c` or `START:STOP:STEP`; adds theta_deg, s1, s2, phase_per_sr.
    #[arg(long = "angles-deg", allow_hyphen_values = true)]
    pub angles_deg: Option<String>,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    /// Draw the phase function (polar, log scale) to this SVG file.
    #[arg(long)]
    pub plot: Option<std::path::PathBuf>,
}

/// clap value parser for numeric flags: a finite number (NaN and ±inf are refused).
pub(crate) fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| format!("{s:?} is not a number"))?;
    if !v.is_finite() {
        return Err(format!("{s:?} is not a finite number"));
    }
    Ok(v)
}


/// Parse a finite number given to `flag`.
pub(crate) fn number(flag: &str, s: &str) -> Result<f64> {
    let v: f64 = s.trim().parse().map_err(|_| anyhow!("{flag}: not a number: {s:?}"))?;
    if !v.is_finite() {
        bail!("{flag}: must be finite, got {s:?}");
    }
    Ok(v)
}

fn positive(flag: &str, s: &str) -> Result<f64> {
    let v = number(flag, s)?;
    if v <= 0.0 {
        bail!("{flag}: must be positive, got {s}");
    }
    Ok(v)
}

fn index(flag: &str, s: &str) -> Result<Complex64> {
    let c = mie::parse_complex(s).with_context(|| flag.to_string())?;
    if c.re <= 0.0 {
        bail!("{flag}: real part must be positive, got {s}");
    }
    if c.im < 0.0 {
        bail!("{flag}: imaginary part must be ≥ 0 (time dependence e^(−iωt): a positive imaginary part absorbs), got {s}");
    }
    Ok(c)
}

/// Parse a list of angles in degrees (`a,b,c` or `START:STOP:STEP`), each in [0, 180].
fn angles(s: &str) -> Result<Vec<f64>> {
    let flag = "--angles-deg";
    let v: Vec<f64> = if s.contains(':') {
        let p: Vec<&str> = s.split(':').collect();
        if p.len() != 3 {
            bail!("{flag}: expected START:STOP:STEP, got {s:?}");
        }
        let (a, b, d) = (number(flag, p[0])?, number(flag, p[1])?, number(flag, p[2])?);
        if d <= 0.0 || b < a {
            bail!("{flag}: expected START ≤ STOP and STEP > 0, got {s:?}");
        }
        let n = ((b - a) / d + 1e-9).floor() as usize;
        if n > 1_000_000 {
            bail!("{flag}: too many angles in {s:?}");
        }
        (0..=n).map(|i| a + i as f64 * d).collect()
    } else {
        s.split(',').map(|t| number(flag, t)).collect::<Result<_>>()?
    };
    for &a in &v {
        if !(0.0..=180.0).contains(&a) {
            bail!("{flag}: angles must lie in [0, 180], got {a}");
        }
    }
    Ok(v)
}

pub fn run(args: Args) -> Result<()> {
    let by_x = args.x.is_some() || args.m.is_some();
    let by_radius = args.radius_um.is_some() || args.wavelength_nm.is_some() || args.n_particle.is_some() || args.n_medium.is_some();
    if by_x && by_radius {
        bail!("give either --x and --m, or --radius-um, --wavelength-nm, --n-particle (and --n-medium), not both");
    }
    let mut ws = MieWorkspace::new();
    let mut out = serde_json::Map::new();
    // host size parameter (complex for an absorbing host) and relative index
    let (x, m, sphere) = if by_radius {
        let r_um = positive("--radius-um", args.radius_um.as_deref().ok_or_else(|| anyhow!("--radius-um is required"))?)?;
        let l_nm = positive("--wavelength-nm", args.wavelength_nm.as_deref().ok_or_else(|| anyhow!("--wavelength-nm is required"))?)?;
        let np = index("--n-particle", args.n_particle.as_deref().ok_or_else(|| anyhow!("--n-particle is required"))?)?;
        let nm = match &args.n_medium {
            Some(s) => index("--n-medium", s)?,
            None => Complex64::new(1.0, 0.0),
        };
        let x = mie::size_parameter(r_um * 1e-6, l_nm * 1e-9, nm);
        mie::check_size(x, np / nm).context("--radius-um, --wavelength-nm, --n-particle, --n-medium")?;
        let alpha = 2.0 * x.im;
        if alpha > mie::MAX_HOST_ATTENUATION {
            bail!("--n-medium: the host absorbs too strongly for this sphere (4πr·n″/λ = {alpha:.3} > {}): the light dies out inside one diameter", mie::MAX_HOST_ATTENUATION);
        }
        let s = ws.sphere(r_um * 1e-6, l_nm * 1e-9, np, nm);
        (x, np / nm, Some(s))
    } else {
        let x = positive("--x", args.x.as_deref().ok_or_else(|| anyhow!("--x is required (or use --radius-um …)"))?)?;
        let m = index("--m", args.m.as_deref().ok_or_else(|| anyhow!("--m is required"))?)?;
        mie::check_size(Complex64::new(x, 0.0), m).context("--x, --m")?;
        (Complex64::new(x, 0.0), m, None)
    };
    let eff = match &sphere {
        Some(s) => s.eff,
        None => ws.efficiencies(x.re, m),
    };
    out.insert("x".into(), json!(x.re));
    if x.im != 0.0 {
        out.insert("x_im".into(), json!(x.im));
    }
    out.insert("m_re".into(), json!(m.re));
    out.insert("m_im".into(), json!(m.im));
    out.insert("terms".into(), json!(eff.terms));
    out.insert("qext".into(), json!(eff.qext));
    out.insert("qsca".into(), json!(eff.qsca));
    out.insert("qabs".into(), json!(eff.qabs));
    out.insert("qback".into(), json!(eff.qback));
    out.insert("g".into(), json!(eff.g));
    if let Some(s) = &sphere {
        out.insert("c_ext_m2".into(), json!(s.c_ext_m2));
        out.insert("c_sca_m2".into(), json!(s.c_sca_m2));
        out.insert("c_abs_m2".into(), json!(s.c_abs_m2));
    }
    let theta = match &args.angles_deg {
        Some(s) => Some(angles(s)?),
        None => None,
    };
    let (a, b) = ws.coefficients(x, m);
    let (a, b) = (a.to_vec(), b.to_vec());
    if let Some(theta) = &theta {
        let mut s1v = vec![];
        let mut s2v = vec![];
        let mut p = vec![];
        for &t in theta {
            let mu = t.to_radians().cos();
            let (s1, s2) = mie::amplitudes(&a, &b, mu);
            s1v.push(json!([s1.re, s1.im]));
            s2v.push(json!([s2.re, s2.im]));
            p.push(json!(mie::phase_function(&a, &b, mu)));
        }
        out.insert("theta_deg".into(), json!(theta));
        out.insert("s1".into(), Value::Array(s1v));
        out.insert("s2".into(), Value::Array(s2v));
        out.insert("phase_per_sr".into(), Value::Array(p));
    }
    if let Some(path) = &args.plot {
        let th: Vec<f64> = (0..=720).map(|i| i as f64 * 0.25).collect();
        let p: Vec<f64> = th.iter().map(|t| mie::phase_function(&a, &b, t.to_radians().cos())).collect();
        let title = format!("Lorenz–Mie phase function, x = {:.4}, m = {:.4}{:+.2e}i, g = {:.4}", x.re, m.re, m.im, eff.g);
        write_svg(path, &polar_log_svg(&th, &p, &title))?;
    }
    if args.json {
        println!("{}", Value::Object(out));
    } else {
        println!("{:<8} {:>14}", "x", sig(x.re, 7));
        if x.im != 0.0 {
            println!("{:<8} {:>14}", "x_im", sig(x.im, 7));
        }
        let m_im = if m.im == 0.0 { String::new() } else { format!("{}{}i", if m.im < 0.0 { "-" } else { "+" }, sig(m.im.abs(), 7)) };
        println!("{:<8} {:>14}{m_im}", "m", sig(m.re, 7));
        println!("{:<8} {:>14}", "terms", eff.terms);
        for (k, unit) in [("qext", ""), ("qsca", ""), ("qabs", ""), ("qback", ""), ("g", ""), ("c_ext_m2", " m²"), ("c_sca_m2", " m²"), ("c_abs_m2", " m²")] {
            if let Some(v) = out.get(k) {
                println!("{k:<8} {:>14}{unit}", sig(v.as_f64().unwrap_or(f64::NAN), 7));
            }
        }
        if let Some(theta) = &theta {
            println!("{:>10} {:>14} {:>14} {:>14} {:>14} {:>14}", "theta_deg", "s1_re", "s1_im", "s2_re", "s2_im", "phase_per_sr");
            for &t in theta {
                let mu = t.to_radians().cos();
                let (s1, s2) = mie::amplitudes(&a, &b, mu);
                let p = mie::phase_function(&a, &b, mu);
                println!("{:>10} {:>14} {:>14} {:>14} {:>14} {:>14}", sig(t, 6), sig(s1.re, 7), sig(s1.im, 7), sig(s2.re, 7), sig(s2.im, 7), sig(p, 7));
            }
        }
    }
    Ok(())
}

/// Write `text` to `path` atomically (temporary name in the same folder, then rename).
pub(crate) fn write_svg(path: &Path, text: &str) -> Result<()> {
    let file_name = path.file_name().ok_or_else(|| anyhow!("--plot: {} is not a file name", path.display()))?;
    let tmp = path.with_file_name(format!("{}.tmp-{}", file_name.to_string_lossy(), std::process::id()));
    std::fs::write(&tmp, text).with_context(|| format!("--plot: cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("--plot: cannot rename to {}", path.display()))?;
    Ok(())
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Polar plot of a phase function, radius ∝ log10 p over the decades shown, both halves mirrored.
pub(crate) fn polar_log_svg(theta_deg: &[f64], p: &[f64], title: &str) -> String {
    let pmax = p.iter().cloned().fold(f64::MIN, f64::max).max(1e-300);
    let pmin_data = p.iter().cloned().filter(|v| *v > 0.0).fold(f64::MAX, f64::min);
    let top = pmax.log10().ceil();
    let bottom = (pmin_data.log10().floor()).max(top - 8.0).min(top - 1.0);
    let (cx, cy, rmax) = (360.0, 330.0, 270.0);
    let rad = |v: f64| ((v.max(1e-300).log10() - bottom) / (top - bottom)).clamp(0.0, 1.0) * rmax;
    let mut s = String::new();
    let _ = writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="720" height="660" viewBox="0 0 720 660" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(s, r#"<rect width="720" height="660" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="360" y="24" text-anchor="middle" font-size="14">{}</text>"#, esc(title));
    for d in 0..=((top - bottom) as i32) {
        let r = d as f64 / (top - bottom) * rmax;
        let _ = writeln!(s, r##"<circle cx="{cx}" cy="{cy}" r="{r:.2}" fill="none" stroke="#ccc"/>"##);
        let _ = writeln!(s, r##"<text x="{:.1}" y="{:.1}" fill="#666">1e{}</text>"##, cx + 3.0, cy - r - 2.0, bottom as i32 + d);
    }
    for a in (0..360).step_by(30) {
        let t = (a as f64).to_radians();
        let _ = writeln!(s, r##"<line x1="{cx}" y1="{cy}" x2="{:.1}" y2="{:.1}" stroke="#eee"/>"##, cx + rmax * t.cos(), cy - rmax * t.sin());
        if a <= 180 {
            let _ = writeln!(s, r##"<text x="{:.1}" y="{:.1}" text-anchor="middle" fill="#666">{a}°</text>"##, cx + (rmax + 16.0) * t.cos(), cy - (rmax + 16.0) * t.sin() + 4.0);
        }
    }
    for sign in [1.0, -1.0] {
        let mut path = String::new();
        for (k, (&t, &v)) in theta_deg.iter().zip(p).enumerate() {
            let r = rad(v);
            let tr = t.to_radians();
            let _ = write!(path, "{}{:.2},{:.2} ", if k == 0 { "M" } else { "L" }, cx + r * tr.cos(), cy - sign * r * tr.sin());
        }
        let _ = writeln!(s, r##"<path d="{path}" fill="none" stroke="#c03" stroke-width="1.5"/>"##);
    }
    let _ = writeln!(s, r##"<text x="360" y="645" text-anchor="middle" fill="#333">p(θ) per sr, log scale; light travels from left to right (θ = 0° forward)</text>"##);
    s.push_str("</svg>\n");
    s
}

/// Line plots of spectra: one panel per (name, unit, log-scale, series) group, x = wavelength in nm.
/// One panel of [`spectra_svg`]: axis label, log scale?, named series.
pub(crate) type Panel<'a> = (&'a str, bool, Vec<(&'a str, Vec<f64>)>);

pub(crate) fn spectra_svg(lambda_nm: &[f64], panels: &[Panel], title: &str) -> String {
    let colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e"];
    let (w, ph, left, right, top0) = (720.0, 260.0, 80.0, 160.0, 40.0);
    let height = top0 + panels.len() as f64 * (ph + 50.0) + 10.0;
    let mut s = String::new();
    let _ = writeln!(s, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{height}" viewBox="0 0 {w} {height}" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(s, r#"<rect width="{w}" height="{height}" fill="white"/>"#);
    let _ = writeln!(s, r#"<text x="{}" y="22" text-anchor="middle" font-size="14">{}</text>"#, w / 2.0, esc(title));
    let (lmin, lmax) = (lambda_nm.iter().cloned().fold(f64::MAX, f64::min), lambda_nm.iter().cloned().fold(f64::MIN, f64::max));
    let lspan = if lmax > lmin { lmax - lmin } else { 1.0 };
    let pw = w - left - right;
    for (pi, (label, log, series)) in panels.iter().enumerate() {
        let y0 = top0 + pi as f64 * (ph + 50.0);
        let tf = |v: f64| if *log { v.max(1e-300).log10() } else { v };
        let vals: Vec<f64> = series.iter().flat_map(|(_, v)| v.iter().cloned()).filter(|v| v.is_finite() && (!*log || *v > 0.0)).map(tf).collect();
        let (mut vmin, mut vmax) = (vals.iter().cloned().fold(f64::MAX, f64::min), vals.iter().cloned().fold(f64::MIN, f64::max));
        if *log {
            vmin = vmin.floor();
            vmax = vmax.ceil().max(vmin + 1.0);
        } else {
            if vmax.is_nan() || vmax <= vmin {
                vmax = vmin + 1.0;
            }
            let pad = 0.05 * (vmax - vmin);
            vmin -= pad;
            vmax += pad;
        }
        if !vmin.is_finite() || !vmax.is_finite() {
            vmin = 0.0;
            vmax = 1.0;
        }
        let px = |l: f64| left + (l - lmin) / lspan * pw;
        let py = |v: f64| y0 + ph - (tf(v) - vmin) / (vmax - vmin) * ph;
        let _ = writeln!(s, r##"<rect x="{left}" y="{y0}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##);
        let _ = writeln!(s, r##"<text x="20" y="{:.1}" transform="rotate(-90 20 {:.1})" text-anchor="middle">{}</text>"##, y0 + ph / 2.0, y0 + ph / 2.0, esc(label));
        // y ticks
        let nt = if *log { (vmax - vmin) as usize } else { 5 };
        for k in 0..=nt {
            let tv = vmin + (vmax - vmin) * k as f64 / nt as f64;
            let y = y0 + ph - (tv - vmin) / (vmax - vmin) * ph;
            let txt = if *log { format!("1e{}", tv.round() as i32) } else { format!("{tv:.3}") };
            let _ = writeln!(s, r##"<line x1="{left}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#eee"/><text x="{:.1}" y="{:.1}" text-anchor="end">{txt}</text>"##, left + pw, left - 4.0, y + 4.0);
        }
        // x ticks every 50 nm
        let mut l = (lmin / 50.0).ceil() * 50.0;
        while l <= lmax + 1e-9 {
            let x = px(l);
            let _ = writeln!(s, r##"<line x1="{x:.1}" y1="{y0}" x2="{x:.1}" y2="{:.1}" stroke="#eee"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{l}</text>"##, y0 + ph, y0 + ph + 16.0);
            l += 50.0;
        }
        let _ = writeln!(s, r##"<text x="{:.1}" y="{:.1}" text-anchor="middle">wavelength [nm]</text>"##, left + pw / 2.0, y0 + ph + 34.0);
        for (si, (name, v)) in series.iter().enumerate() {
            let c = colors[si % colors.len()];
            let mut path = String::new();
            let mut first = true;
            for (&l, &y) in lambda_nm.iter().zip(v) {
                if !y.is_finite() || (*log && y <= 0.0) {
                    first = true;
                    continue;
                }
                let _ = write!(path, "{}{:.2},{:.2} ", if first { "M" } else { "L" }, px(l), py(y));
                first = false;
            }
            let _ = writeln!(s, r##"<path d="{path}" fill="none" stroke="{c}" stroke-width="2"/>"##);
            for (&l, &y) in lambda_nm.iter().zip(v) {
                if y.is_finite() && (!*log || y > 0.0) {
                    let _ = writeln!(s, r##"<circle cx="{:.2}" cy="{:.2}" r="2.5" fill="{c}"/>"##, px(l), py(y));
                }
            }
            let ly = y0 + 16.0 + si as f64 * 18.0;
            let _ = writeln!(s, r##"<line x1="{:.1}" y1="{ly:.1}" x2="{:.1}" y2="{ly:.1}" stroke="{c}" stroke-width="2"/><text x="{:.1}" y="{:.1}">{}</text>"##, left + pw + 10.0, left + pw + 30.0, left + pw + 34.0, ly + 4.0, esc(name));
        }
    }
    s.push_str("</svg>\n");
    s
}
