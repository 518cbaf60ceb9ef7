//! The rig: a turntable that pans and a camera that takes frames, joined to the algorithms by
//! a calibration; and the synthetic rig over aibr-scene.

use aibr_camera::{Aabb, Angle, Camera, CircularMotion, PanRange};
use aibr_scene::{RenderOptions, Scene};
use image::{GrayImage, RgbImage};

use crate::error::{Error, Result};

/// A turntable: moves to a pan angle and reports the angle it reached.
pub trait Turntable {
    /// Moves to `pan` (inside [`range`](Self::range)) and waits until it has settled;
    /// returns the angle actually reached (the unit moves in whole steps).
    fn move_to(&mut self, pan: Angle) -> Result<Angle>;
    /// The pan range the unit can reach.
    fn range(&self) -> PanRange;
    /// The angle of one step.
    fn step(&self) -> Angle;
    /// The pans a move can still reach, when the unit reaches only some: a
    /// [`ReplayRig`](crate::ReplayRig) returns recorded views only, and the capture loop
    /// then plans among them. `None` (the default) when any whole step of the range can.
    fn reachable(&self) -> Option<Vec<Angle>> {
        None
    }
}

/// A captured frame, with its foreground mask when the source knows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// The image (undistorted: the calibration's camera has no distortion).
    pub image: RgbImage,
    /// The object mask, if the source knows it (a synthetic rig does).
    pub mask: Option<GrayImage>,
}

/// A camera that takes a frame after the turntable has settled.
pub trait FrameSource {
    /// A frame taken now.
    fn capture(&mut self) -> Result<Frame>;

    /// Told the angle the turntable reached before each capture. A real camera sees the
    /// turn and ignores this; a synthetic one renders its scene at that angle.
    fn turntable_at(&mut self, _pan: Angle) {}

    /// The true reconstruction volume of what the camera sees, when it is synthetic.
    fn known_volume(&self) -> Option<Aabb> {
        None
    }

    /// Settings to record in the session with the views (a webcam's exposure, white balance
    /// and gain).
    fn settings(&self) -> Option<serde_json::Value> {
        None
    }
}

/// A rig made of a turntable and a camera from different sources (for example the PTU-46
/// turning a synthetic scene): the camera is told every angle the turntable reaches.
#[derive(Debug)]
pub struct Rig<T, C> {
    /// The turntable.
    pub turntable: T,
    /// The camera.
    pub camera: C,
}

impl<T: Turntable, C: FrameSource> Turntable for Rig<T, C> {
    fn move_to(&mut self, pan: Angle) -> Result<Angle> {
        let reached = self.turntable.move_to(pan)?;
        self.camera.turntable_at(reached);
        Ok(reached)
    }

    fn range(&self) -> PanRange {
        self.turntable.range()
    }

    fn step(&self) -> Angle {
        self.turntable.step()
    }

    fn reachable(&self) -> Option<Vec<Angle>> {
        self.turntable.reachable()
    }
}

impl<T, C: FrameSource> FrameSource for Rig<T, C> {
    fn capture(&mut self) -> Result<Frame> {
        self.camera.capture()
    }

    fn known_volume(&self) -> Option<Aabb> {
        self.camera.known_volume()
    }

    fn settings(&self) -> Option<serde_json::Value> {
        self.camera.settings()
    }
}

/// The camera model and the pose model that map a reached pan angle to a camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    /// Intrinsics, distortion and size (its pose is ignored).
    pub camera: Camera,
    /// The camera pose as a function of pan angle, in the turntable frame.
    pub motion: CircularMotion,
}

impl Calibration {
    /// The camera at pan angle `pan`.
    pub fn camera_at(&self, pan: Angle) -> Camera {
        self.camera.with_pose(self.motion.cam_from_world(pan))
    }
}

/// A synthetic camera: a catalogue scene rendered, with sensor noise, at the angle the
/// turntable reports.
///
/// The scene may stand turned on the turntable (`NAME@DEGREES`, e.g. `mirror@20`): the
/// object is then turned that far about the pan axis from where the catalogue puts it, so
/// that at every reported pan the camera, the lights and the studio see it as the catalogue
/// scene at that pan plus the turn. Its geometry stays in the scene's world frame (only the
/// calibration's pose at pan 0 moves), so it is measured against the same truth; what
/// changes is where the object's faces lie against the pan range's ends and the lattices of
/// uniform capture.
pub struct SceneCamera {
    scene: Scene,
    name: String,
    turn: Angle,
    pan: Angle,
    /// The angle whose multiples seed the noise (a frame's noise depends on its step).
    seed_step: Angle,
    options: RenderOptions,
}

impl std::fmt::Debug for SceneCamera {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SceneCamera")
            .field("scene", &self.name)
            .field("pan", &self.pan)
            .finish_non_exhaustive()
    }
}

impl SceneCamera {
    /// The camera of catalogue scene `name` (`SCENE` or `SCENE@DEGREES`, the scene turned on
    /// the turntable by that many degrees, -180 to 180), with 1 grey level of sensor noise;
    /// each frame's noise is seeded by its pan angle in multiples of `seed_step`, so a run is
    /// repeatable.
    pub fn new(name: &str, seed_step: Angle) -> Result<Self> {
        let (scene_name, turn) = match name.split_once('@') {
            None => (name, Angle::ZERO),
            Some((scene_name, degrees)) => {
                let turn = degrees
                    .parse::<f64>()
                    .ok()
                    .filter(|d| (-180.0..=180.0).contains(d))
                    .ok_or_else(|| Error::InvalidParameter {
                        name: "scene turn",
                        reason: format!(
                            "{degrees:?} in {name:?} is not a number of degrees from -180 to 180"
                        ),
                    })?;
                (scene_name, Angle::from_degrees(turn))
            }
        };
        let scene = aibr_scene::catalogue::by_name(scene_name)?;
        Ok(SceneCamera {
            scene,
            name: name.to_owned(),
            turn,
            pan: Angle::ZERO,
            seed_step,
            options: RenderOptions {
                noise_sigma: 1.0 / 255.0,
                seed: 0,
            },
        })
    }

    /// Parses `sim:SCENE` or `sim:SCENE@DEGREES` (see [`SceneCamera::new`]).
    pub fn from_spec(spec: &str, seed_step: Angle) -> Result<Self> {
        let name = spec
            .strip_prefix("sim:")
            .ok_or_else(|| Error::UnknownRig(spec.to_owned()))?;
        Self::new(name, seed_step).map_err(|e| match e {
            // A bad turn names itself; anything else is a scene not in the catalogue.
            Error::InvalidParameter { .. } => e,
            _ => Error::UnknownRig(spec.to_owned()),
        })
    }

    /// The scene's name as given (with its turn, if any).
    pub fn scene_name(&self) -> &str {
        &self.name
    }

    /// How far the scene stands turned on the turntable.
    pub fn turn(&self) -> Angle {
        self.turn
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The camera's calibration (exact: it is synthetic).
    pub fn calibration(&self) -> Result<Calibration> {
        let ring = self.scene.rig.ring;
        Ok(Calibration {
            camera: self.scene.camera(self.turn)?,
            motion: CircularMotion {
                cam_from_world_at_zero: ring.cam_from_world(self.turn),
                ..ring
            },
        })
    }
}

impl FrameSource for SceneCamera {
    fn capture(&mut self) -> Result<Frame> {
        let camera = self.scene.camera(self.pan + self.turn)?;
        // Each frame its own noise, the same for the same pan angle in every run.
        let seed = (self.pan.radians() / self.seed_step.radians()).round() as i64 as u64;
        let frame = self.scene.render(
            &camera,
            &RenderOptions {
                seed: seed ^ self.options.seed,
                ..self.options
            },
        )?;
        Ok(Frame {
            image: frame.rgb8(),
            mask: Some(frame.mask),
        })
    }

    fn turntable_at(&mut self, pan: Angle) {
        self.pan = pan;
    }

    fn known_volume(&self) -> Option<Aabb> {
        Some(self.scene.bounds())
    }
}

/// The synthetic rig: a catalogue scene on a turntable with the resolution of a PTU-46
/// (185.1428 arc seconds a step) and its pan range, rendering at the angle it reached.
#[derive(Debug)]
pub struct SimRig {
    camera: SceneCamera,
    pan: Angle,
    step: Angle,
}

/// The step of a PTU-46 at its default resolution.
pub fn ptu46_step() -> Angle {
    Angle::from_degrees(185.1428 / 3600.0)
}

impl SimRig {
    /// The synthetic rig of catalogue scene `name` (`SCENE` or `SCENE@DEGREES`, turned on the
    /// turntable: [`SceneCamera::new`]), with 1 grey level of sensor noise.
    pub fn new(name: &str) -> Result<Self> {
        Ok(SimRig {
            camera: SceneCamera::new(name, ptu46_step())?,
            pan: Angle::ZERO,
            step: ptu46_step(),
        })
    }

    /// Parses `sim:SCENE` or `sim:SCENE@DEGREES` (see [`SceneCamera::new`]).
    pub fn from_spec(spec: &str) -> Result<Self> {
        Ok(SimRig {
            camera: SceneCamera::from_spec(spec, ptu46_step())?,
            pan: Angle::ZERO,
            step: ptu46_step(),
        })
    }

    /// The scene's name.
    pub fn scene_name(&self) -> &str {
        self.camera.scene_name()
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        self.camera.scene()
    }

    /// How far the scene stands turned on the turntable (`SCENE@DEGREES`; zero otherwise).
    pub fn turn(&self) -> Angle {
        self.camera.turn()
    }

    /// The rig's calibration (exact: it is synthetic).
    pub fn calibration(&self) -> Result<Calibration> {
        self.camera.calibration()
    }

    /// The scene's ground-truth reconstruction volume.
    pub fn volume(&self) -> Aabb {
        self.scene().bounds()
    }
}

impl Turntable for SimRig {
    fn move_to(&mut self, pan: Angle) -> Result<Angle> {
        let reached = self.scene().rig.pan_range.check(pan)?;
        let steps = (reached.radians() / self.step.radians()).round();
        self.pan = Angle::from_radians(steps * self.step.radians());
        self.camera.turntable_at(self.pan);
        Ok(self.pan)
    }

    fn range(&self) -> PanRange {
        self.scene().rig.pan_range
    }

    fn step(&self) -> Angle {
        self.step
    }
}

impl FrameSource for SimRig {
    fn capture(&mut self) -> Result<Frame> {
        self.camera.capture()
    }

    fn known_volume(&self) -> Option<Aabb> {
        self.camera.known_volume()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mean absolute difference of two images, grey levels.
    fn mean_difference(a: &RgbImage, b: &RgbImage) -> f64 {
        let sum: f64 = a
            .as_raw()
            .iter()
            .zip(b.as_raw())
            .map(|(x, y)| f64::from(x.abs_diff(*y)))
            .sum();
        sum / a.as_raw().len() as f64
    }

    #[test]
    fn a_turned_scene_is_the_scene_seen_further_round()
    -> std::result::Result<(), Box<dyn std::error::Error>> {
        let shot = |name: &str, pan: f64| -> Result<Frame> {
            let mut rig = SimRig::new(name)?;
            let reached = rig.move_to(Angle::from_degrees(pan))?;
            let calibration = rig.calibration()?;
            let frame = rig.capture()?;
            // The calibration places the camera where the scene's own camera is, turned.
            let expected = rig.scene().camera(reached + rig.camera.turn())?;
            let got = calibration.camera_at(reached);
            let (e, g) = (expected.cam_from_world, got.cam_from_world);
            assert!((e.translation.vector - g.translation.vector).norm() < 1e-12);
            assert!(e.rotation.angle_to(&g.rotation) < 1e-12);
            Ok(frame)
        };
        let turned = shot("mirror@20", 40.0)?;
        let same = shot("mirror", 60.0)?;
        let unturned = shot("mirror", 40.0)?;
        // The same image but for the sensor noise (1 grey level, seeded by the pan) and for
        // each pan's rounding to whole steps (up to half a step, 0.026 degrees, apart).
        let near = mean_difference(&turned.image, &same.image);
        assert!(near < 1.5, "{near}");
        let (a, b) = (turned.mask.ok_or("no mask")?, same.mask.ok_or("no mask")?);
        let differ = a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count();
        assert!(differ < 200, "{differ} mask pixels differ");
        let far = mean_difference(&turned.image, &unturned.image);
        assert!(far > 5.0 * near, "{far} against {near}");
        Ok(())
    }

    #[test]
    fn a_bad_turn_is_refused_naming_it() {
        for bad in ["mirror@", "mirror@ten", "mirror@200", "mirror@NaN"] {
            let err = SimRig::new(bad).err().map(|e| e.to_string());
            let degrees = bad.split_once('@').map_or("", |(_, d)| d);
            assert!(
                err.as_deref().is_some_and(
                    |e| e.contains("scene turn") && e.contains(&format!("{degrees:?}"))
                ),
                "{bad}: {err:?}"
            );
        }
        assert!(SimRig::new("teapot@10").is_err());
        assert!(SimRig::new("mirror@-180").is_ok());
    }
}
