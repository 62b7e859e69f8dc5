//! Independent f64 reference: plain f64 code written straight from the seeds' formulas,
//! and numerical quadrature of the integrals, used by the tests to check the f32 kernels.
//! (Being filled in.)
