//! The replay rig: a dense ring data set (a Middlebury `*_par.txt` with its images) acting as
//! turntable and camera together, so that capture strategies can be compared on real images.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use aibr_camera::readers::read_middlebury_par;
use aibr_camera::{
    Aabb, Angle, CalibratedPose, Camera, CircularMotion, ImageSize, PanRange, fit_ring,
};
use aibr_voxel::foreground::{DarkBackground, clip_to_volume, dark_background_mask};
use image::{GrayImage, RgbImage};
use nalgebra::Point3;

use crate::error::{Error, Result};
use crate::rig::{Calibration, Frame, FrameSource, Turntable};

/// One recorded view.
#[derive(Debug, Clone)]
pub struct RecordedView {
    /// The image file name.
    pub name: String,
    /// Its pan angle in the ring frame.
    pub pan: Angle,
    /// Its calibrated camera, in the ring frame.
    pub camera: Camera,
    /// The image.
    pub image: RgbImage,
    /// Its silhouette (dark background thresholded, as the Middlebury README suggests, and
    /// clipped to the projection of the README's bounding box when the folder gives one).
    pub mask: GrayImage,
}

#[derive(Debug)]
struct Data {
    dir: PathBuf,
    views: Vec<RecordedView>,
    calibration: Calibration,
    range: PanRange,
    step: Angle,
    volume: Option<Aabb>,
    left_out: Vec<String>,
}

/// A ring data set as a rig. A request for a pan angle returns the nearest recorded view not
/// yet returned (and reports its angle); the views never returned are the held-out ground
/// truth. Views no turntable could have taken are left out ([`ReplayRig::left_out`]). The ring frame comes from [`aibr_camera::fit_ring`]; the calibration's motion is
/// the circle fitted to the recorded poses, so the capture loop sees what a real turntable
/// calibration would give.
#[derive(Debug, Clone)]
pub struct ReplayRig {
    data: Arc<Data>,
    served: Vec<bool>,
    current: Option<usize>,
}

fn io(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        action: "reading",
        path: path.to_owned(),
        source,
    }
}

/// The bounding box a Middlebury README gives: two lines `(x y z)` after the words
/// "bounding box".
fn readme_box(text: &str) -> Option<Aabb> {
    let after = &text[text.to_ascii_lowercase().find("bounding box")?..];
    let points: Vec<Point3<f64>> = after
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            let inner = l.strip_prefix('(')?.strip_suffix(')')?;
            let v: Vec<f64> = inner
                .split_whitespace()
                .map(str::parse)
                .collect::<Result<_, _>>()
                .ok()?;
            (v.len() == 3).then(|| Point3::new(v[0], v[1], v[2]))
        })
        .take(2)
        .collect();
    match points.as_slice() {
        [a, b] => Aabb::new(*a, *b).ok(),
        _ => None,
    }
}

impl ReplayRig {
    /// Loads the ring data set in `dir`: its `*_par.txt`, the images it names, and the
    /// bounding box of its README when it gives one.
    pub fn open(dir: &Path) -> Result<Self> {
        let par = std::fs::read_dir(dir)
            .map_err(io(dir))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .find(|p| p.to_string_lossy().ends_with("_par.txt"))
            .ok_or_else(|| Error::Dataset {
                path: dir.to_owned(),
                reason: "no *_par.txt camera file: a replay rig needs a Middlebury-style ring \
                         folder"
                    .into(),
            })?;
        let records = read_middlebury_par(&par)?;
        let ring = fit_ring(&records.iter().map(|v| v.cam_from_world).collect::<Vec<_>>())?;
        // The README's tight box, in the turntable frame, when the folder has one.
        let volume = std::fs::read_to_string(dir.join("README.txt"))
            .ok()
            .and_then(|t| readme_box(&t))
            .and_then(|b| Aabb::around(b.corners().iter().map(|c| ring.turntable_from_world * c)))
            .map(|b| b.expanded(0.003));
        let mut views = Vec::with_capacity(records.len());
        for (r, pan) in records.iter().zip(&ring.pan_angles) {
            let path = dir.join(&r.image);
            let image = image::open(&path)
                .map_err(|e| Error::Image {
                    path: path.clone(),
                    reason: e.to_string(),
                })?
                .to_rgb8();
            let size = ImageSize::new(image.width(), image.height());
            let camera = r
                .camera(size)?
                .with_pose(ring.to_turntable(&r.cam_from_world));
            let mut mask = dark_background_mask(&image, &DarkBackground::default());
            // Thresholding also marks lit parts of the gantry; the object is in its box.
            if let Some(volume) = &volume {
                clip_to_volume(&mut mask, &camera, volume)?;
            }
            views.push(RecordedView {
                name: r.image.clone(),
                pan: *pan,
                camera,
                image,
                mask,
            });
        }
        let first = views.first().ok_or_else(|| Error::Dataset {
            path: par.clone(),
            reason: "the camera file lists no views".into(),
        })?;
        // A gantry is not a turntable: Middlebury's rings include views taken from over the
        // top of the sphere (upside down, rolled half a turn) and repeated poses. Keep the
        // views that a turntable in front of the first camera would give: orientation within
        // a few degrees of the circle through the first view, and no pose twice.
        let circle = CircularMotion::about_z(first.camera.cam_from_world);
        let mut left_out = Vec::new();
        let mut kept: Vec<RecordedView> = Vec::with_capacity(views.len());
        for v in views {
            let predicted = circle.cam_from_world(v.pan);
            let roll = (predicted.rotation.inverse() * v.camera.cam_from_world.rotation).angle();
            let repeated = kept
                .iter()
                .any(|k| (k.pan.radians() - v.pan.radians()).abs() < 1e-4);
            if roll > 5f64.to_radians() || repeated {
                left_out.push(v.name);
            } else {
                kept.push(v);
            }
        }
        let views = kept;
        let Some(first) = views.first() else {
            return Err(Error::Dataset {
                path: par,
                reason: "no view fits a turntable motion".into(),
            });
        };
        if views.iter().any(|v| v.camera.size != first.camera.size) {
            return Err(Error::Dataset {
                path: par,
                reason: "the images are not all the same size".into(),
            });
        }
        let samples: Vec<CalibratedPose> = views
            .iter()
            .map(|v| CalibratedPose {
                pan: v.pan,
                cam_from_world: v.camera.cam_from_world,
            })
            .collect();
        let motion = CircularMotion::fit(&samples)?.model;
        let calibration = Calibration {
            camera: first.camera.clone(),
            motion,
        };
        let mut pans: Vec<f64> = views.iter().map(|v| v.pan.radians()).collect();
        pans.sort_by(f64::total_cmp);
        let (lo, hi) = (pans[0], pans[pans.len() - 1]);
        let range = PanRange::new(Angle::from_radians(lo), Angle::from_radians(hi))?;
        let step = pans
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 1e-9)
            .fold(f64::INFINITY, f64::min);
        let n = views.len();
        Ok(ReplayRig {
            data: Arc::new(Data {
                dir: dir.to_owned(),
                views,
                calibration,
                range,
                step: Angle::from_radians(if step.is_finite() { step } else { 1e-3 }),
                volume,
                left_out,
            }),
            served: vec![false; n],
            current: None,
        })
    }

    /// Parses `replay:DIR`.
    pub fn from_spec(spec: &str) -> Result<Self> {
        let dir = spec
            .strip_prefix("replay:")
            .ok_or_else(|| Error::UnknownRig(spec.to_owned()))?;
        Self::open(Path::new(dir))
    }

    /// The recorded views left out because no turntable could have taken them (rolled half a
    /// turn, from over the top of a gantry) or because their pose repeats an earlier one.
    pub fn left_out(&self) -> &[String] {
        &self.data.left_out
    }

    /// The data set's folder.
    pub fn dir(&self) -> &Path {
        &self.data.dir
    }

    /// The recorded views.
    pub fn views(&self) -> &[RecordedView] {
        &self.data.views
    }

    /// The calibration: the first view's intrinsics and the circle fitted to the recorded
    /// poses.
    pub fn calibration(&self) -> Calibration {
        self.data.calibration.clone()
    }

    /// The same data set with no view returned yet (for another capture).
    pub fn fresh(&self) -> Self {
        ReplayRig {
            data: self.data.clone(),
            served: vec![false; self.data.views.len()],
            current: None,
        }
    }

    /// Marks the recorded view at `pan` as returned (a resumed capture already holds it).
    pub fn mark_served(&mut self, pan: Angle) {
        if let Some(i) = self.view_at(pan) {
            self.served[i] = true;
        }
    }

    /// The index of the recorded view at `pan` (within a thousandth of a degree), if any.
    pub fn view_at(&self, pan: Angle) -> Option<usize> {
        self.data
            .views
            .iter()
            .position(|v| (v.pan.radians() - pan.radians()).abs() < 1e-5_f64.to_radians())
    }
}

impl Turntable for ReplayRig {
    fn move_to(&mut self, pan: Angle) -> Result<Angle> {
        let pan = self.data.range.check(pan)?;
        let next = self
            .data
            .views
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.served[*i])
            .min_by(|a, b| {
                let da = (a.1.pan.radians() - pan.radians()).abs();
                let db = (b.1.pan.radians() - pan.radians()).abs();
                da.total_cmp(&db)
            })
            .map(|(i, _)| i)
            .ok_or_else(|| {
                Error::Rig(format!(
                    "every one of the {} recorded views has been captured",
                    self.data.views.len()
                ))
            })?;
        self.served[next] = true;
        self.current = Some(next);
        Ok(self.data.views[next].pan)
    }

    fn range(&self) -> PanRange {
        self.data.range
    }

    fn step(&self) -> Angle {
        self.data.step
    }

    /// The recorded views not yet returned.
    fn reachable(&self) -> Option<Vec<Angle>> {
        let unserved = self.data.views.iter().zip(&self.served);
        Some(unserved.filter(|(_, s)| !**s).map(|(v, _)| v.pan).collect())
    }
}

impl FrameSource for ReplayRig {
    fn capture(&mut self) -> Result<Frame> {
        let i = self
            .current
            .ok_or_else(|| Error::Rig("capture before the first move".into()))?;
        let v = &self.data.views[i];
        Ok(Frame {
            image: v.image.clone(),
            mask: Some(v.mask.clone()),
        })
    }

    fn known_volume(&self) -> Option<Aabb> {
        self.data.volume
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_readme_box() {
        let t = "x\nThe (tight) bounding box for the templeRing model is\n(-0.023121 -0.038009 -0.091940)\n(0.078626 0.121636 -0.017395)\n";
        let b = readme_box(t).unwrap();
        assert_eq!(b.min, Point3::new(-0.023121, -0.038009, -0.091940));
        assert_eq!(b.max, Point3::new(0.078626, 0.121636, -0.017395));
        assert!(readme_box("no box here").is_none());
        assert!(readme_box("bounding box\n(1 2)\n(3 4 5)\n").is_none());
    }
}
