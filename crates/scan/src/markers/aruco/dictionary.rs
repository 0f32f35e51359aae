//! ArUco dictionaries: the codes of OpenCV's predefined dictionaries
//! (`crates/scan/data/aruco/dictionaries.txt`, made by `scripts/aruco_dictionaries.py`; the codes
//! are OpenCV's data, so that lucent reads the markers OpenCV prints and finds).

use anyhow::{anyhow, bail, Result};
use std::collections::HashMap;
use std::sync::OnceLock;

const DATA: &str = include_str!("../../../data/aruco/dictionaries.txt");

/// A dictionary of square markers of `size` × `size` bits inside a one-cell black border.
#[derive(Clone, Debug, PartialEq)]
pub struct Dictionary {
    /// OpenCV's name (`DICT_5X5_1000`).
    pub name: String,
    /// Bits per side.
    pub size: usize,
    /// The markers' codes: bit `size² − 1 − (r·size + c)` is the cell in row r, column c (row 0
    /// at the top when the marker stands upright); 1 = white.
    pub codes: Vec<u64>,
    /// OpenCV's maximum number of correctable bits (before its error-correction rate).
    pub max_correction_bits: u32,
    /// OpenCV's enum value (`cv2.aruco.DICT_…`).
    pub opencv_id: i32,
}

struct Table {
    dicts: HashMap<String, Dictionary>,
    by_id: HashMap<i32, String>,
}

fn table() -> &'static Table {
    static T: OnceLock<Table> = OnceLock::new();
    T.get_or_init(|| parse(DATA).expect("the bundled ArUco dictionary table parses (tested)"))
}

fn parse(text: &str) -> Result<Table> {
    let mut sets: HashMap<String, (usize, Vec<u64>)> = HashMap::new();
    let mut current: Option<(String, usize, usize)> = None;
    let mut dicts = HashMap::new();
    let mut by_id = HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        let bad = || anyhow!("dictionaries.txt line {}: cannot read {line:?}", n + 1);
        match f[0] {
            "set" if f.len() == 4 => {
                let size: usize = f[2].parse().map_err(|_| bad())?;
                let count: usize = f[3].parse().map_err(|_| bad())?;
                sets.insert(f[1].to_string(), (size, Vec::with_capacity(count)));
                current = Some((f[1].to_string(), size, count));
            }
            "dict" if f.len() == 6 => {
                let (size, codes) = sets.get(f[2]).ok_or_else(bad)?;
                let count: usize = f[3].parse().map_err(|_| bad())?;
                if count > codes.len() {
                    return Err(bad());
                }
                let d = Dictionary {
                    name: f[1].to_string(),
                    size: *size,
                    codes: codes[..count].to_vec(),
                    max_correction_bits: f[4].parse().map_err(|_| bad())?,
                    opencv_id: f[5].parse().map_err(|_| bad())?,
                };
                by_id.entry(d.opencv_id).or_insert_with(|| d.name.clone());
                dicts.insert(d.name.clone(), d);
            }
            _ => {
                let (name, size, count) = current.as_ref().ok_or_else(bad)?;
                let v = u64::from_str_radix(line, 16).map_err(|_| bad())?;
                if size * size < 64 && v >> (size * size) != 0 {
                    return Err(bad());
                }
                let set = &mut sets.get_mut(name).ok_or_else(bad)?.1;
                if set.len() >= *count {
                    return Err(bad());
                }
                set.push(v);
            }
        }
    }
    if dicts.is_empty() {
        bail!("dictionaries.txt: no dictionary");
    }
    Ok(Table { dicts, by_id })
}

impl Dictionary {
    /// A predefined dictionary by OpenCV's name (`DICT_4X4_50`, `5X5_1000`, case-insensitive,
    /// the `DICT_` prefix optional) or enum value (`"10"` for `cv2.aruco.DICT_6X6_250`).
    pub fn predefined(name: &str) -> Result<Dictionary> {
        let t = table();
        if let Ok(id) = name.trim().parse::<i32>() {
            if let Some(n) = t.by_id.get(&id) {
                return Ok(t.dicts[n].clone());
            }
        }
        let upper = name.trim().to_ascii_uppercase();
        let key = if upper.starts_with("DICT_") { upper } else { format!("DICT_{upper}") };
        t.dicts
            .values()
            .find(|d| d.name.to_ascii_uppercase() == key)
            .cloned()
            .ok_or_else(|| anyhow!("unknown ArUco dictionary {name:?} (OpenCV's names, e.g. DICT_4X4_50, DICT_5X5_1000, DICT_6X6_250, DICT_ARUCO_ORIGINAL, DICT_APRILTAG_36h11)"))
    }

    /// The names of the predefined dictionaries, sorted.
    pub fn names() -> Vec<String> {
        let mut v: Vec<String> = table().dicts.keys().cloned().collect();
        v.sort();
        v
    }

    /// The bits a reader finds error-free: OpenCV's maximum correctable bits times its
    /// error-correction rate (0.6 by default), rounded down.
    pub fn correctable(&self, error_correction_rate: f64) -> u32 {
        (self.max_correction_bits as f64 * error_correction_rate).floor() as u32
    }

    /// The cells of marker `id` (row-major from the top left, `size`² entries; true = white).
    pub fn cells(&self, id: usize) -> Vec<bool> {
        let n = self.size * self.size;
        (0..n).map(|i| (self.codes[id] >> (n - 1 - i)) & 1 == 1).collect()
    }

    /// The closest marker to `code` over the four quarter turns: (id, turns, Hamming distance),
    /// where `turns` quarter turns clockwise of the upright marker give the cells read.
    pub fn closest(&self, code: u64) -> Option<(usize, usize, u32)> {
        let turned = turns(code, self.size);
        let mut best: Option<(usize, usize, u32)> = None;
        for (id, &c) in self.codes.iter().enumerate() {
            for (k, &t) in turned.iter().enumerate() {
                let d = (c ^ t).count_ones();
                if best.is_none_or(|b| d < b.2) {
                    best = Some((id, k, d));
                }
            }
        }
        best
    }
}

/// `code` (row-major cells, first cell most significant) turned back by 0, 1, 2 and 3 quarter
/// turns counter-clockwise: entry k equals the upright code when the cells read were the
/// upright marker turned k quarter turns clockwise.
pub fn turns(code: u64, size: usize) -> [u64; 4] {
    let n = size * size;
    let bit = |c: u64, r: usize, col: usize| (c >> (n - 1 - (r * size + col))) & 1;
    let mut out = [code; 4];
    for k in 1..4 {
        let prev = out[k - 1];
        let mut v = 0u64;
        // A counter-clockwise quarter turn: the new cell (r, c) is the old cell (c, size − 1 − r).
        for r in 0..size {
            for c in 0..size {
                v = (v << 1) | bit(prev, c, size - 1 - r);
            }
        }
        out[k] = v;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_parses_and_names_resolve() {
        let d = Dictionary::predefined("DICT_4X4_50").unwrap();
        assert_eq!((d.size, d.codes.len(), d.max_correction_bits, d.opencv_id), (4, 50, 1, 0));
        let e = Dictionary::predefined("5x5_1000").unwrap();
        assert_eq!((e.size, e.codes.len(), e.max_correction_bits), (5, 1000, 2));
        assert_eq!(Dictionary::predefined("10").unwrap().name, "DICT_6X6_250");
        assert!(Dictionary::predefined("DICT_9X9_50").unwrap_err().to_string().contains("unknown ArUco dictionary"));
        // The smaller dictionaries are the first markers of the 1000-marker ones (as in OpenCV).
        let big = Dictionary::predefined("DICT_6X6_1000").unwrap();
        assert_eq!(Dictionary::predefined("DICT_6X6_250").unwrap().codes[..], big.codes[..250]);
    }

    #[test]
    fn four_quarter_turns_are_the_identity_and_codes_are_apart() {
        for name in ["DICT_4X4_1000", "DICT_5X5_1000", "DICT_6X6_1000", "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL"] {
            let d = Dictionary::predefined(name).unwrap();
            for &c in d.codes.iter().take(50) {
                let t = turns(c, d.size);
                assert_eq!(turns(t[3], d.size)[1], c);
                assert_eq!(turns(t[1], d.size)[3], c);
            }
            // Every marker is at least 2·max_correction_bits + 1 from every other marker in every
            // orientation (the dictionary's defining property), checked on its first 50.
            let k = d.max_correction_bits;
            for (i, &c) in d.codes.iter().take(50).enumerate() {
                let (id, turn, dist) = d.closest(c).unwrap();
                assert_eq!((id, turn, dist), (i, 0, 0), "{name} marker {i}");
                for (j, &o) in d.codes.iter().take(50).enumerate() {
                    for (r, &t) in turns(o, d.size).iter().enumerate() {
                        if i != j || r != 0 {
                            assert!((c ^ t).count_ones() > 2 * (k * 6 / 10), "{name}: markers {i} and {j} turn {r}");
                        }
                    }
                }
            }
        }
    }
}
