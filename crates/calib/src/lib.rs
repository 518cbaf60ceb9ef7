//! Camera and turntable calibration from checkerboards, without clicks.
//!
//! - [`detect_board`]: the inner corners of a checkerboard given only their counts (9x6, ...):
//!   saddle points verified by a ring test, a grid grown over them following perspective,
//!   the board's window chosen by its alternating outer squares, and sub-pixel refinement as
//!   OpenCV's `cornerSubPix` ([`SubPixParams`]). Images where the whole board is not found are
//!   rejected with the reason ([`Rejection`]).
//! - [`calibrate_intrinsics`]: Zhang's closed form, then Levenberg-Marquardt over fx, fy, cx,
//!   cy (optional skew), k1 k2 p1 p2 k3 (any of them held) and every board pose; RMS and
//!   per-view errors, standard deviations of every parameter, outlier views flagged; too
//!   few views, mixed image sizes and parallel boards refused with clear errors.
//! - [`calibrate_turntable`]: the board's pose at each pan position ([`estimate_board_pose`]),
//!   the circular motion fitted to them with its residuals, the aibr-camera
//!   [`aibr_camera::PoseTable`], and each position predicted from the others.
//! - [`CameraFile`]: OpenCV FileStorage YAML and JSON: parsed, formatted, and read from a
//!   file (writing, atomically, is left to the caller's I/O edge).
//!
//! On OpenCV's 13-image sample set the corners land within 0.007 px of OpenCV's, and the
//! calibration matches `calibrateCamera` (fx 532.82 vs 532.83 px, RMS 0.1954 px both, the
//! standard deviations to three digits); see `docs/calibration.md`.
//!
//! ```
//! use aibr_calib::{BoardSpec, DetectorParams, detect_board, estimate_board_pose};
//! use aibr_camera::{Angle, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange};
//! use aibr_scene::{RenderOptions, SceneRig, catalogue};
//!
//! // A 9x6 board (10x7 squares of 25 mm) on a turntable, seen by a webcam 0.42 m away.
//! let rig = SceneRig {
//!     intrinsics: Intrinsics::new(820.0, 820.0, 319.5, 239.5),
//!     distortion: Distortion { k1: -0.2, k2: 0.05, p1: 0.0, p2: 0.0, k3: 0.0 },
//!     size: ImageSize::new(640, 480),
//!     ring: CircularMotion::ring(0.42, 0.40, 0.0)?,
//!     pan_range: PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?,
//! };
//! let scene = catalogue::checkerboard(10, 7, 0.025, rig.clone())?;
//! let camera = scene.camera(Angle::from_degrees(30.0))?;
//! let frame = scene.render(&camera, &RenderOptions::default())?;
//! let grey = image::DynamicImage::ImageRgb8(frame.rgb8()).to_luma8();
//!
//! let board = BoardSpec::new(9, 6, 0.025)?;
//! let found = detect_board(&grey, &board, &DetectorParams::default())?;
//! assert_eq!(found.corners.len(), 54);
//! // With the lens known, the board's pose, and how well it explains the corners.
//! let (cam_from_board, rms) = estimate_board_pose(&board, &rig.intrinsics, &rig.distortion, &found)?;
//! assert!(rms < 0.2, "{rms} px");
//! // The camera is 0.58 m from the board's first corner.
//! let distance = cam_from_board.translation.vector.norm();
//! assert!((distance - 0.58).abs() < 0.02, "{distance} m");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! - **Pixels**: `(0, 0)` is the centre of the top-left pixel, as in OpenCV and aibr-camera.
//! - **Board frame**: origin at inner corner 0, x along a row of corners, y down the columns,
//!   z into the board, metres; corners listed row by row. Corner 0 is the corner of a dark
//!   corner square when `cols + rows` is odd (see [`BoardSpec`]).
//! - **Poses**: `cam_from_board` maps board points into the OpenCV optical camera frame (x
//!   right, y down, z forward). Turntable results are in the turntable frame of
//!   aibr-camera (Z the pan axis, pointing up; origin on the axis).
//! - **Units**: metres for the board and poses, pixels for intrinsics and errors; angles as
//!   [`aibr_camera::Angle`].
//! - **Distortion**: Brown-Conrady, k1 k2 p1 p2 k3 in OpenCV's order and meaning.

pub mod board;
mod bundle;
pub mod detect;
pub mod error;
mod geometry;
pub mod intrinsic;
pub mod io;
mod plane;
pub mod subpix;
pub mod turntable;

pub use board::{BoardSpec, PatternSize};
pub use detect::{BoardDetection, DetectorParams, detect_board};
pub use error::{Error, Rejection, Result};
pub use intrinsic::{
    IntrinsicCalibration, IntrinsicOptions, ParameterStd, ViewResult, calibrate_intrinsics,
};
pub use io::{CameraFile, CameraJson, Format};
pub use subpix::SubPixParams;
pub use turntable::{
    LeftOut, PanPose, PanView, TurntableCalibration, calibrate_turntable, estimate_board_pose,
};
