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
//! The one-layer kernels (`kernel::Single`) run the same arithmetic in base 2: with b
//! and σ0 multiplied by log2(e) ([`LayerCore::base2`], rounded once each from f64), Δ
//! and u_min arrive multiplied by log2(e), and G₂ = m·φ₂(|Δ₂|)·2^(−u_min₂), with
//! φ₂(x) = (1 − 2^(−x))/x (`exprel2_neg`) and 2^y (`exp2_split`), is G/log2(e): neither
//! exponential multiplies by log2(e) nor needs a Cody–Waite split (`B2` below; the
//! several-media kernel keeps base e). The two roundings add at most about
//! 2⁻²⁴·(2 + |b·y0| + |Δ|) to the relative error of τ (σ's directly; b's through
//! u_min, and through φ, whose relative change is at most Δ's), inside the bound below.
//!
//! Error: relative error of τ at most 16 · 2⁻²⁴ · (1 + |b·y0| + |Δ|) for an axis-aligned
//! up vector, tested against the independent f64 reference (`reference::check_sample`,
//! `tests/height_fog.rs`, `tests/extreme.rs`). With a general up vector the f32 rounding
//! of up moves the height dot(o, up) by up to ~|o|·2⁻²⁴ and u = dot(d, up) by ~|d|·2⁻²⁴;
//! the tests treat that as a perturbation of the input (`reference::tau_interval`), since
//! near u = 0 it can flip the sign of u. Subnormal τ is accurate to 2⁻¹⁴⁹ per layer, not
//! relatively. No class of finite input is outside the bound: until the sixty-fourth
//! session heights with |b·(h(o) − h0)| ≥ 2^191 were (both terms of the dense-end exponent
//! beyond the scaled f32 range, so that τ could saturate to +∞ where it is 0, or the
//! reverse); `depth_args_of` now sums them again at a second scale there.

use crate::math::{
    exp2_split, exp2_split_fast, exp_split, exp_split_fast, exprel2_neg, exprel2_neg_fast,
    exprel_neg, exprel_neg_fast, Lane,
};
use crate::scene::LayerCore;

/// Per-ray quantities shared by all layers.
#[derive(Clone, Copy)]
pub(crate) struct RayGeom<L> {
    /// Height of the origin along the up axis: dot(o, up) (±inf where that overflows).
    pub y: L,
    /// dot(o, up) · 2^-64, which does not overflow (along an axis, +0 for heights below
    /// 2^-62, which would be subnormal at that scale: `kernel::height_scaled`).
    pub y_s: L,
    /// frexp of u = dot(d, up) (u = 0 gives e = U_ZERO_EXPONENT + u_shift).
    pub u_m: L,
    pub u_e: L,
    /// frexp of t (t = +∞ gives m = 1, e = INF_EXPONENT; t = ±0 gives m = +0). The
    /// mantissa is NaN where t is negative or NaN ([`Lane::frexp_clamped_nonneg`]): every
    /// optical depth is formed with it as a factor, so it carries the invalid t's NaN that
    /// `guard` does not (a caller that replaces t_m keeps that NaN in the guard).
    pub t_m: L,
    pub t_e: L,
    /// |d| = n_m · 2^n_e.
    pub n_m: L,
    pub n_e: L,
    /// +0 for valid rays, NaN where u, the height or |d| is not finite (an invalid t is
    /// `t_m`'s NaN); added to the mantissa so that invalid rays give NaN instead of
    /// plausible numbers.
    pub guard: L,
}

/// Exponent given to t = +∞: large enough that b·u·t is beyond any finite product of f32
/// exponents, and that t·e^(−u_min) overflows for every u_min that `exp_split` can see
/// (|u_min| ≤ 2^20, i.e. e^(−u_min) ≥ 2^-1.52e6) when u = 0: a horizontal ray to infinity
/// gathers τ = +∞ however thin the fog at its height (found by `tests/extreme.rs`: with
/// 1000 here, a camera 1e4 above the fog looking horizontally gave τ = 0). Small enough
/// that sums of such exponents stay exact in f32 (< 2^24).
const INF_EXPONENT: f32 = 2_097_152.0; // 2^21
/// Exponent given to u = 0 (frexp gives −151): far enough below every other exponent that
/// Δ = b·u·t has an exponent below PHI_MAX_EXP even for t = +∞, so φ = 1 and no part of
/// 1/Δ is moved into the exponent (found by `tests/extreme.rs`: with −151, b = 1e10,
/// u = 0, t = 3e38 gave τ/2, and t = +∞ a finite τ).
const U_ZERO_EXPONENT: f32 = -8_388_608.0; // -2^23
/// 2^40, 2^-64 and 2^64: the scaling of the dense-end exponent (see `layer_depth`).
const TWO40: f32 = 1_099_511_627_776.0;
pub(crate) const TWO_M64: f32 = 5.421_010_862_427_522e-20;
const TWO64: f32 = 18_446_744_073_709_551_616.0;
/// 2^96: the far sum of [`depth_args_of`]'s KIND 2 is scaled back by it twice.
const TWO96: f32 = 79_228_162_514_264_337_593_543_950_336.0;
/// The exponent of Δ is clamped to this before φ is evaluated; beyond it (|Δ| ≥ 256)
/// φ = 1/Δ exactly in f32 and the rest of 1/Δ is carried in the exponent.
const PHI_MAX_EXP: f32 = 8.0;

impl<L: Lane> RayGeom<L> {
    /// `y`: height dot(o, up); `y_s`: dot(o, up) · 2^-64; `u · 2^u_shift`: dot(d, up);
    /// `t`: segment end; `norm`: (n_m, n_e) of |d|.
    #[inline(always)]
    pub(crate) fn new(y: L, y_s: L, u: L, u_shift: L, t: L, norm: (L, L)) -> RayGeom<L> {
        // `frexp_clamped` (on AVX-512 two instructions clamp getexp's ±inf): the guard
        // below and t_m's NaN make every output of a ray with a non-finite u or an
        // invalid t NaN, and t = +∞ gets its own exponent (t = −inf too: its mantissa is
        // NaN), u = 0 U_ZERO_EXPONENT +
        // u_shift (|u_shift| ≤ 2^8: still far below every other exponent, so the same
        // results as U_ZERO_EXPONENT itself). Every exponent stays finite, so that the
        // guard's NaN survives `ldexp` (`vscalefps` in AVX-512 builds gives a number for
        // NaN · 2^±inf).
        let (u_m, u_e) = u.frexp_clamped(U_ZERO_EXPONENT, 128.0);
        let u_e = u_e + u_shift;
        let (t_m, t_e) = t.frexp_clamped_nonneg(-151.0, INF_EXPONENT);
        // u − u is NaN exactly when u is not finite, y_s − y_s when the origin's height is
        // not (NaN or ±inf in a component of o that the height reads; y_s cannot overflow
        // for a finite o), and (u − u)·n_m when |d| is not either (±inf in any component
        // of d: 0·∞). Without the last two (found by fuzz/height_fog) invalid rays gave
        // plausible numbers: for a NaN or infinite height a finite τ in a homogeneous
        // layer (b = 0 never reads it), τ = 0 for |b| > 2^40 (`layer_depth`'s `min` drops
        // a NaN), and the limits τ = +inf or 0 for a height of ±inf; for an infinite
        // component of d off the up axis, τ = +inf. One FMA joins the terms (unit
        // directions, n_m = 1: one add). A negative or NaN t needs no term: t_m is NaN
        // there (on AVX-512 lanes at no cost; a compare and a blend took two instructions
        // per packet).
        #[allow(clippy::eq_op)]
        let guard = (u - u).mul_add(norm.0, y_s - y_s);
        RayGeom {
            y,
            y_s,
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
///
/// `FAST`: the Fast tier's φ and exponential (`math::fast`, relative errors 3.4e-5 and
/// 1.4e-5 instead of 1.7 and 0.95 ULP); the range handling is the same.
///
/// In two halves, [`depth_args`] (exponent arithmetic) and [`depth_of`] (the two
/// exponentials), so that a batch loop can run each over a block of packets.
#[inline(always)]
pub(crate) fn layer_depth<L: Lane, const FAST: bool>(layer: &LayerCore, g: &RayGeom<L>) -> (L, L) {
    depth_of::<L, FAST, false>(layer, depth_args(layer, g))
}

/// The arguments of the two exponentials of [`layer_depth`], and the factors that do
/// not depend on them.
#[derive(Clone, Copy)]
pub(crate) struct DepthArgs<L> {
    /// |Δ| clamped to [2^-60, 2^11), the argument of φ.
    dc: L,
    /// Minus the exponent at the denser end, −u_min (e^(−u_min) is the density there),
    /// negated where it is formed (× −2^64), which is exact, so that `exp_split` needs no
    /// negation.
    neg_u_min: L,
    /// n_m · t_m + the ray's guard (NaN for an invalid ray: G = m·φ·e^(−u_min) is NaN
    /// with it, with no add of the guard in the density stage).
    m: L,
    /// n_e + t_e + the exponent of φ's remainder (n_e + t_e for a homogeneous layer).
    e: L,
}

impl<L: Lane> DepthArgs<L> {
    /// All zero (a placeholder for buffers).
    #[inline(always)]
    pub(crate) fn zero() -> Self {
        let z = L::splat(0.0);
        DepthArgs {
            dc: z,
            neg_u_min: z,
            m: z,
            e: z,
        }
    }
}

/// How [`depth_args`] treats a layer's falloff: 0 homogeneous (b = 0), 1 for
/// 0 < |b| ≤ 2^40, 2 beyond (see the comment on `a0s`).
#[inline(always)]
pub(crate) fn falloff_kind(layer: &LayerCore) -> u8 {
    if layer.b == 0.0 {
        0
    } else if layer.b.abs() <= TWO40 {
        1
    } else {
        2
    }
}

/// The first half of [`layer_depth`].
#[inline(always)]
pub(crate) fn depth_args<L: Lane>(layer: &LayerCore, g: &RayGeom<L>) -> DepthArgs<L> {
    match falloff_kind(layer) {
        0 => depth_args_of::<L, 0>(layer, g),
        1 => depth_args_of::<L, 1>(layer, g),
        _ => depth_args_of::<L, 2>(layer, g),
    }
}

/// [`depth_args`] for a layer whose [`falloff_kind`] is `KIND` (a batch loop can choose
/// the kind once instead of per packet).
#[inline(always)]
pub(crate) fn depth_args_of<L: Lane, const KIND: u8>(
    layer: &LayerCore,
    g: &RayGeom<L>,
) -> DepthArgs<L> {
    let zero = L::splat(0.0);
    if KIND == 0 {
        // Homogeneous layer: G = |d| · t.
        return DepthArgs {
            dc: zero,
            neg_u_min: zero,
            m: g.n_m.mul_add(g.t_m, g.guard),
            e: g.n_e + g.t_e,
        };
    }
    // Δ = b·u·t as mantissa (|dm| in [1, 8) or 0) and exponent.
    let dm = L::splat(layer.b_split.m) * g.u_m * g.t_m;
    let de = L::splat(layer.b_split.e) + g.u_e + g.t_e;

    // φ(|Δ|) with |Δ| clamped to < 2^11; the rest of 1/|Δ| goes to the exponent.
    // Below 2^-60, φ = 1 in f32; clamping there (not lower) keeps every intermediate of
    // `exprel_neg` normal, so tiny falloffs run as fast as typical ones (subnormal
    // arithmetic has a penalty on many CPUs).
    let dc = if L::NATIVE_SCALE {
        // The same values: below 2^-100 both end at the max (clamped there so that
        // `vscalefps` never forms a subnormal: a microcode assist of ~200 cycles on Intel).
        dm.abs()
            .scale2(de.clamp(L::splat(-100.0), L::splat(PHI_MAX_EXP)))
    } else {
        dm.abs() * L::pow2i(de.clamp(L::splat(-100.0), L::splat(PHI_MAX_EXP)))
    }
    .max(L::splat(8.673_617e-19)); // 2^-60

    // Δ·2^-64. `pow2i` needs its exponent clamped; `scale2` saturates by itself, and the
    // unclamped value gives the same bits: beyond 2^127 a negative Δ·2^-64 outweighs
    // any a0s (≤ 1.7e38) by more than 2^-64·f32::MAX, so u_min is −∞ either way. Below
    // (|Δ| < 2^-59, exponent below −62) both clamp to dm·2^-126, never subnormal (a
    // subnormal product or `vscalefps` result costs a microcode assist of ~200 cycles on
    // Intel: `examples/speedscan.rs`, `short_1e-30`); a term that small moves neither
    // sum below: where |a0| ≥ 2^-34 half an ulp of it is at least 2^-58, and elsewhere
    // |u_min| < 2^-33, where the exponential is exactly (1, ±0) either way.
    // (Δ itself, for KIND 1's plain sum below: `vscalefps` forms it from the clamped
    // exponent directly, the scaled Δ then only where the scaled sum is needed.)
    let de_c = de.max(L::splat(-62.0));
    let ds = if L::NATIVE_SCALE {
        dm.scale2(de_c - L::splat(64.0))
    } else {
        dm * L::pow2i((de - L::splat(64.0)).clamp(L::splat(-126.0), L::splat(127.0)))
    };
    // The exponent at the denser end, u_min = b·y0 + min(Δ, 0).
    //
    // KIND 1 (|b| ≤ 2^40): in plain f32, −u_min = (−b)·(y − h0) − min(Δ, 0) with Δ = ds·2^64
    // (exact, or ±∞ beyond f32::MAX), the operations of `depth_args_tame`, so the two
    // paths give the same bits wherever both apply. Every term is either normal, zero,
    // or one of the harmless clamped tiny Δ above: no subnormal arithmetic (the height
    // formed at 2^-64 scale, as before, was subnormal below 2^-62 and cost assists on
    // every ray of a camera within 2e-19 of the base: `camera_1e-19` 11× the time of
    // typical data on the Intel Xeon, forty-sixth session). Saturation is right where
    // only one term is infinite: b·y0 overflows only beyond 2^128 > |Δ| (finite Δ), and
    // Δ = ±∞ outweighs any finite b·y0. Two lane kinds take the scaled sum below
    // instead: y − h0 beyond f32::MAX (a finite height with |b| < 1 whose b·y0 does not
    // outweigh Δ) and ∞ − ∞ (NaN), where both terms saturate.
    //
    // The scaled sum (KIND 2, and those lanes of KIND 1): in units of 2^-64 so that
    // neither term saturates before their sum does: |b·y0| reaches 2^256 and |Δ|
    // 2^(2^21) (t = +∞). With both terms clamped to a common bound (as before), a camera
    // far on the thin side looking into denser fog got the sign of u_min wrong
    // (`tests/extreme.rs`: b = 1e30, camera 2 above the base looking down gave τ = 0,
    // not +∞), and y − h0 overflowed for heights beyond ±1.7e38 (wrong for tiny b).
    // The 2^-64 goes, per layer, to y0 where |b| ≤ 2^40 (y0·2^-64, from the height formed
    // at that scale, `RayGeom::y_s`, cannot overflow, and b·y0·2^-64 neither) and to b
    // otherwise (b·2^-64 is exact; a0·2^-64 overflows only beyond 2^191, and the min
    // keeps +inf + (−inf) from giving NaN; where the sum saturates, a second sum at
    // 2^-192 decides, below). The sum times 2^64 saturates to ±inf, which `exp_split`
    // clamps.
    let neg_u_min = if KIND == 1 {
        let y0 = g.y - L::splat(layer.h0);
        let delta = if L::NATIVE_SCALE {
            dm.scale2(de_c)
        } else {
            ds * L::splat(TWO64)
        };
        let plain = height_term(layer, y0) - delta.min(L::splat(0.0));
        // NaN exactly on the lanes for the scaled sum (y0·0 is NaN where y0 is ±∞ or
        // NaN): one compare.
        let check = y0.mul_add(L::splat(0.0), plain);
        #[allow(clippy::eq_op)]
        let bad = !check.eq(check);
        if L::any(bad) {
            let a0s = L::splat(layer.b) * (g.y_s - L::splat(layer.h0 * TWO_M64));
            L::select(bad, (a0s + ds.min(L::splat(0.0))) * L::splat(-TWO64), plain)
        } else {
            plain
        }
    } else {
        let a0s = (L::splat(layer.b * TWO_M64) * (g.y - L::splat(layer.h0))).min(L::splat(1.7e38));
        let scaled = (a0s + ds.min(L::splat(0.0))) * L::splat(-TWO64);
        // Where that saturates, a term may have saturated first: a positive b·y0 beyond
        // 2^192 (or with y − h0 beyond f32::MAX) is held at 1.7e38·2^64 and loses to a
        // negative Δ of any size, and a Δ beyond 2^192 wins against any b·y0, though
        // which term is larger decides between τ = 0 and τ = +∞ (the `height_fog` fuzz
        // target: b = −1.2e35, camera 1.3e36 below the base, Δ = −3.5e61 gave τ = +∞
        // for u_min = 1.6e71; `tests/extreme.rs`, "both terms huge"). Those lanes take the
        // sum again at 2^-192, where neither term saturates before it outweighs the
        // other: |b·2^-128| ≤ 1 times |y0·2^-64| < 2^65, and Δ·2^-192 saturates only
        // beyond 2^320 > |b·y0|. That sum is used only where the first one is not
        // finite, so |u_min| is beyond 2^128 there or, where the terms cancel, within
        // their rounding (2^-24 of each), as the condition allows; Δ below 2^66 is
        // taken as 2^66·dm (normal at that scale: it moves no sum with a term beyond 2^168).
        let sat = !scaled.abs().le(L::splat(f32::MAX));
        if L::any(sat) {
            // (b·2^-128 in two exact steps: 2^-128 itself is subnormal.)
            let b_t = layer.b * TWO_M64 * TWO_M64;
            let a0t = L::splat(b_t) * (g.y_s - L::splat(layer.h0 * TWO_M64));
            let dt = if L::NATIVE_SCALE {
                dm.scale2(de.max(L::splat(66.0)) - L::splat(192.0))
            } else {
                dm * L::pow2i((de - L::splat(192.0)).clamp(L::splat(-126.0), L::splat(127.0)))
            };
            let far = (a0t + dt.min(L::splat(0.0))) * L::splat(-TWO96) * L::splat(TWO96);
            L::select(sat, far, scaled)
        } else {
            scaled
        }
    };
    // The exponent of G: n_e + t_e + min(PHI_MAX_EXP − de, 0), the part of 1/|Δ| that φ's
    // clamped argument leaves out, formed as n_e + min((PHI_MAX_EXP − b_e) − u_e, t_e)
    // (de = b_e + u_e + t_e): one instruction fewer, the same value, since every term
    // is an integer below 2^24 in magnitude, so every sum is exact.
    let e_phi = (L::splat(PHI_MAX_EXP - layer.b_split.e) - g.u_e).min(g.t_e);
    DepthArgs {
        dc,
        neg_u_min,
        // m + the guard: the same bits as n_m·t_m for a valid ray (guard +0; n_m·t_m ≥ +0).
        m: g.n_m.mul_add(g.t_m, g.guard),
        e: g.n_e + e_phi,
    }
}

/// −b·y0 for a layer of [`falloff_kind`] 1, in plain f32 (±∞ beyond f32::MAX), with
/// heights |y0| below 2^-100/|b| taken as 0: |b·y0| below 2^-100 would be formed
/// subnormal (a microcode assist of ~200 cycles per product on Intel: `camera_1e-38`
/// in `examples/speedscan.rs`) and moves no result (see [`depth_args_of`]'s Δ·2^-64).
#[inline(always)]
fn height_term<L: Lane>(layer: &LayerCore, y0: L) -> L {
    let tiny = L::splat(layer.tiny_height);
    y0.keep(y0.abs().ge(tiny)) * L::splat(-layer.b)
}

/// [`LayerCore::tiny_height`] of a layer with falloff `b`: 2^-100/|b| (+∞ for b = 0),
/// formed once per scene.
pub(crate) fn tiny_height(b: f32) -> f32 {
    TWO_M100 / b.abs()
}

/// 2^-100.
const TWO_M100: f32 = 7.888_609e-31;

/// Bounds of [`depth_args_tame`]'s lanes: |d|·t in [2^-20, 2^31] and |Δ| < 2^8.
const TAME_M_MIN: f32 = 9.536_743e-7; // 2^-20
const TAME_M_MAX: f32 = 2_147_483_648.0; // 2^31
const TAME_DELTA_MAX: f32 = 256.0;
/// The least t the tame tests multiply by (2^-56; NaN and smaller t, zero and negative
/// included, are raised to it): every lane they accept has t above it (m = n_m·t with
/// n_m < 4 below 2^-52 fails them: zero lanes are told by t itself and get m = +0).
const TAME_T_FLOOR: f32 = 1.387_778_8e-17; // 2^-56
/// Sky lanes of [`depth_args_tame_wide`] (t = +∞): |b·u| in [2^-38, 2^12), scaled into
/// φ's argument by 2^17 from 2^-12 up, else by 2^43.
const TAME_SKY_MIN: f32 = 3.637_978_8e-12; // 2^-38
const TAME_SKY_MID: f32 = 2.441_406_3e-4; // 2^-12
const TAME_SKY_MAX: f32 = 4096.0; // 2^12
const SKY_SHIFT: [f32; 2] = [131_072.0, 8_796_093_022_208.0]; // 2^17, 2^43
const SKY_SHIFT_EXP: [f32; 2] = [17.0, 43.0];

/// [`depth_args_of`]`::<L, 1>` (0 < |b| ≤ 2^40) for an axis-aligned up vector, on plain
/// f32 without the mantissa/exponent bookkeeping (no frexp of u and t, no exponent sums,
/// no power-of-two scalings of Δ): `y`, `u` and `t` are the height, the up component of
/// d and the segment end, `norm` is |d| as (n_m, n_e). Returns the arguments and the
/// lanes where they are valid; the caller uses them only if every lane is (the batch
/// kernel decides per packet, so that extreme data keep their speed; t = +∞:
/// [`depth_args_tame_wide`]).
///
/// Where the mask is set, `depth_of` and the `ldexp` of stage 3 give the same bits as
/// from [`depth_args_of`] (tested against it in `kernel::tests`), because the two differ
/// only by exact powers of two while every intermediate is a normal f32:
/// - m = n_m·t and e = n_e instead of n_m·t_m and n_e + t_e: the same G = m·φ·e^(−u_min)
///   scaled by 2^t_e. With φ ≥ 2^-8 (|Δ| < 2^8), e^(−u_min)'s mantissa in [0.70, 1.42]
///   and a channel's mantissa in [2^-16, 2), |m·φ·e^(−u_min)·σ_m| is in [2^-45, 2^33],
///   inside `ldexp`'s precondition [2^-62, 2^39] (and its product with `pow2_pair`'s
///   first factor stays normal), so τ is rounded from the same real number;
/// - Δ = (b·u)·t against (b_m·u_m)·t_m: the same roundings where b·u and Δ are normal,
///   which |Δ| ≥ 2^-60 with t ≤ 2^31 guarantees (|b·u| ≥ 2^-91); below 2^-60 both give
///   φ's argument 2^-60;
/// - |Δ| < 2^8 keeps φ's argument unclamped (exponent of Δ ≤ 7) and φ's exponent 0;
/// - −u_min = −b·(y − h0) − min(Δ, 0) in plain f32 ([`height_term`]: heights below
///   2^-100/|b| taken as 0), the operations of the general path's plain sum, which it
///   takes wherever y − h0 is finite and the sum is not ∞ − ∞ (here y − h0 is checked
///   finite and |Δ| < 2^8). Below |Δ| < 2^-59 the general path's Δ is clamped to
///   dm·2^-62 against the exact Δ here: where |b·y0| ≥ 2^-34 half an ulp of it exceeds
///   both, so both sums round to −b·y0; elsewhere both |u_min| are below 2^-33, where
///   `exp2_split` gives exactly (1, ±0) in both. No term is subnormal (the height formed
///   at 2^-64 scale, as before, was below 2^-62 and cost every such packet microcode
///   assists on Intel: `camera_1e-19_free` 7.4× the time of typical data in
///   `examples/speedscan.rs`, forty-sixth session; a nearly level ray, Δ = −1e-19, once
///   sent the whole packet down the general path);
/// - m carries no guard (the general path adds +0 to n_m·t_m ≥ +0): t is finite and
///   positive, y − h0 is finite (checked), and u is finite because b·u·t is finite with
///   t > 0.
///
#[inline(always)]
pub(crate) fn depth_args_tame<L: Lane>(
    layer: &LayerCore,
    y: L,
    u: L,
    t: L,
    norm: (L, L),
) -> (DepthArgs<L>, L::Mask) {
    // t raised to TAME_T_FLOOR (one `maxps`): a lane below it fails the bounds either
    // way, and the products stay normal (a subnormal t made both products subnormal, a
    // microcode assist each on Intel: `short_1e-40` 11× typical time on the 8-lane path).
    let t = t.max(L::splat(TAME_T_FLOOR));
    let m = norm.0 * t;
    let d = (L::splat(layer.b) * u) * t;
    let ad = d.abs();
    let y0 = y - L::splat(layer.h0);
    let neg_u_min = height_term(layer, y0) - d.min(L::splat(0.0));
    let ok = m.ge(L::splat(TAME_M_MIN))
        & m.le(L::splat(TAME_M_MAX))
        & ad.lt(L::splat(TAME_DELTA_MAX))
        & y0.abs().le(L::splat(f32::MAX));
    let args = DepthArgs {
        dc: ad.max(L::splat(8.673_617e-19)), // 2^-60, as in `depth_args_of`
        neg_u_min,
        m,
        e: norm.1,
    };
    (args, ok)
}

/// Bounds of [`depth_args_tame_wide`]'s lanes: |d|·t in [2^-52, 2^43] (scaled by 2^∓32
/// into the plain bounds where outside them); for far lanes |Δ| in [2^8, 2^90] and
/// |b·u| in [2^-29, 2^29); the power of two that scales the near ones.
const TAME_WIDE_M_MIN: f32 = 2.220_446e-16; // 2^-52
const TAME_WIDE_M_MAX: f32 = 8_796_093_022_208.0; // 2^43
const TAME_FAR_MAX: f32 = 1.237_940_1e27; // 2^90
const TAME_FAR_BU_MIN: f32 = 1.862_645_1e-9; // 2^-29
const TAME_FAR_BU_MAX: f32 = 536_870_912.0; // 2^29
const M_SHIFT: f32 = 4_294_967_296.0; // 2^32
const M_SHIFT_EXP: f32 = 32.0;

/// [`depth_args_tame`]'s arguments widened, for a packet where it rejected some lane:
/// four more kinds of lane (y and |d| finite in all) give the same bits after stage 3 as
/// the general path, three of them by an exact power of two.
/// - **Zero lanes**, t = ±0 with b·u finite: the plain arguments with m = +0. The
///   general path's G is (n_m·(±0) + guard)·φ·e^(−u_min) = +0, with φ(2^-60) = 1 and a
///   finite e^(−u_min) (y finite), and so is this one (Δ = b·u·2^-56 from the raised t,
///   so φ's argument is finite and at least 2^-60, and −u_min is finite where the
///   general path's is); τ = +0 at any exponent. (A depth
///   buffer's pixel at the eye, a batch's padding: these took the general path, at 1.6×
///   the time.)
/// - **Near lanes**, |d|·t in [2^-52, 2^-20) or (2^31, 2^43], otherwise within the plain
///   bounds (|Δ| < 2^8): m = n_m·t times 2^±32
///   into [2^-20, 2^31], and the exponent n_e ∓ 32. The plain argument holds: with
///   t ≤ 2^66 (n_m ≥ 2^-23), |Δ| ≥ 2^-60 still makes b·u normal (above 2^43, b·u could
///   be subnormal there, and the general path would round Δ differently).
/// - **Far lanes**, finite t with |Δ| in [2^8, 2^90] and |b·u| in [2^-29, 2^29): the
///   plain arguments as they are. The general path clamps φ's argument to |dm|·2^8
///   (dm = (b_m·u_m)·t_m, rounded as (b·u)·t is: both normal) and moves 2^(8 − e_Δ)
///   into the exponent; from 25 on φ (`exprel2_neg`, `exprel2_neg_fast`) is 1/x, correctly
///   rounded, so φ(|Δ|) = φ(|dm|·2^8)·2^(8 − e_Δ) exactly (normal: |Δ| ≤ 2^90), and
///   m = n_m·t (t ≤ 2^119, so m is finite) carries 2^t_e: the same G·2^e, with
///   G = m·φ·e^(−u_min) ≈ n_m·e^(−u_min)/|b·u| in [2^-29.5, 2^31.3] (n_m in [1, 2√3):
///   u, so d, is normal; inside `shared_depth`'s [2^-32, 2^32) and, times a channel's
///   mantissa, `ldexp`'s precondition). Δ·2^-64 is exact (|Δ| ≥ 2^8).
/// - **Sky lanes**, t = +∞ and |b·u| in [2^-38, 2^12): the general path has t =
///   1·2^(2^21), φ's argument |dm|·2^8 with dm = b_m·u_m rounded (≥ 256, where φ = 1/x),
///   m = n_m and the exponent n_e + 8 − e_b − e_u; here φ's argument is |b·u|·2^k with
///   k = 17 (|b·u| ≥ 2^-12) or 43, in [32, 2^31), so φ is the general one times
///   2^(8 − k − e_b − e_u) exactly (b·u = dm·2^(e_b + e_u), normal), and the exponent
///   n_e + k makes up for it. G stays in [2^-31.5, 2^-2.7]. The density's exponent, as
///   `depth_args_tame` formed it, is the general one: Δ·2^-64 = ±∞ here, where the
///   general path has ±|dm|·2^127, so min(Δ·2^-64, 0) is 0 (b·u > 0) or makes u_min −∞
///   in both (b·u < 0: |b·y0·2^-64| ≤ 2^104 cannot offset it; then τ = +∞, T = 0).
///
/// Lanes with `NATIVE_SCALE` (AVX-512) do not call it: their general arithmetic costs
/// less than this test (`kernel::single_args`).
///
/// Returns the arguments and the lanes where they are valid. The exponent of a near or
/// sky lane is not n_e, so [`depth_with_tame`]'s shortcut does not apply to such packets.
/// Sky lanes are tried first, and a packet of sky and plain lanes returns before the
/// rest is formed. The products below are [`depth_args_tame`]'s (LLVM forms them once
/// where both run).
#[inline(always)]
pub(crate) fn depth_args_tame_wide<L: Lane, const UNIT: bool>(
    layer: &LayerCore,
    y: L,
    u: L,
    t: L,
    norm: (L, L),
    tame: (DepthArgs<L>, L::Mask),
) -> (DepthArgs<L>, L::Mask) {
    let (args, ok) = tame;
    let bu = L::splat(layer.b) * u;
    let abu = bu.abs();
    // (And −u_min not ∞ − ∞: a sky lane whose b·y0 overflows against Δ = ∓∞ takes the
    // general path's scaled sum.)
    #[allow(clippy::eq_op)]
    let y_fin =
        (y - L::splat(layer.h0)).abs().le(L::splat(f32::MAX)) & args.neg_u_min.eq(args.neg_u_min);
    // |d| finite (an infinite component off the up axis makes the general path's guard
    // NaN) and the height finite: sky and far lanes. (|d| = 1 for `UNIT`: LLVM kept the
    // compare of two constants.)
    let fin = if UNIT {
        y_fin
    } else {
        norm.0.le(L::splat(f32::MAX)) & y_fin
    };
    let inf = t.eq(L::splat(f32::INFINITY)) & fin;
    // Sky lanes, |b·u| in [2^-38, 2^12), scaled by SKY_SHIFT[1] below 2^-12 (nearly level
    // rays) and SKY_SHIFT[0] from there on; a packet of them and plain lanes (a
    // renderer's sky) stops here. (One test for both ranges: with a test and its
    // blends per range, the `stiff` set paid for both.)
    let level = abu.lt(L::splat(TAME_SKY_MID));
    let sky = inf & abu.ge(L::splat(TAME_SKY_MIN)) & abu.lt(L::splat(TAME_SKY_MAX));
    let shift = L::select(level, L::splat(SKY_SHIFT[1]), L::splat(SKY_SHIFT[0]));
    let shift_e = L::select(
        level,
        L::splat(SKY_SHIFT_EXP[1]),
        L::splat(SKY_SHIFT_EXP[0]),
    );
    let args = DepthArgs {
        dc: L::select(sky, abu * shift, args.dc),
        m: L::select(sky, norm.0, args.m),
        e: L::select(sky, norm.1 + shift_e, args.e),
        ..args
    };
    let ok = ok | sky;
    if !L::any(!ok) {
        return (args, ok);
    }
    let d = bu * t.max(L::splat(TAME_T_FLOOR));
    let ad = d.abs();
    // t > 0 (m carries no guard here) follows from |Δ| ≥ 2^8: NaN, negative and zero t
    // were raised to TAME_T_FLOOR (`maxps` returns its second operand for NaN), and
    // |b·u| < 2^29 times it is below 2^-27.
    let far = ad.ge(L::splat(TAME_DELTA_MAX))
        & ad.le(L::splat(TAME_FAR_MAX))
        & abu.ge(L::splat(TAME_FAR_BU_MIN))
        & abu.lt(L::splat(TAME_FAR_BU_MAX))
        & fin;
    // Near: the plain bounds but for m's (sky lanes fail |Δ| < 2^8).
    let m = args.m;
    let near = ad.lt(L::splat(TAME_DELTA_MAX))
        & m.ge(L::splat(TAME_WIDE_M_MIN))
        & m.le(L::splat(TAME_WIDE_M_MAX))
        & y_fin;
    // Zero lanes (t = ±0): m made +0 below (the general path's G, see above).
    let zero = t.eq(L::splat(0.0)) & abu.le(L::splat(f32::MAX)) & fin;
    let scaled = near & !ok;
    let small = m.lt(L::splat(TAME_M_MIN));
    let scale = L::select(small, L::splat(M_SHIFT), L::splat(1.0 / M_SHIFT));
    let shift = L::select(small, L::splat(-M_SHIFT_EXP), L::splat(M_SHIFT_EXP));
    // (m > 0 on every other lane accepted.)
    let args = DepthArgs {
        m: L::select(scaled, m * scale, m).zero_where(zero),
        e: L::select(scaled, norm.1 + shift, args.e),
        ..args
    };
    (args, ok | near | far | zero)
}

/// The second half of [`layer_depth`]: φ(|Δ|) and e^(−u_min), and G assembled.
///
/// `B2`: the layer's constants are in base 2 ([`LayerCore::base2`], the one-layer
/// kernels): φ₂ and 2^(−u_min₂) instead (two and three multiplies and FMAs fewer per
/// lane: `exprel2_neg`, `exp2_split`), and the result is G₂ = G/log2(e).
#[inline(always)]
pub(crate) fn depth_of<L: Lane, const FAST: bool, const B2: bool>(
    layer: &LayerCore,
    a: DepthArgs<L>,
) -> (L, L) {
    depth_with::<L, FAST, B2>(layer, &a, depth_phi::<L, FAST, B2>(&a))
}

/// φ(|Δ|) of [`depth_of`] (φ₂ where `B2`).
#[inline(always)]
pub(crate) fn depth_phi<L: Lane, const FAST: bool, const B2: bool>(a: &DepthArgs<L>) -> L {
    match (FAST, B2) {
        (true, true) => exprel2_neg_fast(a.dc),
        (true, false) => exprel_neg_fast(a.dc),
        (false, true) => exprel2_neg(a.dc),
        (false, false) => exprel_neg(a.dc),
    }
}

/// The density at the denser end of [`depth_of`] as (m, k), e^(−u_min) = m·2^k (2^(−u_min₂)
/// where `B2`).
#[inline(always)]
fn density<L: Lane, const FAST: bool, const B2: bool>(a: &DepthArgs<L>) -> (L, L) {
    match (FAST, B2) {
        (true, true) => exp2_split_fast(a.neg_u_min),
        (true, false) => exp_split_fast(a.neg_u_min),
        (false, true) => exp2_split(a.neg_u_min),
        (false, false) => exp_split(a.neg_u_min),
    }
}

/// The rest of [`depth_of`], given `phi` from [`depth_phi`].
#[inline(always)]
pub(crate) fn depth_with<L: Lane, const FAST: bool, const B2: bool>(
    layer: &LayerCore,
    a: &DepthArgs<L>,
    phi: L,
) -> (L, L) {
    if layer.b == 0.0 {
        depth_with_of::<L, FAST, B2, true>(a, phi)
    } else {
        depth_with_of::<L, FAST, B2, false>(a, phi)
    }
}

/// [`depth_with_of`]`::<L, FAST, true, false>` for arguments from [`depth_args_tame`]
/// (exponent −0 where `UNIT`, the exponent of |d| = 1), with the same bits: adding −0 to
/// the exponent changes nothing. Base 2 only: the one-layer kernels are its only callers.
#[inline(always)]
pub(crate) fn depth_with_tame<L: Lane, const FAST: bool, const UNIT: bool>(
    a: &DepthArgs<L>,
    phi: L,
) -> (L, L) {
    let (em, ek) = density::<L, FAST, true>(a);
    (a.m * phi * em, if UNIT { ek } else { a.e + ek })
}

/// [`depth_with`] for a homogeneous layer (`HOMOGENEOUS`, b = 0) or not.
#[inline(always)]
pub(crate) fn depth_with_of<L: Lane, const FAST: bool, const B2: bool, const HOMOGENEOUS: bool>(
    a: &DepthArgs<L>,
    phi: L,
) -> (L, L) {
    if HOMOGENEOUS {
        return (a.m, a.e);
    }
    let (em, ek) = density::<L, FAST, B2>(a);
    (a.m * phi * em, a.e + ek)
}
