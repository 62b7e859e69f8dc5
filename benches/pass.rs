//! The framebuffer fog pass at 1920×1080: one RGB height fog layer, a Henyey–Greenstein
//! sun and ambient light, linear view depth (a ground plane and sky), interleaved RGB.
//!
//! - `pass/fog_par`, `pass/fog_single`: `Scene::fog_pass` / `Scene::fog_pass_single`
//!   (this frame runs the pass's own one-layer kernel).
//! - `pass/fog_par_fast`, `pass/fog_single_fast`: the same with `Tier::Fast`.
//! - `pass/fog_single_batch_kernel`: `fog_pass_single` with the batch API's kernel
//!   (`Scene::with_batch_kernel_pass`, bit-identical to `Scene::evaluate`).
//! - `pass/plain_par`, `pass/plain_single`: a pass that reads the same depth and colour
//!   and writes the colour (colour = colour·0.5 + depth·1e-3), with the same row split.
//! - `pass/naive_scalar_glam`: what a renderer author writes first: per pixel, glam
//!   `Vec3`, std `f32::exp`, the closed-form height fog integral, HG phase; one thread.
//!
//! `cargo bench --bench pass -- --warm-up-time 1 --measurement-time 5`

use analytic_fog::pass::{Camera, ColourBuffer, Depth, DepthConvention};
use analytic_fog::{Component, HeightFogLayer, Lighting, Phase, Scene, SceneDesc, Sun, Tier};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Duration;

const W: usize = 1920;
const H: usize = 1080;
const B: f32 = 0.1;
const H0: f32 = 0.0;
const SCATTERING: Vec3 = Vec3::new(0.02, 0.03, 0.05);
const G: f32 = 0.6;
const AMBIENT: Vec3 = Vec3::new(0.5, 0.6, 0.7);
const SUN_RADIANCE: Vec3 = Vec3::new(20.0, 18.0, 15.0);
const FOV_Y: f32 = 1.0;
const EYE: Vec3 = Vec3::new(0.0, 2.0, 0.0);

fn sun_dir() -> Vec3 {
    Vec3::new(0.3, 0.4, -0.87).normalize()
}

fn forward() -> Vec3 {
    Vec3::new(0.0, -0.15, -1.0).normalize()
}

fn scene() -> Scene {
    Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: H0,
            falloff: B,
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: SCATTERING,
                absorption: Vec3::ZERO,
                phase: Phase::HenyeyGreenstein(G),
            }],
        }],
        lighting: Lighting {
            ambient: AMBIENT,
            sun: Some(Sun {
                direction: sun_dir(),
                radiance: SUN_RADIANCE,
            }),
        },
        ..SceneDesc::default()
    })
    .unwrap()
}

fn camera() -> Camera {
    Camera::perspective(EYE, forward(), Vec3::Y, FOV_Y, W as f32 / H as f32).unwrap()
}

/// Linear view depth of a ground plane y = 0 seen from the camera (clipped at 2000),
/// sky (+inf) above the horizon; colour: a deterministic pattern in [0, 1].
fn frame() -> (Vec<f32>, Vec<f32>) {
    let cam = camera();
    let mut depth = vec![0.0f32; W * H];
    let mut colour = vec![0.0f32; 3 * W * H];
    for y in 0..H {
        for x in 0..W {
            let r = cam
                .pixel_ray(x, y, W, H, 1.0, DepthConvention::LinearView)
                .unwrap();
            let z = if r.direction.y < 0.0 {
                (-EYE.y / r.direction.y).min(2000.0)
            } else {
                f32::INFINITY
            };
            let i = y * W + x;
            depth[i] = z;
            for c in 0..3 {
                colour[3 * i + c] = ((x * 7 + y * 13 + c * 5) % 97) as f32 / 97.0;
            }
        }
    }
    (depth, colour)
}

/// The straightforward per-pixel implementation: glam and std's exp, one thread.
struct Naive {
    eye: Vec3,
    fwd: Vec3,
    right: Vec3,
    up: Vec3,
    tan_y: f32,
    tan_x: f32,
}

impl Naive {
    fn new() -> Naive {
        let fwd = forward();
        let right = fwd.cross(Vec3::Y).normalize();
        let up = right.cross(fwd);
        let tan_y = (FOV_Y * 0.5).tan();
        Naive {
            eye: EYE,
            fwd,
            right,
            up,
            tan_y,
            tan_x: tan_y * W as f32 / H as f32,
        }
    }

    fn run(&self, depth: &[f32], colour: &mut [f32]) {
        let extinction = SCATTERING; // no absorption
        let sun = sun_dir();
        for y in 0..H {
            for x in 0..W {
                let i = y * W + x;
                let u = (x as f32 + 0.5) * 2.0 / W as f32 - 1.0;
                let v = 1.0 - (y as f32 + 0.5) * 2.0 / H as f32;
                let ray = self.fwd + self.right * (u * self.tan_x) + self.up * (v * self.tan_y);
                let len = ray.length();
                let dir = ray / len;
                let dist = depth[i] * len; // linear view depth to distance
                                           // Optical depth of sigma * exp(-b (h - h0)) along the ray.
                let density0 = (-B * (self.eye.y - H0)).exp();
                let bdy = B * dir.y;
                let integral = if bdy.abs() < 1e-5 {
                    dist
                } else {
                    (1.0 - (-bdy * dist).exp()) / bdy
                };
                let tau = extinction * (density0 * integral);
                let trans = Vec3::new((-tau.x).exp(), (-tau.y).exp(), (-tau.z).exp());
                // Henyey–Greenstein phase for the sun, plus ambient.
                let cos = dir.dot(sun);
                let phase = (1.0 - G * G)
                    / (4.0 * std::f32::consts::PI * (1.0 + G * G - 2.0 * G * cos).powf(1.5));
                let fog_colour = SCATTERING * (AMBIENT + SUN_RADIANCE * phase) / extinction;
                let l_in = fog_colour * (Vec3::ONE - trans);
                let c = Vec3::from_slice(&colour[3 * i..3 * i + 3]);
                let out = c * trans + l_in;
                colour[3 * i..3 * i + 3].copy_from_slice(&out.to_array());
            }
        }
    }
}

/// The plain pass: reads depth and colour, writes colour, same row bands as the fog pass.
fn plain(depth: &[f32], colour: &mut [f32], par: bool) {
    let band = (4096 / W).max(1);
    let f = |(c, d): (&mut [f32], &[f32])| {
        for (px, z) in c.chunks_exact_mut(3).zip(d) {
            for v in px {
                *v = *v * 0.5 + *z * 1e-3;
            }
        }
    };
    if par {
        colour
            .par_chunks_mut(3 * W * band)
            .zip(depth.par_chunks(W * band))
            .for_each(f);
    } else {
        colour
            .chunks_mut(3 * W * band)
            .zip(depth.chunks(W * band))
            .for_each(f);
    }
}

fn bench(c: &mut Criterion) {
    let scene = scene();
    let cam = camera();
    let (depth, colour) = frame();
    // Depth for the plain pass: finite (sky at 1e4), so that its colour stays finite.
    let depth_plain: Vec<f32> = depth.iter().map(|&z| z.min(1e4)).collect();

    // How close the naive implementation is to the pass (a sanity check, printed).
    {
        let mut a = colour.clone();
        let mut b = colour.clone();
        scene
            .fog_pass(
                &cam,
                W,
                H,
                Depth::linear_view(&depth),
                ColourBuffer::Rgb(&mut a),
            )
            .unwrap();
        Naive::new().run(&depth, &mut b);
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs() / x.abs().max(1e-3))
            .fold(0.0f32, f32::max);
        eprintln!("pass vs naive: max relative difference {worst:.2e}");
    }

    let mut g = c.benchmark_group("pass");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    let mut buf = colour.clone();
    g.bench_function("fog_par", |b| {
        b.iter(|| {
            scene
                .fog_pass(
                    &cam,
                    W,
                    H,
                    Depth::linear_view(black_box(&depth)),
                    ColourBuffer::Rgb(&mut buf),
                )
                .unwrap()
        })
    });
    // `fog_single`: one core. `fog_single_lanes8`: the own kernel 8 lanes wide (the same
    // as `fog_single` unless the build has AVX-512). `fog_single_no_avx512_dispatch`: the
    // own kernel at 16 lanes without the run-time AVX-512 dispatch (`wide::f32x16`, two
    // AVX2 halves per operation in an AVX2 build; the same as `fog_single` where
    // `analytic_fog::avx512_dispatch()` is false).
    for (name, sc) in [
        ("fog_single", scene.clone()),
        ("fog_single_lanes8", scene.clone().with_pass_lanes_8()),
        (
            "fog_single_no_avx512_dispatch",
            scene.clone().without_avx512_dispatch(),
        ),
    ] {
        let mut buf = colour.clone();
        g.bench_function(name, |b| {
            b.iter(|| {
                sc.fog_pass_single(
                    &cam,
                    W,
                    H,
                    Depth::linear_view(black_box(&depth)),
                    ColourBuffer::Rgb(&mut buf),
                )
                .unwrap()
            })
        });
    }
    // The Fast tier (`Tier::Fast`: T and E within its 1e-4 budget) through the own
    // kernel, on both cores and on one.
    let fast = scene.clone().with_tier(Tier::Fast);
    let mut buf = colour.clone();
    g.bench_function("fog_par_fast", |b| {
        b.iter(|| {
            fast.fog_pass(
                &cam,
                W,
                H,
                Depth::linear_view(black_box(&depth)),
                ColourBuffer::Rgb(&mut buf),
            )
            .unwrap()
        })
    });
    let mut buf = colour.clone();
    g.bench_function("fog_single_fast", |b| {
        b.iter(|| {
            fast.fog_pass_single(
                &cam,
                W,
                H,
                Depth::linear_view(black_box(&depth)),
                ColourBuffer::Rgb(&mut buf),
            )
            .unwrap()
        })
    });
    let batch_kernel = scene.clone().with_batch_kernel_pass();
    let mut buf = colour.clone();
    g.bench_function("fog_single_batch_kernel", |b| {
        b.iter(|| {
            batch_kernel
                .fog_pass_single(
                    &cam,
                    W,
                    H,
                    Depth::linear_view(black_box(&depth)),
                    ColourBuffer::Rgb(&mut buf),
                )
                .unwrap()
        })
    });
    let mut buf = colour.clone();
    g.bench_function("plain_par", |b| {
        b.iter(|| plain(black_box(&depth_plain), &mut buf, true))
    });
    let mut buf = colour.clone();
    g.bench_function("plain_single", |b| {
        b.iter(|| plain(black_box(&depth_plain), &mut buf, false))
    });
    let naive = Naive::new();
    let mut buf = colour.clone();
    g.bench_function("naive_scalar_glam", |b| {
        b.iter(|| naive.run(black_box(&depth), &mut buf))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);
