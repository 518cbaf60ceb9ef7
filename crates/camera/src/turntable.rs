//! The turntable pose model: ideal circular motion about an axis, its least-squares fit to
//! calibrated poses, and interpolation between poses calibrated at a few pan angles (the
//! paper's "calibration interpolation").
//!
//! # Conventions
//! Panning the turntable by `+theta` turns the object counter-clockwise about the axis
//! direction (right-hand rule) while the camera stays still. In the object (world) frame the
//! camera therefore moves by `-theta`:
//!
//! ```text
//! cam_from_world(theta) = cam_from_world(0) * Rot_axis(theta)
//! centre(theta)         = Rot_axis(-theta) * centre(0)
//! ```

use nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Point3, Quaternion, Rotation3, Translation3, Unit,
    UnitQuaternion, Vector3,
};

use crate::angle::{Angle, PanRange};
use crate::error::{Error, Result};

/// The pan axis: a line through `point` along `direction`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurntableAxis {
    /// A point on the axis, metres.
    pub point: Point3<f64>,
    /// Direction of the axis; positive pan is counter-clockwise about it.
    pub direction: Unit<Vector3<f64>>,
}

impl TurntableAxis {
    /// The axis of the turntable frame: world +Z through the origin.
    pub fn z() -> Self {
        TurntableAxis {
            point: Point3::origin(),
            direction: Vector3::z_axis(),
        }
    }

    /// The rigid motion of the object when the turntable pans by `angle`.
    pub fn rotation(&self, angle: Angle) -> Isometry3<f64> {
        let r = UnitQuaternion::from_axis_angle(&self.direction, angle.radians());
        let a = self.point.coords;
        Isometry3::from_parts(Translation3::from(a - r * a), r)
    }
}

/// A camera pose calibrated at a known pan angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibratedPose {
    /// The pan angle the turntable reported.
    pub pan: Angle,
    /// The pose calibrated there.
    pub cam_from_world: Isometry3<f64>,
}

/// Ideal circular motion: the camera pose at any pan angle from the axis and the pose at
/// pan 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularMotion {
    /// The pan axis in the world frame.
    pub axis: TurntableAxis,
    /// The camera pose at pan 0.
    pub cam_from_world_at_zero: Isometry3<f64>,
}

/// How far one calibrated pose lies from the fitted model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseResidual {
    /// The pan angle of the calibrated pose.
    pub pan: Angle,
    /// Angle of the rotation between the model's and the calibrated camera orientation.
    pub rotation: Angle,
    /// Distance between the model's and the calibrated camera centre, metres.
    pub centre_m: f64,
}

/// A circular motion fitted to calibrated poses, with its residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct CircularFit {
    /// The fitted model.
    pub model: CircularMotion,
    /// One residual per calibrated pose, in input order.
    pub residuals: Vec<PoseResidual>,
}

impl CircularFit {
    /// Root mean square of the centre residuals, metres.
    pub fn rms_centre_m(&self) -> f64 {
        rms(self.residuals.iter().map(|r| r.centre_m))
    }

    /// Root mean square of the rotation residuals.
    pub fn rms_rotation(&self) -> Angle {
        Angle::from_radians(rms(self.residuals.iter().map(|r| r.rotation.radians())))
    }
}

fn rms(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v * v, n + 1));
    if n == 0 { 0.0 } else { (sum / n as f64).sqrt() }
}

/// The rotation nearest a 3x3 matrix in the Frobenius sense (by SVD, with the sign fixed so
/// the result is a proper rotation); the identity if the SVD fails.
pub fn nearest_rotation(m: &Matrix3<f64>) -> UnitQuaternion<f64> {
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => {
            let mut d = Matrix3::identity();
            if (u * v_t).determinant() < 0.0 {
                d[(2, 2)] = -1.0;
            }
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(u * d * v_t))
        }
        _ => UnitQuaternion::identity(),
    }
}

/// The camera pose with orientation `world_from_cam` placed at `centre`.
pub(crate) fn pose_from_centre(
    world_from_cam: UnitQuaternion<f64>,
    centre: &Point3<f64>,
) -> Isometry3<f64> {
    let r = world_from_cam.inverse();
    Isometry3::from_parts(Translation3::from(-(r * centre.coords)), r)
}

/// `cam_from_world` of a camera at `eye` looking at `target`, with `up` pointing up in the
/// image (OpenCV optical frame: x right, y down, z forward).
pub fn look_at(
    eye: &Point3<f64>,
    target: &Point3<f64>,
    up: &Vector3<f64>,
) -> Result<Isometry3<f64>> {
    let forward = target - eye;
    let right = forward.cross(up);
    if !(forward.norm() > 0.0) || right.norm() <= 1e-12 * forward.norm() * up.norm() {
        return Err(Error::Degenerate(
            "look_at: the viewing direction is zero or parallel to `up`".into(),
        ));
    }
    let z = forward.normalize();
    let x = right.normalize();
    let y = z.cross(&x);
    let r = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Ok(Isometry3::from_parts(
        Translation3::from(-(q * eye.coords)),
        q,
    ))
}

impl CircularMotion {
    /// Circular motion about the turntable frame's Z axis.
    pub fn about_z(cam_from_world_at_zero: Isometry3<f64>) -> Self {
        CircularMotion {
            axis: TurntableAxis::z(),
            cam_from_world_at_zero,
        }
    }

    /// The ideal ring of the turntable frame: at pan 0 the camera sits at
    /// `(0, -radius_m, height_m)` on the -Y side, looking at `(0, 0, target_height_m)`,
    /// with world +X to the right of the image and +Z up in it.
    pub fn ring(radius_m: f64, height_m: f64, target_height_m: f64) -> Result<Self> {
        if !(radius_m > 0.0) || !height_m.is_finite() || !target_height_m.is_finite() {
            return Err(Error::InvalidParameter {
                name: "ring radius",
                value: radius_m,
                reason: "must be positive, with finite heights",
            });
        }
        let eye = Point3::new(0.0, -radius_m, height_m);
        let pose = look_at(&eye, &Point3::new(0.0, 0.0, target_height_m), &Vector3::z())?;
        Ok(Self::about_z(pose))
    }

    /// The camera pose at pan angle `pan`.
    pub fn cam_from_world(&self, pan: Angle) -> Isometry3<f64> {
        self.cam_from_world_at_zero * self.axis.rotation(pan)
    }

    /// The camera centre at pan 0 in the world frame.
    pub fn centre_at_zero(&self) -> Point3<f64> {
        self.cam_from_world_at_zero
            .inverse_transform_point(&Point3::origin())
    }

    /// The rigid transform from this model's world frame into the turntable frame: Z along
    /// the axis direction, origin at the foot of the world origin on the axis, and the camera
    /// at pan 0 on the -Y side (so +X is to the right in its image).
    pub fn turntable_from_world(&self) -> Isometry3<f64> {
        let n = self.axis.direction.into_inner();
        let a = self.axis.point.coords;
        let origin = a - n * n.dot(&a);
        turntable_frame(origin, n, self.centre_at_zero().coords)
    }

    /// The same motion expressed in the turntable frame (axis = +Z through the origin).
    pub fn in_turntable_frame(&self) -> CircularMotion {
        let t = self.turntable_from_world();
        CircularMotion::about_z(self.cam_from_world_at_zero * t.inverse())
    }

    /// Least-squares fit to poses calibrated at known pan angles (at least 3, spread over at
    /// least a few degrees).
    ///
    /// 1. The axis direction from the relative rotations of all pairs
    ///    (`R_i^T R_j = Rot(n, theta_j - theta_i)`), least squares on their scaled axes.
    /// 2. The axis point and the camera centre at pan 0 by linear least squares on
    ///    `C_i = Q_i C_0 + (I - Q_i) a` with `Q_i = Rot(n, -theta_i)` and `n . a = 0`.
    /// 3. The orientation at pan 0 as the chordal L2 mean of `R_i Rot(n, -theta_i)`.
    pub fn fit(samples: &[CalibratedPose]) -> Result<CircularFit> {
        if samples.len() < 3 {
            return Err(Error::Degenerate(format!(
                "a circular motion fit needs at least 3 calibrated poses, got {}",
                samples.len()
            )));
        }
        if samples.iter().any(|s| !s.pan.radians().is_finite()) {
            return Err(Error::Degenerate(
                "a calibrated pan angle is not finite".into(),
            ));
        }
        // 1. Axis direction.
        let mut acc = Vector3::zeros();
        for (i, si) in samples.iter().enumerate() {
            for sj in &samples[i + 1..] {
                let delta = sj.pan.wrapped_difference(si.pan).radians();
                // Pairs a few degrees to 170 degrees apart give well-defined axes.
                if delta.abs() < 1e-3 || delta.abs() > 3.0 {
                    continue;
                }
                let rel = si.cam_from_world.rotation.inverse() * sj.cam_from_world.rotation;
                acc += rel.scaled_axis() * delta;
            }
        }
        let n = Unit::try_new(acc, 1e-9).ok_or_else(|| {
            Error::Degenerate(
                "the calibrated poses do not rotate about a common axis (pan angles too close?)"
                    .into(),
            )
        })?;
        // 2. Axis point and centre at pan 0: unknowns [C0; a].
        let rows = 3 * samples.len() + 1;
        let mut a_mat = DMatrix::<f64>::zeros(rows, 6);
        let mut b = DVector::<f64>::zeros(rows);
        for (i, s) in samples.iter().enumerate() {
            let q = Rotation3::from_axis_angle(&n, -s.pan.radians()).into_inner();
            let c = s.cam_from_world.inverse_transform_point(&Point3::origin());
            let r = 3 * i;
            a_mat.view_mut((r, 0), (3, 3)).copy_from(&q);
            a_mat
                .view_mut((r, 3), (3, 3))
                .copy_from(&(Matrix3::identity() - q));
            b.rows_mut(r, 3).copy_from(&c.coords);
        }
        a_mat
            .view_mut((rows - 1, 3), (1, 3))
            .copy_from(&n.into_inner().transpose());
        let svd = a_mat.svd(true, true);
        let smax = svd.singular_values.max();
        let smin = svd.singular_values.min();
        if !(smin > 1e-9 * smax) {
            return Err(Error::Degenerate(
                "the camera centres do not determine the axis (all at one pan angle?)".into(),
            ));
        }
        let x = svd
            .solve(&b, 1e-12 * smax)
            .map_err(|e| Error::Degenerate(format!("axis least squares failed: {e}")))?;
        let c0 = Point3::new(x[0], x[1], x[2]);
        let point = Point3::new(x[3], x[4], x[5]);
        // 3. Orientation at pan 0.
        let mut m = Matrix3::zeros();
        for s in samples {
            let q = Rotation3::from_axis_angle(&n, -s.pan.radians());
            m += s.cam_from_world.rotation.to_rotation_matrix().matrix() * q.matrix();
        }
        let r0 = nearest_rotation(&m);
        let model = CircularMotion {
            axis: TurntableAxis {
                point,
                direction: n,
            },
            cam_from_world_at_zero: Isometry3::from_parts(
                Translation3::from(-(r0 * c0.coords)),
                r0,
            ),
        };
        let residuals = samples
            .iter()
            .map(|s| {
                let predicted = model.cam_from_world(s.pan);
                let rot = predicted.rotation.inverse() * s.cam_from_world.rotation;
                let centre_p = predicted.inverse_transform_point(&Point3::origin());
                let centre_s = s.cam_from_world.inverse_transform_point(&Point3::origin());
                PoseResidual {
                    pan: s.pan,
                    rotation: rotation_angle(&rot),
                    centre_m: (centre_p - centre_s).norm(),
                }
            })
            .collect();
        Ok(CircularFit { model, residuals })
    }
}

/// The turntable frame with `origin` on the axis, Z along `axis`, and `reference` (a camera
/// centre) on its -Y side.
pub(crate) fn turntable_frame(
    origin: Vector3<f64>,
    axis: Vector3<f64>,
    reference: Vector3<f64>,
) -> Isometry3<f64> {
    let z = axis.normalize();
    let mut radial = reference - origin;
    radial -= z * z.dot(&radial);
    let radial = if radial.norm() > 1e-12 {
        radial.normalize()
    } else {
        // The reference is on the axis: any perpendicular direction will do.
        let helper = if z.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        (helper - z * z.dot(&helper)).normalize()
    };
    let y = -radial;
    let x = y.cross(&z);
    let r = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    let q = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r));
    Isometry3::from_parts(Translation3::from(-(q * origin)), q)
}

/// How [`PoseTable`] interpolates between calibrated pan angles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PoseInterpolation {
    /// Slerp the orientations and lerp the camera centres of the two bracketing poses.
    Slerp,
    /// Follow the fitted circular motion and interpolate only each pose's small correction
    /// to it, so sparse tables stay accurate along the arc.
    #[default]
    CircularResidual,
}

/// Camera poses calibrated at a few pan angles (the paper used 15) and the pose at any angle
/// in the pan range interpolated between them.
///
/// Outside the span of the table on a partial range, the pose follows the fitted circular
/// motion with the correction of the nearest calibrated pose. On a full-turn range the table
/// wraps from its last angle to its first.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseTable {
    range: PanRange,
    entries: Vec<CalibratedPose>,
    fit: CircularFit,
    /// Per entry: `cam_from_world_i * circular(theta_i)^-1`.
    corrections: Vec<Isometry3<f64>>,
}

impl PoseTable {
    /// A table of at least 3 poses at distinct angles inside `range` (any order).
    pub fn new(mut entries: Vec<CalibratedPose>, range: PanRange) -> Result<Self> {
        for e in &mut entries {
            e.pan = range.check(e.pan)?;
        }
        entries.sort_by(|a, b| a.pan.radians().total_cmp(&b.pan.radians()));
        if let Some(w) = entries
            .windows(2)
            .find(|w| (w[1].pan.radians() - w[0].pan.radians()).abs() < 1e-9)
        {
            return Err(Error::Degenerate(format!(
                "two calibrated poses at the same pan angle {}",
                w[0].pan
            )));
        }
        let fit = CircularMotion::fit(&entries)?;
        let corrections = entries
            .iter()
            .map(|e| e.cam_from_world * fit.model.cam_from_world(e.pan).inverse())
            .collect();
        Ok(PoseTable {
            range,
            entries,
            fit,
            corrections,
        })
    }

    /// The pan range of the table.
    pub fn range(&self) -> PanRange {
        self.range
    }

    /// The calibrated poses, sorted by pan angle.
    pub fn entries(&self) -> &[CalibratedPose] {
        &self.entries
    }

    /// The circular motion fitted to the table, with its residuals.
    pub fn circular_fit(&self) -> &CircularFit {
        &self.fit
    }

    /// The pose at `pan`, interpolated with [`PoseInterpolation::CircularResidual`].
    pub fn cam_from_world(&self, pan: Angle) -> Result<Isometry3<f64>> {
        self.cam_from_world_with(pan, PoseInterpolation::default())
    }

    /// The pose at `pan` with the given interpolation.
    pub fn cam_from_world_with(
        &self,
        pan: Angle,
        interpolation: PoseInterpolation,
    ) -> Result<Isometry3<f64>> {
        let theta = self.range.check(pan)?;
        let circle = self.fit.model.cam_from_world(theta);
        let Some((i, j, t)) = self.bracket(theta) else {
            // Outside the table: circular motion with the nearest correction.
            let nearest = self.nearest(theta);
            return Ok(self.corrections[nearest] * circle);
        };
        Ok(match interpolation {
            PoseInterpolation::Slerp => interpolate_world_from_cam(
                &self.entries[i].cam_from_world,
                &self.entries[j].cam_from_world,
                t,
            ),
            PoseInterpolation::CircularResidual => {
                interpolate_raw(&self.corrections[i], &self.corrections[j], t) * circle
            }
        })
    }

    /// Entries `(i, j)` bracketing `theta` and the fraction `t` from `i` to `j`.
    fn bracket(&self, theta: Angle) -> Option<(usize, usize, f64)> {
        let th = theta.radians();
        let first = self.entries.first()?.pan.radians();
        let last = self.entries.last()?.pan.radians();
        if th >= first && th <= last {
            let j = self
                .entries
                .partition_point(|e| e.pan.radians() < th)
                .clamp(1, self.entries.len() - 1);
            let (a, b) = (
                self.entries[j - 1].pan.radians(),
                self.entries[j].pan.radians(),
            );
            return Some((j - 1, j, (th - a) / (b - a)));
        }
        if self.range.is_full_turn() {
            // Wrap from the last entry to the first one a turn later.
            let tau = std::f64::consts::TAU;
            let gap = first + tau - last;
            let along = if th > last {
                th - last
            } else {
                th + tau - last
            };
            return Some((self.entries.len() - 1, 0, along / gap));
        }
        None
    }

    fn nearest(&self, theta: Angle) -> usize {
        let th = theta.radians();
        let first = self.entries[0].pan.radians();
        if th < first {
            0
        } else {
            self.entries.len() - 1
        }
    }
}

/// Slerp of rotations, lerp of translations (for small corrections).
fn interpolate_raw(a: &Isometry3<f64>, b: &Isometry3<f64>, t: f64) -> Isometry3<f64> {
    let r = slerp(&a.rotation, &b.rotation, t);
    let tr = a.translation.vector.lerp(&b.translation.vector, t);
    Isometry3::from_parts(Translation3::from(tr), r)
}

/// Interpolation of two camera poses: slerp of orientation, lerp of centre.
fn interpolate_world_from_cam(a: &Isometry3<f64>, b: &Isometry3<f64>, t: f64) -> Isometry3<f64> {
    let ca = a.inverse_transform_point(&Point3::origin());
    let cb = b.inverse_transform_point(&Point3::origin());
    let wa = a.rotation.inverse();
    let wb = b.rotation.inverse();
    pose_from_centre(slerp(&wa, &wb, t), &ca.coords.lerp(&cb.coords, t).into())
}

/// Slerp from `a` (t = 0) to `b` (t = 1) along the shorter arc.
///
/// nalgebra's `slerp` and `angle` go through `acos`, which loses about 1e-8 near the
/// identity, and `slerp` panics on opposite rotations; this one uses `atan2` and cannot
/// panic (between opposite rotations it picks one of the two half-way arcs).
pub(crate) fn slerp(
    a: &UnitQuaternion<f64>,
    b: &UnitQuaternion<f64>,
    t: f64,
) -> UnitQuaternion<f64> {
    let d = a.inverse() * b;
    let (mut w, mut v) = (d.w, d.imag());
    if w < 0.0 {
        w = -w;
        v = -v;
    }
    let s = v.norm();
    if s == 0.0 {
        return *a;
    }
    let half = s.atan2(w) * t;
    let step = Quaternion::from_parts(half.cos(), v * (half.sin() / s));
    a * UnitQuaternion::new_unchecked(step)
}

/// The rotation angle of `q` in [0, pi], accurate near the identity.
pub(crate) fn rotation_angle(q: &UnitQuaternion<f64>) -> Angle {
    Angle::from_radians(2.0 * q.imag().norm().atan2(q.w.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn deg(d: f64) -> Angle {
        Angle::from_degrees(d)
    }

    /// A tilted axis away from the origin, like a checkerboard calibration frame would see.
    fn tilted_motion() -> Result<CircularMotion> {
        let ring = CircularMotion::ring(0.6, 0.35, 0.05)?;
        let world_from_turntable =
            Isometry3::new(Vector3::new(0.2, -0.1, 0.9), Vector3::new(0.4, 0.2, -0.3));
        Ok(CircularMotion {
            axis: TurntableAxis {
                point: world_from_turntable * Point3::origin(),
                direction: Unit::new_normalize(world_from_turntable * Vector3::z()),
            },
            cam_from_world_at_zero: ring.cam_from_world_at_zero * world_from_turntable.inverse(),
        })
    }

    #[test]
    fn ring_geometry() -> Result<()> {
        let m = CircularMotion::ring(1.0, 0.5, 0.0)?;
        let c = m.centre_at_zero();
        assert!((c - Point3::new(0.0, -1.0, 0.5)).norm() < 1e-12);
        // +X appears to the right of the image centre, +Z above it.
        let cam = m.cam_from_world_at_zero;
        assert!(cam.transform_point(&Point3::new(0.1, 0.0, 0.0)).x > 0.0);
        assert!(cam.transform_point(&Point3::new(0.0, 0.0, 0.1)).y < 0.0);
        // Panning by +90 deg moves the camera (in the object frame) to azimuth -180 deg.
        let c90 = m
            .cam_from_world(deg(90.0))
            .inverse_transform_point(&Point3::origin());
        assert!((c90 - Point3::new(-1.0, 0.0, 0.5)).norm() < 1e-12, "{c90}");
        Ok(())
    }

    #[test]
    fn fit_recovers_an_exact_motion() -> Result<()> {
        let truth = tilted_motion()?;
        let samples: Vec<_> = (0..15)
            .map(|i| {
                let pan = deg(-150.0 + 21.0 * i as f64);
                CalibratedPose {
                    pan,
                    cam_from_world: truth.cam_from_world(pan),
                }
            })
            .collect();
        let fit = CircularMotion::fit(&samples)?;
        assert!(fit.rms_centre_m() < 1e-10, "{}", fit.rms_centre_m());
        assert!(fit.rms_rotation().radians() < 1e-10);
        for pan in [deg(-100.0), deg(7.0), deg(140.0)] {
            let d = fit.model.cam_from_world(pan).to_homogeneous()
                - truth.cam_from_world(pan).to_homogeneous();
            assert!(d.norm() < 1e-9);
        }
        // The turntable frame puts the axis on Z and the camera on -Y at pan 0.
        let tt = fit.model.in_turntable_frame();
        let c = tt.centre_at_zero();
        assert!(c.x.abs() < 1e-9 && c.y < 0.0, "{c}");
        assert!(((c.y * c.y + c.x * c.x).sqrt() - 0.6).abs() < 1e-9);
        Ok(())
    }

    #[test]
    fn fit_rejects_degenerate_input() {
        let m = CircularMotion::ring(1.0, 0.5, 0.0);
        let Ok(m) = m else { return };
        let same: Vec<_> = (0..4)
            .map(|_| CalibratedPose {
                pan: deg(10.0),
                cam_from_world: m.cam_from_world(deg(10.0)),
            })
            .collect();
        assert!(matches!(
            CircularMotion::fit(&same),
            Err(Error::Degenerate(_))
        ));
        assert!(CircularMotion::fit(&same[..2]).is_err());
    }

    #[test]
    fn table_residual_beats_slerp_on_sparse_tables() -> Result<()> {
        // A wobbling turntable: the true poses deviate from circular motion smoothly.
        let base = tilted_motion()?;
        let truth = |pan: Angle| {
            let a = pan.radians();
            let wobble = Isometry3::new(
                Vector3::new(
                    0.002 * (2.0 * a).sin(),
                    0.001 * a.cos(),
                    0.0015 * (3.0 * a).sin(),
                ),
                Vector3::new(0.002 * a.sin(), 0.0, 0.001 * (2.0 * a).cos()),
            );
            wobble * base.cam_from_world(pan)
        };
        let range = PanRange::new(deg(-155.0), deg(155.0))?;
        let entries: Vec<_> = (0..15)
            .map(|i| {
                let pan = deg(-155.0 + 310.0 * i as f64 / 14.0);
                CalibratedPose {
                    pan,
                    cam_from_world: truth(pan),
                }
            })
            .collect();
        let table = PoseTable::new(entries.clone(), range)?;
        // Exact at the calibrated angles.
        for e in &entries {
            let p = table.cam_from_world(e.pan)?;
            let d = (p.to_homogeneous() - e.cam_from_world.to_homogeneous()).norm();
            assert!(d < 1e-9, "at {}: {d}", e.pan);
        }
        // Midway between entries, the residual method follows the arc; slerp cuts the chord.
        let (mut worst_res, mut worst_slerp) = (0.0f64, 0.0f64);
        for k in 0..14 {
            let pan = deg(-155.0 + 310.0 * (k as f64 + 0.5) / 14.0);
            let centre = |p: Isometry3<f64>| p.inverse_transform_point(&Point3::origin());
            let c_true = centre(truth(pan));
            let c_res = centre(table.cam_from_world(pan)?);
            let c_slerp = centre(table.cam_from_world_with(pan, PoseInterpolation::Slerp)?);
            worst_res = worst_res.max((c_res - c_true).norm());
            worst_slerp = worst_slerp.max((c_slerp - c_true).norm());
        }
        assert!(
            worst_res < 0.3 * worst_slerp,
            "residual {worst_res} vs slerp {worst_slerp}"
        );
        assert!(worst_res < 1e-3, "{worst_res}");
        assert!(table.cam_from_world(deg(170.0)).is_err());
        Ok(())
    }

    #[test]
    fn full_turn_table_wraps() -> Result<()> {
        let m = CircularMotion::ring(1.0, 0.4, 0.0)?;
        let entries: Vec<_> = (0..6)
            .map(|i| {
                let pan = deg(60.0 * i as f64);
                CalibratedPose {
                    pan,
                    cam_from_world: m.cam_from_world(pan),
                }
            })
            .collect();
        let table = PoseTable::new(entries, PanRange::new(Angle::ZERO, deg(360.0))?)?;
        // 330 deg lies between the last entry (300) and the first a turn later (360).
        for pan in [deg(330.0), deg(-30.0), deg(690.0)] {
            let p = table.cam_from_world_with(pan, PoseInterpolation::Slerp)?;
            let c = p.inverse_transform_point(&Point3::origin());
            let expected = m
                .cam_from_world(deg(330.0))
                .inverse_transform_point(&Point3::origin());
            // Slerp cuts the chord of a 60 degree arc: within 1 - cos(30 deg) of the radius.
            assert!((c - expected).norm() < 0.14, "{pan}: {c} vs {expected}");
            let p = table.cam_from_world(pan)?;
            let c = p.inverse_transform_point(&Point3::origin());
            assert!((c - expected).norm() < 1e-9);
        }
        Ok(())
    }
}
