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
    /// views within `window` of its own (both in azimuth about the pan axis, the grid
    /// frame's z, and in direction from the voxel), averaged over the views weighted by the
    /// arc of directions each stands for, is at most `threshold` (so the test does not
    /// depend on how densely the views sample the arc). With no pair within the window, the
    /// mean over all pairs is compared.
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

/// A [`Criterion`] ready to judge voxels: the angular window's cosine is worked out once per
/// run, not once a voxel (the cosine was some 1% of the fast kernel's time at 128^3,
/// `docs/voxel.md`, "Session 74").
#[derive(Debug, Clone, Copy)]
pub(crate) enum Consistency {
    /// [`Criterion::Classic`].
    Classic { threshold: f32 },
    /// [`Criterion::Angular`].
    Angular { threshold: f32, window: Window },
}

impl From<&Criterion> for Consistency {
    fn from(criterion: &Criterion) -> Self {
        match *criterion {
            Criterion::Classic { threshold } => Consistency::Classic { threshold },
            Criterion::Angular { threshold, window } => Consistency::Angular {
                threshold,
                window: Window::of(window),
            },
        }
    }
}

/// The angular criterion's window: the angle within which two views are neighbours, and its
/// cosine.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Window {
    radians: f64,
    cos: f64,
}

impl Window {
    fn of(window: Angle) -> Self {
        let radians = window.radians();
        Window {
            radians,
            cos: radians.cos(),
        }
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
    /// The last column and row of the image, `width - 1` and `height - 1`, as floats (at
    /// most [`HOLD`]).
    last_u: f32,
    last_v: f32,
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
            // Within `round`'s hold, as `round(x).min(width - 1)` was for any width.
            last_u: (camera.size.width as f32 - 1.0).min(HOLD),
            last_v: (camera.size.height as f32 - 1.0).min(HOLD),
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
        self.along_row_at(base, i as f32)
    }

    /// [`Projector::along_row`] with the index given as `i as f32` (exact below 2^24), as the
    /// loops over a row count it.
    #[inline]
    fn along_row_at(&self, base: &[f32; 3], i: f32) -> [f32; 3] {
        [0, 1, 2].map(|a| base[a] + self.inc[a] * i)
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
        along_row_by_eight(i0, out, |i| self.footprint_at(base, i).0);
    }

    /// The sampled footprints of voxels `i0, i0 + 1, ...` of a row with base `base`, one per
    /// entry of `out`: [`Projector::inset`] by `inset` pixels of [`Projector::along_row`]
    /// ([`Footprint::EMPTY`] for `None`), without branches, as
    /// [`Projector::footprints_along_row`] computes the footprints.
    pub(crate) fn inset_footprints_along_row(
        &self,
        base: &[f32; 3],
        i0: usize,
        inset: f32,
        out: &mut [Footprint],
    ) {
        along_row_by_eight(i0, out, |i| {
            let [x, y, z] = self.along_row_at(base, i);
            self.inset_footprint_of(x, y, z, inset)
        });
    }

    /// The pixels a voxel whose centre projects to `h` is sampled at, `inset` pixels inside
    /// its [`Projector::footprint`] on each side: with `r` half the voxel's projected edge,
    /// those whose centres lie within `r + 1/2 - inset` of the centre's projection in both
    /// directions (the footprint's reach is `r + 1/2`: every pixel the projected square
    /// touches), and at least the pixel of the centre. Inset 0 is the footprint itself, 1/2
    /// the pixels whose centres lie inside the projected square, 1 the pixels wholly inside
    /// it. `None` when the centre is behind the camera or its sampled pixels are off the
    /// image.
    #[inline]
    pub(crate) fn inset(&self, h: [f32; 3], inset: f32) -> Option<Footprint> {
        let fp = self.inset_footprint_of(h[0], h[1], h[2], inset);
        (!fp.is_empty()).then_some(fp)
    }

    /// [`Projector::inset`] with [`Footprint::EMPTY`] for `None`, without branches.
    #[inline]
    fn inset_footprint_of(&self, x: f32, y: f32, z: f32, inset: f32) -> Footprint {
        let inv = 1.0 / z;
        // The half-edge less the inset, never below 0 (the centre's own pixel); `max` also
        // turns a NaN radius (z = 0) into 0, and `rect` then finds the footprint empty.
        let r = (self.half * inv - inset).max(0.0);
        self.rect(x * inv, y * inv, r, z)
    }

    /// The pixels whose centres lie within `r + 1/2` of `(u, v)` in both directions,
    /// clamped to the image, or [`Footprint::EMPTY`] (also for a centre behind the camera).
    #[inline]
    fn rect(&self, u: f32, v: f32, r: f32, z: f32) -> Footprint {
        // Clamped to the image, a footprint wholly off it comes out empty, as `clip` would
        // have it (`u0 <= u1` before clamping).
        // `round(x).max(0)` is `round_within(x, 0, HOLD)` and `round(x).min(last)` is
        // `round_within(x, -HOLD_BELOW, last)`, the clamps done in floats, where baseline
        // x86-64 has vector minimum and maximum instructions (not for 32-bit integers).
        let (u0, u1) = (
            round_within(u - r, 0.0, HOLD),
            round_within(u + r, -HOLD_BELOW, self.last_u),
        );
        let (v0, v1) = (
            round_within(v - r, 0.0, HOLD),
            round_within(v + r, -HOLD_BELOW, self.last_v),
        );
        let empty = !(z > 0.0) || u0 > u1 || v0 > v1;
        if empty {
            Footprint::EMPTY
        } else {
            Footprint {
                u0: u0 as u32,
                u1: u1 as u32,
                v0: v0 as u32,
                v1: v1 as u32,
            }
        }
    }

    /// The footprint of voxel `i` (given as `i as f32`) of a row with base `base` and the
    /// depth (homogeneous w) of its centre: [`Projector::footprint`] of
    /// [`Projector::along_row`], with [`Footprint::EMPTY`] for `None`, computed without
    /// branches so that loops over voxels vectorise.
    #[inline]
    pub(crate) fn footprint_at(&self, base: &[f32; 3], i: f32) -> (Footprint, f32) {
        let [x, y, z] = self.along_row_at(base, i);
        (self.footprint_of(x, y, z), z)
    }

    /// The footprint of a voxel whose centre projects to the homogeneous point `(x, y, z)`:
    /// [`Projector::footprint`] with [`Footprint::EMPTY`] for `None`, without branches.
    #[inline]
    pub(crate) fn footprint_of(&self, x: f32, y: f32, z: f32) -> Footprint {
        let inv = 1.0 / z;
        self.rect(x * inv, y * inv, self.half * inv, z)
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

    /// A pixel rectangle holding the footprint of every voxel `i0..i1` of two rows of a
    /// layer and of the rows between them, given the rows' bases (from the voxels' corner
    /// centres, projected as the footprints are, widened by a pixel against rounding):
    /// `Ok(None)` when every footprint is off the image, `Err(())` when the bound is unknown
    /// (the block reaches behind the camera).
    ///
    /// Why the corners bound the block: over a rectangle of a plane, `u = x / w` and
    /// `v = y / w` are ratios of affine functions with `w > 0`, whose extremes lie at
    /// vertices, and `w` is smallest, so the footprint radius largest, at one too.
    pub(crate) fn block_bounds(
        &self,
        first_row: &[f32; 3],
        last_row: &[f32; 3],
        (i0, i1): (usize, usize),
    ) -> Result<Option<Footprint>, ()> {
        self.corners_bound(&[
            (first_row, i0),
            (first_row, i1 - 1),
            (last_row, i0),
            (last_row, i1 - 1),
        ])
    }

    /// [`Projector::block_bounds`] of a box of voxels over several layers, given the first
    /// and last row bases of its top and bottom layers: over a box, as over a rectangle, the
    /// extremes lie at its corners.
    pub(crate) fn brick_bounds(
        &self,
        top: (&[f32; 3], &[f32; 3]),
        bottom: (&[f32; 3], &[f32; 3]),
        (i0, i1): (usize, usize),
    ) -> Result<Option<Footprint>, ()> {
        self.corners_bound(&[
            (top.0, i0),
            (top.0, i1 - 1),
            (top.1, i0),
            (top.1, i1 - 1),
            (bottom.0, i0),
            (bottom.0, i1 - 1),
            (bottom.1, i0),
            (bottom.1, i1 - 1),
        ])
    }

    /// The pixel rectangle holding the footprints of the voxels `(row base, i)` and of every
    /// voxel of the box they are the corners of.
    fn corners_bound(&self, corners: &[(&[f32; 3], usize)]) -> Result<Option<Footprint>, ()> {
        let (mut ulo, mut uhi, mut vlo, mut vhi) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        let mut wmin = f32::MAX;
        for &(base, i) in corners {
            let h = self.along_row(base, i);
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
        let r = self.half / wmin + 1.0;
        Ok(self.clip(
            round(ulo - r),
            round(uhi + r),
            round(vlo - r),
            round(vhi + r),
        ))
    }

    /// Whether `fp` reaches the image's edge (where a clipped footprint or bound ends).
    #[inline]
    pub(crate) fn touches_edge(&self, fp: &Footprint) -> bool {
        fp.u0 == 0
            || fp.v0 == 0
            || fp.u1 as i32 >= self.width - 1
            || fp.v1 as i32 >= self.height - 1
    }
}

/// Fills `out[l]` with `footprint(i0 + l)` (the index as `f32`, exact below 2^24 as
/// [`Projector::along_row`]'s `i as f32`), eight at a time: a count known when compiling
/// unrolls into vector operations without a remainder loop, and a block's row is eight
/// voxels. (One loop over `out` cost some 3% more of the kernel's time at 128^3, session
/// 27 in `docs/voxel.md`.)
#[inline(always)]
fn along_row_by_eight(i0: usize, out: &mut [Footprint], footprint: impl Fn(f32) -> Footprint) {
    let mut chunks = out.chunks_exact_mut(8);
    let mut first = i0 as f32;
    for chunk in &mut chunks {
        for (l, o) in chunk.iter_mut().enumerate() {
            *o = footprint(first + l as f32);
        }
        first += 8.0;
    }
    for (l, o) in chunks.into_remainder().iter_mut().enumerate() {
        *o = footprint(first + l as f32);
    }
}

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
    round_within(x, -HOLD_BELOW, HOLD)
}

/// The hold of [`round`]: `x` is taken within `[-HOLD_BELOW, HOLD]`.
const HOLD_BELOW: f32 = 1024.0;
const HOLD: f32 = 1_048_576.0; // 2^20

/// [`round`] of `x` held within `[lo, hi]` (NaN goes to `lo`), for integers `lo` and `hi`
/// within [`round`]'s own hold: `floor(x + 0.5)` clamped to `[lo, hi]`, since rounding to
/// the nearest integer keeps order and leaves integers as they are.
#[inline]
fn round_within(x: f32, lo: f32, hi: f32) -> i32 {
    const SHIFT: f32 = 8_388_608.0; // 2^23
    // Not `clamp`: that keeps NaN.
    #[allow(clippy::manual_clamp)]
    let t = x.max(lo).min(hi) + (HOLD_BELOW + 0.5);
    let y = t + SHIFT;
    let nearest = y.to_bits() as i32 - SHIFT.to_bits() as i32;
    nearest - i32::from(y - SHIFT > t) - HOLD_BELOW as i32
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
        self.sum_where(fp, |i| claimed[i] == 0)
    }

    /// Sum and count of the footprint pixels `i` (row-major index) where `take(i)` holds and
    /// that are foreground, with a mask.
    #[inline]
    pub(crate) fn sum_where(
        &self,
        fp: &Footprint,
        take: impl Fn(usize) -> bool,
    ) -> ([u32; 3], u32) {
        let open = |i: usize| take(i) && self.mask.is_none_or(|m| m[i] != 0);
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

/// One bit per pixel of an image, in rows of 64-pixel words (bit `i` of word `w` is pixel
/// `64 w + i`): small enough that every view's stays in cache, and a footprint's row is
/// tested or set a word at a time.
#[derive(Debug, Clone)]
pub(crate) struct PixelBits {
    words: usize,
    bits: Vec<u64>,
}

impl PixelBits {
    /// The bits of a `width` x `height` image, none set.
    pub(crate) fn none_set(width: usize, height: usize) -> Self {
        let words = width.div_ceil(64);
        PixelBits {
            words,
            bits: vec![0; words * height],
        }
    }

    /// The bits of a `width` x `height` image, set where `values` (row-major, one per
    /// pixel) is zero; pixels beyond the end of `values` stay unset.
    pub(crate) fn zeros_of(width: usize, height: usize, values: &[u8]) -> Self {
        let mut out = Self::none_set(width, height);
        if width == 0 {
            return out;
        }
        for (row, words) in values
            .chunks_exact(width)
            .zip(out.bits.chunks_exact_mut(out.words))
        {
            for (word, pixels) in words.iter_mut().zip(row.chunks(64)) {
                let eights = pixels.chunks_exact(8);
                let tail = eights.remainder();
                let mut w = 0u64;
                for (e, bytes) in eights.enumerate() {
                    let mut b = [0u8; 8];
                    b.copy_from_slice(bytes);
                    w |= zero_bytes(u64::from_le_bytes(b)) << (8 * e);
                }
                let done = pixels.len() - tail.len();
                for (i, &p) in tail.iter().enumerate() {
                    w |= u64::from(p == 0) << (done + i);
                }
                *word = w;
            }
        }
        out
    }

    /// Word `w` of row `v`.
    #[inline]
    fn word(&self, v: u32, w: usize) -> u64 {
        self.bits[v as usize * self.words + w]
    }

    #[inline]
    fn row(&self, v: u32) -> &[u64] {
        let at = v as usize * self.words;
        &self.bits[at..at + self.words]
    }

    /// True when `test(word, mask)` holds for every word of every row of `fp` (its pixels
    /// in the word given by the mask); true for an empty footprint.
    ///
    /// The one-word path (nearly every footprint at 128^3) is inlined where the kernel asks
    /// and the rest called: inlining both was 2% slower (session 16) and calling both 2%
    /// slower than this (session 30, `docs/voxel.md`).
    #[inline(always)]
    fn every(&self, fp: &Footprint, test: impl Fn(u64, u64) -> bool) -> bool {
        if fp.is_empty() {
            return true;
        }
        let span = Span::of(fp);
        if let Some(m) = span.single() {
            return (fp.v0..=fp.v1).all(|v| test(self.word(v, span.w0), m));
        }
        self.every_spanning(fp, &span, test)
    }

    /// [`PixelBits::every`] for a footprint whose rows span more than one word.
    #[inline(never)]
    fn every_spanning(&self, fp: &Footprint, span: &Span, test: impl Fn(u64, u64) -> bool) -> bool {
        (fp.v0..=fp.v1).all(|v| span.words(self.row(v)).all(|(w, m)| test(w, m)))
    }

    /// True when every pixel of `fp` is set (also for an empty footprint).
    #[inline]
    pub(crate) fn all(&self, fp: &Footprint) -> bool {
        self.every(fp, |w, m| w & m == m)
    }

    /// True when no pixel of `fp` is set.
    #[inline]
    pub(crate) fn none(&self, fp: &Footprint) -> bool {
        self.every(fp, |w, m| w & m == 0)
    }

    /// Sets every pixel of `fp`.
    #[inline]
    pub(crate) fn set(&mut self, fp: &Footprint) {
        if fp.is_empty() {
            return;
        }
        let span = Span::of(fp);
        for v in fp.v0..=fp.v1 {
            let at = v as usize * self.words;
            for w in span.w0..=span.w1 {
                self.bits[at + w] |= span.mask(w);
            }
        }
    }
}

/// Bit `i` set where byte `i` (little-endian) of `x` is zero.
#[inline]
fn zero_bytes(x: u64) -> u64 {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    // 0x80 in each zero byte and nowhere else (the low seven bits cannot carry across bytes).
    let high = !(((x & LOW7) + LOW7) | x | LOW7);
    // The eight high bits gathered into the top byte, byte 0's lowest.
    ((high >> 7).wrapping_mul(0x0102_0408_1020_4080)) >> 56
}

/// The widest footprint, in pixels, that [`ViewBits::gather`] reads without a branch per
/// pixel (`ViewBits::gather_narrow`): at 128^3 nearly every footprint is 3 or 4 wide.
const NARROW: usize = 4;

/// The words of a row that hold a footprint's pixels `u0..=u1`, and the masks of those
/// pixels in the first and the last (the words between are whole).
#[derive(Debug, Clone, Copy)]
struct Span {
    w0: usize,
    w1: usize,
    first: u64,
    last: u64,
}

impl Span {
    #[inline]
    fn of(fp: &Footprint) -> Self {
        Span {
            w0: (fp.u0 / 64) as usize,
            w1: (fp.u1 / 64) as usize,
            first: u64::MAX << (fp.u0 % 64),
            last: u64::MAX >> (63 - fp.u1 % 64),
        }
    }

    /// The mask of the footprint's pixels when they lie within one word a row, as most do
    /// (a test then reads one word a row).
    #[inline]
    fn single(&self) -> Option<u64> {
        (self.w0 == self.w1).then_some(self.first & self.last)
    }

    /// The mask of the footprint's pixels in word `w` (from `w0` to `w1`).
    #[inline]
    fn mask(&self, w: usize) -> u64 {
        let mut m = u64::MAX;
        if w == self.w0 {
            m &= self.first;
        }
        if w == self.w1 {
            m &= self.last;
        }
        m
    }

    /// The span's words of `row` with their masks.
    #[inline]
    fn words<'r>(&self, row: &'r [u64]) -> impl Iterator<Item = (u64, u64)> + use<'r> {
        let span = *self;
        row[span.w0..=span.w1]
            .iter()
            .enumerate()
            .map(move |(i, &w)| (w, span.mask(span.w0 + i)))
    }
}

/// What masks say of every voxel of a box (a block or a brick): by one view, or by all.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Silhouette {
    /// Rejected: background under the whole bound, which lies on the image.
    Outside,
    /// Not rejected: foreground under the whole bound, or no mask.
    Inside,
    /// Neither: ask voxel by voxel.
    Mixed,
}

/// The fast kernel's per-view state: which pixels are background and which a voxel may no
/// longer gather from, a bit per pixel.
#[derive(Debug, Clone)]
pub(crate) struct ViewBits {
    /// Set where the mask is background; `None` without a mask.
    background: Option<PixelBits>,
    /// Set once a pixel is resolved: claimed by a kept voxel, or background. A gather then
    /// reads one bit instead of the claims and the mask.
    resolved: PixelBits,
}

impl ViewBits {
    pub(crate) fn new(px: &Pixels<'_>) -> Self {
        let (w, h) = (px.width, px.height());
        let background = px.mask.map(|m| PixelBits::zeros_of(w, h, m));
        let resolved = background
            .clone()
            .unwrap_or_else(|| PixelBits::none_set(w, h));
        ViewBits {
            background,
            resolved,
        }
    }

    /// What the mask says of every pixel of `fp`: 0 all background, 2 all foreground (or no
    /// mask), 1 some of each.
    #[inline]
    pub(crate) fn mask_class(&self, fp: &Footprint) -> u8 {
        match &self.background {
            None => 2,
            Some(bg) if bg.none(fp) => 2,
            Some(bg) if bg.all(fp) => 0,
            Some(_) => 1,
        }
    }

    /// Every pixel of `fp` is background (false without a mask).
    #[inline]
    pub(crate) fn all_background(&self, fp: &Footprint) -> bool {
        self.background.as_ref().is_some_and(|bg| bg.all(fp))
    }

    /// Whether this view rejects the voxel whose footprint is `fp` (the silhouette
    /// constraint): the footprint is on the image and all background there.
    #[inline]
    pub(crate) fn rejects(&self, fp: &Footprint) -> bool {
        !fp.is_empty() && self.all_background(fp)
    }

    /// What this view's mask says of every voxel whose footprint lies within `bound`, a
    /// bound [`Projector::block_bounds`] or [`Projector::brick_bounds`] gave for `projector`.
    /// A bound cut by the image's edge may hold voxels whose footprints are wholly off the
    /// image, which the view does not reject: such a bound is never
    /// [`Silhouette::Outside`].
    #[inline]
    pub(crate) fn silhouette(&self, projector: &Projector, bound: &Footprint) -> Silhouette {
        match self.mask_class(bound) {
            2 => Silhouette::Inside,
            0 if !projector.touches_edge(bound) => Silhouette::Outside,
            _ => Silhouette::Mixed,
        }
    }

    /// Every pixel of `fp` is claimed or background: it has nothing to gather.
    #[inline]
    pub(crate) fn all_resolved(&self, fp: &Footprint) -> bool {
        self.resolved.all(fp)
    }

    /// Sum and count of the pixels of `fp` not yet resolved: the same as [`Pixels::gather`]
    /// with the claims and the mask.
    #[inline]
    pub(crate) fn gather(&self, px: &Pixels<'_>, fp: &Footprint) -> ([u32; 3], u32) {
        let mut sum = [0u32; 3];
        let mut n = 0u32;
        if fp.is_empty() {
            return (sum, n);
        }
        let mut add = |i: usize| {
            let c = &px.rgb[3 * i..3 * i + 3];
            sum[0] += u32::from(c[0]);
            sum[1] += u32::from(c[1]);
            sum[2] += u32::from(c[2]);
        };
        let span = Span::of(fp);
        // Counted pixel by pixel: baseline x86-64 has no population count instruction, and
        // `count_ones` of every word cost some 3% of the kernel's time at 128^3.
        let mut add_word = |first: usize, mut open: u64| {
            while open != 0 {
                add(first + open.trailing_zeros() as usize);
                n += 1;
                open &= open - 1;
            }
        };
        if let Some(m) = span.single() {
            if let Some(found) = self.gather_narrow(px, fp, span.w0, m) {
                return found;
            }
            for v in fp.v0..=fp.v1 {
                let w = self.resolved.word(v, span.w0);
                add_word(v as usize * px.width + 64 * span.w0, !w & m);
            }
            return (sum, n);
        }
        for v in fp.v0..=fp.v1 {
            let base = v as usize * px.width + 64 * span.w0;
            for (i, (w, m)) in span.words(self.resolved.row(v)).enumerate() {
                add_word(base + 64 * i, !w & m);
            }
        }
        (sum, n)
    }

    /// [`ViewBits::gather`] for a footprint at most [`NARROW`] pixels wide whose rows lie in
    /// word `w0` of their rows (`m`, the footprint's mask there), as nearly all do at 128^3:
    /// each row's [`NARROW`] pixels from `u0` are loaded at once and weighed by their open
    /// bits (0 or 1), without a branch on the bits, so that the loads of a footprint are issued
    /// together where a mispredicted branch of the bit loop would throw the later ones away.
    /// The same integer sums as the bit loop. `None` when the footprint is wider, or a row's
    /// pixels would run past the image's last byte.
    #[inline]
    fn gather_narrow(
        &self,
        px: &Pixels<'_>,
        fp: &Footprint,
        w0: usize,
        m: u64,
    ) -> Option<([u32; 3], u32)> {
        if (fp.u1 - fp.u0) as usize >= NARROW {
            return None;
        }
        let shift = fp.u0 % 64;
        let mut sum = [0u32; 3];
        let mut n = 0u32;
        for v in fp.v0..=fp.v1 {
            // Bit k: pixel u0 + k is open (none past u1: `m` holds only the footprint's bits).
            let open = (!self.resolved.word(v, w0) & m) >> shift;
            let start = 3 * (v as usize * px.width + fp.u0 as usize);
            let row: &[u8; 3 * NARROW] = px.rgb.get(start..start + 3 * NARROW)?.try_into().ok()?;
            for k in 0..NARROW {
                let b = ((open >> k) & 1) as u32;
                sum[0] += b * u32::from(row[3 * k]);
                sum[1] += b * u32::from(row[3 * k + 1]);
                sum[2] += b * u32::from(row[3 * k + 2]);
                n += b;
            }
        }
        Some((sum, n))
    }

    /// Claims the pixels of `fp`.
    #[inline]
    pub(crate) fn claim(&mut self, fp: &Footprint) {
        self.resolved.set(fp);
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

/// The RMS difference of two colours over R, G and B, in grey levels.
#[inline]
fn rms_difference(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    (squared_difference(a, b) / 3.0).sqrt()
}

/// The squared difference of two colours summed over R, G and B.
#[inline]
pub(crate) fn squared_difference(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// The colour of a consistent voxel (mean of its samples), or `None` when inconsistent.
/// `samples` are in view order; `centres[v]` is the centre of camera `v`; `x` the voxel.
/// `azimuths[v]` caches [`azimuth`] of view `v` seen from `x`'s column (NaN until first
/// needed): it does not depend on the voxel's height, so one column's serve every layer.
pub(crate) fn decide(
    samples: &[Sample],
    centres: &[Point3<f64>],
    x: &Point3<f64>,
    criterion: &Consistency,
    scratch: &mut Vec<Emission>,
    azimuths: &mut [f64],
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
        Consistency::Classic { threshold } => {
            let mut var = 0f32;
            for s in samples {
                for (c, m) in s.colour.iter().zip(&mean) {
                    let d = c - m;
                    var += d * d;
                }
            }
            (var / (3 * n) as f32).sqrt() <= threshold
        }
        Consistency::Angular { threshold, window } => {
            angular_difference(samples, centres, x, window, scratch, azimuths) <= threshold
        }
    };
    ok.then(|| mean.map(|m| m.round().clamp(0.0, 255.0) as u8))
}

/// [`decide`] by one criterion for voxels taken one at a time (the reference and space
/// carving), with no column's azimuths to reuse, and its buffers.
#[derive(Debug)]
pub(crate) struct Judge {
    criterion: Consistency,
    emissions: Vec<Emission>,
    azimuths: Vec<f64>,
}

impl Judge {
    /// A judge by `criterion`.
    pub(crate) fn new(criterion: Consistency) -> Self {
        Judge {
            criterion,
            emissions: Vec::new(),
            azimuths: Vec::new(),
        }
    }

    /// [`decide`] of a voxel at `x` with these samples.
    pub(crate) fn decide(
        &mut self,
        samples: &[Sample],
        centres: &[Point3<f64>],
        x: &Point3<f64>,
    ) -> Option<[u8; 3]> {
        self.azimuths.clear();
        self.azimuths.resize(centres.len(), f64::NAN);
        decide(
            samples,
            centres,
            x,
            &self.criterion,
            &mut self.emissions,
            &mut self.azimuths,
        )
    }
}

/// The azimuth about the pan axis of the direction from `x` to `centre`, radians in
/// `[-pi, pi]`: a function of `x`'s column alone.
#[inline]
pub(crate) fn azimuth(centre: &Point3<f64>, x: &Point3<f64>) -> f64 {
    (centre.y - x.y).atan2(centre.x - x.x)
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
/// within `window` of each other (in azimuth and in direction from it), in grey levels.
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
    window: Window,
    scratch: &mut Vec<Emission>,
    azimuths: &mut [f64],
) -> f32 {
    let n = samples.len();
    // A neighbour is within the window both in azimuth about the pan axis and in direction.
    // Sorted by azimuth, the views within the window in azimuth are contiguous. For views
    // at one elevation `e` the azimuth is the stricter test (directions `d` apart in
    // azimuth are `acos(cos^2 e cos d + sin^2 e) < d` apart), so the direction test drops
    // only pairs whose elevations differ much.
    scratch.clear();
    for (sample, s) in samples.iter().enumerate() {
        let centre = &centres[s.view];
        let azimuth = &mut azimuths[s.view];
        if azimuth.is_nan() {
            *azimuth = self::azimuth(centre, x);
        }
        scratch.push(Emission {
            azimuth: *azimuth,
            dir: (centre - x).normalize(),
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
    let (w, cos_w) = (window.radians, window.cos);
    let gap = |e: &[Emission], a: usize, b: usize| {
        let g = e[b].azimuth - e[a].azimuth;
        if g < 0.0 {
            g + std::f64::consts::TAU
        } else {
            g
        }
    };
    // `(a + step) % n` without a division per pair (`a + step < 2 n`).
    let wrap = |i: usize| if i >= n { i - n } else { i };
    let mut pairs = 0usize;
    for a in 0..n {
        for step in 1..n {
            let b = wrap(a + step);
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
            0.5 * (gap(scratch, wrap(a + n - 1), a).min(w) + gap(scratch, a, wrap(a + 1)).min(w));
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
        // Held within a narrower range, the rounding is the clamped rounding.
        let everywhere = edges.into_iter().chain(far).chain([
            -1e12,
            -1025.0,
            638.5,
            640.0,
            2e6,
            f32::INFINITY,
            f32::NAN,
        ]);
        for x in everywhere {
            for x in [x, x.next_up(), x.next_down()] {
                assert_eq!(round_within(x, 0.0, HOLD), round(x).max(0), "{x}");
                assert_eq!(
                    round_within(x, -HOLD_BELOW, 639.0),
                    round(x).min(639),
                    "{x}"
                );
            }
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
            let (grid, p) = ring_projector(radius, height, target, pan, focal)?;
            let [nx, ny, nz] = grid.dims();
            let mut row = vec![Footprint::EMPTY; nx - FIRST];
            let (mut empty, mut seen) = (0, 0);
            for k in 0..nz {
                for j in 0..ny {
                    let base = p.row_base(&grid, j, k);
                    p.footprints_along_row(&base, FIRST, &mut row);
                    for (i, fast) in (FIRST..nx).zip(&row) {
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
            proptest::prop_assert!(empty + seen == (nx - FIRST) * ny * nz);
        }

        /// The sampled footprints: the row-at-a-time ones equal the one-voxel ones, inset 0
        /// is the footprint itself, and any inset lies inside the footprint and holds the
        /// pixel of the voxel's centre whenever that pixel is on the image.
        #[test]
        fn sampled_footprints_lie_inside_and_hold_the_centre(
            radius in 0.05f64..3.0,
            height in -1.0f64..3.0,
            target in -0.5f64..1.5,
            pan in 0.0f64..360.0,
            focal in 20.0f64..2000.0,
            inset in 0.0f32..8.0,
        ) {
            let (grid, p) = ring_projector(radius, height, target, pan, focal)?;
            let [nx, ny, nz] = grid.dims();
            let mut claimed = vec![Footprint::EMPTY; nx - FIRST];
            let mut sampled = vec![Footprint::EMPTY; nx - FIRST];
            for k in 0..nz {
                for j in 0..ny {
                    let base = p.row_base(&grid, j, k);
                    p.footprints_along_row(&base, FIRST, &mut claimed);
                    p.inset_footprints_along_row(&base, FIRST, inset, &mut sampled);
                    for ((i, c), s) in (FIRST..nx).zip(&claimed).zip(&sampled) {
                        let h = p.along_row(&base, i);
                        let voxel = [i, j, k];
                        let one = p.footprint(h).unwrap_or(Footprint::EMPTY);
                        proptest::prop_assert_eq!(*c, one, "voxel {:?}", voxel);
                        let inner = p.inset(h, inset).unwrap_or(Footprint::EMPTY);
                        proptest::prop_assert_eq!(*s, inner, "voxel {:?}", voxel);
                        proptest::prop_assert_eq!(
                            p.inset(h, 0.0).unwrap_or(Footprint::EMPTY), one
                        );
                        if s.is_empty() {
                            // Empty only where the centre is behind the camera or its pixel
                            // off the image.
                            let (u, v) = (round(h[0] / h[2]), round(h[1] / h[2]));
                            proptest::prop_assert!(
                                !(h[2] > 0.0)
                                    || !(0..p.width).contains(&u)
                                    || !(0..p.height).contains(&v),
                                "voxel {:?}", voxel
                            );
                            continue;
                        }
                        proptest::prop_assert!(
                            c.u0 <= s.u0 && s.u1 <= c.u1 && c.v0 <= s.v0 && s.v1 <= c.v1,
                            "voxel {:?}: {:?} outside {:?}", voxel, s, c
                        );
                    }
                }
            }
        }

        /// A block's bound holds the footprint of every voxel of the block, in every layer,
        /// whatever the camera: the fast kernel settles a whole block from it.
        #[test]
        fn block_bounds_hold_every_footprint_of_the_block(
            radius in 0.05f64..3.0,
            height in -1.0f64..3.0,
            target in -0.5f64..1.5,
            pan in 0.0f64..360.0,
            focal in 20.0f64..2000.0,
            (bi, bj) in (1usize..=8, 1usize..=8),
            (oi, oj) in (0.0f64..1.0, 0.0f64..1.0),
        ) {
            let (grid, p) = ring_projector(radius, height, target, pan, focal)?;
            let [nx, ny, nz] = grid.dims();
            let i0 = ((nx - bi) as f64 * oi) as usize;
            let j0 = ((ny - bj) as f64 * oj) as usize;
            let (i1, j1) = (i0 + bi, j0 + bj);
            for k in 0..nz {
                let bound = p.block_bounds(
                    &p.row_base(&grid, j0, k),
                    &p.row_base(&grid, j1 - 1, k),
                    (i0, i1),
                );
                let Ok(bound) = bound else { continue };
                bound_holds(&grid, &p, bound, [(i0, i1), (j0, j1), (k, k + 1)])?;
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(200))]
        #[test]
        fn brick_bounds_hold_every_footprint_of_the_brick(
            radius in 0.05f64..3.0,
            height in -1.0f64..3.0,
            target in -0.5f64..1.5,
            pan in 0.0f64..360.0,
            focal in 20.0f64..2000.0,
            (bi, bj, bk) in (1usize..=8, 1usize..=8, 1usize..=8),
            (oi, oj, ok) in (0.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0),
        ) {
            let (grid, p) = ring_projector(radius, height, target, pan, focal)?;
            let [nx, ny, nz] = grid.dims();
            let i0 = ((nx - bi) as f64 * oi) as usize;
            let j0 = ((ny - bj) as f64 * oj) as usize;
            let k0 = ((nz - bk) as f64 * ok) as usize;
            let (i1, j1, k1) = (i0 + bi, j0 + bj, k0 + bk);
            let base = |j: usize, k: usize| p.row_base(&grid, j, k);
            let bound = p.brick_bounds(
                (&base(j0, k1 - 1), &base(j1 - 1, k1 - 1)),
                (&base(j0, k0), &base(j1 - 1, k0)),
                (i0, i1),
            );
            let Ok(bound) = bound else { return Ok(()) };
            bound_holds(&grid, &p, bound, [(i0, i1), (j0, j1), (k0, k1)])?;
        }
    }

    /// Every footprint of the voxels `i.0..i.1` x `j.0..j.1` x `k.0..k.1` lies within
    /// `bound` (and a voxel with a footprint has a bound).
    fn bound_holds(
        grid: &VoxelGrid,
        p: &Projector,
        bound: Option<Footprint>,
        [(i0, i1), (j0, j1), (k0, k1)]: [(usize, usize); 3],
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        for k in k0..k1 {
            for j in j0..j1 {
                let base = p.row_base(grid, j, k);
                for i in i0..i1 {
                    let Some(fp) = p.footprint(p.along_row(&base, i)) else {
                        continue;
                    };
                    let inside = bound.is_some_and(|b| {
                        b.u0 <= fp.u0 && fp.u1 <= b.u1 && b.v0 <= fp.v0 && fp.v1 <= b.v1
                    });
                    proptest::prop_assert!(
                        inside,
                        "voxel {:?}: {:?} outside {:?}",
                        [i, j, k],
                        fp,
                        bound
                    );
                }
            }
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(32))]

        /// The visibility pass's z-buffer, which lowers short footprint rows as padded runs
        /// of fixed length, says a voxel is seen exactly when a plain z-buffer over the whole
        /// image (every pixel of every footprint, nearest centre first, ties to the lower
        /// index) gives it at least a quarter of its footprint. Footprints from one pixel to
        /// the whole image, cameras inside the grid and out.
        #[test]
        fn zbuffer_sees_what_a_plain_zbuffer_sees(
            radius in 0.05f64..3.0,
            height in -1.0f64..3.0,
            target in -0.5f64..1.5,
            pan in 0.0f64..360.0,
            focal in 20.0f64..2000.0,
            // A third of the 19^3 grid's voxels, scattered.
            occupied in proptest::collection::vec(
                proptest::bool::weighted(1.0 / 3.0),
                19 * 19 * 19,
            ),
        ) {
            use crate::coloring::{VoxelList, ZBuffer};
            use crate::grid::VoxelModel;

            let (grid, p) = ring_projector(radius, height, target, pan, focal)?;
            let mut model = VoxelModel::empty(grid);
            let [nx, ny, nz] = grid.dims();
            proptest::prop_assert_eq!(occupied.len(), nx * ny * nz);
            for (n, _) in occupied.iter().enumerate().filter(|(_, o)| **o) {
                model.set([n % nx, n / nx % ny, n / (nx * ny)], [0; 3]);
            }
            let list = VoxelList::occupied(&model);
            let mut z = ZBuffer::default();
            z.render(&grid, &p, &list);
            // The plain z-buffer, from one-voxel footprints.
            let (w, h) = (160usize, 120usize);
            let mut nearest = vec![u64::MAX; w * h];
            let footprints: Vec<Footprint> = list
                .voxels
                .iter()
                .enumerate()
                .map(|(n, &[i, j, k])| {
                    let c = p.along_row(&p.row_base(&grid, j, k), i);
                    let fp = p.footprint(c).unwrap_or(Footprint::EMPTY);
                    if !fp.is_empty() {
                        let key = (u64::from(c[2].to_bits()) << 32) | n as u64;
                        for v in fp.v0..=fp.v1 {
                            for u in fp.u0..=fp.u1 {
                                let at = v as usize * w + u as usize;
                                nearest[at] = nearest[at].min(key);
                            }
                        }
                    }
                    fp
                })
                .collect();
            let mut wins = vec![0u32; footprints.len()];
            for &key in nearest.iter().filter(|&&key| key != u64::MAX) {
                wins[(key & u64::from(u32::MAX)) as usize] += 1;
            }
            for (n, (fp, &won)) in footprints.iter().zip(&wins).enumerate() {
                let expected = !fp.is_empty() && 4 * won >= fp.area();
                proptest::prop_assert_eq!(z.sees(n), expected, "voxel {:?}", list.voxels[n]);
            }
        }
    }

    /// The first voxel of the rows the row-at-a-time tests project: 19 - 5 = 14 voxels, one
    /// run of eight and six more.
    const FIRST: usize = 5;

    /// A 19^3 grid over a 1 m box and a 160x120 camera on a ring about it, as the
    /// projection proptests draw them; the camera may stand inside the grid.
    fn ring_projector(
        radius: f64,
        height: f64,
        target: f64,
        pan: f64,
        focal: f64,
    ) -> Result<(VoxelGrid, Projector), proptest::test_runner::TestCaseError> {
        let fail = |e: String| proptest::test_runner::TestCaseError::fail(e);
        let grid = VoxelGrid::with_resolution(
            aibr_camera::Aabb {
                min: Point3::new(-0.5, -0.5, 0.0),
                max: Point3::new(0.5, 0.5, 1.0),
            },
            19,
        )
        .map_err(|e| fail(e.to_string()))?;
        let ring = aibr_camera::CircularMotion::ring(radius, height, target)
            .map_err(|e| fail(e.to_string()))?;
        let camera = Camera::new(
            aibr_camera::Intrinsics::new(focal, focal, 79.5, 59.5),
            aibr_camera::Distortion::NONE,
            ring.cam_from_world(Angle::from_degrees(pan)),
            aibr_camera::ImageSize::new(160, 120),
        )
        .map_err(|e| fail(e.to_string()))?;
        let p = Projector::new(&camera, &grid);
        Ok((grid, p))
    }

    /// A footprint inside a `width` x `height` image from four numbers in `[0, 1)`.
    fn footprint_in(width: u32, height: u32, f: [f64; 4]) -> Footprint {
        let at = |x: f64, n: u32| ((x * f64::from(n)) as u32).min(n - 1);
        let (a, b) = (at(f[0], width), at(f[1], width));
        let (c, d) = (at(f[2], height), at(f[3], height));
        Footprint {
            u0: a.min(b),
            u1: a.max(b),
            v0: c.min(d),
            v1: c.max(d),
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

        /// The fast kernel's bits answer every question as the per-pixel claims and mask
        /// do, for images of one word a row or several, footprints within a word or across
        /// words, with a mask or without; and footprints at most 4 pixels wide anywhere, up to
        /// the image's last pixel, which `ViewBits::gather` reads without a branch per pixel
        /// when their rows' pixels lie within the image's bytes.
        #[test]
        fn view_bits_agree_with_pixels_and_claims(
            width in 1u32..200,
            height in 1u32..40,
            seed in 0u64..u64::MAX,
            with_mask in proptest::bool::ANY,
            claims in proptest::collection::vec(proptest::array::uniform4(0.0f64..1.0), 0..12),
            queries in proptest::collection::vec(proptest::array::uniform4(0.0f64..1.0), 1..24),
            narrow in proptest::collection::vec(
                (0.0f64..1.0, 0.0f64..1.0, 0u32..4, 0u32..5), 1..24),
        ) {
            let mut state = seed | 1;
            let mut next = move || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                state
            };
            let image = RgbImage::from_fn(width, height, |_, _| {
                let r = next();
                image::Rgb([r as u8, (r >> 8) as u8, (r >> 16) as u8])
            });
            // Background in runs, so that footprints meet wholly background pixels too.
            let mask = GrayImage::from_fn(width, height, |x, y| {
                image::Luma([if (x / 7 + y / 5 + (seed as u32 % 3)) % 3 == 0 { 0 } else { 255 }])
            });
            let px = Pixels {
                rgb: image.as_raw(),
                mask: with_mask.then_some(mask.as_raw().as_slice()),
                width: width as usize,
            };
            let mut bits = ViewBits::new(&px);
            let mut claimed = vec![0u8; (width * height) as usize];
            for f in claims {
                let fp = footprint_in(width, height, f);
                bits.claim(&fp);
                claim(&mut claimed, width as usize, &fp);
            }
            let narrow = narrow.into_iter().map(|(x, y, w, h)| {
                let fp = footprint_in(width, height, [x, x, y, y]);
                Footprint { u1: (fp.u0 + w).min(width - 1), v1: (fp.v0 + h).min(height - 1), ..fp }
            });
            for fp in queries.into_iter().map(|f| footprint_in(width, height, f)).chain(narrow) {
                let (sum, n) = px.gather(&fp, &claimed);
                proptest::prop_assert_eq!(bits.gather(&px, &fp), (sum, n));
                proptest::prop_assert_eq!(bits.all_resolved(&fp), n == 0);
                proptest::prop_assert_eq!(bits.all_background(&fp), px.all_background(&fp));
                let background = px.mask.map_or(0, |m| {
                    (fp.v0..=fp.v1)
                        .flat_map(|v| (fp.u0..=fp.u1).map(move |u| (v * width + u) as usize))
                        .filter(|&i| m[i] == 0)
                        .count()
                });
                let expected = match background {
                    0 => 2,
                    b if b as u32 == fp.area() => 0,
                    _ => 1,
                };
                proptest::prop_assert_eq!(bits.mask_class(&fp), expected);
            }
        }
    }

    proptest::proptest! {
        /// A mask's bits are set exactly at its zero pixels, for any byte values (the
        /// word-at-a-time test must not take a byte whose low bits carry for zero), and
        /// pixels past the row's end stay unset.
        #[test]
        fn zeros_of_sets_exactly_the_zero_pixels(
            width in 1usize..200,
            height in 1usize..6,
            values in proptest::collection::vec(
                proptest::prop_oneof![
                    proptest::strategy::Just(0u8),
                    proptest::strategy::Just(1u8),
                    proptest::strategy::Just(0x7f_u8),
                    proptest::strategy::Just(0x80_u8),
                    proptest::num::u8::ANY,
                ],
                1200,
            ),
        ) {
            let values = &values[..width * height];
            let bits = PixelBits::zeros_of(width, height, values);
            for y in 0..height {
                for x in 0..bits.words * 64 {
                    let set = bits.bits[y * bits.words + x / 64] >> (x % 64) & 1 == 1;
                    let zero = x < width && values[y * width + x] == 0;
                    proptest::prop_assert_eq!(set, zero, "pixel ({}, {})", x, y);
                }
            }
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
        let window = Window::of(Angle::from_degrees(35.0));
        let x = Point3::origin();
        let mut scratch = Vec::new();
        let (c, s) = ring(&uniform);
        let sparse = angular_difference(&s, &c, &x, window, &mut scratch, &mut [f64::NAN; 64]);
        let (c, s) = ring(&crowded);
        let dense = angular_difference(&s, &c, &x, window, &mut scratch, &mut [f64::NAN; 64]);
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
        let mut angular = Judge::new(Consistency::from(&Criterion::Angular {
            threshold: 15.0,
            window: Angle::from_degrees(50.0),
        }));
        assert!(angular.decide(&samples, &centres, &x).is_some());
        let mut classic = Judge::new(Consistency::from(&Criterion::Classic { threshold: 15.0 }));
        assert!(classic.decide(&samples, &centres, &x).is_none());
        // Neighbours that disagree fail the angular test too.
        let noisy: Vec<Sample> = (0..8)
            .map(|i| Sample {
                view: i,
                colour: [if i % 2 == 0 { 30.0 } else { 200.0 }, 80.0, 60.0],
            })
            .collect();
        assert!(angular.decide(&noisy, &centres, &x).is_none());
    }
}
