//! Voxel grids for turntable reconstruction: the geometry stage of aibr.
//!
//! - [`VoxelGrid`] and [`VoxelModel`]: a box of the turntable frame cut into cubes, with
//!   dense (ndarray) occupancy and colour; surface voxels; 3D DDA ray casting
//!   ([`VoxelModel::raycast`]), depth maps and visibility for any camera;
//! - [`voxel_coloring`] (Seitz and Dyer 1997, as the paper uses it): one top-down plane
//!   sweep, with the classic or the paper's non-Lambertian [`Criterion`], an optional
//!   silhouette constraint (and with it, views that see a voxel of the visual hull's
//!   boundary from behind it left out: [`ColoringParams::behind_hull`]), parallel within
//!   each layer and identical at any thread count to its scalar reference
//!   [`voxel_coloring_reference`]; with the optional [`column`](mod@column) test
//!   ([`ColoringParams::column_test`]) the sweep passes over a voxel floating over a textured
//!   top, where the views agree clearly better down its column, and reconstructs the surface
//!   below it instead (better geometry in two to three times the time);
//! - [`refine_tops`], an optional pass after voxel coloring: each upward-facing surface voxel
//!   moves down its column to where its views' colours agree best, which a sweep's threshold
//!   cannot find (a voxel floating a layer over a textured top passes it); better geometry,
//!   with pits that cost renders unless its steps are walled, which costs some of the
//!   geometry back (see its module);
//! - [`space_carving`] (Kutulakos and Seitz), multi-sweep, for rigs whose cameras are not all
//!   above the object;
//! - [`VoxelModel::filled`]: a model's shell closed (gaps bridged) and what it encloses
//!   filled, for renderers that cast rays into voxel coloring's hollow, gappy shells;
//! - [`planar_faces`]: a model's large flat faces, whose planes a planner can aim views at
//!   (a face seen only at a slant comes out a few voxels too fat);
//! - [`foreground`] masks from a dark background, [`metrics`] against ground truth, and
//!   [`write_ply`] for MeshLab and Blender.
//!
//! ```
//! use aibr_camera::Angle;
//! use aibr_scene::{RenderOptions, catalogue};
//! use aibr_voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};
//!
//! let scene = catalogue::lambertian()?;
//! let cameras: Vec<_> = (0..12)
//!     .map(|i| scene.camera(Angle::from_degrees(-150.0 + 25.0 * i as f64)))
//!     .collect::<Result<_, _>>()?;
//! let frames: Vec<_> = cameras
//!     .iter()
//!     .map(|c| scene.render(c, &RenderOptions::default()))
//!     .collect::<Result<_, _>>()?;
//! let images: Vec<_> = frames.iter().map(|f| f.rgb8()).collect();
//! let views: Vec<View<'_>> = cameras
//!     .iter()
//!     .zip(&images)
//!     .zip(&frames)
//!     .map(|((camera, image), f)| View { camera, image, mask: Some(&f.mask) })
//!     .collect();
//! let grid = VoxelGrid::with_resolution(scene.bounds(), 32)?;
//! let out = voxel_coloring(&grid, &views, &ColoringParams::default())?;
//! assert!(out.model.occupied_count() > 500);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! Grids live in the turntable frame of `aibr-camera` (metres, Z up along the pan axis).
//! Voxel `[i, j, k]` indexes x, y, z; arrays have shape `(nz, ny, nx)` and are indexed
//! `[[k, j, i]]`. Images are 8-bit RGB seen by pinhole cameras (undistort first); masks are
//! non-zero on the object. A voxel's footprint in a view is the square of pixels whose
//! centres lie within half its projected edge of its projected centre (at least one pixel).

pub mod carving;
pub mod coloring;
pub mod column;
pub mod error;
pub mod faces;
pub mod fill;
pub mod foreground;
pub mod grid;
mod hull;
pub mod kernel;
pub mod metrics;
pub mod ply;
pub mod raycast;
pub mod refine;

pub use carving::{CarvingParams, space_carving, visual_hull};
pub use coloring::{
    ColoringParams, KernelStats, Reconstruction, check_cameras_above, voxel_coloring,
    voxel_coloring_reference,
};
pub use column::ColumnTest;
pub use error::{Error, Result};
pub use faces::{FaceParams, PlanarFace, planar_faces};
pub use grid::{VoxelGrid, VoxelModel};
pub use kernel::{Criterion, View};
pub use ply::{PlyOptions, write_ply};
pub use raycast::{DepthMap, SPLAT_MARGIN_VOXELS, VoxelHit, is_visible, splat_depths};
pub use refine::{RefineStats, TopRefinement, refine_tops};

/// A seeded generator of numbers in `[0, 1)` for the unit tests (a 64-bit linear
/// congruential generator, its top 53 bits).
#[cfg(test)]
pub(crate) fn test_rng(seed: u64) -> impl FnMut() -> f64 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    }
}
