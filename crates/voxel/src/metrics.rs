//! Geometry and silhouette metrics of a reconstruction against ground truth.

use image::GrayImage;
use nalgebra::Point3;
use rayon::prelude::*;

use crate::grid::VoxelModel;
use crate::raycast::DepthMap;

/// Nearest-neighbour queries over a point set (a uniform grid of buckets).
#[derive(Debug, Clone)]
pub struct PointIndex {
    points: Vec<Point3<f64>>,
    min: Point3<f64>,
    cell: f64,
    dims: [usize; 3],
    /// Per cell, the range of `order` holding its points.
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl PointIndex {
    /// An index over `points` with buckets of about `cell` metres (grown if the box would
    /// need more than 16 M buckets).
    pub fn new(points: &[Point3<f64>], cell: f64) -> Self {
        let min = points
            .iter()
            .fold(Point3::from([f64::INFINITY; 3]), |a, p| a.inf(p));
        let max = points
            .iter()
            .fold(Point3::from([f64::NEG_INFINITY; 3]), |a, p| a.sup(p));
        let mut cell = if cell > 0.0 { cell } else { 1e-3 };
        let extent = if points.is_empty() {
            nalgebra::Vector3::zeros()
        } else {
            max - min
        };
        let dims_for = |c: f64| extent.map(|e| (e / c).floor() as usize + 1);
        while dims_for(cell).iter().product::<usize>() > 16 << 20 {
            cell *= 2.0;
        }
        let d = dims_for(cell);
        let dims = [d.x, d.y, d.z];
        let cell_of = |p: &Point3<f64>| {
            let c = |a: usize| (((p[a] - min[a]) / cell).floor() as usize).min(dims[a] - 1);
            (c(2) * dims[1] + c(1)) * dims[0] + c(0)
        };
        let ncells = dims.iter().product::<usize>();
        let mut counts = vec![0u32; ncells + 1];
        for p in points {
            counts[cell_of(p) + 1] += 1;
        }
        for i in 1..counts.len() {
            counts[i] += counts[i - 1];
        }
        let mut fill = counts.clone();
        let mut order = vec![0u32; points.len()];
        for (n, p) in points.iter().enumerate() {
            let c = cell_of(p);
            order[fill[c] as usize] = n as u32;
            fill[c] += 1;
        }
        PointIndex {
            points: points.to_vec(),
            min,
            cell,
            dims,
            starts: counts,
            order,
        }
    }

    /// Distance from `q` to the nearest indexed point (infinite for an empty index).
    pub fn nearest_distance(&self, q: &Point3<f64>) -> f64 {
        if self.points.is_empty() {
            return f64::INFINITY;
        }
        let centre: [i64; 3] = std::array::from_fn(|a| {
            (((q[a] - self.min[a]) / self.cell).floor() as i64).clamp(0, self.dims[a] as i64 - 1)
        });
        // Distance from q to the box of the grid, so rings start counting where points are.
        let outside: f64 = (0..3)
            .map(|a| {
                let hi = self.min[a] + self.dims[a] as f64 * self.cell;
                let d = (self.min[a] - q[a]).max(q[a] - hi).max(0.0);
                d * d
            })
            .sum::<f64>()
            .sqrt();
        let max_ring = *self.dims.iter().max().unwrap_or(&1) as i64;
        let mut best = f64::INFINITY;
        for r in 0..=max_ring {
            for dz in -r..=r {
                for dy in -r..=r {
                    for dx in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let c = [centre[0] + dx, centre[1] + dy, centre[2] + dz];
                        if (0..3).any(|a| c[a] < 0 || c[a] >= self.dims[a] as i64) {
                            continue;
                        }
                        let cell = ((c[2] as usize * self.dims[1]) + c[1] as usize) * self.dims[0]
                            + c[0] as usize;
                        for &n in
                            &self.order[self.starts[cell] as usize..self.starts[cell + 1] as usize]
                        {
                            best = best.min((self.points[n as usize] - q).norm());
                        }
                    }
                }
            }
            // Every point not yet visited lies r cells or more past q's nearest point of the
            // grid box (q projects onto the convex box there), so at least this far away.
            let bound = (outside * outside + (r as f64 * self.cell).powi(2)).sqrt();
            if best <= bound {
                break;
            }
        }
        best
    }
}

/// The `quantile` (0 to 1) of the distances from each `points` entry to the nearest of
/// `reference` (the accuracy of a reconstruction with `quantile = 0.9`), the points in parallel.
pub fn distance_quantile(points: &[Point3<f64>], reference: &PointIndex, quantile: f64) -> f64 {
    let mut d: Vec<f64> = points
        .par_iter()
        .map(|p| reference.nearest_distance(p))
        .collect();
    if d.is_empty() {
        return f64::INFINITY;
    }
    d.sort_by(f64::total_cmp);
    let at = ((quantile.clamp(0.0, 1.0) * d.len() as f64).ceil() as usize).clamp(1, d.len()) - 1;
    d[at]
}

/// The share of `points` within `tolerance` of the nearest of `reference` (the completeness
/// of a reconstruction, with the true surface as `points`), the points in parallel.
pub fn share_within(points: &[Point3<f64>], reference: &PointIndex, tolerance: f64) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let n = points
        .par_iter()
        .filter(|p| reference.nearest_distance(p) <= tolerance)
        .count();
    n as f64 / points.len() as f64
}

/// Accuracy and completeness of a model against a true surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeometryScore {
    /// Distance within which 90% of the model's surface voxel centres lie from the true
    /// surface, in voxel sizes.
    pub accuracy_voxels: f64,
    /// Share of true surface points within 1.5 voxel sizes of a model surface voxel centre.
    pub completeness: f64,
    /// Model surface voxels.
    pub surface_voxels: usize,
}

/// Scores `model` against dense samples of the whole true surface (`surface`, for accuracy)
/// and samples of its visible part (`visible`, for completeness).
pub fn geometry_score(
    model: &VoxelModel,
    surface: &[Point3<f64>],
    visible: &[Point3<f64>],
) -> GeometryScore {
    let s = model.grid().voxel_size();
    let centres: Vec<Point3<f64>> = model
        .surface_voxels()
        .into_iter()
        .map(|v| model.grid().centre(v))
        .collect();
    let truth = PointIndex::new(surface, s);
    let modelled = PointIndex::new(&centres, s);
    GeometryScore {
        accuracy_voxels: distance_quantile(&centres, &truth, 0.9) / s,
        completeness: share_within(visible, &modelled, 1.5 * s),
        surface_voxels: centres.len(),
    }
}

/// How a model's projection (the finite pixels of its depth map) agrees with a silhouette.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SilhouetteAgreement {
    /// Share of silhouette pixels the projection covers.
    pub coverage: f64,
    /// Share of projection pixels outside the silhouette.
    pub spill: f64,
}

/// Coverage and spill of a model's projection against a silhouette of the same size.
pub fn silhouette_agreement(depth: &DepthMap, silhouette: &GrayImage) -> SilhouetteAgreement {
    let (mut both, mut sil, mut proj) = (0usize, 0usize, 0usize);
    for (d, m) in depth.pixels().zip(silhouette.pixels()) {
        let p = d.0[0].is_finite();
        let s = m.0[0] != 0;
        both += usize::from(p && s);
        sil += usize::from(s);
        proj += usize::from(p);
    }
    SilhouetteAgreement {
        coverage: if sil == 0 {
            1.0
        } else {
            both as f64 / sil as f64
        },
        spill: if proj == 0 {
            0.0
        } else {
            (proj - both) as f64 / proj as f64
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_agrees_with_brute_force() {
        let mut r = crate::test_rng(7);
        let pts: Vec<Point3<f64>> = (0..3000)
            .map(|_| Point3::new(r(), r() * 0.5, r() * 2.0))
            .collect();
        let index = PointIndex::new(&pts, 0.05);
        for _ in 0..300 {
            let q = Point3::new(r() * 3.0 - 1.0, r() * 3.0 - 1.0, r() * 3.0 - 1.0);
            let brute = pts
                .iter()
                .map(|p| (p - q).norm())
                .fold(f64::INFINITY, f64::min);
            assert!((index.nearest_distance(&q) - brute).abs() < 1e-12);
        }
        let probe = [Point3::new(0.5, 0.25, 1.0)];
        assert!(distance_quantile(&probe, &index, 0.9) < 0.1);
    }
}
