//! `ldexp`: `m * 2^e` with saturation, for the end of a mantissa/exponent computation;
//! `ldexp_no_subnormal`, the same bits without a subnormal floating-point result.

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

/// 2^23: the least subnormal's reciprocal times the least normal, 2^-126 / 2^-149.
const TWO23: f32 = 8_388_608.0;

/// [`ldexp`] with the same bits for the same inputs (|m| in [2^-62, 2^39] or 0, `e`
/// integer-valued and finite), where no floating-point operation has a subnormal result:
/// a subnormal result is formed from the bits of an integer instead. On x86, a multiply
/// or `vscalefps` whose result is subnormal costs a microcode assist (on the Intel Xeon
/// of the forty-ninth session, batches with τ below 2^-126 took 3 to 14× the time of
/// typical ones: `SCALE=1e-36 OUT=tau examples/speedscan`), so the kernels take this
/// where some lane of a block may have such a result, and [`ldexp`] elsewhere.
///
/// z = |m|·2^(e+149) is the result in units of the least subnormal, 2^-149: exact and
/// normal (its exponent clamped to [−60, 100], where |m|·2^-60 ≤ 2^-21 still rounds to 0
/// and |m|·2^100 ≥ 2^38 still counts as normal). Where z < 2^23 (a result below 2^-126),
/// z + 2^23 rounds z to an integer (ties to even, as the product rounds into the
/// subnormal range) and keeps it in its low 24 bits, the bits of the subnormal result
/// (2^24 from a z that rounds up to 2^23 gives 2^-126's); the sign is m's. Elsewhere the
/// result is `ldexp(m, e)`, which there has a normal (or infinite) result, and the
/// subnormal lanes take `ldexp(m, 0)` instead of forming theirs.
#[inline(always)]
pub fn ldexp_no_subnormal<L: Lane>(m: L, e: L) -> L {
    let k = (e + L::splat(149.0)).clamp(L::splat(-60.0), L::splat(100.0));
    let z = m.abs() * L::pow2i(k);
    let tiny = z.lt(L::splat(TWO23));
    let sub = (z + L::splat(TWO23)).and_bits(0x00ff_ffff).copysign(m);
    let normal = ldexp(m, e.zero_where(tiny));
    L::select(tiny, sub, normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use wide::{f32x16, f32x8};

    /// `ldexp_no_subnormal` gives `ldexp`'s bits (scalar, 8 and 16 lanes) for mantissas
    /// across the domain, both signs and zeros, and every exponent from −420 to 420 (every
    /// subnormal result's rounding, ties included: mantissas with few low bits set) and
    /// far beyond; `tests/exhaustive.rs` checks every mantissa of the domain.
    #[test]
    fn no_subnormal_gives_ldexp_bits() {
        let mut ms = vec![0.0f32, -0.0, 2f32.powi(-62), 2f32.powi(39), 1.5, 1.75, 1.0];
        let mut x = 2f32.powi(-62);
        while x < 2f32.powi(39) {
            ms.extend([x, -x, x * 1.000_000_1, x * 1.499_999_9, x * 1.5, x * 1.75]);
            x *= 1.618;
        }
        let es: Vec<f32> = (-420..=420)
            .map(|e| e as f32)
            .chain([-1e30, -3e38, 1e30, 3e38, -2_147_483_648.0])
            .collect();
        for &m in &ms {
            for es8 in es.chunks(8) {
                let mut e8 = [0.0f32; 8];
                e8[..es8.len()].copy_from_slice(es8);
                let z8 = ldexp_no_subnormal(f32x8::splat(m), f32x8::new(e8)).to_array();
                let mut e16 = [0.0f32; 16];
                e16[..8].copy_from_slice(&e8);
                let z16 = ldexp_no_subnormal(f32x16::splat(m), f32x16::new(e16)).to_array();
                for (l, &e) in es8.iter().enumerate() {
                    let want = ldexp(m, e).to_bits();
                    let z = ldexp_no_subnormal(m, e).to_bits();
                    assert!(
                        z == want && z8[l].to_bits() == want && z16[l].to_bits() == want,
                        "{m:e} {e}: {z:#x} {:#x} {:#x}, want {want:#x}",
                        z8[l].to_bits(),
                        z16[l].to_bits()
                    );
                }
            }
        }
    }
}
