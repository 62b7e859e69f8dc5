//! `exp2_split(y)`: `2^y = m · 2^k` with `m` in [0.70, 1.42] and `k` an integer-valued
//! float, for any `y`: [`exp_split`](fn@super::exp_split) in base 2, for a depth stage whose
//! exponents arrive already multiplied by log2(e) (the falloff pre-scaled, as the
//! framebuffer pass does for its own kernel): the density of the one-layer kernels'
//! depth stage (`medium::height_fog`, `LayerCore::base2`).
//!
//! Reduction: `k = round(y)`, `f = y − k` in [−1/2, 1/2], both exact: no multiply by
//! log2(e) and no Cody–Waite split (three multiplies and FMAs fewer than `exp_split`).
//! Polynomial: `2^f = 1 + f·P(f)`, `P` of degree 5 with
//! [`exp2_nonpos`](fn@super::exp2_nonpos)'s coefficients (`tools/fit_poly.py`), by
//! Horner's rule (the kernels run many independent lanes: the operation count matters
//! there, not the chain's length; docs/speed-history.md). The argument is clamped to
//! ±2^20, far beyond where `m · 2^k` times any f32 factors leaves the f32 range. No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32): `m · 2^k` within 0.876 ULP (of a 24-bit
//! result with unbounded exponent) of 2^y for y in [−149, 128] (max 0.8755 at y =
//! −0.4992455, 0.41% over 0.5 ULP; `exp_split`: 0.951) and within 0.797 ULP for y in
//! [−1022, 1023] beyond; m in [0.7071, 1.4142] for every y.

use super::Lane;

/// `(m, k)` with `2^y = m · 2^k`, m in [0.70, 1.42], k an integer-valued float, y clamped
/// to ±2^20; a NaN `m` (and `k`) for NaN.
#[inline(always)]
pub fn exp2_split<L: Lane>(y: L) -> (L, L) {
    let y = y.clamp(L::splat(-1_048_576.0), L::splat(1_048_576.0));
    let k = y.round();
    let f = y - k;
    let p = L::splat(0.000_154_531_63)
        .mul_add(f, L::splat(0.001_339_086_3))
        .mul_add(f, L::splat(0.009_618_083))
        .mul_add(f, L::splat(0.055_503_57))
        .mul_add(f, L::splat(0.240_226_51))
        .mul_add(f, L::splat(core::f32::consts::LN_2));
    (f.mul_add(p, L::splat(1.0)), k)
}
