//! Undistortion of whole images by a precomputed bilinear remap.

use image::{ImageBuffer, Pixel, Primitive};
use nalgebra::Point2;
use num_traits::NumCast;

use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::intrinsics::{ImageSize, Intrinsics};

/// A remap from a distorted camera image to a pinhole image, built once per camera and reused
/// for every frame.
///
/// For every output pixel it stores the index of the top-left of the four source pixels and
/// the two bilinear weights, so applying it is one gather per pixel with no trigonometry and
/// no allocation (with [`UndistortMap::apply_into`]).
#[derive(Debug, Clone)]
pub struct UndistortMap {
    source: ImageSize,
    target: ImageSize,
    target_intrinsics: Intrinsics,
    /// Per output pixel: source index of the top-left neighbour, or `u32::MAX` when the
    /// source point falls off the image.
    index: Vec<u32>,
    /// Per output pixel: bilinear weights toward x+1 and y+1.
    weight: Vec<[f32; 2]>,
}

impl UndistortMap {
    /// A map that shows what `camera` sees as a pinhole camera with the same intrinsics and
    /// image size.
    pub fn new(camera: &Camera) -> Self {
        Self::with_target(camera, camera.intrinsics, camera.size)
    }

    /// A map to a pinhole camera with `target` intrinsics and `size` (for example to keep
    /// only the valid centre of a strongly distorted image).
    pub fn with_target(camera: &Camera, target: Intrinsics, size: ImageSize) -> Self {
        let n = size.pixel_count();
        let mut index = Vec::with_capacity(n);
        let mut weight = Vec::with_capacity(n);
        let (sw, sh) = (camera.size.width as f64, camera.size.height as f64);
        for v in 0..size.height {
            for u in 0..size.width {
                let normal = target.normalized_from_pixel(Point2::new(u as f64, v as f64));
                let src = camera
                    .intrinsics
                    .pixel_from_normalized(camera.distortion.distort(normal));
                // Accept points within half a pixel of the outer pixel centres; clamp so the
                // 2x2 neighbourhood stays on the image.
                if src.x >= -0.5 && src.y >= -0.5 && src.x <= sw - 0.5 && src.y <= sh - 0.5 {
                    let x = src.x.clamp(0.0, sw - 1.0);
                    let y = src.y.clamp(0.0, sh - 1.0);
                    let x0 = (x.floor() as u32).min(camera.size.width.saturating_sub(2));
                    let y0 = (y.floor() as u32).min(camera.size.height.saturating_sub(2));
                    index.push(y0 * camera.size.width + x0);
                    weight.push([(x - x0 as f64) as f32, (y - y0 as f64) as f32]);
                } else {
                    index.push(u32::MAX);
                    weight.push([0.0, 0.0]);
                }
            }
        }
        UndistortMap {
            source: camera.size,
            target: size,
            target_intrinsics: target,
            index,
            weight,
        }
    }

    /// Size of the images the map reads.
    pub fn source_size(&self) -> ImageSize {
        self.source
    }

    /// Size of the images the map writes.
    pub fn target_size(&self) -> ImageSize {
        self.target
    }

    /// Intrinsics of the pinhole images the map writes.
    pub fn target_intrinsics(&self) -> Intrinsics {
        self.target_intrinsics
    }

    /// The source pixel that output pixel `(u, v)` samples, or `None` when it falls off the
    /// source image (or `(u, v)` is off the target).
    pub fn source_of(&self, u: u32, v: u32) -> Option<Point2<f32>> {
        if u >= self.target.width || v >= self.target.height {
            return None;
        }
        let i = v as usize * self.target.width as usize + u as usize;
        let idx = self.index[i];
        if idx == u32::MAX {
            return None;
        }
        let [wx, wy] = self.weight[i];
        let (x0, y0) = (idx % self.source.width, idx / self.source.width);
        Some(Point2::new(x0 as f32 + wx, y0 as f32 + wy))
    }

    /// Undistorts `src` into a new image. Pixels that see past the source image are zero.
    pub fn apply<P>(
        &self,
        src: &ImageBuffer<P, Vec<P::Subpixel>>,
    ) -> Result<ImageBuffer<P, Vec<P::Subpixel>>>
    where
        P: Pixel,
    {
        let mut dst = ImageBuffer::new(self.target.width, self.target.height);
        self.apply_into(src, &mut dst)?;
        Ok(dst)
    }

    /// Undistorts `src` into `dst`, which must have the target size.
    pub fn apply_into<P>(
        &self,
        src: &ImageBuffer<P, Vec<P::Subpixel>>,
        dst: &mut ImageBuffer<P, Vec<P::Subpixel>>,
    ) -> Result<()>
    where
        P: Pixel,
    {
        check_size(self.source, src.width(), src.height())?;
        check_size(self.target, dst.width(), dst.height())?;
        let channels = P::CHANNEL_COUNT as usize;
        let width = self.source.width as usize;
        // Single-column or single-row sources have no x+1 / y+1 neighbour.
        let dx = if width > 1 { channels } else { 0 };
        let dy = if self.source.height > 1 {
            width * channels
        } else {
            0
        };
        let s: &[P::Subpixel] = src.as_raw();
        let zero = <P::Subpixel as Primitive>::DEFAULT_MIN_VALUE;
        let max = <P::Subpixel as Primitive>::DEFAULT_MAX_VALUE;
        let max_f: f32 = NumCast::from(max).unwrap_or(f32::MAX);
        let is_int = max_f < f32::MAX && max_f.fract() == 0.0 && max_f > 1.0;
        let out: &mut [P::Subpixel] = dst.as_mut();
        for ((o, &idx), &[wx, wy]) in out
            .chunks_exact_mut(channels)
            .zip(&self.index)
            .zip(&self.weight)
        {
            if idx == u32::MAX {
                o.fill(zero);
                continue;
            }
            let base = idx as usize * channels;
            for (c, o) in o.iter_mut().enumerate() {
                let at = |i: usize| -> f32 { NumCast::from(s[i]).unwrap_or(0.0) };
                let i = base + c;
                let top = at(i) + (at(i + dx) - at(i)) * wx;
                let bottom = at(i + dy) + (at(i + dy + dx) - at(i + dy)) * wx;
                let mut v = top + (bottom - top) * wy;
                if is_int {
                    v = v.round().clamp(0.0, max_f);
                }
                *o = NumCast::from(v).unwrap_or(zero);
            }
        }
        Ok(())
    }
}

fn check_size(expected: ImageSize, width: u32, height: u32) -> Result<()> {
    if expected.width != width || expected.height != height {
        return Err(Error::ImageSize {
            expected_width: expected.width,
            expected_height: expected.height,
            actual_width: width,
            actual_height: height,
        });
    }
    Ok(())
}
