//! The profile integrals `∫ f(√(h² + u²)) du` over a piece [ua, ub] of the chord
//! [−w, w] of the unit ball, w = √(1 − h²), in the frame of the ray's closest approach
//! (u = 0 at the closest point, h its distance to the centre). Written once over [`Lane`].
//!
//! A piece carries its length `len` and the distances `da = w + ua`, `db = w − ub` of its
//! ends to the chord's ends, all computed without cancellation by the caller, so that
//! `g(u) = 1 − r² = (w − u)(w + u)` is a product of sums of non-negative terms anywhere on
//! the piece: `w − u = db + (ub − u)`, `w + u = da + (u − ua)`.
//!
//! | profile | f(r) | method | measured C (bound: 32) |
//! |---|---|---|---|
//! | constant | 1 | `len` | 9.7 (boxes), ≤ 6.4 (balls) |
//! | quadratic | 1 − r² = g | Simpson (exact for degree 2), positive weights | 16.3 |
//! | quartic | g² | Boole (exact for degree 4), positive weights | 6.4 |
//! | linear | 1 − r | `len − ∫√(u²+h²)`, asinh form | 4.1 |
//! | spiky | (1 − r)² | `len·(1 + h² + ū²) − 2∫√(u²+h²)`; 12-point Gauss–Legendre on (g/(1+r))² where r > 0.8 on the whole piece | 5.0 |
//! | gaussian | e^(−8r²) | `e^(−8h²)·(erfc(√8·ua) − erfc(√8·ub))·√π/(2√8)` (same side), `erf + erf` (across u = 0); 6-point Gauss–Legendre where the piece is shorter than 1/√8 and on one side | 12.6 |
//!
//! C is the largest `|I_f32 − I| / (ε·(|I| + K))` over 20 000 random rays per shape ×
//! profile (near, inside, clipped, up to 1e6 sizes away) plus the extreme and cut-out
//! tables of `tests/volumes.rs` (`cargo test --release --test volumes -- --nocapture`).
//! ε = 2⁻²⁴ and κ = 1 + K/|I| is the problem's condition number, K the change of the
//! integral under perturbations of every input (ray origin, direction, segment end, the
//! shape's centre and axes) by one f32 rounding (`reference::volume::depth_condition`),
//! so that a result within C·ε·κ is as good as exact inputs rounded to f32 allow. What drives κ, per profile:
//! - all: the camera's distance, through h (κ ≥ |o − c| · |∂I/∂h| / I), and segment ends
//!   near the boundary, where the chord length is sensitive (κ ~ 1/√(1 − h²) at tangency);
//! - linear, quadratic: the density vanishes linearly at r = 1 (κ ~ 1/(1 − r_max) for a
//!   piece that stays near the boundary);
//! - quartic, spiky: it vanishes quadratically (κ ~ 2/(1 − r_max));
//! - gaussian: `16 h²` from the factor e^(−8h²), and `16 u²` from the ends.
//!
//! ∫ √(u² + h²) du over [p, q] is `½[(q·r_q − p·r_p) + h²·(asinh(q/h) − asinh(p/h))]`, with
//! `q·r_q − p·r_p = len · ((r_p + r_q)/2 + (p + q)² / (2(r_p + r_q)))` (every term ≥ 0) and
//! `asinh(q/h) − asinh(p/h) = asinh(D)`, `D = len·(p + q)/(q·r_p + p·r_q)` when p, q have
//! the same sign (after reflecting the piece to q > 0) and `D = (q·r_p − p·r_q)/h²` across
//! zero (both terms ≥ 0). No logarithm of a cancelled sum, no `0.001 +`, and h = 0 is
//! the limit `h² · asinh(D) → 0` of the same arithmetic.

use super::Profile;
use crate::math::{asinh, erf, erfc, exp, Lane};

/// The chord of the unit ball for one ray: h² and w = √(1 − h²) (0 when the ray misses).
#[derive(Clone, Copy)]
pub(crate) struct Chord<L> {
    pub h2: L,
    pub w: L,
}

/// A piece [ua, ub] of the chord (ua ≤ ub), with `len = ub − ua`, `da = w + ua`,
/// `db = w − ub`, all ≥ 0.
#[derive(Clone, Copy)]
pub(crate) struct Piece<L> {
    pub ua: L,
    pub ub: L,
    pub len: L,
    pub da: L,
    pub db: L,
}

/// Gauss–Legendre nodes and weights on [−1, 1] (f64 Newton iteration on P_n, rounded).
const GL6: [(f32, f32); 3] = [
    (0.932_469_514_203_152, 0.171_324_492_379_170_5),
    (0.661_209_386_466_264_6, 0.360_761_573_048_138_6),
    (0.238_619_186_083_196_93, 0.467_913_934_572_691_04),
];
const GL12: [(f32, f32); 6] = [
    (0.981_560_634_246_719_2, 0.047_175_336_386_511_835),
    (0.904_117_256_370_474_8, 0.106_939_325_995_318_57),
    (0.769_902_674_194_304_7, 0.160_078_328_543_346_33),
    (0.587_317_954_286_617_5, 0.203_167_426_723_065_84),
    (0.367_831_498_998_180_2, 0.233_492_536_538_354_78),
    (0.125_233_408_511_468_94, 0.249_147_045_813_402_88),
];

/// √8 = 1 / (√2 · 0.25): u in units of the Gaussian's √2·σ.
const SQRT8: f32 = 2.828_427_124_746_190_1;
/// √π / (2√8).
const GAUSS_NORM: f32 = 0.313_328_534_328_875_03;
/// The spiky profile switches to Gauss–Legendre where r > SPIKY_SHELL on the whole piece.
const SPIKY_SHELL2: f32 = 0.64;
const TINY: f32 = 1e-30;

/// g² of the quartic profile at the node u_a + k·len/4 of Boole's rule (`q` = len/4).
#[inline(always)]
fn quartic_node<L: Lane>(q: L, k: f32, pc: &Piece<L>) -> L {
    let v = q.mul_add(L::splat(4.0 - k), pc.db) * q.mul_add(L::splat(k), pc.da);
    v * v
}

/// The integrand at u of the Gauss–Legendre rules (`wmu`, `wpu`: w − u and w + u; `h2`:
/// the chord's h²): the spiky profile's ρ² where `SPIKY`, else the Gaussian's e^(−8r²).
/// (A const parameter rather than a closure argument: see `rgb!`.)
#[inline(always)]
fn integrand<L: Lane, const SPIKY: bool>(u: L, wmu: L, wpu: L, h2: L) -> L {
    if SPIKY {
        let r = u.mul_add(u, h2).sqrt();
        let rho = wmu * wpu / (L::splat(1.0) + r);
        rho * rho
    } else {
        exp(L::splat(-8.0) * u.mul_add(u, h2))
    }
}

/// Sums `weight · integrand(u, w − u, w + u)` ([`integrand`]) over the Gauss–Legendre
/// nodes of the piece, times len/2.
#[inline(always)]
fn gauss_legendre<L: Lane, const N: usize, const SPIKY: bool>(
    nodes: &[(f32, f32); N],
    p: &Piece<L>,
    h2: L,
) -> L {
    let half = p.len * L::splat(0.5);
    let mid = (p.ua + p.ub) * L::splat(0.5);
    let mut acc = L::splat(0.0);
    for &(x, wt) in nodes {
        for s in [x, -x] {
            let u = half.mul_add(L::splat(s), mid);
            let wmu = half.mul_add(L::splat(1.0 - s), p.db);
            let wpu = half.mul_add(L::splat(1.0 + s), p.da);
            acc = L::splat(wt).mul_add(integrand::<L, SPIKY>(u, wmu, wpu, h2), acc);
        }
    }
    acc * half
}

/// The piece reflected so that `q > 0` when it does not straddle 0 (f is even in u):
/// returns (p, q) with p ≤ q, q ≥ |p| or p ≥ 0.
#[inline(always)]
fn reflect<L: Lane>(pc: &Piece<L>) -> (L, L) {
    let neg = pc.ub.le(L::splat(0.0));
    (
        L::select(neg, pc.ub.neg(), pc.ua),
        L::select(neg, pc.ua.neg(), pc.ub),
    )
}

/// ∫ √(u² + h²) du over the piece (see the module header).
#[inline(always)]
fn sqrt_integral<L: Lane>(c: &Chord<L>, pc: &Piece<L>) -> L {
    let half = L::splat(0.5);
    let tiny = L::splat(TINY);
    let (p, q) = reflect(pc);
    let rp = p.mul_add(p, c.h2).sqrt();
    let rq = q.mul_add(q, c.h2).sqrt();
    let sr = (rp + rq).max(tiny);
    let s = p + q;
    let t1 = pc.len * (sr * half + s * s / (sr + sr));
    let straddle = p.lt(L::splat(0.0));
    let d_same = pc.len * s / q.mul_add(rp, p * rq).max(tiny);
    let d_str = q.mul_add(rp, (p * rq).neg()) / c.h2.max(tiny);
    let d = L::select(straddle, d_str, d_same);
    half * c.h2.mul_add(asinh(d), t1)
}

/// ∫ f(√(h² + u²)) du over the piece, for a ball.
#[inline(always)]
pub(crate) fn integral<L: Lane>(profile: Profile, c: &Chord<L>, pc: &Piece<L>) -> L {
    let zero = L::splat(0.0);
    let len = pc.len;
    let r = match profile {
        Profile::Constant => len,
        Profile::Quadratic => {
            // Simpson, exact for g of degree 2.
            let half = len * L::splat(0.5);
            let ga = (pc.db + len) * pc.da;
            let gb = pc.db * (pc.da + len);
            let gm = (pc.db + half) * (pc.da + half);
            len * gm.mul_add(L::splat(4.0), ga + gb) * L::splat(1.0 / 6.0)
        }
        Profile::Quartic => {
            // Boole, exact for g² of degree 4.
            let q = len * L::splat(0.25);
            let g = |k: f32| quartic_node(q, k, pc);
            let s = L::splat(7.0).mul_add(g(0.0) + g(4.0), L::splat(32.0) * (g(1.0) + g(3.0)));
            len * L::splat(12.0).mul_add(g(2.0), s) * L::splat(1.0 / 90.0)
        }
        Profile::Linear => len - sqrt_integral(c, pc),
        Profile::Spiky => {
            let (p, _) = reflect(pc);
            let rmin2 = L::select(p.gt(zero), p.mul_add(p, c.h2), c.h2);
            let shell = rmin2.ge(L::splat(SPIKY_SHELL2));
            let mut v = zero;
            if L::any(!shell) {
                // len · (1 + h² + (ua² + ua·ub + ub²)/3) − 2∫r
                let s3 = pc.ua.mul_add(pc.ua, pc.ub.mul_add(pc.ub, pc.ua * pc.ub));
                let poly = s3.mul_add(L::splat(1.0 / 3.0), L::splat(1.0) + c.h2);
                v = len.mul_add(poly, L::splat(-2.0) * sqrt_integral(c, pc));
            }
            if L::any(shell) {
                let gl = gauss_legendre::<L, _, true>(&GL12, pc, c.h2);
                v = L::select(shell, gl, v);
            }
            v
        }
        Profile::Gaussian => {
            let (p, q) = reflect(pc);
            let same = p.ge(zero);
            let short = same & (len * L::splat(SQRT8)).lt(L::splat(1.0));
            let mut v = zero;
            if L::any(!short) {
                let xp = p * L::splat(SQRT8);
                let xq = q * L::splat(SQRT8);
                let a = L::select(same, erfc(xp) - erfc(xq), erf(xq) + erf(xp.neg()));
                v = exp(L::splat(-8.0) * c.h2) * a * L::splat(GAUSS_NORM);
            }
            if L::any(short) {
                let gl = gauss_legendre::<L, _, false>(&GL6, pc, c.h2);
                v = L::select(short, gl, v);
            }
            v
        }
    };
    // The density is ≥ 0: a negative result (linear and spiky subtract nearly equal terms
    // where the density vanishes) is rounding, and τ must not go below 0 (fuzz/volumes).
    L::select(len.gt(zero), r.max(zero), zero)
}
