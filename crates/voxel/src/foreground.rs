//! Foreground masks from a dark background: threshold, then morphological clean-up.
//!
//! The Middlebury ring sets show the object on black; their README makes silhouettes with a
//! threshold of 0.19 followed by a dilation of 10 pixels and an erosion of 7.
//!
//! A threshold also marks whatever else is bright in the picture (on templeSparseRing, lit
//! parts of the gantry beside the temple); [`clip_to_volume`] removes what lies outside the
//! object's known bounding volume, and [`DarkBackground::largest_component`] keeps only the
//! largest connected region of the thresholded pixels, before the closing can join clutter
//! to the object.

use aibr_camera::{Aabb, Camera};
use image::{GrayImage, RgbImage};
use nalgebra::Point2;

use crate::error::{Error, Result};

/// Parameters of [`dark_background_mask`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DarkBackground {
    /// A pixel is foreground when its brightest channel exceeds this fraction of full scale.
    pub threshold: f32,
    /// Dilation radius, pixels (square structuring element of side `2 r + 1`).
    pub dilate_px: u32,
    /// Erosion radius after the dilation, pixels.
    pub erode_px: u32,
    /// Keep only the largest 8-connected region of the thresholded pixels, before the
    /// dilation (not in the README's recipe, so off by default). Bright clutter that does not
    /// touch the object goes even where the dilation would have joined it to the object; so
    /// would a part of the object that the threshold cuts off from the rest.
    pub largest_component: bool,
}

impl Default for DarkBackground {
    /// The Middlebury README's recipe: 0.19, dilate 10, erode 7, every region kept.
    fn default() -> Self {
        DarkBackground {
            threshold: 0.19,
            dilate_px: 10,
            erode_px: 7,
            largest_component: false,
        }
    }
}

/// The foreground mask (255 object, 0 background) of an image on a dark background.
pub fn dark_background_mask(image: &RgbImage, params: &DarkBackground) -> GrayImage {
    let limit = (params.threshold.clamp(0.0, 1.0) * 255.0) as u8;
    let mut mask = GrayImage::from_fn(image.width(), image.height(), |x, y| {
        let p = image.get_pixel(x, y).0;
        image::Luma([if p.iter().any(|&c| c > limit) { 255 } else { 0 }])
    });
    if params.largest_component {
        mask = largest_component(&mask);
    }
    if params.dilate_px > 0 {
        mask = morph(&mask, params.dilate_px, true);
    }
    if params.erode_px > 0 {
        mask = morph(&mask, params.erode_px, false);
    }
    mask
}

/// Clears the mask pixels whose ray (through the pixel centre) misses `volume`: the object
/// lies inside its volume, so nothing seen only outside it is object. Returns how many
/// pixels were cleared.
///
/// Errors: a mask whose size differs from the camera's ([`Error::ViewSize`], view 0), or a
/// camera with lens distortion ([`Error::Distorted`]): undistort first.
pub fn clip_to_volume(mask: &mut GrayImage, camera: &Camera, volume: &Aabb) -> Result<usize> {
    let size = camera.size;
    if mask.dimensions() != (size.width, size.height) {
        return Err(Error::ViewSize {
            view: 0,
            what: "mask",
            width: mask.width(),
            height: mask.height(),
            expected_width: size.width,
            expected_height: size.height,
        });
    }
    if !camera.distortion.is_none() {
        return Err(Error::Distorted { view: 0 });
    }
    let mut cleared = 0;
    for (x, y, p) in mask.enumerate_pixels_mut() {
        if p.0[0] == 0 {
            continue;
        }
        let inside = camera
            .ray_through_pixel(Point2::new(f64::from(x), f64::from(y)))
            .is_some_and(|ray| volume.intersect(&ray).is_some());
        if !inside {
            p.0[0] = 0;
            cleared += 1;
        }
    }
    Ok(cleared)
}

/// The largest 8-connected region of a mask's non-zero pixels, as 255 on 0 (the first in
/// row-major order of equally large ones); an empty mask stays empty.
pub fn largest_component(mask: &GrayImage) -> GrayImage {
    let (w, h) = (mask.width() as usize, mask.height() as usize);
    let on = mask.as_raw();
    // Region labels (0: background or not yet seen), filled by a stack flood fill.
    let mut label = vec![0u32; on.len()];
    let mut stack = Vec::new();
    let (mut best, mut best_size, mut next) = (0u32, 0usize, 0u32);
    for start in 0..on.len() {
        if on[start] == 0 || label[start] != 0 {
            continue;
        }
        next += 1;
        label[start] = next;
        stack.push(start);
        let mut size = 0;
        while let Some(i) = stack.pop() {
            size += 1;
            let (x, y) = (i % w, i / w);
            for ny in y.saturating_sub(1)..(y + 2).min(h) {
                for nx in x.saturating_sub(1)..(x + 2).min(w) {
                    let j = ny * w + nx;
                    if on[j] != 0 && label[j] == 0 {
                        label[j] = next;
                        stack.push(j);
                    }
                }
            }
        }
        if size > best_size {
            (best, best_size) = (next, size);
        }
    }
    let mut kept = GrayImage::new(mask.width(), mask.height());
    for (p, &l) in kept.iter_mut().zip(&label) {
        *p = if l != 0 && l == best { 255 } else { 0 };
    }
    kept
}

/// Square dilation (`max`) or erosion (`min`) of radius `r`, separable. Outside the image
/// counts as background for dilation and as foreground for erosion (so erosion does not eat
/// objects that touch the border).
pub fn morph(mask: &GrayImage, r: u32, dilate: bool) -> GrayImage {
    let (w, h) = mask.dimensions();
    let pick = |a: u8, b: u8| if dilate { a.max(b) } else { a.min(b) };
    let r = r as i64;
    let pass = |src: &GrayImage, horizontal: bool| -> GrayImage {
        GrayImage::from_fn(w, h, |x, y| {
            let mut acc = if dilate { 0 } else { 255 };
            for d in -r..=r {
                let (sx, sy) = if horizontal {
                    (x as i64 + d, y as i64)
                } else {
                    (x as i64, y as i64 + d)
                };
                if sx >= 0 && sy >= 0 && sx < w as i64 && sy < h as i64 {
                    acc = pick(acc, src.get_pixel(sx as u32, sy as u32).0[0]);
                }
            }
            image::Luma([acc])
        })
    };
    let tmp = pass(mask, true);
    pass(&tmp, false)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn threshold_and_close() {
        let mut img = RgbImage::new(40, 40);
        for y in 10..30 {
            for x in 10..30 {
                img.put_pixel(x, y, image::Rgb([200, 10, 10]));
            }
        }
        // A dark hole the closing fills, and a dim speck below the threshold.
        img.put_pixel(20, 20, image::Rgb([5, 5, 5]));
        img.put_pixel(2, 2, image::Rgb([30, 30, 30]));
        let m = dark_background_mask(
            &img,
            &DarkBackground {
                threshold: 0.19,
                dilate_px: 2,
                erode_px: 2,
                largest_component: false,
            },
        );
        assert_eq!(m.get_pixel(20, 20).0[0], 255);
        assert_eq!(m.get_pixel(2, 2).0[0], 0);
        assert_eq!(m.get_pixel(10, 10).0[0], 255);
        assert_eq!(m.get_pixel(9, 15).0[0], 0);
    }

    #[test]
    fn only_the_largest_region_is_kept_before_the_closing() {
        // A 20x20 object, a 6x6 bright patch 3 pixels from it (the dilation joins them), and
        // a diagonal line of single pixels that touches the object at a corner (8-connected).
        let mut img = RgbImage::new(60, 40);
        let mut paint = |x0: u32, x1: u32, y0: u32, y1: u32| {
            for y in y0..y1 {
                for x in x0..x1 {
                    img.put_pixel(x, y, image::Rgb([200, 200, 200]));
                }
            }
        };
        paint(10, 30, 10, 30);
        paint(33, 39, 12, 18);
        for k in 0..5 {
            paint(30 + k, 31 + k, 30 + k, 31 + k);
        }
        let params = DarkBackground {
            threshold: 0.19,
            dilate_px: 2,
            erode_px: 2,
            largest_component: true,
        };
        let m = dark_background_mask(&img, &params);
        assert_eq!(m.get_pixel(20, 20).0[0], 255);
        assert_eq!(m.get_pixel(36, 15).0[0], 0, "the patch is gone");
        assert_eq!(
            m.get_pixel(34, 34).0[0],
            255,
            "the diagonal is part of the object"
        );
        // Without the option the closing joins the patch to the object.
        let joined = dark_background_mask(
            &img,
            &DarkBackground {
                largest_component: false,
                ..params
            },
        );
        assert_eq!(joined.get_pixel(36, 15).0[0], 255);
        assert_eq!(joined.get_pixel(31, 15).0[0], 255);
        // Nothing bright: nothing kept.
        let empty = largest_component(&GrayImage::new(5, 5));
        assert!(empty.pixels().all(|p| p.0[0] == 0));
    }

    #[test]
    fn clipping_keeps_exactly_the_projection_of_the_volume() -> Result<()> {
        use aibr_camera::{Distortion, ImageSize, Intrinsics};
        use nalgebra::{Isometry3, Point3};
        // A camera 1 m in front of a 0.2 m cube, looking at it along +z.
        let camera = Camera::new(
            Intrinsics::new(500.0, 500.0, 100.0, 100.0),
            Distortion::NONE,
            Isometry3::translation(0.0, 0.0, 1.0),
            ImageSize::new(201, 201),
        )?;
        let volume = Aabb::new(Point3::new(-0.1, -0.1, -0.1), Point3::new(0.1, 0.1, 0.1))?;
        let mut mask = GrayImage::from_pixel(201, 201, image::Luma([255]));
        let cleared = clip_to_volume(&mut mask, &camera, &volume)?;
        // The silhouette of the cube is the square of its nearer face: |u - 100| <= 500 x
        // 0.1 / 0.9 = 55.6 pixels.
        for (x, y, p) in mask.enumerate_pixels() {
            let (dx, dy) = ((f64::from(x) - 100.0).abs(), (f64::from(y) - 100.0).abs());
            let expected = dx <= 55.5 && dy <= 55.5;
            assert_eq!(p.0[0] != 0, expected, "pixel {x}, {y}");
        }
        assert_eq!(cleared, 201 * 201 - 111 * 111);
        // A mask of the wrong size is refused.
        let mut small = GrayImage::new(10, 10);
        assert!(matches!(
            clip_to_volume(&mut small, &camera, &volume),
            Err(Error::ViewSize { .. })
        ));
        Ok(())
    }
}
