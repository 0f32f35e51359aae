//! Which estimator runs and how long its paths are: the one table of integrator names and codes
//! that the scene loader, the command line and checkpoints share.

/// Which light-transport estimator to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntegratorKind {
    /// Unidirectional path tracing with next-event estimation, MIS and Russian roulette
    /// ([`crate::integrator::path`]).
    Path,
    /// Emission plus direct lighting at the first hit: light and BSDF samples with MIS, no indirect light ([`crate::integrator::direct`]).
    Direct,
    /// Ambient occlusion by cosine-weighted hemisphere sampling.
    Ao,
    /// Volumetric path tracing through homogeneous media ([`crate::integrator::volpath`]).
    Volpath,
}

/// Every integrator with its name (as scene files and the command line spell it) and its code in
/// checkpoints. The one place a new integrator is named.
const TABLE: [(IntegratorKind, &str, u8); 4] = [
    (IntegratorKind::Path, "path", 0),
    (IntegratorKind::Volpath, "volpath", 3),
    (IntegratorKind::Direct, "direct", 1),
    (IntegratorKind::Ao, "ao", 2),
];

impl IntegratorKind {
    /// Every kind, in the order of the name table.
    pub const ALL: [IntegratorKind; 4] = [TABLE[0].0, TABLE[1].0, TABLE[2].0, TABLE[3].0];

    fn entry(self) -> &'static (IntegratorKind, &'static str, u8) {
        // Exhaustive on purpose: a new variant does not compile until it has a row in TABLE.
        let i = match self {
            IntegratorKind::Path => 0,
            IntegratorKind::Volpath => 1,
            IntegratorKind::Direct => 2,
            IntegratorKind::Ao => 3,
        };
        &TABLE[i]
    }

    /// The name as scene files and the command line spell it.
    pub fn name(self) -> &'static str {
        self.entry().1
    }

    /// The byte that stands for this kind in checkpoints.
    pub fn code(self) -> u8 {
        self.entry().2
    }

    /// The kind a checkpoint's byte stands for.
    pub fn from_code(code: u8) -> Option<IntegratorKind> {
        TABLE.iter().find(|e| e.2 == code).map(|e| e.0)
    }

    /// The kind of a name, if it is one.
    pub fn from_name(name: &str) -> Option<IntegratorKind> {
        TABLE.iter().find(|e| e.1 == name).map(|e| e.0)
    }

    /// The names joined by `sep` (for help texts and error messages).
    pub fn names(sep: &str) -> String {
        TABLE.iter().map(|e| e.1).collect::<Vec<_>>().join(sep)
    }

    /// The names as a sentence: "a, b, c or d".
    pub fn names_or() -> String {
        let n = TABLE.len();
        let head: Vec<&str> = TABLE[..n - 1].iter().map(|e| e.1).collect();
        format!("{} or {}", head.join(", "), TABLE[n - 1].1)
    }
}

impl std::str::FromStr for IntegratorKind {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        IntegratorKind::from_name(s).ok_or_else(|| anyhow::anyhow!("unknown integrator `{s}` ({})", IntegratorKind::names(", ")))
    }
}

/// Settings of an integrator (Mitsuba's defaults for `path`: 8 bounces, Russian roulette from the 5th).
#[derive(Clone, Debug)]
pub struct IntegratorSettings {
    /// The estimator.
    pub kind: IntegratorKind,
    /// Longest path in segments (1: emitters seen directly, 2: direct lighting; Mitsuba's `max_depth`).
    pub max_depth: u32,
    /// Russian roulette starts once a path has this many segments (Mitsuba's `rr_depth`).
    pub rr_depth: u32,
}

impl Default for IntegratorSettings {
    fn default() -> Self {
        IntegratorSettings { kind: IntegratorKind::Path, max_depth: 8, rr_depth: 5 }
    }
}

/// How many samples of each technique `direct` takes per camera sample (`[integrator]`
/// `emitter_samples` and `bsdf_samples`; Mitsuba 3's names and defaults).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DirectSamples {
    /// Light samples per camera sample.
    pub emitter: u32,
    /// BSDF samples per camera sample.
    pub bsdf: u32,
}

impl Default for DirectSamples {
    fn default() -> Self {
        DirectSamples { emitter: 1, bsdf: 1 }
    }
}
