//! The 16-lane instantiation (`wide::f32x16`, which the batch kernels use where the build
//! enables AVX-512F, e.g. `-C target-cpu=x86-64-v4`) gives the same bits as the scalar one
//! for every special function, over a sample of every 257th f32 bit pattern (16.7 million
//! inputs, NaN, ±inf, zeros and subnormals included) and the boundaries listed below
//! (NaN counts as equal to NaN whatever the payload).
//!
//! In an x86-64-v3 build `f32x16` is two `f32x8` halves, so this checks the shared `Lane`
//! code; `.ci/run` runs the test suite again with x86-64-v4 where the CPU has AVX-512, which
//! checks the AVX-512 instructions themselves (and, through `tests/height_fog.rs` and
//! `tests/plan.rs`, the kernels: `Scene::evaluate` against `evaluate_scalar` bit for bit).
use analytic_fog::math::{self, Lane};
use rayon::prelude::*;
use wide::f32x16;

const STRIDE: u32 = 257;

/// The same bits, or both NaN (NaN payloads are not part of the contract).
fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Inputs: every STRIDE-th bit pattern from `start`, plus a few exact boundaries.
fn inputs(start: u32) -> impl Iterator<Item = f32> {
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
    (0..u32::MAX / STRIDE)
        .map(move |k| f32::from_bits(start.wrapping_add(k * STRIDE)))
        .chain(specials)
}

/// Runs `f16` over packets of 16 inputs and `f1` over each input alone; the number of
/// lanes whose bits differ (with the first few printed).
fn mismatches<F16, F1>(name: &str, f16: F16, f1: F1) -> usize
where
    F16: Fn(f32x16) -> [f32x16; 2] + Sync,
    F1: Fn(f32) -> [f32; 2] + Sync,
{
    let xs: Vec<f32> = inputs(0x9e37).collect();
    let bad: usize = xs
        .par_chunks(16 * 1024)
        .map(|block| {
            let mut bad = 0;
            for chunk in block.chunks(16) {
                let mut a = [1.0f32; 16];
                a[..chunk.len()].copy_from_slice(chunk);
                let r = f16(f32x16::new(a)).map(|v| v.to_array());
                for (l, &x) in chunk.iter().enumerate() {
                    let s = f1(x);
                    for k in 0..2 {
                        if !same(r[k][l], s[k]) {
                            if bad < 3 {
                                eprintln!(
                                    "{name}({x:e} = {:#010x}) [{k}]: x16 {:#010x}, scalar {:#010x}",
                                    x.to_bits(),
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
        .sum();
    bad
}

/// `exp_neg_mul` with a factor whose flush boundary (x·κ·log2 e = 126.5, x ≈ 88.8) lies
/// in the densely tested [86, 89].
fn exp_neg_mul_near_one<L: Lane>(x: L) -> L {
    math::exp_neg_mul(x, math::ExpNegMul::new(0.987_654_3).expect("in the domain"))
}

macro_rules! one {
    ($f:path) => {
        mismatches(
            stringify!($f),
            |x| [$f(x), f32x16::splat(0.0)],
            |x| [$f(x), 0.0],
        )
    };
}

macro_rules! two {
    ($f:path) => {
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
fn x16_equals_scalar_for_every_special_function() {
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
        // `frexp` but for NaN's mantissa (any): for NaN only the exponent is compared.
        // ±inf must give a finite exponent (AVX-512's getexp gives +inf, which made
        // `vscalefps` turn an invalid ray's NaN into τ = 0 or +inf).
        (
            "frexp_finite",
            mismatches(
                "frexp_finite",
                |x| {
                    let (a, b) = x.frexp_finite();
                    [Lane::select(x.eq(x), a, f32x16::splat(0.0)), b]
                },
                |x| {
                    let (a, b) = math::frexp(x);
                    [if x.is_nan() { 0.0 } else { a }, b]
                },
            ),
        ),
        // The generic form's values for both of `RayGeom::new`'s ranges; for NaN only
        // that the exponent is in [lo, hi].
        (
            "frexp_clamped",
            [(-151.0f32, 2_097_152.0f32), (-8_388_608.0, 128.0)]
                .iter()
                .map(|&(lo, hi)| {
                    mismatches(
                        "frexp_clamped",
                        |x| {
                            let (a, b) = x.frexp_clamped(lo, hi);
                            let ok = b.ge(f32x16::splat(lo)) & b.le(f32x16::splat(hi));
                            let nan_e = Lane::select(ok, f32x16::splat(0.0), f32x16::splat(1.0));
                            let num = x.eq(x);
                            [
                                Lane::select(num, a, f32x16::splat(0.0)),
                                Lane::select(num, b, nan_e),
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
        // With t's validity in the mantissa (`RayGeom::new`'s t): NaN exactly for NaN and
        // negative x (not −0).
        (
            "frexp_clamped_nonneg",
            mismatches(
                "frexp_clamped_nonneg",
                |x| {
                    let (a, b) = x.frexp_clamped_nonneg(-151.0, 2_097_152.0);
                    let ok = b.ge(f32x16::splat(-151.0)) & b.le(f32x16::splat(2_097_152.0));
                    let nan_e = Lane::select(ok, f32x16::splat(0.0), f32x16::splat(1.0));
                    [a, Lane::select(x.eq(x), b, nan_e)]
                },
                |x| {
                    let (a, b) = Lane::frexp_clamped_nonneg(x, -151.0, 2_097_152.0);
                    assert_eq!(a.is_nan(), x.is_nan() || x < 0.0, "{x:e}");
                    [a, if x.is_nan() { 0.0 } else { b }]
                },
            ),
        ),
        // Ties to even (wide 1's `f32x16::round` rounds ties away from zero).
        ("round", one!(Lane::round)),
        ("sqrt", one!(Lane::sqrt)),
    ];
    let bad: Vec<_> = counts.iter().filter(|(_, n)| *n > 0).collect();
    assert!(bad.is_empty(), "x16 differs from scalar: {bad:?}");
}

/// The two-argument helpers, on pairs drawn from their preconditions' domains.
#[test]
fn x16_equals_scalar_for_ldexp_and_lane_operations() {
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
                let e = ((b >> 32) % 48) as i32 - 40;
                let v = mag * 2f32.powi(e);
                if b & (1 << 40) != 0 {
                    -v
                } else {
                    v
                }
            }
        });
        let e: [f32; 16] = core::array::from_fn(|_| (next() % 700) as f32 - 350.0);
        let x: [f32; 16] = core::array::from_fn(|_| f32::from_bits(next() as u32));
        let y: [f32; 16] = core::array::from_fn(|_| f32::from_bits(next() as u32));
        let (vm, ve) = (f32x16::new(m), f32x16::new(e));
        let (vx, vy) = (f32x16::new(x), f32x16::new(y));
        let l = math::ldexp(vm, ve).to_array();
        let (p1, p2) = math::pow2_pair(ve);
        let (p1, p2) = (p1.to_array(), p2.to_array());
        let ops = [
            Lane::min(vx, vy).to_array(),
            Lane::max(vx, vy).to_array(),
            Lane::mul_add(vx, vy, vm).to_array(),
            Lane::sqrt(vx).to_array(),
            Lane::round(vx).to_array(),
            Lane::copysign(vx, vy).to_array(),
            Lane::clamp(vx, vm, vm + f32x16::splat(1.0)).to_array(),
            Lane::select(Lane::ne(vx, vy), vx, vy).to_array(),
            Lane::exponent_field(vx).to_array(),
            Lane::with_unit_exponent(vx).to_array(),
        ];
        for i in 0..16 {
            let want = [
                Lane::min(x[i], y[i]),
                Lane::max(x[i], y[i]),
                Lane::mul_add(x[i], y[i], m[i]),
                Lane::sqrt(x[i]),
                Lane::round(x[i]),
                Lane::copysign(x[i], y[i]),
                Lane::clamp(x[i], m[i], m[i] + 1.0),
                <f32 as Lane>::select(Lane::ne(x[i], y[i]), x[i], y[i]),
                Lane::exponent_field(x[i]),
                Lane::with_unit_exponent(x[i]),
            ];
            let (q1, q2) = math::pow2_pair(e[i]);
            bad += usize::from(!same(l[i], math::ldexp(m[i], e[i])));
            bad += usize::from(!same(p1[i], q1) || !same(p2[i], q2));
            for (k, w) in want.iter().enumerate() {
                if !same(ops[k][i], *w) {
                    if bad < 3 {
                        eprintln!("op {k}: x = {:e}, y = {:e}, m = {:e}", x[i], y[i], m[i]);
                    }
                    bad += 1;
                }
            }
        }
    }
    assert_eq!(bad, 0, "lanes where x16 differs from scalar");
}

/// `Lane::round_pow2i` over its domain [-127, 127] (every 257th f32 there, and every
/// integer and half-integer): k is an integer within 1/2 of y, a tie takes the odd k
/// (as documented), 2^k is exact (0 for k = −127), checked in f64; the 8- and 16-lane
/// forms give the scalar bits.
#[test]
fn round_pow2i_against_f64_in_every_width() {
    let mut ys: Vec<f32> = (0..=508).map(|j| j as f32 * 0.5 - 127.0).collect();
    ys.extend([
        0.0,
        -0.0,
        1e-30,
        -1e-30,
        0.49999997,
        -0.49999997,
        126.99999,
        -126.99999,
    ]);
    let mut b = 0u32;
    while b < 0x8000_0000 {
        for y in [f32::from_bits(b), -f32::from_bits(b)] {
            if y.abs() <= 127.0 {
                ys.push(y);
            }
        }
        b += STRIDE;
    }
    ys.resize(ys.len().div_ceil(16) * 16, 0.0);
    let mut bad = 0;
    for c in ys.chunks_exact(16) {
        let a: [f32; 16] = c.try_into().unwrap();
        let (k16, s16) = Lane::round_pow2i(f32x16::new(a));
        let (k16, s16) = (k16.to_array(), s16.to_array());
        let lo: [f32; 8] = a[..8].try_into().unwrap();
        let (k8, s8) = Lane::round_pow2i(wide::f32x8::new(lo));
        let (k8, s8) = (k8.to_array(), s8.to_array());
        for i in 0..16 {
            let y = f64::from(a[i]);
            let (k, s) = Lane::round_pow2i(a[i]);
            let kd = f64::from(k);
            let ok_k = kd.fract() == 0.0
                && (y - kd).abs() <= 0.5
                && ((y - kd).abs() < 0.5 || kd.rem_euclid(2.0) == 1.0);
            let want_s = if kd <= -127.0 { 0.0 } else { 2f64.powf(kd) };
            let ok = ok_k
                && f64::from(s) == want_s
                && same(k16[i], k)
                && same(s16[i], s)
                && (i >= 8 || (same(k8[i], k) && same(s8[i], s)));
            if !ok {
                if bad < 3 {
                    eprintln!("y = {y:e}: k = {k}, 2^k = {s:e}");
                }
                bad += 1;
            }
        }
    }
    assert_eq!(bad, 0, "inputs where round_pow2i is wrong");
}
