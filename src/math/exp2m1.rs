//! `exp2m1(y) = 2^y − 1` for f32 lanes, accurate near 0 where `2^y − 1` cancels: the
//! framebuffer pass's E(Δ) = expm1(−Δ)/(−Δ), with the falloff pre-scaled by log2(e) so
//! that the argument arrives in base 2.
//!
//! Reduction: `k = round(y)` (ties to even), `f = y − k` in [−1/2, 1/2], both exact (no
//! multiply by log2(e), no Cody–Waite split: two FMAs fewer than
//! [`expm1`](fn@super::expm1)); f and 2^(k−1) from [`Lane::round_frac_pow2i_half`] (an
//! add, two subtracts and a shift; on AVX-512 lanes `vreduceps`, a subtract and
//! `vscalefps`). Polynomial: `2^f − 1 = f·P(f)`, `P` of degree 5, a Chebyshev fit whose
//! f32 coefficients were then moved by a few ULP each to the smallest maximum error
//! (`tools/fit_poly.py`; max relative error 1.64e-8, 0.28 ULP; degree 6, until the
//! forty-fifth session, had 5.6e-9 for one multiply-add more per value). The coefficients
//! are stored doubled (exact), to make up for the 2^(k−1). Reconstruction:
//! `2^y − 1 = f·(2^k·P(f)) + (2^k − 1)`, one FMA with 2^k·P(f) exact; k = 0 returns
//! `f·P(f)` rounded once (tiny inputs come back as `y·ln2`). The argument is clamped to
//! [−64, 127], so 2^(k−1) is always a normal f32 and nothing overflows: `−1` below −64
//! (what 2^y − 1 rounds to there), and above 127 the value at 127, 2^127 (callers that
//! need `+inf` beyond must clamp themselves; the pass's ranges make E saturate T to 0 well
//! before). No branch.
//!
//! Measured (`tests/exhaustive.rs`, every f32): max error 1.782 ULP (at y = 0.54805607,
//! where k = 1 and 2·(2^f − 1) + 1 cancels a little; 1.685 with degree 6), 7.5 % of the
//! inputs in [−64, 127] over 0.5 ULP; −1 exactly below −64, 2^127 above 127.

use super::Lane;

/// `2^y − 1` for `y` in [−64, 127] (clamped outside); NaN for NaN.
#[inline(always)]
pub fn exp2m1<L: Lane>(y: L) -> L {
    // `maxps`/`minps` with y second: NaN stays NaN.
    exp2m1_in_range(L::splat(127.0).min(L::splat(-64.0).max(y)))
}

/// [`exp2m1`] without its clamp, for callers whose arguments are already within
/// [−64.5, 127.25] (the pass's rows of constant b·u clamp t instead: two operations fewer
/// per packet). There k ∈ [−64, 127], 2^(k−1) is a normal f32 and 2^k − 1 finite (from
/// 127.5 on, k = 128 and 2^k − 1 overflows); the same bits as [`exp2m1`] within
/// [−64, 127].
#[inline(always)]
pub fn exp2m1_in_range<L: Lane>(y: L) -> L {
    // f = y − k, h = 2^(k−1): the polynomial's coefficients are doubled (exact) to make up.
    let (f, h) = y.round_frac_pow2i_half();
    let p = L::splat(3.090_619_6e-4)
        .mul_add(f, L::splat(0.002_678_177_6))
        .mul_add(f, L::splat(0.019_236_14))
        .mul_add(f, L::splat(0.111_007_21))
        .mul_add(f, L::splat(0.480_453))
        .mul_add(f, L::splat(2.0 * core::f32::consts::LN_2));
    // 2^(k−1)·p = 2^k·P(f) is exact (a normal number scaled by a power of two), so P is
    // the only rounded factor before the final FMA (f subnormal included), and
    // 2^(k−1)·2 − 1 = 2^k − 1 is rounded once.
    f.mul_add(h * p, h.mul_add(L::splat(2.0), L::splat(-1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use wide::f32x8;

    /// `exp2m1_in_range` against `exp2m1` (same bits) on a stride through [−64, 127], and
    /// in its margins [−64.5, −64) and (127, 127.25] (every f32 there: −1 exactly below,
    /// within 2 ULP of 2^y − 1 above, finite); `tests/exhaustive.rs` checks every f32.
    #[test]
    fn in_range_matches_and_covers_its_margins() {
        let mut x = -64.0f32;
        while x <= 127.0 {
            let v = f32x8::splat(x);
            assert_eq!(exp2m1_in_range(v).to_array(), exp2m1(v).to_array(), "{x}");
            x += 0.013;
        }
        let mut x = -64.5f32;
        while x < -64.0 {
            assert_eq!(exp2m1_in_range(x), -1.0, "{x}");
            x = x.next_up();
        }
        let mut x = 127.0f32.next_up();
        while x <= 127.25 {
            let z = exp2m1_in_range(x);
            let r = (f64::from(x) * core::f64::consts::LN_2).exp_m1();
            let ulp = f64::from((z.abs().next_up() - z.abs()).max(f32::MIN_POSITIVE));
            assert!(
                z.is_finite() && (f64::from(z) - r).abs() <= 2.0 * ulp,
                "{x}: {z}, {r}"
            );
            x = x.next_up();
        }
    }

    /// −1 exactly for every f32 in [−64.5, −25.5) (k ≤ −26: 2^k − 1 rounds to −1 and
    /// f·2^k·P(f) is below half its spacing), at 8 lanes and, with AVX-512, on `Zmm`
    /// lanes: the pass's rows looking up skip `exp2m1` there (`pass::height::FLAT_Y`).
    #[test]
    fn minus_one_below_minus_25_5() {
        let (lo, hi) = ((-25.5f32).to_bits() + 1, (-64.5f32).to_bits());
        let xs: Vec<f32> = (lo..=hi).map(f32::from_bits).collect();
        assert!(xs[0] < -25.5 && xs[xs.len() - 1] == -64.5);
        for chunk in xs.chunks(16) {
            let mut a = [-64.5f32; 16];
            a[..chunk.len()].copy_from_slice(chunk);
            let mut z = [0.0f32; 8];
            for h in 0..2 {
                exp2m1_in_range(<f32x8 as Lane>::load(&a[8 * h..])).store(&mut z);
                assert!(z.iter().all(|&z| z == -1.0), "{:?}: {z:?}", &a[8 * h..]);
            }
            #[cfg(any(zmm_dispatch, zmm_native))]
            if crate::math::avx512_detected() {
                use crate::math::zmm::Zmm;
                let mut z = [0.0f32; 16];
                exp2m1_in_range(Zmm::load(&a)).store(&mut z);
                assert!(z.iter().all(|&z| z == -1.0), "{a:?}: {z:?}");
            }
        }
        assert_eq!(exp2m1_in_range((-25.5f32).next_down()), -1.0);
        // A check that can fail: 2^-24 − 1 is an f32 above −1.
        assert!(exp2m1_in_range(f32x8::splat(-24.0)).to_array()[0] > -1.0);
    }
}
