//! Sets `cfg(zmm_dispatch)` where the crate is built for x86-64 with AVX2 and FMA but
//! without AVX-512F (the repository's x86-64-v3 build): there the one-layer kernels can
//! run 16 lanes in AVX-512 registers chosen at run time (`math::zmm`, ARCHITECTURE "AVX-512
//! chosen at run time"). One name for the condition instead of the four-part `cfg(all(..))`
//! at every item it guards.
//!
//! Sets `cfg(zmm_native)` where the build itself enables the AVX-512 subsets that `Zmm`
//! uses (F, VL, DQ, BW, CD; e.g. `-C target-cpu=x86-64-v4`): there `Zmm` is the kernels'
//! 16-lane type everywhere, with no dispatch.
fn main() {
    println!("cargo:rustc-check-cfg=cfg(zmm_dispatch)");
    println!("cargo:rustc-check-cfg=cfg(zmm_native)");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CARGO_CFG_TARGET_FEATURE");
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let features = std::env::var("CARGO_CFG_TARGET_FEATURE").unwrap_or_default();
    let has = |f: &str| features.split(',').any(|x| x == f);
    if arch == "x86_64" && has("avx2") && has("fma") && !has("avx512f") {
        println!("cargo:rustc-cfg=zmm_dispatch");
    }
    let avx512 = ["avx512f", "avx512vl", "avx512dq", "avx512bw", "avx512cd"];
    if arch == "x86_64" && has("avx2") && has("fma") && avx512.iter().all(|f| has(f)) {
        println!("cargo:rustc-cfg=zmm_native");
    }
}
