//! The pass's own kernel for the most common frame: a perspective camera and one height
//! fog layer with nothing else (no volumes, no distance fog or limits, no lobe; emission,
//! ambient and up to four phase functions of a sun allowed).
//!
//! All rays of such a frame start at the eye, so the density there, ρ₀ = e^(−b·(y₀ − h0)),
//! is a constant of the frame: it is computed once, in f64, and folded into the extinction,
//! K_c = σ_c · ρ₀. (An orthographic camera upright in the scene, with an axis up, has
//! rays that start on the camera plane at one height per row: there ρ₀ and K_c are
//! constants of the row, formed the same way per row, [`HeightPass::for_row`], and the
//! ranges below hold over the rows' heights.) Per pixel, with n = |d|, u = dot(d, up),
//! Δ = b·u·t:
//!
//!   τ_c = K_c · n · t · E(Δ),  E(Δ) = (1 − e^(−Δ))/Δ = expm1(y)/y with y = −Δ,
//!
//! one `expm1` and one division for both signs of Δ (E → 1 as Δ → 0 with no branch, E ≈
//! 1/Δ up, E ≈ e^|Δ|/|Δ| down), where the batch kernel, which must take any origin, needs
//! e^(−u_min) and φ(|Δ|) with their exponents carried apart. That is what makes this
//! kernel cheaper; the pass outputs T and L_in only, never τ, so τ need not be resolved
//! beyond where T = e^(−τ) is 0 (τ > 104).
//!
//! Both exponentials run in base 2, with log2(e) folded into the frame's constants (in
//! f64, rounded once): y' = y·log2(e) = (−b·log2 e)·u·t, E = exp2m1(y')/(y'·ln 2), and
//! T_c = e^(−τ_c) = 2^(−K_c·log2(e)²·g') with g' = n·t·exp2m1(y')/y'. [`exp2m1`] and
//! [`exp2_nonpos`] need no multiply by log2(e) and no Cody–Waite reduction: 4 fewer
//! multiply-adds per pixel in the stage of E and 2 per channel in the stage of T (README
//! "Speed of the pass").
//!
//! That plain f32 product is exact to a few roundings, and saturates only where the true
//! τ is far beyond 104, on the frames that [`HeightPass::new`] accepts (it returns `None`,
//! and the pass uses the batch kernel, otherwise). t is clamped to the frame's T_BIG (sky
//! pixels included): a tenth of the largest power of ten at which K_max·n_max·T_BIG,
//! |b|·n_max·T_BIG and n_max·T_BIG stay within 1e37 (at most 1e36), with n_min ≤ n ≤
//! n_max over the frame, and K_min, K_max the smallest non-zero and the largest K_c:
//! - clamping t: if Δ(T_BIG) ≥ 20, τ(T_BIG) and τ(t) differ by less than e^(−20)
//!   relative; otherwise τ(T_BIG) ≥ K_min·n_min·T_BIG·E(20) > 1e4 (requires
//!   K_min·n_min·T_BIG ≥ 2e5), so both saturate. (With T_BIG fixed at 1e20, as until
//!   the eighteenth session, this required K_min·n_min ≥ 2e-15: an eye 250 m above a
//!   fog of b = 0.1 already fell back to the batch kernel, at twice the time);
//! - E stops growing where `exp2m1` clamps y' at 127 (Δ < −88.03): there E = 2^127/
//!   (y'·ln 2) and τ = K·n·t·E = K·2^127·n/(|b|·|u|) ≥ K·1.7e38/|b| > 5e3 (requires
//!   K_min/|b| ≥ 3e-35; n ≥ |u| as up is unit), so T is 0 as it is for the exact τ;
//! - K_c is a normal f32 (1e-30 ≤ K_c ≤ 1e30 where σ_c > 0);
//! - nothing else overflows: n·t, K·n·t and y' are at most 1e37 (T_BIG's bounds);
//! - n·t·E is clamped to f32::MAX where a channel has σ_c = 0, so that it gives τ = 0, not
//!   0·∞ (without such a channel an infinite n·t·E gives T = 0, as the true τ does).
//! - nothing is subnormal for short rays: t is raised to the frame's T_LO (depth values
//!   to D_LO = T_LO·n_max before the division of distance depths), below which τ ≤
//!   2⁻⁴⁰, so T = 1 and L_in = 0 in f32 as for t = 0 (see [`HeightPass::t_lo`]). Depths
//!   of 1e-40 took 17–18× the time of typical ones on the Intel Xeon (a microcode assist for
//!   each subnormal product: `DEPTHS=subnormal TILT=1 examples/passloop`), where no
//!   row took [`RowFactor`] (whose own t_lo has the same effect).
//!
//! The ranges are checked in the log domain: K_c itself can leave even f64's range.
//!
//! Error: K_c·log2(e)² one rounding (from f64), n two, t (the same f32 ray as the batch
//! API's) none, y' three (relative, amplified by |Δ| in E: the problem's condition),
//! exp2m1 ≤ 1.79 ULP and the division (0.563 ULP on AVX-512 lanes), three products: τ
//! within about 9 + 4·|Δ| ULP, inside the crate's bound 16·2⁻²⁴·(1 + |b·(y₀ − h0)| + |Δ|)
//! (here y₀'s term is resolved in f64); T adds the rounding of K·g (τ·2⁻²³ relative, what
//! the bound on τ allows; none on AVX-512 lanes, where `exp2_nonpos_table_mul` takes the
//! exact product) and `exp2_nonpos`'s 1.09 ULP (`exp2_nonpos_table_mul`'s 1.0 there).
//! `tests/pass.rs` checks every pixel of random frames against the batch API.
//!
//! Where u is the same along a row (a camera upright in the scene), the row forms g' as
//! exp2m1(y')·(n·c) with c = 1/(b2·u) a constant of the row: no division per pixel
//! ([`RowFactor`], which gives its ranges and its error, about one ULP more). With one
//! Henyey–Greenstein phase function whose error bound allows it, n², the phase
//! function's q and (where it varies) u are polynomials in the column's u and no
//! direction is formed, in every row and depth convention ([`LinearRow`],
//! [`PhaseTerm::linear_error`]).

use super::camera::{DepthPlan, FramePlan, RowPlan};
use super::RowColour;
use crate::kernel::Single;
use crate::light::Phase;
use crate::math::{
    exp2_nonpos, exp2_nonpos_table_mul_with, exp2m1, exp2m1_in_range, exp_neg_fast, Lane,
    TableMulConsts,
};
use crate::medium::volume::clamp_colour;
use crate::scene::{Scene, UpAxis};
use crate::Tier;
use wide::{f32x16, f32x8};

/// The lane type of this kernel: 16 lanes in every build. With AVX-512 that is one zmm
/// register (`kernel::Wide`); in an AVX2 build, `wide` keeps an `f32x16` as two ymm
/// halves and issues each operation for both back to back, so every dependency chain of
/// a packet (the reciprocal square roots, `exp2m1` and its division, `exp2_nonpos`) runs
/// next to an independent one in program order (the likely reason, not measured: a small
/// out-of-order window like Zen 1's overlaps those better than the blocks' packets
/// alone): `pass/fog_single` 2 to 5 % faster than `pass/fog_single_lanes8` in the same
/// binary (twenty-first session, Zen 1; README "Speed of the pass"). Same bits at both
/// widths (see [`PassLane`]). The batch kernel measured 3 to 6 % slower with `f32x16` in
/// the AVX2 build and stays at 8 lanes there.
#[cfg(not(zmm_native))]
type PassWide = f32x16;
/// See the other definition: in a build with AVX-512 F, VL, DQ, BW and CD (x86-64-v4),
/// the crate's own [`Zmm`](crate::math::zmm::Zmm), the type the x86-64-v3 build's
/// run-time dispatch runs: with `f32x16` the x86-64-v4 build's pass took 1.16× that
/// path's time on Zen 5 (ARCHITECTURE "AVX-512 chosen at run time").
#[cfg(zmm_native)]
type PassWide = crate::math::zmm::Zmm;

/// Rays are clamped to a frame's T_BIG, at most this (see the module documentation).
const T_BIG_MAX: f32 = 1e37;
/// Below this, E(Δ) = 1 in f32; keeps the division away from 0/0.
const TINY: f32 = 8.673_617e-19; // 2^-60

/// The most phase functions [`fog_rows`] takes (as `Single`).
const MAX_PHASES: usize = 4;

/// One phase function with its colour weights, in the form
/// p = (α + β·c²) · q^(−3/2), q = base + gg·|v + w|², c = dot(v, s) (v the unit view
/// direction, s toward the sun): Henyey–Greenstein (β = 0) and Cornette–Shanks with
/// (1 + g² − 2g·c) written as (1 ∓ g)² ± g·|v ∓ s|² as in `Phase::eval` (no cancellation at
/// the peak), Rayleigh (gg = 0, base = 1). The kernel evaluates p/α = (1 + (β/α)·c²) ·
/// q^(−3/2) and weighs it by α·k (α folded into the weights: one multiply fewer per
/// packet where no term of the frame has β ≠ 0, the same count elsewhere).
#[derive(Clone, Copy, Default)]
struct PhaseTerm {
    beta: f32,
    /// β/α (rounded once from f64).
    beta_rel: f32,
    base: f32,
    gg: f32,
    w: [f32; 3],
    s: [f32; 3],
    /// The colour weights times α (rounded once from f64).
    k: [f32; 3],
}

impl PhaseTerm {
    fn new(phase: Phase, k: [f32; 3], s: [f32; 3]) -> PhaseTerm {
        use core::f32::consts::PI;
        let hg = |g: f32| {
            if g >= 0.0 {
                ((1.0 - g) * (1.0 - g), g, s.map(|v| -v))
            } else {
                ((1.0 + g) * (1.0 + g), -g, s)
            }
        };
        let (alpha, beta, (base, gg, w)) = match phase {
            Phase::Isotropic => (1.0 / (4.0 * PI), 0.0, (1.0, 0.0, [0.0; 3])),
            Phase::Rayleigh => (3.0 / (16.0 * PI), 3.0 / (16.0 * PI), (1.0, 0.0, [0.0; 3])),
            Phase::HenyeyGreenstein(g) => ((1.0 - g) * (1.0 + g) / (4.0 * PI), 0.0, hg(g)),
            Phase::CornetteShanks(g) => {
                let num = 3.0 / (8.0 * PI) * (1.0 - g) * (1.0 + g) / (2.0 + g * g);
                (num, num, hg(g))
            }
        };
        PhaseTerm {
            beta,
            beta_rel: (f64::from(beta) / f64::from(alpha)) as f32,
            base,
            gg,
            w,
            s,
            k: k.map(|k| (f64::from(k) * f64::from(alpha)) as f32),
        }
    }

    /// (1 + β/α)·base^(−3/2): p/α = (1 + (β/α)·c²)·q^(−3/2) with q ≥ base and c² ≤ 1, so
    /// the exact value is at most this, and [`PhaseTerm::eval`] exceeds it by its
    /// roundings only (q^(−3/2) within 3.87·2⁻²⁴ on AVX-512 lanes and 13.2·2⁻²⁴ on AVX2
    /// ones, c² within a few 2⁻²⁴; the test
    /// `phase_values_stay_below_the_peak_bound` checks it at and around the peaks).
    fn peak(&self) -> f64 {
        (1.0 + f64::from(self.beta_rel)) * f64::from(self.base).powf(-1.5)
    }

    /// A bound on the relative error of p/α where q is formed from cos θ instead of
    /// |v + w|² ([`LinearRow`], `HeightPass::phase_linear`), for a frame whose row
    /// directions are d = rd + u·d_u with |d_u·rd| ≤ η·|d_u|·|rd| (η < 1/2): q = q0 +
    /// 2gg·dot(d, w)/n with q0 = base + gg·(1 + |w|²), a sum that cancels toward the
    /// peak, where q = base, where |v + w|² has no cancellation. Absolute error of q (ε =
    /// 2⁻²⁴): the linear form of dot(d, w) (its two coefficients and the fused
    /// multiply-add rounded once each, and the pass's direction itself, whose components
    /// the batch API rounds) ε·G·(κ/2 + 1) with G = 2gg·|w| and κ = √(2/(1 − η)) bounding
    /// (|u·d_u| + |rd|)/n; 1/n's relative error (6ε on AVX2 lanes with the quadratic's
    /// condition (1 + η)/(1 − η), 3ε on AVX-512 ones; the AVX2 figure is used) times G;
    /// q0's rounding ε/2·q0; the last fused multiply-add's ε/2·q. Relative, at the peak
    /// (q ≥ base): e_q = (that)/base + ε/2; p's error 1.5·e_q plus q^(−3/2)'s own
    /// (13.2ε on AVX2 lanes, see [`pow_neg_three_halves`]). +∞ where η ≥ 1/2 or β ≠ 0.
    fn linear_error(&self, eta: f64) -> f64 {
        let eps = 2f64.powi(-24);
        if !(0.0..0.5).contains(&eta) || self.beta != 0.0 || self.base.is_nan() || self.base <= 0.0
        {
            return f64::INFINITY;
        }
        let w = self.w.map(f64::from);
        let w2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        let (gg, base) = (f64::from(self.gg), f64::from(self.base));
        let g = 2.0 * gg * w2.sqrt();
        let q0 = base + gg * (1.0 + w2);
        let kappa = (2.0 / (1.0 - eta)).sqrt();
        let e_inv_n = 6.0 * eps * (1.0 + eta) / (1.0 - eta);
        let e_abs = eps * g * (kappa / 2.0 + 1.0) + g * e_inv_n + eps / 2.0 * q0;
        1.5 * (e_abs / base + eps / 2.0) + 13.2 * eps
    }

    /// p/α for the view directions `d · inv_n` (unit); `beta`: whether any term of the
    /// frame has β ≠ 0 (else c is not formed).
    #[inline(always)]
    fn eval<W: PassLane>(&self, d: [W; 3], inv_n: W, beta: bool) -> W {
        let (w, c) = self.prepare(d, inv_n, beta);
        self.finish(w, c, beta)
    }

    /// p/α for the unit view direction `v`, in f64: [`PhaseTerm::eval`]'s value for an
    /// orthographic frame, whose rays all share it.
    fn value(&self, v: [f64; 3]) -> f64 {
        let w: [f64; 3] = core::array::from_fn(|i| v[i] + f64::from(self.w[i]));
        let q =
            f64::from(self.base) + f64::from(self.gg) * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
        let c =
            v[0] * f64::from(self.s[0]) + v[1] * f64::from(self.s[1]) + v[2] * f64::from(self.s[2]);
        (1.0 + f64::from(self.beta_rel) * c * c) * q.powf(-1.5)
    }

    /// The view direction's part of [`PhaseTerm::eval`]: v + w (v = d·inv_n) and, where
    /// `beta`, c = dot(d, s)·inv_n (else 0).
    #[inline(always)]
    fn prepare<W: PassLane>(&self, d: [W; 3], inv_n: W, beta: bool) -> ([W; 3], W) {
        let w = [
            d[0].mul_add(inv_n, W::splat(self.w[0])),
            d[1].mul_add(inv_n, W::splat(self.w[1])),
            d[2].mul_add(inv_n, W::splat(self.w[2])),
        ];
        let c = if beta {
            crate::light::dot3(d, self.s) * inv_n
        } else {
            W::splat(0.0)
        };
        (w, c)
    }

    /// The rest of [`PhaseTerm::eval`] from [`PhaseTerm::prepare`]'s values.
    #[inline(always)]
    fn finish<W: PassLane>(&self, w: [W; 3], c: W, beta: bool) -> W {
        let m = w[0].mul_add(w[0], w[1].mul_add(w[1], w[2] * w[2]));
        let p = pow_neg_three_halves(m.mul_add(W::splat(self.gg), W::splat(self.base)));
        if beta {
            (c * c).mul_add(W::splat(self.beta_rel), W::splat(1.0)) * p
        } else {
            p
        }
    }
}

/// x^(−3/2) for x > 0 (the phase functions' q^(−3/2)). Where the estimate of 1/√x is
/// AVX-512's (`vrsqrt14ps`, relative error |ε| < 2⁻¹⁴: [`PassLane::PRECISE_RSQRT`]), one
/// Newton step for x^(−3/2) itself: r³·(5 − 3·x·r²)/2 = x^(−3/2)·(1 − 7.5ε² + O(ε³)),
/// below 0.5·2⁻²⁴ before the five roundings; six operations, relative error 3.87·2⁻²⁴
/// (the unit test `pow_neg_three_halves_error`). Elsewhere (`vrsqrtps`, |ε| < 1.5·2⁻¹²)
/// 1/√x refined by [`rsqrt`], then cubed: seven operations, 13.2·2⁻²⁴.
#[inline(always)]
fn pow_neg_three_halves<W: PassLane>(x: W) -> W {
    if W::PRECISE_RSQRT {
        let r = x.rsqrt_estimate();
        let r2 = r * r;
        let h = (x * r2).neg_mul_add(W::splat(1.5), W::splat(2.5));
        (r * r2) * h
    } else {
        let r = rsqrt(x);
        r * (r * r)
    }
}

/// 1/√x: the hardware estimate (relative error < 1.5·2⁻¹², on AMD and Intel; below
/// 2⁻¹⁴ for AVX-512's, which `Zmm` lanes take) and one Newton step, which leaves about
/// 1.5·(1.5·2⁻¹²)² + rounding < 4·2⁻²⁴ relative (1.5·2⁻²⁸ + rounding from AVX-512's).
/// The estimate's bits differ between CPU vendors and instruction sets, so this kernel's
/// last bits may too.
#[inline(always)]
fn rsqrt<W: PassLane>(x: W) -> W {
    let r = x.rsqrt_estimate();
    let h = x * W::splat(0.5);
    r * (h * r).neg_mul_add(r, W::splat(1.5))
}

/// num/den from an estimate e of 1/den with den·e = 1 + ε, |ε| < 2⁻¹⁴ (`vrcp14ps`): q₀ =
/// num·e·(1 + η), |η| ≤ 2⁻²⁴, the residual r = num − den·q₀ by one FMA (|r| ≈ 2⁻¹⁴·|num|,
/// its rounding 2⁻³⁸ relative to the quotient), then q₀ + r·e by one more. Exactly,
/// q₀ + (num − den·q₀)·e = num·e·(1 − ε·(1 + η)) against num/den = num·e/(1 + ε): relative
/// error |δ| ≤ ε² + |ε·η| + 2⁻³⁸ < 2⁻²⁸·(1 + 2⁻⁹) before the last rounding, so within
/// 0.5 + 2²⁴·δ < 0.563 ULP (the spacing at a quotient is at least 2⁻²⁴ of it). Measured
/// by the test `refined_quotient_error` against the f64 quotient (every denominator
/// mantissa): max 0.543 ULP, 0.31 % of the quotients over 0.5 ULP. The
/// pass's denominators are y' with 2⁻⁶⁰ ≤ |y'| ≤ 1.5e37 (`TINY`, `t_big`), so e is a
/// normal number, no product overflows and no 0·∞ arises; NaN stays NaN.
#[inline(always)]
#[cfg_attr(not(any(zmm_dispatch, zmm_native)), allow(dead_code))] // AVX-512 lanes only
fn refined_quotient<W: Lane>(num: W, den: W, e: W) -> W {
    let q0 = num * e;
    q0.neg_mul_add(den, num).mul_add(e, q0)
}

/// What the pass's own kernel needs of a lane type beyond [`Lane`]: the estimate of
/// 1/√x and the interleaved-RGB layouts. Implemented for `f32x8`, `f32x16` and `Zmm`; the kernel
/// runs [`PassWide`] (16 lanes), and gives the same bits at both widths:
/// every operation is the same IEEE operation per element, and the 16-lane estimate is
/// the 8-lane instruction (`vrsqrtps`) on each half, not AVX-512's more precise
/// `vrsqrt14ps` (wide's `f32x16::recip_sqrt` is a square root and a division there).
/// Where AVX-512 is there, every width takes `vrsqrt14ps` instead: the lanes chosen at run
/// time (`Zmm`) and, in a build with AVX-512, `f32x16` and `f32x8` (AVX-512VL), so the
/// widths of one build still agree bit for bit. One instruction instead of four for 16
/// lanes (two estimates, an extract and an insert), the whole pass 1.10× faster on Zen 5,
/// and other last bits than AVX2's (the refined 1/√x within a bound of about 2·2⁻²⁴
/// instead of 4·2⁻²⁴; see [`rsqrt`]).
pub(crate) trait PassLane: Lane {
    /// The lanes' column offsets, 0, 1, …, LANES − 1.
    fn lane_x() -> Self;
    /// `vrsqrtps` on each 8 lanes, or AVX-512's `vrsqrt14ps` where the lanes are AVX-512.
    fn rsqrt_estimate(self) -> Self;
    /// Whether [`PassLane::rsqrt_estimate`] is AVX-512's `vrsqrt14ps` (relative error
    /// below 2⁻¹⁴), precise enough for [`pow_neg_three_halves`]'s one Newton step.
    const PRECISE_RSQRT: bool;
    /// 2^(k·g) for k·g ≤ 0, the transmittance: [`crate::math::exp2_nonpos_table_mul`] (with
    /// its constants given) where the lanes
    /// are AVX-512's (its lookup and masked scale one instruction each, the product fused
    /// into its reduction; the table form made the in-cache frame about 1.15× as fast,
    /// median of eight alternating pairs, on the Intel Xeon of the thirty-sixth session:
    /// README "Speed of the pass"), [`exp2_nonpos`] of the rounded product elsewhere.
    /// Other last bits, like the estimate of 1/√x.
    #[inline(always)]
    fn exp2_nonpos_mul(k: Self, g: Self, c: &TableMulConsts<Self>) -> Self {
        let _ = c;
        exp2_nonpos(k * g)
    }
    /// num / den, the pass's one quotient exp2m1(y')/y': a division, or where the lanes
    /// are AVX-512's the estimate `vrcp14ps` refined by [`refined_quotient`] (off the
    /// divider, which the 16-lane `vdivps` holds for about ten cycles; the in-cache frame
    /// about 1.03× as fast, median of eight alternating pairs, on the Intel Xeon of the
    /// thirty-seventh session, README "Speed of the pass"). Within 0.563 ULP of num/den
    /// (measured 0.543) instead of 0.5; other last bits, like the estimate of 1/√x.
    #[inline(always)]
    fn quotient(num: Self, den: Self) -> Self {
        num / den
    }
    /// y' kept away from 0 for the quotient exp2m1(y')/y': |y'| < [`TINY`] becomes
    /// ±TINY, where E(Δ) = 1 in f32 for either sign (an and, a compare and a blend, which
    /// give +TINY and keep NaN; on AVX-512 lanes one `vrangeps`, which keeps y's sign
    /// (the same E, so the same bits) and turns NaN into ±TINY: a NaN y' comes from a
    /// NaN t, and the factor n·t carries that NaN into g' all the same).
    #[inline(always)]
    fn away_from_zero(y: Self) -> Self {
        let tiny = Self::splat(TINY);
        <Self as Lane>::select(Lane::lt(Lane::abs(y), tiny), tiny, y)
    }
    /// The `h`-th piece of 8 lanes (lanes 8h to 8h + 7; `h < LANES / 8`).
    fn part(self, h: usize) -> f32x8;
    /// Each lane repeated three times, `v0 v0 v0 v1 v1 v1 v2 …` over three vectors: a
    /// per-pixel value laid out as an interleaved RGB buffer (one permutation each).
    fn expand3(self) -> [Self; 3];
    /// Per-channel constants laid out as an interleaved RGB buffer: `c0 c1 c2 c0 c1 …`
    /// over three vectors.
    fn interleaved3(c: [f32; 3]) -> [Self; 3];
    /// Whether the third stage of an interleaved RGB row expands g' and the phase value
    /// itself ([`PassLane::expand3`] in its loop), instead of reading them expanded from
    /// the buffers that stage 2 and the phase loop fill: four stores and four loads per
    /// packet fewer. True where the lanes are AVX-512's (32 registers; with the three
    /// that `exp2_nonpos_table_mul`'s −k held freed too, the 1920×16 frame took 0.95× the
    /// time on Zen 4); with AVX2's 16 the expansion's permutations and their indices in
    /// that loop made the `NO512=1` frame 1.03× slower (README "Zen 4, fifty-fifth
    /// session").
    const EXPAND_IN_THIRD: bool = cfg!(target_feature = "avx512f");
}

impl PassLane for f32x8 {
    #[inline(always)]
    fn lane_x() -> Self {
        f32x8::new([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    }
    const PRECISE_RSQRT: bool = cfg!(all(target_feature = "avx512f", target_feature = "avx512vl"));
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
        return crate::math::rsqrt14_x8(self);
        #[cfg(not(all(target_feature = "avx512f", target_feature = "avx512vl")))]
        self.recip_sqrt()
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn exp2_nonpos_mul(k: Self, g: Self, c: &TableMulConsts<Self>) -> Self {
        exp2_nonpos_table_mul_with(k, g, c)
    }
    #[cfg(all(target_feature = "avx512f", target_feature = "avx512vl"))]
    #[inline(always)]
    fn quotient(num: Self, den: Self) -> Self {
        refined_quotient(num, den, crate::math::rcp14_x8(den))
    }
    #[inline(always)]
    fn part(self, h: usize) -> f32x8 {
        debug_assert_eq!(h, 0);
        self
    }
    #[inline(always)]
    fn expand3(self) -> [Self; 3] {
        // Written out: LLVM makes each a single permutation.
        let a = self.to_array();
        [
            f32x8::new([a[0], a[0], a[0], a[1], a[1], a[1], a[2], a[2]]),
            f32x8::new([a[2], a[3], a[3], a[3], a[4], a[4], a[4], a[5]]),
            f32x8::new([a[5], a[5], a[6], a[6], a[6], a[7], a[7], a[7]]),
        ]
    }
    fn interleaved3(c: [f32; 3]) -> [Self; 3] {
        [0, 1, 2].map(|j| f32x8::new(core::array::from_fn(|k| c[(8 * j + k) % 3])))
    }
}

impl PassLane for f32x16 {
    #[inline(always)]
    fn lane_x() -> Self {
        f32x16::new([
            0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0,
        ])
    }
    const PRECISE_RSQRT: bool = cfg!(target_feature = "avx512f");
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        #[cfg(target_feature = "avx512f")]
        return crate::math::rsqrt14_x16(self);
        #[cfg(not(target_feature = "avx512f"))]
        {
            let [a, b]: [f32x8; 2] = bytemuck::cast(self);
            bytemuck::cast([a.recip_sqrt(), b.recip_sqrt()])
        }
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn exp2_nonpos_mul(k: Self, g: Self, c: &TableMulConsts<Self>) -> Self {
        exp2_nonpos_table_mul_with(k, g, c)
    }
    #[cfg(target_feature = "avx512f")]
    #[inline(always)]
    fn quotient(num: Self, den: Self) -> Self {
        refined_quotient(num, den, crate::math::rcp14_x16(den))
    }
    #[inline(always)]
    fn part(self, h: usize) -> f32x8 {
        let halves: [f32x8; 2] = bytemuck::cast(self);
        halves[h]
    }
    #[inline(always)]
    fn expand3(self) -> [Self; 3] {
        let a = self.to_array();
        [
            f32x16::new([
                a[0], a[0], a[0], a[1], a[1], a[1], a[2], a[2], a[2], a[3], a[3], a[3], a[4], a[4],
                a[4], a[5],
            ]),
            f32x16::new([
                a[5], a[5], a[6], a[6], a[6], a[7], a[7], a[7], a[8], a[8], a[8], a[9], a[9], a[9],
                a[10], a[10],
            ]),
            f32x16::new([
                a[10], a[11], a[11], a[11], a[12], a[12], a[12], a[13], a[13], a[13], a[14], a[14],
                a[14], a[15], a[15], a[15],
            ]),
        ]
    }
    fn interleaved3(c: [f32; 3]) -> [Self; 3] {
        [0, 1, 2].map(|j| f32x16::new(core::array::from_fn(|k| c[(16 * j + k) % 3])))
    }
}

/// [`crate::math::zmm::Zmm`], 16 AVX-512 lanes chosen at run time in a build without
/// AVX-512: the same operations as `f32x16` and `f32x8` except the estimate of 1/√x,
/// AVX-512's `vrsqrt14ps` (see [`PassLane`]), so not the same last bits.
#[cfg(any(zmm_dispatch, zmm_native))]
impl PassLane for crate::math::zmm::Zmm {
    const EXPAND_IN_THIRD: bool = true;
    #[inline(always)]
    fn lane_x() -> Self {
        Self::from_array(core::array::from_fn(|k| k as f32))
    }
    const PRECISE_RSQRT: bool = true;
    #[inline(always)]
    fn rsqrt_estimate(self) -> Self {
        self.rsqrt14()
    }
    #[inline(always)]
    fn exp2_nonpos_mul(k: Self, g: Self, c: &TableMulConsts<Self>) -> Self {
        exp2_nonpos_table_mul_with(k, g, c)
    }
    #[inline(always)]
    fn quotient(num: Self, den: Self) -> Self {
        refined_quotient(num, den, den.rcp14())
    }
    #[inline(always)]
    fn away_from_zero(y: Self) -> Self {
        y.max_magnitude(Self::splat(TINY))
    }
    #[inline(always)]
    fn part(self, h: usize) -> f32x8 {
        self.half(h)
    }
    #[inline(always)]
    fn expand3(self) -> [Self; 3] {
        [
            self.permute([0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4, 5]),
            self.permute([5, 5, 6, 6, 6, 7, 7, 7, 8, 8, 8, 9, 9, 9, 10, 10]),
            self.permute([
                10, 11, 11, 11, 12, 12, 12, 13, 13, 13, 14, 14, 14, 15, 15, 15,
            ]),
        ]
    }
    fn interleaved3(c: [f32; 3]) -> [Self; 3] {
        let lanes = |j: usize| Self::from_array(core::array::from_fn(|k| c[(16 * j + k) % 3]));
        [lanes(0), lanes(1), lanes(2)]
    }
}

/// A frame's constants for [`fog_rows`].
#[derive(Clone, Copy)]
pub(crate) struct HeightPass {
    /// σ_c · ρ₀ · log2(e) per channel: τ_c = k_c·g' (the Fast tier's `exp_neg_fast`).
    k: [f32; 3],
    /// −σ_c · ρ₀ · log2(e)²: T_c = 2^(k2_c·g') ([`exp2_nonpos`]; the Accurate tier).
    k2: [f32; 3],
    /// Falloff along `up`, times −log2(e): y' = −Δ·log2(e) = b2·u·t.
    b2: f32,
    /// The kernel's unit up (an axis, with its sign folded into `b2`, or the scene's).
    up: [f32; 3],
    /// The up axis's index, 3 for a general up (a predictable branch per packet).
    axis: usize,
    /// The fog colour's constant part (ambient, emission, isotropic sun).
    colour: [f32; 3],
    phases: [PhaseTerm; MAX_PHASES],
    n_phases: usize,
    /// Some phase term has β ≠ 0 (Rayleigh, Cornette–Shanks).
    beta: bool,
    /// The fog colour, `colour + Σ p·k` for every value the phase functions take, stays
    /// below f32::MAX: its clamp ([`clamp_colour`]) can be left out where it is formed
    /// in the third stage, with at most one phase function (three operations per packet).
    colour_bounded: bool,
    /// Every value of the fog colour c is at most [`LERP_COLOUR_MAX`] in magnitude: the
    /// pixel is composited as L ← c + (L − c)·T ([`super::over`]), one fused
    /// multiply-add and one subtraction per channel, instead of L·T + (c − c·T), two
    /// fused multiply-adds (so L − c cannot overflow for any finite L, and
    /// (L − c)·T is never ∞·0).
    lerp: bool,
    /// Some channel has K_c = 0: g' is clamped to f32::MAX so that its τ is 0·g' = 0,
    /// not 0·∞ (elsewhere an infinite g' gives T = 0, as it must: the true τ is at least
    /// K_min·3.4e38 ≥ 3.4e8).
    clamp_g: bool,
    grey: bool,
    fast: bool,
    /// The depth conversion: [`LINEAR`], [`DISTANCE`], [`NDC`] or [`NDC_ORTHO`] with its
    /// constants.
    depth: usize,
    /// Run with 8 lanes instead of [`PassWide`]'s 16 ([`Scene::with_pass_lanes_8`]).
    x8: bool,
    /// Run 16 AVX-512 lanes chosen at run time (`crate::math::zmm::Zmm`) instead of
    /// [`PassWide`] (see [`crate::avx512_dispatch`]; not with `x8`).
    zmm: bool,
    /// NDC: z = near / (depth·k + q), sky where depth·sky_s ≥ sky_at.
    /// NDC_ORTHO: z = depth·k + q, the same sky test.
    ndc: [f32; 5],
    /// The frame's T_BIG: rays are clamped to this length.
    t_big: f32,
    /// The frame's T_LO: shorter rays are raised to it (negative depths too, which were
    /// raised to 0). 2⁻⁴⁰/(n_max·max(K_max, |b2|)) (at most 2⁻⁴⁰), so that τ ≤ 2⁻⁴⁰ for
    /// t ≤ T_LO: |Δ| ≤ |b|·n·t ≤ 2⁻⁴⁰ keeps E(Δ) within 2⁻⁴⁰ of 1, and K·n·t ≤ 2⁻⁴⁰.
    /// Then T = 1 in f32 (2^(−2⁻⁴⁰·log2 e) rounds to 1) and L_in = c − c·1 = 0, the
    /// results of t = 0, while n·t, y' and g' stay normal for every depth (a depth of
    /// 1e-40 formed subnormal products). 0 (no clamp) where that bound is below 2⁻¹⁰⁰,
    /// for K_max or |b| near the frame limits (1e30), where short rays may form
    /// subnormals as before.
    t_lo: f32,
    /// The depth value of a distance depth (t = depth/n) is raised to T_LO·n_max before
    /// the division: t·n = depth ≤ T_LO·n_max gives τ ≤ 2⁻⁴⁰ as above, and the product
    /// depth·(1/n) is not formed subnormal.
    d_lo: f32,
    /// The one phase function's q is formed from cos θ in every row ([`LinearRow`]; any
    /// depth convention, rolled cameras too): a frame with one phase function of β = 0
    /// (Henyey–Greenstein) whose [`PhaseTerm::linear_error`] is within
    /// [`LINEAR_PHASE_BUDGET`].
    phase_linear: bool,
    /// u = `d[axis]` is the same for every pixel of a row (an axis up with `d_u[axis]` = 0,
    /// an upright camera), and 2⁻³⁰ ≤ n_min ≤ n_max ≤ 2³⁰: rows may take [`RowFactor`].
    row_uniform: bool,
    /// The least |b2·u| of a row that takes [`RowFactor`]: 2⁻³⁰ and max_c k_c·n_max·2⁻²⁰.
    uni_lo: f32,
    /// An orthographic camera upright in the scene (an axis up, the camera plane's
    /// horizontal axis level): the rays share one direction and start on the camera plane,
    /// at one height per row, so ρ₀, hence `k` and `k2`, is a constant of the row
    /// ([`HeightPass::for_row`]), not of the frame.
    row_density: bool,
    /// σ_c (f64), the falloff and the base height, for [`HeightPass::for_row`].
    sigma: [f64; 3],
    b: f64,
    h0: f64,
    /// g' is raised to this where it is not 0: 2⁻³⁰/max_c max(|k_c|, |k2_c|), so that
    /// g' below it gives τ ≤ 2⁻³⁰ (T = 1 and L_in = 0 in f32, as for the g' raised), and
    /// every channel's k_c·g' stays normal (channels within 2⁷⁰ of the largest). Only
    /// in frames where some pixel's k_c·g' could be below 2⁻¹⁰⁰ otherwise (K far below
    /// 1, an eye far above the fog, with short rays: subnormal products in stage 3 took
    /// 17× the time of typical frames on the Intel Xeon, `EYE_Y=500 DEPTHS=tiny
    /// examples/passloop`); 0 (no floor) elsewhere.
    g_lo: f32,
}

/// A row's constants where u = dot(d, up), hence b2·u, is the same for all its pixels
/// (an axis up with `d_u[axis]` = 0: a camera upright in the scene, as `Camera::perspective`
/// builds it from the scene's up axis). There g' = n·t·exp2m1(y')/y' = exp2m1(y')·(n·c)
/// with c = 1/(b2·u) rounded once from f64, since y' = (b2·u)·t: a product instead of the
/// quotient (its `vrcp14ps` and three refining operations), no [`PassLane::away_from_zero`]
/// (no 0/0 to avoid), and t clamped to [t_lo, t_hi] instead of [0, T_BIG], which keeps y'
/// within [`exp2m1_in_range`]'s domain (its clamp left out): eight operations fewer per
/// packet.
/// - t_lo = 2⁻⁶⁰/|b2·u|, so |y'| ≥ 2⁻⁶⁰ and exp2m1(y') is resolved relative to itself;
///   a shorter ray's τ is at most k_max·n_max·t_lo ≤ 2⁻⁴⁰ (where |b2·u| ≥
///   [`HeightPass::uni_lo`]), so T = 1 and L_in = 0 in f32, as for t = 0.
/// - 2⁻³⁰ ≤ |b2·u| ≤ 2³⁰ with 2⁻³⁰ ≤ n ≤ 2³⁰ (`HeightPass::row_uniform`): c, t_lo and n·c
///   are within 2^±60 and g' ≥ 2⁻⁶¹·2⁻⁶⁰, so nothing is subnormal.
/// - Error: c and n·c one rounding each where the quotient had 0.563 ULP; y' = (b2·u)·t is
///   rounded once more than the quotient's denominator saw (which cancelled it near y' =
///   0): about one ULP more of τ than the module documentation's general path.
#[derive(Clone, Copy)]
struct RowFactor {
    on: bool,
    /// b2·u in f32 (the general path's `b2 * u`, the same bits).
    b2u: f32,
    /// 1/(b2·u), rounded once from f64.
    c: f32,
    /// 2⁻⁶⁰/|b2·u|.
    t_lo: f32,
    /// min(T_BIG, 126/(b2·u)) where b2·u > 0, min(T_BIG, 63/|b2·u|) where it is < 0: |y'|
    /// within `exp2m1_in_range`'s domain, beyond which g' is what `exp2m1`'s clamp gives
    /// (y' ≤ −63: exp2m1 is −1 in f32) or T = 0 either way (y' ≥ 126: τ ≥ K·2¹²⁶·n/(|b|·|u|)
    /// ≥ 2.5e3, the frame check K_min/|b| ≥ 3e-35 with n ≥ |u|).
    t_hi: f32,
}

impl RowFactor {
    #[inline(always)]
    fn of(hp: &HeightPass, rp: &RowPlan) -> RowFactor {
        if hp.row_uniform {
            let b2u = hp.b2 * rp.d[hp.axis];
            let a = b2u.abs();
            if a >= hp.uni_lo && a <= UNI_HI {
                return RowFactor {
                    on: true,
                    b2u,
                    c: (1.0 / f64::from(b2u)) as f32,
                    t_lo: (f64::from(TINY) / f64::from(a)) as f32,
                    t_hi: hp
                        .t_big
                        .min((if b2u > 0.0 { 126.0 } else { 63.0 } / f64::from(a)) as f32),
                };
            }
        }
        RowFactor {
            on: false,
            b2u: 0.0,
            c: 0.0,
            t_lo: 0.0,
            t_hi: 0.0,
        }
    }
}

/// A block whose y' are all at most this skips `exp2m1`: mostly the sky looking up the
/// fog (rays clamped to t_hi in a row of constant b2·u < 0, y' = −63; to T_BIG
/// elsewhere). For y' < −25.5, k = round(y') ≤ −26, 2^k − 1 rounds to −1 and f·2^k·P(f)
/// (below 2^(k−1)·0.7 in magnitude) leaves it there, so [`exp2m1_in_range`] gives −1
/// exactly (every f32 in [−64.5, −25.5) checked by the test
/// `exp2m1::tests::minus_one_below_minus_25_5`), and [`exp2m1`] too (it clamps y' to
/// −64 first). One `maxps` per packet (and a compare per block, except in rows of constant
/// b2·u ≥ 0), about 11 operations fewer per packet in the blocks that qualify.
const FLAT_Y: f32 = -32.0;

/// The largest |b2·u| of a row that takes [`RowFactor`] (2³⁰).
const UNI_HI: f32 = 1_073_741_824.0;

/// t = depth.
const LINEAR: usize = 0;
/// t = depth / |d|.
const DISTANCE: usize = 1;
/// A perspective rasterizer's depth (standard or reversed-Z).
const NDC: usize = 2;
/// An orthographic rasterizer's depth (standard or reversed-Z): linear in the depth value.
const NDC_ORTHO: usize = 3;

impl HeightPass {
    /// The frame's constants, or `None` where this kernel does not apply: an orthographic
    /// camera that is not upright in the scene (see `row_density`),
    /// anything but one height fog layer, or constants outside the ranges of the
    /// module documentation (an eye so far above or below the fog that K_c = σ_c·ρ₀
    /// leaves [1e-30, 1e30], or K_c below about 2e-31·|b|).
    pub(crate) fn new(scene: &Scene, plan: &FramePlan) -> Option<HeightPass> {
        let single = Single::of(scene)?;
        if single.n_phases > MAX_PHASES {
            return None;
        }
        let layer = single.natural;
        // For an axis, up = e_i (dot(d, up) = d[i]).
        let (up, axis) = match scene.axis {
            UpAxis::Axis(i) => {
                let mut e = [0.0; 3];
                e[i] = 1.0;
                (e, i)
            }
            UpAxis::General => (scene.up.to_array(), 3),
        };
        let f = |v: [f32; 3]| v.map(f64::from);
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let norm = |a: [f64; 3]| dot(a, a).sqrt();
        let (o, d0, du, dv, upd) = (f(plan.o0), f(plan.d0), f(plan.d_u), f(plan.d_v), f(up));
        let b = f64::from(layer.b);
        let h0 = f64::from(layer.h0);
        // The heights the rays start at, as b·(y − h0): the eye's; for an orthographic
        // camera, the rows' (each row's origin, `FramePlan::row`, whose height every
        // pixel of the row shares where the camera plane's horizontal axis is level:
        // o = u·o_u + row.o with o_u[axis] = 0, exactly), within those at v = ±1 (the
        // rows' v lie between, and their heights, one multiply-add each, are monotone in
        // v). Not a level axis or a general up: the batch kernel. (NDC depth: t is linear
        // in the depth value, `NDC_ORTHO`; declined where far − near overflows, where
        // t = depth·∞ + near would be NaN at depth 0.)
        let (a0_min, a0_max, n_min, n_max) = if plan.ortho {
            let span_ok = match plan.depth {
                DepthPlan::Linear => true,
                DepthPlan::NdcOrthographic { span, .. } => span.is_finite(),
                _ => false,
            };
            if axis == 3 || plan.o_u[axis] != 0.0 || !span_ok {
                return None;
            }
            let y = |v: f32| f64::from(Lane::mul_add(v, plan.o_v[axis], plan.o0[axis]));
            let (a, c) = (b * (y(-1.0) - h0), b * (y(1.0) - h0));
            // One direction for every ray (d_u = d_v = 0).
            (a.min(c), a.max(c), norm(d0), norm(d0))
        } else {
            let a0 = b * (dot(o, upd) - h0);
            // |d0 + u·d_u + v·d_v| over u, v in [-1, 1]: at most the sum of the norms, at
            // least the distance of the plane d0 + span(d_u, d_v) from the origin.
            let n_max = norm(d0) + norm(du) + norm(dv);
            let cross = [
                du[1] * dv[2] - du[2] * dv[1],
                du[2] * dv[0] - du[0] * dv[2],
                du[0] * dv[1] - du[1] * dv[0],
            ];
            (a0, a0, dot(d0, cross).abs() / norm(cross), n_max)
        };
        // ln K_c = ln σ_c − a0 (K_c itself may leave even f64's range), over the frame's
        // heights.
        let positive = || layer.sigma_t.iter().filter(|&&s| s > 0.0);
        let ln_k: Vec<f64> = positive().map(|&s| f64::from(s).ln() - a0_min).collect();
        let ln_k_max = ln_k.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let ln_k_min = positive()
            .map(|&s| f64::from(s).ln() - a0_max)
            .fold(f64::INFINITY, f64::min);
        // The frame's T_BIG (module documentation): K_max·n_max·T_BIG, |b|·n_max·T_BIG
        // and n_max·T_BIG within 1e37, T_BIG at most T_BIG_MAX.
        let mut ln_t_big = f64::from(T_BIG_MAX).ln().min(1e37f64.ln() - n_max.ln());
        if !ln_k.is_empty() {
            ln_t_big = ln_t_big.min(1e37f64.ln() - ln_k_max - n_max.ln());
        }
        if b != 0.0 {
            ln_t_big = ln_t_big.min(1e37f64.ln() - b.abs().ln() - n_max.ln());
        }
        // Rounded down to a power of ten (then to f32, within a few ULP: the bounds
        // below keep a factor of 10 in hand).
        let t_big = 10f64.powf((ln_t_big / core::f64::consts::LN_10).floor() - 1.0);
        let ok = n_min.is_finite()
            && n_min > 0.0
            && n_max.is_finite()
            && a0_min.is_finite()
            && a0_max.is_finite()
            && t_big.is_finite()
            && t_big >= 1.0
            && (ln_k.is_empty()
                || (ln_k_min >= 1e-30f64.ln()
                    && ln_k_max <= 1e30f64.ln()
                    && ln_k_min + n_min.ln() + t_big.ln() >= 2e5f64.ln()
                    && ln_k_min >= (3e-35 * b.abs()).ln()));
        if !ok {
            return None;
        }
        let t_big = t_big as f32;
        // T_LO (see the field), and D_LO for distance depths.
        let k_max = ln_k_max.exp() * core::f64::consts::LOG2_E;
        let b2_abs = b.abs() * core::f64::consts::LOG2_E;
        let t_lo = (2f64.powi(-40) / (n_max * k_max.max(b2_abs))).min(2f64.powi(-40));
        let (t_lo, d_lo) = if t_lo >= 2f64.powi(-100) && t_lo * n_max >= 2f64.powi(-100) {
            (t_lo as f32, (t_lo * n_max) as f32)
        } else {
            (0.0, 0.0)
        };
        // Rows take `RowFactor` where u is constant along them (see there for the bounds).
        let row_uniform =
            axis < 3 && plan.d_u[axis] == 0.0 && n_min >= 2f64.powi(-30) && n_max <= 2f64.powi(30);
        // g' ≥ n·t·ln 2·(1 − 2⁻⁴⁰) at the least t of any row (g' grows with t): T_LO in
        // general rows, 2⁻⁶⁰/|b2·u| ≥ 2⁻⁶⁰/(|b2|·n_max) in rows that take `RowFactor`.
        let t_min = if row_uniform && b2_abs > 0.0 {
            f64::from(t_lo).min(2f64.powi(-60) / (b2_abs * n_max))
        } else {
            f64::from(t_lo)
        };
        let g_lo = if ln_k.is_empty()
            || ln_k_min + core::f64::consts::LOG2_E.ln() + (0.69 * n_min * t_min).ln()
                >= -100.0 * core::f64::consts::LN_2
        {
            0.0
        } else {
            // max_c max(|k_c|, |k2_c|) = K_max·log2(e)·max(1, log2(e)).
            (2f64.powi(-30) / (k_max * core::f64::consts::LOG2_E)) as f32
        };
        let uni_lo = if ln_k.is_empty() {
            2f64.powi(-30)
        } else {
            2f64.powi(-30).max(k_max * n_max * 2f64.powi(-20))
        };
        let sigma = layer.sigma_t.map(f64::from);
        // (An orthographic frame's rows set their own: `for_row`.)
        let (k, k2) = channel_constants(sigma, a0_min);
        // As `FramePlan::ray`: standard z = n / (1 − depth·k), sky at depth ≥ 1; reversed
        // z = n / (depth·k + q), sky at depth ≤ 0.
        let (depth, ndc) = match plan.depth {
            DepthPlan::Linear => (LINEAR, [0.0; 5]),
            DepthPlan::Distance => (DISTANCE, [0.0; 5]),
            DepthPlan::NdcPerspective { n, k, q, reversed } => (
                NDC,
                if reversed {
                    [n, k, q, -1.0, 0.0]
                } else {
                    [n, -k, 1.0, 1.0, 1.0]
                },
            ),
            // As `FramePlan::ray`: standard z = depth·span + near, sky at depth ≥ 1;
            // reversed z = far − depth·span (the same fused operation as depth·(−span) +
            // far: negating a factor is exact), sky at depth ≤ 0.
            DepthPlan::NdcOrthographic {
                n,
                f,
                span,
                reversed,
            } => (
                NDC_ORTHO,
                if reversed {
                    [0.0, -span, f, -1.0, 0.0]
                } else {
                    [0.0, span, n, 1.0, 1.0]
                },
            ),
        };
        let mut phases = [PhaseTerm::default(); MAX_PHASES];
        let mut n_phases = 0;
        if let Some(s) = single.sun {
            for (p, (phase, w)) in phases.iter_mut().zip(&single.phases[..single.n_phases]) {
                *p = PhaseTerm::new(*phase, *w, s);
            }
            n_phases = single.n_phases;
        }
        // A bound on |c| per channel: each phase value is below twice `PhaseTerm::peak` (a
        // margin far above its roundings).
        let colour_max = core::array::from_fn::<f64, 3, _>(|j| {
            phases[..n_phases]
                .iter()
                .map(|p| f64::from(p.k[j]).abs() * 2.0 * p.peak())
                .sum::<f64>()
                + f64::from(layer.colour_const[j]).abs()
        });
        let colour_bounded = colour_max.iter().all(|&c| c <= 1e38);
        // The rows' directions d = rd + u·d_u, rd = d0 + v·d_v: |d_u·rd| ≤ η·|d_u|·|rd|
        // (|rd| ≥ n_min), for `PhaseTerm::linear_error` and `LinearRow`'s n².
        let eta = (dot(du, d0).abs() + dot(du, dv).abs()) / (norm(du) * n_min);
        let row_uniform = row_uniform && uni_lo <= f64::from(UNI_HI);
        // (Any row: n² = |d|² within 2^±60 keeps the quadratic in f32's range.)
        let phase_linear = !plan.ortho
            && n_min >= 2f64.powi(-30)
            && n_max <= 2f64.powi(30)
            && n_phases == 1
            && eta <= LINEAR_ETA_MAX
            && phases[0].linear_error(eta) <= LINEAR_PHASE_BUDGET;
        let lerp = colour_max.iter().all(|&c| c <= LERP_COLOUR_MAX);
        // An orthographic frame's rays share one direction, so the sun's phase functions
        // take one value: folded into the constant fog colour (in f64, rounded once; the
        // bounds above still hold), the frame runs as one without a sun (no phase function
        // per pixel).
        let mut colour = layer.colour_const;
        if plan.ortho && n_phases > 0 {
            let v = d0.map(|x| x / norm(d0));
            colour = core::array::from_fn(|j| {
                let sun: f64 = phases[..n_phases]
                    .iter()
                    .map(|p| p.value(v) * f64::from(p.k[j]))
                    .sum();
                (f64::from(layer.colour_const[j]) + sun) as f32
            });
            phases = [PhaseTerm::default(); MAX_PHASES];
            n_phases = 0;
        }
        Some(HeightPass {
            // (Equal σ_c give equal constants in every row.)
            grey: if plan.ortho {
                sigma[0] == sigma[1] && sigma[1] == sigma[2]
            } else {
                k[0] == k[1] && k[1] == k[2]
            },
            k,
            k2,
            b2: (-f64::from(layer.b) * core::f64::consts::LOG2_E) as f32,
            up,
            axis,
            colour,
            phases,
            n_phases,
            beta: phases.iter().any(|p| p.beta != 0.0),
            colour_bounded,
            lerp,
            clamp_g: k.contains(&0.0) || k2.contains(&0.0),
            fast: scene.tier == Tier::Fast,
            depth,
            ndc,
            x8: scene.pass_lanes_8,
            zmm: !scene.no_avx512_dispatch && crate::math::avx512_detected(),
            t_big,
            t_lo,
            d_lo,
            row_uniform,
            phase_linear,
            uni_lo: uni_lo as f32,
            g_lo,
            row_density: plan.ortho,
            sigma,
            b,
            h0,
        })
    }

    /// This frame's constants for a row starting at height `y` (every pixel's, see
    /// `new`) where they depend on the row ([`HeightPass::row_density`]): K_c = σ_c·ρ₀
    /// with the row's ρ₀, formed as the frame's K_c is elsewhere (in f64, rounded once),
    /// within the frame's range of K (checked by `new` over the rows' heights).
    fn for_row(&self, y: f32) -> HeightPass {
        let (k, k2) = channel_constants(self.sigma, self.b * (f64::from(y) - self.h0));
        HeightPass { k, k2, ..*self }
    }
}

/// The channels' k_c = σ_c·e^(−a0)·log2(e) and k2_c = −σ_c·e^(−a0)·log2(e)², each rounded
/// once from f64, for the density exponent a0 = b·(y₀ − h0) at the rays' start. (σ_c = 0
/// stays 0: e^(−a0) may be +∞ here, where no channel has extinction.)
fn channel_constants(sigma: [f64; 3], a0: f64) -> ([f32; 3], [f32; 3]) {
    let k64 = sigma.map(|s| if s > 0.0 { s * (-a0).exp() } else { 0.0 });
    let k = k64.map(|k| (k * core::f64::consts::LOG2_E) as f32);
    let k2 = k64.map(|k| (-k * core::f64::consts::LOG2_E * core::f64::consts::LOG2_E) as f32);
    (k, k2)
}

impl HeightPass {
    /// [`HeightPass::phase_linear`] (`Scene::fog_pass_own_kernel`).
    pub(crate) fn phase_linear(&self) -> bool {
        self.phase_linear
    }

    /// How many of the frame's rows take [`RowFactor`] (`Scene::fog_pass_own_kernel`).
    pub(crate) fn uniform_rows(&self, plan: &FramePlan, height: usize) -> usize {
        (0..height)
            .filter(|&y| RowFactor::of(self, &plan.row(y)).on)
            .count()
    }
}

/// A frame's [`HeightPass`] and the horizontal NDC coordinate of each column, u = x·su +
/// ou as `FramePlan::ray` forms it (the same fused multiply-add, so the same bits), up to
/// a whole number of 16-pixel packets: the kernel loads u per packet instead of forming
/// it (an add and a multiply-add per packet fewer).
pub(crate) struct OwnKernel {
    pass: HeightPass,
    columns: Vec<f32>,
}

impl OwnKernel {
    /// [`HeightPass::new`] for a frame `width` pixels wide.
    pub(crate) fn new(scene: &Scene, plan: &FramePlan, width: usize) -> Option<OwnKernel> {
        let pass = HeightPass::new(scene, plan)?;
        // Counted in i32 (the frame plan checks width ≤ 2^24): i32 → f32 is one
        // instruction, usize → f32 a sequence on x86-64-v3 that took a tenth of a
        // 1920×16 frame's time. (x as f32 is exact either way.)
        let end = i32::try_from(width.div_ceil(16) * 16).ok()?;
        let columns = (0..end)
            .map(|x| Lane::mul_add(x as f32, plan.su, plan.ou))
            .collect();
        Some(OwnKernel { pass, columns })
    }
}

/// Fogs the rows `y0`, `y0 + 1`, … of `rows` (each row's depth values and colour) with
/// [`HeightPass`], in packets of [`PassWide`] pixels; a row's tail (width % 16) padded
/// into one more packet whose dead lanes are dropped.
#[inline(never)]
pub(crate) fn fog_rows<'a, R: RowColour>(
    own: &OwnKernel,
    plan: &FramePlan,
    y0: usize,
    rows: impl Iterator<Item = (&'a [f32], R)>,
) {
    let (hp, us) = (&own.pass, &own.columns[..]);
    // Monomorphized per lane width, number of sunlit phase functions (none, one, more),
    // grey or RGB and tier: the frame's choice, taken once per band of rows. (The depth
    // convention is a predictable branch per packet: as a const generic it measured no
    // faster.)
    fn flags<'a, R: RowColour, W: PassLane, const PH: usize>(
        hp: &HeightPass,
        plan: &FramePlan,
        us: &[f32],
        y0: usize,
        rows: impl Iterator<Item = (&'a [f32], R)>,
    ) {
        match (hp.grey, hp.fast) {
            (false, false) => rows_with::<R, W, PH, false, false>(hp, plan, us, y0, rows),
            (false, true) => rows_with::<R, W, PH, false, true>(hp, plan, us, y0, rows),
            (true, false) => rows_with::<R, W, PH, true, false>(hp, plan, us, y0, rows),
            (true, true) => rows_with::<R, W, PH, true, true>(hp, plan, us, y0, rows),
        }
    }
    if hp.zmm && !hp.x8 {
        // (`hp.zmm` is false in builds without the dispatch.)
        #[cfg(zmm_dispatch)]
        return zmm::fog_rows(hp, plan, us, y0, rows);
    }
    match (hp.x8, hp.n_phases) {
        (false, 0) => flags::<R, PassWide, 0>(hp, plan, us, y0, rows),
        (false, 1) => flags::<R, PassWide, 1>(hp, plan, us, y0, rows),
        (false, _) => flags::<R, PassWide, 2>(hp, plan, us, y0, rows),
        (true, 0) => flags::<R, f32x8, 0>(hp, plan, us, y0, rows),
        (true, 1) => flags::<R, f32x8, 1>(hp, plan, us, y0, rows),
        (true, _) => flags::<R, f32x8, 2>(hp, plan, us, y0, rows),
    }
}

/// [`fog_rows`] with [`crate::math::zmm::Zmm`] lanes, compiled with AVX-512 enabled
/// (everything below [`rows_with`] is inlined into it).
#[cfg(zmm_dispatch)]
#[allow(unsafe_code)]
mod zmm {
    use super::{rows_with, FramePlan, HeightPass, RowColour};
    use crate::math::zmm::Zmm;

    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
    fn rows_zmm<'a, R: RowColour, const PH: usize, const GREY: bool, const FAST: bool>(
        hp: &HeightPass,
        plan: &FramePlan,
        us: &[f32],
        y0: usize,
        rows: impl Iterator<Item = (&'a [f32], R)>,
    ) {
        rows_with::<R, Zmm, PH, GREY, FAST>(hp, plan, us, y0, rows)
    }

    /// Call only where `crate::avx512_dispatch()` is true (`HeightPass::zmm`).
    #[inline(always)]
    pub(super) fn fog_rows<'a, R: RowColour>(
        hp: &HeightPass,
        plan: &FramePlan,
        us: &[f32],
        y0: usize,
        rows: impl Iterator<Item = (&'a [f32], R)>,
    ) {
        assert!(crate::math::avx512_detected());
        // SAFETY: the CPU has the features `rows_zmm` is compiled for (asserted above).
        unsafe {
            match (hp.n_phases.min(2), hp.grey, hp.fast) {
                (0, false, false) => rows_zmm::<R, 0, false, false>(hp, plan, us, y0, rows),
                (0, false, true) => rows_zmm::<R, 0, false, true>(hp, plan, us, y0, rows),
                (0, true, false) => rows_zmm::<R, 0, true, false>(hp, plan, us, y0, rows),
                (0, true, true) => rows_zmm::<R, 0, true, true>(hp, plan, us, y0, rows),
                (1, false, false) => rows_zmm::<R, 1, false, false>(hp, plan, us, y0, rows),
                (1, false, true) => rows_zmm::<R, 1, false, true>(hp, plan, us, y0, rows),
                (1, true, false) => rows_zmm::<R, 1, true, false>(hp, plan, us, y0, rows),
                (1, true, true) => rows_zmm::<R, 1, true, true>(hp, plan, us, y0, rows),
                (_, false, false) => rows_zmm::<R, 2, false, false>(hp, plan, us, y0, rows),
                (_, false, true) => rows_zmm::<R, 2, false, true>(hp, plan, us, y0, rows),
                (_, true, false) => rows_zmm::<R, 2, true, false>(hp, plan, us, y0, rows),
                (_, true, true) => rows_zmm::<R, 2, true, true>(hp, plan, us, y0, rows),
            }
        }
    }
}

/// The rows of [`fog_rows`] with one instantiation of [`row`]: the frame's constants
/// copied to a local (kept in registers) and the block buffers made once per band.
#[inline(always)]
fn rows_with<'a, R: RowColour, W: PassLane, const PH: usize, const GREY: bool, const FAST: bool>(
    hp: &HeightPass,
    plan: &FramePlan,
    us: &[f32],
    y0: usize,
    rows: impl Iterator<Item = (&'a [f32], R)>,
) {
    let hp = *hp;
    let mut bufs = Buffers::new(&hp);
    for (k, (depth, out)) in rows.enumerate() {
        if hp.row_density {
            // An orthographic frame: the row's K_c (its height's density).
            let hr = hp.for_row(plan.row(y0 + k).o[hp.axis]);
            bufs.k3 = W::interleaved3(if hr.fast { hr.k } else { hr.k2 });
            row::<R, W, PH, GREY, FAST>(&hr, plan, us, y0 + k, depth, out, &mut bufs);
        } else {
            row::<R, W, PH, GREY, FAST>(&hp, plan, us, y0 + k, depth, out, &mut bufs);
        }
    }
}

/// Packets per block: the row is processed block by block in stages (see [`row`]).
const BLOCK: usize = 16;

/// The largest relative error of the phase value that the linear form of q may add
/// ([`PhaseTerm::linear_error`]): 2⁻¹⁷ = 7.6e-6, within the crate's tolerance on L_in
/// (10⁻⁵ of the fog colour), which the rest of the colour's roundings (a few 2⁻²⁴) leave
/// almost whole. Henyey–Greenstein's |g| up to about 0.63 (AVX2 lanes' bound).
const LINEAR_PHASE_BUDGET: f64 = 7.629_394_531_25e-6;
/// The largest η ([`PhaseTerm::linear_error`]) for the linear form: 2⁻⁶, so that n²'s
/// quadratic in u has a condition below 1.04 (a camera's d_u is orthogonal to its other
/// axes: η is a few 2⁻²⁴ for [`super::Camera::perspective`]).
const LINEAR_ETA_MAX: f64 = 0.015_625;

/// The coefficients of one row's polynomials in u ([`HeightPass::phase_linear`]): n² =
/// (a2·u + a1)·u + a0 and q = (k1·u + k0)·(1/n) + q0, from the row's direction rd + u·d_u
/// (in f64, each rounded once): no direction per pixel, and q in two fused
/// multiply-adds where |v + w|² took six (README "Zen 4, fifty-sixth session"). In a row
/// whose b·u varies (a rolled camera: no [`RowFactor`]), u = dot(d, up) = e1·u + e0 too:
/// for an axis up, e1 and e0 are that axis's components of d_u and rd, and the fused
/// multiply-add gives the bits of the direction's component (`direction`).
#[derive(Clone, Copy, Default)]
struct LinearRow {
    a2: f32,
    a1: f32,
    a0: f32,
    k1: f32,
    k0: f32,
    q0: f32,
    e1: f32,
    e0: f32,
}

impl LinearRow {
    fn new(hp: &HeightPass, plan: &FramePlan, rp: &RowPlan) -> LinearRow {
        let p = &hp.phases[0];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let (du, rd, w) = (
            plan.d_u.map(f64::from),
            rp.d.map(f64::from),
            p.w.map(f64::from),
        );
        let gg = f64::from(p.gg);
        let (e1, e0) = if hp.axis < 3 {
            (plan.d_u[hp.axis], rp.d[hp.axis])
        } else {
            let up = hp.up.map(f64::from);
            (dot(du, up) as f32, dot(rd, up) as f32)
        };
        LinearRow {
            a2: dot(du, du) as f32,
            a1: (2.0 * dot(du, rd)) as f32,
            a0: dot(rd, rd) as f32,
            k1: (2.0 * gg * dot(du, w)) as f32,
            k0: (2.0 * gg * dot(rd, w)) as f32,
            q0: (f64::from(p.base) + gg * (1.0 + dot(w, w))) as f32,
            e1,
            e0,
        }
    }
}

/// The largest fog colour (2^100) for which the pass composites as c + (L − c)·T
/// (`HeightPass::lerp`): for finite L, |L − c| rounds to at most f32::MAX (half an ULP
/// of f32::MAX is 2^103).
const LERP_COLOUR_MAX: f64 = 1.267_650_600_228_229_4e30;

/// Fogs a row in blocks of [`BLOCK`] packets, each block in stages over small buffers:
/// the rays' geometry, then their phase value or fog colour (the directions formed again:
/// four operations per packet), then the optical depth's factor g' = n·t·exp2m1(y')/y',
/// then T, L_in and the colour. One packet's work is a dependency chain of some 150 cycles
/// (the reciprocal square roots, `exp2m1`, a division and `exp2_nonpos` in sequence),
/// longer than the out-of-order window can hide when each packet runs start to end; in
/// stages, the packets of a block are independent within each loop. (Geometry and phase
/// in one loop measured 1.07× slower on Zen 5: that loop's chain ran through both
/// reciprocal square roots.)
///
/// An interleaved RGB row with at most one phase function takes the third stage in the
/// buffer's own layout: g (and the phase value) expanded to three lanes per packet
/// (`expand3`), the channel constants laid out likewise, so that the colour moves as three
/// whole lanes with no (de)interleaving; the same operations per element, so the same bits
/// as the per-channel path, which the other layouts and the row's tail take.
#[inline(always)]
fn row<R: RowColour, W: PassLane, const PH: usize, const GREY: bool, const FAST: bool>(
    hp: &HeightPass,
    plan: &FramePlan,
    us: &[f32],
    y: usize,
    depth: &[f32],
    mut out: R,
    bufs: &mut Buffers<W>,
) {
    let rp = plan.row(y);
    let rf = RowFactor::of(hp, &rp);
    // The row's polynomials in u where it takes the linear form of q (see `block_of`).
    let lr = if PH == 1 && hp.phase_linear {
        LinearRow::new(hp, plan, &rp)
    } else {
        LinearRow::default()
    };
    let width = depth.len();
    let n_lanes = W::LANES;
    let full = width / n_lanes * n_lanes;
    for (b, block) in depth[..full].chunks(n_lanes * BLOCK).enumerate() {
        let x = b * n_lanes * BLOCK;
        block_of::<R, W, PH, GREY, FAST>(
            hp, plan, &rp, &rf, &lr, us, x, block, n_lanes, bufs, &mut out,
        );
    }
    if full < width {
        // The tail, padded into one packet (depth 0 in the dead lanes, dropped).
        let mut padded = [0.0f32; 16];
        let padded = &mut padded[..n_lanes];
        padded[..width - full].copy_from_slice(&depth[full..]);
        let n = width - full;
        block_of::<R, W, PH, GREY, FAST>(
            hp, plan, &rp, &rf, &lr, us, full, padded, n, bufs, &mut out,
        );
    }
}

/// The per-block buffers of [`row`], and the row's constants in the interleaved RGB
/// layout.
struct Buffers<W> {
    /// `k`, the constant fog colour and the first phase term's weights laid out as an
    /// interleaved RGB buffer ([`PassLane::interleaved3`]).
    k3: [W; 3],
    colour3: [W; 3],
    phase_k3: [W; 3],
    ys: [W; BLOCK],
    gs: [W; BLOCK],
    /// One phase function: its value; else unused.
    ps: [W; BLOCK],
    /// More phase functions: the fog colour; else unused.
    colours: [[W; 3]; BLOCK],
    /// An interleaved RGB row, unless [`PassLane::EXPAND_IN_THIRD`]: g and the phase
    /// value expanded to the buffer's layout ([`PassLane::expand3`]) where they are
    /// computed, in a register; expanded from the buffers in the third stage, LLVM built
    /// each lane from partial loads, shuffles and blends (about 10 instructions instead
    /// of 3 permutations).
    gs3: [[W; 3]; BLOCK],
    ps3: [[W; 3]; BLOCK],
}

impl<W: PassLane> Buffers<W> {
    /// (Out of line: its `Zmm` instance is compiled without AVX-512 and calls
    /// `_mm512_loadu_ps` out of line nine times per band of rows, about 1.5 % of a frame's
    /// samples on Zen 5 in bands of two rows, before the pass's bands were made larger for
    /// this kernel (`pass::OWN_BAND_PIXELS`); inlined into the AVX-512 entry point, it moved that function's
    /// register allocation and the stage of T grew from 94 to 101 instructions per packet,
    /// 8 % slower in `passloop`: twenty-ninth session.)
    fn new(hp: &HeightPass) -> Self {
        let zero = W::splat(0.0);
        Buffers {
            k3: W::interleaved3(if hp.fast { hp.k } else { hp.k2 }),
            colour3: W::interleaved3(hp.colour),
            phase_k3: W::interleaved3(hp.phases[0].k),
            ys: [zero; BLOCK],
            gs: [zero; BLOCK],
            ps: [zero; BLOCK],
            colours: [[zero; 3]; BLOCK],
            gs3: [[zero; 3]; BLOCK],
            ps3: [[zero; 3]; BLOCK],
        }
    }
}

/// One block of [`row`]: the packets of `depth` (`W::LANES` values each, at most [`BLOCK`]) from
/// column `x_start`, the last one with `last_n` live lanes.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn block_of<R: RowColour, W: PassLane, const PH: usize, const GREY: bool, const FAST: bool>(
    hp: &HeightPass,
    plan: &FramePlan,
    rp: &RowPlan,
    rf: &RowFactor,
    lr: &LinearRow,
    us: &[f32],
    x_start: usize,
    depth: &[f32],
    last_n: usize,
    bufs: &mut Buffers<W>,
    out: &mut R,
) {
    // T = e^(−τ_c): the Fast tier's `exp_neg_fast` of τ_c = k_c·g', or 2^(k2_c·g').
    // (A function, not a closure: a closure is compiled without the `#[target_feature]` of
    // the AVX-512 entry point `zmm::rows_zmm`, and may stay out of line there.)
    let kk = if FAST { hp.k } else { hp.k2 };
    #[inline(always)]
    fn trans<W: PassLane, const FAST: bool>(k: W, g: W, c: &TableMulConsts<W>) -> W {
        if FAST {
            exp_neg_fast(k * g)
        } else {
            W::exp2_nonpos_mul(k, g, c)
        }
    }
    // The colour's clamp, left out where the frame bounds it (`HeightPass::colour_bounded`;
    // the same bits either way).
    #[inline(always)]
    fn clamp_unless<W: PassLane>(bounded: bool, c: W) -> W {
        if bounded {
            c
        } else {
            clamp_colour(c)
        }
    }
    let bounded = hp.colour_bounded;
    let lerp = hp.lerp;
    let zero = W::splat(0.0);
    let n_lanes = W::LANES;
    let m = depth.len() / n_lanes;
    let Buffers {
        k3,
        colour3,
        phase_k3,
        ys,
        gs,
        ps,
        colours,
        gs3,
        ps3,
    } = bufs;
    let (ys, gs, ps, colours) = (&mut ys[..m], &mut gs[..m], &mut ps[..m], &mut colours[..m]);
    let (gs3, ps3) = (&mut gs3[..m], &mut ps3[..m]);
    // Copies, so that the third stage keeps them in registers: read through the buffers'
    // reference, they were loaded again for every packet in the x86-64-v4 build (whose
    // `Buffers::new` is inlined).
    let (k3, colour3, phase_k3) = (*k3, *colour3, *phase_k3);
    // The third stage takes the buffer's own layout (full packets of an interleaved RGB
    // row with at most one phase function).
    let rgb3 = R::RGB3 && PH < 2;
    // Every packet of the block is full (all blocks but a row's padded tail).
    let full_block = last_n == n_lanes;
    // 1. Geometry: y' = −Δ·log2(e) (away from 0), n·t, and 1/|d| for stage 1b; and the
    // block's largest y' (see `FLAT_Y`), one `maxps` per packet with no branch in every
    // row, though rows of constant b2·u ≥ 0 do not look at it.
    let flat_test = !rf.on || rf.b2u < 0.0;
    let mut y_max = W::splat(f32::NEG_INFINITY);
    // One loop per common case (a row of constant b·u or not, with linear view depth),
    // the others in one: with the row's and the frame's choices tested inside, LLVM kept
    // them as branches in every packet (the up axis tested even where the row does not
    // use it).
    let cols = &us[x_start..x_start + m * n_lanes];
    macro_rules! geometry_loop {
        ($uni:expr, $depth:expr) => {{
            for (((((dv, uv), y), g), p), cw) in depth
                .chunks_exact(n_lanes)
                .zip(cols.chunks_exact(n_lanes))
                .zip(ys.iter_mut())
                .zip(gs.iter_mut())
                .zip(ps.iter_mut())
                .zip(colours.iter_mut())
            {
                // The depth of the next block (the next row's where this is the row's
                // last). (The colour is asked for in the third stage: see there.)
                super::prefetch_read(dv.as_ptr().wrapping_add(BLOCK * n_lanes));
                let d = direction(plan, rp, W::load(uv));
                let (yv, nt, inv_n) = geometry(hp, rf, d, W::load(dv), $uni, $depth);
                // (`Lane::max` is maxps: a NaN y', the first operand, is passed over; its
                // lane's g' stays NaN below either way.)
                y_max = Lane::max(yv, y_max);
                *y = yv;
                *g = nt;
                if PH == 1 {
                    // The phase function's view-dependent inputs for the phase loop below,
                    // in the buffers it then overwrites (`colours` is otherwise unused with
                    // one phase function).
                    let (w, c) = hp.phases[0].prepare(d, inv_n, hp.beta);
                    *cw = w;
                    if hp.beta {
                        *p = c;
                    }
                } else if PH > 1 {
                    // 1/|d| for the phase loop below (which then overwrites it).
                    *p = inv_n;
                }
            }
        }};
    }
    // The linear form of q (`HeightPass::phase_linear`): n² and q from the column's u, no
    // direction; q in the first of `colours`' three buffers.
    let linear = PH == 1 && hp.phase_linear;
    // (One copy of the loop per depth convention and kind of row, each a literal.)
    macro_rules! linear_loop {
        ($uni:expr, $depth:expr) => {{
            for ((((dv, uv), y), g), cw) in depth
                .chunks_exact(n_lanes)
                .zip(cols.chunks_exact(n_lanes))
                .zip(ys.iter_mut())
                .zip(gs.iter_mut())
                .zip(colours.iter_mut())
            {
                super::prefetch_read(dv.as_ptr().wrapping_add(BLOCK * n_lanes));
                let u = W::load(uv);
                let n2 = u
                    .mul_add(W::splat(lr.a2), W::splat(lr.a1))
                    .mul_add(u, W::splat(lr.a0));
                let inv_n = rsqrt(n2);
                // As `geometry`, with u = dot(d, up) from the column's u.
                let t = ray_t(hp, W::load(dv), inv_n, $depth);
                let up = u.mul_add(W::splat(lr.e1), W::splat(lr.e0));
                let (yv, nt) = depth_terms(hp, rf, up, n2 * inv_n, t, $uni);
                y_max = Lane::max(yv, y_max);
                *y = yv;
                *g = nt;
                cw[0] = u
                    .mul_add(W::splat(lr.k1), W::splat(lr.k0))
                    .mul_add(inv_n, W::splat(lr.q0));
            }
        }};
    }
    // An orthographic frame (`HeightPass::row_density`; its phase functions are folded
    // into the colour, PH = 0): every ray of the row has the row's direction (d_u = 0),
    // so |d| and 1/|d| are formed once per block, by `geometry`'s operations on the same
    // values (the same bits: d[c] = u·0 + rd[c] differs from rd[c] at most in the sign of
    // a zero, which the squares drop), and u = d[axis] per packet only in rows that do not
    // take `RowFactor` (as `direction` forms it). About 20 operations per packet fewer.
    macro_rules! ortho_loop {
        ($uni:expr, $depth:expr) => {{
            let (n, inv_n) =
                norm_and_inverse([W::splat(rp.d[0]), W::splat(rp.d[1]), W::splat(rp.d[2])]);
            let axis = hp.axis.min(2);
            for (((dv, uv), y), g) in depth
                .chunks_exact(n_lanes)
                .zip(cols.chunks_exact(n_lanes))
                .zip(ys.iter_mut())
                .zip(gs.iter_mut())
            {
                super::prefetch_read(dv.as_ptr().wrapping_add(BLOCK * n_lanes));
                let t = ray_t(hp, W::load(dv), inv_n, $depth);
                let u = W::load(uv).mul_add(W::splat(plan.d_u[axis]), W::splat(rp.d[axis]));
                let (yv, nt) = depth_terms(hp, rf, u, n, t, $uni);
                y_max = Lane::max(yv, y_max);
                *y = yv;
                *g = nt;
            }
        }};
    }
    if hp.row_density && PH == 0 {
        match (rf.on, hp.depth) {
            (true, LINEAR) => ortho_loop!(true, LINEAR),
            (true, _) => ortho_loop!(true, NDC_ORTHO),
            (false, LINEAR) => ortho_loop!(false, LINEAR),
            (false, _) => ortho_loop!(false, NDC_ORTHO),
        }
    } else if linear {
        match (rf.on, hp.depth) {
            (true, LINEAR) => linear_loop!(true, LINEAR),
            (true, DISTANCE) => linear_loop!(true, DISTANCE),
            // (Never `NDC_ORTHO`: orthographic frames do not take the linear form.)
            (true, _) => linear_loop!(true, NDC),
            (false, LINEAR) => linear_loop!(false, LINEAR),
            (false, DISTANCE) => linear_loop!(false, DISTANCE),
            (false, _) => linear_loop!(false, NDC),
        }
    } else {
        match (rf.on, hp.depth) {
            (true, LINEAR) => geometry_loop!(true, LINEAR),
            (false, LINEAR) => geometry_loop!(false, LINEAR),
            (uni, kind) => geometry_loop!(uni, kind),
        }
    }
    // 1b. The phase value or fog colour, in a loop of its own (see `row`).
    if linear {
        for ((p, c), p3) in ps.iter_mut().zip(colours.iter()).zip(ps3.iter_mut()) {
            let pv = pow_neg_three_halves(c[0]);
            // (As below.)
            if rgb3 && full_block && !W::EXPAND_IN_THIRD {
                *p3 = pv.expand3();
            } else {
                *p = pv;
            }
        }
    } else if PH > 0 {
        let mut x = x_start;
        for ((p, c), p3) in ps.iter_mut().zip(colours.iter_mut()).zip(ps3.iter_mut()) {
            if PH == 1 {
                let pv = hp.phases[0].finish(*c, *p, hp.beta);
                // A full block of an interleaved RGB row reads only the expanded value
                // (where the third stage does not expand it itself).
                if rgb3 && full_block && !W::EXPAND_IN_THIRD {
                    *p3 = pv.expand3();
                } else {
                    *p = pv;
                }
            } else {
                let d = direction(plan, rp, W::load(&us[x..]));
                *c = colour(hp, d, *p);
            }
            x += n_lanes;
        }
    }
    // 2. g' = n·t·exp2m1(y')/y' (= n·t·E(Δ)·ln 2), or exp2m1(y')·(n·c) in a row that
    // takes `RowFactor`, clamped to f32::MAX where some K_c = 0 (`HeightPass::clamp_g`).
    let clamp_g = hp.clamp_g;
    let (floor_g, g_lo) = (hp.g_lo > 0.0, W::splat(hp.g_lo));
    let uni = rf.on;
    // Every y' of the block at most `FLAT_Y`: exp2m1(y') is −1 there, taken as
    // fma(y', 0, −1) in rows of constant b·u (−1 for finite y', NaN for a NaN depth's
    // y': the same bits) and as −1 in the quotient by y' elsewhere.
    let flat = flat_test && !W::any(y_max.gt(W::splat(FLAT_Y)));
    let minus_one = W::splat(-1.0);
    // g' floored, clamped and stored.
    #[inline(always)]
    fn put<W: PassLane>(gv: W, g: &mut W, g3: &mut [W; 3], lim: (bool, W, bool, bool)) {
        let (floor_g, g_lo, clamp_g, three) = lim;
        // (`Lane::max`: NaN, the second operand, stays NaN.)
        let gv = if floor_g { Lane::max(g_lo, gv) } else { gv };
        let gv = if clamp_g {
            Lane::min(W::splat(f32::MAX), gv)
        } else {
            gv
        };
        if three {
            *g3 = gv.expand3();
        } else {
            *g = gv;
        }
    }
    let three = rgb3 && !GREY && full_block && !W::EXPAND_IN_THIRD;
    // One loop per case (with the cases tested inside one loop, LLVM kept fewer of the
    // third stage's constants in registers); loops, not closures (see `trans`). Where g'
    // is stored expanded (AVX2 lanes), the common case (no floor, no clamp, full
    // interleaved packets) has its own copies, its choices literals: LLVM tested them in
    // every packet.
    macro_rules! g_loops {
        ($lim:expr) => {{
            let lim = $lim;
            let each = gs.iter_mut().zip(gs3.iter_mut()).zip(ys.iter());
            match (uni, flat) {
                (true, true) => {
                    for ((g, g3), &y) in each {
                        put(y.mul_add(zero, minus_one) * *g, g, g3, lim);
                    }
                }
                (true, false) => {
                    for ((g, g3), &y) in each {
                        put(exp2m1_in_range(y) * *g, g, g3, lim);
                    }
                }
                (false, true) => {
                    for ((g, g3), &y) in each {
                        // (A NaN y' on 8 lanes, passed over by `maxps`, gives a NaN
                        // quotient.)
                        put(W::quotient(minus_one, y) * *g, g, g3, lim);
                    }
                }
                (false, false) => {
                    for ((g, g3), &y) in each {
                        put(W::quotient(exp2m1(y), y) * *g, g, g3, lim);
                    }
                }
            }
        }};
    }
    if !floor_g && !clamp_g && three {
        g_loops!((false, g_lo, false, true))
    } else {
        g_loops!((floor_g, g_lo, clamp_g, three))
    }
    // 3. T = e^(−τ_c) = 2^(k2_c·g'), L_in = colour · (1 − T), L ← L·T + L_in. T's
    // constants formed here, opaque (see `TableMulConsts`): hoisted to the row function's
    // entry, they were loaded again in every packet.
    let tc = core::hint::black_box(TableMulConsts::<W>::new());
    let mut x0 = x_start;
    for (k, (((&g, &p), c), (g3, p3))) in gs
        .iter()
        .zip(ps.iter())
        .zip(colours.iter())
        .zip(gs3.iter().zip(ps3.iter()))
        .enumerate()
    {
        let n = if k + 1 == m { last_n } else { n_lanes };
        // The colour of the same packet of the next block (the next row's start where
        // this is the row's last block), asked for now: one block ahead of its use, and
        // spread over this stage, the longest. Asked for in the geometry loop of its own
        // block (until the sixty-fifth session: README "Zen 4, sixty-fifth session"), the
        // whole block's misses were issued within that short loop and it waited on them.
        out.prefetch(x0 + BLOCK * n_lanes, n_lanes);
        if rgb3 && full_block {
            let (eg, ep);
            let (g3, p3) = if W::EXPAND_IN_THIRD {
                (eg, ep) = (g.expand3(), p.expand3());
                (&eg, &ep)
            } else {
                (g3, p3)
            };
            let t = if GREY {
                trans::<W, FAST>(W::splat(kk[0]), g, &tc).expand3()
            } else {
                [
                    trans::<W, FAST>(k3[0], g3[0], &tc),
                    trans::<W, FAST>(k3[1], g3[1], &tc),
                    trans::<W, FAST>(k3[2], g3[2], &tc),
                ]
            };
            let mut c = [zero; 3];
            for j in 0..3 {
                c[j] = if PH == 1 {
                    p3[j].mul_add(phase_k3[j], colour3[j])
                } else {
                    colour3[j]
                };
            }
            if lerp {
                // (`lerp` implies `bounded`: no clamp.)
                out.fog_rgb3(x0, t, c, true);
            } else {
                let mut insc = [zero; 3];
                for j in 0..3 {
                    insc[j] = in_scattered(clamp_unless(bounded, c[j]), t[j]);
                }
                out.fog_rgb3(x0, t, insc, false);
            }
        } else {
            let trans = if GREY {
                [trans::<W, FAST>(W::splat(kk[0]), g, &tc); 3]
            } else {
                [
                    trans::<W, FAST>(W::splat(kk[0]), g, &tc),
                    trans::<W, FAST>(W::splat(kk[1]), g, &tc),
                    trans::<W, FAST>(W::splat(kk[2]), g, &tc),
                ]
            };
            // (Written out, no closures: see `trans`.)
            let [c0, c1, c2] = hp.colour;
            let c = match PH {
                0 => [
                    clamp_unless(bounded, W::splat(c0)),
                    clamp_unless(bounded, W::splat(c1)),
                    clamp_unless(bounded, W::splat(c2)),
                ],
                1 => {
                    let [k0, k1, k2] = hp.phases[0].k;
                    [
                        clamp_unless(bounded, p.mul_add(W::splat(k0), W::splat(c0))),
                        clamp_unless(bounded, p.mul_add(W::splat(k1), W::splat(c1))),
                        clamp_unless(bounded, p.mul_add(W::splat(k2), W::splat(c2))),
                    ]
                }
                _ => *c,
            };
            if lerp {
                out.fog_wide(x0, n, trans, c, true);
            } else {
                let insc = [
                    in_scattered(c[0], trans[0]),
                    in_scattered(c[1], trans[1]),
                    in_scattered(c[2], trans[2]),
                ];
                out.fog_wide(x0, n, trans, insc, false);
            }
        }
        x0 += n_lanes;
    }
}

/// The directions of the pixels of a row at horizontal NDC coordinates `u`
/// ([`OwnKernel`]'s columns), as `FramePlan::ray` forms them.
#[inline(always)]
fn direction<W: PassLane>(plan: &FramePlan, rp: &RowPlan, u: W) -> [W; 3] {
    [
        u.mul_add(W::splat(plan.d_u[0]), W::splat(rp.d[0])),
        u.mul_add(W::splat(plan.d_u[1]), W::splat(rp.d[1])),
        u.mul_add(W::splat(plan.d_u[2]), W::splat(rp.d[2])),
    ]
}

/// L_in = c · (1 − T) = c − c·T, one fused multiply-add (one rounding instead of two).
#[inline(always)]
fn in_scattered<W: PassLane>(c: W, t: W) -> W {
    c.neg_mul_add(t, c)
}

/// The ray parameter t of depth values `depth` in the frame's convention (`depth_kind`,
/// `hp.depth`, an argument so that a loop can pass it as a literal), for rays of length
/// 1/`inv_n` per unit t: linear view depth as it is, a distance along the ray over |d|, an
/// NDC depth through the projection (+∞ for sky; a multiply-add for an orthographic one).
#[inline(always)]
fn ray_t<W: PassLane>(hp: &HeightPass, depth: W, inv_n: W, depth_kind: usize) -> W {
    match depth_kind {
        LINEAR => depth,
        // Raised first, so that the product is not formed subnormal (`HeightPass::d_lo`;
        // `Lane::max`: NaN stays NaN).
        DISTANCE => Lane::max(W::splat(hp.d_lo), depth) * inv_n,
        NDC_ORTHO => {
            let [_, k, q, sky_s, sky_at] = hp.ndc;
            let z = depth.mul_add(W::splat(k), W::splat(q));
            let sky = Lane::ge(depth * W::splat(sky_s), W::splat(sky_at));
            <W as Lane>::select(sky, W::splat(f32::INFINITY), z)
        }
        _ => {
            let [near, k, q, sky_s, sky_at] = hp.ndc;
            let z = W::splat(near) / depth.mul_add(W::splat(k), W::splat(q));
            let sky = Lane::ge(depth * W::splat(sky_s), W::splat(sky_at));
            <W as Lane>::select(sky, W::splat(f32::INFINITY), z)
        }
    }
}

/// For the rays from the eye along `d` (any length) to depth values `depth`: y' = −Δ·log2(e)
/// = b2·u·t kept away from 0 (E(Δ) = 1 below 2^-60), n·t, and 1/n; in a row that takes
/// [`RowFactor`] (`uni`: `rf.on`), y' = (b2·u)·t with t ≥ t_lo, n·c, and 1/n. `uni` and
/// `depth_kind` (`hp.depth`) are arguments so that a loop can pass them as literals.
#[inline(always)]
fn geometry<W: PassLane>(
    hp: &HeightPass,
    rf: &RowFactor,
    d: [W; 3],
    depth: W,
    uni: bool,
    depth_kind: usize,
) -> (W, W, W) {
    let (n, inv_n) = norm_and_inverse(d);
    let t = ray_t(hp, depth, inv_n, depth_kind);
    // (Not formed where `uni`: `depth_terms` does not read it there.)
    let u = match hp.axis {
        0 => d[0],
        1 => d[1],
        2 => d[2],
        _ => crate::light::dot3(d, hp.up),
    };
    let (y, nt) = depth_terms(hp, rf, u, n, t, uni);
    (y, nt, inv_n)
}

/// |d| and 1/|d| (the hardware estimate refined once, [`rsqrt`]) for [`geometry`] and the
/// orthographic rows of [`block_of`].
#[inline(always)]
fn norm_and_inverse<W: PassLane>(d: [W; 3]) -> (W, W) {
    let n2 = d[0].mul_add(d[0], d[1].mul_add(d[1], d[2] * d[2]));
    let inv_n = rsqrt(n2);
    (n2 * inv_n, inv_n)
}

/// The rest of [`geometry`] (and of the linear form's loop) from u = dot(d, up), n = |d|
/// and t: y' and n·t, or in a row that takes [`RowFactor`] (`uni`) y' = (b2·u)·t with
/// the row's b2·u and n·c.
#[inline(always)]
fn depth_terms<W: PassLane>(
    hp: &HeightPass,
    rf: &RowFactor,
    u: W,
    n: W,
    t: W,
    uni: bool,
) -> (W, W) {
    // Negative and short depths to T_LO (`Lane::max` is maxps: NaN, the second operand,
    // stays NaN); rays clamped to the frame's T_BIG (`Lane::min`: NaN stays NaN). Not
    // wide's `min`/`max`, which return the other operand for NaN.
    if uni {
        let t = Lane::min(W::splat(rf.t_hi), Lane::max(W::splat(rf.t_lo), t));
        return (W::splat(rf.b2u) * t, n * W::splat(rf.c));
    }
    let t = Lane::min(W::splat(hp.t_big), Lane::max(W::splat(hp.t_lo), t));
    let y = (W::splat(hp.b2) * u) * t;
    (W::away_from_zero(y), n * t)
}

/// The fog colour (clamped) for the view directions `d · inv_n`, any number of phase
/// functions.
#[inline(always)]
fn colour<W: PassLane>(hp: &HeightPass, d: [W; 3], inv_n: W) -> [W; 3] {
    let mut c = [
        W::splat(hp.colour[0]),
        W::splat(hp.colour[1]),
        W::splat(hp.colour[2]),
    ];
    for term in &hp.phases[..hp.n_phases] {
        let p = term.eval(d, inv_n, hp.beta);
        for ch in 0..3 {
            c[ch] = p.mul_add(W::splat(term.k[ch]), c[ch]);
        }
    }
    [clamp_colour(c[0]), clamp_colour(c[1]), clamp_colour(c[2])]
}

/// The bound behind `HeightPass::colour_bounded`, at the build's lanes.
#[cfg(test)]
mod peak_tests {
    use super::*;

    /// `PhaseTerm::linear_error` for Henyey–Greenstein terms as `HeightPass::new` builds
    /// them (a unit sun, η = 0, the figures the README gives): about 6.4e-6 at |g| = 0.6,
    /// within `LINEAR_PHASE_BUDGET` up to |g| = 0.62 and above it from 0.63 (either sign),
    /// growing with |g| and with η, +∞ for Cornette–Shanks (β ≠ 0) and for η ≥ 1/2.
    #[test]
    fn linear_error_admits_g_up_to_0_63() {
        let s = [0.3f32, 0.4, -0.866_025_4];
        let term = |g: f32| PhaseTerm::new(Phase::HenyeyGreenstein(g), [1.0; 3], s);
        let e6 = term(0.6).linear_error(0.0);
        eprintln!("linear_error, g = 0.6: {e6:.3e}");
        assert!((6.3e-6..6.5e-6).contains(&e6), "{e6}");
        for g in [0.62f32, -0.62] {
            assert!(term(g).linear_error(0.0) <= LINEAR_PHASE_BUDGET, "{g}");
        }
        for g in [0.63f32, -0.63, 0.9] {
            assert!(term(g).linear_error(0.0) > LINEAR_PHASE_BUDGET, "{g}");
        }
        assert!(term(0.3).linear_error(0.0) < term(0.5).linear_error(0.0));
        assert!(term(0.5).linear_error(0.0) < term(0.5).linear_error(LINEAR_ETA_MAX));
        assert_eq!(term(0.5).linear_error(0.5), f64::INFINITY);
        let cs = PhaseTerm::new(Phase::CornetteShanks(0.5), [1.0; 3], s);
        assert_eq!(cs.linear_error(0.0), f64::INFINITY);
    }

    /// `PhaseTerm::eval` (1/|d| from the pass's `rsqrt`, as in the pass) stays below
    /// `PhaseTerm::peak`·(1 + 1e-5) for every phase function, g up to ±0.9999, at the peak
    /// (views along and against the sun, unit and scaled directions) and around it, and
    /// comes within 1e-3 of it; `HeightPass::new` keeps a factor of 2. With the build's
    /// 8 lanes and, on a CPU with AVX-512, with `Zmm` lanes (their estimate of 1/√x and
    /// their form of q^(−3/2)).
    #[test]
    fn phase_values_stay_below_the_peak_bound() {
        let worst = peak_ratio::<f32x8>();
        eprintln!("phase values, f32x8: max p / peak bound = {worst:.7}");
        assert!(worst <= 1.0 + 1e-5, "p / peak = {worst}");
        assert!(worst >= 0.999, "the peaks were not reached: {worst}");
        #[cfg(any(zmm_dispatch, zmm_native))]
        if crate::math::avx512_detected() {
            let worst = peak_ratio::<crate::math::zmm::Zmm>();
            eprintln!("phase values, Zmm: max p / peak bound = {worst:.7}");
            assert!(worst <= 1.0 + 1e-5, "p / peak = {worst}");
            assert!(worst >= 0.999, "the peaks were not reached: {worst}");
        }
    }

    /// `pow_neg_three_halves` against f64 over q's range in the pass, [1e-8, 4] (base
    /// (1 − |g|)² down to g = ±0.9999, up to (1 + |g|)²): every 61st f32 there. Relative
    /// error at most 4·2⁻²⁴ with AVX-512's estimate (the one Newton step for x^(−3/2):
    /// 0.47·2⁻²⁴ before five roundings; measured 3.87·2⁻²⁴), 14·2⁻²⁴ with `vrsqrtps` (the refined
    /// 1/√x, within about 1.5·(1.5·2⁻¹²)² = 3.4·2⁻²⁴, cubed; measured 13.2·2⁻²⁴).
    #[test]
    fn pow_neg_three_halves_error() {
        fn worst<W: PassLane>() -> f64 {
            let (lo, hi) = (1e-8f32.to_bits(), 4f32.to_bits());
            let xs: Vec<f32> = (lo..=hi).step_by(61).map(f32::from_bits).collect();
            let n = W::LANES;
            let mut worst = 0.0f64;
            for chunk in xs.chunks(n) {
                let mut a = [1.0f32; 16];
                a[..chunk.len()].copy_from_slice(chunk);
                let mut p = [0.0f32; 16];
                pow_neg_three_halves(W::load(&a[..n])).store(&mut p[..n]);
                for (&x, &p) in chunk.iter().zip(&p) {
                    let want = f64::from(x).powf(-1.5);
                    worst = worst.max((f64::from(p) - want).abs() / want * 16_777_216.0);
                }
            }
            worst
        }
        let bound = |precise: bool| if precise { 4.0 } else { 14.0 };
        let w = worst::<f32x8>();
        eprintln!("x^(-3/2), f32x8: max relative error {w:.3}·2^-24");
        assert!(
            w <= bound(<f32x8 as PassLane>::PRECISE_RSQRT),
            "f32x8: {w}·2^-24"
        );
        #[cfg(any(zmm_dispatch, zmm_native))]
        if crate::math::avx512_detected() {
            use crate::math::zmm::Zmm;
            let w = worst::<Zmm>();
            eprintln!("x^(-3/2), Zmm: max relative error {w:.3}·2^-24");
            assert!(
                w <= bound(<Zmm as PassLane>::PRECISE_RSQRT),
                "Zmm: {w}·2^-24"
            );
        }
    }

    /// The largest evaluated p / peak bound over the test's phase functions and views.
    fn peak_ratio<W: PassLane>() -> f64 {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut rnd = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let gs = [-0.9999f32, -0.99, -0.5, 0.0, 0.3, 0.9, 0.99, 0.9999];
        let mut phases = vec![Phase::Isotropic, Phase::Rayleigh];
        for &g in &gs {
            phases.push(Phase::HenyeyGreenstein(g));
            phases.push(Phase::CornetteShanks(g));
        }
        let n = W::LANES;
        let mut worst = 0.0f64;
        for _ in 0..20 {
            let s = loop {
                let v = [rnd(), rnd(), rnd()];
                let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if n > 0.1 && n <= 1.0 {
                    break v.map(|x| x / n);
                }
            };
            for &phase in &phases {
                let term = PhaseTerm::new(phase, [1.0; 3], s);
                let peak = term.peak();
                let mut dirs = Vec::new();
                for scale in [1.0f32, 3.7, 1e-3, 250.0] {
                    dirs.push(s.map(|x| x * scale));
                    dirs.push(s.map(|x| -x * scale));
                    for k in 0..6 {
                        let e = 1e-4 * (k as f32);
                        dirs.push([0, 1, 2].map(|i| (s[i] + e * rnd()) * scale));
                        dirs.push([0, 1, 2].map(|i| (-s[i] + e * rnd()) * scale));
                    }
                    dirs.push([rnd() * scale, rnd() * scale, rnd() * scale + 2.0]);
                }
                for chunk in dirs.chunks(n) {
                    let mut lanes = [[1.0f32; 16]; 3];
                    for (k, d) in chunk.iter().enumerate() {
                        for i in 0..3 {
                            lanes[i][k] = d[i];
                        }
                    }
                    let d = lanes.map(|l| W::load(&l[..n]));
                    let n2 = d[0].mul_add(d[0], d[1].mul_add(d[1], d[2] * d[2]));
                    let mut p = [0.0f32; 16];
                    term.eval(d, rsqrt(n2), true).store(&mut p[..n]);
                    for &pk in &p[..chunk.len()] {
                        assert!(pk.is_finite() && pk >= 0.0, "{phase:?}: p = {pk}");
                        worst = worst.max(f64::from(pk) / peak);
                    }
                }
            }
        }
        worst
    }
}

#[cfg(all(test, any(zmm_dispatch, zmm_native)))]
mod tests {
    use super::*;
    use crate::math::zmm::Zmm;

    /// |q − x| in units of the f32 spacing of x's binade (x the exact quotient in f64,
    /// a normal f32 magnitude).
    fn ulps(q: f32, x: f64) -> f64 {
        let e = ((x.abs().to_bits() >> 52) & 0x7ff) as i32 - 1023;
        (f64::from(q) - x).abs() / 2f64.powi(e - 23)
    }

    /// The AVX-512 quotient of the pass (`vrcp14ps` refined) against the f64 quotient:
    /// every denominator mantissa in [1, 2) (the estimate's error depends on the mantissa
    /// only), times numerators of every exponent the pass gives (exp2m1 ∈ [−1, 2^127])
    /// and the denominators' extremes (2⁻⁶⁰ to 1.5e37, both signs).
    #[test]
    fn refined_quotient_error() {
        if !crate::avx512_dispatch() {
            eprintln!("no AVX-512 on this CPU: the refined quotient is not tested");
            return;
        }
        let nums = [
            1.0f32,
            -1.0,
            core::f32::consts::LN_2,
            1.999_999_9,
            3.0e-19,
            1.7e38,
            -0.999_999_94,
        ];
        let scales = [1.0f32, -1.0, TINY, -1.5e37, 127.0, -64.0];
        let (mut worst, mut at) = (0.0f64, (0.0f32, 0.0f32));
        let (mut over_half, mut n_all) = (0usize, 0usize);
        let mut den = [0.0f32; 16];
        for m in (0..1u32 << 23).step_by(16) {
            for (k, d) in den.iter_mut().enumerate() {
                *d = f32::from_bits(0x3f80_0000 | (m + k as u32));
            }
            for &s in &scales {
                let dv = Zmm::load(&den.map(|d| d * s));
                // A numerator mantissa that changes with every block of denominators.
                let r = f32::from_bits(0x3f80_0000 | (m.wrapping_mul(2_654_435_761) >> 9));
                for &n in nums.iter().chain([r, -r * 0.75].iter()) {
                    let mut q = [0.0f32; 16];
                    Zmm::quotient(Zmm::splat(n), dv).store(&mut q);
                    for (k, &qk) in q.iter().enumerate() {
                        let d = den[k] * s;
                        let x = f64::from(n) / f64::from(d);
                        // Quotients below f32's normal range are not the pass's.
                        if x.abs() < 1e-37 || x.abs() > 3e38 {
                            continue;
                        }
                        let e = ulps(qk, x);
                        assert!(e.is_finite(), "{n:e}/{d:e} gave {qk:e}");
                        over_half += usize::from(e > 0.5);
                        n_all += 1;
                        if e > worst {
                            (worst, at) = (e, (n, d));
                        }
                    }
                }
            }
        }
        eprintln!(
            "refined quotient: max {worst:.4} ULP at {:e}/{:e}, {over_half} of {n_all} results \
             over 0.5 ULP",
            at.0, at.1
        );
        assert!(worst <= 0.563, "{worst} ULP at {:e}/{:e}", at.0, at.1);
        let mut q = [0.0f32; 16];
        Zmm::quotient(Zmm::splat(f32::NAN), Zmm::splat(2.0)).store(&mut q);
        assert!(q[0].is_nan());
        Zmm::quotient(Zmm::splat(1.0), Zmm::splat(f32::NAN)).store(&mut q);
        assert!(q[0].is_nan());
    }

    /// `away_from_zero` on AVX-512 lanes (`vrangeps`, ±TINY) against the generic form
    /// (+TINY): the same value where |y'| ≥ TINY, the same magnitude below, and the same
    /// bits of E = exp2m1(y')/y' there; NaN becomes ±TINY (NaN in the generic form).
    #[test]
    fn away_from_zero_gives_the_generic_quotient() {
        if !crate::avx512_dispatch() {
            eprintln!("no AVX-512 on this CPU: away_from_zero is not tested");
            return;
        }
        let mut ys = vec![0.0f32, -0.0, f32::MIN_POSITIVE, 1e-45, 1e-30, 1e-20];
        for k in -4..=4 {
            ys.push(TINY * 2f32.powf(k as f32 / 2.0));
        }
        ys.extend([
            TINY * 0.999_999_94,
            TINY * 1.000_000_1,
            1e-10,
            0.5,
            127.0,
            1.5e37,
        ]);
        let ys: Vec<f32> = ys.iter().flat_map(|&y| [y, -y]).collect();
        for chunk in ys.chunks(16) {
            let mut a = [1.0f32; 16];
            a[..chunk.len()].copy_from_slice(chunk);
            let y = Zmm::load(&a);
            let (mut z, mut ez, mut e_tiny) = ([0.0f32; 16], [0.0f32; 16], [0.0f32; 16]);
            let yz = Zmm::away_from_zero(y);
            yz.store(&mut z);
            Zmm::quotient(exp2m1(yz), yz).store(&mut ez);
            let tiny = Zmm::splat(TINY);
            Zmm::quotient(exp2m1(tiny), tiny).store(&mut e_tiny);
            let mut g = [0.0f32; 8];
            for k in 0..16 {
                <f32x8 as PassLane>::away_from_zero(f32x8::splat(a[k])).store(&mut g);
                if a[k].abs() >= TINY {
                    assert_eq!(z[k].to_bits(), a[k].to_bits(), "y' = {:e}", a[k]);
                    assert_eq!(g[0].to_bits(), a[k].to_bits(), "y' = {:e}", a[k]);
                } else {
                    // −TINY for negative y' (−0 included), +TINY in the generic form:
                    // the same E.
                    assert_eq!(z[k].abs(), TINY, "y' = {:e}", a[k]);
                    assert_eq!(g[0], TINY, "y' = {:e}", a[k]);
                    assert_eq!(ez[k].to_bits(), e_tiny[k].to_bits(), "y' = {:e}", a[k]);
                }
            }
        }
        // NaN: ±TINY here (NaN in the generic form); the pass's NaN comes through n·t.
        let mut q = [0.0f32; 16];
        Zmm::away_from_zero(Zmm::splat(f32::NAN)).store(&mut q);
        assert_eq!(q[0].abs(), TINY);
        let mut g = [0.0f32; 8];
        <f32x8 as PassLane>::away_from_zero(f32x8::splat(f32::NAN)).store(&mut g);
        assert!(g[0].is_nan());
    }
}
