//! The cost of each fog control (issue 3) on top of one RGB height fog layer with sun and
//! ambient, 64K typical rays (the C peer's data set, as `benches/height_fog.rs`), full
//! radiance, one thread: `controls/<name>` for the plain layer (`none`: the single-layer
//! fast path), the same layer through the general kernel (`general`: what a scene with any
//! control starts from), and each control alone.
//!
//! `cargo bench --bench controls -- --warm-up-time 1 --measurement-time 3`

use analytic_fog::reference::peer::PeerRays;
use analytic_fog::{
    Component, DistanceFog, Falloff, FogLimits, HeightFogLayer, Lighting, Lobe, Outputs, Phase,
    Rays, Scene, SceneDesc, Sun,
};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;

const N: usize = 65_536;

/// The C peer's typical rays (unit directions in the x-y plane, cameras 0..10 above the
/// base, t up to 1000 or to the ground).
fn rays() -> [Vec<f32>; 7] {
    let p = PeerRays::new(N, false);
    let z = vec![0.0f32; N];
    [z.clone(), p.oy.clone(), z.clone(), p.dx(), p.dy, z, p.t]
}

fn base() -> SceneDesc {
    SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: 0.1,
            components: vec![Component {
                scattering: Vec3::new(0.02, 0.03, 0.05),
                absorption: Vec3::ZERO,
                phase: Phase::HenyeyGreenstein(0.6),
            }],
            emission: Vec3::ZERO,
        }],
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        },
        ..SceneDesc::default()
    }
}

fn cases() -> Vec<(&'static str, SceneDesc)> {
    let fog = |falloff| {
        Some(DistanceFog {
            falloff,
            colour: Vec3::new(0.5, 0.6, 0.7),
        })
    };
    let with = |f: &dyn Fn(&mut SceneDesc)| {
        let mut d = base();
        f(&mut d);
        d
    };
    vec![
        ("none", base()),
        // An empty cutoff beyond every ray: the general kernel, no other work.
        (
            "general",
            with(&|d| d.limits.cutoff_distance = Some(f32::MAX)),
        ),
        (
            "distance_linear",
            with(&|d| {
                d.distance_fog = fog(Falloff::Linear {
                    start: 10.0,
                    end: 800.0,
                })
            }),
        ),
        (
            "distance_exponential",
            with(&|d| d.distance_fog = fog(Falloff::from_visibility(500.0))),
        ),
        (
            "distance_exponential_squared",
            with(&|d| d.distance_fog = fog(Falloff::from_visibility_squared(500.0))),
        ),
        (
            "distance_atmospheric",
            with(&|d| {
                d.distance_fog = fog(Falloff::from_visibility_colours(
                    500.0,
                    Vec3::new(0.3, 0.2, 0.1),
                    Vec3::new(0.6, 0.7, 0.9),
                ))
            }),
        ),
        (
            "start_cutoff",
            with(&|d| {
                d.limits = FogLimits {
                    start_distance: 5.0,
                    cutoff_distance: Some(600.0),
                    ..FogLimits::default()
                }
            }),
        ),
        ("max_opacity", with(&|d| d.limits.max_opacity = 0.8)),
        (
            "lobe",
            with(&|d| {
                d.lobe = Some(Lobe {
                    colour: Vec3::new(1.0, 0.8, 0.5),
                    exponent: 8.0,
                })
            }),
        ),
        (
            "emission",
            with(&|d| d.height_fog[0].emission = Vec3::new(0.1, 0.05, 0.0)),
        ),
    ]
}

fn controls(c: &mut Criterion) {
    let r = rays();
    let rays = Rays::new(&r[0], &r[1], &r[2], &r[3], &r[4], &r[5], &r[6])
        .unwrap()
        .with_unit_directions(true);
    let mut out: Vec<Vec<f32>> = vec![vec![0.0; N]; 6];
    let mut g = c.benchmark_group("controls");
    g.throughput(Throughput::Elements(N as u64));
    for (name, desc) in cases() {
        let scene = Scene::new(desc).unwrap();
        // `<case>_lanes8`: the build's own 8 lanes where `<case>` dispatches to 16 AVX-512
        // lanes at run time (`analytic_fog::avx512_dispatch()`; the same kernel elsewhere).
        let narrow = scene.clone().without_avx512_dispatch();
        for (id, sc) in [
            (name.to_string(), &scene),
            (format!("{name}_lanes8"), &narrow),
        ] {
            g.bench_function(id, |b| {
                b.iter(|| {
                    let [t0, t1, t2, l0, l1, l2] = &mut out[..] else {
                        unreachable!()
                    };
                    sc.evaluate(
                        black_box(&rays),
                        Outputs {
                            transmittance: Some([t0, t1, t2]),
                            inscattering: Some([l0, l1, l2]),
                            ..Outputs::default()
                        },
                    )
                    .unwrap();
                })
            });
        }
    }
    g.finish();
}

criterion_group!(benches, controls);
criterion_main!(benches);
