//! Lorenz–Mie theory for a homogeneous sphere, optionally in an absorbing host.
//!
//! Conventions (Bohren & Huffman 1983): time dependence e^{−iωt}, refractive indices
//! n = n′ + i n″ with n″ ≥ 0 absorbing, outgoing waves ξ_n(ρ) = ρ h_n^{(1)}(ρ).
//! Size parameter in the host x = 2π r n_med / λ (λ in vacuum), relative index m = n_p / n_med.
//!
//! Two code paths:
//! * real host (n_med″ = 0): the classical Bohren–Huffman formulation with D_n(mx) by downward
//!   recurrence and ψ_n, ξ_n by upward recurrence, fused with the sums (no storage of a_n, b_n);
//! * absorbing host: the formulation of Frisvad, Christensen & Jensen (ACM TOG 26(3), 2007),
//!   with ratios of Riccati–Bessel functions so that complex x stays stable
//!   (ψ_nξ_n products and ψ_n/ξ_n ratios by upward recurrence, as in Yang, Appl. Opt. 42, 2003).
//!   It reduces to the classical one when n_med″ = 0 (checked in the tests).
//!
//! Number of terms M = ⌈|x| + 4.3|x|^{1/3} + 1⌉ (10⁻⁸ error bound quoted in the tutorial).
//! The logarithmic derivative D_n(z) is started at zero well above max(M, |z|): at
//! max(M, |z|) + 16 + 4·max(M,|z|)^{1/3}. Starting it at M only is wrong for large |mx|.
//!
//! Supported sizes ([`check_size`]): the work is O(M) for the series and O(|mx|) for the
//! downward recurrence, so both are bounded — at most [`MAX_TERMS`] terms (|x| ≲ 9.96·10⁵) and a
//! recurrence start of at most [`MAX_DOWNWARD_START`] (|mx| ≲ 10⁷), about a tenth of a second
//! each; the smallest size parameter is [`MIN_SIZE_PARAMETER`]. Spheres with |x| and |mx| both
//! below [`SMALL_PARTICLE_LIMIT`] use the small-particle expansion of a₁, b₁, a₂ of Wiscombe
//! (Appl. Opt. 19, 1505, 1980, eqs. R40–R42, here in the e^{−iωt} convention): the upward
//! recurrence of ψ_n(x) loses about 10⁻¹⁶/x² relative accuracy to cancellation, the expansion
//! errs by O(x⁶), so the switch at 0.01 keeps both near 10⁻¹². The functions that return numbers
//! without a `Result` give NaN (or no coefficients) for unsupported sizes instead of hanging.

/// Complex numbers used throughout (re-exported so callers need no direct dependency).
pub use num_complex::Complex64;
use std::f64::consts::PI;

/// Number of terms of the series, M = ⌈|x| + 4.3|x|^{1/3} + 1⌉ (at least 1).
pub fn number_of_terms(x_abs: f64) -> usize {
    let m = (x_abs + 4.3 * x_abs.cbrt() + 1.0).ceil();
    if m.is_finite() && m >= 1.0 {
        m as usize
    } else {
        1
    }
}

/// Index at which the downward recurrence of D_n(z) is started (with D = 0).
fn downward_start(terms: usize, z_abs: f64) -> usize {
    downward_start_f64(terms as f64, z_abs).min(MAX_DOWNWARD_START as f64) as usize
}

fn downward_start_f64(terms: f64, z_abs: f64) -> f64 {
    let top = terms.max(z_abs);
    (top + 16.0 + 4.0 * top.cbrt()).ceil()
}

/// Largest number of series terms M supported (|x| up to about 9.96·10⁵).
pub const MAX_TERMS: usize = 1_000_000;

/// Largest start index of the downward recurrence of D_n(mx) supported (|mx| up to about 10⁷).
pub const MAX_DOWNWARD_START: usize = 10_000_000;

/// Smallest |x| supported: below it |a₁|² ∝ |x|⁶ underflows and the phase function is lost.
pub const MIN_SIZE_PARAMETER: f64 = 1e-30;

/// |x| and |mx| below which the small-particle expansion (Wiscombe 1980) replaces the series.
pub const SMALL_PARTICLE_LIMIT: f64 = 0.01;

/// Smallest |x| at which the series is used when |mx| ≥ [`SMALL_PARTICLE_LIMIT`] (a tiny sphere
/// of a very large index): below it the upward recurrence of ψ_n(x) loses more than ~10⁻⁸.
pub const MIN_SERIES_SIZE_PARAMETER: f64 = 1e-4;

/// Checks that a sphere of host size parameter `x` (complex for an absorbing host) and relative
/// index `m` lies within the supported sizes: finite, |x| ≥ [`MIN_SIZE_PARAMETER`], at most
/// [`MAX_TERMS`] series terms and a downward-recurrence start of at most [`MAX_DOWNWARD_START`].
/// The error says which limit is exceeded and by what.
pub fn check_size(x: Complex64, m: Complex64) -> anyhow::Result<()> {
    sizes(x, m).map(|_| ())
}

/// What [`check_size`] computes on the way: |x|, |m·x|, the series' terms M ([`number_of_terms`])
/// and the start index of the downward recurrence of D_n(mx), so that a caller that checks need
/// not compute them again.
#[derive(Clone, Copy, Debug)]
struct Sizes {
    x_abs: f64,
    mx_abs: f64,
    terms: usize,
    start: usize,
}

fn sizes(x: Complex64, m: Complex64) -> anyhow::Result<Sizes> {
    let (xa, mxa) = (x.norm(), (m * x).norm());
    if !(xa.is_finite() && mxa.is_finite() && m.re.is_finite() && m.im.is_finite()) {
        anyhow::bail!("size parameter x = {x} and relative index m = {m} must be finite");
    }
    if xa < MIN_SIZE_PARAMETER {
        anyhow::bail!("size parameter |x| = {xa:.3e} is below the supported {MIN_SIZE_PARAMETER:e}");
    }
    if xa < MIN_SERIES_SIZE_PARAMETER && mxa >= SMALL_PARTICLE_LIMIT {
        anyhow::bail!(
            "|x| = {xa:.3e} with |m·x| = {mxa:.3e} is not supported: a sphere this small needs |m·x| < {SMALL_PARTICLE_LIMIT} (small-particle expansion) or |x| ≥ {MIN_SERIES_SIZE_PARAMETER:e} (series)"
        );
    }
    let terms = (xa + 4.3 * xa.cbrt() + 1.0).ceil();
    if terms > MAX_TERMS as f64 {
        anyhow::bail!("the Mie series for |x| = {xa:.4e} needs {terms:.0} terms, above the supported {MAX_TERMS} (|x| ≤ 9.96e5)");
    }
    let start = downward_start_f64(terms, mxa);
    if start > MAX_DOWNWARD_START as f64 {
        anyhow::bail!(
            "|m·x| = {mxa:.4e} needs the downward recurrence of D_n(mx) to start at n = {start:.3e}, above the supported {MAX_DOWNWARD_START} (|m·x| ≲ 1e7)"
        );
    }
    // As number_of_terms and downward_start compute them (terms ≥ 1 here: |x| is finite and
    // positive).
    Ok(Sizes { x_abs: xa, mx_abs: mxa, terms: terms as usize, start: start as usize })
}

/// Estimated work of one sphere in recurrence steps: the series terms M plus the start index of
/// the downward recurrence of D_n(mx) (infinite for non-finite input). Used to bound the work of
/// whole size distributions.
pub fn work_estimate(x: Complex64, m: Complex64) -> f64 {
    let (xa, mxa) = (x.norm(), (m * x).norm());
    let terms = (xa + 4.3 * xa.cbrt() + 1.0).ceil().max(1.0);
    let w = terms + downward_start_f64(terms, mxa);
    if w.is_nan() {
        f64::INFINITY
    } else {
        w
    }
}

/// Whether the small-particle expansion is used for (x, m).
fn is_small(x: Complex64, m: Complex64) -> bool {
    x.norm() < SMALL_PARTICLE_LIMIT && (m * x).norm() < SMALL_PARTICLE_LIMIT
}

/// Small-particle Mie coefficients (a₁, b₁, a₂) of Wiscombe 1980 (eqs. R42a–c), written for the
/// e^{−iωt} convention (n″ ≥ 0 absorbs): relative error O(|x|⁶, |mx|⁶); all other a_n, b_n are
/// smaller than |x|⁷.
pub fn small_particle_coefficients(x: Complex64, m: Complex64) -> [Complex64; 3] {
    let m2 = m * m;
    let x2 = x * x;
    let x3 = x2 * x;
    let x4 = x2 * x2;
    let c = Complex64::new(0.0, -2.0 / 3.0) * (m2 - 1.0);
    let a1 = c * (1.0 - 0.1 * x2 + (m2 / 350.0 + 1.0 / 280.0) * x4)
        / (m2 + 2.0 + (1.0 - 0.7 * m2) * x2 - (m2 * m2 / 175.0 - 0.275 * m2 + 0.25) * x4 + x3 * c * (1.0 - 0.1 * x2));
    let b1 = x2 / 30.0 * c * (1.0 + (m2 / 35.0 - 1.0 / 14.0) * x2) / (1.0 - (m2 / 15.0 - 1.0 / 6.0) * x2);
    let a2 = 0.1 * x2 * c * (1.0 - x2 / 14.0) / (2.0 * m2 + 3.0 - (m2 / 7.0 - 0.5) * x2);
    [a1 * x3, b1 * x3, a2 * x3]
}

const NAN_EFFICIENCIES: Efficiencies = Efficiencies { terms: 0, qext: f64::NAN, qsca: f64::NAN, qabs: f64::NAN, qback: f64::NAN, g: f64::NAN };

/// 1/z with one real division.
#[inline(always)]
fn inv(z: Complex64) -> Complex64 {
    let s = 1.0 / (z.re * z.re + z.im * z.im);
    Complex64::new(z.re * s, -z.im * s)
}

/// a/b with one real division (no overflow scaling: Mie quantities stay far from the limits).
#[inline(always)]
fn div(a: Complex64, b: Complex64) -> Complex64 {
    let s = 1.0 / (b.re * b.re + b.im * b.im);
    Complex64::new((a.re * b.re + a.im * b.im) * s, (a.im * b.re - a.re * b.im) * s)
}

/// Largest |Im x| of the host size parameter for which ψ_n(x), ξ_n(x) are built by upward
/// recurrence; above it the ratio formulation is used.
pub const UPWARD_MAX_IM_X: f64 = 1.0;

/// Largest supported α = 4πr n_med″/λ (host attenuation across the sphere, e^{−α}): beyond it the
/// absorbing-host cross sections (which grow like e^{α}) lose meaning and soon overflow.
pub const MAX_HOST_ATTENUATION: f64 = 50.0;

/// Fill `out[0..=terms]` with D_n(z) = ψ_n′(z)/ψ_n(z) by downward recurrence.
fn log_derivative(z: Complex64, terms: usize, out: &mut Vec<Complex64>) {
    let start = downward_start(terms, z.norm());
    out.clear();
    out.resize(terms + 1, Complex64::new(0.0, 0.0));
    let inv_z = inv(z);
    // D_{n−1} = n/z − 1/(D_n + n/z), carried as D = p/q so that the serial chain holds no division
    // (17 % faster): t = p + (n/z)q, p ← (n/z)t − q, q ← t, rescaled when |q| leaves [1e-150, 1e150].
    // The divisions p/q for the stored n are off the chain. Checked against 40-digit values (tests).
    let mut p = Complex64::new(0.0, 0.0);
    let mut q = Complex64::new(1.0, 0.0);
    let mut n = start;
    let step = |n: usize, p: &mut Complex64, q: &mut Complex64| {
        let w = inv_z * n as f64;
        let t = *p + w * *q;
        *p = w * t - *q;
        *q = t;
        let size = q.re.abs() + q.im.abs();
        if !(1e-150..=1e150).contains(&size) {
            let k = 1.0 / size;
            *p *= k;
            *q *= k;
        }
    };
    while n > terms {
        step(n, &mut p, &mut q);
        n -= 1;
    }
    out[terms] = div(p, q);
    while n > 0 {
        step(n, &mut p, &mut q);
        n -= 1;
        out[n] = div(p, q);
    }
}

/// Four f64 lanes (terms n … n+3 of the series): two SSE2 vectors on x86-64 (part of the
/// baseline, so no run-time detection; no fused multiply-add, so every lane rounds as scalar
/// code would), plain arrays elsewhere.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
struct F4(std::arch::x86_64::__m128d, std::arch::x86_64::__m128d);

#[cfg(target_arch = "x86_64")]
mod f4_impl {
    use super::F4;
    use std::arch::x86_64::*;

    impl F4 {
        #[inline(always)]
        pub(super) fn new(v: [f64; 4]) -> F4 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                F4(_mm_set_pd(v[1], v[0]), _mm_set_pd(v[3], v[2]))
            }
        }
        #[inline(always)]
        pub(super) fn splat(v: f64) -> F4 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                F4(_mm_set1_pd(v), _mm_set1_pd(v))
            }
        }
        /// (v₀ + v₁) + (v₂ + v₃).
        #[inline(always)]
        pub(super) fn sum(self) -> f64 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                let lo = _mm_add_sd(self.0, _mm_unpackhi_pd(self.0, self.0));
                let hi = _mm_add_sd(self.1, _mm_unpackhi_pd(self.1, self.1));
                _mm_cvtsd_f64(_mm_add_sd(lo, hi))
            }
        }
        /// The last lane, v₃.
        #[inline(always)]
        pub(super) fn last(self) -> f64 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                _mm_cvtsd_f64(_mm_unpackhi_pd(self.1, self.1))
            }
        }
        /// [carry, v₀, v₁, v₂]: the lanes shifted up by one term.
        #[inline(always)]
        pub(super) fn shift_in(self, carry: f64) -> F4 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                F4(_mm_shuffle_pd::<0b00>(_mm_set_sd(carry), self.0), _mm_shuffle_pd::<0b01>(self.0, self.1))
            }
        }
        /// 1 where the lane is ≤ `limit`, else 0.
        #[inline(always)]
        pub(super) fn le_mask(self, limit: f64) -> F4 {
            // SAFETY: SSE2 is part of the x86-64 baseline, always present.
            unsafe {
                let l = _mm_set1_pd(limit);
                let one = _mm_set1_pd(1.0);
                F4(_mm_and_pd(_mm_cmple_pd(self.0, l), one), _mm_and_pd(_mm_cmple_pd(self.1, l), one))
            }
        }
    }

    macro_rules! f4_op {
        ($tr:ident, $f:ident, $intr:ident) => {
            impl std::ops::$tr for F4 {
                type Output = F4;
                #[inline(always)]
                fn $f(self, o: F4) -> F4 {
                    // SAFETY: SSE2 is part of the x86-64 baseline, always present.
                    unsafe {
                        F4($intr(self.0, o.0), $intr(self.1, o.1))
                    }
                }
            }
        };
    }
    f4_op!(Add, add, _mm_add_pd);
    f4_op!(Sub, sub, _mm_sub_pd);
    f4_op!(Mul, mul, _mm_mul_pd);
    f4_op!(Div, div, _mm_div_pd);
}

#[cfg(not(target_arch = "x86_64"))]
#[derive(Clone, Copy, Debug)]
struct F4([f64; 4]);

#[cfg(not(target_arch = "x86_64"))]
mod f4_impl {
    use super::F4;

    impl F4 {
        #[inline(always)]
        pub(super) fn new(v: [f64; 4]) -> F4 {
            F4(v)
        }
        #[inline(always)]
        pub(super) fn splat(v: f64) -> F4 {
            F4([v; 4])
        }
        #[inline(always)]
        pub(super) fn sum(self) -> f64 {
            (self.0[0] + self.0[1]) + (self.0[2] + self.0[3])
        }
        #[inline(always)]
        pub(super) fn last(self) -> f64 {
            self.0[3]
        }
        #[inline(always)]
        pub(super) fn shift_in(self, carry: f64) -> F4 {
            F4([carry, self.0[0], self.0[1], self.0[2]])
        }
        #[inline(always)]
        pub(super) fn le_mask(self, limit: f64) -> F4 {
            F4(self.0.map(|v| if v <= limit { 1.0 } else { 0.0 }))
        }
    }

    macro_rules! f4_op {
        ($tr:ident, $f:ident, $op:tt) => {
            impl std::ops::$tr for F4 {
                type Output = F4;
                #[inline(always)]
                fn $f(self, o: F4) -> F4 {
                    F4(std::array::from_fn(|k| self.0[k] $op o.0[k]))
                }
            }
        };
    }
    f4_op!(Add, add, +);
    f4_op!(Sub, sub, -);
    f4_op!(Mul, mul, *);
    f4_op!(Div, div, /);
}

impl Default for F4 {
    fn default() -> F4 {
        F4::splat(0.0)
    }
}

/// Four consecutive terms n = 4k+1 … 4k+4 of the real-x series: the numbers [A, C, B, T]
/// (real and imaginary lanes) of [`riccati_downward`].
#[derive(Clone, Copy, Debug, Default)]
struct Block {
    /// Real and imaginary parts of A, C, B, T (in that order), lane by lane.
    v: [[f64; 4]; 8],
}

impl Block {
    #[inline(always)]
    fn set(&mut self, lane: usize, [a, c, b, t]: [Complex64; 4]) {
        for (k, z) in [a, c, b, t].into_iter().enumerate() {
            self.v[2 * k][lane] = z.re;
            self.v[2 * k + 1][lane] = z.im;
        }
    }
}

/// For real x and relative index m, fill the term n = 1..=terms of `rows` (block (n−1)/4,
/// lane (n−1)%4) with the four numbers [A, C, B, T] that give the Bohren–Huffman coefficients
/// without a division for D_n(mx): with t_n ∝ ψ_n(mx) from the downward three-term recurrence
/// t_{n−1} = (2n+1)/(mx)·t_n − t_{n+1} (the same recurrence as D_{n−1} = n/z − 1/(D_n + n/z),
/// D_n = t_{n−1}/t_n − n/z, started with D = 0 at the same index as [`log_derivative`]),
/// D_n/m + n/x = A/C with A = t_{n−1} + (n/x)(m − 1/m)·t_n, C = m·t_n, and
/// m·D_n + n/x = B/T with B = m·t_{n−1}, T = t_n. Each term has one consistent scale of t
/// (the pair is rescaled when |t| leaves [1e-30, 1e30]), and a_n, b_n are homogeneous in it.
/// Lanes past `terms` hold A = B = 1, C = T = 0 (a_n = b_n = ψ_n/ξ_n, finite; their weights are 0).
fn riccati_downward(x: f64, m: Complex64, terms: usize, start: usize, rows: &mut Vec<Block>) {
    let z = m * x;
    let one = Complex64::new(1.0, 0.0);
    let zero = Complex64::new(0.0, 0.0);
    let blocks = terms.div_ceil(4);
    rows.clear();
    rows.resize(blocks, Block::default());
    for n in terms + 1..=4 * blocks {
        rows[(n - 1) / 4].set((n - 1) % 4, [one, zero, one, zero]);
    }
    let inv_z = inv(z);
    let kk = (m - inv(m)) * (1.0 / x);
    // D_start = 0: t_start = 1, t_{start−1} = (start/z)·t_start.
    let mut t1 = one; // t_{n+1}
    let mut t0 = inv_z * start as f64; // t_n
    let mut n = start - 1;
    #[inline(always)]
    fn rescale(t0: &mut Complex64, t1: &mut Complex64) {
        let size = t0.re.abs() + t0.im.abs();
        if !(1e-30..=1e30).contains(&size) {
            let k = 1.0 / size;
            *t0 *= k;
            *t1 *= k;
        }
    }
    // Two steps at a time, t_{n−2} = (c_{n−1}c_n − 1)·t_n − c_{n−1}·t_{n+1} beside
    // t_{n−1} = c_n·t_n − t_{n+1} (c_n = (2n+1)/z): the serial chain is one complex product per
    // two steps.
    let inv_z2 = inv_z * inv_z;
    let two_steps = |n: usize, t0: Complex64, t1: Complex64| {
        let nf = n as f64;
        let c_n = inv_z * (2.0 * nf + 1.0);
        let c_n1 = inv_z * (2.0 * nf - 1.0);
        let a = inv_z2 * (4.0 * nf * nf - 1.0) - 1.0;
        (c_n * t0 - t1, a * t0 - c_n1 * t1)
    };
    while n >= terms + 2 {
        let (u, v) = two_steps(n, t0, t1);
        t1 = u;
        t0 = v;
        n -= 2;
        rescale(&mut t0, &mut t1);
    }
    if n > terms {
        let t = inv_z * (2 * n + 1) as f64 * t0 - t1;
        t1 = t0;
        t0 = t;
        n -= 1;
        rescale(&mut t0, &mut t1);
    }
    // Now t0 = t_terms, t1 = t_{terms+1}.
    let row = |n: usize, t_prev: Complex64, t_n: Complex64| [t_prev + kk * (t_n * n as f64), m * t_n, m * t_prev, t_n];
    let mut put = |n: usize, r: [Complex64; 4]| rows[(n - 1) / 4].set((n - 1) % 4, r);
    while n >= 2 {
        let (u, v) = two_steps(n, t0, t1); // t_{n−1}, t_{n−2}
        put(n, row(n, u, t0));
        put(n - 1, row(n - 1, v, u));
        t1 = u;
        t0 = v;
        n -= 2;
        rescale(&mut t0, &mut t1);
    }
    if n == 1 {
        let t = inv_z * 3.0 * t0 - t1;
        put(1, row(1, t, t0));
    }
}

/// One [`Block`] as vectors.
struct BlockF4 {
    a_re: F4,
    a_im: F4,
    c_re: F4,
    c_im: F4,
    b_re: F4,
    b_im: F4,
    t_re: F4,
    t_im: F4,
}

/// The sums of the real-x series over the blocks of [`riccati_downward`], four terms at a time:
/// ψ_n(x), η_n(x) (ξ_n = ψ_n + iη_n) by upward recurrence, then
/// a_n = (Aψ_n − Cψ_{n−1}) / (Aξ_n − Cξ_{n−1}), b_n = (Bψ_n − Tψ_{n−1}) / (Bξ_n − Tξ_{n−1}),
/// with one division for 1/|·|² of both denominators and 1/(n+1) (for the weights of g).
fn series_blocks(x: f64, terms: usize, rows: &[Block]) -> Sums {
    let terms_f = terms as f64;
    let (s, c) = x.sin_cos();
    let inv_x = 1.0 / x;
    // ψ_{n-1}, η_{n-1} (η_n = x y_n), starting at n = 0.
    let (mut psi_m1, mut psi_0) = (c, s);
    let (mut eta_m1, mut eta_0) = (s, -c);
    let mut ext = F4::default();
    let mut sca = F4::default();
    let mut g_cross = F4::default();
    let mut g_ab = F4::default();
    let mut back_re = F4::default();
    let mut back_im = F4::default();
    let sign = F4::new([-1.0, 1.0, -1.0, 1.0]);
    let (mut a_carry_re, mut a_carry_im, mut b_carry_re, mut b_carry_im) = (0.0, 0.0, 0.0, 0.0);
    let mut inv_n_carry = 1.0;
    let one = F4::splat(1.0);
    let two = F4::splat(2.0);
    let mut nf = F4::new([1.0, 2.0, 3.0, 4.0]);
    let mut n0 = 1.0;
    for blk in rows {
        let mut psi = [0.0; 4];
        let mut psi_p = [0.0; 4];
        let mut eta = [0.0; 4];
        let mut eta_p = [0.0; 4];
        for k in 0..4 {
            let f = (2.0 * (n0 + k as f64) - 1.0) * inv_x;
            let p = f * psi_0 - psi_m1;
            let e = f * eta_0 - eta_m1;
            psi[k] = p;
            psi_p[k] = psi_0;
            eta[k] = e;
            eta_p[k] = eta_0;
            psi_m1 = psi_0;
            psi_0 = p;
            eta_m1 = eta_0;
            eta_0 = e;
        }
        n0 += 4.0;
        let (psi, psi_p, eta, eta_p) = (F4::new(psi), F4::new(psi_p), F4::new(eta), F4::new(eta_p));
        let r = BlockF4 {
            a_re: F4::new(blk.v[0]),
            a_im: F4::new(blk.v[1]),
            c_re: F4::new(blk.v[2]),
            c_im: F4::new(blk.v[3]),
            b_re: F4::new(blk.v[4]),
            b_im: F4::new(blk.v[5]),
            t_re: F4::new(blk.v[6]),
            t_im: F4::new(blk.v[7]),
        };
        let na_re = r.a_re * psi - r.c_re * psi_p;
        let na_im = r.a_im * psi - r.c_im * psi_p;
        let nb_re = r.b_re * psi - r.t_re * psi_p;
        let nb_im = r.b_im * psi - r.t_im * psi_p;
        let da_re = r.a_re * psi - r.a_im * eta - r.c_re * psi_p + r.c_im * eta_p;
        let da_im = r.a_re * eta + r.a_im * psi - r.c_re * eta_p - r.c_im * psi_p;
        let db_re = r.b_re * psi - r.b_im * eta - r.t_re * psi_p + r.t_im * eta_p;
        let db_im = r.b_re * eta + r.b_im * psi - r.t_re * eta_p - r.t_im * psi_p;
        let da2 = da_re * da_re + da_im * da_im;
        let db2 = db_re * db_re + db_im * db_im;
        let dd = da2 * db2;
        let n1 = nf + one;
        let rr = one / (dd * n1);
        let sa = db2 * n1 * rr;
        let sb = da2 * n1 * rr;
        let inv_n1 = dd * rr;
        let an_re = (na_re * da_re + na_im * da_im) * sa;
        let an_im = (na_im * da_re - na_re * da_im) * sa;
        let bn_re = (nb_re * db_re + nb_im * db_im) * sb;
        let bn_im = (nb_im * db_re - nb_re * db_im) * sb;
        // Weights: 2n+1; (n−1)(n+1)/n = n − 1/n for Re(a_{n−1}a*_n + b_{n−1}b*_n);
        // (2n+1)/(n(n+1)) = 1/n + 1/(n+1) for Re(a_n b*_n). Padded lanes have 2n+1 = 0.
        let live = nf.le_mask(terms_f);
        let w = (two * nf + one) * live;
        ext = ext + w * (an_re + bn_re);
        sca = sca + w * (an_re * an_re + an_im * an_im + bn_re * bn_re + bn_im * bn_im);
        let inv_n = inv_n1.shift_in(inv_n_carry);
        let ap_re = an_re.shift_in(a_carry_re);
        let ap_im = an_im.shift_in(a_carry_im);
        let bp_re = bn_re.shift_in(b_carry_re);
        let bp_im = bn_im.shift_in(b_carry_im);
        g_cross = g_cross + (nf - inv_n) * live * (ap_re * an_re + ap_im * an_im + bp_re * bn_re + bp_im * bn_im);
        g_ab = g_ab + (inv_n + inv_n1) * live * (an_re * bn_re + an_im * bn_im);
        let ws = w * sign;
        back_re = back_re + (an_re - bn_re) * ws;
        back_im = back_im + (an_im - bn_im) * ws;
        inv_n_carry = inv_n1.last();
        a_carry_re = an_re.last();
        a_carry_im = an_im.last();
        b_carry_re = bn_re.last();
        b_carry_im = bn_im.last();
        nf = nf + F4::splat(4.0);
    }
    Sums {
        terms: 0,
        ext: Complex64::new(ext.sum(), 0.0),
        sca: sca.sum(),
        g_num: g_cross.sum() + g_ab.sum(),
        back: Complex64::new(back_re.sum(), back_im.sum()),
    }
}

/// Efficiencies and asymmetry parameter of one sphere (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Efficiencies {
    /// Number of series terms used, M.
    pub terms: usize,
    /// Extinction efficiency Q_ext = C_ext / (π r²).
    pub qext: f64,
    /// Scattering efficiency Q_sca.
    pub qsca: f64,
    /// Absorption efficiency Q_abs = Q_ext − Q_sca.
    pub qabs: f64,
    /// Bohren–Huffman radar backscattering efficiency 4|S1(180°)|²/x² (real host).
    pub qback: f64,
    /// Asymmetry parameter g = ⟨cos θ⟩ of the normalised phase function.
    pub g: f64,
}

/// Cross sections (m²) and efficiencies of a sphere of given radius in a (possibly absorbing) host.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Efficiencies (Q = C / (π r²)); for an absorbing host, per Frisvad et al. 2007.
    pub eff: Efficiencies,
    /// Extinction cross section, m².
    pub c_ext_m2: f64,
    /// Scattering cross section, m².
    pub c_sca_m2: f64,
    /// Absorption cross section C_ext − C_sca, m² (negative when the particle absorbs less than the host it displaces).
    pub c_abs_m2: f64,
}

/// Reusable buffers for Mie computations: no allocation in the hot path after warm-up.
#[derive(Default, Clone, Debug)]
pub struct MieWorkspace {
    d_p: Vec<Complex64>,
    d_h: Vec<Complex64>,
    a: Vec<Complex64>,
    b: Vec<Complex64>,
    rows: Vec<Block>,
}

impl MieWorkspace {
    /// Empty workspace.
    pub fn new() -> Self {
        Self::default()
    }

    /// Q's and g for a real size parameter `x` > 0 (non-absorbing host) and relative index `m`.
    /// Classical Bohren–Huffman formulation, fused with the sums.
    /// Unsupported sizes ([`check_size`]) give NaN efficiencies with `terms` = 0.
    pub fn efficiencies(&mut self, x: f64, m: Complex64) -> Efficiencies {
        let xc = Complex64::new(x, 0.0);
        let Ok(size) = sizes(xc, m) else {
            return NAN_EFFICIENCIES;
        };
        // is_small, from the magnitudes already computed.
        if size.x_abs < SMALL_PARTICLE_LIMIT && size.mx_abs < SMALL_PARTICLE_LIMIT {
            let [a1, b1, a2] = small_particle_coefficients(xc, m);
            let z = Complex64::new(0.0, 0.0);
            let mut sums = Sums { terms: 2, ..Default::default() };
            sums.add(1, a1, b1, z, z, -1.0);
            sums.add(2, a2, z, a1, b1, 1.0);
            let x2 = x * x;
            let (qext, qsca) = (2.0 * sums.ext.re / x2, 2.0 * sums.sca / x2);
            return Efficiencies {
                terms: 2,
                qext,
                qsca,
                qabs: qabs_of(qext, qsca, m.im),
                qback: sums.back.norm_sqr() / x2,
                g: if sums.sca > 0.0 { 2.0 * sums.g_num / sums.sca } else { 0.0 },
            };
        }
        let terms = size.terms;
        riccati_downward(x, m, terms, size.start, &mut self.rows);
        let sums = series_blocks(x, terms, &self.rows);
        let x2 = x * x;
        let qext = 2.0 * sums.ext.re / x2;
        let qsca = 2.0 * sums.sca / x2;
        Efficiencies {
            terms,
            qext,
            qsca,
            qabs: qabs_of(qext, qsca, m.im),
            qback: sums.back.norm_sqr() / x2,
            g: if sums.sca > 0.0 { 2.0 * sums.g_num / sums.sca } else { 0.0 },
        }
    }

    /// Mie coefficients a_n, b_n (n = 1..=M, stored at index n−1) for a host size parameter
    /// `x` (complex when the host absorbs) and relative index `m` = n_p/n_med.
    /// Upward recurrence of ψ_n(x), ξ_n(x) when |Im x| ≤ [`UPWARD_MAX_IM_X`], else the ratio formulation.
    /// Small spheres ([`SMALL_PARTICLE_LIMIT`]) get a₁, a₂, b₁ of the small-particle expansion
    /// (b₂ = 0); unsupported sizes ([`check_size`]) get no coefficients.
    pub fn coefficients(&mut self, x: Complex64, m: Complex64) -> (&[Complex64], &[Complex64]) {
        if check_size(x, m).is_err() {
            self.a.clear();
            self.b.clear();
            return (&self.a, &self.b);
        }
        if is_small(x, m) {
            let [a1, b1, a2] = small_particle_coefficients(x, m);
            self.a.clear();
            self.b.clear();
            self.a.extend([a1, a2]);
            self.b.extend([b1, Complex64::new(0.0, 0.0)]);
            return (&self.a, &self.b);
        }
        if x.im.abs() <= UPWARD_MAX_IM_X {
            self.coefficients_upward(x, m)
        } else {
            self.coefficients_ratio(x, m)
        }
    }

    /// a_n, b_n by the Bohren–Huffman formulas with D_n(mx) downward and ψ_n(x), ξ_n(x) upward
    /// (complex x allowed; accurate while |Im x| is moderate).
    pub fn coefficients_upward(&mut self, x: Complex64, m: Complex64) -> (&[Complex64], &[Complex64]) {
        if check_size(x, m).is_err() {
            self.a.clear();
            self.b.clear();
            return (&self.a, &self.b);
        }
        let terms = number_of_terms(x.norm());
        log_derivative(m * x, terms, &mut self.d_p);
        self.a.clear();
        self.b.clear();
        let i = Complex64::new(0.0, 1.0);
        let inv_x = inv(x);
        let inv_m = inv(m);
        let e = (i * x).exp();
        // ψ_{-1} = cos x, ψ_0 = sin x, ξ_{-1} = e^{ix}, ξ_0 = −i e^{ix}
        let (mut psi_m1, mut psi_0) = (x.cos(), x.sin());
        let (mut xi_m1, mut xi_0) = (e, -i * e);
        for n in 1..=terms {
            let nf = n as f64;
            let f = inv_x * (2.0 * nf - 1.0);
            let psi = f * psi_0 - psi_m1;
            let xi = f * xi_0 - xi_m1;
            let dn = self.d_p[n];
            let nx = inv_x * nf;
            let ta = dn * inv_m + nx;
            let tb = dn * m + nx;
            self.a.push(div(ta * psi - psi_0, ta * xi - xi_0));
            self.b.push(div(tb * psi - psi_0, tb * xi - xi_0));
            psi_m1 = psi_0;
            psi_0 = psi;
            xi_m1 = xi_0;
            xi_0 = xi;
        }
        (&self.a, &self.b)
    }

    /// a_n, b_n by the ratio formulation (A_n = ψ_n′/ψ_n downward for x and mx; ψ_nξ_n and ψ_n/ξ_n
    /// upward; B_n = A_n + i/(ψ_nξ_n)), stable for complex x with large imaginary part.
    pub fn coefficients_ratio(&mut self, x: Complex64, m: Complex64) -> (&[Complex64], &[Complex64]) {
        if check_size(x, m).is_err() {
            self.a.clear();
            self.b.clear();
            return (&self.a, &self.b);
        }
        let terms = number_of_terms(x.norm());
        log_derivative(m * x, terms, &mut self.d_p);
        log_derivative(x, terms, &mut self.d_h);
        self.a.clear();
        self.b.clear();
        let i = Complex64::new(0.0, 1.0);
        let inv_x = x.inv();
        // ψ_0ξ_0 = (1 − e^{2ix})/2, ψ_0/ξ_0 = (1 − e^{−2ix})/2, B_0 = i.
        let e2 = (i * 2.0 * x).exp();
        let mut prod = (Complex64::new(1.0, 0.0) - e2) * 0.5;
        let mut ratio = (Complex64::new(1.0, 0.0) - e2.inv()) * 0.5;
        let mut b_h = i;
        for n in 1..=terms {
            let nx = inv_x * n as f64;
            let a_h_prev = self.d_h[n - 1];
            prod = prod * (nx - a_h_prev) * (nx - b_h);
            let a_h = self.d_h[n];
            b_h = a_h + i / prod;
            ratio = ratio * (b_h + nx) / (a_h + nx);
            let a_p = self.d_p[n];
            let an = ratio * (m * a_h - a_p) / (m * b_h - a_p);
            let bn = ratio * (a_h - m * a_p) / (b_h - m * a_p);
            self.a.push(an);
            self.b.push(bn);
        }
        (&self.a, &self.b)
    }

    /// A sphere of radius `radius_m` and complex index `n_particle` in a host of complex index
    /// `n_medium` (n″ ≥ 0 absorbs), illuminated at vacuum wavelength `lambda_m`.
    /// Absorbing host: Frisvad, Christensen & Jensen 2007,
    /// C_ext = λ²/(2π) Re Σ(2n+1)(a_n+b_n)/n_med², C_sca = λ² e^{−α} / (2π γ |n_med|²) Σ(2n+1)(|a_n|²+|b_n|²),
    /// α = 4π r n_med″/λ, γ = 2(1 + (α−1)e^α)/α².
    pub fn sphere(&mut self, radius_m: f64, lambda_m: f64, n_particle: Complex64, n_medium: Complex64) -> Sphere {
        let k0 = 2.0 * PI / lambda_m;
        let area = PI * radius_m * radius_m;
        let m = n_particle / n_medium;
        if n_medium.im == 0.0 {
            let x = k0 * radius_m * n_medium.re;
            let eff = self.efficiencies(x, m);
            return Sphere {
                eff,
                c_ext_m2: eff.qext * area,
                c_sca_m2: eff.qsca * area,
                c_abs_m2: eff.qabs * area,
            };
        }
        let x = n_medium * (k0 * radius_m);
        if check_size(x, m).is_err() {
            return Sphere { eff: NAN_EFFICIENCIES, c_ext_m2: f64::NAN, c_sca_m2: f64::NAN, c_abs_m2: f64::NAN };
        }
        if x.im.abs() <= UPWARD_MAX_IM_X && !is_small(x, m) {
            let sums = self.sums_upward(x, m);
            return cross_sections(&sums, x, radius_m, lambda_m, n_medium);
        }
        self.sphere_keep_coefficients(radius_m, lambda_m, n_particle, n_medium)
    }

    /// Fused upward path for complex x: the sums of the series without storing a_n, b_n.
    fn sums_upward(&mut self, x: Complex64, m: Complex64) -> Sums {
        let terms = number_of_terms(x.norm());
        log_derivative(m * x, terms, &mut self.d_p);
        let i = Complex64::new(0.0, 1.0);
        let inv_x = inv(x);
        let inv_m = inv(m);
        let e = (i * x).exp();
        let (mut psi_m1, mut psi_0) = (x.cos(), x.sin());
        let (mut xi_m1, mut xi_0) = (e, -i * e);
        let mut sums = Sums { terms, ..Default::default() };
        let mut a_prev = Complex64::new(0.0, 0.0);
        let mut b_prev = Complex64::new(0.0, 0.0);
        let mut sign = -1.0;
        for (n, dn) in self.d_p.iter().enumerate().skip(1) {
            let nf = n as f64;
            let f = inv_x * (2.0 * nf - 1.0);
            let psi = f * psi_0 - psi_m1;
            let xi = f * xi_0 - xi_m1;
            let nx = inv_x * nf;
            let ta = dn * inv_m + nx;
            let tb = dn * m + nx;
            let an = div(ta * psi - psi_0, ta * xi - xi_0);
            let bn = div(tb * psi - psi_0, tb * xi - xi_0);
            sums.add(n, an, bn, a_prev, b_prev, sign);
            sign = -sign;
            a_prev = an;
            b_prev = bn;
            psi_m1 = psi_0;
            psi_0 = psi;
            xi_m1 = xi_0;
            xi_0 = xi;
        }
        sums
    }

    /// As [`MieWorkspace::sphere`] but always through stored coefficients, keeping a_n, b_n
    /// for [`MieWorkspace::last_coefficients`] (phase functions).
    pub fn sphere_keep_coefficients(&mut self, radius_m: f64, lambda_m: f64, n_particle: Complex64, n_medium: Complex64) -> Sphere {
        let k0 = 2.0 * PI / lambda_m;
        let m = n_particle / n_medium;
        let x = n_medium * (k0 * radius_m);
        if check_size(x, m).is_err() {
            self.a.clear();
            self.b.clear();
            return Sphere { eff: NAN_EFFICIENCIES, c_ext_m2: f64::NAN, c_sca_m2: f64::NAN, c_abs_m2: f64::NAN };
        }
        self.coefficients(x, m);
        let mut sums = Sums { terms: self.a.len(), ..Default::default() };
        let (mut a_prev, mut b_prev, mut sign) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0), -1.0);
        for (k, (&an, &bn)) in self.a.iter().zip(&self.b).enumerate() {
            sums.add(k + 1, an, bn, a_prev, b_prev, sign);
            sign = -sign;
            a_prev = an;
            b_prev = bn;
        }
        cross_sections(&sums, x, radius_m, lambda_m, n_medium)
    }
}

/// Running sums of the Mie series.
#[derive(Default, Clone, Copy, Debug)]
struct Sums {
    terms: usize,
    /// Σ(2n+1)(a_n + b_n)
    ext: Complex64,
    /// Σ(2n+1)(|a_n|² + |b_n|²)
    sca: f64,
    /// Σ n(n+2)/(n+1) Re(a_n a*_{n+1} + b_n b*_{n+1}) + Σ (2n+1)/(n(n+1)) Re(a_n b*_n)
    g_num: f64,
    /// Σ(2n+1)(−1)^n (a_n − b_n)
    back: Complex64,
}

impl Sums {
    #[inline(always)]
    fn add(&mut self, n: usize, an: Complex64, bn: Complex64, a_prev: Complex64, b_prev: Complex64, sign: f64) {
        let nf = n as f64;
        let w = 2.0 * nf + 1.0;
        self.ext += (an + bn) * w;
        self.sca += w * (an.norm_sqr() + bn.norm_sqr());
        if n > 1 {
            let k = nf - 1.0;
            self.g_num += k * (k + 2.0) / (k + 1.0) * (a_prev.re * an.re + a_prev.im * an.im + b_prev.re * bn.re + b_prev.im * bn.im);
        }
        self.g_num += w / (nf * (nf + 1.0)) * (an.re * bn.re + an.im * bn.im);
        self.back += (an - bn) * (w * sign);
    }
}

/// Q_abs = Q_ext − Q_sca in a non-absorbing host: exactly 0 for a non-absorbing particle
/// (m″ = 0), and ≥ 0 otherwise, so a negative round-off of at most 10⁻⁹ Q_ext is clamped to 0.
fn qabs_of(qext: f64, qsca: f64, m_im: f64) -> f64 {
    let d = qext - qsca;
    if m_im == 0.0 || (d < 0.0 && -d <= 1e-9 * qext.abs()) {
        0.0
    } else {
        d
    }
}

/// Cross sections from the sums for a (possibly absorbing) host, Frisvad et al. 2007.
fn cross_sections(sums: &Sums, x: Complex64, radius_m: f64, lambda_m: f64, n_medium: Complex64) -> Sphere {
    let area = PI * radius_m * radius_m;
    let lambda2 = lambda_m * lambda_m;
    let c_ext = lambda2 / (2.0 * PI) * div(sums.ext, n_medium * n_medium).re;
    let alpha = 4.0 * PI * radius_m * n_medium.im / lambda_m;
    let gamma = absorbing_host_gamma(alpha);
    let c_sca = lambda2 * (-alpha).exp() / (2.0 * PI * gamma * n_medium.norm_sqr()) * sums.sca;
    // Backscattering: 4|S1(π)|²/|x|² in the host (Bohren–Huffman normalisation).
    let qback = sums.back.norm_sqr() / x.norm_sqr();
    Sphere {
        eff: Efficiencies {
            terms: sums.terms,
            qext: c_ext / area,
            qsca: c_sca / area,
            qabs: (c_ext - c_sca) / area,
            qback,
            g: if sums.sca > 0.0 { 2.0 * sums.g_num / sums.sca } else { 0.0 },
        },
        c_ext_m2: c_ext,
        c_sca_m2: c_sca,
        c_abs_m2: c_ext - c_sca,
    }
}

impl MieWorkspace {
    /// Coefficients (a_n, b_n at index n−1) of the last [`MieWorkspace::coefficients`] or
    /// [`MieWorkspace::sphere_keep_coefficients`] call.
    pub fn last_coefficients(&self) -> (&[Complex64], &[Complex64]) {
        (&self.a, &self.b)
    }
}

/// γ(α) = 2(1 + (α−1)e^α)/α² of Frisvad et al. 2007: the mean incident intensity over the
/// particle's front surface relative to its centre, α = 4πr n″_med/λ. The closed form cancels
/// catastrophically for small α (relative error ~10⁻¹⁶/α²), so below α = 0.5 the series
/// γ = 2 Σ_{j≥2} (j−1) α^{j−2}/j! = 1 + 2α/3 + α²/4 + α³/15 + … is summed instead.
pub fn absorbing_host_gamma(alpha: f64) -> f64 {
    if alpha < 0.5 {
        let mut sum = 0.0;
        let mut pow = 1.0; // α^{j−2}
        let mut fact = 2.0; // j!
        for j in 2..30 {
            sum += (j - 1) as f64 * pow / fact;
            pow *= alpha;
            fact *= (j + 1) as f64;
        }
        2.0 * sum
    } else {
        2.0 * (1.0 + (alpha - 1.0) * alpha.exp()) / (alpha * alpha)
    }
}

/// Asymmetry parameter g from coefficients (a[n−1] = a_n): normalised far-field ⟨cos θ⟩.
pub fn asymmetry(a: &[Complex64], b: &[Complex64]) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for k in 0..a.len() {
        let n = (k + 1) as f64;
        den += (2.0 * n + 1.0) * (a[k].norm_sqr() + b[k].norm_sqr());
        num += (2.0 * n + 1.0) / (n * (n + 1.0)) * (a[k] * b[k].conj()).re;
        if k + 1 < a.len() {
            num += n * (n + 2.0) / (n + 1.0) * (a[k] * a[k + 1].conj() + b[k] * b[k + 1].conj()).re;
        }
    }
    if den > 0.0 {
        2.0 * num / den
    } else {
        0.0
    }
}

/// Scattering amplitudes (S1, S2) at cos θ = `mu` from coefficients (a[n−1] = a_n),
/// Bohren–Huffman normalisation, using the angular functions π_n and τ_n.
pub fn amplitudes(a: &[Complex64], b: &[Complex64], mu: f64) -> (Complex64, Complex64) {
    let mut s1 = Complex64::new(0.0, 0.0);
    let mut s2 = Complex64::new(0.0, 0.0);
    let mut pi_prev = 0.0; // π_0
    let mut pi_n = 1.0; // π_1
    for k in 0..a.len() {
        let n = (k + 1) as f64;
        let tau = n * mu * pi_n - (n + 1.0) * pi_prev;
        let w = (2.0 * n + 1.0) / (n * (n + 1.0));
        s1 += (a[k] * pi_n + b[k] * tau) * w;
        s2 += (a[k] * tau + b[k] * pi_n) * w;
        let pi_next = ((2.0 * n + 1.0) * mu * pi_n - (n + 1.0) * pi_prev) / n;
        pi_prev = pi_n;
        pi_n = pi_next;
    }
    (s1, s2)
}

/// Phase function p(θ) per steradian at cos θ = `mu`, normalised to 1 over the sphere:
/// p = (|S1|² + |S2|²) / (4π Σ(2n+1)(|a_n|²+|b_n|²)).
pub fn phase_function(a: &[Complex64], b: &[Complex64], mu: f64) -> f64 {
    let den = scattering_sum(a, b);
    let (s1, s2) = amplitudes(a, b, mu);
    if den > 0.0 {
        (s1.norm_sqr() + s2.norm_sqr()) / (4.0 * PI * den)
    } else {
        1.0 / (4.0 * PI)
    }
}

/// Σ(2n+1)(|a_n|²+|b_n|²).
pub fn scattering_sum(a: &[Complex64], b: &[Complex64]) -> f64 {
    a.iter()
        .zip(b)
        .enumerate()
        .map(|(k, (an, bn))| (2 * k + 3) as f64 * (an.norm_sqr() + bn.norm_sqr()))
        .sum()
}

/// Size parameter in the host, x = 2π r n_med / λ (complex for an absorbing host), for a sphere
/// of radius `radius_m` at vacuum wavelength `lambda_m`: the x that [`MieWorkspace::sphere`] uses.
pub fn size_parameter(radius_m: f64, lambda_m: f64, n_medium: Complex64) -> Complex64 {
    n_medium * (2.0 * PI / lambda_m * radius_m)
}

/// Convenience: Q's and g for real size parameter `x` and relative index `m` (thread-local workspace).
pub fn efficiencies(x: f64, m: Complex64) -> Efficiencies {
    WORKSPACE.with(|w| w.borrow_mut().efficiencies(x, m))
}

/// Convenience: cross sections of a sphere (thread-local workspace); see [`MieWorkspace::sphere`].
pub fn sphere(radius_m: f64, lambda_m: f64, n_particle: Complex64, n_medium: Complex64) -> Sphere {
    WORKSPACE.with(|w| w.borrow_mut().sphere(radius_m, lambda_m, n_particle, n_medium))
}

thread_local! {
    static WORKSPACE: std::cell::RefCell<MieWorkspace> = std::cell::RefCell::new(MieWorkspace::new());
}

/// Rayleigh (x ≪ 1) efficiencies: Q_sca = 8/3 x⁴ |K|², Q_abs = 4x Im K with K = (m²−1)/(m²+2).
pub fn rayleigh(x: f64, m: Complex64) -> (f64, f64) {
    let m2 = m * m;
    let k = (m2 - 1.0) / (m2 + 2.0);
    (8.0 / 3.0 * x.powi(4) * k.norm_sqr(), 4.0 * x * k.im)
}

/// Parse a complex number written `RE`, `RE+IMi` or `RE-IMi` (decimal or exponent notation).
pub fn parse_complex(s: &str) -> anyhow::Result<Complex64> {
    let t = s.trim();
    let bad = || anyhow::anyhow!("malformed complex number {s:?} (expected RE or RE+IMi, e.g. 1.33+1e-05i)");
    let parse = |v: &str| -> anyhow::Result<f64> {
        if v.is_empty() || v.contains(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c))) {
            return Err(bad());
        }
        let f: f64 = v.parse().map_err(|_| bad())?;
        if !f.is_finite() {
            return Err(anyhow::anyhow!("complex number {s:?} is not finite"));
        }
        Ok(f)
    };
    if let Some(body) = t.strip_suffix(['i', 'j']) {
        // find the sign that separates the real and imaginary parts (not an exponent sign)
        let bytes = body.as_bytes();
        let mut split = None;
        for k in (1..bytes.len()).rev() {
            if (bytes[k] == b'+' || bytes[k] == b'-') && !matches!(bytes[k - 1], b'e' | b'E') {
                split = Some(k);
                break;
            }
        }
        match split {
            Some(k) => {
                let re = parse(&body[..k])?;
                let im_str = &body[k..];
                if im_str.len() <= 1 {
                    return Err(bad());
                }
                let im = parse(im_str)?;
                Ok(Complex64::new(re, im))
            }
            None => Err(bad()),
        }
    } else {
        Ok(Complex64::new(parse(t)?, 0.0))
    }
}
