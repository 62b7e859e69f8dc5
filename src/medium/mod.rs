//! Participating media, one file each.

pub(crate) mod distance;
pub(crate) mod height_fog;
pub(crate) mod volume;
