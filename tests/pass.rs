//! The framebuffer fog pass (`analytic_fog::pass`): with the batch API's kernel
//! (`Scene::with_batch_kernel_pass`), every pixel equals the batch API's result for the ray
//! `Camera::pixel_ray` returns (bit for bit, including the final multiply-add); with the
//! pass's own one-layer kernel, every pixel is within the crate's accuracy bound of the
//! independent f64 reference and close to the batch API; on random cameras, depths (sky
//! included), every depth convention, every colour layout and frame sizes with row tails;
//! `pixel_ray` against an independent f64 unprojection; errors naming the buffer.

use analytic_fog::math::Lane;
use analytic_fog::pass::{Camera, ColourBuffer, Depth, DepthConvention, PixelRay, Projection};
use analytic_fog::reference::{self, check_sample};
use analytic_fog::{
    Component, Composition, FogSample, HeightFogLayer, Lighting, Outputs, PassError, Phase, Rays,
    Scene, SceneDesc, Sun, Tier,
};
use glam::{DMat4, DVec3, Mat4, Vec3};

/// xorshift64*, deterministic.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in [0, 1).
    fn f(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.f()
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn unit(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            if v.length() > 0.2 && v.length() < 1.0 {
                return v.normalize();
            }
        }
    }
    /// A random unit vector at least about 6° away from ±`fwd` (a camera's up vector).
    fn up_for(&mut self, fwd: Vec3) -> Vec3 {
        loop {
            let u = self.unit();
            if u.cross(fwd).length() > 0.1 {
                return u;
            }
        }
    }
    /// A point uniform in the cube [−h, h]³.
    fn cube(&mut self, h: f32) -> Vec3 {
        Vec3::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
    }
}

fn component(rng: &mut Rng, phase: Phase) -> Component {
    Component {
        scattering: Vec3::new(
            rng.range(0.0, 0.05),
            rng.range(0.0, 0.05),
            rng.range(0.0, 0.05),
        ),
        absorption: Vec3::splat(rng.range(0.0, 0.01)),
        phase,
    }
}

/// Scene kinds: 0 = one RGB layer with HG sun and ambient (the pass's fast path),
/// 1 = two layers (general kernel), 2 = a tilted up vector, 3 = one layer, X up, Rayleigh.
fn scene(rng: &mut Rng, kind: usize) -> Scene {
    let layer = |rng: &mut Rng, phase| HeightFogLayer {
        base_height: rng.range(-5.0, 5.0),
        falloff: rng.range(0.01, 0.5),
        emission: glam::Vec3::ZERO,
        components: vec![component(rng, phase)],
    };
    let g = rng.range(-0.9, 0.9);
    let height_fog = match kind {
        1 => vec![
            layer(rng, Phase::HenyeyGreenstein(g)),
            layer(rng, Phase::Isotropic),
        ],
        3 => vec![layer(rng, Phase::Rayleigh)],
        _ => vec![layer(rng, Phase::HenyeyGreenstein(g))],
    };
    let up = match kind {
        2 => Vec3::new(0.2, 1.0, -0.3),
        3 => Vec3::X,
        _ => Vec3::Y,
    };
    Scene::new(SceneDesc {
        up,
        height_fog,
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: rng.unit(),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        },
        ..SceneDesc::default()
    })
    .unwrap()
}

fn camera(rng: &mut Rng, w: usize, h: usize) -> Camera {
    let pos = Vec3::new(
        rng.range(-50.0, 50.0),
        rng.range(-5.0, 30.0),
        rng.range(-50.0, 50.0),
    );
    let fwd = rng.unit();
    let up = rng.up_for(fwd);
    let aspect = w as f32 / h as f32;
    match rng.below(4) {
        0 => Camera::perspective(pos, fwd, up, rng.range(0.2, 2.8), aspect).unwrap(),
        1 => Camera::orthographic(pos, fwd, up, rng.range(1.0, 100.0), aspect).unwrap(),
        2 => {
            let view = Mat4::look_at_rh(pos, pos + fwd, up);
            let proj = if rng.below(2) == 0 {
                Mat4::perspective_rh_gl(rng.range(0.3, 2.0), aspect, 0.1, 500.0)
            } else {
                Mat4::perspective_infinite_reverse_rh(rng.range(0.3, 2.0), aspect, 0.05)
            };
            let position = if rng.below(2) == 0 { Some(pos) } else { None };
            Camera::from_inverse_view_projection((proj * view).inverse(), position).unwrap()
        }
        _ => {
            let view = Mat4::look_at_rh(pos, pos + fwd, up);
            let proj = Mat4::orthographic_rh(-7.0, 5.0, -3.0, 4.0, 0.5, 300.0);
            Camera::from_inverse_view_projection((proj * view).inverse(), Some(pos)).unwrap()
        }
    }
}

/// A camera position and a forward direction at least 0.1 rad off the axis `up`.
fn upright_pose(rng: &mut Rng, up: Vec3) -> (Vec3, Vec3) {
    let pos = Vec3::new(
        rng.range(-50.0, 50.0),
        rng.range(-5.0, 30.0),
        rng.range(-50.0, 50.0),
    );
    let fwd = loop {
        let f = rng.unit();
        if f.cross(up).length() > 0.1 {
            break f;
        }
    };
    (pos, fwd)
}

/// A perspective camera upright in a scene whose up is the axis `up`: every row of its
/// frame has one u = dot(d, up) (d_u ⊥ up exactly), the rows the own kernel runs with a
/// product for the division of g' (`RowFactor`).
fn upright_camera(rng: &mut Rng, w: usize, h: usize, up: Vec3) -> Camera {
    let (pos, fwd) = upright_pose(rng, up);
    Camera::perspective(pos, fwd, up, rng.range(0.2, 2.8), w as f32 / h as f32).unwrap()
}

/// An orthographic camera upright in a scene whose up is the axis `up` (its horizontal
/// axis ⊥ up exactly): every pixel of a row starts at the row's height, the frames the own
/// kernel runs with the density per row.
fn upright_ortho_camera(rng: &mut Rng, w: usize, h: usize, up: Vec3) -> Camera {
    let (pos, fwd) = upright_pose(rng, up);
    Camera::orthographic(pos, fwd, up, rng.range(1.0, 100.0), w as f32 / h as f32).unwrap()
}

fn convention(rng: &mut Rng, cam: &Camera) -> DepthConvention {
    let persp = cam.projection() == Projection::Perspective;
    match rng.below(4) {
        0 => DepthConvention::LinearView,
        1 => DepthConvention::Distance,
        k => {
            let near = if persp {
                rng.range(0.01, 1.0)
            } else {
                rng.range(-5.0, 5.0)
            };
            let far = if persp && rng.below(3) == 0 {
                f32::INFINITY
            } else {
                near + rng.range(10.0, 1000.0)
            };
            DepthConvention::NdcZeroToOne {
                near,
                far,
                reversed: k == 3,
            }
        }
    }
}

/// Random depth values for a convention, sky pixels included.
fn depths(rng: &mut Rng, conv: DepthConvention, n: usize) -> Vec<f32> {
    (0..n)
        .map(|_| {
            let r = rng.below(10);
            match conv {
                DepthConvention::LinearView | DepthConvention::Distance => match r {
                    0 => f32::INFINITY,
                    1 => 0.0,
                    2 => -1.0,
                    3 => rng.range(1e3, 1e6),
                    _ => rng.range(0.0, 200.0),
                },
                DepthConvention::NdcZeroToOne { reversed, .. } => match r {
                    0 => f32::from(u8::from(!reversed)), // the far plane: sky
                    1 => f32::from(u8::from(reversed)),  // the near plane
                    2 => f32::INFINITY,
                    3 => 1.0 - rng.f() * 1e-3,
                    4 => rng.f() * 1e-3,
                    _ => rng.f(),
                },
            }
        })
        .collect()
}

/// The surface value whose fogged result recovers T: 2^120·T + L_in is rounded once, and
/// 2^120 is far above every L_in of these scenes.
const BIG: f32 = 1.329_228e36; // 2^120 exactly (1.329228e36 rounds to it)

/// T from one pixel fogged over a surface of [`BIG`] (`white`) and over black (`black`,
/// which is L_in exactly): (white − black) / 2^120 in f64.
fn recover_t(white: f32, black: f32) -> f32 {
    ((white as f64 - black as f64) / BIG as f64) as f32
}

/// Checks a pixel's T and L_in against the f64 reference with the crate's bound
/// (`reference::check_sample`); τ is taken from the reference, the pass having no τ
/// output. Returns the reference's sample for further comparisons.
fn check_pixel(
    desc: &SceneDesc,
    ray: &PixelRay,
    t: [f32; 3],
    l: [f32; 3],
    ctx: impl Fn() -> String,
) -> (reference::RefSample, reference::SampleCheck) {
    let r = reference::sample(
        desc,
        ray.origin.as_dvec3(),
        ray.direction.as_dvec3(),
        ray.t as f64,
    );
    let got = FogSample {
        tau: Vec3::from_array(r.tau.map(|v| v as f32)),
        transmittance: Vec3::from_array(t),
        inscattering: Vec3::from_array(l),
    };
    let chk = check_sample(desc, ray.origin, ray.direction, ray.t, &got);
    assert!(chk.passed(), "{:?}: {}", chk.failure, ctx());
    (r, chk)
}

/// Transmittance and in-scattering from the batch API for the rays of `pixel_ray`.
fn batch_reference(
    scene: &Scene,
    cam: &Camera,
    w: usize,
    h: usize,
    depth: &[f32],
    conv: DepthConvention,
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let n = w * h;
    let mut c: [Vec<f32>; 7] = Default::default();
    for y in 0..h {
        for x in 0..w {
            let r = cam.pixel_ray(x, y, w, h, depth[y * w + x], conv).unwrap();
            for (k, v) in [
                r.origin.x,
                r.origin.y,
                r.origin.z,
                r.direction.x,
                r.direction.y,
                r.direction.z,
                r.t,
            ]
            .into_iter()
            .enumerate()
            {
                c[k].push(v);
            }
        }
    }
    let rays = Rays::new(&c[0], &c[1], &c[2], &c[3], &c[4], &c[5], &c[6]).unwrap();
    let (mut tr, mut tg, mut tb) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut lr, mut lg, mut lb) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    scene
        .evaluate(
            &rays,
            Outputs {
                transmittance: Some([&mut tr, &mut tg, &mut tb]),
                inscattering: Some([&mut lr, &mut lg, &mut lb]),
                ..Outputs::default()
            },
        )
        .unwrap();
    let t = (0..n).map(|i| [tr[i], tg[i], tb[i]]).collect();
    let l = (0..n).map(|i| [lr[i], lg[i], lb[i]]).collect();
    (t, l)
}

const SIZES: [(usize, usize); 11] = [
    (1, 1),
    (7, 3),
    (17, 5),
    (33, 9),
    (8, 2),
    (16, 1),
    (1, 13),
    (9, 8),
    (64, 4),
    (29, 3),
    (40, 2),
];

#[test]
fn pass_equals_batch_api_bit_for_bit() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut pixels = 0usize;
    let mut sky = 0usize;
    for case in 0..400 {
        let (w, h) = SIZES[case % SIZES.len()];
        let scene = scene(&mut rng, case % 4).with_batch_kernel_pass();
        let cam = camera(&mut rng, w, h);
        let conv = convention(&mut rng, &cam);
        let depth = depths(&mut rng, conv, w * h);
        let (tr, li) = batch_reference(&scene, &cam, w, h, &depth, conv);
        let n = w * h;
        let surface: Vec<[f32; 3]> = (0..n)
            .map(|_| {
                [
                    rng.range(0.0, 4.0),
                    rng.range(0.0, 4.0),
                    rng.range(0.0, 4.0),
                ]
            })
            .collect();
        let alpha: Vec<f32> = (0..n).map(|_| rng.f()).collect();
        let expect =
            |i: usize, c: usize| -> f32 { Lane::mul_add(surface[i][c], tr[i][c], li[i][c]) };
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        // One thread, rayon, and one thread without the run-time AVX-512 lanes (the
        // pass's batch-kernel rows of one layer take them where `avx512_dispatch()`).
        for mode in 0..3 {
            let par = mode == 1;
            let sc = if mode == 2 {
                scene.clone().without_avx512_dispatch()
            } else {
                scene.clone()
            };
            let run = |colour: ColourBuffer<'_>| {
                if par {
                    sc.fog_pass(&cam, w, h, d, colour)
                } else {
                    sc.fog_pass_single(&cam, w, h, d, colour)
                }
            };
            // Interleaved RGB.
            let mut rgb: Vec<f32> = surface.iter().flatten().copied().collect();
            run(ColourBuffer::Rgb(&mut rgb)).unwrap();
            // Interleaved RGBA.
            let mut rgba: Vec<f32> = (0..n)
                .flat_map(|i| [surface[i][0], surface[i][1], surface[i][2], alpha[i]])
                .collect();
            run(ColourBuffer::Rgba(&mut rgba)).unwrap();
            // Planar.
            let mut planes: [Vec<f32>; 3] =
                [0, 1, 2].map(|c| surface.iter().map(|s| s[c]).collect());
            let [pr, pg, pb] = &mut planes;
            run(ColourBuffer::Planar([pr, pg, pb])).unwrap();
            for i in 0..n {
                for c in 0..3 {
                    let e = expect(i, c);
                    let ctx = || {
                        format!(
                            "case {case}, {w}x{h}, pixel ({}, {}), channel {c}, mode {mode}, {conv:?}, {cam:?}, depth {}",
                            i % w,
                            i / w,
                            depth[i]
                        )
                    };
                    assert_eq!(rgb[3 * i + c].to_bits(), e.to_bits(), "RGB {}", ctx());
                    assert_eq!(rgba[4 * i + c].to_bits(), e.to_bits(), "RGBA {}", ctx());
                    assert_eq!(planes[c][i].to_bits(), e.to_bits(), "planar {}", ctx());
                    // Finite inputs (depth finite or +inf): no NaN.
                    if !depth[i].is_nan() {
                        assert!(!e.is_nan(), "NaN for finite input: {}", ctx());
                    }
                }
                assert_eq!(
                    rgba[4 * i + 3].to_bits(),
                    alpha[i].to_bits(),
                    "alpha touched"
                );
            }
        }
        pixels += n;
        for (i, &z) in depth.iter().enumerate() {
            let r = cam.pixel_ray(i % w, i / w, w, h, z, conv).unwrap();
            sky += usize::from(r.t == f32::INFINITY);
        }
    }
    assert!(sky > 100, "too few sky pixels: {sky} of {pixels}");
}

/// The pass is the same as `Scene::eval_ray` (the scalar path) too, and a large frame
/// (many bands, so rayon really splits it) gives the same bits in parallel and single.
#[test]
fn large_frame_parallel_equals_single_and_eval_ray() {
    let mut rng = Rng(7);
    let scene = scene(&mut rng, 0);
    let (w, h) = (203, 117);
    let cam = Camera::perspective(
        Vec3::new(3.0, 2.0, 1.0),
        Vec3::new(0.2, -0.1, -1.0),
        Vec3::Y,
        1.1,
        w as f32 / h as f32,
    )
    .unwrap();
    let conv = DepthConvention::NdcZeroToOne {
        near: 0.1,
        far: f32::INFINITY,
        reversed: true,
    };
    let depth = depths(&mut rng, conv, w * h);
    let d = Depth::ndc_reversed(&depth, 0.1, f32::INFINITY);
    let surface: Vec<f32> = (0..3 * w * h).map(|_| rng.range(0.0, 2.0)).collect();
    // Fogs the frame in parallel and on one thread; asserts the same bits.
    let par_equals_single = |scene: &Scene| -> Vec<f32> {
        let mut a = surface.clone();
        let mut b = surface.clone();
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut a))
            .unwrap();
        scene
            .fog_pass_single(&cam, w, h, d, ColourBuffer::Rgb(&mut b))
            .unwrap();
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
        a
    };
    // The pass's own kernel: parallel = single, bit for bit.
    assert!(scene
        .fog_pass_own_kernel(&cam, w, h, conv)
        .unwrap()
        .is_some());
    par_equals_single(&scene);
    // The batch API's kernel: parallel = single = `eval_ray`, bit for bit.
    let scene = scene.with_batch_kernel_pass();
    let a = par_equals_single(&scene);
    for i in (0..w * h).step_by(37).chain([w - 1, w * h - 1]) {
        let r = cam.pixel_ray(i % w, i / w, w, h, depth[i], conv).unwrap();
        let f = scene.eval_ray(r.origin, r.direction, r.t);
        for c in 0..3 {
            let e = Lane::mul_add(surface[3 * i + c], f.transmittance[c], f.inscattering[c]);
            assert_eq!(a[3 * i + c].to_bits(), e.to_bits(), "pixel {i} channel {c}");
        }
    }
}

/// The pass's own one-layer kernel (perspective and upright orthographic cameras,
/// `Scene::fog_pass_own_kernel`)
/// against the independent f64 reference with the crate's bound
/// (`reference::check_sample`): L_in is the result for a black surface (exactly), T is
/// recovered from a surface of 2^120 (2^120·T + L_in, rounded once, minus L_in in f64),
/// and τ is taken from the reference (the pass has no τ output). Random scenes (the
/// default kinds, grey, unlit and two-phase variants, and a stiff variant: falloff up to
/// 4, cameras up to 300 above or below the base), cameras, depths and frame sizes, in the
/// three colour layouts (same bits); frames the own kernel declines are checked
/// too (they run the batch kernel). Also against the batch API: T within 1e-5, L_in
/// within 1e-5 of the colour scale. Where AVX-512 is chosen at run time, the AVX2 lanes'
/// results (8 and 16 lanes, the same bits) are checked against the reference as well,
/// and against the AVX-512 lanes': T within 4e-7, L_in within 1e-6 of the colour scale.
#[test]
fn own_kernel_within_the_accuracy_bound() {
    assert_eq!(BIG, 2f32.powi(120));
    let mut rng = Rng(0x0dd_ba11);
    let (mut own, mut declined, mut pixels, mut worst) = (0, 0, 0usize, 0.0f64);
    let (mut uniform_frames, mut uniform_rows) = (0, 0);
    let (mut dt_max, mut dl_max) = (0.0f32, 0.0f64);
    let (mut dz_t, mut dz_l) = (0.0f32, 0.0f64);
    let (mut linear_frames, mut dz_l_linear, mut worst_linear) = (0usize, 0.0f64, 0.0f64);
    let (mut ortho_frames, mut ortho_ndc, mut worst_ortho) = (0usize, 0usize, 0.0f64);
    for case in 0..240 {
        let (w, h) = SIZES[case % SIZES.len()];
        let kind = [0, 2, 3][case % 3];
        let mut desc = scene(&mut rng, kind).desc().clone();
        if case % 4 == 3 {
            let l = &mut desc.height_fog[0];
            l.falloff = rng.range(-4.0, 4.0);
            l.base_height = rng.range(-300.0, 300.0);
            l.components[0].scattering *= rng.range(0.1, 100.0);
        }
        // The kernel's variants: grey extinction (one exponential), no sun (no phase
        // function), two phase functions (the general colour path).
        match case % 5 {
            1 => {
                let c = &mut desc.height_fog[0].components[0];
                c.scattering = Vec3::splat(c.scattering.x);
            }
            2 => desc.lighting.sun = None,
            3 => {
                let extra = component(&mut rng, Phase::CornetteShanks(0.5));
                desc.height_fog[0].components.push(extra);
            }
            _ => {}
        }
        let scene = Scene::new(desc.clone()).unwrap();
        // Every other frame from an upright camera (the scene's up, or +y where that is
        // not an axis), every other one of those orthographic.
        let cam = if case % 2 == 0 {
            let up = [Vec3::X, Vec3::Y, Vec3::Z]
                .into_iter()
                .find(|&a| a == desc.up)
                .unwrap_or(Vec3::Y);
            if case % 4 == 2 {
                upright_ortho_camera(&mut rng, w, h, up)
            } else {
                upright_camera(&mut rng, w, h, up)
            }
        } else {
            camera(&mut rng, w, h)
        };
        let conv = convention(&mut rng, &cam);
        let frame = scene.fog_pass_own_kernel(&cam, w, h, conv).unwrap();
        let ortho = frame.is_some() && cam.projection() == Projection::Orthographic;
        if frame.is_some() {
            own += 1;
            ortho_frames += usize::from(ortho);
            ortho_ndc += usize::from(ortho && matches!(conv, DepthConvention::NdcZeroToOne { .. }));
        } else {
            declined += 1;
        }
        let linear = frame.is_some_and(|f| f.linear_phase);
        linear_frames += usize::from(linear);
        let rows = frame.map_or(0, |f| f.uniform_rows);
        uniform_frames += usize::from(rows > 0);
        uniform_rows += rows;
        let depth = depths(&mut rng, conv, w * h);
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        let n = w * h;
        let mut black = [vec![0.0f32; n], vec![0.0; n], vec![0.0; n]];
        let mut white = [vec![BIG; n], vec![BIG; n], vec![BIG; n]];
        let [r, g, b] = &mut black;
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Planar([r, g, b]))
            .unwrap();
        let [r, g, b] = &mut white;
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Planar([r, g, b]))
            .unwrap();
        // The interleaved layouts give the same bits (RGB takes its own path in the own
        // kernel: T and L_in in the buffer's layout).
        // Where the own kernel runs AVX-512 lanes chosen at run time, its estimate of 1/√x
        // is AVX-512's (`vrsqrt14ps`): other last bits than the AVX2 widths, which give
        // the same bits as each other; each is held to the bound below.
        let own_zmm = analytic_fog::avx512_dispatch() && frame.is_some();
        // The AVX2 lanes' results for the black and the white surface, RGB.
        let mut avx2 = [vec![0.0f32; 3 * n], vec![0.0f32; 3 * n]];
        for (k, (surface, planes)) in [(0.0, &black), (BIG, &white)].into_iter().enumerate() {
            let mut rgb = vec![surface; 3 * n];
            scene
                .fog_pass_single(&cam, w, h, d, ColourBuffer::Rgb(&mut rgb))
                .unwrap();
            let mut rgba = vec![surface; 4 * n];
            scene
                .fog_pass(&cam, w, h, d, ColourBuffer::Rgba(&mut rgba))
                .unwrap();
            // The own kernel 8 lanes wide: the same bits as the build's width (16 lanes in
            // an AVX-512 build, where this compares two instantiations).
            let mut rgb8 = vec![surface; 3 * n];
            scene
                .clone()
                .with_pass_lanes_8()
                .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut rgb8))
                .unwrap();
            // And 16 lanes without the run-time AVX-512 dispatch (`wide::f32x16`, two
            // AVX2 halves in an AVX2 build) where the default is AVX-512 chosen at run
            // time (`analytic_fog::avx512_dispatch()`; the same path elsewhere).
            let mut rgb16 = vec![surface; 3 * n];
            scene
                .clone()
                .without_avx512_dispatch()
                .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut rgb16))
                .unwrap();
            for i in 0..n {
                for c in 0..3 {
                    let e = planes[c][i].to_bits();
                    assert_eq!(rgb[3 * i + c].to_bits(), e, "case {case}: RGB vs planar");
                    assert_eq!(rgba[4 * i + c].to_bits(), e, "case {case}: RGBA vs planar");
                    let e8 = if own_zmm {
                        rgb16[3 * i + c].to_bits()
                    } else {
                        e
                    };
                    assert_eq!(rgb8[3 * i + c].to_bits(), e8, "case {case}: 8 lanes vs 16");
                    if !own_zmm {
                        assert_eq!(
                            rgb16[3 * i + c].to_bits(),
                            e,
                            "case {case}: without AVX-512 dispatch vs with"
                        );
                    }
                }
            }
            avx2[k] = rgb16;
        }
        let (bt, bl) = batch_reference(&scene, &cam, w, h, &depth, conv);
        for i in 0..n {
            let ray = cam.pixel_ray(i % w, i / w, w, h, depth[i], conv).unwrap();
            if ray.t.is_nan() {
                continue;
            }
            pixels += 1;
            let l = [0, 1, 2].map(|c| black[c][i]);
            let t = [0, 1, 2].map(|c| recover_t(white[c][i], l[c]));
            let ctx = || {
                format!(
                    "case {case}, {w}x{h}, pixel ({}, {}), {conv:?}, depth {}, {cam:?}, {desc:?}",
                    i % w,
                    i / w,
                    depth[i]
                )
            };
            let (r, chk) = check_pixel(&desc, &ray, t, l, ctx);
            worst = worst.max(chk.trans_ratio.max(chk.insc_ratio));
            if linear {
                worst_linear = worst_linear.max(chk.trans_ratio.max(chk.insc_ratio));
            }
            if ortho {
                worst_ortho = worst_ortho.max(chk.trans_ratio.max(chk.insc_ratio));
            }
            let scale = r.colour.iter().cloned().fold(1e-30, f64::max);
            if own_zmm {
                // The AVX2 lanes' results: within the bound too, and near the AVX-512
                // lanes' (|d| and the phase denominators within a few 2⁻²⁴ of each
                // other: T within 4e-7 plus what a few 2⁻²⁴ of t do to τ, which the
                // problem's condition 1 + |Δ| amplifies (t = depth/|d| for distance
                // depth; found at Δ ≈ 10: |dT| 4.8e-7); L_in within 1e-6 of the colour
                // scale).
                let layer = &desc.height_fog[0];
                let delta = (f64::from(layer.falloff)
                    * ray.direction.dot(desc.up.normalize()) as f64
                    * ray.t as f64)
                    .abs();
                let l2 = [0, 1, 2].map(|c| avx2[0][3 * i + c]);
                let t2 = [0, 1, 2].map(|c| recover_t(avx2[1][3 * i + c], l2[c]));
                let (_, chk2) = check_pixel(&desc, &ray, t2, l2, ctx);
                worst = worst.max(chk2.trans_ratio.max(chk2.insc_ratio));
                for c in 0..3 {
                    dz_t = dz_t.max((t[c] - t2[c]).abs());
                    let dl = (l[c] - l2[c]).abs() as f64 / scale;
                    if linear {
                        dz_l_linear = dz_l_linear.max(dl);
                    } else {
                        dz_l = dz_l.max(dl);
                    }
                    // (|Δ| capped: infinite on sky rays, whose τ converges; 0 · ∞ where
                    // T = 0 and τ = ∞: `max` takes the 0.)
                    let cond = t[c] as f64 * r.tau[c] * (1.0 + delta.min(100.0));
                    let allow = 4e-7 + cond.max(0.0) * 8.0 * 2f64.powi(-24);
                    assert!(
                        ((t[c] - t2[c]).abs() as f64) <= allow,
                        "T, AVX-512 vs AVX2: {} vs {}: {}",
                        t[c],
                        t2[c],
                        ctx()
                    );
                    assert!(
                        ((l[c] - l2[c]).abs() as f64) <= if linear { 1e-5 } else { 1e-6 } * scale,
                        "L_in, AVX-512 vs AVX2: {}",
                        ctx()
                    );
                }
            }
            for c in 0..3 {
                dt_max = dt_max.max((t[c] - bt[i][c]).abs());
                dl_max = dl_max.max((l[c] - bl[i][c]).abs() as f64 / scale);
                assert!((t[c] - bt[i][c]).abs() <= 1e-5, "T vs batch: {}", ctx());
                assert!(
                    ((l[c] - bl[i][c]).abs() as f64) <= 1e-5 * scale,
                    "L_in vs batch: {}",
                    ctx()
                );
            }
        }
    }
    eprintln!(
        "own kernel: {own} frames ({uniform_frames} with {uniform_rows} rows of constant b·u), \
         declined {declined}, {pixels} pixels, worst ratio to the \
         bound {worst:.3}; vs batch API: max |dT| {dt_max:.2e}, max |dL|/C {dl_max:.2e}; \
         AVX-512 vs AVX2 lanes: max |dT| {dz_t:.2e}, max |dL|/C {dz_l:.2e}; \
         {linear_frames} frames with the linear phase form (worst ratio {worst_linear:.3}), \
         AVX-512 vs AVX2 max |dL|/C {dz_l_linear:.2e}; {ortho_frames} orthographic frames, \
         {ortho_ndc} of them with NDC depth (worst ratio {worst_ortho:.3})"
    );
    assert!(
        ortho_frames >= 15 && ortho_ndc >= 8,
        "{ortho_frames} orthographic frames, {ortho_ndc} with NDC depth"
    );
    assert!(
        linear_frames >= 3,
        "{linear_frames} frames with the linear phase form"
    );
    assert!(
        own >= 60 && declined >= 20 && uniform_frames >= 20,
        "own {own}, declined {declined}, with rows of constant b·u {uniform_frames}"
    );
}

fn ndc_uv(x: usize, y: usize, w: usize, h: usize) -> (f64, f64) {
    (
        2.0 * (x as f64 + 0.5) / w as f64 - 1.0,
        1.0 - 2.0 * (y as f64 + 0.5) / h as f64,
    )
}

/// `pixel_ray` against an independent f64 unprojection (glam `DMat4`, Direct3D-style
/// [0, 1] depth): directions within 1e-5 rad, origins and (for the linear conventions)
/// end points within 1e-5 of the coordinates' scale (|position| + frame size + segment
/// length);
/// the view depth from NDC depth within 4 f32 roundings times (the condition number of
/// the depth conversion + |d|, since the f32 direction's forward component is 1 only to
/// within |d| roundings: wide fields of view and aspect ratios make |d| large).
#[test]
fn pixel_ray_matches_f64_unprojection() {
    let mut rng = Rng(42);
    let mut worst = [0.0f64; 4];
    for case in 0..300 {
        let (w, h) = (1 + rng.below(200), 1 + rng.below(200));
        let aspect = w as f32 / h as f32;
        let pos = rng.cube(20.0);
        let fwd = rng.unit();
        let up = rng.up_for(fwd);
        let ortho = case % 2 == 1;
        let (near, far) = (rng.range(0.05, 1.0), rng.range(50.0, 2000.0));
        let (cam, proj) = if ortho {
            let height = rng.range(1.0, 50.0);
            let cam = Camera::orthographic(pos, fwd, up, height, aspect).unwrap();
            let (hh, hw) = (height as f64 / 2.0, height as f64 / 2.0 * aspect as f64);
            (
                cam,
                DMat4::orthographic_rh(-hw, hw, -hh, hh, near as f64, far as f64),
            )
        } else {
            let fov = rng.range(0.2, 2.8);
            let cam = Camera::perspective(pos, fwd, up, fov, aspect).unwrap();
            (
                cam,
                DMat4::perspective_rh(fov as f64, aspect as f64, near as f64, far as f64),
            )
        };
        let (p64, f64_, u64_) = (pos.as_dvec3(), fwd.as_dvec3(), up.as_dvec3());
        let view = DMat4::look_at_rh(p64, p64 + f64_, u64_);
        let inv = (proj * view).inverse();
        let fwd_u = f64_.normalize();
        for _ in 0..20 {
            let (x, y) = (rng.below(w), rng.below(h));
            let (u, v) = ndc_uv(x, y, w, h);
            let a = inv.project_point3(DVec3::new(u, v, 0.0));
            let b = inv.project_point3(DVec3::new(u, v, 1.0));
            let dir = (b - a).normalize();
            // Origin: the eye, or the camera plane's point on the ray.
            let origin = if ortho {
                a - dir * (a - p64).dot(dir)
            } else {
                p64
            };
            let z = rng.range(0.0, 500.0);
            for conv in [DepthConvention::LinearView, DepthConvention::Distance] {
                let r: PixelRay = cam.pixel_ray(x, y, w, h, z, conv).unwrap();
                let rd = r.direction.as_dvec3();
                let angle = rd.normalize().cross(dir).length();
                let scale = if ortho {
                    (b - a).length().max(1.0)
                } else {
                    1.0
                };
                let oerr = (r.origin.as_dvec3() - origin).length() / (p64.length() + scale);
                let end = r.origin.as_dvec3() + rd * r.t as f64;
                let true_end = match conv {
                    DepthConvention::LinearView => origin + dir * (z as f64 / dir.dot(fwd_u)),
                    _ => origin + dir * z as f64,
                };
                let eerr =
                    (end - true_end).length() / (p64.length() + scale + (rd * r.t as f64).length());
                worst[0] = worst[0].max(angle);
                worst[1] = worst[1].max(oerr);
                worst[2] = worst[2].max(eerr);
                assert!(angle < 1e-5, "case {case}: direction off by {angle} rad");
                assert!(oerr < 1e-5, "case {case}: origin off by {oerr}");
                assert!(
                    eerr < 1e-5,
                    "case {case}: end point off by {eerr} ({conv:?})"
                );
            }
            // NDC depth: the world point the rasterizer's depth value stands for.
            for reversed in [false, true] {
                let dval = rng.f();
                let conv = DepthConvention::NdcZeroToOne {
                    near,
                    far,
                    reversed,
                };
                let r = cam.pixel_ray(x, y, w, h, dval, conv).unwrap();
                let zs = if reversed {
                    1.0 - dval as f64
                } else {
                    dval as f64
                };
                let p = inv.project_point3(DVec3::new(u, v, zs));
                let true_z = (p - origin).dot(fwd_u);
                let z = r.t as f64 * r.direction.as_dvec3().dot(fwd_u);
                // Condition of z(d): |d · z'(d) / z| (1 for linear, f/n-ish near far).
                let (n, f, d) = (near as f64, far as f64, dval as f64);
                let cond = if ortho {
                    (d * (f - n) / true_z.abs().max(1e-3)).abs() + 1.0
                } else if reversed {
                    1.0 + d * (1.0 - n / f) / (d * (1.0 - n / f) + n / f)
                } else {
                    1.0 + d * (1.0 - n / f) / (1.0 - d * (1.0 - n / f))
                };
                let rel = (z - true_z).abs() / true_z.abs().max(1e-3);
                worst[3] = worst[3].max(rel / (cond + r.direction.length() as f64));
                assert!(
                    rel < 4.0 * 2f64.powi(-24) * (cond + r.direction.length() as f64),
                    "case {case}: NDC depth {dval} reversed {reversed}: z {z} vs {true_z} (cond {cond}) formula {} t {} near {near} far {far} ortho {ortho}", if reversed { n / (d * (1.0 - n / f) + n / f) } else { n / (1.0 - d * (1.0 - n / f)) }, r.t
                );
            }
        }
    }
    eprintln!(
        "worst: direction {:.2e} rad, origin {:.2e}, end point {:.2e}, NDC z rel/cond {:.2e}",
        worst[0], worst[1], worst[2], worst[3]
    );
}

/// A camera from an inverse view-projection matrix gives the same rays (within the f32
/// matrix's rounding) as the constructor with the same parameters, whatever the
/// matrix's z convention.
#[test]
fn inverse_view_projection_matches_constructors() {
    let mut rng = Rng(5);
    for case in 0..200 {
        let (w, h) = (1 + rng.below(100), 1 + rng.below(100));
        let aspect = w as f32 / h as f32;
        let pos = rng.cube(5.0);
        let fwd = rng.unit();
        let up = rng.up_for(fwd);
        let view = Mat4::look_at_rh(pos, pos + fwd, up);
        let fov = rng.range(0.3, 2.5);
        let (a, b) = if case % 4 == 3 {
            let height = rng.range(1.0, 20.0);
            let (hh, hw) = (height / 2.0, height / 2.0 * aspect);
            let proj = Mat4::orthographic_rh(-hw, hw, -hh, hh, 0.0, 100.0);
            (
                Camera::orthographic(pos, fwd, up, height, aspect).unwrap(),
                Camera::from_inverse_view_projection((proj * view).inverse(), Some(pos)).unwrap(),
            )
        } else {
            let proj = match case % 4 {
                0 => Mat4::perspective_rh(fov, aspect, 0.1, 100.0),
                1 => Mat4::perspective_rh_gl(fov, aspect, 0.1, 100.0),
                _ => Mat4::perspective_infinite_reverse_rh(fov, aspect, 0.1),
            };
            (
                Camera::perspective(pos, fwd, up, fov, aspect).unwrap(),
                Camera::from_inverse_view_projection((proj * view).inverse(), None).unwrap(),
            )
        };
        assert_eq!(a.projection(), b.projection());
        assert!((a.forward() - b.forward()).length() < 1e-4, "case {case}");
        for _ in 0..10 {
            let (x, y) = (rng.below(w), rng.below(h));
            let z = rng.range(0.0, 100.0);
            let ra = a
                .pixel_ray(x, y, w, h, z, DepthConvention::LinearView)
                .unwrap();
            let rb = b
                .pixel_ray(x, y, w, h, z, DepthConvention::LinearView)
                .unwrap();
            let tol = 1e-4 * (1.0 + ra.direction.length());
            assert!(
                (ra.origin - rb.origin).length() < 1e-3,
                "case {case}: {ra:?} {rb:?}"
            );
            assert!(
                (ra.direction - rb.direction).length() < tol,
                "case {case}: {ra:?} {rb:?}"
            );
            assert_eq!(ra.t, rb.t);
        }
    }
}

#[test]
fn sky_pixels_take_infinite_rays() {
    let cam = Camera::perspective(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 1.0).unwrap();
    let cases = [
        (DepthConvention::LinearView, f32::INFINITY),
        (DepthConvention::Distance, f32::INFINITY),
        (
            DepthConvention::NdcZeroToOne {
                near: 0.1,
                far: 100.0,
                reversed: false,
            },
            1.0,
        ),
        (
            DepthConvention::NdcZeroToOne {
                near: 0.1,
                far: 100.0,
                reversed: true,
            },
            0.0,
        ),
        (
            DepthConvention::NdcZeroToOne {
                near: 0.1,
                far: f32::INFINITY,
                reversed: true,
            },
            0.0,
        ),
        (
            DepthConvention::NdcZeroToOne {
                near: 0.1,
                far: f32::INFINITY,
                reversed: false,
            },
            1.0,
        ),
    ];
    for (conv, d) in cases {
        assert_eq!(
            cam.pixel_ray(1, 2, 4, 4, d, conv).unwrap().t,
            f32::INFINITY,
            "{conv:?}"
        );
    }
    // The near plane is at the view depth `near`.
    let r = cam
        .pixel_ray(
            0,
            0,
            1,
            1,
            1.0,
            DepthConvention::NdcZeroToOne {
                near: 0.5,
                far: 100.0,
                reversed: true,
            },
        )
        .unwrap();
    assert_eq!(r.t, 0.5);
    let ortho = Camera::orthographic(Vec3::ZERO, Vec3::Z, Vec3::Y, 2.0, 1.0).unwrap();
    let conv = DepthConvention::NdcZeroToOne {
        near: 1.0,
        far: 11.0,
        reversed: false,
    };
    assert_eq!(ortho.pixel_ray(0, 0, 2, 2, 0.5, conv).unwrap().t, 6.0);
    assert_eq!(
        ortho.pixel_ray(0, 0, 2, 2, 1.0, conv).unwrap().t,
        f32::INFINITY
    );
    // Negative depths: no fog (t = 0); NaN stays NaN.
    assert_eq!(
        cam.pixel_ray(0, 0, 1, 1, -3.0, DepthConvention::LinearView)
            .unwrap()
            .t,
        0.0
    );
    assert!(cam
        .pixel_ray(0, 0, 1, 1, f32::NAN, DepthConvention::LinearView)
        .unwrap()
        .t
        .is_nan());
}

#[test]
fn wrong_lengths_and_parameters_are_errors_naming_the_buffer() {
    let mut rng = Rng(3);
    let scene = scene(&mut rng, 0);
    let cam = Camera::perspective(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, 1.0).unwrap();
    let (w, h) = (5, 3);
    let depth = vec![1.0f32; w * h];
    let short = vec![1.0f32; w * h - 1];
    let d = Depth::linear_view(&depth);
    let msg = |e: PassError| e.to_string();

    let mut c = vec![0.0f32; 3 * w * h];
    let e = scene.fog_pass(
        &cam,
        w,
        h,
        Depth::linear_view(&short),
        ColourBuffer::Rgb(&mut c),
    );
    assert_eq!(
        msg(e.unwrap_err()),
        "depth: has 14 elements, a 5x3 frame needs 15"
    );
    let mut c = vec![0.0f32; 3 * w * h + 1];
    let e = scene
        .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut c))
        .unwrap_err();
    assert_eq!(
        e,
        PassError::BufferLength {
            buffer: "colour",
            expected: 45,
            found: 46,
            width: 5,
            height: 3
        }
    );
    let mut c = vec![0.0f32; 3 * w * h];
    let e = scene
        .fog_pass_single(&cam, w, h, d, ColourBuffer::Rgba(&mut c))
        .unwrap_err();
    assert_eq!(msg(e), "colour: has 45 elements, a 5x3 frame needs 60");
    let (mut r, mut g, mut b) = (vec![0.0f32; 15], vec![0.0f32; 15], vec![0.0f32; 14]);
    let e = scene.fog_pass(
        &cam,
        w,
        h,
        d,
        ColourBuffer::Planar([&mut r, &mut g, &mut b]),
    );
    assert_eq!(
        msg(e.unwrap_err()),
        "colour.b: has 14 elements, a 5x3 frame needs 15"
    );
    let mut g2 = vec![0.0f32; 16];
    let e = scene.fog_pass(
        &cam,
        w,
        h,
        d,
        ColourBuffer::Planar([&mut r, &mut g2, &mut b]),
    );
    assert_eq!(
        msg(e.unwrap_err()),
        "colour.g: has 16 elements, a 5x3 frame needs 15"
    );
    // Nothing written on error.
    assert!(r.iter().all(|&v| v == 0.0));

    let mut c = vec![0.0f32; 3 * w * h];
    let bad = Depth::ndc(&depth, 0.0, 100.0);
    let e = scene
        .fog_pass(&cam, w, h, bad, ColourBuffer::Rgb(&mut c))
        .unwrap_err();
    assert!(msg(e).starts_with("depth.near, depth.far: perspective: must be 0 < near < far"));
    let e = cam
        .pixel_ray(5, 0, w, h, 1.0, DepthConvention::LinearView)
        .unwrap_err();
    assert_eq!(msg(e), "pixel (5, 0): outside the 5x3 frame");

    // Empty frames are fine.
    scene
        .fog_pass(
            &cam,
            0,
            7,
            Depth::linear_view(&[]),
            ColourBuffer::Rgb(&mut []),
        )
        .unwrap();

    // Camera parameters.
    let e = Camera::perspective(Vec3::ZERO, Vec3::Z, Vec3::Z, 1.0, 1.0).unwrap_err();
    assert!(msg(e).starts_with("up: "));
    let e = Camera::perspective(Vec3::ZERO, Vec3::ZERO, Vec3::Y, 1.0, 1.0).unwrap_err();
    assert!(msg(e).starts_with("forward: "));
    let e = Camera::perspective(Vec3::ZERO, Vec3::Z, Vec3::Y, 3.2, 1.0).unwrap_err();
    assert!(msg(e).starts_with("fov_y: "));
    let e = Camera::orthographic(Vec3::NAN, Vec3::Z, Vec3::Y, 1.0, 1.0).unwrap_err();
    assert!(msg(e).starts_with("position: "));
    let e = Camera::orthographic(Vec3::ZERO, Vec3::Z, Vec3::Y, 1.0, -1.0).unwrap_err();
    assert!(msg(e).starts_with("aspect: "));
    let e = Camera::from_inverse_view_projection(Mat4::ZERO, None).unwrap_err();
    assert_eq!(msg(e), "inv_vp: must be invertible");
    let ortho = Mat4::orthographic_rh(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0).inverse();
    let e = Camera::from_inverse_view_projection(ortho, None).unwrap_err();
    assert!(msg(e).starts_with("position: required"));
}

// ---------------------------------------------------------------------------------------
// Fog volumes: the pass's per-tile culling (issue 5). A pixel fogged with the tiles'
// candidate lists is bit-identical to the same pixel without any culling
// (`Scene::without_culling`), with the per-packet culling only
// (`Scene::without_tile_culling`) and to the batch API.

/// The world radius of a sphere containing the shape, as the library bounds it (a
/// sphere's radius, an ellipsoid's longest semi-axis, a box's half diagonal, the
/// Frobenius norm of a general matrix).
fn bound_of(shape: &analytic_fog::Shape) -> f32 {
    use analytic_fog::Shape;
    match shape {
        Shape::Sphere { radius, .. } => *radius,
        Shape::Ellipsoid { radii, .. } => radii.max_element(),
        Shape::Affine { matrix, .. } => matrix
            .iter()
            .map(|c| c.length_squared())
            .sum::<f32>()
            .sqrt(),
        Shape::Box { half_extents, .. } => half_extents.length(),
    }
}

fn random_quat(rng: &mut Rng) -> glam::Quat {
    glam::Quat::from_axis_angle(rng.unit(), rng.range(0.0, 6.3))
}

/// A shape of about `size` at `center`.
fn random_shape(rng: &mut Rng, center: Vec3, size: f32) -> analytic_fog::Shape {
    use analytic_fog::Shape;
    match rng.below(4) {
        0 => Shape::Sphere {
            center,
            radius: size,
        },
        1 => Shape::Ellipsoid {
            center,
            radii: Vec3::new(size * rng.range(0.2, 1.0), size * rng.range(0.2, 1.0), size),
            rotation: random_quat(rng),
        },
        2 => Shape::Box {
            center,
            half_extents: Vec3::new(size * rng.range(0.2, 1.0), size, size * rng.range(0.2, 1.0)),
            rotation: random_quat(rng),
            edge_fade: if rng.below(2) == 0 {
                0.0
            } else {
                rng.range(0.05, 1.0)
            },
        },
        _ => loop {
            let m = [0; 3].map(|_| rng.unit() * size * rng.range(0.3, 1.0));
            let det = glam::Mat3::from_cols(m[0], m[1], m[2]).determinant().abs();
            if det / (m[0].length() * m[1].length() * m[2].length()) > 0.1 {
                break Shape::Affine { center, matrix: m };
            }
        },
    }
}

/// Where volumes are put: around the rays of pixels on tile boundaries and frame edges
/// (and random ones), at the distance of the per-packet test's margin from the ray
/// (grazing it from either side), through it, containing the camera; small and many.
fn volumes_in_view(
    rng: &mut Rng,
    cam: &Camera,
    w: usize,
    h: usize,
    count: usize,
    cuts: usize,
) -> Vec<analytic_fog::Volume> {
    use analytic_fog::{Profile, Shape, Volume};
    let (tw, th) = Scene::tile_size();
    let edge = |rng: &mut Rng, n: usize, t: usize| -> usize {
        match rng.below(5) {
            0 => 0,
            1 => n - 1,
            2 | 3 if n > t => {
                // On either side of a tile boundary.
                let b = t * (1 + rng.below((n - 1) / t));
                (b - rng.below(2)).min(n - 1)
            }
            _ => rng.below(n),
        }
    };
    let mut out = Vec::new();
    for i in 0..count + cuts {
        let (x, y) = (edge(rng, w, tw), edge(rng, h, th));
        let r = cam
            .pixel_ray(x, y, w, h, 1.0, DepthConvention::LinearView)
            .unwrap();
        let dir = r.direction.normalize();
        let s = match rng.below(4) {
            0 => rng.range(0.0, 3.0),
            1 => rng.range(3.0, 300.0),
            _ => rng.range(3.0, 60.0),
        };
        let size = match rng.below(3) {
            0 => rng.range(0.01, 0.2),
            1 => rng.range(0.2, 1.5),
            _ => rng.range(1.5, 8.0),
        };
        let mut shape = random_shape(rng, Vec3::ZERO, size);
        let b = bound_of(&shape);
        // Off the ray by the bound times k: inside, at the per-packet test's margin
        // (1.001), just outside it, and clearly outside; toward a random side.
        let k = [
            0.0, 0.5, 0.999, 1.0, 1.0009, 1.001, 1.0011, 1.002, 1.01, 1.3,
        ][rng.below(10)];
        let side = dir.cross(rng.unit()).normalize_or_zero();
        let mut center = r.origin + dir * s + side * (b * k);
        if rng.below(25) == 0 {
            // Containing the camera.
            center = r.origin + rng.unit() * (0.5 * b * rng.f());
        }
        match &mut shape {
            Shape::Sphere { center: c, .. }
            | Shape::Ellipsoid { center: c, .. }
            | Shape::Affine { center: c, .. }
            | Shape::Box { center: c, .. } => *c = center,
        }
        let profile = if matches!(shape, Shape::Box { .. }) {
            Profile::Constant
        } else {
            Profile::ALL[rng.below(6)]
        };
        let v = if i >= count {
            Volume::cut(shape)
        } else {
            let mut v = Volume::new(
                shape,
                profile,
                Vec3::new(
                    rng.range(0.0, 2.0),
                    rng.range(0.0, 2.0),
                    rng.range(0.0, 2.0),
                ) / size.max(0.1),
            );
            v.absorption = Vec3::splat(rng.range(0.0, 0.5));
            v.emission = Vec3::splat(rng.range(0.0, 0.3));
            if rng.below(3) == 0 {
                v.phase = Phase::HenyeyGreenstein(rng.range(-0.8, 0.8));
            }
            v
        };
        out.push(v);
    }
    out
}

/// Depth values with structure (so that tiles have narrow depth ranges and the depth
/// test culls): constant blocks of random size, sky blocks, and a few random pixels.
fn blocky_depths(rng: &mut Rng, conv: DepthConvention, w: usize, h: usize) -> Vec<f32> {
    let (bw, bh) = (1 + rng.below(40), 1 + rng.below(12));
    let vals = depths(rng, conv, w.div_ceil(bw) * h.div_ceil(bh));
    let noise = depths(rng, conv, w * h);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if rng.below(50) == 0 {
                noise[i]
            } else {
                vals[(y / bh) * w.div_ceil(bw) + x / bw]
            }
        })
        .collect()
}

/// Frame sizes: not multiples of the tile size (32 × 8), single rows and columns.
const TILE_SIZES: [(usize, usize); 10] = [
    (1, 1),
    (7, 3),
    (31, 9),
    (33, 17),
    (65, 8),
    (40, 23),
    (97, 31),
    (8, 70),
    (1, 19),
    (130, 12),
];

#[test]
fn volume_tile_culling_is_bit_identical_to_no_culling_and_batch_api() {
    let mut rng = Rng(0x5eed_7113_c011_0001);
    let (mut listed, mut possible) = (0usize, 0usize);
    for case in 0..240 {
        let (w, h) = TILE_SIZES[case % TILE_SIZES.len()];
        let cam = camera(&mut rng, w, h);
        let conv = convention(&mut rng, &cam);
        let depth = if rng.below(2) == 0 {
            blocky_depths(&mut rng, conv, w, h)
        } else {
            depths(&mut rng, conv, w * h)
        };
        let count = if case % 4 == 0 {
            150 + rng.below(150)
        } else {
            1 + rng.below(30)
        };
        let cuts = if rng.below(3) == 0 { rng.below(4) } else { 0 };
        let vols = volumes_in_view(&mut rng, &cam, w, h, count, cuts);
        // With one RGB layer (sun, ambient: the usual case), two layers, or volumes alone.
        let base = scene(&mut rng, [0, 1, 2][case % 3]);
        let mut desc = base.desc().clone();
        if case % 5 == 4 {
            desc.height_fog.clear();
        }
        desc.volumes = vols;
        // Every other frame composites front to back: the rows' list of touched volumes is
        // one per row, reused from tile to tile.
        if case % 2 == 1 {
            desc.composition = Composition::Ordered;
        }
        let scene = Scene::new(desc).unwrap();
        let unculled = scene.clone().without_culling();
        let packet_only = scene.clone().without_tile_culling();
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        let n = w * h;
        let surface: Vec<f32> = (0..3 * n).map(|_| rng.range(0.0, 4.0)).collect();
        let (tr, li) = batch_reference(&scene, &cam, w, h, &depth, conv);
        let run = |s: &Scene, par: bool| {
            let mut c = surface.clone();
            if par {
                s.fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut c))
                    .unwrap();
            } else {
                s.fog_pass_single(&cam, w, h, d, ColourBuffer::Rgb(&mut c))
                    .unwrap();
            }
            c
        };
        let culled = run(&scene, case % 2 == 0);
        let none = run(&unculled, false);
        let packet = run(&packet_only, true);
        // The build's own 8 lanes where the general kernel's rows take 16 AVX-512 lanes
        // chosen at run time (`avx512_dispatch()`; elsewhere the same path again).
        let narrow = run(&scene.clone().without_avx512_dispatch(), case % 2 == 1);
        // Planar and RGBA layouts with the lists too.
        let mut planes: [Vec<f32>; 3] =
            [0, 1, 2].map(|c| (0..n).map(|i| surface[3 * i + c]).collect());
        let [pr, pg, pb] = &mut planes;
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Planar([pr, pg, pb]))
            .unwrap();
        let mut rgba: Vec<f32> = (0..n)
            .flat_map(|i| [surface[3 * i], surface[3 * i + 1], surface[3 * i + 2], 0.5])
            .collect();
        scene
            .fog_pass_single(&cam, w, h, d, ColourBuffer::Rgba(&mut rgba))
            .unwrap();
        for i in 0..n {
            for c in 0..3 {
                let e = Lane::mul_add(surface[3 * i + c], tr[i][c], li[i][c]);
                let ctx = || {
                    format!(
                        "case {case}, {w}x{h}, pixel ({}, {}), channel {c}, {conv:?}, {cam:?}, depth {}",
                        i % w,
                        i / w,
                        depth[i]
                    )
                };
                let bits = culled[3 * i + c].to_bits();
                assert_eq!(
                    bits,
                    none[3 * i + c].to_bits(),
                    "tile culled vs unculled: {}",
                    ctx()
                );
                assert_eq!(
                    bits,
                    packet[3 * i + c].to_bits(),
                    "tile vs packet culled: {}",
                    ctx()
                );
                assert_eq!(
                    bits,
                    narrow[3 * i + c].to_bits(),
                    "16 lanes vs 8: {}",
                    ctx()
                );
                assert_eq!(bits, e.to_bits(), "tile culled vs batch API: {}", ctx());
                assert_eq!(bits, planes[c][i].to_bits(), "planar: {}", ctx());
                assert_eq!(bits, rgba[4 * i + c].to_bits(), "RGBA: {}", ctx());
            }
        }
        let lists = scene
            .fog_pass_tile_candidates(&cam, w, h, d)
            .unwrap()
            .expect("volumes are culled per tile");
        let (tw, th) = Scene::tile_size();
        assert_eq!(lists.len(), w.div_ceil(tw) * h.div_ceil(th));
        listed += lists.iter().sum::<usize>();
        possible += lists.len() * count;
        assert!(lists.iter().all(|&k| k <= count));
        assert!(unculled
            .fog_pass_tile_candidates(&cam, w, h, d)
            .unwrap()
            .is_none());
        assert!(packet_only
            .fog_pass_tile_candidates(&cam, w, h, d)
            .unwrap()
            .is_none());
    }
    // The lists do cull (most volumes are placed at edges and away from most tiles).
    eprintln!("candidates listed: {listed} of {possible} tile-volume pairs");
    assert!(listed * 2 < possible, "{listed} of {possible}");
}

/// Many small volumes in front of a perspective camera at a larger frame, with structured
/// depth: parallel and single passes, tile culled and not, all the same bits.
#[test]
fn many_small_volumes_large_frame_bit_identical() {
    let mut rng = Rng(0xface_b00c);
    let (w, h) = (203, 77);
    let cam = Camera::perspective(
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(0.1, -0.2, -1.0),
        Vec3::Y,
        1.0,
        w as f32 / h as f32,
    )
    .unwrap();
    let mut vols = Vec::new();
    for _ in 0..600 {
        let x = rng.below(w);
        let y = rng.below(h);
        let r = cam
            .pixel_ray(x, y, w, h, 1.0, DepthConvention::LinearView)
            .unwrap();
        let center = r.origin + r.direction.normalize() * rng.range(5.0, 200.0) + rng.unit() * 0.5;
        let size = rng.range(0.1, 1.0);
        let shape = random_shape(&mut rng, center, size);
        let profile = if matches!(shape, analytic_fog::Shape::Box { .. }) {
            analytic_fog::Profile::Constant
        } else {
            analytic_fog::Profile::ALL[rng.below(6)]
        };
        vols.push(analytic_fog::Volume::new(
            shape,
            profile,
            Vec3::new(0.5, 0.7, 0.9),
        ));
    }
    let mut desc = scene(&mut rng, 0).desc().clone();
    desc.volumes = vols;
    let scene = Scene::new(desc).unwrap();
    // A ground plane (y = 0) and sky.
    let depth: Vec<f32> = (0..w * h)
        .map(|i| {
            let r = cam
                .pixel_ray(i % w, i / w, w, h, 1.0, DepthConvention::LinearView)
                .unwrap();
            if r.direction.y < 0.0 {
                -r.origin.y / r.direction.y
            } else {
                f32::INFINITY
            }
        })
        .collect();
    let d = Depth::linear_view(&depth);
    let surface: Vec<f32> = (0..3 * w * h).map(|_| rng.range(0.0, 2.0)).collect();
    let mut a = surface.clone();
    let mut b = surface.clone();
    let mut c = surface.clone();
    scene
        .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut a))
        .unwrap();
    scene
        .fog_pass_single(&cam, w, h, d, ColourBuffer::Rgb(&mut b))
        .unwrap();
    scene
        .clone()
        .without_culling()
        .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut c))
        .unwrap();
    let (tr, li) = batch_reference(&scene, &cam, w, h, &depth, DepthConvention::LinearView);
    for i in 0..w * h {
        for k in 0..3 {
            let e = Lane::mul_add(surface[3 * i + k], tr[i][k], li[i][k]);
            let j = 3 * i + k;
            assert_eq!(a[j].to_bits(), e.to_bits(), "pixel {i} channel {k}");
            assert_eq!(b[j].to_bits(), e.to_bits(), "pixel {i} channel {k}");
            assert_eq!(c[j].to_bits(), e.to_bits(), "pixel {i} channel {k}");
        }
    }
    // Most tiles list few of the 600 volumes.
    let lists = scene
        .fog_pass_tile_candidates(&cam, w, h, d)
        .unwrap()
        .unwrap();
    let mean = lists.iter().sum::<usize>() as f64 / lists.len() as f64;
    eprintln!("mean candidates per tile: {mean:.1} of 600");
    assert!(mean < 60.0, "{mean}");
}

/// The own kernel where its exponentials saturate (`exp2m1` clamps at 2^127 looking down
/// into dense fog, `exp2_nonpos` flushes T to 0) or vanish (E = 1 for tiny Δ, a channel
/// without extinction, T = 1): stiff falloffs of both signs, cameras far above, inside and
/// below the fog, looking down, along and up, depths from 0 to 1e7 and the sky. Every
/// frame must run the own kernel; each pixel is compared with the batch API (T within
/// 1e-5 and exactly 0 or 1 where the batch API's is, L_in within 1e-5 of the colour
/// scale) and with the f64 reference within the crate's bound.
#[test]
fn own_kernel_saturation_and_vanishing_terms() {
    let (w, h) = (29, 7);
    let (mut frames, mut zeros, mut ones, mut steep) = (0, 0, 0, 0);
    for &falloff in &[3.0f32, 0.5, 1e-9, -0.5, -3.0] {
        for &(cam_y, pitch) in &[
            (60.0f32, -0.6f32),
            (60.0, 0.0),
            (2.0, -0.3),
            (2.0, 0.4),
            (-40.0, 0.5),
            (-40.0, -0.2),
        ] {
            let desc = sunlit_layer(
                falloff,
                Vec3::new(0.01, 0.0, 0.02),
                Component {
                    scattering: Vec3::new(0.5, 0.02, 0.0),
                    absorption: Vec3::new(0.1, 0.0, 0.0),
                    phase: Phase::HenyeyGreenstein(0.7),
                },
            );
            let scene = Scene::new(desc.clone()).unwrap();
            let fwd = Vec3::new(0.0, pitch, -1.0).normalize();
            let cam =
                Camera::perspective(Vec3::new(0.0, cam_y, 0.0), fwd, Vec3::Y, 1.2, 29.0 / 7.0)
                    .unwrap();
            let conv = DepthConvention::LinearView;
            if scene
                .fog_pass_own_kernel(&cam, w, h, conv)
                .unwrap()
                .is_none()
            {
                // The frame checks decline what ρ₀ puts out of range (e.g. the camera 60
                // above a layer with falloff 3: ρ₀ = e^-180); the batch kernel runs there.
                continue;
            }
            frames += 1;
            let depth = saturation_depths(w * h);
            let what = format!("falloff {falloff}, camera y {cam_y}, pitch {pitch}");
            let counts = own_kernel_against_batch(&scene, &desc, &cam, (w, h), &depth, &what);
            zeros += counts[0];
            ones += counts[1];
            steep += counts[2];
        }
    }
    // Most of the 30 frames must have run the own kernel (those it declines are listed in
    // the frame checks).
    eprintln!("{frames} frames, {zeros} channels T = 0, {ones} T = 1, {steep} pixels with Δ < −88");
    assert!(frames >= 18, "own kernel ran {frames} of 30 frames");
    assert!(
        zeros > 100 && ones > 100 && steep > 50,
        "{zeros} {ones} {steep}"
    );
}

/// The own kernel in the Fast tier (`Scene::with_tier(Tier::Fast)`: its transmittance is
/// `exp_neg_fast` of K·log2(e)·g', the frame constant being in base 2) against the
/// Accurate batch API: within the Fast tier's budget, 1e-4 in T and in L_in relative to
/// the fog colour (`Tier`), on random scenes, cameras and depths; and the Accurate own
/// kernel of the same frames for comparison (within 1e-5).
#[test]
fn own_kernel_fast_tier_within_its_budget() {
    let mut rng = Rng(0xfa57_0001);
    let (mut own, mut ortho, mut worst_fast, mut worst_acc) = (0, 0, 0.0f64, 0.0f64);
    for case in 0..120 {
        let (w, h) = SIZES[case % SIZES.len()];
        let scene = scene(&mut rng, [0, 2, 3][case % 3]);
        // One frame in four from an orthographic camera upright in the scene (rows of
        // their own density, the phase folded into the colour).
        let cam = if case % 4 == 2 {
            let up = [Vec3::X, Vec3::Y, Vec3::Z]
                .into_iter()
                .find(|&a| a == scene.desc().up)
                .unwrap_or(Vec3::Y);
            upright_ortho_camera(&mut rng, w, h, up)
        } else {
            camera(&mut rng, w, h)
        };
        let conv = convention(&mut rng, &cam);
        if scene
            .fog_pass_own_kernel(&cam, w, h, conv)
            .unwrap()
            .is_none()
        {
            continue;
        }
        own += 1;
        ortho += usize::from(cam.projection() == Projection::Orthographic);
        let depth = depths(&mut rng, conv, w * h);
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        let n = w * h;
        let (bt, bl) = batch_reference(&scene, &cam, w, h, &depth, conv);
        for (tier, bound, worst) in [
            (Tier::Fast, 1e-4, &mut worst_fast),
            (Tier::Accurate, 1e-5, &mut worst_acc),
        ] {
            let sc = scene.clone().with_tier(tier);
            let run = |surface: f32| {
                let mut c = vec![surface; 3 * n];
                sc.fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut c))
                    .unwrap();
                c
            };
            let (black, white) = (run(0.0), run(BIG));
            for i in 0..n {
                let ray = cam.pixel_ray(i % w, i / w, w, h, depth[i], conv).unwrap();
                if ray.t.is_nan() {
                    continue;
                }
                let r = reference::sample(
                    scene.desc(),
                    ray.origin.as_dvec3(),
                    ray.direction.as_dvec3(),
                    ray.t as f64,
                );
                let scale = r.colour.iter().cloned().fold(1e-30, f64::max);
                for c in 0..3 {
                    let l = black[3 * i + c];
                    let t = recover_t(white[3 * i + c], l);
                    let dt = (t - bt[i][c]).abs() as f64;
                    let dl = (l - bl[i][c]).abs() as f64 / scale;
                    *worst = worst.max(dt).max(dl);
                    assert!(
                        dt <= bound && dl <= bound,
                        "{tier:?}, case {case}, pixel {i}: T {t} vs {}, L_in {l} vs {}",
                        bt[i][c],
                        bl[i][c]
                    );
                }
            }
        }
    }
    eprintln!(
        "own kernel: {own} frames ({ortho} orthographic); worst Fast {worst_fast:.2e}, \
         Accurate {worst_acc:.2e}"
    );
    assert!(
        own >= 30 && ortho >= 10,
        "own kernel ran {own} frames, {ortho} orthographic"
    );
}

/// One height fog layer at base height 0 with one component, a sun and ambient light.
fn sunlit_layer(falloff: f32, emission: Vec3, component: Component) -> SceneDesc {
    SceneDesc {
        height_fog: vec![HeightFogLayer {
            base_height: 0.0,
            falloff,
            emission,
            components: vec![component],
        }],
        lighting: Lighting {
            ambient: Vec3::new(0.5, 0.6, 0.7),
            sun: Some(Sun {
                direction: Vec3::new(0.3, 0.4, -0.87),
                radiance: Vec3::new(20.0, 18.0, 15.0),
            }),
        },
        ..SceneDesc::default()
    }
}

/// [`sunlit_layer`] with the benches' fog: falloff 0.1, RGB scattering, Henyey–Greenstein
/// g = 0.6, no emission.
fn typical_sunlit_layer() -> SceneDesc {
    sunlit_layer(
        0.1,
        Vec3::ZERO,
        Component {
            scattering: Vec3::new(0.02, 0.03, 0.05),
            absorption: Vec3::ZERO,
            phase: Phase::HenyeyGreenstein(0.6),
        },
    )
}

/// Depths for the saturation tests: +∞, 0, and 1 to 1e6 in decades.
fn saturation_depths(n: usize) -> Vec<f32> {
    (0..n)
        .map(|i| match i % 9 {
            0 => f32::INFINITY,
            1 => 0.0,
            k => 10f32.powi(k as i32 - 2), // 1 to 1e6
        })
        .collect()
}

/// One frame (linear view depth) through `fog_pass` against the batch API (T within 1e-5,
/// exactly 0 or 1 where the batch API's is; L_in within 1e-5 of the fog colour) and the
/// f64 reference's bound (`check_pixel`). Returns how many channels have T = 0, T = 1,
/// and how many pixels Δ < −88 (where `exp2m1` saturates).
fn own_kernel_against_batch(
    scene: &Scene,
    desc: &SceneDesc,
    cam: &Camera,
    (w, h): (usize, usize),
    depth: &[f32],
    what: &str,
) -> [usize; 3] {
    own_kernel_against_batch_in(
        scene,
        desc,
        cam,
        (w, h),
        depth,
        DepthConvention::LinearView,
        what,
    )
}

/// [`own_kernel_against_batch`] for depths in convention `conv`.
fn own_kernel_against_batch_in(
    scene: &Scene,
    desc: &SceneDesc,
    cam: &Camera,
    (w, h): (usize, usize),
    depth: &[f32],
    conv: DepthConvention,
    what: &str,
) -> [usize; 3] {
    let d = Depth {
        values: depth,
        convention: conv,
    };
    let n = w * h;
    let run = |surface: f32| {
        let mut c = [vec![surface; n], vec![surface; n], vec![surface; n]];
        let [r, g, b] = &mut c;
        scene
            .fog_pass(cam, w, h, d, ColourBuffer::Planar([r, g, b]))
            .unwrap();
        c
    };
    let (black, white) = (run(0.0), run(BIG));
    let (bt, bl) = batch_reference(scene, cam, w, h, depth, conv);
    let mut counts = [0usize; 3];
    for i in 0..n {
        let ctx = || format!("{what}, pixel {i}, depth {}", depth[i]);
        let l = [0, 1, 2].map(|c| black[c][i]);
        let t = [0, 1, 2].map(|c| recover_t(white[c][i], l[c]));
        let ray = cam.pixel_ray(i % w, i / w, w, h, depth[i], conv).unwrap();
        let (r, _) = check_pixel(desc, &ray, t, l, ctx);
        let layer = &desc.height_fog[0];
        let delta = layer.falloff as f64 * ray.direction.y as f64 * ray.t as f64;
        counts[2] += (delta < -88.1) as usize;
        let scale = r.colour.iter().cloned().fold(1e-30, f64::max);
        for c in 0..3 {
            assert!(t[c].is_finite() && l[c].is_finite(), "{}", ctx());
            assert!(
                (t[c] - bt[i][c]).abs() <= 1e-5,
                "T {} vs batch {}: {}",
                t[c],
                bt[i][c],
                ctx()
            );
            counts[0] += (bt[i][c] == 0.0) as usize;
            counts[1] += (bt[i][c] == 1.0) as usize;
            if bt[i][c] == 0.0 || bt[i][c] == 1.0 {
                assert_eq!(t[c], bt[i][c], "T exactly 0 or 1: {}", ctx());
            }
            assert!(
                ((l[c] - bl[i][c]).abs() as f64) <= 1e-5 * scale,
                "L_in {} vs batch {}: {}",
                l[c],
                bl[i][c],
                ctx()
            );
        }
    }
    counts
}

/// The own kernel's rows of constant b·u (`RowFactor`, an upright camera) at their edges:
/// a level camera whose rows pass the horizon (|b2·u| from about 0 on the middle row up
/// to the frame's edges), falloffs whose rows all fall below the bound
/// `HeightPass::uni_lo` on |b2·u| (1e-9) or some of them (1e-5, 1e-4), steep and negative ones,
/// and depths from −1 and 0 through 1e-30 (below t_lo, raised to it) to 1e6 and +∞ (t
/// clamped at 63/|b2·u| looking up and 126/|b2·u| looking down): every pixel against the
/// batch API (T exactly 0 and 1 where the batch API's is) and the f64 reference's bound,
/// and frames with rows of both forms.
#[test]
fn own_kernel_rows_of_constant_bu_at_their_edges() {
    let (w, h) = (23, 41);
    let depths = [
        -1.0f32,
        0.0,
        1e-30,
        1e-12,
        1e-3,
        0.7,
        13.0,
        450.0,
        2e4,
        1e6,
        f32::INFINITY,
    ];
    let depth: Vec<f32> = (0..w * h)
        .map(|i| depths[(i * 7 + i / w) % depths.len()])
        .collect();
    let (mut frames, mut mixed) = (0, 0);
    for &falloff in &[0.1f32, 3.0, -0.7, 1e-9, 1e-5, 1e-4] {
        for &(cam_y, pitch) in &[(2.0f32, 0.0f32), (0.5, 0.05), (-3.0, -0.02), (8.0, 0.3)] {
            let desc = sunlit_layer(
                falloff,
                Vec3::ZERO,
                Component {
                    scattering: Vec3::new(0.3, 0.05, 0.01),
                    absorption: Vec3::new(0.02, 0.0, 0.0),
                    phase: Phase::HenyeyGreenstein(0.8),
                },
            );
            let scene = Scene::new(desc.clone()).unwrap();
            let fwd = Vec3::new(0.0, pitch, -1.0).normalize();
            let cam = Camera::perspective(
                Vec3::new(0.0, cam_y, 0.0),
                fwd,
                Vec3::Y,
                1.1,
                w as f32 / h as f32,
            )
            .unwrap();
            let conv = DepthConvention::LinearView;
            let Some(frame) = scene.fog_pass_own_kernel(&cam, w, h, conv).unwrap() else {
                continue;
            };
            frames += 1;
            let rows = frame.uniform_rows;
            mixed += usize::from(rows > 0 && rows < h);
            let what = format!("falloff {falloff}, camera y {cam_y}, pitch {pitch}, {rows} rows");
            own_kernel_against_batch(&scene, &desc, &cam, (w, h), &depth, &what);
        }
    }
    eprintln!("{frames} frames, {mixed} with rows of both forms");
    assert!(frames >= 20 && mixed >= 6, "{frames} frames, {mixed} mixed");
}

/// Short rays in the own kernel's general rows (a rolled camera: no row has a constant
/// b·u) and in rows of constant b·u: depths from −1, −0 and 0 through subnormal ones
/// (1e-45, 1e-40, 1e-38) and 1e-30 to 1e-12 (below the frame's T_LO, where t is raised to
/// it, `HeightPass::t_lo`: subnormal depths had formed subnormal products, 18× the time
/// of typical depths on the Intel Xeon) and some above, linear and distance depths
/// (raised before their division, `HeightPass::d_lo`), falloffs typical, steep, tiny and
/// negative, coefficients from 1e-3 to 30, eyes 1.5 and 300 above the base (there
/// `HeightPass::g_lo` raises g'): every pixel against the batch API (T exactly 1 where
/// its T is, so the colour is left as it was) and the reference's bound.
#[test]
fn own_kernel_short_and_subnormal_depths() {
    let (w, h) = (21, 9);
    let depths = [
        -1.0f32, -0.0, 0.0, 1e-45, 1e-40, 1e-38, 1e-30, 1e-20, 1e-12, 1e-6, 0.3, 40.0,
    ];
    let depth: Vec<f32> = (0..w * h)
        .map(|i| depths[(i * 5 + i / w) % depths.len()])
        .collect();
    let (mut frames, mut general, mut unit) = (0, 0, 0);
    // Eyes at 1.5 and 300: from 300 above a fog of falloff 0.1, K ≈ 1e-18 and short
    // rays would form subnormal k·g' (the frame's `HeightPass::g_lo` floor).
    for (&falloff, &eye) in [0.1f32, 3.0, 1e-9, -0.7]
        .iter()
        .flat_map(|f| [(f, &1.5f32), (f, &300.0)])
    {
        for &scale in &[1e-3f32, 1.0, 30.0] {
            for &roll in &[0.0f32, 0.08] {
                for conv in [DepthConvention::LinearView, DepthConvention::Distance] {
                    let desc = sunlit_layer(
                        falloff,
                        Vec3::ZERO,
                        Component {
                            scattering: Vec3::new(0.3, 0.05, 0.01) * scale,
                            absorption: Vec3::new(0.02, 0.0, 0.0) * scale,
                            phase: Phase::HenyeyGreenstein(0.8),
                        },
                    );
                    let scene = Scene::new(desc.clone()).unwrap();
                    let cam = Camera::perspective(
                        Vec3::new(0.0, eye, 0.0),
                        Vec3::new(0.0, -0.1, -1.0).normalize(),
                        Vec3::new(roll, 1.0, 0.0),
                        1.1,
                        w as f32 / h as f32,
                    )
                    .unwrap();
                    let Some(frame) = scene.fog_pass_own_kernel(&cam, w, h, conv).unwrap() else {
                        continue;
                    };
                    frames += 1;
                    let rows = frame.uniform_rows;
                    general += usize::from(rows == 0);
                    unit += usize::from(rows > 0);
                    let what = format!(
                        "falloff {falloff}, eye {eye}, scale {scale}, roll {roll}, {conv:?}, {rows} rows"
                    );
                    let counts = own_kernel_against_batch_in(
                        &scene,
                        &desc,
                        &cam,
                        (w, h),
                        &depth,
                        conv,
                        &what,
                    );
                    // Some T is exactly 1 (the short rays).
                    assert!(counts[1] > 0, "{what}: {counts:?}");
                }
            }
        }
    }
    eprintln!("{frames} frames: {general} without rows of constant b·u, {unit} with");
    assert!(
        general >= 12 && unit >= 12,
        "{frames} frames, {general} general, {unit}"
    );
}

/// An eye far above thin fog (b = 0.1, ρ₀ from e^-25 to e^-60): the own kernel runs
/// (its clamp on t, T_BIG, is chosen per frame; with 1e20 fixed it declined such frames
/// from about 230 above the base), and agrees with the batch API and the reference,
/// looking down into the fog, level and up (nearly level sky rays included).
#[test]
fn own_kernel_eye_far_above_the_fog() {
    let (w, h) = (29, 7);
    let mut counts = [0usize; 3];
    for &eye in &[250.0f32, 400.0, 500.0, 600.0] {
        for &pitch in &[-0.6f32, -0.05, 0.0, 0.3] {
            let desc = typical_sunlit_layer();
            let scene = Scene::new(desc.clone()).unwrap();
            let fwd = Vec3::new(0.0, pitch, -1.0).normalize();
            let cam = Camera::perspective(Vec3::new(0.0, eye, 0.0), fwd, Vec3::Y, 1.2, 29.0 / 7.0)
                .unwrap();
            let own = scene
                .fog_pass_own_kernel(&cam, w, h, DepthConvention::LinearView)
                .unwrap()
                .is_some();
            assert!(own, "eye {eye}, pitch {pitch}: the own kernel declined");
            let depth = saturation_depths(w * h);
            let what = format!("eye {eye}, pitch {pitch}");
            let c = own_kernel_against_batch(&scene, &desc, &cam, (w, h), &depth, &what);
            (0..3).for_each(|k| counts[k] += c[k]);
        }
    }
    eprintln!(
        "T = 0: {}, T = 1: {}, Δ < −88: {}",
        counts[0], counts[1], counts[2]
    );
    // Saturated and vanishing fog both occur.
    assert!(counts[0] > 50 && counts[1] > 50, "{counts:?}");
}

/// A NaN depth gives NaN fog in the own kernel too, at every position of a packet and in
/// a row's tail, and its neighbours stay finite (AVX-512 lanes turn a NaN y' into ±TINY;
/// the NaN reaches the pixel through n·t), in the RGB and planar layouts, with linear,
/// distance and reversed-Z depth. Also among sky pixels in rows looking up, whose
/// blocks skip `exp2m1` (every y' at most −32: `pass::height::FLAT_Y`), where the NaN
/// comes through fma(y', 0, −1) in rows of constant b·u and through the quotient by y'
/// in rolled rows.
#[test]
fn own_kernel_nan_depth_gives_nan_fog() {
    let (w, h) = (37, 3);
    let desc = typical_sunlit_layer();
    let scene = Scene::new(desc).unwrap();
    let nan_at = |i: usize| i.is_multiple_of(5) || i % w == w - 1;
    let level = Vec3::NEG_Z;
    // Every row looks up: the forward view 26.6° up, the rows' centres within 20° of it.
    let up_view = Vec3::new(0.0, 0.5, -1.0).normalize();
    // Upright (rows of constant b·u) and rolled (b·u varies along a row); AVX-512 lanes
    // turn a NaN y' into ±TINY, so the 8-lane path is where a rolled row's NaN meets a
    // block that skips `exp2m1`.
    let rolled = Vec3::new(0.05, 1.0, 0.0);
    for scene in [scene.clone(), scene.without_avx512_dispatch()] {
        for up in [Vec3::Y, rolled] {
            for (forward, other) in [(level, 0.5), (up_view, f32::INFINITY), (up_view, 1e30)] {
                let cam =
                    Camera::perspective(Vec3::new(0.0, 2.0, 0.0), forward, up, 1.0, 2.0).unwrap();
                nan_depth_frame(&scene, &cam, (w, h), other, nan_at);
            }
        }
    }
}

/// One frame of `own_kernel_nan_depth_gives_nan_fog`: NaN at `nan_at`, `other`
/// elsewhere (the sky at 0 for reversed-Z where `other` is beyond 1), in each depth
/// convention, fogged by the parallel and the single-threaded pass.
fn nan_depth_frame(
    scene: &Scene,
    cam: &Camera,
    (w, h): (usize, usize),
    other: f32,
    nan_at: impl Fn(usize) -> bool,
) {
    let n = w * h;
    for conv in [
        DepthConvention::LinearView,
        DepthConvention::Distance,
        DepthConvention::NdcZeroToOne {
            near: 0.1,
            far: 1000.0,
            reversed: true,
        },
    ] {
        assert!(scene
            .fog_pass_own_kernel(cam, w, h, conv)
            .unwrap()
            .is_some());
        // (Reversed-Z: the sky at 0.)
        let other = match conv {
            DepthConvention::NdcZeroToOne { .. } if other > 1.0 => 0.0,
            _ => other,
        };
        let depth: Vec<f32> = (0..n)
            .map(|i| if nan_at(i) { f32::NAN } else { other })
            .collect();
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        let mut rgb = vec![0.25f32; 3 * n];
        scene
            .fog_pass(cam, w, h, d, ColourBuffer::Rgb(&mut rgb))
            .unwrap();
        let mut planes = [vec![0.25f32; n], vec![0.25; n], vec![0.25; n]];
        let [r, g, b] = &mut planes;
        scene
            .fog_pass_single(cam, w, h, d, ColourBuffer::Planar([r, g, b]))
            .unwrap();
        for i in 0..n {
            for c in 0..3 {
                for v in [rgb[3 * i + c], planes[c][i]] {
                    assert_eq!(
                        v.is_nan(),
                        nan_at(i),
                        "{conv:?}, pixel {i}, channel {c}: {v}"
                    );
                }
            }
        }
    }
}

/// The own kernel's composite at the ends of the colour range: L ← c + (L − c)·T where
/// every fog colour c of the frame is at most 2^100 (`HeightPass::lerp`: L − c cannot
/// overflow, and is never ∞ times T = 0), L·T + c·(1 − T) above it, and the colour
/// clamped where it may exceed 1e38; on colour buffers holding ±f32::MAX, ±1e30, ±1 and 0
/// among depths whose T is 0, 1 and between (`saturation_depths`). No NaN anywhere;
/// every pixel whose composite L·T + L_in (T and L_in from the batch API, in f64) is below
/// f32::MAX within 2e-5·(|L| + C) of it (C the frame's largest L_in, the fog colour where
/// T = 0), finite where it is below 0.999·f32::MAX; the three layouts the same bits.
#[test]
fn own_kernel_composite_of_extreme_colours() {
    let (w, h) = (37, 5);
    let n = w * h;
    let surfaces = [
        f32::MAX,
        -f32::MAX,
        1e30,
        -1e30,
        1.0,
        -1.0,
        0.0,
        3e38,
        -2.5e38,
        0.25,
    ];
    let cam = Camera::perspective(
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(0.0, -0.1, -1.0).normalize(),
        Vec3::Y,
        1.2,
        w as f32 / h as f32,
    )
    .unwrap();
    let conv = DepthConvention::LinearView;
    let depth = saturation_depths(n);
    let mut checked = 0;
    // The sun's radiance sets the fog colour's scale: the first two frames composite as
    // c + (L − c)·T, the others as L·T + L_in (the last one with the colour's clamp).
    for &radiance in &[20.0f32, 1e29, 1e31, 1e37, 3e38] {
        let mut desc = typical_sunlit_layer();
        if let Some(sun) = desc.lighting.sun.as_mut() {
            sun.radiance = Vec3::splat(radiance);
        }
        let scene = Scene::new(desc.clone()).unwrap();
        assert!(scene
            .fog_pass_own_kernel(&cam, w, h, conv)
            .unwrap()
            .is_some());
        let d = Depth {
            values: &depth,
            convention: conv,
        };
        let surface = |i: usize, c: usize| surfaces[(3 * i + c + i / w) % surfaces.len()];
        let mut rgb: Vec<f32> = (0..3 * n).map(|k| surface(k / 3, k % 3)).collect();
        let mut rgba: Vec<f32> = (0..4 * n)
            .map(|k| {
                if k % 4 == 3 {
                    0.5
                } else {
                    surface(k / 4, k % 4)
                }
            })
            .collect();
        let mut planes = [0, 1, 2].map(|c| (0..n).map(|i| surface(i, c)).collect::<Vec<_>>());
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut rgb))
            .unwrap();
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Rgba(&mut rgba))
            .unwrap();
        let [pr, pg, pb] = &mut planes;
        scene
            .fog_pass(&cam, w, h, d, ColourBuffer::Planar([pr, pg, pb]))
            .unwrap();
        let (bt, bl) = batch_reference(&scene, &cam, w, h, &depth, conv);
        let scale = bl.iter().flatten().fold(1e-30f64, |m, &l| m.max(l as f64));
        for i in 0..n {
            for c in 0..3 {
                let ctx = || format!("radiance {radiance}, pixel {i}, channel {c}");
                let out = rgb[3 * i + c];
                assert_eq!(out.to_bits(), rgba[4 * i + c].to_bits(), "RGBA: {}", ctx());
                assert_eq!(out.to_bits(), planes[c][i].to_bits(), "planar: {}", ctx());
                assert!(!out.is_nan(), "NaN: {}", ctx());
                let l = surface(i, c) as f64;
                let want = l * bt[i][c] as f64 + bl[i][c] as f64;
                if want.abs() < 0.999 * f32::MAX as f64 {
                    assert!(out.is_finite(), "{out} for {want}: {}", ctx());
                }
                if want.abs() <= f32::MAX as f64 {
                    let tol = 2e-5 * (l.abs() + scale);
                    assert!(
                        (out as f64 - want).abs() <= tol,
                        "{out} against {want}: {}",
                        ctx()
                    );
                    checked += 1;
                }
            }
            assert_eq!(rgba[4 * i + 3], 0.5, "alpha");
        }
    }
    assert!(checked >= 5 * 3 * n * 9 / 10, "{checked} channels checked");
}

/// The linear form of the phase function's q (`linear_phase` of
/// `Scene::fog_pass_own_kernel`: q from cos θ, which cancels toward the peak of
/// Henyey–Greenstein's lobe) at that peak: the sun in the middle of narrow frames of an
/// upright or a rolled camera, no ambient light and dense fog (L_in near the fog colour,
/// all of it the sun's), every pixel against the f64 reference with the crate's bound, in
/// the lane widths the pass runs and in the four depth conventions. |g| up to 0.6 takes
/// the linear form (its error bound within 2⁻¹⁷), 0.7 and 0.9 do not.
#[test]
fn linear_phase_form_within_the_bound_at_the_peak() {
    let mut rng = Rng(0x5eed_0056);
    let sun = Vec3::new(0.3, 0.2, -0.93).normalize();
    let (w, h) = (61, 37);
    let mut worst = 0.0f64;
    // (g, field of view, takes the linear form, camera rolled: no row of constant b·u)
    for (g, fov, linear, rolled) in [
        (0.6, 0.02, true, false),
        (0.6, 0.3, true, false),
        (-0.6, 0.02, true, false),
        (0.45, 0.05, true, false),
        (0.2, 1.2, true, false),
        (0.6, 0.3, true, true),
        (-0.45, 0.05, true, true),
        (0.7, 0.02, false, false),
        (0.9, 0.05, false, true),
    ] {
        let desc = SceneDesc {
            height_fog: vec![HeightFogLayer {
                base_height: 0.0,
                falloff: 0.05,
                emission: Vec3::ZERO,
                components: vec![Component {
                    scattering: Vec3::new(0.2, 0.3, 0.5),
                    absorption: Vec3::ZERO,
                    phase: Phase::HenyeyGreenstein(g),
                }],
            }],
            lighting: Lighting {
                ambient: Vec3::ZERO,
                sun: Some(Sun {
                    direction: sun,
                    radiance: Vec3::new(20.0, 18.0, 15.0),
                }),
            },
            ..SceneDesc::default()
        };
        let scene = Scene::new(desc.clone()).unwrap();
        // Toward the sun where g > 0 (the lobe's peak forward), away where g < 0.
        let fwd = if g > 0.0 { sun } else { -sun };
        let up = if rolled {
            Vec3::new(0.4, 1.0, 0.1)
        } else {
            Vec3::Y
        };
        let cam = Camera::perspective(Vec3::new(1.0, 3.0, -2.0), fwd, up, fov, 1.5).unwrap();
        let z: Vec<f32> = (0..w * h)
            .map(|i| {
                if i % 7 == 0 {
                    f32::INFINITY
                } else {
                    rng.range(20.0, 2000.0)
                }
            })
            .collect();
        let ndc = |near: f64, far: f64, reversed: bool| {
            let conv = DepthConvention::NdcZeroToOne {
                near: near as f32,
                far: far as f32,
                reversed,
            };
            // The standard [0, 1] depth far·(z − near)/(z·(far − near)); reversed 1 − it.
            let v = z.iter().map(|&z| {
                let s = if z.is_infinite() {
                    1.0
                } else if far.is_infinite() {
                    1.0 - near / f64::from(z)
                } else {
                    far * (f64::from(z) - near) / (f64::from(z) * (far - near))
                };
                (if reversed { 1.0 - s } else { s }) as f32
            });
            (conv, v.collect::<Vec<f32>>())
        };
        for (conv, depth) in [
            (DepthConvention::LinearView, z.clone()),
            // (As distances along the rays: other rays, as good for the check.)
            (DepthConvention::Distance, z.clone()),
            ndc(0.5, 5000.0, false),
            ndc(0.1, f64::INFINITY, true),
        ] {
            assert_eq!(
                scene
                    .fog_pass_own_kernel(&cam, w, h, conv)
                    .unwrap()
                    .is_some_and(|f| f.linear_phase),
                linear,
                "g {g}, rolled {rolled}, {conv:?}"
            );
            let d = Depth {
                values: &depth,
                convention: conv,
            };
            for lanes in 0..3 {
                let sc = match lanes {
                    0 => scene.clone(),
                    1 => scene.clone().with_pass_lanes_8(),
                    _ => scene.clone().without_avx512_dispatch(),
                };
                let mut black = vec![0.0f32; 3 * w * h];
                sc.fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut black))
                    .unwrap();
                let mut white = vec![BIG; 3 * w * h];
                sc.fog_pass(&cam, w, h, d, ColourBuffer::Rgb(&mut white))
                    .unwrap();
                for i in 0..w * h {
                    let ray = cam.pixel_ray(i % w, i / w, w, h, depth[i], conv).unwrap();
                    let l = [0, 1, 2].map(|c| black[3 * i + c]);
                    let t = [0, 1, 2].map(|c| recover_t(white[3 * i + c], l[c]));
                    let ctx = || {
                        format!(
                            "g {g}, fov {fov}, rolled {rolled}, {conv:?}, lanes {lanes}, pixel {i}"
                        )
                    };
                    let (_, chk) = check_pixel(&desc, &ray, t, l, ctx);
                    worst = worst.max(chk.insc_ratio);
                }
            }
        }
    }
    eprintln!("linear phase form at the peak: worst L_in ratio to the bound {worst:.3}");
}
