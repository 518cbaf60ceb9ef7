//! Foreground masks from a dark background: threshold, then morphological clean-up.
//!
//! The Middlebury ring sets show the object on black; their README makes silhouettes with a
//! threshold of 0.19 followed by a dilation of 10 pixels and an erosion of 7.

use image::{GrayImage, RgbImage};

/// Parameters of [`dark_background_mask`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DarkBackground {
    /// A pixel is foreground when its brightest channel exceeds this fraction of full scale.
    pub threshold: f32,
    /// Dilation radius, pixels (square structuring element of side `2 r + 1`).
    pub dilate_px: u32,
    /// Erosion radius after the dilation, pixels.
    pub erode_px: u32,
}

impl Default for DarkBackground {
    /// The Middlebury README's recipe: 0.19, dilate 10, erode 7.
    fn default() -> Self {
        DarkBackground {
            threshold: 0.19,
            dilate_px: 10,
            erode_px: 7,
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
    if params.dilate_px > 0 {
        mask = morph(&mask, params.dilate_px, true);
    }
    if params.erode_px > 0 {
        mask = morph(&mask, params.erode_px, false);
    }
    mask
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
            },
        );
        assert_eq!(m.get_pixel(20, 20).0[0], 255);
        assert_eq!(m.get_pixel(2, 2).0[0], 0);
        assert_eq!(m.get_pixel(10, 10).0[0], 255);
        assert_eq!(m.get_pixel(9, 15).0[0], 0);
    }
}
