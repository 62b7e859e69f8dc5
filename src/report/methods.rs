//! What the report measures: the crate's kernels and the methods a renderer author would
//! otherwise use (the seeds' closed forms in f32, ray marching), all writing τ, T and L_in
//! for a chunk of rays, and the f64 reference they are compared with.

use super::rays::RaysRef;
use crate::reference as rf;
use crate::reference::volume as rv;
use crate::{Outputs, Phase, Profile, Rays, Scene, SceneDesc, Shape, Tier};
use glam::{DVec3, Vec3};

/// One method of evaluating a kernel's scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Method {
    /// The crate's 8-lane kernel, Accurate tier.
    AccurateX8,
    /// The crate's 8-lane kernel, Fast tier.
    FastX8,
    /// The crate's scalar path (Accurate tier; bit-identical to x8).
    Scalar,
    /// The f64 reference (`analytic_fog::reference`): defines the errors.
    Reference,
    /// The seeds' closed forms in f32 with std's `exp`: seed 000's two-branch optical
    /// depth for height fog, seed 002's antiderivatives (with its origin shift) for
    /// spherical volumes; cut-outs ignored; colours as the kernel's model.
    Seed,
    /// Ray marching in f32 with `n` midpoint samples (std's `exp`).
    March(u32),
}

impl Method {
    /// The method's name in the tables and files (`"accurate_x8"`, `"march_64"`, ...).
    pub fn name(&self) -> String {
        match self {
            Method::AccurateX8 => "accurate_x8".into(),
            Method::FastX8 => "fast_x8".into(),
            Method::Scalar => "scalar".into(),
            Method::Reference => "reference_f64".into(),
            Method::Seed => "seed".into(),
            Method::March(n) => format!("march_{n}"),
        }
    }
}

/// Output columns: τ r,g,b, T r,g,b, L_in r,g,b.
pub type OutCols<'a> = [&'a mut [f32]; 9];

/// A sphere in f32 (the seeds' and the marcher's view of a volume).
#[derive(Clone, Copy, Debug)]
pub struct SphereF {
    pub c: Vec3,
    pub r: f32,
}

#[derive(Clone, Debug)]
struct LayerF {
    h0: f32,
    b: f32,
    bt: [f32; 3],
    comps: Vec<([f32; 3], Phase)>,
}

#[derive(Clone, Debug)]
struct VolF {
    s: SphereF,
    profile: Profile,
    bt: [f32; 3],
    /// colour = base + p(θ) · k (the kernel's per-volume model, constants from f64).
    base: [f32; 3],
    k: [f32; 3],
    phase: Phase,
}

/// A scene in the form the f32 baselines use: height fog along +Y, spherical volumes,
/// spherical cut-outs.
#[derive(Clone, Debug)]
pub struct MediumF {
    layers: Vec<LayerF>,
    vols: Vec<VolF>,
    cuts: Vec<SphereF>,
    amb: [f32; 3],
    sun: Option<(Vec3, [f32; 3])>,
    /// The interval a marcher samples: a sphere's chord (a single-volume kernel) or the
    /// whole segment up to `FAR`.
    pub march_sphere: Option<SphereF>,
}

/// How far a marcher goes along an infinite ray.
pub const FAR: f32 = 1e5;

fn sphere_of(s: &Shape) -> Option<SphereF> {
    match *s {
        Shape::Sphere { center, radius } => Some(SphereF {
            c: center,
            r: radius,
        }),
        _ => None,
    }
}

impl MediumF {
    /// The f32 form of `desc` (up must be +Y and the volumes spheres: the report's scenes).
    pub fn new(desc: &SceneDesc) -> MediumF {
        let layers = desc
            .height_fog
            .iter()
            .map(|l| {
                let bt = [0, 1, 2].map(|ch| {
                    l.components
                        .iter()
                        .map(|c| c.scattering[ch] + c.absorption[ch])
                        .sum()
                });
                LayerF {
                    h0: l.base_height,
                    b: l.falloff,
                    bt,
                    comps: l
                        .components
                        .iter()
                        .map(|c| (c.scattering.to_array(), c.phase))
                        .collect(),
                }
            })
            .collect();
        let mut vols = vec![];
        let mut cuts = vec![];
        for v in &desc.volumes {
            let s = sphere_of(&v.shape).expect("report scenes use spheres");
            if v.subtractive {
                cuts.push(s);
                continue;
            }
            // base = colour with p = 0 (sun radiance 0), k from the colour at a direction
            // where p is known: the model is linear in p (see `reference::volume`).
            let mut dark = desc.lighting.clone();
            if let Some(sun) = dark.sun.as_mut() {
                sun.radiance = Vec3::ZERO;
            }
            let base = rv::volume_colour(v, &dark, DVec3::Y);
            let (k, phase) = match &desc.lighting.sun {
                Some(sun) => {
                    let sd = sun.direction.as_dvec3().normalize();
                    let full = rv::volume_colour(v, &desc.lighting, sd);
                    let p = v.phase.eval_f64(1.0);
                    (
                        [0, 1, 2].map(|ch| ((full[ch] - base[ch]) / p) as f32),
                        v.phase,
                    )
                }
                None => ([0.0; 3], Phase::Isotropic),
            };
            vols.push(VolF {
                s,
                profile: v.profile,
                bt: [0, 1, 2].map(|ch| v.scattering[ch] + v.absorption[ch]),
                base: base.map(|x| x as f32),
                k,
                phase,
            });
        }
        let march_sphere = if desc.height_fog.is_empty() && vols.len() == 1 && cuts.is_empty() {
            Some(vols[0].s)
        } else {
            None
        };
        MediumF {
            layers,
            vols,
            cuts,
            amb: desc.lighting.ambient.to_array(),
            sun: desc
                .lighting
                .sun
                .as_ref()
                .map(|s| (s.direction.normalize(), s.radiance.to_array())),
            march_sphere,
        }
    }

    fn cos_sun(&self, d: Vec3) -> f32 {
        self.sun.map_or(0.0, |(s, _)| d.dot(s).clamp(-1.0, 1.0))
    }

    /// The fog colour of layer `l` and of volume `v` for cos θ, in f32.
    fn layer_colour(&self, l: &LayerF, cos: f32) -> [f32; 3] {
        let e = self.sun.map_or([0.0; 3], |s| s.1);
        let mut num = [0.0f32; 3];
        for (bs, ph) in &l.comps {
            let p = phase_f32(*ph, cos);
            for ch in 0..3 {
                num[ch] += bs[ch] * (p * e[ch] + self.amb[ch]);
            }
        }
        [0, 1, 2].map(|ch| {
            if l.bt[ch] > 0.0 {
                num[ch] / l.bt[ch]
            } else {
                0.0
            }
        })
    }

    fn vol_colour(&self, v: &VolF, cos: f32) -> [f32; 3] {
        let p = phase_f32(v.phase, cos);
        [0, 1, 2].map(|ch| v.base[ch] + p * v.k[ch])
    }
}

/// The phase functions in f32, as a renderer writes them.
fn phase_f32(p: Phase, cos: f32) -> f32 {
    use std::f32::consts::PI;
    match p {
        Phase::Isotropic => 1.0 / (4.0 * PI),
        Phase::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + cos * cos),
        Phase::HenyeyGreenstein(g) => {
            (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos).powf(1.5))
        }
        Phase::CornetteShanks(g) => {
            3.0 / (8.0 * PI) * (1.0 - g * g) / (2.0 + g * g) * (1.0 + cos * cos)
                / (1.0 + g * g - 2.0 * g * cos).powf(1.5)
        }
    }
}

fn profile_f32(p: Profile, r: f32) -> f32 {
    if r > 1.0 {
        return 0.0;
    }
    match p {
        Profile::Constant => 1.0,
        Profile::Linear => 1.0 - r,
        Profile::Quadratic => 1.0 - r * r,
        Profile::Quartic => (1.0 - r * r) * (1.0 - r * r),
        Profile::Spiky => (1.0 - r) * (1.0 - r),
        Profile::Gaussian => (-8.0 * r * r).exp(),
    }
}

/// Seed 000's optical depth of one layer (per unit extinction), f32: two branches on d_up.
pub fn seed000_geo(b: f32, y: f32, u: f32, t: f32) -> f32 {
    if u != 0.0 {
        ((-b * y).exp() - (-b * (y + u * t)).exp()) / (b * u)
    } else {
        (-b * y).exp() * t
    }
}

/// The sphere's chord [s0, s1] clipped to [0, t] by the quadratic formula (f32), or None.
fn chord(s: SphereF, o: Vec3, d: Vec3, t: f32) -> Option<(f32, f32)> {
    let q = o - s.c;
    let a = d.dot(d);
    let b = q.dot(d);
    let c = q.dot(q) - s.r * s.r;
    let disc = b * b - a * c;
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let sq = disc.sqrt();
    let s0 = ((-b - sq) / a).max(0.0);
    let s1 = ((-b + sq) / a).min(t);
    (s1 > s0).then_some((s0, s1))
}

fn write(out: &mut OutCols<'_>, i: usize, tau: [f32; 3], colour: [f32; 3]) {
    for ch in 0..3 {
        let tr = (-tau[ch]).exp();
        out[ch][i] = tau[ch];
        out[3 + ch][i] = tr;
        out[6 + ch][i] = colour[ch] * (1.0 - tr);
    }
}

/// Seed formulas for one ray (the direction made unit, t scaled to match).
fn seed_ray(m: &MediumF, o: Vec3, d: Vec3, t: f32) -> ([f32; 3], [f32; 3]) {
    let l = d.length();
    let (d, t) = (d / l, t * l);
    let cos = m.cos_sun(d);
    let mut tau = [0.0f32; 3];
    let mut num = [0.0f32; 3];
    for l in &m.layers {
        let g = seed000_geo(l.b, o.y - l.h0, d.y, t);
        let c = m.layer_colour(l, cos);
        for ch in 0..3 {
            let x = l.bt[ch] * g;
            tau[ch] += x;
            num[ch] += x * c[ch];
        }
    }
    for v in &m.vols {
        let g = rv::seed002_depth(v.profile, v.s.c, v.s.r, o, d, t);
        let c = m.vol_colour(v, cos);
        for ch in 0..3 {
            let x = v.bt[ch] * g;
            tau[ch] += x;
            num[ch] += x * c[ch];
        }
    }
    let colour = [0, 1, 2].map(|ch| {
        if tau[ch].is_infinite() {
            // An infinite optical depth comes from the height fog: its colour.
            m.layers.first().map_or(0.0, |l| m.layer_colour(l, cos)[ch])
        } else if tau[ch] > 0.0 {
            num[ch] / tau[ch]
        } else {
            0.0
        }
    });
    (tau, colour)
}

/// Midpoint-rule ray marching with `n` samples for one ray: τ and the in-scattered
/// radiance Σ T(s_k) · Σ_media σ_t · colour · Δs (single scattering, the media's colours
/// as in the kernel's model). Returns τ and the effective colour L_in / (1 − T).
fn march_ray(m: &MediumF, o: Vec3, d: Vec3, t: f32, n: u32) -> ([f32; 3], [f32; 3]) {
    let l = d.length();
    let (d, t) = (d / l, t * l);
    let (s0, s1) = match m.march_sphere {
        Some(s) => match chord(s, o, d, t) {
            Some(c) => c,
            None => return ([0.0; 3], [0.0; 3]),
        },
        None => (0.0, t.min(FAR)),
    };
    let cos = m.cos_sun(d);
    let lc: Vec<[f32; 3]> = m.layers.iter().map(|l| m.layer_colour(l, cos)).collect();
    let vc: Vec<[f32; 3]> = m.vols.iter().map(|v| m.vol_colour(v, cos)).collect();
    let h = (s1 - s0) / n as f32;
    let mut tau = [0.0f32; 3];
    let mut lin = [0.0f32; 3];
    for k in 0..n {
        let x = o + d * (s0 + (k as f32 + 0.5) * h);
        let mut sig = [0.0f32; 3];
        let mut src = [0.0f32; 3];
        for (l, c) in m.layers.iter().zip(&lc) {
            let e = (-l.b * (x.y - l.h0)).exp();
            for ch in 0..3 {
                sig[ch] += l.bt[ch] * e;
                src[ch] += l.bt[ch] * e * c[ch];
            }
        }
        let cut = m.cuts.iter().any(|c| (x - c.c).length() < c.r);
        if !cut {
            for (v, c) in m.vols.iter().zip(&vc) {
                let f = profile_f32(v.profile, (x - v.s.c).length() / v.s.r);
                for ch in 0..3 {
                    sig[ch] += v.bt[ch] * f;
                    src[ch] += v.bt[ch] * f * c[ch];
                }
            }
        }
        for ch in 0..3 {
            let dt = sig[ch] * h;
            // The transmittance to the sample's midpoint.
            let tr = (-(tau[ch] + 0.5 * dt)).exp();
            lin[ch] += tr * src[ch] * h;
            tau[ch] += dt;
        }
    }
    let colour = [0, 1, 2].map(|ch| {
        let one_minus_t = 1.0 - (-tau[ch]).exp();
        if one_minus_t > 0.0 {
            lin[ch] / one_minus_t
        } else {
            0.0
        }
    });
    (tau, colour)
}

/// The reference τ, T, L_in and fog colour of one ray (height fog: `reference::sample`;
/// volumes: `reference::volume::volumes_sample`; colours mixed by τ as the kernel does).
pub fn reference_ray(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> [[f64; 3]; 4] {
    let h = rf::sample(desc, o, d, t);
    let (tv, cv) = if desc.volumes.is_empty() {
        ([0.0; 3], [0.0; 3])
    } else {
        rv::volumes_sample(desc, o, d, t)
    };
    let mut r = [[0.0; 3]; 4];
    for ch in 0..3 {
        let tau = tv[ch] + h.tau[ch];
        let colour = if h.tau[ch].is_infinite() {
            h.colour[ch]
        } else if tau > 0.0 {
            // As weights, so that τ near the f64 range does not overflow the products.
            let wv = tv[ch] / tau;
            wv * cv[ch] + (1.0 - wv) * h.colour[ch]
        } else {
            0.0
        };
        r[0][ch] = tau;
        r[1][ch] = (-tau).exp();
        r[2][ch] = colour * -(-tau).exp_m1();
        r[3][ch] = colour;
    }
    r
}

/// What a method needs to run a kernel: the compiled scene, its description and its f32
/// form.
pub struct Evaluators {
    /// The scene's description.
    pub desc: SceneDesc,
    /// The compiled scene (Accurate tier).
    pub accurate: Scene,
    /// Whether the kernel's ray sets have unit directions (declared to the batch API).
    pub unit: bool,
    /// The f32 form of the baselines.
    pub medium: MediumF,
}

impl Evaluators {
    /// All forms of `desc` (which must be a valid scene: the report's own are).
    pub fn new(desc: SceneDesc) -> Evaluators {
        let accurate = Scene::new(desc.clone()).expect("report scenes are valid");
        Evaluators {
            medium: MediumF::new(&desc),
            desc,
            accurate,
            unit: true,
        }
    }

    /// Runs `method` on `rays`, writing τ, T and L_in into `out` (one thread).
    pub fn apply(&self, method: Method, rays: RaysRef<'_>, out: &mut OutCols<'_>) {
        let n = rays.len();
        match method {
            Method::AccurateX8 | Method::FastX8 | Method::Scalar => {
                let r = Rays::new(
                    rays.o[0], rays.o[1], rays.o[2], rays.d[0], rays.d[1], rays.d[2], rays.t,
                )
                .expect("equal lengths")
                .with_unit_directions(self.unit);
                let [a, b, c, d, e, f, g, h, i] = out;
                let o = Outputs {
                    tau: Some([a, b, c]),
                    transmittance: Some([d, e, f]),
                    inscattering: Some([g, h, i]),
                };
                let res = match method {
                    Method::AccurateX8 => self.accurate.evaluate_tier(Tier::Accurate, &r, o),
                    Method::FastX8 => self.accurate.evaluate_tier(Tier::Fast, &r, o),
                    _ => self.accurate.evaluate_scalar(&r, o),
                };
                res.expect("equal lengths");
            }
            Method::Reference => {
                for i in 0..n {
                    let (o, d, t) = rays.get(i);
                    let r = reference_ray(
                        &self.desc,
                        Vec3::from_array(o).as_dvec3(),
                        Vec3::from_array(d).as_dvec3(),
                        t as f64,
                    );
                    for ch in 0..3 {
                        out[ch][i] = r[0][ch] as f32;
                        out[3 + ch][i] = r[1][ch] as f32;
                        out[6 + ch][i] = r[2][ch] as f32;
                    }
                }
            }
            Method::Seed => {
                for i in 0..n {
                    let (o, d, t) = rays.get(i);
                    let (tau, c) =
                        seed_ray(&self.medium, Vec3::from_array(o), Vec3::from_array(d), t);
                    write(out, i, tau, c);
                }
            }
            Method::March(steps) => {
                for i in 0..n {
                    let (o, d, t) = rays.get(i);
                    let (tau, c) = march_ray(
                        &self.medium,
                        Vec3::from_array(o),
                        Vec3::from_array(d),
                        t,
                        steps,
                    );
                    write(out, i, tau, c);
                }
            }
        }
    }

    /// [`Self::apply`] split over rayon's threads (chunks of 4096 rays for the crate's
    /// kernels, 256 for the others).
    pub fn apply_par(&self, method: Method, rays: RaysRef<'_>, out: OutCols<'_>) {
        let n = rays.len();
        // Cache-sized chunks for the fast methods; small ones for the slow per-ray ones
        // (so that their 4096-ray subsets are split over the threads too).
        let chunk = match method {
            Method::AccurateX8 | Method::FastX8 | Method::Scalar => 4096,
            _ => 256,
        };
        if n <= chunk {
            let mut out = out;
            self.apply(method, rays, &mut out);
            return;
        }
        let mid = (n / 2).next_multiple_of(8).min(n);
        let (ra, rb) = rays.split_at(mid);
        let mut a: Vec<&mut [f32]> = Vec::with_capacity(9);
        let mut b: Vec<&mut [f32]> = Vec::with_capacity(9);
        for col in out {
            let (x, y) = col.split_at_mut(mid);
            a.push(x);
            b.push(y);
        }
        let a: OutCols<'_> = a.try_into().expect("9 columns");
        let b: OutCols<'_> = b.try_into().expect("9 columns");
        rayon::join(
            || self.apply_par(method, ra, a),
            || self.apply_par(method, rb, b),
        );
    }
}
