//! `analytic-fog render`: a small ray caster (a height-field terrain or a ground plane, a
//! few spheres, a sky gradient with a sun disc) produces depth and colour, the
//! framebuffer pass (`Scene::fog_pass`) fogs it, and the result is written as PNG.
//!
//! The render scene file wraps a fog scene:
//!
//! ```json
//! { "fog": { ...the scene JSON of `eval`... },
//!   "camera": { "position": [0, 3, 0], "look_at": [0, 2, -50], "fov_y_degrees": 60 },
//!   "sky": { "zenith": [0.15, 0.3, 0.6], "horizon": [0.7, 0.75, 0.8] },
//!   "terrain": { "height": 0, "amplitude": 8, "wavelength": 60, "colour": [0.25, 0.3, 0.15] },
//!   "spheres": [ { "center": [5, 3, -30], "radius": 3, "colour": [0.6, 0.6, 0.6] } ],
//!   "exposure": 1.0 }
//! ```

use crate::CliResult;
use analytic_fog::pass::{Camera, ColourBuffer, Depth, DepthConvention};
use analytic_fog::{Scene, SceneDesc};
use glam::Vec3;
use rayon::prelude::*;
use serde::Deserialize;
use std::path::Path;
use std::time::Instant;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub struct RenderScene {
    fog: SceneDesc,
    camera: CameraDesc,
    #[serde(default)]
    sky: Sky,
    #[serde(default)]
    terrain: Terrain,
    #[serde(default)]
    spheres: Vec<Sphere>,
    #[serde(default = "one")]
    exposure: f32,
}

fn one() -> f32 {
    1.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct CameraDesc {
    position: [f32; 3],
    look_at: [f32; 3],
    #[serde(default = "default_fov")]
    fov_y_degrees: f32,
}

fn default_fov() -> f32 {
    60.0
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Sky {
    zenith: [f32; 3],
    horizon: [f32; 3],
}

impl Default for Sky {
    fn default() -> Sky {
        Sky {
            zenith: [0.15, 0.3, 0.6],
            horizon: [0.7, 0.75, 0.8],
        }
    }
}

/// y = height + amplitude · (a sum of three octaves of sines), amplitude 0: a plane.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Terrain {
    #[serde(default)]
    height: f32,
    #[serde(default)]
    amplitude: f32,
    #[serde(default = "default_wavelength")]
    wavelength: f32,
    #[serde(default = "default_ground")]
    colour: [f32; 3],
}

fn default_wavelength() -> f32 {
    60.0
}
fn default_ground() -> [f32; 3] {
    [0.25, 0.3, 0.15]
}

impl Default for Terrain {
    fn default() -> Terrain {
        Terrain {
            height: 0.0,
            amplitude: 0.0,
            wavelength: default_wavelength(),
            colour: default_ground(),
        }
    }
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
struct Sphere {
    center: [f32; 3],
    radius: f32,
    colour: [f32; 3],
}

impl Terrain {
    fn h(&self, x: f32, z: f32) -> f32 {
        if self.amplitude == 0.0 {
            return self.height;
        }
        let k = std::f32::consts::TAU / self.wavelength;
        let mut s = 0.0;
        let mut a = 1.0;
        let mut f = 1.0;
        for (px, pz) in [(0.3f32, 1.7f32), (2.1, 0.4), (1.3, 2.9)] {
            s += a * ((x * k * f + px).sin() * (z * k * f * 0.8 + pz).cos());
            a *= 0.45;
            f *= 2.3;
        }
        self.height + self.amplitude * s
    }

    /// The first hit of o + s·d (d unit) with the terrain, s in (0, far]: marching
    /// with steps proportional to the height above the terrain, then bisection.
    fn hit(&self, o: Vec3, d: Vec3, far: f32) -> Option<f32> {
        if self.amplitude == 0.0 {
            let s = (self.height - o.y) / d.y;
            return (s > 0.0 && s <= far).then_some(s);
        }
        let top = self.height + 1.6 * self.amplitude.abs();
        let mut s = 0.0f32;
        let mut prev = 0.0f32;
        while s < far {
            let p = o + d * s;
            if d.y > 0.0 && p.y > top {
                return None;
            }
            let gap = p.y - self.h(p.x, p.z);
            if gap < 0.0 {
                let (mut lo, mut hi) = (prev, s);
                for _ in 0..12 {
                    let mid = 0.5 * (lo + hi);
                    let q = o + d * mid;
                    if q.y - self.h(q.x, q.z) < 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some(hi);
            }
            prev = s;
            s += (0.4 * gap).max(0.02 + 0.002 * s);
        }
        None
    }

    fn normal(&self, p: Vec3) -> Vec3 {
        let e = 0.05 * self.wavelength.max(1.0) / 60.0;
        let dx = self.h(p.x + e, p.z) - self.h(p.x - e, p.z);
        let dz = self.h(p.x, p.z + e) - self.h(p.x, p.z - e);
        Vec3::new(-dx, 2.0 * e, -dz).normalize()
    }
}

/// Colour and linear view depth of every pixel (row 0 at the top).
fn cast(
    rs: &RenderScene,
    camera: &Camera,
    w: usize,
    h: usize,
    sun: Option<(Vec3, Vec3)>,
) -> (Vec<f32>, Vec<f32>) {
    let far = 5000.0f32;
    let amb = Vec3::from_array(rs.fog.lighting.ambient.to_array());
    let rows: Vec<(Vec<f32>, Vec<f32>)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut col = vec![0.0f32; w * 3];
            let mut dep = vec![0.0f32; w];
            for x in 0..w {
                // The pass's own ray for this pixel (forward component 1), so that the
                // depth written is exactly what the pass reads back.
                let r = camera
                    .pixel_ray(x, y, w, h, 1.0, DepthConvention::LinearView)
                    .expect("pixel in frame");
                let len = r.direction.length();
                let d = r.direction / len;
                let mut best: Option<(f32, Vec3, Vec3)> = None;
                if let Some(s) = rs.terrain.hit(r.origin, d, far) {
                    let p = r.origin + d * s;
                    let n = rs.terrain.normal(p);
                    best = Some((s, n, Vec3::from_array(rs.terrain.colour)));
                }
                for sp in &rs.spheres {
                    let c = Vec3::from_array(sp.center);
                    let q = r.origin - c;
                    let b = q.dot(d);
                    let disc = b * b - (q.length_squared() - sp.radius * sp.radius);
                    if disc >= 0.0 {
                        let s = -b - disc.sqrt();
                        if s > 0.0 && best.is_none_or(|(bs, _, _)| s < bs) {
                            let n = (q + d * s) / sp.radius;
                            best = Some((s, n, Vec3::from_array(sp.colour)));
                        }
                    }
                }
                let c =
                    match best {
                        Some((s, n, albedo)) => {
                            dep[x] = s / len; // distance along d → view depth
                            let lit = sun.map_or(Vec3::ZERO, |(sd, e)| e * n.dot(sd).max(0.0));
                            albedo * (amb + lit * 0.05)
                        }
                        None => {
                            dep[x] = f32::INFINITY;
                            let t = d.y.max(0.0).sqrt();
                            let sky = Vec3::from_array(rs.sky.horizon)
                                .lerp(Vec3::from_array(rs.sky.zenith), t);
                            let disc = sun.map_or(Vec3::ZERO, |(sd, e)| {
                                if d.dot(sd) > 0.9995 {
                                    e
                                } else {
                                    Vec3::ZERO
                                }
                            });
                            sky + disc
                        }
                    };
                col[3 * x..3 * x + 3].copy_from_slice(&c.to_array());
            }
            (col, dep)
        })
        .collect();
    let mut colour = Vec::with_capacity(w * h * 3);
    let mut depth = Vec::with_capacity(w * h);
    for (c, d) in rows {
        colour.extend(c);
        depth.extend(d);
    }
    (colour, depth)
}

/// sRGB transfer of a tone-mapped linear value (1 − e^(−exposure·x)).
fn to_srgb8(x: f32, exposure: f32) -> u8 {
    let v = 1.0 - (-exposure * x.max(0.0)).exp();
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

pub fn render(
    scene_path: &Path,
    width: u32,
    height: u32,
    out: &Path,
    quiet: bool,
) -> CliResult<()> {
    let name = scene_path.display().to_string();
    let text = std::fs::read(scene_path).map_err(|e| format!("{name}: cannot read: {e}"))?;
    let rs: RenderScene = serde_json::from_slice(&text)
        .map_err(|e| format!("{name}:{}:{}: {}", e.line(), e.column(), e))?;
    let scene = Scene::new(rs.fog.clone()).map_err(|e| format!("{name}: fog.{e}"))?;
    let (w, h) = (width as usize, height as usize);
    let cam = &rs.camera;
    let pos = Vec3::from_array(cam.position);
    let fwd = Vec3::from_array(cam.look_at) - pos;
    let camera = Camera::perspective(
        pos,
        fwd,
        Vec3::Y,
        cam.fov_y_degrees.to_radians(),
        w as f32 / h as f32,
    )
    .map_err(|e| format!("{name}: camera: {e}"))?;
    let sun = rs.fog.lighting.sun.as_ref().map(|s| {
        (
            s.direction.normalize(),
            Vec3::from_array(s.radiance.to_array()),
        )
    });
    let t0 = Instant::now();
    let (mut colour, depth) = cast(&rs, &camera, w, h, sun);
    let t_cast = t0.elapsed();
    let t1 = Instant::now();
    scene
        .fog_pass(
            &camera,
            w,
            h,
            Depth::linear_view(&depth),
            ColourBuffer::Rgb(&mut colour),
        )
        .map_err(|e| format!("{name}: {e}"))?;
    let t_fog = t1.elapsed();
    let pixels: Vec<u8> = colour.iter().map(|&x| to_srgb8(x, rs.exposure)).collect();
    let oname = out.display().to_string();
    let file = std::fs::File::create(out).map_err(|e| format!("{oname}: cannot create: {e}"))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc
        .write_header()
        .map_err(|e| format!("{oname}: cannot write: {e}"))?;
    wr.write_image_data(&pixels)
        .map_err(|e| format!("{oname}: cannot write: {e}"))?;
    wr.finish()
        .map_err(|e| format!("{oname}: cannot write: {e}"))?;
    if !quiet {
        eprintln!(
            "analytic-fog render: {w}x{h}, fog pass {:.2} ms ({:.2} ns/pixel, {} threads, simd {}), ray casting {:.1} ms -> {oname}",
            t_fog.as_secs_f64() * 1e3,
            t_fog.as_secs_f64() * 1e9 / (w * h) as f64,
            rayon::current_num_threads(),
            crate::simd(),
            t_cast.as_secs_f64() * 1e3
        );
    }
    Ok(())
}
