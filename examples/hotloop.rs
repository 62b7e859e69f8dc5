//! Runs one kernel configuration in a loop, for instruction counting:
//! `valgrind --tool=callgrind target/release/examples/hotloop [unit|general|radiance] [typical|extreme]`,
//! and for timing (`REPS=200`: the best of 200 passes, as the C peer reports).
use analytic_fog::{
    Component, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun,
};
use glam::Vec3;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("unit");
    let extreme = args.get(2).map(String::as_str) == Some("extreme");
    let n = 65536;
    let mut s: u64 = 88172645463325252;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 40) as f64 * (1.0 / 16777216.0)) as f32
    };
    let (mut oy, mut dy, mut dx, mut t) = (
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
        vec![0.0f32; n],
    );
    let z = vec![0.0f32; n];
    for i in 0..n {
        let y = uni() * 10.0;
        let mut u = uni() * 2.0 - 1.0;
        let mut d = uni() * 1000.0;
        if extreme && (i & 7) == 0 {
            u = (uni() * 2.0 - 1.0) * 1e-6;
            d = uni() * 1e7;
        }
        if !extreme && u < 0.0 && -y / u < d {
            d = -y / u;
        }
        oy[i] = y;
        dy[i] = u;
        dx[i] = (1.0 - u * u).sqrt();
        t[i] = d;
    }
    let full = mode == "radiance";
    let scene = Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: 0.1,
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::new(0.02, 0.03, 0.05),
                absorption: Vec3::ZERO,
                phase: if full {
                    Phase::HenyeyGreenstein(0.7)
                } else {
                    Phase::Isotropic
                },
            }],
        }],
        lighting: Lighting {
            ambient: Vec3::splat(0.5),
            sun: full.then_some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87),
                radiance: Vec3::splat(10.0),
            }),
        },
        ..SceneDesc::default()
    })
    .unwrap();
    let rays = Rays::new(&z, &oy, &z, &dx, &dy, &z, &t)
        .unwrap()
        .with_unit_directions(mode != "general");
    let mut o: Vec<Vec<f32>> = (0..6).map(|_| vec![0.0f32; n]).collect();
    // Best of `reps` (as the C peer reports), after one untimed pass that touches the outputs.
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(20)
        .max(1);
    let mut best = f64::INFINITY;
    for rep in 0..=reps {
        let [a, b, c, d, e, f] = &mut o[..] else {
            unreachable!()
        };
        let out = Outputs {
            tau: None,
            transmittance: Some([a, b, c]),
            inscattering: if full { Some([d, e, f]) } else { None },
        };
        let t0 = std::time::Instant::now();
        scene.evaluate(&rays, out).unwrap();
        let dt = t0.elapsed().as_secs_f64();
        if rep > 0 {
            best = best.min(dt);
        }
    }
    println!(
        "{mode} {}: {:.3} ns/ray, best of {reps}  (T_r[1] = {})",
        if extreme { "extreme" } else { "typical" },
        best / n as f64 * 1e9,
        o[0][1]
    );
}
