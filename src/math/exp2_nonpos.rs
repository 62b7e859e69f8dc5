//! `exp2_nonpos(y) = 2^y` for `y ≤ 0`: a transmittance from an optical depth that
//! arrives already scaled by −log2(e) (the framebuffer pass folds −log2(e) into its
//! per-frame extinction constants, so `e^(−τ) = 2^(−τ·log2 e)` costs no extra multiply).
//!
//! Cheaper than [`exp_neg`](fn@super::exp_neg): no multiply by log2(e) and no Cody–Waite
//! reduction (two FMAs): `k = round(y)`
//! and `f = y − k` are exact, so the reduction adds no error. k and 2^k come from one add
//! of a magic constant ([`Lane::round_pow2i`]: add, subtract, shift instead of `vroundps`,
//! two µops on Intel, and an add and a shift; the pass 3.6–5.1 % faster on the Intel Xeon
//! of the thirty-fifth session in five of six alternating rounds; a half-integer y now
//! takes the odd k, f = ±1/2 either way, the maxima below unchanged). Polynomial:
//! `2^f = 1 + f·P(f)` on [−1/2, 1/2], `P` of degree 5, a Chebyshev fit from
//! `tools/fit_poly.py` (max relative error of the polynomial with f32 coefficients
//! 9.2e-9, 0.15 ULP), evaluated in Estrin's scheme: 3 operations deep instead of 5, which
//! took the pass's `fog_single` from 5.87 to 5.33 ms (its stage of T is bound by the
//! latency of three such chains per packet; Horner measured 0.88 ULP, Estrin 1.09). The
//! result is scaled by one power of two, flushing results below
//! 2^-126 (y < −126.5) to zero, an absolute error below 1.2e-38. y above −2^-60 is taken
//! as −2^-60 (the result is 1 either way), so that f² is never subnormal. No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≤ 0, −inf included): max error 1.090 ULP (at
//! y = −0.49906224) for results ≥ 2^-126 (y ≥ −126), 0.57% of them over 0.5 ULP; below, an
//! absolute error of at most 0.71 · 2^-126.

use super::Lane;

/// `2^y` for `y ≤ 0` (including `−inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp2_nonpos<L: Lane>(y: L) -> L {
    // y clamped to −127: k ≥ −127, and pow2i(−127) = 0 flushes (`maxps`: NaN stays NaN);
    // and to −2^-60 from above, where the result is 1 either way (f·P(f) is below half an
    // ULP of 1): f² below 2^-126 (subnormal, |y| < 2^-63: τ below about 1e-19, an eye
    // far above thin fog) costs the multiply a microcode assist on Zen 1, 14 % of an
    // eye-at-500 frame's time (`perf annotate`; `minps`: NaN, the second operand, stays).
    let y = L::splat(-127.0).max(L::splat(-8.673_617e-19).min(y)); // −2^-60
    let (k, s) = y.round_pow2i();
    let f = y - k;
    // P(f) = (c0 + c1 f) + f²·((c2 + c3 f) + f²·(c4 + c5 f)) (Estrin: 3 steps deep).
    let f2 = f * f;
    let a = f.mul_add(L::splat(0.240_226_51), L::splat(core::f32::consts::LN_2));
    let b = f.mul_add(L::splat(0.009_618_083), L::splat(0.055_503_57));
    let c = f.mul_add(L::splat(0.000_154_531_63), L::splat(0.001_339_086_3));
    let p = f2.mul_add(f2.mul_add(c, b), a);
    f.mul_add(p, L::splat(1.0)) * s
}
