//! The capture loop serving the model's flat faces first (`CaptureParams::faces_first`), on
//! `lambertian`, whose block has four flat side faces, and deciding to from the initial views
//! (`FacesFirst::Auto`) on `lambertian` and `mirror`.

use aibr::camera::Angle;
use aibr::consistency::{VIEW_DEPENDENT_CONTRAST, edge_on_pans};
use aibr::voxel::PlanarFace;
use aibr::{CaptureParams, CaptureReport, FacesFirst, SimRig, Turntable, capture, new_session};

/// The report of capturing 12 initial views of `scene` and 3 more at 64^3, faces first as
/// `faces_first` says; with `stop_at`, the capture stops there first and is then continued.
fn capture_15(
    scene: &str,
    faces_first: FacesFirst,
    stop_at: Option<usize>,
) -> Result<CaptureReport, Box<dyn std::error::Error>> {
    let mut rig = SimRig::new(scene)?;
    let calibration = rig.calibration()?;
    let dir = std::env::temp_dir().join(format!(
        "aibr-faces-first-{scene}-{faces_first}-{stop_at:?}-{}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let params = CaptureParams {
        initial: 12,
        max: 15,
        grid: 64,
        faces_first,
        ..CaptureParams::default()
    };
    let mut session = new_session(&dir, &format!("sim:{scene}"), &rig, &calibration, &params)?;
    let mut run = || {
        if let Some(max) = stop_at {
            capture(
                &mut rig,
                &mut session,
                &CaptureParams { max, ..params },
                &mut |_| {},
            )?;
        }
        capture(&mut rig, &mut session, &params, &mut |_| {})
    };
    let report = run();
    let _ = std::fs::remove_dir_all(&dir);
    Ok(report?)
}

/// Degrees from `pan` to the nearest of `pans`.
fn off(pan: Angle, pans: &[Angle]) -> f64 {
    pans.iter()
        .map(|p| pan.wrapped_difference(*p).degrees().abs())
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn served_first_the_block_faces_get_views_in_their_planes() -> Result<(), Box<dyn std::error::Error>>
{
    let rig = SimRig::new("lambertian")?;
    let calibration = rig.calibration()?;
    let range = rig.range();
    // Each face of the block (0.13 m square about the axis) is seen edge-on from two pans;
    // a view at either serves it.
    let faces: Vec<Vec<Angle>> = [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)]
        .into_iter()
        .map(|(x, y)| {
            let face = PlanarFace {
                normal: nalgebra::Vector3::new(x, y, 0.0),
                offset_m: 0.065,
                voxels: 0,
            };
            edge_on_pans(&face, &calibration.motion, &range)
        })
        .collect();
    let added = |faces_first| -> Result<Vec<Angle>, Box<dyn std::error::Error>> {
        Ok(capture_15("lambertian", faces_first, None)?.pans[12..].to_vec())
    };
    // Served first, each added view lies within 1.5 degrees of a face's edge-on pan (the faces
    // are found in 64^3 models of 12 to 14 views, whose wedges tilt their planes: 0.5-0.8
    // degrees off here), and no two serve the same face.
    let first = added(FacesFirst::On)?;
    assert_eq!(first.len(), 3, "{first:?}");
    let mut served: Vec<usize> = Vec::new();
    for pan in &first {
        let (face, degrees) = faces
            .iter()
            .enumerate()
            .map(|(i, f)| (i, off(*pan, f)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or("no faces")?;
        assert!(
            degrees < 1.5,
            "{pan}: {degrees:.2} degrees from a face's plane"
        );
        assert!(!served.contains(&face), "{pan} serves face {face} again");
        served.push(face);
    }
    // Without it, the planner splits by rank: here the middles of three arcs, far from every
    // face's plane.
    let ranked = added(FacesFirst::Off)?;
    assert!(
        ranked
            .iter()
            .any(|p| faces.iter().all(|f| off(*p, f) >= 3.0)),
        "{ranked:?}"
    );
    Ok(())
}

/// Decided from the initial views: `mirror`'s arcs stand out (its panel reflects what the
/// model cannot explain), so faces are served first, as with `On`; `lambertian`'s score
/// alike, so they are not, as with `Off`.
#[test]
fn auto_serves_faces_first_on_the_mirror_only() -> Result<(), Box<dyn std::error::Error>> {
    let mirror = capture_15("mirror", FacesFirst::Auto, None)?;
    let lambertian = capture_15("lambertian", FacesFirst::Auto, None)?;
    for (scene, auto, view_dependent) in [
        ("mirror", &mirror, true),
        ("lambertian", &lambertian, false),
    ] {
        let contrast = auto.initial_contrast.ok_or("no contrast measured")?;
        assert_eq!(
            contrast >= VIEW_DEPENDENT_CONTRAST,
            view_dependent,
            "{scene}: contrast {contrast:.2}"
        );
        assert_eq!(auto.served_faces_first, view_dependent, "{scene}");
        let fixed = if view_dependent {
            FacesFirst::On
        } else {
            FacesFirst::Off
        };
        let same = capture_15(scene, fixed, None)?;
        assert_eq!(auto.pans, same.pans, "{scene}");
        assert_eq!(
            same.initial_contrast, None,
            "{scene}: measured without auto"
        );
    }
    // Continued past the initial views, the loop decides again from them, and the same.
    let continued = capture_15("mirror", FacesFirst::Auto, Some(13))?;
    assert_eq!(continued.resumed_from, 13);
    assert_eq!(continued.initial_contrast, mirror.initial_contrast);
    assert!(continued.served_faces_first);
    assert_eq!(continued.pans, mirror.pans);
    Ok(())
}
