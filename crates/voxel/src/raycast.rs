//! Ray casting through a voxel model (3D DDA) and depth maps.

use aibr_camera::Camera;
use image::{ImageBuffer, Luma};
use nalgebra::{Point2, Point3, Vector3};
use rayon::prelude::*;

use crate::grid::VoxelModel;

/// The first occupied voxel along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelHit {
    /// The voxel, `[i, j, k]`.
    pub voxel: [usize; 3],
    /// Ray parameter where the ray enters that voxel (in units of the direction given).
    pub t: f64,
}

/// A depth image: camera-z of the first surface per pixel, `f32::INFINITY` where the ray
/// meets nothing.
pub type DepthMap = ImageBuffer<Luma<f32>, Vec<f32>>;

impl VoxelModel {
    /// The first occupied voxel along `origin + t dir`, `t >= 0` (Amanatides-Woo 3D DDA).
    /// `dir` need not be a unit vector; `t` is in its units.
    pub fn raycast(&self, origin: &Point3<f64>, dir: &Vector3<f64>) -> Option<VoxelHit> {
        self.raycast_from(origin, dir, 0.0)
    }

    /// Like [`raycast`](Self::raycast), starting at `t_start` (voxels before it are ignored;
    /// the voxel holding the start point counts, with `t = t_start`).
    ///
    /// Reads [`occupied`](Self::occupied) in memory order, as the constructors lay it out; an
    /// array of another layout put in that field is copied into that order for every ray,
    /// which is correct but slow.
    pub fn raycast_from(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        t_start: f64,
    ) -> Option<VoxelHit> {
        let grid = self.grid();
        let b = grid.bounds();
        let (t_enter, t_exit) = aibr_camera::aabb::slab(&b.min, &b.max, origin, dir)?;
        let t_enter = t_enter.max(t_start);
        if t_enter > t_exit {
            return None;
        }
        let dims = grid.dims();
        let s = grid.voxel_size();
        // Start in the voxel holding the entry point, nudged inside.
        let p = origin + dir * t_enter;
        let mut cell = [0i64; 3];
        let mut step = [0i64; 3];
        let mut t_max = [f64::INFINITY; 3];
        let mut t_delta = [f64::INFINITY; 3];
        for a in 0..3 {
            let local = (p[a] - b.min[a]) / s;
            // Truncation is the floor for `local >= 0`, and both clamp to 0 below it (NaN too);
            // unlike `floor`, it needs no call into libm on baseline x86-64.
            let c = (local as i64).clamp(0, dims[a] as i64 - 1);
            cell[a] = c;
            if dir[a] > 0.0 {
                step[a] = 1;
                t_delta[a] = s / dir[a];
                t_max[a] = t_enter + ((c + 1) as f64 * s + b.min[a] - p[a]) / dir[a];
            } else if dir[a] < 0.0 {
                step[a] = -1;
                t_delta[a] = -s / dir[a];
                t_max[a] = t_enter + (c as f64 * s + b.min[a] - p[a]) / dir[a];
            }
        }
        let mut t = t_enter;
        // The occupancy in memory order (`[[k, j, i]]`; a view of it unless the field was
        // replaced by an array of another layout), so a step moves a linear index by the
        // axis's stride. (Reading another layout by cell instead of copying it, or the walk as
        // a generic over the two, measured 1-5% slower frames in the renderer, session 15.)
        let occupied = self.occupied.as_standard_layout();
        // Indexed `[[k, j, i]]`: the strides of `i`, `j` and `k` are its last, middle and first.
        let stride = match *occupied.strides() {
            [sk, sj, si] => [si, sj, sk],
            _ => [0; 3], // an `Array3` has three
        };
        let occupied = occupied.as_slice().unwrap_or(&[]);
        let mut at: isize = (0..3).map(|a| cell[a] as isize * stride[a]).sum();
        loop {
            if occupied.get(at as usize) == Some(&true) {
                let voxel = [cell[0] as usize, cell[1] as usize, cell[2] as usize];
                return Some(VoxelHit { voxel, t });
            }
            // Advance along the axis whose boundary comes first.
            let a = if t_max[0] < t_max[1] {
                if t_max[0] < t_max[2] { 0 } else { 2 }
            } else if t_max[1] < t_max[2] {
                1
            } else {
                2
            };
            t = t_max[a];
            if t > t_exit {
                return None;
            }
            cell[a] += step[a];
            if cell[a] < 0 || cell[a] >= dims[a] as i64 {
                return None;
            }
            at += step[a] as isize * stride[a];
            t_max[a] += t_delta[a];
        }
    }

    /// The depth map of the model seen by `camera`: per pixel, the camera-z where its ray
    /// enters the first occupied voxel.
    ///
    /// The surface voxels are first splatted (half their diagonal plus a pixel, so every ray
    /// that meets a voxel lands in a splat); each ray's DDA then starts a voxel before the
    /// nearest splat, and pixels no splat covers meet no voxel.
    pub fn depth_map(&self, camera: &Camera) -> DepthMap {
        let (w, h) = (camera.size.width as usize, camera.size.height as usize);
        let grid = self.grid();
        let s = grid.voxel_size();
        let centres: Vec<Point3<f64>> = self
            .surface_voxels()
            .into_iter()
            .map(|v| grid.centre(v))
            .collect();
        let mut splat = vec![f32::INFINITY; w * h];
        splat_depths(&centres, s, camera, &mut splat);
        let origin = camera.centre();
        let rot = camera.world_from_cam().rotation;
        let margin = SPLAT_MARGIN_VOXELS * s;
        let mut data = vec![f32::INFINITY; w * h];
        data.par_chunks_mut(w)
            .zip(splat.par_chunks(w))
            .enumerate()
            .for_each(|(v, (row, starts))| {
                for (u, (d, start)) in row.iter_mut().zip(starts).enumerate() {
                    if !start.is_finite() {
                        continue;
                    }
                    let Some(n) = camera.normalized_from_pixel(Point2::new(u as f64, v as f64))
                    else {
                        continue;
                    };
                    // Camera-z = 1 direction: the ray parameter is the depth.
                    let dir = rot * Vector3::new(n.x, n.y, 1.0);
                    let from = (*start as f64 - margin).max(0.0);
                    if let Some(hit) = self.raycast_from(&origin, &dir, from) {
                        *d = hit.t as f32;
                    }
                }
            });
        DepthMap::from_raw(w as u32, h as u32, data)
            .unwrap_or_else(|| DepthMap::new(w as u32, h as u32))
    }
}

/// How far in front of a pixel's splatted depth ([`splat_depths`] of the model's surface
/// voxels) its ray may start casting and still meet the model's first occupied voxel, in
/// voxels: one. The first occupied voxel a ray meets is a surface voxel (the ray entered it
/// from an empty or out-of-grid 6-neighbour), so its splat covers the pixel and its centre is
/// not nearer than the splatted depth; and no point of a voxel is nearer than its centre by
/// more than half its diagonal, 0.87 voxels.
pub const SPLAT_MARGIN_VOXELS: f64 = 1.0;

/// Splats voxels (by their centres, edge `voxel_size`) into `out`, a `width * height`
/// buffer of `camera`'s image: each pixel gets the smallest camera-z of the voxels whose
/// splat covers it (half the projected voxel diagonal plus a pixel, two with distortion,
/// so every ray that meets one of the voxels lands in its splat); other pixels are set to
/// infinity. The fast start of ray casting ([`VoxelModel::depth_map`] and the renderer).
pub fn splat_depths(centres: &[Point3<f64>], voxel_size: f64, camera: &Camera, out: &mut [f32]) {
    let (w, h) = (camera.size.width as usize, camera.size.height as usize);
    out.fill(f32::INFINITY);
    // An empty image (a size edited to zero after the camera was made) has no rows to band.
    if out.len() != w * h || out.is_empty() {
        return;
    }
    let f = camera.intrinsics.fx.max(camera.intrinsics.fy);
    let pad = if camera.distortion.is_none() {
        1.0
    } else {
        2.0
    };
    // One band of rows per thread: each projects every voxel and writes the rows of its band,
    // so the writes, which cost most, are shared and no two threads touch a pixel.
    let band = h.div_ceil(rayon::current_num_threads().max(1));
    out.par_chunks_mut(w * band)
        .enumerate()
        .for_each(|(b, rows)| {
            let first = b * band;
            let last = first + rows.len() / w - 1;
            for c in centres {
                let z = camera.depth_of(c);
                if !(z > 0.0) {
                    continue;
                }
                let Some(px) = camera.project(c) else {
                    continue;
                };
                let r = 0.87 * voxel_size * f / z + pad;
                let (u0, u1) = (
                    (px.x - r).floor().max(0.0),
                    (px.x + r).ceil().min(w as f64 - 1.0),
                );
                let (v0, v1) = (
                    (px.y - r).floor().max(first as f64),
                    (px.y + r).ceil().min(last as f64),
                );
                if u0 > u1 || v0 > v1 {
                    continue;
                }
                for yy in v0 as usize - first..=v1 as usize - first {
                    for d in &mut rows[yy * w + u0 as usize..=yy * w + u1 as usize] {
                        *d = d.min(z as f32);
                    }
                }
            }
        });
}

/// True when `camera` sees the world point `p` according to its `depth` map: `p` projects
/// into the image, in front of the camera, and no surface lies more than `tolerance_m`
/// in front of it.
pub fn is_visible(camera: &Camera, depth: &DepthMap, p: &Point3<f64>, tolerance_m: f64) -> bool {
    let Some(px) = camera.project(p) else {
        return false;
    };
    if !camera.size.contains(px) {
        return false;
    }
    let (u, v) = (px.x.round().max(0.0) as u32, px.y.round().max(0.0) as u32);
    let Some(d) = depth.get_pixel_checked(u, v) else {
        return false;
    };
    camera.depth_of(p) <= d.0[0] as f64 + tolerance_m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::VoxelGrid;
    use aibr_camera::Aabb;

    fn model() -> crate::Result<VoxelModel> {
        let g = VoxelGrid::with_resolution(
            Aabb {
                min: Point3::new(0.0, 0.0, 0.0),
                max: Point3::new(1.0, 1.0, 1.0),
            },
            10,
        )?;
        let mut m = VoxelModel::empty(g);
        m.set([3, 4, 5], [1, 2, 3]);
        m.set([7, 4, 5], [1, 2, 3]);
        Ok(m)
    }

    #[test]
    fn dda_finds_the_first_voxel() -> crate::Result<()> {
        let m = model()?;
        let hit = m.raycast(&Point3::new(-1.0, 0.45, 0.55), &Vector3::new(2.0, 0.0, 0.0));
        assert_eq!(hit.map(|h| h.voxel), Some([3, 4, 5]));
        assert!(hit.is_some_and(|h| (h.t - 0.65).abs() < 1e-12));
        let back = m.raycast(&Point3::new(2.0, 0.45, 0.55), &Vector3::new(-1.0, 0.0, 0.0));
        assert_eq!(back.map(|h| h.voxel), Some([7, 4, 5]));
        assert!(back.is_some_and(|h| (h.t - 1.2).abs() < 1e-12));
        // Diagonal rays that pass no occupied voxel.
        assert_eq!(
            m.raycast(&Point3::new(-1.0, -1.0, -1.0), &Vector3::new(1.0, 1.0, 1.0)),
            None
        );
        // A ray starting inside the grid.
        let inside = m.raycast(&Point3::new(0.5, 0.45, 0.55), &Vector3::new(1.0, 0.0, 0.0));
        assert_eq!(inside.map(|h| h.voxel), Some([7, 4, 5]));
        Ok(())
    }

    /// The accelerated depth map equals plain per-pixel ray casting.
    #[test]
    fn depth_map_equals_plain_ray_casting() -> crate::Result<()> {
        let mut m = model()?;
        for (i, j, k) in [
            (1, 1, 1),
            (5, 5, 5),
            (8, 2, 6),
            (2, 8, 3),
            (6, 6, 9),
            (5, 4, 5),
        ] {
            m.set([i, j, k], [9, 9, 9]);
        }
        let ring = aibr_camera::CircularMotion::ring(3.0, 2.5, 0.5)?;
        let ring = aibr_camera::CircularMotion {
            axis: aibr_camera::TurntableAxis {
                point: Point3::new(0.5, 0.5, 0.0),
                direction: Vector3::z_axis(),
            },
            cam_from_world_at_zero: ring.cam_from_world_at_zero
                * nalgebra::Isometry3::translation(-0.5, -0.5, 0.0),
        };
        for pan in [0.0, 37.0, 150.0] {
            let camera = Camera::new(
                aibr_camera::Intrinsics::new(120.0, 120.0, 47.5, 35.5),
                aibr_camera::Distortion::NONE,
                ring.cam_from_world(aibr_camera::Angle::from_degrees(pan)),
                aibr_camera::ImageSize::new(96, 72),
            )?;
            let fast = m.depth_map(&camera);
            let rot = camera.world_from_cam().rotation;
            let mut hits = 0;
            for (u, v, d) in fast.enumerate_pixels() {
                let n = camera
                    .intrinsics
                    .normalized_from_pixel(Point2::new(u as f64, v as f64));
                let plain = m.raycast(&camera.centre(), &(rot * Vector3::new(n.x, n.y, 1.0)));
                assert_eq!(
                    plain.map(|h| h.t as f32),
                    d.0[0].is_finite().then_some(d.0[0]),
                    "({u},{v}) at {pan}"
                );
                hits += usize::from(plain.is_some());
            }
            assert!(hits > 20, "{hits}");
        }
        Ok(())
    }

    /// Splatting in bands of rows, one per thread, gives the same buffer at any thread count
    /// (band edges fall inside splats) as splatting on one thread.
    #[test]
    fn splats_are_the_same_at_any_thread_count() -> Result<(), Box<dyn std::error::Error>> {
        let ring = aibr_camera::CircularMotion::ring(1.5, 0.8, 0.2)?;
        let camera = Camera::new(
            aibr_camera::Intrinsics::new(150.0, 150.0, 47.5, 35.5),
            aibr_camera::Distortion::NONE,
            ring.cam_from_world(aibr_camera::Angle::from_degrees(20.0)),
            aibr_camera::ImageSize::new(96, 71),
        )?;
        // A lattice of voxels around the ring's target, some behind others.
        let centres: Vec<_> = (0..400)
            .map(|n| {
                let (i, j, k) = ((n % 8) as f64, ((n / 8) % 8) as f64, (n / 64) as f64);
                Point3::new(0.05 * i - 0.2, 0.05 * j - 0.2, 0.04 * k)
            })
            .collect();
        let splat = |threads: usize| -> Result<Vec<f32>, rayon::ThreadPoolBuildError> {
            let mut out = vec![0.0; 96 * 71];
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?
                .install(|| splat_depths(&centres, 0.05, &camera, &mut out));
            Ok(out)
        };
        let one = splat(1)?;
        assert!(one.iter().filter(|d| d.is_finite()).count() > 500);
        assert!(one.iter().any(|d| d.is_infinite()));
        for threads in [2, 3, 7] {
            assert_eq!(splat(threads)?, one, "{threads} threads");
        }
        Ok(())
    }

    /// A camera whose size was edited to a zero height splats into its empty buffer
    /// without a panic.
    #[test]
    fn splatting_into_an_empty_image_does_nothing() -> Result<(), Box<dyn std::error::Error>> {
        let ring = aibr_camera::CircularMotion::ring(1.5, 0.8, 0.2)?;
        let mut camera = Camera::new(
            aibr_camera::Intrinsics::new(150.0, 150.0, 47.5, 35.5),
            aibr_camera::Distortion::NONE,
            ring.cam_from_world(aibr_camera::Angle::from_degrees(20.0)),
            aibr_camera::ImageSize::new(96, 71),
        )?;
        camera.size = aibr_camera::ImageSize::new(96, 0);
        let mut out: Vec<f32> = Vec::new();
        splat_depths(&[Point3::new(0.0, 0.0, 0.1)], 0.05, &camera, &mut out);
        assert!(out.is_empty());
        Ok(())
    }

    /// The DDA agrees with a brute-force march on random rays.
    #[test]
    fn dda_agrees_with_marching() -> crate::Result<()> {
        let mut m = model()?;
        for (i, j, k) in [(1, 1, 1), (5, 5, 5), (8, 2, 6), (2, 8, 3), (6, 6, 9)] {
            m.set([i, j, k], [9, 9, 9]);
        }
        agrees_with_marching(&m, 12345);
        Ok(())
    }

    /// In a grid of unequal sides (so no two axes share a stride), also with its occupancy
    /// replaced by an array in column-major order, the DDA agrees with marching.
    #[test]
    fn dda_agrees_with_marching_in_any_layout() -> crate::Result<()> {
        let g = VoxelGrid::with_resolution(
            Aabb {
                min: Point3::new(0.0, 0.0, 0.0),
                max: Point3::new(1.0, 0.7, 0.4),
            },
            10,
        )?;
        assert_eq!(g.dims(), [10, 7, 4]);
        let mut m = VoxelModel::empty(g);
        for (i, j, k) in [
            (1, 1, 1),
            (5, 5, 2),
            (8, 2, 3),
            (2, 6, 0),
            (9, 0, 3),
            (4, 3, 1),
        ] {
            m.set([i, j, k], [9, 9, 9]);
        }
        agrees_with_marching(&m, 777);
        let shape = m.occupied.raw_dim();
        let column_major =
            ndarray::Array3::from_shape_fn(ndarray::ShapeBuilder::f(shape), |at| m.occupied[at]);
        assert!(!column_major.is_standard_layout());
        let mut other = m.clone();
        other.occupied = column_major;
        agrees_with_marching(&other, 777);
        Ok(())
    }

    /// Casts 2000 random rays from around the unit box toward points in it and checks each
    /// against a brute-force march through `m`.
    fn agrees_with_marching(m: &VoxelModel, mut seed: u64) {
        let size = m.grid().voxel_size();
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..2000 {
            let o = Point3::new(rnd() * 3.0 - 1.0, rnd() * 3.0 - 1.0, rnd() * 3.0 - 1.0);
            let target = Point3::new(rnd(), rnd(), rnd());
            let d = target - o;
            let dda = m.raycast(&o, &d).map(|h| h.voxel);
            let mut march = None;
            let n = 20_000;
            for s in 0..n {
                let p = o + d * (s as f64 * 3.0 / n as f64);
                if let Some(v) = m.grid().index_of(&p) {
                    if m.is_occupied(v) {
                        march = Some(v);
                        break;
                    }
                }
            }
            // Where the ray passes through voxel `c`, if it does.
            let cube = |c: [usize; 3]| {
                let lo = m.grid().centre(c) - Vector3::repeat(0.5 * size);
                aibr_camera::aabb::slab(&lo, &(lo + Vector3::repeat(size)), &o, &d)
            };
            // Marching can step over a corner the ray clips; the DDA may then find a voxel
            // first, which the ray must really pass through, no later than marching's.
            if let Some(v) = march {
                let Some(w) = dda else {
                    panic!("DDA missed {v:?} from {o} toward {target}")
                };
                if w != v {
                    let (tw, tv) = (cube(w), cube(v));
                    assert!(tw.is_some() && tv.is_some(), "ray from {o} toward {target}");
                    assert!(tw.map(|t| t.0) <= tv.map(|t| t.0));
                }
            } else if let Some(w) = dda {
                // Only a voxel the ray clips at a corner, which marching stepped over.
                assert!(
                    cube(w).is_some_and(|(t0, t1)| t1 - t0 < 1e-3),
                    "ray from {o} toward {target}"
                );
            }
        }
    }
}
