//! A calibrated camera: intrinsics, distortion, pose and image size.

use nalgebra::{Isometry3, Matrix3x4, Point2, Point3, Unit, Vector3};

use crate::distortion::Distortion;
use crate::error::Result;
use crate::intrinsics::{ImageSize, Intrinsics};

/// A ray in the world frame: `origin + t * direction` for `t >= 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start of the ray (the camera centre for camera rays), metres.
    pub origin: Point3<f64>,
    /// Unit direction.
    pub direction: Unit<Vector3<f64>>,
}

impl Ray {
    /// The point at distance `t` along the ray.
    #[inline]
    pub fn at(&self, t: f64) -> Point3<f64> {
        self.origin + self.direction.into_inner() * t
    }
}

/// A camera: pinhole intrinsics, lens distortion, the pose `cam_from_world` and the image
/// size.
///
/// The camera frame is OpenCV's optical frame (x right, y down, z forward); `cam_from_world`
/// maps world (turntable) coordinates into it.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Pinhole intrinsics.
    pub intrinsics: Intrinsics,
    /// Lens distortion applied on the normalised image plane.
    pub distortion: Distortion,
    /// Maps world points into the camera frame.
    pub cam_from_world: Isometry3<f64>,
    /// Image size, pixels.
    pub size: ImageSize,
}

impl Camera {
    /// A camera; rejects invalid intrinsics or distortion and empty images.
    pub fn new(
        intrinsics: Intrinsics,
        distortion: Distortion,
        cam_from_world: Isometry3<f64>,
        size: ImageSize,
    ) -> Result<Self> {
        intrinsics.validate()?;
        distortion.validate()?;
        if size.width == 0 || size.height == 0 {
            return Err(crate::Error::InvalidParameter {
                name: "image size",
                value: size.pixel_count() as f64,
                reason: "width and height must be positive",
            });
        }
        Ok(Camera {
            intrinsics,
            distortion,
            cam_from_world,
            size,
        })
    }

    /// The same camera at another pose.
    pub fn with_pose(&self, cam_from_world: Isometry3<f64>) -> Self {
        Camera {
            cam_from_world,
            ..self.clone()
        }
    }

    /// The same camera without lens distortion (what an undistorted image shows).
    pub fn pinhole(&self) -> Self {
        Camera {
            distortion: Distortion::NONE,
            ..self.clone()
        }
    }

    /// `cam_from_world` inverted.
    pub fn world_from_cam(&self) -> Isometry3<f64> {
        self.cam_from_world.inverse()
    }

    /// Camera centre in the world frame, metres.
    pub fn centre(&self) -> Point3<f64> {
        self.cam_from_world
            .inverse_transform_point(&Point3::origin())
    }

    /// Direction of the optical axis (camera +z) in the world frame.
    pub fn viewing_direction(&self) -> Unit<Vector3<f64>> {
        Unit::new_unchecked(
            self.cam_from_world
                .rotation
                .inverse_transform_vector(&Vector3::z()),
        )
    }

    /// Depth of a world point along the optical axis (camera z), metres.
    #[inline]
    pub fn depth_of(&self, p_world: &Point3<f64>) -> f64 {
        self.cam_from_world.transform_point(p_world).z
    }

    /// Projects a world point to a pixel (with distortion); `None` if it is not in front of
    /// the camera (`z <= 0`). The pixel may lie outside the image: see [`ImageSize::contains`].
    #[inline]
    pub fn project(&self, p_world: &Point3<f64>) -> Option<Point2<f64>> {
        let pc = self.cam_from_world.transform_point(p_world);
        if !(pc.z > 0.0) {
            return None;
        }
        let n = Point2::new(pc.x / pc.z, pc.y / pc.z);
        Some(
            self.intrinsics
                .pixel_from_normalized(self.distortion.distort(n)),
        )
    }

    /// The undistorted point on the normalised image plane (`z = 1` in the camera frame)
    /// seen at `pixel`; `None` where the distortion model cannot be inverted.
    pub fn normalized_from_pixel(&self, pixel: Point2<f64>) -> Option<Point2<f64>> {
        self.distortion
            .undistort(self.intrinsics.normalized_from_pixel(pixel))
    }

    /// The world ray through `pixel`, from the camera centre; `None` where the distortion
    /// model cannot be inverted.
    pub fn ray_through_pixel(&self, pixel: Point2<f64>) -> Option<Ray> {
        let n = self.normalized_from_pixel(pixel)?;
        let dir_cam = Vector3::new(n.x, n.y, 1.0);
        let dir = self
            .cam_from_world
            .rotation
            .inverse_transform_vector(&dir_cam);
        Some(Ray {
            origin: self.centre(),
            direction: Unit::new_normalize(dir),
        })
    }

    /// The world point seen at `pixel` at optical-axis depth `depth` (metres).
    pub fn unproject(&self, pixel: Point2<f64>, depth: f64) -> Option<Point3<f64>> {
        let n = self.normalized_from_pixel(pixel)?;
        let pc = Point3::new(n.x * depth, n.y * depth, depth);
        Some(self.cam_from_world.inverse_transform_point(&pc))
    }

    /// The pinhole projection matrix `P = K [R | t]` (distortion is not representable in it).
    pub fn projection_matrix(&self) -> Matrix3x4<f64> {
        crate::projection::compose_projection(&self.intrinsics, &self.cam_from_world)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Translation3;

    fn camera() -> Result<Camera> {
        Camera::new(
            Intrinsics::new(500.0, 500.0, 320.0, 240.0),
            Distortion::NONE,
            Isometry3::from_parts(
                Translation3::new(0.0, 0.0, 2.0),
                nalgebra::UnitQuaternion::identity(),
            ),
            ImageSize::new(640, 480),
        )
    }

    #[test]
    fn centre_and_direction() -> Result<()> {
        let cam = camera()?;
        assert!((cam.centre() - Point3::new(0.0, 0.0, -2.0)).norm() < 1e-12);
        assert!((cam.viewing_direction().into_inner() - Vector3::z()).norm() < 1e-12);
        Ok(())
    }

    #[test]
    fn behind_is_none() -> Result<()> {
        let cam = camera()?;
        assert_eq!(cam.project(&Point3::new(0.0, 0.0, -3.0)), None);
        assert_eq!(
            cam.project(&Point3::origin()),
            Some(Point2::new(320.0, 240.0))
        );
        Ok(())
    }

    #[test]
    fn rejects_empty_image() {
        let c = camera().map(|c| {
            Camera::new(
                c.intrinsics,
                c.distortion,
                c.cam_from_world,
                ImageSize::new(0, 4),
            )
        });
        assert!(matches!(c, Ok(Err(_))));
    }
}
