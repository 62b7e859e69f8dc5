//! The error of each composition of in-scattering against a ray-marched single-scattering
//! reference, on the two scenes of `reference::composition_scenes` (README, "Composition
//! of in-scattering"). Prints a markdown table.
//!
//! `cargo run --release --example composition [side] [steps]` (defaults 48 and 400: a
//! 48 × 48 view, 400 midpoint steps per piece of the march).

use analytic_fog::reference::{composition_rays, composition_scenes, marched_sample};
use analytic_fog::{Composition, Outputs, Rays, Scene, SceneDesc};

fn main() {
    let mut args = std::env::args().skip(1);
    let side: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(48);
    let steps: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(400);
    let rays = composition_rays(side);
    let n = rays.len();
    let col = |f: &dyn Fn(usize) -> f32| (0..n).map(f).collect::<Vec<f32>>();
    let o = [0, 1, 2].map(|k| col(&|i| rays[i].0[k] as f32));
    let d = [0, 1, 2].map(|k| col(&|i| rays[i].1[k] as f32));
    let t = col(&|i| rays[i].2 as f32);
    let batch = Rays::new(&o[0], &o[1], &o[2], &d[0], &d[1], &d[2], &t).expect("lengths");
    println!("{n} rays, march with {steps} steps per piece; |ΔL_in| per ray and channel");
    println!();
    println!("| scene | composition | max |ΔL|/L_max | mean |ΔL|/L_max | max |ΔL|/L (L ≥ 0.05 L_max) | mean |ΔL|/L (same rays) |");
    println!("| --- | --- | --: | --: | --: | --: |");
    for (name, desc) in composition_scenes() {
        let marched: Vec<[f64; 3]> = rays
            .iter()
            .map(|&(o, d, t)| marched_sample(&desc, o, d, t, steps).1)
            .collect();
        let l_max = marched
            .iter()
            .flat_map(|l| l.iter().copied())
            .fold(0.0, f64::max);
        for comp in [Composition::Mix, Composition::Ordered] {
            let scene = Scene::new(SceneDesc {
                composition: comp,
                ..desc.clone()
            })
            .expect("valid scene");
            let mut li: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; n]);
            {
                let [a, b, c] = &mut li;
                let out = Outputs {
                    tau: None,
                    transmittance: None,
                    inscattering: Some([a, b, c]),
                };
                scene.evaluate(&batch, out).expect("lengths");
            }
            let (mut max_a, mut sum_a, mut max_r, mut sum_r, mut cnt_r) =
                (0.0f64, 0.0, 0.0f64, 0.0, 0);
            for (i, m) in marched.iter().enumerate() {
                for ch in 0..3 {
                    let e = (li[ch][i] as f64 - m[ch]).abs();
                    max_a = max_a.max(e / l_max);
                    sum_a += e / l_max;
                    if m[ch] >= 0.05 * l_max {
                        max_r = max_r.max(e / m[ch]);
                        sum_r += e / m[ch];
                        cnt_r += 1;
                    }
                }
            }
            println!(
                "| {name} | {comp:?} | {:.2e} | {:.2e} | {:.2e} | {:.2e} |",
                max_a,
                sum_a / (3 * n) as f64,
                max_r,
                sum_r / cnt_r.max(1) as f64
            );
        }
    }
}
