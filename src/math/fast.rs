//! The Fast tier's exponentials: the same reductions and reconstructions as `exp_split`
//! and `exprel_neg` (and as `exp_neg` before its table form), with the degree-4/5 polynomial `Q` replaced by one of
//! degree 2 (shared by all three) and, where the reduced argument allows it, a one-term
//! Cody–Waite reduction.
//!
//! `Q2(r) ≈ (e^r − 1 − r)/r²` on [−ln2/2, ln2/2] (`tools/fit_poly.py`, Chebyshev fit):
//! approximation error alone (f64) 1.40e-5 relative in `e^r = 1 + r + r²·Q2(r)` and
//! 3.37e-5 relative in `e^r − 1 = r + r²·Q2(r)`.
//!
//! Measured (`tests/exhaustive.rs`, `fast_tier_exhaustive`, every f32 of the domain
//! against f64, relative error; x8 and scalar bit-identical):
//! - `exp_neg_fast(x)`, x ≥ 0: 1.422e-5 (at x = 82.83) for results ≥ 2^-126 (x ≤ 87.33),
//!   then flushed to 0 (1.424e-5 with the `(w²)·Q − w + 1` form that `exp_neg` had
//!   before an earlier change);
//! - `exp_split_fast(x)` = m·2^k: 1.403e-5 on [−708, 709] (m·2^k against e^x in f64);
//! - `exprel_neg_fast(x)` = (1 − e^(−x))/x: 3.376e-5 (at x = 0.3466) on [2^-60, 2^11];
//! - `exp2_split_fast(y)` = m·2^k: 1.402e-5 (at y = 0.5000183) on [−1022, 1023] (m·2^k
//!   against 2^y);
//! - `exprel2_neg_fast(x)` = (1 − 2^(−x))/x: 3.381e-5 (at x = 0.4999889) on [2^-60, 2^11],
//!   1/x correctly rounded above.
//!
//! The base-2 pair (for the one-layer kernels' depth stage, whose arguments arrive
//! multiplied by log2(e)) reduce as their Accurate forms do, `k = round(·)` with an exact
//! remainder f in [−1/2, 1/2], and evaluate `Q2` at r = f·ln 2 (one rounding, 2^-24
//! relative, against Q2's 1.4e-5).
//!
//! These bounds are what the Fast tier's 1e-4 bounds on T and L_in are built from (see
//! `Tier`); the NaN, infinity and saturation behaviour is that of the Accurate functions.

use super::exp::{reduce_ln2, LOG2E};
use super::lane::POW2_MAGIC;
use super::Lane;

/// ln 2 rounded to f32: the one-term reduction `w = x + k·ln2` is off by at most
/// |k| · 1.9e-9, i.e. 2.4e-7 relative for |k| ≤ 127.
const LN2: f32 = core::f32::consts::LN_2;

/// `Q2(r)` with the odd coefficient's sign chosen at compile time (`sign = -1` evaluates
/// `Q2(−w)`).
#[inline(always)]
fn q2_signed<L: Lane>(w: L, sign: f32) -> L {
    let c2 = L::splat(0.041_791_987);
    let c1 = L::splat(sign * 0.167_418_99);
    let c0 = L::splat(0.5);
    c2.mul_add(w, c1).mul_add(w, c0)
}

/// `e^(-x)` for `x ≥ 0` (including `+inf`, which gives 0), relative error ≤ 1.5e-5 for
/// results ≥ 2^-126; NaN for NaN.
#[inline(always)]
pub fn exp_neg_fast<L: Lane>(x: L) -> L {
    let x = L::splat(88.0).min(x);
    let (k, s) = (x * L::splat(-LOG2E)).round_pow2i();
    let w = k.mul_add(L::splat(LN2), x);
    // 1 + w·(w·Q(−w) − 1), as `exp_neg` had it before its table form: no subnormal w²
    // for tiny w.
    let p = w.mul_add(w.mul_sub(q2_signed(w, -1.0), L::splat(1.0)), L::splat(1.0));
    p * s
}

/// `e^x` as `(m, k)` with `e^x ≈ m · 2^k`, m in [0.7, 1.42], relative error ≤ 1.5e-5
/// for x in [−2^20, 2^20] (clamped beyond).
#[inline(always)]
pub fn exp_split_fast<L: Lane>(x: L) -> (L, L) {
    let x = x.clamp(L::splat(-1_048_576.0), L::splat(1_048_576.0));
    let (k, r) = reduce_ln2(x);
    ((r * r).mul_add(q2_signed(r, 1.0), r) + L::splat(1.0), k)
}

/// φ(x) = (1 − e^(−x))/x for x in [2^-60, +inf], relative error ≤ 3.5e-5 on [2^-60, 2^11];
/// as `exprel_neg` outside.
#[inline(always)]
pub fn exprel_neg_fast<L: Lane>(x: L) -> L {
    let xc = L::splat(30.0).min(x);
    let (k, s) = (xc * L::splat(-LOG2E)).round_pow2i();
    let w = k.mul_add(L::splat(LN2), xc);
    // e^(−w) − 1 = −w + w²·Q2(−w); e^(−x) = s·(1 + p) with s = 2^k.
    let p = (w * w).mul_sub(q2_signed(w, -1.0), w);
    s.neg_mul_add(p, L::splat(1.0) - s) / x
}

/// `2^y` as `(m, k)` with `2^y ≈ m · 2^k`, m in [0.7, 1.42], relative error ≤ 1.5e-5 for
/// y in [−2^20, 2^20] (clamped beyond): [`exp_split_fast`] in base 2.
#[inline(always)]
pub fn exp2_split_fast<L: Lane>(y: L) -> (L, L) {
    let y = y.clamp(L::splat(-1_048_576.0), L::splat(1_048_576.0));
    let k = y.round();
    let r = (y - k) * L::splat(LN2);
    ((r * r).mul_add(q2_signed(r, 1.0), r) + L::splat(1.0), k)
}

/// (1 − 2^(−x))/x for x in [2^-60, +inf], relative error ≤ 3.5e-5 on [2^-60, 2^11]:
/// [`exprel_neg_fast`] in base 2; 1/x correctly rounded from x = 25 on (where
/// 1 − 2^(−x) rounds to 1).
#[inline(always)]
pub fn exprel2_neg_fast<L: Lane>(x: L) -> L {
    // `minps` with x second: NaN stays NaN.
    let xc = L::splat(64.0).min(x);
    // k = round(−xc) in [−64, 0] and s = 2^k, from one difference (as `exprel2_neg`).
    let t = L::splat(POW2_MAGIC) - xc;
    let k = t - L::splat(POW2_MAGIC);
    let s = L::shl23(t);
    // 2^(−x) = s·2^(−w), w = xc + k in [−1/2, 1/2] exact; 2^(−w) − 1 = −r + r²·Q2(−r).
    let r = (xc + k) * L::splat(LN2);
    let p = (r * r).mul_sub(q2_signed(r, -1.0), r);
    s.neg_mul_add(p, L::splat(1.0) - s) / x
}
