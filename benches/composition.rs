//! The cost of the two compositions of in-scattering (issue 5): `composition/<mode>/<scene>`
//! for `mode` in {`mix`, `ordered`} on the two scenes of `reference::composition_scenes`
//! (`behind`: a bright volume behind a dark one; `side_by_side`: the same two volumes
//! beside each other), and `height_only` (the same height fog without volumes) as the
//! floor. 128 × 128 rays of `reference::composition_rays` (a view through both volumes,
//! unit directions), T and L_in wanted, one thread. Each has a `<name>_lanes8` twin: the
//! build's own 8 lanes (`Scene::without_avx512_dispatch`) where the CPU's AVX-512 is
//! chosen at run time (16 lanes); elsewhere the same as `<name>`.
//!
//! `cargo bench --bench composition -- --warm-up-time 1 --measurement-time 3 --noplot`

use analytic_fog::reference::{composition_rays, composition_scenes};
use analytic_fog::{Composition, Outputs, Rays, Scene, SceneDesc};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

const SIDE: usize = 128;

fn bench(c: &mut Criterion) {
    let rays = composition_rays(SIDE);
    let n = rays.len();
    let col = |f: &dyn Fn(usize) -> f32| (0..n).map(f).collect::<Vec<f32>>();
    let o = [0, 1, 2].map(|k| col(&|i| rays[i].0[k] as f32));
    let d = [0, 1, 2].map(|k| col(&|i| rays[i].1[k] as f32));
    let t = col(&|i| rays[i].2 as f32);
    let batch = Rays::new(&o[0], &o[1], &o[2], &d[0], &d[1], &d[2], &t)
        .expect("equal lengths")
        .with_unit_directions(true);
    let mut out: [Vec<f32>; 6] = std::array::from_fn(|_| vec![0.0; n]);
    let mut g = c.benchmark_group("composition");
    g.throughput(Throughput::Elements(n as u64));
    let mut run = |name: String, desc: SceneDesc| {
        let scene = Scene::new(desc).expect("valid scene");
        let narrow = scene.clone().without_avx512_dispatch();
        for (name, scene) in [(name.clone(), &scene), (format!("{name}_lanes8"), &narrow)] {
            g.bench_function(name, |b| {
                b.iter(|| {
                    let [t0, t1, t2, l0, l1, l2] = &mut out;
                    let o = Outputs {
                        tau: None,
                        transmittance: Some([t0, t1, t2]),
                        inscattering: Some([l0, l1, l2]),
                    };
                    scene.evaluate(black_box(&batch), o).expect("lengths");
                })
            });
        }
    };
    let scenes = composition_scenes();
    run(
        "height_only".into(),
        SceneDesc {
            volumes: vec![],
            ..scenes[0].1.clone()
        },
    );
    for (name, desc) in &scenes {
        for (mode, comp) in [("mix", Composition::Mix), ("ordered", Composition::Ordered)] {
            run(
                format!("{mode}/{name}"),
                SceneDesc {
                    composition: comp,
                    ..desc.clone()
                },
            );
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
