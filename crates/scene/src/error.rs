//! The one error type of aibr-scene.

/// Errors of aibr-scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// No catalogue scene has this name.
    #[error("unknown scene {name:?}; the catalogue has: {known}")]
    UnknownScene {
        /// The name asked for.
        name: String,
        /// The names that exist, comma-separated.
        known: String,
    },
    /// A scene or render parameter is out of its domain.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// A scene has no objects.
    #[error("scene {0:?} has no objects")]
    EmptyScene(String),
    /// An error of the camera model.
    #[error(transparent)]
    Camera(#[from] aibr_camera::Error),
}

/// Result alias of aibr-scene.
pub type Result<T, E = Error> = std::result::Result<T, E>;
