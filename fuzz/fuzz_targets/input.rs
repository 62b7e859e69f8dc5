//! The fuzz targets' reader: the fuzzer's bytes as little-endian f32 bit patterns and
//! bytes (zeros past the end). Included by each target with `#[path]`.

#![allow(dead_code)] // each target uses a subset

use glam::Vec3;

pub struct Input<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Input<'a> {
    pub fn new(data: &'a [u8]) -> Self {
        Input { data, at: 0 }
    }
    pub fn byte(&mut self) -> u8 {
        let b = self.data.get(self.at).copied().unwrap_or(0);
        self.at += 1;
        b
    }
    pub fn f32(&mut self) -> f32 {
        f32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }
    pub fn vec3(&mut self) -> Vec3 {
        Vec3::new(self.f32(), self.f32(), self.f32())
    }
    /// A non-negative parameter (a coefficient, a radius): its absolute value unless `raw`
    /// (so that most scenes are valid).
    pub fn abs3(&mut self, raw: bool) -> Vec3 {
        let v = self.vec3();
        if raw {
            v
        } else {
            v.abs()
        }
    }
    pub fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.at)
    }
}
