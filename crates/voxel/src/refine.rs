//! Lowering a model's upward-facing surface to where its views agree best
//! ([`refine_tops`]), an optional pass after voxel coloring.
//!
//! A single sweep keeps the first voxel down each ray that its views find consistent. Over a
//! horizontal textured face seen from the ring's elevation, a voxel a layer or two above the
//! face still passes: views close in angle see it against nearly the same texture, and the
//! true voxel below is then hidden by it. On `head` that fattens the pedestal top by one or
//! two layers and fills the corner under the neck with a fillet up to ten layers high
//! (`docs/voxel.md`). A threshold cannot tell the two apart (the floating voxel is
//! consistent); a comparison down the column can: every view sees the true surface at the
//! same point, while a point above it is seen at points spread over a circle whose radius
//! grows with the height, so the views' colours agree best at the true height.
//!
//! For every occupied voxel whose upper neighbour is empty, the views that see it (where it
//! is the nearest voxel at no less than a quarter of its footprint, as in voxel coloring's
//! [`crate::ColoringParams::visible_only`]) are asked for the mean colour of the
//! footprint of it and of each of the `max_depth` voxels below it. Each candidate gets the
//! robust spread of those colours (for each view the median of its RMS colour differences to
//! the other views, then the median of that over the views, so a highlight in fewer than half
//! of them does not count); the voxel moves down to the candidate with the smallest spread
//! when that is clearly smaller than its own, by [`TopRefinement::ratio`] and
//! [`TopRefinement::margin`] both. A move is then kept only when the tops around it (those
//! of the 8 neighbouring columns within a layer of it) move about as far: the median of
//! their depths and its own is within one voxel of its own. A floating layer or a fillet
//! moves as a whole, while a lone top that would sink alone into flat colour, digging a pit,
//! stays. The voxels from each kept move's top down to just above its new place are cleared
//! and the new place takes the mean colour. Every decision reads the model as it came in,
//! so the result does not depend on the order or the thread count.
//!
//! It is a geometry pass and is not part of the rendering pipeline: measured on the
//! catalogue (`docs/voxel.md`, "Refining the tops"), it brings `head` within the 1.5-voxel /
//! 90% targets and keeps or improves the other scenes' accuracy, but it leaves pits: where a
//! top sinks beside a column that stays, the cleared cells open that column's hollow (voxel
//! coloring keeps a shell, and what a fillet hid was never reconstructed). Novel views
//! rendered from the refined models are then 0.3-1.1 dB worse at 24 and 48 views on
//! `lambertian`, `mirror` and `chair`, and on the real dinoSparseRing the model covers less of
//! the silhouettes (worst view 97.3% -> 93.2%).
//!
//! [`TopRefinement::walls`] closes the pits: the hollow column's cells beside the cleared
//! ones are occupied, a wall down each step. The walled models render as well as the
//! sweep's (within 0.07 dB on every catalogue scene, 0.2-0.6 dB better on `head`) and cover
//! the dino's silhouettes as the sweep's do (97.2%), but the walls also show where the
//! columns beside a sunken top stayed too high, and `head`'s accuracy falls to 2.02 voxels
//! (`docs/voxel.md`, "Walls for the steps"). So neither setting is best at both, and walls
//! are off by default, which keeps the geometry.
//!
//! # Conventions
//! "Up" is +z of the grid (the turntable frame's pan axis); depths are in voxels, colour
//! differences in grey levels of 8-bit images, RMS over R, G and B, as in the criteria of
//! [`crate::Criterion`].

use std::collections::HashMap;

use rayon::prelude::*;

use crate::coloring::{VoxelList, ZBuffer};
use crate::error::{Error, Result};
use crate::grid::{VoxelGrid, VoxelModel};
use crate::kernel::{Footprint, Pixels, Projector, View, squared_difference, validate_views};

/// Parameters of [`refine_tops`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TopRefinement {
    /// How many voxels below a top voxel its surface may move (default 10).
    pub max_depth: usize,
    /// A move needs the candidate's spread at most this share of the top's (default 0.7).
    pub ratio: f32,
    /// ... and at least this many grey levels below it (default 8): on flat colour the
    /// spreads are sensor noise, and the smallest of them says nothing about the height.
    pub margin: f32,
    /// A top voxel is judged only when at least this many views see it (default 4).
    pub min_views: usize,
    /// Wall the steps the moves leave (default `false`): where a moved top lies beside a
    /// column that stands higher and is hollow below its surface (voxel coloring keeps a
    /// shell), the cleared cells open that hollow to the outside, and rays through the step
    /// meet the far side of the object. With walls, the cells of such a column beside the
    /// cleared ones are occupied, so the model stays as closed as the sweep's: novel views
    /// rendered from it and its silhouettes are then as good as the sweep's, where without
    /// walls they lose. The walls also show the columns that did not move, which costs
    /// accuracy where those stand too high (`head`, 128^3 x 48 views: 1.23 voxels without,
    /// 2.02 with; `docs/voxel.md`, "Walls for the steps").
    pub walls: bool,
}

impl Default for TopRefinement {
    fn default() -> Self {
        TopRefinement {
            max_depth: 10,
            ratio: 0.7,
            margin: 8.0,
            min_views: 4,
            walls: false,
        }
    }
}

impl TopRefinement {
    /// A [`TopRefinement::ratio`] outside `[0, 1]`, a negative [`TopRefinement::margin`] (or
    /// either NaN), or a [`TopRefinement::min_views`] under 2 is [`Error::InvalidParameter`].
    pub fn validate(&self) -> Result<()> {
        if !(0.0..=1.0).contains(&self.ratio) {
            return Err(Error::InvalidParameter {
                name: "ratio",
                value: f64::from(self.ratio),
                reason: "a share of the top's spread must lie in [0, 1]",
            });
        }
        if !(self.margin >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "margin",
                value: f64::from(self.margin),
                reason: "grey levels must not be negative",
            });
        }
        if self.min_views < 2 {
            return Err(Error::InvalidParameter {
                name: "min_views",
                value: self.min_views as f64,
                reason: "a spread needs at least two views",
            });
        }
        Ok(())
    }
}

/// Counts from one [`refine_tops`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RefineStats {
    /// Occupied voxels whose upper neighbour is empty or outside the grid.
    pub tops: usize,
    /// Tops seen by at least [`TopRefinement::min_views`] views, which were judged.
    pub judged: usize,
    /// Tops moved down.
    pub moved: usize,
    /// Moves dropped because the tops around them did not move about as far.
    pub lone: usize,
    /// Voxels cleared above the moved tops' new places (the sum of the moves' depths).
    pub cleared: usize,
    /// Voxels occupied to wall the steps the moves left ([`TopRefinement::walls`]).
    pub walled: usize,
}

/// One top's decision: move voxel `top` down by `depth` and give its new place `colour`.
#[derive(Debug, Clone, Copy)]
struct Move {
    top: [usize; 3],
    depth: usize,
    colour: [u8; 3],
}

/// Moves the model's upward-facing surface down to where its views agree best (module
/// docs). `views` are the views the model was made from (pinhole, images the cameras' size;
/// masks, where given, limit the footprints to foreground pixels).
///
/// Errors: parameters out of their domain ([`TopRefinement::validate`]), fewer views than
/// [`TopRefinement::min_views`], or views the kernels refuse (sizes that differ from their
/// cameras, distorted cameras); the model is then left as it was.
///
/// ```
/// use aibr_scene::{RenderOptions, catalogue};
/// use aibr_voxel::{ColoringParams, TopRefinement, View, VoxelGrid, refine_tops, voxel_coloring};
///
/// let scene = catalogue::lambertian()?;
/// let shots = scene.shoot(&scene.rig.uniform_pans(12), &RenderOptions::default())?;
/// let views: Vec<View<'_>> = shots
///     .iter()
///     .map(|s| View { camera: &s.camera, image: &s.image, mask: Some(&s.frame.mask) })
///     .collect();
/// let grid = VoxelGrid::with_resolution(scene.bounds(), 32)?;
/// let mut model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
/// let stats = refine_tops(&mut model, &views, &TopRefinement::default())?;
/// assert!(stats.judged > 0 && stats.moved <= stats.judged);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn refine_tops(
    model: &mut VoxelModel,
    views: &[View<'_>],
    params: &TopRefinement,
) -> Result<RefineStats> {
    params.validate()?;
    validate_views(views, params.min_views)?;
    let grid = *model.grid();
    let nz = grid.dims()[2];
    let list = VoxelList::occupied(model);
    // Indices into `list` of the tops.
    let tops: Vec<usize> = list
        .voxels
        .iter()
        .enumerate()
        .filter(|&(_, &[i, j, k])| k + 1 == nz || !model.is_occupied([i, j, k + 1]))
        .map(|(n, _)| n)
        .collect();
    let projectors: Vec<Projector> = views
        .iter()
        .map(|v| Projector::new(v.camera, &grid))
        .collect();
    let pixels: Vec<Pixels<'_>> = views.iter().map(Pixels::of).collect();
    // Per view, per top: whether the view sees it.
    let sees: Vec<Vec<bool>> = projectors
        .par_iter()
        .map_init(ZBuffer::default, |z, proj| {
            z.render(&grid, proj, &list);
            tops.iter().map(|&n| z.sees(n)).collect()
        })
        .collect();
    let judged = tops
        .par_iter()
        .enumerate()
        .map_init(Scratch::default, |scratch, (t, &n)| {
            scratch.seeing.clear();
            scratch
                .seeing
                .extend((0..views.len()).filter(|&v| sees[v][t]));
            if scratch.seeing.len() < params.min_views {
                return None;
            }
            let top = list.voxels[n];
            Some(judge(top, &projectors, &pixels, &grid, params, scratch))
        })
        .collect::<Vec<_>>();
    let mut stats = RefineStats {
        tops: tops.len(),
        judged: judged.iter().filter(|j| j.is_some()).count(),
        ..RefineStats::default()
    };
    // Each judged top's depth (0 where it stays), to check moves against their neighbours.
    let depth_of: HashMap<[usize; 3], usize> = tops
        .iter()
        .zip(&judged)
        .filter_map(|(&n, j)| j.map(|m| (list.voxels[n], m.map_or(0, |m| m.depth))))
        .collect();
    let (moves, lone): (Vec<Move>, Vec<Move>) = judged
        .into_iter()
        .flatten()
        .flatten()
        .partition(|m| coherent(m, &depth_of));
    stats.lone = lone.len();
    for m in &moves {
        let [i, j, k] = m.top;
        for t in 0..m.depth {
            model.clear([i, j, k - t]);
        }
        stats.cleared += m.depth;
    }
    for m in &moves {
        let [i, j, k] = m.top;
        model.set([i, j, k - m.depth], m.colour);
    }
    stats.moved = moves.len();
    if params.walls {
        let walls = step_walls(model, &moves);
        stats.walled = walls.len();
        for (cell, colour) in walls {
            model.set(cell, colour);
        }
    }
    Ok(stats)
}

/// The cells that wall the steps the `moves` (already applied to `model`) left: beside each
/// cleared cell, the cell of a 4-neighbouring column that is empty while its column is
/// occupied above it, no higher than a layer over the moved top. That column stands higher
/// than the moved one and is hollow below its surface, and the cleared cell opens the hollow
/// to the outside. Each wall cell takes the colour of the nearest occupied cell above it.
/// Everything is read from `model` before any wall is set, so the walls do not depend on the
/// order of the moves.
fn step_walls(model: &VoxelModel, moves: &[Move]) -> Vec<([usize; 3], [u8; 3])> {
    let [nx, ny, _] = model.grid().dims();
    let mut walls: Vec<([usize; 3], [u8; 3])> = Vec::new();
    for m in moves {
        let [i, j, k] = m.top;
        // The cleared cells: from just above the new place up to the old top.
        for z in k + 1 - m.depth..=k {
            for (di, dj) in [(1isize, 0isize), (-1, 0), (0, 1), (0, -1)] {
                let (Some(a), Some(b)) = (i.checked_add_signed(di), j.checked_add_signed(dj))
                else {
                    continue;
                };
                if a >= nx || b >= ny || model.is_occupied([a, b, z]) {
                    continue;
                }
                let above = (z + 1..=k + 1).find(|&c| model.is_occupied([a, b, c]));
                if let Some(colour) = above.and_then(|c| model.colour_of([a, b, c])) {
                    walls.push(([a, b, z], colour));
                }
            }
        }
    }
    // A cell beside two moves appears twice, with the same colour (the same cell above it).
    walls.sort_unstable_by_key(|&(cell, _)| cell);
    walls.dedup_by_key(|&mut (cell, _)| cell);
    walls
}

/// True when `m`'s depth is within a voxel of the median depth of the judged tops around it
/// (the 8 neighbouring columns' tops within a layer of its own, and itself): the surface it
/// belongs to moves with it. A lone top sinking alone would dig a pit.
fn coherent(m: &Move, depth_of: &HashMap<[usize; 3], usize>) -> bool {
    let [i, j, k] = m.top;
    let mut depths = vec![m.depth];
    for dj in [-1isize, 0, 1] {
        for di in [-1isize, 0, 1] {
            if (di, dj) == (0, 0) {
                continue;
            }
            let (Some(a), Some(b)) = (i.checked_add_signed(di), j.checked_add_signed(dj)) else {
                continue;
            };
            let found = [0isize, -1, 1].into_iter().find_map(|dk| {
                k.checked_add_signed(dk)
                    .and_then(|c| depth_of.get(&[a, b, c]).copied())
            });
            depths.extend(found);
        }
    }
    // The upper median, as the spreads take it.
    let mid = depths.len() / 2;
    depths.select_nth_unstable(mid).1.abs_diff(m.depth) <= 1
}

/// Buffers reused from one top to the next on a thread.
#[derive(Default)]
struct Scratch {
    seeing: Vec<usize>,
    colours: Vec<[f32; 3]>,
    spreads: Spreads,
}

/// The decision for one top seen by the views of `scratch.seeing`: `Some` move when a
/// candidate below it is clearly more consistent, `None` to leave it.
fn judge(
    top: [usize; 3],
    projectors: &[Projector],
    pixels: &[Pixels<'_>],
    grid: &VoxelGrid,
    params: &TopRefinement,
    scratch: &mut Scratch,
) -> Option<Move> {
    let [i, j, k] = top;
    // The views' colours of the voxel `depth` below the top, into `scratch.colours`.
    let colours_at = |depth: usize, scratch: &mut Scratch| {
        let centre = grid.centre([i, j, k - depth]);
        scratch.colours.clear();
        for &n in &scratch.seeing {
            let h = projectors[n].project_point(&centre);
            if let Some(c) = projectors[n]
                .footprint(h)
                .and_then(|fp| mean_colour(&pixels[n], &fp))
            {
                scratch.colours.push(c);
            }
        }
    };
    // Their spread; `None` when fewer than `min_views` views have a foreground pixel there.
    let spread_at = |depth: usize, scratch: &mut Scratch| {
        colours_at(depth, scratch);
        (scratch.colours.len() >= params.min_views)
            .then(|| scratch.spreads.robust(&scratch.colours))
    };
    let own = spread_at(0, scratch)?;
    // No candidate can be `margin` below a spread under it: about half the tops stop here
    // (`docs/voxel.md`, "Refining the tops").
    if own < params.margin {
        return None;
    }
    let mut best: Option<(usize, f32)> = None;
    for depth in 1..=params.max_depth.min(k) {
        if let Some(spread) = spread_at(depth, scratch) {
            if best.is_none_or(|(_, s)| spread < s) {
                best = Some((depth, spread));
            }
        }
    }
    let (depth, spread) = best?;
    if spread > params.ratio * own || own - spread < params.margin {
        return None;
    }
    // The new place's colour, from the colours its spread was taken over.
    colours_at(depth, scratch);
    Some(Move {
        top,
        depth,
        colour: mean_of(&scratch.colours),
    })
}

/// Mean colour of the footprint's pixels (its foreground ones, with a mask); `None` when
/// there are none.
fn mean_colour(px: &Pixels<'_>, fp: &Footprint) -> Option<[f32; 3]> {
    let (sum, n) = px.sum_where(fp, |_| true);
    (n > 0).then(|| sum.map(|s| s as f32 / n as f32))
}

/// The mean of `colours`, rounded to bytes.
fn mean_of(colours: &[[f32; 3]]) -> [u8; 3] {
    let n = colours.len().max(1) as f32;
    [0, 1, 2].map(|c| (colours.iter().map(|x| x[c]).sum::<f32>() / n).round() as u8)
}

/// Buffers for [`Spreads::robust`], reused from one set of colours to the next.
#[derive(Debug, Default)]
pub(crate) struct Spreads {
    /// The squared differences of every pair, `n` by `n`.
    squares: Vec<f32>,
    differences: Vec<f32>,
    per_view: Vec<f32>,
}

impl Spreads {
    /// The robust spread of `colours` (at least two), in grey levels: for each colour the
    /// median of its RMS differences to the others, then the median of those (upper
    /// medians), so that a minority of outliers (a highlight in a few views) does not count.
    /// The medians are taken over squared differences, whose order is the same, and one root
    /// is taken at the end.
    pub(crate) fn robust(&mut self, colours: &[[f32; 3]]) -> f32 {
        let Spreads {
            squares,
            differences,
            per_view,
        } = self;
        let n = colours.len();
        squares.clear();
        squares.resize(n * n, 0.0);
        for a in 0..n {
            for b in a + 1..n {
                let d = squared_difference(&colours[a], &colours[b]);
                squares[a * n + b] = d;
                squares[b * n + a] = d;
            }
        }
        per_view.clear();
        for a in 0..n {
            differences.clear();
            let row = &squares[a * n..(a + 1) * n];
            differences.extend_from_slice(&row[..a]);
            differences.extend_from_slice(&row[a + 1..]);
            per_view.push(upper_median(differences));
        }
        (upper_median(per_view) / 3.0).sqrt()
    }

    /// Whether the robust spread of `colours` is at most `bar` grey levels: the answer of
    /// `self.robust(colours) <= bar` (compared in squares, so up to rounding at the bar
    /// itself), found by counting instead of sorting and given as soon as it is known. A
    /// view's median difference is within the bar when more than half of its differences
    /// are, and the spread when more than half of the views' medians are.
    pub(crate) fn at_most(colours: &[[f32; 3]], bar: f32) -> bool {
        let n = colours.len();
        if n < 2 {
            return bar >= 0.0;
        }
        if !(bar >= 0.0) {
            return false;
        }
        let limit = 3.0 * bar * bar;
        // The upper median of `len` values is within the limit when `len / 2 + 1` are.
        let (need_views, need_pairs) = (n / 2 + 1, (n - 1) / 2 + 1);
        let (mut within, mut beyond) = (0, 0);
        for (a, ca) in colours.iter().enumerate() {
            let (mut near, mut far) = (0, 0);
            for (b, cb) in colours.iter().enumerate() {
                if a == b {
                    continue;
                }
                if squared_difference(ca, cb) <= limit {
                    near += 1;
                    if near == need_pairs {
                        break;
                    }
                } else {
                    far += 1;
                    if far > n - 1 - need_pairs {
                        break;
                    }
                }
            }
            if near == need_pairs {
                within += 1;
                if within == need_views {
                    return true;
                }
            } else {
                beyond += 1;
                if beyond > n - need_views {
                    return false;
                }
            }
        }
        false
    }
}

/// The element at `len / 2` in sorted order (reorders `values`); 0 for none.
fn upper_median(values: &mut [f32]) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spread_ignores_a_minority_of_outliers() {
        let mut spreads = Spreads::default();
        let colours = [[100.0; 3], [102.0; 3], [98.0; 3], [101.0; 3], [250.0; 3]];
        // The views' medians are 2, 4, 4, 3 and 150 (the outlier's); their median is 4.
        assert_eq!(spreads.robust(&colours), 4.0);
        let colours = [[10.0; 3], [100.0; 3], [200.0; 3], [50.0; 3], [150.0; 3]];
        assert!(spreads.robust(&colours) >= 50.0);
    }

    /// The counting test agrees with the spread it stands for, on sets of colours with and
    /// without outliers, at bars on either side of the spread.
    #[test]
    fn counting_agrees_with_the_spread() {
        let mut spreads = Spreads::default();
        let mut rng = crate::test_rng(12345);
        let mut next = || rng() as f32;
        let mut checked = 0;
        for trial in 0..2000 {
            let n = 1 + trial % 40;
            let spread = 1.0 + 60.0 * next();
            let colours: Vec<[f32; 3]> = (0..n)
                .map(|_| {
                    let outlier = next() < 0.3;
                    let scale = if outlier { 200.0 } else { spread };
                    [0, 1, 2].map(|_| 100.0 + scale * (next() - 0.5))
                })
                .collect();
            let exact = spreads.robust(&colours);
            for bar in [
                0.0,
                exact * 0.5,
                exact * 0.99,
                exact * 1.01,
                exact * 2.0,
                300.0,
            ] {
                if (bar - exact).abs() > 1e-3 * exact.max(1.0) || bar == exact {
                    assert_eq!(
                        Spreads::at_most(&colours, bar),
                        exact <= bar,
                        "{colours:?} {bar}"
                    );
                    checked += 1;
                }
            }
        }
        assert!(checked > 10_000, "{checked}");
    }

    #[test]
    fn a_top_moves_only_with_the_tops_around_it() {
        let m = Move {
            top: [5, 5, 20],
            depth: 4,
            colour: [0; 3],
        };
        // Its neighbours' tops: the eight columns around it, at its layer or one off.
        let around = |depth: &dyn Fn(usize) -> usize| -> HashMap<[usize; 3], usize> {
            let mut map = HashMap::new();
            let mut n = 0;
            for j in 4..=6 {
                for i in 4..=6 {
                    if (i, j) != (5, 5) {
                        map.insert([i, j, 19 + n % 3], depth(n));
                        n += 1;
                    }
                }
            }
            map
        };
        assert!(!coherent(&m, &around(&|_| 0)), "a lone top sinking");
        assert!(coherent(&m, &around(&|n| 3 + n % 3)), "a layer sinking 3-5");
        // Five of eight neighbours stay: the median (with its own 4) is 0.
        assert!(!coherent(&m, &around(&|n| if n < 5 { 0 } else { 4 })));
        // Tops two layers off are another surface and do not count: the median is its own.
        let far: HashMap<_, _> = around(&|_| 0)
            .into_keys()
            .map(|[i, j, _]| ([i, j, 23], 0))
            .collect();
        assert!(coherent(&m, &far));
    }

    /// A closed box (its lid at layer 10, standing on the floor) with a 2 x 2 pit sunk four
    /// layers into its lid: the pit's sides open the box's hollow to the outside until the
    /// walls close them.
    #[test]
    fn walls_close_the_hollow_a_sunken_top_opened() {
        use aibr_camera::aabb::Aabb;
        use nalgebra::Point3;
        let bounds = Aabb::new(Point3::origin(), Point3::new(16.0, 16.0, 16.0)).expect("a box");
        let grid = VoxelGrid::new(bounds, 1.0).expect("a grid");
        let mut model = VoxelModel::empty(grid);
        for k in 0..=10 {
            for j in 3..=12 {
                for i in 3..=12 {
                    if i == 3 || i == 12 || j == 3 || j == 12 || k == 10 {
                        model.set([i, j, k], [200, 100, 50]);
                    }
                }
            }
        }
        let moves: Vec<Move> = [[7, 7], [8, 7], [7, 8], [8, 8]]
            .map(|[i, j]| Move {
                top: [i, j, 10],
                depth: 4,
                colour: [9; 3],
            })
            .to_vec();
        for m in &moves {
            let [i, j, k] = m.top;
            model.clear([i, j, k]);
            model.set([i, j, k - m.depth], m.colour);
        }
        let inside = [5, 5, 3];
        assert!(
            !model.filled(0).is_occupied(inside),
            "the pit opens the hollow"
        );
        let walls = step_walls(&model, &moves);
        // Eight cells round the pit, at the three layers between its floor and the lid.
        assert_eq!(walls.len(), 24, "{walls:?}");
        for &([i, j, k], colour) in &walls {
            assert!((7..=9).contains(&k) && (6..=9).contains(&i) && (6..=9).contains(&j));
            assert!(
                !(7..=8).contains(&i) || !(7..=8).contains(&j),
                "not in the pit"
            );
            assert_eq!(colour, [200, 100, 50], "the lid's colour above");
        }
        for (cell, colour) in walls {
            model.set(cell, colour);
        }
        let filled = model.filled(0);
        assert!(filled.is_occupied(inside), "the hollow is closed again");
        assert!(!filled.is_occupied([7, 7, 8]), "the pit stays open");
    }

    #[test]
    fn upper_median_takes_the_middle_or_the_upper_of_two() {
        assert_eq!(upper_median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(upper_median(&mut [4.0, 1.0, 3.0, 2.0]), 3.0);
        assert_eq!(upper_median(&mut []), 0.0);
    }

    #[test]
    fn parameters_out_of_their_domain_are_refused() {
        let bad = [
            TopRefinement {
                ratio: 1.5,
                ..TopRefinement::default()
            },
            TopRefinement {
                ratio: f32::NAN,
                ..TopRefinement::default()
            },
            TopRefinement {
                margin: -1.0,
                ..TopRefinement::default()
            },
            TopRefinement {
                min_views: 1,
                ..TopRefinement::default()
            },
        ];
        for p in bad {
            assert!(
                matches!(p.validate(), Err(Error::InvalidParameter { .. })),
                "{p:?}"
            );
        }
        assert!(TopRefinement::default().validate().is_ok());
    }
}
