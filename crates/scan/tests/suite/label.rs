//! Micropolygon labelling (`scan::label`) against known truth: Meyer's watershed on constructed
//! images whose basins are known (walls between plateaus; cones whose basins are the Voronoi
//! cells of their apexes), k-means on separated clusters, the subdivision's edge bound and area,
//! a plane labelled from its own render (every micropolygon exact away from texture edges), and a
//! board with three albedos and a sphere rendered with noise and 8-bit quantisation (area-weighted
//! accuracy and IoU per label against the truth of an analytic ray cast).

use std::collections::{HashMap, HashSet};
use std::path::Path;

use render::integrator::{render_pass, IntegratorKind, IntegratorSettings};
use render::scene::Scene;
use scan::calib::DeviceCalibration;
use scan::label::io::write_ply;
use scan::label::segment::{kmeans, markers, watershed, BOUNDARY, UNREACHED};
use scan::label::{label, LabelOptions, Mesh, Photo};

use crate::common::{scratch, Pcg};

/// Five rectangular plateaus (gradient 0.1 + a ripple) separated by one-pixel walls of
/// gradient 1, one single-pixel marker each: every plateau pixel joins its marker's basin, every
/// wall pixel between two basins is a boundary, a wall pixel touching one basin joins it, and
/// the wall crossings (all four neighbours walls) are never reached.
#[test]
fn watershed_fills_walled_plateaus_exactly() {
    let (w, h) = (61usize, 41usize);
    let wall_x = |x: usize| x == 20 || x == 40;
    let wall_y = |x: usize, y: usize| y == 20 && x < 40;
    let basin = |x: usize, y: usize| -> i32 {
        match (x < 20, x < 40, y < 20) {
            (true, _, true) => 1,
            (true, _, false) => 2,
            (false, true, true) => 3,
            (false, true, false) => 4,
            _ => 5,
        }
    };
    let mut g = vec![0f32; w * h];
    let mut mk = vec![0i32; w * h];
    for y in 0..h {
        for x in 0..w {
            let wall = wall_x(x) || wall_y(x, y);
            g[y * w + x] = if wall { 1.0 } else { 0.1 + 0.004 * ((x * 7 + y * 3) % 50) as f32 };
        }
    }
    for (x, y) in [(5, 5), (10, 30), (30, 3), (25, 35), (55, 20)] {
        mk[y * w + x] = basin(x, y);
    }
    let lab = watershed(&g, w, h, &mk);
    for y in 0..h {
        for x in 0..w {
            let l = lab[y * w + x];
            let wall = wall_x(x) || wall_y(x, y);
            // A wall pixel joins the basins among its plateau neighbours: none (a crossing of
            // walls) leaves it unreached, one takes it in, two or more make it a boundary.
            let mut near: Vec<i32> = [(x.wrapping_sub(1), y), (x + 1, y), (x, y.wrapping_sub(1)), (x, y + 1)]
                .iter()
                .filter(|&&(a, b)| a < w && b < h && !(wall_x(a) || wall_y(a, b)))
                .map(|&(a, b)| basin(a, b))
                .collect();
            near.sort();
            near.dedup();
            let expect = match (wall, near.len()) {
                (false, _) => basin(x, y),
                (true, 0) => UNREACHED,
                (true, 1) => near[0],
                (true, _) => BOUNDARY,
            };
            assert_eq!(l, expect, "pixel ({x}, {y})");
        }
    }
}

/// Cones g(p) = min_k |p − c_k| flooded from their apexes: the basins are the Voronoi cells of
/// the apexes; every pixel nearer one apex than any other by more than 3 px gets that apex's
/// basin (the 4-connected flood meets within a pixel or two of the true cell edge, more near the
/// triple points), and every pixel is either labelled or a boundary.
#[test]
fn watershed_basins_of_cones_are_voronoi_cells() {
    let (w, h) = (120usize, 90usize);
    let apex = [(20.0, 15.0), (95.0, 20.0), (60.0, 70.0), (15.0, 80.0), (70.0, 40.0)];
    let dist = |x: usize, y: usize, k: usize| ((x as f64 - apex[k].0).powi(2) + (y as f64 - apex[k].1).powi(2)).sqrt();
    let mut g = vec![0f32; w * h];
    let mut mk = vec![0i32; w * h];
    for y in 0..h {
        for x in 0..w {
            g[y * w + x] = (0..apex.len()).map(|k| dist(x, y, k)).fold(f64::INFINITY, f64::min) as f32;
        }
    }
    for (k, &(x, y)) in apex.iter().enumerate() {
        mk[y as usize * w + x as usize] = k as i32 + 1;
    }
    let lab = watershed(&g, w, h, &mk);
    let mut checked = 0;
    for y in 0..h {
        for x in 0..w {
            let mut d: Vec<(f64, usize)> = (0..apex.len()).map(|k| (dist(x, y, k), k)).collect();
            d.sort_by(|a, b| a.0.total_cmp(&b.0));
            let l = lab[y * w + x];
            assert!(l == BOUNDARY || (1..=5).contains(&l), "pixel ({x}, {y}): {l}");
            if d[1].0 - d[0].0 > 3.0 {
                assert_eq!(l, d[0].1 as i32 + 1, "pixel ({x}, {y})");
                checked += 1;
            }
        }
    }
    assert!(checked > w * h * 8 / 10, "{checked}");
}

/// Markers are the 4-connected components of the flat mask after erosion by a square; components
/// smaller than the minimum are dropped.
#[test]
fn markers_are_eroded_components() {
    let (w, h) = (30usize, 20usize);
    // Two 8×8 squares, a 3×3 square, and a thin line.
    let mut flat = vec![false; w * h];
    let mut set = |x0: usize, y0: usize, sx: usize, sy: usize| {
        for y in y0..y0 + sy {
            for x in x0..x0 + sx {
                flat[y * w + x] = true;
            }
        }
    };
    set(1, 1, 8, 8);
    set(12, 2, 8, 8);
    set(24, 10, 3, 3);
    set(0, 15, 30, 1);
    let (m, n) = markers(&flat, w, h, 1, 5);
    // Erosion by 1 leaves 6×6 and 6×6 and 1×1 (dropped: under 5 px) and removes the line.
    assert_eq!(n, 2);
    let count = |id: i32| m.iter().filter(|&&v| v == id).count();
    assert_eq!((count(1), count(2)), (36, 36));
    assert_eq!(m[2 * w + 2], 1);
    assert_eq!(m[3 * w + 13], 2);
    assert_eq!(m[w + 1], 0);
}

/// k-means gives a colour shown only by several small regions (four printed markers, each under
/// 1 % of the heaviest region's pixels, together above) a cluster of its own, and no cluster to
/// a lone speck farther away (0.3 % of the heaviest region).
#[test]
fn kmeans_seeds_a_colour_of_several_small_regions_but_not_a_speck() {
    let mut rng = Pcg::new(5);
    let (mut pts, mut wts, mut truth) = (Vec::new(), Vec::new(), Vec::new());
    for (c, (centre, w, n)) in [([50.0, 0.0, 0.0], 100.0, 20), ([80.0, -30.0, 30.0], 50.0, 20), ([10.0, 0.0, 0.0], 0.4, 4)].into_iter().enumerate() {
        for _ in 0..n {
            pts.push(centre.map(|v: f64| v + 2.0 * rng.normal()));
            wts.push(w);
            truth.push(c);
        }
    }
    pts.push([0.0, 80.0, 0.0]);
    wts.push(0.3);
    let (a, _) = kmeans(&pts, &wts, 3);
    for i in 0..truth.len() {
        for j in 0..truth.len() {
            assert_eq!(a[i] == a[j], truth[i] == truth[j], "points {i} and {j}: {a:?}");
        }
    }
}

/// k-means on three well-separated weighted clusters finds them, with the heaviest first.
#[test]
fn kmeans_finds_separated_clusters() {
    let mut rng = Pcg::new(3);
    let centres = [[50.0, 0.0, 0.0], [20.0, 40.0, -10.0], [80.0, -30.0, 30.0]];
    let mut pts = Vec::new();
    let mut wts = Vec::new();
    let mut truth = Vec::new();
    for i in 0..90 {
        let c = i % 3;
        pts.push(centres[c].map(|v| v + 2.0 * rng.normal()));
        wts.push(if c == 1 { 10.0 } else { 1.0 });
        truth.push(c);
    }
    let (a, rms) = kmeans(&pts, &wts, 3);
    assert_eq!(a[1], 0, "the heaviest cluster is label 0");
    for i in 0..90 {
        for j in 0..90 {
            assert_eq!(a[i] == a[j], truth[i] == truth[j]);
        }
    }
    assert!(rms < 4.0, "{rms}");
}

fn camera(width: u32, height: u32, f: f64, dist: [f64; 5]) -> DeviceCalibration {
    DeviceCalibration { width, height, fx: f, fy: f * 1.002, cx: width as f64 / 2.0 - 0.3, cy: height as f64 / 2.0 + 0.4, distortion: dist.to_vec(), rms_px: 0.0 }
}

fn camera_toml(c: &DeviceCalibration) -> String {
    let d = &c.distortion;
    format!(
        "unit = \"mm\"\n[camera]\nmodel = \"opencv\"\nwidth = {}\nheight = {}\nfx = {:?}\nfy = {:?}\ncx = {:?}\ncy = {:?}\ndist = [{:?}, {:?}, {:?}, {:?}, {:?}]\nR = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\nt = [0, 0, 0]\n\n[integrator]\ntype = \"direct\"\n\n",
        c.width, c.height, c.fx, c.fy, c.cx, c.cy, d[0], d[1], d[2], d[3], d[4]
    )
}

/// Linear sRGB of `spp` passes of a scene, optionally with Gaussian noise of `sigma` and 8-bit
/// sRGB quantisation (a sensor).
fn render(text: &str, dir: &Path, spp: u32, sensor: Option<(f64, u64)>) -> Photo {
    let scene = Scene::from_toml_str(text, "label test", dir).unwrap();
    let (w, h) = scene.resolution();
    let n = (w * h) as usize;
    let settings = IntegratorSettings { kind: IntegratorKind::Direct, max_depth: 2, rr_depth: 5 };
    let mut buf = vec![[0f32; 3]; n];
    let mut sum = vec![[0f64; 3]; n];
    for pass in 0..spp {
        render_pass(&scene, &settings, 7, pass as u64, &mut buf);
        for (s, x) in sum.iter_mut().zip(&buf) {
            for c in 0..3 {
                s[c] += x[c] as f64 / spp as f64;
            }
        }
    }
    let mut rng = Pcg::new(sensor.map_or(0, |s| s.1));
    let rgb = sum
        .iter()
        .map(|&xyz| {
            let lin = optics::color::xyz_to_linear_srgb(xyz);
            lin.map(|v| match sensor {
                Some((sigma, _)) => {
                    let y = (v + sigma * rng.normal()).clamp(0.0, 1.0);
                    let code = (optics::color::srgb_encode(y) * 255.0).round();
                    optics::color::srgb_decode(code / 255.0) as f32
                }
                None => v as f32,
            })
        })
        .collect();
    Photo { width: w as usize, height: h as usize, rgb }
}

fn quad_mesh(c: [[f64; 3]; 4]) -> Mesh {
    Mesh { positions: c.to_vec(), triangles: vec![[0, 1, 2], [0, 2, 3]] }
}

fn v3(p: [f64; 3]) -> String {
    format!("[{:?}, {:?}, {:?}]", p[0], p[1], p[2])
}

fn centroid(m: &Mesh, t: &[u32; 3]) -> [f64; 3] {
    let [a, b, c] = t.map(|v| m.positions[v as usize]);
    [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)
}

fn area(m: &Mesh, t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|v| m.positions[v as usize]);
    let (u, v) = ([0, 1, 2].map(|k| b[k] - a[k]), [0, 1, 2].map(|k| c[k] - a[k]));
    let x = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    0.5 * (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]).sqrt()
}

/// Projection of a camera-frame point with the camera's model (for truth bookkeeping).
fn project(c: &DeviceCalibration, p: [f64; 3]) -> [f64; 2] {
    let d = render::camera::Distortion::from_opencv(&c.distortion).unwrap();
    let (x, y) = d.distort(p[0] / p[2], p[1] / p[2]);
    [c.fx * x + c.cx, c.fy * y + c.cy]
}

fn edges_of(m: &Mesh) -> HashSet<(u32, u32)> {
    let mut edges = HashSet::new();
    for t in &m.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.insert((a.min(b), a.max(b)));
        }
    }
    edges
}

/// Dicing a tilted plane seen through a distorted lens bounds every projected edge by the limit
/// and keeps the surface area; every micropolygon of it inside the image is visible (nothing is
/// in front of it) and labelled. A square facing an undistorted camera dices its two triangles'
/// shared diagonal alike, so the result is conforming: a disc, V − E + F = 1.
#[test]
fn subdivision_bounds_edges_keeps_area_and_conforms() {
    let cam = camera(200, 150, 180.0, [-0.1, 0.02, 0.0, 0.0, 0.0]);
    let plane = quad_mesh([[-60.0, -40.0, 200.0], [60.0, -45.0, 230.0], [65.0, 45.0, 240.0], [-55.0, 40.0, 205.0]]);
    let photo = Photo { width: 200, height: 150, rgb: vec![[0.5; 3]; 200 * 150] };
    let opts = LabelOptions { max_edge_px: 1.0, ..LabelOptions::default() };
    let l = label(&plane, &photo, &cam, &opts).unwrap();
    let m = &l.mesh;
    let a0: f64 = plane.triangles.iter().map(|t| area(&plane, t)).sum();
    let a1: f64 = m.triangles.iter().map(|t| area(m, t)).sum();
    assert!((a1 / a0 - 1.0).abs() < 1e-9, "{a0} {a1}");
    let mut longest = 0f64;
    for (a, b) in edges_of(m) {
        let (p, q) = (project(&cam, m.positions[a as usize]), project(&cam, m.positions[b as usize]));
        longest = longest.max((p[0] - q[0]).hypot(p[1] - q[1]));
    }
    assert!(longest <= 1.0 + 1e-9, "longest projected edge {longest} px");
    assert!(longest > 0.8, "longest projected edge {longest} px: diced too finely");
    assert!(m.triangles.len() > 10_000, "{}", m.triangles.len());
    for (p, &lab) in l.face_pixel.iter().zip(&l.face_label) {
        assert_eq!(p.is_some(), lab >= 0);
    }
    assert!(l.face_label.iter().filter(|&&x| x >= 0).count() > m.triangles.len() / 2);

    let pinhole = camera(200, 150, 180.0, [0.0; 5]);
    let square = quad_mesh([[-50.0, -50.0, 300.0], [50.0, -50.0, 300.0], [50.0, 50.0, 300.0], [-50.0, 50.0, 300.0]]);
    let l = label(&square, &photo, &pinhole, &opts).unwrap();
    let m = &l.mesh;
    let euler = m.positions.len() as i64 - edges_of(m).len() as i64 + m.triangles.len() as i64;
    assert_eq!(euler, 1);
    assert!(m.triangles.len() > 5_000, "{}", m.triangles.len());
}

/// A plane (filling the view) with a 4 × 4 checkerboard of two albedos, under a constant environment, rendered
/// through a distorted OpenCV camera and labelled from that render into two labels: every
/// micropolygon whose centroid lies more than 3 pixel footprints from a checker edge (and inside
/// the image by 3 px) carries the label of its square's albedo.
#[test]
fn plane_labels_match_its_own_render() {
    let dir = scratch("label-plane");
    let cam = camera(160, 120, 150.0, [-0.08, 0.01, 3e-4, -2e-4, 0.0]);
    let c = [[-150.0, -115.0, 200.0], [150.0, -120.0, 215.0], [152.0, 112.0, 220.0], [-148.0, 117.0, 205.0]];
    let mut text = camera_toml(&cam);
    text += "[materials.check]\ntype = \"lambertian\"\nalbedo = { checkerboard = { squares = 4, even = 0.12, odd = 0.7 } }\n\n";
    text += &format!("[[objects]]\nname = \"plane\"\nmaterial = \"check\"\nquads = [[{}, {}, {}, {}]]\n\n", v3(c[0]), v3(c[1]), v3(c[2]), v3(c[3]));
    text += "[[lights]]\ntype = \"environment\"\nradiance = 1.0\n";
    let photo = render(&text, &dir, 16, None);
    let mesh = quad_mesh(c);
    let mut opts = LabelOptions::default();
    opts.segment.labels = Some(2);
    let l = label(&mesh, &photo, &cam, &opts).unwrap();
    assert_eq!(l.segmentation.labels, 2);
    // (u, v) of a point of the planar quad (bilinear inverse by Newton on the parallelogram part).
    let uv = |p: [f64; 3]| -> (f64, f64) {
        // The quad is near a parallelogram; solve p = c0 + u (c1 − c0) + v (c3 − c0) + u v (c2 − c1 − c3 + c0).
        let (mut u, mut v) = (0.5, 0.5);
        for _ in 0..30 {
            let q = [0, 1, 2].map(|k| c[0][k] + u * (c[1][k] - c[0][k]) + v * (c[3][k] - c[0][k]) + u * v * (c[2][k] - c[1][k] - c[3][k] + c[0][k]));
            let du = [0, 1, 2].map(|k| (c[1][k] - c[0][k]) + v * (c[2][k] - c[1][k] - c[3][k] + c[0][k]));
            let dv = [0, 1, 2].map(|k| (c[3][k] - c[0][k]) + u * (c[2][k] - c[1][k] - c[3][k] + c[0][k]));
            let r = [0, 1, 2].map(|k| p[k] - q[k]);
            // Least squares 2×2.
            let (a, b, d) = (dot(du, du), dot(du, dv), dot(dv, dv));
            let (e, f) = (dot(du, r), dot(dv, r));
            let det = a * d - b * b;
            u += (d * e - b * f) / det;
            v += (a * f - b * e) / det;
        }
        (u, v)
    };
    // A pixel footprint at 220 mm is 1.5 mm; the quad is 300 mm wide (squares of 75 mm).
    let margin = 3.0 * 220.0 / 150.0 / 300.0;
    let mut class_of_label: HashMap<i32, usize> = HashMap::new();
    let mut checked = 0;
    for (t, (&lab, px)) in l.mesh.triangles.iter().zip(l.face_label.iter().zip(&l.face_pixel)) {
        let p = centroid(&l.mesh, t);
        let q = project(&cam, p);
        if !(q[0] > 3.0 && q[1] > 3.0 && q[0] < 156.0 && q[1] < 116.0) {
            continue;
        }
        assert!(px.is_some());
        let (u, v) = uv(p);
        let (su, sv) = (u * 4.0, v * 4.0);
        if (su - su.round()).abs() < margin * 4.0 || (sv - sv.round()).abs() < margin * 4.0 {
            continue;
        }
        let class = (su.floor() as i64 + sv.floor() as i64).rem_euclid(2) as usize;
        let expect = *class_of_label.entry(lab).or_insert(class);
        assert_eq!(expect, class, "micropolygon at ({:.1}, {:.1}) px: label {lab}", q[0], q[1]);
        checked += 1;
    }
    assert_eq!(class_of_label.len(), 2, "{class_of_label:?}");
    assert!(checked > 10_000, "{checked}");
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A UV sphere of `n` × `n/2` segments (vertices on the sphere).
fn uv_sphere(centre: [f64; 3], r: f64, n: usize) -> Mesh {
    let mut m = Mesh::default();
    let rings = n / 2;
    for i in 0..=rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..n {
            let ph = std::f64::consts::TAU * j as f64 / n as f64;
            m.positions.push([centre[0] + r * th.sin() * ph.cos(), centre[1] + r * th.cos(), centre[2] + r * th.sin() * ph.sin()]);
        }
    }
    let id = |i: usize, j: usize| (i * n + j % n) as u32;
    for i in 0..rings {
        for j in 0..n {
            if i > 0 {
                m.triangles.push([id(i, j), id(i + 1, j), id(i, j + 1)]);
            }
            if i + 1 < rings {
                m.triangles.push([id(i, j + 1), id(i + 1, j), id(i + 1, j + 1)]);
            }
        }
    }
    m
}

/// The synthetic round trip's labels: a board of three Lambertian albedos (vertical stripes)
/// and a sphere in front of it, lit by a point light at the camera's centre (the sphere's shadow
/// falls behind it) and a constant ambient
/// environment, rendered through a distorted OpenCV camera with Gaussian noise (σ = 0.01) and
/// 8-bit sRGB quantisation. Truth per micropolygon: its class (stripe or sphere) and its
/// visibility by an analytic ray cast (board: the ray to the centroid misses the sphere; sphere:
/// front-facing), counted where its centroid projects inside the image. Each class's label is
/// the one holding most of its visible area, a different one for each class (the background seen
/// around the board is a fifth); then ≥ 98 % of the visible area carries its class's label, and
/// each class's IoU (by area) is ≥ 0.95.
#[test]
fn board_and_sphere_labels_cover_the_visible_area() {
    let dir = scratch("label-board");
    let cam = camera(400, 300, 380.0, [-0.1, 0.05, 4e-4, -3e-4, 0.0]);
    let (zb, hx, hy) = (520.0, 160.0, 120.0);
    let xs = [-hx, -hx / 3.0, hx / 3.0, hx];
    let albedo = [[0.7, 0.2, 0.2], [0.2, 0.6, 0.25], [0.25, 0.3, 0.75]];
    let (sc, sr) = ([30.0, -10.0, 420.0], 70.0);
    let sphere_albedo = [0.8, 0.75, 0.3];
    let mut text = camera_toml(&cam);
    let mut mesh = Mesh::default();
    let mut class_of_source = Vec::new();
    for k in 0..3 {
        let a = albedo[k];
        text += &format!("[materials.s{k}]\ntype = \"lambertian\"\nalbedo = {{ rgb = [{:?}, {:?}, {:?}] }}\n\n", a[0], a[1], a[2]);
        // A slightly tilted board: z grows with x.
        let z = |x: f64| zb + 0.15 * x;
        let q = [[xs[k], -hy, z(xs[k])], [xs[k + 1], -hy, z(xs[k + 1])], [xs[k + 1], hy, z(xs[k + 1])], [xs[k], hy, z(xs[k])]];
        text += &format!("[[objects]]\nname = \"stripe{k}\"\nmaterial = \"s{k}\"\nquads = [[{}, {}, {}, {}]]\n\n", v3(q[0]), v3(q[1]), v3(q[2]), v3(q[3]));
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(q);
        mesh.triangles.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        class_of_source.extend([k, k]);
    }
    let s = sphere_albedo;
    text += &format!("[materials.ball]\ntype = \"lambertian\"\nalbedo = {{ rgb = [{:?}, {:?}, {:?}] }}\n\n", s[0], s[1], s[2]);
    text += &format!("[[objects]]\nname = \"ball\"\nmaterial = \"ball\"\nsphere = {{ center = {}, radius = {:?} }}\n\n", v3(sc), sr);
    text += "[[lights]]\ntype = \"point\"\nposition = [0, 0, 0]\nintensity = 0.45\n\n[[lights]]\ntype = \"environment\"\nradiance = 0.05\n";
    let ball = uv_sphere(sc, sr, 128);
    let base = mesh.positions.len() as u32;
    mesh.positions.extend(&ball.positions);
    mesh.triangles.extend(ball.triangles.iter().map(|t| t.map(|v| v + base)));
    class_of_source.extend(std::iter::repeat_n(3, ball.triangles.len()));
    write_ply(&dir.join("scene-mesh.ply"), &mesh.positions, &mesh.triangles, None).unwrap();

    let photo = render(&text, &dir, 32, Some((0.01, 11)));
    let l = label(&mesh, &photo, &cam, &LabelOptions::default()).unwrap();
    // Truth.
    let hits_sphere_before = |p: [f64; 3]| -> bool {
        // Ray from the origin to p: does it meet the sphere at a parameter below 1?
        let (a, b, c) = (dot(p, p), -2.0 * dot(p, sc), dot(sc, sc) - sr * sr);
        let disc = b * b - 4.0 * a * c;
        disc > 0.0 && (-b - disc.sqrt()) / (2.0 * a) < 1.0 - 1e-9
    };
    let mut truth = Vec::with_capacity(l.mesh.triangles.len());
    for (t, &src) in l.mesh.triangles.iter().zip(&l.source) {
        let p = centroid(&l.mesh, t);
        let q = project(&cam, p);
        let inside = q[0] > -0.5 && q[1] > -0.5 && q[0] < 399.5 && q[1] < 299.5;
        let class = class_of_source[src as usize];
        let visible = inside
            && if class == 3 {
                dot([p[0] - sc[0], p[1] - sc[1], p[2] - sc[2]], p) < 0.0
            } else {
                !hits_sphere_before(p)
            };
        truth.push((class, visible, area(&l.mesh, t)));
    }
    // Each class's label: the one holding most of its visible area; distinct for the four.
    let mut votes: HashMap<(usize, i32), f64> = HashMap::new();
    for (&lab, &(class, vis, a)) in l.face_label.iter().zip(&truth) {
        if lab >= 0 && vis {
            *votes.entry((class, lab)).or_default() += a;
        }
    }
    let label_of: Vec<i32> = (0..4).map(|c| votes.iter().filter(|((k, _), _)| *k == c).max_by(|a, b| a.1.total_cmp(b.1)).map_or(-2, |((_, l), _)| *l)).collect();
    let distinct: HashSet<i32> = label_of.iter().copied().collect();
    assert_eq!(distinct.len(), 4, "two classes on one label: {label_of:?} (labels {})", l.segmentation.labels);
    let map: HashMap<i32, usize> = label_of.iter().enumerate().map(|(c, &l)| (l, c)).collect();
    let (mut visible, mut correct) = (0.0, 0.0);
    let mut inter = [0.0; 4];
    let mut union = [0.0; 4];
    for (&lab, &(class, vis, a)) in l.face_label.iter().zip(&truth) {
        let pred = if lab >= 0 { map.get(&lab).copied() } else { None };
        if vis {
            visible += a;
            if pred == Some(class) {
                correct += a;
            }
        }
        for c in 0..4 {
            let (p, t) = (pred == Some(c), vis && class == c);
            if p && t {
                inter[c] += a;
            }
            if p || t {
                union[c] += a;
            }
        }
    }
    let accuracy = correct / visible;
    let iou: Vec<f64> = (0..4).map(|c| inter[c] / union[c]).collect();
    eprintln!("labels {}, regions {}, accuracy {accuracy:.4}, IoU {iou:.4?}", l.segmentation.labels, l.segmentation.regions);
    assert!(accuracy >= 0.98, "accuracy {accuracy}, IoU {iou:?}");
    for (c, &v) in iou.iter().enumerate() {
        assert!(v >= 0.95, "class {c}: IoU {v} ({iou:?})");
    }
}
