//! Numbers in messages: fixed-point where that reads well, scientific notation where fixed-point
//! would print hundreds of digits (an input of 1e300 or 1e-300 echoed back in an error).

/// `x` with `digits` decimals when 10⁻⁴ ≤ |x| < 10⁹ (or x = 0), else in scientific notation
/// with `digits` decimals in the mantissa; NaN and infinities as Rust prints them.
pub fn fixed(x: f64, digits: usize) -> String {
    let a = x.abs();
    if !x.is_finite() || x == 0.0 || (1e-4..1e9).contains(&a) {
        format!("{x:.digits$}")
    } else {
        format!("{x:.digits$e}")
    }
}

/// `x` as Rust's shortest round-trip form when 10⁻⁴ ≤ |x| < 10⁹ (or x = 0), else in
/// scientific notation (also shortest round-trip).
pub fn short(x: f64) -> String {
    let a = x.abs();
    if !x.is_finite() || x == 0.0 || (1e-4..1e9).contains(&a) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ordinary values print as before; extreme ones stay short and still parse back.
    #[test]
    fn extreme_values_stay_short_and_exact() {
        assert_eq!(short(550.0), "550");
        assert_eq!(short(0.125), "0.125");
        assert_eq!(fixed(0.34521, 4), "0.3452");
        assert_eq!(fixed(-3.0, 1), "-3.0");
        for x in [1e-300, -4.0125e22, 1e30, 6.02214076e23, 1.5e-7] {
            let s = short(x);
            assert!(s.len() < 24, "{s}");
            assert_eq!(s.parse::<f64>().unwrap(), x);
            assert!(fixed(x, 4).len() < 16, "{}", fixed(x, 4));
        }
        assert_eq!(short(f64::NAN), "NaN");
    }
}
