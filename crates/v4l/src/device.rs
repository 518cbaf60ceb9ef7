//! V4L2 devices (the `v4l` feature, Linux): listing, opening, format choice, controls that
//! keep colours consistent between views, and memory-mapped streaming.

use std::io;
use std::path::{Path, PathBuf};
use std::time::Duration;

use v4l::buffer::{Flags, Type};
use v4l::control::{Control, Type as ControlType, Value};
use v4l::io::mmap::Stream;
use v4l::io::traits::CaptureStream;
use v4l::video::Capture;
use v4l::{Device, FourCC};

use crate::convert::RawFrame;
use crate::error::{Error, Result};
use crate::format::{Offer, PixelFormat, choose};
use crate::settle::{
    FrameStream, SettlePolicy, Settled, StreamFrame, TimestampSource, capture_settled,
};

// Control ids of <linux/v4l2-controls.h>.
const CID_EXPOSURE_AUTO: u32 = 0x009a_0901;
const CID_EXPOSURE_ABSOLUTE: u32 = 0x009a_0902;
const CID_AUTO_WHITE_BALANCE: u32 = 0x0098_090c;
const CID_WHITE_BALANCE_TEMPERATURE: u32 = 0x0098_091a;
const CID_AUTOGAIN: u32 = 0x0098_0912;
const CID_GAIN: u32 = 0x0098_0913;
/// `V4L2_EXPOSURE_MANUAL` of the `EXPOSURE_AUTO` menu.
const EXPOSURE_MANUAL: i64 = 1;
const ENODEV: i32 = 19;

/// A capture device and what it offers.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DeviceInfo {
    /// The device file.
    pub path: PathBuf,
    /// The device's name.
    pub card: String,
    /// The kernel driver.
    pub driver: String,
    /// Where it is attached.
    pub bus: String,
    /// Formats and discrete frame sizes (for a stepwise range: its largest size, and
    /// 640x480 when inside it).
    pub offers: Vec<Offer>,
}

fn io_error(path: &Path, action: &'static str, e: io::Error) -> Error {
    match e.kind() {
        io::ErrorKind::NotFound => Error::NoDevice { path: path.into() },
        io::ErrorKind::PermissionDenied => Error::PermissionDenied { path: path.into() },
        _ if e.raw_os_error() == Some(ENODEV) => Error::Disconnected { path: path.into() },
        _ => Error::Io {
            path: path.into(),
            action,
            source: e,
        },
    }
}

fn offers(dev: &Device, path: &Path) -> Result<Vec<Offer>> {
    let mut out = Vec::new();
    for f in dev
        .enum_formats()
        .map_err(|e| io_error(path, "listing formats", e))?
    {
        let sizes = dev
            .enum_framesizes(f.fourcc)
            .map_err(|e| io_error(path, "listing frame sizes", e))?;
        for s in sizes {
            for d in s.size.to_discrete() {
                out.push(Offer {
                    fourcc: f.fourcc.repr,
                    width: d.width,
                    height: d.height,
                });
            }
        }
    }
    out.dedup();
    Ok(out)
}

/// Describes the capture device at `path`.
pub fn describe(path: &Path) -> Result<DeviceInfo> {
    let dev = Device::with_path(path).map_err(|e| io_error(path, "opening", e))?;
    let caps = dev
        .query_caps()
        .map_err(|e| io_error(path, "querying capabilities", e))?;
    Ok(DeviceInfo {
        path: path.into(),
        card: caps.card,
        driver: caps.driver,
        bus: caps.bus,
        offers: offers(&dev, path)?,
    })
}

/// Every video capture device under `/dev` (`/dev/video*`), in name order; nodes that do not
/// capture video (metadata nodes of UVC cameras) are left out.
pub fn list() -> Result<Vec<DeviceInfo>> {
    let dir = Path::new("/dev");
    let mut paths: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| io_error(dir, "listing", e))?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("video"))
        })
        .collect();
    paths.sort();
    let mut out = Vec::new();
    for p in paths {
        let Ok(dev) = Device::with_path(&p) else {
            continue;
        };
        let Ok(caps) = dev.query_caps() else {
            continue;
        };
        if !caps
            .capabilities
            .contains(v4l::capability::Flags::VIDEO_CAPTURE)
        {
            continue;
        }
        out.push(describe(&p)?);
    }
    Ok(out)
}

/// How to set an automatic control.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ControlSetting {
    /// Leave it as the device has it (automatic, usually).
    Auto,
    /// Turn the automatic mode off and keep the value in force now.
    #[default]
    Lock,
    /// Turn the automatic mode off and use this value (device units).
    Manual(i64),
}

/// How to open a webcam.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WebcamOptions {
    /// The frame size; `None` takes the largest of the preferred format.
    pub size: Option<(u32, u32)>,
    /// Memory-mapped buffers queued (at least 4).
    pub buffers: u32,
    /// Exposure (`exposure_absolute`, units of 100 µs).
    pub exposure: ControlSetting,
    /// White balance (`white_balance_temperature`, kelvin).
    pub white_balance: ControlSetting,
    /// Gain (device units).
    pub gain: ControlSetting,
}

impl Default for WebcamOptions {
    fn default() -> Self {
        WebcamOptions {
            size: Some((640, 480)),
            buffers: 4,
            exposure: ControlSetting::Lock,
            white_balance: ControlSetting::Lock,
            gain: ControlSetting::Lock,
        }
    }
}

/// The control values in force, to record with the views they were used for.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ControlRecord {
    /// `exposure_absolute` (100 µs units), if set manually.
    pub exposure_absolute: Option<i64>,
    /// `white_balance_temperature` (kelvin), if set manually.
    pub white_balance_temperature: Option<i64>,
    /// `gain`, if set manually.
    pub gain: Option<i64>,
    /// Controls left automatic or missing on this device, in words.
    pub notes: Vec<String>,
}

/// An open webcam, streaming once the first frame is asked for.
pub struct Webcam {
    path: PathBuf,
    dev: Device,
    stream: Option<Stream<'static>>,
    buffers: u32,
    format: PixelFormat,
    width: u32,
    height: u32,
    stride: usize,
    controls: ControlRecord,
    frame_interval: Duration,
}

impl std::fmt::Debug for Webcam {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Webcam")
            .field("path", &self.path)
            .field("format", &self.format)
            .field("width", &self.width)
            .field("height", &self.height)
            .finish_non_exhaustive()
    }
}

impl Webcam {
    /// Opens the device at `path`, chooses the format (uncompressed YUYV first, then MJPEG,
    /// then RGB3 or GREY) at the size asked for, and sets the colour controls.
    pub fn open(path: &Path, options: &WebcamOptions) -> Result<Self> {
        if options.buffers < 4 {
            return Err(Error::InvalidParameter {
                name: "buffers",
                reason: format!("{} buffers: at least 4 are queued", options.buffers),
            });
        }
        let dev = Device::with_path(path).map_err(|e| io_error(path, "opening", e))?;
        let offered = offers(&dev, path)?;
        let Some((format, width, height)) = choose(&offered, options.size) else {
            return Err(Error::UnsupportedFormat {
                path: path.into(),
                size: options.size,
                offered: offered
                    .iter()
                    .map(|o| o.to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        let mut fmt = dev
            .format()
            .map_err(|e| io_error(path, "reading the format", e))?;
        fmt.width = width;
        fmt.height = height;
        fmt.fourcc = FourCC::new(&format.fourcc());
        let set = dev
            .set_format(&fmt)
            .map_err(|e| io_error(path, "setting the format", e))?;
        if set.fourcc.repr != format.fourcc() || (set.width, set.height) != (width, height) {
            return Err(Error::UnsupportedFormat {
                path: path.into(),
                size: Some((width, height)),
                offered: format!(
                    "{format} {width}x{height} was asked for, the driver set {} {}x{}",
                    String::from_utf8_lossy(&set.fourcc.repr),
                    set.width,
                    set.height
                ),
            });
        }
        let frame_interval = dev
            .params()
            .ok()
            .filter(|p| p.interval.denominator > 0)
            .map(|p| {
                Duration::from_secs_f64(p.interval.numerator as f64 / p.interval.denominator as f64)
            })
            .unwrap_or(Duration::from_micros(33_333));
        let mut cam = Webcam {
            path: path.into(),
            dev,
            stream: None,
            buffers: options.buffers,
            format,
            width,
            height,
            stride: set.stride as usize,
            controls: ControlRecord::default(),
            frame_interval,
        };
        cam.controls = cam.set_controls(options)?;
        Ok(cam)
    }

    /// The format and size in use.
    pub fn format(&self) -> (PixelFormat, u32, u32) {
        (self.format, self.width, self.height)
    }

    /// The device's frame interval.
    pub fn frame_interval(&self) -> Duration {
        self.frame_interval
    }

    /// The control values in force.
    pub fn controls(&self) -> &ControlRecord {
        &self.controls
    }

    /// A settled frame: frames exposed before `motion_end` (on the monotonic clock, see
    /// [`crate::monotonic_now`]) are discarded, then `policy.frames` are averaged.
    pub fn capture(&mut self, motion_end: Duration, policy: &SettlePolicy) -> Result<Settled> {
        let policy = SettlePolicy {
            frame_interval: policy.frame_interval.max(self.frame_interval),
            ..*policy
        };
        capture_settled(self, motion_end, &policy)
    }

    fn set_controls(&self, options: &WebcamOptions) -> Result<ControlRecord> {
        let described = self
            .dev
            .query_controls()
            .map_err(|e| io_error(&self.path, "listing controls", e))?;
        let find = |id| described.iter().find(|d| d.id == id);
        let mut record = ControlRecord::default();
        let groups = [
            (
                "exposure",
                CID_EXPOSURE_AUTO,
                EXPOSURE_MANUAL,
                CID_EXPOSURE_ABSOLUTE,
                options.exposure,
            ),
            (
                "white balance",
                CID_AUTO_WHITE_BALANCE,
                0,
                CID_WHITE_BALANCE_TEMPERATURE,
                options.white_balance,
            ),
            ("gain", CID_AUTOGAIN, 0, CID_GAIN, options.gain),
        ];
        for (name, auto_id, manual_mode, value_id, setting) in groups {
            if setting == ControlSetting::Auto {
                record.notes.push(format!("{name}: left automatic"));
                continue;
            }
            if let Some(auto) = find(auto_id) {
                let value = if auto.typ == ControlType::Boolean {
                    Value::Boolean(manual_mode != 0)
                } else {
                    Value::Integer(manual_mode)
                };
                self.dev
                    .set_control(Control { id: auto_id, value })
                    .map_err(|e| Error::Control {
                        path: self.path.clone(),
                        control: name,
                        reason: format!("turning the automatic mode off: {e}"),
                    })?;
            }
            let Some(desc) = find(value_id) else {
                record
                    .notes
                    .push(format!("{name}: the device has no manual control"));
                continue;
            };
            let value = match setting {
                ControlSetting::Manual(v) => {
                    if v < desc.minimum || v > desc.maximum {
                        return Err(Error::Control {
                            path: self.path.clone(),
                            control: name,
                            reason: format!("{v} is outside {}..={}", desc.minimum, desc.maximum),
                        });
                    }
                    v
                }
                _ => match self.dev.control(value_id) {
                    Ok(Control {
                        value: Value::Integer(v),
                        ..
                    }) => v,
                    Ok(_) => desc.default,
                    Err(e) => {
                        return Err(Error::Control {
                            path: self.path.clone(),
                            control: name,
                            reason: format!("reading the current value: {e}"),
                        });
                    }
                },
            };
            self.dev
                .set_control(Control {
                    id: value_id,
                    value: Value::Integer(value),
                })
                .map_err(|e| Error::Control {
                    path: self.path.clone(),
                    control: name,
                    reason: format!("setting {value}: {e}"),
                })?;
            match name {
                "exposure" => record.exposure_absolute = Some(value),
                "white balance" => record.white_balance_temperature = Some(value),
                _ => record.gain = Some(value),
            }
        }
        Ok(record)
    }
}

impl FrameStream for Webcam {
    fn next_frame(&mut self, timeout: Duration) -> Result<Option<StreamFrame<'_>>> {
        if self.stream.is_none() {
            let s = Stream::with_buffers(&self.dev, Type::VideoCapture, self.buffers)
                .map_err(|e| io_error(&self.path, "mapping buffers", e))?;
            self.stream = Some(s);
        }
        let Some(stream) = self.stream.as_mut() else {
            return Ok(None);
        };
        stream.set_timeout(timeout.max(Duration::from_millis(1)));
        let (buf, meta) = match CaptureStream::next(stream) {
            Ok(x) => x,
            Err(e) if e.kind() == io::ErrorKind::TimedOut => return Ok(None),
            Err(e) => return Err(io_error(&self.path, "streaming", e)),
        };
        let used = (meta.bytesused as usize).min(buf.len());
        let source = if meta.flags.contains(Flags::TSTAMP_SRC_SOE) {
            TimestampSource::StartOfExposure
        } else {
            TimestampSource::EndOfFrame
        };
        Ok(Some(StreamFrame {
            raw: RawFrame {
                format: self.format,
                width: self.width,
                height: self.height,
                stride: self.stride,
                data: &buf[..used],
            },
            timestamp: Duration::new(
                meta.timestamp.sec.max(0) as u64,
                (meta.timestamp.usec.clamp(0, 999_999) * 1000) as u32,
            ),
            source,
            sequence: meta.sequence,
        }))
    }
}
