//! `exp2m1(y) = 2^y − 1` for f32 lanes, accurate near 0 where `2^y − 1` cancels: the
//! framebuffer pass's E(Δ) = expm1(−Δ)/(−Δ), with the falloff pre-scaled by log2(e) so
//! that the argument arrives in base 2.
//!
//! Reduction: `k = round(y)`, `f = y − k` in [−1/2, 1/2], both exact (no multiply by
//! log2(e), no Cody–Waite split: two FMAs fewer than [`expm1`](fn@super::expm1)); k and
//! 2^k from one add ([`Lane::round_pow2i`]). Polynomial:
//! `2^f − 1 = f·P(f)`, `P` of degree 6, a Chebyshev fit from `tools/fit_poly.py` (max
//! relative error with f32 coefficients 5.6e-9, 0.09 ULP). Reconstruction:
//! `2^y − 1 = 2^k·f·P(f) + (2^k − 1)`, one FMA with 2^k·f exact; k = 0 returns `f·P(f)`
//! rounded once (tiny inputs come back as `y·ln2`). The argument is clamped to
//! [−64, 127], so 2^k is always a normal f32 and nothing overflows: `−1` below −64 (what
//! 2^y − 1 rounds to there), and above 127 the value at 127, 2^127 (callers that need
//! `+inf` beyond must clamp themselves; the pass's ranges make E saturate T to 0 well
//! before). No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32): max error 1.685 ULP (at y = 0.5048098, where
//! k = 1 and 2·(2^f − 1) + 1 cancels a little), 7.5% of the inputs in [−64, 127] over
//! 0.5 ULP; −1 exactly below −64, 2^127 above 127.

use super::Lane;

/// `2^y − 1` for `y` in [−64, 127] (clamped outside); NaN for NaN.
#[inline(always)]
pub fn exp2m1<L: Lane>(y: L) -> L {
    // `maxps`/`minps` with y second: NaN stays NaN.
    let y = L::splat(127.0).min(L::splat(-64.0).max(y));
    let (k, s) = y.round_pow2i();
    let f = y - k;
    let p = L::splat(1.529_732_4e-5)
        .mul_add(f, L::splat(0.000_154_614_45))
        .mul_add(f, L::splat(0.001_333_350_2))
        .mul_add(f, L::splat(0.009_618_057))
        .mul_add(f, L::splat(0.055_504_11))
        .mul_add(f, L::splat(0.240_226_51))
        .mul_add(f, L::splat(core::f32::consts::LN_2));
    // 2^k·f is exact, so p is the only rounded factor before the final FMA.
    (s * f).mul_add(p, s - L::splat(1.0))
}
