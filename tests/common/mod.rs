//! Shared by the integration tests: a small deterministic generator (xorshift64; the
//! proptest strategies and the table-driven tests feed it a seed).

#![allow(dead_code)] // each test binary uses a different subset

use glam::{DVec3, Quat, Vec3};

pub struct Rng(pub u64);

impl Rng {
    /// A generator whose state is spread from `seed` (any seed, 0 included).
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    /// Uniform in [0, 1).
    pub fn uni(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    pub fn range(&mut self, a: f64, b: f64) -> f64 {
        a + (b - a) * self.uni()
    }
    /// Log-uniform in [a, b] (a, b > 0).
    pub fn log_range(&mut self, a: f64, b: f64) -> f64 {
        (a.ln() + (b.ln() - a.ln()) * self.uni()).exp()
    }
    pub fn sign(&mut self) -> f64 {
        if self.next() & 1 == 0 {
            1.0
        } else {
            -1.0
        }
    }
    /// Uniform in 0..n.
    pub fn pick(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    /// A uniformly distributed unit vector (f64).
    pub fn unit(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
                self.range(-1.0, 1.0),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
    /// A unit vector rounded to f32 (and normalized there).
    pub fn unit_vec3(&mut self) -> Vec3 {
        loop {
            let v = Vec3::new(
                self.range(-1.0, 1.0) as f32,
                self.range(-1.0, 1.0) as f32,
                self.range(-1.0, 1.0) as f32,
            );
            if v.length() > 0.1 {
                return v.normalize();
            }
        }
    }
    /// Uniform in the unit ball.
    pub fn in_ball(&mut self) -> DVec3 {
        self.unit() * self.uni().cbrt()
    }
    pub fn quat(&mut self) -> Quat {
        let v = [0; 4].map(|_| self.range(-1.0, 1.0) as f32);
        let q = Quat::from_xyzw(v[0], v[1], v[2], v[3]);
        if q.length() < 0.1 {
            Quat::IDENTITY
        } else {
            q.normalize()
        }
    }
    /// Each channel uniform in [a, b].
    pub fn rgb(&mut self, a: f64, b: f64) -> Vec3 {
        Vec3::new(
            self.range(a, b) as f32,
            self.range(a, b) as f32,
            self.range(a, b) as f32,
        )
    }
}

/// The ULP of an f32 (2^-149 for zero and subnormals): the unit of the exhaustive sweeps'
/// errors.
pub fn ulp_of(c: f32) -> f64 {
    let a = c.abs();
    if a < f32::MIN_POSITIVE {
        2f64.powi(-149)
    } else {
        let e = ((a.to_bits() >> 23) & 0xff) as i32 - 127;
        2f64.powi(e - 23)
    }
}
