//! Exhaustive sweeps of the SIMD special functions in `analytic_fog::math` against f64.
//!
//! ```text
//! cargo test --release --test exhaustive -- --ignored --nocapture
//! ```
//!
//! Every f32 input of each function's domain (all 2^32 bit patterns for `exp`, `expm1`,
//! `exp_split`, `exp2_split`, `frexp` and `exp2m1`; every f32 >= 0 for `exp_neg`, every f32
//! <= 0 for `exp2_nonpos` and `exp2_nonpos_table`, every f32 >= 2^-60 for `exprel_neg` and
//! `exprel2_neg`; every mantissa of `ldexp`'s precondition domain with a sampled exponent,
//! `ldexp_no_subnormal` against it)
//! is evaluated 8 at a time through the `wide::f32x8` instantiation, and one at a time
//! through the scalar `f32` instantiation, which must give the same bits. Errors are
//! measured in ULP of the correctly rounded f32 result (2^-149 for subnormal results)
//! against the f64 function, and each sweep asserts the bound written in its function's
//! header. The sweeps are split over all cores with rayon (a few minutes on 2 cores in
//! release; far too slow in debug, hence `#[ignore]`).

mod common;

use analytic_fog::math::{self, Lane};
use common::ulp_of;
use rayon::prelude::*;
use wide::f32x8;

/// Max ULP errors documented in the headers of `src/math/*.rs`; the sweeps assert them.
const EXP_MAX_ULP: f64 = 0.96;
const EXPM1_MAX_ULP: f64 = 1.44;
const EXP_NEG_MAX_ULP: f64 = 0.599;
/// Sampled (`exp_neg_mul_sweep`: 10 factors κ with 12 binades of x each, max 0.6020;
/// 4096 random factors with 2^17 random x each, max 0.6035 measured; 0.6040 with
/// `EXP_NEG_MUL_FACTORS=65536`): a little room for the factors not tried.
const EXP_NEG_MUL_MAX_ULP: f64 = 0.62;
const EXPREL_NEG_MAX_ULP: f64 = 1.73;
const EXPREL2_NEG_MAX_ULP: f64 = 1.611;
/// `exp2_split`'s `m · 2^k` (not rounded into the f32 range), for y in [-1022, 1023] (normal f64 results).
const EXP2_SPLIT_MAX_ULP: f64 = 0.876;
const EXP2_NONPOS_MAX_ULP: f64 = 1.09;
const EXP2_NONPOS_TABLE_MAX_ULP: f64 = 0.993;
/// Sampled (2^22 products; max 0.9945 measured): r comes from the exact product, so it
/// takes values between the f32 grid's and the maximum sits a little above the sweep's.
const EXP2_NONPOS_TABLE_MUL_MAX_ULP: f64 = 1.0;
const EXP2M1_MAX_ULP: f64 = 1.79;
/// `exp_split`'s `m · 2^k` (not rounded into the f32 range), for x in [-104, 89].
const EXP_SPLIT_MAX_ULP: f64 = 0.96;

/// Inputs per rayon task.
const CHUNK: u64 = 1 << 16;

// ---------------------------------------------------------------------------------------
// Error measure and statistics

/// |y − r| in ULP of the correctly rounded f32 result `r as f32`. An overflow (`±inf`)
/// counts as ±2^128 where `r` is finite, so that an early or late overflow costs what the
/// distance to the threshold is; an infinite or NaN `r` must be matched exactly.
fn ulp_err(y: f32, r: f64) -> f64 {
    if r.is_nan() || y.is_nan() {
        return if r.is_nan() && y.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if r.is_infinite() {
        return if y as f64 == r { 0.0 } else { f64::INFINITY };
    }
    let c = r as f32;
    if c.is_infinite() && y == c {
        return 0.0; // a correctly rounded overflow
    }
    let u = if c.is_infinite() {
        ulp_of(f32::MAX)
    } else {
        ulp_of(c)
    };
    let yv = if y.is_infinite() {
        2f64.powi(128).copysign(y as f64)
    } else {
        y as f64
    };
    (yv - r).abs() / u
}

/// The largest error seen and where.
#[derive(Clone, Copy, Debug, Default)]
struct Worst {
    ulp: f64,
    x: f32,
    got: f32,
    want: f64,
}

/// Error statistics of one function over one domain.
#[derive(Clone, Debug, Default)]
struct Errors {
    n: u64,
    worst: Worst,
    over_half: u64,
}

impl Errors {
    #[inline]
    fn record(&mut self, x: f32, got: f32, want: f64, ulp: f64) {
        self.n += 1;
        if ulp > 0.5 {
            self.over_half += 1;
        }
        // A NaN error is recorded as the worst.
        if ulp > self.worst.ulp || ulp.is_nan() {
            self.worst = Worst { ulp, x, got, want };
        }
    }
}

impl Merge for Errors {
    fn merge(mut self, o: Errors) -> Errors {
        self.n += o.n;
        self.over_half += o.over_half;
        if o.worst.ulp > self.worst.ulp || o.worst.ulp.is_nan() {
            self.worst = o.worst;
        }
        self
    }
}

impl Errors {
    fn print(&self, name: &str, domain: &str) {
        let w = &self.worst;
        println!(
            "{name:<24} {domain:<28} max {:.4} ULP at x = {:e} ({:#010x}): got {:e}, f64 {:e}; {} of {} over 0.5 ULP",
            w.ulp,
            w.x,
            w.x.to_bits(),
            w.got,
            w.want,
            self.over_half,
            self.n
        );
    }
}

/// Failures of exact checks (x8 against scalar, invariants), with the first few kept.
#[derive(Clone, Debug, Default)]
struct Failures {
    count: u64,
    first: Vec<String>,
}

impl Failures {
    #[inline]
    fn check(&mut self, ok: bool, what: impl FnOnce() -> String) {
        if !ok {
            self.count += 1;
            if self.first.len() < 8 {
                self.first.push(what());
            }
        }
    }
}

impl Merge for Failures {
    fn merge(mut self, o: Failures) -> Failures {
        self.count += o.count;
        for f in o.first {
            if self.first.len() < 8 {
                self.first.push(f);
            }
        }
        self
    }
}

impl Failures {
    fn assert_none(&self, name: &str) {
        assert!(
            self.count == 0,
            "{name}: {} failures, first: {:#?}",
            self.count,
            self.first
        );
    }
}

/// Inclusive ranges of f32 bit patterns.
type BitRanges = Vec<(u32, u32)>;

/// Every f32 bit pattern.
fn all_f32() -> BitRanges {
    vec![(0, u32::MAX)]
}

/// A sweep's per-task state: the tasks' states are merged into one at the end.
trait Merge {
    fn merge(self, o: Self) -> Self;
}

/// `Merge` for a state struct: field by field.
macro_rules! merge_fields {
    ($t:ident { $($f:ident),+ }) => {
        impl Merge for $t {
            fn merge(self, o: $t) -> $t {
                $t { $($f: self.$f.merge(o.$f)),+ }
            }
        }
    };
}

/// Runs `f` over every bit pattern in `ranges`, 8 consecutive patterns at a time (the last
/// group padded by repeating its last value; `f` gets the number of live lanes), in
/// parallel with rayon, and merges the per-task states.
fn sweep<S, F>(ranges: &BitRanges, f: F) -> S
where
    S: Default + Send + Merge,
    F: Fn(&mut S, [f32; 8], usize) + Sync,
{
    let mut tasks = Vec::new();
    for &(lo, hi) in ranges {
        let (mut a, end) = (lo as u64, hi as u64 + 1);
        while a < end {
            let b = (a + CHUNK).min(end);
            tasks.push((a, b));
            a = b;
        }
    }
    tasks
        .par_iter()
        .fold(S::default, |mut s, &(a, b)| {
            let mut i = a;
            while i < b {
                let live = ((b - i) as usize).min(8);
                let mut xs = [0f32; 8];
                for (l, x) in xs.iter_mut().enumerate() {
                    *x = f32::from_bits((i + l.min(live - 1) as u64) as u32);
                }
                f(&mut s, xs, live);
                i += 8;
            }
            s
        })
        .reduce(S::default, S::merge)
}

/// `f` through the x8 instantiation and lane by lane through the scalar one; records a
/// failure unless the bits agree, and returns the x8 result.
#[inline(always)]
fn x8_and_scalar(
    xs: [f32; 8],
    live: usize,
    fails: &mut Failures,
    name: &str,
    x8: impl Fn(f32x8) -> f32x8,
    scalar: impl Fn(f32) -> f32,
) -> [f32; 8] {
    let v = x8(f32x8::new(xs)).to_array();
    for l in 0..live {
        if xs[l].is_nan() {
            fails.check(v[l].is_nan(), || format!("{name}(NaN) = {:e}", v[l]));
        }
        let s = scalar(xs[l]);
        fails.check(v[l].to_bits() == s.to_bits(), || {
            format!(
                "{name}({:e} = {:#010x}): x8 {:#010x}, scalar {:#010x}",
                xs[l],
                xs[l].to_bits(),
                v[l].to_bits(),
                s.to_bits()
            )
        });
    }
    v
}

fn assert_max(name: &str, e: &Errors, bound: f64) {
    assert!(
        e.worst.ulp <= bound,
        "{name}: max error {} ULP at x = {:e} exceeds the documented {bound} ULP (got {:e}, f64 {:e})",
        e.worst.ulp,
        e.worst.x,
        e.worst.got,
        e.worst.want
    );
}

// ---------------------------------------------------------------------------------------
// exp (and wide's exp for comparison)

#[derive(Default)]
struct ExpState {
    ours: Errors,
    wide_full: Errors,
    wide_valid: Errors,
    fails: Failures,
}
merge_fields!(ExpState {
    ours,
    wide_full,
    wide_valid,
    fails
});

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp_exhaustive() {
    let st = sweep::<ExpState, _>(&all_f32(), |st, xs, live| {
        let y = x8_and_scalar(xs, live, &mut st.fails, "exp", math::exp, math::exp);
        let w = f32x8::new(xs).exp().to_array();
        for l in 0..live {
            let x = xs[l];
            if x.is_nan() {
                // NaN → NaN: checked by `x8_and_scalar`.
                continue;
            }
            if !(-104.0..=89.0).contains(&x) {
                // Outside the domain: saturated exactly (±inf included).
                let want = if x > 0.0 { f32::INFINITY } else { 0.0 };
                st.fails.check(y[l].to_bits() == want.to_bits(), || {
                    format!("exp({x:e}) = {:e}, want {want:e}", y[l])
                });
                continue;
            }
            let r = (x as f64).exp();
            st.ours.record(x, y[l], r, ulp_err(y[l], r));
            let ew = ulp_err(w[l], r);
            st.wide_full.record(x, w[l], r, ew);
            // wide's exp returns 0 for |x| >= 87.3 (and for ±inf and NaN).
            if x.abs() < 87.3 {
                st.wide_valid.record(x, w[l], r, ew);
            }
        }
    });
    println!();
    st.ours.print("math::exp", "[-104, 89]");
    st.wide_full.print("wide f32x8::exp", "[-104, 89]");
    st.wide_valid.print("wide f32x8::exp", "(-87.3, 87.3)");
    st.fails.assert_none("exp");
    let n = 89f32.to_bits() as u64 + 1 + ((-104f32).to_bits() - 0x8000_0000) as u64 + 1;
    assert_eq!(st.ours.n, n);
    assert_max("exp", &st.ours, EXP_MAX_ULP);
}

// ---------------------------------------------------------------------------------------
// expm1

/// The state of a sweep with one error domain (expm1, exp2m1, ldexp).
#[derive(Default)]
struct OneDomain {
    errors: Errors,
    fails: Failures,
}
merge_fields!(OneDomain { errors, fails });

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn expm1_exhaustive() {
    let st = sweep::<OneDomain, _>(&all_f32(), |st, xs, live| {
        let y = x8_and_scalar(xs, live, &mut st.fails, "expm1", math::expm1, math::expm1);
        for l in 0..live {
            let x = xs[l];
            if x.is_nan() {
                // NaN → NaN: checked by `x8_and_scalar`.
                continue;
            }
            // All of f32, ±inf included (expm1(-inf) = -1, expm1(+inf) = +inf).
            let r = (x as f64).exp_m1();
            st.errors.record(x, y[l], r, ulp_err(y[l], r));
            // Tiny inputs come back exactly (−0 gives +0).
            if x.abs() < 1e-30 {
                st.fails
                    .check(y[l] == x, || format!("expm1({x:e}) = {:e}, want x", y[l]));
            }
        }
    });
    println!();
    st.errors.print("math::expm1", "all f32 (±inf included)");
    st.fails.assert_none("expm1");
    assert_eq!(st.errors.n, (1u64 << 32) - 2 * ((1 << 23) - 1));
    assert_max("expm1", &st.errors, EXPM1_MAX_ULP);
}

// ---------------------------------------------------------------------------------------
// exp_neg

#[derive(Default)]
struct ExpNegState {
    /// Results >= 2^-126 (x <= 87.33).
    normal: Errors,
    /// Results below 2^-126: flushed, absolute error below 2^-126.
    flushed: Errors,
    fails: Failures,
}
merge_fields!(ExpNegState {
    normal,
    flushed,
    fails
});

/// A transmittance-like function (results in [0, 1], flushed to 0 below 2^-126) over the
/// bit patterns `ranges`: ULP error where the f64 result `want(x)` is at least 2^-126, the
/// absolute error in units of 2^-126 below, NaN for NaN; prints both and asserts `bound`
/// and an absolute error below 2^-126. Returns the number of inputs in the ULP domain.
fn transmittance_sweep(
    name: &str,
    ranges: &BitRanges,
    domains: [&str; 2],
    f8: impl Fn(f32x8) -> f32x8 + Sync,
    f1: impl Fn(f32) -> f32 + Sync,
    want: impl Fn(f64) -> f64 + Sync,
    bound: f64,
) -> u64 {
    let st = sweep::<ExpNegState, _>(ranges, |st, xs, live| {
        let y = x8_and_scalar(xs, live, &mut st.fails, name, &f8, &f1);
        for l in 0..live {
            let x = xs[l];
            if x.is_nan() {
                // NaN → NaN: checked by `x8_and_scalar`.
                continue;
            }
            let r = want(x as f64);
            if r >= f32::MIN_POSITIVE as f64 {
                st.normal.record(x, y[l], r, ulp_err(y[l], r));
            } else {
                let abs = (y[l] as f64 - r).abs();
                st.flushed
                    .record(x, y[l], r, abs / f32::MIN_POSITIVE as f64);
            }
        }
    });
    println!();
    let label = format!("math::{name}");
    st.normal.print(&label, domains[0]);
    println!(
        "{label:<24} {}: max |error| {:e} = {:.4} * 2^-126 at x = {:e}",
        domains[1],
        st.flushed.worst.ulp * f32::MIN_POSITIVE as f64,
        st.flushed.worst.ulp,
        st.flushed.worst.x
    );
    st.fails.assert_none(name);
    assert_max(name, &st.normal, bound);
    assert!(
        st.flushed.worst.ulp < 1.0,
        "{name}: absolute error {} * 2^-126 for results below 2^-126",
        st.flushed.worst.ulp
    );
    st.normal.n
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp_neg_exhaustive() {
    // Domain x >= 0: every f32 in [0, +inf], -0, and the positive NaNs.
    let _ = transmittance_sweep(
        "exp_neg",
        &vec![(0, 0x7fff_ffff), (0x8000_0000, 0x8000_0000)],
        ["[0, 87.33] (results >= 2^-126)", "(87.33, +inf]"],
        math::exp_neg,
        math::exp_neg,
        |x| (-x).exp(),
        EXP_NEG_MAX_ULP,
    );
}

/// `exp_neg_mul(x, κ)` = e^(−x·κ) (the kernels' T straight from the geometric depth,
/// κ a channel's mantissa): for each κ every f32 x with x·κ in [2^-6, 104] (12 binades
/// of x: the whole of the table and polynomial's work, the flush boundary x·κ ≈ 87.3 and
/// beyond), against f64 e^(−x·κ) of the exact product. κ: the ends of the kernels' range
/// of mantissas [2^-16, 2), some between, and the ends of `ExpNegMul::new`'s domain.
#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp_neg_mul_sweep() {
    let kappas = [
        2f32.powi(-64),
        2f32.powi(-16),
        1.372_549e-5,
        0.012_345_679,
        0.3,
        core::f32::consts::FRAC_1_SQRT_2,
        1.234_567_9,
        1.5,
        1.999_999_9,
        2f32.powi(32),
    ];
    let mut n = 0;
    for kappa in kappas {
        let k = math::ExpNegMul::new(kappa).expect("in the domain");
        let lo = (2f64.powi(-6) / f64::from(kappa)) as f32;
        let hi = (104.0 / f64::from(kappa)) as f32;
        n += transmittance_sweep(
            &format!("exp_neg_mul(x, {kappa:e})"),
            &vec![(lo.to_bits(), hi.to_bits())],
            ["x*k in [2^-6, 87.33]", "x*k in (87.33, 104]"],
            |x| math::exp_neg_mul(x, k),
            |x| math::exp_neg_mul(x, k),
            |x| (-x * f64::from(kappa)).exp(),
            EXP_NEG_MUL_MAX_ULP,
        );
    }
    println!(
        "exp_neg_mul: {n} results >= 2^-126 over {} factors",
        kappas.len()
    );
    // Random factors in the kernels' range [2^-16, 2) (log-uniform), each with random x
    // (x·κ log-uniform in [2^-6, 2^6.5]): the error's maximum moves with κ. 4096 of them
    // unless `EXP_NEG_MUL_FACTORS` says otherwise.
    let factors: u64 = std::env::var("EXP_NEG_MUL_FACTORS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let (worst, at_k, at_x) = (0..factors)
        .into_par_iter()
        .map(|i| {
            let mut s = i.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x0123_4567;
            let mut unit = || {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64
            };
            let kappa = (2f64.powf(-16.0 + 17.0 * unit()) as f32).min(1.999_999_9);
            let k = math::ExpNegMul::new(kappa).expect("in the domain");
            let mut w = (0.0f64, kappa, 0.0f32);
            let mut xs = [0f32; 8];
            for _ in 0..(1 << 14) {
                for x in xs.iter_mut() {
                    *x = (2f64.powf(-6.0 + 12.5 * unit()) / f64::from(kappa)) as f32;
                }
                let y = math::exp_neg_mul(f32x8::new(xs), k).to_array();
                for l in 0..8 {
                    let y1 = math::exp_neg_mul(xs[l], k);
                    assert_eq!(y1.to_bits(), y[l].to_bits(), "x8 vs scalar at {:e}", xs[l]);
                    let r = (-f64::from(xs[l]) * f64::from(kappa)).exp();
                    if r >= f64::from(f32::MIN_POSITIVE) {
                        let e = ulp_err(y1, r);
                        if e > w.0 {
                            w = (e, kappa, xs[l]);
                        }
                    }
                }
            }
            w
        })
        .reduce(|| (0.0, 0.0, 0.0), |a, b| if a.0 >= b.0 { a } else { b });
    println!(
        "exp_neg_mul, {factors} random factors x 2^17 x: max {worst:.4} ULP at κ = {at_k:e}, x = {at_x:e}"
    );
    assert!(
        worst <= EXP_NEG_MUL_MAX_ULP,
        "exp_neg_mul: {worst} ULP at κ = {at_k:e}, x = {at_x:e}"
    );
}

// ---------------------------------------------------------------------------------------
// exp2_nonpos (the pass's transmittance)

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp2_nonpos_exhaustive() {
    // Domain y <= 0: every f32 in [-inf, -0], +0, and the negative NaNs.
    let n = transmittance_sweep(
        "exp2_nonpos",
        &vec![(0, 0), (0x8000_0000, 0xffff_ffff)],
        ["[-126, 0] (results >= 2^-126)", "[-inf, -126)"],
        math::exp2_nonpos,
        math::exp2_nonpos,
        |x| x.exp2(),
        EXP2_NONPOS_MAX_ULP,
    );
    // Every f32 in [-126, -0] and +0 is in the ULP domain.
    assert_eq!(n, (-126f32).to_bits() as u64 - 0x8000_0000 + 2);
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp2_nonpos_table_exhaustive() {
    // The same domain; 8 lanes (one `vpermt2ps` and `vscalefps` each with AVX-512VL, the
    // lane-by-lane forms otherwise) against the scalar form, bit for bit.
    let n = transmittance_sweep(
        "exp2_nonpos_table",
        &vec![(0, 0), (0x8000_0000, 0xffff_ffff)],
        ["[-126, 0] (results >= 2^-126)", "[-inf, -126)"],
        math::exp2_nonpos_table,
        math::exp2_nonpos_table,
        |x| x.exp2(),
        EXP2_NONPOS_TABLE_MAX_ULP,
    );
    assert_eq!(n, (-126f32).to_bits() as u64 - 0x8000_0000 + 2);
}

/// `exp2_nonpos_table_mul(k, g)` = 2^(k·g), the pass's AVX-512 transmittance with the
/// product fused into the reduction (not ignored: sampled). With g = 1 it must give
/// `exp2_nonpos_table`'s bits on every 4099th f32 in [−126, −2⁻⁶⁰]; on pseudo-random
/// pairs (k ≤ 0, g ≥ 0, products down to −140) it must stay within 1 ULP of the f64
/// value of the exact product (normal results) and an absolute error
/// below 2⁻¹²⁶ below, with 8 lanes equal to scalar bit for bit.
#[test]
fn exp2_nonpos_table_mul_products() {
    let one = f32x8::splat(1.0);
    let mut same = 0u64;
    for bits in (0x8000_0000u32..=(-126f32).to_bits()).step_by(4099) {
        let y = f32::from_bits(bits);
        if y > -8.673_617e-19 {
            continue;
        }
        let a = math::exp2_nonpos_table_mul(y, 1.0);
        let b = math::exp2_nonpos_table(y);
        assert_eq!(a.to_bits(), b.to_bits(), "y = {y:e}: {a:e} against {b:e}");
        let v = math::exp2_nonpos_table_mul(f32x8::splat(y), one).to_array()[3];
        assert_eq!(v.to_bits(), a.to_bits(), "8 lanes, y = {y:e}");
        same += 1;
    }
    assert!(same > 130_000, "{same} values compared");
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let (mut worst, mut at) = (0.0f64, (0.0f32, 0.0f32));
    let mut worst_abs = 0.0f64;
    for _ in 0..1 << 19 {
        let mut k = [0.0f32; 8];
        let mut g = [0.0f32; 8];
        for l in 0..8 {
            // |k| over 40 binades, the product's magnitude up to 140.
            let e = next() * 40.0 - 30.0;
            k[l] = -(2f32.powf(e) * (1.0 + next()));
            g[l] = next() * 140.0 / -k[l] * next();
        }
        let v = math::exp2_nonpos_table_mul(f32x8::new(k), f32x8::new(g)).to_array();
        for l in 0..8 {
            let s = math::exp2_nonpos_table_mul(k[l], g[l]);
            assert_eq!(
                v[l].to_bits(),
                s.to_bits(),
                "8 lanes, k = {:e}, g = {:e}",
                k[l],
                g[l]
            );
            let r = (f64::from(k[l]) * f64::from(g[l])).exp2();
            if r >= f64::from(f32::MIN_POSITIVE) {
                let e = ulp_err(s, r);
                if e > worst {
                    (worst, at) = (e, (k[l], g[l]));
                }
            } else {
                worst_abs = worst_abs.max((f64::from(s) - r).abs() / f64::from(f32::MIN_POSITIVE));
            }
        }
    }
    println!(
        "math::exp2_nonpos_table_mul, 2^22 products: max {worst:.4} ULP at k = {:e}, g = {:e}; \
         below 2^-126 max |error| {worst_abs:.4} * 2^-126",
        at.0, at.1
    );
    assert!(
        worst <= EXP2_NONPOS_TABLE_MUL_MAX_ULP,
        "{worst} ULP at k = {:e}, g = {:e}",
        at.0,
        at.1
    );
    assert!(worst_abs < 1.0, "absolute error {worst_abs} * 2^-126");
    for (k, g) in [
        (f32::NEG_INFINITY, 1.0),
        (-1.0, f32::INFINITY),
        (-0.0, 5.0),
        (-3.0, 0.0),
    ] {
        let t = math::exp2_nonpos_table_mul(k, g);
        let want = if k * g == 0.0 { 1.0 } else { 0.0 };
        assert_eq!(t, want, "2^({k:e}·{g:e})");
    }
    assert!(math::exp2_nonpos_table_mul(f32::NAN, 1.0).is_nan());
    assert!(math::exp2_nonpos_table_mul(-1.0, f32::NAN).is_nan());
}

// ---------------------------------------------------------------------------------------
// exp2m1 (the pass's E(Δ))

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp2m1_exhaustive() {
    let at127 = math::exp2m1(127.0f32);
    // `errors`: over [-64, 127].
    let st = sweep::<OneDomain, _>(&all_f32(), |st, xs, live| {
        let y = x8_and_scalar(
            xs,
            live,
            &mut st.fails,
            "exp2m1",
            math::exp2m1,
            math::exp2m1,
        );
        for l in 0..live {
            let x = xs[l];
            if x.is_nan() {
                // NaN → NaN: checked by `x8_and_scalar`.
                continue;
            }
            // `exp2m1_in_range` (no clamp): the same bits within [-64, 127], and in its
            // margins [-64.5, -64) and (127, 127.25] −1 exactly and within the bound.
            if (-64.5..=127.25).contains(&x) {
                let z = math::exp2m1_in_range(x);
                if (-64.0..=127.0).contains(&x) {
                    st.fails.check(z.to_bits() == y[l].to_bits(), || {
                        format!("exp2m1_in_range({x:e}) = {z:e}, exp2m1 {:e}", y[l])
                    });
                } else if x < -64.0 {
                    st.fails.check(z == -1.0, || {
                        format!("exp2m1_in_range({x:e}) = {z:e}, want -1")
                    });
                } else {
                    let r = (x as f64 * core::f64::consts::LN_2).exp_m1();
                    st.fails.check(ulp_err(z, r) <= EXP2M1_MAX_ULP, || {
                        format!("exp2m1_in_range({x:e}) = {z:e}, want {r:e}")
                    });
                }
            }
            if x < -64.0 {
                // 2^x < 2^-64: −1 exactly (what 2^x − 1 rounds to).
                st.fails.check(y[l] == -1.0, || {
                    format!("exp2m1({x:e}) = {:e}, want -1", y[l])
                });
                continue;
            }
            if x > 127.0 {
                // Clamped: the value at 127.
                st.fails.check(y[l].to_bits() == at127.to_bits(), || {
                    format!("exp2m1({x:e}) = {:e}, want exp2m1(127)", y[l])
                });
                continue;
            }
            let r = (x as f64 * core::f64::consts::LN_2).exp_m1();
            st.errors.record(x, y[l], r, ulp_err(y[l], r));
        }
    });
    println!();
    st.errors.print("math::exp2m1", "[-64, 127]");
    st.fails.assert_none("exp2m1");
    assert_eq!(at127, 2f32.powi(127));
    assert_max("exp2m1", &st.errors, EXP2M1_MAX_ULP);
}

// ---------------------------------------------------------------------------------------
// exprel_neg

#[derive(Default)]
struct ExprelState {
    /// [2^-60, 2^11]: the domain the kernels use.
    domain: Errors,
    /// (2^11, +inf]: 1/x.
    beyond: Errors,
    fails: Failures,
}
merge_fields!(ExprelState {
    domain,
    beyond,
    fails
});

/// The exhaustive sweep of a φ-like function `f(x) = (1 − b^−x)/x` (`exprel_neg`,
/// `exprel2_neg`) over every f32 >= 2^-60, +inf and the positive NaNs: x8 against
/// scalar bit for bit, NaN for NaN, and the error against the f64 value
/// −expm1(−x·ln b)/x (`ln_b` = ln b), within `bound` up to 2^11 and `beyond` above
/// (where it is 1/x).
fn exprel_sweep(
    name: &'static str,
    f: fn(f32) -> f32,
    f8: fn(f32x8) -> f32x8,
    ln_b: f64,
    bound: f64,
    beyond: f64,
) {
    let ranges = vec![(2f32.powi(-60).to_bits(), 0x7fff_ffff)];
    let top = 2f32.powi(11);
    let st = sweep::<ExprelState, _>(&ranges, |st, xs, live| {
        let y = x8_and_scalar(xs, live, &mut st.fails, name, f8, f);
        for l in 0..live {
            let x = xs[l];
            if x.is_nan() {
                // NaN → NaN: checked by `x8_and_scalar`.
                continue;
            }
            let xd = x as f64;
            let r = if x.is_infinite() {
                0.0
            } else {
                -(-xd * ln_b).exp_m1() / xd
            };
            let e = ulp_err(y[l], r);
            if x <= top {
                st.domain.record(x, y[l], r, e);
            } else {
                st.beyond.record(x, y[l], r, e);
            }
        }
    });
    let label = format!("math::{name}");
    println!();
    st.domain.print(&label, "[2^-60, 2^11]");
    st.beyond.print(&label, "(2^11, +inf]");
    st.fails.assert_none(name);
    assert_max(name, &st.domain, bound);
    assert_max(&format!("{name} (beyond)"), &st.beyond, beyond);
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exprel_neg_exhaustive() {
    exprel_sweep(
        "exprel_neg",
        math::exprel_neg,
        math::exprel_neg,
        1.0,
        EXPREL_NEG_MAX_ULP,
        EXPREL_NEG_MAX_ULP,
    );
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exprel2_neg_exhaustive() {
    // Above 2^11 the result is 1/x correctly rounded.
    exprel_sweep(
        "exprel2_neg",
        math::exprel2_neg,
        math::exprel2_neg,
        std::f64::consts::LN_2,
        EXPREL2_NEG_MAX_ULP,
        0.5,
    );
}

// ---------------------------------------------------------------------------------------
// exp_split

/// |v − r| in ULP of `r` rounded to 24 bits with an unbounded exponent range (`m · 2^k`
/// is not confined to the f32 range).
fn ulp_err_unbounded(v: f64, r: f64) -> f64 {
    let e = r.abs().log2().floor() as i32;
    let s = r.abs() * pow2(-e); // in [1, 2] up to the log2 rounding
    let e = if (s as f32) >= 2.0 {
        e + 1
    } else if s < 1.0 {
        e - 1
    } else {
        e
    };
    (v - r).abs() / pow2(e - 23)
}

/// 2^n in f64 for n in [-1074, 1023], exact (`powi` goes through 1/2^-n, which overflows
/// for n < -1023).
fn pow2(n: i32) -> f64 {
    let h = n / 2;
    2f64.powi(h) * 2f64.powi(n - h)
}

#[derive(Default)]
struct SplitState {
    /// x in [`SplitSpec::in_range`]: the part whose result fits the f32 range.
    in_range: Errors,
    /// The rest of [`SplitSpec::measured`]: m·2^k against f64 (normal f64 results).
    beyond: Errors,
    /// The range of m for |x| up to [`SplitSpec::m_near`]'s bound, and for all inputs.
    m_near: MinMax,
    m_all: MinMax,
    fails: Failures,
}
merge_fields!(SplitState {
    in_range,
    beyond,
    m_near,
    m_all,
    fails
});

#[derive(Clone, Copy)]
struct MinMax(f32, f32);

impl Default for MinMax {
    fn default() -> Self {
        MinMax(f32::INFINITY, f32::NEG_INFINITY)
    }
}

impl MinMax {
    fn add(&mut self, v: f32) {
        self.0 = self.0.min(v);
        self.1 = self.1.max(v);
    }
}

impl Merge for MinMax {
    fn merge(self, o: MinMax) -> MinMax {
        MinMax(self.0.min(o.0), self.1.max(o.1))
    }
}

/// What [`split_sweep`] checks of one split function `f(x) = (m, k)`, x = m · 2^k in its
/// base.
struct SplitSpec {
    name: &'static str,
    f: fn(f32) -> (f32, f32),
    f8: fn(f32x8) -> (f32x8, f32x8),
    /// The value m · 2^k stands for, in f64.
    want: fn(f64) -> f64,
    /// m's range for every non-NaN input, and the largest |k|.
    m_all: (f32, f32),
    k_max: f32,
    /// m's tighter range for |x| up to the first value.
    m_near: (f32, (f32, f32)),
    /// Where m · 2^k is measured (normal f64 results), and the part of it whose results
    /// fit the f32 range (the first table row; the rest is the second).
    measured: (f32, f32),
    in_range: (f32, f32),
    bound: f64,
}

/// The exhaustive sweep of a split function (`exp_split`, `exp2_split`): x8 against
/// scalar bit for bit, NaN mantissa for NaN, the ranges of m and k, and m · 2^k against
/// f64 with an unbounded exponent.
fn split_sweep(spec: &SplitSpec) {
    let name = spec.name;
    let st = sweep::<SplitState, _>(&all_f32(), |st, xs, live| {
        let (m8, k8) = (spec.f8)(f32x8::new(xs));
        let (m8, k8) = (m8.to_array(), k8.to_array());
        for l in 0..live {
            let x = xs[l];
            let (m, k) = (spec.f)(x);
            st.fails.check(
                m.to_bits() == m8[l].to_bits() && k.to_bits() == k8[l].to_bits(),
                || {
                    format!(
                        "{name}({x:e}): x8 ({:e}, {:e}), scalar ({m:e}, {k:e})",
                        m8[l], k8[l]
                    )
                },
            );
            if x.is_nan() {
                st.fails
                    .check(m.is_nan(), || format!("{name}(NaN) = ({m:e}, {k:e})"));
                continue;
            }
            st.m_all.add(m);
            st.fails.check(
                (spec.m_all.0..=spec.m_all.1).contains(&m)
                    && k == k.round()
                    && k.abs() <= spec.k_max,
                || format!("{name}({x:e}) = ({m:e}, {k:e}): out of range"),
            );
            let (near, (lo, hi)) = spec.m_near;
            if x.abs() <= near {
                st.m_near.add(m);
                st.fails.check((lo..=hi).contains(&m), || {
                    format!("{name}({x:e}) = ({m:e}, {k:e}): m out of range")
                });
            }
            if (spec.measured.0..=spec.measured.1).contains(&x) {
                let r = (spec.want)(x as f64);
                let v = m as f64 * pow2(k as i32);
                let e = ulp_err_unbounded(v, r);
                if (spec.in_range.0..=spec.in_range.1).contains(&x) {
                    st.in_range.record(x, m, r, e);
                } else {
                    st.beyond.record(x, m, r, e);
                }
            }
        }
    });
    let label = format!("math::{name} m·2^k");
    let (a, b) = (spec.in_range, spec.measured);
    println!();
    st.in_range.print(&label, &format!("[{}, {}]", a.0, a.1));
    st.beyond
        .print(&label, &format!("[{}, {}] \\ [{}, {}]", b.0, b.1, a.0, a.1));
    println!(
        "math::{name} m range: [{}, {}] for |x| <= {}, [{}, {}] for all x",
        st.m_near.0, st.m_near.1, spec.m_near.0, st.m_all.0, st.m_all.1
    );
    st.fails.assert_none(name);
    assert_max(name, &st.in_range, spec.bound);
    assert_max(&format!("{name} (beyond)"), &st.beyond, spec.bound);
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp_split_exhaustive() {
    // For every non-NaN input (±inf clamped to ±2^20): m in [0.66, 1.50] and k an integer
    // no larger than 2^20·log2(e); m in [0.70, 1.42] where |x| <= 709 (the rounding of
    // x·log2(e) to f32 widens the reduced range beyond).
    split_sweep(&SplitSpec {
        name: "exp_split",
        f: math::exp_split,
        f8: math::exp_split,
        want: f64::exp,
        m_all: (0.66, 1.50),
        k_max: 1_512_776.0,
        m_near: (709.0, (0.70, 1.42)),
        measured: (-708.0, 709.0),
        in_range: (-104.0, 89.0),
        bound: EXP_SPLIT_MAX_ULP,
    });
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn exp2_split_exhaustive() {
    // For every non-NaN input (±inf clamped to ±2^20): m in [0.70, 1.42], k an integer
    // with |k| <= 2^20.
    split_sweep(&SplitSpec {
        name: "exp2_split",
        f: math::exp2_split,
        f8: math::exp2_split,
        want: f64::exp2,
        m_all: (0.70, 1.42),
        k_max: 1_048_576.0,
        m_near: (f32::INFINITY, (0.70, 1.42)),
        measured: (-1022.0, 1023.0),
        in_range: (-149.0, 128.0),
        bound: EXP2_SPLIT_MAX_ULP,
    });
}

// ---------------------------------------------------------------------------------------
// frexp

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn frexp_exhaustive() {
    let fails = sweep(&all_f32(), |fails: &mut Failures, xs, live| {
        let (m8, e8) = math::frexp(f32x8::new(xs));
        let (m8, e8) = (m8.to_array(), e8.to_array());
        let (mf, ef) = f32x8::new(xs).frexp_finite();
        let (mf, ef) = (mf.to_array(), ef.to_array());
        for l in 0..live {
            let x = xs[l];
            let (m, e) = math::frexp(x);
            // `frexp_finite` (AVX-512: no fix-up of NaN's mantissa): the same but for
            // NaN's mantissa, ±inf included (a finite exponent, 128).
            fails.check(
                (x.is_nan() || m.to_bits() == mf[l].to_bits()) && e.to_bits() == ef[l].to_bits(),
                || {
                    format!(
                        "frexp_finite({x:e}): ({:e}, {:e}), frexp ({m:e}, {e:e})",
                        mf[l], ef[l]
                    )
                },
            );
            fails.check(
                m.to_bits() == m8[l].to_bits() && e.to_bits() == e8[l].to_bits(),
                || {
                    format!(
                        "frexp({x:e}): x8 ({:e}, {:e}), scalar ({m:e}, {e:e})",
                        m8[l], e8[l]
                    )
                },
            );
            let ok = if x.is_nan() {
                m.is_finite() && e == 128.0
            } else if x.is_infinite() {
                m == 1f32.copysign(x) && e == 128.0
            } else if x == 0.0 {
                m == 0.0 && e == -151.0
            } else {
                // Exact: x = m · 2^e with |m| in [1, 2), same sign, e an integer.
                (1.0..2.0).contains(&m.abs())
                    && m.is_sign_negative() == x.is_sign_negative()
                    && e == e.round()
                    && (-149.0..=127.0).contains(&e)
                    && m as f64 * 2f64.powi(e as i32) == x as f64
            };
            fails.check(ok, || {
                format!("frexp({x:e} = {:#010x}) = ({m:e}, {e:e})", x.to_bits())
            });
        }
    });
    println!(
        "\nmath::frexp              all f32                      exact: {} failures of 2^32",
        fails.count
    );
    fails.assert_none("frexp");
}

// ---------------------------------------------------------------------------------------
// ldexp

fn mix(mut z: u64) -> u64 {
    // splitmix64 finalizer
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Exponents that probe `m`: kind 0 puts the result in [2^-153, 2^-126) (subnormals,
/// their rounding, the flush to zero); kind 1 at [2^126, 2^130) (overflow); kind 2 uniform
/// in [-320, 320]; kind 3 extreme integers (far beyond where the product saturates).
fn ldexp_exponent(m: f32, kind: u64) -> f32 {
    let h = mix(((m.to_bits() as u64) << 2) | kind);
    let em = if m == 0.0 {
        0
    } else {
        ((m.to_bits() >> 23) & 0xff) as i64 - 127
    };
    let e = match kind {
        0 => -127 - em - (h % 27) as i64,
        1 => 126 - em + (h % 4) as i64,
        2 => (h % 641) as i64 - 320,
        _ => {
            const EXTREME: [f32; 8] = [
                0.0,
                200.0,
                250.0,
                1000.0,
                16_777_216.0,
                2_147_483_648.0,
                1e30,
                3e38,
            ];
            let v = EXTREME[(h % 8) as usize];
            return if h & 8 != 0 { -v } else { v };
        }
    };
    e as f32
}

/// The correctly rounded `m · 2^e` (f64 holds the exact product for |e| <= 1000).
fn ldexp_want(m: f32, e: f32) -> (f32, f64) {
    let exact = if e.abs() <= 1000.0 {
        m as f64 * f64::from_bits(((e as i64 + 1023) as u64) << 52)
    } else if e > 0.0 && m != 0.0 {
        f64::INFINITY.copysign(m as f64)
    } else {
        0f64.copysign(m as f64)
    };
    (exact as f32, exact)
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn ldexp_sweep() {
    // Precondition: |m| in [2^-62, 2^39] or m = 0 (both signs), every such f32.
    let lo = 2f32.powi(-62).to_bits();
    let hi = 2f32.powi(39).to_bits();
    let ranges = vec![
        (0, 0),
        (lo, hi),
        (0x8000_0000, 0x8000_0000),
        (lo | 0x8000_0000, hi | 0x8000_0000),
    ];
    let st = sweep::<OneDomain, _>(&ranges, |st, ms, live| {
        // One exponent per m: kind 0 (subnormal results, the only ones that round)
        // for half of the packets, kinds 1, 2, 3 in turn for the others.
        let j = (ms[0].to_bits() as u64 / 8) % 6;
        {
            let kind = j.saturating_sub(2);
            let es = ms.map(|m| ldexp_exponent(m, kind));
            let y8 = math::ldexp(f32x8::new(ms), f32x8::new(es)).to_array();
            let z8 = math::ldexp_no_subnormal(f32x8::new(ms), f32x8::new(es)).to_array();
            for l in 0..live {
                let (m, e) = (ms[l], es[l]);
                let y = math::ldexp(m, e);
                st.fails.check(y.to_bits() == y8[l].to_bits(), || {
                    format!("ldexp({m:e}, {e}): x8 {:e}, scalar {y:e}", y8[l])
                });
                // `ldexp_no_subnormal`: the same bits, in both widths.
                let z = math::ldexp_no_subnormal(m, e);
                st.fails.check(
                    z.to_bits() == y.to_bits() && z8[l].to_bits() == y.to_bits(),
                    || {
                        format!(
                            "ldexp_no_subnormal({m:e}, {e}): {z:e}, x8 {:e}, ldexp {y:e}",
                            z8[l]
                        )
                    },
                );
                let (c, exact) = ldexp_want(m, e);
                st.errors.record(m, y, exact, ulp_err(y, exact));
                // One rounding: the correctly rounded result, sign of zero and
                // saturation to ±inf / ±0 included.
                st.fails.check(y.to_bits() == c.to_bits(), || {
                    format!("ldexp({m:e}, {e}) = {y:e}, want {c:e}")
                });
            }
        }
    });
    println!();
    st.errors
        .print("math::ldexp", "|m| in [2^-62, 2^39], one e each");
    st.fails.assert_none("ldexp");
    assert_max("ldexp", &st.errors, 0.5);
}

// ---------------------------------------------------------------------------------------
// The Fast tier's exponentials (`math::fast`): relative error against f64

/// Documented in `src/math/fast.rs`.
const EXP_NEG_FAST_MAX_REL: f64 = 1.5e-5;
const EXP_SPLIT_FAST_MAX_REL: f64 = 1.5e-5;
const EXPREL_NEG_FAST_MAX_REL: f64 = 3.5e-5;
const EXP2_SPLIT_FAST_MAX_REL: f64 = 1.5e-5;
const EXPREL2_NEG_FAST_MAX_REL: f64 = 3.5e-5;

/// The Fast tier's functions, in the order of [`fast_sweep`]'s results.
const FAST_NAMES: [&str; 5] = [
    "exp_neg_fast",
    "exp_split_fast",
    "exprel_neg_fast",
    "exp2_split_fast",
    "exprel2_neg_fast",
];

#[derive(Default)]
struct RelState {
    worst: f64,
    at: f32,
    fails: Failures,
}

impl Merge for RelState {
    fn merge(self, o: RelState) -> RelState {
        let (worst, at) = if o.worst > self.worst {
            (o.worst, o.at)
        } else {
            (self.worst, self.at)
        };
        RelState {
            worst,
            at,
            fails: self.fails.merge(o.fails),
        }
    }
}

impl RelState {
    fn record(&mut self, x: f32, got: f64, want: f64) {
        let e = if got == want {
            0.0
        } else {
            (got - want).abs() / want.abs()
        };
        // NaN errors win too (`partial_cmp` is None for them).
        if e.partial_cmp(&self.worst) != Some(std::cmp::Ordering::Less)
            && e.partial_cmp(&self.worst) != Some(std::cmp::Ordering::Equal)
        {
            self.worst = e;
            self.at = x;
        }
    }
}

/// Sweeps the Fast tier's five functions (every `step`-th 8-group of bit patterns; 1 =
/// all), checks x8 = scalar bit for bit, NaN for NaN, and returns the max relative
/// errors of [`FAST_NAMES`] on their domains.
fn fast_sweep(step: u64) -> [RelState; 5] {
    let top = 2f32.powi(11);
    let go = |ranges: BitRanges, k: usize| -> RelState {
        sweep(&ranges, |st: &mut RelState, xs, live| {
            if step > 1 && !(xs[0].to_bits() as u64 / 8).is_multiple_of(step) {
                return;
            }
            let name = FAST_NAMES[k];
            let y: [f64; 8] = match k {
                0 => x8_and_scalar(
                    xs,
                    live,
                    &mut st.fails,
                    name,
                    math::exp_neg_fast,
                    math::exp_neg_fast,
                )
                .map(|v| v as f64),
                1 | 3 => {
                    let f8: fn(f32x8) -> (f32x8, f32x8) = if k == 1 {
                        math::exp_split_fast
                    } else {
                        math::exp2_split_fast
                    };
                    let f: fn(f32) -> (f32, f32) = if k == 1 {
                        math::exp_split_fast
                    } else {
                        math::exp2_split_fast
                    };
                    let (m, e) = f8(f32x8::new(xs));
                    let (m, e) = (m.to_array(), e.to_array());
                    let mut out = [0.0; 8];
                    for l in 0..live {
                        let (ms, es) = f(xs[l]);
                        st.fails.check(
                            ms.to_bits() == m[l].to_bits() && es.to_bits() == e[l].to_bits(),
                            || format!("{name}({:e}): x8 and scalar differ", xs[l]),
                        );
                        // Compared in log space: m·2^e with e up to ±2^20.
                        out[l] = (m[l] as f64).ln() + e[l] as f64 * std::f64::consts::LN_2;
                    }
                    out
                }
                2 => x8_and_scalar(
                    xs,
                    live,
                    &mut st.fails,
                    name,
                    math::exprel_neg_fast,
                    math::exprel_neg_fast,
                )
                .map(|v| v as f64),
                _ => x8_and_scalar(
                    xs,
                    live,
                    &mut st.fails,
                    name,
                    math::exprel2_neg_fast,
                    math::exprel2_neg_fast,
                )
                .map(|v| v as f64),
            };
            for l in 0..live {
                let x = xs[l];
                if x.is_nan() {
                    st.fails
                        .check(y[l].is_nan(), || format!("{name}(NaN) = {:e}", y[l]));
                    continue;
                }
                let xd = x as f64;
                match k {
                    0 => {
                        let r = (-xd).exp();
                        if r >= f32::MIN_POSITIVE as f64 {
                            st.record(x, y[l], r);
                        } else {
                            st.fails.check(y[l] < 1.2e-38, || {
                                format!("{name}({x:e}) = {:e}: not flushed", y[l])
                            });
                        }
                    }
                    // ln(m·2^e) − x: the relative error of m·2^e is e^(that) − 1.
                    1 if (-708.0..=709.0).contains(&xd) => {
                        st.record(x, (y[l] - xd).exp_m1().abs() + 1.0, 1.0)
                    }
                    1 => {}
                    // ln(m·2^e) − x·ln 2, likewise.
                    3 if (-1022.0..=1023.0).contains(&xd) => st.record(
                        x,
                        (y[l] - xd * std::f64::consts::LN_2).exp_m1().abs() + 1.0,
                        1.0,
                    ),
                    3 => {}
                    2 if x <= top => st.record(x, y[l], -(-xd).exp_m1() / xd),
                    4 if x <= top => {
                        st.record(x, y[l], -(-xd * std::f64::consts::LN_2).exp_m1() / xd)
                    }
                    // Above 2^11: 1/x, correctly rounded.
                    4 => st.fails.check(y[l] == f64::from(1.0 / x), || {
                        format!("{name}({x:e}) = {:e}, not 1/x", y[l])
                    }),
                    _ => {}
                }
            }
        })
    };
    [
        go(vec![(0, 0x7fff_ffff)], 0),
        go(all_f32(), 1),
        go(vec![(2f32.powi(-60).to_bits(), 0x7fff_ffff)], 2),
        go(all_f32(), 3),
        go(vec![(2f32.powi(-60).to_bits(), 0x7fff_ffff)], 4),
    ]
}

fn check_fast(st: [RelState; 5]) {
    let bounds = [
        EXP_NEG_FAST_MAX_REL,
        EXP_SPLIT_FAST_MAX_REL,
        EXPREL_NEG_FAST_MAX_REL,
        EXP2_SPLIT_FAST_MAX_REL,
        EXPREL2_NEG_FAST_MAX_REL,
    ];
    for (k, (s, b)) in st.into_iter().zip(bounds).enumerate() {
        let name = FAST_NAMES[k];
        println!(
            "math::{name:<16} max relative error {:.3e} at x = {:e}",
            s.worst, s.at
        );
        s.fails.assert_none(name);
        assert!(s.worst <= b, "{name}: {:e} > documented {b:e}", s.worst);
    }
}

#[test]
#[ignore = "exhaustive sweep: run in release with --ignored"]
fn fast_tier_exhaustive() {
    check_fast(fast_sweep(1));
}

/// Every 4099th group of 8 bit patterns: a quick version of the sweep above.
#[test]
fn fast_tier_sampled() {
    check_fast(fast_sweep(4099));
}
