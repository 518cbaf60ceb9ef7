//! The one error type of aibr-camera.

use std::path::PathBuf;

/// What went wrong while reading one line of a camera file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ParseErrorKind {
    /// The line holds the wrong number of whitespace-separated fields.
    #[error("expected {expected} fields, found {found}")]
    FieldCount {
        /// How many fields the format asks for.
        expected: usize,
        /// How many the line has.
        found: usize,
    },
    /// A field is not a number.
    #[error("field {index} ({text:?}) is not a number")]
    NotANumber {
        /// 1-based index of the field on its line.
        index: usize,
        /// The offending text.
        text: String,
    },
    /// A number is NaN or infinite.
    #[error("field {index} is not finite ({value})")]
    NotFinite {
        /// 1-based index of the field on its line.
        index: usize,
        /// The value read.
        value: f64,
    },
    /// The 3x3 block that should be a rotation is not one.
    #[error(
        "R is not a rotation (|R^T R - I| = {orthogonality_error:.3e}, det R = {determinant:.6})"
    )]
    NotARotation {
        /// Largest absolute entry of `R^T R - I`.
        orthogonality_error: f64,
        /// Determinant of R.
        determinant: f64,
    },
    /// The intrinsic matrix is not upper triangular with positive focal lengths.
    #[error("invalid intrinsic matrix: {reason}")]
    BadIntrinsics {
        /// Why it was rejected.
        reason: String,
    },
    /// The count on the first line disagrees with the number of records.
    #[error("the first line declares {declared} records but the file has {found}")]
    CountMismatch {
        /// The count the file declares.
        declared: usize,
        /// The records actually found.
        found: usize,
    },
    /// The count line is not a non-negative integer.
    #[error("the first line must be the record count, found {text:?}")]
    BadCount {
        /// The offending text.
        text: String,
    },
    /// The file ends in the middle of a record.
    #[error("the file ends inside a matrix ({rows} of 3 rows read)")]
    Truncated {
        /// Rows read of the unfinished matrix.
        rows: usize,
    },
    /// The file holds no records at all.
    #[error("no records")]
    Empty,
}

/// Errors of aibr-camera.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A camera file could not be read from disk.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// A line of a camera file is malformed.
    #[error("{source_name}:{line}: {kind}")]
    Parse {
        /// The file (or the label given to the parser).
        source_name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        kind: ParseErrorKind,
    },
    /// A parameter is out of its domain (a focal length that is not positive, a NaN, ...).
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The input does not determine the answer (too few or coincident cameras, a singular matrix).
    #[error("degenerate input: {0}")]
    Degenerate(String),
    /// A pan angle lies outside the turntable's range.
    #[error("pan angle {angle_deg:.3} deg is outside the range [{min_deg:.3}, {max_deg:.3}] deg")]
    AngleOutOfRange {
        /// The requested angle, degrees.
        angle_deg: f64,
        /// Lower limit, degrees.
        min_deg: f64,
        /// Upper limit, degrees.
        max_deg: f64,
    },
    /// An image does not have the size the camera was built for.
    #[error("image is {actual_width}x{actual_height}, expected {expected_width}x{expected_height}")]
    ImageSize {
        /// Width the camera expects.
        expected_width: u32,
        /// Height the camera expects.
        expected_height: u32,
        /// Width of the image given.
        actual_width: u32,
        /// Height of the image given.
        actual_height: u32,
    },
}

/// Result alias of aibr-camera.
pub type Result<T, E = Error> = std::result::Result<T, E>;
