//! Distance fog: Bevy's falloff modes (linear, exponential, exponential squared,
//! atmospheric) as media along the ray, so that they combine with height fog and volumes
//! by adding optical depths.
//!
//! Each mode is a cumulative optical depth F(s) of the distance s from the camera (Bevy's
//! fog intensity is 1 − e^(−F(s))); over the integrated interval [s_a, s_b] (the whole ray,
//! or what the scene's start and cutoff distances leave of it) the optical depth is
//! F(s_b) − F(s_a):
//!
//! ```text
//! exponential          F = k·s                 τ = k·len
//! exponential squared  F = (k·s)²              τ = k²·len·(len + 2·s_a)
//! atmospheric          F = β_ext·s (RGB)       τ = β_ext·len;  in-scattering c·(1 − e^(−β_ins·len))
//! linear               e^(−F) = clamp((end − s)/(end − start), 0, 1)
//!                      T = e^(−F(s_b)) / e^(−F(s_a)),  τ = −ln T  (+∞ beyond `end`)
//! ```
//!
//! with len = s_b − s_a. Exponential and atmospheric extinction use the height fog's
//! mantissa/exponent arithmetic (a homogeneous layer: nothing overflows before τ does);
//! the squared form with s_a = 0 squares that pair. Alone, each mode gives exactly Bevy's
//! result (`tests/controls.rs` checks against Bevy's shader formulas in f64).

use crate::error::SceneError;
use crate::math::{exp_neg, expm1, exprel_neg, frexp, ldexp, log, Lane};
use crate::scene::Split;
use glam::Vec3;

/// How distance fog grows with the distance from the camera (Bevy's `FogFalloff`).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "snake_case", deny_unknown_fields)
)]
pub enum Falloff {
    /// No fog before `start`, opaque at `end`; the fog's opacity grows linearly between
    /// (0 ≤ start < end). As a medium its optical depth −ln((end − s)/(end − start)) is
    /// +∞ beyond `end`, so combined with other media everything beyond `end` is fully
    /// fogged and takes this fog's colour.
    Linear {
        /// Where the fog begins: a distance from the camera (the ray's start), ≥ 0.
        start: f32,
        /// Where it becomes opaque, a distance from the camera (> `start`).
        end: f32,
    },
    /// Optical depth `density · distance` (homogeneous fog; density ≥ 0).
    Exponential {
        /// Extinction per unit distance (≥ 0).
        density: f32,
    },
    /// Optical depth `(density · distance)²` (fog that thickens with distance).
    ExponentialSquared {
        /// k in the optical depth (k · distance)², per unit distance (≥ 0).
        density: f32,
    },
    /// Separate extinction and in-scattering (RGB, per unit distance): T = e^(−extinction ·
    /// distance), in-scattered light `colour · (1 − e^(−inscattering · distance))`.
    Atmospheric {
        /// Extinction per unit distance, per channel (≥ 0).
        #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
        extinction: Vec3,
        /// The rate at which the in-scattered light approaches the fog colour, per unit
        /// distance and channel (≥ 0).
        #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
        inscattering: Vec3,
    },
}

impl Falloff {
    /// The contrast threshold of the visibility helpers: 5 %, the revised value of
    /// Koschmieder's 2 % (the one Bevy uses).
    pub const KOSCHMIEDER_CONTRAST: f32 = 0.05;

    /// Koschmieder's extinction coefficient for a visibility distance: the extinction at
    /// which an object `visibility` away keeps `contrast` of its contrast,
    /// `−ln(contrast) / visibility`.
    ///
    /// ```
    /// use analytic_fog::Falloff;
    /// let k = Falloff::koschmieder(100.0, 0.05);
    /// assert!((k - 0.029957).abs() < 1e-6);
    /// ```
    pub fn koschmieder(visibility: f32, contrast: f32) -> f32 {
        (-(contrast as f64).ln() / visibility as f64) as f32
    }

    /// Exponential fog in which objects `visibility` away keep 5 % of their contrast.
    ///
    /// ```
    /// use analytic_fog::Falloff;
    /// let Falloff::Exponential { density } = Falloff::from_visibility(500.0) else {
    ///     unreachable!()
    /// };
    /// // e^(−density · 500) = 0.05
    /// assert!(((-density * 500.0).exp() - 0.05).abs() < 1e-6);
    /// ```
    pub fn from_visibility(visibility: f32) -> Falloff {
        Falloff::from_visibility_contrast(visibility, Self::KOSCHMIEDER_CONTRAST)
    }

    /// Exponential fog with a chosen contrast threshold.
    pub fn from_visibility_contrast(visibility: f32, contrast: f32) -> Falloff {
        Falloff::Exponential {
            density: Falloff::koschmieder(visibility, contrast),
        }
    }

    /// Exponential-squared fog in which objects `visibility` away keep 5 % of their
    /// contrast: `density = √(−ln 0.05) / visibility`.
    pub fn from_visibility_squared(visibility: f32) -> Falloff {
        Falloff::from_visibility_squared_contrast(visibility, Self::KOSCHMIEDER_CONTRAST)
    }

    /// Exponential-squared fog with a chosen contrast threshold.
    pub fn from_visibility_squared_contrast(visibility: f32, contrast: f32) -> Falloff {
        Falloff::ExponentialSquared {
            density: ((-(contrast as f64).ln()).sqrt() / visibility as f64) as f32,
        }
    }

    /// Atmospheric fog with one colour for extinction and in-scattering (see
    /// [`Falloff::from_visibility_colours`]).
    pub fn from_visibility_colour(visibility: f32, colour: Vec3) -> Falloff {
        Falloff::from_visibility_colours(visibility, colour, colour)
    }

    /// Atmospheric fog from a visibility distance and two colours, as Bevy defines it:
    /// extinction `(1 − extinction_colour)^e · k`, in-scattering `inscattering_colour^e · k`
    /// with `k` Koschmieder's coefficient at 5 % contrast (the colours in [0, 1]: an
    /// extinction colour of white, or an in-scattering colour of black, turns that part
    /// off).
    pub fn from_visibility_colours(
        visibility: f32,
        extinction_colour: Vec3,
        inscattering_colour: Vec3,
    ) -> Falloff {
        Falloff::from_visibility_contrast_colours(
            visibility,
            Self::KOSCHMIEDER_CONTRAST,
            extinction_colour,
            inscattering_colour,
        )
    }

    /// [`Falloff::from_visibility_colours`] with a chosen contrast threshold.
    pub fn from_visibility_contrast_colours(
        visibility: f32,
        contrast: f32,
        extinction_colour: Vec3,
        inscattering_colour: Vec3,
    ) -> Falloff {
        let k = Falloff::koschmieder(visibility, contrast);
        let e = core::f32::consts::E;
        let pow = |c: Vec3| Vec3::new(c.x.powf(e), c.y.powf(e), c.z.powf(e));
        Falloff::Atmospheric {
            extinction: pow(Vec3::ONE - extinction_colour) * k,
            inscattering: pow(inscattering_colour) * k,
        }
    }
}

/// Distance fog: a falloff and the fog's colour (the in-scattered radiance of an opaque
/// fog, RGB). Set as [`SceneDesc::distance_fog`](crate::SceneDesc::distance_fog).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct DistanceFog {
    /// How the fog's optical depth grows with distance.
    pub falloff: Falloff,
    /// The in-scattered radiance of an opaque fog (RGB, ≥ 0).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
    pub colour: Vec3,
}

/// The compiled falloff.
#[derive(Clone, Copy, Debug)]
pub(crate) enum DistancePlan {
    /// `1 / (end − start)` rounded once.
    Linear {
        start: f32,
        end: f32,
    },
    /// Extinction per channel (exponential fog: the density in all three).
    Extinction {
        sigma: [Split; 3],
    },
    Squared {
        k: Split,
    },
    Atmospheric {
        sigma: [Split; 3],
        insc: [f32; 3],
    },
}

/// A distance fog ready for the kernel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct DistanceFogPlan {
    pub plan: DistancePlan,
    pub colour: [f32; 3],
}

fn nonneg(field: &str, v: f32) -> Result<f32, SceneError> {
    if !v.is_finite() {
        return Err(SceneError::NonFinite {
            field: field.to_string(),
            value: v,
        });
    }
    if v < 0.0 {
        return Err(SceneError::Negative {
            field: field.to_string(),
            value: v,
        });
    }
    Ok(v)
}

fn nonneg3(field: &str, v: Vec3) -> Result<[f32; 3], SceneError> {
    let mut out = [0.0; 3];
    for i in 0..3 {
        out[i] = nonneg(&format!("{field}[{i}]"), v[i])?;
    }
    Ok(out)
}

/// Validates and compiles a distance fog. `None` when it cannot change any ray (zero
/// density or extinction and in-scattering).
pub(crate) fn compile(fog: &DistanceFog) -> Result<Option<DistanceFogPlan>, SceneError> {
    let colour = nonneg3("distance_fog.colour", fog.colour)?;
    let plan = match fog.falloff {
        Falloff::Linear { start, end } => {
            let start = nonneg("distance_fog.falloff.linear.start", start)?;
            let end = nonneg("distance_fog.falloff.linear.end", end)?;
            if end <= start {
                return Err(SceneError::OutOfRange {
                    field: "distance_fog.falloff.linear.end".into(),
                    value: end,
                    range: "(start, +inf)",
                });
            }
            DistancePlan::Linear { start, end }
        }
        Falloff::Exponential { density } => {
            let k = nonneg("distance_fog.falloff.exponential.density", density)?;
            if k == 0.0 {
                return Ok(None);
            }
            DistancePlan::Extinction {
                sigma: [Split::of(k); 3],
            }
        }
        Falloff::ExponentialSquared { density } => {
            let k = nonneg("distance_fog.falloff.exponential_squared.density", density)?;
            if k == 0.0 {
                return Ok(None);
            }
            DistancePlan::Squared { k: Split::of(k) }
        }
        Falloff::Atmospheric {
            extinction,
            inscattering,
        } => {
            let e = nonneg3("distance_fog.falloff.atmospheric.extinction", extinction)?;
            let i = nonneg3(
                "distance_fog.falloff.atmospheric.inscattering",
                inscattering,
            )?;
            if e.iter().chain(&i).all(|&x| x == 0.0) {
                return Ok(None);
            }
            DistancePlan::Atmospheric {
                sigma: e.map(Split::of),
                insc: i,
            }
        }
    };
    Ok(Some(DistanceFogPlan { plan, colour }))
}

impl DistanceFogPlan {
    pub(crate) fn is_linear(&self) -> bool {
        matches!(self.plan, DistancePlan::Linear { .. })
    }
}

/// The τ-weighted mix of colour `a` (optical depth `tau_a`) and `b` (`tau_b`), with the
/// weights capped at τ = 1e30 so that they stay finite (two infinite depths weigh the
/// same). Returns `b`'s weight and the mix; a colour `b` = 0 gives `a`'s share alone.
#[inline(always)]
pub(crate) fn mix<L: Lane>(a: L, tau_a: L, b: L, tau_b: L) -> (L, L) {
    let cap = L::splat(1e30);
    let zero = L::splat(0.0);
    let ta = cap.min(tau_a);
    let tb = cap.min(tau_b);
    let sum = ta + tb;
    let wb = L::select(sum.gt(zero), tb / sum, zero);
    (wb, wb.mul_add(b - a, a))
}

/// The distance fog of one packet.
pub(crate) struct DistanceOut<L> {
    /// Optical depth per channel.
    pub tau: [L; 3],
    /// Transmittance per channel (the tier's exponential of `tau`, or, for linear fog,
    /// the ratio of Bevy's factors, which needs no logarithm round trip).
    pub trans: [L; 3],
}

/// The distance fog's optical depth and transmittance over the interval that starts
/// `s_a` from the camera and is `len = len_m · 2^len_e` long (`len_f`: the same length
/// rounded to f32, saturating to +∞). `len_m` is NaN for an invalid ray. `fast`: the
/// tier of its exponentials.
#[inline(always)]
pub(crate) fn depth<L: Lane>(
    fog: &DistanceFogPlan,
    s_a: f32,
    len_m: L,
    len_e: L,
    len_f: L,
    fast: bool,
) -> DistanceOut<L> {
    let zero = L::splat(0.0);
    match &fog.plan {
        DistancePlan::Extinction { sigma } | DistancePlan::Atmospheric { sigma, .. } => {
            let tau = rgb!(ch => {
                let s = sigma[ch];
                ldexp(len_m * L::splat(s.m), len_e + L::splat(s.e))
            });
            DistanceOut {
                tau,
                trans: rgb!(ch => crate::math::exp_neg_tier(fast, tau[ch])),
            }
        }
        DistancePlan::Squared { k } => {
            let tau = if s_a == 0.0 {
                // (k·len)² from the mantissa/exponent pair: x_m in [2^-23, 8), so x_m² is
                // inside `ldexp`'s precondition.
                let xm = len_m * L::splat(k.m);
                let xe = len_e + L::splat(k.e);
                ldexp(xm * xm, xe + xe)
            } else {
                // k²·len·(len + 2 s_a) = (k·len) · k · 4c with c = len/4 + s_a/2, which
                // cannot overflow for finite len (so no 0 · ∞ from a k·len that
                // underflows next to a sum that overflows: found by fuzz/height_fog);
                // everything as mantissa/exponent pairs, one rounding at the end.
                let c = (len_f * L::splat(0.25) + L::splat(0.5 * s_a)).min(L::splat(f32::MAX));
                let (cm, ce) = frexp(c);
                let m = len_m * L::splat(k.m) * cm * L::splat(k.m);
                let e = len_e + ce + L::splat(2.0 * k.e + 2.0);
                // NaN `len_m` (an invalid ray) stays NaN.
                ldexp(m, e)
            };
            let tau = L::select(len_f.eq(zero), zero, tau);
            DistanceOut {
                tau: [tau; 3],
                trans: [crate::math::exp_neg_tier(fast, tau); 3],
            }
        }
        DistancePlan::Linear { start, end } => {
            // Bevy's factor f(s) = clamp((end − s)/(end − start), 0, 1); over [s_a, s_b],
            // T = f(s_b)/f(s_a) = (end − max(s_b, start)) / (end − max(s_a, start)),
            // clamped to [0, 1]; 0 for a non-empty interval that starts beyond `end`.
            let sb = L::splat(s_a) + len_f;
            let den = *end - s_a.max(*start);
            let t = if den > 0.0 {
                // 1/den overflows for a subnormal den (end − start below 2.9e-39; found by
                // fuzz/height_fog: 0·∞ = NaN at s_b = end): divide there instead.
                let num = L::splat(*end) - sb.max(L::splat(*start));
                let r = 1.0 / den;
                let f = if r.is_finite() {
                    num * L::splat(r)
                } else {
                    num / L::splat(den)
                };
                f.clamp(zero, L::splat(1.0))
            } else {
                L::select(len_f.gt(zero), zero, L::splat(1.0))
            };
            // NaN stays NaN (an invalid ray: `len_m` carries the geometry's guard).
            #[allow(clippy::eq_op)]
            let t = t + zero.min(len_m - len_m);
            let tau = log(t).neg();
            DistanceOut {
                tau: [tau; 3],
                trans: [t; 3],
            }
        }
    }
}

/// `(1 − e^(−x)) / x` for any x ≥ 0 including +∞ (0 there).
#[inline(always)]
fn exprel_any<L: Lane>(x: L) -> L {
    let small = exprel_neg(x.max(L::splat(8.673_617e-19)).min(L::splat(1.0)));
    let large = (L::splat(1.0) - exp_neg(x)) / x;
    L::select(x.lt(L::splat(1.0)), small, large)
}

/// The atmospheric mode's in-scattered radiance for channel `ch`, when its optical depth
/// `tau_d` is part of the total `tau` (transmittance `trans`): alone it is Bevy's
/// `colour · (1 − e^(−β_ins·len))`; combined, that times `W = φ(τ)/φ(τ_d)` with
/// φ(x) = (1 − e^(−x))/x, which is the share the τ-weighted mix gives a medium of
/// optical depth τ_d (W = (τ_d/τ)·(1 − T)/(1 − T_d)), written so that τ_d = 0 and
/// τ_d = +∞ have their limits.
#[inline(always)]
pub(crate) fn atmospheric_inscattering<L: Lane>(
    insc: f32,
    colour: L,
    len_f: L,
    tau_d: L,
    tau: L,
    trans: L,
    w_d: L,
) -> L {
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    // 1 − e^(−β_ins·len) without cancellation; len = +∞ with β_ins = 0 gives 0.
    let x = L::select(len_f.eq(zero), zero, L::splat(insc) * len_f);
    let x = if insc == 0.0 { zero } else { x };
    let gain = expm1(x.neg()).neg();
    // τ_d ≥ 1: (τ_d/τ) from the capped weights, 1 − T_d ≥ 0.63.
    let big = w_d * (one - trans) / (one - exp_neg(tau_d));
    let small = exprel_any(tau) / exprel_any(tau_d);
    let w = L::select(tau_d.ge(one), big, small);
    colour * gain * w
}
