//! Turntable (pan) calibration: the camera pose at each pan position from a board lying on
//! the turntable, the circular motion fitted to them, and a pose table interpolating them.

use aibr_camera::{
    Angle, CalibratedPose, CircularFit, Distortion, Intrinsics, PanRange, PoseTable,
};
use nalgebra::{Isometry3, Point2};

use crate::board::BoardSpec;
use crate::bundle::{Bundle, CAMERA_PARAMS, camera_params};
use crate::detect::BoardDetection;
use crate::error::{Error, Result};
use crate::geometry::{homography, pose_from_homography};

/// The board seen at one pan position.
#[derive(Debug, Clone, PartialEq)]
pub struct PanView {
    /// The pan angle the turntable reported.
    pub pan: Angle,
    /// The board's corners there.
    pub detection: BoardDetection,
}

/// The board pose at one pan position.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanPose {
    /// The pan angle.
    pub pan: Angle,
    /// The camera pose in the board frame.
    pub cam_from_board: Isometry3<f64>,
    /// RMS reprojection error of the board's corners with this pose, pixels.
    pub rms: f64,
}

/// How well the table predicts a position it was not given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeftOut {
    /// The pan angle left out.
    pub pan: Angle,
    /// Rotation between the predicted and the calibrated camera orientation.
    pub rotation: Angle,
    /// Distance between the predicted and the calibrated camera centre, metres.
    pub centre_m: f64,
    /// RMS distance between the board corners projected with the predicted pose and those
    /// detected, pixels.
    pub reprojection_px: f64,
}

/// The result of [`calibrate_turntable`].
#[derive(Debug, Clone, PartialEq)]
pub struct TurntableCalibration {
    /// The calibrated pose at every position, in input order (board frame).
    pub poses: Vec<PanPose>,
    /// The circular motion fitted to the poses, in the turntable frame (Z the pan axis
    /// through the origin, the board's plane at its height), with the per-position residuals.
    pub fit: CircularFit,
    /// The pose table in the turntable frame.
    pub table: PoseTable,
    /// The rigid transform from the board frame into the turntable frame.
    pub turntable_from_board: Isometry3<f64>,
    /// Each position predicted by the table of all the others (needs 4 positions or more).
    pub left_out: Vec<LeftOut>,
}

/// The pose of the board in one view with known intrinsics and distortion: a homography
/// on the undistorted corners, refined by Levenberg-Marquardt on the reprojection error.
/// Returns the pose and its RMS error, pixels.
pub fn estimate_board_pose(
    board: &BoardSpec,
    intrinsics: &Intrinsics,
    distortion: &Distortion,
    detection: &BoardDetection,
) -> Result<(Isometry3<f64>, f64)> {
    board.check_complete(detection.corners.len(), || "the detection".into())?;
    let normalized: Vec<Point2<f64>> = detection
        .corners
        .iter()
        .map(|&c| distortion.undistort(intrinsics.normalized_from_pixel(c)))
        .collect::<Option<_>>()
        .ok_or_else(|| {
            Error::Degenerate("a corner lies outside the lens model's valid range".into())
        })?;
    let plane: Vec<Point2<f64>> = board
        .object_points()
        .iter()
        .map(|p| Point2::new(p.x, p.y))
        .collect();
    let start = homography(&plane, &normalized)
        .and_then(|h| pose_from_homography(&h))
        .ok_or_else(|| Error::Degenerate("the corners do not determine the board's pose".into()))?;
    let object = board.object_points();
    let problem = Bundle {
        object: &object,
        views: vec![detection.corners.as_slice()],
        free: [false; CAMERA_PARAMS],
        aspect: None,
    };
    let s = problem.solve(camera_params(intrinsics, distortion), &[start], 50);
    let pose = s.poses.first().copied().unwrap_or(start);
    let rms =
        (s.view_sse.first().copied().unwrap_or(f64::INFINITY) / board.corner_count() as f64).sqrt();
    Ok((pose, rms))
}

/// Calibrates the camera's motion about the pan axis from a board lying (or standing) on
/// the turntable, seen at 3 or more pan positions within `range`.
///
/// The board must have `cols + rows` odd so that its corner 0 is the same physical corner
/// in every view (see [`BoardSpec`]).
pub fn calibrate_turntable(
    board: &BoardSpec,
    intrinsics: &Intrinsics,
    distortion: &Distortion,
    views: &[PanView],
    range: PanRange,
) -> Result<TurntableCalibration> {
    if !board.is_unambiguous() {
        return Err(Error::InvalidParameter {
            name: "board",
            value: format!("{}x{}", board.cols, board.rows),
            reason: "looks the same after a half turn, so its poses cannot be compared between pan positions; use one odd and one even corner count, like 9x6",
        });
    }
    if views.len() < 3 {
        return Err(Error::TooFewViews {
            found: views.len(),
            needed: 3,
        });
    }
    let poses = views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (cam_from_board, rms) =
                estimate_board_pose(board, intrinsics, distortion, &v.detection)
                    .map_err(|e| Error::Degenerate(format!("position {i} (pan {}): {e}", v.pan)))?;
            Ok(PanPose {
                pan: v.pan,
                cam_from_board,
                rms,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let in_board: Vec<CalibratedPose> = poses
        .iter()
        .map(|p| CalibratedPose {
            pan: p.pan,
            cam_from_world: p.cam_from_board,
        })
        .collect();
    let board_fit = aibr_camera::CircularMotion::fit(&in_board)?;
    let turntable_from_board = board_fit.model.turntable_from_world();
    let board_from_turntable = turntable_from_board.inverse();
    let entries: Vec<CalibratedPose> = in_board
        .iter()
        .map(|p| CalibratedPose {
            pan: p.pan,
            cam_from_world: p.cam_from_world * board_from_turntable,
        })
        .collect();
    let table = PoseTable::new(entries, range)?;
    let fit = CircularFit {
        model: board_fit.model.in_turntable_frame(),
        residuals: board_fit.residuals.clone(),
    };
    let left_out = leave_one_out(board, intrinsics, distortion, views, &in_board, range);
    Ok(TurntableCalibration {
        poses,
        fit,
        table,
        turntable_from_board,
        left_out,
    })
}

/// Predicts each position from a table of the others.
fn leave_one_out(
    board: &BoardSpec,
    intrinsics: &Intrinsics,
    distortion: &Distortion,
    views: &[PanView],
    poses: &[CalibratedPose],
    range: PanRange,
) -> Vec<LeftOut> {
    if poses.len() < 4 {
        return Vec::new();
    }
    let object = board.object_points();
    let camera = aibr_camera::Camera::new(
        *intrinsics,
        *distortion,
        Isometry3::identity(),
        views[0].detection.image_size,
    );
    let Ok(camera) = camera else {
        return Vec::new();
    };
    (0..poses.len())
        .filter_map(|i| {
            let others: Vec<CalibratedPose> = poses
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, p)| *p)
                .collect();
            let table = PoseTable::new(others, range).ok()?;
            let predicted = table.cam_from_world(poses[i].pan).ok()?;
            let truth = poses[i].cam_from_world;
            let rotation = (predicted.rotation.inverse() * truth.rotation).angle();
            let centre =
                |p: &Isometry3<f64>| p.inverse_transform_point(&nalgebra::Point3::origin());
            let cam = camera.with_pose(predicted);
            let (sum, n) = object.iter().zip(&views[i].detection.corners).fold(
                (0.0, 0usize),
                |(s, n), (x, c)| match cam.project(x) {
                    Some(p) => (s + (p - c).norm_squared(), n + 1),
                    None => (s, n),
                },
            );
            Some(LeftOut {
                pan: poses[i].pan,
                rotation: Angle::from_radians(rotation),
                centre_m: (centre(&predicted) - centre(&truth)).norm(),
                reprojection_px: if n == object.len() {
                    (sum / n as f64).sqrt()
                } else {
                    f64::INFINITY
                },
            })
        })
        .collect()
}
