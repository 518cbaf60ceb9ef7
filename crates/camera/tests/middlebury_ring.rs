//! Ring fit on the Middlebury rings in `AIBR_DATA_DIR`: the circle through the camera centres
//! and the recovered pan angles against the gantry longitudes of `*_ang.txt`.
//!
//! Print the figures with
//! `cargo test --release -p aibr-camera --test middlebury_ring -- --nocapture`.

use aibr_camera::readers::{read_middlebury_ang, read_middlebury_par};
use aibr_camera::{Angle, Result, fit_ring};

struct RingFigures {
    rms_residual_m: f64,
    radius_m: f64,
    max_angle_error_deg: f64,
    rms_angle_error_deg: f64,
    sign: f64,
}

/// Fits the ring of one data set and compares its pan angles with the longitudes, after one
/// offset and one sign for the whole set. Views at positive latitude are the same positions
/// as (-lat, lon + 180) (the Middlebury README), so their longitude is folded first.
fn ring_figures(dataset: &str, par: &str, ang: &str) -> Result<Option<RingFigures>> {
    let Some(dir) = aibr_testdata::dataset(dataset) else {
        return Ok(None);
    };
    let views = read_middlebury_par(dir.join(par))?;
    let angles = read_middlebury_ang(dir.join(ang))?;
    assert_eq!(views.len(), angles.len());
    for (v, a) in views.iter().zip(&angles) {
        assert_eq!(
            v.image, a.image,
            "par and ang files list the same images in order"
        );
    }
    let poses: Vec<_> = views.iter().map(|v| v.cam_from_world).collect();
    let fit = fit_ring(&poses)?;
    let longitudes: Vec<f64> = angles
        .iter()
        .map(|a| {
            let folded = if a.latitude.radians() > 0.0 {
                a.longitude + Angle::from_degrees(180.0)
            } else {
                a.longitude
            };
            folded.radians()
        })
        .collect();
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for sign in [1.0, -1.0] {
        // Circular mean of the offsets.
        let (s, c) = fit
            .pan_angles
            .iter()
            .zip(&longitudes)
            .map(|(p, l)| p.radians() - sign * l)
            .fold((0.0, 0.0), |(s, c), d| (s + d.sin(), c + d.cos()));
        let offset = s.atan2(c);
        let errors: Vec<f64> = fit
            .pan_angles
            .iter()
            .zip(&longitudes)
            .map(|(p, l)| {
                Angle::from_radians(p.radians() - sign * l - offset)
                    .wrapped()
                    .degrees()
                    .abs()
            })
            .collect();
        let max = errors.iter().copied().fold(0.0, f64::max);
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        if best.is_none_or(|b| max < b.1) {
            best = Some((sign, max, rms, offset));
        }
    }
    let Some((sign, max_angle_error_deg, rms_angle_error_deg, offset)) = best else {
        return Ok(None);
    };
    let figures = RingFigures {
        rms_residual_m: fit.rms_residual_m(),
        radius_m: fit.radius_m,
        max_angle_error_deg,
        rms_angle_error_deg,
        sign,
    };
    eprintln!(
        "{dataset}: {} cameras, radius {:.4} m, height {:.4} m, centre RMS residual {:.3e} m \
         ({:.4}% of radius); pan = {:+.0} * longitude {:+.3} deg, angle error RMS {:.3e} deg, \
         max {:.3e} deg",
        views.len(),
        fit.radius_m,
        fit.height_m,
        figures.rms_residual_m,
        100.0 * figures.rms_residual_m / fit.radius_m,
        sign,
        offset.to_degrees(),
        rms_angle_error_deg,
        max_angle_error_deg
    );
    Ok(Some(figures))
}

fn check(figures: Option<RingFigures>) {
    let Some(f) = figures else { return };
    // The gantry moves the camera on a sphere at a fixed latitude: the centres lie on a
    // circle to well under a millimetre, and the longitudes are the pan angles.
    assert!(
        f.rms_residual_m < 1e-3 * f.radius_m,
        "residual {}",
        f.rms_residual_m
    );
    assert!(
        f.max_angle_error_deg < 0.5,
        "angle error {}",
        f.max_angle_error_deg
    );
    assert!(f.rms_angle_error_deg <= f.max_angle_error_deg);
    assert!(f.sign == 1.0 || f.sign == -1.0);
}

#[test]
fn temple_sparse_ring() -> Result<()> {
    check(ring_figures(
        "middlebury-templeSparseRing",
        "templeSR_par.txt",
        "templeSR_ang.txt",
    )?);
    Ok(())
}

#[test]
fn dino_sparse_ring() -> Result<()> {
    check(ring_figures(
        "middlebury-dinoSparseRing",
        "dinoSR_par.txt",
        "dinoSR_ang.txt",
    )?);
    Ok(())
}

#[test]
fn temple_ring() -> Result<()> {
    check(ring_figures(
        "middlebury-templeRing",
        "templeR_par.txt",
        "templeR_ang.txt",
    )?);
    Ok(())
}
