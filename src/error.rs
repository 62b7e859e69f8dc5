//! Typed errors. Every error names what was wrong and where (a field path such as
//! `height_fog[0].components[1].scattering[2]`, or a slice name).

use core::fmt;

/// A scene description that cannot be evaluated.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneError {
    /// A value is NaN or infinite.
    NonFinite {
        /// The field's path.
        field: String,
        /// The value given.
        value: f32,
    },
    /// A value that must be non-negative is negative.
    Negative {
        /// The field's path.
        field: String,
        /// The value given.
        value: f32,
    },
    /// A vector that must have a direction is zero (or too small to normalize).
    ZeroVector {
        /// The field's path.
        field: String,
    },
    /// A value is outside its allowed range.
    OutOfRange {
        /// The field's path.
        field: String,
        /// The value given.
        value: f32,
        /// The allowed range, as the message prints it (e.g. `"(-1, 1)"`).
        range: &'static str,
    },
    /// A list that must not be empty is empty.
    Empty {
        /// The list's path.
        field: String,
    },
    /// A field that needs another one that is not set (e.g. a lobe without a sun).
    Requires {
        /// The field's path.
        field: String,
        /// What it needs, as the message prints it (e.g. `"lighting.sun"`).
        requires: &'static str,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::NonFinite { field, value } => {
                write!(f, "{field}: must be finite, got {value}")
            }
            SceneError::Negative { field, value } => {
                write!(f, "{field}: must be >= 0, got {value}")
            }
            SceneError::ZeroVector { field } => {
                write!(f, "{field}: must be a non-zero vector")
            }
            SceneError::OutOfRange {
                field,
                value,
                range,
            } => write!(f, "{field}: must be in {range}, got {value}"),
            SceneError::Empty { field } => write!(f, "{field}: must not be empty"),
            SceneError::Requires { field, requires } => {
                write!(f, "{field}: needs {requires}")
            }
        }
    }
}

impl SceneError {
    /// The path of the offending field (`height_fog[0].falloff`, `limits.max_opacity`).
    pub fn field(&self) -> &str {
        match self {
            SceneError::NonFinite { field, .. }
            | SceneError::Negative { field, .. }
            | SceneError::ZeroVector { field }
            | SceneError::OutOfRange { field, .. }
            | SceneError::Empty { field }
            | SceneError::Requires { field, .. } => field,
        }
    }
}

impl std::error::Error for SceneError {}

/// A ray batch or output set whose slices do not fit together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BatchError {
    /// A slice's length differs from the batch's ray count.
    LengthMismatch {
        /// The slice's name (`"oy"`, `"T_g"`, ...).
        field: &'static str,
        /// The batch's ray count (the length of `t`).
        expected: usize,
        /// The slice's length.
        found: usize,
    },
}

impl fmt::Display for BatchError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BatchError::LengthMismatch {
                field,
                expected,
                found,
            } => write!(
                f,
                "{field}: has {found} elements, the batch has {expected} rays"
            ),
        }
    }
}

impl std::error::Error for BatchError {}

/// A framebuffer fog pass ([`Scene::fog_pass`](crate::Scene::fog_pass)) or a camera
/// ([`Camera`](crate::pass::Camera)) that cannot be used.
#[derive(Clone, Debug, PartialEq)]
pub enum PassError {
    /// A buffer's length does not fit the frame: `buffer` is `"depth"`, `"colour"` (RGB or
    /// RGBA) or `"colour.r"`, `"colour.g"`, `"colour.b"` (planar).
    BufferLength {
        /// The buffer's name.
        buffer: &'static str,
        /// The length the frame needs (pixels times the buffer's channels).
        expected: usize,
        /// The buffer's length.
        found: usize,
        /// The frame's width in pixels.
        width: usize,
        /// The frame's height in pixels.
        height: usize,
    },
    /// `width × height` (times the channels of a buffer) does not fit in `usize`.
    FrameTooLarge {
        /// The frame's width in pixels.
        width: usize,
        /// The frame's height in pixels.
        height: usize,
    },
    /// A pixel outside the frame was asked for.
    PixelOutside {
        /// The pixel's column.
        x: usize,
        /// The pixel's row.
        y: usize,
        /// The frame's width in pixels.
        width: usize,
        /// The frame's height in pixels.
        height: usize,
    },
    /// A camera parameter or depth convention parameter is unusable.
    InvalidParameter {
        /// The parameter's name (`"fov_y"`, `"depth.near"`, ...).
        field: &'static str,
        /// Why it cannot be used.
        reason: String,
    },
}

impl fmt::Display for PassError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PassError::BufferLength {
                buffer,
                expected,
                found,
                width,
                height,
            } => write!(
                f,
                "{buffer}: has {found} elements, a {width}x{height} frame needs {expected}"
            ),
            PassError::FrameTooLarge { width, height } => {
                write!(
                    f,
                    "frame {width}x{height}: too large for this platform's usize"
                )
            }
            PassError::PixelOutside {
                x,
                y,
                width,
                height,
            } => write!(f, "pixel ({x}, {y}): outside the {width}x{height} frame"),
            PassError::InvalidParameter { field, reason } => write!(f, "{field}: {reason}"),
        }
    }
}

impl std::error::Error for PassError {}
