//! The lane abstraction: every kernel in this crate is written once over [`Lane`] and
//! instantiated for `f32` (the scalar path), `wide::f32x8` (8 rays per instruction) and
//! `wide::f32x16` (16 rays per instruction where the build enables AVX-512F; two `f32x8`
//! halves otherwise).
//!
//! The instantiations are bit-identical: each trait method maps to one IEEE-754
//! operation with the same rounding in all three. `mul_add` is fused in all when the target
//! has FMA and unfused in all when it does not; `min`/`max` follow the x86 `minps`/`maxps`
//! rule `a < b ? a : b` in all, so even NaN inputs give the same bits; `round` is
//! `round_ties_even` in the vector types (wide 1's `round` rounds ties away from zero).
//! `tests/lanes16.rs` checks the 16-lane instantiation against the scalar one.

use core::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};
use wide::{f32x16, f32x8, i32x16, i32x8};

/// The bits of 1.5·2^20 less 127·8: `Lane::pow2_floor_round8` subtracts it from the
/// sum's bits, which leaves m + 1016 = 8·(⌊m/8⌋ + 127) + (m mod 8).
pub(super) const POW2_ROUND8_BIAS: u32 = 0x49c0_0000 - 127 * 8;

/// A vector of `f32` lanes (1, 8 or 16) with the operations the kernels need.
pub trait Lane:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Send
    + Sync
    + 'static
{
    /// A per-lane boolean.
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// Number of lanes.
    const LANES: usize;

    /// `v` in every lane.
    fn splat(v: f32) -> Self;
    /// Loads `LANES` values from the front of `s` (which must hold at least that many).
    fn load(s: &[f32]) -> Self;
    /// Stores `LANES` values to the front of `s` (which must hold at least that many).
    fn store(self, s: &mut [f32]);

    /// `self * a + b`, rounded once where the target has FMA.
    fn mul_add(self, a: Self, b: Self) -> Self;
    /// `-(self * a) + b`, rounded once where the target has FMA.
    fn neg_mul_add(self, a: Self, b: Self) -> Self;
    /// `self * a - b`, rounded once where the target has FMA.
    fn mul_sub(self, a: Self, b: Self) -> Self;
    /// `a < b ? a : b` (x86 `minps` semantics: the second operand wins on NaN).
    fn min(self, b: Self) -> Self;
    /// `a > b ? a : b` (x86 `maxps` semantics: the second operand wins on NaN).
    fn max(self, b: Self) -> Self;
    /// `|self|` (the sign bit cleared).
    fn abs(self) -> Self;
    /// `-self` (the sign bit flipped).
    fn neg(self) -> Self;
    /// The correctly rounded square root.
    fn sqrt(self) -> Self;
    /// Round to the nearest integer, ties to even.
    fn round(self) -> Self;
    /// The magnitude of `self` with the sign of `sign`.
    fn copysign(self, sign: Self) -> Self;
    /// The bits of `self` ANDed with `bits`.
    fn and_bits(self, bits: u32) -> Self;

    /// `self < b` (false where either is NaN).
    fn lt(self, b: Self) -> Self::Mask;
    /// `self <= b` (false where either is NaN).
    fn le(self, b: Self) -> Self::Mask;
    /// `self > b` (false where either is NaN).
    fn gt(self, b: Self) -> Self::Mask;
    /// `self >= b` (false where either is NaN).
    fn ge(self, b: Self) -> Self::Mask;
    /// `self == b` (false where either is NaN; +0 equals −0).
    fn eq(self, b: Self) -> Self::Mask;
    /// Ordered not-equal (`a < b || a > b`): false when either operand is NaN, in both
    /// widths, so NaN lanes take the same branch in the scalar and 8-lane paths.
    fn ne(self, b: Self) -> Self::Mask;
    /// `m ? a : b`, lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// `m ? self : +0`, lane by lane: [`Lane::select`] with +0, the same bits for a mask
    /// from this trait's compares, whose lanes have all bits set or clear (on `wide`
    /// lanes one `and` with the mask, where LLVM made the blend with zero a compare of
    /// the mask's sign and an `and`).
    #[inline(always)]
    fn keep(self, m: Self::Mask) -> Self {
        Self::select(m, self, Self::splat(0.0))
    }
    /// `m ? +0 : self`, lane by lane: [`Lane::select`] with +0 first, the same bits (on
    /// `wide` lanes one `andn` with the mask; see [`Lane::keep`]).
    #[inline(always)]
    fn zero_where(self, m: Self::Mask) -> Self {
        Self::select(m, Self::splat(0.0), self)
    }
    /// True if any lane of the mask is set.
    fn any(m: Self::Mask) -> bool;

    /// `2^k` for an integer-valued `k` in `[-126, 128]` (128 gives `+inf`), built from
    /// the exponent bits: one add and one shift.
    #[inline(always)]
    fn pow2i(k: Self) -> Self {
        Self::shl23(k + Self::splat(POW2_MAGIC))
    }
    /// `(k, 2^k)` with k = y rounded to an integer, for `y` in `[-127, 127]`, where
    /// `2^-127` gives 0: one add of 1.5·2^23 + 127 serves both (the rounded integer is
    /// left in the sum's low mantissa bits), so the pair costs an add, a subtract and a
    /// shift instead of `round` (two µops on Intel) and [`Lane::pow2i`]'s add and shift.
    /// The sum rounds ties to even, and the constant is odd, so a tie (y = j + 1/2) goes
    /// to the odd k, where [`Lane::round`] takes the even one: y − k is ±1/2 either way,
    /// and every caller's polynomial covers both ends. Elsewhere the same bits as
    /// `(y.round(), pow2i(y.round()))`; in every lane type the same bits as each other.
    #[inline(always)]
    fn round_pow2i(self) -> (Self, Self) {
        let t = self + Self::splat(POW2_MAGIC);
        (t - Self::splat(POW2_MAGIC), Self::shl23(t))
    }
    /// `(y − k, 2^(k−1))` with k = y rounded to the nearest integer, ties to even (as
    /// [`Lane::round`]), for `y` in `[-125, 127]`: the reduction of [`exp2m1`]. Here one
    /// add of 1.5·2^23 + 126 (even, so the sum's ties give even k), a subtract, a shift
    /// (the sum's low bits hold k + 126, the biased exponent of 2^(k−1), which stays
    /// normal up to k = 127) and a subtract for y − k; AVX-512 lanes take `vreduceps`
    /// for y − k itself, one subtract for k and `vscalefps` for 2^(k−1): one operation
    /// fewer, the same bits (y − k and k are exact either way).
    ///
    /// [`exp2m1`]: fn@super::exp2m1
    #[inline(always)]
    fn round_frac_pow2i_half(self) -> (Self, Self) {
        let t = self + Self::splat(POW2_MAGIC_EVEN);
        let k = t - Self::splat(POW2_MAGIC_EVEN);
        (self - k, Self::shl23(t))
    }
    /// The bits of `self` shifted left by 23 (an integer in the low mantissa bits moved
    /// into the exponent field).
    fn shl23(self) -> Self;
    /// The biased exponent field of `self` (0 for zero and subnormals, 255 for inf/NaN),
    /// as an integer-valued float.
    fn exponent_field(self) -> Self;
    /// `self` with its exponent field replaced by 127: sign * [1, 2) for normal inputs.
    fn with_unit_exponent(self) -> Self;
    /// [`Lane::with_unit_exponent`] with the sign of `sign`: |m| in [1, 2) from `self`'s
    /// mantissa bits.
    #[inline(always)]
    fn with_unit_exponent_sign(self, sign: Self) -> Self {
        self.with_unit_exponent().copysign(sign)
    }
    /// The bits of `self` read as an `i32`, converted to f32 (`vcvtdq2ps`): exact for the
    /// bits of a non-negative subnormal or zero (below 2^23), which it gives as
    /// `self · 2^149` without arithmetic on the subnormal.
    fn bits_as_int(self) -> Self;

    /// Clamp to `[lo, hi]`; a NaN lane stays NaN.
    #[inline(always)]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        lo.max(hi.min(self))
    }

    /// True where `scale2` is one instruction (AVX-512 `vscalefps`): callers then scale
    /// each channel on its own instead of sharing a [`super::pow2_pair`].
    const NATIVE_SCALE: bool = false;
    /// [`frexp`](fn@super::frexp): `(m, e)` with `self = m · 2^e`, `|m|` in [1, 2).
    #[inline(always)]
    fn frexp(self) -> (Self, Self) {
        super::frexp::frexp_bits(self)
    }
    /// [`Lane::frexp`] for callers that replace the results of NaN lanes themselves
    /// (`RayGeom::new`, whose guard makes them NaN): the same for finite and ±inf lanes
    /// (±inf: (±1, 128)), any mantissa for NaN lanes. The AVX-512 form then skips
    /// `frexp`'s fix-up of the NaN mantissa.
    #[inline(always)]
    fn frexp_finite(self) -> (Self, Self) {
        self.frexp()
    }
    /// [`Lane::frexp_finite`] with the exponent of ±0 set to `lo` and that of ±inf to
    /// `hi` (`lo` ≤ −151 and `hi` ≥ 128, finite: every other lane's exponent lies between
    /// them); NaN lanes get any mantissa and a finite exponent in [`lo`, `hi`]. The
    /// AVX-512 form clamps `vgetexpps`'s −inf and +inf (and NaN) into [`lo`, `hi`] with
    /// one `maxps` and one `minps`, where `frexp_finite` and two selects after it take five
    /// instructions (`RayGeom::new`'s u and t).
    #[inline(always)]
    fn frexp_clamped(self, lo: f32, hi: f32) -> (Self, Self) {
        let (m, e) = self.frexp_finite();
        let e = Self::select(self.eq(Self::splat(0.0)), Self::splat(lo), e);
        let inf = self.abs().eq(Self::splat(f32::INFINITY));
        (m, Self::select(inf, Self::splat(hi), e))
    }
    /// [`Lane::frexp_clamped`] of a segment end t, whose mantissa also says whether t is
    /// valid: NaN where t is negative (not −0) or NaN (here a select; AVX-512's
    /// `vgetmantps` gives it by its sign control at no cost). `RayGeom::new` then needs
    /// no guard term for t: every optical depth it forms takes t's mantissa as a factor.
    #[inline(always)]
    fn frexp_clamped_nonneg(self, lo: f32, hi: f32) -> (Self, Self) {
        let (m, e) = self.frexp_clamped(lo, hi);
        let valid = self.ge(Self::splat(0.0));
        (Self::select(valid, m, Self::splat(f32::NAN)), e)
    }
    /// `table[i]` in each lane, with `i` the low 4 bits of that lane's bits (`vpermps`
    /// with AVX-512; here lane by lane).
    #[inline(always)]
    fn lookup16(self, table: &[f32; 16]) -> Self {
        let (mut a, mut r) = ([0f32; 16], [0f32; 16]);
        self.store(&mut a);
        for (r, a) in r.iter_mut().zip(&a).take(Self::LANES) {
            *r = table[(a.to_bits() & 15) as usize];
        }
        Self::load(&r)
    }
    /// `2^⌊m/8⌋` for `self = 1.5·2^20 + m/8`, `exp_neg`'s rounded sum (m an integer in
    /// [−1016, 1023]): from the sum's bits, m's low 3 bits shifted out and the rest moved
    /// into the exponent field with the bias: one subtract, one shift and one and; +0
    /// for ⌊m/8⌋ = −127 (exponent field 0). With a multiply, cheaper than
    /// [`Lane::scale2_floor_or_zero`] on lanes without [`Lane::NATIVE_SCALE`].
    fn pow2_floor_round8(self) -> Self;
    /// `table[i]` in each lane, with `i` the low 3 bits of that lane's bits; `table`
    /// holds the 8 values twice, so that AVX-512's 16-lane `vpermps`, which reads 4
    /// bits, takes it as it is (`vpermps` on AVX2 and AVX-512 lanes; here lane by lane).
    #[inline(always)]
    fn lookup8(self, table: &[f32; 16]) -> Self {
        let (mut a, mut r) = ([0f32; 16], [0f32; 16]);
        self.store(&mut a);
        for (r, a) in r.iter_mut().zip(&a).take(Self::LANES) {
            *r = table[(a.to_bits() & 7) as usize];
        }
        Self::load(&r)
    }
    /// `self · 2^⌊e⌋` where `y` is not below `lo` (NaN included), and +0 where it is:
    /// AVX-512's `vscalefps` with a zeroing mask. Precondition: where `y ≥ lo`, `e` is
    /// finite and `self` normal or NaN, and the product is not above f32::MAX (then it is
    /// rounded once here as there, subnormal results included); lane by lane here.
    #[inline(always)]
    fn scale2_floor_or_zero(self, e: Self, y: Self, lo: f32) -> Self {
        let (mut a, mut b, mut c) = ([0f32; 16], [0f32; 16], [0f32; 16]);
        self.store(&mut a);
        e.store(&mut b);
        y.store(&mut c);
        for ((a, b), c) in a.iter_mut().zip(&b).zip(&c).take(Self::LANES) {
            *a = if *c < lo {
                0.0
            } else {
                // 2^⌊e⌋ from its bits, in two factors so that both stay normal.
                let k = b.floor().clamp(-252.0, 254.0) as i32;
                let (k1, k2) = (k / 2, k - k / 2);
                let p = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
                *a * p(k1) * p(k2)
            };
        }
        Self::load(&a)
    }
    /// [`ldexp`](fn@super::ldexp): `self · 2^e` rounded once, saturating.
    #[inline(always)]
    fn scale2(self, e: Self) -> Self {
        let (s1, s2) = super::pow2_pair(e);
        self * s1 * s2
    }
}

/// 1.5 · 2^23 + 127: adding it to a float in [-2^22, 2^22] rounds it to an integer k
/// (the sum ties to even, so k ties to odd) and leaves k + 127, the biased exponent of
/// 2^k, in the low mantissa bits.
pub(crate) const POW2_MAGIC: f32 = 12_582_912.0 + 127.0;

/// 1.5 · 2^23 + 126: as [`POW2_MAGIC`], but even, so the rounded integer k ties to even,
/// and the low mantissa bits hold k + 126, the biased exponent of 2^(k−1).
pub(crate) const POW2_MAGIC_EVEN: f32 = 12_582_912.0 + 126.0;

impl Lane for f32 {
    type Mask = bool;
    const LANES: usize = 1;

    #[inline(always)]
    fn splat(v: f32) -> Self {
        v
    }
    #[inline(always)]
    fn load(s: &[f32]) -> Self {
        s[0]
    }
    #[inline(always)]
    fn store(self, s: &mut [f32]) {
        s[0] = self;
    }
    #[inline(always)]
    fn mul_add(self, a: Self, b: Self) -> Self {
        #[cfg(target_feature = "fma")]
        {
            f32::mul_add(self, a, b)
        }
        #[cfg(not(target_feature = "fma"))]
        {
            self * a + b
        }
    }
    #[inline(always)]
    fn mul_sub(self, a: Self, b: Self) -> Self {
        #[cfg(target_feature = "fma")]
        {
            f32::mul_add(self, a, -b)
        }
        #[cfg(not(target_feature = "fma"))]
        {
            self * a - b
        }
    }
    #[inline(always)]
    fn neg_mul_add(self, a: Self, b: Self) -> Self {
        #[cfg(target_feature = "fma")]
        {
            f32::mul_add(-self, a, b)
        }
        #[cfg(not(target_feature = "fma"))]
        {
            b - self * a
        }
    }
    #[inline(always)]
    fn min(self, b: Self) -> Self {
        if self < b {
            self
        } else {
            b
        }
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        if self > b {
            self
        } else {
            b
        }
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn neg(self) -> Self {
        -self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32::sqrt(self)
    }
    #[inline(always)]
    fn round(self) -> Self {
        f32::round_ties_even(self)
    }
    #[inline(always)]
    fn copysign(self, sign: Self) -> Self {
        f32::copysign(self, sign)
    }
    #[inline(always)]
    fn and_bits(self, bits: u32) -> Self {
        f32::from_bits(self.to_bits() & bits)
    }
    #[inline(always)]
    fn lt(self, b: Self) -> bool {
        self < b
    }
    #[inline(always)]
    fn le(self, b: Self) -> bool {
        self <= b
    }
    #[inline(always)]
    fn gt(self, b: Self) -> bool {
        self > b
    }
    #[inline(always)]
    fn ge(self, b: Self) -> bool {
        self >= b
    }
    #[inline(always)]
    fn eq(self, b: Self) -> bool {
        self == b
    }
    #[inline(always)]
    fn ne(self, b: Self) -> bool {
        // Ordered not-equal: false when either is NaN (`!=` is true then; clippy's
        // double_comparisons suggestion, `!=`, would change exactly that).
        #[allow(clippy::double_comparisons)]
        let ne = self < b || self > b;
        ne
    }
    #[inline(always)]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn shl23(self) -> Self {
        f32::from_bits(self.to_bits() << 23)
    }
    #[inline(always)]
    fn pow2_floor_round8(self) -> Self {
        f32::from_bits(self.to_bits().wrapping_sub(POW2_ROUND8_BIAS) << 20 & 0xff80_0000)
    }
    #[inline(always)]
    fn exponent_field(self) -> Self {
        ((self.to_bits() >> 23) & 0xff) as f32
    }
    #[inline(always)]
    fn with_unit_exponent(self) -> Self {
        f32::from_bits((self.to_bits() & 0x807f_ffff) | 0x3f80_0000)
    }
    #[inline(always)]
    fn bits_as_int(self) -> Self {
        self.to_bits() as i32 as f32
    }
}

macro_rules! impl_lane_wide {
    ($mod:ident, $F:ty, $I:ty, $N:expr, { $($avx:tt)* }) => {
        mod $mod {
            use super::*;
            #[inline(always)]
            fn as_i(x: $F) -> $I {
                bytemuck::cast(x)
            }
            #[inline(always)]
            fn as_f(x: $I) -> $F {
                bytemuck::cast(x)
            }

            impl Lane for $F {
                type Mask = $F;
                const LANES: usize = $N;

                #[inline(always)]
                fn splat(v: f32) -> Self {
                    <$F>::splat(v)
                }
                #[inline(always)]
                fn load(s: &[f32]) -> Self {
                    let a: [f32; $N] = s[..$N].try_into().unwrap();
                    <$F>::new(a)
                }
                #[inline(always)]
                fn store(self, s: &mut [f32]) {
                    s[..$N].copy_from_slice(&self.to_array());
                }
                #[inline(always)]
                fn mul_add(self, a: Self, b: Self) -> Self {
                    <$F>::mul_add(self, a, b)
                }
                #[inline(always)]
                fn mul_sub(self, a: Self, b: Self) -> Self {
                    <$F>::mul_sub(self, a, b)
                }
                #[inline(always)]
                fn neg_mul_add(self, a: Self, b: Self) -> Self {
                    <$F>::mul_neg_add(self, a, b)
                }
                #[inline(always)]
                fn min(self, b: Self) -> Self {
                    // vminps(a, b) = a < b ? a : b
                    <$F>::fast_min(self, b)
                }
                #[inline(always)]
                fn max(self, b: Self) -> Self {
                    <$F>::fast_max(self, b)
                }
                #[inline(always)]
                fn abs(self) -> Self {
                    <$F>::abs(self)
                }
                #[inline(always)]
                fn neg(self) -> Self {
                    self ^ <$F>::splat(-0.0)
                }
                #[inline(always)]
                fn sqrt(self) -> Self {
                    <$F>::sqrt(self)
                }
                #[inline(always)]
                fn round(self) -> Self {
                    <$F>::round_ties_even(self)
                }
                #[inline(always)]
                fn copysign(self, sign: Self) -> Self {
                    let s = <$F>::splat(-0.0);
                    (self & !s) | (sign & s)
                }
                #[inline(always)]
                fn and_bits(self, bits: u32) -> Self {
                    self & <$F>::splat(f32::from_bits(bits))
                }
                #[inline(always)]
                fn lt(self, b: Self) -> Self {
                    self.simd_lt(b)
                }
                #[inline(always)]
                fn le(self, b: Self) -> Self {
                    self.simd_le(b)
                }
                #[inline(always)]
                fn gt(self, b: Self) -> Self {
                    self.simd_gt(b)
                }
                #[inline(always)]
                fn ge(self, b: Self) -> Self {
                    self.simd_ge(b)
                }
                #[inline(always)]
                fn eq(self, b: Self) -> Self {
                    self.simd_eq(b)
                }
                #[inline(always)]
                fn ne(self, b: Self) -> Self {
                    // Spelled out: wide's `simd_ne` is unordered (true for NaN).
                    self.simd_lt(b) | self.simd_gt(b)
                }
                #[inline(always)]
                fn select(m: Self, a: Self, b: Self) -> Self {
                    m.select(a, b)
                }
                #[inline(always)]
                fn keep(self, m: Self) -> Self {
                    // (Masks are all-ones or all-zero lanes.)
                    self & m
                }
                #[inline(always)]
                fn zero_where(self, m: Self) -> Self {
                    self & !m
                }
                #[inline(always)]
                fn any(m: Self) -> bool {
                    m.any()
                }
                #[inline(always)]
                fn shl23(self) -> Self {
                    as_f(as_i(self) << 23)
                }
                #[inline(always)]
                fn pow2_floor_round8(self) -> Self {
                    let m = as_i(self) - <$I>::splat(POW2_ROUND8_BIAS as i32);
                    as_f((m << 20) & <$I>::splat(0xff80_0000_u32 as i32))
                }
                #[inline(always)]
                fn exponent_field(self) -> Self {
                    let field: $I = (as_i(self) >> 23) & <$I>::splat(0xff);
                    field.round_float()
                }
                #[inline(always)]
                fn with_unit_exponent(self) -> Self {
                    as_f(
                        (as_i(self) & <$I>::splat(0x807f_ffff_u32 as i32))
                            | <$I>::splat(0x3f80_0000),
                    )
                }
                #[inline(always)]
                fn bits_as_int(self) -> Self {
                    as_i(self).round_float()
                }
                #[inline(always)]
                fn with_unit_exponent_sign(self, sign: Self) -> Self {
                    let s = (as_i(sign) & <$I>::splat(i32::MIN)) | <$I>::splat(0x3f80_0000);
                    as_f((as_i(self) & <$I>::splat(0x007f_ffff)) | s)
                }
                $($avx)*
            }
        }
    };
}

// The AVX-512 overrides (module `avx512` below) where the build enables it; the trait's
// generic forms elsewhere.
impl_lane_wide! { lane_x8, f32x8, i32x8, 8, {
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    const NATIVE_SCALE: bool = true;
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn frexp(self) -> (Self, Self) {
        super::avx512::x8::frexp(self)
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn frexp_finite(self) -> (Self, Self) {
        super::avx512::x8::frexp_finite(self)
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn scale2(self, e: Self) -> Self {
        super::avx512::x8::scalef(self, e)
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn lookup16(self, table: &[f32; 16]) -> Self {
        super::avx512::x8::lookup16(self, table)
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn scale2_floor_or_zero(self, e: Self, y: Self, lo: f32) -> Self {
        super::avx512::x8::scalef_or_zero(self, e, y, lo)
    }
    #[cfg(target_feature = "avx2")]
    #[inline(always)]
    fn lookup8(self, table: &[f32; 16]) -> Self {
        super::avx2::lookup8(self, table)
    }
} }
impl_lane_wide! { lane_x16, f32x16, i32x16, 16, {
    #[cfg(target_feature = "avx512f")]
    const NATIVE_SCALE: bool = true;
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn frexp(self) -> (Self, Self) {
        super::avx512::x16::frexp(self)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn frexp_finite(self) -> (Self, Self) {
        super::avx512::x16::frexp_finite(self)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn scale2(self, e: Self) -> Self {
        super::avx512::x16::scalef(self, e)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn lookup16(self, table: &[f32; 16]) -> Self {
        super::avx512::x16::lookup16(self, table)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn scale2_floor_or_zero(self, e: Self, y: Self, lo: f32) -> Self {
        super::avx512::x16::scalef_or_zero(self, e, y, lo)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn lookup8(self, table: &[f32; 16]) -> Self {
        super::avx512::x16::lookup16(self, table)
    }
    // Without AVX-512F, wide's f32x16 is two f32x8: the AVX2 form on each half.
    #[cfg(all(target_feature = "avx2", not(target_feature = "avx512f")))]
    #[inline(always)]
    fn lookup8(self, table: &[f32; 16]) -> Self {
        let [a, b]: [f32x8; 2] = bytemuck::cast(self);
        bytemuck::cast([a.lookup8(table), b.lookup8(table)])
    }
} }

/// `Lane::lookup8` for f32x8 where the build has AVX2 (the x86-64-v3 build's 8-lane
/// kernels; AVX-512VL builds too): one `vpermps`, which reads the low 3 bits of each
/// index. Sound for the reason given at `mod avx512`: the module exists only where the
/// build enables AVX2 for the whole crate.
#[cfg(target_feature = "avx2")]
#[allow(unsafe_code)]
mod avx2 {
    use core::arch::x86_64::*;
    use wide::f32x8;

    #[inline(always)]
    pub(super) fn lookup8(x: f32x8, table: &[f32; 16]) -> f32x8 {
        let a: __m256 = x.into();
        // SAFETY: see the module documentation; `table` holds 16 values.
        unsafe { _mm256_permutevar8x32_ps(_mm256_loadu_ps(table.as_ptr()), _mm256_castps_si256(a)) }
            .into()
    }
}

/// AVX-512's estimate of 1/√x (`vrsqrt14ps`) on 16 lanes, in builds with AVX-512F: the
/// framebuffer pass's estimate there (`pass::height::PassLane`).
#[cfg(target_feature = "avx512f")]
#[inline(always)]
pub(crate) fn rsqrt14_x16(x: f32x16) -> f32x16 {
    avx512::x16::rsqrt14(x)
}

/// [`rsqrt14_x16`] on 8 lanes (AVX-512VL).
#[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
#[inline(always)]
pub(crate) fn rsqrt14_x8(x: f32x8) -> f32x8 {
    avx512::x8::rsqrt14(x)
}

/// AVX-512's estimate of 1/x (`vrcp14ps`) on 16 lanes, in builds with AVX-512F: the
/// framebuffer pass refines it into its one quotient (`pass::height::PassLane::quotient`).
#[cfg(target_feature = "avx512f")]
#[inline(always)]
pub(crate) fn rcp14_x16(x: f32x16) -> f32x16 {
    avx512::x16::rcp14(x)
}

/// [`rcp14_x16`] on 8 lanes (AVX-512VL).
#[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
#[inline(always)]
pub(crate) fn rcp14_x8(x: f32x8) -> f32x8 {
    avx512::x8::rcp14(x)
}

/// AVX-512 forms of two `Lane` methods: `frexp` by `vgetexpps`/`vgetmantps` (9
/// instructions with the fix-ups for 0, ±inf and NaN, against about 12), `scale2` (ldexp)
/// by `vscalefps` (1, against 11); and AVX-512's estimates of 1/√x and 1/x for the
/// framebuffer pass (`rsqrt14_x16`, `rsqrt14_x8`: other bits than `vrsqrtps`; `rcp14_x16`,
/// `rcp14_x8`, which the pass refines into a quotient). The two
/// `Lane` methods give the same results as the generic forms (NaN payloads aside) within
/// their preconditions:
/// both are exact or round once, and the fix-ups give the generic `frexp`'s values for
/// 0, ±inf and NaN. `tests/lanes16.rs` and the kernels' bit-for-bit tests check it in the
/// x86-64-v4 build (`.ci/run`).
///
/// Its `unsafe` (as that of `mod avx2` above, `math::zmm` and the run-time dispatch in
/// `kernel` and `pass::height`): calling an intrinsic needs it unless the caller is a
/// `#[target_feature]` function, which a trait method cannot be. Sound because the module
/// exists only where the build enables the features for the whole crate, so no code of
/// the crate runs on a CPU without them.
#[cfg(target_feature = "avx512f")]
#[allow(unsafe_code)]
mod avx512 {
    use core::arch::x86_64::*;

    macro_rules! width {
        ($name:ident, $F:ty, $R:ty, $getexp:ident, $getmant:ident, $scalef:ident,
         $rsqrt14:ident, $rcp14:ident, $maskz_scalef:ident, $cmp_mask:ident, $set1:ident,
         $lookup:expr $(, $cfg:meta)?) => {
            $(#[$cfg])?
            pub(super) mod $name {
                use super::*;
                type F = $F;

                /// `frexp` but for the mantissa of NaN lanes: getexp gives −inf for ±0,
                /// getmant ±1, so zero is mended to the generic form's (+0, −151). For
                /// ±inf getmant gives ±1 and getexp +inf, which `fast_min` (`minps`)
                /// brings to the generic form's 128, as it does NaN's exponent (it
                /// returns its second operand for a NaN first one). The exponent must
                /// not stay +inf: a caller's NaN guard (`RayGeom::new`) is lost in
                /// `vscalefps`, which gives +0 for NaN · 2^-inf and +inf for NaN · 2^+inf
                /// (an up component d_up = +inf gave τ = 0 in the x86-64-v4 build).
                #[inline(always)]
                pub(crate) fn frexp_finite(x: F) -> (F, F) {
                    let a: $R = x.into();
                    // SAFETY: see the module documentation.
                    let (e, m) = unsafe {
                        (
                            $getexp(a),
                            $getmant::<_MM_MANT_NORM_1_2, _MM_MANT_SIGN_SRC>(a),
                        )
                    };
                    let (e, m): (F, F) = (e.into(), m.into());
                    let zero = x.simd_eq(F::splat(0.0));
                    let e = zero.select(F::splat(-151.0), e).fast_min(F::splat(128.0));
                    (zero.select(F::splat(0.0), m), e)
                }

                /// `frexp`: [`frexp_finite`] with the mantissa of NaN mended to the
                /// generic form's (the finite `with_unit_exponent` of its bits).
                #[inline(always)]
                pub(crate) fn frexp(x: F) -> (F, F) {
                    let (m, e) = frexp_finite(x);
                    let m = x.is_nan().select(super::super::Lane::with_unit_exponent(x), m);
                    (m, e)
                }

                /// `x · 2^e`, rounded once, saturating (`ldexp`).
                #[inline(always)]
                pub(crate) fn scalef(x: F, e: F) -> F {
                    // SAFETY: see the module documentation.
                    unsafe { $scalef(x.into(), e.into()) }.into()
                }

                /// `Lane::lookup16`: one `vpermps` (16 lanes) or `vpermt2ps` (8 lanes,
                /// the table in two registers).
                #[inline(always)]
                pub(crate) fn lookup16(x: F, table: &[f32; 16]) -> F {
                    let a: $R = x.into();
                    // SAFETY: see the module documentation (`table` holds 16 values).
                    unsafe { ($lookup)(a, table) }.into()
                }

                /// `Lane::scale2_floor_or_zero`: `vscalefps` with a zeroing mask
                /// (`vcmpps` into a mask register, not-less-than: NaN kept).
                #[inline(always)]
                pub(crate) fn scalef_or_zero(x: F, e: F, y: F, lo: f32) -> F {
                    // SAFETY: see the module documentation.
                    unsafe {
                        let keep = $cmp_mask::<_CMP_NLT_UQ>(y.into(), $set1(lo));
                        $maskz_scalef(keep, x.into(), e.into())
                    }
                    .into()
                }

                /// AVX-512's estimate of 1/√x (`vrsqrt14ps`, relative error below
                /// 2⁻¹⁴; not a `Lane` method: its bits are not `vrsqrtps`').
                #[inline(always)]
                pub(crate) fn rsqrt14(x: F) -> F {
                    // SAFETY: see the module documentation.
                    unsafe { $rsqrt14(x.into()) }.into()
                }

                /// AVX-512's estimate of 1/x (`vrcp14ps`, relative error below 2⁻¹⁴;
                /// not a `Lane` method, like `rsqrt14`).
                #[inline(always)]
                pub(crate) fn rcp14(x: F) -> F {
                    // SAFETY: see the module documentation.
                    unsafe { $rcp14(x.into()) }.into()
                }
            }
        };
    }

    width!(
        x16,
        wide::f32x16,
        __m512,
        _mm512_getexp_ps,
        _mm512_getmant_ps,
        _mm512_scalef_ps,
        _mm512_rsqrt14_ps,
        _mm512_rcp14_ps,
        _mm512_maskz_scalef_ps,
        _mm512_cmp_ps_mask,
        _mm512_set1_ps,
        |a: __m512, t: &[f32; 16]| _mm512_permutexvar_ps(
            _mm512_castps_si512(a),
            _mm512_loadu_ps(t.as_ptr())
        )
    );
    width!(
        x8,
        wide::f32x8,
        __m256,
        _mm256_getexp_ps,
        _mm256_getmant_ps,
        _mm256_scalef_ps,
        _mm256_rsqrt14_ps,
        _mm256_rcp14_ps,
        _mm256_maskz_scalef_ps,
        _mm256_cmp_ps_mask,
        _mm256_set1_ps,
        |a: __m256, t: &[f32; 16]| _mm256_permutex2var_ps(
            _mm256_loadu_ps(t.as_ptr()),
            _mm256_castps_si256(a),
            _mm256_loadu_ps(t.as_ptr().add(8))
        ),
        cfg(target_feature = "avx512vl")
    );
}

#[cfg(test)]
mod tests {
    use super::Lane;
    use wide::{f32x16, f32x8};

    /// `keep` and `zero_where` against a plain per-lane oracle (`if c { v } else { +0 }`
    /// and the reverse, with the condition c formed in scalar f32): the same bits on
    /// every lane type with a `wide` mask (their own implementation there) and the
    /// scalar one, for masks from compares, NaN and signed zeros included.
    #[test]
    fn keep_is_select_with_zero() {
        let vals = [
            0.0f32,
            -0.0,
            1.5,
            -2.0,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            3e-31,
        ];
        // The three compares, lane by lane and in scalar f32.
        #[allow(clippy::eq_op)]
        fn masks<L: Lane>(v: L, lim: L) -> [L::Mask; 3] {
            [v.abs().ge(lim), v.lt(lim), v.eq(v)]
        }
        fn conds(v: f32, lim: f32) -> [bool; 3] {
            [v.abs() >= lim, v < lim, !v.is_nan()]
        }
        fn check<L: Lane>(lanes: &[f32], lim: f32) {
            let v = L::load(lanes);
            let mut out = [0.0f32; 16];
            for (k, m) in masks(v, L::splat(lim)).into_iter().enumerate() {
                for keep in [true, false] {
                    let r = if keep { v.keep(m) } else { v.zero_where(m) };
                    r.store(&mut out[..L::LANES]);
                    for (i, &x) in lanes[..L::LANES].iter().enumerate() {
                        let want = if conds(x, lim)[k] == keep { x } else { 0.0 };
                        assert_eq!(
                            out[i].to_bits(),
                            want.to_bits(),
                            "keep={keep} compare {k}: {x} against {lim}"
                        );
                    }
                }
            }
        }
        for &lim in &vals {
            for k in 0..vals.len() {
                let lanes: [f32; 16] = core::array::from_fn(|i| vals[(i + k) % vals.len()]);
                check::<f32>(&lanes, lim);
                check::<f32x8>(&lanes, lim);
                check::<f32x16>(&lanes, lim);
            }
        }
    }
}
