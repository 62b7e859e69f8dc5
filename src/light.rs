//! Phase functions and the per-ray fog colour (seed 001, eqs. 11 and 18).
//!
//! The fog colour of a layer is Σ_c β_s,c · (p_c(cos θ) · E_sun + L_amb) / Σ_c β_t,c. The
//! scene compiles the parts that do not depend on the ray (ambient, isotropic components)
//! into one constant per channel, so a scene without sun, or with only isotropic fog,
//! evaluates no phase function at all.

use crate::error::SceneError;
use crate::math::Lane;

/// A phase function p(cos θ), normalized over the sphere (∮ p dΩ = 1).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Phase {
    /// p = 1 / 4π.
    #[default]
    Isotropic,
    /// p = 3 / 16π · (1 + cos²θ).
    Rayleigh,
    /// p = (1 − g²) / (4π · (1 + g² − 2g cos θ)^{3/2}), with −1 < g < 1.
    HenyeyGreenstein(f32),
    /// Cornette–Shanks: p = 3/(8π) · (1 − g²)/(2 + g²) · (1 + cos²θ) /
    /// (1 + g² − 2g cos θ)^{3/2}, with −1 < g < 1 (Henyey–Greenstein's shape with
    /// Rayleigh's (1 + cos²θ), normalized; a better fit of Mie scattering by haze).
    CornetteShanks(f32),
}

impl Phase {
    pub(crate) fn validate(&self, field: &str) -> Result<(), SceneError> {
        let (g, name) = match *self {
            Phase::HenyeyGreenstein(g) => (g, "henyey_greenstein"),
            Phase::CornetteShanks(g) => (g, "cornette_shanks"),
            _ => return Ok(()),
        };
        if !g.is_finite() {
            return Err(SceneError::NonFinite {
                field: format!("{field}.{name}"),
                value: g,
            });
        }
        if !(g > -1.0 && g < 1.0) {
            return Err(SceneError::OutOfRange {
                field: format!("{field}.{name}"),
                value: g,
                range: "(-1, 1)",
            });
        }
        Ok(())
    }

    /// Evaluates the phase function in f64 from cos θ (the reference form).
    pub fn eval_f64(&self, cos_theta: f64) -> f64 {
        use core::f64::consts::PI;
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::Rayleigh => 3.0 / (16.0 * PI) * (1.0 + cos_theta * cos_theta),
            Phase::HenyeyGreenstein(g) => {
                let g = g as f64;
                (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * cos_theta).powf(1.5))
            }
            Phase::CornetteShanks(g) => {
                let g = g as f64;
                3.0 / (8.0 * PI) * (1.0 - g * g) / (2.0 + g * g) * (1.0 + cos_theta * cos_theta)
                    / (1.0 + g * g - 2.0 * g * cos_theta).powf(1.5)
            }
        }
    }

    /// Evaluates the phase function for unit vectors `v` (view direction) and `s` (toward
    /// the sun), lane-wise (see [`PhaseEval`]).
    #[inline(always)]
    pub(crate) fn eval<L: Lane>(&self, v: [L; 3], s: [f32; 3]) -> L {
        PhaseEval::new(*self, s).eval(v)
    }
}

/// A phase function with its constants for one sun direction computed once (per scene or
/// batch, not per packet): the numerator, and for Henyey–Greenstein and Cornette–Shanks
/// the terms of the denominator.
///
/// Henyey–Greenstein's denominator 1 + g² − 2g·cos θ cancels for |g| → 1 near the peak;
/// it is computed as (1 − g)² + g·|v − s|² (g ≥ 0) or (1 + g)² − g·|v + s|² (g < 0),
/// where every term is non-negative, so the peak (p ≈ 1584 for g = 0.99) keeps full
/// relative precision.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PhaseEval {
    /// 0 isotropic, 1 Rayleigh, 2 Henyey–Greenstein, 3 Cornette–Shanks (the `KIND` of
    /// [`Self::eval_kind`]).
    pub(crate) kind: u8,
    num: f32,
    /// (1 ∓ g)², |g|, and ∓s: the denominator is (base + gg·|v ∓ s|²)^{3/2}.
    base: f32,
    gg: f32,
    ws: [f32; 3],
    s: [f32; 3],
}

impl PhaseEval {
    pub(crate) fn new(phase: Phase, s: [f32; 3]) -> PhaseEval {
        use core::f32::consts::PI;
        let (kind, num, g) = match phase {
            Phase::Isotropic => (0, 1.0 / (4.0 * PI), 0.0),
            Phase::Rayleigh => (1, 3.0 / (16.0 * PI), 0.0),
            Phase::HenyeyGreenstein(g) => (2, (1.0 - g) * (1.0 + g) / (4.0 * PI), g),
            Phase::CornetteShanks(g) => (
                3,
                3.0 / (8.0 * PI) * (1.0 - g) * (1.0 + g) / (2.0 + g * g),
                g,
            ),
        };
        let (base, gg, sign) = if g >= 0.0 {
            ((1.0 - g) * (1.0 - g), g, -1.0)
        } else {
            ((1.0 + g) * (1.0 + g), -g, 1.0)
        };
        PhaseEval {
            kind,
            num,
            base,
            gg,
            ws: s.map(|c| sign * c),
            s,
        }
    }

    /// p(cos θ) for the unit view direction `v`, lane-wise.
    #[inline(always)]
    pub(crate) fn eval<L: Lane>(&self, v: [L; 3]) -> L {
        match self.kind {
            0 => self.eval_kind::<L, 0>(v),
            1 => self.eval_kind::<L, 1>(v),
            2 => self.eval_kind::<L, 2>(v),
            _ => self.eval_kind::<L, 3>(v),
        }
    }

    /// [`Self::eval`] for a phase function whose `kind` is `KIND` (a batch loop can
    /// choose it once instead of per packet).
    #[inline(always)]
    pub(crate) fn eval_kind<L: Lane, const KIND: u8>(&self, v: [L; 3]) -> L {
        match KIND {
            0 => L::splat(self.num),
            1 => {
                let c = dot3(v, self.s);
                c.mul_add(c, L::splat(1.0)) * L::splat(self.num)
            }
            2 => L::splat(self.num) / self.denominator(v),
            _ => {
                let c = dot3(v, self.s);
                (L::splat(self.num) * c.mul_add(c, L::splat(1.0))) / self.denominator(v)
            }
        }
    }

    /// (1 + g² − 2g·cos θ)^{3/2} without cancellation.
    #[inline(always)]
    fn denominator<L: Lane>(&self, v: [L; 3]) -> L {
        // |v ∓ s|²
        let w0 = v[0] + L::splat(self.ws[0]);
        let w1 = v[1] + L::splat(self.ws[1]);
        let w2 = v[2] + L::splat(self.ws[2]);
        let w = w0.mul_add(w0, w1.mul_add(w1, w2 * w2));
        let q = w.mul_add(L::splat(self.gg), L::splat(self.base));
        q * q.sqrt()
    }
}

#[inline(always)]
pub(crate) fn dot3<L: Lane>(v: [L; 3], s: [f32; 3]) -> L {
    v[0].mul_add(
        L::splat(s[0]),
        v[1].mul_add(L::splat(s[1]), v[2] * L::splat(s[2])),
    )
}

/// A directional in-scattering lobe around the sun, next to the physical phase functions
/// (Unreal's directional inscattering, Bevy's directional light colour, Inigo Quilez's
/// sun-coloured fog): `colour · max(cos θ, 0)^exponent` is added to the fog colour of the
/// height fog layers and of the distance fog (not to volumes, which have their own
/// shading), θ the angle between the view direction and the sun. Needs `lighting.sun`
/// (for its direction; the lobe's colour is its own).
///
/// Accuracy: `exp(−exponent · (−ln c))` with the crate's `log` and `exp_neg` (1 ULP
/// each): relative error ≤ (3 + exponent·|ln c|) · 2⁻²⁴ for the computed c = cos θ, whose
/// own rounding (a few ULP of the dot product) is the condition of the lobe (relative
/// change exponent · Δc / c).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Lobe {
    /// The lobe's colour (RGB radiance at its peak, looking straight at the sun).
    #[cfg_attr(feature = "serde", serde(with = "crate::serde_rgb"))]
    pub colour: glam::Vec3,
    /// The sharpness (> 0; Unreal's default is 4, Bevy's 8).
    pub exponent: f32,
}

/// A compiled [`Lobe`].
#[derive(Clone, Copy, Debug)]
pub(crate) struct LobePlan {
    pub colour: [f32; 3],
    pub exponent: f32,
}

impl Lobe {
    /// Validates the lobe; `None` when it adds nothing (a black colour).
    pub(crate) fn compile(&self, field: &str) -> Result<Option<LobePlan>, SceneError> {
        let mut colour = [0.0; 3];
        for i in 0..3 {
            let v = self.colour[i];
            let f = format!("{field}.colour[{i}]");
            if !v.is_finite() {
                return Err(SceneError::NonFinite { field: f, value: v });
            }
            if v < 0.0 {
                return Err(SceneError::Negative { field: f, value: v });
            }
            colour[i] = v;
        }
        let n = self.exponent;
        if !n.is_finite() {
            return Err(SceneError::NonFinite {
                field: format!("{field}.exponent"),
                value: n,
            });
        }
        if n <= 0.0 {
            return Err(SceneError::OutOfRange {
                field: format!("{field}.exponent"),
                value: n,
                range: "(0, +inf)",
            });
        }
        Ok((colour != [0.0; 3]).then_some(LobePlan {
            colour,
            exponent: n,
        }))
    }
}

impl LobePlan {
    /// max(cos θ, 0)^exponent for unit `v` and `s`, lane-wise (0 behind the sun's plane).
    #[inline(always)]
    pub(crate) fn weight<L: Lane>(&self, v: [L; 3], s: [f32; 3]) -> L {
        let c = dot3(v, s).clamp(L::splat(0.0), L::splat(1.0));
        // c^n = e^(−n·(−ln c)); ln 0 = −inf gives e^(−inf) = 0.
        let x = crate::math::log(c).neg() * L::splat(self.exponent);
        crate::math::exp_neg(x)
    }
}
