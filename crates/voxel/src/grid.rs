//! The voxel grid and the voxel model (occupancy and colour).

use aibr_camera::Aabb;
use nalgebra::{Point3, Vector3};
use ndarray::Array3;

use crate::error::{Error, Result};

/// Bytes per voxel of a [`VoxelModel`] (occupancy and RGB).
pub const BYTES_PER_VOXEL: u128 = 4;
/// Default memory limit of a grid, bytes (4 GiB).
pub const DEFAULT_MEMORY_LIMIT: u128 = 4 << 30;

/// A regular grid of cubic voxels over an axis-aligned box of the turntable frame.
///
/// Voxel `[i, j, k]` (x, y, z indices) is the cube
/// `origin + voxel_size * ([i, j, k] + [0..1, 0..1, 0..1])`. Arrays over the grid have shape
/// `(nz, ny, nx)` and are indexed `[[k, j, i]]`, so one horizontal layer is contiguous.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VoxelGrid {
    origin: Point3<f64>,
    voxel_size: f64,
    dims: [usize; 3],
}

impl VoxelGrid {
    /// A grid covering `bounds` with cubes of `voxel_size` metres (the covered box is
    /// `bounds` rounded up to whole voxels). Rejects grids over 4 GiB.
    pub fn new(bounds: Aabb, voxel_size: f64) -> Result<Self> {
        Self::with_memory_limit(bounds, voxel_size, DEFAULT_MEMORY_LIMIT)
    }

    /// Like [`new`](Self::new) with an explicit memory limit (bytes of the model arrays).
    pub fn with_memory_limit(bounds: Aabb, voxel_size: f64, limit: u128) -> Result<Self> {
        if !(voxel_size > 0.0 && voxel_size.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "voxel size",
                value: voxel_size,
                reason: "must be positive and finite",
            });
        }
        let extent = bounds.extent();
        let mut dims = [0usize; 3];
        for (d, e) in dims.iter_mut().zip(extent.iter()) {
            let n = (e / voxel_size - 1e-9).ceil().max(1.0);
            if !(n < 1e9) {
                return Err(Error::InvalidParameter {
                    name: "voxel size",
                    value: voxel_size,
                    reason: "gives more than 1e9 voxels along an axis",
                });
            }
            *d = n as usize;
        }
        let bytes = dims.iter().map(|&d| d as u128).product::<u128>() * BYTES_PER_VOXEL;
        if bytes > limit {
            return Err(Error::GridTooLarge {
                nx: dims[0],
                ny: dims[1],
                nz: dims[2],
                bytes,
                limit,
            });
        }
        Ok(VoxelGrid {
            origin: bounds.min,
            voxel_size,
            dims,
        })
    }

    /// A grid over `bounds` with `resolution` voxels along its longest edge (a "128^3" grid
    /// is `with_resolution(bounds, 128)`).
    pub fn with_resolution(bounds: Aabb, resolution: usize) -> Result<Self> {
        if resolution == 0 {
            return Err(Error::InvalidParameter {
                name: "grid resolution",
                value: 0.0,
                reason: "must be at least 1",
            });
        }
        let longest = bounds.extent().max();
        if !(longest > 0.0) {
            return Err(Error::InvalidParameter {
                name: "volume extent",
                value: longest,
                reason: "the volume must have a positive size",
            });
        }
        Self::new(bounds, longest / resolution as f64)
    }

    /// Voxels along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// Number of voxels.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// True when the grid has no voxels (never: every axis has at least one).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Edge of a voxel, metres.
    pub fn voxel_size(&self) -> f64 {
        self.voxel_size
    }

    /// The box the grid covers (the requested bounds rounded up to whole voxels).
    pub fn bounds(&self) -> Aabb {
        let ext = Vector3::new(
            self.dims[0] as f64,
            self.dims[1] as f64,
            self.dims[2] as f64,
        ) * self.voxel_size;
        Aabb {
            min: self.origin,
            max: self.origin + ext,
        }
    }

    /// Centre of voxel `[i, j, k]`.
    #[inline]
    pub fn centre(&self, [i, j, k]: [usize; 3]) -> Point3<f64> {
        self.origin + Vector3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * self.voxel_size
    }

    /// The voxel holding `p`, if inside the grid.
    pub fn index_of(&self, p: &Point3<f64>) -> Option<[usize; 3]> {
        let mut out = [0usize; 3];
        for a in 0..3 {
            let f = ((p[a] - self.origin[a]) / self.voxel_size).floor();
            if !(f >= 0.0 && f < self.dims[a] as f64) {
                return None;
            }
            out[a] = f as usize;
        }
        Some(out)
    }

    /// Shape of arrays over the grid: `(nz, ny, nx)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.dims[2], self.dims[1], self.dims[0])
    }
}

/// A voxel model: occupancy and colour over a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelModel {
    grid: VoxelGrid,
    /// `[[k, j, i]]`: true where the voxel is occupied.
    pub occupied: Array3<bool>,
    /// `[[k, j, i]]`: colour of occupied voxels (8-bit RGB).
    pub colour: Array3<[u8; 3]>,
}

impl VoxelModel {
    /// A model with every voxel empty.
    pub fn empty(grid: VoxelGrid) -> Self {
        VoxelModel {
            grid,
            occupied: Array3::from_elem(grid.shape(), false),
            colour: Array3::from_elem(grid.shape(), [0; 3]),
        }
    }

    /// A model with every voxel occupied (grey).
    pub fn full(grid: VoxelGrid) -> Self {
        VoxelModel {
            grid,
            occupied: Array3::from_elem(grid.shape(), true),
            colour: Array3::from_elem(grid.shape(), [128; 3]),
        }
    }

    /// A model occupied (grey) at every voxel whose centre `inside` accepts: the voxelisation
    /// of a solid given by a point test, such as a synthetic scene's true geometry
    /// (`|p| scene.inside(p, 0.0)`), to render from or to measure a reconstruction against.
    pub fn from_centres(grid: VoxelGrid, inside: impl Fn(&Point3<f64>) -> bool) -> Self {
        let occupied =
            Array3::from_shape_fn(grid.shape(), |(k, j, i)| inside(&grid.centre([i, j, k])));
        // As `empty` and `set` would leave it: grey where occupied, black elsewhere.
        let colour = occupied.map(|&o| if o { [128; 3] } else { [0; 3] });
        VoxelModel {
            grid,
            occupied,
            colour,
        }
    }

    /// The grid.
    pub fn grid(&self) -> &VoxelGrid {
        &self.grid
    }

    /// True when voxel `[i, j, k]` is occupied (false outside the grid).
    #[inline]
    pub fn is_occupied(&self, [i, j, k]: [usize; 3]) -> bool {
        self.occupied.get([k, j, i]).copied().unwrap_or(false)
    }

    /// Colour of voxel `[i, j, k]`.
    pub fn colour_of(&self, [i, j, k]: [usize; 3]) -> Option<[u8; 3]> {
        self.colour.get([k, j, i]).copied()
    }

    /// Occupies voxel `[i, j, k]` with `colour` (ignored outside the grid).
    pub fn set(&mut self, [i, j, k]: [usize; 3], colour: [u8; 3]) {
        if let Some(o) = self.occupied.get_mut([k, j, i]) {
            *o = true;
            self.colour[[k, j, i]] = colour;
        }
    }

    /// Empties voxel `[i, j, k]`.
    pub fn clear(&mut self, [i, j, k]: [usize; 3]) {
        if let Some(o) = self.occupied.get_mut([k, j, i]) {
            *o = false;
        }
    }

    /// Number of occupied voxels.
    pub fn occupied_count(&self) -> usize {
        self.occupied.iter().filter(|&&o| o).count()
    }

    /// Occupied voxels with at least one empty (or out-of-grid) 6-neighbour, as `[i, j, k]`.
    pub fn surface_voxels(&self) -> Vec<[usize; 3]> {
        let [nx, ny, nz] = self.grid.dims;
        let mut out = Vec::new();
        for ((k, j, i), &o) in self.occupied.indexed_iter() {
            if !o {
                continue;
            }
            let exposed = i == 0
                || j == 0
                || k == 0
                || i + 1 == nx
                || j + 1 == ny
                || k + 1 == nz
                || !self.occupied[[k, j, i - 1]]
                || !self.occupied[[k, j, i + 1]]
                || !self.occupied[[k, j - 1, i]]
                || !self.occupied[[k, j + 1, i]]
                || !self.occupied[[k - 1, j, i]]
                || !self.occupied[[k + 1, j, i]];
            if exposed {
                out.push([i, j, k]);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Aabb {
        Aabb {
            min: Point3::new(-0.5, -0.5, 0.0),
            max: Point3::new(0.5, 0.5, 1.0),
        }
    }

    #[test]
    fn grid_geometry() -> Result<()> {
        let g = VoxelGrid::with_resolution(unit_box(), 10)?;
        assert_eq!(g.dims(), [10, 10, 10]);
        assert!((g.centre([0, 0, 0]) - Point3::new(-0.45, -0.45, 0.05)).norm() < 1e-12);
        assert_eq!(g.index_of(&Point3::new(0.49, -0.49, 0.99)), Some([9, 0, 9]));
        assert_eq!(g.index_of(&Point3::new(0.51, 0.0, 0.5)), None);
        let g = VoxelGrid::new(unit_box(), 0.3)?;
        assert_eq!(g.dims(), [4, 4, 4]);
        Ok(())
    }

    #[test]
    fn too_large_or_bad_sizes() {
        assert!(matches!(
            VoxelGrid::new(unit_box(), 1e-4),
            Err(Error::GridTooLarge { .. })
        ));
        assert!(VoxelGrid::new(unit_box(), 0.0).is_err());
        assert!(VoxelGrid::new(unit_box(), f64::NAN).is_err());
        assert!(VoxelGrid::with_resolution(unit_box(), 0).is_err());
    }

    #[test]
    fn voxelised_ball_is_the_voxels_whose_centres_it_holds() -> Result<()> {
        let g = VoxelGrid::with_resolution(unit_box(), 20)?;
        let centre = Point3::new(0.1, -0.05, 0.45);
        let ball = |p: &Point3<f64>| (p - centre).norm() < 0.3;
        let m = VoxelModel::from_centres(g, ball);
        let [nx, ny, nz] = g.dims();
        let mut count = 0;
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    assert_eq!(m.is_occupied([i, j, k]), ball(&g.centre([i, j, k])));
                    count += usize::from(ball(&g.centre([i, j, k])));
                }
            }
        }
        assert_eq!(m.occupied_count(), count);
        // The same model as filling an empty one voxel by voxel.
        let mut by_hand = VoxelModel::empty(g);
        for ((k, j, i), _) in m.occupied.indexed_iter() {
            if ball(&g.centre([i, j, k])) {
                by_hand.set([i, j, k], [128; 3]);
            }
        }
        assert_eq!(m, by_hand);
        // About the ball's volume, in voxels of 0.05 m.
        let expected = 4.0 / 3.0 * std::f64::consts::PI * 0.3f64.powi(3) / 0.05f64.powi(3);
        assert!(
            (count as f64 - expected).abs() < 0.05 * expected,
            "{count} vs {expected}"
        );
        Ok(())
    }

    #[test]
    fn surface_of_a_solid_cube() -> Result<()> {
        let g = VoxelGrid::with_resolution(unit_box(), 5)?;
        let m = VoxelModel::full(g);
        // 5^3 - 3^3 voxels touch the outside.
        assert_eq!(m.surface_voxels().len(), 125 - 27);
        Ok(())
    }
}
