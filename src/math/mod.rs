//! SIMD special functions, each written once over [`Lane`] (`f32`, `wide::f32x8` and
//! `wide::f32x16`).
//!
//! One function per file, each with its domain and its measured error in the file's
//! header. The exhaustive sweeps that measure them are in `tests/exhaustive.rs`
//! (`cargo test --release --test exhaustive -- --ignored`).

mod asinh;
mod erf;
mod exp;
mod exp2_nonpos;
mod exp2_nonpos_table;
mod exp2_split;
mod exp2m1;
mod exp_neg;
mod expm1;
mod exprel;
mod exprel2;
mod fast;
mod frexp;
mod lane;
mod ldexp;
mod log;
mod log1p;
#[cfg(any(zmm_dispatch, zmm_native))]
pub(crate) mod zmm;

/// Whether the batch kernels run `zmm::Zmm`'s 16 AVX-512 lanes: a build with the
/// run-time dispatch (`cfg(zmm_dispatch)`, see `build.rs`) on a CPU with the AVX-512
/// subsets it uses.
#[inline]
pub(crate) fn avx512_detected() -> bool {
    #[cfg(zmm_dispatch)]
    {
        zmm::detected()
    }
    #[cfg(not(zmm_dispatch))]
    {
        false
    }
}

pub use asinh::asinh;
pub use erf::{erf, erfc};
pub use exp::{exp, exp_split};
pub use exp2_nonpos::exp2_nonpos;
pub use exp2_nonpos_table::{
    exp2_nonpos_table, exp2_nonpos_table_mul, exp2_nonpos_table_mul_with, TableMulConsts,
};
pub use exp2_split::exp2_split;
pub use exp2m1::{exp2m1, exp2m1_in_range};
pub use exp_neg::{exp_neg, exp_neg_mul, ExpNegMul};
pub use expm1::expm1;
pub use exprel::exprel_neg;
pub use exprel2::exprel2_neg;
pub use fast::{exp2_split_fast, exp_neg_fast, exp_split_fast, exprel2_neg_fast, exprel_neg_fast};
pub use frexp::frexp;

/// e^(−x) in the tier that `fast` names ([`exp_neg_fast`] or [`exp_neg()`]): a function,
/// not a closure, for the AVX-512 entry points (see `rgb!`).
#[inline(always)]
pub(crate) fn exp_neg_tier<L: Lane>(fast: bool, x: L) -> L {
    if fast {
        exp_neg_fast(x)
    } else {
        exp_neg(x)
    }
}
pub use lane::Lane;
#[cfg(target_feature = "avx512f")]
pub(crate) use lane::{rcp14_x16, rsqrt14_x16};
#[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
pub(crate) use lane::{rcp14_x8, rsqrt14_x8};
pub use ldexp::{ldexp, ldexp_no_subnormal, pow2_pair};
pub use log::{log, log_scaled};
pub use log1p::log1p;
