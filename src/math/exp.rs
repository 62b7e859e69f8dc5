//! `exp(x)` for f32 lanes, and the split `e^x = m * 2^k` used where a result must
//! outlive the f32 exponent range.
//!
//! Reduction: `k = round(x * log2(e))`, `r = x - k*ln2` with a Cody–Waite split of ln2
//! (16 leading bits in `LN2_HI`, so `k * LN2_HI` is exact for |k| < 256), `r` in
//! [-ln2/2, ln2/2]. Polynomial: `e^r = 1 + r + r^2 * Q(r)`, `Q` of degree 4, a Chebyshev
//! fit from `tools/fit_poly.py` (max relative error of `Q` with f32 coefficients 1.4e-7,
//! which is 0.13 ULP of `e^r`), evaluated as `1 + r·(1 + r·Q(r))`: two FMAs after `Q`
//! and no `r²`, which was subnormal for |r| < 2^-63 (a microcode assist on Zen 1: with
//! cameras 1e-19 above the fog's base a batch took 1.67× the time of typical rays, 1.40×
//! with this form alone; `examples/speedscan.rs camera_1e-19_free`), and more accurate
//! than `(r²·Q + r) + 1` (1.077 ULP, 0.78 % over 0.5 ULP). Scaling by `2^k` in two halves so that subnormal results are
//! rounded once. No branch: out-of-range inputs are clamped, so the time does not depend
//! on the data.
//!
//! Measured (`tests/exhaustive.rs`, every f32 in [-104, 89], and exact saturation to +inf
//! / 0 outside it): max error 0.951 ULP (at x = 16.289688), 0.48% of inputs over 0.5 ULP.

use super::Lane;

pub(crate) const LOG2E: f32 = core::f32::consts::LOG2_E;
pub(crate) const LN2_HI: f32 = 0.693_145_751_953_125;
pub(crate) const LN2_LO: f32 = 1.428_606_765_330_187e-6;

/// `Q(r) = (e^r - 1 - r) / r^2` on [-ln2/2, ln2/2], degree 4.
#[inline(always)]
fn q4<L: Lane>(r: L) -> L {
    q4_signed(r, 1.0)
}

/// `Q(sign * w)`: with `sign = -1` the odd coefficients are negated at compile time, so a
/// caller holding `w = -r` needs no negation.
#[inline(always)]
pub(crate) fn q4_signed<L: Lane>(w: L, sign: f32) -> L {
    let c4 = L::splat(0.001_392_617_6);
    let c3 = L::splat(sign * 0.008_363_173);
    let c2 = L::splat(0.041_666_556);
    let c1 = L::splat(sign * 0.166_665_78);
    let c0 = L::splat(0.5);
    c4.mul_add(w, c3)
        .mul_add(w, c2)
        .mul_add(w, c1)
        .mul_add(w, c0)
}

/// Cody–Waite reduction of an argument in [0, 88] (or NaN) for `e^(-x)`: returns
/// `(w, 2^k)` with `-x = k*ln2 - w`, i.e. `w = x + k*ln2 = -r`; k ≥ −127, where 2^k
/// is 0 ([`Lane::round_pow2i`]).
#[inline(always)]
pub(crate) fn reduce_ln2_neg<L: Lane>(x: L) -> (L, L) {
    let (k, s) = (x * L::splat(-LOG2E)).round_pow2i();
    let w = k.mul_add(L::splat(LN2_HI), x);
    let w = k.mul_add(L::splat(LN2_LO), w);
    (w, s)
}

/// Cody–Waite reduction: returns `(k, r)` with `x = k*ln2 + r`.
#[inline(always)]
pub(crate) fn reduce_ln2<L: Lane>(x: L) -> (L, L) {
    let k = (x * L::splat(LOG2E)).round();
    let r = k.mul_add(L::splat(-LN2_HI), x);
    let r = k.mul_add(L::splat(-LN2_LO), r);
    (k, r)
}

/// `e^r` for `r` in [-ln2/2, ln2/2].
#[inline(always)]
pub(crate) fn exp_reduced<L: Lane>(r: L) -> L {
    r.mul_add(r.mul_add(q4(r), L::splat(1.0)), L::splat(1.0))
}

/// `e^x`, max error 0.951 ULP over all of f32 (subnormal results included); `+inf` above
/// 88.72, `0` below -103.98, NaN for NaN.
#[inline(always)]
pub fn exp<L: Lane>(x: L) -> L {
    let x = x.clamp(L::splat(-104.0), L::splat(89.0));
    let (k, r) = reduce_ln2(x);
    let p = exp_reduced(r);
    // k in [-150, 129]: two factors in [-75, 65], each a normal power of two.
    let k1 = (k * L::splat(0.5)).round();
    let k2 = k - k1;
    p * L::pow2i(k1) * L::pow2i(k2)
}

/// `e^x = m * 2^k` with `m` in [0.70, 1.42] for |x| <= 709 and `k` an integer-valued float,
/// for any `x` (clamped to ±2^20, far beyond where the product with any f32 factors
/// saturates; beyond |x| = 709 the rounding of `x * log2(e)` widens `m` to [0.66, 1.50]).
/// Measured (`tests/exhaustive.rs`, every f32): `m * 2^k` within 0.951 ULP of `e^x` for x
/// in [-104, 89] and within 0.951 ULP (of a 24-bit result with unbounded exponent) for x in
/// [-708, 709]; NaN gives a NaN `m`.
#[inline(always)]
pub fn exp_split<L: Lane>(x: L) -> (L, L) {
    let x = x.clamp(L::splat(-1_048_576.0), L::splat(1_048_576.0));
    let (k, r) = reduce_ln2(x);
    (exp_reduced(r), k)
}
