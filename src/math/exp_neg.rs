//! `exp_neg(x) = e^(-x)` for `x ≥ 0`: the transmittance from an optical depth.
//!
//! The same reduction and polynomial as `exp` (degree-4 `Q`), specialised to the range
//! the kernels need: the argument is never positive, so no overflow clamp and no
//! negation (the reduction works on `w = x + k*ln2 = -r`, the polynomial's odd
//! coefficients are negated at compile time), and the result is scaled by one power of
//! two, flushing results below 2^-126 (τ > 87.34) to zero, an absolute error below
//! 1.2e-38. No branch.
//!
//! The polynomial is evaluated as `1 + w·(w·Q(−w) − 1)`: with `(w²)·Q − w` and then `+ 1`
//! (as before) the sweep measured 1.061 ULP (at x = 16.288475) and 0.81% over 0.5 ULP,
//! and w² went subnormal for τ below about 1e-19 (a camera far above the fog), which cost
//! a stiff batch 1.6× the time of a typical one on Zen 1 (`benches/height_fog.rs`, `stiff`).
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≥ 0, +inf included): max error 0.943 ULP (at
//! x = 5.198426) for results ≥ 2^-126 (x ≤ 87.33), 0.47% of them over 0.5 ULP; beyond,
//! an absolute error of at most 0.71 · 2^-126.

use super::exp::{q4_signed, reduce_ln2_neg};
use super::Lane;

/// `e^(-x)` for `x ≥ 0` (including `+inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp_neg<L: Lane>(x: L) -> L {
    // x clamped to 88: k = round(-x * log2 e) >= -127, and pow2i(-127) = 0 flushes.
    let x = L::splat(88.0).min(x);
    let (w, s) = reduce_ln2_neg(x);
    // e^r = 1 + r + r^2 Q(r) with r = -w, as 1 + w·(w·Q(−w) − 1): no w² (which is
    // subnormal for w < 2^-63, a microcode assist on some CPUs: a `stiff` batch, an eighth
    // of it such τ, took 1.6× a typical one on Zen 1), one operation fewer, and more accurate (see above).
    let p = w.mul_add(w.mul_sub(q4_signed(w, -1.0), L::splat(1.0)), L::splat(1.0));
    p * s
}
