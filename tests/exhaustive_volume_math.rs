//! Exhaustive sweeps of the special functions the fog volumes use (`math::erf`,
//! `math::erfc`, `math::asinh`, `math::log1p`, `math::log`) against f64 references (the
//! `libm` crate's `erf`/`erfc`, std's `asinh`, `ln_1p` and `ln`).
//!
//! ```text
//! cargo test --release --test exhaustive_volume_math -- --ignored --nocapture
//! ```
//!
//! Every f32 bit pattern (2^32 inputs per function) is evaluated 8 at a time through the
//! `wide::f32x8` instantiation and one at a time through the scalar one, which must give
//! the same bits. Errors are in ULP of the correctly rounded f32 result (2^-149 for
//! subnormal results); each sweep asserts the bound in its function's header. Split over
//! all cores with rayon; minutes in release, hence `#[ignore]`.
//!
//! A fast sampled version of each sweep (every 4099th bit pattern) runs in the normal test
//! suite, so that a regression shows up without the long run.

mod common;

use analytic_fog::math;
use common::ulp_of;
use rayon::prelude::*;
use wide::f32x8;

/// Max ULP errors documented in the headers of `src/math/{erf,asinh,log1p,log}.rs`.
const ERF_MAX_ULP: f64 = 1.0;
/// erfc: relative bound for normal results; subnormal results are held to an absolute
/// error of `ERFC_SUBNORMAL_ULP` × 2^-149.
const ERFC_MAX_ULP: f64 = 4.0;
const ERFC_SUBNORMAL_ULP: f64 = 2048.0;
const ASINH_MAX_ULP: f64 = 2.0;
const LOG1P_MAX_ULP: f64 = 1.0;
const LOG_MAX_ULP: f64 = 1.0;

/// |y − r| in ULP of `r as f32`; infinities and NaN must match exactly.
fn ulp_err(y: f32, r: f64) -> f64 {
    if r.is_nan() || y.is_nan() {
        return if r.is_nan() && y.is_nan() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let c = r as f32;
    if c.is_infinite() || y.is_infinite() {
        return if y == c { 0.0 } else { f64::INFINITY };
    }
    (y as f64 - r).abs() / ulp_of(c)
}

#[derive(Clone, Copy, Debug, Default)]
struct Worst {
    ulp: f64,
    x: f32,
    got: f32,
    want: f64,
    mismatches: u64,
}

impl Worst {
    fn merge(self, o: Worst) -> Worst {
        let mut w = if o.ulp > self.ulp { o } else { self };
        w.mismatches = self.mismatches + o.mismatches;
        w
    }
}

/// Sweeps bit patterns `start, start + step, …` below 2^32 through `f8` and `f1`,
/// measuring `err(y, x)`.
fn sweep(
    step: u64,
    f8: impl Fn(f32x8) -> f32x8 + Sync,
    f1: impl Fn(f32) -> f32 + Sync,
    err: impl Fn(f32, f32) -> (f64, f64) + Sync,
) -> Worst {
    let n = (1u64 << 32).div_ceil(step);
    const CHUNK: u64 = 1 << 14;
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut w = Worst::default();
            let lo = c * CHUNK;
            let hi = (lo + CHUNK).min(n);
            let mut i = lo;
            while i < hi {
                let mut xs = [0f32; 8];
                for (k, x) in xs.iter_mut().enumerate() {
                    let j = (i + k as u64).min(hi - 1);
                    *x = f32::from_bits((j * step) as u32);
                }
                let ys = f8(f32x8::new(xs)).to_array();
                for k in 0..8 {
                    if i + k as u64 >= hi {
                        break;
                    }
                    let (x, y) = (xs[k], ys[k]);
                    if f1(x).to_bits() != y.to_bits() {
                        w.mismatches += 1;
                    }
                    let (e, want) = err(y, x);
                    if e > w.ulp || e.is_nan() {
                        w = Worst {
                            ulp: if e.is_nan() { f64::INFINITY } else { e },
                            x,
                            got: y,
                            want,
                            mismatches: w.mismatches,
                        };
                    }
                }
                i += 8;
            }
            w
        })
        .reduce(Worst::default, Worst::merge)
}

fn report(name: &str, w: &Worst, bound: f64) {
    println!(
        "{name}: max {:.3} ULP at x = {:e} ({:#010x}): got {:e}, want {:e}; x8/scalar mismatches: {}",
        w.ulp,
        w.x,
        w.x.to_bits(),
        w.got,
        w.want,
        w.mismatches
    );
    assert_eq!(w.mismatches, 0, "{name}: scalar and x8 differ");
    assert!(w.ulp <= bound, "{name}: {} ULP > {bound}", w.ulp);
}

fn run_erf(step: u64) {
    let w = sweep(step, math::erf::<f32x8>, math::erf::<f32>, |y, x| {
        let r = libm::erf(x as f64);
        (ulp_err(y, r), r)
    });
    report("erf", &w, ERF_MAX_ULP);
}

fn run_erfc(step: u64) {
    let w = sweep(step, math::erfc::<f32x8>, math::erfc::<f32>, |y, x| {
        let r = libm::erfc(x as f64);
        let e = ulp_err(y, r);
        // Subnormal results: an absolute bound in units of 2^-149.
        if (r.abs() as f32) < f32::MIN_POSITIVE {
            return (e * ERFC_MAX_ULP / ERFC_SUBNORMAL_ULP, r);
        }
        (e, r)
    });
    report("erfc", &w, ERFC_MAX_ULP);
}

fn run_asinh(step: u64) {
    let w = sweep(step, math::asinh::<f32x8>, math::asinh::<f32>, |y, x| {
        let r = (x as f64).asinh();
        (ulp_err(y, r), r)
    });
    report("asinh", &w, ASINH_MAX_ULP);
}

fn run_log1p(step: u64) {
    let w = sweep(step, math::log1p::<f32x8>, math::log1p::<f32>, |y, x| {
        let r = if x < -1.0 {
            f64::NAN
        } else {
            (x as f64).ln_1p()
        };
        (ulp_err(y, r), r)
    });
    report("log1p", &w, LOG1P_MAX_ULP);
}

fn run_log(step: u64) {
    let w = sweep(step, math::log::<f32x8>, math::log::<f32>, |y, x| {
        let r = if x < 0.0 { f64::NAN } else { (x as f64).ln() };
        (ulp_err(y, r), r)
    });
    report("log", &w, LOG_MAX_ULP);
}

#[test]
#[ignore]
fn exhaustive_erf() {
    run_erf(1);
}
#[test]
#[ignore]
fn exhaustive_erfc() {
    run_erfc(1);
}
#[test]
#[ignore]
fn exhaustive_asinh() {
    run_asinh(1);
}
#[test]
#[ignore]
fn exhaustive_log1p() {
    run_log1p(1);
}
#[test]
#[ignore]
fn exhaustive_log() {
    run_log(1);
}

/// Every 4099th bit pattern (about 1M inputs per function): the same bounds, fast.
#[test]
fn sampled_volume_math() {
    let step = if cfg!(debug_assertions) { 65537 } else { 4099 };
    run_erf(step);
    run_erfc(step);
    run_asinh(step);
    run_log1p(step);
    run_log(step);
}
