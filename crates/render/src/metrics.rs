//! Image metrics: PSNR and SSIM, optionally inside a mask.
//!
//! SSIM follows Wang et al. 2004 as scikit-image computes it with `gaussian_weights=True,
//! sigma=1.5, use_sample_covariance=False, data_range=255`: an 11-tap Gaussian window
//! (truncated at 3.5 sigma), edge pixels replicated, `K1 = 0.01`, `K2 = 0.03`, the map
//! averaged per channel over the image less a 5-pixel border (and inside the mask, if any),
//! then over channels. Golden values from scikit-image are in `fixtures/metrics/`.

use image::{GrayImage, RgbImage};
use rayon::prelude::*;

use crate::error::{Error, Result};

fn check(a: &RgbImage, b: &RgbImage, mask: Option<&GrayImage>) -> Result<()> {
    let dims = |what, w: u32, h: u32| {
        if (w, h) != a.dimensions() {
            return Err(Error::SizeMismatch {
                what,
                width: w,
                height: h,
                expected_width: a.width(),
                expected_height: a.height(),
            });
        }
        Ok(())
    };
    dims("second image", b.width(), b.height())?;
    if let Some(m) = mask {
        dims("mask", m.width(), m.height())?;
    }
    Ok(())
}

/// Peak signal-to-noise ratio of `b` against `a` (8-bit, peak 255), in dB, over the pixels
/// where `mask` is non-zero (all pixels without a mask). Identical images give infinity.
pub fn psnr(a: &RgbImage, b: &RgbImage, mask: Option<&GrayImage>) -> Result<f64> {
    check(a, b, mask)?;
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, (pa, pb)) in a.pixels().zip(b.pixels()).enumerate() {
        if mask.is_some_and(|m| m.as_raw()[i] == 0) {
            continue;
        }
        for c in 0..3 {
            let d = pa.0[c] as f64 - pb.0[c] as f64;
            sum += d * d;
        }
        n += 3;
    }
    if n == 0 {
        return Err(Error::EmptyMask);
    }
    Ok(psnr_of_mse(sum / n as f64))
}

/// The PSNR (dB, peak 255) of a mean squared error per channel value, as [`psnr`] takes it;
/// infinity for none. For errors pooled over pixels or images before the logarithm.
///
/// ```
/// use aibr_render::metrics::psnr_of_mse;
/// // An error of one grey level everywhere.
/// assert!((psnr_of_mse(1.0) - 48.13).abs() < 0.01);
/// assert_eq!(psnr_of_mse(0.0), f64::INFINITY);
/// ```
pub fn psnr_of_mse(mse: f64) -> f64 {
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0 * 255.0 / mse).log10()
    }
}

/// The mean squared error of a PSNR ([`psnr_of_mse`] inverted); none for infinity.
fn mse_of_psnr(psnr: f64) -> f64 {
    255.0 * 255.0 * 10f64.powf(-psnr / 10.0)
}

/// The PSNR (dB, peak 255) of the mean of several images' squared errors, given each
/// image's PSNR ([`psnr`]): the errors are pooled before the logarithm, so the worst images
/// weigh the most, where a mean of the PSNRs weighs every image's error ratio alike. Each
/// image counts once, whatever its size or mask. `None` for no images; an infinite PSNR (an
/// exact image) counts as no error.
///
/// Never above the mean of the PSNRs (the logarithm is concave), and equal to it when every
/// image has the same PSNR:
///
/// ```
/// use aibr_render::metrics::pooled_psnr;
/// // 10 and 30 dB pool to 12.97 dB: nearly all the 10 dB image's error, over two images.
/// let pooled = pooled_psnr([10.0, 30.0]).unwrap();
/// assert!((pooled - 12.97).abs() < 0.01);
/// let same = pooled_psnr([25.0, 25.0]).unwrap();
/// assert!((same - 25.0).abs() < 1e-9);
/// assert_eq!(pooled_psnr(std::iter::empty()), None);
/// ```
pub fn pooled_psnr(psnrs: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (sum, n) = psnrs.into_iter().fold((0.0f64, 0usize), |(sum, n), p| {
        (sum + mse_of_psnr(p), n + 1)
    });
    (n > 0).then(|| psnr_of_mse(sum / n as f64))
}

/// The pixel rectangle `[x0, x1) x [y0, y1)` over which SSIM is averaged.
#[derive(Debug, Clone, Copy)]
struct Window {
    x0: usize,
    x1: usize,
    y0: usize,
    y1: usize,
}

/// The five per-pixel products SSIM blurs, of one channel of two images.
#[derive(Debug, Clone, Copy)]
enum Map {
    X,
    Y,
    XX,
    YY,
    XY,
}

/// One channel of two images, as the [`Map`] values SSIM blurs.
struct Channel<'a> {
    a: &'a [u8],
    b: &'a [u8],
    c: usize,
    w: usize,
    h: usize,
}

impl Channel<'_> {
    #[inline]
    fn at(&self, map: Map, x: usize, y: usize) -> f64 {
        let i = 3 * (y * self.w + x) + self.c;
        let (p, q) = (self.a[i] as f64, self.b[i] as f64);
        match map {
            Map::X => p,
            Map::Y => q,
            Map::XX => p * p,
            Map::YY => q * q,
            Map::XY => p * q,
        }
    }
}

/// Separable Gaussian blur of one map of `ch` (`kernel` taps, the whole image's edges
/// replicated), computed only over `win`: row-major, `win`'s width per row. Each value is
/// summed in the same order as a blur of the whole image would.
fn blur(ch: &Channel<'_>, map: Map, kernel: &[f64], win: Window) -> Vec<f64> {
    let (w, h, r) = (ch.w, ch.h, kernel.len() / 2);
    let cw = win.x1 - win.x0;
    // Horizontal pass over the rows the vertical pass reads.
    let (ty0, ty1) = (win.y0.saturating_sub(r), (win.y1 + r).min(h));
    // The map's values along a row, `r` either side of the window, edges replicated: output
    // `j` reads `line[j..j + kernel.len()]`, tap by tap over the whole row.
    let mut line = vec![0.0; cw + 2 * r];
    let mut tmp = vec![0.0; cw * (ty1 - ty0)];
    for (y, row) in (ty0..ty1).zip(tmp.chunks_exact_mut(cw)) {
        for (j, v) in line.iter_mut().enumerate() {
            *v = ch.at(map, (win.x0 + j).saturating_sub(r).min(w - 1), y);
        }
        for (t, k) in kernel.iter().enumerate() {
            for (acc, v) in row.iter_mut().zip(&line[t..t + cw]) {
                *acc += k * v;
            }
        }
    }
    // Vertical pass, tap by tap over whole rows.
    let mut out = vec![0.0; cw * (win.y1 - win.y0)];
    for (y, row) in (win.y0..win.y1).zip(out.chunks_exact_mut(cw)) {
        for (t, k) in kernel.iter().enumerate() {
            let yy = (y + t).saturating_sub(r).min(h - 1) - ty0;
            for (acc, v) in row.iter_mut().zip(&tmp[yy * cw..(yy + 1) * cw]) {
                *acc += k * v;
            }
        }
    }
    out
}

/// Structural similarity of `b` against `a` (see the module docs for the exact definition),
/// averaged over the pixels where `mask` is non-zero.
///
/// The Gaussian statistics are computed only over the bounding box of the pixels averaged,
/// the fifteen blurs (five per channel) in parallel; the result is the same as blurring the
/// whole images.
pub fn ssim(a: &RgbImage, b: &RgbImage, mask: Option<&GrayImage>) -> Result<f64> {
    check(a, b, mask)?;
    let (w, h) = (a.width() as usize, a.height() as usize);
    let sigma = 1.5f64;
    let radius = (3.5 * sigma + 0.5) as usize;
    let mut kernel: Vec<f64> = (0..=2 * radius)
        .map(|i| {
            let d = i as f64 - radius as f64;
            (-d * d / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let total: f64 = kernel.iter().sum();
    kernel.iter_mut().for_each(|k| *k /= total);
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let pad = (2 * radius) / 2;
    // The pixels averaged: the image less the border, inside the mask.
    let inside = |x: usize, y: usize| mask.is_none_or(|m| m.as_raw()[y * w + x] != 0);
    let mut win = Window {
        x0: usize::MAX,
        x1: 0,
        y0: usize::MAX,
        y1: 0,
    };
    for y in pad..h.saturating_sub(pad) {
        for x in pad..w.saturating_sub(pad) {
            if inside(x, y) {
                win.x0 = win.x0.min(x);
                win.x1 = win.x1.max(x + 1);
                win.y0 = win.y0.min(y);
                win.y1 = win.y1.max(y + 1);
            }
        }
    }
    if win.x0 >= win.x1 {
        return Err(Error::EmptyMask);
    }
    const MAPS: [Map; 5] = [Map::X, Map::Y, Map::XX, Map::YY, Map::XY];
    let blurred: Vec<Vec<f64>> = (0..3 * MAPS.len())
        .into_par_iter()
        .map(|job| {
            let ch = Channel {
                a: a.as_raw(),
                b: b.as_raw(),
                c: job / MAPS.len(),
                w,
                h,
            };
            blur(&ch, MAPS[job % MAPS.len()], &kernel, win)
        })
        .collect();
    let cw = win.x1 - win.x0;
    let mut channel_means = [0.0f64; 3];
    for (c, mean) in channel_means.iter_mut().enumerate() {
        let [ux, uy, uxx, uyy, uxy] = [0, 1, 2, 3, 4].map(|m| &blurred[c * MAPS.len() + m]);
        let (mut sum, mut n) = (0.0, 0usize);
        for y in win.y0..win.y1 {
            for x in win.x0..win.x1 {
                if !inside(x, y) {
                    continue;
                }
                let i = (y - win.y0) * cw + (x - win.x0);
                let vx = uxx[i] - ux[i] * ux[i];
                let vy = uyy[i] - uy[i] * uy[i];
                let cxy = uxy[i] - ux[i] * uy[i];
                let s = ((2.0 * ux[i] * uy[i] + c1) * (2.0 * cxy + c2))
                    / ((ux[i] * ux[i] + uy[i] * uy[i] + c1) * (vx + vy + c2));
                sum += s;
                n += 1;
            }
        }
        *mean = sum / n.max(1) as f64;
    }
    Ok(channel_means.iter().sum::<f64>() / 3.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Pooling lies between the worst PSNR and the mean of the PSNRs.
        #[test]
        fn pooled_psnr_lies_between_the_worst_and_the_mean(
            psnrs in prop::collection::vec(0.0f64..80.0, 1..50),
        ) {
            let pooled = pooled_psnr(psnrs.iter().copied())
                .ok_or_else(|| TestCaseError::fail("no value"))?;
            let mean = psnrs.iter().sum::<f64>() / psnrs.len() as f64;
            let worst = psnrs.iter().copied().fold(f64::INFINITY, f64::min);
            prop_assert!(pooled <= mean + 1e-9, "pooled {pooled} above mean {mean}");
            prop_assert!(pooled >= worst - 1e-9, "pooled {pooled} below worst {worst}");
            // One image alone, or all alike: the same PSNR.
            let alike = pooled_psnr(std::iter::repeat_n(psnrs[0], psnrs.len()))
                .ok_or_else(|| TestCaseError::fail("no value"))?;
            prop_assert!((alike - psnrs[0]).abs() < 1e-9);
        }
    }

    /// SSIM as the module docs define it, the plainest way: every map blurred over the whole
    /// image, pixel by pixel, tap by tap.
    fn ssim_whole_image(a: &RgbImage, b: &RgbImage, mask: Option<&GrayImage>) -> f64 {
        let (w, h) = (a.width() as usize, a.height() as usize);
        let (sigma, r) = (1.5f64, 5usize);
        let mut kernel: Vec<f64> = (0..=2 * r)
            .map(|i| (-((i as f64 - r as f64).powi(2)) / (2.0 * sigma * sigma)).exp())
            .collect();
        let total: f64 = kernel.iter().sum();
        kernel.iter_mut().for_each(|k| *k /= total);
        let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
        let mut means = 0.0;
        for c in 0..3 {
            let value =
                |img: &RgbImage, x: usize, y: usize| img.as_raw()[3 * (y * w + x) + c] as f64;
            let maps: [&dyn Fn(usize, usize) -> f64; 5] = [
                &|x, y| value(a, x, y),
                &|x, y| value(b, x, y),
                &|x, y| value(a, x, y) * value(a, x, y),
                &|x, y| value(b, x, y) * value(b, x, y),
                &|x, y| value(a, x, y) * value(b, x, y),
            ];
            let [ux, uy, uxx, uyy, uxy] = maps.map(|map| {
                let mut across = vec![0.0; w * h];
                for y in 0..h {
                    for x in 0..w {
                        for (t, k) in kernel.iter().enumerate() {
                            across[y * w + x] += k * map((x + t).saturating_sub(r).min(w - 1), y);
                        }
                    }
                }
                let mut out = vec![0.0; w * h];
                for y in 0..h {
                    for x in 0..w {
                        for (t, k) in kernel.iter().enumerate() {
                            out[y * w + x] +=
                                k * across[(y + t).saturating_sub(r).min(h - 1) * w + x];
                        }
                    }
                }
                out
            });
            let (mut sum, mut n) = (0.0, 0usize);
            for y in r..h.saturating_sub(r) {
                for x in r..w.saturating_sub(r) {
                    let i = y * w + x;
                    if mask.is_some_and(|m| m.as_raw()[i] == 0) {
                        continue;
                    }
                    let vx = uxx[i] - ux[i] * ux[i];
                    let vy = uyy[i] - uy[i] * uy[i];
                    let cxy = uxy[i] - ux[i] * uy[i];
                    sum += ((2.0 * ux[i] * uy[i] + c1) * (2.0 * cxy + c2))
                        / ((ux[i] * ux[i] + uy[i] * uy[i] + c1) * (vx + vy + c2));
                    n += 1;
                }
            }
            means += sum / n.max(1) as f64;
        }
        means / 3.0
    }

    proptest! {
        /// `ssim` blurs only the window the mask needs, row by row: the same value, to the
        /// bit, as blurring the whole images, with or without a mask.
        #[test]
        fn ssim_equals_the_whole_image_blur(
            (w, h, a, b, mask) in (11u32..40, 11u32..40).prop_flat_map(|(w, h)| {
                let n = (w * h) as usize;
                (
                    Just(w),
                    Just(h),
                    prop::collection::vec(any::<u8>(), 3 * n),
                    prop::collection::vec(any::<u8>(), 3 * n),
                    prop::option::of(prop::collection::vec(prop::bool::weighted(0.3), n)),
                )
            }),
        ) {
            let image = |raw: Vec<u8>| {
                RgbImage::from_raw(w, h, raw).ok_or_else(|| TestCaseError::fail("image size"))
            };
            let (a, b) = (image(a)?, image(b)?);
            let mask = mask
                .map(|m| GrayImage::from_raw(w, h, m.iter().map(|&on| 255 * on as u8).collect()))
                .map(|m| m.ok_or_else(|| TestCaseError::fail("mask size")))
                .transpose()?;
            match ssim(&a, &b, mask.as_ref()) {
                Ok(fast) => {
                    let plain = ssim_whole_image(&a, &b, mask.as_ref());
                    prop_assert_eq!(fast.to_bits(), plain.to_bits(), "{} against {}", fast, plain);
                }
                // Only a mask with nothing inside the border is refused.
                Err(Error::EmptyMask) => {
                    let m = mask.ok_or_else(|| TestCaseError::fail("refused without a mask"))?;
                    prop_assert!((5..h - 5).all(|y| (5..w - 5).all(|x| m.get_pixel(x, y)[0] == 0)));
                }
                Err(e) => return Err(TestCaseError::fail(e.to_string())),
            }
        }
    }

    /// The pool of two images' PSNRs is that of their pixels put side by side.
    #[test]
    fn pooled_psnr_is_the_psnr_of_the_images_side_by_side() -> Result<()> {
        let truth = RgbImage::from_fn(8, 4, |x, y| image::Rgb([(x * 20) as u8, (y * 50) as u8, 9]));
        let a = RgbImage::from_fn(8, 4, |x, y| {
            image::Rgb([(x * 20 + 3) as u8, (y * 50) as u8, 9])
        });
        let b = RgbImage::from_fn(8, 4, |x, y| {
            image::Rgb([(x * 20) as u8, (y * 50) as u8, (9 + x + y) as u8])
        });
        // The two pairs side by side, as one image of twice the width.
        let side = |l: &RgbImage, r: &RgbImage| {
            RgbImage::from_fn(16, 4, |x, y| {
                if x < 8 {
                    *l.get_pixel(x, y)
                } else {
                    *r.get_pixel(x - 8, y)
                }
            })
        };
        let whole = psnr(&side(&truth, &truth), &side(&a, &b), None)?;
        let pooled = pooled_psnr([psnr(&truth, &a, None)?, psnr(&truth, &b, None)?]);
        assert!(
            pooled.is_some_and(|p| (p - whole).abs() < 1e-9),
            "{pooled:?} against {whole}"
        );
        // An exact image adds no error, and halves the mean.
        let with_exact = pooled_psnr([psnr(&truth, &a, None)?, f64::INFINITY]);
        let a_alone = psnr(&truth, &a, None)?;
        assert!(with_exact.is_some_and(|p| (p - (a_alone + 10.0 * 2f64.log10())).abs() < 1e-9));
        Ok(())
    }
}
