//! `exprel2_neg(x) = (1 − 2^−x) / x` for `x ≥ 0`: [`exprel_neg`](fn@super::exprel_neg) in
//! base 2, the factor φ of the stable optical depth for a depth stage whose |Δ| arrives
//! multiplied by log2(e) (φ(|Δ|) = log2(e) · exprel2_neg(|Δ|·log2 e)): the one-layer
//! kernels' depth stage (`medium::height_fog`, `LayerCore::base2`).
//!
//! Reduction: with x clamped to 64 (beyond, 1 − 2^−x is 1 in f32), k = round(−x) and
//! 2^k from one subtract from [`Lane::round_pow2i`]'s constant, and w = x + k = −f in
//! [−1/2, 1/2], exact: no multiply by log2(e) and no Cody–Waite split (two
//! multiplies and FMAs fewer than `exprel_neg`). Polynomial: 2^f − 1 = f·P(f), `P` of
//! degree 6 with [`exp2m1`](fn@super::exp2m1)'s coefficients, its odd ones negated so
//! that it takes w. Reconstruction: `1 − 2^−x = (1 − 2^k) + (2^k·w)·P(−w)`, one FMA with
//! 2^k·w exact; k = 0 (x < 1/2) gives w·P(−w) rounded once, so tiny x is not a
//! cancelled difference (the quotient tends to ln 2). Then one division. No branch.
//!
//! Measured (`tests/exhaustive.rs`): max error 1.611 ULP (at x = 0.47303662) over every
//! f32 in [2^-60, 2^11], 9.0 % of them over 0.5 ULP (`exprel_neg`: 1.723 ULP, 8.2 %);
//! correctly rounded (1/x) above 2^11.

use super::lane::POW2_MAGIC;
use super::Lane;

/// `(1 − 2^−x) / x` for `x` ≥ 2^-60 (callers clamp: below that the result is ln 2 in
/// f32); NaN for NaN.
#[inline(always)]
pub fn exprel2_neg<L: Lane>(x: L) -> L {
    // `minps` with x second: NaN stays NaN.
    let xc = L::splat(64.0).min(x);
    // k = round(−xc) in [−64, 0] and 2^k, from the low mantissa bits of one difference.
    let t = L::splat(POW2_MAGIC) - xc;
    let k = t - L::splat(POW2_MAGIC);
    let s = L::shl23(t);
    let w = xc + k;
    // P(−w), P(f) = ln 2 + c2·f + … + c7·f^6 (2^f − 1 = f·P(f)).
    let p = L::splat(1.529_732_4e-5)
        .mul_add(w, L::splat(-0.000_154_614_45))
        .mul_add(w, L::splat(0.001_333_350_2))
        .mul_add(w, L::splat(-0.009_618_057))
        .mul_add(w, L::splat(0.055_504_11))
        .mul_add(w, L::splat(-0.240_226_51))
        .mul_add(w, L::splat(core::f32::consts::LN_2));
    (s * w).mul_add(p, L::splat(1.0) - s) / x
}
