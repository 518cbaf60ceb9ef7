//! The replay rig on Middlebury's templeRing: a ring of real views as turntable and camera.

use aibr::camera::Angle;
use aibr::{CaptureParams, FrameSource, Progress, ReplayRig, Strategy, Turntable};

#[test]
fn templering_replays_its_views() -> Result<(), Box<dyn std::error::Error>> {
    let Some(dir) = aibr_testdata::dataset("middlebury-templeRing") else {
        return Ok(());
    };
    let mut rig = ReplayRig::open(&dir)?;
    // 47 recorded; the gantry's upside-down views and the repeat of templeR0001 are left out.
    assert_eq!(rig.views().len() + rig.left_out().len(), 47);
    assert!(
        rig.left_out().contains(&"templeR0030.png".to_owned()),
        "{:?}",
        rig.left_out()
    );
    assert!(rig.views().len() >= 30, "{}", rig.views().len());
    // The README's box is used, in the ring frame.
    assert!(rig.known_volume().is_some());
    let pans: Vec<f64> = rig.views().iter().map(|v| v.pan.degrees()).collect();
    let range = rig.range();
    assert!(
        pans.iter()
            .all(|p| *p >= range.min().degrees() - 1e-9 && *p <= range.max().degrees() + 1e-9)
    );

    // A request returns the nearest recorded view and reports its angle...
    let want = Angle::from_degrees(10.0);
    let got = rig.move_to(want)?;
    let nearest = pans
        .iter()
        .copied()
        .min_by(|a, b| (a - 10.0).abs().total_cmp(&(b - 10.0).abs()))
        .ok_or("no views")?;
    assert!((got.degrees() - nearest).abs() < 1e-9);
    let frame = rig.capture()?;
    let i = rig.view_at(got).ok_or("reported angle is not a view")?;
    assert_eq!(frame.image, rig.views()[i].image);
    assert!(frame.mask.is_some());
    // ...and never the same view twice: the next request for the same angle gets a neighbour.
    let again = rig.move_to(want)?;
    assert!(again != got);
    // What is left to reach: the views not served, in their order.
    let left: Vec<Angle> = rig
        .views()
        .iter()
        .map(|v| v.pan)
        .filter(|p| *p != got && *p != again)
        .collect();
    assert_eq!(rig.reachable(), Some(left));

    // The calibration's circle reproduces the recorded cameras closely (a real calibration's
    // scatter: well under a degree and a millimetre or two).
    let calibration = rig.calibration();
    for v in rig.views() {
        let fitted = calibration.camera_at(v.pan);
        let c0 = fitted
            .cam_from_world
            .inverse_transform_point(&nalgebra::Point3::origin());
        let c1 = v
            .camera
            .cam_from_world
            .inverse_transform_point(&nalgebra::Point3::origin());
        assert!(
            (c0 - c1).norm() < 0.003,
            "{}: {} m",
            v.name,
            (c0 - c1).norm()
        );
        let roll =
            (fitted.cam_from_world.rotation.inverse() * v.camera.cam_from_world.rotation).angle();
        assert!(
            roll < 1f64.to_radians(),
            "{}: {} deg",
            v.name,
            roll.to_degrees()
        );
    }

    // A fresh rig forgets what was served.
    let mut fresh = rig.fresh();
    assert_eq!(fresh.move_to(want)?, got);
    Ok(())
}

/// An active capture on the replay rig asks for recorded views only, so every view lands
/// where the planner put it. templeRing's ring has no view between -76.6 and -30.6 degrees;
/// the planner used to ask for the middle of that arc, which stayed the widest, and the rig
/// served the views nearest it one after another.
#[test]
fn an_active_capture_on_a_replayed_ring_reaches_every_pan_it_plans()
-> Result<(), Box<dyn std::error::Error>> {
    let Some(dir) = aibr_testdata::dataset("middlebury-templeRing") else {
        return Ok(());
    };
    let mut rig = ReplayRig::open(&dir)?;
    let work = std::env::temp_dir().join(format!("aibr-replay-plan-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    let params = CaptureParams {
        strategy: Strategy::Active,
        initial: 12,
        max: 16,
        grid: 48,
        ..CaptureParams::default()
    };
    let calibration = rig.calibration();
    let spec = format!("replay:{}", dir.display());
    let mut session = aibr::new_session(&work, &spec, &rig, &calibration, &params)?;
    let (mut planned, mut reached) = (Vec::new(), Vec::new());
    aibr::capture(&mut rig, &mut session, &params, &mut |p| match p {
        Progress::Planned { pan, .. } => planned.push(pan),
        Progress::Captured { count, pan, .. } if count > params.initial => reached.push(pan),
        _ => {}
    })?;
    let _ = std::fs::remove_dir_all(&work);
    assert_eq!(planned.len(), params.max - params.initial);
    assert_eq!(planned, reached);
    Ok(())
}

#[test]
fn a_folder_without_cameras_is_named() {
    let dir = std::env::temp_dir().join(format!("aibr-replay-empty-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let err = ReplayRig::open(&dir).unwrap_err().to_string();
    assert!(
        err.contains("_par.txt") && err.contains(&*dir.to_string_lossy()),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
    assert!(ReplayRig::from_spec("sim:mirror").is_err());
}
