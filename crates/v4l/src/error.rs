//! The one error type of aibr-v4l.

use std::path::PathBuf;
use std::time::Duration;

use crate::format::PixelFormat;

/// Errors of aibr-v4l.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A frame buffer is not the size its format and dimensions need.
    #[error(
        "{format} frame of {width}x{height} (stride {stride}) needs {expected} bytes, the buffer has {len}"
    )]
    BadFrame {
        /// The pixel format.
        format: PixelFormat,
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
        /// Bytes per line.
        stride: usize,
        /// Bytes needed.
        expected: usize,
        /// Bytes given.
        len: usize,
    },
    /// A compressed frame could not be decoded.
    #[error("cannot decode the {format} frame: {reason}")]
    Decode {
        /// The pixel format.
        format: PixelFormat,
        /// The decoder's reason.
        reason: String,
    },
    /// Frames of different sizes were averaged.
    #[error("cannot average a {got_width}x{got_height} frame into {width}x{height} frames")]
    SizeMismatch {
        /// The size so far.
        width: u32,
        /// The size so far.
        height: u32,
        /// The new frame's width.
        got_width: u32,
        /// The new frame's height.
        got_height: u32,
    },
    /// The stream stopped delivering usable frames.
    #[error(
        "no {wanted} fresh frame(s) within {waited:?} ({fresh} fresh, {stale} taken before the turntable stopped, {corrupt} corrupt)"
    )]
    Timeout {
        /// How long the capture waited.
        waited: Duration,
        /// Frames wanted.
        wanted: u32,
        /// Fresh frames received.
        fresh: u32,
        /// Stale frames discarded.
        stale: u32,
        /// Frames that could not be converted.
        corrupt: u32,
    },
    /// No device at the path.
    #[error("{path}: no such video device")]
    NoDevice {
        /// The path.
        path: PathBuf,
    },
    /// The device exists but may not be opened.
    #[error("{path}: permission denied (is the user in the `video` group?)")]
    PermissionDenied {
        /// The path.
        path: PathBuf,
    },
    /// The device went away (unplugged) while in use.
    #[error("{path}: the device was disconnected")]
    Disconnected {
        /// The path.
        path: PathBuf,
    },
    /// The device offers no format aibr can convert (at the size asked for).
    #[error("{path}: no usable format{}; the device offers {offered}", size.map(|(w, h)| format!(" at {w}x{h}")).unwrap_or_default())]
    UnsupportedFormat {
        /// The path.
        path: PathBuf,
        /// The size asked for.
        size: Option<(u32, u32)>,
        /// What the device offers ("YUYV 640x480, ...").
        offered: String,
    },
    /// A control could not be read or set.
    #[error("{path}: control {control}: {reason}")]
    Control {
        /// The path.
        path: PathBuf,
        /// The control.
        control: &'static str,
        /// Why.
        reason: String,
    },
    /// Any other device error.
    #[error("{path}: {action}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// What was being done.
        action: &'static str,
        /// The reason.
        #[source]
        source: std::io::Error,
    },
    /// A parameter is out of its domain.
    #[error("invalid {name}: {reason}")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

/// Result alias of aibr-v4l.
pub type Result<T, E = Error> = std::result::Result<T, E>;
