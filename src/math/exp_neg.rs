//! `exp_neg(x) = e^(-x)` for `x ≥ 0`: the transmittance from an optical depth.
//!
//! A table method with the multiply by log2(e) fused into the reduction and a two-part
//! table. With y = −x·log2(e) = m/8 + r, m an integer and |r| ≤ 1/16:
//! - one FMA of x with −log2(e) (as f32, `LOG2E_HI`) and 1.5·2^20 rounds y to a multiple
//!   of 1/8 and leaves j = m mod 8 in the sum's low mantissa bits (the table index);
//! - r' = −r = m/8 + x·LOG2E_HI + x·LOG2E_LO in two FMAs, the first exact but for one
//!   rounding of a number below 1/16 + 2⁻²⁰, the second adding the rest of log2(e)
//!   (`LOG2E_LO`, 1.9e-8: without it x·(log2 e − LOG2E_HI) would cost up to 3 ULP at
//!   x = 87); what is left of log2(e) (below 3e-16 relative) is negligible;
//! - 2^(j/8) = hi_j + lo_j from two 8-entry tables (hi rounded to nearest, lo the rest
//!   rounded), so the table value is exact to about 1e-15 instead of half an ULP (one
//!   table alone measured 1.005 ULP in a 16-entry form); 2^r = 1 − r'·P(−r') with P of
//!   degree 3, a Chebyshev fit on [−1/16, 1/16] (`tools/fit_poly.py`: 3.4e-10 relative
//!   with f32 coefficients, 0.006 ULP);
//! - (hi + lo)·(1 − q), q = r'·P, is gathered as `hi + fma(−q, hi, lo)` (lo·q, below 2⁻²⁹
//!   relative, dropped): one rounding of a small correction and one of the sum;
//! - then scaled by 2^⌊m/8⌋, exactly: on AVX-512 lanes by `vscalefps` with a zeroing mask
//!   that flushes the results of m/8 < −126 (x > 87.3) to +0; elsewhere by a multiply
//!   with 2^⌊m/8⌋ built from the sum's bits (`Lane::pow2_floor_round8`), whose factor is
//!   +0 for those same lanes once x is clamped to 88 (⌊m/8⌋ ≥ −127). The same bits
//!   either way; an absolute error below 2^-126 = 1.2e-38 where flushed.
//!
//! Eight entries, not sixteen: AVX2's `vpermps` indexes 8 (16 took two and a blend per
//! table), and the degree-3 polynomial on the wider interval costs one FMA.
//!
//! x below 2^-62 is taken as 2^-62 (the result is 1 either way, and r'·P stays normal:
//! subnormal operands cost microcode assists on some CPUs, a `stiff` batch 1.6× a typical
//! one on Zen 1 when an earlier form let them through). +inf gives 0, NaN gives NaN. No
//! branch on the data.
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≥ 0, +inf included; 8 lanes and scalar bit
//! for bit): max error 0.6208 ULP (at x = 1.436804) for results ≥ 2^-126, 0.17 % of them
//! over 0.5 ULP (the Cody–Waite form before: 0.943 ULP, 0.47 %); beyond, an absolute
//! error of at most 0.958 · 2^-126. AVX-512 lanes against scalar, bit for bit: every
//! 257th f32 (`Zmm` in the `math::zmm` tests, with every f32 in [86, 89] too; f32x16 in
//! `tests/lanes16.rs`).

use super::Lane;

/// log2(e) rounded to f32 (1.442695: the literal 1.442_695_1 rounds to the next f32 up,
/// which cost 120 ULP at x = 87 in a first version).
const LOG2E_HI: f32 = core::f32::consts::LOG2_E;
/// log2(e) − `LOG2E_HI`, rounded to f32.
const LOG2E_LO: f32 = 1.925_963e-8;

/// 1.5 · 2^20: in [2^20, 2^21) the f32 spacing is 1/8.
const ROUND8: f32 = 1_572_864.0;

/// Results of m/8 below this are flushed to +0.
const FLUSH_BELOW: f32 = -126.0;

/// The 8 values twice (`Lane::lookup8`'s layout).
const fn twice(t: [f32; 8]) -> [f32; 16] {
    [
        t[0], t[1], t[2], t[3], t[4], t[5], t[6], t[7], t[0], t[1], t[2], t[3], t[4], t[5], t[6],
        t[7],
    ]
}

/// 2^(j/8) rounded to nearest f32, j = 0 … 7 (`tools/fit_poly.py` prints both tables).
const TABLE_HI: [f32; 16] = twice([
    1.0,
    1.090_507_7,
    1.189_207_1,
    1.296_839_6,
    core::f32::consts::SQRT_2,
    1.542_210_8,
    1.681_792_9,
    1.834_008_1,
]);

/// 2^(j/8) − `TABLE_HI[j]`, rounded to nearest f32.
const TABLE_LO: [f32; 16] = twice([
    0.0,
    -1.307_754e-8,
    3.797_635_3e-8,
    -4.018_999_5e-8,
    2.420_323_5e-8,
    8.070_905e-9,
    -2.475_532_7e-8,
    -1.123_927_8e-8,
]);

/// 2^-62: smaller x give 1 either way.
const TINY: f32 = 2.168_404_3e-19;

/// `e^(-x)` for `x ≥ 0` (including `+inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp_neg<L: Lane>(x: L) -> L {
    // `maxps`/`minps`: NaN, the second operand, stays NaN.
    let x = L::splat(TINY).max(x);
    // Without the masked scale, x ≤ 88 keeps ⌊m/8⌋ ≥ −127 (see above) and makes +inf
    // finite; the masked scale needs no clamp.
    let x = if L::NATIVE_SCALE {
        x
    } else {
        L::splat(88.0).min(x)
    };
    let t = x.mul_add(L::splat(-LOG2E_HI), L::splat(ROUND8));
    let m8 = t - L::splat(ROUND8);
    // r' = m/8 + x·log2(e) = −r.
    let rn = x.mul_add(L::splat(LOG2E_HI), m8);
    let rn = x.mul_add(L::splat(LOG2E_LO), rn);
    let hi = t.lookup8(&TABLE_HI);
    let lo = t.lookup8(&TABLE_LO);
    // P(−r') = ln2 − c2·r' + c3·r'² − c4·r'³.
    let p = rn
        .mul_add(L::splat(-9.618_731e-3), L::splat(5.550_931_8e-2))
        .mul_add(rn, L::splat(-0.240_226_5))
        .mul_add(rn, L::splat(core::f32::consts::LN_2));
    let q = p * rn;
    let v = q.neg_mul_add(hi, lo) + hi;
    if L::NATIVE_SCALE {
        v.scale2_floor_or_zero(m8, m8, FLUSH_BELOW)
    } else {
        v * t.pow2_floor_round8()
    }
}
