//! Fog volumes: bounded primitives (sphere, ellipsoid, oriented box) with an analytic
//! density profile, integrated in closed form along each ray (seeds 002 and 004).
//!
//! A volume's shape is an invertible affine map `x = c + M·p` of the unit ball (or of the
//! unit cube for boxes); the density at `x` is `σ_t · f(|p|)` with one of the radial
//! [`Profile`]s, zero outside `|p| = 1`. The optical depth of the ray `o + s·d`,
//! s in [0, t], is `σ_t · ∫ f ds` with the length in world units.
//!
//! How the integral stays accurate in f32 (details in `profile.rs`):
//! - it is taken in the frame of the ray's closest approach to the centre, so the
//!   integrand is `f(√(h² + u²))` with `h` the distance of closest approach and `u` in
//!   [−1, 1] whatever the distance of the camera (seed 002's origin shift, taken to the
//!   point where it removes the large terms exactly);
//! - the chord's ends are carried as distances to the boundary, so `1 − r² = (w − u)(w + u)`
//!   never cancels; polynomial profiles are integrated by quadrature rules that are exact
//!   for their degree and have positive weights (no cancellation at all);
//! - `∫ √(u² + h²) du` (linear, spiky) uses `asinh` of a difference formed without
//!   cancellation instead of seed 002's `ln(0.001 + u + √…)`;
//! - the Gaussian uses `erfc(a) − erfc(b)` when both ends lie on one side, `erf(b) + erf(−a)`
//!   across the centre, and Gauss–Legendre on short pieces, where the difference of error
//!   functions would cancel; the spiky profile uses Gauss–Legendre in the outer shell
//!   (r > 0.8), where its closed form cancels.
//!
//! Subtractive volumes (cut-outs) remove the additive volumes' density inside them: each
//! additive volume is integrated over its clipped chord minus the union of the cut-outs'
//! chords, exactly, per lane.
//!
//! Lighting, per volume (seed 002's per-primitive shading): the fog colour is
//! `albedo · (L_amb + E_sun · p(θ) · T_sun) + emission`, with `T_sun` the transmittance
//! of the volume itself from its centre to its boundary toward the sun, compiled once per
//! scene. The kernel mixes the volumes' and the height fog's colours by their optical
//! depths (see `kernel.rs`).

// `!(a > b)` is deliberate here: it is true for NaN as well.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod packet;
pub(crate) mod profile;

#[cfg(test)]
pub(crate) use packet::may_touch_ray;
pub(crate) use packet::{clamp_colour, Entry, OutOfLine, VolumeEval};
/// For the AVX-512 entry points of the x86-64-v3 build (`kernel::zmm`).
#[cfg(zmm_dispatch)]
pub(crate) use packet::{eval_volumes_body, VolOut};

use crate::error::SceneError;
use crate::light::Phase;
use glam::{DMat3, DVec3, Quat, Vec3};

/// The radial density profile of a fog volume, `f(r)` for `r = |p|` in the shape's unit
/// space, zero for r > 1 (seed 002).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Hash)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Profile {
    /// f = 1.
    #[default]
    Constant,
    /// f = 1 − r (a cone).
    Linear,
    /// f = 1 − r² (seed 004's sphere density).
    Quadratic,
    /// f = (1 − r²)², zero slope at the boundary.
    Quartic,
    /// f = (1 − r)², peaked at the centre.
    Spiky,
    /// f = exp(−r² / (2 · 0.25²)), truncated at r = 1 (where it is e^−8 ≈ 3.4e-4).
    Gaussian,
}

impl Profile {
    /// All profiles, for tests and benches.
    pub const ALL: [Profile; 6] = [
        Profile::Constant,
        Profile::Linear,
        Profile::Quadratic,
        Profile::Quartic,
        Profile::Spiky,
        Profile::Gaussian,
    ];

    /// The profile at radius `r` (f64; zero outside the unit ball).
    pub fn eval_f64(self, r: f64) -> f64 {
        if !(r <= 1.0) {
            return 0.0;
        }
        match self {
            Profile::Constant => 1.0,
            Profile::Linear => 1.0 - r,
            Profile::Quadratic => 1.0 - r * r,
            Profile::Quartic => (1.0 - r * r) * (1.0 - r * r),
            Profile::Spiky => (1.0 - r) * (1.0 - r),
            Profile::Gaussian => (-8.0 * r * r).exp(),
        }
    }
}

/// The shape of a fog volume.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum Shape {
    /// A sphere: `|x − center| ≤ radius`.
    Sphere {
        /// The centre, world units.
        center: Vec3,
        /// The radius, in [1e-12, 1e12].
        radius: f32,
    },
    /// An ellipsoid with semi-axes `radii` along the axes of `rotation` (a quaternion
    /// `[x, y, z, w]`, normalized by the library; default identity).
    Ellipsoid {
        /// The centre, world units.
        center: Vec3,
        /// The semi-axes, each in [1e-12, 1e12].
        radii: Vec3,
        /// The orientation of the semi-axes.
        #[cfg_attr(feature = "serde", serde(default = "identity"))]
        rotation: Quat,
    },
    /// Any invertible affine image of the unit ball: `x = center + M·p`, |p| ≤ 1, with
    /// `matrix` the three columns of M (the images of the unit axes).
    Affine {
        /// The centre, world units.
        center: Vec3,
        /// The columns of M (invertible).
        matrix: [Vec3; 3],
    },
    /// An oriented box: `|p_i| ≤ 1` for `x = center + R · (half_extents ⊙ p)`. Constant
    /// density, optionally faded toward the faces: the density is
    /// `Π_i clamp((1 − |p_i|) / edge_fade, 0, 1)`, a linear ramp over the outer
    /// `edge_fade` fraction of each half extent (0 = hard edges, the default; 1 = a tent).
    Box {
        /// The centre, world units.
        center: Vec3,
        /// Half the box's size along each of its axes, each in [1e-12, 1e12].
        half_extents: Vec3,
        /// The orientation of the box's axes.
        #[cfg_attr(feature = "serde", serde(default = "identity"))]
        rotation: Quat,
        /// The fraction of each half extent over which the density fades to 0 at the
        /// faces, in [0, 1].
        #[cfg_attr(feature = "serde", serde(default))]
        edge_fade: f32,
    },
}

#[allow(dead_code)]
fn identity() -> Quat {
    Quat::IDENTITY
}
#[allow(dead_code)]
fn zero3() -> Vec3 {
    Vec3::ZERO
}

/// A fog volume: a shape, a density profile and the medium's coefficients (per RGB
/// channel, at the profile's peak f = 1).
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Volume {
    /// Where the volume is.
    pub shape: Shape,
    /// Density profile (default constant). Boxes take only `constant` (see `edge_fade`).
    #[cfg_attr(feature = "serde", serde(default))]
    pub profile: Profile,
    /// Scattering coefficient β_s at the peak, 1/length (RGB; a number or `[r, g, b]`).
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub scattering: Vec3,
    /// Absorption coefficient β_a at the peak (default 0).
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub absorption: Vec3,
    /// Phase function of the scattering (default isotropic).
    #[cfg_attr(feature = "serde", serde(default))]
    pub phase: Phase,
    /// Emitted radiance of an optically thick volume (RGB, default 0): the source term is
    /// β_t · emission, so that the volume adds `emission · (1 − T)`.
    #[cfg_attr(feature = "serde", serde(default = "zero3", with = "crate::serde_rgb"))]
    pub emission: Vec3,
    /// A cut-out: inside it the additive volumes' density is removed (its coefficients
    /// and profile are ignored). Default false.
    #[cfg_attr(feature = "serde", serde(default))]
    pub subtractive: bool,
}

impl Volume {
    /// A constant-density volume of the given shape and extinction (scattering only).
    pub fn new(shape: Shape, profile: Profile, scattering: Vec3) -> Volume {
        Volume {
            shape,
            profile,
            scattering,
            absorption: Vec3::ZERO,
            phase: Phase::Isotropic,
            emission: Vec3::ZERO,
            subtractive: false,
        }
    }

    /// A cut-out of the given shape.
    pub fn cut(shape: Shape) -> Volume {
        Volume {
            subtractive: true,
            ..Volume::new(shape, Profile::Constant, Vec3::ZERO)
        }
    }
}

/// The most subtractive volumes a scene may have (their chords are kept per ray on the
/// stack).
pub const MAX_CUTS: usize = 16;
/// Radii, half extents and the singular values of affine maps must lie in
/// [1/LENGTH_RANGE, LENGTH_RANGE], so that every unit-space quantity stays in range.
pub const LENGTH_RANGE: f64 = 1e12;

/// The shape kinds the kernel distinguishes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Unit ball.
    Ball,
    /// Unit cube.
    Cube,
}

/// The affine map of a shape in f64: `x = center + m · p`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Affine {
    pub kind: Kind,
    pub center: DVec3,
    pub m: DMat3,
    pub edge_fade: f64,
}

/// One volume's compiled constants.
#[derive(Clone, Debug)]
pub(crate) struct VolumePlan {
    pub kind: Kind,
    pub profile: Profile,
    /// Box edge fade in unit coordinates (0: hard edges).
    pub edge_fade: f32,
    pub center: [f32; 3],
    /// M⁻¹, by rows: p = inv · (x − center).
    pub inv: [[f32; 3]; 3],
    /// M, by rows: x − center = fwd · p.
    pub fwd: [[f32; 3]; 3],
    /// For an additive volume: its centre minus each cut-out's centre (rounded once from
    /// f64), so that cut-outs are placed relative to it without a far origin's rounding.
    pub cut_offsets: Vec<[f32; 3]>,
    /// Extinction per channel.
    pub sigma: [f32; 3],
    /// albedo · (L_amb + E_sun · T_sun / 4π for isotropic scattering) + emission.
    pub colour_const: [f32; 3],
    /// For a non-isotropic phase lit by the sun: the phase and albedo · E_sun · T_sun.
    pub colour_sun: Option<(Phase, [f32; 3])>,
    /// The radius of a sphere about `center` that contains the shape (a sphere's radius,
    /// an ellipsoid's longest semi-axis, a box's half diagonal, the Frobenius norm of M
    /// for a general affine ball), rounded up: the per-packet culling test.
    pub bound_radius: f32,
}

/// The compiled volumes of a scene.
#[derive(Clone, Debug, Default)]
pub(crate) struct VolumeSet {
    pub additive: Vec<VolumePlan>,
    pub cuts: Vec<VolumePlan>,
    /// Skip, per packet, the volumes that no ray of the packet can touch (on unless
    /// `Scene::without_culling`; it changes no result: a lane that cannot touch a volume
    /// gets exactly 0 from it either way).
    pub no_culling: bool,
    /// Skip the framebuffer pass's per-tile culling (`crate::pass`), keeping the
    /// per-packet test: for tests and benchmarks (`Scene::without_tile_culling`).
    pub no_tile_culling: bool,
}

impl VolumeSet {
    /// True if no additive volume exists (cut-outs alone change nothing).
    pub(crate) fn is_empty(&self) -> bool {
        self.additive.is_empty()
    }

    /// True if some volume's colour depends on the view direction.
    pub(crate) fn is_directional(&self) -> bool {
        self.additive.iter().any(|v| v.colour_sun.is_some())
    }
}

fn finite(field: impl FnOnce() -> String, v: f32) -> Result<f64, SceneError> {
    if v.is_finite() {
        Ok(v as f64)
    } else {
        Err(SceneError::NonFinite {
            field: field(),
            value: v,
        })
    }
}

fn finite3(field: &str, v: Vec3) -> Result<DVec3, SceneError> {
    let mut out = [0.0; 3];
    for i in 0..3 {
        out[i] = finite(|| format!("{field}[{i}]"), v[i])?;
    }
    Ok(DVec3::from_array(out))
}

fn length(field: impl Fn() -> String, v: f32) -> Result<f64, SceneError> {
    let x = finite(&field, v)?;
    if !(1.0 / LENGTH_RANGE..=LENGTH_RANGE).contains(&x) {
        return Err(SceneError::OutOfRange {
            field: field(),
            value: v,
            range: "[1e-12, 1e12]",
        });
    }
    Ok(x)
}

fn rotation(field: &str, q: Quat) -> Result<DMat3, SceneError> {
    let a = q.to_array();
    for i in 0..4 {
        finite(|| format!("{field}[{i}]"), a[i])?;
    }
    let d = glam::DQuat::from_xyzw(a[0] as f64, a[1] as f64, a[2] as f64, a[3] as f64);
    let n = d.length();
    if !(n > 1e-30) {
        return Err(SceneError::ZeroVector {
            field: field.to_string(),
        });
    }
    Ok(DMat3::from_quat(d / n))
}

impl Affine {
    /// Validates a shape and returns its affine map in f64. `f` names the field.
    pub(crate) fn of(shape: &Shape, f: &dyn Fn(&str) -> String) -> Result<Affine, SceneError> {
        let (kind, center, m, edge_fade) = match shape {
            Shape::Sphere { center, radius } => {
                let c = finite3(&f("shape.center"), *center)?;
                let r = length(|| f("shape.radius"), *radius)?;
                (Kind::Ball, c, DMat3::from_diagonal(DVec3::splat(r)), 0.0)
            }
            Shape::Ellipsoid {
                center,
                radii,
                rotation: q,
            } => {
                let c = finite3(&f("shape.center"), *center)?;
                let mut r = [0.0; 3];
                for i in 0..3 {
                    r[i] = length(|| f(&format!("shape.radii[{i}]")), radii[i])?;
                }
                let rot = rotation(&f("shape.rotation"), *q)?;
                let m = rot * DMat3::from_diagonal(DVec3::from_array(r));
                (Kind::Ball, c, m, 0.0)
            }
            Shape::Affine { center, matrix } => {
                let c = finite3(&f("shape.center"), *center)?;
                let mut cols = [DVec3::ZERO; 3];
                for j in 0..3 {
                    cols[j] = finite3(&f(&format!("shape.matrix[{j}]")), matrix[j])?;
                }
                let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
                // Invertible, and not so skewed that the inverse leaves the f32 range:
                // every singular value within LENGTH_RANGE (bounded through the column
                // norms and |det|).
                let norms = cols.map(|c| c.length());
                let prod = norms[0] * norms[1] * norms[2];
                let det = m.determinant().abs();
                let smax = norms.iter().cloned().fold(0.0, f64::max);
                let ok = norms
                    .iter()
                    .all(|&n| (1.0 / LENGTH_RANGE..=LENGTH_RANGE).contains(&n))
                    && det > 0.0
                    && det / prod >= 1e-6
                    && det / (smax * smax) >= 1.0 / LENGTH_RANGE;
                if !ok {
                    return Err(SceneError::OutOfRange {
                        field: f("shape.matrix"),
                        value: (det / prod) as f32,
                        range: "invertible matrices with column lengths in [1e-12, 1e12] and \
                                |det| / (product of the column lengths) >= 1e-6; that ratio is",
                    });
                }
                (Kind::Ball, c, m, 0.0)
            }
            Shape::Box {
                center,
                half_extents,
                rotation: q,
                edge_fade,
            } => {
                let c = finite3(&f("shape.center"), *center)?;
                let mut r = [0.0; 3];
                for i in 0..3 {
                    r[i] = length(|| f(&format!("shape.half_extents[{i}]")), half_extents[i])?;
                }
                let rot = rotation(&f("shape.rotation"), *q)?;
                let fade = finite(|| f("shape.edge_fade"), *edge_fade)?;
                if !(0.0..=1.0).contains(&fade) {
                    return Err(SceneError::OutOfRange {
                        field: f("shape.edge_fade"),
                        value: *edge_fade,
                        range: "[0, 1]",
                    });
                }
                let m = rot * DMat3::from_diagonal(DVec3::from_array(r));
                (Kind::Cube, c, m, fade)
            }
        };
        Ok(Affine {
            kind,
            center,
            m,
            edge_fade,
        })
    }
}

fn rgb_nonneg(field: &str, v: Vec3) -> Result<DVec3, SceneError> {
    let d = finite3(field, v)?;
    for i in 0..3 {
        if d[i] < 0.0 {
            return Err(SceneError::Negative {
                field: format!("{field}[{i}]"),
                value: v[i],
            });
        }
    }
    Ok(d)
}

/// Validates and compiles the volumes of a scene. `sun`: unit direction toward the sun and
/// its radiance.
pub(crate) fn compile(
    volumes: &[Volume],
    ambient: Vec3,
    sun: Option<(Vec3, Vec3)>,
) -> Result<VolumeSet, SceneError> {
    let mut set = VolumeSet::default();
    for (vi, v) in volumes.iter().enumerate() {
        let f = |name: &str| format!("volumes[{vi}].{name}");
        let aff = Affine::of(&v.shape, &f)?;
        if aff.kind == Kind::Cube && v.profile != Profile::Constant {
            return Err(SceneError::OutOfRange {
                field: f("profile"),
                value: Profile::ALL
                    .iter()
                    .position(|p| *p == v.profile)
                    .unwrap_or(0) as f32,
                range: "{constant (0)} for boxes (use shape.edge_fade); the profile's index is",
            });
        }
        let bs = rgb_nonneg(&f("scattering"), v.scattering)?;
        let ba = rgb_nonneg(&f("absorption"), v.absorption)?;
        let em = rgb_nonneg(&f("emission"), v.emission)?;
        v.phase.validate(&f("phase"))?;
        let inv64 = aff.m.inverse();
        let inv = [0, 1, 2].map(|r| [0, 1, 2].map(|c| inv64.col(c)[r] as f32));
        let fwd = [0, 1, 2].map(|r| [0, 1, 2].map(|c| aff.m.col(c)[r] as f32));
        // The radius of the smallest sphere about the centre that holds the shape: for a
        // sphere or an ellipsoid (M = R·diag(radii), orthogonal columns) the longest
        // column; for a box its farthest corner, max |M·s| over s in {±1}³; for a general
        // affine ball the Frobenius norm (≥ the largest singular value). Each is exact
        // up to f64 rounding; the margin below covers that.
        let bound = match (&v.shape, aff.kind) {
            (Shape::Sphere { .. } | Shape::Ellipsoid { .. }, _) => {
                (0..3).map(|c| aff.m.col(c).length()).fold(0.0, f64::max)
            }
            (_, Kind::Cube) => (0..8)
                .map(|k| {
                    let s = DVec3::new(
                        if k & 1 == 0 { 1.0 } else { -1.0 },
                        if k & 2 == 0 { 1.0 } else { -1.0 },
                        if k & 4 == 0 { 1.0 } else { -1.0 },
                    );
                    (aff.m * s).length()
                })
                .fold(0.0, f64::max),
            _ => (0..3)
                .map(|c| aff.m.col(c).length_squared())
                .sum::<f64>()
                .sqrt(),
        };
        // Rounded up to f32 and by a margin of its own.
        let bound_radius = (bound * (1.0 + 1e-6)) as f32 * (1.0 + 1e-6);
        let plan_geom = |sigma: [f32; 3], colour_const, colour_sun| VolumePlan {
            bound_radius,
            kind: aff.kind,
            profile: v.profile,
            edge_fade: aff.edge_fade as f32,
            center: aff.center.as_vec3().to_array(),
            inv,
            fwd,
            cut_offsets: Vec::new(),
            sigma,
            colour_const,
            colour_sun,
        };
        if v.subtractive {
            if set.cuts.len() == MAX_CUTS {
                return Err(SceneError::OutOfRange {
                    field: f("subtractive"),
                    value: (MAX_CUTS + 1) as f32,
                    range: "[0, 16] subtractive volumes per scene; the count is",
                });
            }
            set.cuts.push(plan_geom([0.0; 3], [0.0; 3], None));
            continue;
        }
        let bt = bs + ba;
        let sigma = bt.as_vec3().to_array();
        for (i, s) in sigma.iter().enumerate() {
            if !s.is_finite() {
                return Err(SceneError::NonFinite {
                    field: f(&format!("extinction[{i}]")),
                    value: *s,
                });
            }
        }
        let albedo =
            DVec3::from_array([0, 1, 2].map(|i| if bt[i] > 0.0 { bs[i] / bt[i] } else { 0.0 }));
        let mut cc = albedo * ambient.as_dvec3() + em;
        let mut colour_sun = None;
        if let Some((dir, e)) = sun {
            // The volume's own transmittance from its centre to its boundary toward the sun.
            let geom = crate::reference::volume::depth(
                &aff,
                v.profile,
                aff.center,
                dir.as_dvec3(),
                f64::INFINITY,
            );
            let tsun = DVec3::from_array([0, 1, 2].map(|i| (-(sigma[i] as f64) * geom).exp()));
            let k = albedo * e.as_dvec3() * tsun;
            match v.phase {
                Phase::Isotropic => cc += k / (4.0 * core::f64::consts::PI),
                p => {
                    if k.max_element() > 0.0 {
                        colour_sun = Some((p, k.as_vec3().to_array()));
                    }
                }
            }
        }
        let colour_const = cc.as_vec3().to_array();
        for (i, c) in colour_const.iter().enumerate() {
            if !c.is_finite() {
                return Err(SceneError::NonFinite {
                    field: f(&format!("fog colour[{i}]")),
                    value: *c,
                });
            }
        }
        set.additive
            .push(plan_geom(sigma, colour_const, colour_sun));
    }
    // Centre offsets to every cut-out, in f64 from the f32 centres, rounded once.
    let centres: Vec<DVec3> = set
        .cuts
        .iter()
        .map(|c| Vec3::from_array(c.center).as_dvec3())
        .collect();
    for a in &mut set.additive {
        let ca = Vec3::from_array(a.center).as_dvec3();
        a.cut_offsets = centres
            .iter()
            .map(|cc| (ca - *cc).as_vec3().to_array())
            .collect();
    }
    Ok(set)
}
