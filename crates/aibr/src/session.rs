//! Sessions on disk: `session.json`, `views/NNNN.png`, `masks/NNNN.png` and outputs.
//!
//! Every write is atomic (a temporary file in the same folder, fsync, rename, fsync of the
//! folder), so a crash loses at most the view in flight and never leaves a half-written file.
//! `session.json` records a CRC-32 of every view and mask file; opening a session checks them.

use std::io::Write;
use std::path::{Path, PathBuf};

use aibr_camera::{
    Aabb, Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange, TurntableAxis,
};
use image::{GrayImage, RgbImage};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, Unit, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::rig::Calibration;

/// The version of `session.json` this code writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// A camera pose in `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseRecord {
    /// Rotation as a unit quaternion `[w, x, y, z]`.
    pub rotation_wxyz: [f64; 4],
    /// Translation, metres.
    pub translation: [f64; 3],
}

/// The calibration in `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationRecord {
    /// `[fx, fy, cx, cy, skew]`, pixels.
    pub intrinsics: [f64; 5],
    /// `[k1, k2, p1, p2, k3]`.
    pub distortion: [f64; 5],
    /// Image width and height.
    pub size: [u32; 2],
    /// A point on the pan axis (turntable frame).
    pub axis_point: [f64; 3],
    /// The pan axis direction.
    pub axis_direction: [f64; 3],
    /// `cam_from_world` at pan 0.
    pub cam_from_world_at_zero: PoseRecord,
}

/// The turntable in `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TurntableRecord {
    /// Lower pan limit, radians.
    pub min_rad: f64,
    /// Upper pan limit, radians.
    pub max_rad: f64,
    /// One step, radians.
    pub step_rad: f64,
}

/// The parameters of the capture in `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParametersRecord {
    /// `active` or `uniform`.
    pub strategy: String,
    /// Views captured uniformly first.
    pub initial: usize,
    /// The budget of views.
    pub max: usize,
    /// Reconstruct every this many captures.
    pub refine_every: usize,
    /// Voxels along the longest edge of the volume.
    pub grid: usize,
    /// Arcs scoring at or below this are consistent (0: only the budget stops the capture).
    #[serde(default)]
    pub consistent_below: f64,
    /// The planner's width power; 1 in files written before it was recorded, which were
    /// planned with that weight.
    #[serde(default = "ParametersRecord::width_power_before_recorded")]
    pub width_power: f64,
    /// How far from an arc's middle a flat face's edge-on pan may draw a view; 0 in files
    /// written before it was recorded, which split every arc at its middle.
    #[serde(default)]
    pub aim_reach: f64,
    /// Whether the planner served every flat face of the model with a view in its plane
    /// before splitting arcs by rank alone (`false`, `true`, or `"auto"`: when the initial
    /// views show a view-dependent surface); false in files written before it was recorded,
    /// which did not.
    #[serde(default = "ParametersRecord::faces_first_before_recorded")]
    pub faces_first: crate::FacesFirst,
    /// Serving faces first, how near a face's plane (degrees) a view served it; 1 in files
    /// written before it was recorded, which served faces within 1 degree.
    #[serde(default = "ParametersRecord::face_served_deg_before_recorded")]
    pub face_served_deg: f64,
}

impl ParametersRecord {
    /// The record of `params`.
    pub fn of(params: &crate::CaptureParams) -> Self {
        ParametersRecord {
            strategy: params.strategy.name().to_owned(),
            initial: params.initial,
            max: params.max,
            refine_every: params.refine_every,
            grid: params.grid,
            consistent_below: params.consistent_below,
            width_power: params.width_power,
            aim_reach: params.aim_reach,
            faces_first: params.faces_first,
            face_served_deg: params.face_served_deg,
        }
    }

    fn width_power_before_recorded() -> f64 {
        1.0
    }

    fn faces_first_before_recorded() -> crate::FacesFirst {
        crate::FacesFirst::Off
    }

    fn face_served_deg_before_recorded() -> f64 {
        1.0
    }

    /// The active loop's fields as they bore on the views: as recorded for active capture,
    /// and `unused` where no planner chose the views (uniform capture, which captures its
    /// whole budget evenly and reconstructs nothing on the way), or for the face tolerance
    /// where faces were not served first. A session may be resumed with any value of an
    /// unused field.
    fn active_as_used(&self) -> [(&'static str, String); 8] {
        let active = self.strategy == crate::Strategy::Active.name();
        let shown = |used: bool, value: &dyn ToString| {
            if used {
                value.to_string()
            } else {
                "unused".to_owned()
            }
        };
        [
            ("initial", shown(active, &self.initial)),
            ("refine_every", shown(active, &self.refine_every)),
            ("grid", shown(active, &self.grid)),
            ("consistent_below", shown(active, &self.consistent_below)),
            ("width_power", shown(active, &self.width_power)),
            ("aim_reach", shown(active, &self.aim_reach)),
            ("faces_first", shown(active, &self.faces_first)),
            (
                "face_served_deg",
                shown(
                    active && self.faces_first != crate::FacesFirst::Off,
                    &self.face_served_deg,
                ),
            ),
        ]
    }
}

/// One view in `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewRecord {
    /// Capture order, from 0.
    pub index: usize,
    /// The pan angle the turntable reached, radians.
    pub pan_rad: f64,
    /// The same in turntable steps.
    pub pan_steps: i64,
    /// The image file, relative to the session folder.
    pub image: String,
    /// CRC-32 of the image file.
    pub image_crc32: u32,
    /// The mask file, if the source gave one.
    pub mask: Option<String>,
    /// CRC-32 of the mask file.
    pub mask_crc32: Option<u32>,
    /// Capture time, milliseconds since the Unix epoch.
    pub captured_unix_ms: u64,
}

/// `session.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionFile {
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The rig, e.g. `sim:mirror`.
    pub rig: String,
    /// The calibration used.
    pub calibration: CalibrationRecord,
    /// The turntable.
    pub turntable: TurntableRecord,
    /// The reconstruction volume `[min, max]` in the turntable frame, metres.
    pub volume: [[f64; 3]; 2],
    /// The capture parameters.
    pub parameters: ParametersRecord,
    /// The views, in capture order.
    pub views: Vec<ViewRecord>,
    /// What the camera reported of its settings (for a webcam: the exposure, white balance
    /// and gain in force), absent for a synthetic camera.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_settings: Option<serde_json::Value>,
}

impl CalibrationRecord {
    /// The record of `c`.
    pub fn of(c: &Calibration) -> Self {
        let k = c.camera.intrinsics;
        let pose = c.motion.cam_from_world_at_zero;
        let q = pose.rotation.quaternion();
        CalibrationRecord {
            intrinsics: [k.fx, k.fy, k.cx, k.cy, k.skew],
            distortion: c.camera.distortion.to_array(),
            size: [c.camera.size.width, c.camera.size.height],
            axis_point: c.motion.axis.point.coords.into(),
            axis_direction: c.motion.axis.direction.into_inner().into(),
            cam_from_world_at_zero: PoseRecord {
                rotation_wxyz: [q.w, q.i, q.j, q.k],
                translation: pose.translation.vector.into(),
            },
        }
    }

    /// The calibration it records.
    pub fn calibration(&self) -> Result<Calibration> {
        let [fx, fy, cx, cy, skew] = self.intrinsics;
        let p = &self.cam_from_world_at_zero;
        let [w, x, y, z] = p.rotation_wxyz;
        let rotation = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
        let pose =
            Isometry3::from_parts(Translation3::from(Vector3::from(p.translation)), rotation);
        let camera = Camera::new(
            Intrinsics {
                fx,
                fy,
                cx,
                cy,
                skew,
            },
            Distortion::from_opencv(&self.distortion)?,
            pose,
            ImageSize::new(self.size[0], self.size[1]),
        )?;
        let direction = Unit::try_new(Vector3::from(self.axis_direction), 1e-9).ok_or(
            Error::InvalidParameter {
                name: "calibration axis_direction",
                reason: "the axis direction is zero".into(),
            },
        )?;
        Ok(Calibration {
            camera,
            motion: CircularMotion {
                axis: TurntableAxis {
                    point: Point3::from(self.axis_point),
                    direction,
                },
                cam_from_world_at_zero: pose,
            },
        })
    }
}

/// An open session folder.
#[derive(Debug, Clone)]
pub struct Session {
    dir: PathBuf,
    file: SessionFile,
}

/// A view loaded from a session.
#[derive(Debug, Clone)]
pub struct LoadedView {
    /// Its record.
    pub record: ViewRecord,
    /// The camera at its pan angle.
    pub camera: Camera,
    /// The image.
    pub image: RgbImage,
    /// The mask, if recorded.
    pub mask: Option<GrayImage>,
}

fn io<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io {
        action,
        path: path.to_owned(),
        source,
    }
}

/// Refuses a folder with entries other than empty `views` and `masks` folders (a missing
/// folder is empty).
fn check_empty(dir: &Path) -> Result<()> {
    let entries = match std::fs::read_dir(dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        other => other.map_err(io("reading", dir))?,
    };
    for entry in entries {
        let entry = entry.map_err(io("reading", dir))?;
        let name = entry.file_name();
        let path = entry.path();
        let left_by_create = (name == "views" || name == "masks")
            && path.is_dir()
            && std::fs::read_dir(&path)
                .map_err(io("reading", &path))?
                .next()
                .is_none();
        if !left_by_create {
            return Err(Error::FolderNotEmpty {
                path: dir.to_owned(),
                entry: name.to_string_lossy().into_owned(),
            });
        }
    }
    Ok(())
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, fsync, rename, fsync of
/// the folder. The old file (if any) stays intact until the rename, and a write that fails
/// (a full disk, say) removes its temporary file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let mut f = std::fs::File::create(&tmp).map_err(io("creating", &tmp))?;
    let written = f
        .write_all(bytes)
        .map_err(io("writing", &tmp))
        .and_then(|()| f.sync_all().map_err(io("syncing", &tmp)));
    drop(f);
    let placed =
        written.and_then(|()| std::fs::rename(&tmp, path).map_err(io("renaming into place", path)));
    if placed.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    placed?;
    if let Ok(d) = std::fs::File::open(dir) {
        // Make the rename itself durable; not every file system supports it.
        let _ = d.sync_all();
    }
    Ok(())
}

fn encode_png<P>(img: &image::ImageBuffer<P, Vec<u8>>) -> Result<Vec<u8>>
where
    P: image::Pixel<Subpixel = u8> + image::PixelWithColorType,
{
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| Error::Image {
            path: PathBuf::from("<memory>"),
            reason: e.to_string(),
        })?;
    Ok(out.into_inner())
}

impl Session {
    /// Creates a session in `dir` (created if missing); refuses a folder that already holds
    /// one ([`Error::SessionExists`]) or holds anything else ([`Error::FolderNotEmpty`]: the
    /// session's views, masks and outputs could overwrite it), except the empty `views` and
    /// `masks` folders a create that failed before writing `session.json` leaves.
    pub fn create(dir: &Path, file: SessionFile) -> Result<Self> {
        if dir.join("session.json").exists() {
            return Err(Error::SessionExists(dir.to_owned()));
        }
        check_empty(dir)?;
        for sub in ["", "views", "masks"] {
            let d = dir.join(sub);
            std::fs::create_dir_all(&d).map_err(io("creating", &d))?;
        }
        let s = Session {
            dir: dir.to_owned(),
            file,
        };
        s.save()?;
        Ok(s)
    }

    /// Opens the session in `dir`, checking its format and every file's checksum.
    pub fn open(dir: &Path) -> Result<Self> {
        let path = dir.join("session.json");
        if !path.is_file() {
            return Err(Error::NotASession {
                path: dir.to_owned(),
                reason: "it has no session.json".into(),
            });
        }
        let text = std::fs::read_to_string(&path).map_err(io("reading", &path))?;
        let file: SessionFile = serde_json::from_str(&text).map_err(|e| Error::BadSession {
            path: path.clone(),
            reason: format!("line {}, column {}: {e}", e.line(), e.column()),
        })?;
        if file.format_version != FORMAT_VERSION {
            return Err(Error::BadSession {
                path,
                reason: format!(
                    "format version {} (this aibr reads {FORMAT_VERSION})",
                    file.format_version
                ),
            });
        }
        for (i, v) in file.views.iter().enumerate() {
            if v.index != i {
                return Err(Error::BadSession {
                    path: path.clone(),
                    reason: format!("view {i} is recorded with index {}", v.index),
                });
            }
        }
        let s = Session {
            dir: dir.to_owned(),
            file,
        };
        for v in &s.file.views {
            s.check(&v.image, v.image_crc32)?;
            if let (Some(m), Some(c)) = (&v.mask, v.mask_crc32) {
                s.check(m, c)?;
            }
        }
        Ok(s)
    }

    fn check(&self, relative: &str, recorded: u32) -> Result<Vec<u8>> {
        let path = self.resolve(relative)?;
        let bytes = std::fs::read(&path).map_err(io("reading", &path))?;
        let actual = crc32fast::hash(&bytes);
        if actual != recorded {
            return Err(Error::Checksum {
                path,
                recorded,
                actual,
            });
        }
        Ok(bytes)
    }

    /// A path inside the session (refuses names that would leave it).
    fn resolve(&self, relative: &str) -> Result<PathBuf> {
        let p = Path::new(relative);
        if p.is_absolute()
            || p.components()
                .any(|c| matches!(c, std::path::Component::ParentDir))
        {
            return Err(Error::BadSession {
                path: self.dir.join("session.json"),
                reason: format!("file name {relative:?} points outside the session"),
            });
        }
        Ok(self.dir.join(p))
    }

    /// The session folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The contents of `session.json`.
    pub fn file(&self) -> &SessionFile {
        &self.file
    }

    /// Refuses to continue this session on `rig` with `params` unless they are what it was
    /// captured with: views planned under other parameters would be mixed with new ones.
    /// The active loop's fields (the initial count, how often it reconstructs, its grid and
    /// the planner's) count only where a planner chose the views: not for uniform capture,
    /// and the face tolerance only with faces served first. The error names the first field
    /// that differs.
    pub fn check_parameters(&self, rig: &str, params: &crate::CaptureParams) -> Result<()> {
        let (file, given) = (self.file(), ParametersRecord::of(params));
        let have = &file.parameters;
        let mut fields = [
            ("rig", file.rig.clone(), rig.to_owned()),
            ("strategy", have.strategy.clone(), given.strategy.clone()),
            ("max", have.max.to_string(), given.max.to_string()),
        ]
        .into_iter()
        .chain(
            have.active_as_used()
                .into_iter()
                .zip(given.active_as_used())
                .map(|((field, recorded), (_, given))| (field, recorded, given)),
        );
        match fields.find(|(_, recorded, given)| recorded != given) {
            None => Ok(()),
            Some((field, recorded, given)) => Err(Error::ParametersDiffer {
                path: self.dir().to_path_buf(),
                field,
                recorded,
                given,
            }),
        }
    }

    /// The calibration.
    pub fn calibration(&self) -> Result<Calibration> {
        self.file.calibration.calibration()
    }

    /// The turntable's range and step.
    pub fn turntable(&self) -> Result<(PanRange, Angle)> {
        let t = &self.file.turntable;
        Ok((
            PanRange::new(
                Angle::from_radians(t.min_rad),
                Angle::from_radians(t.max_rad),
            )?,
            Angle::from_radians(t.step_rad),
        ))
    }

    /// True when the volume is still to be estimated from the first views (recorded as all
    /// zeros).
    pub fn volume_pending(&self) -> bool {
        self.file.volume == [[0.0; 3]; 2]
    }

    /// Records the reconstruction volume.
    pub fn set_volume(&mut self, volume: &Aabb) -> Result<()> {
        self.file.volume = [volume.min.coords.into(), volume.max.coords.into()];
        self.save()
    }

    /// The reconstruction volume.
    pub fn volume(&self) -> Result<Aabb> {
        if self.volume_pending() {
            return Err(Error::BadSession {
                path: self.dir.join("session.json"),
                reason: "the volume has not been estimated yet (capture the initial views first)"
                    .into(),
            });
        }
        let [a, b] = self.file.volume;
        Ok(Aabb::new(Point3::from(a), Point3::from(b))?)
    }

    /// The pan angles of the views, in capture order.
    pub fn pans(&self) -> Vec<Angle> {
        self.file
            .views
            .iter()
            .map(|v| Angle::from_radians(v.pan_rad))
            .collect()
    }

    fn save(&self) -> Result<()> {
        let text = serde_json::to_string_pretty(&self.file).map_err(|e| Error::BadSession {
            path: self.dir.join("session.json"),
            reason: e.to_string(),
        })?;
        write_atomic(&self.dir.join("session.json"), text.as_bytes())
    }

    /// Adds a view: writes its image (and mask) atomically, then records it in
    /// `session.json` (also atomically). A crash between the two leaves an unrecorded file
    /// that the next capture of that index replaces.
    pub fn add_view(
        &mut self,
        pan: Angle,
        pan_steps: i64,
        image: &RgbImage,
        mask: Option<&GrayImage>,
    ) -> Result<()> {
        let size = self.file.calibration.size;
        let index = self.file.views.len();
        let name = format!("views/{index:04}.png");
        if image.dimensions() != (size[0], size[1]) {
            return Err(Error::ImageSize {
                path: self.dir.join(&name),
                width: image.width(),
                height: image.height(),
                expected_width: size[0],
                expected_height: size[1],
            });
        }
        let bytes = encode_png(image)?;
        write_atomic(&self.dir.join(&name), &bytes)?;
        let (mask_name, mask_crc32) = match mask {
            Some(m) => {
                let mname = format!("masks/{index:04}.png");
                let mb = encode_png(m)?;
                write_atomic(&self.dir.join(&mname), &mb)?;
                (Some(mname), Some(crc32fast::hash(&mb)))
            }
            None => (None, None),
        };
        let captured_unix_ms = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_millis() as u64);
        self.file.views.push(ViewRecord {
            index,
            pan_rad: pan.radians(),
            pan_steps,
            image: name,
            image_crc32: crc32fast::hash(&bytes),
            mask: mask_name,
            mask_crc32,
            captured_unix_ms,
        });
        // Unrecorded, the view is not in the session: the next capture of this index
        // replaces its files.
        self.save().inspect_err(|_| {
            self.file.views.pop();
        })
    }

    /// Loads every view (checksums checked again, sizes against the calibration).
    pub fn load_views(&self) -> Result<Vec<LoadedView>> {
        self.load_views_from(0)
    }

    /// The views from index `first` on (none if `first` is past the last), checked and
    /// decoded like [`Session::load_views`]: for a loop that already holds the earlier ones.
    pub fn load_views_from(&self, first: usize) -> Result<Vec<LoadedView>> {
        let calibration = self.calibration()?;
        let size = calibration.camera.size;
        self.file
            .views
            .iter()
            .skip(first)
            .map(|v| {
                let decode = |relative: &str, crc: u32| -> Result<image::DynamicImage> {
                    let bytes = self.check(relative, crc)?;
                    let path = self.dir.join(relative);
                    let img = image::load_from_memory(&bytes).map_err(|e| Error::Image {
                        path: path.clone(),
                        reason: e.to_string(),
                    })?;
                    if (img.width(), img.height()) != (size.width, size.height) {
                        return Err(Error::ImageSize {
                            path,
                            width: img.width(),
                            height: img.height(),
                            expected_width: size.width,
                            expected_height: size.height,
                        });
                    }
                    Ok(img)
                };
                let image = decode(&v.image, v.image_crc32)?.to_rgb8();
                let mask = match (&v.mask, v.mask_crc32) {
                    (Some(m), Some(c)) => Some(decode(m, c)?.to_luma8()),
                    _ => None,
                };
                Ok(LoadedView {
                    record: v.clone(),
                    camera: calibration.camera_at(Angle::from_radians(v.pan_rad)),
                    image,
                    mask,
                })
            })
            .collect()
    }

    /// Writes an output file (`model.ply`, a render, ...) into the session atomically.
    pub fn write_output(&self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        let path = self.resolve(name)?;
        write_atomic(&path, bytes)?;
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn file(x: [f64; 6], pans: &[f64]) -> SessionFile {
        SessionFile {
            format_version: FORMAT_VERSION,
            rig: "sim:mirror".into(),
            calibration: CalibrationRecord {
                intrinsics: [x[0], x[1], x[2], x[3], 0.0],
                distortion: [x[4], x[5], 0.0, 0.0, 0.0],
                size: [640, 480],
                axis_point: [x[0], 0.0, x[1]],
                axis_direction: [0.0, 0.0, 1.0],
                cam_from_world_at_zero: PoseRecord {
                    rotation_wxyz: [x[2], x[3], x[4], x[5]],
                    translation: [x[5], x[4], x[3]],
                },
            },
            turntable: TurntableRecord {
                min_rad: -x[0],
                max_rad: x[1],
                step_rad: x[2],
            },
            volume: [[x[0], x[1], x[2]], [x[3], x[4], x[5]]],
            parameters: ParametersRecord::of(&crate::CaptureParams {
                consistent_below: x[3].abs(),
                width_power: x[4].abs(),
                aim_reach: x[5].abs().min(1.0),
                ..crate::CaptureParams::default()
            }),
            views: pans
                .iter()
                .enumerate()
                .map(|(index, &pan_rad)| ViewRecord {
                    index,
                    pan_rad,
                    pan_steps: index as i64,
                    image: format!("views/{index:04}.png"),
                    image_crc32: 0,
                    mask: None,
                    mask_crc32: None,
                    captured_unix_ms: 0,
                })
                .collect(),
            camera_settings: None,
        }
    }

    /// A session in a fresh temporary folder, with a plausible camera and no views.
    fn fresh(name: &str) -> Result<(PathBuf, Session)> {
        let dir = std::env::temp_dir().join(format!("aibr-session-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut f = file([500.0, 500.0, 320.0, 240.0, 0.0, 0.0], &[]);
        f.calibration.size = [8, 6];
        let session = Session::create(&dir, f)?;
        Ok((dir, session))
    }

    fn grey(level: u8) -> RgbImage {
        RgbImage::from_pixel(8, 6, image::Rgb([level; 3]))
    }

    /// Files whose name starts with `.` (temporary files) in `dir`.
    fn hidden(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir)
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .map(|e| e.file_name().to_string_lossy().into_owned())
                    .filter(|n| n.starts_with('.'))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Fault injection: a session holding one view is asked to add a second while a folder
    /// stands at the path `blocker` gives (a folder no write or rename can replace, whoever
    /// runs the test). The attempt must fail naming that path, leave the session as it was in
    /// memory and on disk, and leave no temporary file among the views; then the folder is
    /// removed. Returns the session folder and the session.
    fn second_view_against(
        name: &str,
        blocker: impl Fn(&Path) -> PathBuf,
    ) -> Result<(PathBuf, Session)> {
        let (dir, mut session) = fresh(name)?;
        session.add_view(Angle::ZERO, 0, &grey(10), None)?;
        let before = std::fs::read(dir.join("session.json")).map_err(io("reading", &dir))?;
        let blocker = blocker(&dir);
        std::fs::create_dir_all(&blocker).map_err(io("creating", &blocker))?;
        match session.add_view(Angle::from_degrees(10.0), 1, &grey(20), None) {
            Err(Error::Io { path, .. }) => assert_eq!(path, blocker),
            other => panic!(
                "expected an i/o error naming {}: {other:?}",
                blocker.display()
            ),
        }
        assert_eq!(session.file().views.len(), 1);
        assert_eq!(
            std::fs::read(dir.join("session.json")).map_err(io("reading", &dir))?,
            before
        );
        assert_eq!(Session::open(&dir)?.file().views.len(), 1);
        assert_eq!(hidden(&dir.join("views")), Vec::<String>::new());
        std::fs::remove_dir_all(&blocker).map_err(io("removing", &blocker))?;
        Ok((dir, session))
    }

    /// A view's image cannot be put in place; once the fault is gone the same index is
    /// captured.
    #[test]
    fn a_view_that_cannot_be_written_loses_nothing() -> Result<()> {
        let (dir, mut session) =
            second_view_against("image-fault", |dir| dir.join("views/0001.png"))?;
        session.add_view(Angle::from_degrees(10.0), 1, &grey(20), None)?;
        let views = Session::open(&dir)?.load_views()?;
        assert_eq!(views.len(), 2);
        assert_eq!(views[1].image, grey(20));
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    /// `session.json` cannot be written (a folder stands where its temporary file goes)
    /// after a view's image was: the view is not in the session, in memory or on disk, and
    /// the next attempt records it under the same index.
    #[test]
    fn a_view_whose_record_cannot_be_saved_is_not_in_the_session() -> Result<()> {
        let (dir, mut session) = second_view_against("record-fault", |dir| {
            dir.join(format!(".session.json.tmp-{}", std::process::id()))
        })?;
        session.add_view(Angle::from_degrees(10.0), 1, &grey(30), None)?;
        let views = Session::open(&dir)?.load_views()?;
        assert_eq!(views.len(), 2);
        assert_eq!((views[1].record.index, &views[1].image), (1, &grey(30)));
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    /// A new session is refused in a folder holding other files (a report, a view of
    /// something else), naming one, and the folder is left as it was; the empty `views` and
    /// `masks` folders of a create that failed before its record are no obstacle.
    #[test]
    fn a_new_session_leaves_a_folder_with_other_files_alone() -> Result<()> {
        let dir =
            std::env::temp_dir().join(format!("aibr-session-occupied-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let other = dir.join("views/0000.png");
        std::fs::create_dir_all(dir.join("views")).map_err(io("creating", &dir))?;
        std::fs::write(&other, b"not a view of this session").map_err(io("writing", &other))?;
        let new = || {
            let mut f = file([500.0, 500.0, 320.0, 240.0, 0.0, 0.0], &[]);
            f.calibration.size = [8, 6];
            Session::create(&dir, f)
        };
        match new() {
            Err(Error::FolderNotEmpty { path, entry }) => {
                assert_eq!((path, entry.as_str()), (dir.clone(), "views"));
            }
            other => panic!("expected FolderNotEmpty, got {other:?}"),
        }
        assert!(!dir.join("session.json").exists());
        assert!(!dir.join("masks").exists());
        let kept = std::fs::read(&other).map_err(io("reading", &other))?;
        assert_eq!(kept, b"not a view of this session");
        // What an interrupted create leaves: empty views and masks folders.
        std::fs::remove_file(&other).map_err(io("removing", &other))?;
        std::fs::create_dir_all(dir.join("masks")).map_err(io("creating", &dir))?;
        new()?;
        assert!(dir.join("session.json").is_file());
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    /// The planner's fields are checked on resume only where they planned: not for uniform
    /// capture, and the face tolerance only with faces served first. A file written before the
    /// tolerance was recorded was planned at 1 degree.
    #[test]
    fn planner_fields_are_checked_only_where_they_planned()
    -> std::result::Result<(), Box<dyn std::error::Error>> {
        let (dir, session) = fresh("face-tolerance")?;
        drop(session);
        let path = dir.join("session.json");
        // The defaults, but never serving faces first.
        let params = crate::CaptureParams {
            faces_first: crate::FacesFirst::Off,
            ..crate::CaptureParams::default()
        };
        // Rewrites the folder's parameters as `edit` makes them of the record of `params`.
        let rewrite = |edit: &dyn Fn(&mut serde_json::Map<String, serde_json::Value>)| {
            let mut json: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&path)?)?;
            let mut parameters = serde_json::to_value(ParametersRecord::of(&params))?;
            edit(parameters.as_object_mut().ok_or("parameters not a map")?);
            json["parameters"] = parameters;
            std::fs::write(&path, serde_json::to_string_pretty(&json)?)?;
            Session::open(&dir).map_err(Box::<dyn std::error::Error>::from)
        };
        let first = |face_served_deg| crate::CaptureParams {
            faces_first: crate::FacesFirst::On,
            face_served_deg,
            ..params
        };
        // Not serving faces first, the tolerance did not plan, so any resumes (the default is
        // 1 degree, so 2.5 differs from what was recorded).
        let session = rewrite(&|_| ())?;
        session.check_parameters("sim:mirror", &params)?;
        session.check_parameters(
            "sim:mirror",
            &crate::CaptureParams {
                face_served_deg: 2.5,
                ..params
            },
        )?;
        // Uniform capture: no planner chose its views and nothing was reconstructed on the way,
        // so none of the active loop's fields count; the budget still does.
        let session = rewrite(&|p| {
            p.insert("strategy".into(), "uniform".into());
        })?;
        let uniform = crate::CaptureParams {
            strategy: crate::Strategy::Uniform,
            ..params
        };
        let replanned = crate::CaptureParams {
            initial: 6,
            refine_every: 4,
            grid: 64,
            width_power: 1.0,
            aim_reach: 0.0,
            faces_first: crate::FacesFirst::On,
            face_served_deg: 2.5,
            ..uniform
        };
        session.check_parameters("sim:mirror", &replanned)?;
        let err = session
            .check_parameters("sim:mirror", &crate::CaptureParams { max: 36, ..uniform })
            .err()
            .ok_or("resumed with another budget")?;
        assert!(err.to_string().contains("max 48, not 36"), "{err}");
        // Serving faces first, before the tolerance was recorded: planned at 1 degree.
        let session = rewrite(&|p| {
            p.remove("face_served_deg");
            p.insert("faces_first".into(), true.into());
        })?;
        assert_eq!(session.file().parameters.face_served_deg, 1.0);
        session.check_parameters("sim:mirror", &first(1.0))?;
        let err = session
            .check_parameters("sim:mirror", &first(2.5))
            .err()
            .ok_or("resumed at another tolerance")?;
        assert!(
            err.to_string().contains("face_served_deg 1, not 2.5"),
            "{err}"
        );
        // Deciding from the initial views: recorded as "auto", resumed only as auto, and its
        // tolerance counts (faces may have been served).
        let auto = |face_served_deg| crate::CaptureParams {
            faces_first: crate::FacesFirst::Auto,
            face_served_deg,
            ..params
        };
        let session = rewrite(&|p| {
            p.insert("faces_first".into(), "auto".into());
        })?;
        assert_eq!(
            session.file().parameters.faces_first,
            crate::FacesFirst::Auto
        );
        session.check_parameters("sim:mirror", &auto(1.0))?;
        for (other, expected) in [
            (first(1.0), "faces_first auto, not true"),
            (auto(2.5), "face_served_deg 1, not 2.5"),
        ] {
            let err = session
                .check_parameters("sim:mirror", &other)
                .err()
                .ok_or("resumed with other faces-first parameters")?;
            assert!(err.to_string().contains(expected), "{err}");
        }
        // Anything else is refused, naming what it read.
        let err = rewrite(&|p| {
            p.insert("faces_first".into(), "sometimes".into());
        })
        .err()
        .ok_or("read faces_first \"sometimes\"")?;
        assert!(
            err.to_string()
                .contains("\"sometimes\" is not false, true or auto"),
            "{err}"
        );
        // Written before it was recorded: faces were not served first.
        let session = rewrite(&|p| {
            p.remove("faces_first");
        })?;
        assert_eq!(
            session.file().parameters.faces_first,
            crate::FacesFirst::Off
        );
        let _ = std::fs::remove_dir_all(&dir);
        Ok(())
    }

    proptest! {
        /// `session.json` gives back every number it was written with, to the last bit: a
        /// resumed session's pans and calibration are the ones captured.
        #[test]
        fn session_files_round_trip_exactly(
            x in prop::array::uniform6(-1e3..1e3f64),
            pans in prop::collection::vec(-std::f64::consts::PI..std::f64::consts::PI, 0..50),
        ) {
            let written = file(x, &pans);
            let text = serde_json::to_string_pretty(&written);
            prop_assert!(text.is_ok());
            let read: serde_json::Result<SessionFile> =
                serde_json::from_str(text.as_deref().unwrap_or_default());
            prop_assert!(read.is_ok());
            let read = read.unwrap_or_else(|_| written.clone());
            for (a, b) in read.views.iter().zip(&written.views) {
                prop_assert_eq!(a.pan_rad.to_bits(), b.pan_rad.to_bits());
            }
            prop_assert_eq!(read, written);
        }
    }
}
