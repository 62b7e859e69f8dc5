//! Times the batch kernel (the build's lanes: 8, or 16 where AVX-512 is chosen at run time;
//! RGB transmittance, unit directions, one thread) on
//! families of extreme data, each the peer's typical rays with one thing changed, against
//! the typical rays themselves in the same run: where a family is slower, the kernel has a
//! slow path for it (a microcode assist on a subnormal intermediate, or a packet that
//! leaves the tame first stage).
//!
//! `REPS=300 target/release/examples/speedscan [FAMILY ...]`: the best of `REPS` passes
//! over 64K rays per family, in ns per ray, and the ratio to `typical` measured between
//! every two families (the machine drifts). With no argument, every family.
//! `SCALE=s` multiplies the layer's scattering coefficients by s for the families (the
//! typical rays keep the peer's scene), e.g. 1e-30 for optical depths that are subnormal
//! in f32; `OUT=tau` times τ alone, `OUT=all` τ, T and L_in (default: T); `NO512=1` runs
//! the build's own lanes where AVX-512 would be chosen at run time.
use analytic_fog::reference::peer::{scene_desc, Family, PeerRays, EXTREME_FAMILIES};
use analytic_fog::{Outputs, Rays, Scene};

fn time(scene: &Scene, r: &PeerRays, reps: usize, what: &str) -> f64 {
    let n = r.oy.len();
    let z = vec![0.0f32; n];
    // Unit directions: d_x from d_y (d_y stays exact, |d| = 1 to rounding).
    let dx = r.dx();
    let rays = Rays::new(&z, &r.oy, &z, &dx, &r.dy, &z, &r.t)
        .unwrap()
        .with_unit_directions(true);
    let mut o: Vec<Vec<f32>> = (0..9).map(|_| vec![0.0f32; n]).collect();
    let mut best = f64::INFINITY;
    for rep in 0..=reps {
        let [a, b, c, d, e, f, g, h, i] = &mut o[..] else {
            unreachable!()
        };
        let out = match what {
            "tau" => Outputs {
                tau: Some([a, b, c]),
                transmittance: None,
                inscattering: None,
            },
            "all" => Outputs {
                tau: Some([d, e, f]),
                transmittance: Some([a, b, c]),
                inscattering: Some([g, h, i]),
            },
            _ => Outputs {
                tau: None,
                transmittance: Some([a, b, c]),
                inscattering: None,
            },
        };
        let t0 = std::time::Instant::now();
        scene.evaluate(&rays, out).unwrap();
        if rep > 0 {
            best = best.min(t0.elapsed().as_secs_f64());
        }
    }
    if what != "tau" {
        assert!(o[..3].iter().flatten().all(|v| (0.0..=1.0).contains(v)));
    }
    best / n as f64 * 1e9
}

fn main() {
    let n = 65536;
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(100)
        .max(1);
    let wanted: Vec<String> = std::env::args().skip(1).collect();
    let scene = Scene::new(scene_desc()).unwrap();
    let scale: f32 = std::env::var("SCALE")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(1.0);
    let outputs = std::env::var("OUT").unwrap_or_default();
    let mut desc = scene_desc();
    desc.height_fog[0].components[0].scattering *= scale;
    let scaled = Scene::new(desc).unwrap();
    // `NO512=1`: the build's own lanes (8), as on a CPU without AVX-512.
    let (scene, scaled) = if std::env::var("NO512").is_ok_and(|v| v == "1") {
        (
            scene.without_avx512_dispatch(),
            scaled.without_avx512_dispatch(),
        )
    } else {
        (scene, scaled)
    };
    let typical = PeerRays::new(n, false);
    println!("family, ns/ray, typical ns/ray (before, after), ratio: what");
    // `typical`: the typical rays themselves (in the scaled scene, with `SCALE`).
    let typical_family: Family = ("typical", "the typical rays", |_, _, _| {});
    for family in std::iter::once(&typical_family).chain(&EXTREME_FAMILIES) {
        let (name, what, _) = *family;
        if !wanted.is_empty() && !wanted.iter().any(|w| w == name) {
            continue;
        }
        let r = PeerRays::family(n, family);
        let before = time(&scene, &typical, reps, &outputs);
        let ns = time(&scaled, &r, reps, &outputs);
        let after = time(&scene, &typical, reps, &outputs);
        let base = 0.5 * (before + after);
        println!(
            "{name:18} {ns:6.2}  ({before:5.2}, {after:5.2})  {:5.2}×  {what}",
            ns / base
        );
    }
}
