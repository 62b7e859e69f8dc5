//! Scene description (plain data, serde), validation, and the compiled [`Scene`].
//!
//! A [`SceneDesc`] is what a user writes (in Rust or JSON). [`Scene::new`] validates it,
//! naming the offending field, and compiles the per-scene constants the kernels use
//! (normalized vectors, the frexp split of every coefficient, the fog colour terms), so
//! that nothing that is constant per scene is recomputed per ray. A `Scene` cannot be
//! changed after it is built, so a valid scene stays valid.

use crate::error::SceneError;
use crate::light::{Lobe, LobePlan, Phase};
use crate::medium::distance::{DistanceFog, DistanceFogPlan};
use glam::Vec3;

/// One scattering component of a height fog layer (seed 001's Rayleigh or Mie part):
/// coefficients at the layer's base height, per RGB channel, in 1/length.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Component {
    /// Scattering coefficient β_s at the base height (RGB; JSON: a number or `[r, g, b]`).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
    pub scattering: Vec3,
    /// Absorption coefficient β_a at the base height (default 0).
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub absorption: Vec3,
    /// Phase function of the scattering (default isotropic).
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase: Phase,
}

/// An exponential height fog layer: σ(x) = Σ_c (β_s,c + β_a,c) · exp(−b · (dot(x, up) − h0)).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct HeightFogLayer {
    /// h0: the height at which the coefficients apply.
    pub base_height: f32,
    /// b = 1 / scale height. Any finite value: 0 is homogeneous fog, negative means the
    /// density grows with height.
    pub falloff: f32,
    /// The scattering components (at least one).
    pub components: Vec<Component>,
    /// Emitted radiance per unit extinction (RGB, default 0; Godot's FogMaterial
    /// emission, Unreal's emissive fog): added to the layer's fog colour, so an optically
    /// thick layer glows with this radiance and the layer adds `emission · (1 − T)`.
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub emission: Vec3,
}

/// The sun: a directional light.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Sun {
    /// Direction toward the sun (need not be unit length; must not be zero).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
    pub direction: Vec3,
    /// E_sun of seed 001 (RGB).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
    pub radiance: Vec3,
}

/// Light reaching the fog: ambient (isotropic) and an optional sun.
#[derive(Clone, Debug, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Lighting {
    /// L_amb of seed 001 (RGB, default 0).
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub ambient: Vec3,
    /// The sun, if any. A scene without sun evaluates no phase function.
    #[cfg_attr(feature = "serde", serde(default))]
    pub sun: Option<Sun>,
}

/// A scene as written by a user: the JSON model of `analytic-fog eval --scene`.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct SceneDesc {
    /// The up vector (default +Y); normalized by the library.
    #[cfg_attr(
        feature = "serde",
        serde(default = "default_up", with = "crate::serde_rgb")
    )]
    pub up: Vec3,
    /// Height fog layers; optical depths add.
    #[cfg_attr(feature = "serde", serde(default))]
    pub height_fog: Vec<HeightFogLayer>,
    /// Lighting (default: none, so the fog scatters no light).
    #[cfg_attr(feature = "serde", serde(default))]
    pub lighting: Lighting,
    /// Fog volumes (default none): bounded shapes with analytic density profiles, and
    /// cut-outs. Their optical depths add to the height fog's; see [`Volume`](crate::Volume).
    #[cfg_attr(feature = "serde", serde(default))]
    pub volumes: Vec<crate::Volume>,
    /// The accuracy tier [`Scene::evaluate`] runs (default Accurate); a call can choose
    /// another with [`Scene::evaluate_tier`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub tier: Tier,
    /// Distance fog (Bevy's falloff modes; default none). Its optical depth adds to the
    /// other media's and its colour joins the τ-weighted mix; see [`DistanceFog`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub distance_fog: Option<DistanceFog>,
    /// Unreal's start distance, cutoff distance and maximum opacity (default: none),
    /// applied to every medium; see [`FogLimits`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub limits: FogLimits,
    /// A directional in-scattering lobe around the sun (default none; needs
    /// `lighting.sun`); see [`Lobe`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub lobe: Option<Lobe>,
    /// How the in-scattered light of media with different fog colours combines along a
    /// ray (default [`Composition::Mix`]); see [`Composition`].
    #[cfg_attr(feature = "serde", serde(default))]
    pub composition: Composition,
}

/// How the in-scattered light of several media with different fog colours is combined
/// along one ray. Both are exact for a single medium; they differ where a ray crosses
/// media of different colours, and only [`Composition::Ordered`] sees in which order.
///
/// - `Mix` (default, cheap): L_in = c̄ · (1 − T), with c̄ the mix of every medium's fog
///   colour weighted by its optical depth. Blind to order: a bright volume behind a dark
///   one gives the same light as in front of it.
/// - `Ordered`: the fog volumes are composited front to back, each attenuated by
///   everything in front of it: L_in = c̄_bg · (1 − T) + Σ_k (c_k − c̄_bg) · (1 − T_k) ·
///   T(0 → start_k), with c̄_bg the mix of the other media (height fog, distance fog),
///   T_k the volume's own transmittance, and T(0 → start_k) the transmittance of the
///   height fog, the distance fog and the volumes that start before volume k, from the
///   ray's start to where it enters volume k. This is the front-to-back sum
///   Σ_k T(0 → start_k) · c_k · (1 − T_k) with the height fog lit between the volumes,
///   rearranged so that no list has to be sorted per ray. Exact for volumes that do not
///   overlap along the ray, in height fog that is thin inside them; overlapping volumes
///   are ordered by where the ray enters them. Costs O(m²) per packet of 8 rays for the m
///   volumes the packet touches (their list is kept per packet).
///
/// The error of each against a ray-marched single-scattering reference and their costs are
/// measured in the README ("Composition of in-scattering").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Composition {
    /// The τ-weighted mix of the media's fog colours (see above).
    #[default]
    Mix,
    /// The fog volumes composited front to back (see above).
    Ordered,
}

/// Where along a ray fog is integrated, and how opaque it may get (Unreal's exponential
/// height fog controls), applied exactly to the integration interval rather than by fading
/// the result.
///
/// With distances s measured from the camera along the ray (s = t·|d| at the segment's
/// end), every medium (height fog, volumes, distance fog) is integrated over
/// [start_distance, min(t·|d|, cutoff_distance)] only (empty when the segment ends before
/// the start). `max_opacity` m stops the integration where 1 − T reaches m: τ becomes
/// min(τ, −ln(1 − m)), T becomes max(T, 1 − m), and the in-scattered light is scaled by
/// (1 − T_clamped)/(1 − T), which is the exact cut for media of one colour.
///
/// With a start or cutoff distance, rays are integrated from their unit direction and the
/// segment's length rounded once to f32 (lengths beyond f32::MAX count as +∞), so the
/// height fog's relative error bound applies to the shortened segment.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FogLimits {
    /// No fog closer to the camera than this (≥ 0; default 0).
    #[cfg_attr(feature = "serde", serde(default))]
    pub start_distance: f32,
    /// No fog farther from the camera than this (≥ 0; default: none).
    #[cfg_attr(feature = "serde", serde(default))]
    pub cutoff_distance: Option<f32>,
    /// The largest opacity 1 − T (in [0, 1]; default 1: no limit).
    #[cfg_attr(feature = "serde", serde(default = "one"))]
    pub max_opacity: f32,
}

impl Default for FogLimits {
    fn default() -> Self {
        FogLimits {
            start_distance: 0.0,
            cutoff_distance: None,
            max_opacity: 1.0,
        }
    }
}

/// The compiled [`FogLimits`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct LimitsPlan {
    /// A start or cutoff distance is set: rays are cut to the interval.
    pub interval: bool,
    pub start: f32,
    /// +∞ for no cutoff.
    pub cutoff: f32,
    /// A maximum opacity below 1 is set.
    pub opacity: bool,
    /// 1 − max_opacity, and −ln of it (rounded once from f64).
    pub t_floor: f32,
    pub tau_max: f32,
}

#[allow(dead_code)]
fn one() -> f32 {
    1.0
}

/// Accuracy tiers: what the 8-lane kernels trade for speed.
///
/// - `Accurate`: the bounds stated per kernel (height fog: τ within 16·2⁻²⁴ times the
///   problem's condition; volumes: 32·2⁻²⁴ times theirs), special functions within
///   2 ULP.
/// - `Fast`: degree-2 polynomials in the exponentials of the height fog's optical depth
///   and of T (`math::fast`, relative errors 3.4e-5 and 1.4e-5). Bound, tested against
///   the f64 reference (`tests/tiers.rs`): |ΔT| ≤ 1e-4 and |ΔL_in| ≤ 1e-4 · the fog
///   colour, plus the Accurate tier's condition-dependent error; the relative error of
///   τ ≤ 1e-4 plus the Accurate tier's. Every invariant is kept (no NaN for finite input,
///   0 ≤ T ≤ 1, the same range handling and the same speed on extreme data). The volumes'
///   integrals are those of the Accurate tier; only their T is fast.
///
/// The Fast tier runs only in the 8-lane paths ([`Scene::evaluate`], `evaluate_par`,
/// the framebuffer pass); `evaluate_scalar` and `eval_ray` are always Accurate.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum Tier {
    /// The stated bounds (see above).
    #[default]
    Accurate,
    /// Shorter polynomials, within 1e-4 (see above).
    Fast,
}

impl Tier {
    pub(crate) fn width(self) -> crate::kernel::Width {
        match self {
            Tier::Accurate => crate::kernel::Width::X8,
            Tier::Fast => crate::kernel::Width::X8Fast,
        }
    }
}

#[allow(dead_code)]
fn zero3() -> Vec3 {
    Vec3::ZERO
}
#[allow(dead_code)]
fn default_up() -> Vec3 {
    Vec3::Y
}

impl Default for SceneDesc {
    fn default() -> Self {
        SceneDesc {
            up: Vec3::Y,
            height_fog: Vec::new(),
            lighting: Lighting::default(),
            volumes: Vec::new(),
            tier: Tier::Accurate,
            distance_fog: None,
            limits: FogLimits::default(),
            lobe: None,
            composition: Composition::Mix,
        }
    }
}

/// Which axis the up vector is, so that the kernels can skip the dot product.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum UpAxis {
    /// Up is ±X, ±Y or ±Z: the height is one coordinate (the sign is folded into the
    /// layers' constants).
    Axis(usize),
    /// Any other direction: height = dot(x, up).
    General,
}

/// A non-negative f32 split as `m * 2^e` (`m` in [1, 2), or 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Split {
    pub m: f32,
    pub e: f32,
}

impl Split {
    pub(crate) fn of(x: f32) -> Split {
        let (m, e) = crate::math::frexp(x);
        Split { m, e }
    }

    /// A non-negative f64 in f32's normal range or below, the mantissa rounded to f32
    /// once (a value below 2^-126 keeps 24 bits, where `of(x as f32)` would not).
    fn of_f64(x: f64) -> Split {
        if x == 0.0 {
            return Split::of(0.0);
        }
        // f64 is normal here (x ≥ 2^-149·log2(e) at least).
        let e = ((x.to_bits() >> 52) & 0x7ff) as i32 - 1023;
        let m = (x * 2f64.powi(-e)) as f32;
        // m rounded up to 2: the next binade.
        let (m, e) = if m == 2.0 { (1.0, e + 1) } else { (m, e) };
        Split { m, e: e as f32 }
    }
}

/// One layer's compiled constants: the scalars ([`LayerCore`], `Copy`, so that a kernel
/// can hold them in locals) and the sun's phase terms.
#[derive(Clone, Debug)]
pub(crate) struct LayerPlan {
    pub core: LayerCore,
    /// Per non-isotropic component: its phase function and β_s · E_sun / β_t.
    pub colour_sun: Vec<(Phase, [f32; 3])>,
}

impl core::ops::Deref for LayerPlan {
    type Target = LayerCore;
    fn deref(&self) -> &LayerCore {
        &self.core
    }
}

impl core::ops::DerefMut for LayerPlan {
    fn deref_mut(&mut self) -> &mut LayerCore {
        &mut self.core
    }
}

/// A layer's scalar constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LayerCore {
    /// Base height along the (sign-folded) up axis.
    pub h0: f32,
    /// Falloff along the (sign-folded) up axis.
    pub b: f32,
    /// frexp of `b`.
    pub b_split: Split,
    /// frexp of the extinction per channel.
    pub sigma: [Split; 3],
    /// The extinction per channel.
    pub sigma_t: [f32; 3],
    /// When every non-zero channel is within 2^16 of the largest: that channel's exponent
    /// and each channel's extinction divided by 2^exponent, so that the three optical
    /// depths share one pair of scale factors (two multiplies per channel instead of a
    /// saturating ldexp each). `None` for wider ranges (e.g. 1e-20 next to 1e20).
    pub shared_scale: Option<(f32, [f32; 3])>,
    /// Fog colour terms that do not depend on the ray direction:
    /// Σ β_s · (L_amb + E_sun / 4π for isotropic components) / β_t.
    pub colour_const: [f32; 3],
    /// Heights above the base below this count as 0 in the exponent (2^-100/|b|, +∞ for
    /// b = 0: `height_fog::height_term`).
    pub tiny_height: f32,
}

impl LayerCore {
    /// The layer for a depth stage in base 2 (`kernel::Single`): b and σ times log2(e),
    /// each rounded once from f64. With Δ₂ = Δ·log2(e) and u_min₂ = u_min·log2(e), the
    /// same arithmetic gives G₂ = m·φ₂(|Δ₂|)·2^(−u_min₂), φ₂(x) = (1 − 2^(−x))/x, which is
    /// G/log2(e) (φ(|Δ|) = log2(e)·φ₂(|Δ₂|)), so τ = σ₂·G₂. A homogeneous layer (b = 0,
    /// no exponential) is its own. `None` where b·log2(e) is not a normal f32: beyond the
    /// range, or below 2^-126, where its rounding would not be relative (b = 1e-45 would
    /// lose 31 %, which a ray with |Δ| ≫ 1 from a huge non-unit direction turns into
    /// the error of τ). `sigma_t`
    /// is σ₂ rounded to f32 (not read by the kernels: `sigma` and `shared_scale` keep 24
    /// bits below 2^-126, and are finite where σ₂ is not).
    pub(crate) fn base2(&self) -> Option<LayerCore> {
        if self.b == 0.0 {
            return Some(*self);
        }
        let l2e = core::f64::consts::LOG2_E;
        let b = (f64::from(self.b) * l2e) as f32;
        if !b.is_normal() {
            return None;
        }
        let s64 = self.sigma_t.map(|s| f64::from(s) * l2e);
        Some(LayerCore {
            h0: self.h0,
            b,
            b_split: Split::of(b),
            sigma: s64.map(Split::of_f64),
            sigma_t: s64.map(|s| s as f32),
            shared_scale: shared_scale_f64(s64),
            colour_const: self.colour_const,
            tiny_height: crate::medium::height_fog::tiny_height(b),
        })
    }
}

/// A validated, compiled scene. Build it with [`Scene::new`]; it cannot be made invalid
/// afterwards.
#[derive(Clone, Debug)]
pub struct Scene {
    desc: SceneDesc,
    pub(crate) up: Vec3,
    pub(crate) axis: UpAxis,
    pub(crate) layers: Vec<LayerPlan>,
    /// Unit vector toward the sun, if a sun lights a non-isotropic component.
    pub(crate) sun_dir: Option<Vec3>,
    /// The compiled fog volumes.
    pub(crate) volumes: crate::medium::volume::VolumeSet,
    /// The default tier of `evaluate` and of the framebuffer pass.
    pub(crate) tier: Tier,
    /// The compiled distance fog, if it can change a ray.
    pub(crate) distance: Option<DistanceFogPlan>,
    /// Start and cutoff distances, maximum opacity.
    pub(crate) limits: LimitsPlan,
    /// The directional lobe.
    pub(crate) lobe: Option<LobePlan>,
    /// Ordered composition of the fog volumes' in-scattering (`Composition::Ordered` in a
    /// scene with additive volumes).
    pub(crate) ordered: bool,
    /// The framebuffer pass uses the batch kernel even where its own one-layer kernel
    /// applies (`Scene::with_batch_kernel_pass`).
    pub(crate) exact_pass: bool,
    /// The pass's own kernel runs 8 lanes wide instead of 16
    /// (`Scene::with_pass_lanes_8`).
    pub(crate) pass_lanes_8: bool,
    /// The batch kernel stays at the build's own width even where the CPU has AVX-512
    /// (`Scene::without_avx512_dispatch`).
    pub(crate) no_avx512_dispatch: bool,
}

fn check_finite(field: impl FnOnce() -> String, v: f32) -> Result<(), SceneError> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(SceneError::NonFinite {
            field: field(),
            value: v,
        })
    }
}

fn check_rgb_nonneg(field: &str, v: Vec3) -> Result<(), SceneError> {
    for (i, x) in v.to_array().into_iter().enumerate() {
        check_finite(|| format!("{field}[{i}]"), x)?;
        if x < 0.0 {
            return Err(SceneError::Negative {
                field: format!("{field}[{i}]"),
                value: x,
            });
        }
    }
    Ok(())
}

/// Normalizes a finite non-zero vector without overflow or underflow.
pub(crate) fn normalize_robust(field: &str, v: Vec3) -> Result<Vec3, SceneError> {
    for (i, x) in v.to_array().into_iter().enumerate() {
        check_finite(|| format!("{field}[{i}]"), x)?;
    }
    let m = v.abs().max_element();
    if m == 0.0 {
        return Err(SceneError::ZeroVector {
            field: field.to_string(),
        });
    }
    let w = v.as_dvec3() / m as f64;
    Ok((w / w.length()).as_vec3())
}

fn compile_limits(l: &FogLimits) -> Result<LimitsPlan, SceneError> {
    let nonneg = |field: &str, v: f32| -> Result<f32, SceneError> {
        check_finite(|| format!("limits.{field}"), v)?;
        if v < 0.0 {
            return Err(SceneError::Negative {
                field: format!("limits.{field}"),
                value: v,
            });
        }
        Ok(v)
    };
    let start = nonneg("start_distance", l.start_distance)?;
    let cutoff = match l.cutoff_distance {
        Some(c) => nonneg("cutoff_distance", c)?,
        None => f32::INFINITY,
    };
    let m = l.max_opacity;
    check_finite(|| "limits.max_opacity".into(), m)?;
    if !(0.0..=1.0).contains(&m) {
        return Err(SceneError::OutOfRange {
            field: "limits.max_opacity".into(),
            value: m,
            range: "[0, 1]",
        });
    }
    let floor = 1.0 - m as f64;
    Ok(LimitsPlan {
        interval: start > 0.0 || cutoff < f32::INFINITY,
        start,
        cutoff,
        opacity: m < 1.0,
        t_floor: floor as f32,
        tau_max: (-floor.ln()) as f32,
    })
}

/// See [`LayerCore::shared_scale`].
fn shared_scale(sigma: [f32; 3]) -> Option<(f32, [f32; 3])> {
    let (e, m) = shared_scale_f64(sigma.map(f64::from))?;
    // The division by a power of two must be exact (no subnormal channel values).
    let scale = 2.0f64.powi(-(e as i32));
    m.iter()
        .zip(sigma)
        .all(|(&x, s)| (x as f64 / scale) as f32 == s)
        .then_some((e, m))
}

/// [`shared_scale`] for extinctions given in f64 (`LayerCore::base2`; no exactness test:
/// each channel's mantissa is one rounding of its value).
fn shared_scale_f64(sigma: [f64; 3]) -> Option<(f32, [f32; 3])> {
    let max = sigma.iter().cloned().fold(0.0f64, f64::max);
    if max == 0.0 {
        return None;
    }
    let e = Split::of_f64(max).e;
    let scale = 2.0f64.powi(-(e as i32));
    let m = sigma.map(|s| (s * scale) as f32);
    // A channel more than 2^16 below the largest fails the range, also where it rounds
    // to 0 (found by `tests/height_fog.rs`: σ = 1e-45 next to 1e5 gave τ = 0).
    m.iter()
        .zip(sigma)
        .all(|(&x, s)| s == 0.0 || (1.0 / 65536.0..2.0).contains(&x))
        .then_some((e, m))
}

impl Scene {
    /// Validates and compiles a scene description.
    ///
    /// ```
    /// use analytic_fog::{Scene, SceneDesc, HeightFogLayer, Component, Phase};
    /// use glam::Vec3;
    /// let desc = SceneDesc {
    ///     height_fog: vec![HeightFogLayer {
    ///         base_height: 0.0,
    ///         falloff: -1.0 / 0.0, // not finite: rejected
    ///         emission: glam::Vec3::ZERO,
    ///         components: vec![Component {
    ///             scattering: Vec3::splat(0.02),
    ///             absorption: Vec3::ZERO,
    ///             phase: Phase::Isotropic,
    ///         }],
    ///     }],
    ///     ..SceneDesc::default()
    /// };
    /// let err = Scene::new(desc).unwrap_err();
    /// assert_eq!(err.to_string(), "height_fog[0].falloff: must be finite, got -inf");
    /// ```
    pub fn new(desc: SceneDesc) -> Result<Scene, SceneError> {
        let up = normalize_robust("up", desc.up)?;
        // Axis-aligned up: exact when the normalized vector is exactly ±e_i. Both other
        // components must be zero: a component below ~2^-12 leaves the f32 norm at exactly
        // 1, and snapping (0, 1, 2e-4) to +Y would move every height by 2e-4 · |x|, far
        // more than a rounding (found by `tests/height_fog.rs`, `any_finite_input`).
        let axis = (0..3)
            .find(|&i| up[i].abs() == 1.0 && up[(i + 1) % 3] == 0.0 && up[(i + 2) % 3] == 0.0)
            .map(UpAxis::Axis)
            .unwrap_or(UpAxis::General);
        let up_sign = match axis {
            UpAxis::Axis(i) => up[i],
            UpAxis::General => 1.0,
        };

        let lighting = &desc.lighting;
        check_rgb_nonneg("lighting.ambient", lighting.ambient)?;
        let sun = match &lighting.sun {
            Some(s) => {
                let d = normalize_robust("lighting.sun.direction", s.direction)?;
                check_rgb_nonneg("lighting.sun.radiance", s.radiance)?;
                Some((d, s.radiance))
            }
            None => None,
        };

        let mut layers = Vec::with_capacity(desc.height_fog.len());
        let mut any_directional = false;
        for (li, layer) in desc.height_fog.iter().enumerate() {
            let f = |name: &str| format!("height_fog[{li}].{name}");
            check_finite(|| f("base_height"), layer.base_height)?;
            check_finite(|| f("falloff"), layer.falloff)?;
            if layer.components.is_empty() {
                return Err(SceneError::Empty {
                    field: f("components"),
                });
            }
            let mut beta_s = Vec3::ZERO;
            let mut beta_t = glam::DVec3::ZERO;
            for (ci, c) in layer.components.iter().enumerate() {
                let cf = |name: &str| format!("height_fog[{li}].components[{ci}].{name}");
                check_rgb_nonneg(&cf("scattering"), c.scattering)?;
                check_rgb_nonneg(&cf("absorption"), c.absorption)?;
                c.phase.validate(&cf("phase"))?;
                beta_s += c.scattering;
                beta_t += c.scattering.as_dvec3() + c.absorption.as_dvec3();
            }
            let _ = beta_s;
            // Extinction per channel, rounded once from the f64 sum.
            let sigma_t = beta_t.as_vec3().to_array();
            for (i, s) in sigma_t.iter().enumerate() {
                if !s.is_finite() {
                    return Err(SceneError::NonFinite {
                        field: format!("height_fog[{li}].components: extinction[{i}]"),
                        value: *s,
                    });
                }
            }
            // Fog colour terms, in f64 and rounded once.
            let inv_bt = beta_t
                .to_array()
                .map(|b| if b > 0.0 { 1.0 / b } else { 0.0 });
            let amb = lighting.ambient.as_dvec3().to_array();
            let (esun, _) = match sun {
                Some((d, e)) => (e.as_dvec3().to_array(), Some(d)),
                None => ([0.0; 3], None),
            };
            let mut colour_const = [0.0f64; 3];
            let mut colour_sun: Vec<(Phase, [f32; 3])> = Vec::new();
            for c in &layer.components {
                let bs = c.scattering.as_dvec3().to_array();
                let mut sun_k = [0.0f64; 3];
                for ch in 0..3 {
                    colour_const[ch] += bs[ch] * amb[ch] * inv_bt[ch];
                    sun_k[ch] = bs[ch] * esun[ch] * inv_bt[ch];
                }
                if sun.is_some() && sun_k.iter().any(|&k| k > 0.0) {
                    match c.phase {
                        Phase::Isotropic => {
                            for ch in 0..3 {
                                colour_const[ch] += sun_k[ch] / (4.0 * core::f64::consts::PI);
                            }
                        }
                        phase => {
                            // Merge components that share a phase function.
                            let k32 = sun_k.map(|k| k as f32);
                            if let Some(e) = colour_sun.iter_mut().find(|(p, _)| *p == phase) {
                                for ch in 0..3 {
                                    e.1[ch] = (e.1[ch] as f64 + sun_k[ch]) as f32;
                                }
                            } else {
                                colour_sun.push((phase, k32));
                            }
                        }
                    }
                }
            }
            check_rgb_nonneg(&f("emission"), layer.emission)?;
            for ch in 0..3 {
                colour_const[ch] += layer.emission[ch] as f64;
            }
            for (i, v) in colour_const.iter().enumerate() {
                if !(v.is_finite() && (*v as f32).is_finite()) {
                    return Err(SceneError::NonFinite {
                        field: format!("height_fog[{li}]: fog colour[{i}]"),
                        value: *v as f32,
                    });
                }
            }
            any_directional |= !colour_sun.is_empty();
            let b = layer.falloff * up_sign;
            let h0 = layer.base_height * up_sign;
            layers.push(LayerPlan {
                core: LayerCore {
                    h0,
                    b,
                    b_split: Split::of(b),
                    sigma: sigma_t.map(Split::of),
                    shared_scale: shared_scale(sigma_t),
                    sigma_t,
                    colour_const: colour_const.map(|v| v as f32),
                    tiny_height: crate::medium::height_fog::tiny_height(b),
                },
                colour_sun,
            });
        }

        let volumes = crate::medium::volume::compile(&desc.volumes, lighting.ambient, sun)?;
        any_directional |= volumes.is_directional();
        let volumes_empty = volumes.is_empty();

        let distance = match &desc.distance_fog {
            Some(fog) => crate::medium::distance::compile(fog)?,
            None => None,
        };
        let limits = compile_limits(&desc.limits)?;
        let lobe = match &desc.lobe {
            Some(l) => {
                let plan = l.compile("lobe")?;
                if sun.is_none() {
                    return Err(SceneError::Requires {
                        field: "lobe".into(),
                        requires: "lighting.sun",
                    });
                }
                plan
            }
            None => None,
        };
        any_directional |= lobe.is_some();

        Ok(Scene {
            up,
            axis,
            layers,
            volumes,
            sun_dir: if any_directional {
                sun.map(|(d, _)| d)
            } else {
                None
            },
            tier: desc.tier,
            distance,
            limits,
            lobe,
            ordered: desc.composition == Composition::Ordered && !volumes_empty,
            exact_pass: false,
            pass_lanes_8: false,
            no_avx512_dispatch: false,
            desc,
        })
    }

    /// True if the scene has a control beyond height fog and volumes (distance fog,
    /// start/cutoff distance, maximum opacity, directional lobe): those run in the
    /// general kernel.
    pub(crate) fn has_controls(&self) -> bool {
        self.distance.is_some()
            || self.limits.interval
            || self.limits.opacity
            || self.lobe.is_some()
    }

    /// The tier [`Scene::evaluate`] runs.
    pub fn tier(&self) -> Tier {
        self.tier
    }

    /// This scene with the per-packet culling of fog volumes switched off: every volume is
    /// evaluated for every packet. For tests and benchmarks (culling changes no result).
    #[doc(hidden)]
    pub fn without_culling(mut self) -> Scene {
        self.volumes.no_culling = true;
        self
    }

    /// This scene with the framebuffer pass running the batch API's kernel on every frame,
    /// so that each pixel is bit-identical to [`Scene::eval_ray`] for its ray (see
    /// [`crate::pass`]); by default, frames of one height fog layer seen through a
    /// perspective camera (or an upright orthographic one) run the pass's own, cheaper
    /// kernel, which agrees with the batch
    /// API within the accuracy bound rather than bit for bit.
    pub fn with_batch_kernel_pass(mut self) -> Scene {
        self.exact_pass = true;
        self
    }

    /// This scene with the framebuffer pass's own one-layer kernel running 8 lanes wide
    /// instead of 16 (`wide::f32x16`, one AVX-512 register or two AVX2 ones). For tests
    /// and benchmarks: both widths give the same bits.
    #[doc(hidden)]
    pub fn with_pass_lanes_8(mut self) -> Scene {
        self.pass_lanes_8 = true;
        self
    }

    /// This scene with the batch kernel at the build's own width (8 lanes in an AVX2 build)
    /// even where [`crate::avx512_dispatch`] is true: without this, `evaluate` and
    /// `evaluate_par` run every scene 16 lanes wide on such a CPU, and so does the
    /// framebuffer pass. The batch results and the pass's rows through the general kernel
    /// (several layers, volumes, controls) are the same bits either way; the pass's own
    /// one-layer kernel differs in the last bits (T within 4e-7, L_in within 1e-6 of the
    /// fog colour: its AVX-512 lanes take AVX-512's estimate of 1/√x). This is for tests
    /// and benchmarks, and for CPUs whose clock drops under AVX-512 load.
    pub fn without_avx512_dispatch(mut self) -> Scene {
        self.no_avx512_dispatch = true;
        self
    }

    /// This scene with another default tier (for `evaluate`, `evaluate_par` and the
    /// framebuffer pass).
    pub fn with_tier(mut self, tier: Tier) -> Scene {
        self.tier = tier;
        self.desc.tier = tier;
        self
    }

    /// The description this scene was built from.
    pub fn desc(&self) -> &SceneDesc {
        &self.desc
    }

    /// The normalized up vector.
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// True if every layer's extinction is the same in all three channels (one
    /// exponential per ray instead of three).
    pub fn is_grey(&self) -> bool {
        self.layers
            .iter()
            .all(|l| l.sigma_t[0] == l.sigma_t[1] && l.sigma_t[1] == l.sigma_t[2])
    }

    /// True if the scene's in-scattering depends on the ray direction (a sun lighting a
    /// non-isotropic component).
    pub fn has_directional_light(&self) -> bool {
        self.sun_dir.is_some()
    }
}
