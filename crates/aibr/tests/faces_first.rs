//! The capture loop serving the model's flat faces first (`CaptureParams::faces_first`), on
//! `lambertian`, whose block has four flat side faces.

use aibr::camera::Angle;
use aibr::consistency::edge_on_pans;
use aibr::voxel::PlanarFace;
use aibr::{CaptureParams, SimRig, Turntable, capture, new_session};

/// Degrees from `pan` to the nearest of `pans`.
fn off(pan: Angle, pans: &[Angle]) -> f64 {
    pans.iter()
        .map(|p| pan.wrapped_difference(*p).degrees().abs())
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn served_first_the_block_faces_get_views_in_their_planes() -> Result<(), Box<dyn std::error::Error>>
{
    let mut rig = SimRig::new("lambertian")?;
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
    let mut added = |faces_first: bool| -> Result<Vec<Angle>, Box<dyn std::error::Error>> {
        let dir = std::env::temp_dir().join(format!(
            "aibr-faces-first-{faces_first}-{}",
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
        let mut session = new_session(&dir, "sim:lambertian", &rig, &calibration, &params)?;
        let report = capture(&mut rig, &mut session, &params, &mut |_| {})?;
        let _ = std::fs::remove_dir_all(&dir);
        Ok(report.pans[12..].to_vec())
    };
    // Served first, each added view lies within 1.5 degrees of a face's edge-on pan (the faces
    // are found in 64^3 models of 12 to 14 views, whose wedges tilt their planes: 0.5-0.8
    // degrees off here), and no two serve the same face.
    let first = added(true)?;
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
    let ranked = added(false)?;
    assert!(
        ranked
            .iter()
            .any(|p| faces.iter().all(|f| off(*p, f) >= 3.0)),
        "{ranked:?}"
    );
    Ok(())
}
