//! Analytic primitives: intersection, bounds, inside test and uniform surface sampling.

use aibr_camera::Aabb;
use nalgebra::{Point3, Vector3};

use crate::rng::SplitMix64;

/// An analytic primitive in the object (turntable) frame, metres.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// An axis-aligned ellipsoid (a sphere when the radii are equal).
    Ellipsoid {
        /// Centre.
        centre: Point3<f64>,
        /// Semi-axes along x, y, z.
        radii: Vector3<f64>,
    },
    /// An axis-aligned box.
    Cuboid {
        /// Smallest corner.
        min: Point3<f64>,
        /// Largest corner.
        max: Point3<f64>,
    },
    /// A capped cylinder standing along +Z.
    Cylinder {
        /// Centre of the bottom cap.
        base: Point3<f64>,
        /// Radius.
        radius: f64,
        /// Height above the base.
        height: f64,
    },
    /// A parallelogram `corner + a u + b v`, `a, b` in `[0, 1]`; seen from both sides.
    Quad {
        /// One corner.
        corner: Point3<f64>,
        /// First edge.
        u: Vector3<f64>,
        /// Second edge.
        v: Vector3<f64>,
    },
}

/// A ray-surface intersection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter (in units of the ray direction given).
    pub t: f64,
    /// Unit surface normal, outward (for a quad: toward the side the ray came from).
    pub normal: Vector3<f64>,
}

impl Shape {
    /// A sphere.
    pub fn sphere(centre: Point3<f64>, radius: f64) -> Self {
        Shape::Ellipsoid {
            centre,
            radii: Vector3::repeat(radius),
        }
    }

    /// Nearest intersection of `origin + t dir` with `t` in `(t_min, t_max)`.
    pub fn intersect(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        t_min: f64,
        t_max: f64,
    ) -> Option<Hit> {
        match self {
            Shape::Ellipsoid { centre, radii } => {
                let o = (origin - centre).component_div(radii);
                let d = dir.component_div(radii);
                let a = d.dot(&d);
                let b = o.dot(&d);
                let c = o.dot(&o) - 1.0;
                let disc = b * b - a * c;
                if disc < 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                let mut t = (-b - sq) / a;
                if t <= t_min {
                    t = (-b + sq) / a;
                }
                if t <= t_min || t >= t_max {
                    return None;
                }
                let p = origin + dir * t;
                let n = (p - centre).component_div(&radii.component_mul(radii));
                Some(Hit {
                    t,
                    normal: n.normalize(),
                })
            }
            Shape::Cuboid { min, max } => {
                let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
                let (mut a0, mut a1) = (0usize, 0usize);
                for i in 0..3 {
                    let inv = 1.0 / dir[i];
                    let mut ta = (min[i] - origin[i]) * inv;
                    let mut tb = (max[i] - origin[i]) * inv;
                    if ta > tb {
                        std::mem::swap(&mut ta, &mut tb);
                    }
                    if ta > t0 {
                        t0 = ta;
                        a0 = i;
                    }
                    if tb < t1 {
                        t1 = tb;
                        a1 = i;
                    }
                }
                if t0 > t1 {
                    return None;
                }
                let (t, axis, exit) = if t0 > t_min {
                    (t0, a0, false)
                } else {
                    (t1, a1, true)
                };
                if t <= t_min || t >= t_max {
                    return None;
                }
                let mut normal = Vector3::zeros();
                // Entering: the normal opposes the ray; leaving: it follows it.
                normal[axis] = if (dir[axis] < 0.0) != exit { 1.0 } else { -1.0 };
                Some(Hit { t, normal })
            }
            Shape::Cylinder {
                base,
                radius,
                height,
            } => {
                let mut best: Option<Hit> = None;
                let mut consider = |t: f64, normal: Vector3<f64>| {
                    if t > t_min && t < t_max && best.is_none_or(|b| t < b.t) {
                        best = Some(Hit { t, normal });
                    }
                };
                let (ox, oy) = (origin.x - base.x, origin.y - base.y);
                let a = dir.x * dir.x + dir.y * dir.y;
                if a > 0.0 {
                    let b = ox * dir.x + oy * dir.y;
                    let c = ox * ox + oy * oy - radius * radius;
                    let disc = b * b - a * c;
                    if disc >= 0.0 {
                        let sq = disc.sqrt();
                        for t in [(-b - sq) / a, (-b + sq) / a] {
                            let z = origin.z + t * dir.z - base.z;
                            if (0.0..=*height).contains(&z) {
                                let n = Vector3::new(ox + t * dir.x, oy + t * dir.y, 0.0) / *radius;
                                consider(t, n);
                            }
                        }
                    }
                }
                if dir.z != 0.0 {
                    for (z, nz) in [(base.z, -1.0), (base.z + height, 1.0)] {
                        let t = (z - origin.z) / dir.z;
                        let (x, y) = (ox + t * dir.x, oy + t * dir.y);
                        if x * x + y * y <= radius * radius {
                            consider(t, Vector3::new(0.0, 0.0, nz));
                        }
                    }
                }
                best
            }
            Shape::Quad { corner, u, v } => {
                let n = u.cross(v);
                let denom = n.dot(dir);
                if denom == 0.0 {
                    return None;
                }
                let t = n.dot(&(corner - origin)) / denom;
                if t <= t_min || t >= t_max {
                    return None;
                }
                let rel = origin + dir * t - corner;
                let w = n / n.dot(&n);
                let a = w.dot(&rel.cross(v));
                let b = w.dot(&u.cross(&rel));
                if !(0.0..=1.0).contains(&a) || !(0.0..=1.0).contains(&b) {
                    return None;
                }
                let n = n.normalize();
                Some(Hit {
                    t,
                    normal: if denom < 0.0 { n } else { -n },
                })
            }
        }
    }

    /// The planes of its flat vertical sides, each as an outward unit normal `n` and an offset
    /// `d` (the points `x` with `n . x = d`): a cuboid's four; none for the other shapes (an
    /// ellipsoid's and a cylinder's sides are curved, a quad is seen from both sides).
    pub fn side_planes(&self) -> Vec<(Vector3<f64>, f64)> {
        match self {
            Shape::Cuboid { min, max } => vec![
                (Vector3::x(), max.x),
                (-Vector3::x(), -min.x),
                (Vector3::y(), max.y),
                (-Vector3::y(), -min.y),
            ],
            Shape::Ellipsoid { .. } | Shape::Cylinder { .. } | Shape::Quad { .. } => Vec::new(),
        }
    }

    /// The axis-aligned bounds.
    pub fn bounds(&self) -> Aabb {
        match self {
            Shape::Ellipsoid { centre, radii } => Aabb {
                min: centre - radii,
                max: centre + radii,
            },
            Shape::Cuboid { min, max } => Aabb {
                min: *min,
                max: *max,
            },
            Shape::Cylinder {
                base,
                radius,
                height,
            } => Aabb {
                min: Point3::new(base.x - radius, base.y - radius, base.z),
                max: Point3::new(base.x + radius, base.y + radius, base.z + height),
            },
            Shape::Quad { corner, u, v } => {
                let pts = [*corner, corner + u, corner + v, corner + u + v];
                Aabb::around(pts).unwrap_or(Aabb {
                    min: *corner,
                    max: *corner,
                })
            }
        }
    }

    /// True when `p` is inside the solid by more than `eps` (a quad has no inside).
    pub fn contains(&self, p: &Point3<f64>, eps: f64) -> bool {
        match self {
            Shape::Ellipsoid { centre, radii } => {
                let shrunk = radii.map(|r| (r - eps).max(0.0));
                shrunk.iter().all(|&r| r > 0.0)
                    && (p - centre).component_div(&shrunk).norm_squared() < 1.0
            }
            Shape::Cuboid { min, max } => {
                (0..3).all(|i| p[i] > min[i] + eps && p[i] < max[i] - eps)
            }
            Shape::Cylinder {
                base,
                radius,
                height,
            } => {
                let r = radius - eps;
                let (dx, dy) = (p.x - base.x, p.y - base.y);
                r > 0.0
                    && dx * dx + dy * dy < r * r
                    && p.z > base.z + eps
                    && p.z < base.z + height - eps
            }
            Shape::Quad { .. } => false,
        }
    }

    /// Surface area, square metres (an ellipsoid's by Thomsen's formula, within about 1%).
    pub fn area(&self) -> f64 {
        match self {
            Shape::Ellipsoid { radii, .. } => {
                let p = 1.6075;
                let (a, b, c) = (radii.x.powf(p), radii.y.powf(p), radii.z.powf(p));
                4.0 * std::f64::consts::PI * ((a * b + a * c + b * c) / 3.0).powf(1.0 / p)
            }
            Shape::Cuboid { min, max } => {
                let e = max - min;
                2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
            }
            Shape::Cylinder { radius, height, .. } => {
                std::f64::consts::TAU * radius * (height + radius)
            }
            Shape::Quad { u, v, .. } => u.cross(v).norm(),
        }
    }

    /// A point uniformly distributed over the surface, with its outward normal.
    pub fn sample_surface(&self, rng: &mut SplitMix64) -> (Point3<f64>, Vector3<f64>) {
        match self {
            Shape::Ellipsoid { centre, radii } => loop {
                // A uniform direction, accepted in proportion to the ellipsoid's area element.
                let z = 2.0 * rng.uniform() - 1.0;
                let phi = std::f64::consts::TAU * rng.uniform();
                let s = (1.0 - z * z).max(0.0).sqrt();
                let u = Vector3::new(s * phi.cos(), s * phi.sin(), z);
                let (a, b, c) = (radii.x, radii.y, radii.z);
                let element = Vector3::new(b * c * u.x, a * c * u.y, a * b * u.z).norm();
                let most = (b * c).max(a * c).max(a * b);
                if rng.uniform() * most <= element {
                    let p = centre + radii.component_mul(&u);
                    let n = (p - centre).component_div(&radii.component_mul(radii));
                    return (p, n.normalize());
                }
            },
            Shape::Cuboid { min, max } => {
                let e = max - min;
                let faces = [
                    e.y * e.z,
                    e.y * e.z,
                    e.x * e.z,
                    e.x * e.z,
                    e.x * e.y,
                    e.x * e.y,
                ];
                let total: f64 = faces.iter().sum();
                let mut pick = rng.uniform() * total;
                let mut face = 5;
                for (i, a) in faces.iter().enumerate() {
                    if pick < *a {
                        face = i;
                        break;
                    }
                    pick -= a;
                }
                let axis = face / 2;
                let mut p = Point3::new(
                    min.x + rng.uniform() * e.x,
                    min.y + rng.uniform() * e.y,
                    min.z + rng.uniform() * e.z,
                );
                let mut n = Vector3::zeros();
                if face % 2 == 0 {
                    p[axis] = min[axis];
                    n[axis] = -1.0;
                } else {
                    p[axis] = max[axis];
                    n[axis] = 1.0;
                }
                (p, n)
            }
            Shape::Cylinder {
                base,
                radius,
                height,
            } => {
                let side = std::f64::consts::TAU * radius * height;
                let cap = std::f64::consts::PI * radius * radius;
                let pick = rng.uniform() * (side + 2.0 * cap);
                let phi = std::f64::consts::TAU * rng.uniform();
                if pick < side {
                    let n = Vector3::new(phi.cos(), phi.sin(), 0.0);
                    let z = rng.uniform() * height;
                    (base + n * *radius + Vector3::new(0.0, 0.0, z), n)
                } else {
                    let r = radius * rng.uniform().sqrt();
                    let top = pick >= side + cap;
                    let z = if top { *height } else { 0.0 };
                    let p = base + Vector3::new(r * phi.cos(), r * phi.sin(), z);
                    (p, Vector3::new(0.0, 0.0, if top { 1.0 } else { -1.0 }))
                }
            }
            Shape::Quad { corner, u, v } => {
                let p = corner + u * rng.uniform() + v * rng.uniform();
                (p, u.cross(v).normalize())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shapes() -> Vec<Shape> {
        vec![
            Shape::Ellipsoid {
                centre: Point3::new(0.1, -0.2, 0.3),
                radii: Vector3::new(0.05, 0.08, 0.12),
            },
            Shape::Cuboid {
                min: Point3::new(-0.1, -0.05, 0.0),
                max: Point3::new(0.1, 0.05, 0.2),
            },
            Shape::Cylinder {
                base: Point3::new(0.02, 0.01, 0.05),
                radius: 0.04,
                height: 0.1,
            },
        ]
    }

    /// Rays from outside toward sampled surface points hit exactly there.
    #[test]
    fn sampled_points_are_hit() {
        let mut rng = SplitMix64::new(11);
        for s in shapes() {
            for _ in 0..500 {
                let (p, n) = s.sample_surface(&mut rng);
                assert!(s.bounds().expanded(1e-12).contains(&p));
                let origin = p + n * 0.5 + Vector3::new(0.01, -0.02, 0.015);
                let dir = p - origin;
                let hit = s.intersect(&origin, &dir, 1e-9, f64::INFINITY);
                let Some(hit) = hit else {
                    panic!("{s:?} missed {p}")
                };
                assert!((hit.t - 1.0).abs() < 1e-6, "{s:?}: t = {}", hit.t);
                assert!(
                    (hit.normal - n).norm() < 1e-6,
                    "{s:?}: {} vs {n}",
                    hit.normal
                );
                assert!(!s.contains(&p, 1e-9));
                assert!(s.contains(&(p - n * 1e-4), 1e-6) || matches!(s, Shape::Cylinder { .. }));
            }
        }
    }

    #[test]
    fn quad_faces_the_ray() {
        let q = Shape::Quad {
            corner: Point3::new(-1.0, -1.0, 0.0),
            u: Vector3::new(2.0, 0.0, 0.0),
            v: Vector3::new(0.0, 2.0, 0.0),
        };
        let down = q.intersect(&Point3::new(0.2, 0.3, 1.0), &-Vector3::z(), 0.0, 10.0);
        assert_eq!(down.map(|h| (h.t, h.normal)), Some((1.0, Vector3::z())));
        let up = q.intersect(&Point3::new(0.2, 0.3, -2.0), &Vector3::z(), 0.0, 10.0);
        assert_eq!(up.map(|h| (h.t, h.normal)), Some((2.0, -Vector3::z())));
        assert_eq!(
            q.intersect(&Point3::new(1.2, 0.3, 1.0), &-Vector3::z(), 0.0, 10.0),
            None
        );
        assert!((q.area() - 4.0).abs() < 1e-12);
    }

    #[test]
    fn a_cuboid_has_four_side_planes_through_its_corners_and_the_rest_none() {
        for shape in shapes() {
            let planes = shape.side_planes();
            let Shape::Cuboid { min, max } = shape else {
                assert!(planes.is_empty(), "{shape:?}: {planes:?}");
                continue;
            };
            assert_eq!(planes.len(), 4);
            let corners: Vec<Point3<f64>> = (0..8)
                .map(|i| {
                    let pick = |bit, lo: f64, hi: f64| if i & bit == 0 { lo } else { hi };
                    Point3::new(
                        pick(1, min.x, max.x),
                        pick(2, min.y, max.y),
                        pick(4, min.z, max.z),
                    )
                })
                .collect();
            let centre = nalgebra::center(&min, &max);
            for (n, d) in planes {
                assert!((n.norm() - 1.0).abs() < 1e-12 && n.z == 0.0, "{n:?}");
                let on = corners
                    .iter()
                    .filter(|c| (n.dot(&c.coords) - d).abs() < 1e-12);
                assert_eq!(on.count(), 4, "{n:?} {d}");
                assert!(corners.iter().all(|c| n.dot(&c.coords) <= d + 1e-12));
                assert!(n.dot(&centre.coords) < d, "{n:?} {d}: outward");
            }
        }
    }

    #[test]
    fn areas() {
        let sphere = Shape::sphere(Point3::origin(), 1.0);
        assert!((sphere.area() - 4.0 * std::f64::consts::PI).abs() < 1e-9);
        let c = Shape::Cuboid {
            min: Point3::origin(),
            max: Point3::new(1.0, 2.0, 3.0),
        };
        assert!((c.area() - 22.0).abs() < 1e-12);
    }
}
