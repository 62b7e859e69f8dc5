//! The volumes' optical depth and fog colour for one packet of rays (1 or 8 lanes).
//!
//! Per ray and volume: the origin and the unit direction are mapped to the volume's unit
//! space (`q = M⁻¹(o − c)`, `e = M⁻¹·dir`), and the ray is re-parametrised about its closest
//! approach to the centre: `σ_c = −dot(q, e)/|e|²` (world distance to it), `q_c = q + σ_c·e`
//! (the closest point, |q_c| = h). Everything after that is O(1) in unit space, whatever
//! the camera's distance; only the clip at the origin and at t (seed 004's depth-buffer
//! clip) refers back to the ray's own parameter.
//!
//! Balls: `u = |e|·(σ − σ_c)` is the unit-space arc length, the chord is [−w, w] and the
//! world length is `du / |e|`. Cubes: the slabs |q_c + v·e| ≤ 1 in `v = σ − σ_c`, in world
//! units directly; the edge fade is a product of three piecewise-linear ramps, a cubic
//! between the 12 points where a ramp bends, integrated by Simpson's rule per piece (exact
//! for cubics).
//!
//! Cut-outs: each cut's chord, as world distances from its own closest approach, is
//! moved into each additive volume's frame by `σ_c,cut − σ_c`; the cuts are sorted by
//! their start per lane and swept once, integrating the additive volume over the gaps.

use super::profile::{integral, Chord, Piece};
use super::{Kind, VolumePlan, VolumeSet, MAX_CUTS};
use crate::math::{ldexp, Lane};
use crate::scene::Scene;

/// One volume a packet touches, for the ordered composition (`Composition::Ordered`):
/// where each ray enters it (world distance from the ray's start; 0 where the ray misses
/// it, whose τ is then 0), its optical depth and its fog colour (clamped to f32::MAX).
#[derive(Clone, Copy)]
pub(crate) struct Entry<L> {
    pub s: L,
    pub tau: [L; 3],
    pub colour: [L; 3],
}

/// The volumes' contribution for a packet: optical depth per channel, and (if asked) the
/// τ-weighted mix of their fog colours.
#[derive(Clone, Copy)]
pub(crate) struct VolOut<L> {
    pub tau: [L; 3],
    pub colour: [L; 3],
}

impl<L: Lane> VolOut<L> {
    /// Mixes `colour_h` (the height fog's colour, optical depth `tau_h`) with the volumes'
    /// colour by optical depth, for channel `ch`. The weights saturate at τ = 1e30.
    #[inline(always)]
    pub(crate) fn mix(&self, ch: usize, colour_h: L, tau_h: L) -> L {
        let cap = L::splat(1e30);
        let tv = self.tau[ch].min(cap);
        let th = tau_h.min(cap);
        let zero = L::splat(0.0);
        let sum = tv + th;
        let wv = L::select(sum.gt(zero), tv / sum, zero);
        // Both colours are clamped to f32::MAX (`clamp_colour`), so the difference is
        // finite: no ∞ − ∞ or 0 · ∞ from a colour that overflowed (found by fuzz/volumes).
        let cv = clamp_colour(self.colour[ch]);
        wv.mul_add(cv - colour_h, colour_h)
    }
}

/// A fog colour can overflow to +∞ at run time (a huge sun radiance times a phase peak);
/// f32::MAX keeps `colour · (1 − T)` and the colour mixes free of NaN. NaN stays NaN.
#[inline(always)]
pub(crate) fn clamp_colour<L: Lane>(c: L) -> L {
    // vminps(a, b) = a < b ? a : b: NaN in `c` is returned as is.
    L::splat(f32::MAX).min(c)
}

const FAR: f32 = 1e18;

/// A ray in one volume's frame.
#[derive(Clone, Copy)]
struct Frame<L> {
    /// World distance from the origin to the closest approach (along the unit direction).
    sc: L,
    /// The closest point in unit space.
    qc: [L; 3],
    /// The unit direction in unit space, and its length.
    e: [L; 3],
    a: L,
    /// dot(q, e/|e|): the unit-space coordinate of the origin about the closest approach.
    uo: L,
}

/// Row `r` of the matrix `m` times `x` (the products and sums in the order every
/// transform here takes).
#[inline(always)]
fn mat_row<L: Lane>(m: &[[f32; 3]; 3], x: &[L; 3], r: usize) -> L {
    x[0].mul_add(
        L::splat(m[r][0]),
        x[1].mul_add(L::splat(m[r][1]), x[2] * L::splat(m[r][2])),
    )
}

#[inline(always)]
fn frame<L: Lane>(v: &VolumePlan, o: &[L; 3], dir: &[L; 3]) -> Frame<L> {
    let big = L::splat(1.0e25);
    let far = L::splat(FAR);
    // |o − c| ≤ 1e25 and |M⁻¹| ≤ 1e12·√3: the products below cannot overflow (so no
    // inf − inf); a camera farther than that sees the volume as a point anyway.
    let dq = rgb!(i => (o[i] - L::splat(v.center[i])).clamp(big.neg(), big));
    let q = rgb!(r => mat_row(&v.inv, &dq, r).clamp(far.neg(), far));
    frame_at(v, q, dir)
}

/// The frame of a ray whose origin is `q` in the volume's unit space.
#[inline(always)]
fn frame_at<L: Lane>(v: &VolumePlan, q: [L; 3], dir: &[L; 3]) -> Frame<L> {
    let e = rgb!(r => mat_row(&v.inv, dir, r));
    let ee = e[0].mul_add(e[0], e[1].mul_add(e[1], e[2] * e[2]));
    let a = ee.sqrt().max(L::splat(1e-30));
    let inv_a = L::splat(1.0) / a;
    let eh = rgb!(i => e[i] * inv_a);
    let uo = q[0].mul_add(eh[0], q[1].mul_add(eh[1], q[2] * eh[2]));
    let qc = rgb!(i => uo.mul_add(eh[i].neg(), q[i]));
    // Project twice ("twice is enough"): for a far origin u_o is large and the first
    // projection leaves an error of ε·|u_o| along ê, which would enter h² squared (a
    // thin ellipsoid seen edge-on from 1e5 away loses its chord otherwise). The second
    // removes it to ε² · |u_o|.
    let du = qc[0].mul_add(eh[0], qc[1].mul_add(eh[1], qc[2] * eh[2]));
    let qc = rgb!(i => du.mul_add(eh[i].neg(), qc[i]));
    let uo = uo + du;
    Frame {
        sc: uo.neg() * inv_a,
        qc,
        e,
        a,
        uo,
    }
}

/// The ball's chord and the piece of it within [0, t_w] (world distance along the ray).
#[inline(always)]
fn ball_piece<L: Lane>(f: &Frame<L>, t_w: L) -> (Chord<L>, Piece<L>) {
    let zero = L::splat(0.0);
    let h2 = f.qc[0].mul_add(f.qc[0], f.qc[1].mul_add(f.qc[1], f.qc[2] * f.qc[2]));
    let w = (L::splat(1.0) - h2).max(zero).sqrt();
    let w2 = w + w;
    let at = f.a * t_w;
    let ut = f.uo + at;
    let len = w2.min(at).min((w - f.uo).min(w + ut)).max(zero);
    let ua = f.uo.clamp(w.neg(), w);
    let ub = ut.clamp(w.neg(), w);
    let da = (w + f.uo).clamp(zero, w2);
    let db = (w - ut).clamp(zero, w2);
    (
        Chord { h2, w },
        Piece {
            ua,
            ub,
            len,
            da,
            db,
        },
    )
}

/// The cube's slab interval [v_in, v_out] about the closest approach (v_in > v_out when
/// the line misses).
#[inline(always)]
fn cube_interval<L: Lane>(f: &Frame<L>) -> (L, L) {
    let inf = L::splat(f32::INFINITY);
    let one = L::splat(1.0);
    let mut lo = inf.neg();
    let mut hi = inf;
    for i in 0..3 {
        let e = f.e[i];
        let q = f.qc[i];
        let zero_e = e.abs().lt(L::splat(1e-30));
        let inv = one / L::select(zero_e, one, e);
        let v1 = (one.neg() - q) * inv;
        let v2 = (one - q) * inv;
        let inside = q.abs().le(one);
        let l = L::select(zero_e, L::select(inside, inf.neg(), inf), v1.min(v2));
        let h = L::select(zero_e, L::select(inside, inf, inf.neg()), v1.max(v2));
        lo = lo.max(l);
        hi = hi.min(h);
    }
    (lo, hi)
}

/// The box density `Π clamp((1 − |q_c + v·e|) / fade, 0, 1)` at v.
#[inline(always)]
fn fade_at<L: Lane>(f: &Frame<L>, inv_fade: L, v: L) -> L {
    let one = L::splat(1.0);
    let mut p = one;
    for i in 0..3 {
        let x = v.mul_add(f.e[i], f.qc[i]).abs();
        p = p * ((one - x) * inv_fade).clamp(L::splat(0.0), one);
    }
    p
}

/// ∫ box density dv over [va, vb] (va ≤ vb inside the slab interval).
#[inline(always)]
fn cube_integral<L: Lane>(plan: &VolumePlan, f: &Frame<L>, va: L, vb: L) -> L {
    let zero = L::splat(0.0);
    let len = (vb - va).max(zero);
    if plan.edge_fade <= 0.0 {
        return len;
    }
    let one = L::splat(1.0);
    let fade = plan.edge_fade;
    // The 12 points where a ramp bends, clamped into [va, vb], sorted.
    let mut b = [zero; 12];
    for i in 0..3 {
        let e = f.e[i];
        let zero_e = e.abs().lt(L::splat(1e-30));
        let inv = one / L::select(zero_e, one, e);
        for (k, x) in [-1.0, -1.0 + fade, 1.0 - fade, 1.0].into_iter().enumerate() {
            let v = (L::splat(x) - f.qc[i]) * inv;
            b[4 * i + k] = L::select(zero_e, va, v.clamp(va, vb));
        }
    }
    // Odd-even transposition sort (12 rounds: sorted for any input order).
    for round in 0..12 {
        let mut j = round % 2;
        while j + 1 < 12 {
            let (x, y) = (b[j], b[j + 1]);
            b[j] = x.min(y);
            b[j + 1] = x.max(y);
            j += 2;
        }
    }
    let inv_fade = L::splat(1.0 / fade);
    let mut acc = zero;
    let mut prev = va;
    let mut f_prev = fade_at(f, inv_fade, va);
    for k in 0..13 {
        let next = if k < 12 { b[k] } else { vb };
        let h = next - prev;
        let fm = fade_at(f, inv_fade, (prev + next) * L::splat(0.5));
        let f_next = fade_at(f, inv_fade, next);
        acc = h.mul_add(fm.mul_add(L::splat(4.0), f_prev + f_next), acc);
        prev = next;
        f_prev = f_next;
    }
    L::select(len.gt(zero), acc * L::splat(1.0 / 6.0), zero)
}

/// The cut-outs' intervals along the ray in one additive volume's coordinate v (world
/// distance from that volume's closest approach), sorted by their start; empty intervals
/// are (+inf, +inf).
///
/// Each cut's frame is taken from the additive volume's closest point x_c = c + M·q_c,
/// written relative to the cut's centre as `(c − c_cut) + M·q_c` (a per-scene constant
/// plus an O(size) vector), never from the far origin: the two volumes' positions along
/// the ray are then as accurate relative to each other as the scene's geometry, and a
/// far camera shifts them together, as a perturbation of its position would.
#[inline(always)]
fn cut_spans<L: Lane>(
    set: &VolumeSet,
    k: usize,
    f: &Frame<L>,
    dir: &[L; 3],
    out: &mut [(L, L); MAX_CUTS],
) {
    let plan = &set.additive[k];
    let fm = &plan.fwd;
    // x_c − c, world.
    let xr = rgb!(r => mat_row(fm, &f.qc, r));
    let inf = L::splat(f32::INFINITY);
    let far = L::splat(FAR);
    for (j, cut) in set.cuts.iter().enumerate() {
        let off = plan.cut_offsets[j];
        let dq = rgb!(i => xr[i] + L::splat(off[i]));
        let q = rgb!(r => mat_row(&cut.inv, &dq, r).clamp(far.neg(), far));
        let g = frame_at(cut, q, dir);
        let (lo, hi) = match cut.kind {
            Kind::Ball => {
                let (c, _) = ball_piece(&g, L::splat(0.0));
                let r = c.w / g.a;
                (r.neg(), r)
            }
            Kind::Cube => cube_interval(&g),
        };
        let empty = lo.ge(hi);
        out[j] = (
            L::select(empty, inf, g.sc + lo),
            L::select(empty, inf, g.sc + hi),
        );
    }
    // Sort by start (insertion by compare-exchange, per lane).
    let n = set.cuts.len();
    for i in 1..n {
        for j in (1..=i).rev() {
            let (x, y) = (out[j - 1], out[j]);
            let swap = x.0.gt(y.0);
            out[j - 1] = (L::select(swap, y.0, x.0), L::select(swap, y.1, x.1));
            out[j] = (L::select(swap, x.0, y.0), L::select(swap, x.1, y.1));
        }
    }
}

/// ∫ density · world length over the additive volume's segment minus the cuts.
#[inline(always)]
///
/// Also returns the world distance at which the ray enters the volume's clipped segment
/// (cut-outs ignored; for the ordered composition; unspecified where the segment is
/// empty).
fn volume_depth<L: Lane>(set: &VolumeSet, k: usize, o: &[L; 3], dir: &[L; 3], t_w: L) -> (L, L) {
    let plan = &set.additive[k];
    let f = frame(plan, o, dir);
    let zero = L::splat(0.0);
    if set.cuts.is_empty() {
        // No cut-outs: the same operations as the branches below take without cuts, but
        // without the span array (whose zeroing, 1 KB for 8 lanes, cost ~3 % of a frame
        // of small volumes).
        return match plan.kind {
            Kind::Ball => {
                let (chord, seg) = ball_piece(&f, t_w);
                let inv_a = L::splat(1.0) / f.a;
                (
                    integral(plan.profile, &chord, &seg) * inv_a,
                    seg.ua.mul_add(inv_a, f.sc),
                )
            }
            Kind::Cube => {
                let (lo, hi) = cube_interval(&f);
                let va = lo.max(f.sc.neg());
                let vb = hi.min(t_w - f.sc);
                (cube_integral(plan, &f, va, vb.max(va)), f.sc + va)
            }
        };
    }
    let mut spans = [(zero, zero); MAX_CUTS];
    cut_spans(set, k, &f, dir, &mut spans);
    let cuts = &spans[..set.cuts.len()];
    match plan.kind {
        Kind::Ball => {
            let (chord, seg) = ball_piece(&f, t_w);
            let inv_a = L::splat(1.0) / f.a;
            let entry = seg.ua.mul_add(inv_a, f.sc);
            let w = chord.w;
            // Sweep the sorted cuts in this ball's u coordinate.
            let mut pos = seg.ua;
            let mut pos_d = seg.da;
            let mut acc = zero;
            for &(lo, hi) in cuts {
                let ca = f.a * lo;
                let cb = f.a * hi;
                let end_is_ub = ca.ge(seg.ub);
                let end = L::select(end_is_ub, seg.ub, ca.max(pos));
                let end_d = L::select(end_is_ub, seg.db, (w - end).max(zero));
                let whole = end_is_ub & pos.eq(seg.ua);
                let len = L::select(whole, seg.len, (end - pos).max(zero));
                let piece = Piece {
                    ua: pos,
                    ub: end,
                    len,
                    da: pos_d,
                    db: end_d,
                };
                acc = acc + integral(plan.profile, &chord, &piece);
                let cbc = cb.min(seg.ub);
                let moved = cbc.gt(pos);
                pos = L::select(moved, cbc, pos);
                pos_d = L::select(moved, (w + cbc).max(zero), pos_d);
            }
            let whole = pos.eq(seg.ua);
            let piece = Piece {
                ua: pos,
                ub: seg.ub,
                len: L::select(whole, seg.len, (seg.ub - pos).max(zero)),
                da: pos_d,
                db: seg.db,
            };
            acc = acc + integral(plan.profile, &chord, &piece);
            (acc * inv_a, entry)
        }
        Kind::Cube => {
            let (lo, hi) = cube_interval(&f);
            let va = lo.max(f.sc.neg());
            let vb = hi.min(t_w - f.sc);
            let mut pos = va;
            let mut acc = zero;
            for &(ca, cb) in cuts {
                let end = ca.min(vb).max(pos);
                acc = acc + cube_integral(plan, &f, pos, end);
                pos = pos.max(cb.min(vb));
            }
            (acc + cube_integral(plan, &f, pos, vb.max(pos)), f.sc + va)
        }
    }
}

/// Per-lane culling test: whether the segment o + s·dir, s in [0, t_w] (dir unit; lanes
/// whose dir is not are always kept) may come within the volume's bounding sphere.
/// Conservative: the distance is computed in f32, so the sphere is widened by 1e-5 of the
/// coordinates' magnitudes (far more than their rounding) and by 1e-3 of its radius; NaN
/// lanes (invalid rays) give false, and their outputs are NaN regardless.
#[inline(always)]
fn may_touch<L: Lane>(
    plan: &VolumePlan,
    o: &[L; 3],
    dir: &[L; 3],
    t_w: L,
    packet: &CullPacket<L>,
) -> L::Mask {
    let q = rgb!(c => L::splat(plan.center[c]) - o[c]);
    let along = q[0] * dir[0] + q[1] * dir[1] + q[2] * dir[2];
    let s = along.max(L::splat(0.0)).min(t_w);
    let p = rgb!(c => s.neg_mul_add(dir[c], q[c]));
    let d2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
    let mag = q[0].abs() + q[1].abs() + q[2].abs() + packet.o_mag;
    let r = L::splat(plan.bound_radius * 1.001) + mag * L::splat(1e-5);
    d2.le(r * r) | packet.not_unit
}

/// What [`may_touch`] needs of a packet that does not depend on the volume.
struct CullPacket<L: Lane> {
    /// |o|₁, for the margin.
    o_mag: L,
    /// Lanes whose direction is not unit length: a batch declared unit whose directions
    /// are not is a broken promise with an unspecified result, but x8 and scalar must
    /// still agree, so such lanes are never culled.
    not_unit: L::Mask,
}

impl<L: Lane> CullPacket<L> {
    #[inline(always)]
    fn new(o: &[L; 3], dir: &[L; 3]) -> Self {
        let dd = dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2];
        CullPacket {
            o_mag: o[0].abs() + o[1].abs() + o[2].abs(),
            not_unit: (dd - L::splat(1.0)).abs().gt(L::splat(1e-3)),
        }
    }
}

/// The volumes' optical depth and colour for a packet: `o` the origins, `d` the
/// directions as given, `t` the length parameter, `norm` the mantissa and exponent of |d|
/// (`direction_norm`), `dir` the unit directions (zero for a zero direction); the
/// segment's length in world units, t·|d|, may be +inf; invalid rays get τ = NaN. `sun`:
/// toward the sun, used where some colour depends on the view direction and radiance is
/// wanted (`WANT_L`). `entries`: where given (and `WANT_L`), each volume the packet does
/// not skip is appended there as an [`Entry`], for the ordered composition.
///
/// (The nine arguments stay separate: bundling the rays' six into one struct passed by
/// value made the AVX-512 twin, `kernel::zmm::packet_volumes`, 1.12–1.14× slower on the
/// `volumes/{constant,quartic}/x8` benches, sixty-second session.)
///
/// `volumes`: the additive volumes to consider, as increasing indices into
/// `scene.volumes.additive` (`None`: all of them). The framebuffer pass passes a tile's
/// candidates; every volume left out must be one that [`may_touch`] rejects for every
/// lane, so that the result is bit-identical to `None` (a rejected volume contributes
/// exactly nothing). Cut-outs are never left out.
#[inline(never)] // one copy per (L, UNIT, WANT_L), not one per kernel variant: keeps compile time sane
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_volumes<L: Lane, const UNIT: bool, const WANT_L: bool>(
    scene: &Scene,
    o: &[L; 3],
    d: &[L; 3],
    t: L,
    norm: (L, L),
    dir: &[L; 3],
    sun: Option<[f32; 3]>,
    volumes: Option<&[u32]>,
    entries: Option<&mut Vec<Entry<L>>>,
) -> VolOut<L> {
    eval_volumes_body::<L, UNIT, WANT_L>(scene, o, d, t, norm, dir, sun, volumes, entries)
}

/// How the general kernel evaluates a packet's volumes: [`OutOfLine`] calls
/// [`eval_volumes`]; the AVX-512 entry point of the x86-64-v3 build has its own
/// `#[target_feature]` copy (`kernel::zmm`), since code compiled without AVX-512 would
/// call every `Zmm` intrinsic out of line.
pub(crate) trait VolumeEval<L: Lane> {
    #[allow(clippy::too_many_arguments)]
    fn eval<const UNIT: bool, const WANT_L: bool>(
        scene: &Scene,
        o: &[L; 3],
        d: &[L; 3],
        t: L,
        norm: (L, L),
        dir: &[L; 3],
        sun: Option<[f32; 3]>,
        volumes: Option<&[u32]>,
        entries: Option<&mut Vec<Entry<L>>>,
    ) -> VolOut<L>;
}

/// [`VolumeEval`] by a call to [`eval_volumes`].
pub(crate) struct OutOfLine;

impl<L: Lane> VolumeEval<L> for OutOfLine {
    #[inline(always)]
    fn eval<const UNIT: bool, const WANT_L: bool>(
        scene: &Scene,
        o: &[L; 3],
        d: &[L; 3],
        t: L,
        norm: (L, L),
        dir: &[L; 3],
        sun: Option<[f32; 3]>,
        volumes: Option<&[u32]>,
        entries: Option<&mut Vec<Entry<L>>>,
    ) -> VolOut<L> {
        eval_volumes::<L, UNIT, WANT_L>(scene, o, d, t, norm, dir, sun, volumes, entries)
    }
}

/// The body of [`eval_volumes`], inlined into its callers.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn eval_volumes_body<L: Lane, const UNIT: bool, const WANT_L: bool>(
    scene: &Scene,
    o: &[L; 3],
    d: &[L; 3],
    t: L,
    norm: (L, L),
    dir: &[L; 3],
    sun: Option<[f32; 3]>,
    volumes: Option<&[u32]>,
    mut entries: Option<&mut Vec<Entry<L>>>,
) -> VolOut<L> {
    let zero = L::splat(0.0);
    // NaN for invalid rays (a non-finite origin or direction, t NaN or negative).
    #[allow(clippy::eq_op)] // x − x is NaN exactly when x is not finite
    let valid = (o[0] - o[0]).eq(zero)
        & (o[1] - o[1]).eq(zero)
        & (o[2] - o[2]).eq(zero)
        & (d[0] - d[0]).eq(zero)
        & (d[1] - d[1]).eq(zero)
        & (d[2] - d[2]).eq(zero)
        & t.ge(zero);
    // The segment's length in world units: t · |d| (0 for t = 0 or d = 0).
    let t_w = if UNIT {
        t
    } else {
        let dlen = ldexp(norm.0, norm.1);
        L::select(t.eq(zero) | dlen.eq(zero), zero, t * dlen)
    };
    let (o, dir) = (*o, *dir);
    let set = &scene.volumes;
    let mut out = VolOut {
        tau: [zero; 3],
        colour: [zero; 3],
    };
    let mut num = [zero; 3];
    let mut den = [zero; 3];
    let cap = L::splat(1e30);
    let t_w = t_w.min(L::splat(f32::MAX));
    let cull = CullPacket::new(&o, &dir);
    let count = volumes.map_or(set.additive.len(), |v| v.len());
    for j in 0..count {
        let k = match volumes {
            Some(v) => v[j] as usize,
            None => j,
        };
        let plan = &set.additive[k];
        // Lanes whose segment cannot come near the volume get a depth of exactly 0 (the
        // closed forms could leave a rounding residue, e.g. ~1e-43, which a huge
        // extinction makes visible); a packet with no such lane skips the volume, which
        // then changes no result (0 · colour adds nothing either).
        let near = may_touch(plan, &o, &dir, t_w, &cull);
        if !set.no_culling && !L::any(near) {
            continue;
        }
        // Capped so that a zero extinction channel gives 0, never inf · 0.
        let (g, entry) = volume_depth(set, k, &o, &dir, t_w);
        let g = g.min(L::splat(f32::MAX));
        let g = L::select(near, g, zero);
        let mut c = plan.colour_const.map(L::splat);
        if WANT_L {
            if let (Some(s), Some((phase, k))) = (sun, &plan.colour_sun) {
                // Capped (NaN → cap too): a batch marked unit-length whose directions are
                // not would otherwise overflow the phase function and give inf · 0 = NaN
                // in L_in (found by fuzz/volumes).
                let p = phase.eval(dir, s).min(L::splat(1e30));
                for ch in 0..3 {
                    c[ch] = p.mul_add(L::splat(k[ch]), c[ch]).min(L::splat(f32::MAX));
                }
            }
        }
        let mut taus = [zero; 3];
        for ch in 0..3 {
            let tau = g * L::splat(plan.sigma[ch]);
            taus[ch] = tau;
            out.tau[ch] = out.tau[ch] + tau;
            if WANT_L {
                let wt = tau.min(cap);
                num[ch] = wt.mul_add(c[ch], num[ch]);
                den[ch] = den[ch] + wt;
            }
        }
        if WANT_L {
            if let Some(list) = entries.as_deref_mut() {
                // Finite and ≥ 0 on every lane (a lane that misses has τ = 0, so its entry
                // point only has to be harmless); NaN (an invalid ray) becomes 0, the
                // ray's τ is NaN anyway.
                let s = L::splat(0.0).max(entry.min(t_w)).min(L::splat(f32::MAX));
                let s = L::select(s.eq(s), s, zero);
                list.push(Entry {
                    s,
                    tau: taus,
                    colour: c.map(clamp_colour),
                });
            }
        }
    }
    for ch in 0..3 {
        // One canonical NaN (not a payload from the input, which the compiler may
        // propagate differently in the scalar and x8 instantiations).
        out.tau[ch] = L::select(valid, out.tau[ch], L::splat(f32::NAN));
        if WANT_L {
            out.colour[ch] = num[ch] / den[ch].max(L::splat(1e-30));
        }
    }
    out
}

/// The per-packet culling test of [`eval_volumes`] for one ray of a batch not marked unit
/// (the pass's rays): whether `may_touch` keeps the volume for it. For the tests of the
/// pass's per-tile lists (`pass::cull`), which must keep every such volume.
#[cfg(test)]
pub(crate) fn may_touch_ray(plan: &VolumePlan, o: [f32; 3], d: [f32; 3], t: f32) -> bool {
    let (norm, dir) = crate::medium::height_fog::direction_norm(d);
    let dlen = ldexp(norm.0, norm.1);
    let t_w = if t == 0.0 || dlen == 0.0 {
        0.0
    } else {
        t * dlen
    };
    let t_w = Lane::min(t_w, f32::MAX);
    let cull = CullPacket::new(&o, &dir);
    may_touch(plan, &o, &dir, t_w, &cull)
}
