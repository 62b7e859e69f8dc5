//! SIMD special functions, each written once over [`Lane`] (`f32` and `wide::f32x8`).
//!
//! One function per file, each with its domain and its measured error in the file's
//! header. The exhaustive sweeps that measure them are in `tests/exhaustive.rs`
//! (`cargo test --release --test exhaustive -- --ignored`).

mod exp;
mod expm1;
mod frexp;
mod lane;
mod ldexp;

pub use exp::{exp, exp_split};
pub use expm1::expm1;
pub use frexp::frexp;
pub use lane::Lane;
pub use ldexp::ldexp;
