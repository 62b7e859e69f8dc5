//! `frexp`: split a float into a mantissa and a binary exponent carried as a float.
//!
//! The kernels carry products whose factors leave the f32 range while the product does
//! not (a density that underflows times a length that overflows); they multiply the
//! mantissas and add the exponents. Exact: no rounding happens here.

use super::Lane;

const TWO24: f32 = 16_777_216.0;
const MIN_NORMAL: f32 = f32::MIN_POSITIVE;

/// `x = m * 2^e` with `|m|` in [1, 2) and `e` an integer-valued float, subnormals
/// included. `0` gives `(0, -151)`, `±inf` gives `(±1, 128)`; NaN gives a finite `m` with
/// `e = 128` (callers that must see NaN carry it separately).
#[inline(always)]
pub fn frexp<L: Lane>(x: L) -> (L, L) {
    x.frexp()
}

/// [`frexp`] from the exponent bits: `Lane::frexp`'s generic form (AVX-512 builds use
/// `vgetexpps`/`vgetmantps` for the vector types, with the same results).
#[inline(always)]
pub(crate) fn frexp_bits<L: Lane>(x: L) -> (L, L) {
    let tiny = x.abs().lt(L::splat(MIN_NORMAL));
    let xs = L::select(tiny, x * L::splat(TWO24), x);
    let e = xs.exponent_field() - L::select(tiny, L::splat(127.0 + 24.0), L::splat(127.0));
    let m = L::select(x.eq(L::splat(0.0)), L::splat(0.0), xs.with_unit_exponent());
    (m, e)
}
