//! The one error type of aibr-render.

/// Errors of aibr-render.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Two images that must match in size do not.
    #[error("{what}: {width}x{height} does not match {expected_width}x{expected_height}")]
    SizeMismatch {
        /// What was compared.
        what: &'static str,
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Width expected.
        expected_width: u32,
        /// Height expected.
        expected_height: u32,
    },
    /// A model given beside the renderer's is not on its grid.
    #[error("{what}: not on the grid of the model rendered")]
    GridMismatch {
        /// What was given.
        what: &'static str,
    },
    /// A renderer needs at least one source view.
    #[error("no source views")]
    NoSources,
    /// A parameter is out of its domain.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A source camera has lens distortion (undistort its image first).
    #[error("source view {view}: the camera has lens distortion; undistort the image first")]
    Distorted {
        /// Index of the source.
        view: usize,
    },
    /// A metric was asked over an empty mask.
    #[error("the mask selects no pixel")]
    EmptyMask,
    /// Writing an EXR file failed.
    #[error("writing EXR: {0}")]
    Exr(String),
}

/// Result alias of aibr-render.
pub type Result<T, E = Error> = std::result::Result<T, E>;
