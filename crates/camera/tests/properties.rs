//! Property tests: round trips of projection, distortion, decomposition and interpolation,
//! and parsers that never panic.

use aibr_camera::readers::{parse_middlebury_par, parse_projection_matrices};
use aibr_camera::turntable::CalibratedPose;
use aibr_camera::{
    Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange, PoseInterpolation,
    PoseTable, compose_projection, decompose_projection,
};
use nalgebra::{Isometry3, Point2, Point3, Vector3};
use proptest::prelude::*;

/// The OpenCV sample lens at 640x480 (k1 -0.27, k2 -0.04, k3 0.24).
fn webcam(pose: Isometry3<f64>) -> Camera {
    Camera {
        intrinsics: Intrinsics::new(536.0, 536.0, 342.3, 235.5),
        distortion: Distortion {
            k1: -0.27,
            k2: -0.04,
            p1: 0.0018,
            p2: -0.0003,
            k3: 0.24,
        },
        cam_from_world: pose,
        size: ImageSize::new(640, 480),
    }
}

fn pose_strategy() -> impl Strategy<Value = Isometry3<f64>> {
    (
        prop::array::uniform3(-2.0..2.0f64),
        prop::array::uniform3(-3.0..3.0f64),
    )
        .prop_map(|(t, r)| Isometry3::new(Vector3::from(t), Vector3::from(r)))
}

fn intrinsics_strategy() -> impl Strategy<Value = Intrinsics> {
    (
        100.0..3000.0f64,
        0.8..1.25f64,
        0.0..800.0f64,
        0.0..600.0f64,
        -5.0..5.0f64,
    )
        .prop_map(|(fx, aspect, cx, cy, skew)| Intrinsics {
            fx,
            fy: fx * aspect,
            cx,
            cy,
            skew,
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// Any pixel of the image, to the corners, unprojects to a ray that projects back to it.
    #[test]
    fn unproject_then_project(u in -0.5..639.49f64, v in -0.5..479.49f64, depth in 0.05..20.0f64,
                              pose in pose_strategy()) {
        let cam = webcam(pose);
        let px = Point2::new(u, v);
        let p = cam.unproject(px, depth);
        prop_assert!(p.is_some(), "no ray for {px}");
        let p = p.unwrap_or_else(Point3::origin);
        prop_assert!((cam.depth_of(&p) - depth).abs() < 1e-9 * depth.max(1.0));
        let back = cam.project(&p);
        prop_assert!(back.is_some_and(|b| (b - px).norm() < 1e-7), "{px} -> {back:?}");
    }

    /// Project a point in front of the camera, then unproject at its depth.
    #[test]
    fn project_then_unproject(x in -1.0..1.0f64, y in -0.7..0.7f64, z in 0.1..10.0f64,
                              k in intrinsics_strategy(), pose in pose_strategy()) {
        let cam = Camera { intrinsics: k, distortion: Distortion::NONE, cam_from_world: pose,
                           size: ImageSize::new(800, 600) };
        let p_world = pose.inverse_transform_point(&Point3::new(x * z, y * z, z));
        let px = cam.project(&p_world);
        prop_assert!(px.is_some());
        let back = px.and_then(|px| cam.unproject(px, z));
        prop_assert!(back.is_some_and(|b| (b - p_world).norm() < 1e-9 * (1.0 + p_world.coords.norm())));
    }

    /// Distort then undistort, over the whole field of view of the OpenCV sample lens.
    #[test]
    fn distort_then_undistort(x in -0.95..0.95f64, y in -0.7..0.7f64,
                              p1 in -0.003..0.003f64, p2 in -0.003..0.003f64) {
        let d = Distortion { k1: -0.27, k2: -0.04, p1, p2, k3: 0.24 };
        let p = Point2::new(x, y);
        let back = d.undistort(d.distort(p));
        prop_assert!(back.is_some_and(|b| (b - p).norm() < 1e-11), "{p} -> {back:?}");
    }

    /// Decompose then compose gives P back, for any scale and sign.
    #[test]
    fn decompose_then_compose(k in intrinsics_strategy(), pose in pose_strategy(),
                              scale in prop_oneof![0.001..1000.0f64, -1000.0..-0.001f64]) {
        let p = compose_projection(&k, &pose) * scale;
        let d = decompose_projection(&p);
        prop_assert!(d.is_ok());
        let Ok(d) = d else { return Ok(()) };
        prop_assert!(d.intrinsics.fx > 0.0 && d.intrinsics.fy > 0.0);
        prop_assert!(d.cam_from_world.rotation.to_rotation_matrix().matrix().determinant() > 0.0);
        let again = compose_projection(&d.intrinsics, &d.cam_from_world) * d.scale;
        prop_assert!((again - p).norm() < 1e-9 * p.norm());
        prop_assert!((d.intrinsics.fx - k.fx).abs() < 1e-7 * k.fx);
        prop_assert!((d.intrinsics.skew - k.skew).abs() < 1e-6);
    }

    /// Between two calibrated poses, slerp interpolation starts and ends at them and the
    /// camera's pan angle grows monotonically along the arc.
    #[test]
    fn slerp_end_points_and_monotone(start in -150.0..100.0f64, step in 5.0..45.0f64,
                                     radius in 0.2..2.0f64, height in 0.0..1.0f64) {
        let ring = CircularMotion::ring(radius, height, 0.0);
        prop_assert!(ring.is_ok());
        let Ok(ring) = ring else { return Ok(()) };
        let entries: Vec<_> = (0..3).map(|i| {
            let pan = Angle::from_degrees(start + step * i as f64);
            CalibratedPose { pan, cam_from_world: ring.cam_from_world(pan) }
        }).collect();
        let table = PoseTable::new(entries.clone(), PanRange::full_turn());
        prop_assert!(table.is_ok());
        let Ok(table) = table else { return Ok(()) };
        for e in &entries {
            let p = table.cam_from_world_with(e.pan, PoseInterpolation::Slerp);
            prop_assert!(p.is_ok_and(|p| (p.to_homogeneous() - e.cam_from_world.to_homogeneous()).norm() < 1e-9));
        }
        // Pan angle of the interpolated camera centre: azimuth decreases as pan increases.
        let mut previous = f64::NEG_INFINITY;
        for i in 0..=20 {
            let pan = Angle::from_degrees(start + step * i as f64 / 20.0);
            let p = table.cam_from_world_with(pan, PoseInterpolation::Slerp);
            prop_assert!(p.is_ok());
            let Ok(p) = p else { return Ok(()) };
            let c = p.inverse_transform_point(&Point3::origin());
            let recovered = Angle::from_radians(-std::f64::consts::FRAC_PI_2 - c.y.atan2(c.x));
            let unwrapped = start.to_radians() + recovered.wrapped_difference(Angle::from_degrees(start)).radians();
            prop_assert!(unwrapped > previous - 1e-12, "not monotone at step {i}");
            previous = unwrapped;
        }
    }

    /// The parsers return errors, never panic, on arbitrary text.
    #[test]
    fn parsers_never_panic(text in "\\PC*") {
        let _ = parse_middlebury_par(&text, "arbitrary");
        let _ = parse_projection_matrices(&text, "arbitrary");
    }

    /// Numeric-looking garbage too (more likely to get deep into the parsers).
    #[test]
    fn parsers_never_panic_on_numbers(fields in prop::collection::vec(
        prop_oneof![Just("nan".to_string()), Just("inf".to_string()), Just("\n".to_string()),
                    Just("x.png".to_string()), (-1e3..1e3f64).prop_map(|v| v.to_string())], 0..60)) {
        let text = fields.join(" ");
        let _ = parse_middlebury_par(&text, "numbers");
        let _ = parse_middlebury_par(&format!("1\n{text}"), "numbers");
        let _ = parse_projection_matrices(&text, "numbers");
    }

    /// Writing Middlebury par lines and parsing them gives the cameras back.
    #[test]
    fn par_round_trip(cams in prop::collection::vec((intrinsics_strategy(), pose_strategy()), 1..6)) {
        let mut text = format!("{}\n", cams.len());
        for (i, (k, pose)) in cams.iter().enumerate() {
            let k = Intrinsics { skew: 0.0, ..*k };
            let km = k.matrix();
            let r = pose.rotation.to_rotation_matrix();
            let t = pose.translation.vector;
            text += &format!("v{i}.png");
            for v in km.transpose().iter().chain(r.matrix().transpose().iter()).chain(t.iter()) {
                text += &format!(" {v:e}");
            }
            text += "\n";
        }
        let views = parse_middlebury_par(&text, "round trip");
        prop_assert!(views.is_ok(), "{views:?}");
        let Ok(views) = views else { return Ok(()) };
        for (v, (k, pose)) in views.iter().zip(&cams) {
            prop_assert!((v.intrinsics.fx - k.fx).abs() < 1e-9 * k.fx);
            prop_assert!((v.cam_from_world.to_homogeneous() - pose.to_homogeneous()).norm() < 1e-9);
        }
    }
}
