//! Independent f64 reference for exponential height fog: plain f64 code written straight
//! from the seeds' formulas, a numerical quadrature of the integrals, and the error bound
//! the f32 kernels are checked against.
//!
//! Nothing here shares code or method with the f32 kernels (`medium::height_fog`): the
//! kernels anchor the exponential at the denser end of the segment and carry
//! mantissa/exponent pairs; this module anchors at the ray's origin, as seeds 000, 001 and
//! 003 do, and works with the logarithm of τ in f64, which neither overflows nor
//! underflows for any f32 input.
//!
//! # Closed form (seeds 000, 001 eq. 14, 003)
//! For one layer σ(x) = σ0 · exp(−b · (dot(x, up) − h0)), the segment x(s) = o + s·d,
//! s in [0, t], with y0 = dot(o, up) − h0, u = dot(d, up), Δ = b·u·t:
//!
//! ```text
//! τ = σ0 · |d| · ∫_0^t e^(−b (y0 + u s)) ds
//!   = σ0 · |d| · e^(−b·y0) · (1 − e^(−Δ)) / (b·u)          (seed 003's form)
//!   = σ0 · |d| · e^(−b·y0) · t · φ(Δ),    φ(Δ) = −expm1(−Δ) / Δ,  φ(0) = 1
//! ln τ = ln σ0 + ln |d| − b·y0 + ln t + ln φ(Δ)
//! ln φ(Δ) = max(−Δ, 0) + ln(−expm1(−|Δ|) / |Δ|)
//! ```
//!
//! The last line is φ for both signs of Δ without overflow: for Δ < 0,
//! φ(Δ) = (e^|Δ| − 1)/|Δ| = e^|Δ| · (1 − e^(−|Δ|))/|Δ|. t = +∞ is the limit:
//! t·φ(b·u·t) → 1/(b·u) for b·u > 0, and τ = +∞ for b·u ≤ 0 (unless σ0·|d| = 0).
//!
//! # In-scattering (seed 001 eq. 21)
//! L_in = C · (1 − T), with the fog colour of a layer
//! C = Σ_c β_s,c · (p_c(cos θ) · E_sun + L_amb) / Σ_c β_t,c, θ the angle between the ray
//! direction and the direction toward the sun. With several layers, C is the τ-weighted
//! mix Σ_i τ_i C_i / Σ_i τ_i (the documented approximation the kernels use; exact for
//! one layer). [`quad_inscattering`] integrates seed 001's eq. 15 itself.
//!
//! # Domain and accuracy
//! Every function takes a scene description that [`crate::Scene::new`] accepts and f64
//! rays (the tests pass f32 values, converted exactly). [`height_fog_ln_tau`] is defined
//! for every finite origin and direction and every t ≥ 0 including +∞; its absolute error
//! in ln τ is a few f64 ulps of |ln σ0| + |ln |d|| + |b·y0| + |ln t| + |Δ|, i.e. a relative
//! error of τ of about 10⁻¹⁵ · (κ + 100) with κ the condition of [`condition`]: some 10⁸
//! times below the f32 bound 16 · 2⁻²⁴ · κ that [`check_sample`] applies. [`sample`] adds
//! a few f64 ulps for T, the colour and L_in. The quadratures ([`quad_tau`],
//! [`quad_inscattering`]) agree with the closed forms to ~3e-15 on moderate cases
//! (`tests/height_fog.rs`).

mod check;
mod compose;
mod controls;
pub mod peer;
mod quad;
pub mod volume;

pub use check::{
    check_sample, condition, markdown_header, tau_interval, tau_tolerance, up_is_axis, up_rounding,
    SampleCheck, WorstErrors, EPS32, L_IN_TOLERANCE, T_FLUSH,
};
pub use compose::{
    composition_rays, composition_scenes, marched_sample, mixed_sample, ordered_sample,
};
pub use controls::{
    distance_fog_depth, distance_fog_depth_quad, lobe_weight, scene_sample, SceneSample,
};
pub use quad::{quad_inscattering, quad_tau, quad_tau_layers};

use crate::light::Phase;
use crate::scene::{HeightFogLayer, SceneDesc};
use glam::DVec3;

/// The scene's up vector normalized in f64 (without rounding it to f32, unlike the
/// compiled [`crate::Scene`]). Zero for a zero `up` (which `Scene::new` rejects).
pub fn up(desc: &SceneDesc) -> DVec3 {
    unit(desc.up.as_dvec3())
}

/// `v / |v|` in f64 for any finite `v` (scaled first, so huge and tiny vectors neither
/// overflow nor underflow); zero for zero.
pub fn unit(v: DVec3) -> DVec3 {
    let m = v.abs().max_element();
    if m == 0.0 || !m.is_finite() {
        return DVec3::ZERO;
    }
    let w = v / m;
    w / w.length()
}

/// `|v|` in f64 without overflow or underflow for f32 components (f64 has the range).
fn norm(v: DVec3) -> f64 {
    v.length()
}

/// ln φ(Δ) with φ(Δ) = (1 − e^(−Δ))/Δ = −expm1(−Δ)/Δ, φ(0) = 1, for any finite Δ.
///
/// Absolute error a few ulps of max(1, |Δ|).
pub fn ln_phi(delta: f64) -> f64 {
    if delta == 0.0 {
        return 0.0;
    }
    let x = delta.abs();
    // (1 − e^(−x))/x in (0, 1]: no cancellation (expm1), no overflow.
    let r = -(-x).exp_m1() / x;
    let grow = if delta < 0.0 { x } else { 0.0 };
    grow + r.ln()
}

/// Per-ray geometry of one layer, all in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LayerGeometry {
    /// b, the layer's falloff.
    pub b: f64,
    /// y0 = dot(o, up) − h0.
    pub y0: f64,
    /// u = dot(d, up).
    pub u: f64,
    /// |d|.
    pub norm: f64,
    /// t.
    pub t: f64,
}

impl LayerGeometry {
    /// The geometry of `layer` for the ray `origin + s·dir`, s in [0, t].
    pub fn new(layer: &HeightFogLayer, up: DVec3, origin: DVec3, dir: DVec3, t: f64) -> Self {
        LayerGeometry {
            b: layer.falloff as f64,
            y0: origin.dot(up) - layer.base_height as f64,
            u: dir.dot(up),
            norm: norm(dir),
            t,
        }
    }

    /// Δ = b·u·t (+∞ or −∞ for t = +∞ and b·u ≠ 0; 0 for b·u = 0).
    pub fn delta(&self) -> f64 {
        let bu = self.b * self.u;
        if bu == 0.0 {
            0.0
        } else {
            bu * self.t
        }
    }

    /// The geometry with y0 and u moved by `dy` and `du` toward a larger τ (`s` = +1:
    /// b·y0 and b·u decrease) or a smaller one (`s` = −1). τ is monotonic in both, so
    /// the two extremes bound τ over the whole box of perturbations.
    pub fn perturbed(&self, dy: f64, du: f64, s: f64) -> Self {
        let sb = if self.b < 0.0 { -1.0 } else { 1.0 };
        LayerGeometry {
            y0: self.y0 - s * sb * dy,
            u: self.u - s * sb * du,
            ..*self
        }
    }

    /// ln(τ/σ0) = ln(|d| · ∫_0^t e^(−b (y0 + u s)) ds): −∞ where the integral is 0
    /// (t = 0 or d = 0), +∞ where it diverges (t = +∞ and b·u ≤ 0).
    pub fn ln_geometric(&self) -> f64 {
        if self.norm == 0.0 || self.t == 0.0 {
            return f64::NEG_INFINITY;
        }
        let bu = self.b * self.u;
        let ln_len = if self.t.is_infinite() {
            if bu > 0.0 {
                // lim t·φ(b·u·t) = 1/(b·u)
                -bu.ln()
            } else {
                return f64::INFINITY;
            }
        } else {
            self.t.ln() + ln_phi(bu * self.t)
        };
        self.norm.ln() - self.b * self.y0 + ln_len
    }
}

/// The extinction Σ_c (β_s,c + β_a,c) of a layer per channel, in f64 (not rounded to f32).
pub fn extinction(layer: &HeightFogLayer) -> [f64; 3] {
    let mut s = [0.0f64; 3];
    for c in &layer.components {
        for ch in 0..3 {
            s[ch] += c.scattering[ch] as f64 + c.absorption[ch] as f64;
        }
    }
    s
}

/// ln τ of one layer per channel (−∞ for τ = 0, +∞ for τ = +∞).
pub fn layer_ln_tau(
    layer: &HeightFogLayer,
    up: DVec3,
    origin: DVec3,
    dir: DVec3,
    t: f64,
) -> [f64; 3] {
    layer_ln_tau_geom(layer, &LayerGeometry::new(layer, up, origin, dir, t))
}

/// ln τ of one layer per channel for a given geometry.
pub fn layer_ln_tau_geom(layer: &HeightFogLayer, g: &LayerGeometry) -> [f64; 3] {
    let lg = g.ln_geometric();
    extinction(layer).map(|s| {
        if s == 0.0 {
            f64::NEG_INFINITY
        } else {
            s.ln() + lg
        }
    })
}

/// ln(Σ_i e^(l_i)) without overflow; −∞ for no terms or all −∞, +∞ if any is +∞.
pub fn ln_sum_exp(ls: impl Iterator<Item = f64> + Clone) -> f64 {
    let m = ls.clone().fold(f64::NEG_INFINITY, f64::max);
    if !m.is_finite() {
        return m;
    }
    m + ls.map(|l| (l - m).exp()).sum::<f64>().ln()
}

/// ln τ per channel for the whole scene (the layers' optical depths add): −∞ for τ = 0,
/// +∞ for τ = +∞. Defined for every finite origin and direction and t in [0, +∞].
pub fn height_fog_ln_tau(desc: &SceneDesc, origin: DVec3, dir: DVec3, t: f64) -> [f64; 3] {
    let up = up(desc);
    let per: Vec<[f64; 3]> = desc
        .height_fog
        .iter()
        .map(|l| layer_ln_tau(l, up, origin, dir, t))
        .collect();
    [0, 1, 2].map(|ch| ln_sum_exp(per.iter().map(|l| l[ch])))
}

/// τ per channel for the whole scene, in f64 (which overflows to +∞ beyond 1.8e308 and
/// underflows to 0 below 5e-324; use [`height_fog_ln_tau`] to compare beyond that).
pub fn height_fog_tau(desc: &SceneDesc, origin: DVec3, dir: DVec3, t: f64) -> [f64; 3] {
    height_fog_ln_tau(desc, origin, dir, t).map(f64::exp)
}

/// cos θ between the ray direction and the direction toward the sun (0 if either is 0).
pub fn cos_sun(desc: &SceneDesc, dir: DVec3) -> f64 {
    match &desc.lighting.sun {
        Some(s) => unit(dir).dot(unit(s.direction.as_dvec3())).clamp(-1.0, 1.0),
        None => 0.0,
    }
}

/// The fog colour of one layer per channel (seed 001 eq. 21):
/// Σ_c β_s,c · (p_c(cos θ) · E_sun + L_amb) / Σ_c β_t,c (0 where Σ_c β_t,c = 0), plus the
/// layer's emission.
pub fn layer_colour(desc: &SceneDesc, layer: &HeightFogLayer, cos_theta: f64) -> [f64; 3] {
    let amb = desc.lighting.ambient.as_dvec3();
    let esun = desc
        .lighting
        .sun
        .as_ref()
        .map_or(DVec3::ZERO, |s| s.radiance.as_dvec3());
    let bt = extinction(layer);
    let mut num = [0.0f64; 3];
    for c in &layer.components {
        let p = c.phase.eval_f64(cos_theta);
        for ch in 0..3 {
            num[ch] += c.scattering[ch] as f64 * (p * esun[ch] + amb[ch]);
        }
    }
    // Emission is a radiance per unit extinction: it adds to the colour as is.
    [0, 1, 2].map(|ch| {
        let e = layer.emission[ch] as f64;
        if bt[ch] > 0.0 {
            num[ch] / bt[ch] + e
        } else {
            e
        }
    })
}

/// The reference result for one ray.
#[derive(Clone, Debug, PartialEq)]
pub struct RefSample {
    /// ln τ per channel (−∞ for τ = 0, +∞ for τ = +∞): compare huge and tiny τ here.
    pub ln_tau: [f64; 3],
    /// τ = e^(ln τ) in f64.
    pub tau: [f64; 3],
    /// T = e^(−τ).
    pub transmittance: [f64; 3],
    /// The fog colour C (the τ-weighted mix of the layers' colours).
    pub colour: [f64; 3],
    /// L_in = C · (1 − T).
    pub inscattering: [f64; 3],
    /// The layers' colours, per layer (for bounds on the mix).
    pub layer_colours: [Vec<f64>; 3],
}

/// The weights of the τ-weighted colour mix of one channel, normalized to sum to 1, as the
/// f64 limit where τ overflows: layers with finite τ weigh τ_i; where some τ_i = +∞
/// (t = +∞, b_i·u ≤ 0), only the layers that grow fastest count (largest −b_i·u: e^(g t)
/// beats t), weighted by σ0_i · e^(−b_i·y0_i) (the factors left in the limit ratio).
fn mix_weights(
    desc: &SceneDesc,
    up: DVec3,
    origin: DVec3,
    dir: DVec3,
    t: f64,
    ln_tau: &[f64],
    ch: usize,
) -> Vec<f64> {
    let layers = &desc.height_fog;
    let any_inf = ln_tau.contains(&f64::INFINITY);
    // (key, log-weight) per layer; only the layers with the largest key count.
    let keyed: Vec<(f64, f64)> = layers
        .iter()
        .zip(ln_tau)
        .map(|(layer, &l)| {
            if !any_inf {
                (0.0, l)
            } else if l == f64::INFINITY {
                let g = LayerGeometry::new(layer, up, origin, dir, t);
                let growth = -g.b * g.u; // ≥ 0 here
                let ln_sigma = extinction(layer)[ch].ln();
                let lw = ln_sigma - g.b * g.y0 - if growth > 0.0 { growth.ln() } else { 0.0 };
                (growth, lw)
            } else {
                (f64::NEG_INFINITY, f64::NEG_INFINITY)
            }
        })
        .collect();
    let kmax = keyed.iter().map(|k| k.0).fold(f64::NEG_INFINITY, f64::max);
    let lws: Vec<f64> = keyed
        .iter()
        .map(|&(k, lw)| if k == kmax { lw } else { f64::NEG_INFINITY })
        .collect();
    let m = lws.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        // τ = 0 in every layer: any weights will do (1 − T = 0); use equal ones.
        return vec![1.0 / layers.len().max(1) as f64; layers.len()];
    }
    let w: Vec<f64> = lws.iter().map(|&l| (l - m).exp()).collect();
    let s: f64 = w.iter().sum();
    w.into_iter().map(|x| x / s).collect()
}

/// The reference τ, T, fog colour and L_in for one ray (seed 001 eq. 21; several layers:
/// τ adds and the colour is the τ-weighted mix of the layers' colours). Defined for every
/// finite origin and direction and t in [0, +∞].
///
/// Accuracy: τ as [`height_fog_ln_tau`]; T, C and L_in to a few f64 ulps relative beyond
/// that (phase functions in f64, `Phase::eval_f64`).
pub fn sample(desc: &SceneDesc, origin: DVec3, dir: DVec3, t: f64) -> RefSample {
    let up = up(desc);
    let cos = cos_sun(desc, dir);
    let per: Vec<[f64; 3]> = desc
        .height_fog
        .iter()
        .map(|l| layer_ln_tau(l, up, origin, dir, t))
        .collect();
    let colours: Vec<[f64; 3]> = desc
        .height_fog
        .iter()
        .map(|l| layer_colour(desc, l, cos))
        .collect();
    let mut out = RefSample {
        ln_tau: [f64::NEG_INFINITY; 3],
        tau: [0.0; 3],
        transmittance: [1.0; 3],
        colour: [0.0; 3],
        inscattering: [0.0; 3],
        layer_colours: [
            colours.iter().map(|c| c[0]).collect(),
            colours.iter().map(|c| c[1]).collect(),
            colours.iter().map(|c| c[2]).collect(),
        ],
    };
    for ch in 0..3 {
        let ls: Vec<f64> = per.iter().map(|l| l[ch]).collect();
        let ln_tau = ln_sum_exp(ls.iter().copied());
        let tau = ln_tau.exp();
        let w = mix_weights(desc, up, origin, dir, t, &ls, ch);
        let colour: f64 = w.iter().zip(&colours).map(|(w, c)| w * c[ch]).sum();
        out.ln_tau[ch] = ln_tau;
        out.tau[ch] = tau;
        out.transmittance[ch] = (-tau).exp();
        out.colour[ch] = colour;
        // 1 − T without cancellation for small τ.
        out.inscattering[ch] = colour * -(-tau).exp_m1();
    }
    out
}

/// The phase function of seed 001 for unit vectors `view` and `to_sun` (f64).
pub fn phase(p: Phase, view: DVec3, to_sun: DVec3) -> f64 {
    p.eval_f64(unit(view).dot(unit(to_sun)).clamp(-1.0, 1.0))
}
