//! The composition of in-scattering (`Composition::Mix` and `Composition::Ordered`):
//! the kernels against the f64 models (`reference::ordered_sample`, `mixed_sample`), the
//! models against a ray-marched single-scattering reference (`reference::marched_sample`),
//! and the properties every kernel keeps (x8 = scalar = parallel, no NaN).

mod common;

use analytic_fog::reference::{
    composition_rays, composition_scenes, marched_sample, mixed_sample, ordered_sample,
};
use analytic_fog::{
    Component, Composition, HeightFogLayer, Lighting, Outputs, Phase, Profile, Rays, Scene,
    SceneDesc, Shape, Sun, Volume,
};
use common::Rng;
use glam::{DVec3, Vec3};

struct Batch {
    o: [Vec<f32>; 3],
    d: [Vec<f32>; 3],
    t: Vec<f32>,
}

impl Batch {
    fn of(rays: &[(DVec3, DVec3, f64)]) -> Batch {
        let c = |f: &dyn Fn(&(DVec3, DVec3, f64)) -> f32| rays.iter().map(f).collect::<Vec<_>>();
        Batch {
            o: [
                c(&|r| r.0.x as f32),
                c(&|r| r.0.y as f32),
                c(&|r| r.0.z as f32),
            ],
            d: [
                c(&|r| r.1.x as f32),
                c(&|r| r.1.y as f32),
                c(&|r| r.1.z as f32),
            ],
            t: c(&|r| r.2 as f32),
        }
    }
    fn rays(&self) -> Rays<'_> {
        Rays::new(
            &self.o[0], &self.o[1], &self.o[2], &self.d[0], &self.d[1], &self.d[2], &self.t,
        )
        .unwrap()
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Path {
    X8,
    /// `X8` at the build's own width (no run-time AVX-512 dispatch).
    X8Narrow,
    Scalar,
    Par,
}

/// (T, L_in) per ray and channel through one of the batch paths.
fn run(scene: &Scene, b: &Batch, path: Path) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let n = b.t.len();
    let mut tr = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
    let mut li = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
    {
        let [t0, t1, t2] = &mut tr;
        let [l0, l1, l2] = &mut li;
        let out = Outputs {
            tau: None,
            transmittance: Some([t0, t1, t2]),
            inscattering: Some([l0, l1, l2]),
        };
        let rays = b.rays();
        match path {
            Path::X8 => scene.evaluate(&rays, out),
            Path::X8Narrow => scene.clone().without_avx512_dispatch().evaluate(&rays, out),
            Path::Scalar => scene.evaluate_scalar(&rays, out),
            Path::Par => scene.evaluate_par(&rays, out),
        }
        .unwrap();
    }
    let pick = |a: &[Vec<f32>; 3]| (0..n).map(|i| [a[0][i], a[1][i], a[2][i]]).collect();
    (pick(&tr), pick(&li))
}

fn with(desc: &SceneDesc, c: Composition) -> SceneDesc {
    SceneDesc {
        composition: c,
        ..desc.clone()
    }
}

/// The largest colour any medium of the scene can have on these rays (the scale the
/// errors of L_in are measured in): L_in ≤ that.
fn colour_scale(desc: &SceneDesc, rays: &[(DVec3, DVec3, f64)]) -> f64 {
    let mut m: f64 = 0.0;
    for &(_, d, _) in rays {
        for v in desc.volumes.iter().filter(|v| !v.subtractive) {
            let c = analytic_fog::reference::volume::volume_colour(v, &desc.lighting, d);
            m = m.max(c.into_iter().fold(0.0, f64::max));
        }
        let cos = analytic_fog::reference::cos_sun(desc, d);
        for l in &desc.height_fog {
            let c = analytic_fog::reference::layer_colour(desc, l, cos);
            m = m.max(c.into_iter().fold(0.0, f64::max));
        }
    }
    m
}

/// A random scene of 0–2 height fog layers and 1–6 volumes (spheres, ellipsoids, boxes,
/// every profile, some cut-outs) in front of a camera at (0, 1, 0) looking along +Z.
fn random_scene(rng: &mut Rng) -> SceneDesc {
    let rgb = |rng: &mut Rng, a: f64, b: f64| {
        Vec3::new(
            rng.range(a, b) as f32,
            rng.range(a, b) as f32,
            rng.range(a, b) as f32,
        )
    };
    let layers = (0..rng.pick(3))
        .map(|_| HeightFogLayer {
            base_height: rng.range(-2.0, 2.0) as f32,
            falloff: rng.range(-0.1, 0.5) as f32,
            components: vec![Component {
                scattering: rgb(rng, 0.0, 0.03),
                absorption: rgb(rng, 0.0, 0.01),
                phase: if rng.pick(2) == 0 {
                    Phase::Isotropic
                } else {
                    Phase::HenyeyGreenstein(rng.range(-0.8, 0.8) as f32)
                },
            }],
            emission: rgb(rng, 0.0, 0.2),
        })
        .collect();
    let mut volumes = Vec::new();
    for _ in 0..1 + rng.pick(6) {
        let center = Vec3::new(
            rng.range(-4.0, 4.0) as f32,
            rng.range(-1.0, 3.0) as f32,
            rng.range(6.0, 30.0) as f32,
        );
        let shape = match rng.pick(3) {
            0 => Shape::Sphere {
                center,
                radius: rng.range(0.5, 4.0) as f32,
            },
            1 => Shape::Ellipsoid {
                center,
                radii: rgb(rng, 0.5, 4.0),
                rotation: glam::Quat::from_rotation_y(rng.range(0.0, 3.0) as f32),
            },
            _ => Shape::Box {
                center,
                half_extents: rgb(rng, 0.5, 3.0),
                rotation: glam::Quat::from_rotation_x(rng.range(0.0, 3.0) as f32),
                edge_fade: rng.range(0.0, 1.0) as f32,
            },
        };
        let is_box = matches!(shape, Shape::Box { .. });
        if rng.pick(6) == 0 {
            volumes.push(Volume::cut(shape));
            continue;
        }
        let profile = if is_box {
            Profile::Constant
        } else {
            Profile::ALL[rng.pick(6)]
        };
        volumes.push(Volume {
            absorption: rgb(rng, 0.0, 0.5),
            emission: rgb(rng, 0.0, 3.0),
            phase: if rng.pick(2) == 0 {
                Phase::Isotropic
            } else {
                Phase::Rayleigh
            },
            ..Volume::new(shape, profile, rgb(rng, 0.0, 1.0))
        });
    }
    SceneDesc {
        height_fog: layers,
        lighting: Lighting {
            ambient: rgb(rng, 0.0, 1.0),
            sun: (rng.pick(3) > 0).then(|| Sun {
                direction: Vec3::new(0.3, 0.8, -0.5),
                radiance: rgb(rng, 0.0, 3.0),
            }),
        },
        volumes,
        composition: Composition::Ordered,
        ..SceneDesc::default()
    }
}

/// The kernels' ordered composition against its f64 model on random scenes. T is the
/// same bits as with `Mix` (the composition changes only L_in; T's accuracy is the
/// volumes' and the height fog's, tested in `tests/volumes.rs` and `tests/height_fog.rs`).
/// L_in: |ΔL_in| ≤ (4e-6 + 8 · |ΔT|) · the colour scale, with |ΔT| the ray's largest
/// error of T against the reference: the ordered sum is a combination of the same
/// transmittances (each term's weight moves with the optical depths the way T does; a
/// ray grazing a volume's boundary has a large condition and both move together), plus
/// a few ulps of the colours and exponentials per volume. Measured worst: see the
/// message printed with `--nocapture`.
#[test]
fn ordered_kernel_matches_its_f64_model() {
    let mut rng = Rng::new(41);
    let rays = composition_rays(24);
    let b = Batch::of(&rays);
    let (mut worst_l, mut worst_t) = (0.0f64, 0.0f64);
    for _ in 0..40 {
        let desc = random_scene(&mut rng);
        let scene = Scene::new(desc.clone()).unwrap();
        let mix = Scene::new(with(&desc, Composition::Mix)).unwrap();
        let scale = colour_scale(&desc, &rays).max(1e-30);
        let (tr, li) = run(&scene, &b, Path::X8);
        let (tr_mix, _) = run(&mix, &b, Path::X8);
        for (i, &(o, d, t)) in rays.iter().enumerate() {
            let (rt, rl) = ordered_sample(&desc, o, d, t);
            let et = (0..3)
                .map(|ch| (tr[i][ch] as f64 - rt[ch]).abs())
                .fold(0.0, f64::max);
            worst_t = worst_t.max(et);
            for ch in 0..3 {
                assert_eq!(tr[i][ch].to_bits(), tr_mix[i][ch].to_bits(), "T, ray {i}");
                let el = (li[i][ch] as f64 - rl[ch]).abs() / scale;
                worst_l = worst_l.max(el - 8.0 * et);
                assert!(
                    el <= 4e-6 + 8.0 * et,
                    "ray {i} ch {ch}: L_in {} vs {} (scale {scale}), |ΔT| {et:.2e}",
                    li[i][ch],
                    rl[ch],
                );
            }
        }
    }
    eprintln!("worst |ΔL_in|/scale − 8|ΔT| = {worst_l:.3e}; worst |ΔT| = {worst_t:.3e}");
}

/// Mix through the kernel against its f64 model on the same scenes (the composition
/// switch must leave `Mix` as it was).
#[test]
fn mix_kernel_matches_its_f64_model() {
    let mut rng = Rng::new(42);
    let rays = composition_rays(16);
    let b = Batch::of(&rays);
    for _ in 0..20 {
        let desc = with(&random_scene(&mut rng), Composition::Mix);
        let scene = Scene::new(desc.clone()).unwrap();
        let scale = colour_scale(&desc, &rays).max(1e-30);
        let (_, li) = run(&scene, &b, Path::X8);
        for (i, &(o, d, t)) in rays.iter().enumerate() {
            let (_, rl) = mixed_sample(&desc, o, d, t);
            for ch in 0..3 {
                let el = (li[i][ch] as f64 - rl[ch]).abs() / scale;
                assert!(el <= 2e-5, "ray {i} ch {ch}: {} vs {}", li[i][ch], rl[ch]);
            }
        }
    }
}

/// Without height fog and with volumes that no ray crosses in overlapping pieces, the
/// ordered composition is exact: the model against the march within the march's own
/// error (measured: halving the step changes it by < 1e-6 of the scale here).
#[test]
fn ordered_is_exact_for_separate_volumes() {
    let (_, behind) = &composition_scenes()[0];
    let desc = SceneDesc {
        height_fog: vec![],
        composition: Composition::Ordered,
        ..behind.clone()
    };
    let rays = composition_rays(12);
    let scale = colour_scale(&desc, &rays);
    let scene = Scene::new(desc.clone()).unwrap();
    let (_, li) = run(&scene, &Batch::of(&rays), Path::X8);
    let mut hit = 0;
    for (i, &(o, d, t)) in rays.iter().enumerate() {
        let (_, m) = marched_sample(&desc, o, d, t, 400);
        let (_, m2) = marched_sample(&desc, o, d, t, 800);
        let (_, r) = ordered_sample(&desc, o, d, t);
        for ch in 0..3 {
            let conv = (m[ch] - m2[ch]).abs() / scale;
            assert!(conv < 1e-6, "march not converged: {} vs {}", m[ch], m2[ch]);
            assert!(
                (r[ch] - m2[ch]).abs() <= 1e-5 * scale,
                "ray {i}: ordered model {} vs march {}",
                r[ch],
                m2[ch]
            );
            assert!(
                (li[i][ch] as f64 - m2[ch]).abs() <= 3e-5 * scale,
                "ray {i}: kernel {} vs march {}",
                li[i][ch],
                m2[ch]
            );
        }
        hit += (m2[0] > 1e-3 * scale) as usize;
    }
    assert!(hit > 20, "too few rays see the volumes: {hit}");
}

/// Where order matters (a bright volume behind a dark one), the mix is far off and the
/// ordered composition is close; where it does not, both are close. Against the march,
/// as a fraction of the colour scale, worst ray and channel.
#[test]
fn ordered_fixes_what_the_mix_gets_wrong() {
    let rays = composition_rays(12);
    let b = Batch::of(&rays);
    for (name, desc) in composition_scenes() {
        let scale = colour_scale(&desc, &rays);
        let mut worst = [0.0f64; 2];
        for (k, c) in [Composition::Mix, Composition::Ordered]
            .into_iter()
            .enumerate()
        {
            let scene = Scene::new(with(&desc, c)).unwrap();
            let (_, li) = run(&scene, &b, Path::X8);
            for (i, &(o, d, t)) in rays.iter().enumerate() {
                let (_, m) = marched_sample(&desc, o, d, t, 200);
                for ch in 0..3 {
                    worst[k] = worst[k].max((li[i][ch] as f64 - m[ch]).abs() / scale);
                }
            }
        }
        eprintln!(
            "{name}: worst error mix {:.3e}, ordered {:.3e}",
            worst[0], worst[1]
        );
        match name {
            "behind" => {
                assert!(
                    worst[0] > 0.05,
                    "the mix should be wrong here: {}",
                    worst[0]
                );
                assert!(worst[1] < 0.01, "ordered: {}", worst[1]);
            }
            _ => {
                // No ray crosses both volumes: what is left is the order between each
                // volume and the thin height fog around it, which both approximate.
                assert!(worst[0] < 0.05 && worst[1] < 0.05, "{worst:?}");
                assert!(worst[1] <= worst[0], "{worst:?}");
            }
        }
    }
}

/// One volume in no height fog: both compositions are exact and agree with each other.
#[test]
fn one_medium_both_compositions_agree() {
    let (_, behind) = &composition_scenes()[0];
    let desc = SceneDesc {
        height_fog: vec![],
        volumes: behind.volumes[1..].to_vec(),
        ..behind.clone()
    };
    let rays = composition_rays(16);
    let b = Batch::of(&rays);
    let scale = colour_scale(&desc, &rays);
    let (_, a) = run(
        &Scene::new(with(&desc, Composition::Mix)).unwrap(),
        &b,
        Path::X8,
    );
    let (_, o) = run(
        &Scene::new(with(&desc, Composition::Ordered)).unwrap(),
        &b,
        Path::X8,
    );
    for i in 0..rays.len() {
        for ch in 0..3 {
            assert!(
                (a[i][ch] - o[i][ch]).abs() as f64 <= 1e-6 * scale,
                "ray {i}: {} vs {}",
                a[i][ch],
                o[i][ch]
            );
        }
    }
}

/// x8, scalar and rayon give the same bits with the ordered composition (batches of
/// every length up to 40, so every tail of 8 and 16 lanes), with and without the run-time
/// AVX-512 dispatch, and extreme rays give no NaN.
#[test]
fn ordered_paths_agree_and_stay_finite() {
    let mut rng = Rng::new(43);
    for k in 0..80 {
        let desc = random_scene(&mut rng);
        let scene = Scene::new(desc).unwrap();
        let n = 1 + k % 40;
        let rays: Vec<(DVec3, DVec3, f64)> = (0..n)
            .map(|_| {
                let o = DVec3::new(
                    rng.sign() * rng.log_range(1e-3, 1e30),
                    rng.range(-5.0, 5.0),
                    rng.sign() * rng.log_range(1e-3, 1e30),
                );
                let d = DVec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                let t = match rng.pick(4) {
                    0 => f64::INFINITY,
                    1 => 0.0,
                    _ => rng.log_range(1e-3, 1e30),
                };
                (o.as_vec3().as_dvec3(), d.as_vec3().as_dvec3(), t)
            })
            .collect();
        let b = Batch::of(&rays);
        let x8 = run(&scene, &b, Path::X8);
        let sc = run(&scene, &b, Path::Scalar);
        let par = run(&scene, &b, Path::Par);
        let narrow = run(&scene, &b, Path::X8Narrow);
        let bits = |v: &(Vec<[f32; 3]>, Vec<[f32; 3]>)| {
            v.0.iter()
                .chain(&v.1)
                .flat_map(|x| x.map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&x8), bits(&sc), "x8 vs scalar");
        assert_eq!(bits(&x8), bits(&par), "x8 vs par");
        assert_eq!(bits(&x8), bits(&narrow), "x8 vs its own width");
        for (i, ray) in rays.iter().enumerate() {
            for ch in 0..3 {
                let (t, l) = (x8.0[i][ch], x8.1[i][ch]);
                assert!((0.0..=1.0).contains(&t), "T = {t}");
                assert!(l >= 0.0 && l.is_finite(), "L_in = {l} (ray {ray:?})");
            }
        }
    }
}
