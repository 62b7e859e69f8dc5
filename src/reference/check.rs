//! The accuracy bound of issue #2 and the comparison of an f32 result with the reference.
//!
//! # The bound on τ
//! Relative error of τ ≤ 16 · 2⁻²⁴ · κ per channel, with the condition κ of the problem
//! (how far one rounding of the inputs moves the true τ, in units of 2⁻²⁴), the largest
//! over the layers:
//!
//! ```text
//! κ = 1 + |b·y0| + κ_Δ
//! κ_Δ = |Δ|         for Δ = b·u·t ≤ 0   (the issue's |b·d_up·t|)
//! κ_Δ = min(Δ, 1)   for Δ > 0          (tighter than the issue's |Δ|: there the true
//!                                       sensitivity of ln τ to ln Δ, 1 − Δ/(e^Δ − 1), is
//!                                       ≤ 1, and the issue's term is +∞ at t = +∞)
//! ```
//!
//! # A general up vector
//! With an up vector that is not ±X/±Y/±Z the library rounds the normalized up to f32,
//! and computes h(o) = dot(o, up) and u = dot(d, up) in f32: the height moves by up to
//! δy = 4 · 2⁻²⁴ · (|o_x| + |o_y| + |o_z|) + 2⁻¹⁴⁸ and u by
//! δu = 4 · 2⁻²⁴ · (|d_x| + |d_y| + |d_z|) + 2⁻¹⁴⁸ (one rounding of each up component and
//! two of each dot product; the 2⁻¹⁴⁸ is for products that fall into the subnormal range,
//! where f32 rounds absolutely: a direction whose components are all below 2⁻¹²⁶ has a u
//! with few significant bits, and τ at t = +∞, ∝ |d|/|u|, follows it). The documented
//! linearization of this, adding |b|·|o| (and |b|·t·|d|) to κ, fails where u changes
//! sign within δu (a ray within 1e-7 rad of the horizontal to t = +∞: τ finite for the
//! exact up and +∞ for the rounded one; found by `tests/extreme.rs`). So the check
//! treats it as what it is, a perturbation of the input: the reference τ becomes the
//! interval [τ_lo, τ_hi] of exact τ over y0 ± δy, u ± δu (τ is monotonic in both, so the
//! interval's ends are two evaluations), and the f32 τ must lie in
//! [τ_lo · (1 − tol), τ_hi · (1 + tol)], tol = 16 · 2⁻²⁴ · κ. For an axis up vector
//! δy = δu = 0 and the interval is the point τ_ref.
//!
//! # Saturation and subnormal τ
//! τ must be +∞ where τ_lo exceeds f32::MAX by more than the tolerance, and finite where
//! τ_hi is below f32::MAX by more than the tolerance; in between either is accepted (a
//! finite result then must be within the tolerance). Where the reference τ is below
//! 2⁻¹²⁵ (subnormal in f32, where f32 has no relative precision left) the bound gains
//! 2⁻¹⁴⁹ in absolute terms (one subnormal step) per layer: each layer's τ is rounded into
//! the subnormal range before they are added.
//!
//! # T and L_in
//! T must lie in [e^(−τ_hi·(1 + tol)) · (1 − 2⁻²³), e^(−τ_lo·(1 − tol)) · (1 + 2⁻²³)]
//! widened by 2⁻¹⁴⁹: what the τ bound implies, plus one f32 ulp of the exponential. Where
//! the reference T is below 2⁻¹²⁶ (τ > 87.3, subnormal T) the widening is 2⁻¹²⁶ instead:
//! the kernels flush subnormal transmittances to zero ([`T_FLUSH`]).
//! L_in must lie in C · (1 − [that T interval]) widened by C · (10⁻⁵ + m), with C the fog
//! colour (with several layers: the largest layer colour) and m the possible move of the
//! τ-weighted mix when each τ_i moves within its bound (2 · (tol + the relative width of
//! the τ interval), at most 1; 0 for one layer); for colours so small that they are
//! subnormal in f32, plus 2⁻¹⁴⁹ · (2 + Σ_c p_c) per layer (f32 holds them to that
//! absolute precision only). No allowance is made for the phase functions: the kernels'
//! are accurate to a few ulps even beside the peak of g = ±0.99 (`light.rs` forms
//! 1 + g² − 2g·cos θ without cancellation).
//!
//! The ratios reported in [`SampleCheck`] are the distance from the reference value
//! divided by the distance the bound allows on that side (≤ 1 passes).

use super::{sample, RefSample};
use crate::scene::SceneDesc;
use crate::FogSample;
use glam::{DVec3, Vec3};

/// 2⁻²⁴, the unit roundoff of f32.
pub const EPS32: f64 = 1.0 / 16_777_216.0;
/// The tolerance on L_in relative to the fog colour (issue #2).
pub const L_IN_TOLERANCE: f64 = 1e-5;
/// Smallest positive f32 (subnormal), 2⁻¹⁴⁹.
const TINY: f64 = 1.401_298_464_324_817e-45;
/// Smallest normal f32, 2⁻¹²⁶: where the reference T is below it (τ > 87.3), T may be
/// flushed to zero (`math::exp_neg` does, by design), an absolute error below 1.2e-38.
pub const T_FLUSH: f64 = 1.175_494_350_822_287_5e-38;

/// The condition κ of τ for the ray (the largest over the layers with non-zero
/// extinction; 1 for a scene without fog). See the module documentation.
pub fn condition(desc: &SceneDesc, origin: DVec3, dir: DVec3, t: f64) -> f64 {
    let up = super::up(desc);
    let mut kappa = 1.0f64;
    for layer in &desc.height_fog {
        if super::extinction(layer).iter().all(|&s| s == 0.0) {
            continue;
        }
        let g = super::LayerGeometry::new(layer, up, origin, dir, t);
        let delta = g.delta();
        let k_delta = if delta > 0.0 { delta.min(1.0) } else { -delta };
        kappa = kappa.max(1.0 + (g.b * g.y0).abs() + k_delta);
    }
    kappa
}

/// True if the scene's up vector is exactly along ±X, ±Y or ±Z (two components zero):
/// the kernels then read one coordinate and nothing is rounded. (A vector that only
/// rounds to an axis, such as (1e-45, 1, 0), is snapped to it by the library: a rounding
/// of the input, treated like a general one.)
pub fn up_is_axis(desc: &SceneDesc) -> bool {
    desc.up.to_array().iter().filter(|&&c| c == 0.0).count() == 2
}

/// The perturbation (δy, δu) of the height dot(o, up) and of u = dot(d, up) that the f32
/// rounding of a general up vector implies (0 for an axis up vector). See the module
/// documentation.
pub fn up_rounding(desc: &SceneDesc, origin: DVec3, dir: DVec3) -> (f64, f64) {
    if up_is_axis(desc) {
        (0.0, 0.0)
    } else {
        let l1 = |v: DVec3| v.abs().element_sum();
        (
            4.0 * EPS32 * l1(origin) + 2.0 * TINY,
            4.0 * EPS32 * l1(dir) + 2.0 * TINY,
        )
    }
}

/// ln τ_lo and ln τ_hi per channel: the exact optical depth over the perturbations
/// [`up_rounding`] of the height and of u (equal to ln τ for an axis up vector), and the
/// largest relative width τ_hi/τ_lo − 1 of a layer's interval.
pub fn tau_interval(
    desc: &SceneDesc,
    origin: DVec3,
    dir: DVec3,
    t: f64,
) -> ([f64; 3], [f64; 3], f64) {
    let up = super::up(desc);
    let (dy, du) = up_rounding(desc, origin, dir);
    let mut width = 0.0f64;
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for layer in &desc.height_fog {
        let g = super::LayerGeometry::new(layer, up, origin, dir, t);
        let l = super::layer_ln_tau_geom(layer, &g.perturbed(dy, du, -1.0));
        let h = super::layer_ln_tau_geom(layer, &g.perturbed(dy, du, 1.0));
        for ch in 0..3 {
            if l[ch].is_finite() && h[ch].is_finite() {
                width = width.max((h[ch] - l[ch]).exp_m1());
            } else if l[ch] != h[ch] {
                width = f64::INFINITY;
            }
        }
        lo.push(l);
        hi.push(h);
    }
    let sum = |v: &Vec<[f64; 3]>| [0, 1, 2].map(|ch| super::ln_sum_exp(v.iter().map(|l| l[ch])));
    (sum(&lo), sum(&hi), width)
}

/// The tolerance on the relative error of τ for condition `kappa`: 16 · 2⁻²⁴ · κ.
pub fn tau_tolerance(kappa: f64) -> f64 {
    16.0 * EPS32 * kappa
}

/// The result of comparing one f32 sample with the reference.
#[derive(Clone, Debug)]
pub struct SampleCheck {
    /// The reference values.
    pub reference: RefSample,
    /// The condition κ.
    pub condition: f64,
    /// The tolerance on the relative error of τ, 16 · 2⁻²⁴ · κ.
    pub tau_tolerance: f64,
    /// The largest relative width τ_hi/τ_lo − 1 of a layer's reference interval (0 for an
    /// axis up vector).
    pub interval_width: f64,
    /// Measured relative error of τ (largest channel; 0 where both are 0 or both +∞;
    /// +∞ where one saturates wrongly or is NaN).
    pub tau_rel_err: f64,
    /// Measured error of τ divided by what the bound allows (≤ 1 passes).
    pub tau_ratio: f64,
    /// Measured |T − T_ref| (largest channel).
    pub trans_err: f64,
    /// |T − T_ref| divided by what the bound allows.
    pub trans_ratio: f64,
    /// [`trans_ratio`](Self::trans_ratio) over the channels whose reference T is at least
    /// [`T_FLUSH`] (0 if none). Below it the kernels flush T to 0 by design, and the
    /// ratio of a flushed T is T_ref / (2⁻¹²⁶ + the bound's own width): close to 1 for
    /// a T_ref just below 2⁻¹²⁶ whatever the accuracy, so the flushed channels say
    /// nothing about it.
    pub trans_ratio_normal: f64,
    /// Measured |L − L_ref| / C, C the colour scale (largest channel).
    pub insc_err: f64,
    /// |L − L_ref| divided by what the bound allows.
    pub insc_ratio: f64,
    /// The first failure, described.
    pub failure: Option<String>,
}

impl SampleCheck {
    /// True if every quantity is within its bound and the invariants hold.
    pub fn passed(&self) -> bool {
        self.failure.is_none()
    }

    /// True where the bound guarantees no significant digit of τ (tolerance or interval
    /// width ≥ 1): there only the invariants and the saturation rules are informative,
    /// and a ratio near 1 only says that the result is at a physical limit (T = 0 or 1,
    /// L_in = 0) that the bound admits.
    pub fn vacuous(&self) -> bool {
        !(self.tau_tolerance < 1.0 && self.interval_width < 1.0)
    }

    /// The largest of the three ratios.
    pub fn worst_ratio(&self) -> f64 {
        self.tau_ratio.max(self.trans_ratio).max(self.insc_ratio)
    }
}

/// The header of the table [`WorstErrors::markdown_row`] writes (`first` names the first
/// column, `count` the second), with its separator line.
pub fn markdown_header(first: &str, count: &str) -> String {
    format!(
        "| {first:<15} | {count:<6} | no digit | max κ    | max rel err τ | τ err/bound | T err/bound | T ≥ 2⁻¹²⁶ only | L_in err/bound |\n\
         |-----------------|-------:|---------:|---------:|--------------:|------------:|------------:|----------------:|---------------:|"
    )
}

/// The worst errors over a set of [`SampleCheck`]s, for the tests' and reports' tables:
/// every measure is taken over the samples whose bound is not vacuous (see
/// [`SampleCheck::vacuous`]).
#[derive(Clone, Debug, Default)]
pub struct WorstErrors {
    /// Samples added.
    pub samples: usize,
    /// Of them, the ones whose bound is vacuous (κ = +∞: only the invariants are checked).
    pub vacuous: usize,
    /// The largest condition κ.
    pub kappa: f64,
    /// The largest relative error of τ where τ is normal and finite in the result and
    /// finite in the reference (channels apart).
    pub tau_rel: f64,
    /// The largest [`SampleCheck::tau_ratio`] (≤ 1 passes).
    pub tau_ratio: f64,
    /// The largest [`SampleCheck::trans_ratio`] (≤ 1 passes).
    pub trans_ratio: f64,
    /// The largest [`SampleCheck::trans_ratio_normal`]: T's ratio where the reference T
    /// is not in the flushed range.
    pub trans_ratio_normal: f64,
    /// The largest [`SampleCheck::insc_ratio`] (≤ 1 passes).
    pub insc_ratio: f64,
}

impl WorstErrors {
    /// Adds one sample: `c` is [`check_sample`]'s comparison of `got` with the reference.
    pub fn add(&mut self, c: &SampleCheck, got: &FogSample) {
        self.samples += 1;
        if c.vacuous() {
            self.vacuous += 1;
            return;
        }
        self.kappa = self.kappa.max(c.condition);
        for ch in 0..3 {
            let (g, r) = (got.tau[ch] as f64, c.reference.tau[ch]);
            if g.is_finite() && g >= f32::MIN_POSITIVE as f64 && r <= f32::MAX as f64 {
                self.tau_rel = self.tau_rel.max((g - r).abs() / r);
            }
        }
        self.tau_ratio = self.tau_ratio.max(c.tau_ratio);
        self.trans_ratio = self.trans_ratio.max(c.trans_ratio);
        self.trans_ratio_normal = self.trans_ratio_normal.max(c.trans_ratio_normal);
        self.insc_ratio = self.insc_ratio.max(c.insc_ratio);
    }

    /// One row of a Markdown table: `name`, samples, vacuous ones, κ, the relative error
    /// of τ and the ratios to the bound (T's over all channels and over those with
    /// T_ref ≥ 2⁻¹²⁶; see [`markdown_header`]).
    pub fn markdown_row(&self, name: &str) -> String {
        format!(
            "| {:<15} | {:>6} | {:>8} | {:>8.2e} | {:>13.2e} | {:>11.3} | {:>11.3} | {:>15.3} | {:>14.3} |",
            name,
            self.samples,
            self.vacuous,
            self.kappa,
            self.tau_rel,
            self.tau_ratio,
            self.trans_ratio,
            self.trans_ratio_normal,
            self.insc_ratio
        )
    }
}

/// Compares an f32 result `got` for the ray `origin + s·dir`, s in [0, t], with the
/// reference and the bound of the module documentation. Inputs: a scene description that
/// [`crate::Scene::new`] accepts, finite origin and direction, t ≥ 0 or +∞.
pub fn check_sample(
    desc: &SceneDesc,
    origin: Vec3,
    dir: Vec3,
    t: f32,
    got: &FogSample,
) -> SampleCheck {
    let (o, d, t) = (origin.as_dvec3(), dir.as_dvec3(), t as f64);
    let r = sample(desc, o, d, t);
    let kappa = condition(desc, o, d, t);
    let tol = tau_tolerance(kappa);
    let (band_lo, band_hi, width) = tau_interval(desc, o, d, t);
    let ln_max = (f32::MAX as f64).ln();
    let margin = tol.ln_1p();
    let several = desc.height_fog.len() > 1;
    let mut c = SampleCheck {
        reference: r.clone(),
        condition: kappa,
        tau_tolerance: tol,
        interval_width: width,
        tau_rel_err: 0.0,
        tau_ratio: 0.0,
        trans_err: 0.0,
        trans_ratio: 0.0,
        trans_ratio_normal: 0.0,
        insc_err: 0.0,
        insc_ratio: 0.0,
        failure: None,
    };
    let fail = |c: &mut SampleCheck, msg: String| {
        if c.failure.is_none() {
            c.failure = Some(msg);
        }
    };
    let (gt, gx, gl) = (
        got.tau.to_array(),
        got.transmittance.to_array(),
        got.inscattering.to_array(),
    );
    for ch in 0..3 {
        let (tk, xk, lk) = (gt[ch] as f64, gx[ch] as f64, gl[ch] as f64);
        // Invariants.
        let valid = tk >= 0.0 && (0.0..=1.0).contains(&xk) && lk >= 0.0 && lk.is_finite();
        if !valid {
            c.tau_ratio = f64::INFINITY;
            fail(
                &mut c,
                format!("channel {ch}: invariant broken: tau {tk:e}, T {xk:e}, L {lk:e}"),
            );
            continue;
        }
        // τ: the interval [τ_lo, τ_hi] widened by the tolerance.
        let (llo, lhi) = (band_lo[ch], band_hi[ch]);
        let (tlo, thi) = (llo.exp(), lhi.exp());
        let sub = if tlo < 2.0 * f32::MIN_POSITIVE as f64 {
            TINY * desc.height_fog.len().max(1) as f64
        } else {
            0.0
        };
        // (relative error, ratio to the bound)
        let (rel, ratio) = if llo == f64::INFINITY || llo > ln_max + margin {
            // Must saturate.
            if tk == f64::INFINITY {
                (0.0, 0.0)
            } else {
                (f64::INFINITY, f64::INFINITY)
            }
        } else if tk == f64::INFINITY {
            // Saturated: allowed where τ_hi · (1 + tol) ≥ f32::MAX.
            let rel = (ln_max - lhi).exp_m1().max(0.0);
            (rel, rel / tol)
        } else if lhi == f64::NEG_INFINITY {
            // τ = 0 exactly (no extinction, t = 0 or d = 0).
            let bad = if tk == 0.0 { 0.0 } else { f64::INFINITY };
            (bad, bad)
        } else if tk < tlo {
            let rel = if tk > 0.0 {
                (llo - tk.ln()).exp_m1()
            } else {
                1.0
            };
            (rel, (tlo - tk) / (mul0(tol, tlo) + sub))
        } else if tk > thi {
            let rel = (tk.ln() - lhi).exp_m1();
            (rel, (tk - thi) / (mul0(tol, thi) + sub))
        } else {
            (0.0, 0.0)
        };
        c.tau_rel_err = c.tau_rel_err.max(rel);
        c.tau_ratio = c.tau_ratio.max(ratio);
        if exceeds(ratio) {
            fail(
                &mut c,
                format!(
                    "channel {ch}: tau {tk:e} vs reference {:e} (interval [{tlo:e}, {thi:e}]), \
                     rel err {rel:e}, tolerance {tol:e} (condition {kappa:e})",
                    r.tau[ch]
                ),
            );
        }
        // T: e^(−τ) over the widened τ interval, plus one ulp, plus the flush/subnormal step.
        let xr = r.transmittance[ch];
        let slack = if xr < T_FLUSH { T_FLUSH } else { TINY };
        // The widened τ interval (0 · ∞ = 0: an infinite tolerance admits any τ ≥ 0).
        let tau_min = if tol < 1.0 {
            tlo * (1.0 - tol) - sub
        } else {
            0.0
        };
        let tau_max = thi + mul0(tol, thi) + sub;
        let x_lo = (-tau_max).exp() * (1.0 - 2.0 * EPS32);
        let x_hi = (-tau_min).exp() * (1.0 + 2.0 * EPS32);
        let (x_below, x_above) = ((xr - x_lo).max(0.0) + slack, (x_hi - xr).max(0.0) + slack);
        let xerr = (xk - xr).abs();
        let xratio = xerr / if xk < xr { x_below } else { x_above };
        c.trans_err = c.trans_err.max(xerr);
        c.trans_ratio = c.trans_ratio.max(xratio);
        if xr >= T_FLUSH {
            c.trans_ratio_normal = c.trans_ratio_normal.max(xratio);
        }
        if exceeds(xratio) {
            fail(
                &mut c,
                format!(
                    "channel {ch}: T {xk:e} vs reference {xr:e}, allowed [{:e}, {:e}]",
                    xr - x_below,
                    xr + x_above
                ),
            );
        }
        // L_in = C · (1 − T) over that T interval, plus the colour's tolerance.
        let scale = r.layer_colours[ch]
            .iter()
            .copied()
            .fold(r.colour[ch], f64::max);
        // The mix is a convex combination of the layer colours: it cannot move by more
        // than `scale`, whatever the tolerance on τ (which is +∞ where κ is).
        let mix = if several {
            (2.0 * (tol + width)).min(1.0)
        } else {
            0.0
        };
        let colour_tol = if scale > 0.0 {
            scale * (L_IN_TOLERANCE + mix) + subnormal_colour(desc, d)
        } else {
            0.0
        };
        let lr = r.inscattering[ch];
        let c_ref = r.colour[ch];
        let l_below = (lr - c_ref * (1.0 - x_hi - slack).max(0.0)).max(0.0) + colour_tol + TINY;
        let l_above = (c_ref * (1.0 - x_lo + slack).min(1.0) - lr).max(0.0) + colour_tol + TINY;
        let lerr = (lk - lr).abs();
        if scale > 0.0 {
            c.insc_err = c.insc_err.max(lerr / scale);
        }
        let lratio = lerr / if lk < lr { l_below } else { l_above };
        c.insc_ratio = c.insc_ratio.max(lratio);
        if exceeds(lratio) {
            fail(
                &mut c,
                format!(
                    "channel {ch}: L_in {lk:e} vs reference {lr:e} (colour {c_ref:e}), \
                     allowed [{:e}, {:e}]",
                    lr - l_below,
                    lr + l_above
                ),
            );
        }
    }
    c
}

/// The absolute precision of fog colours in f32 where they are subnormal: each layer's
/// compiled colour terms are stored with an error up to 2⁻¹⁵⁰ and the sun terms are then
/// multiplied by their phase functions, so 2⁻¹⁴⁹ · (2 + Σ_c p_c(cos θ)) per layer.
fn subnormal_colour(desc: &SceneDesc, dir: DVec3) -> f64 {
    let cos = super::cos_sun(desc, dir);
    let sun = desc.lighting.sun.is_some();
    desc.height_fog
        .iter()
        .map(|l| {
            let p: f64 = if sun {
                l.components.iter().map(|c| c.phase.eval_f64(cos)).sum()
            } else {
                0.0
            };
            TINY * (2.0 + p)
        })
        .sum()
}

/// True if a ratio to the bound is over 1 or NaN.
fn exceeds(ratio: f64) -> bool {
    ratio.is_nan() || ratio > 1.0
}

/// a · b with 0 · ∞ = 0.
fn mul0(a: f64, b: f64) -> f64 {
    if a == 0.0 || b == 0.0 {
        0.0
    } else {
        a * b
    }
}
