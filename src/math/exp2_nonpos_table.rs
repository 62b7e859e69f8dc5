//! `exp2_nonpos_table(y) = 2^y` for `y ≤ 0`, the table-driven form of
//! [`exp2_nonpos`](fn@super::exp2_nonpos) for lanes where a 16-entry table lookup and a
//! masked scale by a power of two are one instruction each (AVX-512: `vpermps` or
//! `vpermt2ps`, and `vscalefps` with a zeroing mask; other lane types take the same
//! steps lane by lane, with the same bits, for the tests). The framebuffer pass's
//! transmittance on such lanes.
//!
//! y = m/16 + r with m = round(16·y) and |r| ≤ 1/32: one add of 1.5·2^19 rounds y to a
//! multiple of 1/16 and leaves m's low 4 bits, j = m mod 16, in the sum's low mantissa
//! bits, which index the table of 2^(j/16) directly (`vpermps` reads those 4 bits);
//! `vscalefps` multiplies by 2^⌊m/16⌋ (it takes the floor of its exponent operand, so
//! m/16 itself serves). 2^r = 1 + r·P(r), P of degree 2, a Chebyshev fit on
//! [−1/32, 1/32] (`tools/fit_poly.py`; max relative error with f32 coefficients 2.4e-9,
//! 0.04 ULP). The result is 2^(j/16) + 2^(j/16)·(r·P(r)), one fused multiply-add, then
//! scaled exactly. 11 operations against `exp2_nonpos`'s 14 (no degree-5 polynomial, no
//! shift and multiply for 2^k, no lower clamp: the zeroing mask replaces it), and a
//! shorter dependency chain.
//!
//! Results of y below −126 are flushed to +0 by the mask (an absolute error below
//! 2^-126 = 1.2e-38 there), so the only subnormal results are those of y in
//! [−126, −126 + 1/32), where m/16 = −126 and r < 0: `vscalefps` producing subnormals or
//! underflowing to 0 for every y below −126 took the pass 3× as long (microcode assists,
//! the Intel Xeon of the thirty-sixth session). y above −2^-60 is taken as −2^-60 (the
//! result is 1 either way; r·P(r) stays normal). −inf gives 0, NaN gives NaN. No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32 ≤ 0, −inf included): see
//! `EXP2_NONPOS_TABLE_MAX_ULP` there and the README's accuracy table.

use super::Lane;

/// 2^(j/16), j = 0 … 15, each rounded to nearest f32 (the shortest decimals that give
/// those f32; a wrong digit in one entry showed as 1.94 ULP in the exhaustive sweep).
const TABLE: [f32; 16] = [
    1.0,
    1.044_273_7,
    1.090_507_7,
    1.138_788_6,
    1.189_207_1,
    1.241_857_8,
    1.296_839_6,
    1.354_255_6,
    core::f32::consts::SQRT_2,
    1.476_826_2,
    1.542_210_8,
    1.610_490_3,
    1.681_792_9,
    1.756_252_2,
    1.834_008_1,
    1.915_206_6,
];

/// 1.5 · 2^19: in [2^19, 2^20) the f32 spacing is 1/16.
const ROUND16: f32 = 786_432.0;

/// Results of y below this are flushed to +0.
const FLUSH_BELOW: f32 = -126.0;

/// `2^y` for `y ≤ 0` (including `−inf`, which gives 0); NaN for NaN.
#[inline(always)]
pub fn exp2_nonpos_table<L: Lane>(y: L) -> L {
    // `minps`: NaN, the second operand, stays NaN.
    let y = L::splat(-8.673_617e-19).min(y); // −2^-60
    let t = y + L::splat(ROUND16);
    let m16 = t - L::splat(ROUND16);
    let r = y - m16;
    let tab = t.lookup16(&TABLE);
    let p = r
        .mul_add(L::splat(0.055_505_086), L::splat(0.240_233_56))
        .mul_add(r, L::splat(core::f32::consts::LN_2));
    let q = p * r;
    q.mul_add(tab, tab)
        .scale2_floor_or_zero(m16, y, FLUSH_BELOW)
}

/// `2^(k·g)` for `k·g ≤ 0`, the product fused into the reduction: the framebuffer pass's
/// transmittance T = 2^(k2·g') on AVX-512 lanes. m = round(16·k·g) from one FMA with
/// 1.5·2^19 and −r = m/16 − k·g from another, both of the exact product, so the only
/// rounding before the polynomial is that of r itself (relative 2⁻²⁴). The product is
/// never rounded, which [`exp2_nonpos_table`]`(k·g)` pays with up to |k·g|·ln2/2 ULP
/// more; and the multiply and the upper clamp are gone (9 operations and the compare
/// against 12). r is carried negated so that no negation is needed: 2^r = 1 − r'·P(−r'),
/// P's odd coefficient negated; with g = 1 and k in [−126, −2⁻⁶⁰] the bits are
/// `exp2_nonpos_table`'s.
///
/// Precondition: k·g ≤ 0 or NaN (the pass: k2 ≤ 0, g' ≥ 0; a positive product gives a
/// wrong value, never a panic). The mask tests m/16, not the product: results for k·g
/// below −126 − 1/32 (m/16 < −126) are flushed to +0, an absolute error below 2^-126;
/// those of k·g in [−126 − 1/32, −126) are subnormal, the only ones. −inf gives 0, NaN
/// gives NaN. Measured by `tests/exhaustive.rs` (`exp2_nonpos_table_mul_products`): the
/// bits of `exp2_nonpos_table` for g = 1 on every 4099th f32 in [−126, −2⁻⁶⁰], and 2²²
/// pseudo-random products against f64's 2^(k·g) of the exact product: max 0.9945 ULP
/// (bound 1.0) for normal results, below 0.98·2⁻¹²⁶ absolute under them.
#[inline(always)]
pub fn exp2_nonpos_table_mul<L: Lane>(k: L, g: L) -> L {
    exp2_nonpos_table_mul_with(k, g, &TableMulConsts::new())
}

/// The constants of [`exp2_nonpos_table_mul`] as lanes, for callers that set where they
/// are formed: the pass makes them opaque (`core::hint::black_box`) before its loop of
/// T, so that LLVM does not hoist them to the entry of the whole row function, where its
/// other loops left no registers for them and the loop of T loaded four of them again
/// in every packet (README "Zen 4, fifty-sixth session").
#[derive(Clone, Copy)]
pub struct TableMulConsts<L> {
    round16: L,
    c2: L,
    c1: L,
    ln2: L,
}

impl<L: Lane> TableMulConsts<L> {
    /// The constants.
    #[inline(always)]
    pub fn new() -> Self {
        TableMulConsts {
            round16: L::splat(ROUND16),
            c2: L::splat(0.055_505_086),
            c1: L::splat(-0.240_233_56),
            ln2: L::splat(core::f32::consts::LN_2),
        }
    }
}

impl<L: Lane> Default for TableMulConsts<L> {
    fn default() -> Self {
        Self::new()
    }
}

/// [`exp2_nonpos_table_mul`] with its constants given (the same bits).
#[inline(always)]
pub fn exp2_nonpos_table_mul_with<L: Lane>(k: L, g: L, c: &TableMulConsts<L>) -> L {
    let t = k.mul_add(g, c.round16);
    let m16 = t - c.round16;
    // r' = m/16 − k·g = −r. (g negated, not k: LLVM hoists the negation of a
    // loop-invariant k out of the pass's loops and holds −k in three more registers,
    // where g's folds into `vfnmadd`.)
    let rn = g.neg_mul_add(k, m16);
    let tab = t.lookup16(&TABLE);
    let p = rn.mul_add(c.c2, c.c1).mul_add(rn, c.ln2);
    let q = p * rn;
    q.neg_mul_add(tab, tab)
        .scale2_floor_or_zero(m16, m16, FLUSH_BELOW)
}
