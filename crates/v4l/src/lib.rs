//! # aibr-v4l
//!
//! Webcam capture for a turntable rig. The paper's rig used a cheap webcam: noisy,
//! distorted, and with automatic exposure, white balance and gain that would ruin the colour
//! consistency between views. This crate:
//!
//! - converts the formats webcams deliver to RGB ([`to_rgb`]: YUYV, NV12, MJPEG, RGB3,
//!   GREY; YUYV and NV12 agree with OpenCV byte for byte) and chooses among a device's offers
//!   ([`format::choose`]: uncompressed YUYV first, then MJPEG, then RGB3 or GREY);
//! - after the turntable stops, discards the frames already queued, which show the old
//!   position, by their buffer timestamps, and averages K fresh frames
//!   ([`capture_settled`], [`FrameAverager`]);
//! - with the `v4l` feature (Linux; needs libclang at build time: `apt-get install
//!   libclang-dev`), lists and opens V4L2 devices, streams with memory-mapped buffers, and
//!   locks exposure, white balance and gain (`device` module).
//!
//! Everything but the device module builds and is tested without the feature or a camera.
//!
//! ```
//! use std::time::Duration;
//! use aibr_v4l::{FrameStream, PixelFormat, RawFrame, SettlePolicy, StreamFrame,
//!                TimestampSource, capture_settled};
//!
//! /// A stream whose first frames were exposed while the turntable still turned.
//! struct Frames { t: Duration, data: Vec<u8> }
//! impl FrameStream for Frames {
//!     fn next_frame(&mut self, _timeout: Duration) -> aibr_v4l::Result<Option<StreamFrame<'_>>> {
//!         self.t += Duration::from_millis(33);
//!         let raw = RawFrame { format: PixelFormat::Grey, width: 2, height: 1, stride: 0, data: &self.data };
//!         Ok(Some(StreamFrame { raw, timestamp: self.t, source: TimestampSource::StartOfExposure, sequence: 0 }))
//!     }
//! }
//! let mut stream = Frames { t: Duration::from_secs(10), data: vec![7, 9] };
//! let motion_end = Duration::from_millis(10_100);
//! let policy = SettlePolicy { frames: 4, ..SettlePolicy::default() };
//! let shot = capture_settled(&mut stream, motion_end, &policy)?;
//! assert_eq!((shot.averaged, shot.stale), (4, 6)); // frames before 10.2 s are dropped
//! assert_eq!(shot.image.as_raw(), &[7, 7, 7, 9, 9, 9]);
//! # Ok::<(), aibr_v4l::Error>(())
//! ```
//!
//! # Conventions
//! Timestamps are `Duration`s on the monotonic clock (`CLOCK_MONOTONIC`, see
//! [`monotonic_now`]), as V4L2 reports them. Images are 8-bit RGB `image::RgbImage`s.

pub mod average;
pub mod convert;
#[cfg(all(feature = "v4l", target_os = "linux"))]
pub mod device;
mod error;
pub mod format;
mod mjpeg;
pub mod settle;

pub use average::FrameAverager;
pub use convert::{RawFrame, to_rgb};
pub use error::{Error, Result};
pub use format::{Offer, PixelFormat};
pub use settle::{
    FrameStream, SettlePolicy, Settled, StreamFrame, TimestampSource, capture_settled,
    monotonic_now,
};
