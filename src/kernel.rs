//! The evaluation of one packet of rays (1, 8 or 16 lanes) and the batch loops around it.
//!
//! [`eval_packet`] is written once over [`Lane`]; the batch loop instantiates it for
//! [`Wide`] (`f32x8`, or 16 lanes in an AVX-512 build; the tail in padded 8-lane packets,
//! so a ray's result does not depend on its position) and for `f32` (the scalar path).
//! All give bit-identical results (see `math::lane`). Const generics select, per scene and
//! batch, the up axis (no dot product for ±X/±Y/±Z), unit directions (no |d|), and the
//! outputs wanted, so that work a call does not need is compiled out rather than skipped
//! at run time.

use crate::light::PhaseEval;
use crate::math::{
    exp_neg, exp_neg_fast, exp_neg_mul, ldexp, ldexp_no_subnormal, pow2_pair, ExpNegMul, Lane,
};
use crate::medium::distance::DistancePlan;
use crate::medium::height_fog::{
    depth_args_of, depth_args_tame, depth_args_tame_wide, depth_of, depth_phi, depth_with_of,
    depth_with_tame, direction_norm, falloff_kind, layer_depth, DepthArgs, RayGeom, TWO_M64,
};
use crate::medium::volume::{clamp_colour, Entry, OutOfLine, VolumeEval};
use crate::ray::{Outputs, Rays};
use crate::scene::{LayerPlan, Scene, UpAxis};
use wide::f32x8;

/// One packet of rays. Components a kernel does not need are left at zero and never read.
#[derive(Clone, Copy)]
pub(crate) struct PacketIn<L> {
    pub o: [L; 3],
    pub d: [L; 3],
    pub t: L,
}

/// One packet of results.
#[derive(Clone, Copy)]
pub(crate) struct PacketOut<L> {
    pub tau: [L; 3],
    pub trans: [L; 3],
    pub insc: [L; 3],
}

/// `AXIS` in 0..3 means up = ±e_AXIS (sign folded into the layers); 3 means general.
pub(crate) const GENERAL: usize = 3;

/// Which input components a kernel reads.
#[inline(always)]
pub(crate) fn reads<const AXIS: usize, const UNIT: bool>(
    scene: &Scene,
    want_l: bool,
) -> ([bool; 3], [bool; 3]) {
    // Fog volumes need the whole ray.
    let vols = !scene.volumes.is_empty();
    let all_d = !UNIT || (want_l && scene.sun_dir.is_some()) || vols;
    let mut o = [AXIS == GENERAL || vols; 3];
    let mut d = [AXIS == GENERAL || all_d; 3];
    if AXIS < 3 {
        o[AXIS] = true;
        d[AXIS] = true;
    }
    (o, d)
}

/// The fog colour of one layer for a packet (per channel): the compiled constant plus
/// the phase-weighted sun terms.
#[inline(always)]
fn layer_colour<L: Lane>(layer: &LayerPlan, sun: Option<[f32; 3]>, dir: &[L; 3]) -> [L; 3] {
    let mut c = layer.colour_const.map(L::splat);
    if let Some(s) = sun {
        for (phase, k) in &layer.colour_sun {
            let p = phase.eval(*dir, s);
            for ch in 0..3 {
                c[ch] = p.mul_add(L::splat(k[ch]), c[ch]);
            }
        }
    }
    c
}

/// The per-ray quantities shared by all media of a packet: |d| as (mantissa, exponent),
/// the unit direction, the height and u = dot(d, up) split for the layers, and the sun
/// direction when radiance is wanted.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn packet_geometry<L: Lane, const AXIS: usize, const UNIT: bool>(
    up: [f32; 3],
    sun_dir: Option<[f32; 3]>,
    p: &PacketIn<L>,
    want_l: bool,
) -> (RayGeom<L>, (L, L), [L; 3], Option<[f32; 3]>) {
    let (norm, dir) = packet_norm::<L, UNIT>(p);
    let geom = packet_geom::<L, AXIS>(up, p, norm, &dir);
    let sun = if want_l { sun_dir } else { None };
    (geom, norm, dir, sun)
}

/// |d| as (mantissa, exponent) and the unit direction (d itself for `UNIT`).
#[inline(always)]
fn packet_norm<L: Lane, const UNIT: bool>(p: &PacketIn<L>) -> ((L, L), [L; 3]) {
    // Exponents that are known to be 0 are −0.0: x + (−0.0) is x for every x, so the
    // compiler drops the add (x + 0.0 is not: it turns −0.0 into +0.0).
    if UNIT {
        ((L::splat(1.0), L::splat(-0.0)), p.d)
    } else {
        direction_norm(p.d)
    }
}

/// The height dot(o, up) · 2^-64 for an axis-aligned up vector (see [`packet_geom`]).
#[inline(always)]
fn height_scaled<L: Lane, const AXIS: usize>(p: &PacketIn<L>) -> L {
    // Heights below 2^-62 give +0 instead of a subnormal (a microcode assist of ~200
    // cycles per product on Intel): the scaled height is read only where y − h0 or the
    // exponent saturates, where so small a height does not count (`depth_args_of`); the
    // guard reads the height itself (`packet_geom`).
    let y = p.o[AXIS];
    y.zero_where(y.abs().lt(L::splat(TWO_M62))) * L::splat(TWO_M64)
}

/// 2^-62: heights below it are subnormal at 2^-64 scale.
const TWO_M62: f32 = 2.168_404_3e-19;

/// [`RayGeom`] of a packet, given [`packet_norm`]'s results.
#[inline(always)]
fn packet_geom<L: Lane, const AXIS: usize>(
    up: [f32; 3],
    p: &PacketIn<L>,
    norm: (L, L),
    dir: &[L; 3],
) -> RayGeom<L> {
    // Height, height · 2^-64, and u = dot(d, up) as u · 2^u_shift. For a general up,
    // dot(o, up) and dot(d, up) overflow for finite o and d near f32::MAX (NaN for a
    // finite ray, found by `tests/height_fog.rs`): the height is also formed at 2^-64
    // scale, and u from the unit direction times n_m, with |d|'s exponent n_e carried
    // apart (which also keeps u's precision for subnormal directions).
    if AXIS < 3 {
        // The guard reads the height itself (finite exactly where its scaled form is),
        // so that the scaled height, which only `depth_args_of`'s rare scaled sum reads,
        // is formed there alone.
        let y = p.o[AXIS];
        let g = RayGeom::new(y, y, p.d[AXIS], L::splat(-0.0), p.t, norm);
        return RayGeom {
            y_s: height_scaled::<L, AXIS>(p),
            ..g
        };
    }
    let (y, y_s, u, u_shift) = {
        let up_s = up.map(|c| c * TWO_M64);
        let u = crate::light::dot3(*dir, up) * norm.0;
        (
            crate::light::dot3(p.o, up),
            crate::light::dot3(p.o, up_s),
            u,
            norm.1,
        )
    };
    RayGeom::new(y, y_s, u, u_shift, p.t, norm)
}

/// True if the scene is one height fog layer and nothing else: the case
/// [`eval_packet`] handles inline; everything else goes to [`eval_general`].
#[inline(always)]
fn is_single_layer(scene: &Scene) -> bool {
    scene.layers.len() == 1
        && scene.layers[0].colour_sun.len() <= MAX_PHASES
        && scene.volumes.is_empty()
        && !scene.has_controls()
}

/// The most distinct directional phase functions the single-layer kernel holds in
/// registers (more go to the general kernel).
const MAX_PHASES: usize = 4;

/// The single-layer kernel's constants, copied out of the scene once per batch into a
/// local, so that the packet loop keeps them in registers. Read through `&Scene`, they
/// were reloaded and re-tested on every packet (LLVM cannot prove that the output stores
/// do not alias the scene's heap data): 33 instead of 24 instructions per ray against a
/// hand-written kernel (`benches/plan.rs`).
#[derive(Clone, Copy)]
pub(crate) struct Single {
    /// The layer in base 2 ([`LayerCore::base2`](crate::scene::LayerCore::base2)): the
    /// depth stage forms G₂ = G/log2(e) with φ₂ and 2^x (no multiply by log2(e) and no
    /// Cody–Waite split in either exponential), and τ = σ₂·G₂.
    pub(crate) layer: crate::scene::LayerCore,
    /// The layer as compiled (natural base), for the framebuffer pass's own kernel.
    pub(crate) natural: crate::scene::LayerCore,
    pub(crate) phases: [(crate::light::Phase, [f32; 3]); MAX_PHASES],
    pub(crate) n_phases: usize,
    /// The three channels' extinction is the same: one τ and one exponential.
    pub(crate) grey: bool,
    /// How τ is formed from the layer's depth: 0 grey, 1 one pair of scale factors for
    /// the three channels (`LayerCore::shared_scale`), 2 one saturating ldexp each.
    pub(crate) tau_kind: u8,
    /// The layer's `shared_scale` where `tau_kind` is 1 (zeros otherwise).
    pub(crate) shared: (f32, [f32; 3]),
    /// Where `tau_kind` < 2, T straight from the geometric depth (see [`depth_trans`]):
    /// the exponent added to the depth's (e_σ grey, e_s shared) and each channel's
    /// mantissa (m_σ, m_c) as an [`exp_neg_mul`] factor.
    pub(crate) depth_scale: (f32, [ExpNegMul; 3]),
    pub(crate) up: [f32; 3],
    pub(crate) sun: Option<[f32; 3]>,
    /// The phase functions with their constants for the sun's direction (the first
    /// `n_lit` entries; `n_lit` is 0 without a sun).
    pub(crate) lit: [(PhaseEval, [f32; 3]); MAX_PHASES],
    pub(crate) n_lit: usize,
    /// Depth exponents below this may give some channel a τ below 2^-126 (see
    /// [`Single::tiny_tau`]); −∞ where every σ is 0.
    pub(crate) tiny_tau_e: f32,
    /// Sums ge + x (x the exponent of gm) below this may give some channel a τ below
    /// 2^-126 (see [`Single::tiny_tau`]).
    pub(crate) tiny_exact_e: f32,
}

/// The least exponent of the layer's non-zero extinctions (+∞ where all are 0).
fn least_sigma_exponent(layer: &crate::scene::LayerCore) -> f32 {
    layer
        .sigma
        .iter()
        .filter(|s| s.m != 0.0)
        .map(|s| s.e)
        .fold(f32::INFINITY, f32::min)
}

/// The least non-zero |gm| of the general depth stages (`height_fog::depth_of`: G = m·2^e
/// with |m| in [2^-38, 2^5] or 0).
const MANTISSA_MIN: f32 = 3.637_978_8e-12; // 2^-38

impl Single {
    /// `None` unless [`is_single_layer`] and the layer has a base-2 form (b = 0, or
    /// b·log2(e) a normal f32; otherwise the general kernel).
    #[inline(always)]
    pub(crate) fn of(scene: &Scene) -> Option<Single> {
        if !is_single_layer(scene) {
            return None;
        }
        let l = &scene.layers[0];
        let layer = l.core.base2()?;
        let grey = l.core.sigma[0] == l.core.sigma[1] && l.core.sigma[1] == l.core.sigma[2];
        let mut phases = [(crate::light::Phase::Isotropic, [0.0; 3]); MAX_PHASES];
        phases[..l.colour_sun.len()].copy_from_slice(&l.colour_sun);
        let sun = scene.sun_dir.map(|s| s.to_array());
        let s = sun.unwrap_or([0.0; 3]);
        let lit = phases.map(|(p, k)| (PhaseEval::new(p, s), k));
        let n_lit = if sun.is_some() { l.colour_sun.len() } else { 0 };
        Some(Single {
            layer,
            natural: l.core,
            phases,
            n_phases: l.colour_sun.len(),
            grey,
            tau_kind: if grey {
                0
            } else if layer.shared_scale.is_some() {
                1
            } else {
                2
            },
            shared: layer.shared_scale.unwrap_or((0.0, [0.0; 3])),
            depth_scale: {
                // The mantissas of σ₂ (T = e^(−τ) of τ = σ₂·G₂ as `single_tau` forms it).
                let (e, m) = if grey {
                    (layer.sigma[0].e, [layer.sigma[0].m; 3])
                } else {
                    layer.shared_scale.unwrap_or((0.0, [0.0; 3]))
                };
                (e, m.map(|m| ExpNegMul::new(m).unwrap_or_default()))
            },
            up: scene.up.to_array(),
            sun,
            lit,
            n_lit,
            // τ_c = (gm·m_c)·2^(ge + e_c) with |gm| ≥ 2^-38 (or 0) and m_c in [1, 2): at
            // least 2^-126 where ge ≥ −88 − e_c, and at least 2^(ge + x + e_c) with x the
            // exponent of gm (one below that, for the rounding of gm·m_c).
            tiny_tau_e: -88.0 - least_sigma_exponent(&layer),
            tiny_exact_e: -125.0 - least_sigma_exponent(&layer),
        })
    }

    /// Whether some lane of the depths (gm, ge) of a packet or block may have a channel's
    /// τ below 2^-126: then stage 3 takes [`single_tau_tiny`], whose subnormal results
    /// cost no microcode assist (nor do its results that round to 0: a `vscalefps` whose
    /// result underflows to 0 cost one too, `SCALE=1e-20 OUT=all speedscan short_1e-30`).
    /// Two `minps` per packet where no lane's depth is low (typical data): τ_c =
    /// (gm·m_c)·2^(ge + e_c) with m_c in [1, 2) is at least 2^-126 where gm ≥ 2^-38 (the
    /// general stages' least mantissa) and ge ≥ −88 − e_c; the tame stages keep G in gm
    /// with ge = 0. Where some lane is low, a second look takes gm's own exponent x and
    /// counts the lanes with G ≠ 0 and ge + x + e_c < −125 for some channel: G = 0 (t = 0)
    /// gives τ = 0 without an assist. (NaN lanes count as not tiny.)
    #[inline(always)]
    pub(crate) fn tiny_tau<L: Lane>(&self, depth: &[(L, L)]) -> bool {
        // (Loops, not closures: a closure is compiled without the `#[target_feature]` of
        // the AVX-512 entry points, and its intrinsics stayed out of line.)
        let (mut lo_m, mut lo_e) = (L::splat(f32::INFINITY), L::splat(f32::INFINITY));
        for &(gm, ge) in depth {
            lo_m = Lane::min(gm, lo_m);
            lo_e = Lane::min(ge, lo_e);
        }
        if !L::any(lo_e.lt(L::splat(self.tiny_tau_e)) | lo_m.lt(L::splat(MANTISSA_MIN))) {
            return false;
        }
        let (hi, zero) = (L::splat(self.tiny_exact_e), L::splat(0.0));
        let mut tiny = false;
        for &(gm, ge) in depth {
            let (_, x) = gm.frexp();
            tiny |= L::any((ge + x).lt(hi) & gm.ne(zero));
        }
        tiny
    }
}

/// One height fog layer (see [`is_single_layer`]): the five stages below, one after the
/// other, for one packet (the batch's padded tail, the framebuffer pass's packets). The
/// batch loop runs the same stages over a block of packets at a time (`run_single`, with
/// stage 2 split in its two exponentials), which gives the same bits.
#[inline(always)]
pub(crate) fn eval_packet<
    L: Lane,
    const AXIS: usize,
    const UNIT: bool,
    const WANT_T: bool,
    const WANT_L: bool,
    const FAST: bool,
>(
    single: &Single,
    p: &PacketIn<L>,
) -> PacketOut<L> {
    let (args, dir, _) = match falloff_kind(&single.layer) {
        0 => single_args::<L, AXIS, UNIT, WANT_L, 0, true>(single, p),
        1 => single_args::<L, AXIS, UNIT, WANT_L, 1, true>(single, p),
        _ => single_args::<L, AXIS, UNIT, WANT_L, 2, true>(single, p),
    };
    let depth = single_depth::<L, FAST>(single, args);
    let tau = match single.tau_kind {
        _ if single.tiny_tau(&[depth]) => single_tau_tiny(single, depth),
        0 => single_tau::<L, 0>(single, depth),
        1 => single_tau::<L, 1>(single, depth),
        _ => single_tau::<L, 2>(single, depth),
    };
    let trans = if WANT_T || WANT_L {
        if single.t_from_depth::<FAST>() {
            depth_trans(single, shared_g(L::splat(single.depth_scale.0), depth))
        } else if single.grey {
            [single_trans::<L, FAST>(tau[0]); 3]
        } else {
            tau.map(single_trans::<L, FAST>)
        }
    } else {
        [L::splat(1.0); 3]
    };
    let insc = if WANT_L {
        single_colour::<L>(single, &dir, &trans)
    } else {
        [L::splat(0.0); 3]
    };
    PacketOut { tau, trans, insc }
}

/// Stage 1 of the single-layer kernel: the geometry and the arguments of the layer's
/// two exponentials (see `layer_depth`), and the unit direction when the colour needs
/// it (`WANT_L`; zeros otherwise).
///
/// For an axis-aligned up vector and 0 < |b|·log2(e) ≤ 2^40 (`KIND` 1, the common case), a
/// packet whose rays all stay within `depth_args_tame`'s bounds takes the arguments
/// from it (no frexp, no exponent sums): the same bits after stage 3, for 55 instead of
/// 93 instructions per 8-lane packet on the C peer's rays. A packet it rejects tries
/// `depth_args_tame_wide` (sky lanes, segments from 2^-52 to 2^43 or of length 0, |Δ| up
/// to 2^90; the
/// benches' `sky` and `stiff` sets take it for every packet); the rest (|b·u| far out
/// of range, a non-finite input) take the general arithmetic, so such data cost at
/// most the general path's time. Lanes with [`Lane::NATIVE_SCALE`] (AVX-512) skip the
/// widened test: there frexp and ldexp are one instruction each and the general
/// arithmetic costs less than the test. Vector lanes only: the scalar path keeps
/// the general arithmetic (its frexp is cheap on scalar registers, and a branch per ray
/// made `transmittance_rgb/scalar` 5 % slower), which also makes the suites'
/// bit-for-bit comparisons of the scalar and vector paths a check of the tame path.
///
/// `TRY_TAME` false skips the tame tests (the general arithmetic at once): `run_single`
/// does so on AVX-512 lanes for [`SKIP_TAME_BLOCKS`] blocks after a block in which no
/// packet passed them (the `stiff` and `sky` sets 0.91× and 0.92× the time, typical data
/// unchanged, on the Intel Xeon of the forty-third session; README).
///
/// The third value says whether the packet took the plain tame path, no widened lanes
/// (then its exponent is −0 for unit directions: see [`depth_with_tame`]).
#[inline(always)]
pub(crate) fn single_args<
    L: Lane,
    const AXIS: usize,
    const UNIT: bool,
    const WANT_L: bool,
    const KIND: u8,
    const TRY_TAME: bool,
>(
    single: &Single,
    p: &PacketIn<L>,
) -> (DepthArgs<L>, [L; 3], bool) {
    let (norm, dir) = packet_norm::<L, UNIT>(p);
    let dir_out = if WANT_L { dir } else { [L::splat(0.0); 3] };
    if TRY_TAME && KIND == 1 && AXIS < GENERAL && L::LANES > 1 {
        let y = p.o[AXIS];
        let u = p.d[AXIS];
        let tame = depth_args_tame(&single.layer, y, u, p.t, norm);
        if !L::any(!tame.1) {
            return (tame.0, dir_out, true);
        }
        // Sky, far, near and zero lanes of a packet the plain tame stage rejected. Not
        // where frexp and ldexp are single instructions (AVX-512's getexp, getmant,
        // scalef): there the general arithmetic costs less than this test (the `stiff`
        // set 1.41× faster without it, with 16 lanes on Zen 5; ARCHITECTURE).
        if !L::NATIVE_SCALE {
            let (args, ok) = depth_args_tame_wide::<L, UNIT>(&single.layer, y, u, p.t, norm, tame);
            if !L::any(!ok) {
                return (args, dir_out, false);
            }
        }
    }
    let geom = packet_geom::<L, AXIS>(single.up, p, norm, &dir);
    (
        depth_args_of::<L, KIND>(&single.layer, &geom),
        dir_out,
        false,
    )
}

/// [`single_args`] without the tame path: the general arithmetic for every packet (the
/// oracle of the tame path's tests).
#[cfg(test)]
pub(crate) fn single_args_general<L: Lane, const AXIS: usize, const UNIT: bool, const KIND: u8>(
    single: &Single,
    p: &PacketIn<L>,
) -> DepthArgs<L> {
    let (norm, dir) = packet_norm::<L, UNIT>(p);
    let geom = packet_geom::<L, AXIS>(single.up, p, norm, &dir);
    depth_args_of::<L, KIND>(&single.layer, &geom)
}

/// Stage 2: the layer's geometric depth G = τ/σ0 as (mantissa, exponent).
#[inline(always)]
pub(crate) fn single_depth<L: Lane, const FAST: bool>(single: &Single, a: DepthArgs<L>) -> (L, L) {
    depth_of::<L, FAST, true>(&single.layer, a)
}

/// Stage 3: τ per channel from the geometric depth; `KIND` is [`Single::tau_kind`].
#[inline(always)]
pub(crate) fn single_tau<L: Lane, const KIND: u8>(single: &Single, (gm, ge): (L, L)) -> [L; 3] {
    let layer = &single.layer;
    if KIND == 0 {
        // One optical depth (and one exponential) for all three channels.
        let s = layer.sigma[0];
        [ldexp(gm * L::splat(s.m), ge + L::splat(s.e)); 3]
    } else if KIND == 1 && !L::NATIVE_SCALE {
        // One pair of scale factors for the three channels (`shared`, the layer's
        // `shared_scale` taken out of its `Option` once per batch).
        let (e, m) = single.shared;
        // gm·s1 is exact (normal); one rounding by the channel, one (only into the
        // subnormal range) by s2.
        let (s1, s2) = pow2_pair(ge + L::splat(e));
        let g1 = gm * s1;
        rgb!(ch => g1 * L::splat(m[ch]) * s2)
    } else {
        rgb!(ch => {
            let s = layer.sigma[ch];
            ldexp(gm * L::splat(s.m), ge + L::splat(s.e))
        })
    }
}

/// Stage 3 where some lane's τ may be below 2^-126 ([`Single::tiny_tau`]): the same bits
/// as [`single_tau`] (each channel's τ is (gm·m_c)·2^(ge + e_c) rounded once more into the
/// subnormal range in both), formed by [`ldexp_no_subnormal`] (subnormal results from
/// integer bits: no microcode assist, 3 to 14× the time of typical data where τ is
/// subnormal on the Intel Xeon of the forty-ninth session, README).
#[inline(always)]
pub(crate) fn single_tau_tiny<L: Lane>(single: &Single, (gm, ge): (L, L)) -> [L; 3] {
    let sigma = &single.layer.sigma;
    if single.tau_kind == 0 {
        let s = sigma[0];
        [ldexp_no_subnormal(gm * L::splat(s.m), ge + L::splat(s.e)); 3]
    } else {
        rgb!(ch => {
            let s = sigma[ch];
            ldexp_no_subnormal(gm * L::splat(s.m), ge + L::splat(s.e))
        })
    }
}

/// Stage 4: the transmittance of one channel, in the tier's accuracy (see `Tier`).
#[inline(always)]
pub(crate) fn single_trans<L: Lane, const FAST: bool>(tau: L) -> L {
    if FAST {
        exp_neg_fast(tau)
    } else {
        exp_neg(tau)
    }
}

impl Single {
    /// Whether stage 4 takes T straight from the geometric depth ([`depth_trans`])
    /// instead of from τ: the accurate tier, for a grey layer or one whose channels
    /// share a scale.
    #[inline(always)]
    pub(crate) fn t_from_depth<const FAST: bool>(&self) -> bool {
        !FAST && self.tau_kind < 2
    }
}

/// g = gm·2^e with e = ge + `es` clamped to [−64, 64] (see [`shared_depth`]), NaN where e
/// is (e − e is 0 or NaN: the NaN carried in one FMA instead of a test per block).
// (e − e is meant: it is not 0 for NaN.)
#[allow(clippy::eq_op)]
#[inline(always)]
fn shared_g<L: Lane>(es: L, (gm, ge): (L, L)) -> L {
    let e = ge + es;
    let e_clamped = e.clamp(L::splat(-64.0), L::splat(64.0));
    if L::NATIVE_SCALE {
        // `vscalefps`: the same exact product, and NaN where e is (the clamp keeps it);
        // one instruction for the four of 2^e from its bits and the FMA.
        gm.scale2(e_clamped)
    } else {
        gm.mul_add(L::pow2i(e_clamped), e - e)
    }
}

/// Stage 4 where [`Single::t_from_depth`]: T_c = e^(−g·m_c) from g of [`shared_g`], the
/// product taken exactly inside [`exp_neg_mul`] (no rounding of τ before T, and no
/// multiply per channel). See [`shared_depth`] for why the clamp of e does not matter.
#[inline(always)]
pub(crate) fn depth_trans<L: Lane>(single: &Single, g: L) -> [L; 3] {
    let k = single.depth_scale.1;
    if single.grey {
        [exp_neg_mul(g, k[0]); 3]
    } else {
        rgb!(ch => exp_neg_mul(g, k[ch]))
    }
}

/// Stage 5: the in-scattered light, the layer's fog colour (constant plus the sunlit
/// phase terms along `dir`) times 1 − T.
#[inline(always)]
pub(crate) fn single_colour<L: Lane>(single: &Single, dir: &[L; 3], trans: &[L; 3]) -> [L; 3] {
    let mut c = rgb!(ch => L::splat(single.layer.colour_const[ch]));
    for (phase, k) in &single.lit[..single.n_lit] {
        let p = phase.eval(*dir);
        for ch in 0..3 {
            c[ch] = p.mul_add(L::splat(k[ch]), c[ch]);
        }
    }
    single_insc(c, trans)
}

/// [`single_colour`] for exactly one sunlit phase function, whose kind is `KIND`: `one`
/// holds its constants and the constant part of the fog colour (see [`OneLit`]).
#[inline(always)]
pub(crate) fn single_colour_one<L: Lane, const KIND: u8>(
    one: &OneLit,
    dir: &[L; 3],
    trans: &[L; 3],
) -> [L; 3] {
    let mut c = rgb!(ch => L::splat(one.colour_const[ch]));
    let p = one.phase.eval_kind::<L, KIND>(*dir);
    for ch in 0..3 {
        c[ch] = p.mul_add(L::splat(one.k[ch]), c[ch]);
    }
    single_insc(c, trans)
}

/// The constants of [`single_colour_one`], copied out of [`Single`] into a local before
/// the colour loop: read through `&Single`, LLVM reloaded all twelve of them on every
/// packet (it cannot tell that the loop's stores to the caller's arrays leave them
/// alone).
#[derive(Clone, Copy)]
pub(crate) struct OneLit {
    phase: PhaseEval,
    k: [f32; 3],
    colour_const: [f32; 3],
}

impl OneLit {
    #[inline(always)]
    fn of(single: &Single) -> OneLit {
        OneLit {
            phase: single.lit[0].0,
            k: single.lit[0].1,
            colour_const: single.layer.colour_const,
        }
    }
}

/// The in-scattered light from the fog colour: clamp(c) · (1 − T).
#[inline(always)]
fn single_insc<L: Lane>(c: [L; 3], trans: &[L; 3]) -> [L; 3] {
    let one = L::splat(1.0);
    rgb!(ch => clamp_colour(c[ch]) * (one - trans[ch]))
}

/// Several layers and/or fog volumes. Not inlined: one copy per lane type and direction
/// kind instead of one per kernel variant (the variants differ in what the single-layer
/// fast path above leaves out; here the outputs are selected at run time, which costs a
/// predictable branch per packet).
///
/// Optical depths add; the fog colour is the τ-weighted mix of the layers' (and volumes')
/// colours (exact for one medium, an approximation otherwise). The weights are formed
/// from the mantissa/exponent pairs relative to the largest exponent, so they stay finite
/// where τ itself saturates. (No allocation: the second pass recomputes each layer's
/// depth.)
///
/// All of the scene's fog volumes are candidates; see [`eval_general_with`].
#[inline(always)]
fn eval_general<L: Lane, const AXIS: usize, const UNIT: bool>(
    scene: &Scene,
    p: PacketIn<L>,
    want_t: bool,
    want_l: bool,
    fast: bool,
    scratch: &mut Vec<Entry<L>>,
) -> PacketOut<L> {
    eval_general_with::<L, AXIS, UNIT>(scene, p, want_t, want_l, fast, None, scratch)
}

/// [`eval_general`] with the additive fog volumes to consider: `volumes` lists indices
/// into the scene's additive volumes in increasing order (`None`: all). The framebuffer
/// pass passes each tile's candidates (`crate::pass`); a volume may be left out only if
/// the per-packet test rejects it for every ray the list is used with, so that the result
/// is the same bits as with `None`.
///
/// `scratch`: the list of the volumes a packet touches, for the ordered composition
/// (`Composition::Ordered`); owned by the caller so that it is allocated once per batch,
/// not per packet. Cleared here before use.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn eval_general_with<L: Lane, const AXIS: usize, const UNIT: bool>(
    scene: &Scene,
    p: PacketIn<L>,
    want_t: bool,
    want_l: bool,
    fast: bool,
    volumes: Option<&[u32]>,
    scratch: &mut Vec<Entry<L>>,
) -> PacketOut<L> {
    general_packet::<L, AXIS, UNIT, OutOfLine>(scene, p, want_t, want_l, fast, volumes, scratch)
}

/// The body of [`eval_general_with`], inlined there (the other lane types) and into its
/// `#[target_feature]` twin for `Zmm` lanes (`zmm::general_packet`), where every function
/// it calls must be inlined too (see ARCHITECTURE "AVX-512 chosen at run time").
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn general_packet<L: Lane, const AXIS: usize, const UNIT: bool, V: VolumeEval<L>>(
    scene: &Scene,
    p: PacketIn<L>,
    want_t: bool,
    want_l: bool,
    fast: bool,
    volumes: Option<&[u32]>,
    scratch: &mut Vec<Entry<L>>,
) -> PacketOut<L> {
    let p = &p;
    // The tier (see `Tier`): a predictable branch per call. (Its work in functions: a
    // closure that held it was compiled without the `#[target_feature]` of the AVX-512
    // entry points and stayed out of line; these one-call wrappers are inlined.)
    let layer_depth = |layer, geom| tier_layer_depth(fast, layer, geom);
    let exp_neg = |x: L| crate::math::exp_neg_tier(fast, x);
    let (geom, norm, dir, sun) = packet_geometry::<L, AXIS, UNIT>(
        scene.up.to_array(),
        scene.sun_dir.map(|s| s.to_array()),
        p,
        want_l,
    );
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    // Start and cutoff distances (`FogLimits`): every medium sees the ray cut to
    // [start, min(t·|d|, cutoff)], from the start point along the unit direction.
    let limits = &scene.limits;
    let cut;
    let (p, geom, norm) = if limits.interval {
        let dlen = ldexp(norm.0, norm.1);
        let dist = L::select(p.t.eq(zero) | dlen.eq(zero), zero, p.t * dlen);
        let start = L::splat(limits.start);
        let len = (dist.min(L::splat(limits.cutoff)) - start).max(zero);
        // NaN, as without limits, for t NaN or negative and for a non-finite direction.
        #[allow(clippy::eq_op)] // x − x is NaN exactly when x is not finite
        let len = L::select(p.t.ge(zero), len, L::splat(f32::NAN)) + (norm.0 - norm.0);
        // The height of the start point from the ray's own height (y may be ±inf where
        // dot(o, up) overflows) and at 2^-64 scale: the start point itself may lie beyond
        // the f32 range (found by fuzz/height_fog: an origin near f32::MAX moved by a
        // start distance of 2.6e36 overflowed to +inf and gave τ = NaN).
        let u = if AXIS < 3 {
            dir[AXIS]
        } else {
            crate::light::dot3(dir, scene.up.to_array())
        };
        // |u| ≤ 1 for a unit direction; clamped so that a batch declared unit whose
        // directions are not (a broken promise, unspecified but never NaN) cannot
        // overflow the scaled height (found by fuzz/volumes). NaN stays NaN.
        let uc = u.clamp(L::splat(-1.0), one);
        let y = uc.mul_add(start, geom.y);
        let y_s = uc.mul_add(L::splat(limits.start * TWO_M64), geom.y_s);
        let g = RayGeom::new(y, y_s, u, zero, len, (one, zero));
        // The volumes take the cut ray itself. Where the start point leaves the f32 range
        // the ray moves away from every volume in that coordinate (it overflowed because
        // o and d agree in sign there, by more than any volume's extent): an empty
        // segment from the original origin. An invalid origin stays invalid (NaN).
        let oc = rgb!(c => dir[c].mul_add(start, p.o[c]));
        #[allow(clippy::eq_op)]
        let fin = (oc[0] - oc[0]).eq(zero) & (oc[1] - oc[1]).eq(zero) & (oc[2] - oc[2]).eq(zero);
        cut = PacketIn {
            o: rgb!(c => L::select(fin, oc[c], p.o[c])),
            d: dir,
            // zero.min(len): 0, or NaN for an invalid ray (found by fuzz/volumes).
            t: L::select(fin, len, zero.min(len)),
        };
        (&cut, g, (one, zero))
    } else {
        (p, geom, norm)
    };
    let (geom, dir) = (&geom, &dir);
    let mut out = PacketOut {
        tau: [zero; 3],
        trans: [one; 3],
        insc: [zero; 3],
    };
    let layers = &scene.layers;
    let mut emax = [L::splat(-1.0e30); 3];
    for layer in layers {
        let (gm, ge) = layer_depth(layer, geom);
        for ch in 0..3 {
            let s = layer.sigma[ch];
            let x = gm * L::splat(s.m);
            let e = ge + L::splat(s.e);
            out.tau[ch] = out.tau[ch] + ldexp(x, e);
            // The exponent of the value x · 2^e (not just of the pair), so that the
            // largest weight below is in [1, 2): with weights down to 2^-38, w·c lost
            // fog colours below ~2^-88 to underflow (found by `tests/height_fog.rs`).
            let ex = e + x.exponent_field() - L::splat(127.0);
            emax[ch] = L::select(x.ne(zero), ex.max(emax[ch]), emax[ch]);
        }
    }
    // Fog volumes (medium::volume): their τ adds to the layers'; their colour joins the
    // τ-weighted mix below (the same approximation as between layers).
    let tau_h = out.tau;
    let ordered = scene.ordered && want_l;
    scratch.clear();
    let vol = if scene.volumes.is_empty() {
        None
    } else {
        let v = if want_l {
            let list = if ordered { Some(&mut *scratch) } else { None };
            V::eval::<UNIT, true>(scene, &p.o, &p.d, p.t, norm, dir, sun, volumes, list)
        } else {
            V::eval::<UNIT, false>(scene, &p.o, &p.d, p.t, norm, dir, sun, volumes, None)
        };
        for ch in 0..3 {
            out.tau[ch] = out.tau[ch] + v.tau[ch];
        }
        Some(v)
    };
    // Distance fog over the same interval: its length from the geometry (mantissa and
    // exponent, t = +∞ included; NaN for an invalid ray).
    let tau_hv = out.tau;
    // (`if let`, not `Option::map`: see `rgb!`.)
    let dist_fog = if let Some(f) = scene.distance.as_ref() {
        let len_m = geom.n_m * geom.t_m + geom.guard;
        let len_e = geom.n_e + geom.t_e;
        let len_f = ldexp(len_m, len_e);
        let s_a = if limits.interval { limits.start } else { 0.0 };
        let d = crate::medium::distance::depth(f, s_a, len_m, len_e, len_f, fast);
        for ch in 0..3 {
            out.tau[ch] = out.tau[ch] + d.tau[ch];
        }
        Some((f, d, len_f))
    } else {
        None
    };
    if want_t || want_l {
        for ch in 0..3 {
            out.trans[ch] = match &dist_fog {
                // Linear fog's T is Bevy's ratio itself (no logarithm round trip).
                Some((f, d, _)) if f.is_linear() => exp_neg(tau_hv[ch]) * d.trans[ch],
                _ => exp_neg(out.tau[ch]),
            };
        }
    }
    // The lobe's weight, added to the colour of the height fog and the distance fog.
    let lobe = match (&scene.lobe, sun) {
        (Some(l), Some(s)) if want_l => Some((l, l.weight(*dir, s))),
        _ => None,
    };
    if want_l {
        let mut num = [zero; 3];
        let mut den = [zero; 3];
        // The colour of the media other than volumes, for the ordered composition.
        let mut c_bg = [zero; 3];
        for layer in layers {
            let (gm, ge) = layer_depth(layer, geom);
            let c = layer_colour(layer, sun, dir);
            for ch in 0..3 {
                let s = layer.sigma[ch];
                let w = ldexp(gm * L::splat(s.m), ge + L::splat(s.e) - emax[ch]);
                num[ch] = w.mul_add(clamp_colour(c[ch]), num[ch]);
                den[ch] = den[ch] + w;
            }
        }
        for ch in 0..3 {
            let mut colour = num[ch] / den[ch].max(L::splat(1e-30));
            let mut lobe_c = zero;
            if let Some((l, w)) = lobe {
                lobe_c = w * L::splat(l.colour[ch]);
                colour = colour + lobe_c;
            }
            let colour = clamp_colour(colour);
            let colour = match &vol {
                // Ordered: the volumes are added front to back below.
                Some(v) if !ordered => v.mix(ch, colour, tau_h[ch]),
                _ => colour,
            };
            out.insc[ch] = match &dist_fog {
                None => {
                    c_bg[ch] = colour;
                    colour * (one - out.trans[ch])
                }
                Some((f, d, len_f)) => {
                    let c_d = clamp_colour(L::splat(f.colour[ch]) + lobe_c);
                    // Atmospheric fog's in-scattering is not colour · (1 − T): its share
                    // is added below, so it weighs in the mix with colour 0.
                    let atm = matches!(f.plan, DistancePlan::Atmospheric { .. });
                    let (w_d, colour) = crate::medium::distance::mix(
                        colour,
                        tau_hv[ch],
                        if atm { zero } else { c_d },
                        d.tau[ch],
                    );
                    let extra = match f.plan {
                        DistancePlan::Atmospheric { insc, .. } => {
                            crate::medium::distance::atmospheric_inscattering(
                                insc[ch],
                                c_d,
                                *len_f,
                                d.tau[ch],
                                out.tau[ch],
                                out.trans[ch],
                                w_d,
                            )
                        }
                        _ => zero,
                    };
                    c_bg[ch] = colour;
                    colour * (one - out.trans[ch]) + extra
                }
            };
        }
        if ordered && !scratch.is_empty() {
            let unit_geom = if limits.interval {
                *geom
            } else {
                // The height fog along the unit direction from the ray's origin (the
                // entry points are world distances).
                let u = if AXIS < 3 {
                    dir[AXIS]
                } else {
                    crate::light::dot3(*dir, scene.up.to_array())
                };
                RayGeom::new(geom.y, geom.y_s, u, zero, zero, (one, zero))
            };
            // `ordered_volumes` replaces t_m by the entry points', so the ray's guard is
            // taken with the NaN of an invalid t that geom.t_m carries (t_m − t_m: 0 or
            // NaN; a mantissa is never infinite).
            #[allow(clippy::eq_op)]
            let unit_geom = RayGeom {
                guard: geom.guard + (geom.t_m - geom.t_m),
                ..unit_geom
            };
            let s_a = if limits.interval { limits.start } else { 0.0 };
            let d = ordered_volumes(
                scratch,
                layers,
                &unit_geom,
                dist_fog.as_ref().map(|(f, _, _)| (*f, s_a)),
                c_bg,
                fast,
            );
            for ch in 0..3 {
                // Positive and negative terms summed apart and clamped, so that no
                // ∞ − ∞ can arise; the light is ≥ 0 (NaN stays NaN).
                let sum = L::splat(f32::MAX).min(out.insc[ch] + d.0[ch]);
                out.insc[ch] = zero.max(sum - L::splat(f32::MAX).min(d.1[ch]));
            }
        }
    }
    // Maximum opacity: the integration stops where 1 − T reaches it (see `FogLimits`).
    if limits.opacity {
        let floor = L::splat(limits.t_floor);
        for ch in 0..3 {
            // `a.max(b)` / `a.min(b)` return b when either is NaN: NaN stays NaN.
            out.tau[ch] = L::splat(limits.tau_max).min(out.tau[ch]);
            if want_t || want_l {
                let t = out.trans[ch];
                let tc = floor.max(t);
                if want_l {
                    let scale = L::select(t.lt(floor), (one - tc) / (one - t), one);
                    out.insc[ch] = out.insc[ch] * scale;
                }
                out.trans[ch] = tc;
            }
        }
    }
    out
}

/// [`layer_depth`] in the tier that `fast` names.
#[inline(always)]
fn tier_layer_depth<L: Lane>(
    fast: bool,
    layer: &crate::scene::LayerCore,
    geom: &RayGeom<L>,
) -> (L, L) {
    if fast {
        layer_depth::<L, true>(layer, geom)
    } else {
        layer_depth::<L, false>(layer, geom)
    }
}

/// The ordered composition's correction to `c_bg · (1 − T)` (see `Composition`):
/// Σ_k (c_k − c_bg) · (1 − T_k) · T(0 → s_k), returned as the sums of its positive and
/// of its negative terms per channel (each ≥ 0). T(0 → s_k) is the transmittance of the
/// height fog layers (`geom`: the ray along its unit direction), of the distance fog (over
/// [s_a, s_a + s_k]) and of the volumes the ray enters before s_k (ties broken by the
/// volumes' order in the scene, so that each pair is counted once). O(m²) in the number of
/// entries, without sorting (each lane has its own order).
#[inline(always)]
fn ordered_volumes<L: Lane>(
    entries: &[Entry<L>],
    layers: &[LayerPlan],
    geom: &RayGeom<L>,
    distance: Option<(&crate::medium::distance::DistanceFogPlan, f32)>,
    c_bg: [L; 3],
    fast: bool,
) -> ([L; 3], [L; 3]) {
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    let exp_neg = |x: L| crate::math::exp_neg_tier(fast, x);
    let mut pos = [zero; 3];
    let mut neg = [zero; 3];
    for (k, ek) in entries.iter().enumerate() {
        // The optical depth in front of the entry point: volumes that start earlier...
        let mut front = [zero; 3];
        for (j, ej) in entries.iter().enumerate() {
            if j == k {
                continue;
            }
            let before = if j < k { ej.s.le(ek.s) } else { ej.s.lt(ek.s) };
            for ch in 0..3 {
                front[ch] = front[ch] + L::select(before, ej.tau[ch], zero);
            }
        }
        // ...and the height fog from the start to the entry point.
        let (t_m, t_e) = crate::math::frexp(ek.s);
        let g = RayGeom { t_m, t_e, ..*geom };
        for layer in layers {
            let (gm, ge) = tier_layer_depth(fast, layer, &g);
            for ch in 0..3 {
                let s = layer.sigma[ch];
                front[ch] = front[ch] + ldexp(gm * L::splat(s.m), ge + L::splat(s.e));
            }
        }
        let t_d = match distance {
            Some((f, s_a)) => {
                let (lm, le) = crate::math::frexp(ek.s);
                crate::medium::distance::depth(f, s_a, lm, le, ek.s, fast).trans
            }
            None => [one; 3],
        };
        for ch in 0..3 {
            let att = exp_neg(front[ch]) * t_d[ch];
            let w = (one - exp_neg(ek.tau[ch])) * att;
            let dc = ek.colour[ch] - c_bg[ch];
            pos[ch] = w.mul_add(dc.max(zero), pos[ch]);
            neg[ch] = w.mul_add(dc.neg().max(zero), neg[ch]);
        }
    }
    (pos, neg)
}

#[inline(always)]
fn load<L: Lane>(s: &[f32], i: usize, wanted: bool) -> L {
    if wanted {
        L::load(&s[i..i + L::LANES])
    } else {
        L::splat(0.0)
    }
}

/// An output cut to its first `full` elements (so that the packet loop's stores need no
/// bounds checks), borrowed out of `Outputs` into a local.
#[inline(always)]
#[allow(clippy::type_complexity)]
fn cut_rgb<'b>(
    o: &'b mut Option<crate::ray::RgbSlices<'_>>,
    full: usize,
) -> Option<[&'b mut [f32]; 3]> {
    o.as_mut()
        .map(|[a, b, c]| [&mut a[..full], &mut b[..full], &mut c[..full]])
}

#[inline(always)]
fn store<L: Lane>(v: [L; 3], dst: &mut Option<[&mut [f32]; 3]>, i: usize) {
    if let Some(d) = dst {
        for ch in 0..3 {
            v[ch].store(&mut d[ch][i..i + L::LANES]);
        }
    }
}

/// Packets per block of the single-layer batch loop ([`run_single`]).
const BLOCK: usize = 16;
/// Blocks of [`run_single`] that skip the tame test after a block where no packet
/// passed it (AVX-512 lanes only).
const SKIP_TAME_BLOCKS: usize = 3;

/// Evaluates a whole batch with lanes of type `L` (full packets), then the tail (fewer
/// than `L::LANES` rays) in padded 8-lane packets.
fn run<
    L: Lane,
    const AXIS: usize,
    const UNIT: bool,
    const WANT_T: bool,
    const WANT_L: bool,
    const FAST: bool,
>(
    scene: &Scene,
    rays: &Rays<'_>,
    out: &mut Outputs<'_>,
) {
    let n = rays.len();
    let (ro, rd) = reads::<AXIS, UNIT>(scene, WANT_L);
    // The choice between the single-layer kernel (inlined: no call, no spills) and the
    // general one (out of line) is made once per batch, not per packet.
    let single = Single::of(scene);
    // 16 AVX-512 lanes chosen at run time where the build has 8 (see `zmm`).
    let zmm = L::LANES == 8 && !scene.no_avx512_dispatch && crate::math::avx512_detected();
    let full = n - n % if zmm { 16 } else { L::LANES };
    // Slices cut to `full` up front, so the loop's indexing needs no bounds checks.
    let (o0, o1, o2) = (&rays.o[0][..full], &rays.o[1][..full], &rays.o[2][..full]);
    let (d0, d1, d2) = (&rays.d[0][..full], &rays.d[1][..full], &rays.d[2][..full]);
    let t = &rays.t[..full];
    let (mut o_tau, mut o_tr, mut o_li) = (
        cut_rgb(&mut out.tau, full),
        cut_rgb(&mut out.transmittance, full),
        cut_rgb(&mut out.inscattering, full),
    );
    macro_rules! packets {
        ($f:expr) => {{
            let mut i = 0;
            while i + L::LANES <= full {
                let p = PacketIn {
                    o: [
                        load::<L>(o0, i, ro[0]),
                        load::<L>(o1, i, ro[1]),
                        load::<L>(o2, i, ro[2]),
                    ],
                    d: [
                        load::<L>(d0, i, rd[0]),
                        load::<L>(d1, i, rd[1]),
                        load::<L>(d2, i, rd[2]),
                    ],
                    t: L::load(&t[i..i + L::LANES]),
                };
                let r = $f(p);
                store(r.tau, &mut o_tau, i);
                store(r.trans, &mut o_tr, i);
                store(r.insc, &mut o_li, i);
                i += L::LANES;
            }
        }};
    }
    let mut scratch = Vec::new();
    if let Some(single) = &single {
        let rays = [o0, o1, o2, d0, d1, d2, t];
        let outs = [&mut o_tau, &mut o_tr, &mut o_li];
        if zmm {
            // (`zmm` is false in builds without the dispatch.)
            #[cfg(zmm_dispatch)]
            zmm::run_single::<AXIS, UNIT, WANT_T, WANT_L, FAST>(single, rays, outs);
        } else {
            run_single::<L, AXIS, UNIT, WANT_T, WANT_L, FAST>(single, rays, outs);
        }
    } else if zmm {
        #[cfg(zmm_dispatch)]
        zmm::run_general::<AXIS, UNIT, WANT_T, WANT_L, FAST>(
            scene,
            [o0, o1, o2, d0, d1, d2, t],
            (ro, rd),
            [&mut o_tau, &mut o_tr, &mut o_li],
        );
    } else {
        packets!(|p: PacketIn<L>| eval_general::<L, AXIS, UNIT>(
            scene,
            p,
            WANT_T,
            WANT_L,
            FAST,
            &mut scratch
        ));
    }
    let _ = (o_tau, o_tr, o_li);
    // The tail (fewer than `L::LANES` rays): in 8-lane packets, the last one padded with a
    // harmless ray (t = 0), their live lanes stored. Same instructions per lane as a full
    // packet of any width, so the same bits.
    let mut s = full;
    while s < n {
        let rem = (n - s).min(8);
        let pad = |v: &[f32], fill: f32| {
            let mut b = [fill; 8];
            b[..rem].copy_from_slice(&v[s..s + rem]);
            b
        };
        let o = [0, 1, 2].map(|c| f32x8::new(pad(rays.o[c], 0.0)));
        let d = [0, 1, 2].map(|c| f32x8::new(pad(rays.d[c], 1.0)));
        let t = f32x8::new(pad(rays.t, 0.0));
        let p = PacketIn { o, d, t };
        let r = if let Some(single) = &single {
            eval_packet::<f32x8, AXIS, UNIT, WANT_T, WANT_L, FAST>(single, &p)
        } else {
            eval_general::<f32x8, AXIS, UNIT>(scene, p, WANT_T, WANT_L, FAST, &mut Vec::new())
        };
        let put = |v: [f32x8; 3], dst: &mut Option<crate::ray::RgbSlices<'_>>| {
            if let Some(d) = dst {
                for ch in 0..3 {
                    d[ch][s..s + rem].copy_from_slice(&v[ch].to_array()[..rem]);
                }
            }
        };
        put(r.tau, &mut out.tau);
        put(r.trans, &mut out.transmittance);
        put(r.insc, &mut out.inscattering);
        s += rem;
    }
}

/// The single-layer batch loop: full packets only (`rays`: ox, oy, oz, dx, dy, dz, t, all
/// of one length, a multiple of `L::LANES`; `outs`: τ, T, L_in, cut to that length).
///
/// In blocks of [`BLOCK`] packets, stage by stage (see [`eval_packet`], whose bits this
/// gives): one packet's chain (frexp, φ with its division, the exponentials) is long and
/// serial, and a block lets the CPU overlap the chains of independent packets; each stage
/// also needs fewer constants, which then stay in registers across the block
/// (`examples/hotloop.rs`, RGB transmittance on the C peer's typical rays: 5.7 ns per
/// ray packet by packet, 3.5 in stages).
#[inline(always)]
fn run_single<
    L: Lane,
    const AXIS: usize,
    const UNIT: bool,
    const WANT_T: bool,
    const WANT_L: bool,
    const FAST: bool,
>(
    single: &Single,
    rays: [&[f32]; 7],
    outs: [&mut Option<[&mut [f32]; 3]>; 3],
) {
    let [o_tau, o_tr, o_li] = outs;
    let full = rays[6].len();
    // A local copy: the loops' stores go through the caller's slices, and LLVM keeps the
    // constants of a local in registers across them, where through `&Single` it
    // reloaded (and re-tested) them on every packet.
    let single_copy = *single;
    let single = &single_copy;
    // What the kernel reads (see [`reads`]; a single layer has no volumes): known at
    // compile time except whether a sun needs the whole direction.
    let all_d = AXIS == GENERAL || !UNIT || (WANT_L && single.sun.is_some());
    #[inline(always)]
    fn read<const AXIS: usize>(c: usize, all_d: bool) -> bool {
        match c {
            0..=2 => AXIS == GENERAL || AXIS == c,
            3..=5 => all_d || AXIS == c - 3,
            _ => true,
        }
    }
    let kind = falloff_kind(&single.layer);
    let zero = L::splat(0.0);
    let mut args = [DepthArgs::zero(); BLOCK];
    let mut phis = [zero; BLOCK];
    let mut depth = [(zero, zero); BLOCK];
    let mut dirs = [[zero; 3]; BLOCK];
    let mut taus = [[zero; 3]; BLOCK];
    let mut trans = [[zero; 3]; BLOCK];
    let mut gs = [zero; BLOCK];
    let mut skip_tame = 0usize;
    let mut i = 0;
    while i < full {
        let m = ((full - i) / L::LANES).min(BLOCK);
        // The block's inputs, cut to it, so that the loads below need no bounds checks.
        // (Written out: `rays.map(..)` compiled to a call per block.)
        let w = m * L::LANES;
        let blk = [
            &rays[0][i..i + w],
            &rays[1][i..i + w],
            &rays[2][i..i + w],
            &rays[3][i..i + w],
            &rays[4][i..i + w],
            &rays[5][i..i + w],
            &rays[6][i..i + w],
        ];
        // The per-batch choices (falloff kind, how τ is formed) are made once per block,
        // outside the loops, so that no loop body tests them per packet.
        // The loads zip the block's arrays in packet-sized chunks (no bounds check per
        // packet); whether the whole direction is read (`all_d`) is a literal in each
        // copy of the loop, not a test per packet.
        let mut all_tame = true;
        let mut any_tame = false;
        macro_rules! args_loop {
            ($kind:literal, $all_d:literal) => {
                args_loop!($kind, $all_d, true)
            };
            ($kind:literal, $all_d:literal, $try:literal) => {{
                let c = |j: usize| blk[j].chunks_exact(L::LANES);
                let os = c(0).zip(c(1)).zip(c(2));
                let ds = c(3).zip(c(4)).zip(c(5));
                let slots = args[..m].iter_mut().zip(dirs[..m].iter_mut());
                for ((a, dir), ((((o0, o1), o2), ((d0, d1), d2)), t)) in
                    slots.zip(os.zip(ds).zip(c(6)))
                {
                    // (No closure: see `rgb!`.)
                    let ins = [o0, o1, o2, d0, d1, d2];
                    let at = |j: usize| read::<AXIS>(j, $all_d);
                    let p = PacketIn {
                        o: rgb!(c => if at(c) { L::load(ins[c]) } else { zero }),
                        d: rgb!(c => if at(c + 3) { L::load(ins[c + 3]) } else { zero }),
                        t: L::load(t),
                    };
                    let (args_k, dir_k, tame_k) =
                        single_args::<L, AXIS, UNIT, WANT_L, $kind, $try>(single, &p);
                    all_tame &= tame_k;
                    any_tame |= tame_k;
                    *a = args_k;
                    if !UNIT {
                        *dir = dir_k;
                    }
                }
            }};
        }
        match (kind, all_d, skip_tame > 0) {
            (0, false, _) => args_loop!(0, false),
            (0, true, _) => args_loop!(0, true),
            (1, false, false) => args_loop!(1, false),
            (1, true, false) => args_loop!(1, true),
            (1, false, true) => args_loop!(1, false, false),
            (1, true, true) => args_loop!(1, true, false),
            (_, false, _) => args_loop!(2, false),
            (_, true, _) => args_loop!(2, true),
        }
        // Where frexp and ldexp are single instructions (AVX-512), a block in which no
        // packet passed the tame test (extreme data: sky, far, near lanes in every
        // packet) makes the next SKIP_TAME_BLOCKS blocks take the general arithmetic
        // without trying the test first (see `single_args`); then it is tried again.
        if L::NATIVE_SCALE && kind == 1 {
            skip_tame = if skip_tame > 0 {
                skip_tame - 1
            } else if any_tame {
                0
            } else {
                SKIP_TAME_BLOCKS
            };
        }
        // A block of tame packets skips their exponent (same bits).
        if all_tame && kind == 1 {
            depth_stages_tame::<L, FAST, UNIT>(&args[..m], &mut phis, &mut depth);
        } else {
            depth_stages::<L, FAST>(kind, &args[..m], &mut phis, &mut depth);
        }
        // T from one value g per packet (see `shared_depth`), for a grey layer or three
        // channels sharing one pair of scale factors: in the accurate tier straight
        // from g (`depth_trans`, whether τ is stored or not); in the Fast tier, without
        // the masked scale, from τ = g·m_c formed in the T loop where τ is not stored.
        let from_depth = single.t_from_depth::<FAST>() && (WANT_T || WANT_L);
        let shared_block = from_depth
            || (FAST
                && !L::NATIVE_SCALE
                && single.tau_kind < 2
                && o_tau.is_none()
                && (WANT_T || WANT_L));
        if shared_block {
            shared_depth(single, &depth[..m], &mut gs);
        }
        macro_rules! tau_loop {
            ($f:expr) => {{
                let pairs = taus[..m].iter_mut().zip(depth[..m].iter());
                match o_tau.as_mut() {
                    Some([d0, d1, d2]) => {
                        let w = m * L::LANES;
                        let chunks = d0[i..i + w]
                            .chunks_exact_mut(L::LANES)
                            .zip(d1[i..i + w].chunks_exact_mut(L::LANES))
                            .zip(d2[i..i + w].chunks_exact_mut(L::LANES));
                        for ((tau, &g), ((a, b), c)) in pairs.zip(chunks) {
                            let x = $f(single, g);
                            x[0].store(a);
                            x[1].store(b);
                            x[2].store(c);
                            // (Kept for the later stages only: τ alone is stored once.)
                            if (WANT_T || WANT_L) && !shared_block {
                                *tau = x;
                            }
                        }
                    }
                    None => {
                        for (tau, &g) in pairs {
                            *tau = $f(single, g);
                        }
                    }
                }
            }};
        }
        if !shared_block || o_tau.is_some() {
            // A block where some lane's τ may be subnormal: `single_tau_tiny` (same bits).
            match single.tau_kind {
                _ if single.tiny_tau(&depth[..m]) => tau_loop!(single_tau_tiny::<L>),
                0 => tau_loop!(single_tau::<L, 0>),
                1 => tau_loop!(single_tau::<L, 1>),
                _ => tau_loop!(single_tau::<L, 2>),
            }
        }
        // Stored T (the streaming case): each packet also asks for the inputs of the
        // same packet two blocks ahead, one cache line per array (every other packet on
        // 8 lanes). The hardware's prefetch alone left the first stage, which reads
        // them, waiting on memory while this longest loop had none in flight: 16M rays
        // on both cores of Zen 4 took 0.89× the time with it (README "Zen 4,
        // sixty-fifth session"). The arrays are those known at compile time: t, and the
        // up axis's origin and direction, or the three origins with a general up;
        // directions read only for a sun or a general up are left to the hardware (a
        // test per array and packet took registers the loop's constants need: 1.05× its
        // time in cache). Hints only: the same bits; past the batch's end they ask for
        // nothing that is read.
        // The T loop of a shared block: `$f` gives the three channels' T from `$g`, with
        // one load of g per packet (an expression, not a closure: see `rgb!`).
        macro_rules! shared_t_loop {
            ($g:ident => $f:expr) => {{
                let w = m * L::LANES;
                let pairs = gs[..m].iter().zip(trans[..m].iter_mut());
                match o_tr.as_mut() {
                    Some([d0, d1, d2]) => {
                        let chunks = d0[i..i + w]
                            .chunks_exact_mut(L::LANES)
                            .zip(d1[i..i + w].chunks_exact_mut(L::LANES))
                            .zip(d2[i..i + w].chunks_exact_mut(L::LANES));
                        let mut ahead = i + 2 * BLOCK * L::LANES;
                        for ((&$g, tr_k), ((a, b), c)) in pairs.zip(chunks) {
                            if L::LANES >= 16 || ahead % 16 == 0 {
                                for (j, r) in rays.iter().enumerate() {
                                    if read::<AXIS>(j, false) {
                                        crate::pass::prefetch_read(r.as_ptr().wrapping_add(ahead));
                                    }
                                }
                            }
                            ahead += L::LANES;
                            let tr: [L; 3] = $f;
                            tr[0].store(a);
                            tr[1].store(b);
                            tr[2].store(c);
                            if WANT_L {
                                *tr_k = tr;
                            }
                        }
                    }
                    None => {
                        for (&$g, tr_k) in pairs {
                            *tr_k = $f;
                        }
                    }
                }
            }};
        }
        if from_depth && single.grey {
            // One exponential for the three channels.
            let k = single.depth_scale.1[0];
            shared_t_loop!(g => [exp_neg_mul(g, k); 3]);
        } else if from_depth {
            let k = single.depth_scale.1;
            shared_t_loop!(g => rgb!(ch => exp_neg_mul(g, k[ch])));
        } else if shared_block && single.grey {
            // One exponential for the three channels.
            let k = L::splat(single.layer.sigma[0].m);
            shared_t_loop!(g => [single_trans::<L, FAST>(g * k); 3]);
        } else if shared_block {
            // The three channels in one loop.
            let mc = rgb!(ch => L::splat(single.shared.1[ch]));
            shared_t_loop!(g => rgb!(ch => single_trans::<L, FAST>(g * mc[ch])));
        } else if WANT_T || WANT_L {
            // One channel at a time: the exponential's constants stay in registers. Each
            // value goes straight to the caller's array (the block's part of it, in
            // chunks: no bounds check per packet) and, for the colour, to `trans`.
            let mut dst = o_tr
                .as_mut()
                .map(|d| d.each_mut().map(|s| &mut s[i..i + m * L::LANES]));
            if single.grey {
                // One exponential, stored to the three channels.
                let pairs = taus[..m].iter().zip(trans[..m].iter_mut());
                match &mut dst {
                    Some([d0, d1, d2]) => {
                        let chunks = d0
                            .chunks_exact_mut(L::LANES)
                            .zip(d1.chunks_exact_mut(L::LANES))
                            .zip(d2.chunks_exact_mut(L::LANES));
                        for ((tau, tr_k), ((a, b), c)) in pairs.zip(chunks) {
                            let tr = single_trans::<L, FAST>(tau[0]);
                            tr.store(a);
                            tr.store(b);
                            tr.store(c);
                            if WANT_L {
                                *tr_k = [tr; 3];
                            }
                        }
                    }
                    None => {
                        for (tau, tr_k) in pairs {
                            *tr_k = [single_trans::<L, FAST>(tau[0]); 3];
                        }
                    }
                }
            } else {
                for ch in 0..3 {
                    let pairs = taus[..m].iter().zip(trans[..m].iter_mut());
                    match &mut dst {
                        Some(d) => {
                            for ((tau, tr_k), x) in pairs.zip(d[ch].chunks_exact_mut(L::LANES)) {
                                let tr = single_trans::<L, FAST>(tau[ch]);
                                tr.store(x);
                                if WANT_L {
                                    tr_k[ch] = tr;
                                }
                            }
                        }
                        None => {
                            for (tau, tr_k) in pairs {
                                tr_k[ch] = single_trans::<L, FAST>(tau[ch]);
                            }
                        }
                    }
                }
            }
        }
        if WANT_L {
            // One sunlit phase function (the usual case): its kind chosen per block. The
            // values go straight to the caller's arrays, in the block's chunks (no bounds
            // check per packet); unit directions are loaded again here rather than
            // carried from stage 1 in `dirs` (three loads instead of three stores and
            // three loads, and stage 1's registers left alone).
            macro_rules! colour_loop {
                ($consts:expr, $f:expr) => {
                    if let Some([d0, d1, d2]) = o_li.as_mut() {
                        let consts = $consts;
                        let w = m * L::LANES;
                        let outs = d0[i..i + w]
                            .chunks_exact_mut(L::LANES)
                            .zip(d1[i..i + w].chunks_exact_mut(L::LANES))
                            .zip(d2[i..i + w].chunks_exact_mut(L::LANES));
                        let lit = single.n_lit > 0;
                        let c = |j: usize| blk[j].chunks_exact(L::LANES);
                        let ds = c(3).zip(c(4)).zip(c(5));
                        let per = trans[..m].iter().zip(dirs[..m].iter()).zip(ds);
                        for (((tr, dir_k), ((x0, x1), x2)), ((a, b), c)) in per.zip(outs) {
                            let dir = if !UNIT {
                                *dir_k
                            } else if lit {
                                [L::load(x0), L::load(x1), L::load(x2)]
                            } else {
                                [zero; 3]
                            };
                            let [x, y, z] = $f(&consts, &dir, tr);
                            x.store(a);
                            y.store(b);
                            z.store(c);
                        }
                    }
                };
            }
            match (single.n_lit, single.lit[0].0.kind) {
                (1, 1) => colour_loop!(OneLit::of(single), single_colour_one::<L, 1>),
                (1, 2) => colour_loop!(OneLit::of(single), single_colour_one::<L, 2>),
                (1, 3) => colour_loop!(OneLit::of(single), single_colour_one::<L, 3>),
                _ => colour_loop!(*single, single_colour::<L>),
            }
        }
        i += m * L::LANES;
    }
}

/// For a block of a grey layer (`tau_kind` 0: σ = m_σ·2^e_σ) or one whose channels share
/// a scale (`tau_kind` 1: σ_c = m_c·2^e_s): writes g = gm·2^e per packet ([`shared_g`]),
/// (gm, ge) being the geometric depth, e = ge + e_σ or ge + e_s clamped to [−64, 64], so
/// that the T loop takes τ_c = g·m_c from one value per packet, where `single_tau` would
/// store three (with the three channels in one loop, 6.36 → 5.88 ns per ray in `hotloop
/// unit typical` on Zen 1).
///
/// Here gm < 2^32, gm ≥ 2^-32 or gm = 0 (m·φ·e^(−u_min) with φ ≥ 2^-11 and m in [1, 4),
/// or the tame stage's G, in [2^-31.6, 2^31.6]: see `depth_args_tame` and
/// `depth_args_tame_wide`), m_σ is in [1, 2) (`frexp`) and a non-zero m_c in [2^-16, 2)
/// (`shared_scale`). So:
/// - for |e| ≤ 64, g = gm·2^e exactly (normal: ≥ 2^-96, ≤ 2^96), and τ_c = g·m_c is
///   the true product: the accurate tier's `depth_trans` takes it unrounded. The Fast
///   tier rounds it once, to the same bits as `single_tau`'s τ: shared scale, its
///   τ_c = (gm·s1)·m_c·s2 with s1 = 2^e and s2 = 1 from `pow2_pair` is the same products
///   of the same values; grey, its τ = `ldexp`(gm·m_σ, e) = round(gm·m_σ)·2^e is the
///   same number as round(gm·2^e·m_σ), since every value is normal, where scaling by
///   2^e commutes with rounding;
/// - for e < −64 both τ are below 2^32·2^-64·2 = 2^-31, where `exp_neg`, `exp_neg_mul`
///   and `exp_neg_fast` give 1 (as the true e^(−τ) rounds to: 1 − τ rounds to 1 below
///   2^-25);
/// - for e > 64 both τ are at least 2^-32·2^64·2^-16 = 2^16 (or 0 in both where m_c or
///   gm is 0), where all three give 0 (and the true e^(−τ) is below f32's range);
/// - a NaN gm or e gives NaN in both.
///
/// The Fast tier's T is then the same bits as from `single_tau`'s τ; the accurate tier's
/// is e^(−τ) of the unrounded τ (see [`exp_neg_mul`]), not `exp_neg` of the rounded one.
#[inline(always)]
fn shared_depth<L: Lane>(single: &Single, depth: &[(L, L)], gs: &mut [L; BLOCK]) {
    let es = L::splat(single.depth_scale.0);
    for (g, &d) in gs.iter_mut().zip(depth) {
        *g = shared_g(es, d);
    }
}

/// Run-time dispatch to 16 AVX-512 lanes ([`crate::math::zmm::Zmm`]) in builds that do not
/// enable AVX-512 themselves, where the CPU has it.
#[cfg(zmm_dispatch)]
#[allow(unsafe_code)]
pub(crate) mod zmm {
    use super::{PacketIn, PacketIo, PacketOut, Scene, Single, UpAxis, GENERAL};
    use crate::math::zmm::{detected, Zmm};
    use crate::math::Lane;
    use crate::medium::volume::{eval_volumes_body, Entry, VolOut, VolumeEval};

    /// [`run_single`](super::run_single) with [`Zmm`] lanes, compiled with AVX-512
    /// enabled. Call only where [`detected`] is true (and lengths multiples of 16).
    #[inline(always)]
    pub(crate) fn run_single<
        const AXIS: usize,
        const UNIT: bool,
        const WANT_T: bool,
        const WANT_L: bool,
        const FAST: bool,
    >(
        single: &Single,
        rays: [&[f32]; 7],
        outs: [&mut Option<[&mut [f32]; 3]>; 3],
    ) {
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
        fn go<
            const AXIS: usize,
            const UNIT: bool,
            const WANT_T: bool,
            const WANT_L: bool,
            const FAST: bool,
        >(
            single: &Single,
            rays: [&[f32]; 7],
            outs: [&mut Option<[&mut [f32]; 3]>; 3],
        ) {
            super::run_single::<Zmm, AXIS, UNIT, WANT_T, WANT_L, FAST>(single, rays, outs)
        }
        assert!(detected());
        // SAFETY: the CPU has the features `go` is compiled for (asserted above).
        unsafe { go::<AXIS, UNIT, WANT_T, WANT_L, FAST>(single, rays, outs) }
    }

    /// The general kernel's packet loop ([`general_packet`](super::general_packet), all
    /// of the scene's volumes) with [`Zmm`] lanes, compiled with AVX-512 enabled. Call
    /// only where [`detected`] is true (and lengths multiples of 16); `reads`: which
    /// components of o and d the kernel reads ([`reads`](super::reads)).
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    pub(crate) fn run_general<
        const AXIS: usize,
        const UNIT: bool,
        const WANT_T: bool,
        const WANT_L: bool,
        const FAST: bool,
    >(
        scene: &Scene,
        rays: [&[f32]; 7],
        reads: ([bool; 3], [bool; 3]),
        outs: [&mut Option<[&mut [f32]; 3]>; 3],
    ) {
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
        #[allow(clippy::type_complexity)]
        fn go<
            const AXIS: usize,
            const UNIT: bool,
            const WANT_T: bool,
            const WANT_L: bool,
            const FAST: bool,
        >(
            scene: &Scene,
            rays: [&[f32]; 7],
            (ro, rd): ([bool; 3], [bool; 3]),
            outs: [&mut Option<[&mut [f32]; 3]>; 3],
        ) {
            let [o_tau, o_tr, o_li] = outs;
            let mut scratch = Vec::new();
            let full = rays[6].len();
            let mut i = 0;
            while i + 16 <= full {
                let p = PacketIn {
                    o: [
                        super::load::<Zmm>(rays[0], i, ro[0]),
                        super::load::<Zmm>(rays[1], i, ro[1]),
                        super::load::<Zmm>(rays[2], i, ro[2]),
                    ],
                    d: [
                        super::load::<Zmm>(rays[3], i, rd[0]),
                        super::load::<Zmm>(rays[4], i, rd[1]),
                        super::load::<Zmm>(rays[5], i, rd[2]),
                    ],
                    t: Zmm::load(&rays[6][i..i + 16]),
                };
                let r = general_packet::<AXIS, UNIT>(
                    scene,
                    p,
                    WANT_T,
                    WANT_L,
                    FAST,
                    None,
                    &mut scratch,
                );
                super::store(r.tau, o_tau, i);
                super::store(r.trans, o_tr, i);
                super::store(r.insc, o_li, i);
                i += 16;
            }
        }
        assert!(detected());
        // SAFETY: the CPU has the features `go` is compiled for (asserted above).
        unsafe { go::<AXIS, UNIT, WANT_T, WANT_L, FAST>(scene, rays, reads, outs) }
    }

    /// [`run_packets`](super::run_packets) for a scene that is not one height fog layer,
    /// with [`Zmm`] lanes: the framebuffer pass's general rows where AVX-512 is chosen at
    /// run time. The same packets through the same kernel as `run_general`, so the same
    /// bits as a batch. Call only where [`detected`] is true. `scratch` as in
    /// [`run_packets`](super::run_packets).
    #[inline(always)]
    pub(crate) fn run_packets_general<const UNIT: bool, S: PacketIo<Zmm>>(
        scene: &Scene,
        volumes: Option<&[u32]>,
        count: usize,
        io: &mut S,
        scratch: &mut Vec<Entry<Zmm>>,
    ) {
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
        fn go<const AXIS: usize, const UNIT: bool, S: PacketIo<Zmm>>(
            scene: &Scene,
            volumes: Option<&[u32]>,
            count: usize,
            io: &mut S,
            scratch: &mut Vec<Entry<Zmm>>,
        ) {
            let fast = scene.tier == crate::Tier::Fast;
            for i in 0..count {
                let p = io.make(i);
                let r = general_packet::<AXIS, UNIT>(scene, p, true, true, fast, volumes, scratch);
                io.take(i, &r);
            }
        }
        assert!(detected());
        // SAFETY: the CPU has the features `go` is compiled for (asserted above).
        unsafe {
            match scene.axis {
                UpAxis::Axis(0) => go::<0, UNIT, S>(scene, volumes, count, io, scratch),
                UpAxis::Axis(1) => go::<1, UNIT, S>(scene, volumes, count, io, scratch),
                UpAxis::Axis(2) => go::<2, UNIT, S>(scene, volumes, count, io, scratch),
                _ => go::<GENERAL, UNIT, S>(scene, volumes, count, io, scratch),
            }
        }
    }

    /// One packet of the general kernel with AVX-512 (out of line, one copy per
    /// (AXIS, UNIT), as `eval_general_with` is); `volumes` as there.
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn general_packet<const AXIS: usize, const UNIT: bool>(
        scene: &Scene,
        p: PacketIn<Zmm>,
        want_t: bool,
        want_l: bool,
        fast: bool,
        volumes: Option<&[u32]>,
        scratch: &mut Vec<Entry<Zmm>>,
    ) -> PacketOut<Zmm> {
        super::general_packet::<Zmm, AXIS, UNIT, ZmmVolumes>(
            scene, p, want_t, want_l, fast, volumes, scratch,
        )
    }

    /// [`VolumeEval`] by [`packet_volumes`]: used only inside [`general_packet`].
    struct ZmmVolumes;

    impl VolumeEval<Zmm> for ZmmVolumes {
        #[inline(always)]
        fn eval<const UNIT: bool, const WANT_L: bool>(
            scene: &Scene,
            o: &[Zmm; 3],
            d: &[Zmm; 3],
            t: Zmm,
            norm: (Zmm, Zmm),
            dir: &[Zmm; 3],
            sun: Option<[f32; 3]>,
            volumes: Option<&[u32]>,
            entries: Option<&mut Vec<Entry<Zmm>>>,
        ) -> VolOut<Zmm> {
            // SAFETY: only `general_packet` uses `ZmmVolumes`, and it runs only where the
            // CPU has these features (`run_general` asserts `detected`).
            unsafe {
                packet_volumes::<UNIT, WANT_L>(scene, o, d, t, norm, dir, sun, volumes, entries)
            }
        }
    }

    /// The volumes of one packet with AVX-512 (out of line, one copy per (UNIT, WANT_L),
    /// as `eval_volumes` is).
    #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
    #[inline(never)]
    #[allow(clippy::too_many_arguments)]
    fn packet_volumes<const UNIT: bool, const WANT_L: bool>(
        scene: &Scene,
        o: &[Zmm; 3],
        d: &[Zmm; 3],
        t: Zmm,
        norm: (Zmm, Zmm),
        dir: &[Zmm; 3],
        sun: Option<[f32; 3]>,
        volumes: Option<&[u32]>,
        entries: Option<&mut Vec<Entry<Zmm>>>,
    ) -> VolOut<Zmm> {
        eval_volumes_body::<Zmm, UNIT, WANT_L>(scene, o, d, t, norm, dir, sun, volumes, entries)
    }
}

/// The lane type of the vector paths: `f32x8` (AVX2: one ymm register), or where the build
/// enables AVX-512 (e.g. `-C target-cpu=x86-64-v4`) one zmm register: the crate's own
/// [`Zmm`](crate::math::zmm::Zmm) with F, VL, DQ, BW and CD (`cfg(zmm_native)`), else
/// `wide::f32x16`. All give the same bits (each `Lane` method is the same IEEE operation at
/// any width). `Zmm` rather than `f32x16` there: the code the run-time dispatch of the
/// x86-64-v3 build runs (the batch kernels measured the same with either; the pass's own
/// kernel 1.12× faster with `Zmm` and its constants copied into locals; `Zmm` alone about
/// 1.05×, the copy alone nothing: ARCHITECTURE "AVX-512 chosen at run time").
#[cfg(not(any(target_feature = "avx512f", zmm_native)))]
pub(crate) type Wide = f32x8;
/// See the other definition.
#[cfg(all(target_feature = "avx512f", not(zmm_native)))]
pub(crate) type Wide = wide::f32x16;
/// See the other definition.
#[cfg(zmm_native)]
pub(crate) type Wide = crate::math::zmm::Zmm;

/// Which lane type a batch runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Width {
    /// [`Wide`] lanes (8, or 16 with AVX-512), Accurate tier.
    X8,
    /// [`Wide`] lanes, Fast tier.
    X8Fast,
    /// 1 lane, Accurate tier (bit-identical to `X8`).
    Scalar,
}

macro_rules! dispatch_outputs {
    ($L:ty, $F:expr, $AXIS:expr, $UNIT:expr, $scene:expr, $rays:expr, $out:expr) => {{
        let want_l = $out.inscattering.is_some();
        let want_t = $out.transmittance.is_some();
        match (want_t, want_l) {
            (_, true) => run::<$L, $AXIS, $UNIT, true, true, $F>($scene, $rays, $out),
            (true, false) => run::<$L, $AXIS, $UNIT, true, false, $F>($scene, $rays, $out),
            (false, false) => run::<$L, $AXIS, $UNIT, false, false, $F>($scene, $rays, $out),
        }
    }};
}

macro_rules! dispatch_geometry {
    ($L:ty, $F:expr, $scene:expr, $rays:expr, $out:expr) => {{
        match ($scene.axis, $rays.unit) {
            (UpAxis::Axis(0), false) => dispatch_outputs!($L, $F, 0, false, $scene, $rays, $out),
            (UpAxis::Axis(1), false) => dispatch_outputs!($L, $F, 1, false, $scene, $rays, $out),
            (UpAxis::Axis(2), false) => dispatch_outputs!($L, $F, 2, false, $scene, $rays, $out),
            (UpAxis::Axis(0), true) => dispatch_outputs!($L, $F, 0, true, $scene, $rays, $out),
            (UpAxis::Axis(1), true) => dispatch_outputs!($L, $F, 1, true, $scene, $rays, $out),
            (UpAxis::Axis(2), true) => dispatch_outputs!($L, $F, 2, true, $scene, $rays, $out),
            (_, false) => dispatch_outputs!($L, $F, GENERAL, false, $scene, $rays, $out),
            (_, true) => dispatch_outputs!($L, $F, GENERAL, true, $scene, $rays, $out),
        }
    }};
}

/// Evaluates a batch on the calling thread.
pub(crate) fn evaluate(scene: &Scene, rays: &Rays<'_>, out: &mut Outputs<'_>, width: Width) {
    match width {
        Width::X8 => dispatch_geometry!(Wide, false, scene, rays, out),
        Width::X8Fast => dispatch_geometry!(Wide, true, scene, rays, out),
        Width::Scalar => dispatch_geometry!(f32, false, scene, rays, out),
    }
}

/// Rays per parallel task, at least: inputs and outputs of one chunk (64 bytes per ray)
/// fit in a core's L2 cache.
pub(crate) const PAR_CHUNK: usize = 4096;
/// Rays per parallel task, at most (see [`evaluate_par`]).
pub(crate) const PAR_CHUNK_MAX: usize = 65536;

/// Evaluates a batch with rayon, splitting it in halves (multiples of 16 rays) down to
/// chunks of [`PAR_CHUNK`] to [`PAR_CHUNK_MAX`] rays: at least eight per thread where the
/// batch has the rays. (Each call of [`evaluate`] has a fixed cost: a 64K-ray batch as
/// sixteen calls of 4096 rays took 1.05× the time of one call on Zen 5.)
pub(crate) fn evaluate_par(scene: &Scene, rays: &Rays<'_>, out: Outputs<'_>, width: Width) {
    let chunk = par_task_len(rays.len(), PAR_CHUNK, PAR_CHUNK_MAX);
    split_par(scene, rays, out, width, chunk);
}

/// The size of a parallel task over `items` units of work: at least eight tasks per rayon
/// thread where there are items enough, each of `min` to `max` items (`min ≤ max`). Used
/// by [`evaluate_par`] (rays) and the framebuffer pass (rows).
pub(crate) fn par_task_len(items: usize, min: usize, max: usize) -> usize {
    (items / (8 * rayon::current_num_threads().max(1))).clamp(min, max)
}

/// [`evaluate_par`] in halves down to `chunk` rays.
fn split_par(scene: &Scene, rays: &Rays<'_>, out: Outputs<'_>, width: Width, chunk: usize) {
    let n = rays.len();
    if n <= chunk {
        let mut out = out;
        evaluate(scene, rays, &mut out, width);
        return;
    }
    let mid = (n / 2).next_multiple_of(16).min(n);
    let (a, b) = out.split_at(mid);
    let (ra, rb) = (rays.slice(0, mid), rays.slice(mid, n));
    rayon::join(
        || split_par(scene, &ra, a, width, chunk),
        || split_par(scene, &rb, b, width, chunk),
    );
}

/// The ray source and result sink of [`run_packets`]: `make(i)` produces packet `i`,
/// `take(i, &out)` consumes its result. (A trait with `#[inline(always)]` methods rather
/// than closures, so that both are inlined into the packet loop.)
pub(crate) trait PacketIo<L> {
    fn make(&mut self, i: usize) -> PacketIn<L>;
    /// The packet's T and L_in (its τ is not formed by every kernel: see `eval_block`).
    fn take(&mut self, i: usize, out: &PacketOut<L>);
}

/// Evaluates `count` packets of `L::LANES` rays that `io.make(i)` produces (transmittance and
/// in-scattering wanted, like a batch with both outputs), handing each result to
/// `io.take(i, &out)`: the entry point of the framebuffer pass (`crate::pass`), which
/// generates its rays in registers instead of reading them from slices.
///
/// The kernel is chosen once per call (up axis, single layer or general), as [`run`]
/// chooses it once per batch, and the packets go through the same [`eval_packet`] /
/// [`eval_general`] instantiations as a batch with `unit == UNIT`, so a ray gives the same
/// bits here as through `Scene::evaluate`. Components the kernel does not read (see
/// [`reads`]) may hold anything.
///
/// `volumes`: the candidate fog volumes of these packets (see [`eval_general_with`]):
/// the pass's per-tile list, or `None` for all. `scratch`: the general kernel's list of
/// the volumes a packet touches (ordered composition), owned by the caller so that a row
/// of tiles allocates it once, not once per tile.
#[inline(always)]
pub(crate) fn run_packets<L: Lane, const UNIT: bool, S: PacketIo<L>>(
    scene: &Scene,
    volumes: Option<&[u32]>,
    count: usize,
    io: &mut S,
    scratch: &mut Vec<Entry<L>>,
) {
    if let Some(single) = Single::of(scene) {
        return run_packets_single::<L, UNIT, S>(scene, &single, count, io);
    }
    // The general kernel, packet by packet (the tier is an argument of `eval_general`).
    #[inline(always)]
    fn general<L: Lane, const AXIS: usize, const UNIT: bool, S: PacketIo<L>>(
        scene: &Scene,
        volumes: Option<&[u32]>,
        count: usize,
        io: &mut S,
        scratch: &mut Vec<Entry<L>>,
    ) {
        let fast = scene.tier == crate::Tier::Fast;
        for i in 0..count {
            let p = io.make(i);
            let r =
                eval_general_with::<L, AXIS, UNIT>(scene, p, true, true, fast, volumes, scratch);
            io.take(i, &r);
        }
    }
    match scene.axis {
        UpAxis::Axis(0) => general::<L, 0, UNIT, S>(scene, volumes, count, io, scratch),
        UpAxis::Axis(1) => general::<L, 1, UNIT, S>(scene, volumes, count, io, scratch),
        UpAxis::Axis(2) => general::<L, 2, UNIT, S>(scene, volumes, count, io, scratch),
        _ => general::<L, GENERAL, UNIT, S>(scene, volumes, count, io, scratch),
    }
}

/// [`run_packets`] for a scene of one height fog layer (`single`, its [`Single::of`]).
/// Lanes of any width: the framebuffer pass also calls it with
/// [`Zmm`](crate::math::zmm::Zmm) lanes where AVX-512 is chosen at run time (every
/// function below is inlined, so that the entry point's target features reach each lane
/// operation).
#[inline(always)]
pub(crate) fn run_packets_single<L: Lane, const UNIT: bool, S: PacketIo<L>>(
    scene: &Scene,
    single: &Single,
    count: usize,
    io: &mut S,
) {
    match (scene.axis, scene.tier == crate::Tier::Fast) {
        (UpAxis::Axis(0), false) => single_packets::<L, 0, UNIT, false, S>(single, count, io),
        (UpAxis::Axis(1), false) => single_packets::<L, 1, UNIT, false, S>(single, count, io),
        (UpAxis::Axis(2), false) => single_packets::<L, 2, UNIT, false, S>(single, count, io),
        (_, false) => single_packets::<L, GENERAL, UNIT, false, S>(single, count, io),
        (UpAxis::Axis(0), true) => single_packets::<L, 0, UNIT, true, S>(single, count, io),
        (UpAxis::Axis(1), true) => single_packets::<L, 1, UNIT, true, S>(single, count, io),
        (UpAxis::Axis(2), true) => single_packets::<L, 2, UNIT, true, S>(single, count, io),
        (_, true) => single_packets::<L, GENERAL, UNIT, true, S>(single, count, io),
    }
}

/// The packets of [`run_packets`] for one height fog layer: in blocks, stage by stage,
/// like [`run_single`]: the packets of a block are made, evaluated by [`eval_block`] and
/// handed back in three loops.
#[inline(always)]
fn single_packets<
    L: Lane,
    const AXIS: usize,
    const UNIT: bool,
    const FAST: bool,
    S: PacketIo<L>,
>(
    single: &Single,
    count: usize,
    io: &mut S,
) {
    let z = L::splat(0.0);
    let mut ins = [PacketIn {
        o: [z; 3],
        d: [z; 3],
        t: z,
    }; BLOCK];
    let mut outs = [PacketOut {
        tau: [z; 3],
        trans: [z; 3],
        insc: [z; 3],
    }; BLOCK];
    let mut i = 0;
    while i < count {
        let m = (count - i).min(BLOCK);
        for (k, p) in ins[..m].iter_mut().enumerate() {
            *p = io.make(i + k);
        }
        eval_block::<L, AXIS, UNIT, FAST>(single, &ins[..m], &mut outs[..m]);
        for (k, r) in outs[..m].iter().enumerate() {
            io.take(i + k, r);
        }
        i += m;
    }
}

/// The depth stages of a block ([`run_single`], [`eval_block`]): φ and the density
/// exponential in two loops (fewer constants each), giving the geometric depth of each
/// packet of `args` in `depth` (`kind`: the layer's [`falloff_kind`]; a homogeneous layer
/// needs neither exponential).
#[inline(always)]
fn depth_stages<L: Lane, const FAST: bool>(
    kind: u8,
    args: &[DepthArgs<L>],
    phis: &mut [L; BLOCK],
    depth: &mut [(L, L); BLOCK],
) {
    if kind == 0 {
        for (d, a) in depth.iter_mut().zip(args) {
            *d = depth_with_of::<L, FAST, true, true>(a, L::splat(0.0));
        }
    } else {
        for (phi, a) in phis.iter_mut().zip(args) {
            *phi = depth_phi::<L, FAST, true>(a);
        }
        for ((d, a), &phi) in depth.iter_mut().zip(args).zip(phis.iter()) {
            *d = depth_with_of::<L, FAST, true, false>(a, phi);
        }
    }
}

/// [`depth_stages`] for a block of packets that all took the tame stage 1 (a falloff
/// of kind 1), with the same bits: for unit directions their exponent is −0, so the
/// density stage skips adding it (a load and an add per packet).
#[inline(always)]
fn depth_stages_tame<L: Lane, const FAST: bool, const UNIT: bool>(
    args: &[DepthArgs<L>],
    phis: &mut [L; BLOCK],
    depth: &mut [(L, L); BLOCK],
) {
    for (phi, a) in phis.iter_mut().zip(args) {
        *phi = depth_phi::<L, FAST, true>(a);
    }
    for ((d, a), &phi) in depth.iter_mut().zip(args).zip(phis.iter()) {
        *d = depth_with_tame::<L, FAST, UNIT>(a, phi);
    }
}

/// [`eval_packet`]`::<L, AXIS, UNIT, true, true, FAST>` for each packet of `ins` (at
/// most [`BLOCK`]), stage by stage over the block as in [`run_single`]: the same stage
/// functions in the same order, so the same bits. T and L_in are always formed (the
/// pass wants both); τ only where T is formed from it (not where [`Single::t_from_depth`]).
#[inline(always)]
fn eval_block<L: Lane, const AXIS: usize, const UNIT: bool, const FAST: bool>(
    single: &Single,
    ins: &[PacketIn<L>],
    outs: &mut [PacketOut<L>],
) {
    let single_copy = *single;
    let single = &single_copy;
    let z = L::splat(0.0);
    let mut args = [DepthArgs::zero(); BLOCK];
    let mut dirs = [[z; 3]; BLOCK];
    let mut phis = [z; BLOCK];
    let mut depth = [(z, z); BLOCK];
    let m = ins.len().min(outs.len()).min(BLOCK);
    let (ins, outs) = (&ins[..m], &mut outs[..m]);
    let kind = falloff_kind(&single.layer);
    macro_rules! args_loop {
        ($kind:literal) => {
            for ((a, dir), p) in args.iter_mut().zip(dirs.iter_mut()).zip(ins) {
                (*a, *dir, _) = single_args::<L, AXIS, UNIT, true, $kind, true>(single, p);
            }
        };
    }
    match kind {
        0 => args_loop!(0),
        1 => args_loop!(1),
        _ => args_loop!(2),
    }
    depth_stages::<L, FAST>(kind, &args[..m], &mut phis, &mut depth);
    macro_rules! tau_loop {
        ($f:expr) => {
            for (r, &g) in outs.iter_mut().zip(&depth) {
                r.tau = $f(single, g);
            }
        };
    }
    // τ only where T is formed from it: the pass reads T and L_in, never τ (`PacketIo`),
    // so where T comes from the depth (`depth_trans`) `outs`' τ stays as it was.
    match single.tau_kind {
        _ if single.t_from_depth::<FAST>() => {}
        _ if single.tiny_tau(&depth[..m]) => tau_loop!(single_tau_tiny::<L>),
        0 => tau_loop!(single_tau::<L, 0>),
        1 => tau_loop!(single_tau::<L, 1>),
        _ => tau_loop!(single_tau::<L, 2>),
    }
    if single.t_from_depth::<FAST>() {
        let es = L::splat(single.depth_scale.0);
        for (r, &d) in outs.iter_mut().zip(&depth) {
            r.trans = depth_trans(single, shared_g(es, d));
        }
    } else if single.grey {
        for r in outs.iter_mut() {
            r.trans = [single_trans::<L, FAST>(r.tau[0]); 3];
        }
    } else {
        for ch in 0..3 {
            for r in outs.iter_mut() {
                r.trans[ch] = single_trans::<L, FAST>(r.tau[ch]);
            }
        }
    }
    macro_rules! colour_loop {
        ($consts:expr, $f:expr) => {{
            let consts = $consts;
            for (r, dir) in outs.iter_mut().zip(&dirs) {
                r.insc = $f(&consts, dir, &r.trans);
            }
        }};
    }
    match (single.n_lit, single.lit[0].0.kind) {
        (1, 1) => colour_loop!(OneLit::of(single), single_colour_one::<L, 1>),
        (1, 2) => colour_loop!(OneLit::of(single), single_colour_one::<L, 2>),
        (1, 3) => colour_loop!(OneLit::of(single), single_colour_one::<L, 3>),
        _ => colour_loop!(*single, single_colour::<L>),
    }
}

/// The unspecialized baseline of `tests/plan.rs`: every packet of the batch through
/// [`eval_general`]`::<f32x8, GENERAL, false>` (up as a dot product, |d| computed, τ, T
/// and L_in all computed, the outputs chosen at run time), the tail padded as [`run`] pads
/// it. `Scene::new` folds the sign of an axis-aligned up vector into the layers' constants
/// for the axis kernels; they are unfolded here, so that the dot product with the scene's
/// up vector gives the height.
fn run_unspecialized(scene: &Scene, rays: &Rays<'_>, out: &mut Outputs<'_>) {
    let mut general = scene.clone();
    if let UpAxis::Axis(i) = scene.axis {
        let sign = scene.up[i];
        for l in &mut general.layers {
            l.h0 *= sign;
            l.b *= sign;
            l.b_split = crate::scene::Split::of(l.b);
        }
        general.axis = UpAxis::General;
    }
    let scene = &general;
    let fast = scene.tier == crate::Tier::Fast;
    let n = rays.len();
    let mut i = 0;
    let mut scratch = Vec::new();
    while i < n {
        let m = (n - i).min(8);
        let pad = |s: &[f32], fill: f32| {
            let mut b = [fill; 8];
            b[..m].copy_from_slice(&s[i..i + m]);
            f32x8::new(b)
        };
        let p = PacketIn {
            o: [0, 1, 2].map(|c| pad(rays.o[c], 0.0)),
            d: [0, 1, 2].map(|c| pad(rays.d[c], 1.0)),
            t: pad(rays.t, 0.0),
        };
        let r = eval_general::<f32x8, GENERAL, false>(scene, p, true, true, fast, &mut scratch);
        for (v, dst) in [
            (r.tau, &mut out.tau),
            (r.trans, &mut out.transmittance),
            (r.insc, &mut out.inscattering),
        ] {
            if let Some(d) = dst {
                for ch in 0..3 {
                    d[ch][i..i + m].copy_from_slice(&v[ch].to_array()[..m]);
                }
            }
        }
        i += m;
    }
}

impl Scene {
    /// [`Scene::evaluate`] without the kernel specializations: every packet through the
    /// general kernel (general up vector, non-unit directions, all outputs computed). For
    /// tests (`tests/plan.rs`: the specialized kernels agree with it within the stated
    /// bound).
    #[doc(hidden)]
    pub fn evaluate_unspecialized(
        &self,
        rays: &Rays<'_>,
        mut out: Outputs<'_>,
    ) -> Result<(), crate::BatchError> {
        out.check(rays.len())?;
        run_unspecialized(self, rays, &mut out);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    //! The tame path of stage 1 (`depth_args_tame`) against the general arithmetic it
    //! replaces: τ and T must have the same bits for every ray the tame path accepts.
    use super::*;
    use crate::{Component, HeightFogLayer, Phase, SceneDesc};
    use glam::Vec3;

    /// τ (three channels) and T of lane 0 after stages 2 to 4 from the given stage-1
    /// arguments (NaN as one pattern: its sign and payload are not specified).
    fn finish<const FAST: bool>(single: &Single, args: DepthArgs<f32x8>) -> [u32; 6] {
        let depth = single_depth::<f32x8, FAST>(single, args);
        let tau = match single.tau_kind {
            0 => single_tau::<f32x8, 0>(single, depth),
            1 => single_tau::<f32x8, 1>(single, depth),
            _ => single_tau::<f32x8, 2>(single, depth),
        }
        .map(|x| x.to_array()[0]);
        let t = tau.map(single_trans::<f32, FAST>);
        [tau[0], tau[1], tau[2], t[0], t[1], t[2]].map(|x| {
            if x.is_nan() {
                u32::MAX
            } else {
                x.to_bits()
            }
        })
    }

    /// `depth_with_tame` gives the bits of `depth_with_of` on tame arguments (both tiers).
    fn same_depth<const UNIT: bool>(a: &DepthArgs<f32x8>, ctx: &str) {
        let bits = |(m, e): (f32x8, f32x8)| {
            (
                m.to_array().map(f32::to_bits),
                e.to_array().map(f32::to_bits),
            )
        };
        let phi = depth_phi::<f32x8, false, true>(a);
        assert_eq!(
            bits(depth_with_tame::<f32x8, false, UNIT>(a, phi)),
            bits(depth_with_of::<f32x8, false, true, false>(a, phi)),
            "density stage: {ctx}"
        );
        let phi = depth_phi::<f32x8, true, true>(a);
        assert_eq!(
            bits(depth_with_tame::<f32x8, true, UNIT>(a, phi)),
            bits(depth_with_of::<f32x8, true, true, false>(a, phi)),
            "density stage, Fast tier: {ctx}"
        );
    }

    fn single(b: f32, h0: f32, sigma: [f32; 3]) -> Single {
        let scene = Scene::new(SceneDesc {
            height_fog: vec![HeightFogLayer {
                base_height: h0,
                falloff: b,
                emission: Vec3::ZERO,
                components: vec![Component {
                    scattering: Vec3::from_array(sigma),
                    absorption: Vec3::ZERO,
                    phase: Phase::Isotropic,
                }],
            }],
            ..SceneDesc::default()
        })
        .unwrap();
        Single::of(&scene).unwrap()
    }

    /// Values on both sides of every bound of the tame path, and the extremes.
    fn edge_values(bounds: &[f32]) -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-45,
            1e-30,
            1e-12,
            0.3,
            1.0,
            7.5,
            1e3,
            1e12,
            3e38,
            f32::MAX,
            f32::INFINITY,
            f32::NAN,
        ];
        for &b in bounds {
            for k in -1i32..=1 {
                v.push(f32::from_bits((b.to_bits() as i32 + k) as u32));
            }
        }
        let neg: Vec<f32> = v.iter().map(|x| -x).collect();
        v.extend(neg);
        v
    }

    /// `shared_depth`'s g against the exact τ: the accurate tier's `depth_trans` within
    /// `exp_neg_mul`'s 0.62 ULP of the f64 e^(−τ) of the exact τ = gm·2^(ge+e_s)·m_c (an
    /// absolute error below 2^-126 where that is below 2^-126), and the Fast tier's T from
    /// g·m_c the same bits as from `single_tau`'s τ; for depths (gm, ge) over the whole
    /// range the kernel produces (gm < 2^32, ≥ 2^-32 or 0, NaN), with the scale exponent
    /// e = ge + e_s on both sides of ±64 and far beyond, σ sets with a zero channel and
    /// channels 2^16 apart, and grey ones (zero included). A NaN exponent gives NaN in its
    /// lane only.
    #[test]
    fn shared_depth_gives_the_transmittance_of_the_exact_tau() {
        let two = |e: i32| 2.0f32.powi(e);
        let gms = [
            0.0,
            two(-32),
            0.66 * two(-11),
            0.3,
            1.0,
            1.999_999_9,
            5.999_999_5,
            1.5 * two(31),
            f32::from_bits(two(32).to_bits() - 1),
            f32::NAN,
        ];
        let sigmas = [
            [0.02, 0.03, 0.05],
            [1e-20, 1.3e-20, 0.0],
            [1.0, 1.0 / 65536.0, 0.7],
            [3e30, 2e30, 1e30],
            [0.0, 0.0, 1e-3],
            // Grey (`tau_kind` 0).
            [0.02; 3],
            [1e-30; 3],
            [3e30; 3],
            [1.0; 3],
            [0.0; 3],
        ];
        let bits = |x: f32x8| {
            let x = x.to_array()[0];
            if x.is_nan() {
                u32::MAX
            } else {
                x.to_bits()
            }
        };
        let mut checked = [0usize; 3];
        let mut worst = 0.0f64;
        for sigma in sigmas {
            let s = single(0.1, 0.0, sigma);
            let grey = sigma[0] == sigma[1] && sigma[1] == sigma[2];
            assert_eq!(s.tau_kind, if grey { 0 } else { 1 }, "{sigma:?}");
            let (es, mc) = if grey {
                (s.layer.sigma[0].e, [s.layer.sigma[0].m; 3])
            } else {
                s.shared
            };
            let es = es as i32;
            for &gm in &gms {
                for e in (-200..=200).chain([-2_000_000, 2_000_000]) {
                    let ge = (e - es) as f32;
                    let depth = [(f32x8::splat(gm), f32x8::splat(ge)); BLOCK];
                    let mut gs = [f32x8::splat(0.0); BLOCK];
                    shared_depth(&s, &depth, &mut gs);
                    // AVX-512 lanes (`vscalefps` in place of 2^e from its bits and the
                    // FMA) give the same g, bit for bit.
                    #[cfg(zmm_dispatch)]
                    if crate::math::zmm::detected() {
                        use crate::math::zmm::Zmm;
                        let es = Zmm::splat(s.depth_scale.0);
                        let g = shared_g(es, (Zmm::splat(gm), Zmm::splat(ge)));
                        let mut a = [0f32; 16];
                        g.store(&mut a);
                        let z = if a[0].is_nan() {
                            u32::MAX
                        } else {
                            a[0].to_bits()
                        };
                        assert_eq!(z, bits(gs[0]), "16 lanes: gm={gm:e} e={e}");
                    }
                    let tau = if grey {
                        single_tau::<f32x8, 0>(&s, depth[0])
                    } else {
                        single_tau::<f32x8, 1>(&s, depth[0])
                    };
                    let tr = depth_trans(&s, gs[0]);
                    for ch in 0..3 {
                        let ctx = format!("sigma={sigma:?} gm={gm:e} e={e} channel {ch}");
                        assert_eq!(
                            bits(single_trans::<f32x8, true>(gs[0] * f32x8::splat(mc[ch]))),
                            bits(single_trans::<f32x8, true>(tau[ch])),
                            "Fast tier: {ctx}"
                        );
                        let t = tr[ch].to_array()[0];
                        // The exact τ (gm·m_c is exact in f64; 2^e may leave its range,
                        // to 0 or inf, where e^(−τ) is 1 or 0 either way).
                        let exact = f64::from(gm) * f64::from(mc[ch]) * 2f64.powi(e);
                        let want = if (mc[ch] == 0.0 || gm == 0.0) && gm.is_finite() {
                            1.0
                        } else {
                            (-exact).exp()
                        };
                        if gm.is_nan() {
                            assert!(t.is_nan(), "{ctx}: {t:e}");
                            continue;
                        }
                        let err = if want >= f64::from(f32::MIN_POSITIVE) {
                            let ulp = 2f64.powi(want.log2().floor() as i32 - 23);
                            (f64::from(t) - want).abs() / ulp
                        } else {
                            let abs = (f64::from(t) - want).abs();
                            assert!(abs < f64::from(f32::MIN_POSITIVE), "{ctx}: {t:e}");
                            0.0
                        };
                        assert!(err <= 0.62, "{ctx}: T = {t:e}, want {want:e}: {err} ULP");
                        worst = worst.max(err);
                        checked[if t == 1.0 {
                            0
                        } else if t == 0.0 {
                            1
                        } else {
                            2
                        }] += 1;
                    }
                }
            }
        }
        // T = 1, T = 0 and T in between were all compared.
        assert!(checked.iter().all(|&n| n > 500), "{checked:?}");
        assert!(worst > 0.0, "no rounding seen: the test does not test");
        // A NaN exponent in one lane of one packet: NaN there, the other lanes' T as
        // without it.
        let s = single(0.1, 0.0, [0.02, 0.03, 0.05]);
        let mut depth = [(f32x8::splat(1.0), f32x8::splat(0.0)); BLOCK];
        let clean = depth;
        let mut ge = [0.0f32; 8];
        ge[5] = f32::NAN;
        depth[BLOCK - 1].1 = f32x8::from(ge);
        let (mut gs, mut gs_clean) = ([f32x8::splat(0.0); BLOCK], [f32x8::splat(0.0); BLOCK]);
        shared_depth(&s, &depth, &mut gs);
        shared_depth(&s, &clean, &mut gs_clean);
        for k in 0..BLOCK {
            let (a, b) = (gs[k].to_array(), gs_clean[k].to_array());
            for l in 0..8 {
                if k == BLOCK - 1 && l == 5 {
                    assert!(a[l].is_nan());
                } else {
                    assert_eq!(a[l].to_bits(), b[l].to_bits(), "packet {k} lane {l}");
                }
            }
        }
    }

    #[test]
    fn tame_stage_one_gives_the_general_bits() {
        let two = |e: i32| 2.0f32.powi(e);
        let ts = edge_values(&[
            two(-20),
            two(31),
            two(-59),
            256.0,
            two(-52),
            two(43),
            two(90),
            // The tame tests' floor on t.
            two(-56),
        ]);
        // (2^k/0.1: the bounds on |b·u| of the sky and far lanes for the first layer.)
        let us = edge_values(&[
            two(-59),
            two(-90),
            two(-126),
            256.0,
            two(-62),
            two(-12) / 0.1,
            two(12) / 0.1,
            two(-38) / 0.1,
            two(-29) / 0.1,
            two(29) / 0.1,
            // Δ = b·u·t about 2^-60 (φ's clamp, the general path's clamped Δ·2^-64) for
            // t = 1 and 7.5 in the first layer.
            two(-60) / 0.1,
            two(-62) / 0.1,
            two(-63) / 0.75,
        ]);
        // |b·y| about 2^-34 (|a0s| about 2^-98, where a tiny negative Δ could move the
        // general path's u_min) in the first layer.
        let ys = edge_values(&[two(-62), two(-60), two(64), two(100), two(-34) / 0.1]);
        // (b, h0): typical, negative, tiny and the largest of KIND 1; base heights that
        // make y − h0 cancel or leave the scaled range.
        let layers = [
            (0.1, 0.0),
            (-0.37, 5.0),
            (1e-30, -1e20),
            // b·log2(e) just under 2^40 (the base-2 layer's bound of `KIND` 1).
            (7.62e11, 1e-19),
            (3.0, 2.168_404_3e-19), // 2^-62
            (1e-12, 3e38),
        ];
        let sigmas = [
            [0.5; 3],
            [0.02, 0.03, 0.05],
            [1e-20, 1.0, 1e20],
            [1e-38, 2e-38, 0.0],
        ];
        let (mut tame, mut total) = (0usize, 0usize);
        // Lanes the widened stage takes: near (m scaled), far, sky, zero.
        let mut wide = [0usize; 4];
        for &(b, h0) in &layers {
            for sigma in sigmas {
                let s = single(b, h0, sigma);
                assert_eq!(falloff_kind(&s.layer), 1);
                for &y in &ys {
                    for &u in &us {
                        for &t in &ts {
                            // One ray in all eight lanes: the tame path is taken exactly
                            // where `ok` says.
                            let p = |dx: f32| PacketIn {
                                o: [0.0, y, 0.0].map(f32x8::splat),
                                d: [dx, u, 0.0].map(f32x8::splat),
                                t: f32x8::splat(t),
                            };
                            let ctx = || {
                                format!("b={b:e} h0={h0:e} sigma={sigma:?} y={y:e} u={u:e} t={t:e}")
                            };
                            total += 1;
                            let norm = (1.0, -0.0);
                            let plain = depth_args_tame(&s.layer, y, u, t, norm);
                            let (_, ok) =
                                depth_args_tame_wide::<_, true>(&s.layer, y, u, t, norm, plain);
                            tame += ok as usize;
                            let plain = plain.1;
                            if ok && !plain {
                                let far = t.is_finite() && (b * u * t).abs() >= 256.0;
                                wide[if t == 0.0 {
                                    3
                                } else if t.is_infinite() {
                                    2
                                } else {
                                    far as usize
                                }] += 1;
                            }
                            // Unit directions.
                            let (a, _, tamed) =
                                single_args::<f32x8, 1, true, false, 1, true>(&s, &p(0.0));
                            assert_eq!(tamed, ok && plain, "{}", ctx());
                            if tamed {
                                same_depth::<true>(&a, &ctx());
                            }
                            let g = single_args_general::<f32x8, 1, true, 1>(&s, &p(0.0));
                            assert_eq!(finish::<false>(&s, a), finish::<false>(&s, g), "{}", ctx());
                            assert_eq!(
                                finish::<true>(&s, a),
                                finish::<true>(&s, g),
                                "Fast tier: {}",
                                ctx()
                            );
                            // General directions (|d| carried as mantissa and exponent).
                            for dx in [0.6f32, 1e-30, 3e20, f32::INFINITY, f32::NAN] {
                                let (a, _, tamed) =
                                    single_args::<f32x8, 1, false, false, 1, true>(&s, &p(dx));
                                if tamed {
                                    same_depth::<false>(&a, &ctx());
                                }
                                let g = single_args_general::<f32x8, 1, false, 1>(&s, &p(dx));
                                assert_eq!(
                                    finish::<false>(&s, a),
                                    finish::<false>(&s, g),
                                    "dx={dx:e} {}",
                                    ctx()
                                );
                            }
                        }
                    }
                }
            }
        }
        // Both paths, and each kind of the widened stage's lanes, were exercised.
        eprintln!("{tame} of {total} tame; near, far, sky, zero: {wide:?}");
        assert!(
            tame > total / 20 && tame < total / 2 && wide.iter().all(|&k| k > total / 1000),
            "{tame} of {total} tame; near, far, sky, zero: {wide:?}"
        );
    }

    /// The tame path covers every packet of both of the peer's data sets (README,
    /// "Speed"; the extreme set is extreme for a plain f32 formula, whose exponentials
    /// overflow and underflow there, not for the tame path's bounds, which leave the
    /// density's exponential split): a change that sent them to the general arithmetic
    /// would keep the bits and lose the speed unnoticed.
    #[test]
    fn tame_path_covers_the_peer_data() {
        use crate::reference::peer::{PeerRays, BETA, FALLOFF};
        let s = single(FALLOFF, 0.0, BETA);
        for extreme in [false, true] {
            let rays = PeerRays::new(65536, extreme);
            let (mut tame, mut total) = (0usize, 0usize);
            for k in (0..rays.t.len()).step_by(8) {
                let v = |a: &[f32]| f32x8::new(a[k..k + 8].try_into().unwrap());
                let (_, ok) = depth_args_tame(
                    &s.layer,
                    v(&rays.oy),
                    v(&rays.dy),
                    v(&rays.t),
                    (f32x8::splat(1.0), f32x8::splat(-0.0)),
                );
                tame += ok.all() as usize;
                total += 1;
            }
            let share = tame as f64 / total as f64;
            eprintln!("extreme={extreme}: {tame} of {total} packets of 8 tame ({share:.3})");
            assert_eq!(tame, total, "extreme={extreme}");
        }
    }

    /// The widened tame stage (`depth_args_tame_wide`) covers every packet of the
    /// benches' `sky` and `stiff` sets (`PeerRays::crate_extreme`), so that they run at
    /// the tame stage's speed where the lanes are not `Lane::NATIVE_SCALE` (AVX2's 8
    /// lanes; AVX-512 lanes take the general arithmetic instead, see `single_args`);
    /// `tame_stage_one_gives_the_general_bits` checks its bits.
    #[test]
    fn widened_tame_path_covers_the_crate_extreme_data() {
        use crate::reference::peer::{PeerRays, BETA, FALLOFF};
        let s = single(FALLOFF, 0.0, BETA);
        for stiff in [false, true] {
            let rays = PeerRays::crate_extreme(65536, stiff);
            let (mut plain, mut wide, mut total) = (0usize, 0usize, 0usize);
            for k in (0..rays.t.len()).step_by(8) {
                let v = |a: &[f32]| f32x8::new(a[k..k + 8].try_into().unwrap());
                let (y, u, t) = (v(&rays.oy), v(&rays.dy), v(&rays.t));
                let norm = (f32x8::splat(1.0), f32x8::splat(-0.0));
                let tame = depth_args_tame(&s.layer, y, u, t, norm);
                plain += tame.1.all() as usize;
                let (_, ok) = depth_args_tame_wide::<_, true>(&s.layer, y, u, t, norm, tame);
                wide += ok.all() as usize;
                total += 1;
            }
            eprintln!("stiff={stiff}: {plain} plain, {wide} widened of {total} packets");
            assert!(
                plain < total / 10,
                "stiff={stiff}: {plain} of {total} plain"
            );
            assert_eq!(wide, total, "stiff={stiff}");
        }
    }
}
