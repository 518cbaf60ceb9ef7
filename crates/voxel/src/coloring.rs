//! Voxel coloring (Seitz and Dyer 1997): a single top-down plane sweep.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use nalgebra::Point3;
use rayon::prelude::*;

use crate::carving::carve_hull;
use crate::column::{ColumnTest, KeptSamples, Sweep};
use crate::error::{Error, Result};
use crate::grid::{VoxelGrid, VoxelModel};
use crate::hull::{Hull, any_mask, behind};
use crate::kernel::{
    Consistency, Criterion, Footprint, Judge, Pixels, Projector, Sample, Silhouette, View,
    ViewBits, claim, decide, prepare_views,
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
    /// z-buffer at no less than a quarter of their footprint (default true). A single
    /// top-down sweep judges the voxels of one layer together although, for cameras not far
    /// above, they hide each other; walls then come out a few voxels thick, and this removes
    /// the hidden part.
    pub visible_only: bool,
    /// Views behind the visual hull (default `Some(-0.3)`; needs masks). A voxel on the
    /// boundary of the masks' visual hull is not judged by a view whose direction from it
    /// makes a cosine below this with the hull's outward normal: that view looks at it
    /// through the hull, so its pixels there show another surface, or, through a hole
    /// already carved, the object's far side, which would make a true voxel look
    /// inconsistent. `None` asks every view, as Seitz and Dyer do. See `docs/voxel.md`.
    pub behind_hull: Option<f64>,
    /// Which pixels of a voxel's footprint in a view it is judged by, in pixels inside the
    /// footprint on each side (default 0: all of them). A kept voxel claims every pixel its
    /// projected square touches (its footprint), so that no seam is left open between
    /// neighbours; with an inset it is sampled, and sees a view, only at the pixels whose
    /// centres lie within the square grown by `1/2 - sample_inset` pixels (and at least at
    /// the pixel of its centre): 0.5 takes the pixels whose centres lie inside the projected
    /// square, 1 those wholly inside it. A voxel hidden but for a rim of pixels it barely
    /// touches is then not judged by them. With dense views that is faster and as good (48
    /// views at 128^3: 12-18% less time, the same geometry on `lambertian`, `head` 0.9 points
    /// less complete, `mirror` and `chair` better); with sparse views the rims' samples are
    /// what reject voxels floating off the surface, and the models come out fatter
    /// (`lambertian` with 12 views: 2.21 voxels / 87.3% at 0.5 against 1.71 / 92.5%).
    /// See `docs/voxel.md`, "Sampled pixels".
    pub sample_inset: f32,
    /// The column test (default `None`, off): a top the criterion keeps is passed over when
    /// the views agree clearly better further down its column, and with it the tops around
    /// it, so that a layer floating over a textured face or a fillet in a corner is not kept
    /// and the sweep reconstructs the surface below. It gives better geometry (`head`,
    /// 128^3 x 48 views: 2.99 -> 1.16 voxels) in two to three times the time, and novel
    /// views rendered from its models are better on some scenes (`head`, `lambertian`) and
    /// worse on others (`mirror`, `chair`), so it is off by default. See [`crate::column`]
    /// and `docs/voxel.md`, "The column test".
    pub column_test: Option<ColumnTest>,
}

impl Default for ColoringParams {
    fn default() -> Self {
        ColoringParams {
            criterion: Criterion::default(),
            min_views: 3,
            visible_only: true,
            behind_hull: Some(-0.3),
            sample_inset: 0.0,
            column_test: None,
        }
    }
}

impl ColoringParams {
    /// Checks the parameters the kernels would refuse: a [`ColoringParams::behind_hull`]
    /// outside `[-1, 1]` (or NaN), or a [`ColoringParams::sample_inset`] outside `[0, 8]`
    /// pixels (or NaN), is [`Error::InvalidParameter`].
    pub fn validate(&self) -> Result<()> {
        if let Some(cosine) = self.behind_hull {
            if !(-1.0..=1.0).contains(&cosine) {
                return Err(Error::InvalidParameter {
                    name: "behind_hull",
                    value: cosine,
                    reason: "a cosine must lie in [-1, 1]",
                });
            }
        }
        if !(0.0..=8.0).contains(&self.sample_inset) {
            return Err(Error::InvalidParameter {
                name: "sample_inset",
                value: f64::from(self.sample_inset),
                reason: "pixels inside the footprint must lie in [0, 8]",
            });
        }
        if let Some(test) = &self.column_test {
            test.validate()?;
        }
        Ok(())
    }

    /// [`ColoringParams::sample_inset`] when it is one, `None` when the voxels are judged by
    /// their whole footprints: whether the fast kernel's sampled footprints differ from the
    /// whole ones.
    fn inset(&self) -> Option<f32> {
        (self.sample_inset > 0.0).then_some(self.sample_inset)
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
    /// Voxels the criterion kept that the column test then passed over
    /// ([`ColoringParams::column_test`]; not counted in `kept`).
    pub sunk: usize,
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
    params.validate()?;
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
/// cameras, a camera not above the grid ([`Error::CameraNotAbove`]), or a
/// [`ColoringParams::behind_hull`] outside `[-1, 1]`.
pub fn voxel_coloring(
    grid: &VoxelGrid,
    views: &[View<'_>],
    params: &ColoringParams,
) -> Result<Reconstruction> {
    let (projectors, pixels, centres) = prepare(grid, views, params)?;
    let n = views.len();
    let [nx, ny, nz] = grid.dims();
    let mut bits: Vec<ViewBits> = pixels.par_iter().map(ViewBits::new).collect();
    let hull = params
        .behind_hull
        .filter(|_| any_mask(&pixels))
        .map(|cosine| (Hull::culled(grid, &projectors, &bits, BLOCK), cosine));
    let criterion = Consistency::from(&params.criterion);
    let mut model = VoxelModel::empty(*grid);
    let mut stats = KernelStats {
        voxels: grid.len(),
        ..KernelStats::default()
    };
    let (bx, by) = (nx.div_ceil(BLOCK), ny.div_ceil(BLOCK));
    // Per view: the footprints the layer's kept voxels claim there.
    let mut claims: Vec<Vec<Footprint>> = vec![Vec::new(); n];
    // Every view's row bases of the layer being decided, shared by its blocks; the top
    // layer's now, each next one's as the layer above claims its pixels.
    let mut bases = vec![[0f32; 3]; n * ny];
    let row_bases = |rows: &mut [[f32; 3]], p: &Projector, k: usize| {
        for (j, b) in rows.iter_mut().enumerate() {
            *b = p.row_base(grid, j, k);
        }
    };
    if nz > 0 {
        bases
            .par_chunks_mut(ny)
            .zip(&projectors)
            .for_each(|(rows, p)| row_bases(rows, p, nz - 1));
    }
    // Per block, per voxel column, per view: the view's azimuth from the column, computed
    // when a voxel of the column is first decided (see `decide`); a block's are allocated
    // when it first decides a voxel, which most blocks never do.
    let azimuths: Vec<Mutex<Vec<f64>>> = (0..bx * by).map(|_| Mutex::default()).collect();
    // The blocks of a layer are dealt out one at a time to one task per thread, each with
    // its buffers for the whole run, in the order of the work each block found in the layer
    // above (a block's layers are alike), most first: a layer then ends on a light block,
    // not with one thread waiting on the other's last heavy one.
    let mut tasks: Vec<BlockScratch> = (0..rayon::current_num_threads().max(1))
        .map(|_| BlockScratch::new(n))
        .collect();
    let mut order: Vec<usize> = (0..bx * by).collect();
    let mut work = vec![0u64; bx * by];
    // With the column test: the samples each kept voxel of the layer was judged by.
    let mut kept_samples = KeptSamples::default();
    for k in (0..nz).rev() {
        let layer = Layer {
            k,
            ny,
            bases: &bases,
        };
        // Decide the layer block by block, blocks in parallel, against the claims of the
        // layers above.
        order.sort_by_key(|&b| std::cmp::Reverse(work[b]));
        let next = AtomicUsize::new(0);
        let blocks: Vec<Vec<(usize, BlockResult)>> = tasks
            .par_iter_mut()
            .map(|scratch| {
                let mut done = Vec::new();
                while let Some(&b) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let (i0, j0) = ((b % bx) * BLOCK, (b / bx) * BLOCK);
                    let (i1, j1) = ((i0 + BLOCK).min(nx), (j0 + BLOCK).min(ny));
                    let mut azimuths = azimuths[b].lock().unwrap_or_else(PoisonError::into_inner);
                    let result = decide_block(
                        grid,
                        (i0, i1),
                        (j0, j1),
                        &layer,
                        &projectors,
                        &pixels,
                        &centres,
                        &bits,
                        hull.as_ref(),
                        params,
                        &criterion,
                        scratch,
                        &mut azimuths,
                    );
                    done.push((b, result));
                }
                done
            })
            .collect();
        // In the order the tasks took the blocks: what a block keeps and claims does not
        // depend on it.
        let mut kept = Vec::new();
        kept_samples.clear();
        for (b, block) in blocks.iter().flatten() {
            work[*b] = block.work;
            stats.silhouette_rejected += block.rejected;
            stats.tested += block.tested;
            kept.extend_from_slice(&block.kept);
            kept_samples.extend(&block.samples);
            for &(v, fp) in &block.claims {
                claims[v as usize].push(fp);
            }
        }
        if let Some(test) = &params.column_test {
            let gather = |v: usize, fp: &Footprint| bits[v].gather(&pixels[v], fp);
            let sweep = Sweep::new(grid, &projectors, params, gather);
            let sunk = sweep.drop_sunk(test, &model, &mut kept, &kept_samples);
            stats.sunk += sunk;
            if sunk > 0 {
                // The blocks' claims included the sunk voxels': claim the footprints of
                // those kept instead, in every view, as the reference does.
                claims
                    .par_iter_mut()
                    .zip(&projectors)
                    .enumerate()
                    .for_each(|(v, (fps, p))| {
                        fps.clear();
                        for &([i, j, _], _) in &kept {
                            if let Some(fp) = p.footprint(p.along_row(layer.base(v, j), i)) {
                                fps.push(fp);
                            }
                        }
                    });
            }
        }
        stats.kept += kept.len();
        for &(idx, c) in &kept {
            model.set(idx, c);
        }
        // Claim the layer's footprints and project the next layer's row bases, views in
        // parallel.
        bits.par_iter_mut()
            .zip(claims.par_iter_mut())
            .zip(bases.par_chunks_mut(ny).zip(&projectors))
            .for_each(|((b, fps), (rows, p))| {
                for fp in fps.drain(..) {
                    b.claim(&fp);
                }
                if k > 0 {
                    row_bases(rows, p, k - 1);
                }
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
    let list = VoxelList::occupied(model);
    let count = list.voxels.len();
    let seen = projectors
        .par_iter()
        .fold(
            || (vec![false; count], ZBuffer::default()),
            |(mut seen, mut z), proj| {
                z.mark_seen(&grid, proj, &list, &mut seen);
                (seen, z)
            },
        )
        .map(|(seen, _)| seen)
        .reduce(
            || vec![false; count],
            |mut a, b| {
                for (x, y) in a.iter_mut().zip(b) {
                    *x |= y;
                }
                a
            },
        );
    for (&v, &s) in list.voxels.iter().zip(&seen) {
        if !s {
            model.clear(v);
            stats.kept -= 1;
        }
    }
}

/// Voxels listed row by row, as the z-buffers take them: each view projects each row's
/// base once.
pub(crate) struct VoxelList {
    /// The voxels `[i, j, k]`, row by row.
    pub(crate) voxels: Vec<[usize; 3]>,
    /// The rows `(j, k)` that hold listed voxels.
    rows: Vec<(usize, usize)>,
    /// Per voxel: its row in `rows`.
    row_of: Vec<usize>,
}

impl VoxelList {
    /// The occupied voxels of `model`, layer by layer from the bottom, row by row.
    pub(crate) fn occupied(model: &VoxelModel) -> Self {
        let layers: Vec<Vec<[usize; 3]>> = (0..model.occupied.len_of(ndarray::Axis(0)))
            .into_par_iter()
            .map(|k| {
                model
                    .occupied
                    .index_axis(ndarray::Axis(0), k)
                    .indexed_iter()
                    .filter(|(_, o)| **o)
                    .map(|((j, i), _)| [i, j, k])
                    .collect()
            })
            .collect();
        VoxelList::new(layers.concat())
    }

    /// The list of `voxels`, which must come row by row (all of one row `(j, k)` together).
    fn new(voxels: Vec<[usize; 3]>) -> Self {
        let mut rows: Vec<(usize, usize)> = Vec::new();
        let mut row_of = Vec::with_capacity(voxels.len());
        for &[_, j, k] in &voxels {
            if rows.last() != Some(&(j, k)) {
                rows.push((j, k));
            }
            row_of.push(rows.len() - 1);
        }
        VoxelList {
            voxels,
            rows,
            row_of,
        }
    }
}

/// One view's z-buffer over a list of voxels, its buffers kept from view to view.
#[derive(Default)]
pub(crate) struct ZBuffer {
    /// Per row of the list: its base in this view.
    bases: Vec<[f32; 3]>,
    /// Per voxel: the homogeneous projection of its centre (`h[2]`, the depth).
    h: [Vec<f32>; 3],
    /// Per voxel: its footprint.
    footprints: Vec<Footprint>,
    /// Per pixel of the footprints' bounding box, the nearest voxel as one key: the depth's
    /// bits (positive floats order as their bits do) above the voxel's index, so the
    /// smallest key is the nearest voxel and ties go to the lower index, the same in every
    /// run.
    nearest: Vec<u64>,
    /// Per voxel: the pixels it is nearest at.
    wins: Vec<u32>,
}

impl ZBuffer {
    /// Sets `seen[n]` for every voxel `n` of `list` nearest in this view at no less than a
    /// quarter of its footprint.
    fn mark_seen(
        &mut self,
        grid: &VoxelGrid,
        proj: &Projector,
        list: &VoxelList,
        seen: &mut [bool],
    ) {
        self.render(grid, proj, list);
        for ((s, fp), &wins) in seen.iter_mut().zip(&self.footprints).zip(&self.wins) {
            *s |= nearest_enough(fp, wins);
        }
    }

    /// True when voxel `n` of the list last rendered is nearest in its view at no less than a
    /// quarter of its footprint: the view sees it.
    pub(crate) fn sees(&self, n: usize) -> bool {
        nearest_enough(&self.footprints[n], self.wins[n])
    }

    /// Z-buffers the voxels of `list` in the view of `proj`: afterwards
    /// [`ZBuffer::sees`] answers for each of them.
    pub(crate) fn render(&mut self, grid: &VoxelGrid, proj: &Projector, list: &VoxelList) {
        self.bases.clear();
        self.bases
            .extend(list.rows.iter().map(|&(j, k)| proj.row_base(grid, j, k)));
        // The centres' projections first, then the footprints in a loop of their own, which
        // vectorises.
        let count = list.voxels.len();
        for h in &mut self.h {
            h.clear();
            h.resize(count, 0.0);
        }
        {
            let [hx, hy, hz] = &mut self.h;
            for ((((&r, v), x), y), z) in list
                .row_of
                .iter()
                .zip(&list.voxels)
                .zip(hx.iter_mut())
                .zip(hy.iter_mut())
                .zip(hz.iter_mut())
            {
                [*x, *y, *z] = proj.along_row(&self.bases[r], v[0]);
            }
        }
        let [hx, hy, depths] = &self.h;
        let fps = &mut self.footprints;
        fps.clear();
        fps.extend(
            hx.iter()
                .zip(hy)
                .zip(depths)
                .map(|((&x, &y), &z)| proj.footprint_of(x, y, z)),
        );
        self.wins.clear();
        self.wins.resize(fps.len(), 0);
        // The z-buffer covers only the footprints' bounding box.
        let (mut u0, mut u1, mut v0, mut v1) = (u32::MAX, 0, u32::MAX, 0);
        for fp in fps.iter().filter(|fp| !fp.is_empty()) {
            (u0, u1) = (u0.min(fp.u0), u1.max(fp.u1));
            (v0, v1) = (v0.min(fp.v0), v1.max(fp.v1));
        }
        if u0 > u1 {
            return;
        }
        // Each row padded by `RUN - 1` keys that no footprint reaches, so that a footprint's
        // row of up to `RUN` pixels is lowered as a run of fixed length (see `lower_rows`).
        let width = (u1 - u0) as usize + RUN;
        self.nearest.clear();
        self.nearest
            .resize(width * (v1 - v0 + 1) as usize, u64::MAX);
        for (n, (fp, z)) in fps.iter().zip(depths.iter()).enumerate() {
            if fp.is_empty() {
                continue;
            }
            let key = (u64::from(z.to_bits()) << 32) | n as u64;
            let (a, b) = ((fp.u0 - u0) as usize, (fp.u1 - u0) as usize + 1);
            let rows = (fp.v0 - v0) as usize..(fp.v1 - v0) as usize + 1;
            if b - a <= 4 {
                lower_rows::<4>(&mut self.nearest, width, rows, a, b - a, key);
            } else if b - a <= RUN {
                lower_rows::<RUN>(&mut self.nearest, width, rows, a, b - a, key);
            } else {
                for v in rows {
                    let row = v * width;
                    for k in &mut self.nearest[row + a..row + b] {
                        *k = (*k).min(key);
                    }
                }
            }
        }
        for &k in &self.nearest {
            if k != u64::MAX {
                self.wins[(k & u64::from(u32::MAX)) as usize] += 1;
            }
        }
    }
}

/// The longest footprint row [`ZBuffer::render`] lowers as a run of fixed length.
const RUN: usize = 8;

/// Lowers to `key` the keys `a..a + len` (`len` at most `N`) of rows `rows` of `nearest`,
/// rows of `width` keys, as runs of `N` keys from `a` (the keys past `a + len` lowered to
/// `u64::MAX`, which keeps them). A count known when compiling: footprint rows are short (3
/// or 4 pixels at 128^3 with VGA views, 2 or 3 at 256^3), and a loop over exactly their
/// pixels spent more time choosing between its vector and remainder paths than lowering
/// keys (some 4% of the kernel's time at 128^3, `docs/voxel.md`).
#[inline(always)]
fn lower_rows<const N: usize>(
    nearest: &mut [u64],
    width: usize,
    rows: std::ops::Range<usize>,
    a: usize,
    len: usize,
    key: u64,
) {
    let keys: [u64; N] = std::array::from_fn(|l| if l < len { key } else { u64::MAX });
    for v in rows {
        let at = v * width + a;
        for (k, &new) in nearest[at..at + N].iter_mut().zip(&keys) {
            *k = (*k).min(new);
        }
    }
}

/// True when a voxel nearest at `wins` pixels of its footprint `fp` is seen: at no less than
/// a quarter of it.
#[inline]
fn nearest_enough(fp: &Footprint, wins: u32) -> bool {
    !fp.is_empty() && 4 * wins >= fp.area()
}

/// Edge of the square blocks of a layer that the fast kernel culls together, voxels.
const BLOCK: usize = 8;

/// What one block of a layer decided.
struct BlockResult {
    kept: Vec<([usize; 3], [u8; 3])>,
    /// With the column test, the samples each kept voxel was judged by.
    samples: KeptSamples,
    /// The footprints the kept voxels claim, with their views. Only views where a claim
    /// can change something are listed: with no inset, those where the voxel's footprint
    /// still had a pixel open when it was tested; with one, those that could still see the
    /// block (in the others every pixel under the block is already resolved).
    claims: Vec<(u32, Footprint)>,
    rejected: usize,
    tested: usize,
    /// The questions the block left to its voxels: its live voxels times the views still
    /// open for it after the block-wide tests (0 when those settled it).
    work: u64,
}

/// Per-thread buffers of the fast kernel.
struct BlockScratch {
    silhouette: Vec<usize>,
    active: Vec<usize>,
    footprints: BlockFootprints,
    /// Per voxel of the block: still a candidate (not rejected by a silhouette, still able
    /// to reach `min_views`).
    alive: Vec<bool>,
    /// Per voxel of the block, up to one per view (`views` a voxel): its samples in view
    /// order, and how many.
    samples: Vec<Sample>,
    counts: Vec<usize>,
    decide: Vec<crate::kernel::Emission>,
    /// Per voxel of the block, with [`ColoringParams::behind_hull`]: its hull normal and
    /// its centre, once it has met an open view.
    normals: Vec<Option<([i32; 3], Point3<f64>)>>,
    /// Per voxel of the block, a bit per view (`n.div_ceil(64)` words a voxel, `n` views):
    /// bit `a` set where the voxel's footprint in the block's active view `a` still had a
    /// pixel open when it was tested. A kept voxel claims only there: elsewhere every pixel
    /// of its footprint is already resolved.
    open: Vec<u64>,
}

impl BlockScratch {
    fn new(n: usize) -> Self {
        let cells = BLOCK * BLOCK;
        BlockScratch {
            silhouette: Vec::with_capacity(n),
            active: Vec::with_capacity(n),
            footprints: BlockFootprints::new(n),
            alive: vec![false; cells],
            samples: vec![
                Sample {
                    view: 0,
                    colour: [0.0; 3]
                };
                n * cells
            ],
            counts: vec![0; cells],
            decide: Vec::with_capacity(n),
            normals: vec![None; cells],
            open: vec![0; cells * n.div_ceil(64)],
        }
    }
}

/// One kind of footprint of one block's voxels in every view, each view's computed on first
/// use within the block.
struct FootprintCache {
    /// Per view: are its footprints of the current block in `footprints`?
    projected: Vec<bool>,
    /// Per view, per voxel of the block (row-major, `BLOCK * BLOCK` a view): footprints,
    /// empty where the voxel is behind the camera or off the image.
    footprints: Vec<Footprint>,
}

impl FootprintCache {
    fn new(n: usize) -> Self {
        FootprintCache {
            projected: vec![false; n],
            footprints: vec![Footprint::EMPTY; n * BLOCK * BLOCK],
        }
    }

    /// Forgets every view's footprints, for the next block.
    fn clear(&mut self) {
        self.projected.fill(false);
    }

    /// The cached footprints of view `v`, if they were computed for this block.
    fn get(&self, v: usize) -> Option<&[Footprint]> {
        let cells = BLOCK * BLOCK;
        self.projected[v].then(|| &self.footprints[v * cells..(v + 1) * cells])
    }
}

/// The footprints of one block's voxels in every view: the whole footprints (the pixels a
/// voxel covers and claims; the silhouettes ask those) and the sampled ones, inset by
/// [`ColoringParams::sample_inset`] (the pixels a voxel is judged by). Inset by nothing, the
/// sampled footprints are the whole ones and share their cache.
struct BlockFootprints {
    whole: FootprintCache,
    sampled: FootprintCache,
}

impl BlockFootprints {
    fn new(n: usize) -> Self {
        BlockFootprints {
            whole: FootprintCache::new(n),
            sampled: FootprintCache::new(n),
        }
    }

    fn clear(&mut self) {
        self.whole.clear();
        self.sampled.clear();
    }

    /// The footprints in view `v` of the voxels `[i0..i1) x [j0..j1)` of layer `k` (inset
    /// by `inset` pixels when it is `Some`, as [`ColoringParams::inset`] gives it),
    /// computed on first use within the block for the rows that hold a voxel still `alive`
    /// (flags row-major, as the footprints are). The other rows keep stale values: ask only
    /// for voxels alive at the first use (they are alive then).
    #[allow(clippy::too_many_arguments)]
    fn of(
        &mut self,
        p: &Projector,
        v: usize,
        (i0, i1): (usize, usize),
        (j0, j1): (usize, usize),
        layer: &Layer<'_>,
        alive: &[bool],
        inset: Option<f32>,
    ) -> &[Footprint] {
        let cells = BLOCK * BLOCK;
        let cache = match inset {
            None => &mut self.whole,
            Some(_) => &mut self.sampled,
        };
        let out = &mut cache.footprints[v * cells..(v + 1) * cells];
        if !cache.projected[v] {
            cache.projected[v] = true;
            let width = i1 - i0;
            for j in j0..j1 {
                let row = (j - j0) * width..(j - j0 + 1) * width;
                if alive[row.clone()].iter().any(|&a| a) {
                    let base = layer.base(v, j);
                    match inset {
                        None => p.footprints_along_row(base, i0, &mut out[row]),
                        Some(inset) => p.inset_footprints_along_row(base, i0, inset, &mut out[row]),
                    }
                }
            }
        }
        out
    }

    /// The whole footprint in view `v` of voxel `x` of the block, voxel `i` of row `j` of the
    /// layer: from the cache when the view's whole footprints were computed for the block
    /// while the voxel was alive (always, for a voxel kept: it was alive throughout), else
    /// projected now.
    fn whole_of(
        &self,
        p: &Projector,
        v: usize,
        x: usize,
        (i, j): (usize, usize),
        layer: &Layer<'_>,
    ) -> Footprint {
        match self.whole.get(v) {
            Some(fps) => fps[x],
            None => p.footprint_at(layer.base(v, j), i as f32).0,
        }
    }
}

/// The layer being decided and every view's row bases in it.
struct Layer<'a> {
    k: usize,
    ny: usize,
    /// Per view, per row `j`: [`Projector::row_base`] of row `j` of layer `k`.
    bases: &'a [[f32; 3]],
}

impl Layer<'_> {
    /// The base of row `j` in view `v`.
    #[inline]
    fn base(&self, v: usize, j: usize) -> &[f32; 3] {
        &self.bases[v * self.ny + j]
    }
}

/// Decides the voxels `[i0..i1) x [j0..j1)` of a layer.
///
/// Per view, the block's projected bounds against the view bits settle most questions
/// for all its voxels at once, exactly: a view whose mask is background under the whole
/// bound (not cut by the image's edge) rejects the block; one that is foreground under it
/// rejects none of its voxels; one that is claimed under it sees none of them. With a
/// `hull`, the hull's flags stand in for the masks. The views left open are then asked one
/// at a time for every voxel of the block still in question (so each view's pixels under
/// the block are read while in cache): first the silhouette views, then the active ones in
/// view order (leaving out, with a `hull`, those behind it), with the same arithmetic as the
/// reference.
#[allow(clippy::too_many_arguments)]
fn decide_block(
    grid: &VoxelGrid,
    (i0, i1): (usize, usize),
    (j0, j1): (usize, usize),
    layer: &Layer<'_>,
    projectors: &[Projector],
    pixels: &[Pixels<'_>],
    centres: &[Point3<f64>],
    bits: &[ViewBits],
    hull: Option<&(Hull, f64)>,
    params: &ColoringParams,
    criterion: &Consistency,
    scratch: &mut BlockScratch,
    azimuths: &mut Vec<f64>,
) -> BlockResult {
    let size = (i1 - i0) * (j1 - j0);
    let mut out = BlockResult {
        kept: Vec::new(),
        samples: KeptSamples::default(),
        claims: Vec::new(),
        rejected: 0,
        tested: 0,
        work: 0,
    };
    scratch.silhouette.clear();
    scratch.active.clear();
    // With the visual hull at hand, it is the silhouette constraint, voxel by voxel.
    let inside =
        hull.map(|(hull, _)| hull.block(layer.k, (i0, i1), (j0, j1), &mut scratch.alive[..size]));
    if let Some(inside) = inside {
        out.rejected = size - inside;
        if inside == 0 {
            return out;
        }
    }
    for (v, proj) in projectors.iter().enumerate() {
        let has_mask = inside.is_none() && pixels[v].mask.is_some();
        match proj.block_bounds(layer.base(v, j0), layer.base(v, j1 - 1), (i0, i1)) {
            // Every footprint is off this image: the view neither rejects nor sees.
            Ok(None) => {}
            Ok(Some(bound)) => {
                if has_mask {
                    match bits[v].silhouette(proj, &bound) {
                        Silhouette::Outside => {
                            out.rejected = size;
                            return out;
                        }
                        Silhouette::Inside => {}
                        Silhouette::Mixed => scratch.silhouette.push(v),
                    }
                }
                if !bits[v].all_resolved(&bound) {
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
    scratch.footprints.clear();
    let mut alive = match inside {
        Some(inside) => inside,
        None => {
            scratch.alive[..size].fill(true);
            size
        }
    };
    out.work = (alive * scratch.active.len()) as u64;
    let silhouette = std::mem::take(&mut scratch.silhouette);
    for &v in &silhouette {
        let fps = scratch.footprints.of(
            &projectors[v],
            v,
            (i0, i1),
            (j0, j1),
            layer,
            &scratch.alive,
            None,
        );
        for (x, fp) in fps[..size].iter().enumerate() {
            if scratch.alive[x] && bits[v].rejects(fp) {
                scratch.alive[x] = false;
                alive -= 1;
            }
        }
        if alive == 0 {
            break;
        }
    }
    scratch.silhouette = silhouette;
    out.rejected = size - alive;
    scratch.counts[..size].fill(0);
    let n = projectors.len();
    let words = n.div_ceil(64);
    scratch.open[..size * words].fill(0);
    let width = i1 - i0;
    if hull.is_some() {
        scratch.normals[..size].fill(None);
    }
    let active = std::mem::take(&mut scratch.active);
    let m = active.len();
    for (a, &v) in active.iter().enumerate() {
        if alive == 0 {
            break;
        }
        let sampled = scratch.footprints.of(
            &projectors[v],
            v,
            (i0, i1),
            (j0, j1),
            layer,
            &scratch.alive,
            params.inset(),
        );
        for (x, fp) in sampled[..size].iter().enumerate() {
            if !scratch.alive[x] {
                continue;
            }
            // A voxel that can no longer reach `min_views` is not tested.
            let count = scratch.counts[x];
            if count + (m - a) < params.min_views {
                scratch.alive[x] = false;
                alive -= 1;
                continue;
            }
            if fp.is_empty() || bits[v].all_resolved(fp) {
                continue;
            }
            scratch.open[x * words + a / 64] |= 1 << (a % 64);
            if let Some((hull, cosine)) = hull {
                // The voxel's hull normal, on its first open view.
                let (normal, centre) = *scratch.normals[x].get_or_insert_with(|| {
                    let idx = [i0 + x % width, j0 + x / width, layer.k];
                    (hull.normal(idx), grid.centre(idx))
                });
                if behind(normal, &centres[v], &centre, *cosine) {
                    continue;
                }
            }
            let (sum, c) = bits[v].gather(&pixels[v], fp);
            if c > 0 {
                scratch.samples[x * n + count] = Sample::new(v, sum, c);
                scratch.counts[x] = count + 1;
            }
        }
    }
    scratch.active = active;
    // Without an inset a voxel was tested on its whole footprints, so it claims only in the
    // views where one still had a pixel open; with one, in every view that could still see
    // the block.
    let claim_where_open = params.inset().is_none();
    for x in 0..size {
        let count = scratch.counts[x];
        if !scratch.alive[x] || count < params.min_views {
            continue;
        }
        out.tested += 1;
        if azimuths.is_empty() {
            azimuths.resize(BLOCK * BLOCK * n, f64::NAN);
        }
        let (i, j) = (i0 + x % width, j0 + x / width);
        let voxel = grid.centre([i, j, layer.k]);
        let samples = &scratch.samples[x * n..x * n + count];
        if let Some(c) = decide(
            samples,
            centres,
            &voxel,
            criterion,
            &mut scratch.decide,
            &mut azimuths[x * n..(x + 1) * n],
        ) {
            out.kept.push(([i, j, layer.k], c));
            if params.column_test.is_some() {
                out.samples.push(samples);
            }
            // It claims its whole footprints (see `claim_where_open`).
            let open = &scratch.open[x * words..(x + 1) * words];
            for (a, &v) in scratch.active.iter().enumerate() {
                if claim_where_open && open[a / 64] & (1 << (a % 64)) == 0 {
                    continue;
                }
                let fp = scratch
                    .footprints
                    .whole_of(&projectors[v], v, x, (i, j), layer);
                if !fp.is_empty() {
                    out.claims.push((v as u32, fp));
                }
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
    let mut judge = Judge::new(Consistency::from(&params.criterion));
    let hull = params
        .behind_hull
        .filter(|_| any_mask(&pixels))
        .map(|cosine| {
            let mut model = VoxelModel::full(*grid);
            carve_hull(&mut model, &projectors, &pixels);
            (Hull::of_model(&model), cosine)
        });
    // With the column test: the samples each kept voxel of the layer was judged by.
    let mut kept_samples = KeptSamples::default();
    for k in (0..nz).rev() {
        let mut layer = Vec::new();
        kept_samples.clear();
        for j in 0..ny {
            for i in 0..nx {
                // The voxel's centre in view `v`, its footprint there, and its sampled pixels.
                let centre_in = |v: usize| {
                    let p = &projectors[v];
                    p.along_row(&p.row_base(grid, j, k), i)
                };
                let project = |v: usize| projectors[v].footprint(centre_in(v));
                let sampled = |v: usize| projectors[v].inset(centre_in(v), params.sample_inset);
                let background =
                    (0..n).any(|v| project(v).is_some_and(|fp| pixels[v].all_background(&fp)));
                if background {
                    stats.silhouette_rejected += 1;
                    continue;
                }
                let x = grid.centre([i, j, k]);
                let normal = hull
                    .as_ref()
                    .map(|(h, cosine)| (h.normal([i, j, k]), *cosine));
                let mut samples = Vec::new();
                for v in 0..n {
                    if let Some((normal, cosine)) = normal {
                        if behind(normal, &centres[v], &x, cosine) {
                            continue;
                        }
                    }
                    if let Some(fp) = sampled(v) {
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
                if let Some(c) = judge.decide(&samples, &centres, &x) {
                    layer.push(([i, j, k], c));
                    if params.column_test.is_some() {
                        kept_samples.push(&samples);
                    }
                }
            }
        }
        if let Some(test) = &params.column_test {
            let gather = |v: usize, fp: &Footprint| pixels[v].gather(fp, &claimed[v]);
            let sweep = Sweep::new(grid, &projectors, params, gather);
            stats.sunk += sweep.drop_sunk(test, &model, &mut layer, &kept_samples);
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
