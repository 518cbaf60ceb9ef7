//! The one error type of aibr-consistency.

/// Errors of aibr-consistency.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A view has no foreground mask (the estimator needs one: give masks, or estimate them
    /// with [`crate::foreground`]).
    #[error("view {view} has no foreground mask")]
    NoMask {
        /// Index of the view.
        view: usize,
    },
    /// Images that must match in size do not.
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
    /// The pan angles and the views disagree in number.
    #[error("{pans} pan angles for {views} views")]
    CountMismatch {
        /// Pan angles given.
        pans: usize,
        /// Views given.
        views: usize,
    },
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
    /// Fewer images than needed.
    #[error("{found} images given, at least {needed} needed")]
    TooFewImages {
        /// Images given.
        found: usize,
        /// Images needed.
        needed: usize,
    },
}

/// Result alias of aibr-consistency.
pub type Result<T, E = Error> = std::result::Result<T, E>;
