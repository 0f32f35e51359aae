//! Reading the small numeric CSV tables embedded in the crate and given by users (spectra,
//! colour-matching functions): a header row of column names, then one number per column.

use anyhow::{bail, Context, Result};

/// Parses a CSV text: lines starting with `#` and blank lines are skipped, the first other line is
/// the header row (column names), every following line has one number per column.
/// Returns (names, columns). Errors name the line (1-based) and column.
pub fn read_csv_columns(text: &str) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let mut names: Option<Vec<String>> = None;
    let mut cols: Vec<Vec<f64>> = Vec::new();
    for (lineno, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        match &names {
            None => {
                if let Some((j, f)) = fields.iter().enumerate().find(|(j, f)| fields[..*j].contains(f)) {
                    bail!("CSV line {}: column '{}' appears twice in the header (columns {} and {})", lineno + 1, f, fields.iter().position(|g| g == f).unwrap_or(0) + 1, j + 1);
                }
                names = Some(fields.iter().map(|s| s.to_string()).collect());
                cols = vec![Vec::new(); fields.len()];
            }
            Some(n) => {
                if fields.len() != n.len() {
                    bail!(
                        "CSV line {}: {} fields but the header has {}",
                        lineno + 1,
                        fields.len(),
                        n.len()
                    );
                }
                for (j, f) in fields.iter().enumerate() {
                    let v: f64 = f.parse().with_context(|| {
                        format!(
                            "CSV line {}, column '{}': '{}' is not a number",
                            lineno + 1,
                            n[j],
                            f
                        )
                    })?;
                    if !v.is_finite() {
                        bail!(
                            "CSV line {}, column '{}': value is not finite",
                            lineno + 1,
                            n[j]
                        );
                    }
                    cols[j].push(v);
                }
            }
        }
    }
    let names = names.context("CSV has no header row")?;
    if cols.first().is_none_or(|c| c.is_empty()) {
        bail!("CSV has a header but no data rows");
    }
    Ok((names, cols))
}
