//! Waiting for fresh frames after the turntable stops.
//!
//! A webcam streams continuously into a queue of buffers, so the frames waiting when the
//! turntable stops were exposed while it was still turning. [`capture_settled`] discards
//! every frame whose exposure began before the motion ended (judged by the buffer's
//! timestamp, on the monotonic clock V4L2 uses), then averages the next K frames.

use std::time::{Duration, Instant};

use image::RgbImage;

use crate::average::FrameAverager;
use crate::convert::{RawFrame, to_rgb};
use crate::error::{Error, Result};

/// What a buffer timestamp marks (V4L2 `V4L2_BUF_FLAG_TSTAMP_SRC_SOE` or `_EOF`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimestampSource {
    /// The start of the exposure.
    StartOfExposure,
    /// The end of the frame (UVC webcams); the exposure began up to a frame interval
    /// earlier.
    EndOfFrame,
}

/// A frame from a stream, with its timestamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamFrame<'a> {
    /// The frame.
    pub raw: RawFrame<'a>,
    /// The buffer timestamp on the monotonic clock.
    pub timestamp: Duration,
    /// What the timestamp marks.
    pub source: TimestampSource,
    /// The driver's frame counter.
    pub sequence: u32,
}

/// A source of frames: a V4L2 stream, or frames made in a test.
pub trait FrameStream {
    /// The next frame, waiting at most `timeout`; `None` if none came in time.
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<StreamFrame<'_>>>;
}

/// How [`capture_settled`] flushes and averages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SettlePolicy {
    /// Extra time after the motion ended before a frame counts as fresh (the object may
    /// still sway; default 100 ms).
    pub settle: Duration,
    /// Fresh frames to average (default 1: no averaging).
    pub frames: u32,
    /// The longest the whole capture may take (default 3 s).
    pub timeout: Duration,
    /// The frame interval, used to date the start of exposure of end-of-frame timestamps
    /// (default 1/15 s: conservative for a 30 fps webcam that lowers its rate in dim light).
    pub frame_interval: Duration,
}

impl Default for SettlePolicy {
    fn default() -> Self {
        SettlePolicy {
            settle: Duration::from_millis(100),
            frames: 1,
            timeout: Duration::from_secs(3),
            frame_interval: Duration::from_micros(66_667),
        }
    }
}

impl SettlePolicy {
    /// Whether a frame with `timestamp` was exposed wholly after `motion_end` + settle.
    pub fn is_fresh(
        &self,
        timestamp: Duration,
        source: TimestampSource,
        motion_end: Duration,
    ) -> bool {
        let exposure_start = match source {
            TimestampSource::StartOfExposure => Some(timestamp),
            TimestampSource::EndOfFrame => timestamp.checked_sub(self.frame_interval),
        };
        exposure_start.is_some_and(|t| t >= motion_end + self.settle)
    }
}

/// What [`capture_settled`] produced.
#[derive(Debug, Clone, PartialEq)]
pub struct Settled {
    /// The mean of the fresh frames.
    pub image: RgbImage,
    /// Frames averaged.
    pub averaged: u32,
    /// Stale frames discarded.
    pub stale: u32,
    /// Fresh frames that could not be converted (a torn MJPEG frame, say) and were skipped.
    pub corrupt: u32,
    /// The timestamp of the first frame used.
    pub first_timestamp: Duration,
}

/// Discards frames exposed before `motion_end` (+ the settle time) and averages the next
/// `policy.frames` fresh ones; a frame that does not convert is skipped. Fails with
/// [`Error::Timeout`] if they do not all come within `policy.timeout`.
pub fn capture_settled<S: FrameStream + ?Sized>(
    stream: &mut S,
    motion_end: Duration,
    policy: &SettlePolicy,
) -> Result<Settled> {
    if policy.frames == 0 {
        return Err(Error::InvalidParameter {
            name: "frames",
            reason: "at least one frame must be averaged".into(),
        });
    }
    let start = Instant::now();
    let mut averager = FrameAverager::new();
    let mut rgb = RgbImage::new(0, 0);
    let (mut stale, mut corrupt) = (0, 0);
    let mut first = None;
    loop {
        let left = policy.timeout.saturating_sub(start.elapsed());
        if left.is_zero() {
            return Err(Error::Timeout {
                waited: start.elapsed(),
                wanted: policy.frames,
                fresh: averager.count(),
                stale,
                corrupt,
            });
        }
        let Some(frame) = stream.next_frame(left)? else {
            continue;
        };
        if !policy.is_fresh(frame.timestamp, frame.source, motion_end) {
            stale += 1;
            continue;
        }
        match to_rgb(&frame.raw, &mut rgb) {
            Ok(()) => {}
            Err(Error::Decode { .. } | Error::BadFrame { .. }) => {
                corrupt += 1;
                continue;
            }
            Err(e) => return Err(e),
        }
        first.get_or_insert(frame.timestamp);
        averager.add(&rgb)?;
        if averager.count() == policy.frames {
            break;
        }
    }
    Ok(Settled {
        image: averager.mean().unwrap_or(rgb),
        averaged: averager.count(),
        stale,
        corrupt,
        first_timestamp: first.unwrap_or_default(),
    })
}

/// Now on the monotonic clock (`CLOCK_MONOTONIC`), the clock of V4L2 buffer timestamps:
/// record it when the turntable reports that it stopped.
pub fn monotonic_now() -> Duration {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    Duration::new(
        t.tv_sec.max(0) as u64,
        t.tv_nsec.clamp(0, 999_999_999) as u32,
    )
}
