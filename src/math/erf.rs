//! `erf(x)` and `erfc(x) = 1 − erf(x)` for f32 lanes. The Gaussian fog-volume profile
//! integrates to a difference of error functions; where both ends lie on the same side
//! of the centre it is formed as `erfc(a) − erfc(b)`, so the tails do not cancel.
//!
//! fdlibm's `erff`/`erfcf` (FreeBSD `s_erff.c`, Sun Microsystems' permissive notice),
//! made branch-free over [`Lane`]; each rational approximation is evaluated only where
//! some lane needs it (the scalar path evaluates one), which keeps scalar and x8
//! bit-identical. For a = |x|:
//! - a < 0.84375: `erf = x + x·P(x²)/Q(x²)` (erfc as `1 − erf`, or `0.5 − (x − 0.5 + x·y)`
//!   for 1/4 ≤ x, which is exact in the subtraction);
//! - 0.84375 ≤ a < 1.25: `erfc(a) = 1 − erx − P(s)/Q(s)`, s = a − 1;
//! - 1.25 ≤ a < 28: `erfc(a) = exp(−z² − 0.5625) · exp((z − a)(z + a) + R(1/a²)/S(1/a²)) / a`
//!   with `z` = a rounded to 11 significant bits (`z²` exact), two coefficient sets split
//!   at 1/0.35; the exponentials are this crate's [`exp`](fn@super::exp) (1 ULP);
//! - erfc(x < 0) = 2 − erfc(|x|); erf(a ≥ 6) = 1 (the true value rounds to 1);
//!   erfc(x ≥ 28) = 0 (the true value leaves the f32 range at x ≈ 10.05).
//!
//! Domain: all f32 (`erf(±inf) = ±1`, `erfc(+inf) = 0`, `erfc(−inf) = 2`, NaN for NaN).
//! Measured over every f32 (`tests/exhaustive_volume_math.rs`, against the `libm` crate's
//! f64 erf/erfc; x8 and scalar bit-identical): erf max error 0.86 ULP; erfc max error
//! 3.13 ULP where the result is normal (x < 9.19), and within 2048 · 2^-149 absolute
//! where it is subnormal. Asserted bounds: 1 and 4 ULP.

use super::{exp, Lane};

const ERX: f32 = 8.450_629_115_1e-1;
const EFX8: f32 = 1.027_033_329_0;
const PP: [f32; 5] = [
    1.283_791_661_3e-1,
    -3.250_420_987_6e-1,
    -2.848_174_981_8e-2,
    -5.770_270_247_0e-3,
    -2.376_301_745_2e-5,
];
const QQ: [f32; 5] = [
    3.979_172_110_6e-1,
    6.502_225_250_0e-2,
    5.081_306_211_7e-3,
    1.324_947_370_4e-4,
    -3.960_228_241_3e-6,
];
const PA: [f32; 7] = [
    -2.362_118_568_3e-3,
    4.148_561_060_4e-1,
    -3.722_078_800_2e-1,
    3.183_466_196_1e-1,
    -1.108_946_949_2e-1,
    3.547_830_507_2e-2,
    -2.166_375_517_8e-3,
];
const QA: [f32; 6] = [
    1.064_208_820_5e-1,
    5.403_979_420_7e-1,
    7.182_865_589_9e-2,
    1.261_712_163_7e-1,
    1.363_708_358_3e-2,
    1.198_450_010_3e-2,
];
const RA: [f32; 8] = [
    -9.864_944_033_3e-3,
    -6.938_585_639_0e-1,
    -1.055_862_617_5e1,
    -6.237_533_187_9e1,
    -1.623_966_674_8e2,
    -1.846_050_872_8e2,
    -8.128_743_743_9e1,
    -9.814_329_147_3,
];
const SA: [f32; 8] = [
    1.965_127_182_0e1,
    1.376_577_606_2e2,
    4.345_658_874_5e2,
    6.453_872_680_7e2,
    4.290_081_481_9e2,
    1.086_350_021_4e2,
    6.570_249_557_5,
    -6.042_441_353_2e-2,
];
const RB: [f32; 7] = [
    -9.864_943_102_0e-3,
    -7.992_832_660_7e-1,
    -1.775_795_555_1e1,
    -1.606_363_830_6e2,
    -6.375_664_672_9e2,
    -1.025_095_092_8e3,
    -4.835_191_955_6e2,
];
const SB: [f32; 7] = [
    3.033_806_037_9e1,
    3.257_925_109_9e2,
    1.536_729_614_3e3,
    3.199_858_154_3e3,
    2.553_050_293_0e3,
    4.745_285_339_4e2,
    -2.244_095_230_1e1,
];

/// Horner: `c[0] + s·(c[1] + s·(…))`.
#[inline(always)]
fn horner<L: Lane>(c: &[f32], s: L) -> L {
    let n = c.len();
    let mut r = L::splat(c[n - 1]);
    for i in (0..n - 1).rev() {
        r = r.mul_add(s, L::splat(c[i]));
    }
    r
}

/// `1 + s·(c[0] + s·(c[1] + …))`.
#[inline(always)]
fn horner1<L: Lane>(c: &[f32], s: L) -> L {
    horner(c, s).mul_add(s, L::splat(1.0))
}

/// `y = P(x²)/Q(x²)` of the range |x| < 0.84375: erf(x) = x + x·y.
#[inline(always)]
fn small_y<L: Lane>(x: L) -> L {
    let z = x * x;
    horner(&PP, z) / horner1(&QQ, z)
}

/// `P(s)/Q(s)` of the range [0.84375, 1.25), s = a − 1.
#[inline(always)]
fn mid_pq<L: Lane>(a: L) -> L {
    let s = a - L::splat(1.0);
    horner(&PA, s) / horner1(&QA, s)
}

/// erfc(a) for a in [1.25, 28) (any a > 0 is safe to pass: the result is then unused).
#[inline(always)]
fn tail<L: Lane>(a: L) -> L {
    let a = a.clamp(L::splat(1.25), L::splat(28.0));
    let s = L::splat(1.0) / (a * a);
    let lo = a.lt(L::splat(1.0 / 0.35));
    let (r, big_s) = if !L::any(lo) {
        (horner(&RB, s), horner1(&SB, s))
    } else if !L::any(!lo) {
        (horner(&RA, s), horner1(&SA, s))
    } else {
        (
            L::select(lo, horner(&RA, s), horner(&RB, s)),
            L::select(lo, horner1(&SA, s), horner1(&SB, s)),
        )
    };
    // z: a rounded to 11 significant bits (a < 32, so a multiple of 2^-6): z² is exact.
    let z = (a * L::splat(64.0)).round() * L::splat(1.0 / 64.0);
    let e1 = exp(z.mul_add(z.neg(), L::splat(-0.5625)));
    let e2 = exp((z - a).mul_add(z + a, r / big_s));
    e1 * e2 / a
}

/// `erfc(|x|)` for |x| ≥ 0.84375 (the value for smaller |x| is unspecified), with the
/// ranges evaluated only where some lane needs them.
#[inline(always)]
fn erfc_abs_large<L: Lane>(a: L) -> L {
    let mid = a.lt(L::splat(1.25));
    let mut r = L::splat(0.0);
    if L::any(mid) {
        r = L::splat(1.0 - ERX) - mid_pq(a);
    }
    if L::any(!mid) {
        r = L::select(mid, r, tail(a));
    }
    r
}

/// `erf(x)`, max error 0.86 ULP (every f32).
#[inline(always)]
pub fn erf<L: Lane>(x: L) -> L {
    let a = x.abs();
    let small = a.lt(L::splat(0.84375));
    let mut r = L::splat(0.0);
    if L::any(small) {
        let y = small_y(x);
        let tiny = a.lt(L::splat(3.725_290_3e-9)); // 2^-28: avoid underflow in x·y
        let v = L::select(
            tiny,
            L::splat(0.125) * L::splat(8.0).mul_add(x, L::splat(EFX8) * x),
            x.mul_add(y, x),
        );
        r = L::select(small, v, r);
    }
    let large = !small;
    if L::any(large) {
        let mid = a.lt(L::splat(1.25));
        let mut v = L::splat(0.0);
        if L::any(mid & large) {
            v = L::splat(ERX) + mid_pq(a);
        }
        let tl = large & !mid & a.lt(L::splat(6.0));
        if L::any(tl) {
            v = L::select(mid, v, L::splat(1.0) - tail(a));
        }
        // a ≥ 6 (or inf): 1 (the true value rounds to 1).
        v = L::select(a.ge(L::splat(6.0)), L::splat(1.0), v);
        r = L::select(small, r, v.copysign(x));
    }
    // NaN: every comparison above was false, so r is 1 with x's sign; put NaN back.
    L::select(x.eq(x), r, x)
}

/// `erfc(x) = 1 − erf(x)`, max error 3.13 ULP for normal results (every f32).
#[inline(always)]
pub fn erfc<L: Lane>(x: L) -> L {
    let one = L::splat(1.0);
    let a = x.abs();
    let small = a.lt(L::splat(0.84375));
    let mut r = L::splat(0.0);
    if L::any(small) {
        let y = small_y(x);
        let quarter = x.ge(L::splat(0.25));
        let v = L::select(
            quarter,
            L::splat(0.5) - (x - L::splat(0.5) + x * y),
            one - x.mul_add(y, x),
        );
        r = L::select(small, v, r);
    }
    let large = !small;
    if L::any(large) {
        let c = erfc_abs_large(a);
        let c = c.zero_where(a.ge(L::splat(28.0)));
        let v = L::select(x.lt(L::splat(0.0)), L::splat(2.0) - c, c);
        r = L::select(small, r, v);
    }
    L::select(x.eq(x), r, x)
}
