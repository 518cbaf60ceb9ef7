//! A V4L2 webcam as the rig's camera (the `v4l` feature).

use std::path::Path;
use std::time::Duration;

use aibr_camera::{Angle, Camera, UndistortMap};
use aibr_v4l::SettlePolicy;
use aibr_v4l::device::{Webcam, WebcamOptions};
use image::RgbImage;

use crate::error::{Error, Result};
use crate::rig::{Frame, FrameSource};

/// A webcam looking at the turntable. Frames exposed before the turntable reported that it
/// stopped are discarded (by buffer timestamp), `policy.frames` fresh frames are averaged,
/// and the result is undistorted with the calibration's lens model, so that the views match
/// the distortion-free camera the session records.
#[derive(Debug)]
pub struct V4lCamera {
    webcam: Webcam,
    policy: SettlePolicy,
    motion_end: Duration,
    undistort: Option<UndistortMap>,
    out: RgbImage,
}

impl V4lCamera {
    /// Opens the webcam at `path` at the size of `camera` (the calibrated camera, with its
    /// distortion), with the colour controls set by `options`.
    pub fn open(
        path: &Path,
        camera: &Camera,
        options: WebcamOptions,
        policy: SettlePolicy,
    ) -> Result<Self> {
        let options = WebcamOptions {
            size: Some((camera.size.width, camera.size.height)),
            ..options
        };
        let webcam = Webcam::open(path, &options)?;
        let distorted = camera.distortion.to_array().iter().any(|&d| d != 0.0);
        Ok(V4lCamera {
            webcam,
            policy,
            motion_end: aibr_v4l::monotonic_now(),
            undistort: distorted.then(|| UndistortMap::new(camera)),
            out: RgbImage::new(camera.size.width, camera.size.height),
        })
    }

    /// The webcam.
    pub fn webcam(&self) -> &Webcam {
        &self.webcam
    }
}

impl FrameSource for V4lCamera {
    fn capture(&mut self) -> Result<Frame> {
        let shot = self.webcam.capture(self.motion_end, &self.policy)?;
        let image = match &self.undistort {
            Some(map) => {
                map.apply_into(&shot.image, &mut self.out)
                    .map_err(Error::Camera)?;
                self.out.clone()
            }
            None => shot.image,
        };
        Ok(Frame { image, mask: None })
    }

    fn turntable_at(&mut self, _pan: Angle) {
        // The turntable has just reported that it stopped: only later frames are fresh.
        self.motion_end = aibr_v4l::monotonic_now();
    }

    fn settings(&self) -> Option<serde_json::Value> {
        let (format, width, height) = self.webcam.format();
        serde_json::to_value(serde_json::json!({
            "camera": "v4l",
            "format": format.to_string(),
            "width": width,
            "height": height,
            "controls": self.webcam.controls(),
            "averaged_frames": self.policy.frames,
            "settle_ms": self.policy.settle.as_millis() as u64,
        }))
        .ok()
    }
}
