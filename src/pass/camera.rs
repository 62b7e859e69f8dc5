//! Cameras, depth conventions, and the ray the fog pass uses for a pixel.
//!
//! A camera is stored as an affine field of rays over the normalized device coordinates
//! (u, v) of the pixel centre: origin o(u, v) = o₀ + u·o_u + v·o_v and direction
//! d(u, v) = d₀ + u·d_u + v·d_v. For a perspective camera the origin is the eye and d has
//! forward component 1 (so t along d is the linear view depth); for an orthographic one
//! d is the unit forward vector and the origins lie on the camera plane. The pass and
//! [`Camera::pixel_ray`] evaluate this field with the same f32 operations in the same
//! order ([`FramePlan::row`], [`FramePlan::ray`]), so the pass feeds the kernel exactly
//! the ray `pixel_ray` returns.

use crate::error::PassError;
use crate::math::Lane;
use glam::{DMat4, DVec3, DVec4, Mat4, Vec3};

/// The kind of projection of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Rays from one eye point.
    Perspective,
    /// Parallel rays from the camera plane.
    Orthographic,
}

/// A pinhole (perspective) or orthographic camera, as the fog pass sees it: the ray of
/// every pixel. Build it with [`Camera::perspective`], [`Camera::orthographic`] or
/// [`Camera::from_inverse_view_projection`].
///
/// Pixel conventions (all of the pass): pixel (x, y) has row `y = 0` at the **top** and
/// `x = 0` at the left; its ray goes through the pixel **centre**, at normalized device
/// coordinates u = 2·(x + 0.5)/width − 1 (−1 at the left edge of the frame, +1 at the
/// right) and v = 1 − 2·(y + 0.5)/height (NDC y points up: +1 at the top edge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    projection: Projection,
    /// The eye (perspective) or the camera plane's point at NDC (0, 0) (orthographic).
    o0: Vec3,
    o_u: Vec3,
    o_v: Vec3,
    d0: Vec3,
    d_u: Vec3,
    d_v: Vec3,
    forward: Vec3,
}

/// How the values of a depth buffer are to be read. Whatever the convention, a value of
/// `+inf` (and, for [`DepthConvention::NdcZeroToOne`], a value at or beyond the far
/// plane) is a **sky** pixel: its ray goes to t = +∞ and receives the fog of an infinite
/// ray. Negative depths are clamped to 0 (no fog); NaN gives NaN fog.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthConvention {
    /// Linear view depth: the distance from the camera plane (through the eye, for a
    /// perspective camera) along the camera's forward axis, in world units
    /// (−z_view for a right-handed view matrix). `+inf` is sky.
    LinearView,
    /// The distance from the ray's origin to the surface along the ray (Euclidean, world
    /// units), as a ray tracer reports it. `+inf` is sky.
    Distance,
    /// The value a rasterizer stores in its depth buffer, in **[0, 1]**: NDC z as in
    /// Direct3D, Vulkan, Metal and wgpu, which is also OpenGL's window depth under the
    /// default `glDepthRange(0, 1)` (for an OpenGL NDC z in [−1, 1], pass (z + 1)/2).
    /// Standard: 0 at `near`, 1 at `far`; `reversed` (reversed-Z): 1 at `near`, 0 at
    /// `far`. A perspective camera's depth is hyperbolic (d = far·(z − near) /
    /// (z·(far − near)) standard), an orthographic one's linear; `near` and `far` are the
    /// projection's planes as view depths. Perspective: 0 < near < far, `far` may be
    /// `+inf` (an infinite projection). Orthographic: both finite, near < far. Values at
    /// or beyond the far plane (≥ 1 standard, ≤ 0 reversed) are sky.
    NdcZeroToOne {
        /// The near plane's view depth.
        near: f32,
        /// The far plane's view depth (`+inf` for an infinite perspective projection).
        far: f32,
        /// Reversed-Z: 1 at `near`, 0 at `far`.
        reversed: bool,
    },
}

/// The ray the fog pass evaluates for one pixel: `origin + s · direction`, s in [0, t].
/// Feed it to [`Scene::eval_ray`](crate::Scene::eval_ray) or a batch (with unit
/// directions **not** declared) to get the same bits as the pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelRay {
    /// The eye (perspective) or the point on the camera plane (orthographic).
    pub origin: Vec3,
    /// Perspective: forward component 1 (not unit length); orthographic: the unit forward
    /// vector.
    pub direction: Vec3,
    /// The segment's end in units of `direction` (+∞ for a sky pixel).
    pub t: f32,
}

fn invalid(field: &'static str, reason: impl Into<String>) -> PassError {
    PassError::InvalidParameter {
        field,
        reason: reason.into(),
    }
}

fn finite_vec(field: &'static str, v: Vec3) -> Result<DVec3, PassError> {
    if v.is_finite() {
        Ok(v.as_dvec3())
    } else {
        Err(invalid(field, format!("must be finite, got {v}")))
    }
}

/// Right-handed orthonormal frame (forward, right, up) from a forward and an up hint.
fn frame(forward: Vec3, up: Vec3) -> Result<(DVec3, DVec3, DVec3), PassError> {
    let f = finite_vec("forward", forward)?;
    let u = finite_vec("up", up)?;
    if f.length() == 0.0 || !f.length().is_finite() {
        return Err(invalid("forward", "must be a non-zero vector"));
    }
    let f = f / f.length();
    let r = f.cross(u);
    if r.length() <= 1e-6 * u.length() || !r.length().is_finite() {
        return Err(invalid(
            "up",
            "must be a non-zero vector not parallel to forward",
        ));
    }
    let r = r / r.length();
    Ok((f, r, r.cross(f)))
}

fn positive(field: &'static str, v: f32) -> Result<f64, PassError> {
    if v.is_finite() && v > 0.0 {
        Ok(v as f64)
    } else {
        Err(invalid(field, format!("must be finite and > 0, got {v}")))
    }
}

impl Camera {
    /// A perspective camera at `position` looking along `forward`, with `up` giving the
    /// roll (any vector not parallel to `forward`; the frame is right-handed: right =
    /// forward × up), vertical field of view `fov_y` in radians (in (0, π)) and
    /// `aspect` = width / height of the frame.
    ///
    /// ```
    /// use analytic_fog::pass::Camera;
    /// use glam::Vec3;
    /// let cam = Camera::perspective(Vec3::new(0.0, 2.0, 0.0), Vec3::NEG_Z, Vec3::Y, 1.0, 16.0 / 9.0)?;
    /// assert_eq!(cam.forward(), Vec3::NEG_Z);
    /// # Ok::<(), analytic_fog::PassError>(())
    /// ```
    pub fn perspective(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y: f32,
        aspect: f32,
    ) -> Result<Camera, PassError> {
        finite_vec("position", position)?;
        let (f, r, u) = frame(forward, up)?;
        if !(fov_y > 0.0 && fov_y < core::f32::consts::PI) {
            return Err(invalid(
                "fov_y",
                format!("must be in (0, pi) radians, got {fov_y}"),
            ));
        }
        let aspect = positive("aspect", aspect)?;
        let h = (fov_y as f64 * 0.5).tan();
        Ok(Camera {
            projection: Projection::Perspective,
            o0: position,
            o_u: Vec3::ZERO,
            o_v: Vec3::ZERO,
            d0: f.as_vec3(),
            d_u: (r * (h * aspect)).as_vec3(),
            d_v: (u * h).as_vec3(),
            forward: f.as_vec3(),
        })
    }

    /// An orthographic camera: parallel rays along `forward` from the camera plane through
    /// `position` (the frame's centre), covering `height` world units vertically and
    /// `height · aspect` horizontally; `up` as for [`Camera::perspective`].
    pub fn orthographic(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        height: f32,
        aspect: f32,
    ) -> Result<Camera, PassError> {
        finite_vec("position", position)?;
        let (f, r, u) = frame(forward, up)?;
        let half = positive("height", height)? * 0.5;
        let aspect = positive("aspect", aspect)?;
        Ok(Camera {
            projection: Projection::Orthographic,
            o0: position,
            o_u: (r * (half * aspect)).as_vec3(),
            o_v: (u * half).as_vec3(),
            d0: f.as_vec3(),
            d_u: Vec3::ZERO,
            d_v: Vec3::ZERO,
            forward: f.as_vec3(),
        })
    }

    /// A camera from the inverse of a view-projection matrix (clip = VP · world, column
    /// vectors, as glam's `Mat4::perspective_rh * Mat4::look_at_rh`), perspective or
    /// orthographic (told apart by the matrix: perspective if clip w varies with the
    /// position). The NDC z convention of the matrix does not matter (OpenGL's [−1, 1],
    /// Direct3D's [0, 1], reversed-Z and infinite far planes all work): only the rays'
    /// directions are taken from it; depth values are interpreted by the
    /// [`DepthConvention`] given to the pass. Off-centre (asymmetric) frustums work.
    ///
    /// `position`: the eye of a perspective camera (`None`: derived from the matrix), or
    /// any point on the camera plane of an orthographic one, where the rays start and
    /// from which linear view depth is measured (required: the matrix does not know it).
    /// The forward direction is the one in which clip w grows (perspective) or toward
    /// the view volume (orthographic).
    ///
    /// ```
    /// use analytic_fog::pass::{Camera, Projection};
    /// use glam::{Mat4, Vec3};
    /// let eye = Vec3::new(1.0, 5.0, 3.0);
    /// let view = Mat4::look_at_rh(eye, Vec3::new(0.0, 0.0, -10.0), Vec3::Y);
    /// let proj = Mat4::perspective_infinite_reverse_rh(0.9, 1.5, 0.1);
    /// let cam = Camera::from_inverse_view_projection((proj * view).inverse(), None)?;
    /// assert_eq!(cam.projection(), Projection::Perspective);
    /// assert!((cam.position() - eye).length() < 1e-4);
    /// # Ok::<(), analytic_fog::PassError>(())
    /// ```
    pub fn from_inverse_view_projection(
        inv_vp: Mat4,
        position: Option<Vec3>,
    ) -> Result<Camera, PassError> {
        if !inv_vp.is_finite() {
            return Err(invalid("inv_vp", "must be finite"));
        }
        let m = inv_vp.as_dmat4();
        let det = m.determinant();
        if det == 0.0 || !det.is_finite() {
            return Err(invalid("inv_vp", "must be invertible"));
        }
        let pos = match position {
            Some(p) => Some(finite_vec("position", p)?),
            None => None,
        };
        let vp: DMat4 = m.inverse();
        let unproject_h = |u: f64, v: f64, z: f64| m * DVec4::new(u, v, z, 1.0);
        let unproject = |u: f64, v: f64, z: f64| {
            let h = unproject_h(u, v, z);
            h.truncate() / h.w
        };
        // Perspective iff the unprojected w varies along the view axis.
        let (a, b) = (unproject_h(0.0, 0.0, 0.25).w, unproject_h(0.0, 0.0, 0.75).w);
        let perspective = (a - b).abs() > 1e-4 * a.abs().max(b.abs());
        let bad = || invalid("inv_vp", "does not describe a usable camera");
        let cam = if perspective {
            // Visible points have clip w > 0: w grows along the forward axis.
            let w_row = vp.row(3);
            let fw = w_row.truncate();
            if fw.length() == 0.0 {
                return Err(bad());
            }
            let f = fw / fw.length();
            let eye = match pos {
                Some(p) => p,
                None => {
                    let e = m * DVec4::new(0.0, 0.0, 1.0, 0.0);
                    e.truncate() / e.w
                }
            };
            if !eye.is_finite() {
                return Err(bad());
            }
            // The direction through NDC (u, v), scaled to forward component 1. Formed
            // homogeneously, so a point at infinity (w = 0) works too.
            let dir = |u: f64, v: f64| {
                let h = unproject_h(u, v, 0.5);
                let d = h.truncate() - eye * h.w;
                d / d.dot(f)
            };
            let (d0, d1, d2) = (dir(0.0, 0.0), dir(1.0, 0.0), dir(0.0, 1.0));
            Camera {
                projection: Projection::Perspective,
                o0: eye.as_vec3(),
                o_u: Vec3::ZERO,
                o_v: Vec3::ZERO,
                d0: d0.as_vec3(),
                d_u: (d1 - d0).as_vec3(),
                d_v: (d2 - d0).as_vec3(),
                forward: f.as_vec3(),
            }
        } else {
            let p = pos.ok_or_else(|| {
                invalid(
                    "position",
                    "required for an orthographic matrix (the camera plane)",
                )
            })?;
            let h = (m * DVec4::new(0.0, 0.0, 1.0, 0.0)).truncate();
            let c = unproject(0.0, 0.0, 0.5);
            let s = (c - p).dot(h);
            if h.length() == 0.0 || s == 0.0 || !s.is_finite() {
                return Err(bad());
            }
            let f = h / h.length() * s.signum();
            // The camera-plane point of the ray through NDC (u, v).
            let origin = |u: f64, v: f64| {
                let x = unproject(u, v, 0.5);
                x - f * (x - p).dot(f)
            };
            let (o0, o1, o2) = (origin(0.0, 0.0), origin(1.0, 0.0), origin(0.0, 1.0));
            Camera {
                projection: Projection::Orthographic,
                o0: o0.as_vec3(),
                o_u: (o1 - o0).as_vec3(),
                o_v: (o2 - o0).as_vec3(),
                d0: f.as_vec3(),
                d_u: Vec3::ZERO,
                d_v: Vec3::ZERO,
                forward: f.as_vec3(),
            }
        };
        let parts = [cam.o0, cam.o_u, cam.o_v, cam.d0, cam.d_u, cam.d_v];
        if parts.iter().all(|v| v.is_finite()) && cam.forward.is_finite() {
            Ok(cam)
        } else {
            Err(bad())
        }
    }

    /// Perspective or orthographic.
    pub fn projection(&self) -> Projection {
        self.projection
    }

    /// The eye (perspective), or the origin of the ray through the centre of the frame
    /// (NDC (0, 0); orthographic).
    pub fn position(&self) -> Vec3 {
        self.o0
    }

    /// The unit forward axis, along which linear view depth is measured.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// The ray the fog pass evaluates for pixel (x, y) of a `width × height` frame whose
    /// depth buffer holds `depth` there under `convention`: the same f32 origin,
    /// direction and t, computed by the same operations, so that
    /// `scene.eval_ray(r.origin, r.direction, r.t)` gives the bits the pass uses. Errors
    /// for a pixel outside the frame or an invalid convention.
    ///
    /// ```
    /// use analytic_fog::pass::{Camera, DepthConvention};
    /// use glam::Vec3;
    /// let cam = Camera::perspective(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.2, 2.0)?;
    /// let r = cam.pixel_ray(0, 0, 640, 320, 10.0, DepthConvention::LinearView)?;
    /// assert_eq!(r.direction.z, -1.0); // forward component 1: t is the view depth
    /// assert_eq!(r.t, 10.0);
    /// assert!(r.direction.x < 0.0 && r.direction.y > 0.0); // top-left pixel
    /// # Ok::<(), analytic_fog::PassError>(())
    /// ```
    pub fn pixel_ray(
        &self,
        x: usize,
        y: usize,
        width: usize,
        height: usize,
        depth: f32,
        convention: DepthConvention,
    ) -> Result<PixelRay, PassError> {
        if x >= width || y >= height {
            return Err(PassError::PixelOutside {
                x,
                y,
                width,
                height,
            });
        }
        let plan = FramePlan::new(self, width, height, convention)?;
        let row = plan.row(y);
        let (o, d, t) = plan.ray::<f32>(&row, x as f32, depth);
        Ok(PixelRay {
            origin: Vec3::from_array(o),
            direction: Vec3::from_array(d),
            t,
        })
    }
}

/// The depth conversion, with its per-frame constants.
#[derive(Clone, Copy, Debug)]
pub(crate) enum DepthPlan {
    /// t = depth.
    Linear,
    /// t = depth / |d| (perspective; orthographic distance is `Linear`).
    Distance,
    /// z = n / (1 − depth·k) (standard) or n / (depth·k + q) (reversed), q = n/f, k = 1 − q.
    NdcPerspective {
        n: f32,
        k: f32,
        q: f32,
        reversed: bool,
    },
    /// z = depth·(f − n) + n (standard) or f − depth·(f − n) (reversed).
    NdcOrthographic {
        n: f32,
        f: f32,
        span: f32,
        reversed: bool,
    },
}

/// Everything about a frame that does not change per pixel: the NDC mapping, the
/// camera's ray field, and the depth conversion constants.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FramePlan {
    pub(super) ortho: bool,
    pub(super) su: f32,
    pub(super) ou: f32,
    pub(super) sv: f32,
    pub(super) ov: f32,
    pub(super) o0: [f32; 3],
    pub(super) o_u: [f32; 3],
    pub(super) o_v: [f32; 3],
    pub(super) d0: [f32; 3],
    pub(super) d_u: [f32; 3],
    pub(super) d_v: [f32; 3],
    pub(super) depth: DepthPlan,
}

/// The parts of a pixel's ray that are constant along a row.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RowPlan {
    pub(super) o: [f32; 3],
    pub(super) d: [f32; 3],
}

impl FramePlan {
    pub(crate) fn new(
        cam: &Camera,
        width: usize,
        height: usize,
        convention: DepthConvention,
    ) -> Result<FramePlan, PassError> {
        let ortho = cam.projection == Projection::Orthographic;
        let depth = match convention {
            DepthConvention::LinearView => DepthPlan::Linear,
            DepthConvention::Distance if ortho => DepthPlan::Linear,
            DepthConvention::Distance => DepthPlan::Distance,
            DepthConvention::NdcZeroToOne {
                near,
                far,
                reversed,
            } => {
                if ortho {
                    if !(near.is_finite() && far.is_finite() && near < far) {
                        return Err(invalid(
                            "depth.near, depth.far",
                            format!(
                                "orthographic: must be finite with near < far, got {near}, {far}"
                            ),
                        ));
                    }
                    DepthPlan::NdcOrthographic {
                        n: near,
                        f: far,
                        span: far - near,
                        reversed,
                    }
                } else {
                    if !(near.is_finite() && near > 0.0 && far > near) {
                        return Err(invalid(
                            "depth.near, depth.far",
                            format!(
                                "perspective: must be 0 < near < far (far may be inf), got {near}, {far}"
                            ),
                        ));
                    }
                    let q = near / far;
                    DepthPlan::NdcPerspective {
                        n: near,
                        k: 1.0 - q,
                        q,
                        reversed,
                    }
                }
            }
        };
        if width > 1 << 24 || height > 1 << 24 {
            return Err(PassError::FrameTooLarge { width, height });
        }
        let (w, h) = (width.max(1) as f64, height.max(1) as f64);
        Ok(FramePlan {
            ortho,
            su: (2.0 / w) as f32,
            ou: (1.0 / w - 1.0) as f32,
            sv: (-2.0 / h) as f32,
            ov: (1.0 - 1.0 / h) as f32,
            o0: cam.o0.to_array(),
            o_u: cam.o_u.to_array(),
            o_v: cam.o_v.to_array(),
            d0: cam.d0.to_array(),
            d_u: cam.d_u.to_array(),
            d_v: cam.d_v.to_array(),
            depth,
        })
    }

    /// The row's constants: v = y·sv + ov, then o₀ + v·o_v and d₀ + v·d_v.
    #[inline(always)]
    pub(crate) fn row(&self, y: usize) -> RowPlan {
        let v: f32 = Lane::mul_add(y as f32, self.sv, self.ov);
        let mut o = self.o0;
        let mut d = [0.0; 3];
        for c in 0..3 {
            if self.ortho {
                o[c] = Lane::mul_add(v, self.o_v[c], self.o0[c]);
            }
            d[c] = Lane::mul_add(v, self.d_v[c], self.d0[c]);
        }
        RowPlan { o, d }
    }

    /// The rays of the pixels at columns `x` (integer-valued) of a row, for depth buffer
    /// values `depth`: (origin, direction, t).
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    pub(crate) fn ray<L: Lane>(&self, row: &RowPlan, x: L, depth: L) -> ([L; 3], [L; 3], L) {
        let u = x.mul_add(L::splat(self.su), L::splat(self.ou));
        let mut o = row.o.map(L::splat);
        let mut d = [L::splat(0.0); 3];
        for c in 0..3 {
            if self.ortho {
                o[c] = u.mul_add(L::splat(self.o_u[c]), o[c]);
            }
            d[c] = u.mul_add(L::splat(self.d_u[c]), L::splat(row.d[c]));
        }
        let inf = L::splat(f32::INFINITY);
        let t = match self.depth {
            DepthPlan::Linear => depth,
            DepthPlan::Distance => {
                let n = d[0].mul_add(d[0], d[1].mul_add(d[1], d[2] * d[2])).sqrt();
                depth / n
            }
            DepthPlan::NdcPerspective { n, k, q, reversed } => {
                if reversed {
                    let z = L::splat(n) / depth.mul_add(L::splat(k), L::splat(q));
                    L::select(depth.le(L::splat(0.0)), inf, z)
                } else {
                    let z = L::splat(n) / depth.neg_mul_add(L::splat(k), L::splat(1.0));
                    L::select(depth.ge(L::splat(1.0)), inf, z)
                }
            }
            DepthPlan::NdcOrthographic {
                n,
                f,
                span,
                reversed,
            } => {
                if reversed {
                    let z = depth.neg_mul_add(L::splat(span), L::splat(f));
                    L::select(depth.le(L::splat(0.0)), inf, z)
                } else {
                    let z = depth.mul_add(L::splat(span), L::splat(n));
                    L::select(depth.ge(L::splat(1.0)), inf, z)
                }
            }
        };
        // Negative depths to 0; NaN stays NaN (maxps: the second operand wins on NaN).
        let t = L::splat(0.0).max(t);
        (o, d, t)
    }
}
