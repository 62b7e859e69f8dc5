//! Stability sweeps: the relative error of a height fog layer's optical depth τ, in f32,
//! for the crate's stable form and for the forms other code uses, against the f64
//! reference, over the ray's vertical direction d_up (1e-12 to 1, up and down) and over
//! the camera's height (far below to far above the fog's base).
//!
//! The forms (f32, std's `exp`), with x = b·d_up·t and ρ0 = e^(−b·(y − h0)):
//! - `seed000`: seed 000's two branches, σ/(b·d_up)·(ρ0 − e^(−b·(y − h0 + d_up·t))), or
//!   σ·ρ0·t for d_up = 0;
//! - `seed003`: seed 003's transformed form σ·ρ0·(1 − e^(−x))/(b·d_up), no branch but d_up = 0;
//! - `unreal_taylor`: σ·ρ0·t·(1 − e^(−x))/x, switching to the Taylor term 1 − x/2 below
//!   |x| = 0.01 (Unreal's exponential height fog, in base e);
//! - `hdrp_clamp`: seed 003's form with |d_up| clamped to at least 0.001 (as Unity HDRP
//!   clamps the direction);
//! - `stable`: this crate's kernel (`Scene::evaluate`, 8 lanes).

use crate::reference as rf;
use crate::{Component, HeightFogLayer, Outputs, Phase, Rays, Scene, SceneDesc};
use glam::{DVec3, Vec3};

/// The optical-depth forms compared: this crate's, seed 000's two branches, seed 003's
/// transformed form, Unreal's Taylor switch (|b·Δz| ≤ 0.01) and HDRP's clamped direction.
pub const FORMS: [&str; 5] = [
    "stable",
    "seed000",
    "seed003",
    "unreal_taylor",
    "hdrp_clamp",
];

/// One sweep: x values and, per form, the relative error of τ at each (NaN results are
/// stored as +∞).
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The sweep's name.
    pub name: &'static str,
    /// What varies, for the chart's axis.
    pub x_label: &'static str,
    /// The parameters held fixed, for the chart's caption.
    pub setup: String,
    /// The values swept.
    pub x: Vec<f64>,
    /// Per value, the relative error of τ of each of [`FORMS`].
    pub err: Vec<[f64; 5]>,
}

/// The stability sweeps (over d_up and over the camera height).
#[derive(Clone, Debug)]
pub struct Stability {
    /// One per sweep.
    pub sweeps: Vec<Sweep>,
}

fn tau_forms(sigma: f32, b: f32, y: f32, u: f32, t: f32) -> [f32; 4] {
    let rho0 = (-b * y).exp();
    let seed000 = sigma * super::seed000_geo(b, y, u, t);
    let seed003 = if u != 0.0 {
        sigma * rho0 * (1.0 - (-b * u * t).exp()) / (b * u)
    } else {
        sigma * rho0 * t
    };
    let x = b * u * t;
    let phi = if x.abs() > 0.01 {
        (1.0 - (-x).exp()) / x
    } else {
        1.0 - 0.5 * x
    };
    let unreal = sigma * rho0 * t * phi;
    let uc = if u < 0.0 {
        -u.abs().max(1e-3)
    } else {
        u.abs().max(1e-3)
    };
    let hdrp = sigma * rho0 * (1.0 - (-b * uc * t).exp()) / (b * uc);
    [seed000, seed003, unreal, hdrp]
}

fn rel(got: f32, want: f64) -> f64 {
    super::tau_rel_err(got as f64, want)
}

/// Evaluates the sweep's rays (origin height `ys[i]`, direction up-component `us[i]`).
#[allow(clippy::too_many_arguments)] // one call site per sweep, every argument named there
fn sweep(
    name: &'static str,
    x_label: &'static str,
    sigma: f32,
    b: f32,
    t: f32,
    xs: Vec<f64>,
    ys: Vec<f32>,
    us: Vec<f32>,
) -> Sweep {
    let desc = SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: b,
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::splat(sigma),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
            }],
        }],
        ..SceneDesc::default()
    };
    let scene = Scene::new(desc.clone()).expect("valid sweep scene");
    let n = xs.len();
    let dx: Vec<f32> = us.iter().map(|u| (1.0 - u * u).max(0.0).sqrt()).collect();
    let zero = vec![0.0f32; n];
    let ts = vec![t; n];
    let mut tau = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
    {
        let rays = Rays::new(&zero, &ys, &zero, &dx, &us, &zero, &ts)
            .expect("equal lengths")
            .with_unit_directions(true);
        let [a, bb, c] = &mut tau;
        scene
            .evaluate(
                &rays,
                Outputs {
                    tau: Some([a, bb, c]),
                    ..Outputs::default()
                },
            )
            .expect("equal lengths");
    }
    let err = (0..n)
        .map(|i| {
            let want = rf::height_fog_tau(
                &desc,
                DVec3::new(0.0, ys[i] as f64, 0.0),
                DVec3::new(dx[i] as f64, us[i] as f64, 0.0),
                t as f64,
            )[0];
            let f = tau_forms(sigma, b, ys[i], us[i], t);
            [
                rel(tau[0][i], want),
                rel(f[0], want),
                rel(f[1], want),
                rel(f[2], want),
                rel(f[3], want),
            ]
        })
        .collect();
    Sweep {
        name,
        x_label,
        setup: format!("sigma_t {sigma:e}, falloff {b}, t {t}"),
        x: xs,
        err,
    }
}

/// Runs the sweeps (a few milliseconds).
pub fn run() -> Stability {
    let mut sweeps = vec![];
    // d_up from 1e-12 to 1, camera 2 above the base, 1000 long: x = b·d_up·t spans
    // 1e-10 to 100 (upward) and −1e-10 to −100 (downward).
    let ks: Vec<f64> = (0..=96).map(|i| -12.0 + i as f64 * 0.125).collect();
    for (name, sign) in [("d_up_upward", 1.0f32), ("d_up_downward", -1.0f32)] {
        let us: Vec<f32> = ks.iter().map(|k| sign * 10f64.powf(*k) as f32).collect();
        let xs = us.iter().map(|u| u.abs() as f64).collect();
        let ys = vec![2.0f32; us.len()];
        sweeps.push(sweep(
            name,
            if sign > 0.0 { "d_up" } else { "-d_up" },
            0.02,
            0.1,
            1000.0,
            xs,
            ys,
            us,
        ));
    }
    // Camera height from 110 scale heights below the base to 60 above, looking up at
    // d_up = 0.3 over 10 scale heights: the true τ stays within the f32 range throughout.
    let ys: Vec<f32> = (0..=170).map(|i| -110.0 + i as f32).collect();
    let xs = ys.iter().map(|y| *y as f64).collect();
    let us = vec![0.3f32; ys.len()];
    sweeps.push(sweep(
        "camera_height",
        "camera height / scale height",
        1e-10,
        1.0,
        10.0,
        xs,
        ys,
        us,
    ));
    Stability { sweeps }
}

impl Stability {
    /// Max relative error per form and sweep, as text.
    pub fn summary(&self) -> String {
        let mut s = String::from("stability: max relative error of tau (f32) against f64\n");
        s.push_str(&format!("  {:<14}", "sweep"));
        for f in FORMS {
            s.push_str(&format!(" {f:>13}"));
        }
        s.push('\n');
        for sw in &self.sweeps {
            s.push_str(&format!("  {:<14}", sw.name));
            for k in 0..5 {
                let m = sw.err.iter().map(|e| e[k]).fold(0.0, f64::max);
                s.push_str(&format!(" {:>13}", super::fmt_e(m)));
            }
            s.push('\n');
        }
        s
    }

    /// The sweeps as CSV: `sweep,x` and one column per form.
    pub fn to_csv(&self) -> String {
        let mut s = String::from("sweep,x");
        for f in FORMS {
            s.push_str(&format!(",{f}"));
        }
        s.push('\n');
        for sw in &self.sweeps {
            for (x, e) in sw.x.iter().zip(&sw.err) {
                s.push_str(&format!("{},{x:e}", sw.name));
                for v in e {
                    s.push_str(&format!(",{v:e}"));
                }
                s.push('\n');
            }
        }
        s
    }

    /// The sweeps as JSON (non-finite errors as `null`).
    pub fn to_json(&self) -> serde_json::Value {
        let num = |x: f64| {
            if x.is_finite() {
                serde_json::json!(x)
            } else {
                serde_json::Value::Null
            }
        };
        serde_json::Value::Array(
            self.sweeps
                .iter()
                .map(|sw| {
                    let mut forms = serde_json::Map::new();
                    for (k, f) in FORMS.iter().enumerate() {
                        forms.insert(
                            f.to_string(),
                            serde_json::Value::Array(sw.err.iter().map(|e| num(e[k])).collect()),
                        );
                    }
                    serde_json::json!({
                        "sweep": sw.name, "x_label": sw.x_label, "setup": sw.setup,
                        "x": sw.x, "tau_rel_err": forms,
                    })
                })
                .collect(),
        )
    }
}
