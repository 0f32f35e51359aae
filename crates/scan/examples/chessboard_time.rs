//! Time the calibration-target finders on a folder of photographs (decoding excluded), as
//! `benches-peers/opencv_target_sets.py` times them against OpenCV through the Python package.
//!
//! `cargo run --release -p scan --example chessboard_time -- DIR COLSxROWS [REPEATS] [chessboard|circles|acircles]`

use scan::calib::chessboard::{find_chessboard, GrayImage};
use scan::markers::grid::{find_circles_grid, GridKind};
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 {
        eprintln!("usage: chessboard_time DIR COLSxROWS [REPEATS] [chessboard|circles|acircles]");
        std::process::exit(2);
    }
    let (cols, rows) = args[1].split_once('x').map(|(a, b)| (a.parse::<usize>().unwrap(), b.parse::<usize>().unwrap())).expect("COLSxROWS");
    let repeats: usize = args.get(2).map(|r| r.parse().expect("REPEATS")).unwrap_or(1);
    let pattern = args.get(3).map(String::as_str).unwrap_or("chessboard");
    let mut files: Vec<_> = std::fs::read_dir(&args[0]).expect("a folder").filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.extension().is_some_and(|x| x == "jpg" || x == "png")).collect();
    files.sort();
    let images: Vec<GrayImage> = files.iter().map(|p| GrayImage::load(p).expect("an image")).collect();
    // The circle finder reads 8-bit codes scaled to [0, 1], as `scan calibrate-camera` does.
    let discs: Vec<scan::markers::Image> = images.iter().map(|g| scan::markers::Image::new(g.width, g.height, g.data.iter().map(|v| v / 255.0).collect()).expect("an image")).collect();
    let start = Instant::now();
    let mut found = 0;
    for _ in 0..repeats {
        found = match pattern {
            "chessboard" => images.iter().filter(|im| find_chessboard(im, cols, rows).is_some()).count(),
            "circles" | "acircles" => {
                let kind = if pattern == "circles" { GridKind::Symmetric } else { GridKind::Asymmetric };
                discs.iter().filter(|im| find_circles_grid(im, kind, cols, rows).is_some()).count()
            }
            other => panic!("unknown pattern {other}"),
        };
    }
    let per_view = start.elapsed().as_secs_f64() / (repeats * images.len()) as f64;
    println!("{found}/{} {pattern} targets, {:.2} ms a view", images.len(), 1e3 * per_view);
}
