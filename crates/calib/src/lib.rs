//! Camera and turntable calibration from checkerboards.

pub mod board;
pub mod detect;
pub mod error;
mod plane;
pub mod subpix;

pub use board::{BoardSpec, PatternSize};
pub use detect::{BoardDetection, DetectorParams, FileDetection, detect_board, detect_in_files};
pub use error::{Error, Rejection, Result};
pub use subpix::SubPixParams;
mod bundle;
mod geometry;
pub mod intrinsic;
pub use intrinsic::{
    IntrinsicCalibration, IntrinsicOptions, ParameterStd, ViewResult, calibrate_intrinsics,
};
pub mod turntable;
pub use turntable::{
    LeftOut, PanPose, PanView, TurntableCalibration, calibrate_turntable, estimate_board_pose,
};
pub mod io;
pub use io::{CameraFile, CameraJson, Format};
