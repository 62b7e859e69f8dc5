//! Runs one kernel configuration in a loop, for instruction counting:
//! `valgrind --tool=callgrind target/release/examples/hotloop [unit|general|radiance] [typical|extreme|sky|stiff]`,
//! and for timing (`REPS=200`: the best of 200 passes, as the C peer reports). Then prints
//! the accuracy the way the peer measures its own: max |T − T_f64| against the same closed
//! form in f64 (which takes |d| = 1; `general`'s directions are unit to rounding).
//! `CHUNK=k` evaluates the 65536 rays as calls of k rays each (the fixed cost per call);
//! `N=n` evaluates n rays instead of 65536 (`N=16777216`: the streaming bench's size).
//! `NO512=1` takes the 8-lane path on a CPU with AVX-512 (`Scene::without_avx512_dispatch`).
//! `MIX=k` with `sky` or `stiff`: that set's ray on one ray in k, typical rays elsewhere.
use analytic_fog::reference::peer::{PeerRays, BETA, FALLOFF};
use analytic_fog::{
    Component, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun,
};
use glam::Vec3;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map(String::as_str).unwrap_or("unit");
    // The data set: the peer's `typical` or `extreme`, or the crate's `sky` or `stiff`
    // (`PeerRays::crate_extreme`, the benches' sets of those names).
    let set = args.get(2).map(String::as_str).unwrap_or("typical");
    let extreme = set == "extreme";
    // `N=n`: another batch size (default 65536, in cache; 16777216 streams from memory).
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(65536)
        .max(1);
    let mut peer = match set {
        "sky" | "stiff" => PeerRays::crate_extreme(n, set == "stiff"),
        _ => PeerRays::new(n, extreme),
    };
    // `MIX=k` (with `sky` or `stiff`): that set's ray on one ray in k (i % k == 0), the
    // typical ray elsewhere: packets with a few extreme lanes among typical ones.
    if let Some(k) = std::env::var("MIX")
        .ok()
        .and_then(|k| k.parse::<usize>().ok())
    {
        let typical = PeerRays::new(n, false);
        for i in (0..n).filter(|i| i % k.max(1) != 0) {
            peer.oy[i] = typical.oy[i];
            peer.dy[i] = typical.dy[i];
            peer.t[i] = typical.t[i];
        }
    }
    let (oy, dy, t, dx) = (&peer.oy, &peer.dy, &peer.t, peer.dx());
    let z = vec![0.0f32; n];
    let full = mode == "radiance";
    let scene = Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: FALLOFF,
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
    // `NO512=1`: the 8-lane path where the CPU has AVX-512 (the dispatch turned off).
    let scene = if std::env::var_os("NO512").is_some() {
        scene.without_avx512_dispatch()
    } else {
        scene
    };
    let rays = Rays::new(&z, oy, &z, &dx, dy, &z, t)
        .unwrap()
        .with_unit_directions(mode != "general");
    let mut o: Vec<Vec<f32>> = (0..6).map(|_| vec![0.0f32; n]).collect();
    // Best of `reps` (as the C peer reports), after one untimed pass that touches the outputs.
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(20)
        .max(1);
    let chunk: usize = std::env::var("CHUNK")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(n)
        .max(1);
    let mut best = f64::INFINITY;
    for rep in 0..=reps {
        let [a, b, c, d, e, f] = &mut o[..] else {
            unreachable!()
        };
        let t0 = std::time::Instant::now();
        if chunk >= n {
            let out = Outputs {
                tau: None,
                transmittance: Some([a, b, c]),
                inscattering: if full { Some([d, e, f]) } else { None },
            };
            scene.evaluate(&rays, out).unwrap();
        } else {
            // `CHUNK=k`: the batch as n/k calls of k rays (what `evaluate_par`'s tasks do).
            for s in (0..n).step_by(chunk) {
                let r = s..(s + chunk).min(n);
                let rays = Rays::new(
                    &z[r.clone()],
                    &oy[r.clone()],
                    &z[r.clone()],
                    &dx[r.clone()],
                    &dy[r.clone()],
                    &z[r.clone()],
                    &t[r.clone()],
                )
                .unwrap()
                .with_unit_directions(mode != "general");
                let out = Outputs {
                    tau: None,
                    transmittance: Some([&mut a[r.clone()], &mut b[r.clone()], &mut c[r.clone()]]),
                    inscattering: if full {
                        Some([&mut d[r.clone()], &mut e[r.clone()], &mut f[r.clone()]])
                    } else {
                        None
                    },
                };
                scene.evaluate(&rays, out).unwrap();
            }
        }
        let dt = t0.elapsed().as_secs_f64();
        if rep > 0 {
            best = best.min(dt);
        }
    }
    // Accuracy as the C peer measures its own (red channel, as the peer prints, and the
    // worst of the three).
    // (Not for `sky` and `stiff`: the peer's closed form has no t = +∞.)
    let acc = if matches!(set, "sky" | "stiff") {
        String::new()
    } else {
        let (err_r, err_rgb) = peer.max_trans_error([&o[0], &o[1], &o[2]]);
        format!("  max|dT| = {err_r:.3e} (red), {err_rgb:.3e} (RGB)")
    };
    println!(
        "{mode} {set}: {:.3} ns/ray, best of {reps}{acc}",
        best / n as f64 * 1e9,
    );
}
