//! Fog volume throughput per profile: the kernel (x8 and scalar), the seeds' formulas
//! (seed 002's antiderivatives in f32 with its origin shift; seed 004's `computeFog` for
//! the quadratic profile) and ray marching with 16, 64 and 256 midpoint steps, on the same
//! rays. Before timing, each method's max error against the f64 reference over the rays
//! (relative to the volume's depth through its centre) is printed, so that speed can be
//! compared at equal error.
//!
//! `cargo bench --bench volumes` (all), a filter such as `cargo bench --bench volumes --
//! gaussian`, `-- --quick` for a short run, or a filter that matches no benchmark
//! (`-- errors-only`) to print the errors alone.
//!
//! The rays: a unit sphere seen from 3 to 30 radii away, aimed at a random point of
//! the sphere (every ray hits), half of them clipped by a depth inside the sphere.

use analytic_fog::reference::volume as rv;
use analytic_fog::{Outputs, Profile, Rays, Scene, SceneDesc, Shape, Volume};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::{DVec3, Vec3};
use std::time::Duration;

const N: usize = 4096;
const CENTER: Vec3 = Vec3::new(0.5, -0.25, 2.0);

struct RaySet {
    o: [Vec<f32>; 3],
    d: [Vec<f32>; 3],
    t: Vec<f32>,
}

fn rays() -> RaySet {
    let mut s: u64 = 88172645463325252;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut unit = || loop {
        let v = DVec3::new(uni() * 2.0 - 1.0, uni() * 2.0 - 1.0, uni() * 2.0 - 1.0);
        let l = v.length();
        if l > 0.1 && l <= 1.0 {
            return v / l;
        }
    };
    let mut r = RaySet {
        o: Default::default(),
        d: Default::default(),
        t: vec![],
    };
    for i in 0..N {
        let dist = 3.0 * 10f64.powf((i % 97) as f64 / 97.0);
        let o = CENTER.as_dvec3() + unit() * dist;
        let target = CENTER.as_dvec3() + unit() * 0.95 * ((i % 13) as f64 / 13.0).cbrt();
        let d = (target - o).normalize();
        let t = if i % 2 == 0 {
            f32::INFINITY
        } else {
            ((target - o).length() * (0.8 + 0.4 * ((i % 7) as f64 / 7.0))) as f32
        };
        for c in 0..3 {
            r.o[c].push(o[c] as f32);
            r.d[c].push(d[c] as f32);
        }
        r.t.push(t);
    }
    r
}

fn shape() -> Shape {
    Shape::Sphere {
        center: CENTER,
        radius: 1.0,
    }
}

fn scene(p: Profile) -> Scene {
    Scene::new(SceneDesc {
        volumes: vec![Volume::new(shape(), p, Vec3::ONE)],
        ..SceneDesc::default()
    })
    .unwrap()
}

fn ray(r: &RaySet, i: usize) -> (Vec3, Vec3, f32) {
    (
        Vec3::new(r.o[0][i], r.o[1][i], r.o[2][i]),
        Vec3::new(r.d[0][i], r.d[1][i], r.d[2][i]),
        r.t[i],
    )
}

/// Ray marching in f32: the sphere's chord by the quadratic formula, then `steps`
/// midpoint samples of the profile.
fn march(p: Profile, o: Vec3, d: Vec3, t: f32, steps: u32) -> f32 {
    let q = o - CENTER;
    let a = d.dot(d);
    let b = q.dot(d);
    let c = q.dot(q) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return 0.0;
    }
    let sq = disc.sqrt();
    let s0 = ((-b - sq) / a).max(0.0);
    let s1 = ((-b + sq) / a).min(t);
    if s1 <= s0 || s1.is_nan() {
        return 0.0;
    }
    let h = (s1 - s0) / steps as f32;
    let mut acc = 0.0;
    for k in 0..steps {
        let x = q + d * (s0 + (k as f32 + 0.5) * h);
        let r = x.length();
        let f = match p {
            Profile::Constant => 1.0,
            Profile::Linear => 1.0 - r,
            Profile::Quadratic => 1.0 - r * r,
            Profile::Quartic => (1.0 - r * r) * (1.0 - r * r),
            Profile::Spiky => (1.0 - r) * (1.0 - r),
            Profile::Gaussian => (-8.0 * r * r).exp(),
        };
        acc += if r <= 1.0 { f } else { 0.0 };
    }
    acc * h * d.length()
}

fn seed(p: Profile, o: Vec3, d: Vec3, t: f32) -> f32 {
    rv::seed002_depth(p, CENTER, 1.0, o, d, t)
}

fn seed004(o: Vec3, d: Vec3, t: f32) -> f32 {
    rv::compute_fog_seed004(o, d, CENTER, 1.0, t) / 0.75
}

/// Max error of `f` over the ray set against the f64 reference, relative to the
/// integral through the centre (the volume's full depth): an absolute error in τ scaled
/// to the volume, not dominated by grazing rays whose own condition is large.
fn max_error(r: &RaySet, p: Profile, f: impl Fn(Vec3, Vec3, f32) -> f32) -> f64 {
    let full = rv::volume_depth(
        &shape(),
        p,
        &[],
        CENTER.as_dvec3() - DVec3::X * 3.0,
        DVec3::X,
        f64::INFINITY,
    );
    let mut worst: f64 = 0.0;
    for i in 0..N {
        let (o, d, t) = ray(r, i);
        let want = rv::volume_depth(&shape(), p, &[], o.as_dvec3(), d.as_dvec3(), t as f64);
        worst = worst.max((f(o, d, t) as f64 - want).abs() / full);
    }
    worst
}

fn bench(c: &mut Criterion) {
    let r = rays();
    let name = |p: Profile| format!("{p:?}").to_lowercase();
    for p in Profile::ALL {
        let sc = scene(p);
        let kernel = |o: Vec3, d: Vec3, t: f32| sc.eval_ray(o, d, t).tau.x;
        println!(
            "volumes/{}: max error / (depth through the centre) over {N} rays",
            name(p)
        );
        println!("  kernel (x8 = scalar): {:.2e}", max_error(&r, p, kernel));
        println!(
            "  seed 002 formula:     {:.2e}",
            max_error(&r, p, |o, d, t| seed(p, o, d, t))
        );
        if p == Profile::Quadratic {
            println!("  seed 004 computeFog:  {:.2e}", max_error(&r, p, seed004));
        }
        for steps in [16, 64, 256] {
            println!(
                "  ray march {steps:>3} steps: {:.2e}",
                max_error(&r, p, |o, d, t| march(p, o, d, t, steps))
            );
        }

        let mut g = c.benchmark_group(format!("volumes/{}", name(p)));
        g.throughput(Throughput::Elements(N as u64));
        g.warm_up_time(Duration::from_millis(300));
        g.measurement_time(Duration::from_secs(2));
        let rays = Rays::new(&r.o[0], &r.o[1], &r.o[2], &r.d[0], &r.d[1], &r.d[2], &r.t)
            .unwrap()
            .with_unit_directions(true);
        let mut out = [vec![0.0f32; N], vec![0.0f32; N], vec![0.0f32; N]];
        g.bench_function("x8", |b| {
            b.iter(|| {
                let [x, y, z] = &mut out;
                sc.evaluate(
                    black_box(&rays),
                    Outputs {
                        tau: Some([x, y, z]),
                        ..Outputs::default()
                    },
                )
                .unwrap()
            })
        });
        // The build's own 8 lanes where `x8` dispatches to 16 AVX-512 lanes at run time
        // (`analytic_fog::avx512_dispatch()`; the same kernel elsewhere).
        let narrow = sc.clone().without_avx512_dispatch();
        g.bench_function("x8_lanes8", |b| {
            b.iter(|| {
                let [x, y, z] = &mut out;
                narrow
                    .evaluate(
                        black_box(&rays),
                        Outputs {
                            tau: Some([x, y, z]),
                            ..Outputs::default()
                        },
                    )
                    .unwrap()
            })
        });
        g.bench_function("scalar", |b| {
            b.iter(|| {
                let [x, y, z] = &mut out;
                sc.evaluate_scalar(
                    black_box(&rays),
                    Outputs {
                        tau: Some([x, y, z]),
                        ..Outputs::default()
                    },
                )
                .unwrap()
            })
        });
        let per_ray = |f: &dyn Fn(Vec3, Vec3, f32) -> f32, out: &mut Vec<f32>| {
            for (i, x) in out.iter_mut().enumerate() {
                let (o, d, t) = ray(&r, i);
                *x = f(black_box(o), d, t);
            }
        };
        g.bench_function("seed002", |b| {
            b.iter(|| per_ray(&|o, d, t| seed(p, o, d, t), &mut out[0]))
        });
        if p == Profile::Quadratic {
            g.bench_function("seed004", |b| b.iter(|| per_ray(&seed004, &mut out[0])));
        }
        for steps in [16u32, 64, 256] {
            g.bench_function(format!("march{steps}"), |b| {
                b.iter(|| per_ray(&|o, d, t| march(p, o, d, t, steps), &mut out[0]))
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
