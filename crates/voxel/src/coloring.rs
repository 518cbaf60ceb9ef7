//! Voxel coloring (Seitz and Dyer 1997): a single top-down plane sweep.

use nalgebra::Point3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::grid::{VoxelGrid, VoxelModel};
use crate::kernel::{
    Criterion, Footprint, Pixels, Projector, Sample, Tiles, View, claim, decide, prepare_views,
};

/// Parameters of [`voxel_coloring`] and [`voxel_coloring_reference`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColoringParams {
    /// The consistency criterion (default: the paper's angular one, [`Criterion::angular`]).
    pub criterion: Criterion,
    /// A voxel is kept only when at least this many views see unclaimed pixels of it
    /// (default 3: two views close together hardly test consistency).
    pub min_views: usize,
    /// After the sweep, keep only voxels that some view sees: nearest in that view's
    /// z-buffer at no less than half their footprint (default true). A single top-down sweep
    /// judges the voxels of one layer together although, for cameras not far above, they
    /// hide each other; walls then come out a few voxels thick, and this removes the hidden
    /// part.
    pub visible_only: bool,
}

impl Default for ColoringParams {
    fn default() -> Self {
        ColoringParams {
            criterion: Criterion::default(),
            min_views: 3,
            visible_only: true,
        }
    }
}

/// Counts from one run of a kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct KernelStats {
    /// Voxels in the grid.
    pub voxels: usize,
    /// Voxels found outside a silhouette (some view's mask is background at all their
    /// pixels). The fast kernel skips voxels already hidden in every view without asking the
    /// masks, so it may count fewer than the reference; the models are the same.
    pub silhouette_rejected: usize,
    /// Voxels seen by enough views to be tested for consistency.
    pub tested: usize,
    /// Voxels kept (or, for carving, left occupied).
    pub kept: usize,
}

/// A reconstructed model and the counts of the run.
#[derive(Debug, Clone, PartialEq)]
pub struct Reconstruction {
    /// The model.
    pub model: VoxelModel,
    /// Counts.
    pub stats: KernelStats,
}

/// Checks the ordinal visibility condition: every camera centre above the top of the grid.
pub fn check_cameras_above(grid: &VoxelGrid, views: &[View<'_>]) -> Result<()> {
    let top = grid.bounds().max.z;
    for (i, v) in views.iter().enumerate() {
        let z = v.camera.centre().z;
        if !(z > top) {
            return Err(Error::CameraNotAbove {
                view: i,
                camera_z: z,
                volume_top: top,
            });
        }
    }
    Ok(())
}

/// Projectors, pixel access and camera centres of the views.
type Prepared<'a> = (Vec<Projector>, Vec<Pixels<'a>>, Vec<Point3<f64>>);

fn prepare<'a>(
    grid: &VoxelGrid,
    views: &[View<'a>],
    params: &ColoringParams,
) -> Result<Prepared<'a>> {
    let (projectors, pixels) = prepare_views(grid, views, params.min_views.max(1))?;
    check_cameras_above(grid, views)?;
    let centres = projectors.iter().map(|p| p.centre).collect();
    Ok((projectors, pixels, centres))
}

/// Voxel coloring, parallel within each layer.
///
/// Layers are swept from the top of the grid (nearest the cameras) down. For each voxel:
/// a view whose mask is background at every footprint pixel rejects it; otherwise every view
/// contributes the mean colour of its footprint pixels not yet claimed by voxels above (and
/// foreground, with a mask); a voxel seen by at least `min_views` views and consistent by
/// the criterion is kept with the mean colour. After each layer the kept voxels claim their
/// footprints in every view. The result is identical at any thread count and to
/// [`voxel_coloring_reference`].
///
/// Errors: too few views, image or mask sizes that differ from their camera, distorted
/// cameras, or a camera not above the grid ([`Error::CameraNotAbove`]).
pub fn voxel_coloring(
    grid: &VoxelGrid,
    views: &[View<'_>],
    params: &ColoringParams,
) -> Result<Reconstruction> {
    let (projectors, pixels, centres) = prepare(grid, views, params)?;
    let n = views.len();
    let [nx, ny, nz] = grid.dims();
    let mut tiles: Vec<Tiles> = pixels.iter().map(Tiles::new).collect();
    let mut model = VoxelModel::empty(*grid);
    let mut stats = KernelStats {
        voxels: grid.len(),
        ..KernelStats::default()
    };
    let (bx, by) = (nx.div_ceil(BLOCK), ny.div_ceil(BLOCK));
    for k in (0..nz).rev() {
        // Decide the layer block by block, blocks in parallel, against the claims of the
        // layers above.
        let tiles_ref = &tiles;
        let blocks: Vec<BlockResult> = (0..bx * by)
            .into_par_iter()
            .map_init(
                || BlockScratch::new(n),
                |scratch, b| {
                    let (i0, j0) = ((b % bx) * BLOCK, (b / bx) * BLOCK);
                    let (i1, j1) = ((i0 + BLOCK).min(nx), (j0 + BLOCK).min(ny));
                    decide_block(
                        grid,
                        (i0, i1),
                        (j0, j1),
                        k,
                        &projectors,
                        &pixels,
                        &centres,
                        tiles_ref,
                        params,
                        scratch,
                    )
                },
            )
            .collect();
        for block in &blocks {
            stats.silhouette_rejected += block.rejected;
            stats.tested += block.tested;
            stats.kept += block.kept.len();
            for &(idx, c) in &block.kept {
                model.set(idx, c);
            }
        }
        // Claim the layer's footprints, views in parallel.
        tiles
            .par_iter_mut()
            .zip(projectors.par_iter())
            .for_each(|(tl, proj)| {
                for &([i, j, k], _) in blocks.iter().flat_map(|b| &b.kept) {
                    let base = proj.row_base(grid, j, k);
                    if let Some(fp) = proj.footprint(proj.along_row(&base, i)) {
                        tl.claim(&fp);
                    }
                }
                tl.settle();
            });
    }
    if params.visible_only {
        keep_visible(&mut model, &projectors, &mut stats);
    }
    Ok(Reconstruction { model, stats })
}

/// Removes the voxels no view sees (see [`ColoringParams::visible_only`]).
fn keep_visible(model: &mut VoxelModel, projectors: &[Projector], stats: &mut KernelStats) {
    let grid = *model.grid();
    let voxels: Vec<[usize; 3]> = model
        .occupied
        .indexed_iter()
        .filter(|(_, o)| **o)
        .map(|((k, j, i), _)| [i, j, k])
        .collect();
    let seen: Vec<Vec<bool>> = projectors
        .par_iter()
        .map(|proj| {
            let fps: Vec<Option<(Footprint, f32)>> = voxels
                .iter()
                .map(|&[i, j, k]| {
                    let h = proj.along_row(&proj.row_base(&grid, j, k), i);
                    proj.footprint(h).map(|fp| (fp, h[2]))
                })
                .collect();
            // The z-buffer covers only the footprints' bounding box.
            let (mut u0, mut u1, mut v0, mut v1) = (u32::MAX, 0, u32::MAX, 0);
            for (fp, _) in fps.iter().flatten() {
                (u0, u1) = (u0.min(fp.u0), u1.max(fp.u1));
                (v0, v1) = (v0.min(fp.v0), v1.max(fp.v1));
            }
            let width = u1.saturating_sub(u0) as usize + 1;
            let area = if u0 > u1 {
                0
            } else {
                width * (v1 - v0 + 1) as usize
            };
            let mut depth = vec![f32::INFINITY; area];
            let mut owner = vec![u32::MAX; area];
            for (n, f) in fps.iter().enumerate() {
                let Some((fp, z)) = f else { continue };
                for v in fp.v0..=fp.v1 {
                    for u in fp.u0..=fp.u1 {
                        let p = (v - v0) as usize * width + (u - u0) as usize;
                        // Ties go to the lower index, the same in every run.
                        if *z < depth[p] {
                            depth[p] = *z;
                            owner[p] = n as u32;
                        }
                    }
                }
            }
            let mut wins = vec![0u32; voxels.len()];
            for &o in &owner {
                if o != u32::MAX {
                    wins[o as usize] += 1;
                }
            }
            fps.iter()
                .zip(&wins)
                .map(|(f, &w)| {
                    f.is_some_and(|(fp, _)| {
                        let size = (fp.u1 - fp.u0 + 1) * (fp.v1 - fp.v0 + 1);
                        4 * w >= size
                    })
                })
                .collect()
        })
        .collect();
    for (n, &v) in voxels.iter().enumerate() {
        if !seen.iter().any(|s| s[n]) {
            model.clear(v);
            stats.kept -= 1;
        }
    }
}

/// Edge of the square blocks of a layer that the fast kernel culls together, voxels.
const BLOCK: usize = 8;

/// What one block of a layer decided.
struct BlockResult {
    kept: Vec<([usize; 3], [u8; 3])>,
    rejected: usize,
    tested: usize,
}

/// Per-thread buffers of the fast kernel.
struct BlockScratch {
    silhouette: Vec<usize>,
    active: Vec<usize>,
    /// Per view: does the per-voxel path need it (silhouette or active)?
    needed: Vec<bool>,
    /// Per view: the projection of voxel `[0, j, k]` of the current row.
    bases: Vec<[f32; 3]>,
    /// Per view: the footprint of voxel `stamps[v]` (so a view that is both a silhouette and
    /// an active view projects each voxel once).
    footprints: Vec<Option<Footprint>>,
    stamps: Vec<usize>,
    /// Index into `silhouette` of the view that rejected the last rejected voxel: neighbours
    /// tend to fall outside the same silhouette, so it is asked first.
    rejecter: usize,
    samples: Vec<Sample>,
    decide: Vec<crate::kernel::Emission>,
}

impl BlockScratch {
    fn new(n: usize) -> Self {
        BlockScratch {
            silhouette: Vec::with_capacity(n),
            active: Vec::with_capacity(n),
            needed: vec![false; n],
            bases: vec![[0.0; 3]; n],
            footprints: vec![None; n],
            stamps: vec![usize::MAX; n],
            rejecter: 0,
            samples: Vec::with_capacity(n),
            decide: Vec::with_capacity(n),
        }
    }

    /// The footprint of voxel `i` of the current row (stamp `stamp`) in view `v`.
    #[inline]
    fn footprint(&mut self, p: &Projector, v: usize, i: usize, stamp: usize) -> Option<Footprint> {
        if self.stamps[v] != stamp {
            self.stamps[v] = stamp;
            self.footprints[v] = p.footprint(p.along_row(&self.bases[v], i));
        }
        self.footprints[v]
    }
}

/// Decides the voxels `[i0..i1) x [j0..j1)` of layer `k`.
///
/// Per view, the block's projected bounds against the tile summaries settle most questions
/// for all its voxels at once, exactly: a view whose mask is background under the whole
/// bound rejects the block; one that is foreground under it rejects none of its voxels; one
/// that is claimed under it sees none of them. Only the views left open are asked voxel by
/// voxel, in the same order and with the same arithmetic as the reference.
#[allow(clippy::too_many_arguments)]
fn decide_block(
    grid: &VoxelGrid,
    (i0, i1): (usize, usize),
    (j0, j1): (usize, usize),
    k: usize,
    projectors: &[Projector],
    pixels: &[Pixels<'_>],
    centres: &[Point3<f64>],
    tiles: &[Tiles],
    params: &ColoringParams,
    scratch: &mut BlockScratch,
) -> BlockResult {
    let size = (i1 - i0) * (j1 - j0);
    let mut out = BlockResult {
        kept: Vec::new(),
        rejected: 0,
        tested: 0,
    };
    scratch.silhouette.clear();
    scratch.active.clear();
    for (v, proj) in projectors.iter().enumerate() {
        let has_mask = pixels[v].mask.is_some();
        match proj.block_bounds(grid, (i0, i1), (j0, j1), k) {
            // Every footprint is off this image: the view neither rejects nor sees.
            Ok(None) => {}
            Ok(Some(bound)) => {
                if has_mask {
                    match tiles[v].mask_class(&bound) {
                        0 => {
                            out.rejected = size;
                            return out;
                        }
                        2 => {}
                        _ => scratch.silhouette.push(v),
                    }
                }
                if !tiles[v].all_claimed(&bound) {
                    scratch.active.push(v);
                }
            }
            Err(()) => {
                if has_mask {
                    scratch.silhouette.push(v);
                }
                scratch.active.push(v);
            }
        }
    }
    if scratch.active.len() < params.min_views {
        // No voxel of the block can be seen by enough views (and so none is tested).
        return out;
    }
    scratch.needed.fill(false);
    for &v in scratch.silhouette.iter().chain(&scratch.active) {
        scratch.needed[v] = true;
    }
    scratch.stamps.fill(usize::MAX);
    scratch.rejecter = 0;
    for j in j0..j1 {
        for (v, p) in projectors.iter().enumerate() {
            if scratch.needed[v] {
                scratch.bases[v] = p.row_base(grid, j, k);
            }
        }
        for i in i0..i1 {
            // A stamp unique to the voxel within the block.
            let stamp = (j - j0) * (i1 - i0) + (i - i0);
            let m = scratch.silhouette.len();
            let rejected = (0..m).any(|a| {
                let s = (scratch.rejecter + a) % m;
                let v = scratch.silhouette[s];
                let out = scratch
                    .footprint(&projectors[v], v, i, stamp)
                    .is_some_and(|f| tiles[v].all_background(&pixels[v], &f));
                if out {
                    scratch.rejecter = s;
                }
                out
            });
            if rejected {
                out.rejected += 1;
                continue;
            }
            scratch.samples.clear();
            let m = scratch.active.len();
            for a in 0..m {
                // A voxel that can no longer reach `min_views` is not tested.
                if scratch.samples.len() + (m - a) < params.min_views {
                    break;
                }
                let v = scratch.active[a];
                let Some(f) = scratch.footprint(&projectors[v], v, i, stamp) else {
                    continue;
                };
                if tiles[v].all_claimed(&f) {
                    continue;
                }
                let (sum, count) = tiles[v].gather(&pixels[v], &f);
                if count > 0 {
                    scratch.samples.push(Sample::new(v, sum, count));
                }
            }
            if scratch.samples.len() < params.min_views {
                continue;
            }
            out.tested += 1;
            let x = grid.centre([i, j, k]);
            if let Some(c) = decide(
                &scratch.samples,
                centres,
                &x,
                &params.criterion,
                &mut scratch.decide,
            ) {
                out.kept.push(([i, j, k], c));
            }
        }
    }
    out
}

/// The plain scalar reference of [`voxel_coloring`]: one voxel at a time, every view, no
/// early rejection, no threads. Kept to prove the fast path right; use that one.
pub fn voxel_coloring_reference(
    grid: &VoxelGrid,
    views: &[View<'_>],
    params: &ColoringParams,
) -> Result<Reconstruction> {
    let (projectors, pixels, centres) = prepare(grid, views, params)?;
    let n = views.len();
    let [nx, ny, nz] = grid.dims();
    let mut claimed: Vec<Vec<u8>> = pixels.iter().map(|p| vec![0u8; p.rgb.len() / 3]).collect();
    let mut model = VoxelModel::empty(*grid);
    let mut stats = KernelStats {
        voxels: grid.len(),
        ..KernelStats::default()
    };
    let mut scratch = Vec::new();
    for k in (0..nz).rev() {
        let mut layer = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                let project = |v: usize| {
                    let p = &projectors[v];
                    p.footprint(p.along_row(&p.row_base(grid, j, k), i))
                };
                let background =
                    (0..n).any(|v| project(v).is_some_and(|fp| pixels[v].all_background(&fp)));
                if background {
                    stats.silhouette_rejected += 1;
                    continue;
                }
                let mut samples = Vec::new();
                for v in 0..n {
                    if let Some(fp) = project(v) {
                        let (sum, count) = pixels[v].gather(&fp, &claimed[v]);
                        if count > 0 {
                            samples.push(Sample::new(v, sum, count));
                        }
                    }
                }
                if samples.len() < params.min_views {
                    continue;
                }
                stats.tested += 1;
                let x = grid.centre([i, j, k]);
                if let Some(c) = decide(&samples, &centres, &x, &params.criterion, &mut scratch) {
                    layer.push(([i, j, k], c));
                }
            }
        }
        for &(idx, c) in &layer {
            model.set(idx, c);
            for v in 0..n {
                let p = &projectors[v];
                if let Some(fp) =
                    p.footprint(p.along_row(&p.row_base(grid, idx[1], idx[2]), idx[0]))
                {
                    claim(&mut claimed[v], pixels[v].width, &fp);
                }
            }
        }
        stats.kept += layer.len();
    }
    if params.visible_only {
        keep_visible(&mut model, &projectors, &mut stats);
    }
    Ok(Reconstruction { model, stats })
}
