//! Height fog throughput: x8, scalar and the seeds' naive formula, on the two data sets of
//! `../shared/peers/c-libmvec/height_fog.c` (same generator, same seed, same medium), in
//! cache (64K rays) and streaming (16M rays), single thread and rayon, RGB transmittance
//! alone and full radiance; in cache also on two sets extreme for this crate's own ranges
//! (`sky`, `stiff`: [`make_crate_extreme`]).
//!
//! `cargo bench --bench height_fog` (all), or a filter such as
//! `cargo bench --bench height_fog -- transmittance_rgb`.
//! Set `FOG_BENCH_STREAM=0` to skip the 16M-ray groups.

use analytic_fog::reference::peer::PeerRays;
use analytic_fog::{
    Component, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun, Tier,
};
use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Duration;

/// The peer's medium: sigma_t = beta_rgb * exp(-b * (y - h0)), b = 0.1, h0 = 0.
const B: f32 = 0.1;
const BETA: [f32; 3] = [0.02, 0.03, 0.05];

/// The rays of one data set, structure of arrays.
pub struct RaySet {
    pub o: [Vec<f32>; 3],
    pub d: [Vec<f32>; 3],
    pub t: Vec<f32>,
}

/// The C peer's data sets (`analytic_fog::reference::peer`; the peer only uses oy, dy and
/// t; ox = oz = 0 and dx = sqrt(1 - dy^2), dz = 0 make the same rays unit length in 3-D).
pub fn make(n: usize, extreme: bool) -> RaySet {
    ray_set(PeerRays::new(n, extreme))
}

fn ray_set(p: PeerRays) -> RaySet {
    let z = vec![0.0; p.t.len()];
    RaySet {
        o: [z.clone(), p.oy.clone(), z.clone()],
        d: [p.dx(), p.dy, z],
        t: p.t,
    }
}

/// `PeerRays::crate_extreme` as a [`RaySet`] (`sky`, or `stiff`).
pub fn make_crate_extreme(n: usize, stiff: bool) -> RaySet {
    ray_set(PeerRays::crate_extreme(n, stiff))
}

fn scene(full: bool) -> Scene {
    let lighting = if full {
        Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        }
    } else {
        Lighting::default()
    };
    Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: B,
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::from_array(BETA),
                absorption: Vec3::ZERO,
                phase: if full {
                    Phase::HenyeyGreenstein(0.7)
                } else {
                    Phase::Isotropic
                },
            }],
        }],
        lighting,
        ..SceneDesc::default()
    })
    .unwrap()
}

struct Out {
    v: Vec<Vec<f32>>,
}

impl Out {
    fn new(n: usize) -> Out {
        Out {
            v: (0..9).map(|_| vec![0.0; n]).collect(),
        }
    }
    fn outputs(&mut self, full: bool) -> Outputs<'_> {
        let [a, b, c, d, e, f, ..] = &mut self.v[..] else {
            unreachable!()
        };
        Outputs {
            tau: None,
            transmittance: Some([a, b, c]),
            inscattering: if full { Some([d, e, f]) } else { None },
        }
    }
}

fn rays<'a>(r: &'a RaySet, unit: bool) -> Rays<'a> {
    Rays::new(&r.o[0], &r.o[1], &r.o[2], &r.d[0], &r.d[1], &r.d[2], &r.t)
        .unwrap()
        .with_unit_directions(unit)
}

/// Seed 000's two-branch formula in f32 with std's exp, as a renderer author writes it
/// first: tau = A/(B dz) (e^(-B oz) - e^(-B (oz + dz t))), or A e^(-B oz) t for dz = 0.
fn naive_seed(r: &RaySet, out: &mut [Vec<f32>]) {
    let (oy, dy, t) = (&r.o[1], &r.d[1], &r.t);
    let [tr, tg, tb, ..] = out else {
        unreachable!()
    };
    for i in 0..t.len() {
        let geo = if dy[i] != 0.0 {
            ((-B * oy[i]).exp() - (-B * (oy[i] + dy[i] * t[i])).exp()) / (B * dy[i])
        } else {
            (-B * oy[i]).exp() * t[i]
        };
        tr[i] = (-BETA[0] * geo).exp();
        tg[i] = (-BETA[1] * geo).exp();
        tb[i] = (-BETA[2] * geo).exp();
    }
}

fn in_cache(c: &mut Criterion) {
    let n = 65536;
    for (full, group) in [(false, "transmittance_rgb"), (true, "radiance")] {
        let sc = scene(full);
        let narrow = sc.clone().without_avx512_dispatch();
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements(n as u64));
        g.warm_up_time(Duration::from_millis(500));
        g.measurement_time(Duration::from_secs(2));
        for set in ["typical", "extreme", "sky", "stiff"] {
            let r = match set {
                "typical" | "extreme" => make(n, set == "extreme"),
                _ => make_crate_extreme(n, set == "stiff"),
            };
            let mut o = Out::new(n);
            g.bench_function(BenchmarkId::new("x8_unit", set), |b| {
                b.iter(|| sc.evaluate(&rays(&r, true), o.outputs(full)).unwrap())
            });
            // The build's own 8 lanes where `x8_unit` dispatches to 16 AVX-512 lanes at
            // run time (`analytic_fog::avx512_dispatch()`; the same kernel elsewhere).
            g.bench_function(BenchmarkId::new("x8_unit_lanes8", set), |b| {
                b.iter(|| narrow.evaluate(&rays(&r, true), o.outputs(full)).unwrap())
            });
            g.bench_function(BenchmarkId::new("x8_unit_fast", set), |b| {
                b.iter(|| {
                    sc.evaluate_tier(Tier::Fast, &rays(&r, true), o.outputs(full))
                        .unwrap()
                })
            });
            g.bench_function(BenchmarkId::new("x8_general", set), |b| {
                b.iter(|| sc.evaluate(&rays(&r, false), o.outputs(full)).unwrap())
            });
            g.bench_function(BenchmarkId::new("scalar", set), |b| {
                b.iter(|| {
                    sc.evaluate_scalar(&rays(&r, true), o.outputs(full))
                        .unwrap()
                })
            });
            g.bench_function(BenchmarkId::new("x8_rayon", set), |b| {
                b.iter(|| sc.evaluate_par(&rays(&r, true), o.outputs(full)).unwrap())
            });
            if !full {
                g.bench_function(BenchmarkId::new("naive_seed", set), |b| {
                    b.iter(|| naive_seed(black_box(&r), &mut o.v))
                });
            }
        }
        g.finish();
    }
}

/// 16M rays: the rayon path against a parallel plain copy of the same bytes (the three
/// inputs the unit-direction kernel reads, the three outputs it writes). `copy_rayon`
/// copies the arrays one after another; `copy_rayon_fused` copies all three in one loop
/// (six streams at once, the kernel's access pattern). v4 build, three runs: the fused
/// copy took 1.11–1.23× the plain copy, the kernel 1.81–1.93× the fused copy (docs/speed-history.md).
fn streaming(c: &mut Criterion) {
    if std::env::var("FOG_BENCH_STREAM").as_deref() == Ok("0") {
        return;
    }
    let n = 16 << 20;
    let sc = scene(false);
    let mut g = c.benchmark_group("streaming_16m");
    g.throughput(Throughput::Elements(n as u64));
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(500));
    g.measurement_time(Duration::from_secs(6));
    for (set, extreme) in [("typical", false), ("extreme", true)] {
        let r = make(n, extreme);
        let mut o = Out::new(n);
        g.bench_function(BenchmarkId::new("x8_rayon", set), |b| {
            b.iter(|| sc.evaluate_par(&rays(&r, true), o.outputs(false)).unwrap())
        });
        g.bench_function(BenchmarkId::new("x8_single", set), |b| {
            b.iter(|| sc.evaluate(&rays(&r, true), o.outputs(false)).unwrap())
        });
        if !extreme {
            g.bench_function(BenchmarkId::new("copy_rayon", set), |b| {
                b.iter(|| {
                    let [a, bb, cc, ..] = &mut o.v[..] else {
                        unreachable!()
                    };
                    let src = [&r.o[1], &r.d[1], &r.t];
                    for (dst, s) in [a, bb, cc].into_iter().zip(src) {
                        dst.par_chunks_mut(4096)
                            .zip(s.par_chunks(4096))
                            .for_each(|(d, s)| d.copy_from_slice(s));
                    }
                    black_box(&o.v[0][0]);
                })
            });
            g.bench_function(BenchmarkId::new("copy_rayon_fused", set), |b| {
                b.iter(|| {
                    let [a, bb, cc, ..] = &mut o.v[..] else {
                        unreachable!()
                    };
                    a.par_chunks_mut(4096)
                        .zip(bb.par_chunks_mut(4096))
                        .zip(cc.par_chunks_mut(4096))
                        .zip(r.o[1].par_chunks(4096))
                        .zip(r.d[1].par_chunks(4096))
                        .zip(r.t.par_chunks(4096))
                        .for_each(|(((((a, bb), cc), y), u), t)| {
                            let dst = a.iter_mut().zip(bb.iter_mut()).zip(cc.iter_mut());
                            let src = y.iter().zip(u).zip(t);
                            for (((a, b), c), ((y, u), t)) in dst.zip(src) {
                                *a = *y;
                                *b = *u;
                                *c = *t;
                            }
                        });
                    black_box(&o.v[0][0]);
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, in_cache, streaming);
criterion_main!(benches);
