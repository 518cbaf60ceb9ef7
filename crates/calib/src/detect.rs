//! Checkerboard detection: saddle points, a grid grown over them, sub-pixel corners.
//!
//! 1. Blur the image and find saddle points of its intensity: maxima of
//!    `Ixy^2 - Ixx Iyy` (minus the Hessian determinant), which is large where four squares
//!    meet and zero on straight edges.
//! 2. Keep the saddles whose surrounding circle alternates dark, light, dark, light with
//!    opposite sides alike (the X of a chessboard corner, not the L of the board's outline or
//!    a texture).
//! 3. From the strongest saddles in turn, grow a grid: each next corner is predicted from
//!    the two before it in its row or column (which follows perspective) and must be the
//!    saddle nearest the prediction.
//! 4. A grid of exactly the board's size is labelled (see [`BoardSpec`] for which corner is
//!    number 0) and refined to sub-pixel accuracy ([`crate::subpix`]).

use std::collections::HashMap;

use aibr_camera::ImageSize;
use image::GrayImage;
use nalgebra::{Point2, Vector2};

use crate::board::BoardSpec;
use crate::error::Rejection;
use crate::plane::Plane;
use crate::subpix::{SubPixParams, refine_corner};

/// Settings of [`detect_board`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorParams {
    /// Standard deviation of the blur before saddle detection, pixels.
    pub blur_sigma: f64,
    /// Radius of the circle that verifies a saddle, pixels (less than half the smallest
    /// square's side in the image).
    pub ring_radius: f64,
    /// Smallest difference between the light and dark squares around a corner, grey levels.
    pub min_contrast: f32,
    /// Saddles weaker than this fraction of the strongest are ignored.
    pub relative_threshold: f32,
    /// How many of the strongest saddles are tried as the start of the grid.
    pub max_seeds: usize,
    /// A corner must lie within this fraction of the local square size of its prediction.
    pub grid_tolerance: f64,
    /// Sub-pixel refinement.
    pub subpix: SubPixParams,
}

impl Default for DetectorParams {
    fn default() -> Self {
        DetectorParams {
            blur_sigma: 1.5,
            ring_radius: 5.0,
            min_contrast: 16.0,
            relative_threshold: 0.01,
            max_seeds: 40,
            grid_tolerance: 0.3,
            subpix: SubPixParams::default(),
        }
    }
}

/// The inner corners of a board found in an image.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardDetection {
    /// The image size.
    pub image_size: ImageSize,
    /// Inner corners, pixels, in the board's order (row by row, see [`BoardSpec`]).
    pub corners: Vec<Point2<f64>>,
}

/// A verified saddle point.
#[derive(Debug, Clone, Copy)]
struct Saddle {
    position: Point2<f64>,
    response: f32,
}

/// Finds the inner corners of `board` in `image`.
pub fn detect_board(
    image: &GrayImage,
    board: &BoardSpec,
    params: &DetectorParams,
) -> Result<BoardDetection, Rejection> {
    let (w, h) = image.dimensions();
    let margin = (params.ring_radius.ceil() as u32 + 2) * 2;
    if w < 4 * margin || h < 4 * margin {
        return Err(Rejection::TooSmall {
            width: w,
            height: h,
        });
    }
    let raw = Plane::from_gray(image);
    let blurred = raw.gaussian_blur(params.blur_sigma);
    let saddles = find_saddles(&blurred, params);
    if saddles.is_empty() {
        return Err(Rejection::NoCorners);
    }
    let index = Buckets::new(&saddles, w as f64, h as f64);
    let mut best: Option<Grid> = None;
    for seed in 0..saddles.len().min(params.max_seeds) {
        let Some(grid) = grow_grid(&saddles, &index, seed, params) else {
            continue;
        };
        if let Some(window) = board_window(&grid, board, &saddles, &blurred) {
            let corners = label(&window, &saddles, board, &blurred);
            let corners = corners
                .into_iter()
                .map(|c| refine_corner(&raw, c, &params.subpix))
                .collect();
            return Ok(BoardDetection {
                image_size: ImageSize::new(w, h),
                corners,
            });
        }
        if best
            .as_ref()
            .is_none_or(|b| grid.cells.len() > b.cells.len())
        {
            best = Some(grid);
        }
    }
    let (found, (grid_cols, grid_rows)) = best
        .map(|b| (b.cells.len(), b.extent()))
        .unwrap_or((1, (1, 1)));
    Err(Rejection::IncompleteGrid {
        expected_cols: board.cols,
        expected_rows: board.rows,
        expected: board.corner_count(),
        found,
        grid_cols,
        grid_rows,
    })
}

/// Saddle points of the blurred image that pass the ring test, strongest first.
fn find_saddles(p: &Plane, params: &DetectorParams) -> Vec<Saddle> {
    let (w, h) = (p.width, p.height);
    let mut response = vec![0.0f32; w * h];
    let mut max_r = 0.0f32;
    for y in 1..h - 1 {
        let (up, row, down) = (
            &p.data[(y - 1) * w..y * w],
            &p.data[y * w..(y + 1) * w],
            &p.data[(y + 1) * w..(y + 2) * w],
        );
        let out = &mut response[y * w..(y + 1) * w];
        for x in 1..w - 1 {
            let ixx = row[x + 1] - 2.0 * row[x] + row[x - 1];
            let iyy = down[x] - 2.0 * row[x] + up[x];
            let ixy = 0.25 * (down[x + 1] - down[x - 1] - up[x + 1] + up[x - 1]);
            let r = ixy * ixy - ixx * iyy;
            out[x] = r;
            max_r = max_r.max(r);
        }
    }
    if !(max_r > 0.0) {
        return Vec::new();
    }
    let threshold = max_r * params.relative_threshold;
    let border = params.ring_radius.ceil() as usize + 2;
    let mut saddles = Vec::new();
    for y in border..h - border {
        for x in border..w - border {
            let r = response[y * w + x];
            if r <= threshold {
                continue;
            }
            // A strict maximum over its 5x5 neighbourhood (ties go to the first in raster order).
            let mut is_max = true;
            'n: for dy in -2isize..=2 {
                for dx in -2isize..=2 {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let o = response[(y as isize + dy) as usize * w + (x as isize + dx) as usize];
                    let before = dy < 0 || (dy == 0 && dx < 0);
                    if o > r || (before && o == r) {
                        is_max = false;
                        break 'n;
                    }
                }
            }
            if !is_max {
                continue;
            }
            // Sub-pixel peak by a parabola through the neighbours each way.
            let at = |dx: isize, dy: isize| {
                response[(y as isize + dy) as usize * w + (x as isize + dx) as usize] as f64
            };
            let offset = |m: f64, c: f64, pl: f64| {
                let d = m - 2.0 * c + pl;
                if d < 0.0 {
                    (0.5 * (m - pl) / d).clamp(-0.5, 0.5)
                } else {
                    0.0
                }
            };
            let position = Point2::new(
                x as f64 + offset(at(-1, 0), at(0, 0), at(1, 0)),
                y as f64 + offset(at(0, -1), at(0, 0), at(0, 1)),
            );
            if is_chessboard_corner(p, position, params) {
                saddles.push(Saddle {
                    position,
                    response: r,
                });
            }
        }
    }
    saddles.sort_by(|a, b| b.response.total_cmp(&a.response));
    saddles
}

/// The ring test: 16 samples on a circle alternate light and dark four times, opposite
/// samples agree, and the contrast is high enough.
fn is_chessboard_corner(p: &Plane, c: Point2<f64>, params: &DetectorParams) -> bool {
    const N: usize = 16;
    let mut v = [0.0f32; N];
    for (k, s) in v.iter_mut().enumerate() {
        let a = k as f64 * std::f64::consts::TAU / N as f64;
        *s = p.bilinear(
            c.x + params.ring_radius * a.cos(),
            c.y + params.ring_radius * a.sin(),
        );
    }
    let (lo, hi) = v
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
    let contrast = hi - lo;
    if !(contrast >= params.min_contrast) {
        return false;
    }
    // ChESS: opposite quadrants alike, adjacent ones different.
    let sum: f32 = (0..N / 4)
        .map(|k| ((v[k] + v[k + N / 2]) - (v[k + N / 4] + v[k + 3 * N / 4])).abs())
        .sum();
    let diff: f32 = (0..N / 2).map(|k| (v[k] - v[k + N / 2]).abs()).sum();
    if !(sum > diff) {
        return false;
    }
    // Exactly four transitions between clearly light and clearly dark samples.
    let mean = v.iter().sum::<f32>() / N as f32;
    let band = 0.15 * contrast;
    let signs: Vec<i8> = v
        .iter()
        .filter_map(|&x| {
            if x > mean + band {
                Some(1)
            } else if x < mean - band {
                Some(-1)
            } else {
                None
            }
        })
        .collect();
    let transitions = (0..signs.len())
        .filter(|&i| signs[i] != signs[(i + 1) % signs.len()])
        .count();
    transitions == 4
}

/// Saddles bucketed on a coarse grid for nearest-neighbour queries.
struct Buckets {
    cols: usize,
    rows: usize,
    items: Vec<Vec<usize>>,
}

impl Buckets {
    const CELL: f64 = 16.0;

    fn new(saddles: &[Saddle], width: f64, height: f64) -> Self {
        let cols = (width / Self::CELL).ceil() as usize + 1;
        let rows = (height / Self::CELL).ceil() as usize + 1;
        let mut items = vec![Vec::new(); cols * rows];
        for (i, s) in saddles.iter().enumerate() {
            let (cx, cy) = Self::cell_of(s.position, cols, rows);
            items[cy * cols + cx].push(i);
        }
        Buckets { cols, rows, items }
    }

    fn cell_of(p: Point2<f64>, cols: usize, rows: usize) -> (usize, usize) {
        let cx = (p.x / Self::CELL).floor().clamp(0.0, (cols - 1) as f64) as usize;
        let cy = (p.y / Self::CELL).floor().clamp(0.0, (rows - 1) as f64) as usize;
        (cx, cy)
    }

    /// Calls `f(index, distance)` for every saddle within `radius` of `p`.
    fn for_each_within(
        &self,
        saddles: &[Saddle],
        p: Point2<f64>,
        radius: f64,
        mut f: impl FnMut(usize, f64),
    ) {
        if !(p.x.is_finite() && p.y.is_finite() && radius.is_finite()) {
            return;
        }
        let reach = (radius / Self::CELL).ceil() as isize;
        let (cx, cy) = Self::cell_of(p, self.cols, self.rows);
        for y in (cy as isize - reach).max(0)..=(cy as isize + reach).min(self.rows as isize - 1) {
            for x in
                (cx as isize - reach).max(0)..=(cx as isize + reach).min(self.cols as isize - 1)
            {
                for &i in &self.items[y as usize * self.cols + x as usize] {
                    let d = (saddles[i].position - p).norm();
                    if d <= radius {
                        f(i, d);
                    }
                }
            }
        }
    }

    /// The saddle nearest `p` within `radius`, if any.
    fn nearest(&self, saddles: &[Saddle], p: Point2<f64>, radius: f64) -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        self.for_each_within(saddles, p, radius, |i, d| {
            if best.is_none_or(|(_, bd)| d < bd) {
                best = Some((i, d));
            }
        });
        best.map(|(i, _)| i)
    }

    /// Up to `k` saddles nearest saddle `own` within `radius`, nearest first, without it.
    fn k_nearest(&self, saddles: &[Saddle], own: usize, radius: f64, k: usize) -> Vec<usize> {
        let mut found = Vec::new();
        self.for_each_within(saddles, saddles[own].position, radius, |i, d| {
            if i != own {
                found.push((i, d));
            }
        });
        found.sort_by(|a, b| a.1.total_cmp(&b.1));
        found.into_iter().take(k).map(|(i, _)| i).collect()
    }
}

/// A cell on a window's outer edge and its inward neighbour.
type EdgeCell = ((i32, i32), (i32, i32));

/// A grid of saddles indexed by integer lattice coordinates.
struct Grid {
    cells: HashMap<(i32, i32), usize>,
}

impl Grid {
    fn bounds(&self) -> (i32, i32, i32, i32) {
        self.cells.keys().fold(
            (i32::MAX, i32::MAX, i32::MIN, i32::MIN),
            |(x0, y0, x1, y1), &(x, y)| (x0.min(x), y0.min(y), x1.max(x), y1.max(y)),
        )
    }

    /// Columns and rows spanned.
    fn extent(&self) -> (usize, usize) {
        let (x0, y0, x1, y1) = self.bounds();
        ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize)
    }
}

/// The window of the board's size (either way round) that the grid fills completely and
/// whose outer squares alternate most clearly on every side. A grid can run past the board
/// where its outline meets a dark frame or background in X-like junctions; the squares
/// beyond those are not a checkerboard's, while those beyond the board's outermost inner
/// corners are.
fn board_window(
    grid: &Grid,
    board: &BoardSpec,
    saddles: &[Saddle],
    blurred: &Plane,
) -> Option<Grid> {
    let (x0, y0, x1, y1) = grid.bounds();
    let shapes = if board.cols == board.rows {
        vec![(board.cols, board.rows)]
    } else {
        vec![(board.cols, board.rows), (board.rows, board.cols)]
    };
    let pos = |x: i32, y: i32| grid.cells.get(&(x, y)).map(|&i| saddles[i].position);
    let mut best: Option<((i32, i32, i32, i32), f32)> = None;
    for (w, h) in shapes {
        let (w, h) = (w as i32, h as i32);
        for wy in y0..=y1 - h + 1 {
            for wx in x0..=x1 - w + 1 {
                let full =
                    (wy..wy + h).all(|y| (wx..wx + w).all(|x| grid.cells.contains_key(&(x, y))));
                if !full {
                    continue;
                }
                // Per side: the outer edge's corners and their inward neighbours.
                let sides: [Vec<EdgeCell>; 4] = [
                    (wx..wx + w).map(|x| ((x, wy), (x, wy + 1))).collect(),
                    (wx..wx + w)
                        .map(|x| ((x, wy + h - 1), (x, wy + h - 2)))
                        .collect(),
                    (wy..wy + h).map(|y| ((wx, y), (wx + 1, y))).collect(),
                    (wy..wy + h)
                        .map(|y| ((wx + w - 1, y), (wx + w - 2, y)))
                        .collect(),
                ];
                let mut score = f32::MAX;
                for side in &sides {
                    let outer: Option<Vec<f32>> = side
                        .windows(2)
                        .map(|pair| {
                            let (e0, i0) = pair[0];
                            let (e1, i1) = pair[1];
                            let mid = nalgebra::center(&pos(e0.0, e0.1)?, &pos(e1.0, e1.1)?);
                            let inner = nalgebra::center(&pos(i0.0, i0.1)?, &pos(i1.0, i1.1)?);
                            Some(mean_around(blurred, mid + (mid - inner) * 0.5, 1))
                        })
                        .collect();
                    let outer = outer.unwrap_or_default();
                    let alternation = outer.windows(2).map(|v| (v[0] - v[1]).abs()).sum::<f32>()
                        / (outer.len().max(2) - 1) as f32;
                    score = score.min(alternation);
                }
                if best.is_none_or(|(_, s)| score > s) {
                    best = Some(((wx, wy, w, h), score));
                }
            }
        }
    }
    let ((wx, wy, w, h), _) = best?;
    Some(Grid {
        cells: grid
            .cells
            .iter()
            .filter(|((x, y), _)| (wx..wx + w).contains(x) && (wy..wy + h).contains(y))
            .map(|(&k, &v)| (k, v))
            .collect(),
    })
}

/// Grows a lattice of saddles from `seed`.
fn grow_grid(
    saddles: &[Saddle],
    index: &Buckets,
    seed: usize,
    params: &DetectorParams,
) -> Option<Grid> {
    // The two lattice directions: neighbours whose opposite neighbour is there too (so the
    // seed is an inner corner), the nearest one and the nearest one not along it.
    let near = index.k_nearest(saddles, seed, 200.0, 8);
    let s = saddles[seed].position;
    let tol = params.grid_tolerance;
    let axes: Vec<Vector2<f64>> = near
        .iter()
        .map(|&i| saddles[i].position - s)
        .filter(|v| {
            index
                .nearest(saddles, s - v, tol * v.norm())
                .is_some_and(|j| j != seed)
        })
        .collect();
    let a = *axes.first()?;
    let b = *axes[1..]
        .iter()
        .find(|v| (a.dot(v) / (a.norm() * v.norm())).abs() < 0.8)?;
    if b.norm() > 2.0 * a.norm() || a.norm() > 2.0 * b.norm() {
        return None;
    }
    let mut grid = Grid {
        cells: HashMap::from([((0, 0), seed)]),
    };
    let mut used = vec![false; saddles.len()];
    used[seed] = true;
    let try_cell = |grid: &mut Grid,
                    used: &mut Vec<bool>,
                    cell: (i32, i32),
                    predicted: Point2<f64>,
                    step: f64| {
        if let Some(i) = index.nearest(saddles, predicted, tol * step) {
            if !used[i] {
                used[i] = true;
                grid.cells.insert(cell, i);
                return true;
            }
        }
        false
    };
    for (cell, v) in [((1, 0), a), ((0, 1), b), ((-1, 0), -a), ((0, -1), -b)] {
        try_cell(&mut grid, &mut used, cell, s + v, v.norm());
    }
    const DIRS: [(i32, i32); 4] = [(1, 0), (-1, 0), (0, 1), (0, -1)];
    // Grow while any frontier cell can be predicted from two corners in line (or a
    // parallelogram) and finds its saddle.
    loop {
        let mut grew = false;
        let snapshot: Vec<(i32, i32)> = grid.cells.keys().copied().collect();
        for (x, y) in snapshot {
            for (dx, dy) in DIRS {
                let cell = (x + dx, y + dy);
                if grid.cells.contains_key(&cell) {
                    continue;
                }
                let Some((predicted, step)) = predict(&grid, saddles, cell, (dx, dy)) else {
                    continue;
                };
                if try_cell(&mut grid, &mut used, cell, predicted, step) {
                    grew = true;
                }
            }
        }
        if !grew {
            break;
        }
        // A grid far larger than any board means the lattice is not a board's.
        if grid.cells.len() > 1_000_000 {
            return None;
        }
    }
    Some(grid)
}

/// The predicted position of `cell`, reached from its neighbour `cell - dir`, and the local
/// square size.
fn predict(
    grid: &Grid,
    saddles: &[Saddle],
    cell: (i32, i32),
    dir: (i32, i32),
) -> Option<(Point2<f64>, f64)> {
    let pos = |c: (i32, i32)| grid.cells.get(&c).map(|&i| saddles[i].position);
    let n = (cell.0 - dir.0, cell.1 - dir.1);
    let pn = pos(n)?;
    // Two in line: extrapolate the step.
    if let Some(pnn) = pos((n.0 - dir.0, n.1 - dir.1)) {
        let step: Vector2<f64> = pn - pnn;
        return Some((pn + step, step.norm()));
    }
    // A parallelogram with a row or column beside.
    for side in [(dir.1, dir.0), (-dir.1, -dir.0)] {
        if let (Some(ps), Some(pt)) = (
            pos((n.0 + side.0, n.1 + side.1)),
            pos((cell.0 + side.0, cell.1 + side.1)),
        ) {
            let step = pt - ps;
            return Some((pn + step, step.norm()));
        }
    }
    None
}

/// The grid's saddles in board order: rows along the board's longer or shorter side as
/// the board says, right-handed, corner 0 at the dark corner square.
fn label(grid: &Grid, saddles: &[Saddle], board: &BoardSpec, blurred: &Plane) -> Vec<Point2<f64>> {
    let (x0, y0, _, _) = grid.bounds();
    let (cols, _) = grid.extent();
    let transpose = cols != board.cols;
    let at = |c: usize, r: usize| -> Point2<f64> {
        let (i, j) = if transpose { (r, c) } else { (c, r) };
        grid.cells
            .get(&(x0 + i as i32, y0 + j as i32))
            .map(|&k| saddles[k].position)
            .unwrap_or(Point2::origin())
    };
    let mut corners: Vec<Point2<f64>> = (0..board.rows)
        .flat_map(|r| (0..board.cols).map(move |c| (c, r)))
        .map(|(c, r)| at(c, r))
        .collect();
    let (nc, nr) = (board.cols, board.rows);
    // Right-handed in the image (x right, y down): the board's x then y turn clockwise.
    let u = corners[1] - corners[0];
    let v = corners[nc] - corners[0];
    if u.x * v.y - u.y * v.x < 0.0 {
        corners = (0..nr)
            .flat_map(|r| (0..nc).map(move |c| (c, nr - 1 - r)))
            .map(|(c, r)| corners[r * nc + c])
            .collect();
    }
    // Corner 0 at the darker of the two corner squares that a half turn swaps.
    if board.is_unambiguous() {
        let outer = |corner: Point2<f64>, inner: Point2<f64>| {
            let centre = corner + (corner - inner) * 0.5;
            mean_around(blurred, centre, 2)
        };
        let first = outer(corners[0], corners[nc + 1]);
        let last = outer(corners[nr * nc - 1], corners[(nr - 1) * nc - 2]);
        if first > last {
            corners.reverse();
        }
    }
    corners
}

fn mean_around(p: &Plane, c: Point2<f64>, r: isize) -> f32 {
    let mut sum = 0.0;
    for dy in -r..=r {
        for dx in -r..=r {
            sum += p.bilinear(c.x + dx as f64, c.y + dy as f64);
        }
    }
    sum / ((2 * r + 1) * (2 * r + 1)) as f32
}
