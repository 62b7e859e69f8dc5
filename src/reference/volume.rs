//! f64 reference for fog volumes: the textbook closed forms (antiderivatives evaluated at
//! the ends of the chord, seed 002), an adaptive Gauss–Kronrod quadrature that
//! cross-checks them and takes over where their subtraction cancels, seed 004's
//! `computeFog` and seed 002's f32 antiderivatives reproduced as written, the condition
//! number the f32 kernels are held to, and a ray-marched single-scattering reference for
//! the per-volume lighting model.
//!
//! Nothing here shares code with the f32 kernel (`medium::volume`): the kernel never
//! subtracts antiderivatives (it integrates pieces by positive-weight rules and forms
//! differences of asinh and erf without cancellation); this module does subtract them,
//! in f64, in the frame of the ray's closest approach, and checks how much it cancelled.
//!
//! Antiderivatives, with h the distance of closest approach in the unit space,
//! w² = 1 − h², r = √(h² + u²), J(u) = ½(u·r + h²·asinh(u/h)) (= ½·u·|u| for h = 0):
//!
//! ```text
//! constant   u
//! linear     u − J(u)
//! quadratic  w²·u − u³/3
//! quartic    w⁴·u − ⅔·w²·u³ + u⁵/5
//! spiky      (1 + h²)·u + u³/3 − 2·J(u)
//! gaussian   e^(−8h²) · √π/(2√8) · erf(√8·u)
//! ```
//!
//! and the world length is `du · |d| / |M⁻¹ d|`.

// `!(a > b)` is deliberate here: it is true for NaN as well.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::light::Phase;
use crate::medium::volume::{Affine, Kind, Profile, Shape, Volume};
use crate::scene::{Lighting, SceneDesc};
use glam::{DMat3, DVec3, Quat, Vec3};

const SQRT8: f64 = 2.828_427_124_746_190_1;
const GAUSS_NORM: f64 = 0.313_328_534_328_875_03; // √π / (2√8)

// ---------------------------------------------------------------------------------------
// f64 erf / erfc (no dependency): a series with positive terms and a continued fraction.

/// erf(x) for |x| < 3 by `erf(x) = 2/√π · e^(−x²) · Σ 2^n x^(2n+1) / (1·3···(2n+1))`
/// (positive terms: relative error a few f64 ulps); erfc's continued fraction beyond.
pub fn erf(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    let a = x.abs();
    if a >= 3.0 {
        return (1.0 - erfc(a)).copysign(x);
    }
    let x2 = a * a;
    let mut term = a;
    let mut sum = a;
    let mut n = 0.0;
    while term > sum * 1e-18 {
        n += 1.0;
        term *= 2.0 * x2 / (2.0 * n + 1.0);
        sum += term;
    }
    (2.0 / core::f64::consts::PI.sqrt() * (-x2).exp() * sum).copysign(x)
}

/// erfc(x): `1 − erf(x)` below 0.5, Lentz's continued fraction
/// `erfc(x) = e^(−x²)/√π · 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + …))))` at and above 3, and
/// between them the series erf subtracted from 1 (at most 2 bits lost: erfc(3) = 2.2e-5
/// loses 15 bits; the continued fraction is used from 2 on, where it converges in < 200
/// terms).
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x < 2.0 {
        return 1.0 - erf(x);
    }
    // Modified Lentz for the continued fraction K = x + (1/2)/(x + (2/2)/(x + ...)).
    let tiny = 1e-300;
    let mut f = x;
    let mut c = x;
    let mut d = 0.0;
    for k in 1..5000 {
        let ak = k as f64 * 0.5;
        d = x + ak * d;
        if d.abs() < tiny {
            d = tiny;
        }
        c = x + ak / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() < 1e-17 {
            break;
        }
    }
    (-x * x).exp() / core::f64::consts::PI.sqrt() / f
}

/// erf(b) − erf(a) without cancelling the tails.
fn erf_diff(a: f64, b: f64) -> f64 {
    if a >= 0.0 {
        erfc(a) - erfc(b)
    } else if b <= 0.0 {
        erfc(-b) - erfc(-a)
    } else {
        erf(b) - erf(a)
    }
}

// ---------------------------------------------------------------------------------------
// Geometry

/// A validated shape in f64, or `None` (the shape fails `Scene::new`'s checks).
pub fn affine(shape: &Shape) -> Option<AffineRef> {
    Affine::of(shape, &|s: &str| s.to_string())
        .ok()
        .map(AffineRef)
}

/// A shape as an affine map of the unit ball or cube, in f64.
#[derive(Clone, Copy, Debug)]
pub struct AffineRef(pub(crate) Affine);

/// The ray `o + s·d` in the unit space of a shape: `q + s·e`.
fn unit_ray(aff: &Affine, o: DVec3, d: DVec3) -> (DVec3, DVec3) {
    let inv: DMat3 = aff.m.inverse();
    (inv * (o - aff.center), inv * d)
}

/// The parameter interval (in s) where the line o + s·d is inside the shape, unclipped.
fn line_interval(aff: &Affine, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (q, e) = unit_ray(aff, o, d);
    match aff.kind {
        Kind::Ball => {
            let a2 = e.length_squared();
            if a2 == 0.0 {
                return (q.length_squared() <= 1.0).then_some((f64::NEG_INFINITY, f64::INFINITY));
            }
            let s0 = -q.dot(e) / a2;
            let h2 = (q + s0 * e).length_squared();
            if h2 >= 1.0 {
                return None;
            }
            let half = (1.0 - h2).sqrt() / a2.sqrt();
            Some((s0 - half, s0 + half))
        }
        Kind::Cube => {
            let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
            for i in 0..3 {
                if e[i] == 0.0 {
                    if q[i].abs() > 1.0 {
                        return None;
                    }
                } else {
                    let a = (-1.0 - q[i]) / e[i];
                    let b = (1.0 - q[i]) / e[i];
                    lo = lo.max(a.min(b));
                    hi = hi.min(a.max(b));
                }
            }
            (lo < hi).then_some((lo, hi))
        }
    }
}

/// ∫ profile over s in [s0, s1] (inside the shape), world length, closed form; also
/// returns the magnitude of the terms that were subtracted (for the cancellation check).
fn piece_closed(
    aff: &Affine,
    profile: Profile,
    o: DVec3,
    d: DVec3,
    s0: f64,
    s1: f64,
) -> (f64, f64) {
    if !(s1 > s0) {
        return (0.0, 0.0);
    }
    let (q, e) = unit_ray(aff, o, d);
    let dl = d.length();
    match aff.kind {
        Kind::Ball => {
            let a = e.length();
            let eh = e / a;
            let uo = q.dot(eh);
            let h2 = (q - uo * eh).length_squared().min(1.0);
            let w2 = 1.0 - h2;
            let h = h2.sqrt();
            let j = |u: f64| {
                let r = (h2 + u * u).sqrt();
                if h == 0.0 {
                    0.5 * u * u.abs()
                } else {
                    0.5 * (u * r + h2 * (u / h).asinh())
                }
            };
            let w = w2.sqrt();
            let ua = (uo + a * s0).clamp(-w, w);
            let ub = (uo + a * s1).clamp(-w, w);
            let f = |u: f64| match profile {
                Profile::Constant => u,
                Profile::Linear => u - j(u),
                Profile::Quadratic => w2 * u - u * u * u / 3.0,
                Profile::Quartic => w2 * w2 * u - 2.0 / 3.0 * w2 * u.powi(3) + u.powi(5) / 5.0,
                Profile::Spiky => (1.0 + h2) * u + u.powi(3) / 3.0 - 2.0 * j(u),
                Profile::Gaussian => 0.0,
            };
            let scale = dl / a;
            if profile == Profile::Gaussian {
                let v = (-8.0 * h2).exp() * GAUSS_NORM * erf_diff(SQRT8 * ua, SQRT8 * ub);
                return (v * scale, v.abs() * scale);
            }
            let (fa, fb) = (f(ua), f(ub));
            ((fb - fa) * scale, (fa.abs() + fb.abs()) * scale)
        }
        Kind::Cube => {
            let fade = aff.edge_fade;
            if fade == 0.0 {
                return ((s1 - s0) * dl, (s1 - s0) * dl);
            }
            let dens = |s: f64| {
                let x = q + s * e;
                (0..3)
                    .map(|i| ((1.0 - x[i].abs()) / fade).clamp(0.0, 1.0))
                    .product::<f64>()
            };
            let mut b = vec![s0, s1];
            for i in 0..3 {
                if e[i] != 0.0 {
                    for c in [-1.0, -1.0 + fade, 1.0 - fade, 1.0] {
                        let s = (c - q[i]) / e[i];
                        if s > s0 && s < s1 {
                            b.push(s);
                        }
                    }
                }
            }
            b.sort_by(|x, y| x.total_cmp(y));
            let mut acc = 0.0;
            for k in 0..b.len() - 1 {
                let (x, y) = (b[k], b[k + 1]);
                acc += (y - x) / 6.0 * (dens(x) + 4.0 * dens(0.5 * (x + y)) + dens(y));
            }
            (acc * dl, acc * dl)
        }
    }
}

/// The integrand (density profile) at s, world length per unit s included.
fn integrand(aff: &Affine, profile: Profile, q: DVec3, e: DVec3, dl: f64, s: f64) -> f64 {
    integrand_at(aff, profile, q + s * e, dl)
}

/// The density at the unit-space point x, times `dl`.
fn integrand_at(aff: &Affine, profile: Profile, x: DVec3, dl: f64) -> f64 {
    match aff.kind {
        Kind::Ball => profile.eval_f64(x.length()) * dl,
        Kind::Cube => {
            if aff.edge_fade == 0.0 {
                return if x.abs().max_element() <= 1.0 {
                    dl
                } else {
                    0.0
                };
            }
            (0..3)
                .map(|i| ((1.0 - x[i].abs()) / aff.edge_fade).clamp(0.0, 1.0))
                .product::<f64>()
                * dl
        }
    }
}

/// The density (profile, box fade) at the world point `x` (f64).
pub(crate) fn integrand_at_world(aff: &AffineRef, profile: Profile, x: DVec3) -> f64 {
    let p = aff.0.m.inverse() * (x - aff.0.center);
    integrand_at(&aff.0, profile, p, 1.0)
}

/// Whether the world point `x` lies inside the shape (a cut-out removes density there).
pub(crate) fn inside_world(aff: &AffineRef, x: DVec3) -> bool {
    let p = aff.0.m.inverse() * (x - aff.0.center);
    match aff.0.kind {
        Kind::Ball => p.length_squared() <= 1.0,
        Kind::Cube => p.abs().max_element() <= 1.0,
    }
}

/// The parameter interval (in s) where the line o + s·d is inside the shape, unclipped.
pub(crate) fn line_interval_of(aff: &AffineRef, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    line_interval(&aff.0, o, d)
}

/// Adaptive Gauss–Kronrod (7, 15) on [a, b] to a relative tolerance of 1e-14.
pub fn gauss_kronrod(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const XGK: [f64; 8] = [
        0.991_455_371_120_812_6,
        0.949_107_912_342_758_5,
        0.864_864_423_359_769_1,
        0.741_531_185_599_394_4,
        0.586_087_235_467_691_1,
        0.405_845_151_377_397_2,
        0.207_784_955_007_898_5,
        0.0,
    ];
    const WGK: [f64; 8] = [
        0.022_935_322_010_529_22,
        0.063_092_092_629_978_55,
        0.104_790_010_322_250_2,
        0.140_653_259_715_525_9,
        0.169_004_726_639_267_9,
        0.190_350_578_064_785_4,
        0.204_432_940_075_298_9,
        0.209_482_141_084_728_0,
    ];
    const WG: [f64; 4] = [
        0.129_484_966_168_869_7,
        0.279_705_391_489_276_7,
        0.381_830_050_505_118_9,
        0.417_959_183_673_469_4,
    ];
    fn rule(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> (f64, f64) {
        let c = 0.5 * (a + b);
        let h = 0.5 * (b - a);
        let fc = f(c);
        let mut k = WGK[7] * fc;
        let mut g = WG[3] * fc;
        for i in 0..7 {
            let (f1, f2) = (f(c - h * XGK[i]), f(c + h * XGK[i]));
            k += WGK[i] * (f1 + f2);
            if i % 2 == 1 {
                g += WG[i / 2] * (f1 + f2);
            }
        }
        (k * h, ((k - g) * h).abs())
    }
    fn rec(f: &dyn Fn(f64) -> f64, a: f64, b: f64, whole: f64, depth: u32) -> f64 {
        let (k, err) = rule(f, a, b);
        if depth == 0 || err <= 1e-14 * whole.abs().max(1e-300) || err == 0.0 {
            return k;
        }
        let m = 0.5 * (a + b);
        rec(f, a, m, whole, depth - 1) + rec(f, m, b, whole, depth - 1)
    }
    if !(b > a) {
        return 0.0;
    }
    let (est, _) = rule(f, a, b);
    let est = if est == 0.0 {
        // A rough estimate for the tolerance (the rule may miss a narrow bump).
        (0..64)
            .map(|i| f(a + (b - a) * (i as f64 + 0.5) / 64.0).abs())
            .sum::<f64>()
            * (b - a)
            / 64.0
    } else {
        est
    };
    rec(f, a, b, est, 16)
}

/// ∫ profile over s in [s0, s1] by quadrature, split where the integrand has a kink
/// (closest approach, box breakpoints).
fn piece_quad(aff: &Affine, profile: Profile, o: DVec3, d: DVec3, s0: f64, s1: f64) -> f64 {
    if !(s1 > s0) {
        return 0.0;
    }
    let (q, e) = unit_ray(aff, o, d);
    let dl = d.length();
    // In v = s − s_c about the closest approach, so that the integrand carries no
    // rounding noise from a far origin (x = q_c + v·e is O(1)).
    let e2 = e.length_squared();
    let sc = if e2 > 0.0 { -q.dot(e) / e2 } else { 0.0 };
    let qc = q + sc * e;
    let (v0, v1) = (s0 - sc, s1 - sc);
    let mut cuts = vec![v0, v1, 0.0];
    if aff.kind == Kind::Cube {
        for i in 0..3 {
            if e[i] != 0.0 {
                for c in [-1.0, -1.0 + aff.edge_fade, 1.0 - aff.edge_fade, 1.0] {
                    cuts.push((c - qc[i]) / e[i]);
                }
            }
        }
    }
    cuts.retain(|&v| v >= v0 && v <= v1);
    cuts.sort_by(|a, b| a.total_cmp(b));
    let f = |v: f64| integrand_at(aff, profile, qc + v * e, dl);
    cuts.windows(2).map(|w| gauss_kronrod(&f, w[0], w[1])).sum()
}

/// The pieces of [0, t] inside `aff` and outside every cut.
fn pieces(aff: &Affine, cuts: &[Affine], o: DVec3, d: DVec3, t: f64) -> Vec<(f64, f64)> {
    if d == DVec3::ZERO {
        return vec![]; // a zero-length segment, whatever t
    }
    let Some((a, b)) = line_interval(aff, o, d) else {
        return vec![];
    };
    let (a, b) = (a.max(0.0), b.min(t));
    if !(b > a) {
        return vec![];
    }
    let mut cs: Vec<(f64, f64)> = cuts.iter().filter_map(|c| line_interval(c, o, d)).collect();
    cs.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut out = vec![];
    let mut pos = a;
    for (ca, cb) in cs {
        if ca > pos {
            out.push((pos, ca.min(b)));
        }
        pos = pos.max(cb);
        if pos >= b {
            break;
        }
    }
    if b > pos {
        out.push((pos, b));
    }
    out.retain(|p| p.1 > p.0);
    out
}

/// How much the closed form may cancel before the quadrature takes over (relative).
const CANCEL_LIMIT: f64 = 1e4;

pub(crate) fn depth_aff(
    aff: &Affine,
    profile: Profile,
    cuts: &[Affine],
    o: DVec3,
    d: DVec3,
    t: f64,
) -> f64 {
    pieces(aff, cuts, o, d, t)
        .into_iter()
        .map(|(s0, s1)| {
            let (v, mag) = piece_closed(aff, profile, o, d, s0, s1);
            if mag > CANCEL_LIMIT * v.abs() {
                piece_quad(aff, profile, o, d, s0, s1)
            } else {
                v
            }
        })
        .sum()
}

/// `∫_0^t f(o + s·d) |d| ds` for one volume shape (no extinction factor), in closed form
/// (quadrature where the closed form cancels by more than 1e4). `t` may be +∞.
pub(crate) fn depth(aff: &Affine, profile: Profile, o: DVec3, d: DVec3, t: f64) -> f64 {
    depth_aff(aff, profile, &[], o, d, t)
}

/// The geometric optical depth (∫ profile · world length, no extinction factor) of a
/// volume shape along `o + s·d`, s in [0, t], minus the cut-outs, in f64. NaN for a shape
/// that `Scene::new` rejects.
pub fn volume_depth(
    shape: &Shape,
    profile: Profile,
    cuts: &[Shape],
    o: DVec3,
    d: DVec3,
    t: f64,
) -> f64 {
    let Some((a, cs)) = affines(shape, cuts) else {
        return f64::NAN;
    };
    depth_aff(&a, profile, &cs, o, d, t)
}

/// The maps of a shape and of its cut-outs, `None` if `Scene::new` would reject one.
fn affines(shape: &Shape, cuts: &[Shape]) -> Option<(Affine, Vec<Affine>)> {
    let a = affine(shape)?.0;
    let cs = cuts
        .iter()
        .map(|c| affine(c).map(|x| x.0))
        .collect::<Option<_>>()?;
    Some((a, cs))
}

/// The same integral by adaptive quadrature only (the cross-check of the closed forms).
pub fn volume_depth_quad(
    shape: &Shape,
    profile: Profile,
    cuts: &[Shape],
    o: DVec3,
    d: DVec3,
    t: f64,
) -> f64 {
    let Some((a, cs)) = affines(shape, cuts) else {
        return f64::NAN;
    };
    pieces(&a, &cs, o, d, t)
        .into_iter()
        .map(|(s0, s1)| piece_quad(&a, profile, o, d, s0, s1))
        .sum()
}

/// The closed forms alone, without the quadrature fallback (to measure where they
/// cancel).
pub fn volume_depth_closed(shape: &Shape, profile: Profile, o: DVec3, d: DVec3, t: f64) -> f64 {
    let Some(a) = affine(shape) else {
        return f64::NAN;
    };
    pieces(&a.0, &[], o, d, t)
        .into_iter()
        .map(|(s0, s1)| piece_closed(&a.0, profile, o, d, s0, s1).0)
        .sum()
}

// ---------------------------------------------------------------------------------------
// Condition number

/// The scalar inputs of a shape, in a fixed order, and the shape rebuilt from them.
pub fn shape_params(shape: &Shape) -> Vec<f32> {
    let q = |r: &Quat| r.to_array().to_vec();
    match shape {
        Shape::Sphere { center, radius } => [center.to_array().to_vec(), vec![*radius]].concat(),
        Shape::Ellipsoid {
            center,
            radii,
            rotation,
        } => [
            center.to_array().to_vec(),
            radii.to_array().to_vec(),
            q(rotation),
        ]
        .concat(),
        Shape::Affine { center, matrix } => [
            center.to_array().to_vec(),
            matrix.iter().flat_map(|c| c.to_array()).collect(),
        ]
        .concat(),
        Shape::Box {
            center,
            half_extents,
            rotation,
            edge_fade,
        } => [
            center.to_array().to_vec(),
            half_extents.to_array().to_vec(),
            q(rotation),
            vec![*edge_fade],
        ]
        .concat(),
    }
}

/// `shape` with its scalar inputs replaced by `p` (the order of [`shape_params`]).
pub fn with_params(shape: &Shape, p: &[f64]) -> Shape {
    let v = |i: usize| Vec3::new(p[i] as f32, p[i + 1] as f32, p[i + 2] as f32);
    let qt = |i: usize| {
        Quat::from_xyzw(
            p[i] as f32,
            p[i + 1] as f32,
            p[i + 2] as f32,
            p[i + 3] as f32,
        )
    };
    match shape {
        Shape::Sphere { .. } => Shape::Sphere {
            center: v(0),
            radius: p[3] as f32,
        },
        Shape::Ellipsoid { .. } => Shape::Ellipsoid {
            center: v(0),
            radii: v(3),
            rotation: qt(6),
        },
        Shape::Affine { .. } => Shape::Affine {
            center: v(0),
            matrix: [v(3), v(6), v(9)],
        },
        Shape::Box { .. } => Shape::Box {
            center: v(0),
            half_extents: v(3),
            rotation: qt(6),
            edge_fade: p[10] as f32,
        },
    }
}

/// The absolute condition K of the geometric optical depth I with respect to
/// perturbations of every input at the scale of one f32 rounding:
///
/// ```text
/// K = Σ_i max_{±, m ∈ {1, 4, 16}} |I(x_i ± m·δ·s_i) − I(x)| / (m·δ),   δ = 2^-24
/// ```
///
/// over the ray's origin, direction and t, and every shape's and cut-out's parameters
/// (see [`shape_params`]), with `s_i` the norm of the vector the input belongs to
/// (origin, direction, a centre, a quaternion, a matrix column: rounding a vector
/// computation errs relative to its length, whatever the frame) or |x_i| for a scalar
/// (t, a radius, an edge fade). Secants rather than derivatives, over 1, 4 and 16
/// roundings (the kernel rounds a far camera's distance several times): near tangency I has a square-root singularity, and where I is flat but
/// about to change (a segment ending just before the volume) the change counts. Inputs are
/// perturbed in f64 and shapes rebuilt in f64. The relative condition number is
/// κ = 1 + K/|I|; the kernels are held to `|I_f32 − I| ≤ c · 2^-24 · (|I| + K)`.
pub fn depth_condition(
    shape: &Shape,
    profile: Profile,
    cuts: &[Shape],
    o: Vec3,
    d: Vec3,
    t: f32,
) -> f64 {
    let delta = 2f64.powi(-24);
    // Inputs: o, d, t, then every shape's parameters.
    let mut x: Vec<f64> = [o.to_array(), d.to_array()]
        .concat()
        .iter()
        .map(|&v| v as f64)
        .collect();
    x.push(t as f64);
    // Perturbation scales: vectors normwise (o, d, centres, quaternions, matrix columns:
    // each component moved by δ·|vector|, as rounding a vector computation relative to
    // its length does), scalars relative to themselves.
    let norm3 = |v: &[f64]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let mut scale = vec![norm3(&x[0..3]); 3];
    scale.extend([norm3(&x[3..6]); 3]);
    scale.push((t as f64).abs());
    let mut spans = vec![];
    for s in std::iter::once(shape).chain(cuts.iter()) {
        let p: Vec<f64> = shape_params(s).iter().map(|&v| v as f64).collect();
        spans.push((x.len(), p.len()));
        let c = norm3(&p[0..3]);
        let q4 = |i: usize| (p[i..i + 4].iter().map(|v| v * v).sum::<f64>()).sqrt();
        let sc: Vec<f64> = match s {
            Shape::Sphere { .. } => vec![c, c, c, p[3].abs()],
            Shape::Ellipsoid { .. } => [
                vec![c; 3],
                p[3..6].iter().map(|v| v.abs()).collect(),
                vec![q4(6); 4],
            ]
            .concat(),
            Shape::Affine { .. } => [
                vec![c; 3],
                vec![norm3(&p[3..6]); 3],
                vec![norm3(&p[6..9]); 3],
                vec![norm3(&p[9..12]); 3],
            ]
            .concat(),
            Shape::Box { .. } => [
                vec![c; 3],
                p[3..6].iter().map(|v| v.abs()).collect(),
                vec![q4(6); 4],
                vec![p[10].abs()],
            ]
            .concat(),
        };
        scale.extend(sc);
        x.extend(p);
    }
    let eval = |x: &[f64]| -> f64 {
        let o = DVec3::new(x[0], x[1], x[2]);
        let d = DVec3::new(x[3], x[4], x[5]);
        let t = x[6];
        let mut shapes = spans.iter().zip(std::iter::once(shape).chain(cuts.iter()));
        let (&(i0, n0), s0) = shapes.next().unwrap();
        let main = affine_f64(s0, &x[i0..i0 + n0]);
        let cs: Vec<Affine> = shapes
            .filter_map(|(&(i, n), s)| affine_f64(s, &x[i..i + n]))
            .collect();
        match main {
            Some(a) => depth_aff(&a, profile, &cs, o, d, t),
            None => f64::NAN,
        }
    };
    let base = eval(&x);
    let mut sum = 0.0;
    for i in 0..x.len() {
        if scale[i] == 0.0 || !x[i].is_finite() || !scale[i].is_finite() {
            continue;
        }
        let mut worst: f64 = 0.0;
        for m in [1.0, 4.0, 16.0] {
            for s in [m * delta, -m * delta] {
                let mut y = x.clone();
                y[i] += s * scale[i];
                let v = eval(&y);
                if v.is_finite() {
                    worst = worst.max((v - base).abs() / m);
                }
            }
        }
        sum += worst / delta;
    }
    sum
}

/// A shape's affine map built in f64 from (possibly perturbed) f64 parameters.
fn affine_f64(shape: &Shape, p: &[f64]) -> Option<Affine> {
    let v = |i: usize| DVec3::new(p[i], p[i + 1], p[i + 2]);
    let rot = |i: usize| {
        let q = glam::DQuat::from_xyzw(p[i], p[i + 1], p[i + 2], p[i + 3]);
        DMat3::from_quat(q / q.length())
    };
    let (kind, center, m, fade) = match shape {
        Shape::Sphere { .. } => (
            Kind::Ball,
            v(0),
            DMat3::from_diagonal(DVec3::splat(p[3])),
            0.0,
        ),
        Shape::Ellipsoid { .. } => (Kind::Ball, v(0), rot(6) * DMat3::from_diagonal(v(3)), 0.0),
        Shape::Affine { .. } => (Kind::Ball, v(0), DMat3::from_cols(v(3), v(6), v(9)), 0.0),
        Shape::Box { .. } => (Kind::Cube, v(0), rot(6) * DMat3::from_diagonal(v(3)), p[10]),
    };
    (m.determinant() != 0.0).then_some(Affine {
        kind,
        center,
        m,
        edge_fade: fade,
    })
}

// ---------------------------------------------------------------------------------------
// Scene-level model (what the kernel computes), in f64

/// The volumes' optical depth per channel and their τ-weighted fog colour for one ray, in
/// f64, by the per-volume lighting model of `medium::volume` (cut-outs applied to τ).
pub fn volumes_sample(desc: &SceneDesc, o: DVec3, d: DVec3, t: f64) -> ([f64; 3], [f64; 3]) {
    let cuts: Vec<Affine> = desc
        .volumes
        .iter()
        .filter(|v| v.subtractive)
        .filter_map(|v| affine(&v.shape).map(|a| a.0))
        .collect();
    let mut tau = [0.0; 3];
    let mut num = [0.0; 3];
    for v in desc.volumes.iter().filter(|v| !v.subtractive) {
        let Some(a) = affine(&v.shape) else {
            continue;
        };
        let g = depth_aff(&a.0, v.profile, &cuts, o, d, t);
        let c = volume_colour(v, &desc.lighting, d);
        for ch in 0..3 {
            let s = v.scattering[ch] as f64 + v.absorption[ch] as f64;
            let s32 = s as f32 as f64; // the kernel's extinction, rounded once
            tau[ch] += s32 * g;
            num[ch] += s32 * g * c[ch];
        }
    }
    let colour = [0, 1, 2].map(|ch| {
        if tau[ch] > 0.0 {
            num[ch] / tau[ch]
        } else {
            0.0
        }
    });
    (tau, colour)
}

/// The per-volume fog colour `albedo · (L_amb + E_sun · p(θ) · T_sun) + emission` for the
/// view direction `d` (f64), with `T_sun` the volume's transmittance from its centre to its
/// boundary toward the sun.
pub fn volume_colour(v: &Volume, lighting: &Lighting, d: DVec3) -> [f64; 3] {
    let Some(a) = affine(&v.shape) else {
        return [f64::NAN; 3];
    };
    let mut c = [0.0; 3];
    for ch in 0..3 {
        let bs = v.scattering[ch] as f64;
        let bt = bs + v.absorption[ch] as f64;
        let albedo = if bt > 0.0 { bs / bt } else { 0.0 };
        let mut l = lighting.ambient[ch] as f64;
        if let Some(sun) = &lighting.sun {
            let s = sun.direction.as_dvec3().normalize();
            let geom = depth(&a.0, v.profile, a.0.center, s, f64::INFINITY);
            let tsun = (-(bt as f32 as f64) * geom).exp();
            let p = super::phase(v.phase, d, s);
            l += sun.radiance[ch] as f64 * p * tsun;
        }
        c[ch] = albedo * l + v.emission[ch] as f64;
    }
    c
}

/// Single scattering in one volume, ray-marched with `steps` midpoint samples over the
/// ray's segment inside it: `L_in = ∫ T(0, s) · [β_s f · (E_sun · p(θ) · T_sun(x) + L_amb)
/// + β_t f · emission] ds`, with `T_sun(x)` the volume's transmittance from x toward the
/// sun (the volume shadows itself; cut-outs ignored) and both transmittances in closed
/// form. The reference for the per-volume lighting model, whose only approximation is
/// `T_sun(x) ≈ T_sun(centre)`.
pub fn single_scatter_marched(
    v: &Volume,
    lighting: &Lighting,
    o: DVec3,
    d: DVec3,
    t: f64,
    steps: usize,
) -> [f64; 3] {
    let Some(a) = affine(&v.shape) else {
        return [f64::NAN; 3];
    };
    let a = a.0;
    let Some((s0, s1)) = line_interval(&a, o, d) else {
        return [0.0; 3];
    };
    let (s0, s1) = (s0.max(0.0), s1.min(t));
    if !(s1 > s0) {
        return [0.0; 3];
    }
    let (q, e) = unit_ray(&a, o, d);
    let dl = d.length();
    let bt = [0, 1, 2].map(|ch| (v.scattering[ch] as f64 + v.absorption[ch] as f64) as f32 as f64);
    let sun = lighting
        .sun
        .as_ref()
        .map(|s| (s.direction.as_dvec3().normalize(), s.radiance.as_dvec3()));
    let p = sun.map(|(s, _)| super::phase(v.phase, d, s)).unwrap_or(0.0);
    let h = (s1 - s0) / steps as f64;
    let mut out = [0.0; 3];
    for k in 0..steps {
        let s = s0 + (k as f64 + 0.5) * h;
        let f = integrand(&a, v.profile, q, e, dl, s); // includes |d|
        if f == 0.0 {
            continue;
        }
        let view = depth(&a, v.profile, o, d, s);
        let x = o + s * d;
        let sun_geom = sun.map(|(sd, _)| depth(&a, v.profile, x, sd, f64::INFINITY));
        for ch in 0..3 {
            let tv = (-bt[ch] * view).exp();
            let mut src = v.scattering[ch] as f64 * lighting.ambient[ch] as f64;
            if let (Some((_, e_sun)), Some(g)) = (sun, sun_geom) {
                src += v.scattering[ch] as f64 * e_sun[ch] * p * (-bt[ch] * g).exp();
            }
            src += bt[ch] * v.emission[ch] as f64;
            out[ch] += tv * src * f * h;
        }
    }
    out
}

/// The per-volume model's in-scattering for one volume alone: colour · (1 − T).
pub fn single_volume_model(
    v: &Volume,
    lighting: &Lighting,
    o: DVec3,
    d: DVec3,
    t: f64,
) -> [f64; 3] {
    let Some(a) = affine(&v.shape) else {
        return [f64::NAN; 3];
    };
    let g = depth(&a.0, v.profile, o, d, t);
    let c = volume_colour(v, lighting, d);
    [0, 1, 2].map(|ch| {
        let bt = (v.scattering[ch] as f64 + v.absorption[ch] as f64) as f32 as f64;
        c[ch] * -(-bt * g).exp_m1()
    })
}

/// Does `phase` depend on the view direction?
pub fn is_directional(phase: Phase) -> bool {
    phase != Phase::Isotropic
}

// ---------------------------------------------------------------------------------------
// The seeds' formulas, as written

/// Seed 004's `computeFog` (Íñigo Quílez, "sphere density"), transcribed in f32: the
/// quadratic-density sphere integrated from the camera to the depth buffer, in units of
/// the radius, normalized by 3/4 so that a ray through the centre from surface to surface
/// gives 1. `rd` must be unit length.
pub fn compute_fog_seed004(ro: Vec3, rd: Vec3, sc: Vec3, sr: f32, dbuffer: f32) -> f32 {
    let ndbuffer = dbuffer / sr;
    let rc = (ro - sc) / sr;
    let b = rd.dot(rc);
    let c = rc.dot(rc) - 1.0;
    let h = b * b - c;
    if h < 0.0 {
        return 0.0;
    }
    let h = h.sqrt();
    let mut t1 = -b - h;
    let mut t2 = -b + h;
    if t2 < 0.0 || t1 > ndbuffer {
        return 0.0;
    }
    t1 = t1.max(0.0);
    t2 = t2.min(ndbuffer);
    let i1 = -(c * t1 + b * t1 * t1 + t1 * t1 * t1 / 3.0);
    let i2 = -(c * t2 + b * t2 * t2 + t2 * t2 * t2 / 3.0);
    (i2 - i1) * (3.0 / 4.0)
}

/// The same as [`compute_fog_seed004`] in f64 (the seed's arithmetic, no f32 rounding).
pub fn compute_fog_seed004_f64(ro: DVec3, rd: DVec3, sc: DVec3, sr: f64, dbuffer: f64) -> f64 {
    let ndbuffer = dbuffer / sr;
    let rc = (ro - sc) / sr;
    let b = rd.dot(rc);
    let c = rc.dot(rc) - 1.0;
    let h = b * b - c;
    if h < 0.0 {
        return 0.0;
    }
    let h = h.sqrt();
    let (t1, t2) = (-b - h, -b + h);
    if t2 < 0.0 || t1 > ndbuffer {
        return 0.0;
    }
    let (t1, t2) = (t1.max(0.0), t2.min(ndbuffer));
    let i1 = -(c * t1 + b * t1 * t1 + t1 * t1 * t1 / 3.0);
    let i2 = -(c * t2 + b * t2 * t2 + t2 * t2 * t2 / 3.0);
    (i2 - i1) * (3.0 / 4.0)
}

/// Seed 002's antiderivatives, transcribed in f32 (`antiderivativeLinear`, `…Quadratic`,
/// `…Quartic`, `…Spiky`, `…Gaussian` with the seed's erf approximation), for a sphere
/// (centre, radius) and the segment o + s·d, s in [0, t], with the seed's origin shift
/// (the ray restarted at the sphere's entry point, limits 0 and t_b − t_a). Returns the
/// world-length integral (the seed's value times the radius · |d| / |d|... in world
/// units), 0 if the ray misses. This is the baseline the f32 kernel is compared with.
pub fn seed002_depth(profile: Profile, center: Vec3, radius: f32, o: Vec3, d: Vec3, t: f32) -> f32 {
    // Unit space: r_o' = (o − c)/R, r_d' = d/R (the seed's "M (r_o + t r_d)").
    let ro = (o - center) / radius;
    let rd = d / radius;
    let a = rd.dot(rd);
    let b = rd.dot(ro);
    let c = ro.dot(ro);
    // Entry/exit: a s² + 2 b s + c = 1.
    let disc = b * b - a * (c - 1.0);
    if disc < 0.0 {
        return 0.0;
    }
    let sq = disc.sqrt();
    let ta = ((-b - sq) / a).max(0.0);
    let tb = ((-b + sq) / a).min(t);
    if !(tb > ta) {
        return 0.0;
    }
    // The seed's origin shift: restart the ray at ta.
    let ro = ro + rd * ta;
    let b = rd.dot(ro);
    let c = ro.dot(ro);
    let tt = tb - ta;
    let lin = |t: f32| {
        let u = t + b / a;
        let v = (b * b - a * c) / (a * a);
        let radical = (u * u - v).sqrt();
        t - a.sqrt() * (u * radical - v * (0.001 + u + radical).ln()) / 2.0
    };
    let quad = |t: f32| t * (t * (t * a / -3.0 - b) - c + 1.0);
    let quart = |t: f32| {
        t * (t
            * (t * (t * (a * a * t / 5.0 + a * b) + (2.0 * b * b + a * c - a) * 2.0 / 3.0)
                + (b * c - b) * 2.0)
            + (c * c - 2.0 * c + 1.0))
    };
    let spiky = |t: f32| {
        let u = t + b / a;
        let v = (b * b - a * c) / (a * a);
        let radical = (u * u - v).sqrt();
        t * (t * (t * a / 3.0 + b) + c + 1.0)
            - a.sqrt() * (u * radical - v * (0.001 + u + radical).ln())
    };
    let seed_erf = |z: f32| {
        let az = z.abs();
        z.signum()
            * (1.0
                - 1.0
                    / (1.0 + az * (0.278393 + az * (0.230389 + az * (0.000972 + az * 0.078108))))
                        .powf(4.0))
    };
    // The seed's Gaussian is e^(−|p|²); ours is e^(−8|p|²): scale the unit space by √8.
    let gauss = |t: f32| {
        let s8 = 8.0f32;
        let (a, b, c) = (a * s8, b * s8, c * s8);
        let sqrt_a = a.sqrt();
        core::f32::consts::PI.sqrt() * (b * b / a - c).exp() * seed_erf((a * t + b) / sqrt_a)
            / (2.0 * sqrt_a)
    };
    let f = |t: f32| match profile {
        Profile::Constant => t,
        Profile::Linear => lin(t),
        Profile::Quadratic => quad(t),
        Profile::Quartic => quart(t),
        Profile::Spiky => spiky(t),
        Profile::Gaussian => gauss(t),
    };
    // The seed integrates in the ray parameter; world length is |d| per unit parameter.
    (f(tt) - f(0.0)) * d.length()
}
