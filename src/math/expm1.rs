//! `expm1(x) = e^x - 1` for f32 lanes, accurate near 0 where `exp(x) - 1` cancels.
//!
//! Reduction as in `exp`; `expm1(r) = r + r^2 * Q(r)` with `Q` of degree 5 (Chebyshev fit
//! from `tools/fit_poly.py`, max relative error of `Q` with f32 coefficients 9.1e-9). The
//! reconstruction `e^x - 1 = 2^k * expm1(r) + (2^k - 1)` is one FMA; for k > 0 it is done
//! at half scale (`2 * (2^(k-1) * p + (2^(k-1) - 1/2))`, exact doubling) so that k = 128
//! needs no special case, and for k = 0 it returns `expm1(r)` untouched (tiny and subnormal
//! inputs come back exactly). No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32, ±inf included): max error 1.439 ULP (at
//! x = 17.001972, where the half-scale reconstruction rounds twice), 0.28% of inputs over
//! 0.5 ULP.

use super::exp::reduce_ln2;
use super::Lane;

/// `Q(r) = (e^r - 1 - r) / r^2` on [-ln2/2, ln2/2], degree 5.
#[inline(always)]
fn q5<L: Lane>(r: L) -> L {
    q5_signed(r, 1.0)
}

/// `Q(sign * w)` (odd coefficients negated at compile time for `sign = -1`).
#[inline(always)]
pub(crate) fn q5_signed<L: Lane>(r: L, sign: f32) -> L {
    let c5 = L::splat(sign * 0.000_198_909_81);
    let c4 = L::splat(0.001_393_364_2);
    let c3 = L::splat(sign * 0.008_333_310_5);
    let c2 = L::splat(0.041_666_467);
    let c1 = L::splat(sign * 0.166_666_67);
    let c0 = L::splat(0.5);
    c5.mul_add(r, c4)
        .mul_add(r, c3)
        .mul_add(r, c2)
        .mul_add(r, c1)
        .mul_add(r, c0)
}

/// `e^x - 1`, max error 1.44 ULP over all of f32; `-1` below -17.33, `+inf` above 88.72,
/// NaN for NaN; `x` itself for tiny `x` (`-0` gives `+0`).
#[inline(always)]
pub fn expm1<L: Lane>(x: L) -> L {
    let x = x.clamp(L::splat(-30.0), L::splat(89.0));
    let (k, r) = reduce_ln2(x);
    let p = (r * r).mul_add(q5(r), r);
    let up = k.gt(L::splat(0.0));
    let s = L::pow2i(k - L::splat(1.0).keep(up));
    let h = L::select(up, L::splat(0.5), L::splat(1.0));
    s.mul_add(p, s - h) * L::select(up, L::splat(2.0), L::splat(1.0))
}
