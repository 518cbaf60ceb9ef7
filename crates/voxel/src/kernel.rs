//! Pieces shared by the voxel kernels: views, projection of voxel footprints, pixel
//! gathering and the consistency criteria.
//!
//! Every kernel (fast or reference) computes a voxel's projection with the same operations
//! in the same order (`row_base + inc * i`, f32), presents the per-view samples in view order,
//! and decides with the same consistency function; so the fast and reference paths agree
//! voxel for voxel.

use aibr_camera::{Angle, Camera};
use image::{GrayImage, RgbImage};
use nalgebra::{Point3, Vector3};

use crate::error::{Error, Result};
use crate::grid::VoxelGrid;

/// One input view: a pinhole camera, its image and optionally its foreground mask.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// The camera (no lens distortion: undistort the image first).
    pub camera: &'a Camera,
    /// The image.
    pub image: &'a RgbImage,
    /// Foreground mask (non-zero = object), same size as the image.
    pub mask: Option<&'a GrayImage>,
}

/// How a voxel's per-view colours are judged consistent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Criterion {
    /// Seitz-Dyer: the standard deviation of the per-view colours (RMS over R, G, B, in
    /// 8-bit grey levels) is at most `threshold`.
    Classic {
        /// Largest standard deviation, grey levels.
        threshold: f32,
    },
    /// The paper's non-Lambertian criterion: rays from one surface point need agree only
    /// where their emission angles are close. Each view's mean RMS colour difference to the
    /// views whose directions from the voxel are within `window` of its own, averaged over
    /// the views weighted by the arc of directions each stands for, is at most `threshold`
    /// (so the test does not depend on how densely the views sample the arc). With no pair
    /// within the window, the mean over all pairs is compared.
    Angular {
        /// Largest mean RMS difference of neighbouring views, grey levels.
        threshold: f32,
        /// Angular neighbourhood.
        window: Angle,
    },
}

impl Criterion {
    /// The classic criterion with its default threshold (25 grey levels).
    pub fn classic() -> Self {
        Criterion::Classic { threshold: 25.0 }
    }

    /// The angular criterion with its defaults (20 grey levels within 30 degrees).
    pub fn angular() -> Self {
        Criterion::Angular {
            threshold: 20.0,
            window: Angle::from_degrees(30.0),
        }
    }
}

impl Default for Criterion {
    /// [`Criterion::angular`], the paper's.
    fn default() -> Self {
        Criterion::angular()
    }
}

/// Checks sizes and distortion of the views.
pub(crate) fn validate_views(views: &[View<'_>], needed: usize) -> Result<()> {
    if views.len() < needed {
        return Err(Error::TooFewViews {
            found: views.len(),
            needed,
        });
    }
    for (i, v) in views.iter().enumerate() {
        let size = v.camera.size;
        if !v.camera.distortion.is_none() {
            return Err(Error::Distorted { view: i });
        }
        let check = |what, w: u32, h: u32| {
            if (w, h) != (size.width, size.height) {
                return Err(Error::ViewSize {
                    view: i,
                    what,
                    width: w,
                    height: h,
                    expected_width: size.width,
                    expected_height: size.height,
                });
            }
            Ok(())
        };
        check("image", v.image.width(), v.image.height())?;
        if let Some(m) = v.mask {
            check("mask", m.width(), m.height())?;
        }
    }
    Ok(())
}

/// Checks the views (at least `needed` of them) and prepares their projectors into `grid`
/// and their raw pixels, in view order: what every kernel starts from.
pub(crate) fn prepare_views<'a>(
    grid: &VoxelGrid,
    views: &[View<'a>],
    needed: usize,
) -> Result<(Vec<Projector>, Vec<Pixels<'a>>)> {
    validate_views(views, needed)?;
    let projectors = views
        .iter()
        .map(|v| Projector::new(v.camera, grid))
        .collect();
    Ok((projectors, views.iter().map(Pixels::of).collect()))
}

/// The pixels `[u0, u1] x [v0, v1]` (inclusive) a voxel covers in one view.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Footprint {
    pub(crate) u0: u32,
    pub(crate) u1: u32,
    pub(crate) v0: u32,
    pub(crate) v1: u32,
}

impl Footprint {
    /// No pixel: the footprint of a voxel behind the camera or off the image, where an
    /// `Option` would cost a branch per voxel.
    pub(crate) const EMPTY: Footprint = Footprint {
        u0: 1,
        u1: 0,
        v0: 1,
        v1: 0,
    };

    /// True for a footprint with no pixel.
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.u0 > self.u1 || self.v0 > self.v1
    }

    /// Its number of pixels.
    #[inline]
    pub(crate) fn area(&self) -> u32 {
        if self.is_empty() {
            0
        } else {
            (self.u1 - self.u0 + 1) * (self.v1 - self.v0 + 1)
        }
    }
}

/// Projection of voxels of one grid into one view.
#[derive(Debug, Clone)]
pub(crate) struct Projector {
    /// `P = K [R | t]`, f64 for row bases.
    p: [[f64; 4]; 3],
    /// `P[:, 0] * voxel_size`: the step of the homogeneous projection along +x.
    inc: [f32; 3],
    /// Half the projected voxel edge at unit depth, pixels.
    half: f32,
    width: i32,
    height: i32,
    /// Camera centre, world.
    pub(crate) centre: Point3<f64>,
}

impl Projector {
    pub(crate) fn new(camera: &Camera, grid: &VoxelGrid) -> Self {
        let m = camera.projection_matrix();
        let mut p = [[0.0; 4]; 3];
        for (r, row) in p.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = m[(r, c)];
            }
        }
        let s = grid.voxel_size();
        let k = camera.intrinsics;
        Projector {
            inc: [
                (p[0][0] * s) as f32,
                (p[1][0] * s) as f32,
                (p[2][0] * s) as f32,
            ],
            half: (0.5 * s * k.fx.max(k.fy)) as f32,
            p,
            width: camera.size.width as i32,
            height: camera.size.height as i32,
            centre: camera.centre(),
        }
    }

    /// Homogeneous projection of a world point.
    #[inline]
    pub(crate) fn project_point(&self, x: &Point3<f64>) -> [f32; 3] {
        let r = |row: &[f64; 4]| (row[0] * x.x + row[1] * x.y + row[2] * x.z + row[3]) as f32;
        [r(&self.p[0]), r(&self.p[1]), r(&self.p[2])]
    }

    /// Homogeneous projection of the centre of voxel `[0, j, k]`.
    #[inline]
    pub(crate) fn row_base(&self, grid: &VoxelGrid, j: usize, k: usize) -> [f32; 3] {
        self.project_point(&grid.centre([0, j, k]))
    }

    /// Homogeneous projection of voxel `i` of a row with base `base`.
    #[inline]
    pub(crate) fn along_row(&self, base: &[f32; 3], i: usize) -> [f32; 3] {
        let f = i as f32;
        [
            base[0] + self.inc[0] * f,
            base[1] + self.inc[1] * f,
            base[2] + self.inc[2] * f,
        ]
    }

    /// The footprint of a voxel whose centre projects to `h`, clipped to the image; `None`
    /// when it is behind the camera or wholly off the image.
    #[inline]
    pub(crate) fn footprint(&self, h: [f32; 3]) -> Option<Footprint> {
        if !(h[2] > 0.0) {
            return None;
        }
        let inv = 1.0 / h[2];
        let (u, v, r) = (h[0] * inv, h[1] * inv, self.half * inv);
        self.clip(round(u - r), round(u + r), round(v - r), round(v + r))
    }

    /// The footprints of voxels `i0, i0 + 1, ...` of a row with base `base`, one per entry of
    /// `out`: the same values as [`Projector::footprint`] of [`Projector::along_row`]
    /// ([`Footprint::EMPTY`] for `None`), eight voxels at a time and without branches so that
    /// the arithmetic vectorises.
    pub(crate) fn footprints_along_row(&self, base: &[f32; 3], i0: usize, out: &mut [Footprint]) {
        let first = i0 as f32;
        for (l, o) in out.iter_mut().enumerate() {
            // `first + l` is exact for any index below 2^24, like `along_row`'s `i as f32`.
            *o = self.footprint_at(base, first + l as f32).0;
        }
    }

    /// The footprint of voxel `i` (given as `i as f32`) of a row with base `base` and the
    /// depth (homogeneous w) of its centre: [`Projector::footprint`] of
    /// [`Projector::along_row`], with [`Footprint::EMPTY`] for `None`, computed without
    /// branches so that loops over voxels vectorise.
    #[inline]
    pub(crate) fn footprint_at(&self, base: &[f32; 3], i: f32) -> (Footprint, f32) {
        let [x, y, z] = [0, 1, 2].map(|a| base[a] + self.inc[a] * i);
        let inv = 1.0 / z;
        let (u, v, r) = (x * inv, y * inv, self.half * inv);
        // Clamped to the image, a footprint wholly off it comes out empty, as `clip` would
        // have it (`u0 <= u1` before clamping).
        let (u0, u1) = (round(u - r).max(0), round(u + r).min(self.width - 1));
        let (v0, v1) = (round(v - r).max(0), round(v + r).min(self.height - 1));
        let empty = !(z > 0.0) || u0 > u1 || v0 > v1;
        let fp = if empty {
            Footprint::EMPTY
        } else {
            Footprint {
                u0: u0 as u32,
                u1: u1 as u32,
                v0: v0 as u32,
                v1: v1 as u32,
            }
        };
        (fp, z)
    }

    #[inline]
    fn clip(&self, u0: i32, u1: i32, v0: i32, v1: i32) -> Option<Footprint> {
        if u1 < 0 || v1 < 0 || u0 >= self.width || v0 >= self.height {
            return None;
        }
        Some(Footprint {
            u0: u0.max(0) as u32,
            u1: u1.min(self.width - 1) as u32,
            v0: v0.max(0) as u32,
            v1: v1.min(self.height - 1) as u32,
        })
    }

    /// A pixel rectangle holding the footprint of every voxel `[i0..i1) x [j0..j1)` of layer
    /// `k` (from its corner centres, widened by a pixel against rounding): `Ok(None)` when
    /// every footprint is off the image, `Err(())` when the bound is unknown (the block
    /// reaches behind the camera).
    pub(crate) fn block_bounds(
        &self,
        grid: &VoxelGrid,
        (i0, i1): (usize, usize),
        (j0, j1): (usize, usize),
        k: usize,
    ) -> Result<Option<Footprint>, ()> {
        let corners = [(i0, j0), (i1 - 1, j0), (i0, j1 - 1), (i1 - 1, j1 - 1)];
        let (mut ulo, mut uhi, mut vlo, mut vhi) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        let mut wmin = f32::MAX;
        for (i, j) in corners {
            let h = self.project_point(&grid.centre([i, j, k]));
            if !(h[2] > 0.0) {
                return Err(());
            }
            let (u, v) = (h[0] / h[2], h[1] / h[2]);
            ulo = ulo.min(u);
            uhi = uhi.max(u);
            vlo = vlo.min(v);
            vhi = vhi.max(v);
            wmin = wmin.min(h[2]);
        }
        // The homogeneous w is affine over the block, so its minimum is at a corner, and the
        // largest footprint radius is the one there.
        let r = self.half / wmin + 1.0;
        Ok(self.clip(
            round(ulo - r),
            round(uhi + r),
            round(vlo - r),
            round(vhi + r),
        ))
    }
}

/// Edge of the square tiles that summarise masks and claims, pixels.
pub(crate) const TILE: u32 = 4;

/// `floor(x + 0.5)`, for `x` held within `[-1024, 2^20]` (NaN goes to -1024): every
/// footprint further off the image is clipped away either way.
///
/// Neither libm's `floorf` (baseline x86-64 has no rounding instruction, and the call was
/// 18% of the kernel's time) nor a float-to-integer cast (its saturation keeps loops over
/// voxels from vectorising; unheld, it overflowed for coordinates beyond 2^31 pixels): adding
/// 2^23 to `t = x + 1024.5` (in `[0, 2^22)`) leaves `t` rounded to the nearest integer in the
/// low mantissa bits, and one comparison turns that into the floor.
#[inline]
fn round(x: f32) -> i32 {
    const SHIFT: f32 = 8_388_608.0; // 2^23
    // Not `clamp`: that keeps NaN.
    #[allow(clippy::manual_clamp)]
    let t = x.max(-1024.0).min(1_048_576.0) + 1024.5;
    let y = t + SHIFT;
    let nearest = y.to_bits() as i32 - SHIFT.to_bits() as i32;
    nearest - i32::from(y - SHIFT > t) - 1024
}

/// Raw pixels of one view, for fast access.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Pixels<'a> {
    pub(crate) rgb: &'a [u8],
    pub(crate) mask: Option<&'a [u8]>,
    pub(crate) width: usize,
}

impl<'a> Pixels<'a> {
    pub(crate) fn of(view: &View<'a>) -> Self {
        Pixels {
            rgb: view.image.as_raw(),
            mask: view.mask.map(|m| m.as_raw().as_slice()),
            width: view.image.width() as usize,
        }
    }

    pub(crate) fn height(&self) -> usize {
        self.rgb.len() / 3 / self.width.max(1)
    }

    /// True when every footprint pixel is background (false without a mask).
    #[inline]
    pub(crate) fn all_background(&self, fp: &Footprint) -> bool {
        let Some(mask) = self.mask else { return false };
        let (u0, u1) = (fp.u0 as usize, fp.u1 as usize + 1);
        (fp.v0 as usize..fp.v1 as usize + 1).all(|v| {
            let row = v * self.width;
            mask[row + u0..row + u1].iter().all(|&m| m == 0)
        })
    }

    /// Sum and count of the footprint pixels not yet claimed (and foreground, with a mask).
    #[inline]
    pub(crate) fn gather(&self, fp: &Footprint, claimed: &[u8]) -> ([u32; 3], u32) {
        self.sum_where(fp, |i| {
            claimed[i] == 0 && self.mask.is_none_or(|m| m[i] != 0)
        })
    }

    /// Sum and count of the footprint pixels (by index) that `open` accepts, in row order.
    #[inline]
    pub(crate) fn sum_where(
        &self,
        fp: &Footprint,
        open: impl Fn(usize) -> bool,
    ) -> ([u32; 3], u32) {
        let mut sum = [0u32; 3];
        let mut n = 0u32;
        for v in fp.v0..=fp.v1 {
            let row = v as usize * self.width;
            for u in fp.u0..=fp.u1 {
                let i = row + u as usize;
                if !open(i) {
                    continue;
                }
                let c = &self.rgb[3 * i..3 * i + 3];
                sum[0] += c[0] as u32;
                sum[1] += c[1] as u32;
                sum[2] += c[2] as u32;
                n += 1;
            }
        }
        (sum, n)
    }
}

/// The fast kernel's per-view state: which pixels a voxel may still gather from, and
/// per-tile summaries of that and of the mask ([`TILE`] x [`TILE`] pixels, small enough to
/// stay in cache) that settle most questions exactly without visiting pixels.
#[derive(Debug, Clone)]
pub(crate) struct Tiles {
    pub(crate) cols: usize,
    /// Per pixel: 0 while it is foreground and unclaimed, 1 once it is claimed or when it is
    /// background. A gather then reads one array instead of the claims and the mask.
    pub(crate) resolved: Vec<u8>,
    /// Per tile: 0 = every pixel background, 2 = every pixel foreground, 1 = mixed (no mask:
    /// all 2).
    pub(crate) mask: Vec<u8>,
    /// Per tile: 1 when every pixel is resolved (so no voxel can gather from the tile any
    /// more).
    pub(crate) full: Vec<u8>,
    /// Tiles claimed into since the last [`Tiles::settle`], to be checked for fullness.
    dirty: Vec<u32>,
    /// Per tile: listed in `dirty`.
    listed: Vec<bool>,
    width: usize,
    height: usize,
}

impl Tiles {
    pub(crate) fn new(px: &Pixels<'_>) -> Self {
        let (w, h) = (px.width, px.height());
        let t = TILE as usize;
        let (cols, rows) = (w.div_ceil(t), h.div_ceil(t));
        let mut mask = vec![2u8; cols * rows];
        let resolved: Vec<u8> = match px.mask {
            Some(m) => m.iter().map(|&b| u8::from(b == 0)).collect(),
            None => vec![0; w * h],
        };
        if px.mask.is_some() {
            for ty in 0..rows {
                for tx in 0..cols {
                    let (mut fg, mut bg) = (false, false);
                    for y in ty * t..((ty + 1) * t).min(h) {
                        for &r in &resolved[y * w + tx * t..y * w + ((tx + 1) * t).min(w)] {
                            if r == 0 {
                                fg = true;
                            } else {
                                bg = true;
                            }
                        }
                    }
                    mask[ty * cols + tx] = match (fg, bg) {
                        (false, _) => 0,
                        (true, false) => 2,
                        (true, true) => 1,
                    };
                }
            }
        }
        let full = mask.iter().map(|&m| u8::from(m == 0)).collect();
        Tiles {
            cols,
            resolved,
            mask,
            full,
            dirty: Vec::new(),
            listed: vec![false; cols * rows],
            width: w,
            height: h,
        }
    }

    #[inline]
    fn range(fp: &Footprint) -> (usize, usize, usize, usize) {
        (
            (fp.u0 / TILE) as usize,
            (fp.u1 / TILE) as usize,
            (fp.v0 / TILE) as usize,
            (fp.v1 / TILE) as usize,
        )
    }

    /// Exact: every footprint pixel is background (false without a mask).
    #[inline]
    pub(crate) fn all_background(&self, px: &Pixels<'_>, fp: &Footprint) -> bool {
        if px.mask.is_none() {
            return false;
        }
        let (tx0, tx1, ty0, ty1) = Self::range(fp);
        let mut mixed = false;
        for ty in ty0..ty1 + 1 {
            let row = ty * self.cols;
            for &m in &self.mask[row + tx0..row + tx1 + 1] {
                match m {
                    2 => return false,
                    1 => mixed = true,
                    _ => {}
                }
            }
        }
        !mixed || px.all_background(fp)
    }

    /// What the mask says of every pixel of `fp`: 0 all background, 2 all foreground,
    /// 1 unknown from the tiles.
    #[inline]
    pub(crate) fn mask_class(&self, fp: &Footprint) -> u8 {
        let (tx0, tx1, ty0, ty1) = Self::range(fp);
        let (mut any_bg, mut any_other) = (false, false);
        let mut all_fg = true;
        for ty in ty0..ty1 + 1 {
            let row = ty * self.cols;
            for &m in &self.mask[row + tx0..row + tx1 + 1] {
                match m {
                    0 => {
                        any_bg = true;
                        all_fg = false;
                    }
                    2 => any_other = true,
                    _ => {
                        all_fg = false;
                        any_other = true;
                    }
                }
            }
        }
        if all_fg {
            2
        } else if any_bg && !any_other {
            0
        } else {
            1
        }
    }

    /// Exact: every footprint pixel is claimed or background (it has nothing to gather).
    #[inline]
    pub(crate) fn all_claimed(&self, fp: &Footprint) -> bool {
        let (tx0, tx1, ty0, ty1) = Self::range(fp);
        (ty0..ty1 + 1).all(|ty| {
            let row = ty * self.cols;
            self.full[row + tx0..row + tx1 + 1].iter().all(|&f| f != 0)
        })
    }

    /// Sum and count of the footprint pixels not yet resolved: the same as
    /// [`Pixels::gather`] with the claims and the mask, from one array.
    #[inline]
    pub(crate) fn gather(&self, px: &Pixels<'_>, fp: &Footprint) -> ([u32; 3], u32) {
        // Without branches: whether a pixel is open is close to random along a claim edge.
        let mut sum = [0u32; 3];
        let mut n = 0u32;
        let (u0, u1) = (fp.u0 as usize, fp.u1 as usize + 1);
        for v in fp.v0 as usize..fp.v1 as usize + 1 {
            let row = v * self.width;
            let resolved = &self.resolved[row + u0..row + u1];
            let rgb = &px.rgb[3 * (row + u0)..3 * (row + u1)];
            for (&r, c) in resolved.iter().zip(rgb.chunks_exact(3)) {
                let open = u32::from(r == 0);
                sum[0] += u32::from(c[0]) * open;
                sum[1] += u32::from(c[1]) * open;
                sum[2] += u32::from(c[2]) * open;
                n += open;
            }
        }
        (sum, n)
    }

    /// Claims the pixels of `fp`; the tile summaries follow at the next [`Tiles::settle`].
    pub(crate) fn claim(&mut self, fp: &Footprint) {
        claim(&mut self.resolved, self.width, fp);
        let (tx0, tx1, ty0, ty1) = Self::range(fp);
        for ty in ty0..ty1 + 1 {
            for t in ty * self.cols + tx0..ty * self.cols + tx1 + 1 {
                if self.full[t] == 0 && !self.listed[t] {
                    self.listed[t] = true;
                    self.dirty.push(t as u32);
                }
            }
        }
    }

    /// Brings the tile summaries up to date with the claims made since the last call.
    pub(crate) fn settle(&mut self) {
        let t = TILE as usize;
        for tile in self.dirty.drain(..) {
            let tile = tile as usize;
            self.listed[tile] = false;
            let (tx, ty) = (tile % self.cols, tile / self.cols);
            let (x0, x1) = (tx * t, ((tx + 1) * t).min(self.width));
            let full = (ty * t..((ty + 1) * t).min(self.height)).all(|y| {
                let row = &self.resolved[y * self.width + x0..y * self.width + x1];
                row.iter().all(|&r| r != 0)
            });
            self.full[tile] = u8::from(full);
        }
    }
}

/// Marks a footprint claimed.
#[inline]
pub(crate) fn claim(claimed: &mut [u8], width: usize, fp: &Footprint) {
    let (u0, u1) = (fp.u0 as usize, fp.u1 as usize + 1);
    for v in fp.v0 as usize..fp.v1 as usize + 1 {
        claimed[v * width + u0..v * width + u1].fill(1);
    }
}

/// One view's observation of a voxel: mean colour of its unclaimed footprint pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Sample {
    pub(crate) view: usize,
    pub(crate) colour: [f32; 3],
}

impl Sample {
    pub(crate) fn new(view: usize, sum: [u32; 3], n: u32) -> Self {
        let inv = 1.0 / n as f32;
        Sample {
            view,
            colour: [
                sum[0] as f32 * inv,
                sum[1] as f32 * inv,
                sum[2] as f32 * inv,
            ],
        }
    }
}

#[inline]
fn rms_difference(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / 3.0).sqrt()
}

/// The colour of a consistent voxel (mean of its samples), or `None` when inconsistent.
/// `samples` are in view order; `centres[v]` is the centre of camera `v`; `x` the voxel.
pub(crate) fn decide(
    samples: &[Sample],
    centres: &[Point3<f64>],
    x: &Point3<f64>,
    criterion: &Criterion,
    scratch: &mut Vec<Emission>,
) -> Option<[u8; 3]> {
    let n = samples.len();
    if n == 0 {
        return None;
    }
    let mut mean = [0f32; 3];
    for s in samples {
        for (m, c) in mean.iter_mut().zip(s.colour) {
            *m += c;
        }
    }
    for m in &mut mean {
        *m /= n as f32;
    }
    let ok = match *criterion {
        Criterion::Classic { threshold } => {
            let mut var = 0f32;
            for s in samples {
                for (c, m) in s.colour.iter().zip(&mean) {
                    let d = c - m;
                    var += d * d;
                }
            }
            (var / (3 * n) as f32).sqrt() <= threshold
        }
        Criterion::Angular { threshold, window } => {
            angular_difference(samples, centres, x, window, scratch) <= threshold
        }
    };
    ok.then(|| mean.map(|m| m.round().clamp(0.0, 255.0) as u8))
}

/// One sample's ray as the angular criterion sees it, with its running comparison.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Emission {
    /// Azimuth of the direction from the voxel to the camera, about the pan axis.
    azimuth: f64,
    /// That direction.
    dir: Vector3<f64>,
    /// The sample.
    sample: usize,
    /// Summed RMS difference to the neighbours within the window, and their number.
    sum: f32,
    count: u32,
}

/// The angular criterion's measure of a voxel: how much its colour changes between views
/// whose directions from it are within `window`, in grey levels.
///
/// Each view's mean difference to its neighbours within the window, weighted by the arc of
/// emission angles the view stands for (half the azimuth gaps to its neighbours, each capped
/// at the window): the measure follows the surface's angular colour change, not how densely
/// the views sample it. (A plain mean over pairs let a cluster of close views, such as an
/// active capture adds, outvote the rest with its many pairs of nearly equal rays, and
/// thickened surfaces seen from elsewhere.) With no pair within the window, the mean over all
/// pairs.
fn angular_difference(
    samples: &[Sample],
    centres: &[Point3<f64>],
    x: &Point3<f64>,
    window: Angle,
    scratch: &mut Vec<Emission>,
) -> f32 {
    let n = samples.len();
    // Sorted by azimuth, neighbours within the window are contiguous (a superset filter:
    // elevation only adds angle).
    scratch.clear();
    for (sample, s) in samples.iter().enumerate() {
        let dir = (centres[s.view] - x).normalize();
        scratch.push(Emission {
            azimuth: dir.y.atan2(dir.x),
            dir,
            sample,
            sum: 0.0,
            count: 0,
        });
    }
    scratch.sort_by(|a, b| {
        a.azimuth
            .total_cmp(&b.azimuth)
            .then(a.sample.cmp(&b.sample))
    });
    let w = window.radians();
    let cos_w = w.cos();
    let gap = |e: &[Emission], a: usize, b: usize| {
        let g = e[b].azimuth - e[a].azimuth;
        if g < 0.0 {
            g + std::f64::consts::TAU
        } else {
            g
        }
    };
    let mut pairs = 0usize;
    for a in 0..n {
        for step in 1..n {
            let b = (a + step) % n;
            if gap(scratch, a, b) > w {
                break;
            }
            if scratch[a].dir.dot(&scratch[b].dir) >= cos_w {
                let d = rms_difference(
                    &samples[scratch[a].sample].colour,
                    &samples[scratch[b].sample].colour,
                );
                for k in [a, b] {
                    scratch[k].sum += d;
                    scratch[k].count += 1;
                }
                pairs += 1;
            }
        }
    }
    if pairs == 0 {
        let mut sum = 0f32;
        for a in 0..n {
            for b in a + 1..n {
                sum += rms_difference(&samples[a].colour, &samples[b].colour);
                pairs += 1;
            }
        }
        return if pairs == 0 { 0.0 } else { sum / pairs as f32 };
    }
    let (mut sum, mut weights) = (0f32, 0f32);
    for a in 0..n {
        let e = &scratch[a];
        if e.count == 0 {
            continue;
        }
        let arc =
            0.5 * (gap(scratch, (a + n - 1) % n, a).min(w) + gap(scratch, a, (a + 1) % n).min(w));
        sum += arc as f32 * e.sum / e.count as f32;
        weights += arc as f32;
    }
    if weights > 0.0 { sum / weights } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_floors_within_the_hold() {
        // The plain formula, in 64 bits so that it cannot overflow.
        let cast = |x: f32| (x + 1024.5) as i64 - 1024;
        let edges: [f32; 9] = [
            -1024.0,
            -1023.5,
            -1.5,
            -0.5,
            -0.499_999_97,
            0.0,
            0.5,
            1.5,
            2.5,
        ];
        let far: [f32; 4] = [639.5, 639.499_94, 1e5 + 0.5, 1_048_575.5];
        for x in edges.into_iter().chain(far) {
            for x in [x, x.next_up(), x.next_down()] {
                assert_eq!(i64::from(round(x)), cast(x), "{x}");
            }
        }
        // Outside the hold: off any image of fewer than 2^20 pixels a side, on its side.
        for x in [-1e12, -1e4, -1025.0, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(round(x), -1024, "{x}");
        }
        for x in [2e6, 1e12, f32::INFINITY] {
            assert_eq!(round(x), 1 << 20, "{x}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(24))]

        /// The row-at-a-time footprints (the fast kernel's) equal the one-voxel ones (the
        /// reference's) everywhere, also for voxels behind the camera or off the image: the
        /// camera may stand inside the grid, outside it, or close enough to blow footprints
        /// up to thousands of pixels.
        #[test]
        fn footprints_along_a_row_equal_one_at_a_time(
            radius in 0.05f64..3.0,
            height in -1.0f64..3.0,
            target in -0.5f64..1.5,
            pan in 0.0f64..360.0,
            focal in 20.0f64..2000.0,
        ) {
            let grid = VoxelGrid::with_resolution(
                aibr_camera::Aabb {
                    min: Point3::new(-0.5, -0.5, 0.0),
                    max: Point3::new(0.5, 0.5, 1.0),
                },
                19,
            )
            .map_err(|e| proptest::test_runner::TestCaseError::fail(e.to_string()))?;
            let fail = |e: aibr_camera::Error| proptest::test_runner::TestCaseError::fail(e.to_string());
            let ring = aibr_camera::CircularMotion::ring(radius, height, target).map_err(fail)?;
            let camera = Camera::new(
                aibr_camera::Intrinsics::new(focal, focal, 79.5, 59.5),
                aibr_camera::Distortion::NONE,
                ring.cam_from_world(Angle::from_degrees(pan)),
                aibr_camera::ImageSize::new(160, 120),
            )
            .map_err(fail)?;
            let p = Projector::new(&camera, &grid);
            let [nx, ny, nz] = grid.dims();
            let mut row = vec![Footprint::EMPTY; nx - 3];
            let (mut empty, mut seen) = (0, 0);
            for k in 0..nz {
                for j in 0..ny {
                    let base = p.row_base(&grid, j, k);
                    p.footprints_along_row(&base, 3, &mut row);
                    for (i, fast) in (3..nx).zip(&row) {
                        let h = p.along_row(&base, i);
                        let one = p.footprint(h).unwrap_or(Footprint::EMPTY);
                        proptest::prop_assert_eq!(*fast, one, "voxel {:?}", [i, j, k]);
                        let (at, w) = p.footprint_at(&base, i as f32);
                        proptest::prop_assert_eq!(at, one);
                        proptest::prop_assert_eq!(w.to_bits(), h[2].to_bits());
                        if fast.is_empty() { empty += 1 } else { seen += 1 }
                    }
                }
            }
            proptest::prop_assert!(empty + seen == (nx - 3) * ny * nz);
        }
    }

    #[test]
    fn angular_measure_does_not_depend_on_view_density() {
        // A voxel whose colour changes 10 grey levels per 10 degrees of emission angle, seen
        // from a ring every 10 degrees over 0-180; then with 20 more views crowded into
        // 40-60 degrees, which see nearly the same colour. The measure is about the surface,
        // so it must not drop because of the crowd.
        let ring = |degrees: &[f64]| -> (Vec<Point3<f64>>, Vec<Sample>) {
            let centres = degrees
                .iter()
                .map(|d| {
                    let a = d.to_radians();
                    Point3::new(a.cos(), a.sin(), 0.5)
                })
                .collect();
            let samples = degrees
                .iter()
                .enumerate()
                .map(|(view, d)| Sample {
                    view,
                    colour: [100.0, 80.0, 60.0].map(|c| c + *d as f32),
                })
                .collect();
            (centres, samples)
        };
        let uniform: Vec<f64> = (0..=18).map(|i| 10.0 * f64::from(i)).collect();
        let mut crowded = uniform.clone();
        crowded.extend((0..20).map(|i| 40.5 + f64::from(i)));
        let window = Angle::from_degrees(35.0);
        let x = Point3::origin();
        let mut scratch = Vec::new();
        let (c, s) = ring(&uniform);
        let sparse = angular_difference(&s, &c, &x, window, &mut scratch);
        let (c, s) = ring(&crowded);
        let dense = angular_difference(&s, &c, &x, window, &mut scratch);
        // Neighbours 10, 20 and 30 degrees apart differ by 10, 20 and 30 levels: 20 on
        // average for a view with three on each side (less near the ends).
        assert!((sparse - 20.0).abs() < 1.0, "uniform ring: {sparse}");
        // The crowd's nearer neighbours differ less, but it stands for only 20 degrees (a
        // plain mean over pairs gives 12.5).
        assert!(
            dense > 0.9 * sparse,
            "crowded ring: {dense} against {sparse}"
        );
    }

    #[test]
    fn angular_tolerates_far_disagreement() {
        // Eight cameras on a ring; colours drift smoothly with the angle (a glossy point).
        let centres: Vec<Point3<f64>> = (0..8)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 8.0;
                Point3::new(a.cos(), a.sin(), 0.5)
            })
            .collect();
        let samples: Vec<Sample> = (0..8)
            .map(|i| Sample {
                view: i,
                colour: [100.0 + 12.0 * i as f32, 80.0, 60.0],
            })
            .collect();
        let x = Point3::origin();
        let mut scratch = Vec::new();
        let angular = Criterion::Angular {
            threshold: 15.0,
            window: Angle::from_degrees(50.0),
        };
        assert!(decide(&samples, &centres, &x, &angular, &mut scratch).is_some());
        let classic = Criterion::Classic { threshold: 15.0 };
        assert!(decide(&samples, &centres, &x, &classic, &mut scratch).is_none());
        // Neighbours that disagree fail the angular test too.
        let noisy: Vec<Sample> = (0..8)
            .map(|i| Sample {
                view: i,
                colour: [if i % 2 == 0 { 30.0 } else { 200.0 }, 80.0, 60.0],
            })
            .collect();
        assert!(decide(&noisy, &centres, &x, &angular, &mut scratch).is_none());
    }
}
