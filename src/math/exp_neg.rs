//! `exp_neg(x) = e^(-x)` for `x ≥ 0`: the transmittance from an optical depth.
//!
//! The same reduction and polynomial as `exp` (degree-4 `Q`), specialised to the range
//! the kernels need: the argument is never positive, so no overflow clamp and no
//! negation (the reduction works on `w = x + k*ln2 = -r`, the polynomial's odd
//! coefficients are negated at compile time), and the result is scaled by one power of
//! two, flushing results below 2^-126 (τ > 87.34) to zero, an absolute error below
//! 1.2e-38. No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≥ 0, +inf included): max error 1.061 ULP (at
//! x = 16.288475) for results ≥ 2^-126 (x ≤ 87.33), 0.81% of them over 0.5 ULP; beyond,
//! an absolute error of at most 0.71 · 2^-126.

use super::exp::{q4_signed, reduce_ln2_neg};
use super::Lane;

/// `e^(-x)` for `x ≥ 0` (including `+inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp_neg<L: Lane>(x: L) -> L {
    // x clamped to 88: k = round(-x * log2 e) >= -127, and pow2i(-127) = 0 flushes.
    let x = L::splat(88.0).min(x);
    let (k, w) = reduce_ln2_neg(x);
    // e^r = 1 + r + r^2 Q(r) with r = -w
    let p = (w * w).mul_sub(q4_signed(w, -1.0), w) + L::splat(1.0);
    p * L::pow2i(k)
}
