//! `exp2_nonpos(y) = 2^y` for `y ≤ 0`: a transmittance from an optical depth that
//! arrives already scaled by −log2(e) (the framebuffer pass folds −log2(e) into its
//! per-frame extinction constants, so `e^(−τ) = 2^(−τ·log2 e)` costs no extra multiply).
//!
//! Cheaper than [`exp_neg`](super::exp_neg) on the multiply-add pipes, which bound the
//! pass: no multiply by log2(e) and no Cody–Waite reduction (two FMAs): `k = round(y)`
//! and `f = y − k` are exact, so the reduction adds no error. Polynomial:
//! `2^f = 1 + f·P(f)` on [−1/2, 1/2], `P` of degree 5, a Chebyshev fit from
//! `tools/fit_poly.py` (max relative error of the polynomial with f32 coefficients
//! 9.2e-9, 0.15 ULP). The result is scaled by one power of two, flushing results below
//! 2^-126 (y < −126.5) to zero, an absolute error below 1.2e-38. No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≤ 0, −inf included): max error 0.876 ULP (at
//! y = −0.4992455) for results ≥ 2^-126 (y ≥ −126), 0.44% of them over 0.5 ULP; below, an
//! absolute error of at most 0.71 · 2^-126.

use super::Lane;

/// `2^y` for `y ≤ 0` (including `−inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp2_nonpos<L: Lane>(y: L) -> L {
    // y clamped to −127: k ≥ −127, and pow2i(−127) = 0 flushes (`maxps`: NaN stays NaN).
    let y = L::splat(-127.0).max(y);
    let k = y.round();
    let f = y - k;
    let p = L::splat(0.000_154_531_63)
        .mul_add(f, L::splat(0.001_339_086_3))
        .mul_add(f, L::splat(0.009_618_083))
        .mul_add(f, L::splat(0.055_503_57))
        .mul_add(f, L::splat(0.240_226_51))
        .mul_add(f, L::splat(core::f32::consts::LN_2));
    f.mul_add(p, L::splat(1.0)) * L::pow2i(k)
}
