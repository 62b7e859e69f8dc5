//! Exponential height fog: the optical depth of a ray segment in closed form, stable in
//! f32 for every finite input.
//!
//! For a layer σ(x) = σ0 · exp(−b · (h(x) − h0)) and the segment o + s·d, s in [0, t],
//! with y0 = h(o) − h0, u = dot(d, up), Δ = b·u·t:
//!
//! ```text
//! τ = σ0 · |d| · ∫_0^t exp(−b (y0 + u s)) ds = σ0 · |d| · t · e^(−u_min) · φ(|Δ|)
//! u_min = b·y0 + min(Δ, 0)          (the exponent at the denser end of the segment)
//! φ(x)  = (1 − e^(−x)) / x = −expm1(−x) / x,   φ(0) = 1
//! ```
//!
//! Anchoring at the denser end keeps the exponential ≤ the true integrand's maximum, and
//! `−expm1(−x)/x` neither cancels for small x (no branch on d_up, no Taylor switch) nor
//! overflows for large x. Every factor can still leave the f32 range while τ does not
//! (a density of e^(−1000) at the camera times a segment of 1e30; t·|d| or 1/(b·u)
//! overflowing while σ0 is tiny), so the factors are carried as mantissa × 2^exponent
//! with the exponents added as integer-valued floats, and τ is assembled by one
//! saturating `ldexp` per channel. t = +∞ is the limit t·φ(b·u·t) → 1/|b·u| (or +∞ when
//! the segment does not thin out), which falls out of the same arithmetic.
//!
//! Error: relative error of τ at most 16 · 2⁻²⁴ · (1 + |b·y0| + |Δ|) for an axis-aligned
//! up vector (tested against `reference` in `tests/height_fog.rs`). With a general up
//! vector the height dot(o, up) is rounded relative to |o|, adding |b|·|o|·2⁻²⁴ to the
//! condition.

use crate::math::{exp_split, exprel_neg, frexp, Lane};
use crate::scene::LayerPlan;

/// Per-ray quantities shared by all layers.
#[derive(Clone, Copy)]
pub(crate) struct RayGeom<L> {
    /// Height of the origin along the up axis: dot(o, up).
    pub y: L,
    /// frexp of u = dot(d, up).
    pub u_m: L,
    pub u_e: L,
    /// frexp of t (t = +∞ gives m = 1, e = 1000).
    pub t_m: L,
    pub t_e: L,
    /// |d| = n_m · 2^n_e.
    pub n_m: L,
    pub n_e: L,
    /// +0 for valid rays, NaN where u is not finite or t is NaN or negative; added to the
    /// mantissa so that invalid rays give NaN instead of plausible numbers.
    pub guard: L,
}

/// Exponent given to t = +∞: large enough that b·u·t is beyond any finite product of f32
/// exponents, small enough that sums of such exponents stay exact in f32.
const INF_EXPONENT: f32 = 1000.0;
/// The exponent of Δ is clamped to this before φ is evaluated; beyond it (|Δ| ≥ 256)
/// φ = 1/Δ exactly in f32 and the rest of 1/Δ is carried in the exponent.
const PHI_MAX_EXP: f32 = 8.0;

impl<L: Lane> RayGeom<L> {
    /// `y`: height dot(o, up); `u`: dot(d, up); `t`: segment end; `norm`: (n_m, n_e) of |d|.
    #[inline(always)]
    pub(crate) fn new(y: L, u: L, t: L, norm: (L, L)) -> RayGeom<L> {
        let (u_m, u_e) = frexp(u);
        let (t_m, t_e) = frexp(t);
        let t_e = L::select(t.eq(L::splat(f32::INFINITY)), L::splat(INF_EXPONENT), t_e);
        #[allow(clippy::eq_op)] // u - u is NaN exactly when u is not finite
        let guard = (u - u) + L::select(t.ge(L::splat(0.0)), L::splat(0.0), L::splat(f32::NAN));
        RayGeom {
            y,
            u_m,
            u_e,
            t_m,
            t_e,
            n_m: norm.0,
            n_e: norm.1,
            guard,
        }
    }
}

/// |d| as (mantissa, exponent) without overflow or underflow, and the unit direction
/// (zero for d = 0).
#[inline(always)]
pub(crate) fn direction_norm<L: Lane>(d: [L; 3]) -> ((L, L), [L; 3]) {
    let mx = d[0].abs().max(d[1].abs()).max(d[2].abs());
    // Scale by 2^-e(max) so that the largest component is in [1, 2) (exact).
    // Biased exponent clamped to [1, 253]: subnormal maxima are scaled by 2^126 and the
    // top binade by 2^-126, both exact and both keeping the sum of squares finite.
    let f = mx.exponent_field().clamp(L::splat(1.0), L::splat(253.0));
    let scale = L::pow2i(L::splat(127.0) - f);
    let s = [d[0] * scale, d[1] * scale, d[2] * scale];
    let n_m = s[0].mul_add(s[0], s[1].mul_add(s[1], s[2] * s[2])).sqrt();
    let inv = L::splat(1.0) / n_m.max(L::splat(1e-30));
    let dir = [s[0] * inv, s[1] * inv, s[2] * inv];
    ((n_m, f - L::splat(127.0)), dir)
}

/// The geometric part of one layer's optical depth, G = τ / σ0, as `(m, e)` with
/// G = m · 2^e, |m| in [2^-38, 2^5] or 0: n_m ≥ 2^-23 (subnormal |d|), t_m ≥ 1,
/// φ ≥ 2^-14, e^r ≥ 0.7. Times a channel's mantissa (≥ 2^-16 relative to the largest
/// channel) this stays inside the precondition of [`crate::math::ldexp`].
#[inline(always)]
pub(crate) fn layer_depth<L: Lane>(layer: &LayerPlan, g: &RayGeom<L>) -> (L, L) {
    if layer.b == 0.0 {
        // Homogeneous layer: G = |d| · t.
        return (g.n_m * g.t_m + g.guard, g.n_e + g.t_e);
    }
    // b != 0: b·y0 may be ±inf (|y0| beyond f32), never NaN.
    let a0 = L::splat(layer.b) * (g.y - L::splat(layer.h0));

    // Δ = b·u·t as mantissa (|dm| in [1, 8) or 0) and exponent.
    let dm = L::splat(layer.b_split.m) * g.u_m * g.t_m;
    let de = L::splat(layer.b_split.e) + g.u_e + g.t_e;

    // φ(|Δ|) with |Δ| clamped to < 2^11; the rest of 1/|Δ| goes to the exponent.
    let dc = (dm.abs() * L::pow2i(de.clamp(L::splat(-100.0), L::splat(PHI_MAX_EXP))))
        .max(L::splat(7.888_609e-31)); // 2^-100: φ = 1 below it
    let phi = exprel_neg(dc);
    let phi_e = (L::splat(PHI_MAX_EXP) - de).min(L::splat(0.0));

    // The exponent at the denser end: b·y0 + min(Δ, 0), with Δ clamped to |Δ| < 2^90
    // (finite, so a0 = ±inf gives ±inf, not NaN).
    let dsigned = dm * L::pow2i(de.clamp(L::splat(-126.0), L::splat(87.0)));
    let u_min = a0 + dsigned.min(L::splat(0.0));
    let (em, ek) = exp_split(u_min.neg());

    let m = g.n_m * g.t_m * phi * em + g.guard;
    let e = g.n_e + g.t_e + phi_e + ek;
    (m, e)
}
