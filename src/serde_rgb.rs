//! serde helper: an RGB (or any 3-vector) value written as one number or `[x, y, z]`.

use core::fmt;
use glam::Vec3;
use serde::de::{self, SeqAccess, Visitor};
use serde::{Deserializer, Serialize, Serializer};

pub fn serialize<S: Serializer>(v: &Vec3, s: S) -> Result<S::Ok, S::Error> {
    v.to_array().serialize(s)
}

pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    // A visitor rather than an untagged enum: errors then point at the value itself
    // (serde_json line and column) and say what was found.
    d.deserialize_any(Rgb)
}

struct Rgb;

impl<'de> Visitor<'de> for Rgb {
    type Value = Vec3;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a number or an array of 3 numbers")
    }

    // Numbers are rounded to f32 (a value beyond its range becomes infinite, which
    // `Scene::new` then rejects, naming the field).
    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec3, A::Error> {
        let mut a = [0.0f32; 3];
        for (i, x) in a.iter_mut().enumerate() {
            *x = seq
                .next_element()?
                .ok_or_else(|| de::Error::invalid_length(i, &"an array of 3 numbers"))?;
        }
        let mut extra = 0;
        while seq.next_element::<de::IgnoredAny>()?.is_some() {
            extra += 1;
        }
        if extra > 0 {
            return Err(de::Error::invalid_length(
                3 + extra,
                &"an array of 3 numbers",
            ));
        }
        Ok(Vec3::from_array(a))
    }
}
