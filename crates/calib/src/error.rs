//! Errors of aibr-calib.

use std::path::PathBuf;

/// Why a checkerboard was not found in an image.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rejection {
    /// No point in the image looks like the crossing of four squares.
    #[error("no checkerboard corners in the image")]
    NoCorners,
    /// Corners were found, but no grid of the board's size could be formed from them.
    #[error(
        "no {expected_cols}x{expected_rows} grid of corners: the largest grid found has {found} of {expected} corners ({grid_cols}x{grid_rows}); is the whole board in view?"
    )]
    IncompleteGrid {
        /// Inner corners per row of the board.
        expected_cols: usize,
        /// Inner corner rows of the board.
        expected_rows: usize,
        /// `expected_cols * expected_rows`.
        expected: usize,
        /// Corners in the largest grid found.
        found: usize,
        /// Columns spanned by that grid.
        grid_cols: usize,
        /// Rows spanned by that grid.
        grid_rows: usize,
    },
    /// The image is too small to hold a board.
    #[error("the image is {width}x{height} pixels, too small for a board")]
    TooSmall {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
}

/// Errors of aibr-calib.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A parameter is out of range.
    #[error("invalid {name}: {value} ({reason})")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value, as text.
        value: String,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// Fewer usable views than the calibration needs.
    #[error("too few views: {found} usable, {needed} needed")]
    TooFewViews {
        /// Usable views.
        found: usize,
        /// Views needed.
        needed: usize,
    },
    /// The images of one set are not all the same size.
    #[error(
        "view {index} is {width}x{height} pixels but the first view is {first_width}x{first_height}: one calibration needs one image size"
    )]
    SizeMismatch {
        /// Index of the offending view (0-based, input order).
        index: usize,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The first view's width.
        first_width: u32,
        /// The first view's height.
        first_height: u32,
    },
    /// The views do not determine the parameters (for example, all boards parallel).
    #[error("degenerate views: {0}")]
    Degenerate(String),
    /// The optimisation did not reach a usable solution.
    #[error("calibration did not converge: {0}")]
    NoConvergence(String),
    /// A file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A calibration file is malformed.
    #[error("{source_name}:{line}: {message}")]
    Parse {
        /// The file (or a description of the text).
        source_name: String,
        /// 1-based line (0 when the error is not tied to a line).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A camera model rejected a value.
    #[error(transparent)]
    Camera(#[from] aibr_camera::Error),
}

/// Result with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
