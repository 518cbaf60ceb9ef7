//! The ring frame of a set of cameras: fit the circle through their centres and express them
//! as a turntable capture.

use nalgebra::{Isometry3, Matrix3, Point3, Vector2, Vector3};

use crate::angle::Angle;
use crate::error::{Error, Result};
use crate::turntable::turntable_frame;

/// The circle through a set of camera centres, and the turntable frame it defines.
#[derive(Debug, Clone, PartialEq)]
pub struct RingFit {
    /// Maps the cameras' world frame into the turntable frame: Z along the circle's axis,
    /// pointing to the side the cameras look down from; origin at the foot of the old world
    /// origin on the axis; the first camera on the -Y side (its pan angle is 0).
    pub turntable_from_world: Isometry3<f64>,
    /// Pan angle of each camera, in input order, wrapped into (-pi, pi]. Camera `i` is where
    /// the first camera would be after the turntable panned by `pan_angles[i]`
    /// (see [`crate::turntable`]).
    pub pan_angles: Vec<Angle>,
    /// Radius of the fitted circle, metres.
    pub radius_m: f64,
    /// Height of the circle's plane above the turntable origin, metres.
    pub height_m: f64,
    /// Distance of each camera centre from the fitted circle, metres.
    pub residuals_m: Vec<f64>,
}

impl RingFit {
    /// Root mean square of [`residuals_m`](Self::residuals_m).
    pub fn rms_residual_m(&self) -> f64 {
        let n = self.residuals_m.len().max(1) as f64;
        (self.residuals_m.iter().map(|r| r * r).sum::<f64>() / n).sqrt()
    }

    /// A pose of the input set expressed in the turntable frame.
    pub fn to_turntable(&self, cam_from_world: &Isometry3<f64>) -> Isometry3<f64> {
        cam_from_world * self.turntable_from_world.inverse()
    }
}

/// Fits the ring through the centres of `cams_from_world` (at least 3, not collinear).
///
/// The plane is the total-least-squares plane of the centres; the circle in it is Kasa's
/// algebraic fit refined by Gauss-Newton on the geometric distance. Residuals are 3D
/// distances from the circle (in-plane and out-of-plane together).
pub fn fit_ring(cams_from_world: &[Isometry3<f64>]) -> Result<RingFit> {
    let n = cams_from_world.len();
    if n < 3 {
        return Err(Error::Degenerate(format!(
            "a ring fit needs at least 3 cameras, got {n}"
        )));
    }
    let centres: Vec<Vector3<f64>> = cams_from_world
        .iter()
        .map(|c| c.inverse_transform_point(&Point3::origin()).coords)
        .collect();
    if centres.iter().any(|c| !c.iter().all(|v| v.is_finite())) {
        return Err(Error::Degenerate("a camera centre is not finite".into()));
    }
    let mean = centres.iter().sum::<Vector3<f64>>() / n as f64;
    let mut cov = Matrix3::zeros();
    for c in &centres {
        let d = c - mean;
        cov += d * d.transpose();
    }
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let (l0, l1) = (eig.eigenvalues[order[0]], eig.eigenvalues[order[1]]);
    if !(l1 > 1e-10 * l0.max(1e-300)) {
        return Err(Error::Degenerate(
            "the camera centres are collinear or coincident: no ring".into(),
        ));
    }
    let e1: Vector3<f64> = eig.eigenvectors.column(order[0]).into_owned();
    let e2: Vector3<f64> = eig.eigenvectors.column(order[1]).into_owned();
    let mut normal: Vector3<f64> = e1.cross(&e2).normalize();
    let planar: Vec<Vector2<f64>> = centres
        .iter()
        .map(|c| Vector2::new((c - mean).dot(&e1), (c - mean).dot(&e2)))
        .collect();
    let (centre2, radius) = fit_circle_2d(&planar)?;
    let circle_centre = mean + e1 * centre2.x + e2 * centre2.y;

    // Z points to the side the cameras look down from.
    let look: f64 = cams_from_world
        .iter()
        .map(|c| {
            c.rotation
                .inverse_transform_vector(&Vector3::z())
                .dot(&normal)
        })
        .sum::<f64>();
    if look > 0.0 {
        normal = -normal;
    }
    let origin = circle_centre - normal * normal.dot(&circle_centre);
    let turntable_from_world = turntable_frame(origin, normal, centres[0]);

    let mut pan_angles = Vec::with_capacity(n);
    let mut residuals_m = Vec::with_capacity(n);
    let mut height = 0.0;
    for c in &centres {
        let p = turntable_from_world.transform_point(&Point3::from(*c));
        let azimuth = p.y.atan2(p.x);
        pan_angles.push(Angle::from_radians(-std::f64::consts::FRAC_PI_2 - azimuth).wrapped());
        let d = c - circle_centre;
        let out = d.dot(&normal);
        let inplane = (d - normal * out).norm() - radius;
        residuals_m.push((inplane * inplane + out * out).sqrt());
        height += p.z;
    }
    Ok(RingFit {
        turntable_from_world,
        pan_angles,
        radius_m: radius,
        height_m: height / n as f64,
        residuals_m,
    })
}

/// Circle through 2D points: Kasa's algebraic fit, then Gauss-Newton on geometric distance.
fn fit_circle_2d(points: &[Vector2<f64>]) -> Result<(Vector2<f64>, f64)> {
    // x^2 + y^2 + D x + E y + F = 0, least squares via the normal equations.
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for p in points {
        let row = Vector3::new(p.x, p.y, 1.0);
        ata += row * row.transpose();
        atb -= row * p.norm_squared();
    }
    let sol = ata
        .lu()
        .solve(&atb)
        .ok_or_else(|| Error::Degenerate("circle fit: the centres are collinear".into()))?;
    let mut c = Vector2::new(-sol.x / 2.0, -sol.y / 2.0);
    let r2 = c.norm_squared() - sol.z;
    if !(r2 > 0.0) {
        return Err(Error::Degenerate("circle fit: no real circle".into()));
    }
    let mut r = r2.sqrt();
    for _ in 0..20 {
        let mut jtj = Matrix3::zeros();
        let mut jtr = Vector3::zeros();
        for p in points {
            let d = p - c;
            let dist = d.norm();
            if dist == 0.0 {
                continue;
            }
            let res = dist - r;
            let j = Vector3::new(-d.x / dist, -d.y / dist, -1.0);
            jtj += j * j.transpose();
            jtr += j * res;
        }
        let Some(step) = jtj.lu().solve(&jtr) else {
            break;
        };
        c -= step.xy();
        r -= step.z;
        if step.norm() < 1e-14 * (1.0 + r) {
            break;
        }
    }
    Ok((c, r.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::turntable::CircularMotion;

    #[test]
    fn recovers_a_synthetic_ring() -> Result<()> {
        let ring = CircularMotion::ring(0.7, 0.4, 0.0)?;
        // The world origin sits at turntable height 0, where the fit puts its origin.
        let rot = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::new(0.3, -0.6, 0.9));
        let world_from_turntable = Isometry3::from_parts(
            nalgebra::Translation3::from(rot * Vector3::new(1.0, 2.0, 0.0)),
            rot,
        );
        let pans: Vec<f64> = vec![0.0, 25.0, 60.0, 110.0, -170.0, -90.0, -20.0];
        let cams: Vec<_> = pans
            .iter()
            .map(|&d| ring.cam_from_world(Angle::from_degrees(d)) * world_from_turntable.inverse())
            .collect();
        let fit = fit_ring(&cams)?;
        assert!(fit.rms_residual_m() < 1e-9);
        assert!((fit.radius_m - 0.7).abs() < 1e-9);
        assert!((fit.height_m - 0.4).abs() < 1e-9, "{}", fit.height_m);
        for (a, d) in fit.pan_angles.iter().zip(&pans) {
            assert!(
                a.wrapped_difference(Angle::from_degrees(*d))
                    .radians()
                    .abs()
                    < 1e-9
            );
        }
        // Expressed in the fitted frame, the poses are the ring's own.
        for (cam, d) in cams.iter().zip(&pans) {
            let p = fit.to_turntable(cam);
            let q = ring.cam_from_world(Angle::from_degrees(*d));
            assert!((p.to_homogeneous() - q.to_homogeneous()).norm() < 1e-9);
        }
        Ok(())
    }

    #[test]
    fn rejects_collinear() {
        let cams: Vec<_> = (0..4)
            .map(|i| Isometry3::translation(i as f64, 0.0, 0.0))
            .collect();
        assert!(fit_ring(&cams).is_err());
        assert!(fit_ring(&cams[..2]).is_err());
    }
}
