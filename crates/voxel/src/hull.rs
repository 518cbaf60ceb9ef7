//! The visual hull as voxel coloring uses it: which views look at a voxel on the hull's
//! boundary from behind that boundary (see [`crate::ColoringParams::behind_hull`]).
//!
//! A voxel on the boundary of the visual hull that belongs to the object lies where the
//! object touches its hull, and there the object's surface faces the way the hull's does. A
//! view whose ray reaches such a voxel from the hull's inside looks at it through the object:
//! what that view shows at the voxel's footprint is some other surface (or, through a hole
//! that voxel coloring has already carved, the far side of the object) and says nothing of
//! this voxel's colour. Voxel coloring's own visibility cannot tell, because it knows only
//! the voxels kept in the layers above.

use nalgebra::{Point3, Vector3};
use rayon::prelude::*;

use crate::grid::{VoxelGrid, VoxelModel};
use crate::kernel::{Footprint, Pixels, Projector, Silhouette, ViewBits};

/// The visual hull of the views' masks, one flag per voxel.
pub(crate) struct Hull {
    dims: [usize; 3],
    /// Inside the hull, indexed `(k * ny + j) * nx + i`.
    inside: Vec<bool>,
}

impl Hull {
    /// The hull of a model that holds it (the reference's, from [`crate::visual_hull`]'s
    /// voxel-by-voxel carving).
    pub(crate) fn of_model(model: &VoxelModel) -> Self {
        let [nx, ny, nz] = model.grid().dims();
        let mut inside = vec![false; nx * ny * nz];
        for ((k, j, i), &o) in model.occupied.indexed_iter() {
            inside[(k * ny + j) * nx + i] = o;
        }
        Hull {
            dims: [nx, ny, nz],
            inside,
        }
    }

    /// The same hull as [`crate::visual_hull`], faster. The grid is cut into bricks of
    /// `edge`^3 voxels, slabs of `edge` layers in parallel. A brick's projected bound in a
    /// view (the union of its top and bottom layers' [`Projector::block_bounds`]: over a box,
    /// the projection's extremes lie at its corners) settles that view for all its voxels at
    /// once: foreground under the whole bound, the view carves none of them; background under
    /// it, every one (when the bound is not cut by the image's edge, so that every footprint
    /// is on the image). Only the views left mixed are asked again, for each layer's block
    /// of the brick and then voxel by voxel.
    pub(crate) fn culled(
        grid: &VoxelGrid,
        projectors: &[Projector],
        bits: &[ViewBits],
        edge: usize,
    ) -> Self {
        let [nx, ny, nz] = grid.dims();
        let slabs: Vec<Vec<bool>> = (0..nz.div_ceil(edge))
            .into_par_iter()
            .map_init(
                || (vec![Footprint::EMPTY; edge], Vec::new(), Vec::new()),
                |(row, brick_views, mixed), s| {
                    let (k0, k1) = (s * edge, ((s + 1) * edge).min(nz));
                    let mut slab = vec![true; nx * ny * (k1 - k0)];
                    // Per view, per layer of the slab, per row: the row's base.
                    let bases: Vec<Vec<[f32; 3]>> = projectors
                        .iter()
                        .map(|p| {
                            (k0..k1)
                                .flat_map(|k| (0..ny).map(move |j| (j, k)))
                                .map(|(j, k)| p.row_base(grid, j, k))
                                .collect()
                        })
                        .collect();
                    for j0 in (0..ny).step_by(edge) {
                        let j1 = (j0 + edge).min(ny);
                        for i0 in (0..nx).step_by(edge) {
                            let i1 = (i0 + edge).min(nx);
                            let brick = Brick {
                                i: (i0, i1),
                                j: (j0, j1),
                                layers: k1 - k0,
                                ny,
                            };
                            match brick.classify(projectors, &bases, bits, brick_views) {
                                Silhouette::Outside => {
                                    for l in 0..k1 - k0 {
                                        for j in j0..j1 {
                                            let r = (l * ny + j) * nx;
                                            slab[r + i0..r + i1].fill(false);
                                        }
                                    }
                                }
                                Silhouette::Inside => {}
                                Silhouette::Mixed => {
                                    for l in 0..k1 - k0 {
                                        let mut cells = BlockCells {
                                            layer: &mut slab[l * nx * ny..(l + 1) * nx * ny],
                                            nx,
                                            i: (i0, i1),
                                            j: (j0, j1),
                                            row: &mut row[..i1 - i0],
                                        };
                                        let rows = |v: usize| &bases[v][l * ny..(l + 1) * ny];
                                        cells.carve(projectors, rows, bits, brick_views, mixed);
                                    }
                                }
                            }
                        }
                    }
                    slab
                },
            )
            .collect();
        Hull {
            dims: [nx, ny, nz],
            inside: slabs.concat(),
        }
    }

    /// Copies the flags of the voxels `i.0..i.1` x `j.0..j.1` of layer `k`, row by row, into
    /// `cells`; returns how many are inside.
    pub(crate) fn block(
        &self,
        k: usize,
        (i0, i1): (usize, usize),
        (j0, j1): (usize, usize),
        cells: &mut [bool],
    ) -> usize {
        let [nx, ny, _] = self.dims;
        let w = i1 - i0;
        let mut count = 0;
        for (j, out) in (j0..j1).zip(cells.chunks_exact_mut(w)) {
            let r = (k * ny + j) * nx;
            out.copy_from_slice(&self.inside[r + i0..r + i1]);
            count += out.iter().filter(|&&c| c).count();
        }
        count
    }

    #[inline]
    fn at(&self, i: usize, j: usize, k: usize) -> bool {
        let [nx, ny, _] = self.dims;
        self.inside[(k * ny + j) * nx + i]
    }

    /// The hull's outward normal at voxel `[i, j, k]`, unnormalised: the sum of the
    /// directions to its outside 26-neighbours (neighbours beyond the grid count as the
    /// voxel's nearest voxel of the grid, so the grid's own faces are no boundary). Zero
    /// unless the voxel is inside the hull and some 6-neighbour is not. Integers, so every
    /// path computes the same normal.
    pub(crate) fn normal(&self, [i, j, k]: [usize; 3]) -> [i32; 3] {
        if !self.at(i, j, k) {
            return [0; 3];
        }
        let [nx, ny, nz] = self.dims;
        let step = |x: usize, d: i32, n: usize| (x as i64 + i64::from(d)).clamp(0, n as i64 - 1);
        let outside = |[di, dj, dk]: [i32; 3]| {
            let (a, b, c) = (step(i, di, nx), step(j, dj, ny), step(k, dk, nz));
            !self.at(a as usize, b as usize, c as usize)
        };
        // Most voxels asked lie inside with all six face neighbours: those six first.
        const FACES: [[i32; 3]; 6] = [
            [-1, 0, 0],
            [1, 0, 0],
            [0, -1, 0],
            [0, 1, 0],
            [0, 0, -1],
            [0, 0, 1],
        ];
        if !FACES.into_iter().any(outside) {
            return [0; 3];
        }
        let mut normal = [0i32; 3];
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    if outside([di, dj, dk]) {
                        normal[0] += di;
                        normal[1] += dj;
                        normal[2] += dk;
                    }
                }
            }
        }
        normal
    }
}

/// A brick of [`Hull::culled`]: voxels `i.0..i.1` x `j.0..j.1` of `layers` layers.
struct Brick {
    i: (usize, usize),
    j: (usize, usize),
    layers: usize,
    ny: usize,
}

impl Brick {
    /// What the views' bounds over the whole brick say (see [`settle`]).
    fn classify(
        &self,
        projectors: &[Projector],
        bases: &[Vec<[f32; 3]>],
        bits: &[ViewBits],
        views: &mut Vec<usize>,
    ) -> Silhouette {
        let ((i0, i1), (j0, j1)) = (self.i, self.j);
        let top = (self.layers - 1) * self.ny;
        let bound = |v: usize| {
            let b = &bases[v];
            projectors[v].brick_bounds(
                (&b[top + j0], &b[top + j1 - 1]),
                (&b[j0], &b[j1 - 1]),
                (i0, i1),
            )
        };
        settle(0..projectors.len(), bound, projectors, bits, views)
    }
}

/// What the masks of `views` say of every voxel of a box, from each view's `bound` over it:
/// [`Silhouette::Outside`] as soon as one view rejects them all; otherwise the views that
/// must be asked again (a mixed bound, or none computable) are listed in `mixed`, and the box
/// is [`Silhouette::Mixed`] if there are any.
fn settle(
    views: impl Iterator<Item = usize>,
    bound: impl Fn(usize) -> Result<Option<Footprint>, ()>,
    projectors: &[Projector],
    bits: &[ViewBits],
    mixed: &mut Vec<usize>,
) -> Silhouette {
    mixed.clear();
    for v in views {
        match bound(v) {
            // Every footprint is off this image: the view rejects none.
            Ok(None) => {}
            Ok(Some(bound)) => match bits[v].silhouette(&projectors[v], &bound) {
                Silhouette::Outside => return Silhouette::Outside,
                Silhouette::Inside => {}
                Silhouette::Mixed => mixed.push(v),
            },
            Err(()) => mixed.push(v),
        }
    }
    if mixed.is_empty() {
        Silhouette::Inside
    } else {
        Silhouette::Mixed
    }
}

/// One block of a layer while [`Hull::culled`] carves it.
struct BlockCells<'a> {
    layer: &'a mut [bool],
    nx: usize,
    i: (usize, usize),
    j: (usize, usize),
    row: &'a mut [Footprint],
}

impl BlockCells<'_> {
    /// Carves the block's voxels that one of `views` shows as background: first each view's
    /// bound over the block (as [`Brick::classify`] does), then the views whose bound is
    /// mixed, voxel by voxel.
    fn carve<'b>(
        &mut self,
        projectors: &[Projector],
        rows: impl Fn(usize) -> &'b [[f32; 3]],
        bits: &[ViewBits],
        views: &[usize],
        mixed: &mut Vec<usize>,
    ) {
        let ((i0, i1), (j0, j1)) = (self.i, self.j);
        let bound = |v: usize| {
            let b = rows(v);
            projectors[v].block_bounds(&b[j0], &b[j1 - 1], (i0, i1))
        };
        match settle(views.iter().copied(), bound, projectors, bits, mixed) {
            Silhouette::Outside => {
                for j in j0..j1 {
                    self.layer[j * self.nx + i0..j * self.nx + i1].fill(false);
                }
                return;
            }
            Silhouette::Inside => return,
            Silhouette::Mixed => {}
        }
        for &v in mixed.iter() {
            let mut any = false;
            for j in j0..j1 {
                let cells = &mut self.layer[j * self.nx + i0..j * self.nx + i1];
                if !cells.iter().any(|&c| c) {
                    continue;
                }
                projectors[v].footprints_along_row(&rows(v)[j], i0, self.row);
                for (cell, fp) in cells.iter_mut().zip(self.row.iter()) {
                    if *cell && bits[v].rejects(fp) {
                        *cell = false;
                    }
                    any |= *cell;
                }
            }
            if !any {
                return;
            }
        }
    }
}

/// Whether a camera at `centre` looks at the voxel at `x`, whose hull normal is `normal`
/// ([`Hull::normal`]), from behind the hull's boundary: the cosine between the normal and
/// the direction to the camera is below `cosine`. Never for a zero normal. Compared in
/// squares, without a square root.
#[inline]
pub(crate) fn behind(normal: [i32; 3], centre: &Point3<f64>, x: &Point3<f64>, cosine: f64) -> bool {
    if normal == [0; 3] {
        return false;
    }
    let n = Vector3::new(
        f64::from(normal[0]),
        f64::from(normal[1]),
        f64::from(normal[2]),
    );
    let d = centre - x;
    let dot = n.dot(&d);
    // cos = dot / (|n| |d|) < cosine, with |n| |d| > 0 (a camera at the voxel's centre is
    // not behind).
    let bound = cosine * cosine * n.norm_squared() * d.norm_squared();
    if cosine <= 0.0 {
        dot < 0.0 && dot * dot > bound
    } else {
        dot < 0.0 || dot * dot < bound
    }
}

/// Whether any view has a mask: without one there is no hull to look from behind.
pub(crate) fn any_mask(pixels: &[Pixels<'_>]) -> bool {
    pixels.iter().any(|p| p.mask.is_some())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hull_of(dims: [usize; 3], inside: impl Fn(usize, usize, usize) -> bool) -> Hull {
        let [nx, ny, nz] = dims;
        let mut flags = vec![false; nx * ny * nz];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    flags[(k * ny + j) * nx + i] = inside(i, j, k);
                }
            }
        }
        Hull {
            dims,
            inside: flags,
        }
    }

    #[test]
    fn the_culled_hull_is_the_visual_hull() -> Result<(), Box<dyn std::error::Error>> {
        use crate::carving::carve_hull;
        use crate::kernel::{View, prepare_views};
        use aibr_scene::{RenderOptions, catalogue};
        // The chair's thin legs and slats give many mixed bricks; two grid sizes put the
        // bricks' edges in different places, and one odd size leaves partial bricks.
        let scene = catalogue::chair()?;
        let shots = scene.shoot(&scene.rig.uniform_pans(9), &RenderOptions::default())?;
        let views: Vec<View<'_>> = shots
            .iter()
            .map(|s| View {
                camera: &s.camera,
                image: &s.image,
                mask: Some(&s.frame.mask),
            })
            .collect();
        for resolution in [37, 64] {
            let grid = VoxelGrid::with_resolution(scene.bounds(), resolution)?;
            let (projectors, pixels) = prepare_views(&grid, &views, 1)?;
            let bits: Vec<ViewBits> = pixels.iter().map(ViewBits::new).collect();
            let mut model = VoxelModel::full(grid);
            carve_hull(&mut model, &projectors, &pixels);
            let naive = Hull::of_model(&model);
            for edge in [8, 5] {
                let culled = Hull::culled(&grid, &projectors, &bits, edge);
                assert!(culled.inside == naive.inside, "{resolution} {edge}");
            }
            let inside = naive.inside.iter().filter(|&&x| x).count();
            assert!(inside > 1000 && inside < naive.inside.len() / 2, "{inside}");
        }
        Ok(())
    }

    #[test]
    fn normals_point_out_of_a_box_and_vanish_inside_it() {
        // A box of voxels 2..=7 in x and y, 0..=5 in z, in a 10 x 10 x 8 grid: it stands on
        // the grid's floor, which is no boundary.
        let hull = hull_of([10, 10, 8], |i, j, k| {
            (2..=7).contains(&i) && (2..=7).contains(&j) && k <= 5
        });
        assert_eq!(hull.normal([2, 4, 3]), [-9, 0, 0], "-x face");
        assert_eq!(hull.normal([7, 4, 3]), [9, 0, 0], "+x face");
        assert_eq!(hull.normal([4, 4, 5]), [0, 0, 9], "top");
        assert_eq!(
            hull.normal([4, 2, 0]),
            [0, -9, 0],
            "on the floor: no downward part"
        );
        assert_eq!(hull.normal([4, 4, 3]), [0; 3], "inside");
        assert_eq!(
            hull.normal([4, 4, 0]),
            [0; 3],
            "the floor is not a boundary"
        );
        assert_eq!(hull.normal([0, 0, 0]), [0; 3], "outside");
        let edge = hull.normal([7, 7, 3]);
        assert!(
            edge[0] > 0 && edge[0] == edge[1] && edge[2] == 0,
            "{edge:?}"
        );
    }

    #[test]
    fn a_camera_behind_the_boundary_is_behind() {
        let x = Point3::new(0.0, 0.0, 0.0);
        let out = [1, 0, 0];
        assert!(!behind(out, &Point3::new(1.0, 0.2, 0.5), &x, -0.3));
        assert!(behind(out, &Point3::new(-1.0, 0.2, 0.5), &x, -0.3));
        // Grazing, at 100 degrees from the normal: cos = -0.17, not below -0.3.
        let a = 100f64.to_radians();
        assert!(!behind(out, &Point3::new(a.cos(), a.sin(), 0.0), &x, -0.3));
        assert!(behind(out, &Point3::new(a.cos(), a.sin(), 0.0), &x, 0.0));
        assert!(!behind([0; 3], &Point3::new(-1.0, 0.0, 0.0), &x, 0.9));
    }
}
