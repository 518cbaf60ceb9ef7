//! Active image-based rendering on a turntable: the facade.
//!
//! A camera looks at an object on a turntable that only pans. aibr captures a few uniform
//! views, reconstructs the object by voxel coloring, estimates from colour consistency where
//! the rendering is worst, turns the object there, captures one more view, and repeats until a
//! budget; novel views are rendered by depth-driven interpolation of the captured rays.
//!
//! This crate composes the others (re-exported below): the rig traits ([`Turntable`],
//! [`FrameSource`]) with a [`Calibration`] mapping the reached angle to a camera; the rigs:
//! the synthetic [`SimRig`], a real ring data set replayed ([`ReplayRig`]), and
//! [`Rig`]`{ turntable, camera }` joining a [`PtuTurntable`] (the PTU-46 driver, [`ptu`]) to
//! a [`SceneCamera`] or, with the `v4l` feature, a webcam (`V4lCamera`); the loop
//! [`capture()`](fn@capture); [`Session`]s on disk; and the comparison of strategies against
//! the truth ([`evaluate`], [`evaluate_rig`]).
//!
//! A short active capture of the synthetic mirror (12 uniform views, then two where the
//! estimate says a rendering would be worst), at a coarse grid so that it runs in seconds:
//!
//! ```
//! use aibr::{CaptureParams, SimRig, capture, new_session};
//!
//! let dir = std::env::temp_dir().join(format!("aibr-doc-{}", std::process::id()));
//! # let _ = std::fs::remove_dir_all(&dir); // left by a failed run of a process with this id
//! let mut rig = SimRig::new("mirror")?;
//! let calibration = rig.calibration()?;
//! let params = CaptureParams { initial: 12, max: 14, grid: 48, ..CaptureParams::default() };
//! let mut session = new_session(&dir, "sim:mirror", &rig, &calibration, &params)?;
//! let report = capture(&mut rig, &mut session, &params, &mut |p| eprintln!("{p:?}"))?;
//! // The session on disk holds every view captured, in the order taken.
//! assert_eq!(report.pans.len(), 14);
//! assert_eq!(session.file().views.len(), 14);
//! println!("pan angles: {:?}", report.pans);
//! std::fs::remove_dir_all(&dir)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! The world frame is the turntable frame (Z up the pan axis); pan angles are
//! `aibr_camera::Angle` in the turntable's absolute range; turntable steps appear only in the
//! rig adapters and the session records.

pub mod capture;
pub mod error;
pub mod eval;
mod ptu_rig;
pub mod replay;
pub mod rig;
pub mod session;
#[cfg(all(feature = "v4l", target_os = "linux"))]
mod webcam;

pub use aibr_calib as calib;
pub use aibr_camera as camera;
pub use aibr_consistency as consistency;
pub use aibr_ptu as ptu;
pub use aibr_render as render;
pub use aibr_scene as scene;
pub use aibr_v4l as v4l;
pub use aibr_voxel as voxel;

pub use capture::{
    CaptureParams, CaptureReport, FacesFirst, Progress, StageTimings, Strategy, capture,
    estimate_volume, pair_scores, reconstruct, reconstruct_loaded, reconstruct_refined,
    reconstruct_views, render_loaded, render_session, renderer_for, renderer_with, uniform_pans,
    why_not_voxel_coloring,
};
pub use error::{Error, Result};
pub use eval::{
    ArcSplit, Checkpoint, EvalModel, EvalParams, EvalRig, NovelView, ObjectArc, StrategyEval,
    ViewFigures, evaluate, evaluate_rig,
};
pub use ptu_rig::PtuTurntable;
pub use replay::ReplayRig;
pub use rig::{Calibration, Frame, FrameSource, Rig, SceneCamera, SimRig, Turntable, ptu46_step};
pub use session::{FORMAT_VERSION, LoadedView, Session, SessionFile, write_atomic};
#[cfg(all(feature = "v4l", target_os = "linux"))]
pub use webcam::V4lCamera;

use session::{CalibrationRecord, ParametersRecord, TurntableRecord};

/// Where the reconstruction volume comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum VolumeSource {
    /// The synthetic scene's ground-truth box.
    Scene,
    /// A box the user gives (turntable frame, metres).
    Given(camera::Aabb),
    /// Estimated from the foreground of the initial views (see [`estimate_volume`]).
    Estimated,
}

/// Creates a new session in `dir` for a capture on `rig` described as `spec` (e.g.
/// `sim:mirror`), recording the calibration, turntable, volume and parameters.
pub fn new_session<R: Turntable + FrameSource>(
    dir: &std::path::Path,
    spec: &str,
    rig: &R,
    calibration: &Calibration,
    params: &CaptureParams,
) -> Result<Session> {
    new_session_with_volume(dir, spec, rig, calibration, params, VolumeSource::Scene)
}

/// Like [`new_session`], with the volume from `volume` ([`VolumeSource::Scene`] needs a rig
/// whose camera is synthetic).
pub fn new_session_with_volume<R: Turntable + FrameSource>(
    dir: &std::path::Path,
    spec: &str,
    rig: &R,
    calibration: &Calibration,
    params: &CaptureParams,
    volume: VolumeSource,
) -> Result<Session> {
    params.validate()?;
    let volume = match volume {
        VolumeSource::Scene => rig.known_volume().ok_or_else(|| Error::InvalidParameter {
            name: "volume",
            reason: "this rig's camera is not synthetic, so there is no true volume: \
                     estimate it (auto) or give a box"
                .into(),
        })?,
        VolumeSource::Given(b) => b,
        // All zeros: estimated after the initial views.
        VolumeSource::Estimated => camera::Aabb {
            min: nalgebra::Point3::origin(),
            max: nalgebra::Point3::origin(),
        },
    };
    let range = rig.range();
    Session::create(
        dir,
        SessionFile {
            format_version: FORMAT_VERSION,
            rig: spec.to_owned(),
            calibration: CalibrationRecord::of(calibration),
            turntable: TurntableRecord {
                min_rad: range.min().radians(),
                max_rad: range.max().radians(),
                step_rad: rig.step().radians(),
            },
            volume: [volume.min.coords.into(), volume.max.coords.into()],
            parameters: ParametersRecord::of(params),
            views: Vec::new(),
            camera_settings: rig.settings(),
        },
    )
}
