//! The one error type of the facade.

use std::path::PathBuf;

/// Errors of aibr.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{action} {path}: {source}")]
    Io {
        /// What was being done ("reading", "writing", ...).
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// A folder is not an aibr session.
    #[error("{path} is not an aibr session: {reason}")]
    NotASession {
        /// The folder.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// A folder or file is not a usable ring data set (for the replay rig).
    #[error("{path}: {reason}")]
    Dataset {
        /// The folder or file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A session file is malformed.
    #[error("{path}: {reason}")]
    BadSession {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A view file does not match its recorded checksum.
    #[error(
        "{path}: checksum mismatch (recorded {recorded:08x}, file {actual:08x}); the file is corrupt or was changed"
    )]
    Checksum {
        /// The view file.
        path: PathBuf,
        /// The checksum in session.json.
        recorded: u32,
        /// The checksum of the file.
        actual: u32,
    },
    /// A session was to be continued with other parameters than it was captured with.
    #[error(
        "{path} was captured with {field} {recorded}, not {given}: continue it with the same options, or use another folder"
    )]
    ParametersDiffer {
        /// The session folder.
        path: PathBuf,
        /// The field of `session.json` that differs (`rig`, `strategy`, `width_power`, ...).
        field: &'static str,
        /// Its value in the session.
        recorded: String,
        /// The value asked for.
        given: String,
    },
    /// A new session was asked for in a folder that holds other files, which its views, masks
    /// and outputs could overwrite.
    #[error(
        "{path} is not empty ({entry} is there) and holds no session: capture into a new or empty folder"
    )]
    FolderNotEmpty {
        /// The folder.
        path: PathBuf,
        /// One of its entries.
        entry: String,
    },
    /// A session exists where a new one was asked for.
    #[error("{0} already holds a session: pass --resume to continue it, or choose another folder")]
    SessionExists(PathBuf),
    /// A rig description could not be understood.
    #[error(
        "unknown rig {0:?}: expected sim:SCENE or sim:SCENE@DEGREES (scenes: mirror, mirror-broad, head, chair, lambertian; the scene turned by DEGREES), replay:DIR (a ring data set), or a turntable ptu:PATH"
    )]
    UnknownRig(String),
    /// A parameter is out of its domain.
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// An image is not the size the calibration says.
    #[error("{path}: image is {width}x{height}, the camera is {expected_width}x{expected_height}")]
    ImageSize {
        /// The image file.
        path: PathBuf,
        /// Its width.
        width: u32,
        /// Its height.
        height: u32,
        /// The camera's width.
        expected_width: u32,
        /// The camera's height.
        expected_height: u32,
    },
    /// An image file could not be decoded.
    #[error("{path}: {reason}")]
    Image {
        /// The file.
        path: PathBuf,
        /// The decoder's reason.
        reason: String,
    },
    /// The rig failed.
    #[error("rig: {0}")]
    Rig(String),
    /// From aibr-camera.
    #[error(transparent)]
    Camera(#[from] aibr_camera::Error),
    /// From aibr-scene.
    #[error(transparent)]
    Scene(#[from] aibr_scene::Error),
    /// From aibr-voxel.
    #[error(transparent)]
    Voxel(#[from] aibr_voxel::Error),
    /// From aibr-consistency.
    #[error(transparent)]
    Consistency(#[from] aibr_consistency::Error),
    /// From aibr-render.
    #[error(transparent)]
    Render(#[from] aibr_render::Error),
    /// From the PTU-46 driver.
    #[error("PTU: {0}")]
    Ptu(#[from] aibr_ptu::Error),
    /// From the webcam.
    #[error("camera: {0}")]
    V4l(#[from] aibr_v4l::Error),
}

/// Result alias of aibr.
pub type Result<T, E = Error> = std::result::Result<T, E>;
