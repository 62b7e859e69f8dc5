//! # analytic-fog
//!
//! Fog evaluated analytically for large batches of rays on the CPU: exponential height
//! fog (optical depth, transmittance and in-scattering in closed form), 8 rays at a time
//! with `wide::f32x8`, in parallel with rayon, with a measured and tested error bound on
//! every input, the stiff and extreme ones included.
//!
//! ```
//! use analytic_fog::{Component, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun};
//! use glam::Vec3;
//!
//! let scene = Scene::new(SceneDesc {
//!     height_fog: vec![HeightFogLayer {
//!         base_height: 0.0,
//!         falloff: 0.08,
//!         emission: glam::Vec3::ZERO,
//!         components: vec![Component {
//!             scattering: Vec3::splat(0.02),
//!             absorption: Vec3::ZERO,
//!             phase: Phase::HenyeyGreenstein(0.7),
//!         }],
//!     }],
//!     lighting: Lighting {
//!         ambient: Vec3::new(0.5, 0.6, 0.7),
//!         sun: Some(Sun { direction: Vec3::new(0.3, 0.4, -0.87), radiance: Vec3::new(20.0, 18.0, 15.0) }),
//!     },
//!     ..SceneDesc::default()
//! })?;
//!
//! // One ray through the scalar API...
//! let s = scene.eval_ray(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -0.1, 1.0), 100.0);
//! assert!(s.transmittance.x > 0.0 && s.transmittance.x < 1.0);
//!
//! // ...and a structure-of-arrays batch, 8 lanes at a time.
//! let n = 1000;
//! let (ox, oy, oz) = (vec![0.0; n], vec![2.0; n], vec![0.0; n]);
//! let (dx, dy, dz) = (vec![0.0; n], vec![-0.1; n], vec![1.0; n]);
//! let t = vec![100.0; n];
//! let rays = Rays::new(&ox, &oy, &oz, &dx, &dy, &dz, &t)?;
//! let (mut tr, mut tg, mut tb) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
//! scene.evaluate(&rays, Outputs { transmittance: Some([&mut tr, &mut tg, &mut tb]), ..Outputs::default() })?;
//! assert_eq!(tr[999], s.transmittance.x);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Builder
//! [`SceneBuilder`] builds the same [`SceneDesc`] fluently
//! (`SceneBuilder::new().layer(..).sun(..).build()?`); `build` runs [`Scene::new`], so its
//! errors name the same fields as the JSON loader's.
//!
//! ## Media and composition
//! A scene holds height fog layers, fog volumes ([`Volume`]: bounded shapes with analytic
//! density profiles, and cut-outs), distance fog and Unreal-style limits ([`DistanceFog`],
//! [`FogLimits`]), lit by ambient light and a sun. Optical depths add; the in-scattered
//! light of media with different colours combines by [`Composition`]: the τ-weighted mix
//! (default) or the fog volumes composited front to back.
//!
//! ## Framebuffer pass
//! [`Scene::fog_pass`] fogs a renderer's frame in place from a [`pass::Camera`], a depth
//! buffer and a colour buffer (RGB, RGBA or planar), 8 pixels at a time and in parallel;
//! each pixel is the batch API's result for the ray [`pass::Camera::pixel_ray`] returns:
//! within the accuracy bound for frames of one height fog layer (the pass's own, cheaper
//! kernel), bit for bit otherwise and with [`Scene::with_batch_kernel_pass`]. See the
//! [`pass`] module.
//!
//! ## Feature flags
//! - `serde`: `Serialize`/`Deserialize` for the scene description types (the JSON model
//!   of the command-line tool).
//! - `report`: the `report` module, the error-against-run-time measurement (pulls serde_json and
//!   plotters).
//! - `cli`: the `analytic-fog` binary (`src/bin/`; enables `serde` and `report`); pulls
//!   serde_json, clap, png and plotters. A renderer that depends on the library gets none
//!   of them.
//!
//! ## Build for AVX2/FMA
//! `wide` selects its AVX2/FMA code paths at compile time only. Build with
//! `RUSTFLAGS="-C target-cpu=x86-64-v3"` (or `native`), or in `.cargo/config.toml`; without
//! it the same code runs on SSE2 (correct, bit-identical between scalar and x8, slower).
//! With AVX-512 enabled (`-C target-cpu=x86-64-v4`, or `native` on such a CPU) the batch
//! kernels run 16 lanes per instruction (`wide::f32x16`), with the same bits; the binary
//! then needs AVX-512 to run. (The framebuffer pass's own kernel runs `f32x16` in every
//! build: two 8-lane halves per operation with AVX2.) [`simd_level`] reports what was
//! compiled in.
//!
//! A build with AVX2 and FMA but without AVX-512 (x86-64-v3, this repository's own) that
//! runs on a CPU with AVX-512 (F, VL, DQ, BW, CD) evaluates 16 lanes wide anyway, in
//! AVX-512 registers, chosen at run time: `Scene::evaluate` and `evaluate_par` (every
//! scene: one height fog layer, and several layers, volumes, controls), and the
//! framebuffer pass's own kernel and its rows of one layer, with the same bits as the
//! 8-lane path (the pass's own kernel: T within 4e-7 of it, L_in within 1e-6 of the fog
//! colour, since it takes AVX-512's estimate of 1/√x there) ([`avx512_dispatch`] says
//! whether it happens, [`Scene::without_avx512_dispatch`] turns it off). The pass's rows
//! of other scenes run the build's width.
//!
//! The crate's `unsafe` code is the AVX-512 intrinsics `wide` does not offer: `math::lane`'s
//! AVX-512 module (compiled only where the build enables AVX-512F: `vgetexpps`,
//! `vgetmantps`, `vscalefps`), and the run-time dispatch: `math::zmm` (a lane type over
//! `__m512`) and the two `#[target_feature]` entry points that use it, called only after
//! `is_x86_feature_detected!` has found the features.

#![deny(unsafe_code)]
// Every public item is documented (`cargo clippy -- -D warnings` in `.ci/run` enforces it).
#![warn(missing_docs)]
// Channel loops index several parallel [_; 3] arrays; coefficients are written with all
// the digits of their derivation.
#![allow(clippy::needless_range_loop, clippy::excessive_precision)]

/// `[e, e, e]` with `$ch` bound to the channel 0, 1, 2: a per-channel array without a
/// closure. The kernels' hot loops use it instead of `[0, 1, 2].map(|ch| ..)`: a closure
/// is a function of its own, compiled without the `#[target_feature]` of the AVX-512
/// entry points (`kernel::zmm`, `pass::height::zmm`), and LLVM left `array::map`'s calls
/// to such closures out of line there, a call (and spills) per operation.
macro_rules! rgb {
    ($ch:ident => $e:expr) => {
        [
            {
                let $ch = 0usize;
                $e
            },
            {
                let $ch = 1usize;
                $e
            },
            {
                let $ch = 2usize;
                $e
            },
        ]
    };
}

mod builder;
mod error;
mod kernel;
pub mod light;
pub mod math;
mod medium;
pub mod pass;
mod ray;
pub mod reference;
#[cfg(feature = "report")]
pub mod report;
mod scene;
#[cfg(feature = "serde")]
mod serde_rgb;

pub use builder::SceneBuilder;
pub use error::{BatchError, PassError, SceneError};
pub use light::{Lobe, Phase};
pub use medium::distance::{DistanceFog, Falloff};
pub use medium::volume::{Profile, Shape, Volume, MAX_CUTS};
pub use ray::{Outputs, Rays, RgbSlices};
pub use scene::{
    Component, Composition, FogLimits, HeightFogLayer, Lighting, Scene, SceneDesc, Sun, Tier,
};

use glam::Vec3;
use kernel::Width;

/// True where this build, compiled without AVX-512 but with AVX2 and FMA (the repository's
/// x86-64-v3 build), runs on a CPU with AVX-512 (F, VL, DQ, BW, CD): `Scene::evaluate` and
/// `Scene::evaluate_par` then evaluate every scene 16 lanes wide in AVX-512 registers,
/// chosen at run time, with the same bits as the 8-lane path; so does
/// the framebuffer pass's own kernel, whose T there is within 4e-7 of the 8-lane path's
/// and L_in within 1e-6 of the fog colour (AVX-512's estimate of 1/√x: other last bits)
/// ([`Scene::without_avx512_dispatch`] turns it off). False in an AVX-512 build, which
/// runs 16 lanes everywhere anyway (see [`simd_level`]).
pub fn avx512_dispatch() -> bool {
    math::avx512_detected()
}

/// The SIMD instruction set `wide` was compiled for: `"avx512f+avx2+fma"` (the batch
/// kernels then run 16 lanes per instruction), `"avx2+fma"`, `"avx2"`, `"avx"`, `"sse4.1"`,
/// `"sse2"` or `"scalar"`.
pub fn simd_level() -> &'static str {
    if cfg!(all(
        target_feature = "avx512f",
        target_feature = "avx2",
        target_feature = "fma"
    )) {
        "avx512f+avx2+fma"
    } else if cfg!(all(target_feature = "avx2", target_feature = "fma")) {
        "avx2+fma"
    } else if cfg!(target_feature = "avx2") {
        "avx2"
    } else if cfg!(target_feature = "avx") {
        "avx"
    } else if cfg!(target_feature = "sse4.1") {
        "sse4.1"
    } else if cfg!(target_feature = "sse2") {
        "sse2"
    } else {
        "scalar"
    }
}

/// The fog along one ray, per RGB channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FogSample {
    /// Optical depth τ.
    pub tau: Vec3,
    /// Transmittance T = exp(−τ).
    pub transmittance: Vec3,
    /// In-scattered radiance: the pixel is `surface * transmittance + inscattering`.
    pub inscattering: Vec3,
}

impl Scene {
    /// Evaluates a batch 8 rays at a time on the calling thread, writing the outputs that
    /// `out` asks for. Errors if a slice's length differs from the batch's.
    /// Runs the scene's tier ([`SceneDesc::tier`], Accurate by default).
    pub fn evaluate(&self, rays: &Rays<'_>, out: Outputs<'_>) -> Result<(), BatchError> {
        self.evaluate_tier(self.tier, rays, out)
    }

    /// [`Scene::evaluate`] with the accuracy tier chosen for this call.
    pub fn evaluate_tier(
        &self,
        tier: Tier,
        rays: &Rays<'_>,
        mut out: Outputs<'_>,
    ) -> Result<(), BatchError> {
        out.check(rays.len())?;
        kernel::evaluate(self, rays, &mut out, tier.width());
        Ok(())
    }

    /// The scalar path: the same kernel one ray at a time, always the Accurate tier.
    /// Bit-identical to [`Scene::evaluate`] in the Accurate tier.
    pub fn evaluate_scalar(&self, rays: &Rays<'_>, mut out: Outputs<'_>) -> Result<(), BatchError> {
        out.check(rays.len())?;
        kernel::evaluate(self, rays, &mut out, Width::Scalar);
        Ok(())
    }

    /// Like [`Scene::evaluate`], in parallel with rayon over cache-sized chunks.
    /// Bit-identical to [`Scene::evaluate`].
    pub fn evaluate_par(&self, rays: &Rays<'_>, out: Outputs<'_>) -> Result<(), BatchError> {
        self.evaluate_par_tier(self.tier, rays, out)
    }

    /// [`Scene::evaluate_par`] with the accuracy tier chosen for this call.
    pub fn evaluate_par_tier(
        &self,
        tier: Tier,
        rays: &Rays<'_>,
        out: Outputs<'_>,
    ) -> Result<(), BatchError> {
        out.check(rays.len())?;
        kernel::evaluate_par(self, rays, out, tier.width());
        Ok(())
    }

    /// The fog along one ray `origin + s * dir`, s in [0, t] (scalar path, Accurate tier).
    pub fn eval_ray(&self, origin: Vec3, dir: Vec3, t: f32) -> FogSample {
        let (o, d) = (origin.to_array(), dir.to_array());
        let (mut tau, mut tr, mut li) = ([[0.0f32]; 3], [[0.0f32]; 3], [[0.0f32]; 3]);
        let [t0, t1, t2] = &mut tau;
        let [x0, x1, x2] = &mut tr;
        let [l0, l1, l2] = &mut li;
        let rays = Rays {
            o: [&o[0..1], &o[1..2], &o[2..3]],
            d: [&d[0..1], &d[1..2], &d[2..3]],
            t: core::slice::from_ref(&t),
            unit: false,
        };
        let mut out = Outputs {
            tau: Some([t0, t1, t2]),
            transmittance: Some([x0, x1, x2]),
            inscattering: Some([l0, l1, l2]),
        };
        kernel::evaluate(self, &rays, &mut out, Width::Scalar);
        let v = |a: [[f32; 1]; 3]| Vec3::new(a[0][0], a[1][0], a[2][0]);
        FogSample {
            tau: v(tau),
            transmittance: v(tr),
            inscattering: v(li),
        }
    }
}

/// The README's Rust examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
