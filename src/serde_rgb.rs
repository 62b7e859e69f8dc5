//! serde helper: an RGB (or any 3-vector) value written as one number or `[x, y, z]`.

use glam::Vec3;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

#[derive(Deserialize)]
#[serde(untagged)]
enum Form {
    One(f32),
    Three([f32; 3]),
}

pub fn serialize<S: Serializer>(v: &Vec3, s: S) -> Result<S::Ok, S::Error> {
    v.to_array().serialize(s)
}

pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
    match Form::deserialize(d) {
        Ok(Form::One(x)) => Ok(Vec3::splat(x)),
        Ok(Form::Three(a)) => Ok(Vec3::from_array(a)),
        Err(_) => Err(serde::de::Error::custom(
            "expected a number or an array of 3 numbers",
        )),
    }
}
