//! Plane homographies and board poses.

use aibr_camera::nearest_rotation;
use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Point2, Translation3, Vector3};

/// Similarity that moves points to their centroid and scales their mean distance to √2.
fn normalizer(points: &[Point2<f64>]) -> Matrix3<f64> {
    let n = points.len().max(1) as f64;
    let c = points
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + Vector3::new(p.x, p.y, 0.0))
        / n;
    let mean_d = points
        .iter()
        .map(|p| ((p.x - c.x).powi(2) + (p.y - c.y).powi(2)).sqrt())
        .sum::<f64>()
        / n;
    let s = if mean_d > 0.0 {
        std::f64::consts::SQRT_2 / mean_d
    } else {
        1.0
    };
    Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0)
}

/// The homography `H` with `dst ~ H src` by the normalised direct linear transform (at least
/// 4 points, not all on a line); `None` when the points do not determine it.
pub(crate) fn homography(src: &[Point2<f64>], dst: &[Point2<f64>]) -> Option<Matrix3<f64>> {
    if src.len() != dst.len() || src.len() < 4 {
        return None;
    }
    let (ts, td) = (normalizer(src), normalizer(dst));
    let mut a = DMatrix::<f64>::zeros(2 * src.len(), 9);
    for (i, (s, d)) in src.iter().zip(dst).enumerate() {
        let s = ts * Vector3::new(s.x, s.y, 1.0);
        let d = td * Vector3::new(d.x, d.y, 1.0);
        let (x, y, u, v) = (s.x, s.y, d.x, d.y);
        a.row_mut(2 * i)
            .copy_from_slice(&[-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u]);
        a.row_mut(2 * i + 1)
            .copy_from_slice(&[0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v]);
    }
    let h = null_vector(&a)?;
    let hn = Matrix3::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], h[8]);
    let h = td.try_inverse()? * hn * ts;
    let scale = h[(2, 2)];
    (scale.abs() > 1e-300 && h.iter().all(|v| v.is_finite())).then(|| h / scale)
}

/// The unit vector `x` minimising `|A x|`: the eigenvector of `AᵀA` with the smallest
/// eigenvalue (the null vector of `A` when it has one).
pub(crate) fn null_vector(a: &DMatrix<f64>) -> Option<DVector<f64>> {
    let eig = (a.transpose() * a).symmetric_eigen();
    let (k, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.total_cmp(y.1))?;
    Some(eig.eigenvectors.column(k).into_owned())
}

/// The pose of a plane (`z = 0` of its frame) from its homography to normalised image
/// coordinates `Kinv H`: columns `λ [r1 r2 t]`, the plane in front of the camera.
pub(crate) fn pose_from_homography(m: &Matrix3<f64>) -> Option<Isometry3<f64>> {
    let (m1, m2, m3) = (
        m.column(0).into_owned(),
        m.column(1).into_owned(),
        m.column(2).into_owned(),
    );
    let norm = 0.5 * (m1.norm() + m2.norm());
    if !(norm > 0.0) {
        return None;
    }
    let mut lambda = 1.0 / norm;
    if m3.z * lambda < 0.0 {
        lambda = -lambda;
    }
    let r1 = m1 * lambda;
    let r2 = m2 * lambda;
    let r = nearest_rotation(&Matrix3::from_columns(&[r1, r2, r1.cross(&r2)]));
    let t = m3 * lambda;
    Some(Isometry3::from_parts(Translation3::from(t), r))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn homography_recovers_a_projective_map() {
        let h = Matrix3::new(1.2, 0.1, 30.0, -0.05, 0.9, 12.0, 1e-3, -2e-3, 1.0);
        let src: Vec<Point2<f64>> = (0..6)
            .flat_map(|i| (0..4).map(move |j| Point2::new(i as f64 * 7.0, j as f64 * 5.0)))
            .collect();
        let dst: Vec<Point2<f64>> = src
            .iter()
            .map(|p| {
                let q = h * Vector3::new(p.x, p.y, 1.0);
                Point2::new(q.x / q.z, q.y / q.z)
            })
            .collect();
        let est = homography(&src, &dst).unwrap_or_else(Matrix3::zeros);
        assert!((est - h).abs().max() < 1e-9, "{est}");
        assert!(homography(&src[..3], &dst[..3]).is_none());
    }
}
