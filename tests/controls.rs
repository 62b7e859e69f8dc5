//! The fog controls engines offer (issue 3): Bevy's distance-fog falloffs and visibility
//! helpers, Unreal's start distance, cutoff distance and maximum opacity, the directional
//! lobe, emission. Each is checked against the f64 reference (`reference::scene_sample`),
//! against the engine's own formula where one exists (Bevy's shader, in f64), and the
//! closed forms against quadrature; x8 against scalar bit for bit; no NaN for finite
//! input.

#![allow(clippy::needless_range_loop)]

use analytic_fog::reference::{
    condition, distance_fog_depth, distance_fog_depth_quad, quad_tau, scene_sample, tau_tolerance,
    EPS32,
};
use analytic_fog::{
    Component, DistanceFog, Falloff, FogLimits, HeightFogLayer, Lighting, Lobe, Outputs, Phase,
    Rays, Scene, SceneDesc, SceneError, Shape, Sun, Tier, Volume,
};
use glam::{DVec3, Vec3};

mod common;
use common::Rng;

/// Results of one batch: τ, T, L_in per ray.
type Res = Vec<[[f32; 3]; 3]>;

fn run(scene: &Scene, rays: &[(Vec3, Vec3, f32)], unit: bool, scalar: bool) -> Res {
    let n = rays.len();
    let col = |f: &dyn Fn(&(Vec3, Vec3, f32)) -> f32| rays.iter().map(f).collect::<Vec<f32>>();
    let (ox, oy, oz) = (col(&|r| r.0.x), col(&|r| r.0.y), col(&|r| r.0.z));
    let (dx, dy, dz) = (col(&|r| r.1.x), col(&|r| r.1.y), col(&|r| r.1.z));
    let t = col(&|r| r.2);
    let rays = Rays::new(&ox, &oy, &oz, &dx, &dy, &dz, &t)
        .unwrap()
        .with_unit_directions(unit);
    let mut b = vec![vec![0.0f32; n]; 9];
    {
        let [a0, a1, a2, b0, b1, b2, c0, c1, c2] = &mut b[..] else {
            unreachable!()
        };
        let out = Outputs {
            tau: Some([a0, a1, a2]),
            transmittance: Some([b0, b1, b2]),
            inscattering: Some([c0, c1, c2]),
        };
        if scalar {
            scene.evaluate_scalar(&rays, out).unwrap();
        } else {
            scene.evaluate(&rays, out).unwrap();
        }
    }
    (0..n)
        .map(|i| {
            [
                [b[0][i], b[1][i], b[2][i]],
                [b[3][i], b[4][i], b[5][i]],
                [b[6][i], b[7][i], b[8][i]],
            ]
        })
        .collect()
}

fn layer(h0: f32, b: f32, s: Vec3, phase: Phase) -> HeightFogLayer {
    HeightFogLayer {
        base_height: h0,
        falloff: b,
        components: vec![Component {
            scattering: s,
            absorption: s * 0.25,
            phase,
        }],
        emission: Vec3::ZERO,
    }
}

fn sunlit() -> Lighting {
    Lighting {
        ambient: Vec3::new(0.3, 0.35, 0.4),
        sun: Some(Sun {
            direction: Vec3::new(0.4, 0.3, -0.85),
            radiance: Vec3::new(8.0, 7.0, 6.0),
        }),
    }
}

fn d64(v: Vec3) -> DVec3 {
    v.as_dvec3()
}

/// Bevy's shader formulas (`fog.wgsl`), in f64: (T, L_in) of distance fog alone at
/// distance `d` with colour `c` (the in-scattered light is `mix(input, colour, a)` =
/// input · (1 − a) + colour · a, i.e. T = 1 − a and L_in = colour · a, except for
/// atmospheric fog).
fn bevy(f: Falloff, c: f64, ch: usize, d: f64) -> (f64, f64) {
    match f {
        Falloff::Linear { start, end } => {
            let a = 1.0 - ((end as f64 - d) / (end as f64 - start as f64)).clamp(0.0, 1.0);
            (1.0 - a, c * a)
        }
        Falloff::Exponential { density } => {
            let a = 1.0 - 1.0 / (d * density as f64).exp();
            (1.0 - a, c * a)
        }
        Falloff::ExponentialSquared { density } => {
            let x = d * density as f64;
            let a = 1.0 - 1.0 / (x * x).exp();
            (1.0 - a, c * a)
        }
        Falloff::Atmospheric {
            extinction,
            inscattering,
        } => {
            let e = 1.0 - 1.0 / (d * extinction[ch] as f64).exp();
            let i = 1.0 - 1.0 / (d * inscattering[ch] as f64).exp();
            (1.0 - e, c * i)
        }
    }
}

fn random_falloff(rng: &mut Rng) -> Falloff {
    match rng.pick(4) {
        0 => {
            let start = rng.range(0.0, 200.0) as f32;
            Falloff::Linear {
                start,
                end: start + rng.log_range(1.0, 2000.0) as f32,
            }
        }
        1 => Falloff::Exponential {
            density: rng.log_range(1e-5, 1.0) as f32,
        },
        2 => Falloff::ExponentialSquared {
            density: rng.log_range(1e-5, 1.0) as f32,
        },
        _ => Falloff::Atmospheric {
            extinction: rng.rgb(0.0, 0.05),
            inscattering: rng.rgb(0.0, 0.05),
        },
    }
}

/// The tolerance on T of a Bevy falloff alone: the exponential forms' τ is within a few
/// ULP (|ΔT| ≤ τ·e^(−τ)·4·2⁻²⁴ plus T's own ULP); linear fog's ratio loses |end|·2⁻²⁴ to
/// the subtraction end − s, relative to the ramp's length.
fn bevy_tolerance(f: Falloff, d: f64) -> f64 {
    match f {
        Falloff::Linear { start, end } => {
            4.0 * EPS32 * (1.0 + (end as f64).max(d.min(end as f64)) / (end - start) as f64)
        }
        _ => 8.0 * EPS32,
    }
}

/// Every falloff alone gives Bevy's T and L_in, for rays of any length and direction
/// (x8 and scalar, bit for bit).
#[test]
fn distance_fog_alone_is_bevys_formula() {
    let mut rng = Rng::new(1);
    let mut worst = 0.0f64;
    for _ in 0..400 {
        let f = random_falloff(&mut rng);
        let colour = rng.rgb(0.0, 2.0);
        let scene = Scene::new(SceneDesc {
            distance_fog: Some(DistanceFog { falloff: f, colour }),
            ..SceneDesc::default()
        })
        .unwrap();
        let mut rays = Vec::new();
        for _ in 0..13 {
            let o = rng.rgb(-100.0, 100.0);
            let d = rng.unit_vec3() * rng.log_range(0.01, 100.0) as f32;
            let t = match rng.pick(6) {
                0 => 0.0,
                1 => f32::INFINITY,
                _ => rng.log_range(1e-3, 1e4) as f32,
            };
            rays.push((o, d, t));
        }
        let x8 = run(&scene, &rays, false, false);
        let sc = run(&scene, &rays, false, true);
        for (i, &(_, d, t)) in rays.iter().enumerate() {
            for q in 0..3 {
                for ch in 0..3 {
                    assert_eq!(
                        x8[i][q][ch].to_bits(),
                        sc[i][q][ch].to_bits(),
                        "x8 != scalar"
                    );
                }
            }
            let dist = if t == 0.0 {
                0.0
            } else {
                t as f64 * d64(d).length()
            };
            for ch in 0..3 {
                let (tb, lb) = bevy(f, colour[ch] as f64, ch, dist);
                let tol = bevy_tolerance(f, dist);
                let et = (x8[i][1][ch] as f64 - tb).abs();
                let el = (x8[i][2][ch] as f64 - lb).abs();
                let cmax = colour.max_element() as f64;
                worst = worst.max(et / tol);
                assert!(
                    et <= tol,
                    "{f:?}: d = {dist}: T = {} vs Bevy {tb} (tolerance {tol})",
                    x8[i][1][ch]
                );
                assert!(
                    el <= 1e-5 * cmax + cmax * tol,
                    "{f:?}: d = {dist}: L_in = {} vs Bevy {lb}",
                    x8[i][2][ch]
                );
                assert!(x8[i][0][ch] >= 0.0);
            }
        }
    }
    println!("distance fog vs Bevy: worst |ΔT| / tolerance = {worst:.3}");
}

/// The visibility helpers put 5 % of an object's contrast at the visibility distance.
#[test]
fn visibility_helpers_meet_koschmieder() {
    for v in [0.5f32, 30.0, 1000.0, 2e5] {
        let check = |f: Falloff, want: f64| {
            let scene = Scene::new(SceneDesc {
                distance_fog: Some(DistanceFog {
                    falloff: f,
                    colour: Vec3::ONE,
                }),
                ..SceneDesc::default()
            })
            .unwrap();
            let s = scene.eval_ray(Vec3::ZERO, Vec3::X, v);
            let got = s.transmittance.x as f64;
            assert!(
                (got - want).abs() < 4e-6,
                "{f:?} at {v}: T = {got}, want {want}"
            );
        };
        check(Falloff::from_visibility(v), 0.05);
        check(Falloff::from_visibility_squared(v), 0.05);
        check(Falloff::from_visibility_contrast(v, 0.02), 0.02);
        check(Falloff::from_visibility_squared_contrast(v, 0.02), 0.02);
        // A black extinction colour: full Koschmieder extinction in every channel.
        check(Falloff::from_visibility_colour(v, Vec3::ZERO), 0.05);
        // A white extinction colour turns extinction off.
        check(
            Falloff::from_visibility_colours(v, Vec3::ONE, Vec3::ONE),
            1.0,
        );
    }
    assert!((Falloff::koschmieder(1.0, 0.05) - 2.995_732_3).abs() < 1e-6);
}

/// The distance fog's closed forms against quadrature of their density, in f64 and
/// through the kernel (τ within a few ULP).
#[test]
fn distance_fog_closed_forms_match_quadrature() {
    let mut rng = Rng::new(2);
    for _ in 0..300 {
        let f = random_falloff(&mut rng);
        let fog = DistanceFog {
            falloff: f,
            colour: Vec3::ONE,
        };
        let start = [0.0, rng.range(0.0, 300.0)][rng.pick(2)];
        let mut len = rng.log_range(1e-2, 1e3);
        if let Falloff::Linear { end, .. } = f {
            // The quadrature of 1/(end − s) needs to stop short of `end`.
            let room = end as f64 - start;
            if room <= 1.0 {
                continue;
            }
            len = len.min(room * 0.999);
        }
        let (closed, _) = distance_fog_depth(&fog, start, len);
        let quad = distance_fog_depth_quad(&fog, start, len);
        for ch in 0..3 {
            let err = (closed[ch] - quad[ch]).abs();
            // The quadrature sees the interval through its rounded ends (start + len):
            // its length is off by an f64 ULP of the end.
            let ends = 4.0 * f64::EPSILON * (start + len) / len;
            assert!(
                err <= (1e-12 + ends) * quad[ch].abs().max(1e-300),
                "{f:?} [{start}, +{len}]: closed {} vs quadrature {}",
                closed[ch],
                quad[ch]
            );
        }
        // The kernel over the same interval (start distance; the ray is long enough).
        let scene = Scene::new(SceneDesc {
            distance_fog: Some(fog),
            limits: FogLimits {
                start_distance: start as f32,
                cutoff_distance: Some((start + len) as f32),
                ..FogLimits::default()
            },
            ..SceneDesc::default()
        })
        .unwrap();
        let s = scene.eval_ray(Vec3::ZERO, Vec3::Z, 1e9);
        // The interval as the kernel sees it: its ends rounded to f32.
        let (s32, e32) = (start as f32 as f64, (start + len) as f32 as f64);
        let (want, _) = distance_fog_depth(&fog, s32, (e32 as f32 - s32 as f32) as f64);
        for ch in 0..3 {
            let got = s.tau[ch] as f64;
            // Linear: −ln of a ratio whose terms lose |end|·2⁻²⁴ (relative to the ratio's
            // distance from 1, which τ is proportional to for small τ).
            let tol = match f {
                Falloff::Linear { end, .. } => {
                    let t = (-want[ch]).exp();
                    8.0 * EPS32 * (end as f64 / (end as f64 - e32).max(1e-3)) / t.max(1e-30)
                        + 8.0 * EPS32 * want[ch]
                }
                _ => 8.0 * EPS32 * want[ch],
            };
            assert!(
                (got - want[ch]).abs() <= tol + 1e-37,
                "{f:?} [{s32}, {e32}]: kernel τ {got} vs {}",
                want[ch]
            );
        }
    }
}

/// A random scene with every control, and rays through it.
fn random_scene(rng: &mut Rng) -> SceneDesc {
    let phases = [
        Phase::Isotropic,
        Phase::Rayleigh,
        Phase::HenyeyGreenstein(0.7),
        Phase::CornetteShanks(-0.4),
    ];
    let mut desc = SceneDesc {
        lighting: sunlit(),
        ..SceneDesc::default()
    };
    for _ in 0..rng.pick(3) {
        let s = if rng.pick(2) == 0 {
            Vec3::splat(rng.log_range(1e-3, 0.1) as f32)
        } else {
            rng.rgb(1e-3, 0.1)
        };
        let mut l = layer(
            rng.range(-20.0, 20.0) as f32,
            [0.0, rng.range(-0.3, 0.3)][rng.pick(2)] as f32,
            s,
            phases[rng.pick(4)],
        );
        if rng.pick(2) == 0 {
            l.emission = rng.rgb(0.0, 1.0);
        }
        desc.height_fog.push(l);
    }
    if rng.pick(3) == 0 {
        let c = rng.rgb(-30.0, 30.0);
        desc.volumes.push(Volume::new(
            Shape::Sphere {
                center: c,
                radius: rng.range(2.0, 20.0) as f32,
            },
            Default::default(),
            rng.rgb(1e-3, 0.2),
        ));
    }
    if rng.pick(4) != 0 {
        desc.distance_fog = Some(DistanceFog {
            falloff: random_falloff(rng),
            colour: rng.rgb(0.0, 2.0),
        });
    }
    if rng.pick(2) == 0 {
        desc.limits.start_distance = [0.0, rng.range(0.0, 50.0)][rng.pick(2)] as f32;
        if rng.pick(2) == 0 {
            desc.limits.cutoff_distance = Some(rng.range(0.0, 500.0) as f32);
        }
    }
    if rng.pick(3) == 0 {
        desc.limits.max_opacity = rng.range(0.0, 1.0) as f32;
    }
    if rng.pick(2) == 0 {
        desc.lobe = Some(Lobe {
            colour: rng.rgb(0.0, 3.0),
            exponent: rng.log_range(0.5, 64.0) as f32,
        });
    }
    if rng.pick(3) == 0 {
        desc.tier = Tier::Fast;
    }
    desc
}

/// Random scenes with every control against `reference::scene_sample`, x8 against
/// scalar bit for bit (Accurate tier), τ-only and T-only outputs equal to the full ones.
///
/// Bound: |ΔT| ≤ τ·T·(16·2⁻²⁴·κ) + 4e-6 (κ the height fog's condition on the cut ray;
/// the constant covers the distance fog's and the interval's roundings, a few ULP of
/// T), |ΔL_in| ≤ the colour scale · (2·|ΔT| bound + 1e-5) (the L_in bound of the crate);
/// the Fast tier adds its stated 1e-4 to both.
#[test]
fn controls_against_reference() {
    let mut rng = Rng::new(3);
    let (mut worst_t, mut worst_l) = (0.0f64, 0.0f64);
    for _ in 0..600 {
        let desc = random_scene(&mut rng);
        let scene = Scene::new(desc.clone()).unwrap();
        let mut rays = Vec::new();
        for _ in 0..19 {
            let o = Vec3::new(
                rng.range(-50.0, 50.0) as f32,
                rng.range(-10.0, 40.0) as f32,
                rng.range(-50.0, 50.0) as f32,
            );
            let unit = rng.unit_vec3();
            let t = match rng.pick(8) {
                0 => 0.0,
                1 => f32::INFINITY,
                _ => rng.log_range(1e-2, 2e3) as f32,
            };
            rays.push((o, unit, t));
        }
        let x8 = run(&scene, &rays, true, false);
        let general = run(&scene, &rays, false, false);
        if desc.tier == Tier::Accurate {
            let sc = run(&scene, &rays, true, true);
            for i in 0..rays.len() {
                for q in 0..3 {
                    for ch in 0..3 {
                        assert_eq!(
                            x8[i][q][ch].to_bits(),
                            sc[i][q][ch].to_bits(),
                            "x8 != scalar: {desc:?} ray {:?}",
                            rays[i]
                        );
                    }
                }
            }
        }
        let extra = if desc.tier == Tier::Fast { 1e-4 } else { 0.0 };
        for (i, &(o, d, t)) in rays.iter().enumerate() {
            let r = scene_sample(&desc, d64(o), d64(d), t as f64);
            // The height fog's condition on the cut ray, plus the cut's own (its length is
            // t·|d| − start with t·|d| rounded first: relative 2⁻²⁴ · t·|d| / length).
            let lim = &desc.limits;
            let dist = if t == 0.0 { 0.0 } else { t as f64 };
            let end = dist.min(lim.cutoff_distance.map_or(f64::INFINITY, |c| c as f64));
            let len = (end - lim.start_distance as f64).max(0.0);
            let o2 = d64(o) + d64(d) * lim.start_distance as f64;
            let cut = if len == f64::INFINITY {
                1.0
            } else if lim.start_distance > 0.0 || lim.cutoff_distance.is_some() {
                end / len.max(1e-30)
            } else {
                0.0
            };
            let kappa = condition(&desc, o2, d64(d), len) + cut;
            for res in [&x8[i], &general[i]] {
                for ch in 0..3 {
                    let (tk, lk) = (res[1][ch] as f64, res[2][ch] as f64);
                    assert!(tk.is_finite() && lk.is_finite() && res[0][ch] >= 0.0);
                    assert!((0.0..=1.0).contains(&tk));
                    let tr = r.transmittance[ch];
                    let x = r.tau[ch].min(1e30) * tr;
                    let bt = if x == 0.0 {
                        0.0
                    } else {
                        x * tau_tolerance(kappa)
                    } + 4e-6
                        + extra;
                    let bl = r.colour_scale * (2.0 * bt + 1e-5 + extra);
                    let (et, el) = ((tk - tr).abs(), (lk - r.inscattering[ch]).abs());
                    worst_t = worst_t.max(et / bt);
                    assert!(
                        et <= bt,
                        "T {tk} vs {tr} (bound {bt}) ch {ch}\n{desc:?}\nray {o:?} {d:?} {t}"
                    );
                    // Several height fog layers with τ = +∞: the layers' colour mix is
                    // defined differently by the kernel (weights from the mantissa and
                    // exponent pairs) and the reference (the layers that grow fastest);
                    // a known disagreement, not one of the controls (see the notes).
                    if desc.height_fog.len() > 1 && r.tau[ch] == f64::INFINITY {
                        continue;
                    }
                    worst_l = worst_l.max(el / bl.max(1e-300));
                    assert!(
                        el <= bl,
                        "L_in {lk} vs {} (bound {bl}) ch {ch}\n{desc:?}\nray {o:?} {d:?} {t}",
                        r.inscattering[ch]
                    );
                }
            }
        }
    }
    println!("controls vs reference: worst |ΔT|/bound {worst_t:.3}, |ΔL_in|/bound {worst_l:.3}");
}

/// Where AVX-512 is chosen at run time (`analytic_fog::avx512_dispatch`), the general
/// kernel's 16 lanes give the bits of the build's own width: random scenes with every
/// control, both tiers, unit and general directions, batches of every length up to 40
/// (full 16-lane packets and every tail), all three outputs. (Elsewhere both runs
/// take the same path, and the test checks nothing new.)
#[test]
fn avx512_dispatch_gives_the_same_bits() {
    let mut rng = Rng::new(17);
    for k in 0..240 {
        let desc = random_scene(&mut rng);
        let scene = Scene::new(desc.clone()).unwrap();
        let narrow = scene.clone().without_avx512_dispatch();
        let n = 1 + k % 40;
        let rays: Vec<(Vec3, Vec3, f32)> = (0..n)
            .map(|_| {
                let o = Vec3::new(
                    rng.range(-50.0, 50.0) as f32,
                    rng.range(-10.0, 40.0) as f32,
                    rng.range(-50.0, 50.0) as f32,
                );
                let d = rng.unit_vec3() * [1.0, rng.log_range(1e-3, 1e3) as f32][k % 2];
                let t = match rng.pick(8) {
                    0 => 0.0,
                    1 => f32::INFINITY,
                    _ => rng.log_range(1e-2, 2e3) as f32,
                };
                (o, d, t)
            })
            .collect();
        let unit = k % 2 == 0;
        let (a, b) = (
            run(&scene, &rays, unit, false),
            run(&narrow, &rays, unit, false),
        );
        for i in 0..n {
            for q in 0..3 {
                for ch in 0..3 {
                    assert_eq!(
                        a[i][q][ch].to_bits(),
                        b[i][q][ch].to_bits(),
                        "output {q} channel {ch} ray {:?}\n{desc:?}",
                        rays[i]
                    );
                }
            }
        }
    }
}

/// Start and cutoff distances cut the integration interval exactly: τ of the height fog
/// equals the quadrature over [start, min(t·|d|, cutoff)], and splitting the interval in
/// two adds up.
#[test]
fn start_and_cutoff_cut_the_interval() {
    let mut rng = Rng::new(4);
    for _ in 0..300 {
        let base = SceneDesc {
            height_fog: vec![layer(
                rng.range(-5.0, 5.0) as f32,
                rng.range(-0.2, 0.5) as f32,
                Vec3::new(0.01, 0.02, 0.03),
                Phase::Isotropic,
            )],
            lighting: sunlit(),
            ..SceneDesc::default()
        };
        let o = Vec3::new(0.0, rng.range(-10.0, 30.0) as f32, 0.0);
        let d = rng.unit_vec3() * rng.log_range(0.1, 10.0) as f32;
        let t = rng.log_range(1.0, 300.0) as f32;
        let a = rng.range(0.0, 100.0) as f32;
        let b = a + rng.range(0.0, 100.0) as f32;
        let c = b + rng.range(0.0, 100.0) as f32;
        let with = |start: f32, cutoff: f32| {
            let mut desc = base.clone();
            desc.limits.start_distance = start;
            desc.limits.cutoff_distance = Some(cutoff);
            Scene::new(desc).unwrap().eval_ray(o, d, t)
        };
        let whole = with(a, c);
        let (p1, p2) = (with(a, b), with(b, c));
        // Quadrature over the cut segment, from the start point along the unit direction.
        let dn = d64(d).length();
        let dist = t as f64 * dn;
        let len = (dist.min(c as f64) - a as f64).max(0.0);
        let dh = d64(d) / dn;
        let o2 = d64(o) + dh * a as f64;
        let q = quad_tau(&base, o2, dh, len);
        // The interval's own condition: its length is t·|d| − start (or cutoff − start)
        // with t·|d| rounded to f32 first, a relative error of 2⁻²⁴ · t·|d| / len.
        let kappa = condition(&base, o2, dh, len) + dist.min(c as f64) / len.max(1e-30);
        for ch in 0..3 {
            let tol = tau_tolerance(kappa) * q[ch] + 1e-30;
            assert!(
                (whole.tau[ch] as f64 - q[ch]).abs() <= tol,
                "τ {} vs quadrature {} over [{a}, {c}] (dist {dist})",
                whole.tau[ch],
                q[ch]
            );
            let sum = p1.tau[ch] as f64 + p2.tau[ch] as f64;
            assert!(
                (sum - whole.tau[ch] as f64).abs() <= 2.0 * tol + 1e-6 * q[ch],
                "split τ {sum} vs whole {}",
                whole.tau[ch]
            );
        }
        // A segment that ends before the start distance sees no fog at all.
        let none = with(dist as f32 * 1.01 + 1.0, dist as f32 * 2.0 + 2.0);
        assert_eq!(none.tau, Vec3::ZERO);
        assert_eq!(none.transmittance, Vec3::ONE);
        assert_eq!(none.inscattering, Vec3::ZERO);
    }
}

/// Maximum opacity: T never drops below 1 − m, τ never exceeds −ln(1 − m), and for one
/// medium of one colour L_in = colour · (1 − T) with the clamped T.
#[test]
fn max_opacity_clamps_exactly() {
    let mut rng = Rng::new(5);
    for _ in 0..200 {
        let m = [0.0, 1.0, rng.range(0.0, 1.0)][rng.pick(3)] as f32;
        let desc = SceneDesc {
            height_fog: vec![layer(
                0.0,
                0.0,
                Vec3::new(0.02, 0.05, 0.1),
                Phase::Isotropic,
            )],
            lighting: Lighting {
                ambient: Vec3::ONE,
                sun: None,
            },
            limits: FogLimits {
                max_opacity: m,
                ..FogLimits::default()
            },
            ..SceneDesc::default()
        };
        let scene = Scene::new(desc).unwrap();
        // Homogeneous fog with ambient 1 and albedo 0.8: colour 0.8 in every channel.
        let t = rng.log_range(1e-2, 1e4) as f32;
        let s = scene.eval_ray(Vec3::ZERO, Vec3::X, t);
        let floor = 1.0 - m;
        for ch in 0..3 {
            let tau = Vec3::new(0.02, 0.05, 0.1)[ch] as f64 * 1.25 * t as f64;
            // The floor as the library forms it: 1 − m in f64 (exact), rounded once.
            let floor64 = 1.0 - m as f64;
            let tr = (-tau).exp().max(floor64);
            assert!(s.transmittance[ch] >= floor);
            assert!(
                (s.transmittance[ch] as f64 - tr).abs() <= 4e-7,
                "T {} vs {tr}",
                s.transmittance[ch]
            );
            assert!(s.tau[ch] as f64 <= -floor64.ln() * (1.0 + 4.0 * EPS32) + 1e-30);
            let l = 0.8 * (1.0 - tr);
            assert!(
                (s.inscattering[ch] as f64 - l).abs() <= 1e-6,
                "L {} vs {l}",
                s.inscattering[ch]
            );
        }
    }
}

/// The lobe adds colour · max(cos θ, 0)^n to the fog colour; emission adds its colour.
#[test]
fn lobe_and_emission() {
    let lobe = Lobe {
        colour: Vec3::new(1.0, 0.8, 0.5),
        exponent: 8.0,
    };
    let sun_dir = Vec3::new(0.0, 0.0, 1.0);
    let desc = SceneDesc {
        height_fog: vec![HeightFogLayer {
            emission: Vec3::new(0.1, 0.2, 0.3),
            // Absorption only: without emission and lobe the fog would be black.
            components: vec![Component {
                scattering: Vec3::ZERO,
                absorption: Vec3::splat(0.05),
                phase: Phase::Isotropic,
            }],
            ..layer(0.0, 0.0, Vec3::ZERO, Phase::Isotropic)
        }],
        lighting: Lighting {
            ambient: Vec3::ZERO,
            sun: Some(Sun {
                direction: sun_dir,
                radiance: Vec3::ONE,
            }),
        },
        lobe: Some(lobe),
        ..SceneDesc::default()
    };
    let scene = Scene::new(desc.clone()).unwrap();
    let mut rng = Rng::new(6);
    for _ in 0..500 {
        let d = rng.unit_vec3();
        let s = scene.eval_ray(Vec3::ZERO, d, 20.0);
        let cos = (d.as_dvec3().normalize()).dot(sun_dir.as_dvec3()).max(0.0);
        let w = cos.powf(8.0);
        let one_m_t = -(-0.05f64 * 20.0).exp_m1();
        for ch in 0..3 {
            let want =
                (desc.height_fog[0].emission[ch] as f64 + lobe.colour[ch] as f64 * w) * one_m_t;
            let err = (s.inscattering[ch] as f64 - want).abs();
            assert!(
                err <= 1e-6,
                "d {d:?}: L_in {} vs {want}",
                s.inscattering[ch]
            );
        }
    }
    // Straight at the sun the lobe is its full colour; behind, nothing.
    let front = scene.eval_ray(Vec3::ZERO, sun_dir, 1e6);
    let back = scene.eval_ray(Vec3::ZERO, -sun_dir, 1e6);
    assert!((front.inscattering.x - 1.1).abs() < 1e-6, "{front:?}");
    assert!((back.inscattering.x - 0.1).abs() < 1e-6, "{back:?}");
}

/// Finite input never gives NaN, with every control on, at extreme rays.
#[test]
fn controls_extreme_rays_no_nan() {
    let mut rng = Rng::new(7);
    let extremes = [0.0f32, 1e-30, 1e-6, 1.0, 1e6, 1e30, 3e38, f32::INFINITY];
    for _ in 0..300 {
        let desc = random_scene(&mut rng);
        let scene = Scene::new(desc.clone()).unwrap();
        let mut rays = Vec::new();
        for _ in 0..16 {
            let o = rng.unit_vec3() * [0.0f32, 1.0, 1e4, 1e20, 3e38][rng.pick(5)];
            let d = rng.unit_vec3() * [1e-30f32, 1.0, 1e20, 1e38][rng.pick(4)];
            let t = extremes[rng.pick(extremes.len())];
            rays.push((o, d, t));
        }
        let x8 = run(&scene, &rays, false, false);
        let sc = run(&scene, &rays, false, true);
        for i in 0..rays.len() {
            for ch in 0..3 {
                let (tau, tr, l) = (x8[i][0][ch], x8[i][1][ch], x8[i][2][ch]);
                assert!(
                    !tau.is_nan()
                        && tau >= 0.0
                        && (0.0..=1.0).contains(&tr)
                        && l.is_finite()
                        && l >= 0.0,
                    "τ {tau} T {tr} L {l}\n{desc:?}\nray {:?}",
                    rays[i]
                );
                if desc.tier == Tier::Accurate {
                    for q in 0..3 {
                        assert_eq!(x8[i][q][ch].to_bits(), sc[i][q][ch].to_bits());
                    }
                }
            }
        }
    }
}

/// Invalid controls are rejected with the field named.
#[test]
fn invalid_controls_are_named() {
    let bad = |f: &dyn Fn(&mut SceneDesc), field: &str| {
        let mut d = SceneDesc {
            lighting: sunlit(),
            ..SceneDesc::default()
        };
        f(&mut d);
        let e: SceneError = Scene::new(d).unwrap_err();
        assert_eq!(e.field(), field, "{e}");
    };
    let fog = |falloff| {
        Some(DistanceFog {
            falloff,
            colour: Vec3::ONE,
        })
    };
    bad(
        &|d| {
            d.distance_fog = fog(Falloff::Linear {
                start: 10.0,
                end: 5.0,
            })
        },
        "distance_fog.falloff.linear.end",
    );
    bad(
        &|d| {
            d.distance_fog = fog(Falloff::Linear {
                start: -1.0,
                end: 5.0,
            })
        },
        "distance_fog.falloff.linear.start",
    );
    bad(
        &|d| d.distance_fog = fog(Falloff::Exponential { density: f32::NAN }),
        "distance_fog.falloff.exponential.density",
    );
    bad(
        &|d| d.distance_fog = fog(Falloff::ExponentialSquared { density: -1.0 }),
        "distance_fog.falloff.exponential_squared.density",
    );
    bad(
        &|d| {
            d.distance_fog = fog(Falloff::Atmospheric {
                extinction: Vec3::new(0.0, -1.0, 0.0),
                inscattering: Vec3::ONE,
            })
        },
        "distance_fog.falloff.atmospheric.extinction[1]",
    );
    bad(
        &|d| {
            d.distance_fog = Some(DistanceFog {
                falloff: Falloff::Exponential { density: 1.0 },
                colour: Vec3::new(0.0, 0.0, f32::INFINITY),
            })
        },
        "distance_fog.colour[2]",
    );
    bad(&|d| d.limits.start_distance = -1.0, "limits.start_distance");
    bad(
        &|d| d.limits.cutoff_distance = Some(f32::NAN),
        "limits.cutoff_distance",
    );
    bad(&|d| d.limits.max_opacity = 1.5, "limits.max_opacity");
    bad(
        &|d| {
            d.lobe = Some(Lobe {
                colour: Vec3::ONE,
                exponent: 0.0,
            })
        },
        "lobe.exponent",
    );
    bad(
        &|d| {
            d.lobe = Some(Lobe {
                colour: Vec3::ONE,
                exponent: 4.0,
            });
            d.lighting.sun = None;
        },
        "lobe",
    );
    bad(
        &|d| {
            let mut l = layer(0.0, 0.1, Vec3::ONE, Phase::Isotropic);
            l.emission = Vec3::new(-1.0, 0.0, 0.0);
            d.height_fog.push(l);
        },
        "height_fog[0].emission[0]",
    );
}

/// The controls in JSON: every field, parsed and evaluated like the Rust description.
/// (serde_json comes with the `report` feature, which implies `serde`.)
#[cfg(feature = "report")]
#[test]
fn controls_from_json() {
    let text = r#"{
        "height_fog": [{"base_height": 0, "falloff": 0.1, "emission": [0.1, 0.0, 0.0],
                        "components": [{"scattering": 0.02}]}],
        "lighting": {"ambient": 0.5, "sun": {"direction": [0, 1, 1], "radiance": 5}},
        "distance_fog": {"falloff": {"atmospheric": {"extinction": [0.01, 0.02, 0.03],
                                                     "inscattering": 0.01}},
                         "colour": [0.6, 0.7, 0.8]},
        "limits": {"start_distance": 5, "cutoff_distance": 500, "max_opacity": 0.9},
        "lobe": {"colour": [1, 0.9, 0.7], "exponent": 8}
    }"#;
    let desc: SceneDesc = serde_json::from_str(text).unwrap();
    assert_eq!(desc.limits.cutoff_distance, Some(500.0));
    assert_eq!(desc.lobe.unwrap().exponent, 8.0);
    let back: SceneDesc = serde_json::from_str(&serde_json::to_string(&desc).unwrap()).unwrap();
    assert_eq!(back, desc);
    for (f, json) in [
        (
            Falloff::Linear {
                start: 1.0,
                end: 2.0,
            },
            r#"{"linear":{"start":1.0,"end":2.0}}"#,
        ),
        (
            Falloff::Exponential { density: 0.5 },
            r#"{"exponential":{"density":0.5}}"#,
        ),
        (
            Falloff::ExponentialSquared { density: 0.5 },
            r#"{"exponential_squared":{"density":0.5}}"#,
        ),
    ] {
        assert_eq!(serde_json::from_str::<Falloff>(json).unwrap(), f);
    }
    let scene = Scene::new(desc).unwrap();
    let s = scene.eval_ray(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.2, 1.0), 1e4);
    assert!(s.transmittance.min_element() >= 0.1 - 1e-6);
}

/// Linear distance fog whose span `end − start` is subnormal (1/span overflows f32): no
/// NaN at, before or beyond `end` (found by fuzz/height_fog: 0·∞ at s = end).
#[test]
fn linear_fog_with_a_subnormal_span() {
    let end = 9.1835e-41f32;
    let scene = Scene::new(SceneDesc {
        distance_fog: Some(DistanceFog {
            falloff: Falloff::Linear { start: 0.0, end },
            colour: Vec3::new(0.5, 0.6, 0.7),
        }),
        ..SceneDesc::default()
    })
    .unwrap();
    let o = Vec3::new(7.7e-44, -1.974495e-11, 6.820748e-38);
    let rays: Vec<(Vec3, Vec3, f32)> = [0.0, end * 0.5, end, end * 2.0, 1.0, f32::INFINITY]
        .iter()
        .map(|&t| (o, Vec3::Y, t))
        .collect();
    for scalar in [false, true] {
        for (k, r) in run(&scene, &rays, false, scalar).iter().enumerate() {
            let t = rays[k].2;
            for c in 0..3 {
                let (tau, tr, l) = (r[0][c], r[1][c], r[2][c]);
                assert!(
                    tau >= 0.0 && (0.0..=1.0).contains(&tr) && l >= 0.0,
                    "t {t}: {r:?}"
                );
                // Beyond `end` the fog is opaque; before it, nearly clear.
                if t >= end * 2.0 {
                    assert_eq!(tr, 0.0, "t {t}: {r:?}");
                } else if t < end {
                    assert!(tr > 0.4, "t {t}: {r:?}");
                }
            }
        }
    }
}
