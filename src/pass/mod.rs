//! The framebuffer fog pass: what a CPU software renderer calls once per frame.
//!
//! [`Scene::fog_pass`] takes a [`Camera`], the frame's depth buffer ([`Depth`]) and its
//! linear-light colour buffer ([`ColourBuffer`]) and fogs the colour in place:
//! `L = L_surface · T + L_in` per channel, with T and L_in the fog of the pixel's ray from
//! the camera to the surface (t = +∞ for sky pixels). Rays are generated 8 pixels at a
//! time in registers (16 in the own kernel, two halves of 8 in an AVX2 build; no per-pixel
//! ray buffer), bands of rows run in parallel with rayon
//! ([`Scene::fog_pass_single`]: on the calling thread), and everything that does not
//! change per pixel (the NDC mapping, the camera's ray field, the depth conversion
//! constants; the scene's phase and colour constants live in the compiled [`Scene`]) is
//! computed once per frame. The height-dependent terms of the camera (its density) are
//! computed per ray by the same kernel as the batch API. With fog volumes, each tile of
//! 32×8 pixels gets the list of the volumes its rays may reach, built once and used by all
//! its packets (`cull.rs`); the list changes no result.
//!
//! Two kernels. The most common frame, one height fog layer and nothing else seen
//! through a perspective camera (or an orthographic one upright in the scene), runs the
//! pass's own kernel (`height.rs`): every ray starts at the eye (at its row's height), so
//! the density there is a constant of the frame (of the row; computed once, in f64) and
//! each pixel needs one `exp2m1` where the batch kernel, which takes any origin,
//! carries two exponentials' exponents apart; its rays are processed in stages over blocks
//! of packets, and an interleaved RGB buffer gets T and L_in in its own layout. Its T and L_in are within the crate's accuracy bound of the f64 reference
//! (`tests/pass.rs` checks every pixel of random frames: at most 0.654 of the bound) and
//! within 4.3e-7 of the batch API's (T absolute, L_in relative to the fog colour; same
//! test, measured on Zen 5), not bit-identical. Its |d| and phase denominators use the hardware reciprocal
//! square root estimate refined by one Newton step: the same bits on every run, thread
//! count and colour layout on one machine, but CPUs whose estimates differ (AMD and Intel
//! do, and AVX-512's `vrsqrt14ps`, which the lanes chosen at run time take, differs from
//! AVX2's `vrsqrtps`) may differ in the last bits, within the bound. Frames outside its ranges (an eye thousands of scale heights
//! above or below the fog, extinctions beyond 1e±30, see `height.rs`) fall back to the
//! batch kernel.
//!
//! Every other frame (several layers, fog volumes, distance fog and the other controls,
//! other orthographic cameras), and every frame of a scene made with
//! [`Scene::with_batch_kernel_pass`], runs the batch API's kernel, and a pixel's result is
//! bit-identical to the batch API's for the ray [`Camera::pixel_ray`] returns: the pass
//! generates the same f32 ray with the same operations, evaluates it with the same kernel
//! instantiation (rays not marked unit) at the build's width (`kernel::Wide`: 8 lanes, or
//! 16 with AVX-512, whose lanes give the same bits as 8; a single layer takes 16 lanes
//! chosen at run time where the CPU has AVX-512, as the batch API does), pads the tail of
//! a row into one more packet as the batch loop pads its tail, and composites with one fused
//! multiply-add per channel,
//! `L_surface.mul_add(T, L_in)` through [`Lane::mul_add`] (fused where the target has
//! FMA); the own kernel composites the same way.
//!
//! Buffers are row-major with row 0 at the top: pixel (x, y) is element `y·width + x` of
//! the depth buffer and of each planar channel, elements `3·(y·width + x) + c` of an RGB
//! buffer and `4·(y·width + x) + c` of an RGBA one (alpha, c = 3, is left untouched).
//! Pixel rays go through pixel centres; see [`Camera`] for the NDC convention.

mod camera;
mod cull;
mod height;

pub use crate::error::PassError;
pub use camera::{Camera, DepthConvention, PixelRay, Projection};

use crate::kernel::Wide;
use crate::kernel::{run_packets, run_packets_single, PacketIn, PacketIo, PacketOut};
use crate::math::Lane;
use crate::scene::Scene;
use camera::{FramePlan, RowPlan};
use cull::{FrameCull, TileLists, TILE_H, TILE_W};
use height::{HeightPass, OwnKernel, PassLane};
use rayon::prelude::*;
use wide::f32x8;

/// A depth buffer (`width × height` values, row-major, row 0 at the top) and how to read
/// it.
#[derive(Clone, Copy, Debug)]
pub struct Depth<'a> {
    /// One value per pixel.
    pub values: &'a [f32],
    /// What the values mean.
    pub convention: DepthConvention,
}

impl<'a> Depth<'a> {
    /// Linear view depth ([`DepthConvention::LinearView`]).
    pub fn linear_view(values: &'a [f32]) -> Self {
        Depth {
            values,
            convention: DepthConvention::LinearView,
        }
    }

    /// Distance along the ray ([`DepthConvention::Distance`]).
    pub fn distance(values: &'a [f32]) -> Self {
        Depth {
            values,
            convention: DepthConvention::Distance,
        }
    }

    /// A rasterizer's [0, 1] depth, 0 at `near` ([`DepthConvention::NdcZeroToOne`]).
    pub fn ndc(values: &'a [f32], near: f32, far: f32) -> Self {
        Depth {
            values,
            convention: DepthConvention::NdcZeroToOne {
                near,
                far,
                reversed: false,
            },
        }
    }

    /// A rasterizer's reversed-Z [0, 1] depth, 1 at `near`, 0 at `far` (which may be
    /// `+inf`) ([`DepthConvention::NdcZeroToOne`]).
    pub fn ndc_reversed(values: &'a [f32], near: f32, far: f32) -> Self {
        Depth {
            values,
            convention: DepthConvention::NdcZeroToOne {
                near,
                far,
                reversed: true,
            },
        }
    }
}

/// A linear-light f32 colour buffer, fogged in place (row-major, row 0 at the top).
#[derive(Debug)]
pub enum ColourBuffer<'a> {
    /// Interleaved RGB: `3 · width · height` values.
    Rgb(&'a mut [f32]),
    /// Interleaved RGBA: `4 · width · height` values; alpha is not touched.
    Rgba(&'a mut [f32]),
    /// One plane per channel (R, G, B), `width · height` values each.
    Planar([&'a mut [f32]; 3]),
}

/// A band of a planar frame: its index, the three planes' rows and the depth rows.
type PlanarBand<'a> = (
    usize,
    (((&'a mut [f32], &'a mut [f32]), &'a mut [f32]), &'a [f32]),
);

/// Pixels per parallel task (whole rows, at least one): about 100 KB of colour and depth.
const BAND_PIXELS: usize = 4096;
/// At most this many for the frame's own kernel (`height.rs`), whose per-band set-up
/// costs more: 17 rows of a 1920-pixel frame.
const OWN_BAND_PIXELS: usize = 32768;

impl Scene {
    /// Fogs a frame in place: every pixel's colour L becomes `L · T + L_in`, with T and
    /// L_in the fog along the pixel's ray ([`Camera::pixel_ray`]) from the camera to the
    /// depth buffer's surface (t = +∞ for sky pixels). Bands of rows run in parallel with
    /// rayon; [`Scene::fog_pass_single`] does the same on the calling thread. A pixel's
    /// result is [`Scene::eval_ray`] for the same ray followed by `L.mul_add(T, L_in)`:
    /// bit for bit where the pass runs the batch kernel, within the accuracy bound where
    /// it runs its own one-layer kernel (see the [module](crate::pass) documentation).
    ///
    /// Errors (nothing is written) if a buffer's length does not fit `width × height`
    /// (naming the buffer), or for an unusable depth convention (e.g. a perspective
    /// `near ≤ 0`).
    ///
    /// ```
    /// use analytic_fog::pass::{Camera, ColourBuffer, Depth};
    /// use analytic_fog::{Component, HeightFogLayer, Lighting, Phase, Scene, SceneDesc, Sun};
    /// use glam::Vec3;
    ///
    /// let scene = Scene::new(SceneDesc {
    ///     height_fog: vec![HeightFogLayer {
    ///         base_height: 0.0,
    ///         falloff: 0.1,
    ///         emission: glam::Vec3::ZERO,
    ///         components: vec![Component {
    ///             scattering: Vec3::new(0.02, 0.03, 0.05),
    ///             absorption: Vec3::ZERO,
    ///             phase: Phase::HenyeyGreenstein(0.6),
    ///         }],
    ///     }],
    ///     lighting: Lighting {
    ///         ambient: Vec3::new(0.5, 0.6, 0.7),
    ///         sun: Some(Sun { direction: Vec3::new(0.3, 0.4, -0.87), radiance: Vec3::splat(20.0) }),
    ///     },
    ///     ..SceneDesc::default()
    /// })?;
    /// let (w, h) = (64, 36);
    /// let camera = Camera::perspective(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Z, Vec3::Y, 1.0, w as f32 / h as f32)?;
    ///
    /// // A reversed-Z depth buffer (0 = sky) and an RGBA frame.
    /// let depth: Vec<f32> = (0..w * h).map(|i| if i < w * h / 2 { 0.0 } else { 0.01 }).collect();
    /// let mut rgba = vec![1.0f32; 4 * w * h];
    /// scene.fog_pass(&camera, w, h, Depth::ndc_reversed(&depth, 0.1, f32::INFINITY), ColourBuffer::Rgba(&mut rgba))?;
    /// assert!(rgba[0] != 1.0 && rgba[3] == 1.0); // fogged; alpha untouched
    ///
    /// // The same pixel through the batch API: within the accuracy bound (this frame runs
    /// // the pass's own kernel), and bit for bit with `with_batch_kernel_pass`.
    /// let r = camera.pixel_ray(0, 0, w, h, depth[0], Depth::ndc_reversed(&depth, 0.1, f32::INFINITY).convention)?;
    /// let f = scene.eval_ray(r.origin, r.direction, r.t);
    /// use analytic_fog::math::Lane;
    /// let expected = Lane::mul_add(1.0f32, f.transmittance.x, f.inscattering.x);
    /// assert!((rgba[0] - expected).abs() <= 1e-6 * expected);
    /// let exact = scene.clone().with_batch_kernel_pass();
    /// let mut rgba = vec![1.0f32; 4 * w * h];
    /// exact.fog_pass(&camera, w, h, Depth::ndc_reversed(&depth, 0.1, f32::INFINITY), ColourBuffer::Rgba(&mut rgba))?;
    /// assert_eq!(rgba[0], expected);
    ///
    /// // Wrong lengths name the buffer.
    /// let err = scene.fog_pass(&camera, w, h, Depth::linear_view(&depth[1..]), ColourBuffer::Rgba(&mut rgba));
    /// assert_eq!(err.unwrap_err().to_string(), "depth: has 2303 elements, a 64x36 frame needs 2304");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn fog_pass(
        &self,
        camera: &Camera,
        width: usize,
        height: usize,
        depth: Depth<'_>,
        colour: ColourBuffer<'_>,
    ) -> Result<(), PassError> {
        fog_pass(self, camera, width, height, depth, colour, true)
    }

    /// [`Scene::fog_pass`] on the calling thread (no rayon). Same results, bit for bit.
    pub fn fog_pass_single(
        &self,
        camera: &Camera,
        width: usize,
        height: usize,
        depth: Depth<'_>,
        colour: ColourBuffer<'_>,
    ) -> Result<(), PassError> {
        fog_pass(self, camera, width, height, depth, colour, false)
    }

    /// This scene with the framebuffer pass's per-tile culling of fog volumes switched
    /// off, the per-packet culling kept (as in the batch API). For tests and benchmarks:
    /// it changes no result.
    #[doc(hidden)]
    pub fn without_tile_culling(mut self) -> Scene {
        self.volumes.no_tile_culling = true;
        self
    }

    /// The number of candidate fog volumes the pass gives the kernel for each tile of
    /// `tile_size()` pixels (row-major over the frame's tiles), or `None` where the pass
    /// lists none (no additive volume, or culling switched off). For tests and benchmarks.
    #[doc(hidden)]
    pub fn fog_pass_tile_candidates(
        &self,
        camera: &Camera,
        width: usize,
        height: usize,
        depth: Depth<'_>,
    ) -> Result<Option<Vec<usize>>, PassError> {
        check_len("depth", depth.values.len(), 1, width, height)?;
        let plan = FramePlan::new(camera, width, height, depth.convention)?;
        if width == 0 || height == 0 {
            return Ok(None);
        }
        let Some(cull) = FrameCull::new(self, &plan, width, height) else {
            return Ok(None);
        };
        let mut counts = Vec::new();
        let mut lists = TileLists::default();
        for (g, d) in depth.values.chunks(TILE_H * width).enumerate() {
            cull.tiles(&plan, g * TILE_H, d, &mut lists);
            counts.extend((0..lists.len()).map(|j| lists.list(j).len()));
        }
        Ok(Some(counts))
    }

    /// What [`Scene::fog_pass`] runs for this camera, frame size and depth convention:
    /// `Some` where its own one-layer kernel (`height.rs`), with the choices it makes for
    /// the frame, `None` where the batch API's. For tests and benchmarks.
    #[doc(hidden)]
    pub fn fog_pass_own_kernel(
        &self,
        camera: &Camera,
        width: usize,
        height: usize,
        convention: DepthConvention,
    ) -> Result<Option<OwnKernelFrame>, PassError> {
        Ok(self
            .own_height_pass(camera, width, height, convention)?
            .map(|(plan, hp)| OwnKernelFrame {
                uniform_rows: hp.uniform_rows(&plan, height),
                linear_phase: hp.phase_linear(),
            }))
    }

    /// The frame's plan and own kernel constants where [`Scene::fog_pass`] runs the own
    /// kernel (the choice `fog_pass` makes: no exact pass, no volumes to cull, a frame
    /// `HeightPass::new` accepts).
    fn own_height_pass(
        &self,
        camera: &Camera,
        width: usize,
        height: usize,
        convention: DepthConvention,
    ) -> Result<Option<(FramePlan, HeightPass)>, PassError> {
        let plan = FramePlan::new(camera, width, height, convention)?;
        if self.exact_pass || FrameCull::new(self, &plan, width, height).is_some() {
            return Ok(None);
        }
        Ok(HeightPass::new(self, &plan).map(|hp| (plan, hp)))
    }

    /// The tile size of [`Scene::fog_pass_tile_candidates`]: (width, height) in pixels.
    #[doc(hidden)]
    pub fn tile_size() -> (usize, usize) {
        (cull::TILE_W, TILE_H)
    }
}

fn check_len(
    buffer: &'static str,
    found: usize,
    channels: usize,
    width: usize,
    height: usize,
) -> Result<(), PassError> {
    let expected = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .ok_or(PassError::FrameTooLarge { width, height })?;
    if found == expected {
        Ok(())
    } else {
        Err(PassError::BufferLength {
            buffer,
            expected,
            found,
            width,
            height,
        })
    }
}

fn fog_pass(
    scene: &Scene,
    camera: &Camera,
    width: usize,
    height: usize,
    depth: Depth<'_>,
    colour: ColourBuffer<'_>,
    par: bool,
) -> Result<(), PassError> {
    check_len("depth", depth.values.len(), 1, width, height)?;
    match &colour {
        ColourBuffer::Rgb(c) => check_len("colour", c.len(), 3, width, height)?,
        ColourBuffer::Rgba(c) => check_len("colour", c.len(), 4, width, height)?,
        ColourBuffer::Planar([r, g, b]) => {
            check_len("colour.r", r.len(), 1, width, height)?;
            check_len("colour.g", g.len(), 1, width, height)?;
            check_len("colour.b", b.len(), 1, width, height)?;
        }
    }
    let plan = FramePlan::new(camera, width, height, depth.convention)?;
    if width == 0 || height == 0 {
        return Ok(());
    }
    // With fog volumes, bands of whole tile rows, whose tiles' candidate lists are built
    // once and used by all their packets (`cull`).
    let cull = FrameCull::new(scene, &plan, width, height);
    let cull = cull.as_ref();
    // The frame's own kernel where it applies (`height.rs`).
    let hp = if cull.is_none() && !scene.exact_pass {
        OwnKernel::new(scene, &plan, width)
    } else {
        None
    };
    let hp = hp.as_ref();
    let band = match (cull, hp) {
        (Some(_), _) => TILE_H * (BAND_PIXELS / (width * TILE_H)).max(1),
        // The own kernel sets up its block buffers once per band (about 12 KB zeroed, the
        // constants formed): in bands of two 1920-pixel rows a 1080p frame took 1.12× the
        // time of one band on Zen 5 (thirtieth session). So one band on one thread, and in
        // parallel larger ones where there are rows enough for at least eight per thread.
        (None, Some(_)) if !par => height,
        (None, Some(_)) => crate::kernel::par_task_len(
            height,
            (BAND_PIXELS / width).max(1),
            (OWN_BAND_PIXELS / width).max(1),
        ),
        (None, None) => (BAND_PIXELS / width).max(1),
    };
    let d = depth.values;
    match colour {
        ColourBuffer::Rgb(c) => interleaved::<3>(scene, &plan, cull, hp, width, band, d, c, par),
        ColourBuffer::Rgba(c) => interleaved::<4>(scene, &plan, cull, hp, width, band, d, c, par),
        ColourBuffer::Planar([r, g, b]) => {
            let f = |(bi, (((r, g), b), d)): PlanarBand<'_>| {
                if let Some(cull) = cull {
                    let mut rows: Vec<Planar<'_>> = r
                        .chunks_exact_mut(width)
                        .zip(g.chunks_exact_mut(width))
                        .zip(b.chunks_exact_mut(width))
                        .map(|((r, g), b)| Planar([r, g, b]))
                        .collect();
                    fog_band_tiled(scene, &plan, cull, bi * band, d, &mut rows);
                    return;
                }
                let rows = d
                    .chunks_exact(width)
                    .zip(r.chunks_exact_mut(width))
                    .zip(g.chunks_exact_mut(width))
                    .zip(b.chunks_exact_mut(width))
                    .map(|(((dr, r), g), b)| (dr, Planar([r, g, b])));
                match hp {
                    Some(hp) => height::fog_rows(hp, &plan, bi * band, rows),
                    None => {
                        for (k, (dr, row)) in rows.enumerate() {
                            fog_row(scene, &plan, bi * band + k, dr, row);
                        }
                    }
                }
            };
            let n = width * band;
            if par {
                r.par_chunks_mut(n)
                    .zip(g.par_chunks_mut(n))
                    .zip(b.par_chunks_mut(n))
                    .zip(d.par_chunks(n))
                    .enumerate()
                    .for_each(f);
            } else {
                r.chunks_mut(n)
                    .zip(g.chunks_mut(n))
                    .zip(b.chunks_mut(n))
                    .zip(d.chunks(n))
                    .enumerate()
                    .for_each(f);
            }
        }
    }
    Ok(())
}

#[allow(clippy::too_many_arguments)]
fn interleaved<const C: usize>(
    scene: &Scene,
    plan: &FramePlan,
    cull: Option<&FrameCull>,
    hp: Option<&OwnKernel>,
    width: usize,
    band: usize,
    depth: &[f32],
    colour: &mut [f32],
    par: bool,
) {
    let f = |(bi, (c, d)): (usize, (&mut [f32], &[f32]))| {
        if let Some(cull) = cull {
            let mut rows: Vec<Interleaved<'_, C>> = c
                .chunks_exact_mut(C * width)
                .map(Interleaved::<C>)
                .collect();
            fog_band_tiled(scene, plan, cull, bi * band, d, &mut rows);
            return;
        }
        let rows = d
            .chunks_exact(width)
            .zip(c.chunks_exact_mut(C * width))
            .map(|(dr, cr)| (dr, Interleaved::<C>(cr)));
        match hp {
            Some(hp) => height::fog_rows(hp, plan, bi * band, rows),
            None => {
                for (k, (dr, row)) in rows.enumerate() {
                    fog_row(scene, plan, bi * band + k, dr, row);
                }
            }
        }
    };
    if par {
        colour
            .par_chunks_mut(C * width * band)
            .zip(depth.par_chunks(width * band))
            .enumerate()
            .for_each(f);
    } else {
        colour
            .chunks_mut(C * width * band)
            .zip(depth.chunks(width * band))
            .enumerate()
            .for_each(f);
    }
}

/// One row of a colour buffer: loads and stores up to 8 pixels as three channel lanes.
trait RowColour {
    /// An interleaved RGB row: [`RowColour::fog_rgb3`] applies.
    const RGB3: bool = false;
    fn load(&self, x0: usize, n: usize) -> [f32x8; 3];
    fn store(&mut self, x0: usize, n: usize, v: [f32x8; 3]);
    /// For [`RowColour::RGB3`] rows: [`over`] for the `W::LANES` pixels from `x0`, with T
    /// and `v` (L_in, or with `lerp` the fog colour) given in the buffer's interleaved
    /// layout (3·LANES values in three vectors).
    #[inline(always)]
    fn fog_rgb3<W: Lane>(&mut self, x0: usize, trans: [W; 3], v: [W; 3], lerp: bool) {
        let _ = (x0, trans, v, lerp);
        unreachable!("fog_rgb3 on a row that is not interleaved RGB");
    }
    /// Asks the cache for the colour of the `n` pixels from `x0` ahead of
    /// [`RowColour::fog_rgb3`]/[`RowColour::fog_wide`] (a hint; nothing by default). `x0`
    /// may lie past the row's end (the pass asks one block ahead): nothing is read.
    #[inline(always)]
    fn prefetch(&self, x0: usize, n: usize) {
        let _ = (x0, n);
    }
    /// [`over`] for the `n` pixels from `x0`.
    #[inline(always)]
    fn fog(&mut self, x0: usize, n: usize, trans: [f32x8; 3], v: [f32x8; 3], lerp: bool) {
        let l = self.load(x0, n);
        let out = rgb!(ch => over(l[ch], trans[ch], v[ch], lerp));
        self.store(x0, n, out);
    }
    /// [`RowColour::fog`] for a packet of `W::LANES` pixels (`n` of them live), in pieces
    /// of 8: the layouts load and store 8 lanes.
    #[inline(always)]
    fn fog_wide<W: PassLane>(&mut self, x0: usize, n: usize, trans: [W; 3], v: [W; 3], lerp: bool) {
        for h in 0..W::LANES / 8 {
            let live = n.saturating_sub(8 * h).min(8);
            if live > 0 {
                let t = [trans[0].part(h), trans[1].part(h), trans[2].part(h)];
                let v = [v[0].part(h), v[1].part(h), v[2].part(h)];
                self.fog(x0 + 8 * h, live, t, v, lerp);
            }
        }
    }
}

/// A pixel's channel L fogged: `L · T + v` (v = L_in: one fused multiply-add), or with
/// `lerp` `v + (L − v) · T` (v = the fog colour c, L_in = c·(1 − T): a subtraction and
/// one fused multiply-add, the same pixel rounded otherwise; the caller keeps |c| small
/// enough that L − c stays finite for finite L: `height::HeightPass`'s `lerp`). `lerp` is
/// a literal or a frame's constant at each call.
#[inline(always)]
fn over<W: Lane>(l: W, t: W, v: W, lerp: bool) -> W {
    if lerp {
        Lane::mul_add(l - v, t, v)
    } else {
        Lane::mul_add(l, t, v)
    }
}

/// Three channel lanes of 8 pixels as the 24 interleaved values `r0 g0 b0 r1 …` in three
/// lanes (LLVM turns it into shuffles).
#[inline(always)]
fn interleave3(v: [f32x8; 3]) -> [f32x8; 3] {
    let (r, g, b) = (v[0].to_array(), v[1].to_array(), v[2].to_array());
    [
        f32x8::new([r[0], g[0], b[0], r[1], g[1], b[1], r[2], g[2]]),
        f32x8::new([b[2], r[3], g[3], b[3], r[4], g[4], b[4], r[5]]),
        f32x8::new([g[5], b[5], r[6], g[6], b[6], r[7], g[7], b[7]]),
    ]
}

/// Asks for the `bytes` from `p` (rounded to cache lines of 64 bytes from `p`; a line
/// that `p` starts inside is the previous call's) to be read soon: [`prefetch_read`]
/// for each line. The pass reads and then writes each colour it fogs, in order, so the
/// lines it asks for are each asked for once.
#[inline(always)]
fn prefetch_bytes(p: *const f32, bytes: usize) {
    let mut off = 0;
    while off < bytes {
        prefetch_read(p.wrapping_byte_add(off));
        off += 64;
    }
}

/// Asks for the cache line at `p` to be read soon (`prefetcht0`). A hint only, no access:
/// `p` may point anywhere, past the end of its buffer included (it cannot fault).
#[inline(always)]
pub(crate) fn prefetch_read(p: *const f32) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint that reads or writes nothing and never faults.
    #[allow(unsafe_code)]
    unsafe {
        core::arch::x86_64::_mm_prefetch::<{ core::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// A row of an interleaved buffer with `C` floats per pixel (RGB first).
struct Interleaved<'a, const C: usize>(&'a mut [f32]);

impl<const C: usize> RowColour for Interleaved<'_, C> {
    const RGB3: bool = C == 3;
    #[inline(always)]
    fn prefetch(&self, x0: usize, n: usize) {
        prefetch_bytes(self.0.as_ptr().wrapping_add(x0 * C), n * C * 4);
    }
    #[inline(always)]
    fn fog_rgb3<W: Lane>(&mut self, x0: usize, trans: [W; 3], v: [W; 3], lerp: bool) {
        let n = W::LANES;
        let s = &mut self.0[x0 * 3..(x0 + n) * 3];
        for j in 0..3 {
            let l = W::load(&s[n * j..n * j + n]);
            over(l, trans[j], v[j], lerp).store(&mut s[n * j..n * j + n]);
        }
    }
    #[inline(always)]
    fn load(&self, x0: usize, n: usize) -> [f32x8; 3] {
        let mut v = [[0.0f32; 8]; 3];
        if n == 8 {
            let s = &self.0[x0 * C..(x0 + 8) * C];
            for k in 0..8 {
                for ch in 0..3 {
                    v[ch][k] = s[k * C + ch];
                }
            }
        } else {
            let s = &self.0[x0 * C..(x0 + n) * C];
            for k in 0..n {
                for ch in 0..3 {
                    v[ch][k] = s[k * C + ch];
                }
            }
        }
        rgb!(ch => f32x8::new(v[ch]))
    }
    #[inline(always)]
    fn store(&mut self, x0: usize, n: usize, v: [f32x8; 3]) {
        let v = rgb!(ch => v[ch].to_array());
        if n == 8 {
            let s = &mut self.0[x0 * C..(x0 + 8) * C];
            for k in 0..8 {
                for ch in 0..3 {
                    s[k * C + ch] = v[ch][k];
                }
            }
        } else {
            let s = &mut self.0[x0 * C..(x0 + n) * C];
            for k in 0..n {
                for ch in 0..3 {
                    s[k * C + ch] = v[ch][k];
                }
            }
        }
    }
    #[inline(always)]
    fn fog(&mut self, x0: usize, n: usize, trans: [f32x8; 3], v: [f32x8; 3], lerp: bool) {
        if C == 3 && n == 8 {
            // Interleave T and v (two sets of shuffles) rather than de-interleave the
            // colour and interleave it again: the colour moves as three whole lanes.
            let (t, v) = (interleave3(trans), interleave3(v));
            let s = &mut self.0[x0 * 3..(x0 + 8) * 3];
            for j in 0..3 {
                let l = f32x8::load(&s[8 * j..8 * j + 8]);
                over(l, t[j], v[j], lerp).store(&mut s[8 * j..8 * j + 8]);
            }
        } else {
            let l = self.load(x0, n);
            let out = rgb!(ch => over(l[ch], trans[ch], v[ch], lerp));
            self.store(x0, n, out);
        }
    }
}

/// A row of a planar buffer.
struct Planar<'a>([&'a mut [f32]; 3]);

impl<R: RowColour> RowColour for &mut R {
    const RGB3: bool = R::RGB3;
    #[inline(always)]
    fn prefetch(&self, x0: usize, n: usize) {
        (**self).prefetch(x0, n)
    }
    #[inline(always)]
    fn fog_rgb3<W: Lane>(&mut self, x0: usize, trans: [W; 3], v: [W; 3], lerp: bool) {
        (**self).fog_rgb3(x0, trans, v, lerp)
    }
    #[inline(always)]
    fn load(&self, x0: usize, n: usize) -> [f32x8; 3] {
        (**self).load(x0, n)
    }
    #[inline(always)]
    fn store(&mut self, x0: usize, n: usize, v: [f32x8; 3]) {
        (**self).store(x0, n, v)
    }
    #[inline(always)]
    fn fog(&mut self, x0: usize, n: usize, trans: [f32x8; 3], v: [f32x8; 3], lerp: bool) {
        (**self).fog(x0, n, trans, v, lerp)
    }
}

impl RowColour for Planar<'_> {
    #[inline(always)]
    fn prefetch(&self, x0: usize, n: usize) {
        for ch in 0..3 {
            prefetch_bytes(self.0[ch].as_ptr().wrapping_add(x0), n * 4);
        }
    }
    #[inline(always)]
    fn load(&self, x0: usize, n: usize) -> [f32x8; 3] {
        rgb!(ch => {
            if n == 8 {
                f32x8::load(&self.0[ch][x0..x0 + 8])
            } else {
                let mut b = [0.0f32; 8];
                b[..n].copy_from_slice(&self.0[ch][x0..x0 + n]);
                f32x8::new(b)
            }
        })
    }
    #[inline(always)]
    fn store(&mut self, x0: usize, n: usize, v: [f32x8; 3]) {
        for ch in 0..3 {
            if n == 8 {
                v[ch].store(&mut self.0[ch][x0..x0 + 8]);
            } else {
                self.0[ch][x0..x0 + n].copy_from_slice(&v[ch].to_array()[..n]);
            }
        }
    }
}

/// One row of the pass, as the kernel's ray source and result sink, in packets of
/// `W::LANES` pixels.
struct RowIo<'a, R, W> {
    plan: &'a FramePlan,
    row: RowPlan,
    depth: &'a [f32],
    out: R,
    /// The row's packet that the kernel's packet 0 is.
    first: usize,
    lanes: core::marker::PhantomData<W>,
}

impl<'a, R, W> RowIo<'a, R, W> {
    /// Row `y` of the frame, from its first packet.
    fn new(plan: &'a FramePlan, y: usize, depth: &'a [f32], out: R) -> Self {
        RowIo {
            plan,
            row: plan.row(y),
            depth,
            out,
            first: 0,
            lanes: core::marker::PhantomData,
        }
    }
}

impl<R: RowColour, W: PassLane> PacketIo<W> for RowIo<'_, R, W> {
    #[inline(always)]
    fn make(&mut self, i: usize) -> PacketIn<W> {
        let n = W::LANES;
        let x0 = (self.first + i) * n;
        let width = self.depth.len();
        let dv = if x0 + n <= width {
            W::load(&self.depth[x0..x0 + n])
        } else {
            let mut b = [0.0f32; 16];
            b[..width - x0].copy_from_slice(&self.depth[x0..]);
            W::load(&b[..n])
        };
        // x0 + k is exact in f32 (width ≤ 2^24): the value pixel_ray uses.
        let xs = W::splat(x0 as f32) + W::lane_x();
        let (o, d, t) = self.plan.ray(&self.row, xs, dv);
        PacketIn { o, d, t }
    }

    #[inline(always)]
    fn take(&mut self, i: usize, r: &PacketOut<W>) {
        let x0 = (self.first + i) * W::LANES;
        let n = (self.depth.len() - x0).min(W::LANES);
        self.out.fog_wide(x0, n, r.trans, r.insc, false);
    }
}

/// Fogs one row: rays generated a packet at a time, the tail padded into one more packet
/// (depth 0 in the dead lanes, whose results are dropped). Packets of [`Wide`] lanes (8,
/// or 16 in an AVX-512 build) for the general kernel, of 8 for a single layer: its staged
/// blocks measured 0.85× as fast with `wide::f32x16` lanes in the pass
/// (`pass/fog_single_batch_kernel` 12.3 → 14.0 and 15.3 ms on Zen 4), where the general
/// kernel gained 1.15× to 1.3× (`volumes_10` and `volumes_1000` of
/// `benches/pass_volumes.rs`). Where AVX-512 is chosen at run time a single layer takes 16
/// `Zmm` lanes ([`zmm_row`]): 0.80–0.86× the 8-lane time on the Intel Xeon (`EXACT=1
/// passloop`, against `NO512=1`). Same bits in every case.
#[inline(never)]
fn fog_row<R: RowColour>(scene: &Scene, plan: &FramePlan, y: usize, depth: &[f32], out: R) {
    if let Some(single) = crate::kernel::Single::of(scene) {
        #[cfg(zmm_dispatch)]
        if !scene.no_avx512_dispatch && crate::math::avx512_detected() {
            return zmm_row::fog_row_single(scene, &single, plan, y, depth, out);
        }
        // (The `Single` made once per row: `run_packets` would make it again.)
        let mut io = RowIo::<R, f32x8>::new(plan, y, depth, out);
        let count = depth.len().div_ceil(f32x8::LANES);
        run_packets_single::<f32x8, false, _>(scene, &single, count, &mut io);
    } else {
        #[cfg(zmm_dispatch)]
        if !scene.no_avx512_dispatch && crate::math::avx512_detected() {
            return zmm_row::fog_row_general(scene, plan, y, depth, out, None);
        }
        let mut io = RowIo::<R, Wide>::new(plan, y, depth, out);
        let packets = depth.len().div_ceil(Wide::LANES);
        run_packets::<Wide, false, _>(scene, None, packets, &mut io, &mut Vec::new());
    }
}

/// [`fog_row`] for one height fog layer with 16 AVX-512 lanes chosen at run time
/// ([`crate::math::zmm::Zmm`], as the batch API's `kernel::zmm`): the same packets and
/// stages, so the same bits.
#[cfg(zmm_dispatch)]
#[allow(unsafe_code)]
mod zmm_row {
    use super::{FramePlan, RowColour, RowIo, Scene, TileLists, TILE_W};
    use crate::kernel::zmm::run_packets_general;
    use crate::kernel::{run_packets_single, Single};
    use crate::math::zmm::{detected, Zmm};
    use crate::math::Lane;

    pub(super) fn fog_row_single<R: RowColour>(
        scene: &Scene,
        single: &Single,
        plan: &FramePlan,
        y: usize,
        depth: &[f32],
        out: R,
    ) {
        // (The row's ray source holds no lanes yet: made here, outside the entry point.)
        #[target_feature(enable = "avx512f,avx512vl,avx512dq,avx512bw,avx512cd")]
        fn go<R: RowColour>(scene: &Scene, single: &Single, mut io: RowIo<'_, R, Zmm>) {
            let count = io.depth.len().div_ceil(Zmm::LANES);
            run_packets_single::<Zmm, false, _>(scene, single, count, &mut io);
        }
        let io = RowIo::<R, Zmm>::new(plan, y, depth, out);
        assert!(detected());
        // SAFETY: the CPU has the features `go` is compiled for (asserted above).
        unsafe { go::<R>(scene, single, io) }
    }

    /// [`fog_row`](super::fog_row)'s general kernel (and [`fog_row_tiled`]'s, with the
    /// tiles' lists) on 16 lanes: [`TILE_W`] is a multiple of 16, so a tile's packets are
    /// whole and the same as on 8 lanes (the same rays, the same candidates).
    ///
    /// [`fog_row_tiled`]: super::fog_row_tiled
    pub(super) fn fog_row_general<R: RowColour>(
        scene: &Scene,
        plan: &FramePlan,
        y: usize,
        depth: &[f32],
        out: R,
        lists: Option<&TileLists>,
    ) {
        const { assert!(TILE_W.is_multiple_of(Zmm::LANES)) };
        let mut io = RowIo::<R, Zmm>::new(plan, y, depth, out);
        let packets = depth.len().div_ceil(Zmm::LANES);
        let mut scratch = Vec::new();
        let Some(lists) = lists else {
            return run_packets_general::<false, _>(scene, None, packets, &mut io, &mut scratch);
        };
        let tile_packets = TILE_W / Zmm::LANES;
        for j in 0..lists.len() {
            io.first = j * tile_packets;
            let count = (packets - io.first).min(tile_packets);
            let list = Some(lists.list(j));
            run_packets_general::<false, _>(scene, list, count, &mut io, &mut scratch);
        }
    }
}

/// Fogs a band of rows starting at row `y0` (`depth`: their depth values; `rows`: their
/// colour) tile by tile: per group of [`TILE_H`] rows, the tiles' candidate volumes are
/// listed once (`cull`), then each row is fogged with its tiles' lists.
fn fog_band_tiled<R: RowColour>(
    scene: &Scene,
    plan: &FramePlan,
    cull: &FrameCull,
    y0: usize,
    depth: &[f32],
    rows: &mut [R],
) {
    let width = depth.len() / rows.len();
    let mut lists = TileLists::default();
    for (g, group) in rows.chunks_mut(TILE_H).enumerate() {
        let gy = g * TILE_H;
        let d = &depth[gy * width..(gy + group.len()) * width];
        cull.tiles(plan, y0 + gy, d, &mut lists);
        for (k, row) in group.iter_mut().enumerate() {
            let dr = &d[k * width..(k + 1) * width];
            fog_row_tiled(scene, plan, y0 + gy + k, dr, row, &lists);
        }
    }
}

/// [`fog_row`] with the tiles' candidate volumes: the packets of tile `j` (the row's
/// packets `j·TILE_W/lanes ..`) evaluate only `lists.list(j)`. The same packets as
/// [`fog_row`] (tail included), so the same bits.
#[inline(never)]
fn fog_row_tiled<R: RowColour>(
    scene: &Scene,
    plan: &FramePlan,
    y: usize,
    depth: &[f32],
    out: &mut R,
    lists: &TileLists,
) {
    #[cfg(zmm_dispatch)]
    if !scene.no_avx512_dispatch && crate::math::avx512_detected() {
        return zmm_row::fog_row_general(scene, plan, y, depth, out, Some(lists));
    }
    let packets = depth.len().div_ceil(Wide::LANES);
    let tile_packets = TILE_W / Wide::LANES;
    let mut io = RowIo::<&mut R, Wide>::new(plan, y, depth, out);
    // One list of touched volumes for the row's tiles (ordered composition).
    let mut scratch = Vec::new();
    for j in 0..lists.len() {
        io.first = j * tile_packets;
        let count = (packets - io.first).min(tile_packets);
        let list = Some(lists.list(j));
        run_packets::<Wide, false, _>(scene, list, count, &mut io, &mut scratch);
    }
}

/// The choices of the fog pass's own one-layer kernel for a frame
/// ([`Scene::fog_pass_own_kernel`]). For tests and benchmarks.
#[doc(hidden)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OwnKernelFrame {
    /// How many rows it runs with a constant b·u (its `RowFactor`: a product for the
    /// division of g').
    pub uniform_rows: usize,
    /// Whether it forms its phase function's q = base + gg·|v + w|² from cos θ in the
    /// frame's rows (a polynomial in the column's u; where the bound on the error this
    /// adds is within 2⁻¹⁷ relative).
    pub linear_phase: bool,
}
