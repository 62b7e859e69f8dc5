//! Table-driven test of stiff and extreme height fog cases (issue #2), each row checked
//! against the independent f64 reference with the bound of `reference::check_sample`
//! (documented in `src/reference/check.rs`), and the worst error per group printed:
//!
//! ```text
//! cargo test --release --test extreme -- --nocapture
//! ```
//!
//! Columns: rows; "no digit": rows where the bound guarantees no significant digit
//! (16 · 2⁻²⁴ · κ ≥ 1, e.g. t = +∞ into denser fog where κ = +∞ and τ = +∞, or a general
//! up vector whose rounding flips the sign of u): only the invariants and the saturation
//! rules are checked there, and they are; then over the other rows: the largest
//! condition κ; the largest relative error of τ (where τ is finite and normal in f32);
//! and the largest error divided by what the bound allows, for τ, T and L_in (≤ 1
//! passes).

use analytic_fog::reference::{self, check_sample, EPS32};
use analytic_fog::{
    Component, FogSample, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun,
};
use glam::Vec3;

/// One row of the table.
struct Row {
    group: &'static str,
    desc: SceneDesc,
    o: Vec3,
    d: Vec3,
    t: f32,
}

const T_SET: [f32; 8] = [0.0, 1e-6, 1.0, 1e3, 1e12, 3e38, f32::MAX, f32::INFINITY];
const D_UP_TINY: [f32; 9] = [
    0.0, 1e-38, -1e-38, 1e-30, -1e-30, 1e-12, -1e-12, 1e-7, -1e-7,
];
const D_UP_SOME: [f32; 8] = [1.0, -1.0, 0.5, -0.5, 1e-7, -1e-7, 0.0, 1e-38];
/// Camera height relative to the base height: at it, moderately above, 1e4 above, 1e3
/// below.
const HEIGHTS: [f32; 4] = [0.0, 2.0, 1e4, -1e3];

fn component(scattering: Vec3, absorption: Vec3, phase: Phase) -> Component {
    Component {
        scattering,
        absorption,
        phase,
    }
}

fn layer(h0: f32, b: f32, components: Vec<Component>) -> HeightFogLayer {
    HeightFogLayer {
        base_height: h0,
        falloff: b,
        emission: glam::Vec3::ZERO,
        components,
    }
}

fn lighting() -> Lighting {
    Lighting {
        ambient: Vec3::new(0.5, 0.6, 0.7),
        sun: Some(Sun {
            direction: Vec3::new(0.3, 0.4, -0.87),
            radiance: Vec3::new(20.0, 18.0, 15.0),
        }),
    }
}

/// The standard scene: +Y up, one layer at h0 = 0 with falloff `b`, RGB scattering with
/// some absorption, Mie-like Henyey–Greenstein plus a Rayleigh component.
fn scene(b: f32) -> SceneDesc {
    SceneDesc {
        height_fog: vec![layer(
            0.0,
            b,
            vec![
                component(
                    Vec3::new(0.02, 0.03, 0.05),
                    Vec3::splat(0.001),
                    Phase::HenyeyGreenstein(0.7),
                ),
                component(Vec3::new(0.005, 0.01, 0.02), Vec3::ZERO, Phase::Rayleigh),
            ],
        )],
        lighting: lighting(),
        ..SceneDesc::default()
    }
}

/// A direction with up component `dup` along +Y (unit length where representable).
fn dir_y(dup: f32) -> Vec3 {
    let h = (1.0 - (dup as f64).powi(2)).max(0.0).sqrt() as f32;
    Vec3::new(h * 0.6, dup, h * 0.8)
}

fn rows() -> Vec<Row> {
    let mut rows = Vec::new();
    let mut push = |group, desc: &SceneDesc, o: Vec3, d: Vec3, t: f32| {
        rows.push(Row {
            group,
            desc: desc.clone(),
            o,
            d,
            t,
        })
    };

    // d_up = 0, ±1e-38, ±1e-30, ±1e-12, ±1e-7: nearly horizontal rays, where the seeds'
    // difference of exponentials cancels.
    for b in [0.1f32, 1.0, -0.1] {
        let desc = scene(b);
        for dup in D_UP_TINY {
            for h in HEIGHTS {
                for t in T_SET {
                    push("d_up tiny", &desc, Vec3::new(1.0, h, -2.0), dir_y(dup), t);
                }
            }
        }
    }
    // b = 0, tiny (1e-30, subnormal), negative, huge (1e10, 1e30).
    for b in [
        0.0f32, 1e-30, -1e-30, 1e-45, -0.1, -1.0, 1e10, -1e10, 1e30, -1e30,
    ] {
        let desc = scene(b);
        for dup in D_UP_SOME {
            for h in HEIGHTS {
                for t in T_SET {
                    push("falloff b", &desc, Vec3::new(0.0, h, 0.0), dir_y(dup), t);
                }
            }
        }
    }
    // t = 0, 1e-6, 1e12, 3e38, f32::MAX, +inf over all directions.
    {
        let desc = scene(0.08);
        for t in [0.0f32, 1e-6, 1e12, 3e38, f32::MAX, f32::INFINITY] {
            for dup in [1.0f32, -1.0, 0.3, -0.3, 1e-3, -1e-3, 0.0] {
                for h in [0.0f32, 5.0, 50.0] {
                    push("t extreme", &desc, Vec3::new(3.0, h, 4.0), dir_y(dup), t);
                }
            }
        }
    }
    // Camera 1e4 above and 1e3 below the base height (and a base height far away).
    for (h0, y) in [
        (0.0f32, 1e4f32),
        (0.0, -1e3),
        (1e4, 0.0),
        (-1e3, 0.0),
        (5e3, -5e3),
    ] {
        let mut desc = scene(0.1);
        desc.height_fog[0].base_height = h0;
        for dup in D_UP_SOME {
            for t in T_SET {
                push("camera far", &desc, Vec3::new(0.0, y, 0.0), dir_y(dup), t);
            }
        }
    }
    // Coefficients 1e-20 and 1e20.
    for k in [1e-20f32, 1e20] {
        let mut desc = scene(0.1);
        desc.height_fog[0].components = vec![
            component(Vec3::new(k, 2.0 * k, 0.5 * k), Vec3::ZERO, Phase::Isotropic),
            component(
                Vec3::splat(k),
                Vec3::splat(k),
                Phase::HenyeyGreenstein(-0.5),
            ),
        ];
        for dup in D_UP_SOME {
            for h in HEIGHTS {
                for t in T_SET {
                    push("coefficients", &desc, Vec3::new(0.0, h, 0.0), dir_y(dup), t);
                }
            }
        }
    }
    // Non-unit, huge (1e30) and tiny (1e-30) directions.
    {
        let desc = scene(0.1);
        for s in [3.7f32, 1e30, 1e-30, 1e-38] {
            for dup in D_UP_SOME {
                for h in HEIGHTS {
                    for t in T_SET {
                        push(
                            "direction scale",
                            &desc,
                            Vec3::new(0.0, h, 0.0),
                            dir_y(dup) * s,
                            t,
                        );
                    }
                }
            }
        }
    }
    // Up vectors: -Y, +Z, and two general ones (the condition adds |b|·|o| and the
    // rounding of u; see `reference::condition`).
    for up in [
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::new(1.0, 2.0, 3.0),
        Vec3::new(0.3, -0.9, 0.1),
    ] {
        let mut desc = scene(0.1);
        desc.up = up;
        let upn = reference::unit(up.as_dvec3());
        let (e1, e2) = upn.any_orthonormal_pair();
        for dup in [1.0f64, -1.0, 0.5, -0.5, 1e-3, 0.0] {
            let d = (dup * upn + (1.0 - dup * dup).sqrt() * (0.6 * e1 + 0.8 * e2)).as_vec3();
            for h in [0.0f64, 2.0, 1e4, -1e3] {
                let o = (h * upn + 3.0 * e1 - 4.0 * e2).as_vec3();
                for t in T_SET {
                    push("up vector", &desc, o, d, t);
                }
            }
        }
    }
    // Several layers: different falloffs (0, negative, huge), base heights, colours.
    {
        let mk = |layers: Vec<HeightFogLayer>| SceneDesc {
            height_fog: layers,
            lighting: lighting(),
            ..SceneDesc::default()
        };
        let iso = |s: f32| vec![component(Vec3::splat(s), Vec3::ZERO, Phase::Isotropic)];
        let red = |s: f32| {
            vec![component(
                Vec3::new(s, 0.1 * s, 0.01 * s),
                Vec3::ZERO,
                Phase::HenyeyGreenstein(0.9),
            )]
        };
        let scenes = [
            mk(vec![layer(0.0, 0.1, iso(0.02)), layer(0.0, 1.0, red(0.5))]),
            mk(vec![
                layer(0.0, 0.0, iso(1e-4)),
                layer(10.0, -0.5, red(0.01)),
                layer(-5.0, 2.0, iso(0.3)),
            ]),
            mk(vec![
                layer(0.0, 1e10, red(1.0)),
                layer(0.0, 1e-30, iso(1e-3)),
            ]),
            mk(vec![
                layer(0.0, 1.0, iso(1e-20)),
                layer(0.0, 0.5, red(1e20)),
            ]),
        ];
        for desc in &scenes {
            for dup in D_UP_SOME {
                for h in HEIGHTS {
                    for t in T_SET {
                        push(
                            "several layers",
                            desc,
                            Vec3::new(0.0, h, 0.0),
                            dir_y(dup),
                            t,
                        );
                    }
                }
            }
        }
    }
    // The sun straight ahead and straight behind, Henyey–Greenstein g = ±0.99.
    for g in [0.99f32, -0.99] {
        for d in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(0.3, -0.4, 0.86),
            Vec3::new(1e-3, 1.0, 0.0),
        ] {
            for behind in [false, true] {
                let desc = sun_scene(g, if behind { -d } else { d });
                for (h, t) in [(2.0f32, 10.0f32), (0.0, 1e3), (0.0, f32::INFINITY)] {
                    push("sun HG ±0.99", &desc, Vec3::new(0.0, h, 0.0), d, t);
                }
            }
        }
    }
    // Huge falloffs with a far camera: b·(y − h0) and Δ = b·d_up·t both beyond 2^192
    // (saturating at the general path's 2^-64 scale) or y − h0 beyond f32::MAX, with
    // opposite signs, so that which term wins decides between τ = 0 and τ = +∞ (found by
    // the `height_fog` fuzz target: b = −1.2e35, camera 1.3e36 below the base, Δ =
    // −3.5e61 gave τ = +∞ for a true τ of e^(−1.6e71)).
    for b in [
        1.2e35f32, -1.2e35, 2.2e12, -2.2e12, 1e30, -1e30, 3e38, -3e38,
    ] {
        for (h0, y) in [
            (0.0f32, 1.3e36f32),
            (0.0, -1.3e36),
            (-3e38, 3e38),
            (3e38, -3e38),
            (0.0, 1e20),
            (0.0, -1e20),
        ] {
            let mut desc = scene(b);
            desc.height_fog[0].base_height = h0;
            for dup in [9.2e27f32, -9.2e27, 4.0, -4.0, 1.0, -1.0, 1e10, -1e10] {
                for t in [0.03125f32, 1.0, 1e12, 3e38, f32::INFINITY] {
                    let d = Vec3::new(0.6, dup, 0.8);
                    push("both terms huge", &desc, Vec3::new(0.0, y, 0.0), d, t);
                }
            }
        }
    }
    rows
}

/// One Henyey–Greenstein component lit by a sun of radiance 1 from `sun`, no ambient: the
/// fog colour is the phase function.
fn sun_scene(g: f32, sun: Vec3) -> SceneDesc {
    SceneDesc {
        height_fog: vec![layer(
            0.0,
            0.1,
            vec![component(
                Vec3::splat(0.05),
                Vec3::ZERO,
                Phase::HenyeyGreenstein(g),
            )],
        )],
        lighting: Lighting {
            ambient: Vec3::ZERO,
            sun: Some(Sun {
                direction: sun,
                radiance: Vec3::ONE,
            }),
        },
        ..SceneDesc::default()
    }
}

/// Evaluates one ray with x8 (a batch of 9 copies: one full packet and a tail) and the
/// scalar path, asserting identical bits.
fn eval(scene: &Scene, o: Vec3, d: Vec3, t: f32) -> FogSample {
    const N: usize = 9;
    let s = |v: f32| vec![v; N];
    let (ox, oy, oz, dx, dy, dz, tt) = (s(o.x), s(o.y), s(o.z), s(d.x), s(d.y), s(d.z), s(t));
    let rays = Rays::new(&ox, &oy, &oz, &dx, &dy, &dz, &tt).unwrap();
    let mut buf = [[[f32::NAN; N]; 3]; 3];
    {
        let [a, b, c] = &mut buf;
        fn rgb(x: &mut [[f32; N]; 3]) -> Option<[&mut [f32]; 3]> {
            let [r, g, b] = x;
            Some([&mut r[..], &mut g[..], &mut b[..]])
        }
        scene
            .evaluate(
                &rays,
                Outputs {
                    tau: rgb(a),
                    transmittance: rgb(b),
                    inscattering: rgb(c),
                },
            )
            .unwrap();
    }
    let scalar = scene.eval_ray(o, d, t);
    for i in [0, N - 1] {
        let v = |k: usize| Vec3::new(buf[k][0][i], buf[k][1][i], buf[k][2][i]);
        let x8 = FogSample {
            tau: v(0),
            transmittance: v(1),
            inscattering: v(2),
        };
        for (a, b) in [
            (x8.tau, scalar.tau),
            (x8.transmittance, scalar.transmittance),
            (x8.inscattering, scalar.inscattering),
        ] {
            for ch in 0..3 {
                assert_eq!(
                    a[ch].to_bits(),
                    b[ch].to_bits(),
                    "x8 lane {i} vs scalar: {a:?} vs {b:?} for o {o:?} d {d:?} t {t:e}"
                );
            }
        }
    }
    scalar
}

#[test]
fn extreme_table() {
    let rows = rows();
    let mut groups: Vec<(&'static str, reference::WorstErrors)> = Vec::new();
    let mut failures = Vec::new();
    for row in &rows {
        let scene = Scene::new(row.desc.clone()).expect("valid scene");
        let got = eval(&scene, row.o, row.d, row.t);
        let c = check_sample(&row.desc, row.o, row.d, row.t, &got);
        if !c.passed() {
            failures.push(format!(
                "[{}] o {:?} d {:?} t {:e} b {:?}: {}\n    got {:?}",
                row.group,
                row.o,
                row.d,
                row.t,
                row.desc
                    .height_fog
                    .iter()
                    .map(|l| l.falloff)
                    .collect::<Vec<_>>(),
                c.failure.as_deref().unwrap_or(""),
                got
            ));
        }
        match groups.iter_mut().find(|g| g.0 == row.group) {
            Some(g) => g.1.add(&c, &got),
            None => {
                let mut w = reference::WorstErrors::default();
                w.add(&c, &got);
                groups.push((row.group, w));
            }
        }
    }
    println!();
    println!("{}", reference::markdown_header("group", "rows"));
    for (name, w) in &groups {
        println!("{}", w.markdown_row(name));
    }
    println!(
        "(bound on τ: 16·2⁻²⁴·κ = {:.2e}·κ; ratios ≤ 1 pass)",
        16.0 * EPS32
    );
    assert!(
        failures.is_empty(),
        "{} of {} rows outside the bound:\n{}",
        failures.len(),
        rows.len(),
        failures
            .iter()
            .take(30)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

/// The phase function's peak: with the sun straight ahead (g = 0.99) or straight behind
/// (g = −0.99), and τ = +∞ (T = 0 exactly), L_in is the phase function itself. Checked
/// against the f64 formula within 8 · 2⁻²⁴ relative (measured: see the printed line).
#[test]
fn henyey_greenstein_peak() {
    let mut worst: f64 = 0.0;
    for g in [0.99f32, -0.99, 0.9, -0.9, 0.5, 0.0] {
        for d in [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(0.3, -0.4, 0.86),
            Vec3::new(-0.7, -0.1, 0.2) * 3.0,
            Vec3::new(1e-3, -1.0, 1e-5),
        ] {
            for behind in [false, true] {
                let sun = if behind { -d } else { d };
                let desc = sun_scene(g, sun);
                let scene = Scene::new(desc.clone()).unwrap();
                // Horizontal or looking down to infinity: τ = +∞, T = 0, L_in = p.
                let got = eval(&scene, Vec3::ZERO, d, f32::INFINITY);
                assert_eq!(got.transmittance, Vec3::ZERO, "g {g} d {d:?}");
                let p = reference::phase(Phase::HenyeyGreenstein(g), d.as_dvec3(), sun.as_dvec3());
                for ch in 0..3 {
                    let rel = (got.inscattering[ch] as f64 - p).abs() / p;
                    worst = worst.max(rel);
                    assert!(
                        rel <= 8.0 * EPS32,
                        "g {g} d {d:?} sun {sun:?}: phase {} vs {p} (rel {rel:e})",
                        got.inscattering[ch]
                    );
                }
            }
        }
    }
    println!(
        "Henyey–Greenstein peak: worst relative error {worst:.2e} (bound 8·2⁻²⁴ = {:.2e})",
        8.0 * EPS32
    );
}
