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
//! - 2^(j/8) = hi_j·(1 + c_j) from two 8-entry tables (hi rounded to nearest, c_j =
//!   lo_j/hi_j rounded, lo_j the rest), so the table value is exact to about 1e-15
//!   instead of half an ULP (one table alone measured 1.005 ULP in a 16-entry form);
//!   2^r = 1 − r'·P(−r') with P of degree 3, a Chebyshev fit on [−1/16, 1/16]
//!   (`tools/fit_poly.py`: 3.4e-10 relative with f32 coefficients, 0.006 ULP);
//! - hi·(1 + c)·(1 − q), q = r'·P, is gathered as `fma(−fma(P, r', −c), hi, hi)` (c·q,
//!   below 2⁻²⁹ relative, dropped): one rounding of the small q − c and one of the
//!   result. (Until the sixty-third session `hi + fma(−q, hi, lo)` with the table of lo:
//!   one operation more per exponential, three per ray in the RGB kernels, and 0.6208
//!   ULP, 0.17 % over 0.5, where this form measures 0.5982 and 0.14 %.)
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
//! for bit): max error 0.5982 ULP (at x = 2.8130124) for results ≥ 2^-126, 0.14 % of them
//! over 0.5 ULP (the Cody–Waite form before the table: 0.943 ULP, 0.47 %); beyond, an absolute
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

/// (2^(j/8) − `TABLE_HI[j]`) / `TABLE_HI[j]`, rounded to nearest f32 (`tools/fit_poly.py`):
/// the table's low part relative to its high part, subtracted from q in the FMA that
/// forms q, so that one FMA gathers the result (see the module's header).
const TABLE_LO_REL: [f32; 16] = twice([
    0.0,
    -1.199_215_75e-8,
    3.193_418e-8,
    -3.099_072e-8,
    1.711_427_1e-8,
    5.233_334e-9,
    -1.471_960_5e-8,
    -6.128_259_7e-9,
]);

/// 2^-62: smaller x give 1 either way.
const TINY: f32 = 2.168_404_3e-19;

/// `e^(-x)` for `x ≥ 0` (including `+inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp_neg<L: Lane>(x: L) -> L {
    // Without the masked scale, x ≤ 88 keeps ⌊m/8⌋ ≥ −127 (see above) and makes +inf
    // finite; the masked scale needs no clamp.
    reduce_and_scale(x, LOG2E_HI, LOG2E_LO, 88.0)
}

/// The factor κ of [`exp_neg_mul`], prepared: κ·log2(e) in two f32 parts (rounded from
/// f64) and the clamp of x for lanes without the masked scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExpNegMul {
    hi: f32,
    lo: f32,
    x_max: f32,
}

impl ExpNegMul {
    /// κ = 0 or 2⁻⁶⁴ ≤ κ ≤ 2³²; `None` outside (or for NaN).
    pub fn new(kappa: f32) -> Option<ExpNegMul> {
        let ok = kappa == 0.0 || (2f32.powi(-64)..=2f32.powi(32)).contains(&kappa);
        if !ok {
            return None;
        }
        let k = f64::from(kappa) * core::f64::consts::LOG2_E;
        let hi = k as f32;
        Some(ExpNegMul {
            hi,
            lo: (k - f64::from(hi)) as f32,
            // x·κ·log2(e) ≤ 126.5 (126.5 ± 2⁻¹⁷ once rounded): m/8 ≤ −126.5 is flushed
            // and ⌊m/8⌋ ≥ −127 (see the module's header); every larger x is flushed too.
            x_max: if hi == 0.0 {
                f32::INFINITY
            } else {
                (126.5 / f64::from(hi)) as f32
            },
        })
    }
}

/// κ = 0: `exp_neg_mul` gives 1 for every finite x (NaN for ±inf·0 and NaN).
impl Default for ExpNegMul {
    fn default() -> ExpNegMul {
        ExpNegMul {
            hi: 0.0,
            lo: 0.0,
            x_max: f32::INFINITY,
        }
    }
}

/// `e^(-x·κ)` for `x ≥ 0` (`+inf` gives 0 for κ > 0, NaN gives NaN), the product taken
/// exactly:
/// [`exp_neg`]'s code with κ·log2(e) in place of log2(e), so no rounding of x·κ before
/// the exponential (the kernels' T straight from the geometric depth, one multiply per
/// channel fewer). With [`ExpNegMul::new`]'s domain, x·κ < 2⁻²⁵ where x is clamped to
/// 2⁻⁶², so that clamp gives 1 as the exact value does. The same bits in every lane type.
///
/// Measured (`exp_neg_mul_sweep` in `tests/exhaustive.rs`, 8 lanes and scalar bit for
/// bit): 10 factors from 2⁻⁶⁴ to 2³², every x with x·κ in [2⁻⁶, 104], max 0.6020 ULP (at
/// κ = 1.9999999, x = 1.9979447e-2) for results ≥ 2^-126, 1.3 % of them over 0.5 ULP, an
/// absolute error of at most 0.958 · 2^-126 below; 4096 random factors in [2⁻¹⁶, 2) with
/// 2^17 random x each, max 0.6035 ULP (0.6040 with `EXP_NEG_MUL_FACTORS=65536`). The
/// sweep asserts 0.62: not every factor was tried. (The form with the table of lo
/// before the sixty-third session: 0.6265, 0.6294 and 0.6301.) κ = 1 gives `exp_neg`'s bits (`math::exp_neg::tests`).
#[inline(always)]
pub fn exp_neg_mul<L: Lane>(x: L, k: ExpNegMul) -> L {
    reduce_and_scale(x, k.hi, k.lo, k.x_max)
}

/// e^(−x·κ) with κ·log2(e) = `k_hi` + `k_lo`; lanes without the masked scale clamp x to
/// `x_max`, at which x·k_hi lies in (126.125, 127].
#[inline(always)]
fn reduce_and_scale<L: Lane>(x: L, k_hi: f32, k_lo: f32, x_max: f32) -> L {
    // `maxps`/`minps`: NaN, the second operand, stays NaN.
    let x = L::splat(TINY).max(x);
    let x = if L::NATIVE_SCALE {
        x
    } else {
        L::splat(x_max).min(x)
    };
    let t = x.mul_add(L::splat(-k_hi), L::splat(ROUND8));
    let m8 = t - L::splat(ROUND8);
    // r' = m/8 + x·κ·log2(e) = −r.
    let rn = x.mul_add(L::splat(k_hi), m8);
    let rn = x.mul_add(L::splat(k_lo), rn);
    let hi = t.lookup8(&TABLE_HI);
    let lo_rel = t.lookup8(&TABLE_LO_REL);
    // P(−r') = ln2 − c2·r' + c3·r'² − c4·r'³.
    let p = rn
        .mul_add(L::splat(-9.618_731e-3), L::splat(5.550_931_8e-2))
        .mul_add(rn, L::splat(-0.240_226_5))
        .mul_add(rn, L::splat(core::f32::consts::LN_2));
    // hi·(1 − (q − lo/hi)) = hi + lo − hi·q.
    let q = p.mul_sub(rn, lo_rel);
    let v = q.neg_mul_add(hi, hi);
    if L::NATIVE_SCALE {
        v.scale2_floor_or_zero(m8, m8, FLUSH_BELOW)
    } else {
        v * t.pow2_floor_round8()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wide::f32x8;

    /// κ = 1 is `exp_neg`, bit for bit (its constants from f64 are `LOG2E_HI`/`LOG2E_LO`).
    #[test]
    fn exp_neg_mul_of_one_is_exp_neg() {
        let k = ExpNegMul::new(1.0).unwrap();
        assert_eq!((k.hi, k.lo), (LOG2E_HI, LOG2E_LO));
        for b in (0..=0x7f80_0000u32).step_by(97).chain([0x7fc0_0000]) {
            let x = f32::from_bits(b);
            let (a, e) = (exp_neg_mul(x, k), exp_neg(x));
            assert!(
                a.to_bits() == e.to_bits() || (a.is_nan() && e.is_nan()),
                "{x:e}"
            );
            let a8 = exp_neg_mul(f32x8::splat(x), k).to_array()[3];
            assert!(
                a8.to_bits() == e.to_bits() || (a8.is_nan() && e.is_nan()),
                "{x:e}"
            );
        }
    }

    /// The domain of `ExpNegMul::new`, and κ = 0 (the default) giving 1.
    #[test]
    fn factor_domain() {
        for k in [-1.0, 1e-30, 1e10, f32::INFINITY, f32::NAN, -0.0] {
            assert_eq!(ExpNegMul::new(k).is_some(), k == 0.0, "{k:e}");
        }
        let zero = ExpNegMul::new(0.0).unwrap();
        assert_eq!(zero, ExpNegMul::default());
        for x in [0.0, 1.0, 1e30, f32::MAX] {
            assert_eq!(exp_neg_mul(x, zero), 1.0, "{x:e}");
        }
        assert!(exp_neg_mul(f32::NAN, zero).is_nan());
        assert!(exp_neg_mul(f32::INFINITY, zero).is_nan());
        let small = ExpNegMul::new(2f32.powi(-64)).unwrap();
        assert_eq!(exp_neg_mul(f32::MAX, small), 0.0);
        assert_eq!(exp_neg_mul(f32::INFINITY, small), 0.0);
        assert_eq!(exp_neg_mul(2f32.powi(30), small), 1.0);
    }
}
