//! The report's ray sets: structure-of-arrays columns, typical and extreme, reproducible
//! (xorshift with fixed seeds).

/// A batch of rays, structure of arrays (the crate's batch layout).
pub struct RaySet {
    /// Origins, x, y, z.
    pub o: [Vec<f32>; 3],
    /// Directions, x, y, z.
    pub d: [Vec<f32>; 3],
    /// Segment ends.
    pub t: Vec<f32>,
}

/// Borrowed slices of a [`RaySet`] (one chunk of it).
#[derive(Clone, Copy)]
pub struct RaysRef<'a> {
    /// Origins, x, y, z.
    pub o: [&'a [f32]; 3],
    /// Directions, x, y, z.
    pub d: [&'a [f32]; 3],
    /// Segment ends.
    pub t: &'a [f32],
}

impl RaySet {
    pub(crate) fn with_len(n: usize) -> RaySet {
        RaySet {
            o: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            d: [vec![0.0; n], vec![0.0; n], vec![0.0; n]],
            t: vec![0.0; n],
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The whole set, borrowed.
    pub fn view(&self) -> RaysRef<'_> {
        RaysRef {
            o: [&self.o[0], &self.o[1], &self.o[2]],
            d: [&self.d[0], &self.d[1], &self.d[2]],
            t: &self.t,
        }
    }

    pub(crate) fn set(&mut self, i: usize, o: [f32; 3], d: [f32; 3], t: f32) {
        for c in 0..3 {
            self.o[c][i] = o[c];
            self.d[c][i] = d[c];
        }
        self.t[i] = t;
    }
}

impl<'a> RaysRef<'a> {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The rays before `mid` and from `mid` (panics if `mid > len`, as `slice::split_at`).
    pub fn split_at(&self, mid: usize) -> (RaysRef<'a>, RaysRef<'a>) {
        let s = |x: &'a [f32]| x.split_at(mid);
        let (o0, o1, o2) = (s(self.o[0]), s(self.o[1]), s(self.o[2]));
        let (d0, d1, d2) = (s(self.d[0]), s(self.d[1]), s(self.d[2]));
        let t = s(self.t);
        (
            RaysRef {
                o: [o0.0, o1.0, o2.0],
                d: [d0.0, d1.0, d2.0],
                t: t.0,
            },
            RaysRef {
                o: [o0.1, o1.1, o2.1],
                d: [d0.1, d1.1, d2.1],
                t: t.1,
            },
        )
    }

    /// Ray `i` as (origin, direction, t).
    pub fn get(&self, i: usize) -> ([f32; 3], [f32; 3], f32) {
        (
            [self.o[0][i], self.o[1][i], self.o[2][i]],
            [self.d[0][i], self.d[1][i], self.d[2][i]],
            self.t[i],
        )
    }
}

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [0, 1) with 24 bits (the C peer's generator).
    fn uni(&mut self) -> f32 {
        ((self.next() >> 40) as f64 * (1.0 / 16777216.0)) as f32
    }
    fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.uni()
    }
    fn unit(&mut self) -> [f32; 3] {
        loop {
            let v = [0, 1, 2].map(|_| self.range(-1.0, 1.0));
            let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
            if l2 > 1e-4 && l2 <= 1.0 {
                let l = l2.sqrt();
                return v.map(|x| x / l);
            }
        }
    }
}

fn norm(v: [f32; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    v.map(|x| x / l)
}

/// Height fog rays: the C peer's data sets (`../shared/peers/`, same generator and seed):
/// cameras 0–10 above the base, directions in a vertical plane, segments up to 1000
/// stopping at the ground; extreme: every 8th ray nearly horizontal (|d_up| ≤ 1e-6) and
/// up to 1e7 long.
pub fn height_fog(n: usize, extreme: bool) -> RaySet {
    let p = crate::reference::peer::PeerRays::new(n, extreme);
    let dx = p.dx();
    let mut s = RaySet::with_len(n);
    for i in 0..n {
        s.set(i, [0.0, p.oy[i], 0.0], [dx[i], p.dy[i], 0.0], p.t[i]);
    }
    s
}

/// Rays toward a sphere (centre `c`, radius `rad`): typical: cameras 1.5–6 radii away
/// aimed at points within 1.3 radii of the centre, segments ending before, inside or
/// beyond it. Extreme: cameras up to 1e6 radii away, near-tangent rays, rays starting
/// inside, zero-length and infinite segments.
pub fn toward_sphere(n: usize, extreme: bool, c: [f32; 3], rad: f32) -> RaySet {
    let mut r = Rng(0x9E3779B97F4A7C15);
    let mut s = RaySet::with_len(n);
    for i in 0..n {
        let kind = if extreme { i % 6 } else { 0 };
        let dist = match kind {
            1 => rad * 10f32.powf(r.range(2.0, 6.0)),
            3 => rad * r.uni() * 0.9,
            _ => rad * r.range(1.5, 6.0),
        };
        let dir_o = r.unit();
        let o = [0, 1, 2].map(|k| c[k] + dir_o[k] * dist);
        let aim_r = match kind {
            2 => rad * r.range(0.999, 1.001),
            _ => rad * 1.3 * r.uni().cbrt(),
        };
        let a = r.unit();
        let target = [0, 1, 2].map(|k| c[k] + a[k] * aim_r);
        let d = if kind == 3 {
            r.unit()
        } else {
            norm([0, 1, 2].map(|k| target[k] - o[k]))
        };
        let t = match kind {
            4 => 0.0,
            5 => f32::INFINITY,
            _ => dist * r.range(0.5, 2.5),
        };
        s.set(i, o, d, t);
    }
    s
}

/// Camera rays of a landscape: a camera 1–3 above the ground near the origin, directions
/// in the front half-space from 30° below to 60° above the horizon, segments 1–300 that
/// stop at the ground y = 0, and every 16th ray looking up to the sky (t = +∞). Extreme:
/// a quarter of the rays from cameras 1e-2 to 1e4 below or above the fog's base and up
/// to 1e5 away, nearly horizontal, with segments up to 1e7 or infinite.
pub fn landscape(n: usize, extreme: bool) -> RaySet {
    let mut r = Rng(0x2545F4914F6CDD1D);
    let mut s = RaySet::with_len(n);
    for i in 0..n {
        let wild = extreme && i % 4 == 0;
        let o = if wild {
            [
                r.range(-1e5, 1e5),
                10f32.powf(r.range(-2.0, 4.0)) * if r.uni() < 0.5 { -1.0 } else { 1.0 },
                r.range(-1e5, 1e5),
            ]
        } else {
            [r.range(-2.0, 2.0), r.range(1.0, 3.0), r.range(-2.0, 2.0)]
        };
        let az = r.range(-1.2, 1.2);
        let el = if wild {
            r.range(-1e-6, 1e-6)
        } else {
            r.range(-0.5, 1.0)
        };
        let d = [el.cos() * az.sin(), el.sin(), el.cos() * az.cos()];
        let t = if wild {
            if i % 16 == 0 {
                f32::INFINITY
            } else {
                10f32.powf(r.range(0.0, 7.0))
            }
        } else if d[1] > 0.05 && i % 16 == 15 {
            // Sky pixels look up; the others stop at the ground (y = 0) or earlier.
            f32::INFINITY
        } else {
            let t = r.range(1.0, 300.0);
            if d[1] < 0.0 {
                t.min(o[1] / -d[1])
            } else {
                t
            }
        };
        s.set(i, o, d, t);
    }
    s
}
