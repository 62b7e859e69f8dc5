//! The C peer's benchmark data (`../shared/peers/c-libmvec/height_fog.c`) and its
//! accuracy measure, so that benches, examples and tests use one copy of them.
//!
//! Medium: b = 0.1, h0 = 0, β = (0.02, 0.03, 0.05), +Y up, unit directions. Data sets, from
//! the peer's xorshift generator and seed: *typical*: camera height U(0, 10), d_y U(−1, 1),
//! t U(0, 1000) clipped at the ground y = 0; *extreme*: no clipping, and every 8th ray
//! with |d_y| < 1e-6 and t up to 1e7.

use crate::{Component, HeightFogLayer, Phase, SceneDesc};
use glam::Vec3;

/// The peer's falloff b.
pub const FALLOFF: f32 = 0.1;
/// The peer's extinction per channel (scattering; no absorption).
pub const BETA: [f32; 3] = [0.02, 0.03, 0.05];

/// The peer's medium as a scene: one layer (base height 0, falloff [`FALLOFF`],
/// scattering [`BETA`], isotropic), no light.
pub fn scene_desc() -> SceneDesc {
    SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: FALLOFF,
            emission: Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::from_array(BETA),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
            }],
        }],
        ..SceneDesc::default()
    }
}

/// The peer's rays: camera heights `oy`, up components `dy` of the unit directions
/// (d = (√(1 − d_y²), d_y, 0)) and lengths `t`, as the peer generates them.
pub struct PeerRays {
    /// Camera heights above the base.
    pub oy: Vec<f32>,
    /// Up components of the directions.
    pub dy: Vec<f32>,
    /// Segment lengths.
    pub t: Vec<f32>,
}

impl PeerRays {
    /// The first `n` rays of the typical or the extreme set.
    pub fn new(n: usize, extreme: bool) -> PeerRays {
        let mut uni = uniform(88172645463325252);
        let mut r = PeerRays {
            oy: vec![0.0; n],
            dy: vec![0.0; n],
            t: vec![0.0; n],
        };
        for i in 0..n {
            let y = uni() * 10.0;
            let mut u = uni() * 2.0 - 1.0;
            let mut d = uni() * 1000.0;
            if extreme && (i & 7) == 0 {
                u = (uni() * 2.0 - 1.0) * 1e-6;
                d = uni() * 1e7;
            }
            if !extreme && u < 0.0 && -y / u < d {
                d = -y / u;
            }
            (r.oy[i], r.dy[i], r.t[i]) = (y, u, d);
        }
        r
    }

    /// Data extreme for this crate's own ranges rather than the peer's (the peer's extreme
    /// set stays inside the kernel's tame first stage), from the first `n` rays of the
    /// typical set:
    /// - `stiff` false, *sky*: every t = +∞ (a renderer's sky pixels; looking down,
    ///   τ = +∞ and T = 0);
    /// - `stiff` true: each ray one of four kinds at random: t = +∞; t from 1e9 to 1e12
    ///   (|Δ| far beyond 256 unless the ray is nearly level); t from 1e-9 to 1e-7 (|d|·t
    ///   below 2^-20); a camera 1e4 above or 1e3 below the base (the density at the camera
    ///   under- or overflows f32) with a typical t.
    pub fn crate_extreme(n: usize, stiff: bool) -> PeerRays {
        let mut r = PeerRays::new(n, false);
        if !stiff {
            r.t.iter_mut().for_each(|t| *t = f32::INFINITY);
            return r;
        }
        let mut uni = uniform(0x9E37_79B9_7F4A_7C15);
        for i in 0..n {
            let kind = (uni() * 4.0) as u32;
            match kind {
                0 => r.t[i] = f32::INFINITY,
                1 => r.t[i] = 1e9 * 1e3f32.powf(uni()),
                2 => r.t[i] = 1e-9 * 1e2f32.powf(uni()),
                _ => r.oy[i] = if uni() < 0.5 { 1e4 } else { -1e3 },
            }
        }
        r
    }

    /// The x components of the unit directions, √(1 − d_y²).
    pub fn dx(&self) -> Vec<f32> {
        self.dy
            .iter()
            .map(|u| (1.0 - u * u).max(0.0).sqrt())
            .collect()
    }

    /// T_f64 of ray `i` with extinction `beta`: the peer's closed form, evaluated in f64
    /// from the f32 inputs as the peer checks itself (|d| = 1).
    pub fn transmittance_f64(&self, i: usize, beta: f32) -> f64 {
        let b = f64::from(FALLOFF);
        let x = b * f64::from(self.dy[i]) * f64::from(self.t[i]);
        let phi = if x != 0.0 { -(-x).exp_m1() / x } else { 1.0 };
        let geo = (-b * f64::from(self.oy[i])).exp() * f64::from(self.t[i]) * phi;
        (-geo * f64::from(beta)).exp()
    }

    /// The peer's accuracy measure for transmittances `trans` (per channel, one value per
    /// ray): max |T − T_f64| for the first channel (what the peer prints, for β_r) and
    /// over all three.
    pub fn max_trans_error(&self, trans: [&[f32]; 3]) -> (f64, f64) {
        let (mut first, mut all) = (0.0f64, 0.0f64);
        for i in 0..self.t.len() {
            for (ch, (tr, &beta)) in trans.iter().zip(&BETA).enumerate() {
                let e = (f64::from(tr[i]) - self.transmittance_f64(i, beta)).abs();
                if ch == 0 {
                    first = first.max(e);
                }
                all = all.max(e);
            }
        }
        (first, all)
    }
}

/// One family of [`EXTREME_FAMILIES`]: a name, what it is, and how it changes a typical
/// ray (camera height, up component of the direction, t).
pub type Family = (&'static str, &'static str, fn(&mut f32, &mut f32, &mut f32));

/// Families of extreme data, each the typical rays with one thing changed, so that a
/// slow path for one kind of extreme input shows by itself (`examples/speedscan.rs`
/// times them; `tests/height_fog.rs` checks the vector path against the scalar one and
/// the reference on them). Directions (√(1 − d_y²), d_y, 0) as [`PeerRays::dx`] forms
/// them.
pub const EXTREME_FAMILIES: [Family; 18] = [
    (
        "camera_1e-19",
        "camera heights × 1e-19 (t clipped at the ground)",
        |y, _, t| {
            *y *= 1e-19;
            *t = t.min(1000.0) * 1e-19;
        },
    ),
    (
        "camera_1e-19_free",
        "camera heights × 1e-19, t as typical",
        |y, _, _| *y *= 1e-19,
    ),
    (
        "camera_1e-30",
        "camera heights × 1e-30, t as typical",
        |y, _, _| *y *= 1e-30,
    ),
    (
        "camera_1e-38",
        "camera heights × 1e-38 (some subnormal)",
        |y, _, _| *y *= 1e-38,
    ),
    ("camera_high", "camera 1e4 above the base", |y, _, _| {
        *y += 1e4
    }),
    ("camera_low", "camera 1e3 below the base", |y, _, _| {
        *y -= 1e3
    }),
    ("level_1e-7", "d_up × 1e-7 (nearly level)", |_, u, _| {
        *u *= 1e-7
    }),
    ("level_1e-20", "d_up × 1e-20", |_, u, _| *u *= 1e-20),
    ("level_1e-30", "d_up × 1e-30", |_, u, _| *u *= 1e-30),
    ("level_0", "d_up = 0", |_, u, _| *u = 0.0),
    ("short_1e-10", "t × 1e-10", |_, _, t| *t *= 1e-10),
    ("short_1e-30", "t × 1e-30", |_, _, t| *t *= 1e-30),
    ("short_1e-40", "t × 1e-40 (subnormal)", |_, _, t| {
        *t *= 1e-40
    }),
    ("long_1e6", "t × 1e6", |_, _, t| *t *= 1e6),
    ("long_1e30", "t × 1e30", |_, _, t| *t *= 1e30),
    ("sky", "t = +inf", |_, _, t| *t = f32::INFINITY),
    ("t_max", "t = f32::MAX (a far sentinel)", |_, _, t| {
        *t = f32::MAX
    }),
    ("zero_length", "t = 0", |_, _, t| *t = 0.0),
];

impl PeerRays {
    /// The first `n` typical rays changed by `family` (see [`EXTREME_FAMILIES`]).
    pub fn family(n: usize, family: &Family) -> PeerRays {
        let mut r = PeerRays::new(n, false);
        for i in 0..n {
            (family.2)(&mut r.oy[i], &mut r.dy[i], &mut r.t[i]);
        }
        r
    }
}

/// The peer's xorshift generator from `seed`: uniform f32 in [0, 1) with 24 bits.
fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        ((s >> 40) as f64 * (1.0 / 16777216.0)) as f32
    }
}
