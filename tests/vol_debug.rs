use analytic_fog::reference::volume as rv;
use analytic_fog::*;
use glam::*;
#[test]
fn dbg_seed004() {
    let sc = Vec3::new(0.3, -0.2, 4.0);
    let sr = 1.5f32;
    let sphere = Shape::Sphere {
        center: sc,
        radius: sr,
    };
    for (ro, rd, db) in [
        (Vec3::ZERO, (sc - Vec3::ZERO).normalize(), 1e30f32),
        (Vec3::ZERO, (sc + Vec3::new(0.5, 0.3, 0.0)).normalize(), 3.5),
    ] {
        let want = rv::compute_fog_seed004_f64(
            ro.as_dvec3(),
            rd.as_dvec3(),
            sc.as_dvec3(),
            sr as f64,
            db as f64,
        );
        let r = rv::volume_depth(
            &sphere,
            Profile::Quadratic,
            &[],
            ro.as_dvec3(),
            rd.as_dvec3(),
            db as f64,
        );
        let q = rv::volume_depth_quad(
            &sphere,
            Profile::Quadratic,
            &[],
            ro.as_dvec3(),
            rd.as_dvec3(),
            db as f64,
        );
        let c = rv::volume_depth_closed(
            &sphere,
            Profile::Quadratic,
            ro.as_dvec3(),
            rd.as_dvec3(),
            db as f64,
        );
        println!(
            "{want} {} {} {} |rd|-1={:e}",
            r * 0.75 / 1.5,
            q * 0.75 / 1.5,
            c * 0.75 / 1.5,
            rd.as_dvec3().length() - 1.0
        );
    }
}
