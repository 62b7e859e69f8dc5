//! [`Zmm`]: 16 `f32` lanes in one AVX-512 register, for builds that do not enable AVX-512
//! themselves (the repository's x86-64-v3 build, or a dependent's) but run on a CPU that
//! has it. The one-layer kernels pick it at run time (`detected`), so such a build gets
//! the 16-lane speed of an x86-64-v4 build without requiring AVX-512 to run. Compiled
//! where `build.rs` sets `cfg(zmm_dispatch)`, and where it sets `cfg(zmm_native)` (a build
//! that enables these AVX-512 subsets itself, e.g. x86-64-v4): there it is the kernels'
//! 16-lane type (`kernel::Wide`, the pass's `PassWide`), with no dispatch.
//!
//! Each method is the same IEEE-754 operation as in `wide::f32x8` (the rounding, the
//! `minps`/`maxps` rule, the ordered comparisons, ties-to-even rounding), and `frexp`,
//! `frexp_finite` and `scale2` are the x86-64-v4 build's `vgetexpps`/`vgetmantps` and
//! `vscalefps` forms, so a ray gives the same bits through `Zmm` as through `f32x8` and
//! the scalar path (`tests/lanes16.rs` checks each method, the suites' bit-for-bit tests
//! the kernels). Two methods are not in `Lane` and have other bits: [`Zmm::rsqrt14`] and
//! [`Zmm::rcp14`], the estimates the framebuffer pass refines. Masks are AVX-512 mask
//! registers (`__mmask16`).
//!
//! # Safety
//! Every method calls AVX-512F intrinsics. A `Zmm` value must therefore exist only on a
//! CPU with AVX-512F, AVX-512VL, AVX-512DQ, AVX-512BW and AVX-512CD: the type is private
//! to the crate, and the only code that creates one is reached through the
//! `#[target_feature]` entry points of `kernel`, which are called only after
//! `is_x86_feature_detected!` has found those features (or, with `cfg(zmm_native)`,
//! anywhere: such a binary enables the features at compile time and needs them to run at
//! all, as every x86-64-v4 binary does). The methods are
//! `#[inline(always)]` so that they are compiled inside those entry points, with the
//! features enabled (a method compiled outside them would still be correct, only slow:
//! a call per intrinsic).
#![allow(unsafe_code)]
// Where the build enables AVX-512 itself (`cfg(zmm_native)`), the intrinsics are safe to
// call and the `unsafe` blocks are redundant there.
#![cfg_attr(zmm_native, allow(unused_unsafe))]

use super::lane::POW2_ROUND8_BIAS;
use super::Lane;
use core::arch::x86_64::*;
use core::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

/// Whether this CPU has the AVX-512 subsets [`Zmm`] uses (F, VL, DQ, BW, CD), cached by
/// std after the first call.
#[cfg(zmm_dispatch)]
#[inline]
pub(crate) fn detected() -> bool {
    std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx512vl")
        && std::is_x86_feature_detected!("avx512dq")
        && std::is_x86_feature_detected!("avx512bw")
        && std::is_x86_feature_detected!("avx512cd")
}

/// 16 `f32` lanes in a `zmm` register (see the module documentation for when one may
/// exist).
#[derive(Clone, Copy)]
#[repr(transparent)]
pub(crate) struct Zmm(__m512);

/// A per-lane boolean of [`Zmm`]: an AVX-512 mask register.
#[derive(Clone, Copy)]
pub(crate) struct ZmmMask(__mmask16);

// SAFETY (every `unsafe` block below): the intrinsics need AVX-512F (and for `_mm512_and_ps`
// style operations, DQ); a `Zmm` exists only where they are present (module docs).

impl BitAnd for ZmmMask {
    type Output = ZmmMask;
    #[inline(always)]
    fn bitand(self, b: ZmmMask) -> ZmmMask {
        ZmmMask(self.0 & b.0)
    }
}
impl BitOr for ZmmMask {
    type Output = ZmmMask;
    #[inline(always)]
    fn bitor(self, b: ZmmMask) -> ZmmMask {
        ZmmMask(self.0 | b.0)
    }
}
impl Not for ZmmMask {
    type Output = ZmmMask;
    #[inline(always)]
    fn not(self) -> ZmmMask {
        ZmmMask(!self.0)
    }
}

macro_rules! binop {
    ($tr:ident, $f:ident, $intr:ident) => {
        impl $tr for Zmm {
            type Output = Zmm;
            #[inline(always)]
            fn $f(self, b: Zmm) -> Zmm {
                Zmm(unsafe { $intr(self.0, b.0) })
            }
        }
    };
}
binop!(Add, add, _mm512_add_ps);
binop!(Sub, sub, _mm512_sub_ps);
binop!(Mul, mul, _mm512_mul_ps);
binop!(Div, div, _mm512_div_ps);

// SAFETY: plain data (sixteen f32), like `wide::f32x16`.
unsafe impl Send for Zmm {}
unsafe impl Sync for Zmm {}

impl Zmm {
    #[inline(always)]
    fn bits(self) -> __m512i {
        unsafe { _mm512_castps_si512(self.0) }
    }
    #[inline(always)]
    fn from_bits(i: __m512i) -> Zmm {
        Zmm(unsafe { _mm512_castsi512_ps(i) })
    }
    #[inline(always)]
    fn and_bits(self, m: u32) -> Zmm {
        Zmm::from_bits(unsafe { _mm512_and_si512(self.bits(), _mm512_set1_epi32(m as i32)) })
    }
    #[inline(always)]
    fn is_nan(self) -> ZmmMask {
        ZmmMask(unsafe { _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(self.0, self.0) })
    }

    /// The lanes of `a`.
    #[inline(always)]
    pub(crate) fn from_array(a: [f32; 16]) -> Zmm {
        Zmm::load(&a)
    }

    /// AVX-512's estimate of 1/√x (`vrsqrt14ps`, relative error below 2⁻¹⁴): one
    /// instruction where `vrsqrtps` on each 8-lane half takes four (with the extract and
    /// insert), and more precise, but other bits than `vrsqrtps`; the same bits as an
    /// AVX-512 build's `math::rsqrt14_x16`.
    #[inline(always)]
    pub(crate) fn rsqrt14(self) -> Zmm {
        Zmm(unsafe { _mm512_rsqrt14_ps(self.0) })
    }

    /// AVX-512's estimate of 1/x (`vrcp14ps`, relative error below 2⁻¹⁴), which the
    /// framebuffer pass refines into a quotient (`PassLane::quotient`).
    #[inline(always)]
    pub(crate) fn rcp14(self) -> Zmm {
        Zmm(unsafe { _mm512_rcp14_ps(self.0) })
    }

    /// `Lane::frexp_clamped` with `vgetmantps`'s sign control `SIGN` (the source's sign,
    /// or NaN for a negative source): `vgetmantps` gives ±1 for ±0, zeroed there by its
    /// mask (lanes ≠ 0, NaN included), with no mask inversion; `vgetexpps`'s ±inf (and
    /// NaN) clamped to `lo` below and `hi` above.
    #[inline(always)]
    fn frexp_clamped_sign<const SIGN: _MM_MANTISSA_SIGN_ENUM>(
        self,
        lo: f32,
        hi: f32,
    ) -> (Zmm, Zmm) {
        let (e, m) = unsafe {
            let nonzero = _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self.0, _mm512_setzero_ps());
            (
                Zmm(_mm512_getexp_ps(self.0)),
                Zmm(_mm512_maskz_getmant_ps::<_MM_MANT_NORM_1_2, SIGN>(
                    nonzero, self.0,
                )),
            )
        };
        (m, e.max(Zmm::splat(lo)).min(Zmm::splat(hi)))
    }

    /// |self| raised to at least `b` (positive), with the sign of `self` (`vrangeps`:
    /// the immediate's bits 1:0 = 11, the larger magnitude; bits 3:2 = 00, the sign of
    /// the first source, `self`; 01 would take the sign of the value chosen): one
    /// instruction for an and, a compare and a blend. A NaN lane gives ±`b`, not NaN
    /// (`vrangeps` returns the other operand where one is a quiet NaN).
    #[inline(always)]
    pub(crate) fn max_magnitude(self, b: Zmm) -> Zmm {
        Zmm(unsafe { _mm512_range_ps::<0b0011>(self.0, b.0) })
    }

    /// Lanes 8h to 8h + 7 (`h` is 0 or 1).
    #[inline(always)]
    pub(crate) fn half(self, h: usize) -> wide::f32x8 {
        wide::f32x8::from(unsafe {
            if h == 0 {
                _mm512_castps512_ps256(self.0)
            } else {
                _mm512_extractf32x8_ps::<1>(self.0)
            }
        })
    }

    /// Lane `idx[k]` of `self` in lane `k` (`vpermps`).
    #[inline(always)]
    pub(crate) fn permute(self, idx: [u32; 16]) -> Zmm {
        Zmm(unsafe {
            let i = _mm512_loadu_si512(idx.as_ptr().cast());
            _mm512_permutexvar_ps(i, self.0)
        })
    }
}

macro_rules! cmp {
    ($f:ident, $pred:ident) => {
        #[inline(always)]
        fn $f(self, b: Self) -> ZmmMask {
            ZmmMask(unsafe { _mm512_cmp_ps_mask::<$pred>(self.0, b.0) })
        }
    };
}

impl Lane for Zmm {
    type Mask = ZmmMask;
    const LANES: usize = 16;
    const NATIVE_SCALE: bool = true;

    #[inline(always)]
    fn splat(v: f32) -> Self {
        Zmm(unsafe { _mm512_set1_ps(v) })
    }
    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        let s = &s[..16];
        Zmm(unsafe { _mm512_loadu_ps(s.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        let s = &mut s[..16];
        unsafe { _mm512_storeu_ps(s.as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        Zmm(unsafe { _mm512_fmadd_ps(self.0, a.0, b.0) })
    }
    #[inline(always)]
    fn neg_mul_add(self, a: Self, b: Self) -> Self {
        Zmm(unsafe { _mm512_fnmadd_ps(self.0, a.0, b.0) })
    }
    #[inline(always)]
    fn mul_sub(self, a: Self, b: Self) -> Self {
        Zmm(unsafe { _mm512_fmsub_ps(self.0, a.0, b.0) })
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        // vminps: a < b ? a : b
        Zmm(unsafe { _mm512_min_ps(self.0, b.0) })
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        Zmm(unsafe { _mm512_max_ps(self.0, b.0) })
    }
    #[inline(always)]
    fn abs(self) -> Self {
        self.and_bits(0x7fff_ffff)
    }
    #[inline(always)]
    fn neg(self) -> Self {
        Zmm::from_bits(unsafe {
            _mm512_xor_si512(self.bits(), _mm512_set1_epi32(0x8000_0000_u32 as i32))
        })
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Zmm(unsafe { _mm512_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn round(self) -> Self {
        // Round to nearest even, no precision exception (imm 0x08), as wide's
        // `round_ties_even` (`vroundps` with the same imm).
        Zmm(unsafe { _mm512_roundscale_ps::<0x08>(self.0) })
    }
    #[inline(always)]
    fn and_bits(self, bits: u32) -> Self {
        Zmm::and_bits(self, bits)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        Zmm::from_bits(unsafe {
            _mm512_or_si512(
                self.and_bits(0x7fff_ffff).bits(),
                sign.and_bits(0x8000_0000).bits(),
            )
        })
    }
    cmp!(lt, _CMP_LT_OQ);
    cmp!(le, _CMP_LE_OQ);
    cmp!(gt, _CMP_GT_OQ);
    cmp!(ge, _CMP_GE_OQ);
    cmp!(eq, _CMP_EQ_OQ);
    // Ordered not-equal: false where either is NaN, as the other lane types.
    cmp!(ne, _CMP_NEQ_OQ);
    #[inline(always)]
    fn select(m: ZmmMask, a: Self, b: Self) -> Self {
        // blend(k, x, y) takes y where k is set.
        Zmm(unsafe { _mm512_mask_blend_ps(m.0, b.0, a.0) })
    }
    #[inline(always)]
    fn any(m: ZmmMask) -> bool {
        m.0 != 0
    }
    #[inline(always)]
    fn shl23(self) -> Self {
        Zmm::from_bits(unsafe { _mm512_slli_epi32::<23>(self.bits()) })
    }
    #[inline(always)]
    fn exponent_field(self) -> Self {
        Zmm(unsafe {
            let f = _mm512_srli_epi32::<23>(self.bits());
            _mm512_cvtepi32_ps(_mm512_and_si512(f, _mm512_set1_epi32(0xff)))
        })
    }
    #[inline(always)]
    fn with_unit_exponent(self) -> Self {
        Zmm::from_bits(unsafe {
            _mm512_or_si512(
                self.and_bits(0x807f_ffff).bits(),
                _mm512_set1_epi32(0x3f80_0000),
            )
        })
    }
    #[inline(always)]
    fn bits_as_int(self) -> Self {
        Zmm(unsafe { _mm512_cvtepi32_ps(self.bits()) })
    }
    /// As the x86-64-v4 build's `frexp_finite` (`math::lane`'s AVX-512 module): getexp
    /// gives −inf for ±0 and +inf for ±inf, mended to the generic form's −151 and 128
    /// (`minps` also brings NaN's exponent to 128); getmant gives ±1 for ±0, mended to 0.
    #[inline(always)]
    fn frexp_finite(self) -> (Self, Self) {
        let (e, m) = unsafe {
            (
                Zmm(_mm512_getexp_ps(self.0)),
                Zmm(_mm512_getmant_ps::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_SRC>(
                    self.0,
                )),
            )
        };
        let zero = self.eq(Zmm::splat(0.0));
        let e = Zmm::select(zero, Zmm::splat(-151.0), e).min(Zmm::splat(128.0));
        (Zmm::select(zero, Zmm::splat(0.0), m), e)
    }
    /// getexp's −inf (±0) and +inf (±inf) clamped to `lo` and `hi` by `maxps` and
    /// `minps`; NaN, their first operand, becomes `lo` (they return the second operand
    /// for a NaN one).
    #[inline(always)]
    fn frexp_clamped(self, lo: f32, hi: f32) -> (Self, Self) {
        self.frexp_clamped_sign::<_MM_MANT_SIGN_SRC>(lo, hi)
    }
    #[inline(always)]
    fn frexp_clamped_nonneg(self, lo: f32, hi: f32) -> (Self, Self) {
        // The sign control that gives NaN for a negative source (−0 is zeroed by the mask
        // first; −inf and negative subnormals give NaN).
        self.frexp_clamped_sign::<_MM_MANT_SIGN_NAN>(lo, hi)
    }
    #[inline(always)]
    fn frexp(self) -> (Self, Self) {
        let (m, e) = self.frexp_finite();
        (Zmm::select(self.is_nan(), self.with_unit_exponent(), m), e)
    }
    #[inline(always)]
    fn round_frac_pow2i_half(self) -> (Self, Self) {
        // `vreduceps` with imm 0x08 (keep 0 fraction bits, round to nearest even, no
        // precision exception): y − k exactly; then k = y − (y − k), exact; 2^(k−1) by
        // `vscalefps`. NaN gives NaN for both.
        let f = Zmm(unsafe { _mm512_reduce_ps::<0x08>(self.0) });
        let k = self - f;
        (f, Zmm::splat(0.5).scale2(k))
    }
    #[inline(always)]
    fn scale2(self, e: Self) -> Self {
        Zmm(unsafe { _mm512_scalef_ps(self.0, e.0) })
    }
    #[inline(always)]
    fn lookup16(self, table: &[f32; 16]) -> Self {
        Zmm(unsafe { _mm512_permutexvar_ps(self.bits(), _mm512_loadu_ps(table.as_ptr())) })
    }
    #[inline(always)]
    fn lookup8(self, table: &[f32; 16]) -> Self {
        // The table holds its 8 values twice: the 4-bit index of `vpermps` serves.
        self.lookup16(table)
    }
    #[inline(always)]
    fn pow2_floor_round8(self) -> Self {
        Zmm::from_bits(unsafe {
            let m = _mm512_sub_epi32(self.bits(), _mm512_set1_epi32(POW2_ROUND8_BIAS as i32));
            _mm512_and_si512(
                _mm512_slli_epi32::<20>(m),
                _mm512_set1_epi32(0xff80_0000_u32 as i32),
            )
        })
    }
    #[inline(always)]
    fn scale2_floor_or_zero(self, e: Self, y: Self, lo: f32) -> Self {
        Zmm(unsafe {
            let keep = _mm512_cmp_ps_mask::<_CMP_NLT_UQ>(y.0, _mm512_set1_ps(lo));
            _mm512_maskz_scalef_ps(keep, self.0, e.0)
        })
    }
}

/// `Zmm` against the scalar lane type, bit for bit (NaN payloads aside), on a CPU with
/// AVX-512 (the tests pass vacuously elsewhere, and say so): every special function over a
/// sample of every 257th f32 bit pattern plus boundaries (as `tests/lanes16.rs` checks
/// `wide::f32x16`) and every f32 in [86, 89], and each `Lane` method on random pairs.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::math;
    use rayon::prelude::*;

    fn detected() -> bool {
        let d = crate::avx512_dispatch();
        if !d {
            eprintln!("no AVX-512 on this CPU: Zmm not tested");
        }
        d
    }

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn arr(v: Zmm) -> [f32; 16] {
        let mut a = [0.0; 16];
        v.store(&mut a);
        a
    }

    fn inputs() -> Vec<f32> {
        let specials = [
            0.0f32,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0,
            -1.0,
            0.5,
            88.72284,
            -87.33655,
            -103.97208,
            104.0,
            -104.0,
            1e-30,
            8.673_617e-19,
        ];
        (0..u32::MAX / 257)
            .map(|k| f32::from_bits(0x9e37u32.wrapping_add(k * 257)))
            .chain(specials)
            // Every f32 in [86, 89]: `exp_neg`'s flush boundary (x ≈ 87.34, where the
            // masked scale here and the exponent bits of the scalar form must agree).
            .chain((86.0f32.to_bits()..=89.0f32.to_bits()).map(f32::from_bits))
            .collect()
    }

    /// The number of lanes where `fz` and `f1` differ over [`inputs`].
    fn mismatches(
        name: &str,
        fz: impl Fn(Zmm) -> [Zmm; 2] + Sync,
        f1: impl Fn(f32) -> [f32; 2] + Sync,
    ) -> usize {
        inputs()
            .par_chunks(16 * 1024)
            .map(|block| {
                let mut bad = 0;
                for chunk in block.chunks(16) {
                    let mut a = [1.0f32; 16];
                    a[..chunk.len()].copy_from_slice(chunk);
                    let r = fz(Zmm::load(&a)).map(arr);
                    for (l, &x) in chunk.iter().enumerate() {
                        let s = f1(x);
                        for k in 0..2 {
                            if !same(r[k][l], s[k]) {
                                if bad < 3 {
                                    eprintln!(
                                        "{name}({x:e}) [{k}]: zmm {:#010x}, scalar {:#010x}",
                                        r[k][l].to_bits(),
                                        s[k].to_bits()
                                    );
                                }
                                bad += 1;
                            }
                        }
                    }
                }
                bad
            })
            .sum()
    }

    /// `exp_neg_mul` with a factor whose flush boundary (x·κ·log2 e = 126.5, x ≈ 88.8) lies
    /// in the densely tested [86, 89].
    fn exp_neg_mul_near_one<L: Lane>(x: L) -> L {
        math::exp_neg_mul(x, math::ExpNegMul::new(0.987_654_3).expect("in the domain"))
    }

    macro_rules! one {
        ($f:expr) => {
            mismatches(
                stringify!($f),
                |x| [$f(x), Zmm::splat(0.0)],
                |x| [$f(x), 0.0],
            )
        };
    }
    macro_rules! two {
        ($f:expr) => {
            mismatches(
                stringify!($f),
                |x| {
                    let (a, b) = $f(x);
                    [a, b]
                },
                |x| {
                    let (a, b) = $f(x);
                    [a, b]
                },
            )
        };
    }

    #[test]
    fn zmm_equals_scalar_for_every_special_function() {
        if !detected() {
            return;
        }
        let counts = [
            ("exp", one!(math::exp)),
            ("exp_neg", one!(math::exp_neg)),
            ("exp_neg_mul", one!(exp_neg_mul_near_one)),
            ("expm1", one!(math::expm1)),
            ("exp2_nonpos", one!(math::exp2_nonpos)),
            ("exp2_nonpos_table", one!(math::exp2_nonpos_table)),
            ("exp2m1", one!(math::exp2m1)),
            ("exprel_neg", one!(math::exprel_neg)),
            ("exprel2_neg", one!(math::exprel2_neg)),
            ("exp_neg_fast", one!(math::exp_neg_fast)),
            ("exprel_neg_fast", one!(math::exprel_neg_fast)),
            ("exprel2_neg_fast", one!(math::exprel2_neg_fast)),
            ("erf", one!(math::erf)),
            ("erfc", one!(math::erfc)),
            ("asinh", one!(math::asinh)),
            ("log", one!(math::log)),
            ("log1p", one!(math::log1p)),
            ("exp_split", two!(math::exp_split)),
            ("exp2_split", two!(math::exp2_split)),
            ("exp_split_fast", two!(math::exp_split_fast)),
            ("exp2_split_fast", two!(math::exp2_split_fast)),
            ("frexp", two!(math::frexp)),
            // For NaN only the exponent is compared (the mantissa is any); ±inf must
            // give the finite exponent 128 (see `Lane::frexp_finite`).
            (
                "frexp_finite",
                mismatches(
                    "frexp_finite",
                    |x| {
                        let (a, b) = x.frexp_finite();
                        [Zmm::select(x.eq(x), a, Zmm::splat(0.0)), b]
                    },
                    |x| {
                        let (a, b) = math::frexp(x);
                        [if x.is_nan() { 0.0 } else { a }, b]
                    },
                ),
            ),
            // The generic form's values (scalar `f32`) for both of `RayGeom::new`'s
            // ranges; for NaN only that the exponent is in [lo, hi].
            (
                "frexp_clamped",
                [(-151.0f32, 2_097_152.0f32), (-8_388_608.0, 128.0)]
                    .iter()
                    .map(|&(lo, hi)| {
                        mismatches(
                            "frexp_clamped",
                            |x| {
                                let (a, b) = x.frexp_clamped(lo, hi);
                                let ok = b.ge(Zmm::splat(lo)) & b.le(Zmm::splat(hi));
                                let nan_e = Zmm::select(ok, Zmm::splat(0.0), Zmm::splat(1.0));
                                let num = x.eq(x);
                                [
                                    Zmm::select(num, a, Zmm::splat(0.0)),
                                    Zmm::select(num, b, nan_e),
                                ]
                            },
                            |x| {
                                let (a, b) = Lane::frexp_clamped(x, lo, hi);
                                if x.is_nan() {
                                    [0.0, 0.0]
                                } else {
                                    [a, b]
                                }
                            },
                        )
                    })
                    .sum(),
            ),
            // The same with t's validity in the mantissa: NaN exactly for NaN and
            // negative x (not −0) in both forms, the same bits elsewhere.
            (
                "frexp_clamped_nonneg",
                mismatches(
                    "frexp_clamped_nonneg",
                    |x| {
                        let (a, b) = x.frexp_clamped_nonneg(-151.0, 2_097_152.0);
                        let ok = b.ge(Zmm::splat(-151.0)) & b.le(Zmm::splat(2_097_152.0));
                        let nan_e = Zmm::select(ok, Zmm::splat(0.0), Zmm::splat(1.0));
                        [a, Zmm::select(x.eq(x), b, nan_e)]
                    },
                    |x| {
                        let (a, b) = Lane::frexp_clamped_nonneg(x, -151.0, 2_097_152.0);
                        assert_eq!(a.is_nan(), x.is_nan() || x < 0.0, "{x:e}");
                        [a, if x.is_nan() { 0.0 } else { b }]
                    },
                ),
            ),
            ("round", one!(Lane::round)),
            ("sqrt", one!(Lane::sqrt)),
            ("abs", one!(Lane::abs)),
            ("neg", one!(Lane::neg)),
            ("exponent_field", one!(Lane::exponent_field)),
            ("with_unit_exponent", one!(Lane::with_unit_exponent)),
            ("bits_as_int", one!(Lane::bits_as_int)),
        ];
        let bad: Vec<_> = counts.iter().filter(|(_, n)| *n > 0).collect();
        assert!(bad.is_empty(), "Zmm differs from scalar: {bad:?}");
    }

    /// Each two- and three-operand method, the comparisons (through `select`), `ldexp`
    /// within its precondition and `pow2i` over its domain, on random operands.
    #[test]
    fn zmm_equals_scalar_for_lane_operations() {
        if !detected() {
            return;
        }
        let mut s: u64 = 0x2545_f491_4f6c_dd1d;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut bad = 0;
        for _ in 0..200_000 {
            let m: [f32; 16] = core::array::from_fn(|_| {
                let b = next();
                // Mantissas in [2^-40, 2^8] of either sign, and zero.
                if b % 17 == 0 {
                    0.0
                } else {
                    let mag = f32::from_bits(0x3f80_0000 | (b as u32 & 0x007f_ffff));
                    let v = mag * 2f32.powi(((b >> 32) % 48) as i32 - 40);
                    if b & (1 << 40) != 0 {
                        -v
                    } else {
                        v
                    }
                }
            });
            let e: [f32; 16] = core::array::from_fn(|_| (next() % 700) as f32 - 350.0);
            let k: [f32; 16] = core::array::from_fn(|_| (next() % 255) as f32 - 126.0);
            // Random bit patterns, a quarter of them equal to the other operand's.
            let x: [f32; 16] = core::array::from_fn(|_| f32::from_bits(next() as u32));
            let y: [f32; 16] = core::array::from_fn(|i| {
                let b = next();
                if b % 4 == 0 {
                    x[i]
                } else {
                    f32::from_bits(b as u32)
                }
            });
            let [vm, ve, vk, vx, vy] = [m, e, k, x, y].map(|a| Zmm::load(&a));
            let sel = |c: ZmmMask| arr(Zmm::select(c, vx, vy));
            let got = [
                arr(math::ldexp(vm, ve)),
                arr(Zmm::pow2i(vk)),
                arr(vx + vy),
                arr(vx - vy),
                arr(vx * vy),
                arr(vx / vy),
                arr(Lane::min(vx, vy)),
                arr(Lane::max(vx, vy)),
                arr(vx.mul_add(vy, vm)),
                arr(vx.mul_sub(vy, vm)),
                arr(vx.neg_mul_add(vy, vm)),
                arr(vx.copysign(vy)),
                arr(vx.clamp(vm, vm + Zmm::splat(1.0))),
                sel(vx.lt(vy)),
                sel(vx.le(vy)),
                sel(vx.gt(vy)),
                sel(vx.ge(vy)),
                sel(vx.eq(vy)),
                sel(vx.ne(vy)),
                sel(vx.lt(vy) & !vx.eq(vm) | vy.gt(vm)),
            ];
            let any = Zmm::any(vx.lt(vy));
            let mut any1 = false;
            for i in 0..16 {
                let (a, b) = (x[i], y[i]);
                let sel1 = |c: bool| if c { a } else { b };
                any1 |= a < b;
                let want = [
                    math::ldexp(m[i], e[i]),
                    f32::pow2i(k[i]),
                    a + b,
                    a - b,
                    a * b,
                    a / b,
                    Lane::min(a, b),
                    Lane::max(a, b),
                    a.mul_add(b, m[i]),
                    Lane::mul_sub(a, b, m[i]),
                    Lane::neg_mul_add(a, b, m[i]),
                    Lane::copysign(a, b),
                    Lane::clamp(a, m[i], m[i] + 1.0),
                    sel1(Lane::lt(a, b)),
                    sel1(Lane::le(a, b)),
                    sel1(Lane::gt(a, b)),
                    sel1(Lane::ge(a, b)),
                    sel1(Lane::eq(a, b)),
                    sel1(Lane::ne(a, b)),
                    sel1(Lane::lt(a, b) & !Lane::eq(a, m[i]) | Lane::gt(b, m[i])),
                ];
                for (j, w) in want.iter().enumerate() {
                    if !same(got[j][i], *w) {
                        if bad < 3 {
                            eprintln!("op {j}: x = {a:e}, y = {b:e}, m = {:e}", m[i]);
                        }
                        bad += 1;
                    }
                }
            }
            bad += usize::from(any != any1);
        }
        assert_eq!(bad, 0, "lanes where Zmm differs from scalar");
    }
}
