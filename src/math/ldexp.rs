//! `ldexp`: `m * 2^e` with saturation, for the end of a mantissa/exponent computation.

use super::Lane;

/// `m * 2^e` for `|m|` in [2^-30, 2^30] or `m = 0`, and any integer-valued `e` (even far
/// outside the f32 range): overflows to `±inf` and underflows to `±0` exactly where the
/// true product does, with one rounding for normal results and at most two (an error
/// below 2^-149) for subnormal ones.
#[inline(always)]
pub fn ldexp<L: Lane>(m: L, e: L) -> L {
    let e1 = e.clamp(L::splat(-90.0), L::splat(90.0));
    let e2 = (e - e1).clamp(L::splat(-126.0), L::splat(127.0));
    m * L::pow2i(e1) * L::pow2i(e2)
}
