//! Numbers in human-readable output (JSON keeps full precision).

/// A measured quantity in text output: `digits` significant digits, trailing zeros dropped,
/// exponent notation outside [10⁻⁴, 10^digits) (JSON output keeps full precision).
pub(crate) fn sig(v: f64, digits: usize) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    let digits = digits.max(1);
    let e = v.abs().log10().floor() as i32;
    if (-4..digits as i32).contains(&e) {
        let decimals = (digits as i32 - 1 - e).max(0) as usize;
        let t = format!("{v:.decimals$}");
        let t = if t.contains('.') { t.trim_end_matches('0').trim_end_matches('.').to_string() } else { t };
        // rounding may carry into a new digit (9.9999996 → 10.000000): still correct
        if t == "-0" { "0".into() } else { t }
    } else {
        let t = format!("{v:.*e}", digits - 1);
        match t.split_once('e') {
            Some((mant, exp)) if mant.contains('.') => format!("{}e{exp}", mant.trim_end_matches('0').trim_end_matches('.')),
            _ => t,
        }
    }
}
