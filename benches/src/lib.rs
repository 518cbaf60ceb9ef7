//! Criterion benches of aibr, run with `cargo bench -p aibr-benches`.
//!
//! The benches live in `benches/benches/`; this library holds the fixtures they share.

use aibr_camera::{Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics, Result};

/// A VGA webcam with the OpenCV sample lens, on a ring 0.6 m from the axis and 0.3 m up,
/// at pan angle `pan`.
pub fn webcam_on_ring(pan: Angle) -> Result<Camera> {
    let ring = CircularMotion::ring(0.6, 0.3, 0.0)?;
    Camera::new(
        Intrinsics::new(536.0, 536.0, 342.3, 235.5),
        Distortion {
            k1: -0.27,
            k2: -0.04,
            p1: 0.0018,
            p2: -0.0003,
            k3: 0.24,
        },
        ring.cam_from_world(pan),
        ImageSize::new(640, 480),
    )
}

/// The voxel kernels' views of a synthetic scene's `shots`: each camera and image, with its
/// ground-truth mask.
pub fn views_of(shots: &[aibr_scene::Shot]) -> Vec<aibr_voxel::View<'_>> {
    shots
        .iter()
        .map(|s| aibr_voxel::View {
            camera: &s.camera,
            image: &s.image,
            mask: Some(&s.frame.mask),
        })
        .collect()
}
