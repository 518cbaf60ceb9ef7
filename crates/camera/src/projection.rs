//! Decomposition of a 3x4 projection matrix `P = s K [R | t]` into intrinsics and pose, and
//! back.

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::error::{Error, Result};
use crate::intrinsics::Intrinsics;

/// The parts of a projection matrix `P = scale * K [R | t]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecomposedProjection {
    /// `K`, normalised so that `K[2][2] = 1`, with `fx, fy > 0`.
    pub intrinsics: Intrinsics,
    /// `[R | t]` with `det R = 1`.
    pub cam_from_world: Isometry3<f64>,
    /// The scale of `P` (negative when `P` was given with the opposite sign, which describes
    /// the same camera).
    pub scale: f64,
}

/// `P = K [R | t]`.
pub fn compose_projection(
    intrinsics: &Intrinsics,
    cam_from_world: &Isometry3<f64>,
) -> Matrix3x4<f64> {
    let rt = cam_from_world.to_homogeneous();
    intrinsics.matrix() * rt.fixed_view::<3, 4>(0, 0)
}

/// RQ decomposition of a 3x3 matrix: `m = r q` with `r` upper triangular with a
/// non-negative diagonal and `q` orthogonal.
fn rq3(m: &Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
    // With J the exchange matrix: QR of (J m)^T = Q R gives m = (J R^T J)(J Q^T).
    let j = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0);
    let qr = (j * m).transpose().qr();
    let mut r = j * qr.r().transpose() * j;
    let mut q = j * qr.q().transpose();
    for i in 0..3 {
        if r[(i, i)] < 0.0 {
            // r D and D q with D = diag(.., -1, ..): flip column i of r and row i of q.
            r.column_mut(i).neg_mut();
            q.row_mut(i).neg_mut();
        }
    }
    (r, q)
}

/// Decomposes `P` into `K` (with skew), `R` and `t` by RQ decomposition of its left 3x3 block,
/// with signs fixed so that `fx, fy > 0` and `det R = 1`.
///
/// Errors when `P` has a non-finite entry or its left block is singular (a camera at
/// infinity).
pub fn decompose_projection(p: &Matrix3x4<f64>) -> Result<DecomposedProjection> {
    if p.iter().any(|v| !v.is_finite()) {
        return Err(Error::Degenerate(
            "projection matrix has a non-finite entry".into(),
        ));
    }
    let mut m: Matrix3<f64> = p.fixed_view::<3, 3>(0, 0).into_owned();
    let mut p4: Vector3<f64> = p.column(3).into_owned();
    let norm = m.norm();
    let det = m.determinant();
    if norm == 0.0 || det.abs() <= 1e-12 * norm.powi(3) {
        return Err(Error::Degenerate(format!(
            "the left 3x3 block of the projection matrix is singular (det = {det:.3e})"
        )));
    }
    let mut sign = 1.0;
    if det < 0.0 {
        // -P is the same camera; with it, R comes out a proper rotation.
        m = -m;
        p4 = -p4;
        sign = -1.0;
    }
    let (r_upper, q) = rq3(&m);
    let scale = r_upper[(2, 2)];
    let k = r_upper / scale;
    let intrinsics = Intrinsics::from_matrix(&k)?;
    // P[:, 3] = scale K t  =>  t = r_upper^-1 p4.
    let t = r_upper
        .try_inverse()
        .ok_or_else(|| Error::Degenerate("singular intrinsic block".into()))?
        * p4;
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(q));
    Ok(DecomposedProjection {
        intrinsics,
        cam_from_world: Isometry3::from_parts(Translation3::from(t), rotation),
        scale: sign * scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decomposes_a_known_camera() -> Result<()> {
        let k = Intrinsics {
            fx: 800.0,
            fy: 780.0,
            cx: 330.0,
            cy: 250.0,
            skew: 2.0,
        };
        let pose = Isometry3::new(Vector3::new(0.1, -0.2, 1.5), Vector3::new(0.3, -0.5, 2.0));
        for s in [1.0, -2.5, 1e-3] {
            let d = decompose_projection(&(compose_projection(&k, &pose) * s))?;
            assert!((d.scale - s).abs() < 1e-9 * s.abs());
            assert!((d.intrinsics.fx - k.fx).abs() < 1e-8);
            assert!((d.intrinsics.skew - k.skew).abs() < 1e-8);
            let err = (d.cam_from_world.to_homogeneous() - pose.to_homogeneous()).norm();
            assert!(err < 1e-10, "pose error {err}");
        }
        Ok(())
    }

    #[test]
    fn rejects_singular() {
        let mut p = Matrix3x4::zeros();
        p[(0, 3)] = 1.0;
        assert!(decompose_projection(&p).is_err());
        p[(0, 0)] = f64::NAN;
        assert!(decompose_projection(&p).is_err());
    }
}
