//! Fuzzes the SIMD special functions of `analytic_fog::math` on arbitrary f32 bit patterns
//! (NaN, ±inf, subnormals included):
//!
//! - the `wide::f32x8` and scalar `f32` instantiations give the same bits, NaN included;
//! - `exp`: NaN exactly for NaN, else ≥ 0, within its exhaustively measured ULP bound of
//!   f64 `exp` (+inf above 88.72, 0 below -103.98, ±inf → +inf / 0);
//! - `expm1`: NaN exactly for NaN, else ≥ -1, the sign of x, within its ULP bound;
//! - `exp_neg` (x >= 0): NaN exactly for NaN, within its ULP bound for results >= 2^-126,
//!   below 2^-126 absolute error beyond;
//! - `exp_neg_mul` (x >= 0, a factor κ from the input's bits where `ExpNegMul::new`
//!   takes it): e^(−x·κ) of the exact product, as `exp_neg`; NaN exactly for NaN x (and
//!   for +inf x with κ = 0);
//! - `exprel_neg` (x >= 2^-60): NaN exactly for NaN, in [0, 1], within its ULP bound;
//!   `exprel2_neg` the same in [0, ln 2 + 1 ulp];
//! - `exp_split`: NaN mantissa for NaN, else m in [0.70, 1.42] (|x| <= 709; [0.66, 1.50]
//!   beyond), k an integer; `exp2_split` m in [0.70, 1.42] for every non-NaN input;
//! - `frexp`: exact (m · 2^e == x), |m| in [1, 2); and `ldexp(frexp(x)) == x`;
//! - `ldexp`: on its precondition (|m| in [2^-62, 2^39] or 0, integer-valued e, any size)
//!   the correctly rounded m · 2^e, saturation and sign of zero included; outside it, no
//!   panic, and x8 == scalar where `f32x8` has no native scaling (in an AVX-512 build it
//!   scales with `vscalefps`, `Lane::NATIVE_SCALE`, which floors a fractional exponent
//!   and gives NaN for a NaN one, where the generic form rounds and clamps: the two agree
//!   on the precondition only, which is all the kernels use).
//!
//! `RUSTC_BOOTSTRAP=1 cargo fuzz run math -- -max_total_time=60`

#![no_main]

use analytic_fog::math::{self, Lane};
use libfuzzer_sys::fuzz_target;
use wide::f32x8;

/// The bounds measured by `tests/exhaustive.rs` (and written in `src/math/*.rs`).
const EXP_MAX_ULP: f64 = 0.96;
const EXPM1_MAX_ULP: f64 = 1.44;
const EXP_NEG_MAX_ULP: f64 = 0.621;
const EXP_NEG_MUL_MAX_ULP: f64 = 0.64;
const EXPREL_NEG_MAX_ULP: f64 = 1.73;
const EXPREL2_NEG_MAX_ULP: f64 = 1.611;

fn ulp_of(c: f32) -> f64 {
    let a = c.abs();
    if a < f32::MIN_POSITIVE {
        2f64.powi(-149)
    } else {
        2f64.powi(((a.to_bits() >> 23) & 0xff) as i32 - 127 - 23)
    }
}

/// Error of `y` against the f64 value `r` in ULP of `r as f32` (see tests/exhaustive.rs).
fn ulp_err(y: f32, r: f64) -> f64 {
    if r.is_nan() || y.is_nan() {
        return if r.is_nan() && y.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    if r.is_infinite() {
        return if y as f64 == r { 0.0 } else { f64::INFINITY };
    }
    let c = r as f32;
    if c.is_infinite() && y == c {
        return 0.0;
    }
    let u = if c.is_infinite() {
        ulp_of(f32::MAX)
    } else {
        ulp_of(c)
    };
    let yv = if y.is_infinite() {
        2f64.powi(128).copysign(y as f64)
    } else {
        y as f64
    };
    (yv - r).abs() / u
}

fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits()
}

fn lanes(data: &[u8], at: usize) -> [f32; 8] {
    let mut v = [0f32; 8];
    for (l, x) in v.iter_mut().enumerate() {
        let mut b = [0u8; 4];
        for (k, byte) in b.iter_mut().enumerate() {
            *byte = data.get(at + 4 * l + k).copied().unwrap_or(0);
        }
        *x = f32::from_le_bytes(b);
    }
    v
}

fuzz_target!(|data: &[u8]| {
    let xs = lanes(data, 0);
    let es = lanes(data, 32);
    let x8 = f32x8::new(xs);

    // exp
    let y8 = math::exp(x8).to_array();
    for l in 0..8 {
        let (x, y) = (xs[l], math::exp(xs[l]));
        assert!(same(y, y8[l]), "exp({x:e}): x8 {:e}, scalar {y:e}", y8[l]);
        assert_eq!(y.is_nan(), x.is_nan(), "exp({x:e}) = {y:e}");
        if !x.is_nan() {
            assert!(y >= 0.0, "exp({x:e}) = {y:e}");
            let e = ulp_err(y, (x as f64).exp());
            assert!(e <= EXP_MAX_ULP, "exp({x:e}) = {y:e}: {e} ULP");
        }
    }

    // expm1
    let y8 = math::expm1(x8).to_array();
    for l in 0..8 {
        let (x, y) = (xs[l], math::expm1(xs[l]));
        assert!(same(y, y8[l]), "expm1({x:e}): x8 {:e}, scalar {y:e}", y8[l]);
        assert_eq!(y.is_nan(), x.is_nan(), "expm1({x:e}) = {y:e}");
        if !x.is_nan() {
            assert!(y >= -1.0, "expm1({x:e}) = {y:e}");
            assert!(x == 0.0 || (y < 0.0) == (x < 0.0), "expm1({x:e}) = {y:e}");
            let e = ulp_err(y, (x as f64).exp_m1());
            assert!(e <= EXPM1_MAX_ULP, "expm1({x:e}) = {y:e}: {e} ULP");
        }
    }

    // exp_neg and exprel_neg on |x| (their domains are x >= 0 and x >= 2^-60)
    let ax = xs.map(f32::abs);
    let y8 = math::exp_neg(f32x8::new(ax)).to_array();
    for l in 0..8 {
        let (x, y) = (ax[l], math::exp_neg(ax[l]));
        assert!(
            same(y, y8[l]),
            "exp_neg({x:e}): x8 {:e}, scalar {y:e}",
            y8[l]
        );
        assert_eq!(y.is_nan(), x.is_nan(), "exp_neg({x:e}) = {y:e}");
        if !x.is_nan() {
            let r = (-(x as f64)).exp();
            if r >= f32::MIN_POSITIVE as f64 {
                let e = ulp_err(y, r);
                assert!(e <= EXP_NEG_MAX_ULP, "exp_neg({x:e}) = {y:e}: {e} ULP");
            } else {
                assert!(y >= 0.0 && ((y as f64) - r).abs() < f32::MIN_POSITIVE as f64);
            }
        }
    }
    // exp_neg_mul on |x| with κ = |es[0]| where that is in the factor's domain.
    let kappa = es[0].abs();
    if let Some(k) = math::ExpNegMul::new(kappa) {
        let y8 = math::exp_neg_mul(f32x8::new(ax), k).to_array();
        for l in 0..8 {
            let (x, y) = (ax[l], math::exp_neg_mul(ax[l], k));
            let ctx = || format!("exp_neg_mul({x:e}, {kappa:e}) = {y:e}");
            assert!(
                same(y, y8[l]) || (y.is_nan() && y8[l].is_nan()),
                "{}: x8 {:e}",
                ctx(),
                y8[l]
            );
            let nan = x.is_nan() || (x.is_infinite() && kappa == 0.0);
            assert_eq!(y.is_nan(), nan, "{}", ctx());
            if !nan {
                // The product is exact in f64 (24 + 24 bits, within its range).
                let r = (-(x as f64) * kappa as f64).exp();
                if r >= f32::MIN_POSITIVE as f64 {
                    let e = ulp_err(y, r);
                    assert!(e <= EXP_NEG_MUL_MAX_ULP, "{}: {e} ULP", ctx());
                } else {
                    assert!(
                        y >= 0.0 && ((y as f64) - r).abs() < f32::MIN_POSITIVE as f64,
                        "{}",
                        ctx()
                    );
                }
            }
        }
    }
    // (`x < lo` is false for NaN, which stays.)
    let ax = ax.map(|x| {
        if x < 2f32.powi(-60) {
            2f32.powi(-60)
        } else {
            x
        }
    });
    let y8 = math::exprel_neg(f32x8::new(ax)).to_array();
    for l in 0..8 {
        let (x, y) = (ax[l], math::exprel_neg(ax[l]));
        assert!(
            same(y, y8[l]),
            "exprel_neg({x:e}): x8 {:e}, scalar {y:e}",
            y8[l]
        );
        assert_eq!(y.is_nan(), x.is_nan(), "exprel_neg({x:e}) = {y:e}");
        if !x.is_nan() {
            assert!((0.0..=1.0).contains(&y), "exprel_neg({x:e}) = {y:e}");
            let r = if x.is_infinite() {
                0.0
            } else {
                -(-(x as f64)).exp_m1() / x as f64
            };
            let e = ulp_err(y, r);
            assert!(
                e <= EXPREL_NEG_MAX_ULP,
                "exprel_neg({x:e}) = {y:e}: {e} ULP"
            );
        }
    }
    let y8 = math::exprel2_neg(f32x8::new(ax)).to_array();
    for l in 0..8 {
        let (x, y) = (ax[l], math::exprel2_neg(ax[l]));
        assert!(
            same(y, y8[l]),
            "exprel2_neg({x:e}): x8 {:e}, scalar {y:e}",
            y8[l]
        );
        assert_eq!(y.is_nan(), x.is_nan(), "exprel2_neg({x:e}) = {y:e}");
        if !x.is_nan() {
            // At most one ulp above ln 2: the product and the quotient are rounded apart.
            let top = f32::from_bits(core::f32::consts::LN_2.to_bits() + 1);
            assert!((0.0..=top).contains(&y), "exprel2_neg({x:e}) = {y:e}");
            let r = if x.is_infinite() {
                0.0
            } else {
                -(-(x as f64) * core::f64::consts::LN_2).exp_m1() / x as f64
            };
            let e = ulp_err(y, r);
            assert!(
                e <= EXPREL2_NEG_MAX_ULP,
                "exprel2_neg({x:e}) = {y:e}: {e} ULP"
            );
        }
    }

    // exp_split
    let (m8, k8) = math::exp_split(x8);
    let (m8, k8) = (m8.to_array(), k8.to_array());
    for l in 0..8 {
        let x = xs[l];
        let (m, k) = math::exp_split(x);
        assert!(same(m, m8[l]) && same(k, k8[l]), "exp_split({x:e})");
        if x.is_nan() {
            assert!(m.is_nan(), "exp_split(NaN) = ({m:e}, {k:e})");
        } else {
            let mr = if x.abs() <= 709.0 {
                0.70..=1.42
            } else {
                0.66..=1.50
            };
            assert!(
                mr.contains(&m) && k == k.round() && k.abs() <= 1_512_776.0,
                "exp_split({x:e}) = ({m:e}, {k:e})"
            );
        }
    }

    // exp2_split
    let (m8, k8) = math::exp2_split(x8);
    let (m8, k8) = (m8.to_array(), k8.to_array());
    for l in 0..8 {
        let x = xs[l];
        let (m, k) = math::exp2_split(x);
        assert!(same(m, m8[l]) && same(k, k8[l]), "exp2_split({x:e})");
        if x.is_nan() {
            assert!(m.is_nan(), "exp2_split(NaN) = ({m:e}, {k:e})");
        } else {
            assert!(
                (0.70..=1.42).contains(&m) && k == k.round() && k.abs() <= 1_048_576.0,
                "exp2_split({x:e}) = ({m:e}, {k:e})"
            );
        }
    }

    // frexp, and ldexp(frexp(x)) == x
    let (m8, e8) = math::frexp(x8);
    let back8 = math::ldexp(m8, e8).to_array();
    let (m8, e8) = (m8.to_array(), e8.to_array());
    for l in 0..8 {
        let x = xs[l];
        let (m, e) = math::frexp(x);
        assert!(same(m, m8[l]) && same(e, e8[l]), "frexp({x:e})");
        let back = math::ldexp(m, e);
        assert!(same(back, back8[l]), "ldexp(frexp({x:e}))");
        if x.is_finite() && x != 0.0 {
            assert!(
                (1.0..2.0).contains(&m.abs())
                    && e == e.round()
                    && m as f64 * 2f64.powi(e as i32) == x as f64,
                "frexp({x:e}) = ({m:e}, {e:e})"
            );
            assert!(same(back, x), "ldexp(frexp({x:e})) = {back:e}");
        } else if x == 0.0 {
            assert!(m == 0.0 && e == -151.0 && back == 0.0, "frexp({x:e})");
        } else if x.is_infinite() {
            assert!(same(back, x), "ldexp(frexp({x:e})) = {back:e}");
        } else {
            assert!(e == 128.0 && m.is_finite(), "frexp(NaN) = ({m:e}, {e:e})");
        }
    }

    // ldexp on arbitrary bits: x8 == scalar always; correctly rounded on its precondition.
    // The mantissa is xs with its exponent folded into [2^-62, 2^40).
    let ms = xs.map(|x| {
        if x.is_finite() && x != 0.0 {
            let (m, e) = math::frexp(x);
            m * 2f32.powi((e as i32).rem_euclid(102) - 62)
        } else {
            x
        }
    });
    for (mm, raw) in [(ms, es), (ms, es.map(f32::round)), (xs, es)] {
        let y8 = math::ldexp(f32x8::new(mm), f32x8::new(raw)).to_array();
        for l in 0..8 {
            let (m, e) = (mm[l], raw[l]);
            let y = math::ldexp(m, e);
            let pre = (m == 0.0 || (2f32.powi(-62)..=2f32.powi(39)).contains(&m.abs()))
                && e.is_finite()
                && e == e.round();
            assert!(
                same(y, y8[l]) || (<f32x8 as Lane>::NATIVE_SCALE && !pre),
                "ldexp({m:e}, {e:e}): x8 {:e}, scalar {y:e}",
                y8[l]
            );
            if pre {
                let exact = if e.abs() <= 1000.0 {
                    m as f64 * 2f64.powi(e as i32)
                } else if e > 0.0 && m != 0.0 {
                    f64::INFINITY.copysign(m as f64)
                } else {
                    0f64.copysign(m as f64)
                };
                let want = exact as f32;
                assert!(same(y, want), "ldexp({m:e}, {e:e}) = {y:e}, want {want:e}");
            }
        }
    }
});
