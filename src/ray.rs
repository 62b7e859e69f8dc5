//! Structure-of-arrays ray batches and output sets that borrow the caller's slices.

use crate::error::BatchError;

/// A batch of rays o + s·d, s in [0, t], as seven borrowed slices of equal length.
///
/// `d` need not be unit length (the segment's length is t·|d|) unless the batch is marked
/// with [`Rays::with_unit_directions`]. `t` may be `+inf` (a sky pixel). Rays with a NaN
/// or infinite origin or direction, or a NaN or negative `t`, are invalid: their outputs
/// are NaN (never a plausible number), and nothing panics.
#[derive(Clone, Copy, Debug)]
pub struct Rays<'a> {
    pub(crate) o: [&'a [f32]; 3],
    pub(crate) d: [&'a [f32]; 3],
    pub(crate) t: &'a [f32],
    pub(crate) unit: bool,
}

impl<'a> Rays<'a> {
    /// Borrows the seven slices; they must all have the same length.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        ox: &'a [f32],
        oy: &'a [f32],
        oz: &'a [f32],
        dx: &'a [f32],
        dy: &'a [f32],
        dz: &'a [f32],
        t: &'a [f32],
    ) -> Result<Rays<'a>, BatchError> {
        let n = t.len();
        for (field, s) in [
            ("ox", ox),
            ("oy", oy),
            ("oz", oz),
            ("dx", dx),
            ("dy", dy),
            ("dz", dz),
        ] {
            if s.len() != n {
                return Err(BatchError::LengthMismatch {
                    field,
                    expected: n,
                    found: s.len(),
                });
            }
        }
        Ok(Rays {
            o: [ox, oy, oz],
            d: [dx, dy, dz],
            t,
            unit: false,
        })
    }

    /// Declares that every direction has unit length (within rounding), so the kernels
    /// skip computing |d| and, where the scene allows, do not read the direction
    /// components they do not need. Results for non-unit directions are then scaled by
    /// |d| (finite, but not the segment's true optical depth).
    pub fn with_unit_directions(mut self, unit: bool) -> Self {
        self.unit = unit;
        self
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.t.len()
    }

    /// True if the batch holds no ray.
    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    /// The rays in `start..end` (clamped to the batch).
    pub fn slice(&self, start: usize, end: usize) -> Rays<'a> {
        let end = end.min(self.len());
        let start = start.min(end);
        Rays {
            o: self.o.map(|s| &s[start..end]),
            d: self.d.map(|s| &s[start..end]),
            t: &self.t[start..end],
            unit: self.unit,
        }
    }
}

/// Three mutable slices, one per RGB channel.
pub type RgbSlices<'a> = [&'a mut [f32]; 3];

/// The outputs a caller wants, written into the caller's slices. Outputs left `None`
/// are not computed (τ only is cheapest; in-scattering needs the transmittance).
#[derive(Debug, Default)]
pub struct Outputs<'a> {
    /// Optical depth τ per channel.
    pub tau: Option<RgbSlices<'a>>,
    /// Transmittance T = exp(−τ) per channel.
    pub transmittance: Option<RgbSlices<'a>>,
    /// In-scattered radiance L_in per channel (so that L = L_surface · T + L_in).
    pub inscattering: Option<RgbSlices<'a>>,
}

impl<'a> Outputs<'a> {
    pub(crate) fn check(&self, n: usize) -> Result<(), BatchError> {
        let groups: [(&Option<RgbSlices<'a>>, [&'static str; 3]); 3] = [
            (&self.tau, ["tau_r", "tau_g", "tau_b"]),
            (&self.transmittance, ["T_r", "T_g", "T_b"]),
            (&self.inscattering, ["in_r", "in_g", "in_b"]),
        ];
        for (g, names) in groups {
            if let Some(s) = g {
                for c in 0..3 {
                    if s[c].len() != n {
                        return Err(BatchError::LengthMismatch {
                            field: names[c],
                            expected: n,
                            found: s[c].len(),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// Splits off the outputs for rays `0..mid` and returns them; `self` keeps the rest.
    pub(crate) fn split_at(self, mid: usize) -> (Outputs<'a>, Outputs<'a>) {
        fn split<'b>(
            s: Option<RgbSlices<'b>>,
            mid: usize,
        ) -> (Option<RgbSlices<'b>>, Option<RgbSlices<'b>>) {
            match s {
                None => (None, None),
                Some([r, g, b]) => {
                    let (r0, r1) = r.split_at_mut(mid);
                    let (g0, g1) = g.split_at_mut(mid);
                    let (b0, b1) = b.split_at_mut(mid);
                    (Some([r0, g0, b0]), Some([r1, g1, b1]))
                }
            }
        }
        let (t0, t1) = split(self.tau, mid);
        let (x0, x1) = split(self.transmittance, mid);
        let (l0, l1) = split(self.inscattering, mid);
        (
            Outputs {
                tau: t0,
                transmittance: x0,
                inscattering: l0,
            },
            Outputs {
                tau: t1,
                transmittance: x1,
                inscattering: l1,
            },
        )
    }
}
