//! Image metrics: PSNR and SSIM, optionally inside a mask.
//!
//! SSIM follows Wang et al. 2004 as scikit-image computes it with `gaussian_weights=True,
//! sigma=1.5, use_sample_covariance=False, data_range=255`: an 11-tap Gaussian window
//! (truncated at 3.5 sigma), edge pixels replicated, `K1 = 0.01`, `K2 = 0.03`, the map
//! averaged per channel over the image less a 5-pixel border (and inside the mask, if any),
//! then over channels. Golden values from scikit-image are in `fixtures/metrics/`.

use image::{GrayImage, RgbImage};

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
    let mse = sum / n as f64;
    Ok(if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0 * 255.0 / mse).log10()
    })
}

/// Separable Gaussian blur (sigma 1.5, 11 taps, edges replicated).
fn blur(src: &[f64], w: usize, h: usize, kernel: &[f64]) -> Vec<f64> {
    let r = kernel.len() / 2;
    let mut tmp = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (t, k) in kernel.iter().enumerate() {
                let xx = (x + t).saturating_sub(r).min(w - 1);
                s += k * src[y * w + xx];
            }
            tmp[y * w + x] = s;
        }
    }
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (t, k) in kernel.iter().enumerate() {
                let yy = (y + t).saturating_sub(r).min(h - 1);
                s += k * tmp[yy * w + x];
            }
            out[y * w + x] = s;
        }
    }
    out
}

/// Structural similarity of `b` against `a` (see the module docs for the exact definition),
/// averaged over the pixels where `mask` is non-zero.
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
    let mut channel_means = [0.0f64; 3];
    for (c, mean) in channel_means.iter_mut().enumerate() {
        let x: Vec<f64> = a.pixels().map(|p| p.0[c] as f64).collect();
        let y: Vec<f64> = b.pixels().map(|p| p.0[c] as f64).collect();
        let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
        let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
        let xy: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p * q).collect();
        let (ux, uy) = (blur(&x, w, h, &kernel), blur(&y, w, h, &kernel));
        let (uxx, uyy, uxy) = (
            blur(&xx, w, h, &kernel),
            blur(&yy, w, h, &kernel),
            blur(&xy, w, h, &kernel),
        );
        let (mut sum, mut n) = (0.0, 0usize);
        for yy_ in pad..h.saturating_sub(pad) {
            for xx_ in pad..w.saturating_sub(pad) {
                let i = yy_ * w + xx_;
                if mask.is_some_and(|m| m.as_raw()[i] == 0) {
                    continue;
                }
                let vx = uxx[i] - ux[i] * ux[i];
                let vy = uyy[i] - uy[i] * uy[i];
                let cxy = uxy[i] - ux[i] * uy[i];
                let s = ((2.0 * ux[i] * uy[i] + c1) * (2.0 * cxy + c2))
                    / ((ux[i] * ux[i] + uy[i] * uy[i] + c1) * (vx + vy + c2));
                sum += s;
                n += 1;
            }
        }
        if n == 0 {
            return Err(Error::EmptyMask);
        }
        *mean = sum / n as f64;
    }
    Ok(channel_means.iter().sum::<f64>() / 3.0)
}
