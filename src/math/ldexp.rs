//! `ldexp`: `m * 2^e` with saturation, for the end of a mantissa/exponent computation.

use super::Lane;

/// Bound on the first factor's exponent: `m * 2^E1` must stay normal and finite.
const E1: f32 = 64.0;

/// The two powers of two whose product is `2^e`, clamped so that for `|m|` in
/// [2^-62, 2^39] the product `m * s1 * s2` is `m * 2^e` rounded once (normal result),
/// `±inf` exactly where that overflows, and `±0` where it is below half the smallest
/// subnormal. Shared by several mantissas with the same exponent (the RGB channels of
/// one optical depth).
#[inline(always)]
pub fn pow2_pair<L: Lane>(e: L) -> (L, L) {
    let e1 = e.clamp(L::splat(-E1), L::splat(E1));
    let e2 = (e - e1).clamp(L::splat(-126.0), L::splat(127.0));
    (L::pow2i(e1), L::pow2i(e2))
}

/// `m * 2^e` for `|m|` in [2^-62, 2^39] or `m = 0`, and any integer-valued `e` (even far
/// outside the f32 range): overflows to `±inf` and underflows to `±0` exactly where the
/// true product does, with one rounding: `m * 2^e1` is exact and normal, so the result is
/// the correctly rounded product, subnormal results included (verified by
/// `tests/exhaustive.rs` for every such `m`, sign of zero and saturation included).
///
/// Why these bounds: `m * 2^±64` must be normal (|m| ≥ 2^-62, < 2^64); a clamped
/// `e2 = 127` must still overflow (|m| · 2^191 ≥ 2^128); a clamped `e2 = -126` must still
/// round to zero (|m| · 2^-190 < 2^-150).
#[inline(always)]
pub fn ldexp<L: Lane>(m: L, e: L) -> L {
    // `m * s1 * s2` from `pow2_pair`, or one `vscalefps` (same result) in AVX-512 builds.
    m.scale2(e)
}
