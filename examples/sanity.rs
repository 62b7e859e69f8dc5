use analytic_fog::*;
use glam::Vec3;
fn main() {
    let scene = Scene::new(SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff: 0.1,
            emission: glam::Vec3::ZERO,
            components: vec![Component {
                scattering: Vec3::new(0.02, 0.03, 0.05),
                absorption: Vec3::ZERO,
                phase: Phase::Isotropic,
            }],
        }],
        lighting: Lighting {
            ambient: Vec3::ONE,
            sun: None,
        },
        ..Default::default()
    })
    .unwrap();
    for (oy, dy, t) in [
        (5.0f32, 0.3f32, 100.0f32),
        (5.0, 0.0, 100.0),
        (5.0, -0.3, 10.0),
        (5.0, 0.3, f32::INFINITY),
        (5.0, -0.3, f32::INFINITY),
        (5.0, 1e-7, 1e7),
        (1e4, -1.0, 1e4),
        (0.0, 0.0, 0.0),
    ] {
        let d = Vec3::new((1.0 - dy * dy).sqrt(), dy, 0.0);
        let s = scene.eval_ray(Vec3::new(0.0, oy, 0.0), d, t);
        let (b, o, u, tt) = (0.1f64, oy as f64, dy as f64, t as f64);
        let x = b * u * tt;
        let phi = if x != 0.0 { -(-x).exp_m1() / x } else { 1.0 };
        let geo = (-b * o).exp() * tt * phi;
        let tau = 0.02 * geo;
        println!(
            "oy={oy} dy={dy} t={t}: tau_r={:e} ref={:e}  T={} Lin={}",
            s.tau.x, tau, s.transmittance.x, s.inscattering.x
        );
    }
}
