//! Helpers shared by the optics tests.

use num_complex::Complex64;

#[allow(dead_code)]
pub fn c(re: f64, im: f64) -> Complex64 {
    Complex64::new(re, im)
}

#[allow(dead_code)]
pub fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}
