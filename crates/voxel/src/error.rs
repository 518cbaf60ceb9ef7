//! The one error type of aibr-voxel.

/// Errors of aibr-voxel.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A grid or kernel parameter is out of its domain.
    #[error("invalid {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is rejected.
        reason: &'static str,
    },
    /// The grid would not fit in memory.
    #[error(
        "a {nx}x{ny}x{nz} grid needs {bytes} bytes, over the limit of {limit} bytes; use a coarser voxel size"
    )]
    GridTooLarge {
        /// Voxels along x.
        nx: usize,
        /// Voxels along y.
        ny: usize,
        /// Voxels along z.
        nz: usize,
        /// Bytes the grid needs.
        bytes: u128,
        /// The limit.
        limit: u128,
    },
    /// Voxel coloring needs every camera above the volume (the ordinal visibility condition).
    #[error(
        "view {view}: camera centre at z = {camera_z:.4} m is not above the top of the volume \
         (z = {volume_top:.4} m); voxel coloring needs every camera above the volume: use space \
         carving for this rig"
    )]
    CameraNotAbove {
        /// Index of the view.
        view: usize,
        /// Height of its camera centre.
        camera_z: f64,
        /// Top of the volume.
        volume_top: f64,
    },
    /// An image or mask does not match its camera.
    #[error(
        "view {view}: {what} is {width}x{height}, but the camera is {expected_width}x{expected_height}"
    )]
    ViewSize {
        /// Index of the view.
        view: usize,
        /// "image" or "mask".
        what: &'static str,
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Width of the camera.
        expected_width: u32,
        /// Height of the camera.
        expected_height: u32,
    },
    /// The kernels take pinhole images: undistort first.
    #[error(
        "view {view}: the camera has lens distortion; undistort the image first (aibr_camera::UndistortMap) and pass the pinhole camera"
    )]
    Distorted {
        /// Index of the view.
        view: usize,
    },
    /// Fewer views than the kernel needs.
    #[error("{found} views given, at least {needed} needed")]
    TooFewViews {
        /// Views given.
        found: usize,
        /// Views needed.
        needed: usize,
    },
    /// Writing a file failed.
    #[error("writing {what}: {source}")]
    Io {
        /// What was being written.
        what: &'static str,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// An error of the camera model.
    #[error(transparent)]
    Camera(#[from] aibr_camera::Error),
}

/// Result alias of aibr-voxel.
pub type Result<T, E = Error> = std::result::Result<T, E>;
