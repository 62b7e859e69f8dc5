//! Issue 5, "Specialized plans": what each specialization of the plan gains over the
//! general kernel, and how close the plan comes to a kernel written by hand for exactly
//! one case.
//!
//! `cargo bench --bench plan -- --warm-up-time 1 --measurement-time 3 --noplot`
//!
//! 64K rays in cache (structure of arrays), typical data: cameras 0.5 to 10 above the fog
//! base, 100 apart horizontally, unit directions uniform on the sphere, t in [1, 300]
//! clipped at the ground. One height fog layer, b = 0.1.
//!
//! - Group `plan_vs_general`: for each case, `plan/<case>` is `Scene::evaluate` (the
//!   specialized kernel the plan selects) and `general/<case>` is
//!   `Scene::evaluate_unspecialized` (every packet through the general kernel: up as a dot
//!   product, |d| computed, τ, T and L_in all computed), same rays, same outputs.
//! - Group `plan_vs_hand`: `plan/<case>` against `hand/<case>`, a kernel written here over
//!   `wide::f32x8` with the crate's public `analytic_fog::math` functions only, for exactly
//!   that case: the same stable closed form as `layer_depth` (anchored at the denser end,
//!   `exprel_neg(|Δ|)`, mantissa/exponent carried so that nothing overflows, NaN for an
//!   invalid ray), without what the case does not need (no layer loop, no run-time
//!   output or falloff tests, scene constants in registers, no colour clamp). The hand
//!   kernel is staged like the library's single-layer batch loop (`run_single`): blocks of
//!   16 packets of 8 rays, one loop per stage (loads and exponent arithmetic; φ;
//!   e^(−u_min) and G; τ; T per channel; colour), intermediates in stack arrays.
//!   `hand_per_packet/<case>` is the same arithmetic packet by packet (each packet from
//!   its loads to its stores before the next), which shows what the staging gains. The
//!   setup asserts that both hand kernels agree with `Scene::evaluate` on the bench rays
//!   (they give the same bits).

// Channel loops index several parallel arrays.
#![allow(clippy::needless_range_loop)]

use analytic_fog::math::{exp_neg, exp_split, exprel_neg, frexp, ldexp, pow2_pair, Lane};
use analytic_fog::{
    Component, HeightFogLayer, Lighting, Outputs, Phase, Rays, Scene, SceneDesc, Sun,
};
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::{DVec3, Vec3};
use wide::f32x8;

const N: usize = 65536;
/// Falloff and base height of the layer.
const B: f32 = 0.1;
const H0: f32 = 0.0;
const RGB: [f32; 3] = [0.02, 0.03, 0.05];
const GREY: [f32; 3] = [0.03, 0.03, 0.03];
const AMBIENT: [f32; 3] = [0.5, 0.6, 0.7];
const SUN_DIR: [f32; 3] = [0.3, 0.4, -0.87];
const SUN_RAD: [f32; 3] = [20.0, 18.0, 15.0];
const HG_G: f32 = 0.7;
/// The general up vector (normalized by the scene).
const UP_GENERAL: [f32; 3] = [0.3, 1.0, 0.2];

// ---------------------------------------------------------------------------------------
// Data

struct RaySet {
    o: [Vec<f32>; 3],
    d: [Vec<f32>; 3],
    t: Vec<f32>,
    unit: bool,
}

impl RaySet {
    fn rays(&self) -> Rays<'_> {
        Rays::new(
            &self.o[0], &self.o[1], &self.o[2], &self.d[0], &self.d[1], &self.d[2], &self.t,
        )
        .unwrap()
        .with_unit_directions(self.unit)
    }
}

/// Typical rays; `scaled`: each direction multiplied by a factor in [0.5, 2] (non-unit,
/// t divided by it so that the segments are the same).
fn make_rays(n: usize, scaled: bool) -> RaySet {
    let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut uni = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    };
    let mut r = RaySet {
        o: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        d: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
        t: vec![0.0; n],
        unit: !scaled,
    };
    for i in 0..n {
        let y = 0.5 + 9.5 * uni();
        let x = 200.0 * uni() - 100.0;
        let z = 200.0 * uni() - 100.0;
        let dy = 2.0 * uni() - 1.0;
        let phi = std::f64::consts::TAU * uni();
        let h = (1.0 - dy * dy).max(0.0).sqrt();
        let d = DVec3::new(h * phi.cos(), dy, h * phi.sin()).normalize();
        let mut t = 1.0 + 299.0 * uni();
        if d.y < 0.0 && -y / d.y < t {
            t = -y / d.y;
        }
        let k = if scaled { 0.5 + 1.5 * uni() } else { 1.0 };
        r.o[0][i] = x as f32;
        r.o[1][i] = y as f32;
        r.o[2][i] = z as f32;
        for c in 0..3 {
            r.d[c][i] = (d[c] * k) as f32;
        }
        r.t[i] = (t / k) as f32;
    }
    r
}

#[derive(Clone, Copy)]
struct Case {
    name: &'static str,
    grey: bool,
    sun: bool,
    ambient: bool,
    general_up: bool,
    unit: bool,
    tau: bool,
    trans: bool,
    insc: bool,
}

impl Case {
    const BASE: Case = Case {
        name: "",
        grey: false,
        sun: false,
        ambient: false,
        general_up: false,
        unit: true,
        tau: false,
        trans: true,
        insc: false,
    };
}

fn scene(c: &Case) -> Scene {
    let beta = if c.grey { GREY } else { RGB };
    Scene::new(SceneDesc {
        up: if c.general_up {
            Vec3::from_array(UP_GENERAL)
        } else {
            Vec3::Y
        },
        height_fog: vec![HeightFogLayer {
            base_height: H0,
            falloff: B,
            emission: Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::from_array(beta),
                absorption: Vec3::ZERO,
                phase: if c.sun {
                    Phase::HenyeyGreenstein(HG_G)
                } else {
                    Phase::Isotropic
                },
            }],
        }],
        lighting: Lighting {
            ambient: if c.ambient {
                Vec3::from_array(AMBIENT)
            } else {
                Vec3::ZERO
            },
            sun: c.sun.then(|| Sun {
                direction: Vec3::from_array(SUN_DIR),
                radiance: Vec3::from_array(SUN_RAD),
            }),
        },
        ..SceneDesc::default()
    })
    .unwrap()
}

/// Nine output arrays: τ, T, L_in per channel.
struct Out {
    v: Vec<Vec<f32>>,
}

impl Out {
    fn new(n: usize) -> Out {
        Out {
            v: (0..9).map(|_| vec![0.0; n]).collect(),
        }
    }
    fn outputs(&mut self, tau: bool, trans: bool, insc: bool) -> Outputs<'_> {
        let [a, b, c, d, e, f, g, h, i] = &mut self.v[..] else {
            unreachable!()
        };
        Outputs {
            tau: tau.then_some([a, b, c]),
            transmittance: trans.then_some([d, e, f]),
            inscattering: insc.then_some([g, h, i]),
        }
    }
    fn case(&mut self, c: &Case) -> Outputs<'_> {
        self.outputs(c.tau, c.trans, c.insc)
    }
}

// ---------------------------------------------------------------------------------------
// Hand-written kernels

const TWO_M64: f32 = 1.0 / TWO64;
const TWO64: f32 = 18_446_744_073_709_551_616.0;
const TWO40: f32 = 1_099_511_627_776.0;
/// frexp exponent given to t = +∞ and to u = 0 (see `medium/height_fog.rs`).
const INF_EXPONENT: f32 = 2_097_152.0;
const U_ZERO_EXPONENT: f32 = -8_388_608.0;
const PHI_MAX_EXP: f32 = 8.0;

#[inline(always)]
fn sp(v: f32) -> f32x8 {
    f32x8::splat(v)
}

/// `lo.max(hi.min(x))` with x86 minps/maxps semantics (NaN stays NaN).
#[inline(always)]
fn clamp(x: f32x8, lo: f32, hi: f32) -> f32x8 {
    sp(lo).fast_max(sp(hi).fast_min(x))
}

#[inline(always)]
fn load(s: &[f32], i: usize) -> f32x8 {
    <f32x8 as Lane>::load(&s[i..i + 8])
}

#[inline(always)]
fn store(v: f32x8, s: &mut [f32], i: usize) {
    s[i..i + 8].copy_from_slice(&v.to_array());
}

/// One layer's constants, for a falloff 0 < |b| ≤ 2^40 (checked when built).
#[derive(Clone, Copy)]
struct HandLayer {
    b: f32,
    h0_s: f32,
    b_m: f32,
    b_e: f32,
    /// The extinction as a shared exponent and three mantissas (exact).
    s_e: f32,
    s_m: [f32; 3],
}

impl HandLayer {
    /// `up_sign`: the sign of an axis-aligned up vector (folded into b and h0), 1 for a
    /// general one.
    fn new(b: f32, h0: f32, sigma: [f32; 3], up_sign: f32) -> HandLayer {
        let b = b * up_sign;
        let h0 = h0 * up_sign;
        assert!(b != 0.0 && b.abs() <= TWO40);
        let (b_m, b_e) = frexp(b);
        let max = sigma.iter().cloned().fold(0.0f32, f32::max);
        let (_, s_e) = frexp(max);
        let s_m = sigma.map(|s| (s as f64 * 2f64.powi(-(s_e as i32))) as f32);
        for c in 0..3 {
            assert_eq!((s_m[c] as f64 * 2f64.powi(s_e as i32)) as f32, sigma[c]);
        }
        HandLayer {
            b,
            h0_s: h0 * TWO_M64,
            b_m,
            b_e,
            s_e,
            s_m,
        }
    }
}

/// frexp of u = dot(d, up) (times 2^u_shift) and of t, and the NaN guard.
#[inline(always)]
fn split_ray(u: f32x8, u_shift: Option<f32x8>, t: f32x8) -> (f32x8, f32x8, f32x8, f32x8) {
    let (u_m, u_e) = frexp(u);
    let u_e = match u_shift {
        Some(s) => u_e + s,
        None => u_e,
    };
    let u_e = u.simd_eq(sp(0.0)).select(sp(U_ZERO_EXPONENT), u_e);
    let (t_m, t_e) = frexp(t);
    let t_e = t.simd_eq(sp(f32::INFINITY)).select(sp(INF_EXPONENT), t_e);
    (u_m, u_e, t_m, t_e)
}

/// The arguments of the two exponentials of [`depth`] and the factors that do not depend
/// on them (the first half of `depth`, like the library's `DepthArgs`).
#[derive(Clone, Copy)]
struct HandArgs {
    /// |Δ| clamped to [2^-60, 2^11), the argument of φ.
    dc: f32x8,
    /// The dense-end exponent u_min.
    u_min: f32x8,
    /// n_m · t_m (t_m for unit directions).
    m: f32x8,
    /// n_e + t_e + the exponent of φ's remainder.
    e: f32x8,
    guard: f32x8,
}

impl HandArgs {
    const ZERO: HandArgs = HandArgs {
        dc: f32x8::ZERO,
        u_min: f32x8::ZERO,
        m: f32x8::ZERO,
        e: f32x8::ZERO,
        guard: f32x8::ZERO,
    };
}

/// The first half of [`depth`]: everything up to the two exponentials.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn depth_args(
    l: &HandLayer,
    norm: Option<(f32x8, f32x8)>,
    y_s: f32x8,
    u_m: f32x8,
    u_e: f32x8,
    t_m: f32x8,
    t_e: f32x8,
    guard: f32x8,
) -> HandArgs {
    // Δ = b·u·t as mantissa and exponent.
    let dm = sp(l.b_m) * u_m * t_m;
    let de = sp(l.b_e) + u_e + t_e;
    // |Δ| clamped to [2^-60, 2^11) for φ; the rest of 1/|Δ| in the exponent.
    let dc = (dm.abs() * f32x8::pow2i(clamp(de, -100.0, PHI_MAX_EXP))).fast_max(sp(8.673_617e-19));
    let phi_e = (sp(PHI_MAX_EXP) - de).fast_min(sp(0.0));
    // The dense-end exponent u_min = b·y0 + min(Δ, 0), summed at 2^-64 scale.
    let a0s = sp(l.b) * (y_s - sp(l.h0_s));
    let ds = dm * f32x8::pow2i(clamp(de - sp(64.0), -126.0, 127.0));
    let u_min = (a0s + ds.fast_min(sp(0.0))) * sp(TWO64);
    let (m, e) = match norm {
        Some((n_m, n_e)) => (n_m * t_m, n_e + t_e + phi_e),
        None => (t_m, t_e + phi_e),
    };
    HandArgs {
        dc,
        u_min,
        m,
        e,
        guard,
    }
}

/// The second half of [`depth`], given φ(|Δ|) = `exprel_neg(a.dc)`: e^(−u_min) and G
/// assembled.
#[inline(always)]
fn depth_with(a: &HandArgs, phi: f32x8) -> (f32x8, f32x8) {
    let (em, ek) = exp_split(a.u_min.neg());
    (a.m * phi * em + a.guard, a.e + ek)
}

/// G = τ/σ0 as (m, e): the closed form of `layer_depth`; `norm`: |d| as (n_m, n_e), or
/// `None` for unit directions. The two halves in one go (the per-packet kernels).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn depth(
    l: &HandLayer,
    norm: Option<(f32x8, f32x8)>,
    y_s: f32x8,
    u_m: f32x8,
    u_e: f32x8,
    t_m: f32x8,
    t_e: f32x8,
    guard: f32x8,
) -> (f32x8, f32x8) {
    let a = depth_args(l, norm, y_s, u_m, u_e, t_m, t_e, guard);
    depth_with(&a, exprel_neg(a.dc))
}

/// +0 for a valid ray, NaN where u or the height is not finite or t is NaN or negative.
#[inline(always)]
#[allow(clippy::eq_op)] // x − x is NaN exactly when x is not finite
fn nan_guard(u: f32x8, y_s: f32x8, t: f32x8) -> f32x8 {
    (u - u) + (y_s - y_s) + t.simd_ge(sp(0.0)).select(sp(0.0), sp(f32::NAN))
}

/// (a) packet by packet: each packet of 8 rays from its loads to its stores before the
/// next (the staged [`hand_grey_y_unit_t`] gives the same bits).
fn hand_grey_y_unit_t_per_packet(l: &HandLayer, r: &RaySet, tr: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (oy, dy, t) = (&r.o[1][..n], &r.d[1][..n], &r.t[..n]);
    let [t0, t1, t2] = tr else { unreachable!() };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let mut i = 0;
    while i + 8 <= n {
        let y = load(oy, i);
        let u = load(dy, i);
        let tt = load(t, i);
        let y_s = y * sp(TWO_M64);
        let (u_m, u_e, t_m, t_e) = split_ray(u, None, tt);
        let guard = nan_guard(u, y_s, tt);
        let (gm, ge) = depth(l, None, y_s, u_m, u_e, t_m, t_e, guard);
        let tau = ldexp(gm * sp(l.s_m[0]), ge + sp(l.s_e));
        let tr = exp_neg(tau);
        store(tr, t0, i);
        store(tr, t1, i);
        store(tr, t2, i);
        i += 8;
    }
}

/// The fog colour constants of (b): Σ β_s·L_amb/β_t and β_s·E_sun/β_t (f64, rounded
/// once), the Henyey–Greenstein numerator and the unit sun direction.
struct HandLight {
    c_const: [f32; 3],
    k_sun: [f32; 3],
    hg_num: f32,
    hg_base: f32,
    hg_g: f32,
    sun: [f32; 3],
}

impl HandLight {
    fn new(beta_s: [f32; 3], beta_t: [f32; 3]) -> HandLight {
        let mut c_const = [0.0; 3];
        let mut k_sun = [0.0; 3];
        for c in 0..3 {
            let r = beta_s[c] as f64 / beta_t[c] as f64;
            c_const[c] = (r * AMBIENT[c] as f64) as f32;
            k_sun[c] = (r * SUN_RAD[c] as f64) as f32;
        }
        let s = Vec3::from_array(SUN_DIR);
        let w = s.as_dvec3() / s.abs().max_element() as f64;
        let sun = (w / w.length()).as_vec3().to_array();
        let g = HG_G;
        assert!(g >= 0.0);
        HandLight {
            c_const,
            k_sun,
            hg_num: (1.0 - g) * (1.0 + g) / (4.0 * std::f32::consts::PI),
            hg_base: (1.0 - g) * (1.0 - g),
            hg_g: g,
            sun,
        }
    }
}

/// (b) packet by packet (see [`hand_rgb_y_unit_full`]).
fn hand_rgb_y_unit_full_per_packet(
    l: &HandLayer,
    li: &HandLight,
    r: &RaySet,
    out: &mut [Vec<f32>],
) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (dx, dy, dz) = (&r.d[0][..n], &r.d[1][..n], &r.d[2][..n]);
    let (oy, t) = (&r.o[1][..n], &r.t[..n]);
    let [t0, t1, t2, l0, l1, l2] = out else {
        unreachable!()
    };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let (l0, l1, l2) = (&mut l0[..n], &mut l1[..n], &mut l2[..n]);
    let mut i = 0;
    while i + 8 <= n {
        let y = load(oy, i);
        let v = [load(dx, i), load(dy, i), load(dz, i)];
        let tt = load(t, i);
        let y_s = y * sp(TWO_M64);
        let u = v[1];
        let (u_m, u_e, t_m, t_e) = split_ray(u, None, tt);
        let guard = nan_guard(u, y_s, tt);
        let (gm, ge) = depth(l, None, y_s, u_m, u_e, t_m, t_e, guard);
        // τ per channel from one pair of scale factors.
        let (s1, s2) = pow2_pair(ge + sp(l.s_e));
        let g1 = gm * s1;
        let tr = [0, 1, 2].map(|c| exp_neg(g1 * sp(l.s_m[c]) * s2));
        // Henyey–Greenstein: (1 + g² − 2g cos θ) as (1 − g)² + g·|v − s|².
        let w0 = v[0] - sp(li.sun[0]);
        let w1 = v[1] - sp(li.sun[1]);
        let w2 = v[2] - sp(li.sun[2]);
        let w = w0.mul_add(w0, w1.mul_add(w1, w2 * w2));
        let q = w.mul_add(sp(li.hg_g), sp(li.hg_base));
        let p = sp(li.hg_num) / (q * q.sqrt());
        let ins =
            [0, 1, 2].map(|c| p.mul_add(sp(li.k_sun[c]), sp(li.c_const[c])) * (sp(1.0) - tr[c]));
        store(tr[0], t0, i);
        store(tr[1], t1, i);
        store(tr[2], t2, i);
        store(ins[0], l0, i);
        store(ins[1], l1, i);
        store(ins[2], l2, i);
        i += 8;
    }
}

/// (c) packet by packet (see [`hand_grey_general_t`]).
fn hand_grey_general_t_per_packet(l: &HandLayer, up: [f32; 3], r: &RaySet, tr: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (ox, oy, oz) = (&r.o[0][..n], &r.o[1][..n], &r.o[2][..n]);
    let (dx, dy, dz) = (&r.d[0][..n], &r.d[1][..n], &r.d[2][..n]);
    let t = &r.t[..n];
    let [t0, t1, t2] = tr else { unreachable!() };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let up_s = up.map(|c| c * TWO_M64);
    let dot = |v: [f32x8; 3], s: [f32; 3]| {
        v[0].mul_add(sp(s[0]), v[1].mul_add(sp(s[1]), v[2] * sp(s[2])))
    };
    let mut i = 0;
    while i + 8 <= n {
        let o = [load(ox, i), load(oy, i), load(oz, i)];
        let d = [load(dx, i), load(dy, i), load(dz, i)];
        let tt = load(t, i);
        // |d| = n_m · 2^n_e and the unit direction, without overflow or underflow.
        let mx = d[0].abs().fast_max(d[1].abs()).fast_max(d[2].abs());
        let f = clamp(mx.exponent_field(), 1.0, 253.0);
        let scale = f32x8::pow2i(sp(127.0) - f);
        let s = d.map(|c| c * scale);
        let n_m = s[0].mul_add(s[0], s[1].mul_add(s[1], s[2] * s[2])).sqrt();
        let n_e = f - sp(127.0);
        let inv = sp(1.0) / n_m.fast_max(sp(1e-30));
        let dir = s.map(|c| c * inv);
        let u = dot(dir, up) * n_m;
        let y_s = dot(o, up_s);
        let (u_m, u_e, t_m, t_e) = split_ray(u, Some(n_e), tt);
        #[allow(clippy::eq_op)] // NaN where |d| is not finite
        let guard = nan_guard(u, y_s, tt) + (n_m - n_m);
        let (gm, ge) = depth(l, Some((n_m, n_e)), y_s, u_m, u_e, t_m, t_e, guard);
        let tau = ldexp(gm * sp(l.s_m[0]), ge + sp(l.s_e));
        let tr = exp_neg(tau);
        store(tr, t0, i);
        store(tr, t1, i);
        store(tr, t2, i);
        i += 8;
    }
}

// ---------------------------------------------------------------------------------------
// Staged hand kernels: the same arithmetic as the per-packet ones above, over blocks of
// `BLOCK` packets, one loop per stage, like the library's batch loop (`run_single` in
// `src/kernel.rs`): A loads and exponent arithmetic, B φ, C e^(−u_min) and G, D τ, E T
// (one loop per channel), F the colour. The intermediate results of a block live in
// fixed-size arrays on the stack; each stage's loop needs only its own constants. The
// loops zip the block's slices (in 8-float chunks) with the arrays cut to the block, so
// that no load, store or array access needs a bounds check.

/// Packets per block (as the library's `BLOCK`).
const BLOCK: usize = 16;

/// The packets of a block slice (a multiple of 8 floats), loaded.
#[inline(always)]
fn packets(s: &[f32]) -> impl Iterator<Item = f32x8> + '_ {
    s.chunks_exact(8).map(<f32x8 as Lane>::load)
}

/// The packets of a block slice of an output.
#[inline(always)]
fn slots(s: &mut [f32]) -> std::slice::ChunksExactMut<'_, f32> {
    s.chunks_exact_mut(8)
}

/// Stores one packet into its 8-float slot.
#[inline(always)]
fn put(v: f32x8, slot: &mut [f32]) {
    slot.copy_from_slice(&v.to_array());
}

/// Stage A of the staged kernels for up +Y and unit directions: loads (oy, dy, t) and the
/// exponent arithmetic, one `HandArgs` per packet of the block.
#[inline(always)]
fn stage_a_y_unit(l: &HandLayer, oy: &[f32], dy: &[f32], t: &[f32], args: &mut [HandArgs]) {
    for (a, ((y, u), tt)) in args
        .iter_mut()
        .zip(packets(oy).zip(packets(dy)).zip(packets(t)))
    {
        let y_s = y * sp(TWO_M64);
        let (u_m, u_e, t_m, t_e) = split_ray(u, None, tt);
        let guard = nan_guard(u, y_s, tt);
        *a = depth_args(l, None, y_s, u_m, u_e, t_m, t_e, guard);
    }
}

/// Stages B and C of the staged kernels: φ, then e^(−u_min) and G.
#[inline(always)]
fn stages_b_c(args: &[HandArgs], phis: &mut [f32x8], g: &mut [(f32x8, f32x8)]) {
    // B: φ.
    for (phi, a) in phis.iter_mut().zip(args.iter()) {
        *phi = exprel_neg(a.dc);
    }
    // C: e^(−u_min) and G.
    for (gk, (a, &phi)) in g.iter_mut().zip(args.iter().zip(phis.iter())) {
        *gk = depth_with(a, phi);
    }
}

/// Stage D of the RGB kernels: τ per channel from one pair of scale factors.
#[inline(always)]
fn stage_d_rgb(l: &HandLayer, g: &[(f32x8, f32x8)], [tau0, tau1, tau2]: [&mut [f32x8]; 3]) {
    let taus_k = tau0.iter_mut().zip(tau1.iter_mut()).zip(tau2.iter_mut());
    for (((x0, x1), x2), &(gm, ge)) in taus_k.zip(g.iter()) {
        let (s1, s2) = pow2_pair(ge + sp(l.s_e));
        let g1 = gm * s1;
        *x0 = g1 * sp(l.s_m[0]) * s2;
        *x1 = g1 * sp(l.s_m[1]) * s2;
        *x2 = g1 * sp(l.s_m[2]) * s2;
    }
}

/// Stages B to E of the staged grey kernels over one block: φ, e^(−u_min) and G, τ, and
/// T stored to the three channels' slots of the block.
#[inline(always)]
fn grey_stages_b_to_e(
    l: &HandLayer,
    args: &[HandArgs],
    phis: &mut [f32x8],
    g: &mut [(f32x8, f32x8)],
    taus: &mut [f32x8],
    [t0, t1, t2]: [&mut [f32]; 3],
) {
    stages_b_c(args, phis, g);
    // D: τ.
    for (tau, &(gm, ge)) in taus.iter_mut().zip(g.iter()) {
        *tau = ldexp(gm * sp(l.s_m[0]), ge + sp(l.s_e));
    }
    // E: T, stored to the three channels.
    for (&tau, ((s0, s1), s2)) in taus.iter().zip(slots(t0).zip(slots(t1)).zip(slots(t2))) {
        let tr = exp_neg(tau);
        put(tr, s0);
        put(tr, s1);
        put(tr, s2);
    }
}

/// (a) grey, one layer, up +Y, unit directions, T only (RGB transmittance written).
fn hand_grey_y_unit_t(l: &HandLayer, r: &RaySet, tr: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (oy, dy, t) = (&r.o[1][..n], &r.d[1][..n], &r.t[..n]);
    let [t0, t1, t2] = tr else { unreachable!() };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let z = f32x8::ZERO;
    let mut args = [HandArgs::ZERO; BLOCK];
    let mut phis = [z; BLOCK];
    let mut g = [(z, z); BLOCK];
    let mut taus = [z; BLOCK];
    let mut i = 0;
    while i < n {
        let m = ((n - i) / 8).min(BLOCK);
        let w = m * 8;
        // The block's slices and arrays.
        let (oy, dy, t) = (&oy[i..i + w], &dy[i..i + w], &t[i..i + w]);
        let (t0, t1, t2) = (&mut t0[i..i + w], &mut t1[i..i + w], &mut t2[i..i + w]);
        let (args, phis, g, taus) = (&mut args[..m], &mut phis[..m], &mut g[..m], &mut taus[..m]);
        stage_a_y_unit(l, oy, dy, t, args);
        grey_stages_b_to_e(l, args, phis, g, taus, [t0, t1, t2]);
        i += w;
    }
}

/// (d) and (e): RGB, one layer, up +Y, unit directions; `TRANS`: T only (d), else τ only
/// (e). τ per channel from one pair of scale factors, as in (b).
fn hand_rgb_y_unit<const TRANS: bool>(l: &HandLayer, r: &RaySet, out: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (oy, dy, t) = (&r.o[1][..n], &r.d[1][..n], &r.t[..n]);
    let [o0, o1, o2] = out else { unreachable!() };
    let (o0, o1, o2) = (&mut o0[..n], &mut o1[..n], &mut o2[..n]);
    let z = f32x8::ZERO;
    let mut args = [HandArgs::ZERO; BLOCK];
    let mut phis = [z; BLOCK];
    let mut g = [(z, z); BLOCK];
    let mut taus = [[z; BLOCK]; 3];
    let mut i = 0;
    while i < n {
        let m = ((n - i) / 8).min(BLOCK);
        let w = m * 8;
        // The block's slices and arrays.
        let (oy, dy, t) = (&oy[i..i + w], &dy[i..i + w], &t[i..i + w]);
        let ob = [&mut o0[i..i + w], &mut o1[i..i + w], &mut o2[i..i + w]];
        let (args, phis, g) = (&mut args[..m], &mut phis[..m], &mut g[..m]);
        let [tau0, tau1, tau2] = &mut taus;
        let (tau0, tau1, tau2) = (&mut tau0[..m], &mut tau1[..m], &mut tau2[..m]);
        stage_a_y_unit(l, oy, dy, t, args);
        stages_b_c(args, phis, g);
        if TRANS {
            stage_d_rgb(l, g, [&mut *tau0, &mut *tau1, &mut *tau2]);
            // E: T, one channel at a time.
            for (dst, tau) in ob.into_iter().zip([&*tau0, &*tau1, &*tau2]) {
                for (slot, &x) in slots(dst).zip(tau.iter()) {
                    put(exp_neg(x), slot);
                }
            }
        } else {
            // D: τ per channel, stored.
            let [s0, s1, s2] = ob;
            let outs = slots(s0).zip(slots(s1)).zip(slots(s2));
            for (((d0, d1), d2), &(gm, ge)) in outs.zip(g.iter()) {
                let (p1, p2) = pow2_pair(ge + sp(l.s_e));
                let g1 = gm * p1;
                put(g1 * sp(l.s_m[0]) * p2, d0);
                put(g1 * sp(l.s_m[1]) * p2, d1);
                put(g1 * sp(l.s_m[2]) * p2, d2);
            }
        }
        i += w;
    }
}

/// (b) RGB, one layer, up +Y, unit directions, T and L_in with a Henyey–Greenstein sun
/// (g ≥ 0) and ambient light.
fn hand_rgb_y_unit_full(l: &HandLayer, li: &HandLight, r: &RaySet, out: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (dx, dy, dz) = (&r.d[0][..n], &r.d[1][..n], &r.d[2][..n]);
    let (oy, t) = (&r.o[1][..n], &r.t[..n]);
    let [t0, t1, t2, l0, l1, l2] = out else {
        unreachable!()
    };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let (l0, l1, l2) = (&mut l0[..n], &mut l1[..n], &mut l2[..n]);
    let z = f32x8::ZERO;
    let mut args = [HandArgs::ZERO; BLOCK];
    let mut phis = [z; BLOCK];
    let mut g = [(z, z); BLOCK];
    // Channel-major: stage E runs over one channel at a time.
    let mut taus = [[z; BLOCK]; 3];
    let mut trs = [[z; BLOCK]; 3];
    let mut i = 0;
    while i < n {
        let m = ((n - i) / 8).min(BLOCK);
        let w = m * 8;
        // The block's slices and arrays.
        let (dx, dy, dz) = (&dx[i..i + w], &dy[i..i + w], &dz[i..i + w]);
        let (oy, t) = (&oy[i..i + w], &t[i..i + w]);
        let tb = [&mut t0[i..i + w], &mut t1[i..i + w], &mut t2[i..i + w]];
        let (l0, l1, l2) = (&mut l0[i..i + w], &mut l1[i..i + w], &mut l2[i..i + w]);
        let (args, phis, g) = (&mut args[..m], &mut phis[..m], &mut g[..m]);
        let [tau0, tau1, tau2] = &mut taus;
        let (tau0, tau1, tau2) = (&mut tau0[..m], &mut tau1[..m], &mut tau2[..m]);
        let [tr0, tr1, tr2] = &mut trs;
        let (tr0, tr1, tr2) = (&mut tr0[..m], &mut tr1[..m], &mut tr2[..m]);
        stage_a_y_unit(l, oy, dy, t, args);
        stages_b_c(args, phis, g);
        stage_d_rgb(l, g, [&mut *tau0, &mut *tau1, &mut *tau2]);
        // E: T, one channel at a time.
        for (dst, (tau, tr)) in tb.into_iter().zip([
            (&*tau0, &mut *tr0),
            (&*tau1, &mut *tr1),
            (&*tau2, &mut *tr2),
        ]) {
            for (slot, (&x, trk)) in slots(dst).zip(tau.iter().zip(tr.iter_mut())) {
                *trk = exp_neg(x);
                put(*trk, slot);
            }
        }
        // F: Henyey–Greenstein: (1 + g² − 2g cos θ) as (1 − g)² + g·|v − s|², and L_in.
        let dirs = packets(dx).zip(packets(dy)).zip(packets(dz));
        let trk = tr0.iter().zip(tr1.iter()).zip(tr2.iter());
        let outs = slots(l0).zip(slots(l1)).zip(slots(l2));
        for (((v0, v1), v2), (((&r0, &r1), &r2), ((s0, s1), s2))) in dirs.zip(trk.zip(outs)) {
            let w0 = v0 - sp(li.sun[0]);
            let w1 = v1 - sp(li.sun[1]);
            let w2 = v2 - sp(li.sun[2]);
            let w = w0.mul_add(w0, w1.mul_add(w1, w2 * w2));
            let q = w.mul_add(sp(li.hg_g), sp(li.hg_base));
            let p = sp(li.hg_num) / (q * q.sqrt());
            let ins = |c: usize, tr: f32x8| {
                p.mul_add(sp(li.k_sun[c]), sp(li.c_const[c])) * (sp(1.0) - tr)
            };
            put(ins(0, r0), s0);
            put(ins(1, r1), s1);
            put(ins(2, r2), s2);
        }
        i += w;
    }
}

/// (c) grey, one layer, a general up vector (unit, f32), directions of any length, T only.
fn hand_grey_general_t(l: &HandLayer, up: [f32; 3], r: &RaySet, tr: &mut [Vec<f32>]) {
    let n = r.t.len();
    assert!(n.is_multiple_of(8));
    let (ox, oy, oz) = (&r.o[0][..n], &r.o[1][..n], &r.o[2][..n]);
    let (dx, dy, dz) = (&r.d[0][..n], &r.d[1][..n], &r.d[2][..n]);
    let t = &r.t[..n];
    let [t0, t1, t2] = tr else { unreachable!() };
    let (t0, t1, t2) = (&mut t0[..n], &mut t1[..n], &mut t2[..n]);
    let up_s = up.map(|c| c * TWO_M64);
    let dot = |v: [f32x8; 3], s: [f32; 3]| {
        v[0].mul_add(sp(s[0]), v[1].mul_add(sp(s[1]), v[2] * sp(s[2])))
    };
    let z = f32x8::ZERO;
    let mut args = [HandArgs::ZERO; BLOCK];
    let mut phis = [z; BLOCK];
    let mut g = [(z, z); BLOCK];
    let mut taus = [z; BLOCK];
    let mut i = 0;
    while i < n {
        let m = ((n - i) / 8).min(BLOCK);
        let w = m * 8;
        // The block's slices and arrays.
        let (ox, oy, oz) = (&ox[i..i + w], &oy[i..i + w], &oz[i..i + w]);
        let (dx, dy, dz) = (&dx[i..i + w], &dy[i..i + w], &dz[i..i + w]);
        let t = &t[i..i + w];
        let (t0, t1, t2) = (&mut t0[i..i + w], &mut t1[i..i + w], &mut t2[i..i + w]);
        let (args, phis, g, taus) = (&mut args[..m], &mut phis[..m], &mut g[..m], &mut taus[..m]);
        // A: loads, |d| and the exponent arithmetic.
        let os = packets(ox).zip(packets(oy)).zip(packets(oz));
        let ds = packets(dx).zip(packets(dy)).zip(packets(dz));
        for (a, ((((o0, o1), o2), ((d0, d1), d2)), tt)) in
            args.iter_mut().zip(os.zip(ds).zip(packets(t)))
        {
            let (o, d) = ([o0, o1, o2], [d0, d1, d2]);
            // |d| = n_m · 2^n_e and the unit direction, without overflow or underflow.
            let mx = d[0].abs().fast_max(d[1].abs()).fast_max(d[2].abs());
            let f = clamp(mx.exponent_field(), 1.0, 253.0);
            let scale = f32x8::pow2i(sp(127.0) - f);
            let s = d.map(|c| c * scale);
            let n_m = s[0].mul_add(s[0], s[1].mul_add(s[1], s[2] * s[2])).sqrt();
            let n_e = f - sp(127.0);
            let inv = sp(1.0) / n_m.fast_max(sp(1e-30));
            let dir = s.map(|c| c * inv);
            let u = dot(dir, up) * n_m;
            let y_s = dot(o, up_s);
            let (u_m, u_e, t_m, t_e) = split_ray(u, Some(n_e), tt);
            #[allow(clippy::eq_op)] // NaN where |d| is not finite
            let guard = nan_guard(u, y_s, tt) + (n_m - n_m);
            *a = depth_args(l, Some((n_m, n_e)), y_s, u_m, u_e, t_m, t_e, guard);
        }
        grey_stages_b_to_e(l, args, phis, g, taus, [t0, t1, t2]);
        i += w;
    }
}

/// Asserts that `got` agrees with `want` within 4 ULP relative (plus an absolute 1e-37 for
/// values flushed near the bottom of the range).
fn assert_close(what: &str, got: &[f32], want: &[f32]) {
    let mut worst = 0.0f64;
    for (i, (&g, &w)) in got.iter().zip(want).enumerate() {
        let diff = (g as f64 - w as f64).abs();
        let allowed = 4.0 * f32::EPSILON as f64 * (w as f64).abs() + 1e-37;
        assert!(
            diff <= allowed,
            "{what}: ray {i}: hand {g:e}, plan {w:e} (diff {diff:e} > {allowed:e})"
        );
        if w != 0.0 {
            worst = worst.max(diff / (w as f64).abs());
        }
    }
    eprintln!(
        "{what}: agrees with Scene::evaluate, largest relative difference {:.2} ULP",
        worst / f32::EPSILON as f64
    );
}

// ---------------------------------------------------------------------------------------
// Benches

fn cases() -> Vec<Case> {
    let b = Case::BASE;
    vec![
        Case { name: "rgb_T", ..b },
        Case {
            name: "grey_T",
            grey: true,
            ..b
        },
        Case {
            name: "rgb_tau",
            tau: true,
            trans: false,
            ..b
        },
        Case {
            name: "rgb_full_dark",
            insc: true,
            ..b
        },
        Case {
            name: "rgb_full_amb",
            insc: true,
            ambient: true,
            ..b
        },
        Case {
            name: "rgb_full_sun",
            insc: true,
            sun: true,
            ..b
        },
        Case {
            name: "rgb_full_sun_amb",
            insc: true,
            sun: true,
            ambient: true,
            ..b
        },
        Case {
            name: "grey_full_sun_amb",
            grey: true,
            insc: true,
            sun: true,
            ambient: true,
            ..b
        },
        Case {
            name: "rgb_T_up_general",
            general_up: true,
            ..b
        },
        Case {
            name: "rgb_T_nonunit",
            unit: false,
            ..b
        },
        Case {
            name: "grey_T_up_general_nonunit",
            grey: true,
            general_up: true,
            unit: false,
            ..b
        },
    ]
}

fn plan_vs_general(c: &mut Criterion) {
    let unit = make_rays(N, false);
    let scaled = make_rays(N, true);
    let mut g = c.benchmark_group("plan_vs_general");
    g.throughput(Throughput::Elements(N as u64));
    let mut o = Out::new(N);
    for case in cases() {
        let sc = scene(&case);
        let r = if case.unit { &unit } else { &scaled };
        g.bench_function(format!("plan/{}", case.name), |b| {
            b.iter(|| sc.evaluate(&black_box(r).rays(), o.case(&case)).unwrap())
        });
        g.bench_function(format!("general/{}", case.name), |b| {
            b.iter(|| {
                sc.evaluate_unspecialized(&black_box(r).rays(), o.case(&case))
                    .unwrap()
            })
        });
    }
    g.finish();
}

fn plan_vs_hand(c: &mut Criterion) {
    let unit = make_rays(N, false);
    let scaled = make_rays(N, true);
    let mut g = c.benchmark_group("plan_vs_hand");
    g.throughput(Throughput::Elements(N as u64));
    let mut o = Out::new(N);
    let mut h = Out::new(N);

    // (a) grey, +Y, unit, T only.
    {
        let case = Case {
            name: "grey_y_unit_T",
            grey: true,
            ..Case::BASE
        };
        let sc = scene(&case);
        let l = HandLayer::new(B, H0, GREY, 1.0);
        sc.evaluate(&unit.rays(), o.case(&case)).unwrap();
        hand_grey_y_unit_t(&l, &unit, &mut h.v[3..6]);
        for ch in 0..3 {
            assert_close("hand/grey_y_unit_T T", &h.v[3 + ch], &o.v[3 + ch]);
        }
        hand_grey_y_unit_t_per_packet(&l, &unit, &mut h.v[3..6]);
        for ch in 0..3 {
            assert_close(
                "hand_per_packet/grey_y_unit_T T",
                &h.v[3 + ch],
                &o.v[3 + ch],
            );
        }
        g.bench_function("plan/grey_y_unit_T", |b| {
            b.iter(|| {
                sc.evaluate(&black_box(&unit).rays(), o.case(&case))
                    .unwrap()
            })
        });
        g.bench_function("hand/grey_y_unit_T", |b| {
            b.iter(|| hand_grey_y_unit_t(black_box(&l), black_box(&unit), &mut h.v[3..6]))
        });
        g.bench_function("hand_per_packet/grey_y_unit_T", |b| {
            b.iter(|| {
                hand_grey_y_unit_t_per_packet(black_box(&l), black_box(&unit), &mut h.v[3..6])
            })
        });
    }

    // (b) RGB, +Y, unit, T and L_in, Henyey–Greenstein sun and ambient.
    {
        let case = Case {
            name: "rgb_y_unit_full_sun_amb",
            insc: true,
            sun: true,
            ambient: true,
            ..Case::BASE
        };
        let sc = scene(&case);
        let l = HandLayer::new(B, H0, RGB, 1.0);
        let li = HandLight::new(RGB, RGB);
        sc.evaluate(&unit.rays(), o.case(&case)).unwrap();
        hand_rgb_y_unit_full(&l, &li, &unit, &mut h.v[3..9]);
        for ch in 0..3 {
            assert_close("hand/rgb_y_unit_full_sun_amb T", &h.v[3 + ch], &o.v[3 + ch]);
            assert_close(
                "hand/rgb_y_unit_full_sun_amb L_in",
                &h.v[6 + ch],
                &o.v[6 + ch],
            );
        }
        hand_rgb_y_unit_full_per_packet(&l, &li, &unit, &mut h.v[3..9]);
        for ch in 0..3 {
            assert_close(
                "hand_per_packet/rgb_y_unit_full_sun_amb T",
                &h.v[3 + ch],
                &o.v[3 + ch],
            );
            assert_close(
                "hand_per_packet/rgb_y_unit_full_sun_amb L_in",
                &h.v[6 + ch],
                &o.v[6 + ch],
            );
        }
        g.bench_function("plan/rgb_y_unit_full_sun_amb", |b| {
            b.iter(|| {
                sc.evaluate(&black_box(&unit).rays(), o.case(&case))
                    .unwrap()
            })
        });
        g.bench_function("hand/rgb_y_unit_full_sun_amb", |b| {
            b.iter(|| {
                hand_rgb_y_unit_full(
                    black_box(&l),
                    black_box(&li),
                    black_box(&unit),
                    &mut h.v[3..9],
                )
            })
        });
        g.bench_function("hand_per_packet/rgb_y_unit_full_sun_amb", |b| {
            b.iter(|| {
                hand_rgb_y_unit_full_per_packet(
                    black_box(&l),
                    black_box(&li),
                    black_box(&unit),
                    &mut h.v[3..9],
                )
            })
        });
    }

    // (d) RGB, +Y, unit, T only; (e) the same, τ only.
    for (name, trans, at) in [("rgb_y_unit_T", true, 3), ("rgb_y_unit_tau", false, 0)] {
        let case = Case {
            name,
            tau: !trans,
            trans,
            ..Case::BASE
        };
        let sc = scene(&case);
        let l = HandLayer::new(B, H0, RGB, 1.0);
        sc.evaluate(&unit.rays(), o.case(&case)).unwrap();
        let hand = |l: &HandLayer, r: &RaySet, out: &mut [Vec<f32>]| {
            if trans {
                hand_rgb_y_unit::<true>(l, r, out)
            } else {
                hand_rgb_y_unit::<false>(l, r, out)
            }
        };
        hand(&l, &unit, &mut h.v[at..at + 3]);
        for ch in 0..3 {
            assert_close(&format!("hand/{name}"), &h.v[at + ch], &o.v[at + ch]);
        }
        g.bench_function(format!("plan/{name}"), |b| {
            b.iter(|| {
                sc.evaluate(&black_box(&unit).rays(), o.case(&case))
                    .unwrap()
            })
        });
        g.bench_function(format!("hand/{name}"), |b| {
            b.iter(|| hand(black_box(&l), black_box(&unit), &mut h.v[at..at + 3]))
        });
    }

    // (c) grey, general up, non-unit directions, T only.
    {
        let case = Case {
            name: "grey_up_general_nonunit_T",
            grey: true,
            general_up: true,
            unit: false,
            ..Case::BASE
        };
        let sc = scene(&case);
        let up = sc.up().to_array();
        let l = HandLayer::new(B, H0, GREY, 1.0);
        sc.evaluate(&scaled.rays(), o.case(&case)).unwrap();
        hand_grey_general_t(&l, up, &scaled, &mut h.v[3..6]);
        for ch in 0..3 {
            assert_close(
                "hand/grey_up_general_nonunit_T T",
                &h.v[3 + ch],
                &o.v[3 + ch],
            );
        }
        hand_grey_general_t_per_packet(&l, up, &scaled, &mut h.v[3..6]);
        for ch in 0..3 {
            assert_close(
                "hand_per_packet/grey_up_general_nonunit_T T",
                &h.v[3 + ch],
                &o.v[3 + ch],
            );
        }
        g.bench_function("plan/grey_up_general_nonunit_T", |b| {
            b.iter(|| {
                sc.evaluate(&black_box(&scaled).rays(), o.case(&case))
                    .unwrap()
            })
        });
        g.bench_function("hand/grey_up_general_nonunit_T", |b| {
            b.iter(|| {
                hand_grey_general_t(
                    black_box(&l),
                    black_box(up),
                    black_box(&scaled),
                    &mut h.v[3..6],
                )
            })
        });
        g.bench_function("hand_per_packet/grey_up_general_nonunit_T", |b| {
            b.iter(|| {
                hand_grey_general_t_per_packet(
                    black_box(&l),
                    black_box(up),
                    black_box(&scaled),
                    &mut h.v[3..6],
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, plan_vs_general, plan_vs_hand);
criterion_main!(benches);
