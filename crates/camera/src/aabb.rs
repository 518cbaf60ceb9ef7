//! Axis-aligned boxes in the turntable frame.

use nalgebra::{Point3, Vector3};

use crate::camera::Ray;
use crate::error::{Error, Result};

/// An axis-aligned box `[min, max]` (metres), for example the volume a voxel grid covers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Point3<f64>,
    /// The corner with the largest coordinates.
    pub max: Point3<f64>,
}

impl Aabb {
    /// The box between two corners; rejects non-finite corners and `min > max` on any axis.
    pub fn new(min: Point3<f64>, max: Point3<f64>) -> Result<Self> {
        if !(min.iter().chain(max.iter()).all(|v| v.is_finite())) {
            return Err(Error::Degenerate("a box corner is not finite".into()));
        }
        if (0..3).any(|i| min[i] > max[i]) {
            return Err(Error::Degenerate(format!(
                "box min ({}, {}, {}) exceeds max ({}, {}, {}) on some axis",
                min.x, min.y, min.z, max.x, max.y, max.z
            )));
        }
        Ok(Aabb { min, max })
    }

    /// The smallest box holding every point (`None` for no points).
    pub fn around(points: impl IntoIterator<Item = Point3<f64>>) -> Option<Self> {
        let mut it = points.into_iter();
        let first = it.next()?;
        let (min, max) = it.fold((first, first), |(lo, hi), p| (lo.inf(&p), hi.sup(&p)));
        Some(Aabb { min, max })
    }

    /// The box grown by `margin` metres on every side.
    pub fn expanded(&self, margin: f64) -> Self {
        let m = Vector3::repeat(margin);
        Aabb {
            min: self.min - m,
            max: self.max + m,
        }
    }

    /// The smallest box holding both.
    pub fn union(&self, other: &Aabb) -> Self {
        Aabb {
            min: self.min.inf(&other.min),
            max: self.max.sup(&other.max),
        }
    }

    /// Edge lengths.
    pub fn extent(&self) -> Vector3<f64> {
        self.max - self.min
    }

    /// Centre point.
    pub fn centre(&self) -> Point3<f64> {
        nalgebra::center(&self.min, &self.max)
    }

    /// True when `p` lies inside or on the box.
    pub fn contains(&self, p: &Point3<f64>) -> bool {
        (0..3).all(|i| p[i] >= self.min[i] && p[i] <= self.max[i])
    }

    /// The eight corners.
    pub fn corners(&self) -> [Point3<f64>; 8] {
        let (a, b) = (self.min, self.max);
        [
            Point3::new(a.x, a.y, a.z),
            Point3::new(b.x, a.y, a.z),
            Point3::new(a.x, b.y, a.z),
            Point3::new(b.x, b.y, a.z),
            Point3::new(a.x, a.y, b.z),
            Point3::new(b.x, a.y, b.z),
            Point3::new(a.x, b.y, b.z),
            Point3::new(b.x, b.y, b.z),
        ]
    }

    /// The parameter interval `[t_enter, t_exit]` (clipped to `t >= 0`) where `ray` is inside
    /// the box, or `None` when it misses. `t` is the distance along the ray's unit direction.
    pub fn intersect(&self, ray: &Ray) -> Option<(f64, f64)> {
        slab(&self.min, &self.max, &ray.origin, ray.direction.as_ref())
    }
}

/// Slab test of the ray `origin + t dir` against `[min, max]`, for any (not necessarily unit)
/// direction; `t` is in units of `dir`.
#[inline]
pub fn slab(
    min: &Point3<f64>,
    max: &Point3<f64>,
    origin: &Point3<f64>,
    dir: &Vector3<f64>,
) -> Option<(f64, f64)> {
    let mut t0 = 0.0f64;
    let mut t1 = f64::INFINITY;
    for i in 0..3 {
        let inv = 1.0 / dir[i];
        let mut a = (min[i] - origin[i]) * inv;
        let mut b = (max[i] - origin[i]) * inv;
        if a > b {
            std::mem::swap(&mut a, &mut b);
        }
        // NaN (origin on a slab plane with dir[i] = 0) keeps the current bounds.
        if a > t0 {
            t0 = a;
        }
        if b < t1 {
            t1 = b;
        }
        if t0 > t1 {
            return None;
        }
    }
    Some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Unit;

    #[test]
    fn ray_box() -> Result<()> {
        let b = Aabb::new(Point3::new(-1.0, -1.0, -1.0), Point3::new(1.0, 1.0, 1.0))?;
        let ray = Ray {
            origin: Point3::new(-5.0, 0.0, 0.0),
            direction: Vector3::x_axis(),
        };
        assert_eq!(b.intersect(&ray), Some((4.0, 6.0)));
        let miss = Ray {
            origin: Point3::new(-5.0, 2.0, 0.0),
            direction: Vector3::x_axis(),
        };
        assert_eq!(b.intersect(&miss), None);
        let inside = Ray {
            origin: Point3::origin(),
            direction: Unit::new_normalize(Vector3::new(1.0, 1.0, 0.0)),
        };
        let (t0, t1) = b.intersect(&inside).unwrap_or((9.0, 9.0));
        assert!(t0 == 0.0 && (t1 - 2f64.sqrt()).abs() < 1e-12);
        assert!(Aabb::new(Point3::new(1.0, 0.0, 0.0), Point3::origin()).is_err());
        Ok(())
    }

    #[test]
    fn around_points() {
        let b = Aabb::around([Point3::new(1.0, -2.0, 0.5), Point3::new(-1.0, 3.0, 0.0)]);
        assert_eq!(
            b,
            Some(Aabb {
                min: Point3::new(-1.0, -2.0, 0.0),
                max: Point3::new(1.0, 3.0, 0.5)
            })
        );
        assert_eq!(Aabb::around(std::iter::empty()), None);
    }
}
