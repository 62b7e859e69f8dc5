//! The scene-level reference in f64: height fog and volumes over the interval that the
//! start and cutoff distances leave, distance fog, the directional lobe and the maximum
//! opacity, written from their definitions (the docs of [`crate::FogLimits`],
//! [`crate::Falloff`] and [`crate::Lobe`]), plus a quadrature of the distance fog's
//! density for an independent check of its closed forms.

use super::{cos_sun, sample, unit, volume::gauss_kronrod, volume::volumes_sample};
use crate::medium::distance::{DistanceFog, Falloff};
use crate::scene::SceneDesc;
use glam::DVec3;

/// The reference result of a whole scene for one ray.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSample {
    /// Optical depth per channel.
    pub tau: [f64; 3],
    /// Transmittance e^(−τ) per channel.
    pub transmittance: [f64; 3],
    /// In-scattered radiance per channel.
    pub inscattering: [f64; 3],
    /// The largest fog colour that enters the ray's in-scattering (layers, volumes,
    /// distance fog, lobe): the scale of the L_in tolerance.
    pub colour_scale: f64,
}

/// max(cos θ, 0)^exponent of the scene's lobe for view direction `dir` (0 without lobe).
pub fn lobe_weight(desc: &SceneDesc, dir: DVec3) -> f64 {
    match (&desc.lobe, &desc.lighting.sun) {
        (Some(l), Some(_)) => cos_sun(desc, dir).max(0.0).powf(l.exponent as f64),
        _ => 0.0,
    }
}

/// Bevy's fog factor of linear fog at distance `s`: clamp((end − s)/(end − start), 0, 1).
fn linear_factor(start: f64, end: f64, s: f64) -> f64 {
    ((end - s) / (end - start)).clamp(0.0, 1.0)
}

/// The distance fog's optical depth and transmittance per channel over the interval that
/// starts `s_a` from the camera and is `len` long (`len` may be +∞).
pub fn distance_fog_depth(fog: &DistanceFog, s_a: f64, len: f64) -> ([f64; 3], [f64; 3]) {
    let s_b = s_a + len;
    let tau: [f64; 3] = match fog.falloff {
        Falloff::Linear { start, end } => {
            let (start, end) = (start as f64, end as f64);
            let fa = linear_factor(start, end, s_a);
            let fb = linear_factor(start, end, s_b);
            let t = if fa > 0.0 {
                fb / fa
            } else if len > 0.0 {
                0.0
            } else {
                1.0
            };
            return ([-t.ln(); 3], [t; 3]);
        }
        Falloff::Exponential { density } => [density as f64 * len; 3],
        Falloff::ExponentialSquared { density } => {
            let k = density as f64;
            // (k·s_b)² − (k·s_a)²; len = 0 gives 0 even with s_a = +∞.
            let v = if len == 0.0 {
                0.0
            } else {
                k * k * len * (len + 2.0 * s_a)
            };
            [v; 3]
        }
        Falloff::Atmospheric { extinction, .. } => [0, 1, 2].map(|c| {
            if len == 0.0 {
                0.0
            } else {
                extinction[c] as f64 * len
            }
        }),
    };
    (tau, tau.map(|x| (-x).exp()))
}

/// The distance fog's optical depth by adaptive Gauss–Kronrod quadrature of its density
/// σ(s) = dF/ds (exponential k, squared 2k²s, atmospheric β_ext, linear 1/(end − s) on
/// [start, end)), for finite intervals; linear fog must end before `end`.
pub fn distance_fog_depth_quad(fog: &DistanceFog, s_a: f64, len: f64) -> [f64; 3] {
    let s_b = s_a + len;
    if len == 0.0 {
        return [0.0; 3];
    }
    match fog.falloff {
        Falloff::Linear { start, end } => {
            let (start, end) = (start as f64, end as f64);
            let a = s_a.max(start);
            if s_b <= a {
                return [0.0; 3];
            }
            assert!(s_b < end, "the quadrature needs s_b < end");
            [gauss_kronrod(&|s| 1.0 / (end - s), a, s_b); 3]
        }
        Falloff::Exponential { density } => [gauss_kronrod(&|_| density as f64, s_a, s_b); 3],
        Falloff::ExponentialSquared { density } => {
            let k = density as f64;
            [gauss_kronrod(&|s| 2.0 * k * k * s, s_a, s_b); 3]
        }
        Falloff::Atmospheric { extinction, .. } => {
            [0, 1, 2].map(|c| gauss_kronrod(&|_| extinction[c] as f64, s_a, s_b))
        }
    }
}

/// Weight of `b` in the τ-weighted mix of two media, weights capped at 1e30 (the
/// kernel's definition for infinite depths: two of them weigh the same).
fn weight(tau_a: f64, tau_b: f64) -> f64 {
    let (a, b) = (tau_a.min(1e30), tau_b.min(1e30));
    if a + b > 0.0 {
        b / (a + b)
    } else {
        0.0
    }
}

/// The whole scene for one ray (`origin + s·dir`, s in [0, t]), in f64: the interval,
/// the media's optical depths added, the fog colour as the τ-weighted mix (height fog
/// layers with the lobe, volumes, distance fog with the lobe), atmospheric fog's
/// in-scattering share, and the maximum opacity.
pub fn scene_sample(desc: &SceneDesc, origin: DVec3, dir: DVec3, t: f64) -> SceneSample {
    let dn = dir.length();
    let dhat = unit(dir);
    let dist = if t == 0.0 || dn == 0.0 { 0.0 } else { t * dn };
    let lim = &desc.limits;
    let start = lim.start_distance as f64;
    let cutoff = lim.cutoff_distance.map_or(f64::INFINITY, |c| c as f64);
    let interval = start > 0.0 || cutoff < f64::INFINITY;
    let (o2, d2, t2, s_a, len) = if interval {
        let len = (dist.min(cutoff) - start).max(0.0);
        (origin + dhat * start, dhat, len, start, len)
    } else {
        (origin, dir, t, 0.0, dist)
    };

    let lobe = match &desc.lobe {
        Some(l) => (l.colour.as_dvec3() * lobe_weight(desc, dir)).to_array(),
        None => [0.0; 3],
    };
    let mut scale: f64 = 0.0;
    let (tau_h, mut c_h) = if desc.height_fog.is_empty() {
        ([0.0; 3], [0.0; 3])
    } else {
        let s = sample(desc, o2, d2, t2);
        for ch in 0..3 {
            for c in &s.layer_colours[ch] {
                scale = scale.max(*c);
            }
        }
        (s.tau, s.colour)
    };
    for ch in 0..3 {
        c_h[ch] += lobe[ch];
        scale = scale.max(lobe[ch] + c_h[ch]);
    }
    let (tau_v, c_v) = if desc.volumes.iter().any(|v| !v.subtractive) {
        volumes_sample(desc, o2, d2, t2)
    } else {
        ([0.0; 3], [0.0; 3])
    };
    let mut tau_hv = [0.0; 3];
    let mut c_hv = [0.0; 3];
    for ch in 0..3 {
        scale = scale.max(c_v[ch]);
        tau_hv[ch] = tau_h[ch] + tau_v[ch];
        let w = weight(tau_h[ch], tau_v[ch]);
        c_hv[ch] = c_h[ch] + w * (c_v[ch] - c_h[ch]);
    }

    let mut out = SceneSample {
        tau: tau_hv,
        transmittance: tau_hv.map(|x| (-x).exp()),
        inscattering: [0, 1, 2].map(|ch| c_hv[ch] * -(-tau_hv[ch]).exp_m1()),
        colour_scale: 0.0,
    };
    if let Some(fog) = &desc.distance_fog {
        let (tau_d, t_d) = distance_fog_depth(fog, s_a, len);
        for ch in 0..3 {
            let c_d = fog.colour[ch] as f64 + lobe[ch];
            scale = scale.max(c_d);
            let tau = tau_hv[ch] + tau_d[ch];
            let trans = (-tau_hv[ch]).exp() * t_d[ch];
            let one_m_t = match fog.falloff {
                Falloff::Linear { .. } => 1.0 - trans,
                _ => -(-tau).exp_m1(),
            };
            let w_d = weight(tau_hv[ch], tau_d[ch]);
            let l = match fog.falloff {
                Falloff::Atmospheric { inscattering, .. } => {
                    let x = if len == 0.0 {
                        0.0
                    } else {
                        inscattering[ch] as f64 * len
                    };
                    let gain = -(-x).exp_m1();
                    let td = tau_d[ch];
                    // W = (τ_d/τ)·(1 − T)/(1 − T_d) and its limits.
                    let w = if td == 0.0 {
                        if tau > 0.0 {
                            one_m_t / tau
                        } else {
                            1.0
                        }
                    } else if td == f64::INFINITY || tau == f64::INFINITY {
                        w_d * one_m_t / -(-td).exp_m1()
                    } else {
                        (td / tau) * one_m_t / -(-td).exp_m1()
                    };
                    c_hv[ch] * (1.0 - w_d) * one_m_t + c_d * gain * w
                }
                _ => (c_hv[ch] + w_d * (c_d - c_hv[ch])) * one_m_t,
            };
            out.tau[ch] = tau;
            out.transmittance[ch] = trans;
            out.inscattering[ch] = l;
        }
    }
    if lim.max_opacity < 1.0 {
        let floor = 1.0 - lim.max_opacity as f64;
        for ch in 0..3 {
            let t = out.transmittance[ch];
            if t < floor {
                out.inscattering[ch] *= (1.0 - floor) / (1.0 - t);
                out.transmittance[ch] = floor;
            }
            out.tau[ch] = out.tau[ch].min(-floor.ln());
        }
    }
    out.colour_scale = scale;
    out
}
