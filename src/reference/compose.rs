//! The composition of in-scattering along a ray (`Composition`), in f64: the ordered
//! model the kernels compute, and a ray-marched single-scattering reference that both
//! compositions are measured against.
//!
//! Scope: height fog layers, fog volumes (with cut-outs), lighting and the directional
//! lobe; rays `o + s·d`, s in [0, t] with t finite. Distance fog and the start/cutoff
//! distances and maximum opacity are not modelled here (the functions return NaN for a
//! scene that has them), nor is t = +∞ by the march.
//!
//! Both use the per-medium fog colours of the kernels' lighting model (a height fog layer's
//! colour of seed 001 eq. 21 plus the lobe; a volume's
//! `albedo · (L_amb + E_sun · p · T_sun) + emission` with its self-shadowing taken at the
//! centre): the march integrates
//! `L_in = ∫ T(0, s) · Σ_m σ_m(s) · c_m ds` with the exact order of the media along the ray,
//! so what it measures is the error of the composition alone.

use super::volume::{
    affine, depth_aff, inside_world, integrand_at_world, line_interval_of, volume_colour,
};
use super::{cos_sun, extinction, height_fog_tau, layer_colour, lobe_weight, sample, up};
use crate::scene::SceneDesc;
use glam::DVec3;

fn has_unmodelled(desc: &SceneDesc) -> bool {
    let l = &desc.limits;
    desc.distance_fog.is_some()
        || l.start_distance > 0.0
        || l.cutoff_distance.is_some()
        || l.max_opacity < 1.0
}

/// The colour of the height fog per unit extinction along this ray (the τ-weighted mix of
/// the layers' colours, plus the lobe), as the kernels form it; the lobe alone if there is
/// no layer.
fn height_colour(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> [f64; 3] {
    let lobe = match &desc.lobe {
        Some(l) => (l.colour.as_dvec3() * lobe_weight(desc, d)).to_array(),
        None => [0.0; 3],
    };
    let c = if desc.height_fog.is_empty() {
        [0.0; 3]
    } else {
        sample(desc, o, d, t).colour
    };
    [0, 1, 2].map(|ch| c[ch] + lobe[ch])
}

/// One additive volume on the ray: the parameter s (along d) where the ray enters its
/// clipped segment (cut-outs ignored), its optical depth per channel (cut-outs applied)
/// and its colour.
struct OnRay {
    s: f64,
    tau: [f64; 3],
    colour: [f64; 3],
}

fn volumes_on_ray(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> Vec<OnRay> {
    let cuts: Vec<_> = desc
        .volumes
        .iter()
        .filter(|v| v.subtractive)
        .filter_map(|v| affine(&v.shape).map(|a| a.0))
        .collect();
    let mut out = Vec::new();
    for v in desc.volumes.iter().filter(|v| !v.subtractive) {
        let Some(a) = affine(&v.shape) else {
            continue;
        };
        let g = depth_aff(&a.0, v.profile, &cuts, o, d, t);
        let s = line_interval_of(&a, o, d).map_or(0.0, |(s0, _)| s0.clamp(0.0, t));
        let tau = [0, 1, 2].map(|ch| {
            let bt = (v.scattering[ch] as f64 + v.absorption[ch] as f64) as f32 as f64;
            bt * g
        });
        out.push(OnRay {
            s,
            tau,
            colour: volume_colour(v, &desc.lighting, d),
        });
    }
    out
}

/// `Composition::Ordered` in f64 for one ray: `c_h · (1 − T) + Σ_k (c_k − c_h) · (1 − T_k)
/// · T(0 → s_k)`, with `c_h` the height fog's colour (layers' mix plus lobe), `T` the
/// whole ray's transmittance, and `T(0 → s_k)` that of the height fog and of the volumes
/// entered before volume k (ties: the earlier volume in the scene first). Returns
/// (T, L_in) per channel.
pub fn ordered_sample(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> ([f64; 3], [f64; 3]) {
    if has_unmodelled(desc) {
        return ([f64::NAN; 3], [f64::NAN; 3]);
    }
    let c_h = height_colour(desc, o, d, t);
    let tau_h = if desc.height_fog.is_empty() {
        [0.0; 3]
    } else {
        height_fog_tau(desc, o, d, t)
    };
    let vols = volumes_on_ray(desc, o, d, t);
    let mut tau = tau_h;
    for v in &vols {
        for ch in 0..3 {
            tau[ch] += v.tau[ch];
        }
    }
    let trans = tau.map(|x| (-x).exp());
    let mut l = [0, 1, 2].map(|ch| c_h[ch] * -(-tau[ch]).exp_m1());
    for (k, vk) in vols.iter().enumerate() {
        let mut front = if desc.height_fog.is_empty() {
            [0.0; 3]
        } else {
            height_fog_tau(desc, o, d, vk.s)
        };
        for (j, vj) in vols.iter().enumerate() {
            let before = vj.s < vk.s || (vj.s == vk.s && j < k);
            if before {
                for ch in 0..3 {
                    front[ch] += vj.tau[ch];
                }
            }
        }
        for ch in 0..3 {
            l[ch] += (vk.colour[ch] - c_h[ch]) * -(-vk.tau[ch]).exp_m1() * (-front[ch]).exp();
        }
    }
    (trans, l)
}

/// Single scattering along the ray, marched: `L_in = ∫_0^t T(0, s) · Σ_m σ_m(s) · c_m ·
/// |d| ds` over the height fog layers (colour: the layer's, plus the lobe) and the volumes
/// (colour: [`volume_colour`]; density zero inside cut-outs). The segment is split where
/// the ray enters or leaves a volume or a cut-out, and each piece is integrated by the
/// midpoint rule with `steps` points, with T(0, s) in closed form at every point (the
/// reference closed forms: [`height_fog_tau`], the volumes' depths). Returns (T, L_in)
/// per channel. The midpoint rule's error falls as steps⁻² (`tests/composition.rs`
/// checks 2× the steps changes the result by less than the bound it uses).
pub fn marched_sample(
    desc: &SceneDesc,
    o: DVec3,
    d: DVec3,
    t: f64,
    steps: usize,
) -> ([f64; 3], [f64; 3]) {
    if has_unmodelled(desc) || !t.is_finite() {
        return ([f64::NAN; 3], [f64::NAN; 3]);
    }
    let dl = d.length();
    let up = up(desc);
    let cos = cos_sun(desc, d);
    let lobe = match &desc.lobe {
        Some(l) => (l.colour.as_dvec3() * lobe_weight(desc, d)).to_array(),
        None => [0.0; 3],
    };
    let layers: Vec<([f64; 3], [f64; 3])> = desc
        .height_fog
        .iter()
        .map(|l| {
            let c = layer_colour(desc, l, cos);
            (extinction(l), [0, 1, 2].map(|ch| c[ch] + lobe[ch]))
        })
        .collect();
    struct Vol {
        aff: super::volume::AffineRef,
        profile: crate::Profile,
        sigma: [f64; 3],
        colour: [f64; 3],
    }
    let mut cuts = Vec::new();
    let mut vols = Vec::new();
    for v in &desc.volumes {
        let Some(a) = affine(&v.shape) else {
            return ([f64::NAN; 3], [f64::NAN; 3]);
        };
        if v.subtractive {
            cuts.push(a);
        } else {
            vols.push(Vol {
                aff: a,
                profile: v.profile,
                sigma: [0, 1, 2]
                    .map(|ch| (v.scattering[ch] as f64 + v.absorption[ch] as f64) as f32 as f64),
                colour: volume_colour(v, &desc.lighting, d),
            });
        }
    }
    let cut_affs: Vec<_> = cuts.iter().map(|a| a.0).collect();
    // Break points: every boundary crossing inside [0, t].
    let mut br = vec![0.0, t];
    for a in vols.iter().map(|v| &v.aff).chain(cuts.iter()) {
        if let Some((s0, s1)) = line_interval_of(a, o, d) {
            br.extend([s0, s1].into_iter().filter(|s| *s > 0.0 && *s < t));
        }
    }
    br.sort_by(f64::total_cmp);
    br.dedup();
    let tau_to = |s: f64| -> [f64; 3] {
        let mut tau = if desc.height_fog.is_empty() {
            [0.0; 3]
        } else {
            height_fog_tau(desc, o, d, s)
        };
        for v in &vols {
            let g = depth_aff(&v.aff.0, v.profile, &cut_affs, o, d, s);
            for ch in 0..3 {
                tau[ch] += v.sigma[ch] * g;
            }
        }
        tau
    };
    let mut l = [0.0; 3];
    for w in br.windows(2) {
        let (a, b) = (w[0], w[1]);
        let h = (b - a) / steps as f64;
        for i in 0..steps {
            let s = a + (i as f64 + 0.5) * h;
            let x = o + s * d;
            let tr = tau_to(s).map(|x| (-x).exp());
            let mut src = [0.0; 3];
            for (layer, (sigma, c)) in desc.height_fog.iter().zip(&layers) {
                let dens = (-(layer.falloff as f64) * (x.dot(up) - layer.base_height as f64)).exp();
                for ch in 0..3 {
                    src[ch] += sigma[ch] * dens * c[ch];
                }
            }
            let in_cut = cuts.iter().any(|c| inside_world(c, x));
            if !in_cut {
                for v in &vols {
                    let f = integrand_at_world(&v.aff, v.profile, x);
                    for ch in 0..3 {
                        src[ch] += v.sigma[ch] * f * v.colour[ch];
                    }
                }
            }
            for ch in 0..3 {
                l[ch] += tr[ch] * src[ch] * dl * h;
            }
        }
    }
    (tau_to(t).map(|x| (-x).exp()), l)
}

/// `Composition::Mix` in f64 for one ray (the τ-weighted mix of every medium's colour,
/// times 1 − T), with the same per-medium colours as [`ordered_sample`]. Returns (T, L_in).
pub fn mixed_sample(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> ([f64; 3], [f64; 3]) {
    if has_unmodelled(desc) {
        return ([f64::NAN; 3], [f64::NAN; 3]);
    }
    let s = super::scene_sample(desc, o, d, t);
    (s.transmittance, s.inscattering)
}

/// The two scenes on which the compositions are measured (README, "Composition of
/// in-scattering"; `tests/composition.rs`, `benches/composition.rs`), with
/// `Composition::Mix`: `"behind"`, a bright emissive sphere behind a dark absorbing one on
/// the view axis (order matters), and `"side_by_side"`, the same two spheres beside each
/// other (no ray crosses both; only the order between them and the thin height fog
/// remains). Both in a thin grey height fog lit by ambient light and a sun.
pub fn composition_scenes() -> [(&'static str, SceneDesc); 2] {
    use crate::{Component, HeightFogLayer, Lighting, Phase, Profile, Shape, Sun, Volume};
    use glam::Vec3;
    let scene = |dark: Vec3, bright: Vec3| SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: 0.2,
            components: vec![Component {
                scattering: Vec3::splat(0.01),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
            }],
            emission: Vec3::ZERO,
        }],
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.55, 0.6),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.8, -0.5),
                radiance: Vec3::new(3.0, 2.8, 2.5),
            }),
        },
        volumes: vec![
            Volume {
                absorption: Vec3::splat(0.45),
                ..Volume::new(
                    Shape::Sphere {
                        center: dark,
                        radius: 3.0,
                    },
                    Profile::Constant,
                    Vec3::splat(0.05),
                )
            },
            Volume {
                emission: Vec3::new(4.0, 3.0, 1.5),
                phase: Phase::HenyeyGreenstein(0.6),
                ..Volume::new(
                    Shape::Sphere {
                        center: bright,
                        radius: 3.0,
                    },
                    Profile::Quadratic,
                    Vec3::splat(0.4),
                )
            },
        ],
        ..SceneDesc::default()
    };
    [
        (
            "behind",
            scene(Vec3::new(0.0, 1.0, 12.0), Vec3::new(0.0, 1.0, 20.0)),
        ),
        (
            "side_by_side",
            scene(Vec3::new(-4.0, 1.0, 16.0), Vec3::new(4.0, 1.0, 16.0)),
        ),
    ]
}

/// The rays of the composition measurement: a `side` × `side` pinhole view from
/// (0, 1, 0) toward +Z, ±0.45 rad horizontally and ±0.25 rad vertically, unit directions,
/// each ending on a wall 40 units away (t = 40 / d_z). As (origin, direction, t).
pub fn composition_rays(side: usize) -> Vec<(DVec3, DVec3, f64)> {
    let mut out = Vec::with_capacity(side * side);
    for j in 0..side {
        for i in 0..side {
            let x = -0.45 + 0.9 * (i as f64 + 0.5) / side as f64;
            let y = -0.25 + 0.5 * (j as f64 + 0.5) / side as f64;
            let d = DVec3::new(x.tan(), y.tan(), 1.0).normalize();
            // f32 values, so that the f32 kernels see exactly these rays.
            let d = d.as_vec3().as_dvec3();
            out.push((DVec3::new(0.0, 1.0, 0.0), d, (40.0 / d.z) as f32 as f64));
        }
    }
    out
}
