//! One 1920×1080 frame through the framebuffer pass on one thread (the frame of
//! `benches/pass.rs`: one RGB height fog layer, Henyey–Greenstein sun and ambient,
//! interleaved RGB; here the lower half at depths 10 to 106, the upper half sky), for
//! counting instructions:
//!
//! `cargo build --release --example passloop && valgrind --tool=callgrind
//! target/release/examples/passloop` (then `callgrind_annotate --inclusive=yes` and look
//! for `height::fog_rows`; a frame is 2,073,600 pixels, 259,200 packets of 8).
//! `passloop batch` runs the batch API's kernel (`Scene::with_batch_kernel_pass`).
//! `FRAMES=n` runs n frames and prints the best frame's time (for `perf record`);
//! `EYE_Y=y` puts the eye at height y (default 2); `W=w H=h` sets the frame's size (e.g.
//! `W=1920 H=16`, whose depth and colour stay in cache, against the full frame's 58 MB).
//! `PAR=1` runs the rayon pass (`Scene::fog_pass`; `RAYON_NUM_THREADS` sets its threads)
//! instead of the calling thread's (`Scene::fog_pass_single`); `PAR=2` runs two frames at
//! once, each on one thread. `NO512=1` keeps the build's own lanes where the x86-64-v3
//! build would run AVX-512 ones (`Scene::without_avx512_dispatch`). `EXACT=1` runs every
//! frame through the batch API's kernel (`Scene::with_batch_kernel_pass`).
//! `PLAIN=1` runs the plain pass of `benches/pass.rs` (read depth and colour, write
//! colour; one thread) instead of the fog pass: with `H=` it shows at what frame size the
//! frame stops fitting in the cache this process gets (the fog pass's memory stalls).
//! `DEPTH=k` sets the depth convention (the same view depths converted): `distance`,
//! `ndc` (standard, near 0.1, far 1e4) or `ndc_rev` (reversed-Z, near 0.1, far +∞).
//! `DEPTHS=k` replaces the lower half's depths, for extreme data: `zero` (0), `subnormal`
//! (1e-40 to 1e-38), `tiny` (1e-30), `huge` (1e30), `max` (f32::MAX), `sky` (every pixel
//! +∞). `TILT=1` rolls the camera a little (its up +Y + 0.05·X), so that no row has a
//! constant dot(d, up) and every row takes the general form (no `RowFactor`). `ORTHO=1`
//! makes the camera orthographic (4 units high); its `ndc` and `ndc_rev` depths are an
//! orthographic rasterizer's, (z − near)/(far − near), with far 1e4 in both.
//! `FALLOFF=b` sets the layer's falloff (default 0.1) and `SCALE=s` multiplies its
//! scattering coefficients (default 1), for scanning extreme media.

use analytic_fog::pass::{Camera, ColourBuffer, Depth};
use analytic_fog::{Component, HeightFogLayer, Lighting, Phase, Scene, SceneDesc, Sun};
use glam::Vec3;
fn main() {
    let env_f32 = |k: &str, d: f32| {
        std::env::var(k)
            .ok()
            .and_then(|f| f.parse().ok())
            .unwrap_or(d)
    };
    let scene = Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: env_f32("FALLOFF", 0.1),
            emission: Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::new(0.02, 0.03, 0.05) * env_f32("SCALE", 1.0),
                absorption: Vec3::ZERO,
                phase: Phase::HenyeyGreenstein(0.6),
            }],
        }],
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87).normalize(),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        },
        ..SceneDesc::default()
    })
    .unwrap();
    let scene = if std::env::args().nth(1).as_deref() == Some("batch") {
        scene.with_batch_kernel_pass()
    } else {
        scene
    };
    // `NO512=1`: the build's own lanes, as on a CPU without AVX-512
    // (`Scene::without_avx512_dispatch`).
    let scene = if std::env::var("NO512").is_ok_and(|v| v == "1") {
        scene.without_avx512_dispatch()
    } else {
        scene
    };
    // `EXACT=1`: the batch API's kernel on every frame (`Scene::with_batch_kernel_pass`).
    let scene = if std::env::var("EXACT").is_ok_and(|v| v == "1") {
        scene.with_batch_kernel_pass()
    } else {
        scene
    };
    // `W=w H=h`: another frame size (default 1920×1080; a small one stays in cache).
    let env_usize = |k: &str, d: usize| {
        std::env::var(k)
            .ok()
            .and_then(|f| f.parse().ok())
            .unwrap_or(d)
    };
    let (w, h) = (env_usize("W", 1920).max(1), env_usize("H", 1080).max(1));
    // `EYE_Y=y`: the eye's height (default 2; e.g. 500, far above the fog, where τ is
    // below 1e-19 everywhere in the frame).
    let eye_y = env_f32("EYE_Y", 2.0);
    let tilt = std::env::var("TILT").is_ok_and(|v| v == "1");
    let up = if tilt {
        Vec3::new(0.05, 1.0, 0.0)
    } else {
        Vec3::Y
    };
    let forward = Vec3::new(0.0, -0.15, -1.0).normalize();
    let aspect = w as f32 / h as f32;
    // `ORTHO=1`: an orthographic camera (4 units high) at the same place, looking the same way.
    let cam = if std::env::var("ORTHO").is_ok_and(|v| v == "1") {
        Camera::orthographic(Vec3::new(0.0, eye_y, 0.0), forward, up, 4.0, aspect)
    } else {
        Camera::perspective(Vec3::new(0.0, eye_y, 0.0), forward, up, 1.0, aspect)
    }
    .unwrap();
    let depths = std::env::var("DEPTHS").unwrap_or_default();
    let depth: Vec<f32> = (0..w * h)
        .map(|i| {
            if (i / w) < h / 2 {
                return f32::INFINITY;
            }
            let k = (i % 97) as f32;
            match depths.as_str() {
                "zero" => 0.0,
                "subnormal" => 1e-40 + k * 1e-40,
                "tiny" => 1e-30 * (1.0 + k),
                "huge" => 1e30 * (1.0 + k),
                "max" => f32::MAX,
                "sky" => f32::INFINITY,
                _ => 10.0 + k,
            }
        })
        .collect();
    // `DEPTH=k`: the depth convention, the same view depths converted: `distance` (taken
    // as distances along the rays), `ndc` (standard, near 0.1, far 1e4) or `ndc_rev`
    // (reversed-Z, near 0.1, infinite far; 1e4 for an orthographic camera, which needs
    // it finite); linear view depth otherwise.
    let convention = std::env::var("DEPTH").unwrap_or_default();
    let ortho = cam.projection() == analytic_fog::pass::Projection::Orthographic;
    let (near, far) = (0.1f64, 1e4f64);
    let far_rev = if ortho { far as f32 } else { f32::INFINITY };
    let depth: Vec<f32> = depth
        .iter()
        .map(|&z| {
            let z = f64::from(z);
            match convention.as_str() {
                "ndc" | "ndc_rev" if ortho => {
                    let s = if z.is_infinite() {
                        1.0
                    } else {
                        (z - near) / (far - near)
                    };
                    (if convention == "ndc" { s } else { 1.0 - s }) as f32
                }
                "ndc" if z.is_infinite() => 1.0,
                "ndc" => (far * (z - near) / (z * (far - near))) as f32,
                "ndc_rev" => (near / z) as f32,
                _ => z as f32,
            }
        })
        .collect();
    let depth_of = |values| match convention.as_str() {
        "distance" => Depth::distance(values),
        "ndc" => Depth::ndc(values, near as f32, far as f32),
        "ndc_rev" => Depth::ndc_reversed(values, near as f32, far_rev),
        _ => Depth::linear_view(values),
    };
    let depth = depth.as_slice();
    let mut c = vec![0.5f32; 3 * w * h];
    // `FRAMES=n`: n frames (for a sampling profiler), printing the best frame's time.
    let frames: usize = std::env::var("FRAMES")
        .ok()
        .and_then(|f| f.parse().ok())
        .unwrap_or(1)
        .max(1);
    // `PAR=1`: the rayon pass (`Scene::fog_pass`) instead of the calling thread's.
    let par = std::env::var("PAR").is_ok_and(|v| v == "1");
    // `PLAIN=1`: the plain pass: `benches/pass.rs`'s `plain` arithmetic on one thread, sky
    // depths clamped to 1e4 as in the bench's depth for it (so the colour stays finite).
    if std::env::var("PLAIN").is_ok_and(|v| v == "1") {
        let best = best_of(frames, || {
            for (px, z) in c.chunks_exact_mut(3).zip(depth) {
                let z = z.min(1e4);
                for v in px {
                    *v = *v * 0.5 + z * 1e-3;
                }
            }
        });
        let (ms, ns) = (best * 1e3, best * 1e9 / (w * h) as f64);
        let v = c[12345 % c.len()];
        println!("{v}  plain pass, best frame of {frames}: {ms:.3} ms, {ns:.3} ns per pixel");
        return;
    }
    // `PAR=2`: two frames at once, each on its own thread (`rayon::join` of two
    // `fog_pass_single`), printing the best pair's time per frame: how the cores scale
    // without the pass's own split into bands.
    if std::env::var("PAR").is_ok_and(|v| v == "2") {
        let mut c2 = c.clone();
        let frame = |c: &mut [f32]| {
            let (dv, cb) = (depth_of(depth), ColourBuffer::Rgb(c));
            scene.fog_pass_single(&cam, w, h, dv, cb).unwrap()
        };
        let best = best_of(frames, || {
            rayon::join(|| frame(&mut c), || frame(&mut c2));
        }) / 2.0;
        println!(
            "two frames at once: best {:.3} ms per frame, {:.3} ns per pixel",
            best * 1e3,
            best * 1e9 / (w * h) as f64
        );
        return;
    }
    let best = best_of(frames, || {
        let (dv, cb) = (depth_of(depth), ColourBuffer::Rgb(&mut c));
        if par {
            scene.fog_pass(&cam, w, h, dv, cb).unwrap();
        } else {
            scene.fog_pass_single(&cam, w, h, dv, cb).unwrap();
        }
    });
    let frame = scene
        .fog_pass_own_kernel(&cam, w, h, depth_of(depth).convention)
        .unwrap();
    let own = frame.is_some();
    let uniform = frame.map_or(0, |f| f.uniform_rows);
    let linear = frame.is_some_and(|f| f.linear_phase);
    println!(
        "{}  best frame of {frames}: {:.3} ms, {:.3} ns per pixel ({}, {uniform} uniform rows, \
         linear phase form: {linear})",
        c[12345 % c.len()],
        best * 1e3,
        best * 1e9 / (w * h) as f64,
        if own { "own kernel" } else { "batch kernel" }
    );
}

/// The shortest of `frames` runs of `f`, in seconds.
fn best_of(frames: usize, mut f: impl FnMut()) -> f64 {
    let mut best = f64::INFINITY;
    for _ in 0..frames {
        let t0 = std::time::Instant::now();
        f();
        best = best.min(t0.elapsed().as_secs_f64());
    }
    best
}
