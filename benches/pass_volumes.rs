//! The framebuffer fog pass with many fog volumes (issue 5): a 1920×1080 frame, one RGB
//! height fog layer, a Henyey–Greenstein sun and ambient light (the scene and camera of
//! `benches/pass.rs`: linear view depth of a ground plane, sky above the horizon),
//! interleaved RGB, one thread (`Scene::fog_pass_single`, for stable ratios), plus fog
//! volumes:
//!
//! - `volumes_1000/tile_culled`: 1,000 small volumes (spheres, ellipsoids, boxes; all six
//!   profiles) scattered in view, in front of the ground, 10 to 400 units away; the
//!   pass as shipped (per-tile candidate lists, then the per-packet test on them).
//! - `volumes_10/tile_culled`: only the 10 of them that cover the most pixels (coverage
//!   counted once, before timing, by evaluating each volume alone on the pixels of its
//!   projected bounding box: a pixel is covered if its τ > 0).
//! - `volumes_1000/packet_culled_only`: the 1,000 volumes, per-packet test only
//!   (`Scene::without_tile_culling`: each packet tests every volume's bounding sphere).
//! - `volumes_1000/unculled`: the 1,000 volumes with all culling off
//!   (`Scene::without_culling`: every volume evaluated on every pixel). About 60 s per
//!   1920×1080 frame, so it runs on a 240×135 frame of the same view (1/64 of the pixels;
//!   the cost per pixel does not depend on the frame size here): compare it per pixel
//!   (criterion's throughput, elements = pixels) or scale its time by 64.
//! - `volumes_0/fog_only`: no volumes (the height fog alone, for scale).
//! - `volumes_1000/tile_culled_lanes8`, `volumes_10/tile_culled_lanes8`: the same with the
//!   build's own 8 lanes (`Scene::without_avx512_dispatch`) where the CPU's AVX-512 is
//!   chosen at run time (16 lanes); elsewhere the same as `tile_culled`.
//! - `volumes_1000/tile_culled_ordered`, `volumes_10/tile_culled_ordered`: `tile_culled`
//!   with the volumes composited front to back (`Composition::Ordered`; the others mix
//!   the media's fog colours).
//!
//! Before timing it prints the coverage and the candidates per tile.
//!
//! `cargo bench --bench pass_volumes` (about 3 minutes; `-- tile_culled` for the fast ones).

use analytic_fog::pass::{Camera, ColourBuffer, Depth, DepthConvention};
use analytic_fog::{
    Component, Composition, HeightFogLayer, Lighting, Outputs, Phase, Profile, Rays, Scene,
    SceneDesc, Shape, Sun, Volume,
};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::{Quat, Vec3};
use std::time::Duration;

const W: usize = 1920;
const H: usize = 1080;
/// The frame of `volumes_1000/unculled`: 1/64 of the pixels, same aspect.
const W_SMALL: usize = 240;
const H_SMALL: usize = 135;
const FOV_Y: f32 = 1.0;
const EYE: Vec3 = Vec3::new(0.0, 2.0, 0.0);
const VOLUMES: usize = 1000;

fn forward() -> Vec3 {
    Vec3::new(0.0, -0.15, -1.0).normalize()
}

fn camera(w: usize, h: usize) -> Camera {
    Camera::perspective(EYE, forward(), Vec3::Y, FOV_Y, w as f32 / h as f32).unwrap()
}

fn scene(volumes: Vec<Volume>) -> Scene {
    scene_composed(volumes, Composition::Mix)
}

fn scene_composed(volumes: Vec<Volume>, composition: Composition) -> Scene {
    Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: 0.1,
            emission: Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::new(0.02, 0.03, 0.05),
                absorption: Vec3::ZERO,
                phase: Phase::HenyeyGreenstein(0.6),
            }],
        }],
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87).normalize(),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        },
        volumes,
        composition,
        ..SceneDesc::default()
    })
    .unwrap()
}

/// Linear view depth of the ground plane y = 0 (clipped at 2000), sky above the horizon;
/// colour: a deterministic pattern.
fn frame(w: usize, h: usize) -> (Vec<f32>, Vec<f32>) {
    let cam = camera(w, h);
    let mut depth = vec![0.0f32; w * h];
    let mut colour = vec![0.0f32; 3 * w * h];
    for y in 0..h {
        for x in 0..w {
            let r = cam
                .pixel_ray(x, y, w, h, 1.0, DepthConvention::LinearView)
                .unwrap();
            let i = y * w + x;
            depth[i] = if r.direction.y < 0.0 {
                (-EYE.y / r.direction.y).min(2000.0)
            } else {
                f32::INFINITY
            };
            for c in 0..3 {
                colour[3 * i + c] = ((x * 7 + y * 13 + c * 5) % 97) as f32 / 97.0;
            }
        }
    }
    (depth, colour)
}

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn f(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// 1,000 small volumes scattered in view: each centred on the ray of a random pixel, at a
/// log-uniform distance in [10, 400] but in front of the ground there, size 0.3 to 1.2.
fn volumes(depth: &[f32]) -> Vec<Volume> {
    let cam = camera(W, H);
    let mut rng = Rng(0x0123_4567_89ab_cdef);
    (0..VOLUMES)
        .map(|i| {
            let (x, y) = (rng.below(W), rng.below(H));
            let r = cam
                .pixel_ray(x, y, W, H, 1.0, DepthConvention::LinearView)
                .unwrap();
            let z_max = (0.9 * depth[y * W + x]).min(400.0);
            let z = (10f32.ln() + (z_max.max(10.5).ln() - 10f32.ln()) * rng.f()).exp();
            let center = r.origin + r.direction * z;
            let size = rng.range(0.3, 1.2);
            let rotation = Quat::from_rotation_y(rng.range(0.0, std::f32::consts::TAU));
            let (shape, profile) = match i % 4 {
                0 | 1 => (
                    Shape::Sphere {
                        center,
                        radius: size,
                    },
                    Profile::ALL[rng.below(6)],
                ),
                2 => (
                    Shape::Ellipsoid {
                        center,
                        radii: Vec3::new(size, 0.5 * size, 0.8 * size),
                        rotation,
                    },
                    Profile::ALL[rng.below(6)],
                ),
                _ => (
                    Shape::Box {
                        center,
                        half_extents: Vec3::new(size, 0.6 * size, 0.8 * size),
                        rotation,
                        edge_fade: 0.3,
                    },
                    Profile::Constant,
                ),
            };
            let mut v = Volume::new(shape, profile, Vec3::new(0.6, 0.5, 0.4) / size);
            v.phase = Phase::HenyeyGreenstein(0.3);
            v
        })
        .collect()
}

/// The pixels of the `W × H` frame each volume covers (τ > 0 when evaluated alone),
/// counted on the pixels of its projected bounding box.
fn coverage(vols: &[Volume], depth: &[f32]) -> Vec<usize> {
    let cam = camera(W, H);
    let f = forward();
    let right = f.cross(Vec3::Y).normalize();
    let up = right.cross(f);
    let th = (FOV_Y * 0.5).tan();
    let tw = th * W as f32 / H as f32;
    vols.iter()
        .map(|v| {
            let (c, b) = match v.shape {
                Shape::Sphere { center, radius } => (center, radius),
                Shape::Ellipsoid { center, radii, .. } => (center, radii.max_element()),
                Shape::Affine { center, matrix } => (
                    center,
                    matrix
                        .iter()
                        .map(|m| m.length_squared())
                        .sum::<f32>()
                        .sqrt(),
                ),
                Shape::Box {
                    center,
                    half_extents,
                    ..
                } => (center, half_extents.length()),
            };
            let q = c - EYE;
            let (x, y, z) = (q.dot(right), q.dot(up), q.dot(f));
            let (xa, xb, ya, yb) = if z - b > 0.1 {
                let ext = |p: f32| {
                    let r = [(p - b) / (z - b), (p - b) / (z + b), (p + b) / (z - b)];
                    let r = [r[0], r[1], r[2], (p + b) / (z + b)];
                    (
                        r.iter().cloned().fold(f32::INFINITY, f32::min),
                        r.iter().cloned().fold(f32::NEG_INFINITY, f32::max),
                    )
                };
                let (ulo, uhi) = ext(x);
                let (vlo, vhi) = ext(y);
                let px = |u: f32| ((u / tw + 1.0) * 0.5 * W as f32 - 0.5) as isize;
                let py = |v: f32| ((1.0 - v / th) * 0.5 * H as f32 - 0.5) as isize;
                (px(ulo) - 2, px(uhi) + 2, py(vhi) - 2, py(vlo) + 2)
            } else {
                (0, W as isize - 1, 0, H as isize - 1)
            };
            let (xa, xb) = (xa.max(0) as usize, (xb.min(W as isize - 1)).max(0) as usize);
            let (ya, yb) = (ya.max(0) as usize, (yb.min(H as isize - 1)).max(0) as usize);
            let mut cols: [Vec<f32>; 7] = Default::default();
            for py in ya..=yb {
                for px in xa..=xb {
                    let r = cam
                        .pixel_ray(
                            px,
                            py,
                            W,
                            H,
                            depth[py * W + px],
                            DepthConvention::LinearView,
                        )
                        .unwrap();
                    let vals = [
                        r.origin.x,
                        r.origin.y,
                        r.origin.z,
                        r.direction.x,
                        r.direction.y,
                        r.direction.z,
                        r.t,
                    ];
                    for k in 0..7 {
                        cols[k].push(vals[k]);
                    }
                }
            }
            let alone = Scene::new(SceneDesc {
                volumes: vec![v.clone()],
                ..SceneDesc::default()
            })
            .unwrap();
            let rays = Rays::new(
                &cols[0], &cols[1], &cols[2], &cols[3], &cols[4], &cols[5], &cols[6],
            )
            .unwrap();
            let n = cols[6].len();
            let (mut t0, mut t1, mut t2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            alone
                .evaluate(
                    &rays,
                    Outputs {
                        tau: Some([&mut t0, &mut t1, &mut t2]),
                        ..Outputs::default()
                    },
                )
                .unwrap();
            t0.iter().filter(|&&t| t > 0.0).count()
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let (depth, colour) = frame(W, H);
    let (depth_s, colour_s) = frame(W_SMALL, H_SMALL);
    let vols = volumes(&depth);
    let cover = coverage(&vols, &depth);
    let mut order: Vec<usize> = (0..vols.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(cover[i]));
    let top: Vec<Volume> = order[..10].iter().map(|&i| vols[i].clone()).collect();
    let total: usize = cover.iter().sum();
    let top_total: usize = order[..10].iter().map(|&i| cover[i]).sum();
    eprintln!(
        "coverage, pixel-volume pairs with tau > 0: 1000 volumes {total} ({:.1} % of the frame's \
         pixels), the top 10 {top_total} ({:.1} %); largest {}, median {}",
        100.0 * total as f64 / (W * H) as f64,
        100.0 * top_total as f64 / (W * H) as f64,
        cover[order[0]],
        cover[order[500]],
    );
    let s1000 = scene(vols.clone());
    let s10 = scene(top);
    let s0 = scene(Vec::new());
    let cam = camera(W, H);
    let cam_s = camera(W_SMALL, H_SMALL);
    for (name, s) in [("1000", &s1000), ("10", &s10)] {
        let lists = s
            .fog_pass_tile_candidates(&cam, W, H, Depth::linear_view(&depth))
            .unwrap()
            .unwrap();
        let mean = lists.iter().sum::<usize>() as f64 / lists.len() as f64;
        let max = lists.iter().max().unwrap();
        let empty = lists.iter().filter(|&&k| k == 0).count();
        eprintln!(
            "{name} volumes: {} tiles of {:?} px, candidates per tile mean {mean:.2}, max {max}, \
             {empty} tiles with none",
            lists.len(),
            Scene::tile_size()
        );
    }

    let run = |s: &Scene, cam: &Camera, w: usize, h: usize, d: &[f32], buf: &mut Vec<f32>| {
        s.fog_pass_single(
            cam,
            w,
            h,
            Depth::linear_view(black_box(d)),
            ColourBuffer::Rgb(buf),
        )
        .unwrap()
    };

    let mut g = c.benchmark_group("volumes_1000");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    let mut buf = colour.clone();
    g.bench_function("tile_culled", |b| {
        b.iter(|| run(&s1000, &cam, W, H, &depth, &mut buf))
    });
    let s1000_8 = s1000.clone().without_avx512_dispatch();
    g.bench_function("tile_culled_lanes8", |b| {
        b.iter(|| run(&s1000_8, &cam, W, H, &depth, &mut buf))
    });
    let s1000_ordered = scene_composed(vols.clone(), Composition::Ordered);
    g.bench_function("tile_culled_ordered", |b| {
        b.iter(|| run(&s1000_ordered, &cam, W, H, &depth, &mut buf))
    });
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(15));
    let packet_only = s1000.clone().without_tile_culling();
    let mut buf = colour.clone();
    g.bench_function("packet_culled_only", |b| {
        b.iter(|| run(&packet_only, &cam, W, H, &depth, &mut buf))
    });
    g.throughput(Throughput::Elements((W_SMALL * H_SMALL) as u64));
    let unculled = s1000.clone().without_culling();
    let mut buf = colour_s.clone();
    g.bench_function("unculled", |b| {
        b.iter(|| run(&unculled, &cam_s, W_SMALL, H_SMALL, &depth_s, &mut buf))
    });
    g.finish();

    let mut g = c.benchmark_group("volumes_10");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    let mut buf = colour.clone();
    g.bench_function("tile_culled", |b| {
        b.iter(|| run(&s10, &cam, W, H, &depth, &mut buf))
    });
    let s10_8 = s10.clone().without_avx512_dispatch();
    g.bench_function("tile_culled_lanes8", |b| {
        b.iter(|| run(&s10_8, &cam, W, H, &depth, &mut buf))
    });
    let s10_ordered = scene_composed(s10.desc().volumes.clone(), Composition::Ordered);
    g.bench_function("tile_culled_ordered", |b| {
        b.iter(|| run(&s10_ordered, &cam, W, H, &depth, &mut buf))
    });
    g.finish();

    let mut g = c.benchmark_group("volumes_0");
    g.throughput(Throughput::Elements((W * H) as u64));
    g.sample_size(20);
    let mut buf = colour;
    g.bench_function("fog_only", |b| {
        b.iter(|| run(&s0, &cam, W, H, &depth, &mut buf))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().warm_up_time(Duration::from_secs(1));
    targets = bench
}
criterion_main!(benches);
