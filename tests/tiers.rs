//! The Fast tier against the f64 reference (`Tier`'s documented bound), its invariants on
//! extreme input, and the tier selection per scene and per call.

#![allow(clippy::needless_range_loop)] // parallel per-channel columns

use analytic_fog::reference::{self as rf, self as check};
use analytic_fog::{
    Component, HeightFogLayer, Lighting, Outputs, Phase, Profile, Rays, Scene, SceneDesc, Shape,
    Sun, Tier, Volume,
};
use glam::{DVec3, Vec3};

/// The Fast tier's own error budget (`Tier`): 1e-4 in T and in L_in relative to the fog
/// colour, on top of the Accurate tier's condition-dependent error.
const FAST_T: f64 = 1e-4;
/// Relative error of τ the Fast tier adds (φ 3.4e-5, the exponential 1.4e-5, roundings).
const FAST_TAU: f64 = 1e-4;

mod common;
use common::Rng;

fn random_scene(r: &mut Rng, extreme: bool) -> SceneDesc {
    let n = 1 + (r.next() % 3) as usize;
    let phases = [
        Phase::Isotropic,
        Phase::Rayleigh,
        Phase::HenyeyGreenstein(0.7),
        Phase::HenyeyGreenstein(-0.3),
    ];
    let layers = (0..n)
        .map(|_| {
            let b = if r.next().is_multiple_of(8) {
                0.0
            } else if extreme {
                r.sign() * r.log_range(1e-8, 1e3)
            } else {
                r.sign() * r.log_range(1e-3, 1.0)
            };
            let grey = r.next().is_multiple_of(3);
            let comps = (0..1 + r.next() % 2)
                .map(|_| {
                    let s = r.log_range(1e-4, 0.2) as f32;
                    Component {
                        scattering: if grey {
                            Vec3::splat(s)
                        } else {
                            Vec3::new(s, s * 1.7, s * 3.1)
                        },
                        absorption: Vec3::splat(s * 0.1),
                        phase: phases[(r.next() % 4) as usize],
                    }
                })
                .collect();
            HeightFogLayer {
                base_height: r.range(-5.0, 5.0) as f32,
                falloff: b as f32,
                emission: glam::Vec3::ZERO,
                components: comps,
            }
        })
        .collect();
    SceneDesc {
        height_fog: layers,
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

struct Batch {
    o: [Vec<f32>; 3],
    d: [Vec<f32>; 3],
    t: Vec<f32>,
}

fn random_rays(r: &mut Rng, n: usize, extreme: bool) -> Batch {
    let mut b = Batch {
        o: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        d: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        t: vec![0.0; n],
    };
    for i in 0..n {
        let wild = extreme && i % 2 == 0;
        let y = if wild {
            r.sign() * r.log_range(1e-3, 1e6)
        } else {
            r.range(-20.0, 50.0)
        };
        let u = if wild && i % 4 == 0 {
            r.sign() * r.log_range(1e-12, 1e-3)
        } else {
            r.range(-1.0, 1.0)
        };
        let t = match i % 7 {
            0 => f64::INFINITY,
            1 if wild => r.log_range(1e4, 1e30),
            _ => r.log_range(1e-2, 1e4),
        };
        let h = (1.0 - u * u).max(0.0).sqrt();
        let az = r.range(0.0, std::f64::consts::TAU);
        b.o[0][i] = r.range(-10.0, 10.0) as f32;
        b.o[1][i] = y as f32;
        b.o[2][i] = r.range(-10.0, 10.0) as f32;
        b.d[0][i] = (h * az.cos()) as f32;
        b.d[1][i] = u as f32;
        b.d[2][i] = (h * az.sin()) as f32;
        b.t[i] = t as f32;
    }
    b
}

/// τ, T and L_in of a batch through `evaluate_tier`.
fn run(scene: &Scene, b: &Batch, tier: Tier) -> [Vec<f32>; 9] {
    let n = b.t.len();
    let mut v: [Vec<f32>; 9] = std::array::from_fn(|_| vec![0.0; n]);
    let rays = Rays::new(&b.o[0], &b.o[1], &b.o[2], &b.d[0], &b.d[1], &b.d[2], &b.t).unwrap();
    let [a, bb, c, d, e, f, g, h, i] = &mut v;
    scene
        .evaluate_tier(
            tier,
            &rays,
            Outputs {
                tau: Some([a, bb, c]),
                transmittance: Some([d, e, f]),
                inscattering: Some([g, h, i]),
            },
        )
        .unwrap();
    v
}

#[test]
fn fast_tier_within_its_bound() {
    let mut r = Rng(0x1234_5678_9abc_def1);
    let (mut worst_t, mut worst_l, mut worst_tau) = (0.0f64, 0.0f64, 0.0f64);
    let mut checked = 0;
    for case in 0..160 {
        let extreme = case % 2 == 1;
        let desc = random_scene(&mut r, extreme);
        let scene = Scene::new(desc.clone()).unwrap();
        let b = random_rays(&mut r, 67, extreme);
        let got = run(&scene, &b, Tier::Fast);
        for i in 0..b.t.len() {
            let o = DVec3::new(b.o[0][i] as f64, b.o[1][i] as f64, b.o[2][i] as f64);
            let d = DVec3::new(b.d[0][i] as f64, b.d[1][i] as f64, b.d[2][i] as f64);
            let t = b.t[i] as f64;
            let want = rf::sample(&desc, o, d, t);
            let kappa = check::condition(&desc, o, d, t);
            let delta = FAST_TAU + check::tau_tolerance(kappa);
            let cmax = want
                .layer_colours
                .iter()
                .flatten()
                .fold(0.0f64, |a, c| a.max(c.abs()));
            for ch in 0..3 {
                let (tau, tr, li) = (
                    got[ch][i] as f64,
                    got[3 + ch][i] as f64,
                    got[6 + ch][i] as f64,
                );
                assert!(
                    !tau.is_nan() && !tr.is_nan() && !li.is_nan(),
                    "NaN, case {case} ray {i}"
                );
                assert!((0.0..=1.0).contains(&tr) && tau >= 0.0 && li >= 0.0);
                let (wt, wtr) = (want.tau[ch], want.transmittance[ch]);
                // τ, where it is a normal f32 (beyond: saturation, checked through T).
                if wt > 1e-30 && wt < 1e30 {
                    let e = (tau - wt).abs() / wt;
                    worst_tau = worst_tau.max(e / delta);
                    assert!(
                        e <= delta,
                        "τ {tau} vs {wt} (κ {kappa}), case {case} ray {i}"
                    );
                }
                // T: the fast exponential's own error (1.5e-5 relative) plus what δ does
                // to e^(−τ): T·(e^(τδ) − 1).
                let spread = if wtr > 0.0 {
                    wtr * (wt * delta).min(700.0).exp_m1()
                } else {
                    0.0
                };
                let tol_t = 1.5e-5 * wtr + spread + check::EPS32;
                let et = (tr - wtr).abs();
                worst_t = worst_t.max(et);
                assert!(
                    et <= tol_t,
                    "T {tr} vs {wtr} (τ {wt}, κ {kappa}), case {case} ray {i}"
                );
                // L_in = C·(1 − T): the error of T times the colour, plus the colour
                // mix's weights (several layers) off by δ.
                let c = want.colour[ch].abs();
                let el = (li - want.inscattering[ch]).abs();
                let tol_l = c * (et + 1e-5) + cmax * delta * 2.0 + 1e-30;
                // (Rays whose τ is beyond 1e30 are left out of the statistic: there the
                // kernel's weights of several layers saturate while the reference's
                // mix uses exact ratios of the huge τ, in both tiers; κ allows it.)
                if cmax > 0.0 && wt < 1e30 {
                    worst_l = worst_l.max(el / cmax);
                }
                assert!(
                    el <= tol_l,
                    "L_in {li} vs {} (C {c}), case {case} ray {i}",
                    want.inscattering[ch]
                );
                checked += 1;
            }
        }
    }
    println!(
        "fast tier: {checked} channel samples; max |ΔT| {worst_t:.2e}, max |ΔL_in|/C {worst_l:.2e}, max τ error / bound {worst_tau:.2}"
    );
    assert!(worst_t <= FAST_T, "max |ΔT| {worst_t:e}");
    assert!(worst_l <= 2.0 * FAST_T, "max |ΔL_in| / C {worst_l:e}");
}

/// The tier is chosen per scene (`SceneDesc::tier`, `Scene::with_tier`) and per call
/// (`evaluate_tier`); the Fast tier differs from the Accurate one (so the selection is
/// real) and never by more than its bound.
#[test]
fn tier_selection() {
    let mut r = Rng(99);
    let desc = random_scene(&mut r, false);
    let b = random_rays(&mut r, 203, false);
    let acc = Scene::new(desc.clone()).unwrap();
    assert_eq!(acc.tier(), Tier::Accurate);
    let fast = Scene::new(SceneDesc {
        tier: Tier::Fast,
        ..desc.clone()
    })
    .unwrap();
    assert_eq!(fast.tier(), Tier::Fast);
    let a = run(&acc, &b, Tier::Accurate);
    let f = run(&acc, &b, Tier::Fast);
    let mut differ = 0;
    for k in 0..9 {
        for i in 0..b.t.len() {
            if a[k][i] != f[k][i] {
                differ += 1;
            }
        }
    }
    assert!(
        differ > 100,
        "the Fast tier should not reproduce the Accurate bits"
    );
    // `evaluate` runs the scene's tier; `with_tier` changes it.
    let mut v: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; b.t.len()]);
    let rays = Rays::new(&b.o[0], &b.o[1], &b.o[2], &b.d[0], &b.d[1], &b.d[2], &b.t).unwrap();
    for (scene, want) in [(&fast, &f), (&acc, &a)] {
        let [x, y, z] = &mut v;
        scene
            .evaluate(
                &rays,
                Outputs {
                    transmittance: Some([x, y, z]),
                    ..Outputs::default()
                },
            )
            .unwrap();
        assert_eq!(v[0], want[3]);
    }
    let again = acc.clone().with_tier(Tier::Fast);
    assert_eq!(run(&again, &b, again.tier()), f);
    // evaluate_par_tier gives the evaluate_tier bits.
    let [x, y, z] = &mut v;
    acc.evaluate_par_tier(
        Tier::Fast,
        &rays,
        Outputs {
            transmittance: Some([x, y, z]),
            ..Outputs::default()
        },
    )
    .unwrap();
    assert_eq!(v[0], f[3]);
}

/// Fog volumes in the Fast tier: the same integrals (τ bit for bit), T = e^(−τ) within
/// the fast exponential's 1.5e-5, and L_in = C·(1 − T) with the Accurate tier's colour.
#[test]
fn fast_tier_volumes() {
    let mut r = Rng(7);
    let mut vols = vec![];
    for (k, p) in Profile::ALL.into_iter().enumerate() {
        vols.push(Volume::new(
            Shape::Sphere {
                center: Vec3::new(k as f32 * 3.0 - 8.0, 1.0, 10.0),
                radius: 2.0,
            },
            p,
            Vec3::new(0.3, 0.5, 0.8),
        ));
    }
    vols.push(Volume::cut(Shape::Sphere {
        center: Vec3::new(-2.0, 1.0, 10.0),
        radius: 1.0,
    }));
    let mut desc = random_scene(&mut r, false);
    desc.height_fog.truncate(1);
    desc.volumes = vols;
    let scene = Scene::new(desc).unwrap();
    let mut b = random_rays(&mut r, 999, false);
    for i in 0..b.t.len() {
        // Aim at the row of volumes.
        let target = Vec3::new(r.range(-10.0, 10.0) as f32, 1.0, 10.0);
        let o = Vec3::new(b.o[0][i], r.range(0.0, 3.0) as f32, -5.0);
        let d = (target - o).normalize();
        for c in 0..3 {
            b.o[c][i] = o[c];
            b.d[c][i] = d[c];
        }
    }
    let a = run(&scene, &b, Tier::Accurate);
    let f = run(&scene, &b, Tier::Fast);
    for i in 0..b.t.len() {
        for ch in 0..3 {
            let (tau, tr) = (f[ch][i] as f64, f[3 + ch][i] as f64);
            let want = (-tau).exp();
            assert!(
                (tr - want).abs() <= 1.5e-5 * want + check::EPS32,
                "T {tr} vs e^-τ {want}"
            );
            // The volumes' integrals are the Accurate ones; the height fog's τ differs by
            // its Fast bound.
            let ta = a[ch][i] as f64;
            assert!(
                tau == ta || (tau - ta).abs() <= FAST_TAU * ta,
                "τ {tau} vs {ta}"
            );
            let (la, lf) = (a[6 + ch][i] as f64, f[6 + ch][i] as f64);
            let one_minus = 1.0 - a[3 + ch][i] as f64;
            if one_minus > 1e-3 {
                let colour = la / one_minus;
                assert!(
                    (lf - la).abs() <= colour * (FAST_T + 1e-5),
                    "L_in {lf} vs {la} (C {colour})"
                );
            }
        }
    }
}
