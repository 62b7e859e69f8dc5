//! `analytic-fog report`: error against run time for every kernel and every method, and
//! the stability sweeps (feature `report`, enabled by `cli`).
//!
//! For each kernel (height fog grey and RGB with in-scattering, a sphere volume with each
//! density profile, a mixed scene) and each ray set (typical, extreme), every method of
//! [`Method`] is timed (median of repeats, one thread and all of rayon's threads) and
//! compared with the f64 reference ray by ray: |ΔT|, the relative error of τ, and the
//! error of L_in relative to the fog colour (max, p99, mean over rays of the worst
//! channel). The results go to a table on stdout, `report.json` and `report.csv`, and the
//! log–log charts of error against time; [`stability`] adds the sweeps over d_up and the
//! camera height.

mod chart;
mod methods;
mod rays;
pub mod stability;

pub use methods::{reference_ray, seed000_geo, Evaluators, Method};
pub use rays::{RaySet, RaysRef};

use crate::{
    Component, HeightFogLayer, Lighting, Phase, Profile, Scene, SceneDesc, Shape, Sun, Tier, Volume,
};
use glam::Vec3;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// What to run.
#[derive(Clone, Debug)]
pub struct Options {
    /// Where report.json, report.csv and the charts go.
    pub out_dir: PathBuf,
    /// Rays per set (typical and extreme); ray marching with 64 steps or more uses the
    /// first `min(rays, 4096)` of them.
    pub rays: usize,
    /// Fewest timing repeats per measurement (the median is reported; see `median_time`).
    pub repeats: usize,
    /// Marching step counts.
    pub march_steps: Vec<u32>,
    /// Only kernels whose name contains this.
    pub filter: Option<String>,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            out_dir: PathBuf::from("target/report"),
            rays: 1 << 15,
            repeats: 7,
            march_steps: vec![4, 16, 64, 256, 1024],
            filter: None,
        }
    }
}

/// Error statistics over a ray set (per ray: the worst of the three channels).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Stats {
    /// The largest error.
    pub max: f64,
    /// The 99th percentile.
    pub p99: f64,
    /// The mean.
    pub mean: f64,
}

impl Stats {
    fn of(mut v: Vec<f64>) -> Stats {
        if v.is_empty() {
            return Stats::default();
        }
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        v.sort_by(|a, b| a.total_cmp(b));
        let p99 = v[((v.len() as f64 * 0.99).ceil() as usize).clamp(1, v.len()) - 1];
        Stats {
            max: *v.last().expect("non-empty"),
            p99,
            mean,
        }
    }
}

/// One measured (kernel, ray set, method).
#[derive(Clone, Debug)]
pub struct Row {
    /// The kernel's name ([`Kernel::name`]).
    pub kernel: String,
    /// The ray set's name (`"typical"`, `"extreme"`).
    pub set: &'static str,
    /// What was run.
    pub method: Method,
    /// Rays evaluated: the whole set, or its first 8192 for the reference and 4096 for
    /// marching with 64 steps or more.
    pub rays: usize,
    /// Median time per ray on one thread, in ns.
    pub ns_1t: f64,
    /// Median time per ray with all of rayon's threads, in ns.
    pub ns_mt: f64,
    /// |ΔT| against the f64 reference.
    pub t_abs: Stats,
    /// Relative error of τ against the f64 reference.
    pub tau_rel: Stats,
    /// Error of L_in relative to the fog colour.
    pub lin_rel: Stats,
    /// Rays with a NaN in any output (none for the crate's kernels on finite input).
    pub nan_rays: usize,
}

/// The ray-marching step count that matches the Accurate tier's max |ΔT|, and the
/// speedup of the Accurate kernel at that error.
#[derive(Clone, Debug)]
pub struct Match {
    /// The kernel's name.
    pub kernel: String,
    /// The ray set's name.
    pub set: &'static str,
    /// The Accurate tier's max |ΔT| on this set.
    pub accurate_err: f64,
    /// Steps needed (measured, or extrapolated from the last two step counts assuming
    /// error ∝ steps^−p), None where marching does not converge toward it.
    pub steps: Option<f64>,
    /// Whether `steps` is extrapolated rather than measured.
    pub extrapolated: bool,
    /// time(march at `steps`) / time(accurate x8), one thread.
    pub speedup: Option<f64>,
}

/// Everything the report measured.
pub struct Report {
    /// The SIMD level compiled in ([`crate::simd_level`]).
    pub simd: &'static str,
    /// Whether one-layer batches ran 16 AVX-512 lanes chosen at run time
    /// ([`crate::avx512_dispatch`]).
    pub avx512_dispatch: bool,
    /// rayon's thread count.
    pub threads: usize,
    /// One per (kernel, ray set, method).
    pub rows: Vec<Row>,
    /// One per (kernel, ray set) where ray marching ran.
    pub matches: Vec<Match>,
    /// The stability sweeps.
    pub stability: stability::Stability,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// The report's own run time.
    pub elapsed: Duration,
}

/// A kernel of the report: a scene and its ray sets.
pub struct Kernel {
    /// Its name in the tables and files.
    pub name: String,
    /// The scene, in the forms the methods need.
    pub eval: Evaluators,
    /// The named ray sets.
    pub sets: Vec<(&'static str, RaySet)>,
    /// For the framebuffer pass: one frame per set (same order); the crate's 8-lane
    /// methods are then timed through `Scene::fog_pass`, per pixel.
    pub frames: Vec<Frame>,
}

/// A frame for the framebuffer pass: a camera and a linear-view depth buffer, with the
/// pixel rays (as `Camera::pixel_ray` makes them) in the kernel's ray set.
pub struct Frame {
    /// The camera.
    pub camera: crate::pass::Camera,
    /// The frame's width in pixels.
    pub width: usize,
    /// The frame's height in pixels.
    pub height: usize,
    /// Linear view depth per pixel, row by row.
    pub depth: Vec<f32>,
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// A camera over a ground plane y = 0 in the RGB height fog: the typical frame 2 above
/// the ground looking at the horizon; the extreme one 5000 above (500 scale heights over
/// the fog's base) looking down 30°, so that most pixels' rays cross the whole fog.
fn pass_frame(n: usize, extreme: bool) -> (Frame, RaySet) {
    use crate::pass::{Camera, DepthConvention};
    let width = ((n as f64 * 16.0 / 9.0).sqrt().round() as usize).max(8);
    let height = (n / width).max(1);
    let (pos, fwd) = if extreme {
        (Vec3::new(0.0, 5000.0, 0.0), Vec3::new(0.0, -0.5, -0.866))
    } else {
        (Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -0.05, -1.0))
    };
    let camera = Camera::perspective(pos, fwd, Vec3::Y, 1.0, width as f32 / height as f32)
        .expect("valid camera");
    let mut depth = vec![0.0f32; width * height];
    let mut rays = RaySet::with_len(width * height);
    let n_px = (width * height) as u64;
    let stride = (7919..)
        .find(|p| gcd(*p, n_px) == 1)
        .expect("a coprime stride");
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            // Direction with forward component 1: the view depth of the ground is the
            // ray parameter where y reaches 0.
            let r = camera
                .pixel_ray(x, y, width, height, 1.0, DepthConvention::LinearView)
                .expect("pixel in frame");
            depth[i] = if r.direction.y < 0.0 {
                -pos.y / r.direction.y
            } else {
                f32::INFINITY
            };
            let r = camera
                .pixel_ray(x, y, width, height, depth[i], DepthConvention::LinearView)
                .expect("pixel in frame");
            // Pixels in a scattered order (i·P mod N, P coprime to N), so that the first
            // 4096 rays that the slow methods use cover the whole frame.
            let j = (i as u64 * stride % (width * height) as u64) as usize;
            rays.set(j, r.origin.to_array(), r.direction.to_array(), r.t);
        }
    }
    (
        Frame {
            camera,
            width,
            height,
            depth,
        },
        rays,
    )
}

fn layer(b: f32, comps: Vec<Component>) -> HeightFogLayer {
    HeightFogLayer {
        base_height: 0.0,
        falloff: b,
        emission: glam::Vec3::ZERO,
        components: comps,
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

fn rgb_layer() -> HeightFogLayer {
    layer(
        0.1,
        vec![
            Component {
                scattering: Vec3::new(0.005, 0.012, 0.03),
                absorption: Vec3::ZERO,
                phase: Phase::Rayleigh,
            },
            Component {
                scattering: Vec3::splat(0.02),
                absorption: Vec3::splat(0.002),
                phase: Phase::HenyeyGreenstein(0.7),
            },
        ],
    )
}

fn sphere_volume(c: Vec3, r: f32, p: Profile, s: Vec3) -> Volume {
    Volume {
        absorption: Vec3::splat(0.01),
        phase: Phase::HenyeyGreenstein(0.5),
        emission: Vec3::new(0.05, 0.02, 0.0),
        ..Volume::new(
            Shape::Sphere {
                center: c,
                radius: r,
            },
            p,
            s,
        )
    }
}

/// The report's kernels, `n` rays per set.
pub fn kernels(n: usize) -> Vec<Kernel> {
    let mut ks = vec![];
    let hf = |name: &str, l: HeightFogLayer| Kernel {
        name: name.into(),
        eval: Evaluators::new(SceneDesc {
            height_fog: vec![l],
            lighting: lighting(),
            ..SceneDesc::default()
        }),
        sets: vec![
            ("typical", rays::height_fog(n, false)),
            ("extreme", rays::height_fog(n, true)),
        ],
        frames: vec![],
    };
    ks.push(hf(
        "height_fog_grey",
        layer(
            0.1,
            vec![Component {
                scattering: Vec3::splat(0.02),
                absorption: Vec3::splat(0.005),
                phase: Phase::Isotropic,
            }],
        ),
    ));
    ks.push(hf("height_fog_rgb", rgb_layer()));
    let (c, r) = (Vec3::new(0.0, 2.0, 30.0), 10.0);
    for p in Profile::ALL {
        ks.push(Kernel {
            name: format!("volume_{}", format!("{p:?}").to_lowercase()),
            eval: Evaluators::new(SceneDesc {
                volumes: vec![sphere_volume(c, r, p, Vec3::new(0.08, 0.1, 0.12))],
                lighting: lighting(),
                ..SceneDesc::default()
            }),
            sets: vec![
                ("typical", rays::toward_sphere(n, false, c.to_array(), r)),
                ("extreme", rays::toward_sphere(n, true, c.to_array(), r)),
            ],
            frames: vec![],
        });
    }
    let vols = vec![
        sphere_volume(
            Vec3::new(-20.0, 3.0, 60.0),
            12.0,
            Profile::Gaussian,
            Vec3::splat(0.2),
        ),
        sphere_volume(
            Vec3::new(15.0, 1.0, 40.0),
            8.0,
            Profile::Quadratic,
            Vec3::new(0.05, 0.08, 0.1),
        ),
        sphere_volume(
            Vec3::new(0.0, 6.0, 100.0),
            20.0,
            Profile::Spiky,
            Vec3::splat(0.1),
        ),
        sphere_volume(
            Vec3::new(40.0, 0.0, 120.0),
            15.0,
            Profile::Constant,
            Vec3::splat(0.03),
        ),
        Volume::cut(Shape::Sphere {
            center: Vec3::new(-20.0, 3.0, 60.0),
            radius: 5.0,
        }),
    ];
    ks.push(Kernel {
        name: "mixed".into(),
        eval: Evaluators::new(SceneDesc {
            height_fog: vec![rgb_layer()],
            volumes: vols,
            lighting: lighting(),
            ..SceneDesc::default()
        }),
        sets: vec![
            ("typical", rays::landscape(n, false)),
            ("extreme", rays::landscape(n, true)),
        ],
        frames: vec![],
    });
    let (ft, rt) = pass_frame(n, false);
    let (fe, re) = pass_frame(n, true);
    let mut eval = Evaluators::new(SceneDesc {
        height_fog: vec![rgb_layer()],
        lighting: lighting(),
        ..SceneDesc::default()
    });
    // Pixel rays have a forward component of 1, not unit length.
    eval.unit = false;
    ks.push(Kernel {
        name: "framebuffer_pass".into(),
        eval,
        sets: vec![("typical", rt), ("extreme", re)],
        frames: vec![ft, fe],
    });
    ks
}

/// Output columns for `n` rays.
struct Cols(Vec<Vec<f32>>);

impl Cols {
    fn new(n: usize) -> Cols {
        Cols((0..9).map(|_| vec![0.0; n]).collect())
    }
    fn view(&mut self) -> methods::OutCols<'_> {
        let v: Vec<&mut [f32]> = self.0.iter_mut().map(|c| &mut c[..]).collect();
        v.try_into().expect("9 columns")
    }
}

/// The median of `repeats` timings of `f` or more: short measurements repeat until they
/// have run 30 ms in all (at most 400 times), long ones stop after 3 once 0.25 s is spent.
fn median_time(repeats: usize, mut f: impl FnMut()) -> Duration {
    let mut ts = vec![];
    let start = Instant::now();
    loop {
        let t0 = Instant::now();
        f();
        ts.push(t0.elapsed());
        let spent = start.elapsed();
        let enough = ts.len() >= repeats.max(1) && spent >= Duration::from_millis(30);
        let long = ts.len() >= 3 && spent > Duration::from_millis(250);
        if enough || long || ts.len() >= 400 {
            break;
        }
    }
    ts.sort();
    ts[ts.len() / 2]
}

/// The relative error of an f32 optical depth against the f64 one, where the f64 value
/// rounded to f32 counts as exact (τ beyond f32::MAX is +∞, below half the least
/// subnormal 0); a wrong +∞ or 0 counts as 1; capped at 1e30.
pub fn tau_rel_err(got: f64, want: f64) -> f64 {
    if got == want || got == want as f32 as f64 {
        0.0
    } else if got.is_nan() {
        f64::INFINITY
    } else if want == 0.0 || want.is_infinite() || got.is_infinite() {
        1.0
    } else {
        ((got - want).abs() / want).min(1e30)
    }
}

/// The framebuffer pass over `f` (an RGB colour buffer fogged in place), one thread and
/// all threads: median times for the whole frame. With the batch API's kernel
/// (`with_batch_kernel_pass`), whose errors the report measures on the same pixel rays;
/// the pass's own one-layer kernel is measured by `benches/pass.rs` and `tests/pass.rs`.
fn pass_times(scene: &Scene, tier: Tier, f: &Frame, repeats: usize) -> (Duration, Duration) {
    use crate::pass::{ColourBuffer, Depth};
    let scene = scene.clone().with_tier(tier).with_batch_kernel_pass();
    let mut colour = vec![0.5f32; f.width * f.height * 3];
    let mut go = |par: bool| {
        median_time(repeats, || {
            let depth = Depth::linear_view(&f.depth);
            let c = ColourBuffer::Rgb(&mut colour);
            let r = if par {
                scene.fog_pass(&f.camera, f.width, f.height, depth, c)
            } else {
                scene.fog_pass_single(&f.camera, f.width, f.height, depth, c)
            };
            r.expect("valid frame");
        })
    };
    let t1 = go(false);
    (t1, go(true))
}

/// Per-ray errors of `got` against the reference `want` ([τ, T, L_in, colour] per ray).
fn errors(got: &Cols, want: &[[[f64; 3]; 4]]) -> (Stats, Stats, Stats, usize) {
    let n = want.len();
    let set_colour = [0, 1, 2].map(|ch| {
        let m = want.iter().map(|w| w[3][ch].abs()).fold(0.0, f64::max);
        if m > 0.0 {
            m
        } else {
            1.0
        }
    });
    let (mut ta, mut tr, mut lr) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let mut nans = 0;
    for (i, w) in want.iter().enumerate() {
        let (mut a, mut r, mut l) = (0.0f64, 0.0f64, 0.0f64);
        let mut nan = false;
        for ch in 0..3 {
            let tau = got.0[ch][i] as f64;
            let t = got.0[3 + ch][i] as f64;
            let lin = got.0[6 + ch][i] as f64;
            if tau.is_nan() || t.is_nan() || lin.is_nan() {
                nan = true;
                continue;
            }
            a = a.max((t - w[1][ch]).abs());
            r = r.max(tau_rel_err(tau, w[0][ch]));
            // Relative to the fog colour: the reference's, or where the reference ray
            // sees no medium (colour 0), the largest fog colour of the ray set.
            // (Floored at 1e-6 of that: a reference colour that is tiny but not 0 comes
            // from a degenerate mix, not from the scene's light.)
            let scale = w[3][ch].abs().max(1e-6 * set_colour[ch]);
            l = l.max(((lin - w[2][ch]).abs() / scale).min(1e30));
        }
        if nan {
            nans += 1;
            a = f64::INFINITY;
            r = f64::INFINITY;
            l = f64::INFINITY;
        }
        ta.push(a);
        tr.push(r);
        lr.push(l);
    }
    (Stats::of(ta), Stats::of(tr), Stats::of(lr), nans)
}

/// Runs the report. `progress` receives one line per step (the CLI prints it on stderr).
pub fn run(opts: &Options, progress: &mut dyn FnMut(&str)) -> Result<Report, String> {
    let start = Instant::now();
    let threads = rayon::current_num_threads();
    std::fs::create_dir_all(&opts.out_dir)
        .map_err(|e| format!("{}: cannot create directory: {e}", opts.out_dir.display()))?;
    let mut ks = kernels(opts.rays);
    if let Some(f) = &opts.filter {
        ks.retain(|k| k.name.contains(f.as_str()));
        if ks.is_empty() {
            return Err(format!("--kernel {f:?}: no kernel of that name"));
        }
    }
    let mut rows = vec![];
    let total = ks.len() * 2;
    let mut done = 0;
    for k in &ks {
        for (set_index, (set, rs)) in k.sets.iter().enumerate() {
            done += 1;
            progress(&format!("[{done}/{total}] {} ({set})", k.name));
            let reference: Vec<[[f64; 3]; 4]> = {
                use rayon::prelude::*;
                let v = rs.view();
                (0..rs.len())
                    .into_par_iter()
                    .map(|i| {
                        let (o, d, t) = v.get(i);
                        reference_ray(
                            &k.eval.desc,
                            Vec3::from_array(o).as_dvec3(),
                            Vec3::from_array(d).as_dvec3(),
                            t as f64,
                        )
                    })
                    .collect()
            };
            let mut methods = vec![
                Method::AccurateX8,
                Method::FastX8,
                Method::Scalar,
                Method::Reference,
                Method::Seed,
            ];
            methods.extend(opts.march_steps.iter().map(|&s| Method::March(s)));
            for m in methods {
                let n = match m {
                    Method::March(s) if s >= 64 => rs.len().min(4096),
                    Method::Reference => rs.len().min(8192),
                    _ => rs.len(),
                };
                let view = rs.view().split_at(n).0;
                let mut out = Cols::new(n);
                k.eval.apply(m, view, &mut out.view());
                let (t_abs, tau_rel, lin_rel, nan_rays) = errors(&out, &reference[..n]);
                let frame = k.frames.get(set_index);
                let (t1, tm) = match (frame, m) {
                    (Some(f), Method::AccurateX8 | Method::FastX8) => {
                        let tier = if m == Method::FastX8 {
                            Tier::Fast
                        } else {
                            Tier::Accurate
                        };
                        pass_times(&k.eval.accurate, tier, f, opts.repeats)
                    }
                    _ => (
                        median_time(opts.repeats, || k.eval.apply(m, view, &mut out.view())),
                        median_time(opts.repeats, || k.eval.apply_par(m, view, out.view())),
                    ),
                };
                rows.push(Row {
                    kernel: k.name.clone(),
                    set,
                    method: m,
                    rays: n,
                    ns_1t: t1.as_secs_f64() * 1e9 / n as f64,
                    ns_mt: tm.as_secs_f64() * 1e9 / n as f64,
                    t_abs,
                    tau_rel,
                    lin_rel,
                    nan_rays,
                });
            }
        }
    }
    let matches = march_matches(&rows);
    progress("stability sweeps");
    let stab = stability::run();
    let mut report = Report {
        simd: crate::simd_level(),
        avx512_dispatch: crate::avx512_dispatch(),
        threads,
        rows,
        matches,
        stability: stab,
        files: vec![],
        elapsed: Duration::ZERO,
    };
    progress("writing files");
    report.files = write_files(&report, opts)?;
    report.elapsed = start.elapsed();
    Ok(report)
}

/// For every kernel and set: the marching step count at the Accurate tier's max |ΔT|.
fn march_matches(rows: &[Row]) -> Vec<Match> {
    let mut out = vec![];
    for acc in rows.iter().filter(|r| r.method == Method::AccurateX8) {
        let mut marches: Vec<&Row> = rows
            .iter()
            .filter(|r| r.kernel == acc.kernel && r.set == acc.set)
            .filter(|r| matches!(r.method, Method::March(_)))
            .collect();
        marches.sort_by_key(|r| match r.method {
            Method::March(s) => s,
            _ => 0,
        });
        let steps = |r: &Row| match r.method {
            Method::March(s) => s as f64,
            _ => 0.0,
        };
        let e_a = acc.t_abs.max;
        let mut m = Match {
            kernel: acc.kernel.clone(),
            set: acc.set,
            accurate_err: e_a,
            steps: None,
            extrapolated: false,
            speedup: None,
        };
        if let Some(r) = marches.iter().find(|r| r.t_abs.max <= e_a) {
            m.steps = Some(steps(r));
            m.speedup = Some(r.ns_1t / acc.ns_1t);
        } else if marches.len() >= 2 {
            let (a, b) = (marches[marches.len() - 2], marches[marches.len() - 1]);
            let (e1, e2) = (a.t_abs.max, b.t_abs.max);
            let p = (e1 / e2).ln() / (steps(b) / steps(a)).ln();
            let n = steps(b) * (e2 / e_a).powf(1.0 / p);
            // Extrapolated only from a clear power law, and at most 100× beyond the
            // largest step count measured.
            if p.is_finite() && p > 0.5 && e2 > 0.0 && e_a > 0.0 && n <= 100.0 * steps(b) {
                m.steps = Some(n);
                m.extrapolated = true;
                m.speedup = Some(b.ns_1t * (n / steps(b)) / acc.ns_1t);
            }
        }
        out.push(m);
    }
    out
}

fn fmt_e(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if x.is_infinite() {
        "inf".into()
    } else {
        format!("{x:.1e}")
    }
}

/// The report as a text table.
pub fn table(r: &Report) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "analytic-fog report: simd {}{}, {} threads; errors against the f64 reference (worst channel per ray)",
        r.simd,
        if r.avx512_dispatch { " (avx512 at run time)" } else { "" },
        r.threads
    );
    let mut last = String::new();
    for row in &r.rows {
        let key = format!("{} ({})", row.kernel, row.set);
        if key != last {
            let _ = writeln!(
                s,
                "\n{key}\n  {:<14} {:>6} {:>9} {:>9} {:>8} {:>8} {:>8} {:>8} {:>8} {:>5}",
                "method",
                "rays",
                "ns/ray 1t",
                "ns/ray mt",
                "|dT|max",
                "|dT|p99",
                "tau rel",
                "Lin rel",
                "Lin p99",
                "NaN"
            );
            last = key;
        }
        let _ = writeln!(
            s,
            "  {:<14} {:>6} {:>9.2} {:>9.2} {:>8} {:>8} {:>8} {:>8} {:>8} {:>5}",
            row.method.name(),
            row.rays,
            row.ns_1t,
            row.ns_mt,
            fmt_e(row.t_abs.max),
            fmt_e(row.t_abs.p99),
            fmt_e(row.tau_rel.max),
            fmt_e(row.lin_rel.max),
            fmt_e(row.lin_rel.p99),
            row.nan_rays
        );
    }
    let _ = writeln!(
        s,
        "\nray marching at the Accurate tier's max |dT| (steps; time relative to accurate_x8, one thread):"
    );
    for m in &r.matches {
        let _ = writeln!(
            s,
            "  {:<18} {:<8} |dT| {:>8}: {}",
            m.kernel,
            m.set,
            fmt_e(m.accurate_err),
            match (m.steps, m.speedup) {
                (Some(n), Some(x)) => format!(
                    "{} {n:.0} steps, accurate_x8 {x:.0}x faster",
                    if m.extrapolated { "~" } else { "" }
                ),
                _ => "not reached (no clear convergence toward it within 100x the steps measured)"
                    .into(),
            }
        );
    }
    let _ = writeln!(s, "\n{}", r.stability.summary());
    s
}

fn write_files(r: &Report, opts: &Options) -> Result<Vec<PathBuf>, String> {
    let dir = &opts.out_dir;
    let put = |name: &str, bytes: &[u8]| -> Result<PathBuf, String> {
        let p = dir.join(name);
        std::fs::write(&p, bytes).map_err(|e| format!("{}: cannot write: {e}", p.display()))?;
        Ok(p)
    };
    let mut files = vec![];
    // CSV
    let mut csv = String::from(
        "kernel,set,method,rays,ns_per_ray_1t,ns_per_ray_mt,T_abs_max,T_abs_p99,T_abs_mean,\
         tau_rel_max,tau_rel_p99,tau_rel_mean,lin_rel_max,lin_rel_p99,lin_rel_mean,nan_rays\n",
    );
    for x in &r.rows {
        csv.push_str(&format!(
            "{},{},{},{},{:.4},{:.4},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{}\n",
            x.kernel,
            x.set,
            x.method.name(),
            x.rays,
            x.ns_1t,
            x.ns_mt,
            x.t_abs.max,
            x.t_abs.p99,
            x.t_abs.mean,
            x.tau_rel.max,
            x.tau_rel.p99,
            x.tau_rel.mean,
            x.lin_rel.max,
            x.lin_rel.p99,
            x.lin_rel.mean,
            x.nan_rays
        ));
    }
    files.push(put("report.csv", csv.as_bytes())?);
    // JSON (non-finite numbers as null)
    let num = |x: f64| {
        if x.is_finite() {
            serde_json::json!(x)
        } else {
            serde_json::Value::Null
        }
    };
    let stats =
        |s: &Stats| serde_json::json!({"max": num(s.max), "p99": num(s.p99), "mean": num(s.mean)});
    let rows: Vec<_> = r
        .rows
        .iter()
        .map(|x| {
            serde_json::json!({
                "kernel": x.kernel, "set": x.set, "method": x.method.name(), "rays": x.rays,
                "ns_per_ray_1t": num(x.ns_1t), "ns_per_ray_mt": num(x.ns_mt),
                "T_abs": stats(&x.t_abs), "tau_rel": stats(&x.tau_rel), "lin_rel": stats(&x.lin_rel),
                "nan_rays": x.nan_rays,
            })
        })
        .collect();
    let matches: Vec<_> = r
        .matches
        .iter()
        .map(|m| {
            serde_json::json!({
                "kernel": m.kernel, "set": m.set, "accurate_T_abs_max": num(m.accurate_err),
                "march_steps": m.steps.map(num), "extrapolated": m.extrapolated,
                "speedup": m.speedup.map(num),
            })
        })
        .collect();
    let doc = serde_json::json!({
        "simd": r.simd, "avx512_dispatch": r.avx512_dispatch, "threads": r.threads, "rows": rows, "march_to_accurate": matches,
        "stability": r.stability.to_json(),
    });
    let text = serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?;
    files.push(put("report.json", text.as_bytes())?);
    files.push(put("stability.csv", r.stability.to_csv().as_bytes())?);
    files.extend(chart::draw_all(r, dir)?);
    Ok(files)
}
