//! Camera models for turntable capture.
//!
//! aibr-camera holds the geometry every other aibr crate builds on:
//!
//! - [`Intrinsics`] (fx, fy, cx, cy, skew) and [`Distortion`] (Brown-Conrady, k1 k2 p1 p2 k3
//!   in Bouguet/OpenCV order), joined with a pose and an image size in [`Camera`]: project a
//!   world point to a pixel, or a pixel back to a ray with a Newton undistortion that
//!   converges to the corners of real webcam images;
//! - [`UndistortMap`]: undistortion of whole images by a bilinear remap built once per camera;
//! - [`decompose_projection`] / [`compose_projection`]: `P = K [R | t]` by RQ decomposition;
//! - the turntable pose model: [`CircularMotion`] (the pose at any pan angle from an axis and
//!   the pose at pan 0, fitted to calibrated poses by least squares) and [`PoseTable`] (poses
//!   calibrated at a few pan angles, interpolated along the fitted circle), over a
//!   [`PanRange`] with limits;
//! - [`fit_ring`]: the turntable frame of a dataset whose cameras lie on a ring;
//! - [`Aabb`]: axis-aligned boxes (reconstruction volumes, ground-truth bounds);
//! - [`readers`]: Middlebury `*_par.txt` / `*_ang.txt` and files of 3x4 matrices.
//!
//! ```
//! use aibr_camera::{Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics};
//! use nalgebra::Point3;
//!
//! // A webcam 0.6 m from the pan axis and 0.3 m above the turntable, looking at its centre.
//! let ring = CircularMotion::ring(0.6, 0.3, 0.0)?;
//! let lens = Distortion { k1: -0.27, k2: -0.04, p1: 0.0, p2: 0.0, k3: 0.24 };
//! let camera = Camera::new(
//!     Intrinsics::new(536.0, 536.0, 319.5, 239.5),
//!     lens,
//!     ring.cam_from_world(Angle::from_degrees(30.0)),
//!     ImageSize::new(640, 480),
//! )?;
//! // The axis point at turntable height 0 is seen at the principal point...
//! let px = camera.project(&Point3::origin()).ok_or("behind the camera")?;
//! assert!((px.x - 319.5).abs() < 1e-9 && (px.y - 239.5).abs() < 1e-9);
//! // ...and a pixel's ray leads back to the point.
//! let corner = nalgebra::Point2::new(0.0, 0.0);
//! let ray = camera.ray_through_pixel(corner).ok_or("no ray")?;
//! let back = camera.project(&ray.at(0.5)).ok_or("behind the camera")?;
//! assert!((back - corner).norm() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! - **World frame = turntable (object) frame**: Z is the pan axis, pointing up toward the
//!   cameras; the origin is on the axis. Positive pan turns the object counter-clockwise seen
//!   from above; the camera at pan 0 of an ideal [`CircularMotion::ring`] sits on the -Y side
//!   with world +X to the right of its image.
//! - **Camera frame**: OpenCV optical, x right, y down, z forward.
//! - **Poses** are named by the frames they map: `cam_from_world` maps world points into the
//!   camera frame (`p_cam = R p_world + t`).
//! - **Units**: metres and radians ([`Angle`] carries angles in public APIs); pixels for
//!   intrinsics.
//! - **Pixels**: `(0, 0)` is the centre of the top-left pixel; the image covers
//!   `[-0.5, w - 0.5) x [-0.5, h - 0.5)`.
//! - Geometry is `f64` throughout.

pub mod aabb;
pub mod angle;
pub mod camera;
pub mod distortion;
pub mod error;
pub mod intrinsics;
pub mod projection;
pub mod readers;
pub mod ring;
pub mod turntable;
pub mod undistort;

pub use aabb::Aabb;
pub use angle::{Angle, PanRange};
pub use camera::{Camera, Ray};
pub use distortion::Distortion;
pub use error::{Error, ParseErrorKind, Result};
pub use intrinsics::{ImageSize, Intrinsics};
pub use projection::{DecomposedProjection, compose_projection, decompose_projection};
pub use ring::{RingFit, fit_ring};
pub use turntable::{
    CalibratedPose, CircularFit, CircularMotion, PoseInterpolation, PoseResidual, PoseTable,
    TurntableAxis, look_at, nearest_rotation,
};
pub use undistort::UndistortMap;
