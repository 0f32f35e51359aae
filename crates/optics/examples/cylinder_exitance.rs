//! Where does light injected at one surface point of a finite milk cylinder leave it?
//!
//! Compares, for a pencil beam at normal incidence on the milk column of scenes/milk-glass.toml
//! (radius 32.45 mm, 6.05 ≤ y ≤ 75 mm, η = 1.35), the exitance of the corrected directional dipole
//! (`DirectionalLineDipole`, evaluated pairwise exactly as the renderer does, π·S_d·4C_φ(1/η) per
//! unit power entering) integrated over the real closed surface, face by face and in distance
//! bins, with an analogue Monte Carlo random walk in the same cylinder (Fresnel boundary, isotropic
//! scattering with the reduced coefficient σ'_s = σ_s(1 − g) — the similarity relation, which is
//! what the dipole sees — and absorption σ_a). Also the same two on a half-space (the dipole's own
//! geometry), as the baseline of the model's error.
//!
//!   cargo run --release -p optics --example cylinder_exitance -- [FAT_PERCENT] [PHOTONS]
#![allow(clippy::needless_range_loop)]

use optics::bssrdf::{c_phi, gauss_legendre, DirectionalLineDipole, OpticalProperties};
use std::f64::consts::PI;

type V3 = [f64; 3];

const R: f64 = 32.45; // mm
const Y0: f64 = 6.05;
const Y1: f64 = 75.0;
const ETA: f64 = 1.35;
/// Distance bins (mm) from the source.
const DBINS: [f64; 8] = [0.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0, 1e9];
const FACES: [&str; 3] = ["top", "side", "bottom"];

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        // splitmix64
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
}

fn dbin(d: f64) -> usize {
    DBINS.windows(2).position(|w| d >= w[0] && d < w[1]).unwrap_or(DBINS.len() - 2)
}

fn dist(a: V3, b: V3) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Quadrature points on [a, b] with panels graded geometrically towards c (smallest h0).
fn graded(a: f64, b: f64, c: f64, h0: f64, gl: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let c = c.clamp(a, b);
    let mut br = vec![a, b, c];
    let mut h = h0;
    while h < (b - a) {
        br.push(c + h);
        br.push(c - h);
        h *= 1.6;
    }
    let mut br: Vec<f64> = br.into_iter().filter(|x| *x >= a && *x <= b).collect();
    br.sort_by(|x, y| x.total_cmp(y));
    br.dedup_by(|x, y| (*x - *y).abs() < 1e-12);
    let mut pts = Vec::new();
    for w in br.windows(2) {
        let (m, hl) = (0.5 * (w[0] + w[1]), 0.5 * (w[1] - w[0]));
        for &(x, wt) in gl {
            pts.push((m + hl * x, wt * hl));
        }
    }
    pts
}

/// Exitance of the dipole (per unit power entering, mm⁻² → summed over bins) over the closed
/// cylinder: [face][distance bin] fractions of the entering power.
fn dipole_cylinder(m: &DirectionalLineDipole, xs: V3, ns: V3) -> [[f64; 7]; 3] {
    let gl = gauss_legendre(8);
    let mut out = [[0.0; 7]; 3];
    let k = PI * 4.0 * c_phi(1.0 / ETA);
    let mm = |v: V3| [v[0] * 1e-3, v[1] * 1e-3, v[2] * 1e-3];
    let (xi, ni) = (mm(xs), ns);
    let eval = |xo: V3, no: V3| m.sd(xi, ni, ni, mm(xo), no) * 1e-6 * k; // per mm²
    let th_s = xs[2].atan2(xs[0]);
    let r_s = xs[0].hypot(xs[2]);
    let h0 = 0.01;
    // Disks.
    for (f, y, ny) in [(0usize, Y1, 1.0), (2usize, Y0, -1.0)] {
        let rs = graded(0.0, R, r_s, h0, &gl);
        for &(r, wr) in &rs {
            let hth = if r > 0.0 { h0 / r.max(h0) } else { 1.0 };
            let ths = graded(th_s - PI, th_s + PI, th_s, hth, &gl);
            for &(th, wt) in &ths {
                let xo = [r * th.cos(), y, r * th.sin()];
                let v = eval(xo, [0.0, ny, 0.0]) * r * wr * wt;
                out[f][dbin(dist(xo, xs))] += v;
            }
        }
    }
    // Side, unrolled: (θ, y), dA = R dθ dy.
    let ys = graded(Y0, Y1, xs[1], h0, &gl);
    let ths = graded(th_s - PI, th_s + PI, th_s, h0 / R, &gl);
    for &(y, wy) in &ys {
        for &(th, wt) in &ths {
            let no = [th.cos(), 0.0, th.sin()];
            let xo = [R * no[0], y, R * no[2]];
            let v = eval(xo, no) * R * wy * wt;
            out[1][dbin(dist(xo, xs))] += v;
        }
    }
    out
}

/// Quarter-space ("wedge") image solution for a source near an edge: the line of monopoles along
/// −n_s with its image in the source's extrapolated plane (height A·d_e, as in the dipole), and
/// both mirrored in a second perpendicular boundary plane {x·n2 = c2} moved out by A·d_e, with
/// opposite sign (the four-image solution of the diffusion equation in a right-angle wedge with
/// zero fluence on both extrapolated planes). Exitance per mm² per unit power entering, same
/// normalisation and exitance formula (C_φ φ + C_E E·n_o) as `DirectionalLineDipole`.
fn wedge(m: &DirectionalLineDipole, xs: V3, ns: V3, n2: V3, c2: f64, xo: V3, no: V3) -> f64 {
    let b = &m.base;
    let k = PI * 4.0 * c_phi(1.0 / ETA);
    let zb = b.a * b.d_e_m * 1e3; // mm
    let st = b.props.sigma_tr_per_m * 1e-3;
    let d = b.props.d_m * 1e3;
    let dot = |a: V3, c: V3| a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    let mirror = |p: V3, n: V3, c: f64| {
        let s = 2.0 * (c - dot(p, n));
        [p[0] + s * n[0], p[1] + s * n[1], p[2] + s * n[2]]
    };
    let c1 = dot(xs, ns) + zb;
    let c2 = c2 + zb;
    let mono = |src: V3| {
        let x = [xo[0] - src[0], xo[1] - src[1], xo[2] - src[2]];
        let d2 = dot(x, x).max(1e-12);
        let r = d2.sqrt();
        (-st * r).exp() / (d2 * r) * (b.c_phi / d * d2 + b.c_e * (1.0 + st * r) * dot(x, no))
    };
    let mut s = 0.0;
    for &(tk, wk) in &m.nodes {
        let t = tk * 1e3;
        let p = [xs[0] - t * ns[0], xs[1] - t * ns[1], xs[2] - t * ns[2]];
        let p1 = mirror(p, ns, c1);
        let p2 = mirror(p, n2, c2);
        let p12 = mirror(p1, n2, c2);
        s += wk * (mono(p) - mono(p1) - mono(p2) + mono(p12));
    }
    // b.norm is per m² with lengths in m; here lengths are mm: S_d[mm⁻²] = norm · (mm-terms).
    (s * b.norm).max(0.0) * k
}

/// [`wedge`] integrated over the top and side faces, binned as [`dipole_cylinder`].
fn wedge_cylinder(m: &DirectionalLineDipole, xs: V3, ns: V3, n2: V3, c2: f64) -> [[f64; 7]; 3] {
    let gl = gauss_legendre(8);
    let mut out = [[0.0; 7]; 3];
    let th_s = xs[2].atan2(xs[0]);
    let r_s = xs[0].hypot(xs[2]);
    let h0 = 0.01;
    for (f, y, ny) in [(0usize, Y1, 1.0), (2usize, Y0, -1.0)] {
        for &(r, wr) in &graded(0.0, R, r_s, h0, &gl) {
            let hth = if r > 0.0 { h0 / r.max(h0) } else { 1.0 };
            for &(th, wt) in &graded(th_s - PI, th_s + PI, th_s, hth, &gl) {
                let xo = [r * th.cos(), y, r * th.sin()];
                out[f][dbin(dist(xo, xs))] += wedge(m, xs, ns, n2, c2, xo, [0.0, ny, 0.0]) * r * wr * wt;
            }
        }
    }
    for &(y, wy) in &graded(Y0, Y1, xs[1], h0, &gl) {
        for &(th, wt) in &graded(th_s - PI, th_s + PI, th_s, h0 / R, &gl) {
            let no = [th.cos(), 0.0, th.sin()];
            let xo = [R * no[0], y, R * no[2]];
            out[1][dbin(dist(xo, xs))] += wedge(m, xs, ns, n2, c2, xo, no) * R * wy * wt;
        }
    }
    out
}

/// Dipole on the half-space (the plane of the source), binned by distance.
fn dipole_halfspace(m: &DirectionalLineDipole) -> [f64; 7] {
    let gl = gauss_legendre(8);
    let k = PI * 4.0 * c_phi(1.0 / ETA);
    let n = [0.0, 0.0, 1.0];
    let mut out = [0.0; 7];
    for &(r, wr) in &graded(0.0, 2000.0, 0.0, 0.01, &gl) {
        let v = m.sd([0.0; 3], n, n, [r * 1e-3, 0.0, 0.0], n) * 1e-6 * k * 2.0 * PI * r * wr;
        out[dbin(r)] += v;
    }
    out
}

/// Monte Carlo: pencil beam at normal incidence into the cylinder (or the half-space y < Y1 when
/// `half`), isotropic scattering σ'_s, absorption σ_a (mm⁻¹), Fresnel boundary of index η.
fn mc(xs: V3, ns: V3, sps: f64, sa: f64, half: bool, photons: u64, seed: u64) -> ([[f64; 7]; 3], f64) {
    let mut rng = Rng(seed);
    let mut out = [[0.0; 7]; 3];
    let st = sps + sa;
    let alb = sps / st;
    let mut steps = 0u64;
    for _ in 0..photons {
        let mut p = xs;
        let mut d = [-ns[0], -ns[1], -ns[2]];
        let mut w = 1.0f64;
        loop {
            let s = -(rng.next()).ln() / st;
            // Distance to the boundary along d.
            let mut tb = f64::INFINITY;
            let mut face = 0usize;
            let mut nrm = [0.0, 1.0, 0.0];
            if d[1] > 0.0 {
                let t = (Y1 - p[1]) / d[1];
                if t < tb {
                    tb = t;
                    face = 0;
                    nrm = [0.0, 1.0, 0.0];
                }
            }
            if !half {
                if d[1] < 0.0 {
                    let t = (Y0 - p[1]) / d[1];
                    if t < tb {
                        tb = t;
                        face = 2;
                        nrm = [0.0, -1.0, 0.0];
                    }
                }
                let a = d[0] * d[0] + d[2] * d[2];
                if a > 1e-18 {
                    let b = p[0] * d[0] + p[2] * d[2];
                    let c = p[0] * p[0] + p[2] * p[2] - R * R;
                    let disc = (b * b - a * c).max(0.0);
                    let t = (-b + disc.sqrt()) / a;
                    if t < tb {
                        tb = t.max(0.0);
                        face = 1;
                        let q = [p[0] + t * d[0], p[2] + t * d[2]];
                        let l = q[0].hypot(q[1]);
                        nrm = [q[0] / l, 0.0, q[1] / l];
                    }
                }
            }
            if s < tb {
                for k in 0..3 {
                    p[k] += s * d[k];
                }
                w *= alb;
                // isotropic
                let z = 2.0 * rng.next() - 1.0;
                let phi = 2.0 * PI * rng.next();
                let sxy = (1.0 - z * z).max(0.0).sqrt();
                d = [sxy * phi.cos(), z, sxy * phi.sin()];
                steps += 1;
                if w < 1e-3 {
                    if rng.next() < 0.1 {
                        w *= 10.0;
                    } else {
                        break;
                    }
                }
            } else {
                for k in 0..3 {
                    p[k] += tb * d[k];
                }
                let cos = d[0] * nrm[0] + d[1] * nrm[1] + d[2] * nrm[2];
                let f = optics::fresnel::fresnel_dielectric(cos, 1.0 / ETA);
                if rng.next() < f {
                    for k in 0..3 {
                        d[k] -= 2.0 * cos * nrm[k];
                    }
                    // Keep the point on the boundary (numerically inside).
                    for k in 0..3 {
                        p[k] -= 1e-9 * nrm[k];
                    }
                } else {
                    out[face][dbin(dist(p, xs))] += w;
                    break;
                }
            }
        }
    }
    for f in out.iter_mut() {
        for v in f.iter_mut() {
            *v /= photons as f64;
        }
    }
    (out, steps as f64 / photons as f64)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let fat: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0.1);
    let photons: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20000);
    let lambda = [650.0, 550.0, 450.0];
    let b = optics::milk::milk_properties(fat, 3.4, 20.0, &lambda).expect("milk");
    let sources: [(&str, V3, V3); 4] = [
        ("top centre", [0.0, Y1, 0.0], [0.0, 1.0, 0.0]),
        ("top, 3 mm from rim", [R - 3.0, Y1, 0.0], [0.0, 1.0, 0.0]),
        ("side middle", [R, 0.5 * (Y0 + Y1), 0.0], [1.0, 0.0, 0.0]),
        ("side, 5 mm below top", [R, Y1 - 5.0, 0.0], [1.0, 0.0, 0.0]),
    ];
    println!("milk {fat} % fat; η = {ETA}; pencil beam, normal incidence; {photons} photons per MC run");
    println!("fractions of the power entering that leave through each face (dipole: π·S_d·4C_φ(1/η) integrated)");
    for (c, name) in ["R 650", "G 550", "B 450"].iter().enumerate() {
        let p = OpticalProperties {
            eta: ETA,
            sigma_s_per_m: b.sigma_s_per_m[c],
            sigma_a_per_m: b.sigma_a_per_m[c],
            g: b.g[c],
        };
        let m = DirectionalLineDipole::new(&p).unwrap();
        let pr = m.base.props;
        let (sps, sa) = (pr.sigma_s_prime_per_m * 1e-3, pr.sigma_a_per_m * 1e-3);
        println!(
            "\n== {name} nm: σ'_s = {sps:.4} /mm, σ_a = {sa:.5} /mm, g = {:.3}, α' = {:.5}, 1/σ_tr = {:.1} mm",
            p.g,
            pr.alpha_prime,
            1e3 / pr.sigma_tr_per_m
        );
        let hs = dipole_halfspace(&m);
        let (mch, steps) = mc([0.0, Y1, 0.0], [0.0, 1.0, 0.0], sps, sa, true, photons, 7 + c as u64);
        let hs_t: f64 = hs.iter().sum();
        let mch_t: f64 = mch[0].iter().sum();
        println!(
            "half-space: dipole {hs_t:.4}, MC {mch_t:.4} (dipole/MC {:.3}; {steps:.0} scatterings/photon)",
            hs_t / mch_t
        );
        println!("  by distance {DBINS:?} mm: dipole {:?}", hs.map(|v| (v * 1e4).round() / 1e4));
        println!("                          MC     {:?}", mch[0].map(|v| (v * 1e4).round() / 1e4));
        for (si, (sname, xs, ns)) in sources.iter().enumerate() {
            let dc = dipole_cylinder(&m, *xs, *ns);
            let (mcc, _) = mc(*xs, *ns, sps, sa, false, photons, 1000 + 10 * si as u64 + c as u64);
            let dt: f64 = dc.iter().flatten().sum();
            let mt: f64 = mcc.iter().flatten().sum();
            println!(
                "{sname}: total dipole {dt:.4} (×{:.3} its half-space), MC {mt:.4}; dipole/MC {:.3}",
                dt / hs_t,
                dt / mt
            );
            // Edge images: the side plane for a top source near the rim, the top plane for a side
            // source near the top.
            let edge = match si {
                1 => Some(([1.0, 0.0, 0.0], R)),
                3 => Some(([0.0, 1.0, 0.0], Y1)),
                _ => None,
            };
            if let Some((n2, c2)) = edge {
                let wc = wedge_cylinder(&m, *xs, *ns, n2, c2);
                let s = |a: &[f64; 7]| a.iter().sum::<f64>();
                println!(
                    "  wedge images: top {:.4} ({:+.1} % vs MC; dipole {:+.1} %), side {:.4} ({:+.1} % vs MC; dipole {:+.1} %)",
                    s(&wc[0]),
                    100.0 * (s(&wc[0]) / s(&mcc[0]) - 1.0),
                    100.0 * (s(&dc[0]) / s(&mcc[0]) - 1.0),
                    s(&wc[1]),
                    100.0 * (s(&wc[1]) / s(&mcc[1]) - 1.0),
                    100.0 * (s(&dc[1]) / s(&mcc[1]) - 1.0)
                );
                println!("    wedge top by distance {:?}\n    wedge side by distance {:?}", wc[0].map(|v| (v * 1e4).round() / 1e4), wc[1].map(|v| (v * 1e4).round() / 1e4));
            }
            for f in 0..3 {
                let (a, b): (f64, f64) = (dc[f].iter().sum(), mcc[f].iter().sum());
                println!(
                    "  {:6} dipole {a:.4} MC {b:.4} | by distance dipole {:?}\n  {:6}                          MC     {:?}",
                    FACES[f],
                    dc[f].map(|v| (v * 1e4).round() / 1e4),
                    "",
                    mcc[f].map(|v| (v * 1e4).round() / 1e4)
                );
            }
        }
    }
}
