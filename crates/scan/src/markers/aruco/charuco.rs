//! ChArUco boards (OpenCV's `CharucoBoard` and `CharucoDetector`): a chessboard whose light
//! squares carry ArUco markers, so that a partly visible or partly occluded board still gives
//! identified chessboard corners.
//!
//! The layout is OpenCV's (4.6 and later): `squares_x` × `squares_y` squares of side
//! `square_length`, the top-left square dark, markers of side `marker_length` centred in the
//! light squares, numbered row by row from the top left with ids 0, 1, 2, … (or `ids`). With
//! `legacy` (OpenCV's `setLegacyPattern(true)`, the layout of OpenCV before 4.6) a board with an
//! even number of rows has its top-left square light instead. Board coordinates: x right, y
//! down, z = 0, in the unit of the lengths; chessboard corner k = j·(squares_x − 1) + i lies at
//! ((i + 1)·square, (j + 1)·square).
//!
//! Corners are found as OpenCV finds them without a camera model: every chessboard corner whose
//! two neighbouring markers are both found (OpenCV's `minMarkers` = 2) is predicted by each
//! marker's homography (board → image, from the corners of lines fitted to the marker's sides);
//! where the predictions agree within a tenth of a square the corner is placed at their mean,
//! then refined as OpenCV's `cornerSubPix` refines it, on the image as it is (a blur would carry
//! the markers' edges towards the corner), in a window of 0.4 of the square's shorter side from
//! which the two markers, grown by 1.5 px, are left out
//! ([`crate::calib::chessboard::corner_subpix_masked`]). OpenCV instead shrinks the window to
//! stay clear of the markers; on small squares (under about 40 px) that leaves a few pixels of
//! edge, and the masked window's corners fit a camera with a quarter less reprojection error
//! (docs/scanning.md, "ChArUco boards").

use super::detect::{detect_markers, intersections, ArucoMarker, ArucoSettings};
use super::dictionary::Dictionary;
use crate::calib::chessboard::{corner_subpix_masked, GrayImage};
use crate::calib::homography::{apply, fit_homography, Point2};
use anyhow::{bail, Result};

/// A ChArUco board.
#[derive(Clone, Debug)]
pub struct CharucoBoard {
    pub squares_x: usize,
    pub squares_y: usize,
    pub square_length: f64,
    pub marker_length: f64,
    pub dictionary: Dictionary,
    /// The markers' ids in board order.
    pub ids: Vec<usize>,
    pub legacy: bool,
}

/// Corners found on one photograph: chessboard corner ids with their pixels, and the markers.
#[derive(Clone, Debug)]
pub struct CharucoDetection {
    pub corners: Vec<(usize, Point2)>,
    pub markers: Vec<ArucoMarker>,
}

/// A convex quadrilateral grown outwards by `d` pixels along its sides' normals (itself where
/// that fails: parallel sides).
fn grow(q: &[Point2; 4], d: f64) -> [Point2; 4] {
    let c = [q.iter().map(|p| p[0]).sum::<f64>() / 4.0, q.iter().map(|p| p[1]).sum::<f64>() / 4.0];
    let lines: [(f64, f64, f64); 4] = std::array::from_fn(|k| {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        let (tx, ty) = (b[0] - a[0], b[1] - a[1]);
        let l = tx.hypot(ty).max(1e-12);
        let (mut nx, mut ny) = (ty / l, -tx / l);
        if (a[0] - c[0]) * nx + (a[1] - c[1]) * ny < 0.0 {
            nx = -nx;
            ny = -ny;
        }
        (nx, ny, nx * a[0] + ny * a[1] + d)
    });
    intersections(&lines, q, f64::INFINITY).unwrap_or(*q)
}

/// Whether `p` lies inside the convex quadrilateral `q` (either orientation).
fn inside(q: &[Point2; 4], p: Point2) -> bool {
    let mut sign = 0.0f64;
    for k in 0..4 {
        let (a, b) = (q[k], q[(k + 1) % 4]);
        let cr = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
        if cr != 0.0 {
            if sign != 0.0 && cr.signum() != sign {
                return false;
            }
            sign = cr.signum();
        }
    }
    true
}

impl CharucoBoard {
    /// A board with OpenCV's default ids (0, 1, 2, …).
    pub fn new(squares_x: usize, squares_y: usize, square_length: f64, marker_length: f64, dictionary: Dictionary, legacy: bool) -> Result<CharucoBoard> {
        if squares_x < 2 || squares_y < 2 {
            bail!("a ChArUco board needs at least 2 × 2 squares, got {squares_x} × {squares_y}");
        }
        if !(square_length > 0.0 && square_length.is_finite()) {
            bail!("the square length must be positive, got {square_length}");
        }
        if !(marker_length > 0.0 && marker_length < square_length) {
            bail!("the marker length must be positive and below the square length ({square_length}), got {marker_length}");
        }
        let mut b = CharucoBoard { squares_x, squares_y, square_length, marker_length, dictionary, ids: vec![], legacy };
        let n = b.marker_squares().len();
        if n > b.dictionary.codes.len() {
            bail!("{} squares × {} need {n} markers; {} has {}", squares_x, squares_y, b.dictionary.name, b.dictionary.codes.len());
        }
        b.ids = (0..n).collect();
        Ok(b)
    }

    /// Whether square (x, y) carries a marker.
    fn has_marker(&self, x: usize, y: usize) -> bool {
        if self.legacy && self.squares_y % 2 == 0 {
            (x + y) % 2 == 0
        } else {
            (x + y) % 2 == 1
        }
    }

    /// The squares (x, y) that carry markers, in board order.
    pub fn marker_squares(&self) -> Vec<(usize, usize)> {
        let mut v = Vec::new();
        for y in 0..self.squares_y {
            for x in 0..self.squares_x {
                if self.has_marker(x, y) {
                    v.push((x, y));
                }
            }
        }
        v
    }

    /// For each square (row-major), the board-order index of its marker, if it has one.
    fn marker_grid(&self) -> Vec<Option<usize>> {
        let mut grid = vec![None; self.squares_x * self.squares_y];
        for (k, (x, y)) in self.marker_squares().into_iter().enumerate() {
            grid[y * self.squares_x + x] = Some(k);
        }
        grid
    }

    /// Marker k's corners on the board (top left, top right, bottom right, bottom left).
    pub fn marker_corners(&self, k: usize) -> [Point2; 4] {
        let (x, y) = self.marker_squares()[k];
        self.marker_corners_in(x, y)
    }

    /// The corners of the marker in square (x, y).
    fn marker_corners_in(&self, x: usize, y: usize) -> [Point2; 4] {
        let m = (self.square_length - self.marker_length) / 2.0;
        let (x0, y0) = (x as f64 * self.square_length + m, y as f64 * self.square_length + m);
        let l = self.marker_length;
        [[x0, y0], [x0 + l, y0], [x0 + l, y0 + l], [x0, y0 + l]]
    }

    /// The chessboard corners on the board, by id.
    pub fn chessboard_corners(&self) -> Vec<Point2> {
        let s = self.square_length;
        let mut v = Vec::new();
        for j in 0..self.squares_y - 1 {
            for i in 0..self.squares_x - 1 {
                v.push([(i + 1) as f64 * s, (j + 1) as f64 * s]);
            }
        }
        v
    }

    /// For each chessboard corner, the indices (board order) of the markers in the squares that
    /// touch it.
    pub fn corner_markers(&self) -> Vec<Vec<usize>> {
        let grid = self.marker_grid();
        let index = |x: usize, y: usize| grid[y * self.squares_x + x];
        let mut v = Vec::new();
        for j in 0..self.squares_y - 1 {
            for i in 0..self.squares_x - 1 {
                v.push([(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)].iter().filter_map(|&(x, y)| index(x, y)).collect());
            }
        }
        v
    }

    /// The board's chessboard corners in `img`, with the markers found.
    pub fn detect(&self, img: &GrayImage, settings: &ArucoSettings) -> CharucoDetection {
        let found = detect_markers(img, &self.dictionary, settings);
        // Board index of each marker found (a marker id found twice is ambiguous: left out).
        let mut at: Vec<Option<usize>> = vec![None; self.ids.len()];
        let mut markers = Vec::new();
        for m in &found {
            let Some(k) = self.ids.iter().position(|&id| id == m.id) else { continue };
            if found.iter().filter(|o| o.id == m.id).count() > 1 {
                continue;
            }
            at[k] = Some(markers.len());
            markers.push(m.clone());
        }
        let squares = self.marker_squares();
        let homographies: Vec<Option<_>> = (0..self.ids.len())
            .map(|k| at[k].and_then(|i| fit_homography(&self.marker_corners_in(squares[k].0, squares[k].1), &markers[i].line_corners.unwrap_or(markers[i].corners))))
            .collect();
        let board = self.chessboard_corners();
        let mut corners = Vec::new();
        for (c, near) in self.corner_markers().iter().enumerate() {
            if near.len() < 2 || near.iter().any(|&k| homographies[k].is_none()) {
                continue;
            }
            let preds: Vec<Point2> = near.iter().map(|&k| apply(homographies[k].as_ref().unwrap(), board[c])).collect();
            let p = [preds.iter().map(|q| q[0]).sum::<f64>() / preds.len() as f64, preds.iter().map(|q| q[1]).sum::<f64>() / preds.len() as f64];
            // The markers must agree on where the corner is (within a tenth of a square, measured
            // along the first marker's side): markers of another layout or board do not.
            let h0 = homographies[near[0]].as_ref().unwrap();
            // The square's shorter side in the image near the corner (pixels).
            let step = {
                let a = apply(h0, board[c]);
                let side = |dx: f64, dy: f64| {
                    let b = apply(h0, [board[c][0] + dx, board[c][1] + dy]);
                    (a[0] - b[0]).hypot(a[1] - b[1])
                };
                let sq = self.square_length;
                side(sq, 0.0).min(side(-sq, 0.0)).min(side(0.0, sq)).min(side(0.0, -sq))
            };
            if preds.iter().any(|q| (q[0] - p[0]).hypot(q[1] - p[1]) > 0.1 * step) {
                continue;
            }
            // The window: 0.4 of the square's shorter side (at most 15 px), so that it stays
            // within the four squares around the corner, with the neighbouring markers, grown by
            // 1.5 px for the gradients' reach, left out of it (their edges would pull the corner).
            let quads: Vec<[Point2; 4]> = near.iter().map(|&k| {
                let m = &markers[at[k].unwrap()];
                grow(&m.line_corners.unwrap_or(m.corners), 1.5)
            }).collect();
            let half = ((0.4 * step).floor() as usize).clamp(2, 15);
            if !(p[0] >= half as f64 && p[1] >= half as f64 && p[0] < (img.width - half) as f64 && p[1] < (img.height - half) as f64) {
                continue;
            }
            let mut one = [p];
            corner_subpix_masked(img, &mut one, half, 100, 0.01, 0.0, &|x, y| !quads.iter().any(|q| inside(q, [x, y])));
            if one[0][0].is_finite() && one[0][1].is_finite() && (one[0][0] - p[0]).hypot(one[0][1] - p[1]) <= half as f64 {
                corners.push((c, one[0]));
            }
        }
        CharucoDetection { corners, markers }
    }

    /// All chessboard corners of a detection, NaN where not found (the form the calibrations
    /// take for partial views).
    pub fn full_view(&self, d: &CharucoDetection) -> Vec<Point2> {
        let mut v = vec![[f64::NAN, f64::NAN]; (self.squares_x - 1) * (self.squares_y - 1)];
        for &(id, p) in &d.corners {
            v[id] = p;
        }
        v
    }

    /// The board's grey level (30 dark, 220 light) at board point (x, y); light paper around it.
    fn level(&self, x: f64, y: f64, grid: &[Option<usize>]) -> f32 {
        let s = self.square_length;
        if x < 0.0 || y < 0.0 || x >= self.squares_x as f64 * s || y >= self.squares_y as f64 * s {
            return 220.0;
        }
        let (sx, sy) = ((x / s) as usize, (y / s) as usize);
        if !self.has_marker(sx, sy) {
            return 30.0;
        }
        let Some(k) = grid[sy * self.squares_x + sx] else { return 220.0 };
        let c = self.marker_corners_in(sx, sy)[0];
        let n = self.dictionary.size;
        let cell = self.marker_length / (n + 2) as f64;
        let (u, v) = ((x - c[0]) / cell, (y - c[1]) / cell);
        if u < 0.0 || v < 0.0 || u >= (n + 2) as f64 || v >= (n + 2) as f64 {
            return 220.0;
        }
        let (cu, cv) = (u as usize, v as usize);
        if cu == 0 || cv == 0 || cu == n + 1 || cv == n + 1 {
            return 30.0;
        }
        let code = self.dictionary.codes[self.ids[k]];
        let bit = n * n - 1 - ((cv - 1) * n + cu - 1);
        if (code >> bit) & 1 == 1 { 220.0 } else { 30.0 }
    }

    /// The board seen through the homography `board_to_image` (board units → pixels) on light
    /// paper, `width` × `height` pixels of grey levels 30 (dark) to 220 (light), each pixel the
    /// mean of 4 × 4 samples (OpenCV's `generateImage` for a tilted view; tests and examples).
    pub fn render(&self, board_to_image: &nalgebra::Matrix3<f64>, width: usize, height: usize) -> GrayImage {
        let inv = board_to_image.try_inverse().unwrap_or_else(nalgebra::Matrix3::zeros);
        let grid = self.marker_grid();
        let mut data = vec![0f32; width * height];
        for y in 0..height {
            for x in 0..width {
                let mut acc = 0.0;
                for i in 0..4 {
                    for j in 0..4 {
                        let p = apply(&inv, [x as f64 - 0.375 + 0.25 * j as f64, y as f64 - 0.375 + 0.25 * i as f64]);
                        acc += self.level(p[0], p[1], &grid);
                    }
                }
                data[y * width + x] = acc / 16.0;
            }
        }
        GrayImage { width, height, data }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn board(legacy: bool) -> CharucoBoard {
        board_with(legacy, 30.0)
    }

    fn board_with(legacy: bool, marker: f64) -> CharucoBoard {
        CharucoBoard::new(7, 5, 40.0, marker, Dictionary::predefined("DICT_4X4_50").unwrap(), legacy).unwrap()
    }

    /// A homography from the board to a 640 × 480 image: scale, turn by `angle`, tilt.
    fn view(angle: f64, tilt: f64) -> nalgebra::Matrix3<f64> {
        let (c, s) = (angle.cos(), angle.sin());
        let k = 1.5;
        nalgebra::Matrix3::new(k * c, -k * s, 320.0, k * s, k * c, 240.0, tilt, 0.3 * tilt, 1.0)
            * nalgebra::Matrix3::new(1.0, 0.0, -140.0, 0.0, 1.0, -100.0, 0.0, 0.0, 1.0)
    }

    #[test]
    fn layout_is_opencvs() {
        // cv2.aruco.CharucoBoard((5, 6), 1, 0.5, DICT_4X4_50).getObjPoints(): the first markers
        // sit in squares (1, 0), (3, 0), (0, 1), (2, 1); with setLegacyPattern(True) in (0, 0),
        // (2, 0), (4, 0), (1, 1); an odd row count keeps the new layout.
        let d = Dictionary::predefined("DICT_4X4_50").unwrap();
        let new = CharucoBoard::new(5, 6, 1.0, 0.5, d.clone(), false).unwrap();
        assert_eq!(new.marker_squares()[..4], [(1, 0), (3, 0), (0, 1), (2, 1)]);
        assert_eq!(new.marker_corners(0), [[1.25, 0.25], [1.75, 0.25], [1.75, 0.75], [1.25, 0.75]]);
        let legacy = CharucoBoard::new(5, 6, 1.0, 0.5, d.clone(), true).unwrap();
        assert_eq!(legacy.marker_squares()[..4], [(0, 0), (2, 0), (4, 0), (1, 1)]);
        let odd = CharucoBoard::new(5, 7, 1.0, 0.5, d.clone(), true).unwrap();
        assert_eq!(odd.marker_squares()[..4], [(1, 0), (3, 0), (0, 1), (2, 1)]);
        assert_eq!(new.chessboard_corners()[..2], [[1.0, 1.0], [2.0, 1.0]]);
        assert_eq!(new.chessboard_corners().len(), 4 * 5);
        assert!(CharucoBoard::new(5, 6, 1.0, 1.2, d, false).is_err());
    }

    #[test]
    fn markers_and_corners_of_a_rendered_board() {
        // With markers of 0.75 of the square the refinement window reaches the markers' corners
        // (the largest window without a marker inside), and their edges pull a corner by up to
        // 0.25 px on these sharp renders; with markers of 0.5 of the square the window is clear
        // (15 px) and the corners are within 0.1 px (the bilinear gradients of a sharp edge,
        // unblurred as OpenCV reads them, are not quite isotropic).
        for (legacy, angle, tilt, marker, tol) in [(false, 0.1, 0.0004, 30.0, 0.1), (false, 1.7, -0.0003, 30.0, 0.1), (true, 3.3, 0.0002, 30.0, 0.1), (false, -1.2, 0.0, 20.0, 0.1), (false, 0.5, 0.0003, 20.0, 0.1)] {
            let b = board_with(legacy, marker);
            let h = view(angle, tilt);
            let img = b.render(&h, 640, 480);
            let d = b.detect(&img, &ArucoSettings::default());
            // Every marker, with its own id, corners in OpenCV's order: the polygon's within 1.5 px
            // (the threshold moves edges by up to a pixel), the sub-pixel ones within 0.2 px.
            assert_eq!(d.markers.len(), b.ids.len(), "legacy {legacy}, angle {angle}");
            for m in &d.markers {
                let k = b.ids.iter().position(|&i| i == m.id).unwrap();
                let truth = b.marker_corners(k).map(|p| apply(&h, p));
                for (c, t) in m.corners.iter().zip(&truth) {
                    assert!((c[0] - t[0]).hypot(c[1] - t[1]) < 1.5, "marker {} corner {c:?} truth {t:?}", m.id);
                }
                for (c, t) in m.line_corners.unwrap().iter().zip(&truth) {
                    assert!((c[0] - t[0]).hypot(c[1] - t[1]) < 0.2, "marker {} line corner {c:?} truth {t:?}", m.id);
                }
            }
            // Every chessboard corner, within `tol` of the truth.
            let board_pts = b.chessboard_corners();
            assert_eq!(d.corners.len(), board_pts.len());
            for &(id, p) in &d.corners {
                let t = apply(&h, board_pts[id]);
                assert!((p[0] - t[0]).hypot(p[1] - t[1]) < tol, "corner {id}: {p:?} truth {t:?}");
            }
        }
    }

    #[test]
    fn a_covered_board_gives_the_corners_of_its_visible_markers() {
        let b = board(false);
        let h = view(0.3, 0.0002);
        let mut img = b.render(&h, 640, 480);
        // A grey card over the image's left third.
        for y in 0..480 {
            for x in 0..230 {
                img.data[y * 640 + x] = 128.0;
            }
        }
        let d = b.detect(&img, &ArucoSettings::default());
        assert!(!d.markers.is_empty() && d.markers.len() < b.ids.len());
        let board_pts = b.chessboard_corners();
        let near = b.corner_markers();
        assert!(d.corners.len() >= 4);
        for &(id, p) in &d.corners {
            let t = apply(&h, board_pts[id]);
            assert!((p[0] - t[0]).hypot(p[1] - t[1]) < 0.25, "corner {id}: {p:?} truth {t:?}");
            assert!(p[0] > 230.0);
            // Both of its markers were found.
            for &k in &near[id] {
                assert!(d.markers.iter().any(|m| m.id == b.ids[k]));
            }
        }
        let full = b.full_view(&d);
        assert_eq!(full.iter().filter(|p| p[0].is_finite()).count(), d.corners.len());
    }

    #[test]
    fn no_markers_in_noise_or_a_plain_chessboard() {
        let d = Dictionary::predefined("DICT_6X6_250").unwrap();
        // A chessboard of 40-pixel squares and pseudo-random noise: no marker of a 6×6 dictionary.
        let (w, h) = (320, 240);
        let mut state = 12345u64;
        let data = (0..w * h)
            .map(|i| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let (x, y) = (i % w, i / w);
                let base = if ((x / 40) + (y / 40)) % 2 == 0 { 40.0 } else { 210.0 };
                base + ((state >> 33) % 30) as f32
            })
            .collect();
        let img = GrayImage { width: w, height: h, data };
        assert!(detect_markers(&img, &d, &ArucoSettings::default()).is_empty());
    }
}
