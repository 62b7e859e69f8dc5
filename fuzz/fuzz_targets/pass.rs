//! Fuzzes the framebuffer pass with arbitrary f32 bit patterns for one height fog layer
//! (the scenes of the pass's own kernel and, where it declines them, of the batch kernel),
//! a perspective camera, a depth convention and the depth buffer.
//!
//! Scenes and cameras that `Scene::new`, `Camera::perspective` or the pass reject are
//! skipped. The frame is fogged twice, with the pass's own kernel where it applies and with
//! the batch API's kernel (`Scene::with_batch_kernel_pass`), on a finite, non-negative
//! surface colour, and checked for:
//! - no panic;
//! - for a pixel whose depth is not NaN (any other value is a valid depth: ±inf and
//!   negative values included): no NaN and no negative value in either result;
//! - a NaN depth gives NaN in both (all three channels): never a plausible colour;
//! - where both results are finite, the up vector is an axis and the scene's lights,
//!   scattering and surface are moderate (below 1e3), they agree within 1e-3 relative
//!   (the two kernels' accuracy bounds are far tighter; this guards against a wrong
//!   branch, not rounding). With a general up vector both kernels round it, and a ray
//!   within 1e-7 rad of the horizontal to t = +∞ may get τ = +∞ from one and a large finite
//!   τ from the other: the problem's condition is unbounded there.
//!
//! `RUSTC_BOOTSTRAP=1 cargo fuzz run pass -- -max_total_time=60`

#![no_main]

use analytic_fog::pass::{Camera, ColourBuffer, Depth, DepthConvention};
use analytic_fog::{Component, HeightFogLayer, Lighting, Phase, Scene, SceneDesc, Sun, Tier};
use glam::Vec3;
use libfuzzer_sys::fuzz_target;

#[path = "input.rs"]
mod input;
use input::Input;

fuzz_target!(|data: &[u8]| {
    let mut inp = Input::new(data);
    let flags = inp.byte();
    let up = match flags & 3 {
        0 => Vec3::Y,
        1 => Vec3::NEG_Z,
        2 => Vec3::X,
        _ => inp.vec3(),
    };
    let base_height = inp.f32();
    let falloff = inp.f32();
    let scattering = inp.vec3().abs();
    let absorption = Vec3::splat(inp.f32().abs());
    let g = inp.f32();
    let phase = match inp.byte() % 4 {
        0 => Phase::Isotropic,
        1 => Phase::Rayleigh,
        2 => Phase::HenyeyGreenstein(g),
        _ => Phase::CornetteShanks(g),
    };
    let ambient = inp.vec3().abs();
    let sun = if flags & 4 != 0 {
        Some(Sun {
            direction: inp.vec3(),
            radiance: inp.vec3().abs(),
        })
    } else {
        None
    };
    let desc = SceneDesc {
        up,
        height_fog: vec![HeightFogLayer {
            base_height,
            falloff,
            emission: Vec3::ZERO,
            components: vec![Component {
                scattering,
                absorption,
                phase,
            }],
        }],
        lighting: Lighting { ambient, sun },
        tier: if flags & 8 != 0 {
            Tier::Fast
        } else {
            Tier::Accurate
        },
        ..SceneDesc::default()
    };
    let Ok(scene) = Scene::new(desc) else {
        return;
    };
    let (w, h) = (
        1 + (inp.byte() % 19) as usize,
        1 + (inp.byte() % 4) as usize,
    );
    let position = inp.vec3();
    let forward = inp.vec3();
    let up_hint = inp.vec3();
    let fov = inp.f32();
    let Ok(camera) = Camera::perspective(position, forward, up_hint, fov, w as f32 / h as f32)
    else {
        return;
    };
    let convention = match (flags >> 4) & 3 {
        0 => DepthConvention::LinearView,
        1 => DepthConvention::Distance,
        k => DepthConvention::NdcZeroToOne {
            near: inp.f32(),
            far: inp.f32(),
            reversed: k == 3,
        },
    };
    let depth: Vec<f32> = (0..w * h).map(|_| inp.f32()).collect();
    let surface: Vec<f32> = (0..3 * w * h)
        .map(|_| {
            let v = inp.f32().abs();
            if v.is_finite() {
                v
            } else {
                0.5
            }
        })
        .collect();
    let d = Depth {
        values: &depth,
        convention,
    };
    let mut own = surface.clone();
    if scene
        .fog_pass(&camera, w, h, d, ColourBuffer::Rgb(&mut own))
        .is_err()
    {
        return;
    }
    let mut batch = surface.clone();
    scene
        .clone()
        .with_batch_kernel_pass()
        .fog_pass_single(&camera, w, h, d, ColourBuffer::Rgb(&mut batch))
        .unwrap();
    let moderate = flags & 3 != 3
        && [scattering, ambient]
            .iter()
            .chain(scene.desc().lighting.sun.as_ref().map(|s| &s.radiance))
            .all(|v| v.max_element() < 1e3);
    for i in 0..w * h {
        for c in 0..3 {
            let (a, b, s) = (own[3 * i + c], batch[3 * i + c], surface[3 * i + c]);
            if depth[i].is_nan() {
                assert!(
                    a.is_nan() && b.is_nan(),
                    "pixel {i}: NaN depth gave {a}, {b}"
                );
                continue;
            }
            assert!(
                a >= 0.0 && b >= 0.0,
                "pixel {i} channel {c}: {a}, {b} (depth {}, {convention:?}, {camera:?}, {:?})",
                depth[i],
                scene.desc()
            );
            if moderate && s < 1e3 && a.is_finite() && b.is_finite() {
                assert!(
                    (a - b).abs() <= 1e-3 * (1.0 + a.abs().max(b.abs())),
                    "pixel {i} channel {c}: own kernel {a}, batch kernel {b} (depth {})",
                    depth[i]
                );
            }
        }
    }
});
