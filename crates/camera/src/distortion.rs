//! Brown-Conrady lens distortion in Bouguet/OpenCV order (k1 k2 p1 p2 k3).

use nalgebra::{Matrix2, Point2, Vector2};

use crate::error::{Error, Result};

/// Radial (k1, k2, k3) and tangential (p1, p2) distortion of normalised image coordinates,
/// the model of Bouguet's toolbox and OpenCV:
///
/// ```text
/// r2 = x^2 + y^2,  radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3
/// xd = x radial + 2 p1 x y + p2 (r2 + 2 x^2)
/// yd = y radial + p1 (r2 + 2 y^2) + 2 p2 x y
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial, r^2 term.
    pub k1: f64,
    /// Radial, r^4 term.
    pub k2: f64,
    /// Tangential, first.
    pub p1: f64,
    /// Tangential, second.
    pub p2: f64,
    /// Radial, r^6 term.
    pub k3: f64,
}

/// Newton iterations allowed in [`Distortion::undistort`].
const MAX_NEWTON_ITERATIONS: usize = 40;
/// Convergence threshold of [`Distortion::undistort`], normalised units (about 1e-10 px).
const UNDISTORT_TOLERANCE: f64 = 1e-13;

impl Distortion {
    /// No distortion.
    pub const NONE: Distortion = Distortion {
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };

    /// From OpenCV's coefficient vector: 4 (`k1 k2 p1 p2`) or 5 (`k1 k2 p1 p2 k3`) values.
    pub fn from_opencv(coefficients: &[f64]) -> Result<Self> {
        let d = match *coefficients {
            [k1, k2, p1, p2] => Distortion {
                k1,
                k2,
                p1,
                p2,
                k3: 0.0,
            },
            [k1, k2, p1, p2, k3] => Distortion { k1, k2, p1, p2, k3 },
            _ => {
                return Err(Error::InvalidParameter {
                    name: "distortion coefficient count",
                    value: coefficients.len() as f64,
                    reason: "expected 4 or 5 (k1 k2 p1 p2 [k3])",
                });
            }
        };
        d.validate()?;
        Ok(d)
    }

    /// The coefficients in OpenCV order `[k1, k2, p1, p2, k3]`.
    pub fn to_array(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Checks that every coefficient is finite.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("k1", self.k1),
            ("k2", self.k2),
            ("p1", self.p1),
            ("p2", self.p2),
            ("k3", self.k3),
        ] {
            if !v.is_finite() {
                return Err(Error::InvalidParameter {
                    name,
                    value: v,
                    reason: "distortion coefficients must be finite",
                });
            }
        }
        Ok(())
    }

    /// True when every coefficient is zero.
    pub fn is_none(&self) -> bool {
        *self == Distortion::NONE
    }

    /// Distorts a point on the normalised image plane.
    #[inline]
    pub fn distort(&self, p: Point2<f64>) -> Point2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Point2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian of [`distort`](Self::distort) at `p`.
    #[inline]
    pub fn jacobian(&self, p: Point2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d radial / d r2
        let dradial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let dxx = radial + 2.0 * x * x * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x;
        let dxy = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyx = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        let dyy = radial + 2.0 * y * y * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x;
        Matrix2::new(dxx, dxy, dyx, dyy)
    }

    /// Inverts [`distort`](Self::distort): the undistorted point whose distortion is `pd`.
    ///
    /// Damped Newton iteration from `pd`, which converges in a few steps for real webcam
    /// lenses up to the image corners (unlike the fixed-point iteration of OpenCV's
    /// `undistortPoints`). Returns `None` when no solution is found, or when the solution
    /// lies beyond the radius where the model folds back on itself (Jacobian determinant
    /// not positive), which a physical lens never images.
    pub fn undistort(&self, pd: Point2<f64>) -> Option<Point2<f64>> {
        if self.is_none() {
            return Some(pd);
        }
        if !(pd.x.is_finite() && pd.y.is_finite()) {
            return None;
        }
        let mut p = pd;
        let mut residual: Vector2<f64> = self.distort(p) - pd;
        let mut norm = residual.norm();
        for _ in 0..MAX_NEWTON_ITERATIONS {
            if norm <= UNDISTORT_TOLERANCE {
                break;
            }
            let j = self.jacobian(p);
            let step = j.lu().solve(&residual)?;
            // Backtrack until the residual decreases (the model is a polynomial of degree 7:
            // a full step can overshoot far from the centre).
            let mut t = 1.0;
            loop {
                let candidate = p - step * t;
                let r = self.distort(candidate) - pd;
                let n = r.norm();
                if n < norm {
                    p = candidate;
                    residual = r;
                    norm = n;
                    break;
                }
                t *= 0.5;
                if t < 1e-6 {
                    return None;
                }
            }
        }
        let scale = 1.0 + pd.coords.norm();
        if norm > 1e-9 * scale || self.jacobian(p).determinant() <= 0.0 {
            return None;
        }
        Some(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The OpenCV sample lens (left camera of the 9x6 chessboard set).
    const OPENCV_SAMPLE: Distortion = Distortion {
        k1: -0.27,
        k2: -0.04,
        p1: 0.0018,
        p2: -0.0003,
        k3: 0.24,
    };

    #[test]
    fn jacobian_matches_finite_differences() {
        let p = Point2::new(0.41, -0.33);
        let j = OPENCV_SAMPLE.jacobian(p);
        let h = 1e-7;
        for c in 0..2 {
            let mut a = p;
            let mut b = p;
            a[c] += h;
            b[c] -= h;
            let d = (OPENCV_SAMPLE.distort(a) - OPENCV_SAMPLE.distort(b)) / (2.0 * h);
            assert!(
                (d - j.column(c)).norm() < 1e-6,
                "column {c}: {d} vs {}",
                j.column(c)
            );
        }
    }

    #[test]
    fn undistort_inverts_distort() {
        for &(x, y) in &[(0.0, 0.0), (0.1, 0.2), (-0.6, 0.45), (0.8, -0.5)] {
            let p = Point2::new(x, y);
            let back = OPENCV_SAMPLE.undistort(OPENCV_SAMPLE.distort(p));
            assert!(
                back.is_some_and(|b| (b - p).norm() < 1e-12),
                "{p} -> {back:?}"
            );
        }
    }

    #[test]
    fn opencv_vector_order() -> Result<()> {
        let d = Distortion::from_opencv(&[1.0, 2.0, 3.0, 4.0, 5.0])?;
        assert_eq!(d.to_array(), [1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(Distortion::from_opencv(&[1.0, 2.0, 3.0, 4.0])?.k3, 0.0);
        assert!(Distortion::from_opencv(&[1.0]).is_err());
        assert!(Distortion::from_opencv(&[f64::NAN, 0.0, 0.0, 0.0]).is_err());
        Ok(())
    }
}
