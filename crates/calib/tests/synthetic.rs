//! Calibration on boards rendered by aibr-scene at known poses, with lens distortion and
//! sensor noise: the ground truth is known exactly.

// Test helpers too may stop a test loudly.
#![allow(clippy::panic)]

use aibr_calib::{
    BoardDetection, BoardSpec, DetectorParams, Error, IntrinsicOptions, PanView, Rejection,
    calibrate_intrinsics, calibrate_turntable, detect_board,
};
use aibr_camera::{
    Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange, look_at,
};
use aibr_scene::{RenderOptions, Scene, SceneRig};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

const SQUARE: f64 = 0.025;

fn truth_intrinsics() -> Intrinsics {
    Intrinsics::new(820.0, 815.0, 331.0, 244.0)
}

/// The OpenCV sample lens, scaled: strong barrel distortion.
fn truth_distortion() -> Distortion {
    Distortion {
        k1: -0.25,
        k2: 0.08,
        p1: 0.001,
        p2: -0.0005,
        k3: 0.0,
    }
}

/// A printed 9x6 board (10x7 squares on white paper) lying on the turntable centred on the
/// axis (aibr-scene's calibration target), and its board frame.
fn board_scene() -> (Scene, Isometry3<f64>) {
    let s = SQUARE;
    let rig = SceneRig {
        intrinsics: truth_intrinsics(),
        distortion: truth_distortion(),
        size: ImageSize::new(640, 480),
        ring: CircularMotion::ring(0.42, 0.42, 0.0).unwrap_or_else(|e| panic!("{e}")),
        pan_range: PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))
            .unwrap_or_else(|e| panic!("{e}")),
    };
    let scene =
        aibr_scene::catalogue::checkerboard(10, 7, s, rig).unwrap_or_else(|e| panic!("{e}"));
    // Squares (i, j) from (-5 s, -3.5 s); the dark corner squares are (9, 0) and (9, 6), so
    // corner 0 is the inner corner beside (9, 0), at (4 s, -2.5 s), with the board's x
    // along -X, y along +Y and z down.
    let world_from_board = Isometry3::from_parts(
        Translation3::new(4.0 * s, -2.5 * s, 0.0),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(
            nalgebra::Matrix3::new(-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0),
        )),
    );
    (scene, world_from_board)
}

fn render(scene: &Scene, camera: &Camera, seed: u64) -> image::GrayImage {
    let frame = scene
        .render(
            camera,
            &RenderOptions {
                noise_sigma: 2.0 / 255.0,
                seed,
            },
        )
        .unwrap_or_else(|e| panic!("{e}"));
    image::DynamicImage::ImageRgb8(frame.rgb8()).to_luma8()
}

fn camera_at(eye: Point3<f64>, target: Point3<f64>) -> Camera {
    let pose = look_at(&eye, &target, &Vector3::z()).unwrap_or_else(|e| panic!("{e}"));
    Camera::new(
        truth_intrinsics(),
        truth_distortion(),
        pose,
        ImageSize::new(640, 480),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Cameras around and above the board at different tilts and distances.
fn tilted_cameras() -> Vec<Camera> {
    let views = [
        (0.0, 55.0, 0.50),
        (30.0, 62.0, 0.46),
        (70.0, 45.0, 0.52),
        (110.0, 75.0, 0.44),
        (150.0, 50.0, 0.50),
        (185.0, 68.0, 0.47),
        (215.0, 42.0, 0.53),
        (250.0, 80.0, 0.45),
        (285.0, 58.0, 0.49),
        (320.0, 48.0, 0.51),
        (345.0, 70.0, 0.46),
        (95.0, 60.0, 0.48),
    ];
    views
        .iter()
        .map(|&(azimuth, elevation, distance): &(f64, f64, f64)| {
            let (a, e) = (azimuth.to_radians(), elevation.to_radians());
            let eye = Point3::new(
                distance * e.cos() * a.cos(),
                distance * e.cos() * a.sin(),
                distance * e.sin(),
            );
            camera_at(eye, Point3::new(0.01 * a.sin(), -0.01 * a.cos(), 0.0))
        })
        .collect()
}

fn detect(image: &image::GrayImage) -> Result<BoardDetection, Rejection> {
    detect_board(
        image,
        &BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}")),
        &DetectorParams::default(),
    )
}

#[test]
fn corners_land_on_the_true_projections() {
    let (scene, world_from_board) = board_scene();
    let board = BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}"));
    let mut worst: f64 = 0.0;
    for (i, camera) in tilted_cameras().iter().enumerate() {
        let det =
            detect(&render(&scene, camera, i as u64)).unwrap_or_else(|e| panic!("view {i}: {e}"));
        for (p, c) in board.object_points().iter().zip(&det.corners) {
            let truth = camera
                .project(&(world_from_board * p))
                .unwrap_or_else(|| panic!("behind"));
            worst = worst.max((truth - c).norm());
        }
    }
    eprintln!("worst corner error {worst:.3} px");
    // Same labelling as the truth (corner 0 at the dark corner square), sub-pixel accuracy.
    assert!(worst < 0.25, "worst corner {worst} px from the truth");
}

#[test]
fn intrinsic_calibration_recovers_the_truth() {
    let (scene, _) = board_scene();
    let views: Vec<BoardDetection> = tilted_cameras()
        .iter()
        .enumerate()
        .map(|(i, c)| {
            detect(&render(&scene, c, 100 + i as u64)).unwrap_or_else(|e| panic!("view {i}: {e}"))
        })
        .collect();
    let board = BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}"));
    let options = IntrinsicOptions {
        fix_distortion: [false, false, false, false, true],
        ..Default::default()
    };
    let cal = calibrate_intrinsics(&board, &views, &options).unwrap_or_else(|e| panic!("{e}"));
    let (t, i) = (truth_intrinsics(), cal.intrinsics);
    eprintln!(
        "{i:?} {:?} rms {:.3} std {:?}",
        cal.distortion, cal.rms, cal.std
    );
    assert!(
        (i.fx / t.fx - 1.0).abs() < 0.005 && (i.fy / t.fy - 1.0).abs() < 0.005,
        "{i:?}"
    );
    assert!(
        (i.cx - t.cx).abs() < 3.0 && (i.cy - t.cy).abs() < 3.0,
        "{i:?}"
    );
    assert!(
        (cal.distortion.k1 - truth_distortion().k1).abs() < 0.01,
        "{:?}",
        cal.distortion
    );
    assert!(cal.rms < 0.2, "rms {}", cal.rms);
    // The truth lies within 3 standard deviations (plus the renderer's own bias, which a
    // pixel-centre ray tracer has of a few hundredths of a pixel).
    let s = cal.std;
    for (name, est, truth, std) in [
        ("fx", i.fx, t.fx, s.fx),
        ("fy", i.fy, t.fy, s.fy),
        ("cx", i.cx, t.cx, s.cx),
        ("cy", i.cy, t.cy, s.cy),
    ] {
        assert!(
            (est - truth).abs() < 3.0 * std + 0.3,
            "{name} {est} ± {std}, truth {truth}"
        );
    }
}

#[test]
fn parallel_boards_are_degenerate() {
    let (scene, _) = board_scene();
    // Straight down from different heights and offsets: every board plane parallel.
    let views: Vec<BoardDetection> = [
        (0.0, 0.0, 0.45),
        (0.03, 0.01, 0.40),
        (-0.02, 0.02, 0.50),
        (0.01, -0.03, 0.43),
    ]
    .iter()
    .enumerate()
    .map(|(i, &(x, y, z))| {
        let pose = Isometry3::look_at_rh(
            &Point3::new(x, y, z),
            &Point3::new(x, y, 0.0),
            &Vector3::y(),
        );
        // look_at_rh gives a camera looking along -z; turn it to the optical frame.
        let flip = Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
        );
        let camera = Camera::new(
            truth_intrinsics(),
            truth_distortion(),
            flip * pose,
            ImageSize::new(640, 480),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        detect(&render(&scene, &camera, i as u64)).unwrap_or_else(|e| panic!("view {i}: {e}"))
    })
    .collect();
    let board = BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}"));
    match calibrate_intrinsics(&board, &views, &Default::default()) {
        Err(Error::Degenerate(m)) => assert!(m.contains("parallel"), "{m}"),
        other => panic!("expected a degenerate set, got {other:?}"),
    }
}

#[test]
fn bad_sets_are_refused_with_reasons() {
    let (scene, _) = board_scene();
    let cams = tilted_cameras();
    let a = detect(&render(&scene, &cams[0], 1)).unwrap_or_else(|e| panic!("{e}"));
    let b = detect(&render(&scene, &cams[1], 2)).unwrap_or_else(|e| panic!("{e}"));
    let board = BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(
        calibrate_intrinsics(&board, &[a.clone(), b.clone()], &Default::default()),
        Err(Error::TooFewViews {
            found: 2,
            needed: 3,
            ..
        })
    ));
    let mut small = b.clone();
    small.image_size = ImageSize::new(320, 240);
    match calibrate_intrinsics(&board, &[a.clone(), b, small], &Default::default()) {
        Err(e @ Error::SizeMismatch { index: 2, .. }) => assert!(e.to_string().contains("320x240")),
        other => panic!("expected a size mismatch, got {other:?}"),
    }
    // A board half out of the picture is rejected, with the grid it did find.
    let camera = camera_at(Point3::new(0.25, 0.0, 0.3), Point3::new(-0.12, 0.0, 0.0));
    match detect(&render(&scene, &camera, 5)) {
        Err(r @ (Rejection::IncompleteGrid { .. } | Rejection::NoCorners)) => eprintln!("{r}"),
        other => panic!("expected a rejection, got {other:?}"),
    }
    // No board at all.
    let blank = image::GrayImage::from_pixel(640, 480, image::Luma([128]));
    assert_eq!(detect(&blank), Err(Rejection::NoCorners));
}

#[test]
fn turntable_calibration_recovers_the_ring() {
    let (scene, world_from_board) = board_scene();
    let pans: Vec<Angle> = (0..12)
        .map(|i| Angle::from_degrees(-150.0 + 300.0 * i as f64 / 11.0))
        .collect();
    let views: Vec<PanView> = pans
        .iter()
        .enumerate()
        .map(|(i, &pan)| {
            let camera = scene.camera(pan).unwrap_or_else(|e| panic!("{e}"));
            let detection = detect(&render(&scene, &camera, 200 + i as u64))
                .unwrap_or_else(|e| panic!("pan {pan}: {e}"));
            PanView { pan, detection }
        })
        .collect();
    let board = BoardSpec::new(9, 6, SQUARE).unwrap_or_else(|e| panic!("{e}"));
    let range = scene.rig.pan_range;
    let cal = calibrate_turntable(
        &board,
        &truth_intrinsics(),
        &truth_distortion(),
        &views,
        range,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    // Every pose matches the truth.
    for (p, &pan) in cal.poses.iter().zip(&pans) {
        let truth = scene.rig.ring.cam_from_world(pan) * world_from_board;
        let rot = (p.cam_from_board.rotation.inverse() * truth.rotation)
            .angle()
            .to_degrees();
        let dt = (p.cam_from_board.translation.vector - truth.translation.vector).norm();
        assert!(
            rot < 0.1 && dt < 1e-3,
            "pan {pan}: {rot} degrees, {dt} m off"
        );
    }
    // The axis is the world Z axis through the origin, seen in the board frame.
    let board_from_world = world_from_board.inverse();
    let axis_in_board = board_from_world.rotation * Vector3::z();
    let fitted = cal
        .turntable_from_board
        .inverse_transform_vector(&Vector3::z());
    assert!(
        fitted.dot(&axis_in_board).abs() > (0.1f64).to_radians().cos(),
        "axis {fitted} vs {axis_in_board}"
    );
    let foot = board_from_world * Point3::origin();
    let fitted_origin = cal
        .turntable_from_board
        .inverse_transform_point(&Point3::origin());
    let off_axis =
        (fitted_origin - foot) - axis_in_board * axis_in_board.dot(&(fitted_origin - foot));
    assert!(
        off_axis.norm() < 1e-3,
        "axis {} mm off",
        off_axis.norm() * 1e3
    );
    assert!(cal.fit.rms_centre_m() < 1e-3, "{}", cal.fit.rms_centre_m());
    // Left-out positions predicted within a pixel.
    assert_eq!(cal.left_out.len(), 12);
    let worst = cal
        .left_out
        .iter()
        .map(|l| l.reprojection_px)
        .fold(0.0, f64::max);
    eprintln!(
        "left out: worst {worst:.3} px; {:?}",
        cal.left_out
            .iter()
            .map(|l| format!("{:.3}", l.reprojection_px))
            .collect::<Vec<_>>()
    );
    assert!(worst < 1.0, "worst left-out prediction {worst} px");
    // The table in the turntable frame gives the ring's camera centres.
    for &pan in &pans {
        let c = cal
            .table
            .cam_from_world(pan)
            .unwrap_or_else(|e| panic!("{e}"))
            .inverse_transform_point(&Point3::origin());
        let truth = scene
            .rig
            .ring
            .cam_from_world(pan)
            .inverse_transform_point(&Point3::origin());
        assert!(
            (c.coords.xy().norm() - truth.coords.xy().norm()).abs() < 2e-3,
            "radius at {pan}"
        );
    }
}
