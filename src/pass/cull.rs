//! Per-tile culling of fog volumes in the framebuffer pass.
//!
//! The kernel skips, per packet of 8 rays, every additive volume whose bounding sphere no
//! ray of the packet can reach (`may_touch` in `medium::volume::packet`); with many
//! volumes that test itself (once per volume per packet) dominates. The pass therefore
//! gives the kernel, per tile of [`TILE_W`] × [`TILE_H`] pixels, the list of the volumes
//! that some ray of the tile may reach, built once per tile and used by all its packets
//! (which still run the per-packet test on it). The lists are built hierarchically: the
//! whole frame once, each band of [`TILE_H`] rows against the frame's list, each tile
//! against its band's.
//!
//! The test. The camera is an affine field of rays over NDC (u, v) (`camera.rs`); the
//! pixel centres of a tile span a rectangle [u_lo, u_hi] × [v_lo, v_hi], whose rays
//! fill a convex set bounded by four planes: through the eye for a perspective camera
//! (directions d₀ + u·d_u + v·d_v, a parallelogram in the plane of forward component 1),
//! parallel to the direction for an orthographic one (origins o₀ + u·o_u + v·o_v). The
//! plane of the edge u = u_lo has the normal ±(d₀ + u_lo·d_u) × d_v (perspective) or
//! ±o_v × d₀ (orthographic), oriented by the sign of det(d₀, d_u, d_v) (det(o_u, o_v,
//! d₀)), a per-frame constant: no orientation is guessed from a tile's size, and a tile
//! one pixel wide gives two opposite normals of one plane, which is right. The rays are
//! also no longer than the tile's depth range allows: t_max from the least and greatest
//! depth value of the tile (the depth conventions are monotonic; sky and NaN give +∞),
//! times the largest |d| at the tile's corners. A volume is dropped when its widened
//! bounding sphere lies entirely outside one plane, behind the camera, or farther than
//! t_max from every origin of the tile.
//!
//! Why this is conservative (a volume that `may_touch` accepts for some ray of the tile
//! is never dropped, so the kernel gives the same bits with or without the list; a volume
//! that it rejects for every lane contributes exactly nothing). In exact arithmetic the
//! set above contains every ray of the tile: the field is affine, so the rays of a
//! rectangle of pixels lie in the parallelogram spanned by its corners; the NDC
//! coordinates of the corners are computed by the same f32 operations as the pass's.
//! The sphere is widened to cover what `may_touch` accepts and the rounding of the f32
//! rays it sees: its radius there (the bound times 1.001, plus 1e-5 of the coordinates'
//! magnitudes |c − o|₁ + |o|₁), again that margin for its own f32 arithmetic, 1e-6 of the
//! ray field's magnitudes for the rounding of the origins, and 1e-6 of the field's
//! direction magnitudes over |d| (an angle) times the distance for that of the
//! directions (each over ten times the few roundings involved); t_max gets 1e-5 relative.
//! The planes and distances here are computed in f64 from the same f32 values, with
//! errors near 1e-16 relative, far inside those margins.

use super::camera::{DepthPlan, FramePlan};
use crate::math::Lane;
use crate::scene::Scene;
use wide::f32x8;

/// Tile width in pixels (a multiple of 16: whole packets of 8 or 16 lanes).
pub(crate) const TILE_W: usize = 32;
/// Tile height in rows.
pub(crate) const TILE_H: usize = 8;

/// A volume's bounding sphere, widened (see the module documentation); the centre is
/// relative to the camera field's o₀.
#[derive(Clone, Copy, Debug)]
struct Sphere {
    c: [f64; 3],
    r: f64,
    /// A lower bound of the world distance from the tile's origins to the sphere (may be
    /// negative): the volume is out of reach of rays shorter than this.
    near: f64,
}

/// The region of space that the rays of a tile (or band, or frame) may cover.
#[derive(Clone, Copy, Debug)]
struct Region {
    /// Unit inward normals (zero: no constraint) and offsets: a point x (relative to o₀)
    /// of the region has n·x + k ≥ 0.
    n: [[f64; 3]; 4],
    k: [f64; 4],
    /// An upper bound of the rays' world length.
    t_max: f64,
}

impl Region {
    #[inline(always)]
    fn keeps(&self, s: &Sphere) -> bool {
        // (NaN compares false: kept.)
        if s.near > self.t_max {
            return false;
        }
        for i in 0..4 {
            let n = self.n[i];
            if n[0].mul_add(s.c[0], n[1].mul_add(s.c[1], n[2] * s.c[2])) + self.k[i] < -s.r {
                return false;
            }
        }
        true
    }
}

/// The least and greatest depth values of a set of pixels, and whether one is NaN.
#[derive(Clone, Copy, Debug)]
struct DepthRange {
    lo: f32,
    hi: f32,
    nan: bool,
}

impl DepthRange {
    const EMPTY: DepthRange = DepthRange {
        lo: f32::INFINITY,
        hi: f32::NEG_INFINITY,
        nan: false,
    };

    fn join(self, o: DepthRange) -> DepthRange {
        DepthRange {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            nan: self.nan | o.nan,
        }
    }

    /// The range of `values`.
    fn of(values: &[f32]) -> DepthRange {
        let mut chunks = values.chunks_exact(8);
        let mut lo = f32x8::splat(f32::INFINITY);
        let mut hi = f32x8::splat(f32::NEG_INFINITY);
        let mut nan = Lane::ne(f32x8::splat(0.0), f32x8::splat(0.0));
        for c in &mut chunks {
            let v = f32x8::load(c);
            // minps/maxps: the second operand wins on NaN, so NaN values are skipped.
            lo = Lane::min(v, lo);
            hi = Lane::max(v, hi);
            // (Not `ne`: the x8 `ne` is ordered, false for NaN.)
            nan |= !Lane::eq(v, v);
        }
        let lo8 = lo.to_array();
        let hi8 = hi.to_array();
        let mut r = DepthRange {
            lo: lo8.iter().fold(f32::INFINITY, |a, &b| a.min(b)),
            hi: hi8.iter().fold(f32::NEG_INFINITY, |a, &b| a.max(b)),
            nan: <f32x8 as Lane>::any(nan),
        };
        for &v in chunks.remainder() {
            r = r.join(DepthRange {
                lo: v,
                hi: v,
                nan: v.is_nan(),
            });
        }
        r
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

fn norm1(a: [f64; 3]) -> f64 {
    a[0].abs() + a[1].abs() + a[2].abs()
}

/// a + s·b
fn axpy(s: f64, b: [f64; 3], a: [f64; 3]) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

fn scale(s: f64, a: [f64; 3]) -> [f64; 3] {
    a.map(|x| s * x)
}

fn f64s(a: [f32; 3]) -> [f64; 3] {
    a.map(f64::from)
}

/// The candidate lists of the tiles of one group of [`TILE_H`] rows: tile `j`'s list is
/// `list(j)` (volume indices, increasing).
#[derive(Default, Debug)]
pub(crate) struct TileLists {
    /// Positions in the frame's list of the volumes the rows may see.
    band: Vec<u32>,
    /// Per tile, its depth range.
    ranges: Vec<DepthRange>,
    /// The tiles' lists, concatenated, and where each ends.
    idx: Vec<u32>,
    ends: Vec<usize>,
}

impl TileLists {
    /// Number of tiles.
    pub(crate) fn len(&self) -> usize {
        self.ends.len()
    }

    /// The candidates of tile `j`.
    pub(crate) fn list(&self, j: usize) -> &[u32] {
        let a = if j == 0 { 0 } else { self.ends[j - 1] };
        &self.idx[a..self.ends[j]]
    }
}

/// Everything about a frame that the culling needs: the ray field in f64 and the volumes
/// the whole frame may see.
#[derive(Debug)]
pub(crate) struct FrameCull {
    ortho: bool,
    o_u: [f64; 3],
    o_v: [f64; 3],
    d0: [f64; 3],
    d_u: [f64; 3],
    d_v: [f64; 3],
    /// sign of det(d₀, d_u, d_v) (perspective) or det(o_u, o_v, d₀) (orthographic); 0
    /// for a degenerate field (then no plane is used).
    sign: f64,
    width: usize,
    height: usize,
    /// Indices of the additive volumes the frame may see, and their spheres.
    index: Vec<u32>,
    spheres: Vec<Sphere>,
}

impl FrameCull {
    /// `None` where the pass evaluates without lists: no additive volume, or culling
    /// switched off (`Scene::without_culling`, `Scene::without_tile_culling`).
    pub(crate) fn new(
        scene: &Scene,
        plan: &FramePlan,
        width: usize,
        height: usize,
    ) -> Option<FrameCull> {
        let set = &scene.volumes;
        if set.additive.is_empty() || set.no_culling || set.no_tile_culling {
            return None;
        }
        let (o0, o_u, o_v) = (f64s(plan.o0), f64s(plan.o_u), f64s(plan.o_v));
        let (d0, d_u, d_v) = (f64s(plan.d0), f64s(plan.d_u), f64s(plan.d_v));
        let ortho = plan.ortho;
        let det = if ortho {
            dot(o_u, cross(o_v, d0))
        } else {
            dot(d0, cross(d_u, d_v))
        };
        let scale_det = if ortho {
            norm(o_u) * norm(o_v) * norm(d0)
        } else {
            norm(d0) * norm(d_u) * norm(d_v)
        };
        let sign = if det.is_finite() && det.abs() > 1e-9 * scale_det {
            det.signum()
        } else {
            0.0
        };
        // The forward axis: every ray point x has f·(x − o) ≥ 0, f·d > 0 (perspective:
        // d_u, d_v ⊥ f, so f·d = f·d₀ across the frame).
        let f = if ortho || sign == 0.0 {
            scale(1.0 / norm(d0), d0)
        } else {
            let c = cross(d_u, d_v);
            let c = scale(1.0 / norm(c), c);
            if dot(c, d0) < 0.0 {
                scale(-1.0, c)
            } else {
                c
            }
        };
        // The least |d| over the field, for the directions' rounding as an angle.
        let d_min = if ortho || sign == 0.0 {
            norm(d0)
        } else {
            dot(f, d0)
        };
        let f_d = norm1(d0) + norm1(d_u) + norm1(d_v);
        let alpha = if d_min > 0.0 && d_min.is_finite() {
            1e-6 * f_d / d_min + 1e-6
        } else {
            f64::INFINITY
        };
        let f_o = norm1(o0) + norm1(o_u) + norm1(o_v);
        let f_ouv = norm1(o_u) + norm1(o_v);
        let mut cull = FrameCull {
            ortho,
            o_u,
            o_v,
            d0,
            d_u,
            d_v,
            sign,
            width,
            height,
            index: Vec::new(),
            spheres: Vec::new(),
        };
        let frame = cull.region(
            0,
            width.max(1) - 1,
            0,
            height.max(1) - 1,
            DepthRange {
                lo: f32::NEG_INFINITY,
                hi: f32::INFINITY,
                nan: true,
            },
            plan,
        );
        for (k, v) in set.additive.iter().enumerate() {
            let c = [0, 1, 2].map(|i| f64::from(v.center[i]) - o0[i]);
            let b = f64::from(v.bound_radius);
            // Bounds |c − o|₁ + |o|₁ over the frame's origins (`may_touch`'s magnitude).
            let mag = (norm1(c) + f_ouv + f_o) * 1.001;
            let dist = norm(c);
            let r = 1.0011 * b + 2.1e-5 * mag + 2e-6 * f_o + alpha * (dist + f_ouv + 2.0 * b);
            let ahead = dot(f, c);
            let near = if ortho { ahead - r } else { dist - r };
            let s = Sphere { c, r, near };
            let visible = if alpha.is_finite() && r.is_finite() {
                ahead >= -r && frame.keeps(&s)
            } else {
                // Unusable numbers: never drop (NaN compares false).
                cull.sign = 0.0;
                true
            };
            if visible {
                cull.index.push(k as u32);
                cull.spheres.push(s);
            }
        }
        if cull.sign == 0.0 || !alpha.is_finite() {
            // No usable geometry: every volume is a candidate everywhere.
            cull.index = (0..set.additive.len() as u32).collect();
            cull.spheres = vec![
                Sphere {
                    c: [0.0; 3],
                    r: f64::INFINITY,
                    near: f64::NEG_INFINITY,
                };
                set.additive.len()
            ];
        }
        Some(cull)
    }

    /// The region of the pixels with columns x_a..=x_b and rows y_a..=y_b whose depth
    /// values span `range`.
    fn region(
        &self,
        x_a: usize,
        x_b: usize,
        y_a: usize,
        y_b: usize,
        range: DepthRange,
        plan: &FramePlan,
    ) -> Region {
        // NDC of the pixel centres, as `FramePlan::row` / `FramePlan::ray` form them
        // (increasing in x, decreasing in y).
        let u = |x: usize| f64::from(Lane::mul_add(x as f32, plan.su, plan.ou));
        let v = |y: usize| f64::from(Lane::mul_add(y as f32, plan.sv, plan.ov));
        let (u_lo, u_hi, v_hi, v_lo) = (u(x_a), u(x_b), v(y_a), v(y_b));
        let s = self.sign;
        let mut n = [[0.0; 3]; 4];
        let mut k = [0.0; 4];
        let d_max;
        if self.ortho {
            let m_v = cross(self.o_v, self.d0);
            let m_u = cross(self.o_u, self.d0);
            let planes = [
                (scale(s, m_v), scale(u_lo, self.o_u)),
                (scale(-s, m_v), scale(u_hi, self.o_u)),
                (scale(-s, m_u), scale(v_lo, self.o_v)),
                (scale(s, m_u), scale(v_hi, self.o_v)),
            ];
            for (i, (m, p)) in planes.into_iter().enumerate() {
                let l = norm(m);
                if s != 0.0 && l > 0.0 && l.is_finite() {
                    n[i] = scale(1.0 / l, m);
                    k[i] = -dot(n[i], p);
                }
            }
            d_max = norm(self.d0);
        } else {
            let a_lo = axpy(u_lo, self.d_u, self.d0);
            let a_hi = axpy(u_hi, self.d_u, self.d0);
            let b_lo = axpy(v_lo, self.d_v, self.d0);
            let b_hi = axpy(v_hi, self.d_v, self.d0);
            let planes = [
                scale(-s, cross(a_lo, self.d_v)),
                scale(s, cross(a_hi, self.d_v)),
                scale(s, cross(b_lo, self.d_u)),
                scale(-s, cross(b_hi, self.d_u)),
            ];
            for (i, m) in planes.into_iter().enumerate() {
                let l = norm(m);
                if s != 0.0 && l > 0.0 && l.is_finite() {
                    n[i] = scale(1.0 / l, m);
                }
            }
            d_max = [(u_lo, v_lo), (u_lo, v_hi), (u_hi, v_lo), (u_hi, v_hi)]
                .into_iter()
                .map(|(u, v)| norm(axpy(v, self.d_v, axpy(u, self.d_u, self.d0))))
                .fold(0.0, f64::max);
        }
        Region {
            n,
            k,
            t_max: world_length(plan, range, d_max),
        }
    }

    /// The candidate lists of the tiles of rows y..y + depth.len()/width (at most
    /// [`TILE_H`] rows; `depth`: their depth values) into `out`.
    pub(crate) fn tiles(&self, plan: &FramePlan, y: usize, depth: &[f32], out: &mut TileLists) {
        let width = self.width;
        let rows = depth.len() / width;
        debug_assert!((1..=TILE_H).contains(&rows) && y + rows <= self.height);
        let tiles = width.div_ceil(TILE_W);
        out.ranges.clear();
        for j in 0..tiles {
            let (xa, xb) = (j * TILE_W, ((j + 1) * TILE_W).min(width));
            let mut r = DepthRange::EMPTY;
            for row in depth.chunks_exact(width) {
                r = r.join(DepthRange::of(&row[xa..xb]));
            }
            out.ranges.push(r);
        }
        let all = out.ranges.iter().fold(DepthRange::EMPTY, |a, &b| a.join(b));
        let band = self.region(0, width - 1, y, y + rows - 1, all, plan);
        out.band.clear();
        for (p, s) in self.spheres.iter().enumerate() {
            if band.keeps(s) {
                out.band.push(p as u32);
            }
        }
        out.idx.clear();
        out.ends.clear();
        for j in 0..tiles {
            if !out.band.is_empty() {
                let (xa, xb) = (j * TILE_W, ((j + 1) * TILE_W).min(width) - 1);
                let tile = self.region(xa, xb, y, y + rows - 1, out.ranges[j], plan);
                for &p in &out.band {
                    if tile.keeps(&self.spheres[p as usize]) {
                        out.idx.push(self.index[p as usize]);
                    }
                }
            }
            out.ends.push(out.idx.len());
        }
    }
}

/// An upper bound of the world length t·|d| of the rays whose depth values span `range`,
/// for |d| ≤ `d_max`: the depth conventions are monotonic in the value (`FramePlan::ray`).
fn world_length(plan: &FramePlan, r: DepthRange, d_max: f64) -> f64 {
    let inf = f64::INFINITY;
    if r.nan {
        return inf;
    }
    if r.lo > r.hi {
        // No pixel.
        return 0.0;
    }
    let (lo, hi) = (f64::from(r.lo), f64::from(r.hi));
    // t in units of d, or the world length directly for `Distance`.
    let (t, world) = match plan.depth {
        DepthPlan::Linear => (hi, false),
        // t = depth / |d| in f32, so t·|d| = depth within a few roundings.
        DepthPlan::Distance => (hi, true),
        DepthPlan::NdcPerspective { n, k, q, reversed } => {
            let (n, k, q) = (f64::from(n), f64::from(k), f64::from(q));
            let t = if reversed {
                if lo > 0.0 {
                    n / lo.mul_add(k, q)
                } else {
                    inf
                }
            } else if hi < 1.0 {
                n / (-hi).mul_add(k, 1.0)
            } else {
                inf
            };
            (t, false)
        }
        DepthPlan::NdcOrthographic {
            n,
            f,
            span,
            reversed,
        } => {
            let (n, f, span) = (f64::from(n), f64::from(f), f64::from(span));
            // The f32 multiply-add rounds once, relative to its terms' magnitudes.
            let slack = 1e-6 * (n.abs() + f.abs() + span.abs());
            let t = if reversed {
                if lo > 0.0 {
                    (-lo).mul_add(span, f) + slack
                } else {
                    inf
                }
            } else if hi < 1.0 {
                hi.mul_add(span, n) + slack
            } else {
                inf
            };
            (t, false)
        }
    };
    let t = t.max(0.0);
    let w = if world { t } else { t * d_max };
    let w = w * (1.0 + 1e-5);
    if w.is_nan() || w > 1e30 {
        inf
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    //! The lists keep every volume that the kernel's per-packet test keeps for some ray of
    //! the tile (the rays generated exactly as the pass generates them), with volumes
    //! placed at that test's margin: beside a pixel's ray and beyond its end, from near and
    //! far cameras of every kind, under every depth convention.
    use super::*;
    use crate::medium::volume::may_touch_ray;
    use crate::pass::{Camera, DepthConvention};
    use crate::{Scene, SceneDesc, Shape, Volume};
    use glam::{DVec3, Mat4, Vec3};

    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }
        fn f(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.f()
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
        fn unit(&mut self) -> DVec3 {
            loop {
                let v = DVec3::new(
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                    self.range(-1.0, 1.0),
                );
                if v.length() > 0.2 && v.length() <= 1.0 {
                    return v.normalize();
                }
            }
        }
    }

    fn camera(rng: &mut Rng, far: f64, aspect: f32) -> Camera {
        let pos = (rng.unit() * far * rng.f()).as_vec3();
        let fwd = rng.unit().as_vec3();
        let up = loop {
            let u = rng.unit().as_vec3();
            if u.cross(fwd).length() > 0.1 {
                break u;
            }
        };
        match rng.below(4) {
            0 => Camera::perspective(pos, fwd, up, rng.range(0.1, 3.0) as f32, aspect).unwrap(),
            1 => Camera::orthographic(pos, fwd, up, rng.range(0.5, 200.0) as f32, aspect).unwrap(),
            2 => {
                let view = Mat4::look_at_rh(pos, pos + fwd, up);
                let proj = Mat4::perspective_infinite_reverse_rh(
                    rng.range(0.2, 2.5) as f32,
                    aspect * rng.range(0.5, 2.0) as f32,
                    0.05,
                );
                Camera::from_inverse_view_projection((proj * view).inverse(), None).unwrap()
            }
            _ => {
                let view = Mat4::look_at_rh(pos, pos + fwd, up);
                let proj = Mat4::orthographic_rh(-7.0, 5.0, -3.0, 4.0, 0.5, 300.0);
                Camera::from_inverse_view_projection((proj * view).inverse(), Some(pos)).unwrap()
            }
        }
    }

    fn convention(rng: &mut Rng, cam: &Camera) -> DepthConvention {
        let persp = cam.projection() == crate::pass::Projection::Perspective;
        match rng.below(4) {
            0 => DepthConvention::LinearView,
            1 => DepthConvention::Distance,
            k => {
                let near = if persp {
                    rng.range(0.01, 1.0) as f32
                } else {
                    rng.range(-5.0, 5.0) as f32
                };
                let far = if persp && rng.below(3) == 0 {
                    f32::INFINITY
                } else {
                    near + rng.range(10.0, 1000.0) as f32
                };
                DepthConvention::NdcZeroToOne {
                    near,
                    far,
                    reversed: k == 3,
                }
            }
        }
    }

    fn depth_value(rng: &mut Rng, conv: DepthConvention) -> f32 {
        match conv {
            DepthConvention::LinearView | DepthConvention::Distance => match rng.below(8) {
                0 => f32::INFINITY,
                1 => 0.0,
                2 => -1.0,
                3 => f32::NAN,
                _ => rng.range(0.0, 150.0) as f32,
            },
            DepthConvention::NdcZeroToOne { reversed, .. } => match rng.below(8) {
                0 => f32::from(u8::from(!reversed)),
                1 => f32::from(u8::from(reversed)),
                2 => f32::NAN,
                _ => rng.f() as f32,
            },
        }
    }

    #[test]
    fn lists_keep_every_volume_the_packet_test_keeps() {
        let mut rng = Rng(0x1234_5678_9abc_def1);
        let sizes = [(7, 3), (33, 9), (40, 17), (65, 8), (1, 11), (70, 20)];
        let (mut kept_by_packet, mut listed, mut pairs) = (0usize, 0usize, 0usize);
        for case in 0..300 {
            let (w, h) = sizes[case % sizes.len()];
            let far = [1.0, 50.0, 1e4][case % 3];
            let cam = camera(&mut rng, far, w as f32 / h as f32);
            let conv = convention(&mut rng, &cam);
            // Depth: blocks of one value (narrow tile ranges) with a few outliers.
            let block: Vec<f32> = (0..16).map(|_| depth_value(&mut rng, conv)).collect();
            let depth: Vec<f32> = (0..w * h)
                .map(|i| {
                    if rng.below(30) == 0 {
                        depth_value(&mut rng, conv)
                    } else {
                        block[(i % w) / 9 % 4 + 4 * ((i / w) / 5 % 4)]
                    }
                })
                .collect();
            let plan = FramePlan::new(&cam, w, h, conv).unwrap();
            // Shapes at the origin first, for their compiled bounding radii.
            let count = 40;
            let shapes: Vec<(f32, Shape)> = (0..count)
                .map(|_| {
                    let size = [0.01, 0.3, 3.0][rng.below(3)] * rng.range(0.5, 1.0);
                    let s = match rng.below(3) {
                        0 => Shape::Sphere {
                            center: Vec3::ZERO,
                            radius: size as f32,
                        },
                        1 => Shape::Ellipsoid {
                            center: Vec3::ZERO,
                            radii: Vec3::new(size as f32, 0.3 * size as f32, 0.7 * size as f32),
                            rotation: glam::Quat::from_axis_angle(rng.unit().as_vec3(), 1.0),
                        },
                        _ => Shape::Box {
                            center: Vec3::ZERO,
                            half_extents: Vec3::new(size as f32, 0.5 * size as f32, 0.2),
                            rotation: glam::Quat::IDENTITY,
                            edge_fade: 0.0,
                        },
                    };
                    (0.0, s)
                })
                .collect();
            let probe = Scene::new(SceneDesc {
                volumes: shapes
                    .iter()
                    .map(|(_, s)| Volume::new(s.clone(), crate::Profile::Constant, Vec3::ONE))
                    .collect(),
                ..SceneDesc::default()
            })
            .unwrap();
            let mut vols = Vec::new();
            for (k, (_, shape)) in shapes.into_iter().enumerate() {
                let b = f64::from(probe.volumes.additive[k].bound_radius);
                let (x, y) = (rng.below(w), rng.below(h));
                let row = plan.row(y);
                let (o, d, t) = plan.ray::<f32>(&row, x as f32, depth[y * w + x]);
                let (o, d) = (
                    DVec3::from_array(o.map(f64::from)),
                    DVec3::from_array(d.map(f64::from)),
                );
                let dir = d.normalize();
                let t_w = f64::from(t) * d.length();
                let side = dir.cross(rng.unit()).normalize();
                // The per-packet test's radius at a centre c: b·1.001 + 1e-5·(|c − o|₁ + |o|₁).
                let r_mt = |c: DVec3| {
                    b * 1.001 + 1e-5 * ((c - o).abs().element_sum() + o.abs().element_sum())
                };
                let delta = [1e-7, 1e-6, 1e-5, 1e-4, -1e-6, -1e-3][rng.below(6)];
                let mut c = match rng.below(3) {
                    // Beyond the segment's end, on the ray.
                    0 if t_w.is_finite() => o + dir * (t_w + b),
                    // Beside the ray, within the segment.
                    _ => {
                        let s = if t_w.is_finite() {
                            t_w * rng.f()
                        } else {
                            rng.range(0.0, 300.0)
                        };
                        o + dir * s + side * b
                    }
                };
                // Move the centre to (1 − δ) times the test's radius from the ray point.
                let anchor = if t_w.is_finite() && (c - o).dot(dir) > t_w {
                    o + dir * t_w
                } else {
                    o + dir * (c - o).dot(dir)
                };
                for _ in 0..3 {
                    let off = (c - anchor).normalize_or_zero();
                    c = anchor + off * (r_mt(c) * (1.0 - delta));
                }
                let shape = match shape {
                    Shape::Sphere { radius, .. } => Shape::Sphere {
                        center: c.as_vec3(),
                        radius,
                    },
                    Shape::Ellipsoid {
                        radii, rotation, ..
                    } => Shape::Ellipsoid {
                        center: c.as_vec3(),
                        radii,
                        rotation,
                    },
                    Shape::Box {
                        half_extents,
                        rotation,
                        edge_fade,
                        ..
                    } => Shape::Box {
                        center: c.as_vec3(),
                        half_extents,
                        rotation,
                        edge_fade,
                    },
                    s => s,
                };
                vols.push(Volume::new(shape, crate::Profile::Constant, Vec3::ONE));
            }
            let scene = Scene::new(SceneDesc {
                volumes: vols,
                ..SceneDesc::default()
            })
            .unwrap();
            let cull = FrameCull::new(&scene, &plan, w, h).unwrap();
            let mut lists = TileLists::default();
            for (g, dg) in depth.chunks(TILE_H * w).enumerate() {
                cull.tiles(&plan, g * TILE_H, dg, &mut lists);
                for j in 0..lists.len() {
                    let list = lists.list(j);
                    listed += list.len();
                    pairs += count;
                    let xs = j * TILE_W..((j + 1) * TILE_W).min(w);
                    for y in g * TILE_H..(g * TILE_H + dg.len() / w) {
                        let row = plan.row(y);
                        for x in xs.clone() {
                            let (o, d, t) = plan.ray::<f32>(&row, x as f32, depth[y * w + x]);
                            for (k, v) in scene.volumes.additive.iter().enumerate() {
                                if may_touch_ray(v, o, d, t) {
                                    kept_by_packet += 1;
                                    assert!(
                                        list.contains(&(k as u32)),
                                        "case {case}: volume {k} dropped from tile {j} of rows {g}, \
                                         pixel ({x}, {y}), {w}x{h}, {cam:?}, {conv:?}, depth {}",
                                        depth[y * w + x]
                                    );
                                }
                            }
                        }
                    }
                }
            }
        }
        // The placements do reach the test's margin, and the lists do cull.
        assert!(kept_by_packet > 10_000, "{kept_by_packet}");
        assert!(listed * 2 < pairs, "{listed} of {pairs}");
    }
}
