//! Scene parameters addressed by path, for analysis by synthesis (`lucent fit scene`; the
//! minimiser is in the `analysis` crate).
//!
//! A parameter path is a dot-separated walk through the scene's TOML document, following the
//! scene format's own tables (docs/scene-format.md): table keys by name, array entries by index
//! or, for `[[objects]]` and `[[lights]]`, by the entry's `name`. Examples:
//! `spectra.light.scale`, `lights.0.scale`, `materials.wall.albedo`,
//! `objects.milk_whole.medium.milk.fat_percent`. The leaf must be a number, except that a missing
//! `scale` key (whose default is 1 for every spectrum and light) may be addressed and is then
//! inserted. Each evaluation edits the parsed document, re-serialises it and builds the scene
//! with [`Scene::from_toml_str`] resolving relative files against the original scene's folder.
//!

use crate::load::error::{quote, short};
use crate::scene::Scene;
use anyhow::{bail, Context, Result};
use std::path::{Path, PathBuf};

/// One fitted parameter: its path in the scene document and its box bounds (inclusive).
#[derive(Clone, Debug, PartialEq)]
pub struct ParamSpec {
    /// Dot-separated path into the scene's TOML document.
    pub path: String,
    /// Lower bound (same unit as the scene field).
    pub min: f64,
    /// Upper bound (same unit as the scene field).
    pub max: f64,
}

impl ParamSpec {
    /// Parse `PATH=MIN:MAX` (as given to `--param`).
    pub fn parse(text: &str) -> Result<ParamSpec> {
        let (path, range) = text
            .split_once('=')
            .with_context(|| format!("--param {}: expected PATH=MIN:MAX", quote(text)))?;
        let (lo, hi) = range
            .split_once(':')
            .with_context(|| format!("--param {}: expected PATH=MIN:MAX", quote(text)))?;
        let num = |s: &str| -> Result<f64> {
            match s.trim().parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => bail!("--param {}: bound {} is not a finite number", quote(text), quote(s)),
            }
        };
        let (min, max) = (num(lo)?, num(hi)?);
        let path = path.trim().to_string();
        if path.is_empty() || path.split('.').any(|s| s.is_empty()) {
            bail!("--param {}: empty path or path segment", quote(text));
        }
        if !(min < max) {
            bail!("--param {path}: MIN {min} must be below MAX {max}");
        }
        Ok(ParamSpec { path, min, max })
    }
}

/// Finds the child of `v` named by `seg`: a table key, an array index, or the array entry whose
/// `name` is `seg`.
fn child<'a>(v: &'a mut toml::Value, seg: &str) -> Option<&'a mut toml::Value> {
    match v {
        toml::Value::Table(t) => t.get_mut(seg),
        toml::Value::Array(a) => {
            if let Ok(i) = seg.parse::<usize>() {
                a.get_mut(i)
            } else {
                a.iter_mut().find(|e| e.get("name").and_then(|n| n.as_str()) == Some(seg))
            }
        }
        _ => None,
    }
}

/// The number at `path` (a missing `scale` leaf reads as its default, 1).
pub fn get_param(doc: &toml::Value, path: &str) -> Result<f64> {
    let mut copy = doc.clone();
    let slot = resolve(&mut copy, path, false)?;
    Ok(slot.map(|v| number(v, path)).transpose()?.unwrap_or(1.0))
}

/// Sets the number at `path` (inserting a missing `scale` leaf).
pub fn set_param(doc: &mut toml::Value, path: &str, value: f64) -> Result<()> {
    let slot = resolve(doc, path, true)?.expect("resolve inserts when asked");
    number(slot, path)?;
    *slot = toml::Value::Float(value);
    Ok(())
}

fn number(v: &toml::Value, path: &str) -> Result<f64> {
    match v {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => bail!("parameter {path} is a {}, not a number", other.type_str()),
    }
}

/// Walks `path`; `Ok(None)` for a missing `scale` leaf in an existing table (inserted when `insert`).
fn resolve<'a>(doc: &'a mut toml::Value, path: &str, insert: bool) -> Result<Option<&'a mut toml::Value>> {
    let segs: Vec<&str> = path.split('.').collect();
    let mut cur = doc;
    for (k, seg) in segs.iter().enumerate() {
        let last = k + 1 == segs.len();
        if last && *seg == "scale" && cur.is_table() && cur.get("scale").is_none() {
            if !insert {
                return Ok(None);
            }
            let t = cur.as_table_mut().expect("checked table");
            t.insert("scale".into(), toml::Value::Float(1.0));
            return Ok(t.get_mut("scale"));
        }
        let prefix = segs[..=k].join(".");
        cur = match child(cur, seg) {
            Some(c) => c,
            None => bail!("parameter path {} does not exist in the scene (no {})", short(path), quote(&prefix)),
        };
    }
    Ok(Some(cur))
}

/// A parsed scene document from which scenes with changed parameters are built.
#[derive(Clone, Debug)]
pub struct SceneTemplate {
    /// The parsed TOML document.
    pub doc: toml::Value,
    /// Name for error messages (the file name).
    pub name: String,
    /// Folder against which the scene's relative file names resolve.
    pub base_dir: PathBuf,
}

impl SceneTemplate {
    /// Reads and parses a scene file (checking that it builds as is).
    pub fn load(path: &Path) -> Result<SceneTemplate> {
        Scene::load(path)?;
        let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read scene", path.display()))?;
        let doc: toml::Value = toml::from_str(&text).with_context(|| format!("{}: invalid TOML", path.display()))?;
        let base_dir = path.parent().map(|p| p.to_path_buf()).unwrap_or_default();
        Ok(SceneTemplate { doc, name: path.display().to_string(), base_dir })
    }

    /// The scene with each `(path, value)` set.
    pub fn build(&self, values: &[(&str, f64)]) -> Result<Scene> {
        let mut doc = self.doc.clone();
        for (p, v) in values {
            set_param(&mut doc, p, *v)?;
        }
        let text = to_inline_toml(&doc)?;
        let label = format!("{} (with fitted parameters)", self.name);
        Scene::from_toml_str(&text, &label, &self.base_dir)
    }
}

/// Serialises a document as one `key = value` line per top-level key, every nested table inline.
/// (`toml::to_string` writes nested tables as `[objects.medium.milk]` headers, which the scene
/// parser's span-tracking values do not accept back.)
pub fn to_inline_toml(doc: &toml::Value) -> Result<String> {
    let Some(table) = doc.as_table() else { bail!("scene document is not a table") };
    let mut s = String::new();
    for (k, v) in table {
        let key = if !k.is_empty() && k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
            k.clone()
        } else {
            toml::Value::String(k.clone()).to_string()
        };
        s += &format!("{key} = {v}\n");
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_resolve_by_key_index_and_name() {
        let mut doc: toml::Value = toml::from_str(
            "[spectra.w]\nconstant = 0.5\n[[objects]]\nname = \"milk\"\nmedium = { milk = { fat_percent = 3 } }\n",
        )
        .unwrap();
        assert_eq!(get_param(&doc, "objects.milk.medium.milk.fat_percent").unwrap(), 3.0);
        assert_eq!(get_param(&doc, "objects.0.medium.milk.fat_percent").unwrap(), 3.0);
        assert_eq!(get_param(&doc, "spectra.w.scale").unwrap(), 1.0);
        set_param(&mut doc, "spectra.w.scale", 0.7).unwrap();
        assert_eq!(get_param(&doc, "spectra.w.scale").unwrap(), 0.7);
        let e = get_param(&doc, "objects.milk.medium.milk.fat").unwrap_err().to_string();
        assert!(e.contains("objects.milk.medium.milk.fat"), "{e}");
        assert!(get_param(&doc, "objects.2.name").is_err());
        assert!(get_param(&doc, "objects.milk.name").is_err()); // a string, not a number
        let back: toml::Value = toml::from_str(&to_inline_toml(&doc).unwrap()).unwrap();
        assert_eq!(back, doc);
    }

    #[test]
    fn param_spec_parses_and_rejects() {
        let p = ParamSpec::parse("lights.0.scale=0.5:2").unwrap();
        assert_eq!((p.path.as_str(), p.min, p.max), ("lights.0.scale", 0.5, 2.0));
        assert!(ParamSpec::parse("a.b=2:1").is_err());
        assert!(ParamSpec::parse("a.b=nan:1").is_err());
        assert!(ParamSpec::parse("a.b").is_err());
        assert!(ParamSpec::parse("a..b=0:1").is_err());
    }

}
