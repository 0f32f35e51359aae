//! Checkpoints: the film's sums and counts with everything needed to resume or merge a render.
//!
//! Binary format, all integers and floats little-endian. Version 1 (a film of the image only;
//! still written for such films, so older builds read them):
//! ```text
//! magic      8 bytes  "LUCENTCK"
//! version    u32      1
//! width      u32      pixels
//! height     u32      pixels
//! scene_hash u64      FNV-1a 64 of scene content hash + resolution + integrator settings (see scene_hash)
//! scene      u32 length + UTF-8   what was rendered (file path or "built-in Cornell box"), for messages
//! integrator u8 kind (IntegratorKind::code: 0 path, 1 direct, 2 ao, 3 volpath), u32 max_depth, u32 rr_depth
//! target_spp u64      samples per pixel the run was asked for (0: none, e.g. --time)
//! spp        u64      samples per pixel accumulated
//! rejected   u64      non-finite samples counted as zero
//! runs       u32 count, then per run: seed u64, first_pass u64, passes u64
//! sums       width*height*3 f64, row-major XYZ sums
//! checksum   u64      FNV-1a 64 of every byte before it
//! ```
//! Version 2 (a film with AOVs or spectral bins) is version 1 with, after `runs`:
//! ```text
//! aovs       u32 count, then one u8 code per AOV (Aov::code: 0 albedo, 1 normal, 2 depth,
//!            3 position, 4 object_id, 5 variance), in increasing order
//! bins       u8 0 (none) or 1, then f32 start_nm, f32 width_nm, u32 count
//! ```
//! and, after the XYZ sums, `extras`: width*height*E f64, pixel-major, E = the film's
//! [`FilmLayout::extra_len`] (the channels of the AOVs in that order, then one per bin).
//! A single render's checkpoint holds one run (seed, passes 0..n): resuming continues at pass n.
//! A merged checkpoint holds several runs; runs of the same seed must cover disjoint pass ranges,
//! because a pass is a deterministic function of (seed, pass): overlapping ranges would count
//! the very same samples twice.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use crate::film::{Film, FilmLayout};
use crate::integrator::aov::Aov;
use crate::math::spectral::SpectralBins;
use crate::integrator::settings::{IntegratorKind, IntegratorSettings};
use crate::scene::Scene;

const MAGIC: &[u8; 8] = b"LUCENTCK";
/// Newest version of the checkpoint format this build writes (and the oldest it reads is 1):
/// version 1 for films of the image only, 2 for films with AOVs or spectral bins.
pub const CHECKPOINT_VERSION: u32 = 2;

pub use crate::math::hash::Fnv1a64;

/// Name of an integrator as the CLI spells it.
pub fn integrator_name(kind: IntegratorKind) -> &'static str {
    kind.name()
}

/// Stable identity of a render: FNV-1a 64 of the scene's content hash
/// ([`Scene::content_hash`]: scene text and every file it reads), the resolution in pixels and
/// the integrator settings. Two runs with the same hash sample the same image, so their
/// checkpoints can be resumed or merged.
pub fn scene_hash(scene_content_hash: u64, width: u32, height: u32, settings: &IntegratorSettings) -> u64 {
    let mut h = Fnv1a64::new();
    h.write_field(b"lucent render identity v1");
    h.write(&scene_content_hash.to_le_bytes());
    h.write(&width.to_le_bytes());
    h.write(&height.to_le_bytes());
    h.write(&[settings.kind.code()]);
    h.write(&settings.max_depth.to_le_bytes());
    h.write(&settings.rr_depth.to_le_bytes());
    h.finish()
}

/// One contiguous run of passes of one seed: passes `first_pass .. first_pass + passes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// Seed of the random sequence (`--seed`).
    pub seed: u64,
    /// First pass index rendered.
    pub first_pass: u64,
    /// Number of passes rendered (samples per pixel contributed).
    pub passes: u64,
}

impl Run {
    /// Index of the pass after the last one of this run.
    pub fn end_pass(&self) -> u64 {
        self.first_pass + self.passes
    }
    fn overlaps(&self, other: &Run) -> bool {
        self.seed == other.seed && self.first_pass < other.end_pass() && other.first_pass < self.end_pass()
    }
}

/// What a checkpoint must match to be resumed or merged with a render.
#[derive(Clone, Debug)]
pub struct RenderIdentity {
    /// [`scene_hash`] of the render.
    pub scene_hash: u64,
    /// Human-readable scene name, for messages (file path or "built-in Cornell box").
    pub scene_name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Integrator and its settings.
    pub settings: IntegratorSettings,
}

impl RenderIdentity {
    /// Identity of a render of a scene with content hash `scene_content_hash` at `width`×`height` with `settings`.
    pub fn new(scene_content_hash: u64, scene_name: &str, width: u32, height: u32, settings: &IntegratorSettings) -> Self {
        RenderIdentity {
            scene_hash: scene_hash(scene_content_hash, width, height, settings),
            scene_name: scene_name.to_string(),
            width,
            height,
            settings: settings.clone(),
        }
    }

    /// Identity of a render of `scene` (at its current resolution) with `settings`.
    pub fn of_scene(scene: &Scene, settings: &IntegratorSettings) -> Self {
        let (w, h) = scene.resolution();
        RenderIdentity::new(scene.content_hash(), &scene.source, w, h, settings)
    }
}

fn describe_settings(s: &IntegratorSettings) -> String {
    format!("{} (max depth {}, roulette from {})", integrator_name(s.kind), s.max_depth, s.rr_depth)
}

/// Accumulated state of one render (or a merge of several): film, identity, runs.
#[derive(Clone, Debug)]
pub struct Checkpoint {
    /// What was rendered.
    pub identity: RenderIdentity,
    /// Samples per pixel the run was asked for (`--spp`), if any.
    pub target_spp: Option<u64>,
    /// The runs whose samples the film holds.
    pub runs: Vec<Run>,
    /// The accumulated sums and counts.
    pub film: Film,
}

struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        if self.bytes.len() - self.pos < n {
            bail!("truncated: file ends inside `{what}` at byte {}", self.pos);
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(s)
    }
    fn u8(&mut self, what: &str) -> Result<u8> {
        Ok(self.take(1, what)?[0])
    }
    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
    fn u64(&mut self, what: &str) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8, what)?.try_into().unwrap()))
    }
    fn f32(&mut self, what: &str) -> Result<f32> {
        Ok(f32::from_le_bytes(self.take(4, what)?.try_into().unwrap()))
    }
}

impl Checkpoint {
    /// A checkpoint of a single run of `seed` whose film holds passes `0..film.samples_per_pixel()`.
    pub fn single_run(identity: RenderIdentity, seed: u64, target_spp: Option<u64>, film: Film) -> Checkpoint {
        let runs = vec![Run { seed, first_pass: 0, passes: film.samples_per_pixel() }];
        Checkpoint { identity, target_spp, runs, film }
    }

    /// Serialise to the binary format described in the module documentation.
    pub fn to_bytes(&self) -> Vec<u8> {
        encode(&self.identity, self.target_spp, &self.runs, &self.film)
    }

    /// Parse the binary format; errors say which field is wrong (without the file name).
    pub fn from_bytes(bytes: &[u8]) -> Result<Checkpoint> {
        if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
            bail!("not a lucent checkpoint (bad magic bytes)");
        }
        if bytes.len() < MAGIC.len() + 4 + 8 {
            bail!("truncated checkpoint ({} bytes)", bytes.len());
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let mut r = Reader { bytes: body, pos: MAGIC.len() };
        let version = r.u32("version")?;
        if !(1..=CHECKPOINT_VERSION).contains(&version) {
            bail!("checkpoint format version {version}, this lucent reads versions 1 to {CHECKPOINT_VERSION}");
        }
        let mut h = Fnv1a64::new();
        h.write(body);
        if h.finish() != u64::from_le_bytes(tail.try_into().unwrap()) {
            bail!("checksum mismatch: the checkpoint is truncated or corrupted");
        }
        let width = r.u32("width")?;
        let height = r.u32("height")?;
        if width == 0 || height == 0 {
            bail!("bad resolution {width}×{height}");
        }
        let scene_hash = r.u64("scene_hash")?;
        let name_len = r.u32("scene name length")? as usize;
        let scene_name = std::str::from_utf8(r.take(name_len, "scene name")?)
            .context("scene name is not UTF-8")?
            .to_string();
        let code = r.u8("integrator")?;
        let kind = IntegratorKind::from_code(code).with_context(|| format!("unknown integrator code {code}"))?;
        let max_depth = r.u32("max_depth")?;
        let rr_depth = r.u32("rr_depth")?;
        let target = r.u64("target_spp")?;
        let spp = r.u64("spp")?;
        let rejected = r.u64("rejected")?;
        let n_runs = r.u32("runs")? as usize;
        let mut runs = Vec::with_capacity(n_runs.min(1 << 16));
        for _ in 0..n_runs {
            let seed = r.u64("run seed")?;
            let first_pass = r.u64("run first_pass")?;
            let passes = r.u64("run passes")?;
            if first_pass.checked_add(passes).is_none() {
                bail!("run {} (seed {seed}): passes {first_pass} + {passes} overflow a 64-bit counter", runs.len());
            }
            runs.push(Run { seed, first_pass, passes });
        }
        let total = runs.iter().try_fold(0u64, |t, r| t.checked_add(r.passes));
        if total != Some(spp) {
            match total {
                Some(t) => bail!("runs add up to {t} samples per pixel but the film holds {spp}"),
                None => bail!("the runs' pass counts overflow a 64-bit counter (the film holds {spp} samples per pixel)"),
            }
        }
        let layout = if version >= 2 { read_layout(&mut r)? } else { FilmLayout::default() };
        let n = width as usize * height as usize;
        let per_pixel = 3 + layout.extra_len();
        let need = n
            .checked_mul(8 * per_pixel)
            .ok_or_else(|| anyhow::anyhow!("bad resolution {width}×{height}: too many pixels"))?;
        if body.len() - r.pos != need {
            bail!(
                "expected {need} bytes of sums for {width}×{height} pixels with {}, found {}",
                layout.describe(),
                body.len() - r.pos
            );
        }
        let (xyz_bytes, extra_bytes) = body[r.pos..].split_at(24 * n);
        let f64_at = |c: &[u8], k: usize| f64::from_le_bytes(c[8 * k..8 * k + 8].try_into().unwrap());
        let sums: Vec<[f64; 3]> = xyz_bytes.chunks_exact(24).map(|c| [f64_at(c, 0), f64_at(c, 1), f64_at(c, 2)]).collect();
        let extra: Vec<f64> = extra_bytes.chunks_exact(8).map(|c| f64_at(c, 0)).collect();
        let film = Film::from_parts(width, height, layout, sums, extra, spp, rejected)?;
        let settings = IntegratorSettings { kind, max_depth, rr_depth };
        Ok(Checkpoint {
            identity: RenderIdentity { scene_hash, scene_name, width, height, settings },
            target_spp: (target > 0).then_some(target),
            runs,
            film,
        })
    }

    /// Write atomically (temporary name, then rename): a failed write leaves any old file intact.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_bytes(path, &self.to_bytes())
    }

    /// Write the checkpoint of a single run of `seed` (passes `0..film.samples_per_pixel()`)
    /// atomically, without copying the film.
    pub fn write_single_run(path: &Path, identity: &RenderIdentity, seed: u64, target_spp: Option<u64>, film: &Film) -> Result<()> {
        let runs = [Run { seed, first_pass: 0, passes: film.samples_per_pixel() }];
        write_bytes(path, &encode(identity, target_spp, &runs, film))
    }

    /// Read a checkpoint; errors name the file.
    pub fn read(path: &Path) -> Result<Checkpoint> {
        let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read checkpoint", path.display()))?;
        Checkpoint::from_bytes(&bytes).with_context(|| format!("{}: bad checkpoint", path.display()))
    }

    /// Refuse (with an error naming `path`) a checkpoint whose film accumulates other AOVs or
    /// spectral bins than `layout`.
    pub fn check_layout(&self, path: &Path, layout: &FilmLayout) -> Result<()> {
        let have = self.film.layout();
        if have != layout {
            bail!("{}: checkpoint holds {}, this render asks for {}", path.display(), have.describe(), layout.describe());
        }
        Ok(())
    }

    /// Refuse (with an error naming `path`) a checkpoint of another scene, resolution or integrator.
    pub fn check_matches(&self, path: &Path, expected: &RenderIdentity) -> Result<()> {
        let id = &self.identity;
        let file = path.display();
        if (id.width, id.height) != (expected.width, expected.height) {
            bail!(
                "{file}: checkpoint is {}×{} pixels, this render is {}×{}",
                id.width,
                id.height,
                expected.width,
                expected.height
            );
        }
        let (a, b) = (&id.settings, &expected.settings);
        if (a.kind, a.max_depth, a.rr_depth) != (b.kind, b.max_depth, b.rr_depth) {
            bail!(
                "{file}: checkpoint was rendered with integrator {}, this render uses {}",
                describe_settings(a),
                describe_settings(b)
            );
        }
        if id.scene_hash != expected.scene_hash {
            bail!(
                "{file}: checkpoint is of another scene ({}, hash {:016x}), not {} (hash {:016x})",
                id.scene_name,
                id.scene_hash,
                expected.scene_name,
                expected.scene_hash
            );
        }
        Ok(())
    }

    /// Seed and next pass index to continue this checkpoint; only a single run's checkpoint
    /// can be resumed (`path` is for the error message).
    pub fn resume_point(&self, path: &Path) -> Result<(u64, u64)> {
        match self.runs.as_slice() {
            [run] => Ok((run.seed, run.end_pass())),
            runs => bail!(
                "{}: checkpoint holds {} merged runs; only a single run's checkpoint can be resumed",
                path.display(),
                runs.len()
            ),
        }
    }

    /// Merge checkpoints of independent runs of the same render: sums and sample counts add,
    /// so each run is weighted by its number of samples. Refuses checkpoints of another scene,
    /// resolution or integrator than the first, and runs that repeat passes of the same seed.
    /// (To merge many large checkpoints without holding them all in memory, use [`Merger`].)
    pub fn merge(parts: &[(PathBuf, Checkpoint)]) -> Result<Checkpoint> {
        let mut m = Merger::new();
        for (path, c) in parts {
            m.add(path, c.clone())?;
        }
        m.finish()
    }
}

/// Merges checkpoints one at a time, so that only the running total and one part are in memory.
#[derive(Debug, Default)]
pub struct Merger {
    merged: Option<(PathBuf, Checkpoint)>,
    origin: Vec<(Run, PathBuf)>,
}

impl Merger {
    /// An empty merge.
    pub fn new() -> Merger {
        Merger::default()
    }

    /// Add the checkpoint read from `path` (the path names it in errors).
    pub fn add(&mut self, path: &Path, part: Checkpoint) -> Result<()> {
        if let Some((first_path, merged)) = &self.merged {
            part.check_matches(path, &merged.identity)
                .with_context(|| format!("cannot merge with {}", first_path.display()))?;
            part.check_layout(path, merged.film.layout())
                .with_context(|| format!("cannot merge with {}", first_path.display()))?;
        }
        for (i, run) in part.runs.iter().enumerate() {
            let earlier = self.origin.iter().map(|(r, p)| (r, p.as_path()));
            let within = part.runs[..i].iter().map(|r| (r, path));
            if let Some((other, other_path)) = earlier.chain(within).find(|(o, _)| o.overlaps(run)) {
                bail!(
                    "{}: seed {} passes {}..{} were already merged from {} (seed {} passes {}..{}): \
                     the same seed gives the same samples; render each part with its own --seed",
                    path.display(),
                    run.seed,
                    run.first_pass,
                    run.end_pass(),
                    other_path.display(),
                    other.seed,
                    other.first_pass,
                    other.end_pass()
                );
            }
        }
        self.origin.extend(part.runs.iter().map(|r| (*r, path.to_path_buf())));
        match &mut self.merged {
            None => {
                let mut first = part;
                first.target_spp = None;
                self.merged = Some((path.to_path_buf(), first));
            }
            Some((_, merged)) => {
                let spp = merged.film.samples_per_pixel().checked_add(part.film.samples_per_pixel());
                let rejected = merged.film.rejected_samples().checked_add(part.film.rejected_samples());
                if spp.is_none() || rejected.is_none() {
                    bail!("{}: merged sample counts would overflow 64 bits", path.display());
                }
                merged.film.add_film(&part.film)?;
                merged.runs.extend_from_slice(&part.runs);
            }
        }
        Ok(())
    }

    /// The merged checkpoint; an error if nothing was added.
    pub fn finish(self) -> Result<Checkpoint> {
        match self.merged {
            Some((_, c)) => Ok(c),
            None => bail!("nothing to merge: no checkpoints given"),
        }
    }
}

/// Serialise to the binary format described in the module documentation.
fn encode(id: &RenderIdentity, target_spp: Option<u64>, runs: &[Run], film: &Film) -> Vec<u8> {
    let n = film.pixel_count();
    let layout = film.layout();
    let version: u32 = if layout.is_empty() { 1 } else { 2 };
    let mut b = Vec::with_capacity(160 + id.scene_name.len() + 24 * runs.len() + 8 * (3 + layout.extra_len()) * n);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&version.to_le_bytes());
    b.extend_from_slice(&id.width.to_le_bytes());
    b.extend_from_slice(&id.height.to_le_bytes());
    b.extend_from_slice(&id.scene_hash.to_le_bytes());
    b.extend_from_slice(&(id.scene_name.len() as u32).to_le_bytes());
    b.extend_from_slice(id.scene_name.as_bytes());
    b.push(id.settings.kind.code());
    b.extend_from_slice(&id.settings.max_depth.to_le_bytes());
    b.extend_from_slice(&id.settings.rr_depth.to_le_bytes());
    b.extend_from_slice(&target_spp.unwrap_or(0).to_le_bytes());
    b.extend_from_slice(&film.samples_per_pixel().to_le_bytes());
    b.extend_from_slice(&film.rejected_samples().to_le_bytes());
    b.extend_from_slice(&(runs.len() as u32).to_le_bytes());
    for r in runs {
        b.extend_from_slice(&r.seed.to_le_bytes());
        b.extend_from_slice(&r.first_pass.to_le_bytes());
        b.extend_from_slice(&r.passes.to_le_bytes());
    }
    if version >= 2 {
        b.extend_from_slice(&(layout.aovs.len() as u32).to_le_bytes());
        b.extend(layout.aovs.iter().map(|a| a.code()));
        match layout.bins {
            None => b.push(0),
            Some(bins) => {
                b.push(1);
                b.extend_from_slice(&bins.start_nm.to_le_bytes());
                b.extend_from_slice(&bins.width_nm.to_le_bytes());
                b.extend_from_slice(&bins.count.to_le_bytes());
            }
        }
    }
    for s in film.sums() {
        for v in s {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    for v in film.extra_sums() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let mut h = Fnv1a64::new();
    h.write(&b);
    b.extend_from_slice(&h.finish().to_le_bytes());
    b
}

/// The AOVs and bins of a version-2 checkpoint.
fn read_layout(r: &mut Reader) -> Result<FilmLayout> {
    let n_aovs = r.u32("aovs")? as usize;
    if n_aovs > Aov::ALL.len() {
        bail!("{n_aovs} AOVs listed; there are {} kinds", Aov::ALL.len());
    }
    let mut aovs = Vec::with_capacity(n_aovs);
    for _ in 0..n_aovs {
        let code = r.u8("aov")?;
        let aov = Aov::from_code(code).with_context(|| format!("unknown AOV code {code}"))?;
        if aovs.last().is_some_and(|&last| last >= aov) {
            bail!("AOVs are not listed in increasing order without repeats");
        }
        aovs.push(aov);
    }
    let bins = match r.u8("bins")? {
        0 => None,
        1 => {
            let start = r.f32("bins start_nm")?;
            let width = r.f32("bins width_nm")?;
            let count = r.u32("bins count")?;
            let end = start as f64 + width as f64 * count as f64;
            let bins = SpectralBins::new(start as f64, end, width as f64).map_err(|e| anyhow::anyhow!("bad spectral bins: {e}"))?;
            if bins.count != count || bins.start_nm != start || bins.width_nm != width {
                bail!("bad spectral bins: {start} nm + {count} × {width} nm");
            }
            Some(bins)
        }
        other => bail!("bad spectral-bins flag {other}"),
    };
    Ok(FilmLayout::new(aovs, bins))
}

fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    crate::image_io::write_atomic(path, |tmp| {
        std::fs::write(tmp, bytes).with_context(|| format!("cannot write {}", tmp.display()))
    })
    .with_context(|| format!("{}: cannot write checkpoint", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings(kind: IntegratorKind) -> IntegratorSettings {
        IntegratorSettings { kind, max_depth: 8, rr_depth: 5 }
    }

    fn identity(scene: &[u8], w: u32, h: u32) -> RenderIdentity {
        let mut f = Fnv1a64::new();
        f.write(scene);
        RenderIdentity::new(f.finish(), "test.toml", w, h, &settings(IntegratorKind::Path))
    }

    fn film_with(w: u32, h: u32, values: &[f32]) -> Film {
        let mut f = Film::new(w, h);
        for &v in values {
            let pass: Vec<[f32; 3]> = (0..(w * h)).map(|i| [v + i as f32, 2.0 * v, 0.1 * v]).collect();
            f.add_pass(&pass);
        }
        f
    }

    #[test]
    fn fnv1a_matches_published_test_vectors() {
        // Reference values from the FNV test suite (Fowler/Noll/Vo, isthe.com/chongo/tech/comp/fnv).
        let h = |s: &[u8]| {
            let mut f = Fnv1a64::new();
            f.write(s);
            f.finish()
        };
        assert_eq!(h(b""), 0xcbf29ce484222325);
        assert_eq!(h(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(h(b"foobar"), 0x85944171f73967e8);
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let film = film_with(3, 2, &[0.1, 0.7, 1.0 / 3.0]);
        let c = Checkpoint::single_run(identity(b"scene", 3, 2), 42, Some(16), film.clone());
        let back = Checkpoint::from_bytes(&c.to_bytes()).unwrap();
        assert_eq!(back.film, film);
        assert_eq!(back.runs, vec![Run { seed: 42, first_pass: 0, passes: 3 }]);
        assert_eq!(back.target_spp, Some(16));
        assert_eq!(back.identity.scene_hash, c.identity.scene_hash);
        assert_eq!(back.identity.scene_name, "test.toml");
        assert_eq!(back.resume_point(Path::new("x")).unwrap(), (42, 3));
    }

    #[test]
    fn corrupted_or_truncated_bytes_are_refused() {
        let c = Checkpoint::single_run(identity(b"scene", 2, 2), 1, None, film_with(2, 2, &[1.0]));
        let mut bytes = c.to_bytes();
        assert!(Checkpoint::from_bytes(&bytes[..bytes.len() - 9]).is_err());
        let k = bytes.len() / 2;
        bytes[k] ^= 1;
        let err = Checkpoint::from_bytes(&bytes).unwrap_err().to_string();
        assert!(err.contains("checksum"), "{err}");
        assert!(Checkpoint::from_bytes(b"PNG not a checkpoint").is_err());
    }

    #[test]
    fn file_round_trip_and_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("lucent-ckpt-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.ckpt");
        let c = Checkpoint::single_run(identity(b"scene", 2, 2), 7, None, film_with(2, 2, &[1.0, 2.0]));
        c.write(&path).unwrap();
        let back = Checkpoint::read(&path).unwrap();
        assert_eq!(back.film, c.film);
        std::fs::write(dir.join("bad.ckpt"), b"garbage").unwrap();
        let err = format!("{:#}", Checkpoint::read(&dir.join("bad.ckpt")).unwrap_err());
        assert!(err.contains("bad.ckpt"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn checkpoint_of_another_scene_resolution_or_integrator_is_refused() {
        let c = Checkpoint::single_run(identity(b"scene A", 2, 2), 1, None, film_with(2, 2, &[1.0]));
        let p = Path::new("runs/a.ckpt");
        assert!(c.check_matches(p, &identity(b"scene A", 2, 2)).is_ok());
        let err = c.check_matches(p, &identity(b"scene B", 2, 2)).unwrap_err().to_string();
        assert!(err.contains("runs/a.ckpt") && err.contains("another scene"), "{err}");
        let err = c.check_matches(p, &identity(b"scene A", 4, 2)).unwrap_err().to_string();
        assert!(err.contains("runs/a.ckpt") && err.contains("2×2"), "{err}");
        let ao = RenderIdentity { settings: settings(IntegratorKind::Ao), ..identity(b"scene A", 2, 2) };
        let err = c.check_matches(p, &ao).unwrap_err().to_string();
        assert!(err.contains("integrator"), "{err}");
        // The hash itself separates scenes, resolutions and integrator settings.
        let s = settings(IntegratorKind::Path);
        let base = scene_hash(1, 2, 2, &s);
        assert_ne!(base, scene_hash(2, 2, 2, &s));
        assert_ne!(base, scene_hash(1, 2, 3, &s));
        assert_ne!(base, scene_hash(1, 3, 2, &s));
        assert_ne!(base, scene_hash(1, 2, 2, &settings(IntegratorKind::Direct)));
        assert_ne!(base, scene_hash(1, 2, 2, &IntegratorSettings { max_depth: 9, ..s.clone() }));
        assert_ne!(base, scene_hash(1, 2, 2, &IntegratorSettings { rr_depth: 4, ..s.clone() }));
        assert_eq!(base, scene_hash(1, 2, 2, &s));
    }

    #[test]
    fn merge_weights_by_sample_count() {
        // Seed 1: 3 samples of 1, seed 2: 1 sample of 5 → per-pixel mean (3 + 5)/4 = 2 in Y/2.
        let a = Checkpoint::single_run(identity(b"s", 1, 1), 1, Some(3), film_with(1, 1, &[1.0, 1.0, 1.0]));
        let b = Checkpoint::single_run(identity(b"s", 1, 1), 2, Some(1), film_with(1, 1, &[5.0]));
        let m = Checkpoint::merge(&[("a".into(), a), ("b".into(), b)]).unwrap();
        assert_eq!(m.film.samples_per_pixel(), 4);
        assert_eq!(m.film.mean_xyz(0)[1], 2.0 * 2.0);
        assert_eq!(m.runs.len(), 2);
        assert_eq!(m.target_spp, None);
        assert!(m.resume_point(Path::new("m")).is_err());
        // And the merged checkpoint survives a round trip.
        let back = Checkpoint::from_bytes(&m.to_bytes()).unwrap();
        assert_eq!(back.film, m.film);
        assert_eq!(back.runs, m.runs);
    }

    #[test]
    fn merge_refuses_repeated_seed_and_other_scenes() {
        let a = Checkpoint::single_run(identity(b"s", 1, 1), 1, None, film_with(1, 1, &[1.0, 2.0]));
        let same_seed = Checkpoint::single_run(identity(b"s", 1, 1), 1, None, film_with(1, 1, &[1.0]));
        let err = Checkpoint::merge(&[("a.ckpt".into(), a.clone()), ("b.ckpt".into(), same_seed)]).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("b.ckpt") && msg.contains("a.ckpt") && msg.contains("seed 1"), "{msg}");
        // Same seed, disjoint passes: independent samples, accepted.
        let mut later = Checkpoint::single_run(identity(b"s", 1, 1), 1, None, film_with(1, 1, &[3.0]));
        later.runs[0].first_pass = 2;
        assert!(Checkpoint::merge(&[("a".into(), a.clone()), ("c".into(), later)]).is_ok());
        let other = Checkpoint::single_run(identity(b"t", 1, 1), 2, None, film_with(1, 1, &[1.0]));
        let err = format!("{:#}", Checkpoint::merge(&[("a".into(), a), ("o.ckpt".into(), other)]).unwrap_err());
        assert!(err.contains("o.ckpt") && err.contains("another scene"), "{err}");
        assert!(Checkpoint::merge(&[]).is_err());
        // Overlap inside one part (a hand-made or corrupted merged checkpoint) is caught as well.
        let mut twice = Checkpoint::single_run(identity(b"s", 1, 1), 8, None, film_with(1, 1, &[1.0, 2.0]));
        twice.runs = vec![Run { seed: 8, first_pass: 0, passes: 1 }, Run { seed: 8, first_pass: 0, passes: 1 }];
        let err = Checkpoint::merge(&[("t.ckpt".into(), twice)]).unwrap_err().to_string();
        assert!(err.contains("t.ckpt") && err.contains("seed 8"), "{err}");
    }
}
