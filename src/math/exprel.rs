//! `exprel_neg(x) = (1 - e^(-x)) / x` for `x ≥ 0` (1 at 0): the factor φ of the stable
//! optical depth, τ = σ · L · e^(-u_min) · φ(|Δ|).
//!
//! `1 - e^(-x)` is `-expm1(-x)`, reconstructed as in `expm1` for k ≤ 0 only:
//! `1 - e^(-x) = (1 - 2^k) - 2^k * expm1(r)`, one FMA; for k = 0 that is `-expm1(r)`
//! untouched, so tiny x gives φ = 1 - x/2 correctly rounded rather than a cancelled
//! difference. Then one division. The reduction works on `w = -r` with the polynomial's
//! odd coefficients negated at compile time (no negation). No branch on the value of x:
//! the d_up → 0 limit needs no Taylor switch.
//!
//! Measured (`tests/exhaustive.rs`): max error 1.723 ULP (at x = 0.35189965) over every f32
//! in [2^-60, 2^11], 12.8% of them over 0.5 ULP; correctly rounded (1/x) above 2^11.

use super::exp::reduce_ln2_neg;
use super::expm1::q5_signed;
use super::Lane;

/// `(1 - e^(-x)) / x` for `x` ≥ 2^-60 (callers clamp: below that the result is 1 in
/// f32); NaN for NaN.
#[inline(always)]
pub fn exprel_neg<L: Lane>(x: L) -> L {
    // Beyond 30, 1 - e^(-x) = 1 in f32.
    let xc = L::splat(30.0).min(x);
    let (w, s) = reduce_ln2_neg(xc);
    // expm1(r) = r + r^2 Q(r) with r = -w
    let p = (w * w).mul_sub(q5_signed(w, -1.0), w);
    s.neg_mul_add(p, L::splat(1.0) - s) / x
}
