//! The column test: voxel coloring passes over a floating voxel when the views agree
//! clearly better further down its column ([`ColumnTest`], an option of
//! [`crate::ColoringParams`]).
//!
//! A single sweep keeps the first voxel down each ray that its views find consistent. Over a
//! horizontal textured face seen from the ring's elevation, a voxel a layer or two above the
//! face still passes the criteria, which compare views close in angle: they see it against
//! nearly the same texture. The true voxel below is then hidden by it. On `head` that fattens
//! the pedestal top and fills the corner under the neck with a fillet up to ten layers high
//! (`docs/voxel.md`). A threshold cannot tell the two apart; a comparison down the column
//! can. Every view sees the true surface at the same point, while a point above it is seen at
//! points spread over a circle whose radius grows with the height, so over all the views,
//! wide baselines included, the colours agree best at the true height.
//!
//! With the test on, a voxel the criterion keeps whose column above is empty in the model
//! so far (a top) is asked one more question before it is kept. Over the views the criterion
//! judged it by, the robust spread of its colours (for each view the median of its RMS differences to
//! the others, then the median over the views, so a highlight in a few views does not count)
//! is compared with the same spread of each of the [`ColumnTest::depth`] voxels below it,
//! each sampled from the same views at its own footprint's unclaimed pixels. When the best of
//! those is clearly smaller, by [`ColumnTest::ratio`] and [`ColumnTest::margin`] both, the
//! top would sink. It does, and is not kept, only when at least [`ColumnTest::neighbours`]
//! of the tops the layer keeps in the 8 columns around it would sink too: a floating layer
//! or a fillet sinks as a whole, while a lone top on flat colour or at a texture edge stays.
//!
//! A top that sinks leaves its pixels unclaimed, so the sweep goes on down the column and
//! judges the voxel below it with them, as if the floating one had been inconsistent. That
//! is what sets it apart from [`crate::refine_tops`], a pass after the sweep: there, what a
//! lowered top had hidden was never reconstructed, and the model is left with pits.
//!
//! The decisions of a layer read only the claims of the layers above and the kept voxels of
//! the layer, so they are the same at any thread count, and the same in
//! [`crate::voxel_coloring`] and [`crate::voxel_coloring_reference`], which both call this
//! module.
//!
//! # Conventions
//! "Up" is +z of the grid (the turntable frame's pan axis); depths are in voxels, colour
//! differences in grey levels of 8-bit images, RMS over R, G and B, as in the criteria of
//! [`crate::Criterion`].

use rayon::prelude::*;

use crate::coloring::ColoringParams;
use crate::error::{Error, Result};
use crate::grid::{VoxelGrid, VoxelModel};
use crate::kernel::{Footprint, Projector, Sample};
use crate::refine::Spreads;

/// Parameters of the column test ([`crate::ColoringParams::column_test`]); see the
/// [module](self) for what it does. The defaults were chosen on the catalogue at 128^3
/// with 48 views (`docs/voxel.md`, "The column test").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnTest {
    /// How many voxels below a top are compared with it (default 12, the best geometry; at
    /// 8 `head` stays within 1.5 voxels with the angular criterion, and the models render
    /// `chair` and the mirrors closer to the plain sweep's: `docs/voxel.md`, "The column
    /// test").
    pub depth: usize,
    /// A top sinks only when the best spread below is at most this share of its own
    /// (default 0.7) ...
    pub ratio: f32,
    /// ... and at least this many grey levels below it (default 6): on flat colour the
    /// spreads are sensor noise, and the smallest of them says nothing about the height.
    pub margin: f32,
    /// ... and at least this share of the tops the layer keeps in the 8 columns around it
    /// would sink too (default 0.5).
    pub neighbours: f32,
}

impl Default for ColumnTest {
    fn default() -> Self {
        ColumnTest {
            depth: 12,
            ratio: 0.7,
            margin: 6.0,
            neighbours: 0.5,
        }
    }
}

impl ColumnTest {
    /// A [`ColumnTest::depth`] of 0, a [`ColumnTest::ratio`] or [`ColumnTest::neighbours`]
    /// outside `[0, 1]`, or a negative [`ColumnTest::margin`] (any of them NaN) is
    /// [`Error::InvalidParameter`].
    pub fn validate(&self) -> Result<()> {
        let share = |name, value: f32| {
            if (0.0..=1.0).contains(&value) {
                Ok(())
            } else {
                Err(Error::InvalidParameter {
                    name,
                    value: f64::from(value),
                    reason: "a share must lie in [0, 1]",
                })
            }
        };
        share("column_test.ratio", self.ratio)?;
        share("column_test.neighbours", self.neighbours)?;
        if !(self.margin >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "column_test.margin",
                value: f64::from(self.margin),
                reason: "grey levels must not be negative",
            });
        }
        if self.depth == 0 {
            return Err(Error::InvalidParameter {
                name: "column_test.depth",
                value: 0.0,
                reason: "at least one voxel below must be compared",
            });
        }
        Ok(())
    }
}

/// The samples a kernel judged each kept voxel of a layer by, one voxel's after another:
/// the column test compares a top with the voxels below it in those views.
#[derive(Debug, Default)]
pub(crate) struct KeptSamples {
    samples: Vec<Sample>,
    /// Where each voxel's samples end in `samples`.
    ends: Vec<usize>,
}

impl KeptSamples {
    /// Forgets every voxel's samples.
    pub(crate) fn clear(&mut self) {
        self.samples.clear();
        self.ends.clear();
    }

    /// Adds the next kept voxel's samples.
    pub(crate) fn push(&mut self, samples: &[Sample]) {
        self.samples.extend_from_slice(samples);
        self.ends.push(self.samples.len());
    }

    /// Adds every voxel of `other` after those here.
    pub(crate) fn extend(&mut self, other: &KeptSamples) {
        let base = self.samples.len();
        self.samples.extend_from_slice(&other.samples);
        self.ends.extend(other.ends.iter().map(|e| base + e));
    }

    /// The samples of kept voxel `i`.
    fn of(&self, i: usize) -> &[Sample] {
        let start = if i == 0 { 0 } else { self.ends[i - 1] };
        &self.samples[start..self.ends[i]]
    }
}

/// What the column test needs of a kernel's state while it decides a layer.
pub(crate) struct Sweep<'a, G> {
    grid: &'a VoxelGrid,
    projectors: &'a [Projector],
    /// [`crate::ColoringParams::sample_inset`].
    inset: f32,
    /// [`crate::ColoringParams::min_views`].
    min_views: usize,
    /// Sum and count of the pixels of a footprint in view `v` not yet claimed (and
    /// foreground, with a mask): the kernel's own gather.
    gather: G,
}

impl<'a, G> Sweep<'a, G>
where
    G: Fn(usize, &Footprint) -> ([u32; 3], u32) + Sync,
{
    /// A kernel's state: its views' projectors, its parameters and its gather.
    pub(crate) fn new(
        grid: &'a VoxelGrid,
        projectors: &'a [Projector],
        params: &ColoringParams,
        gather: G,
    ) -> Self {
        Sweep {
            grid,
            projectors,
            inset: params.sample_inset,
            min_views: params.min_views,
            gather,
        }
    }

    /// Removes from `kept`, the voxels the criterion keeps in one layer (`model` holds the
    /// layers above) judged by `samples`, those the test sinks; returns how many.
    pub(crate) fn drop_sunk(
        &self,
        test: &ColumnTest,
        model: &VoxelModel,
        kept: &mut Vec<([usize; 3], [u8; 3])>,
        samples: &KeptSamples,
    ) -> usize {
        let sinking = self.sinking(test, model, kept, samples);
        let before = kept.len();
        let mut sinks = sinking.into_iter();
        kept.retain(|_| !sinks.next().unwrap_or(false));
        before - kept.len()
    }

    /// For each voxel of `kept`, the voxels the criterion keeps in one layer (`model` holds
    /// the layers above), whether the test drops it.
    fn sinking(
        &self,
        test: &ColumnTest,
        model: &VoxelModel,
        kept: &[([usize; 3], [u8; 3])],
        samples: &KeptSamples,
    ) -> Vec<bool> {
        let nz = self.grid.dims()[2];
        let top = |[i, j, k]: [usize; 3]| k + 1 >= nz || !model.is_occupied([i, j, k + 1]);
        // Per kept voxel: `None` when it is no top, else whether it would sink.
        let would: Vec<Option<bool>> = kept
            .par_iter()
            .enumerate()
            .map_init(Judging::default, |scratch, (n, &(idx, _))| {
                top(idx).then(|| self.would_sink(test, idx, samples.of(n), scratch))
            })
            .collect();
        // The tops of the layer by column, for the neighbour count.
        let [nx, ny, _] = self.grid.dims();
        let mut columns = vec![None; nx * ny];
        for (&(idx, _), &w) in kept.iter().zip(&would) {
            columns[idx[1] * nx + idx[0]] = w;
        }
        kept.iter()
            .zip(&would)
            .map(|(&([i, j, _], _), &w)| {
                if w != Some(true) {
                    return false;
                }
                let (mut judged, mut sinking) = (0u32, 0u32);
                for b in j.saturating_sub(1)..(j + 2).min(ny) {
                    for a in i.saturating_sub(1)..(i + 2).min(nx) {
                        if (a, b) == (i, j) {
                            continue;
                        }
                        if let Some(s) = columns[b * nx + a] {
                            judged += 1;
                            sinking += u32::from(s);
                        }
                    }
                }
                sinking as f32 >= test.neighbours * judged as f32
            })
            .collect()
    }

    /// Whether the top `idx`, judged by `own`, would sink, before its neighbours are asked.
    fn would_sink(
        &self,
        test: &ColumnTest,
        [i, j, k]: [usize; 3],
        own: &[Sample],
        scratch: &mut Judging,
    ) -> bool {
        scratch.colours.clear();
        scratch.colours.extend(own.iter().map(|s| s.colour));
        if scratch.colours.len() < self.min_views.max(2) {
            return false;
        }
        // No candidate can be `margin` below a spread within it: a fifth to a quarter of the
        // tops stop here (`docs/voxel.md`, "The column test").
        if Spreads::at_most(&scratch.colours, test.margin) {
            return false;
        }
        let spread = scratch.spreads.robust(&scratch.colours);
        // The top would sink when some candidate's spread is at most this: the first such
        // candidate settles it.
        let bar = (test.ratio * spread).min(spread - test.margin);
        (1..=test.depth.min(k)).any(|d| {
            scratch.colours.clear();
            for v in own.iter().map(|s| s.view) {
                if let Some(c) = self.colour(&self.projectors[v], v, [i, j, k - d]) {
                    scratch.colours.push(c);
                }
            }
            scratch.colours.len() >= self.min_views.max(2)
                && Spreads::at_most(&scratch.colours, bar)
        })
    }

    /// The mean colour of voxel `idx`'s unclaimed sampled pixels in view `v`, if any.
    fn colour(&self, p: &Projector, v: usize, [i, j, k]: [usize; 3]) -> Option<[f32; 3]> {
        let fp = p.inset(p.along_row(&p.row_base(self.grid, j, k), i), self.inset)?;
        let (sum, count) = (self.gather)(v, &fp);
        (count > 0).then(|| Sample::new(v, sum, count).colour)
    }
}

/// Buffers reused from one top to the next on a thread.
#[derive(Default)]
struct Judging {
    colours: Vec<[f32; 3]>,
    spreads: Spreads,
}
