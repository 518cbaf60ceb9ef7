//! Pinhole intrinsics and image sizes.

use nalgebra::{Matrix3, Point2};

use crate::error::{Error, Result};

/// Pinhole intrinsics in pixels: `u = fx x + skew y + cx`, `v = fy y + cy` for a point
/// `(x, y)` on the normalised image plane `z = 1`.
///
/// This is the upper-triangular matrix `K = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]`.
/// `skew` is in pixels (OpenCV has none; Bouguet's `alpha_c` is `skew / fx`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels (pixel (0,0) is the centre of the top-left pixel).
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Skew, pixels: the `K[0][1]` entry.
    pub skew: f64,
}

impl Intrinsics {
    /// Intrinsics without skew.
    pub const fn new(fx: f64, fy: f64, cx: f64, cy: f64) -> Self {
        Intrinsics {
            fx,
            fy,
            cx,
            cy,
            skew: 0.0,
        }
    }

    /// Checks that every entry is finite and both focal lengths are positive.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [
            ("fx", self.fx),
            ("fy", self.fy),
            ("cx", self.cx),
            ("cy", self.cy),
            ("skew", self.skew),
        ] {
            if !v.is_finite() {
                return Err(Error::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite",
                });
            }
        }
        for (name, v) in [("fx", self.fx), ("fy", self.fy)] {
            if v <= 0.0 {
                return Err(Error::InvalidParameter {
                    name,
                    value: v,
                    reason: "focal length must be positive",
                });
            }
        }
        Ok(())
    }

    /// Reads `K` (any positive scale: it is divided by `K[2][2]`). The lower triangle must be
    /// zero to within `1e-9` of the scale.
    pub fn from_matrix(k: &Matrix3<f64>) -> Result<Self> {
        let s = k[(2, 2)];
        if !s.is_finite() || s <= 0.0 {
            return Err(Error::InvalidParameter {
                name: "K[2][2]",
                value: s,
                reason: "must be positive",
            });
        }
        for (r, c) in [(1, 0), (2, 0), (2, 1)] {
            let v = k[(r, c)] / s;
            if !(v.abs() <= 1e-9) {
                return Err(Error::InvalidParameter {
                    name: "K lower triangle",
                    value: v,
                    reason: "K must be upper triangular",
                });
            }
        }
        let i = Intrinsics {
            fx: k[(0, 0)] / s,
            fy: k[(1, 1)] / s,
            cx: k[(0, 2)] / s,
            cy: k[(1, 2)] / s,
            skew: k[(0, 1)] / s,
        };
        i.validate()?;
        Ok(i)
    }

    /// The matrix `K`.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::new(
            self.fx, self.skew, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0,
        )
    }

    /// Pixel of a point on the normalised image plane.
    #[inline]
    pub fn pixel_from_normalized(&self, p: Point2<f64>) -> Point2<f64> {
        Point2::new(
            self.fx * p.x + self.skew * p.y + self.cx,
            self.fy * p.y + self.cy,
        )
    }

    /// Point on the normalised image plane of a pixel (the inverse of
    /// [`pixel_from_normalized`](Self::pixel_from_normalized)).
    #[inline]
    pub fn normalized_from_pixel(&self, px: Point2<f64>) -> Point2<f64> {
        let y = (px.y - self.cy) / self.fy;
        let x = (px.x - self.cx - self.skew * y) / self.fx;
        Point2::new(x, y)
    }
}

/// Width and height of an image, pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ImageSize {
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

impl ImageSize {
    /// A size of `width` x `height`.
    pub const fn new(width: u32, height: u32) -> Self {
        ImageSize { width, height }
    }

    /// Number of pixels.
    pub const fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// True when `px` lies on the image: within half a pixel of the outer pixel centres.
    #[inline]
    pub fn contains(&self, px: Point2<f64>) -> bool {
        px.x >= -0.5
            && px.y >= -0.5
            && px.x < self.width as f64 - 0.5
            && px.y < self.height as f64 - 0.5
    }

    /// The centres of the four corner pixels.
    pub fn corner_pixels(&self) -> [Point2<f64>; 4] {
        let (w, h) = (self.width as f64 - 1.0, self.height as f64 - 1.0);
        [
            Point2::new(0.0, 0.0),
            Point2::new(w, 0.0),
            Point2::new(0.0, h),
            Point2::new(w, h),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matrix_round_trip() -> Result<()> {
        let k = Intrinsics {
            fx: 500.0,
            fy: 510.0,
            cx: 320.0,
            cy: 240.0,
            skew: 1.5,
        };
        assert_eq!(Intrinsics::from_matrix(&(k.matrix() * 3.0))?, k);
        let p = Point2::new(0.3, -0.2);
        let back = k.normalized_from_pixel(k.pixel_from_normalized(p));
        assert!((back - p).norm() < 1e-12);
        Ok(())
    }

    #[test]
    fn rejects_bad_matrices() {
        let mut m = Intrinsics::new(500.0, 500.0, 320.0, 240.0).matrix();
        m[(1, 0)] = 3.0;
        assert!(Intrinsics::from_matrix(&m).is_err());
        assert!(Intrinsics::new(-1.0, 500.0, 0.0, 0.0).validate().is_err());
        assert!(
            Intrinsics::new(f64::NAN, 500.0, 0.0, 0.0)
                .validate()
                .is_err()
        );
    }
}
