//! Independent f64 reference (placeholder, replaced below).
