//! Circle-grid calibration targets (OpenCV's `findCirclesGrid`): the centres of a symmetric or
//! asymmetric grid of discs, in the order of the target's object points, for camera calibration.
//!
//! 1. **Discs.** Candidates from thresholded regions ([`super::blobs`], as OpenCV's blob
//!    detector finds them), refined to sub-pixel ellipses from edge points
//!    ([`super::detect::refine`]), dark discs on a light ground first, then light on dark; where
//!    neither gives the grid, the size-invariant Hough candidates of [`super::detect`] (dark,
//!    then light); where none does, all of it again on the image blurred by σ = 0.7 px.
//! 2. **Lattice growth.** The grid's nearest neighbours span a lattice: along the rows and
//!    columns of a symmetric grid (spacing s), along the diagonals of an asymmetric one (spacing
//!    s√2 against 2s along its rows). From a seed disc and its two nearest neighbours in
//!    different directions, the lattice grows breadth first: each missing node is predicted by
//!    continuing the line through its neighbour and that neighbour's neighbour on the far side
//!    (which follows perspective), else by the step of a parallel edge next to it, else by the
//!    seed's step, and it takes the nearest unassigned disc within 0.3 of the step whose radius
//!    is within a factor 1.6 of its neighbour's. Each disc is a seed in turn until a lattice has
//!    the target's shape.
//! 3. **Shape and order.** A lattice node (u, v) lies at board position T(u, v) for one of the
//!    lattice's eight symmetries T (symmetric: ±u, ±v in either order; asymmetric: the two board
//!    diagonals (±1, ±1) in either order). The target's points are those of OpenCV's calibration
//!    sample for a pattern of `cols` × `rows`:
//!    - symmetric: (j s, i s), j < cols, i < rows;
//!    - asymmetric: ((2j + i mod 2) s, i s), j < cols, i < rows;
//!
//!    listed row by row (index i·cols + j). The lattice must cover them exactly for some T and
//!    offset. Of the labelings that do, those that keep the image's handedness (the board seen
//!    from its front, its x and y axes turning as the image's do) are kept; an asymmetric grid of
//!    an odd number of rows then has one, a symmetric grid two (180° apart) or four (square), of
//!    which the one whose point 0 is nearest the image's top-left is taken, as for chessboards
//!    ([`crate::calib::chessboard`]).
//!
//! Centres are those of the fitted ellipses. Under perspective the image of a disc's centre is not
//! the centre of its image ellipse (docs/markers.md); OpenCV's blob centres share that offset, which
//! grows with the disc's size relative to its distance.

// `!(x > 0.0)` is deliberate: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::collections::{HashMap, VecDeque};

use super::blobs::threshold_candidates;
use super::detect::refine_all;
use super::hough::HoughSettings;
use super::{detect, DetectSettings, Image, Marker};
use crate::calib::homography::Point2;

/// The layout of a circle grid (OpenCV's `CALIB_CB_SYMMETRIC_GRID`, `CALIB_CB_ASYMMETRIC_GRID`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GridKind {
    /// Rows of `cols` discs on a square lattice.
    Symmetric,
    /// Rows of `cols` discs 2s apart, every second row shifted by s.
    Asymmetric,
}

/// The target's points (z = 0) in units of the spacing `s`, row by row: OpenCV's object points for
/// `cols` × `rows` (module documentation).
pub fn grid_points(kind: GridKind, cols: usize, rows: usize, s: f64) -> Vec<Point2> {
    let mut v = Vec::with_capacity(cols * rows);
    for i in 0..rows {
        for j in 0..cols {
            let x = match kind {
                GridKind::Symmetric => j as f64,
                GridKind::Asymmetric => (2 * j + i % 2) as f64,
            };
            v.push([x * s, i as f64 * s]);
        }
    }
    v
}

/// The grid's integer board positions (units of s), in the order of [`grid_points`].
fn grid_cells(kind: GridKind, cols: usize, rows: usize) -> Vec<(i32, i32)> {
    grid_points(kind, cols, rows, 1.0).iter().map(|p| (p[0] as i32, p[1] as i32)).collect()
}

/// The centres of a `cols` × `rows` circle grid in `img`, in the order of [`grid_points`], or None
/// when no set of discs has the target's shape.
pub fn find_circles_grid(img: &Image, kind: GridKind, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    if cols == 0 || rows == 0 || cols * rows < 4 {
        return None;
    }
    if let Some(v) = find_at(img, kind, cols, rows) {
        return Some(v);
    }
    // Small discs in a sharp, noisy photograph can lose edge points to pixel noise; a Gaussian
    // of σ = 0.7 px (which moves no disc's centre) recovers them: four of 112 photographs of
    // OpenCV's and other public circle-grid sets (discs of radius 4–6 px) are found only so.
    let g = crate::calib::chessboard::GrayImage { width: img.width, height: img.height, data: img.data.clone() }.blur(0.7);
    find_at(&Image { width: g.width, height: g.height, data: g.data }, kind, cols, rows)
}

/// [`find_circles_grid`] on the image as it is.
fn find_at(img: &Image, kind: GridKind, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    let s = DetectSettings::default();
    // Candidates from thresholded regions first (fast), dark discs and then light ones; the
    // Hough transform (ten times slower on a 1080p photograph) only where neither gives the grid
    // (an uneven ground).
    for dark in [true, false] {
        if let Some(v) = find_grid_in(&refine_all(img, &threshold_candidates(img, dark), &s), kind, cols, rows) {
            return Some(v);
        }
    }
    for dark in [true, false] {
        let hough = DetectSettings { hough: HoughSettings { dark: Some(dark), ..s.hough }, ..s };
        if let Some(v) = find_grid_in(&detect(img, &hough), kind, cols, rows) {
            return Some(v);
        }
    }
    None
}

/// [`find_circles_grid`] on detected discs.
pub fn find_grid_in(markers: &[Marker], kind: GridKind, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    for dark in [true, false] {
        let discs: Vec<&Marker> = markers.iter().filter(|m| m.dark == dark).collect();
        if discs.len() < cols * rows {
            continue;
        }
        if let Some(v) = grid_of(&discs, kind, cols, rows) {
            return Some(v);
        }
    }
    None
}

fn dist(a: Point2, b: Point2) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

fn grid_of(discs: &[&Marker], kind: GridKind, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    let pts: Vec<Point2> = discs.iter().map(|m| [m.x, m.y]).collect();
    let n = pts.len();
    // Seeds: discs whose nearest neighbours are most alike first (inside the grid), so that a
    // stray disc rarely starts a lattice.
    let mut neighbours: Vec<Vec<(f64, usize)>> = Vec::with_capacity(n);
    for i in 0..n {
        let mut d: Vec<(f64, usize)> = (0..n).filter(|&j| j != i).map(|j| (dist(pts[i], pts[j]), j)).collect();
        d.sort_by(|a, b| a.0.total_cmp(&b.0));
        d.truncate(8);
        neighbours.push(d);
    }
    let mut seeds: Vec<(f64, usize)> = (0..n)
        .filter(|&i| neighbours[i].len() >= 4)
        .map(|i| {
            let d = &neighbours[i];
            (d[3].0 / d[0].0, i)
        })
        .collect();
    seeds.sort_by(|a, b| a.0.total_cmp(&b.0));
    for &(_, seed) in &seeds {
        let near = &neighbours[seed];
        let a = sub(pts[near[0].1], pts[seed]);
        // The second basis vector: the nearest neighbour at 45°–135° from the first.
        let Some(&(_, j)) = near[1..].iter().find(|(d, j)| {
            let b = sub(pts[*j], pts[seed]);
            let cos = (a[0] * b[0] + a[1] * b[1]) / (near[0].0 * d);
            cos.abs() < std::f64::consts::FRAC_1_SQRT_2 && *d < 1.6 * near[0].0
        }) else {
            continue;
        };
        let b = sub(pts[j], pts[seed]);
        let lattice = grow(discs, &pts, seed, a, b);
        if lattice.len() < cols * rows {
            continue;
        }
        if let Some(v) = label(&lattice, &pts, kind, cols, rows) {
            return Some(v);
        }
    }
    None
}

fn sub(a: Point2, b: Point2) -> Point2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// The lattice grown from `seed` with steps `a` (along u) and `b` (along v): node → disc index.
fn grow(discs: &[&Marker], pts: &[Point2], seed: usize, a: Point2, b: Point2) -> HashMap<(i32, i32), usize> {
    let mut node: HashMap<(i32, i32), usize> = HashMap::new();
    let mut taken = vec![false; pts.len()];
    node.insert((0, 0), seed);
    taken[seed] = true;
    let mut queue = VecDeque::from([(0i32, 0i32)]);
    let dirs = [(1, 0), (-1, 0), (0, 1), (0, -1)];
    while let Some((u, v)) = queue.pop_front() {
        let here = node[&(u, v)];
        for (du, dv) in dirs {
            let t = (u + du, v + dv);
            if node.contains_key(&t) {
                continue;
            }
            let step = if let Some(&back) = node.get(&(u - du, v - dv)) {
                sub(pts[here], pts[back])
            } else if let Some(s) = [(dv, du), (-dv, -du)].iter().find_map(|&(pu, pv)| {
                // A parallel edge beside this one: (u, v) + p → (u, v) + p + d.
                let (Some(&p0), Some(&p1)) = (node.get(&(u + pu, v + pv)), node.get(&(u + pu + du, v + pv + dv))) else { return None };
                Some(sub(pts[p1], pts[p0]))
            }) {
                s
            } else {
                let base = if du != 0 { a } else { b };
                let sign = f64::from(du + dv);
                [base[0] * sign, base[1] * sign]
            };
            let pred = [pts[here][0] + step[0], pts[here][1] + step[1]];
            let len = step[0].hypot(step[1]);
            let r0 = discs[here].radius_px;
            let best = (0..pts.len())
                .filter(|&k| !taken[k])
                .map(|k| (dist(pts[k], pred), k))
                .filter(|&(d, k)| d < 0.3 * len && (discs[k].radius_px / r0).max(r0 / discs[k].radius_px) < 1.6)
                .min_by(|x, y| x.0.total_cmp(&y.0));
            if let Some((_, k)) = best {
                node.insert(t, k);
                taken[k] = true;
                queue.push_back(t);
            }
        }
    }
    node
}

/// The target's labeling of a lattice (module documentation, step 3), or None.
fn label(lattice: &HashMap<(i32, i32), usize>, pts: &[Point2], kind: GridKind, cols: usize, rows: usize) -> Option<Vec<Point2>> {
    let cells = grid_cells(kind, cols, rows);
    // The lattice's symmetries: board position = u·e₁ + v·e₂.
    let axes: Vec<(i32, i32)> = match kind {
        GridKind::Symmetric => vec![(1, 0), (-1, 0), (0, 1), (0, -1)],
        GridKind::Asymmetric => vec![(1, 1), (1, -1), (-1, 1), (-1, -1)],
    };
    let mut best: Option<(f64, f64, Vec<Point2>)> = None;
    for &e1 in &axes {
        for &e2 in &axes {
            if e1.0 * e2.0 + e1.1 * e2.1 != 0 {
                continue;
            }
            let board: HashMap<(i32, i32), usize> = lattice.iter().map(|(&(u, v), &k)| ((u * e1.0 + v * e2.0, u * e1.1 + v * e2.1), k)).collect();
            // Offsets that put the target's first cell on a lattice node.
            for &(bx, by) in board.keys() {
                let (ox, oy) = (bx - cells[0].0, by - cells[0].1);
                let Some(v) = cells.iter().map(|&(x, y)| board.get(&(x + ox, y + oy)).map(|&k| pts[k])).collect::<Option<Vec<Point2>>>() else { continue };
                // No other node of the lattice within one step of the target's box (a grid larger
                // than the target, or a stray disc on the lattice, is not this target).
                let inside = board.keys().filter(|&&(x, y)| {
                    let (x, y) = (x - ox, y - oy);
                    (-1..=rows as i32).contains(&y) && x >= -1 && x <= cells.iter().map(|c| c.0).max().unwrap_or(0) + 1
                });
                if inside.count() != cells.len() {
                    continue;
                }
                // Handedness: the image turns from the board's x axis to its y axis as the board
                // does (both y-down), i.e. the board is seen from its front.
                let x_axis = sub(v[cols.min(v.len()) - 1], v[0]);
                let y_axis = sub(v[(rows - 1) * cols], v[0]);
                let turn = x_axis[0] * y_axis[1] - x_axis[1] * y_axis[0];
                if !(turn > 0.0) && rows > 1 && cols > 1 {
                    continue;
                }
                let key = v[0][0] + v[0][1];
                let tie = v[1][1] - v[1][0];
                if best.as_ref().is_none_or(|b| key < b.0 - 1e-9 || (key < b.0 + 1e-9 && tie < b.1)) {
                    best = Some((key, tie, v));
                }
            }
        }
    }
    best.map(|b| b.2)
}
