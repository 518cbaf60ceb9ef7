//! The scene model: objects with materials, lab-fixed lights, backdrop and environment, and
//! the default capture rig.

use aibr_camera::{
    Aabb, Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange,
};
use nalgebra::{Point3, Rotation3, Vector3};

use crate::error::{Error, Result};
use crate::rng::SplitMix64;
use crate::shape::{Hit, Shape};
use crate::texture::{Colour, Texture, fbm};

/// How a surface reflects light.
#[derive(Debug, Clone, PartialEq)]
pub enum Material {
    /// Lambertian with a solid texture.
    Matte {
        /// Albedo.
        texture: Texture,
    },
    /// Lambertian plus a Blinn-Phong highlight.
    Glossy {
        /// Albedo.
        texture: Texture,
        /// Strength of the highlight (0 to 1).
        specular: f32,
        /// Blinn-Phong exponent (larger is tighter).
        shininess: f32,
    },
    /// A perfect mirror, optionally tinted, reflecting the scene and the environment.
    Mirror {
        /// Per-channel reflectance (white for a plain mirror).
        tint: Colour,
    },
}

/// Samples of a scene's true surface to score a reconstruction against
/// ([`Scene::geometry_reference`]).
#[derive(Debug, Clone, PartialEq)]
pub struct GeometryReference {
    /// Points over the whole exposed surface, seen or not (for accuracy).
    pub exposed: Vec<Point3<f64>>,
    /// Points over the surface the rig's cameras see (for completeness).
    pub visible: Vec<Point3<f64>>,
}

/// A primitive with its material.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneObject {
    /// The shape, object frame.
    pub shape: Shape,
    /// The material.
    pub material: Material,
}

/// A point light fixed in the lab (it does not turn with the object).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Position in the lab frame, metres (see [`Scene`] for the lab frame).
    pub position_lab: Point3<f64>,
    /// Intensity per channel.
    pub colour: Colour,
}

/// Hemispherical sky light: irradiance blends from `down` (normals pointing down) to `up`
/// (normals pointing up). It depends only on the normal's Z, so it is the same at every pan
/// angle. No shadows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SkyLight {
    /// Irradiance on a surface facing up.
    pub up: Colour,
    /// Irradiance on a surface facing down.
    pub down: Colour,
}

/// What the camera sees where no object is: fixed in the lab, so it does not turn with the
/// object (every view sees the same backdrop, as on a real rig).
#[derive(Debug, Clone, PartialEq)]
pub enum Backdrop {
    /// Black, like the Middlebury sets.
    Black,
    /// One colour.
    Solid(Colour),
    /// Value noise over viewing directions between two colours.
    Noise {
        /// Colour at noise 0.
        low: Colour,
        /// Colour at noise 1.
        high: Colour,
        /// Angular feature size, radians.
        feature: f64,
        /// Seed.
        seed: u64,
    },
}

/// What mirrors reflect beyond the object: a textured room fixed in the lab.
#[derive(Debug, Clone, PartialEq)]
pub enum Environment {
    /// One colour in every direction.
    Solid(Colour),
    /// A studio: coloured wall panels by azimuth with fine vertical stripes, a bright
    /// ceiling and a floor of randomly coloured tiles. Strongly direction dependent, so a
    /// mirror's image changes quickly as the object turns: the stripes alternate every 3
    /// degrees of azimuth, the floor tiles are a tenth of the floor's depth below the object
    /// across, and a reflection turns twice as fast as the object, so a stripe's image lasts
    /// 1.5 degrees of turn.
    Studio,
    /// The studio with broad features only: its wall panels (45 degrees of azimuth each)
    /// without the stripes, its bands and ceiling, and floor tiles five times as large. A
    /// mirror's image of it changes about half as fast with the turn (after one degree of
    /// turn a quarter of a mirror's points have changed colour, against two thirds in the
    /// studio), so it is sampled better by denser views (`docs/scene.md`).
    BroadStudio,
}

/// The default capture rig of a scene: a camera on a ring above the object.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneRig {
    /// Pinhole intrinsics.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
    /// Image size.
    pub size: ImageSize,
    /// Camera pose as a function of pan angle.
    pub ring: CircularMotion,
    /// The pan range of the turntable (a PTU-46 covers about 318 degrees).
    pub pan_range: PanRange,
}

impl SceneRig {
    /// `n` pan angles spread evenly over the pan range, both limits included (one view: the
    /// middle of the range).
    pub fn uniform_pans(&self, n: usize) -> Vec<Angle> {
        let (min, span) = (self.pan_range.min(), self.pan_range.span());
        match n {
            0 => Vec::new(),
            1 => vec![min + span * 0.5],
            _ => (0..n)
                .map(|i| min + span * (i as f64 / (n - 1) as f64))
                .collect(),
        }
    }

    /// The rig camera at pan angle `pan`.
    pub fn camera(&self, pan: Angle) -> Result<Camera> {
        Ok(Camera::new(
            self.intrinsics,
            self.distortion,
            self.ring.cam_from_world(pan),
            self.size,
        )?)
    }
}

/// A synthetic turntable scene.
///
/// # Conventions
/// Objects live in the world (turntable, object) frame: Z up along the pan axis, the
/// turntable surface at `z = 0`. Lights, backdrop and environment are fixed in the **lab**:
/// the frame that coincides with the world frame at pan 0 and stays with the camera as the
/// object turns. A render at a camera whose centre has azimuth `phi` is taken at pan angle
/// `theta = -pi/2 - phi` (the convention of `aibr-camera`), and the lab is the world frame
/// turned by `theta` about Z. So a highlight or a reflection slides over the object as it
/// turns, and the backdrop stays where it is.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Name (for catalogue scenes, the name `by_name` takes).
    pub name: String,
    /// The objects.
    pub objects: Vec<SceneObject>,
    /// Point lights, lab frame.
    pub lights: Vec<Light>,
    /// Sky light.
    pub sky: SkyLight,
    /// Backdrop.
    pub backdrop: Backdrop,
    /// Environment seen in mirrors.
    pub environment: Environment,
    /// The default rig.
    pub rig: SceneRig,
    /// Bounds of the objects (tight).
    object_bounds: Aabb,
}

/// The nearest object hit along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHit {
    /// The intersection.
    pub hit: Hit,
    /// Index of the object hit.
    pub object: usize,
}

/// Rays start this far off a surface (metres) so that they do not hit it again.
pub const SURFACE_EPSILON: f64 = 1e-7;
/// Mirror reflections followed at most this many times.
pub const MAX_BOUNCES: u32 = 4;

impl Scene {
    /// A scene; rejects an empty object list.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        name: impl Into<String>,
        objects: Vec<SceneObject>,
        lights: Vec<Light>,
        sky: SkyLight,
        backdrop: Backdrop,
        environment: Environment,
        rig: SceneRig,
    ) -> Result<Self> {
        let name = name.into();
        let object_bounds = objects
            .iter()
            .map(|o| o.shape.bounds())
            .reduce(|a, b| a.union(&b))
            .ok_or_else(|| Error::EmptyScene(name.clone()))?;
        Ok(Scene {
            name,
            objects,
            lights,
            sky,
            backdrop,
            environment,
            rig,
            object_bounds,
        })
    }

    /// Tight bounds of all objects.
    pub fn object_bounds(&self) -> Aabb {
        self.object_bounds
    }

    /// The ground-truth reconstruction volume: the object bounds grown by 5 mm on every
    /// side, so a voxel grid over it holds the whole object with a margin of empty space.
    pub fn bounds(&self) -> Aabb {
        self.object_bounds.expanded(0.005)
    }

    /// The default rig camera at pan angle `pan`.
    pub fn camera(&self, pan: Angle) -> Result<Camera> {
        self.rig.camera(pan)
    }

    /// The nearest object along `origin + t dir`, `t` in `(t_min, t_max)`.
    pub fn first_hit(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        t_min: f64,
        t_max: f64,
    ) -> Option<SceneHit> {
        let (enter, exit) = aibr_camera::aabb::slab(
            &self.object_bounds.min,
            &self.object_bounds.max,
            origin,
            dir,
        )?;
        if exit <= t_min || enter >= t_max {
            return None;
        }
        let mut best: Option<SceneHit> = None;
        let mut limit = t_max;
        for (i, o) in self.objects.iter().enumerate() {
            if let Some(hit) = o.shape.intersect(origin, dir, t_min, limit) {
                limit = hit.t;
                best = Some(SceneHit { hit, object: i });
            }
        }
        best
    }

    /// True when something lies on the segment `from + t dir`, `t` in `(t_min, t_max)`.
    pub fn occluded(&self, from: &Point3<f64>, dir: &Vector3<f64>, t_min: f64, t_max: f64) -> bool {
        let Some((enter, exit)) =
            aibr_camera::aabb::slab(&self.object_bounds.min, &self.object_bounds.max, from, dir)
        else {
            return false;
        };
        if exit <= t_min || enter >= t_max {
            return false;
        }
        self.objects
            .iter()
            .any(|o| o.shape.intersect(from, dir, t_min, t_max).is_some())
    }

    /// True when `p` lies inside some object by more than `eps`.
    pub fn inside(&self, p: &Point3<f64>, eps: f64) -> bool {
        self.objects.iter().any(|o| o.shape.contains(p, eps))
    }

    /// Points spread uniformly over the surface that the rig can see: sampled by area over
    /// all objects, then kept only when they lie inside no other object and at least one of
    /// 72 rig cameras spread over the pan range sees them unoccluded. Deterministic for a
    /// given `seed`. Each sample comes with its outward normal.
    pub fn surface_samples(
        &self,
        count: usize,
        seed: u64,
    ) -> Result<Vec<(Point3<f64>, Vector3<f64>)>> {
        let cameras: Vec<Camera> = self
            .rig
            .uniform_pans(72)
            .into_iter()
            .map(|pan| self.camera(pan))
            .collect::<Result<_>>()?;
        Ok(self.sample_surface(count, seed, Some(&cameras)))
    }

    /// Points spread uniformly over the whole exposed surface (inside no other object),
    /// seen or not: the reference surface for the accuracy of a reconstruction.
    pub fn exposed_surface_samples(
        &self,
        count: usize,
        seed: u64,
    ) -> Vec<(Point3<f64>, Vector3<f64>)> {
        self.sample_surface(count, seed, None)
    }

    /// The true surface the project scores reconstructions of this scene against
    /// (`aibr_voxel::metrics::geometry_score`): 400,000 points over the whole exposed surface
    /// ([`Scene::exposed_surface_samples`], seed 7) for accuracy and 50,000 over the part the
    /// rig sees ([`Scene::surface_samples`], seed 8) for completeness. The geometry figures
    /// of `docs/results.md` are measured against it. Deterministic.
    pub fn geometry_reference(&self) -> Result<GeometryReference> {
        self.geometry_reference_of(400_000, 50_000)
    }

    /// [`Scene::geometry_reference`] with `exposed` and `visible` points (the same seeds),
    /// for checks that can do with fewer.
    pub fn geometry_reference_of(
        &self,
        exposed: usize,
        visible: usize,
    ) -> Result<GeometryReference> {
        let points = |s: Vec<(Point3<f64>, Vector3<f64>)>| s.into_iter().map(|(p, _)| p).collect();
        Ok(GeometryReference {
            exposed: points(self.exposed_surface_samples(exposed, 7)),
            visible: points(self.surface_samples(visible, 8)?),
        })
    }

    fn sample_surface(
        &self,
        count: usize,
        seed: u64,
        cameras: Option<&[Camera]>,
    ) -> Vec<(Point3<f64>, Vector3<f64>)> {
        let areas: Vec<f64> = self.objects.iter().map(|o| o.shape.area()).collect();
        let total: f64 = areas.iter().sum();
        let mut rng = SplitMix64::new(seed);
        let mut out = Vec::with_capacity(count);
        // Hidden samples are rejected: bound the work even if most of the surface is hidden.
        let mut attempts = 0usize;
        while out.len() < count && attempts < 50 * count.max(1) {
            attempts += 1;
            let mut pick = rng.uniform() * total;
            let mut index = areas.len() - 1;
            for (i, a) in areas.iter().enumerate() {
                if pick < *a {
                    index = i;
                    break;
                }
                pick -= a;
            }
            let (p, n) = self.objects[index].shape.sample_surface(&mut rng);
            if self.inside(&p, 1e-6) {
                continue;
            }
            let Some(cameras) = cameras else {
                out.push((p, n));
                continue;
            };
            let seen = cameras.iter().any(|cam| {
                let c = cam.centre();
                let to_cam = c - p;
                to_cam.dot(&n) > 0.0
                    && cam.project(&p).is_some_and(|px| cam.size.contains(px))
                    && !self.occluded(&(p + n * 1e-6), &to_cam, 1e-9, 1.0)
            });
            if seen {
                out.push((p, n));
            }
        }
        out
    }

    /// The lab-from-world rotation for a camera (see the conventions above).
    pub(crate) fn lab_from_world(camera: &Camera) -> Rotation3<f64> {
        let c = camera.centre();
        let pan = if c.x == 0.0 && c.y == 0.0 {
            0.0
        } else {
            -std::f64::consts::FRAC_PI_2 - c.y.atan2(c.x)
        };
        Rotation3::from_axis_angle(&Vector3::z_axis(), pan)
    }

    /// The backdrop colour for a unit direction in the lab frame.
    pub(crate) fn backdrop_colour(&self, dir_lab: &Vector3<f64>) -> Colour {
        match &self.backdrop {
            Backdrop::Black => Colour::zeros(),
            Backdrop::Solid(c) => *c,
            Backdrop::Noise {
                low,
                high,
                feature,
                seed,
            } => {
                let t = fbm(&(dir_lab / *feature), 3, *seed) as f32;
                low + (high - low) * t
            }
        }
    }

    /// The environment colour for a unit direction in the lab frame.
    pub(crate) fn environment_colour(&self, d: &Vector3<f64>) -> Colour {
        match &self.environment {
            Environment::Solid(c) => *c,
            Environment::Studio => studio(d, false),
            Environment::BroadStudio => studio(d, true),
        }
    }
}

/// Colours of the studio's wall panels and floor tiles.
const STUDIO_PALETTE: [[f32; 3]; 8] = [
    [0.85, 0.2, 0.15],
    [0.95, 0.75, 0.2],
    [0.2, 0.65, 0.3],
    [0.15, 0.45, 0.85],
    [0.6, 0.25, 0.75],
    [0.9, 0.5, 0.6],
    [0.3, 0.8, 0.8],
    [0.5, 0.35, 0.2],
];

/// The procedural studio of [`Environment::Studio`], or with `broad` of
/// [`Environment::BroadStudio`].
fn studio(d: &Vector3<f64>, broad: bool) -> Colour {
    if d.z < -0.02 {
        // Floor: tiles of random palette colours on the plane one unit below.
        let s = -1.0 / d.z;
        let tile_m = if broad { 0.5 } else { 0.1 };
        let (x, y) = (
            (d.x * s / tile_m).floor() as i64,
            (d.y * s / tile_m).floor() as i64,
        );
        let tile = crate::rng::hash3(x, y, 0, 0x57D10) % 8;
        let fade = (1.0 / (1.0 + 0.05 * s)) as f32;
        return Colour::from(STUDIO_PALETTE[tile as usize]) * (0.8 * fade);
    }
    if d.z > 0.75 {
        return Colour::new(0.95, 0.95, 0.9);
    }
    let phi = d.y.atan2(d.x) + std::f64::consts::PI;
    let panel = ((phi / std::f64::consts::TAU * 8.0) as usize).min(7);
    let stripe = if broad {
        1.0
    } else {
        0.75 + 0.25 * (phi * 60.0).sin().signum() as f32
    };
    let band = if (d.z * 12.0).floor() as i64 % 2 == 0 {
        1.0
    } else {
        0.8
    };
    Colour::from(STUDIO_PALETTE[panel]) * stripe * band
}
