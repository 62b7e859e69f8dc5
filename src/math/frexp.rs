//! `frexp`: split a float into a mantissa and a binary exponent carried as a float.
//!
//! The kernels carry products whose factors leave the f32 range while the product does
//! not (a density that underflows times a length that overflows); they multiply the
//! mantissas and add the exponents. Exact: no rounding happens here.

use super::Lane;

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
///
/// A subnormal is normalized through its bits read as an integer, |x|·2^149 (exact,
/// below 2^23), not by a multiply: on Intel a multiply with a subnormal operand costs a
/// microcode assist of 130–200 cycles (segments of subnormal length ran at 11× the time of
/// typical ones on the 8-lane path: `examples/speedscan.rs`, `short_1e-40`).
#[inline(always)]
pub(crate) fn frexp_bits<L: Lane>(x: L) -> (L, L) {
    let ax = x.abs();
    let tiny = ax.lt(L::splat(MIN_NORMAL));
    let zero = x.eq(L::splat(0.0));
    let xs = L::select(tiny, ax.bits_as_int(), x);
    let e = xs.exponent_field() - L::select(tiny, L::splat(127.0 + 149.0), L::splat(127.0));
    let e = L::select(zero, L::splat(ZERO_EXPONENT), e);
    let m = xs.with_unit_exponent_sign(x).zero_where(zero);
    (m, e)
}

/// The exponent `frexp` gives ±0.
const ZERO_EXPONENT: f32 = -151.0;
