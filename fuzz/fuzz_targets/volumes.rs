//! Fuzzes the fog-volume kernels with arbitrary f32 bit patterns for the volumes'
//! parameters (shapes, profiles, coefficients, cut-outs), an optional height fog layer,
//! sun, start/cutoff distance and maximum opacity, either composition of the in-scattering,
//! and a batch of rays.
//!
//! The scene is built through `Scene::new` (inputs it rejects are skipped); the batch is
//! evaluated with `evaluate` (8 lanes), `evaluate_scalar` and `evaluate_par`, and checked
//! for:
//!
//! - no panic, anywhere;
//! - x8, scalar and rayon bit-identical for every output (any NaN matching any NaN: see
//!   `same`);
//! - for a valid ray (finite o and d, t ≥ 0 or +inf) in a valid scene: no NaN, τ ≥ 0,
//!   0 ≤ T ≤ 1, L_in ≥ 0 and not NaN;
//! - for an invalid ray (NaN or ±inf in o or d, t NaN or negative) in a scene with at
//!   least one additive volume: NaN τ in every channel.
//!
//! `RUSTC_BOOTSTRAP=1 cargo fuzz run volumes -- -max_total_time=60`

#![no_main]

use analytic_fog::{
    Component, Composition, HeightFogLayer, Lighting, Outputs, Phase, Profile, Rays, Scene,
    SceneDesc, Shape, Sun, Volume,
};
use glam::{Quat, Vec3};
use libfuzzer_sys::fuzz_target;

#[path = "input.rs"]
mod input;
use input::Input;

const MAX_RAYS: usize = 29;

fn shape_from(inp: &mut Input, raw: bool) -> Shape {
    let sel = inp.byte();
    let center = inp.vec3();
    match sel % 4 {
        0 => Shape::Sphere {
            center,
            radius: inp.abs3(raw).x,
        },
        1 => Shape::Ellipsoid {
            center,
            radii: inp.abs3(raw),
            rotation: Quat::from_xyzw(inp.f32(), inp.f32(), inp.f32(), inp.f32()),
        },
        2 => Shape::Affine {
            center,
            matrix: [inp.vec3(), inp.vec3(), inp.vec3()],
        },
        _ => {
            let half_extents = inp.abs3(raw);
            let rotation = Quat::from_xyzw(inp.f32(), inp.f32(), inp.f32(), inp.f32());
            let f = inp.f32();
            let edge_fade = if raw { f } else { f.abs().fract() };
            Shape::Box {
                center,
                half_extents,
                rotation,
                edge_fade,
            }
        }
    }
}

fn scene_from(inp: &mut Input) -> SceneDesc {
    let flags = inp.byte();
    let raw = flags & 0x80 != 0;
    let n = (flags & 3) as usize + 1;
    let mut volumes = Vec::new();
    for _ in 0..n {
        let shape = shape_from(inp, raw);
        let sel = inp.byte();
        let profile = Profile::ALL[(sel % 6) as usize];
        let profile = if matches!(shape, Shape::Box { .. }) && !raw {
            Profile::Constant
        } else {
            profile
        };
        let g = inp.f32();
        let g = if raw { g } else { g.abs().fract() * 0.99 };
        let phase = match (sel >> 3) % 4 {
            0 => Phase::Isotropic,
            1 => Phase::Rayleigh,
            2 => Phase::HenyeyGreenstein(g),
            _ => Phase::CornetteShanks(g),
        };
        volumes.push(Volume {
            shape,
            profile,
            scattering: inp.abs3(raw),
            absorption: inp.abs3(raw),
            phase,
            emission: inp.abs3(raw),
            subtractive: sel & 0x80 != 0,
        });
    }
    let height_fog = if flags & 0x20 != 0 {
        vec![HeightFogLayer {
            base_height: inp.f32(),
            falloff: inp.f32(),
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: inp.abs3(raw),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
            }],
        }]
    } else {
        vec![]
    };
    let ambient = inp.abs3(raw);
    let sun = if flags & 0x10 != 0 {
        Some(Sun {
            direction: inp.vec3(),
            radiance: inp.abs3(raw),
        })
    } else {
        None
    };
    let mut desc = SceneDesc {
        height_fog,
        lighting: Lighting { ambient, sun },
        volumes,
        // Bit 2: the ordered composition of the volumes' in-scattering.
        composition: if flags & 0x04 != 0 {
            Composition::Ordered
        } else {
            Composition::Mix
        },
        ..SceneDesc::default()
    };
    if flags & 0x40 != 0 {
        // Start/cutoff distances (the ray is cut before the volumes see it) and a maximum
        // opacity.
        let pos = |inp: &mut Input| {
            let v = inp.f32();
            if raw {
                v
            } else {
                v.abs()
            }
        };
        let c = inp.byte();
        desc.limits.start_distance = pos(inp);
        if c & 1 != 0 {
            desc.limits.cutoff_distance = Some(pos(inp));
        }
        if c & 2 != 0 {
            let m = inp.f32();
            desc.limits.max_opacity = if raw {
                m
            } else {
                (m.to_bits() & 0xff_ffff) as f32 / 16_777_216.0
            };
        }
    }
    desc
}

fn run(scene: &Scene, rays: &Rays, mode: u8, n: usize) -> Vec<Vec<f32>> {
    let mut o = vec![vec![-7.0f32; n]; 9];
    {
        let [t0, t1, t2, x0, x1, x2, l0, l1, l2] = &mut o[..] else {
            unreachable!()
        };
        let out = Outputs {
            tau: Some([t0, t1, t2]),
            transmittance: Some([x0, x1, x2]),
            inscattering: Some([l0, l1, l2]),
        };
        match mode {
            0 => scene.evaluate(rays, out).unwrap(),
            1 => scene.evaluate_scalar(rays, out).unwrap(),
            _ => scene.evaluate_par(rays, out).unwrap(),
        }
    }
    o
}

/// Bit-identical, except that any NaN equals any NaN: an invalid ray's outputs combine
/// NaNs from several sources (the input's payload, the volumes' canonical NaN, the height
/// fog's guard), and which payload survives an operation on two NaNs is up to the
/// instruction the compiler picks for each instantiation.
fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fuzz_target!(|data: &[u8]| {
    let mut inp = Input::new(data);
    let desc = scene_from(&mut inp);
    let unit = inp.byte() & 1 != 0;
    let n = (inp.remaining() / 28).min(MAX_RAYS);
    let mut cols: [Vec<f32>; 7] = Default::default();
    for _ in 0..n {
        for c in cols.iter_mut() {
            c.push(inp.f32());
        }
    }
    let additive = desc.volumes.iter().any(|v| !v.subtractive);
    let scene = match Scene::new(desc) {
        Ok(s) => s,
        Err(_) => return,
    };
    let [ox, oy, oz, dx, dy, dz, t] = &cols;
    let rays = Rays::new(ox, oy, oz, dx, dy, dz, t)
        .unwrap()
        .with_unit_directions(unit);
    let x8 = run(&scene, &rays, 0, n);
    let sc = run(&scene, &rays, 1, n);
    let par = run(&scene, &rays, 2, n);
    for k in 0..9 {
        for i in 0..n {
            assert!(
                same(x8[k][i], sc[k][i]),
                "x8 vs scalar, output {k} ray {i}: {:e} vs {:e}; ray {:?} unit {unit}; {:?}",
                x8[k][i],
                sc[k][i],
                [ox[i], oy[i], oz[i], dx[i], dy[i], dz[i], t[i]],
                scene.desc().volumes
            );
            assert!(same(x8[k][i], par[k][i]), "x8 vs par, output {k} ray {i}");
        }
    }
    for i in 0..n {
        let fin = [ox[i], oy[i], oz[i], dx[i], dy[i], dz[i]]
            .iter()
            .all(|v| v.is_finite());
        let valid = fin && (t[i] >= 0.0);
        for ch in 0..3 {
            let (tau, tr, li) = (x8[ch][i], x8[3 + ch][i], x8[6 + ch][i]);
            if valid {
                let ctx = || {
                    format!(
                        "ray {i} {:?} unit {unit}; {:?}",
                        [ox[i], oy[i], oz[i], dx[i], dy[i], dz[i], t[i]],
                        scene.desc()
                    )
                };
                assert!(tau >= 0.0, "τ {tau}; {}", ctx());
                assert!((0.0..=1.0).contains(&tr), "T {tr}; {}", ctx());
                assert!(li >= 0.0, "L_in {li}; {}", ctx());
            } else if additive {
                assert!(
                    tau.is_nan(),
                    "invalid ray {i} gave τ {tau}: {:?} unit {unit}; {:?}",
                    [ox[i], oy[i], oz[i], dx[i], dy[i], dz[i], t[i]],
                    scene.desc()
                );
            }
        }
    }
});
