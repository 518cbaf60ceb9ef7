//! Foreground masks without ground truth.
//!
//! Three sources, in order of preference: masks given with the views; a dark-background
//! threshold (re-exported from aibr-voxel, the Middlebury recipe); and the turntable's own
//! gift, here: the backdrop does not turn with the object, so the per-pixel median over the
//! captured views estimates it, and the object is what differs from it.

use image::{GrayImage, RgbImage};

pub use aibr_voxel::foreground::{DarkBackground, dark_background_mask, morph};

use crate::error::{Error, Result};

/// The backdrop of a turntable capture estimated from its views.
#[derive(Debug, Clone, PartialEq)]
pub struct BackdropEstimate {
    /// Per pixel and channel, the median over the views: the backdrop wherever the object
    /// covers that pixel in fewer than half the views.
    pub backdrop: RgbImage,
    /// Per pixel, the largest over channels of the median absolute deviation from that
    /// median: small where the views agree (backdrop, noise), large where the turning object
    /// covers the pixel in most views (and the median is not the backdrop).
    pub spread: GrayImage,
}

/// The per-pixel median of `images` (at least 3, all of one size), and its spread.
pub fn median_backdrop(images: &[&RgbImage]) -> Result<BackdropEstimate> {
    let Some(first) = images.first() else {
        return Err(Error::TooFewImages {
            found: 0,
            needed: 3,
        });
    };
    if images.len() < 3 {
        return Err(Error::TooFewImages {
            found: images.len(),
            needed: 3,
        });
    }
    let (w, h) = first.dimensions();
    for im in images {
        if im.dimensions() != (w, h) {
            return Err(Error::SizeMismatch {
                what: "image",
                width: im.width(),
                height: im.height(),
                expected_width: w,
                expected_height: h,
            });
        }
    }
    let mut backdrop = RgbImage::new(w, h);
    let mut spread = GrayImage::new(w, h);
    let mut values = Vec::with_capacity(images.len());
    let mut deviations = Vec::with_capacity(images.len());
    for (i, px) in backdrop.as_mut().iter_mut().enumerate() {
        values.clear();
        values.extend(images.iter().map(|im| im.as_raw()[i]));
        values.sort_unstable();
        let median = values[values.len() / 2];
        *px = median;
        deviations.clear();
        deviations.extend(values.iter().map(|v| v.abs_diff(median)));
        deviations.sort_unstable();
        let s = &mut spread.as_mut()[i / 3];
        *s = (*s).max(deviations[deviations.len() / 2]);
    }
    Ok(BackdropEstimate { backdrop, spread })
}

/// Parameters of [`foreground_from_backdrop`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackdropDifference {
    /// A pixel is foreground when some channel differs from the backdrop by more than this
    /// many grey levels (default 25).
    pub threshold: u8,
    /// Pixels whose spread across the views exceeds this many grey levels are foreground
    /// whatever their difference (default 20): the object covers them in most views, so the
    /// median there is not the backdrop.
    pub spread_threshold: u8,
    /// Closing (dilate, then erode) radius, pixels, to fill small holes (default 2).
    pub close_px: u32,
}

impl Default for BackdropDifference {
    fn default() -> Self {
        BackdropDifference {
            threshold: 25,
            spread_threshold: 20,
            close_px: 2,
        }
    }
}

/// The foreground of `image` against an estimated backdrop of the same size.
pub fn foreground_from_backdrop(
    image: &RgbImage,
    estimate: &BackdropEstimate,
    params: &BackdropDifference,
) -> Result<GrayImage> {
    let backdrop = &estimate.backdrop;
    if image.dimensions() != backdrop.dimensions() {
        return Err(Error::SizeMismatch {
            what: "backdrop",
            width: backdrop.width(),
            height: backdrop.height(),
            expected_width: image.width(),
            expected_height: image.height(),
        });
    }
    let mut mask = GrayImage::from_fn(image.width(), image.height(), |x, y| {
        let (a, b) = (image.get_pixel(x, y).0, backdrop.get_pixel(x, y).0);
        let differs = (0..3).any(|c| a[c].abs_diff(b[c]) > params.threshold)
            || estimate.spread.get_pixel(x, y).0[0] > params.spread_threshold;
        image::Luma([if differs { 255 } else { 0 }])
    });
    if params.close_px > 0 {
        mask = morph(&morph(&mask, params.close_px, true), params.close_px, false);
    }
    Ok(mask)
}
