//! Pixel-format conversion to 8-bit RGB.
//!
//! YUYV and NV12 use BT.601 video-range coefficients in 20-bit fixed point, the arithmetic
//! of OpenCV's `cvtColor` (`COLOR_YUV2RGB_YUYV`, `COLOR_YUV2RGB_NV12`); the tests compare
//! with OpenCV's output byte for byte (`fixtures/v4l/yuv_golden.py`).

use image::RgbImage;

use crate::error::{Error, Result};
use crate::format::PixelFormat;

/// One frame as the device delivered it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawFrame<'a> {
    /// The pixel format.
    pub format: PixelFormat,
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Bytes per line of the (first) plane; 0 means the format's minimum.
    pub stride: usize,
    /// The bytes (for MJPEG, the JPEG data).
    pub data: &'a [u8],
}

const SHIFT: i32 = 20;
const HALF: i32 = 1 << (SHIFT - 1);
const CY: i32 = 1_220_542;
const CUB: i32 = 2_116_026;
const CUG: i32 = -409_993;
const CVG: i32 = -852_492;
const CVR: i32 = 1_673_527;

/// One YUV sample to RGB (BT.601, video range, OpenCV's rounding).
#[inline]
fn yuv_pixel(y: u8, u: u8, v: u8, out: &mut [u8]) {
    let (u, v) = (u as i32 - 128, v as i32 - 128);
    let ruv = HALF + CVR * v;
    let guv = HALF + CVG * v + CUG * u;
    let buv = HALF + CUB * u;
    let y = (y as i32 - 16).max(0) * CY;
    out[0] = ((y + ruv) >> SHIFT).clamp(0, 255) as u8;
    out[1] = ((y + guv) >> SHIFT).clamp(0, 255) as u8;
    out[2] = ((y + buv) >> SHIFT).clamp(0, 255) as u8;
}

impl RawFrame<'_> {
    fn stride(&self) -> usize {
        if self.stride == 0 {
            self.format.min_stride(self.width)
        } else {
            self.stride
        }
    }

    fn check(&self) -> Result<usize> {
        let stride = self.stride();
        if self.width == 0 || self.height == 0 {
            return Err(Error::InvalidParameter {
                name: "frame size",
                reason: format!("{}x{} is empty", self.width, self.height),
            });
        }
        if matches!(self.format, PixelFormat::Yuyv | PixelFormat::Nv12) && self.width % 2 == 1 {
            return Err(Error::InvalidParameter {
                name: "frame width",
                reason: format!(
                    "{} frames have an even width, not {}",
                    self.format, self.width
                ),
            });
        }
        let bad = |expected| Error::BadFrame {
            format: self.format,
            width: self.width,
            height: self.height,
            stride,
            expected,
            len: self.data.len(),
        };
        let min = self.format.min_stride(self.width);
        if stride < min {
            return Err(bad(min * self.height as usize));
        }
        if let Some(need) = self.format.frame_len(self.height, stride) {
            // The last line need not be padded to the stride.
            let need = need - (stride - min);
            if self.data.len() < need {
                return Err(bad(need));
            }
        }
        Ok(stride)
    }
}

/// Converts `frame` to RGB into `out`, which is reallocated only when its size differs.
pub fn to_rgb(frame: &RawFrame<'_>, out: &mut RgbImage) -> Result<()> {
    let stride = frame.check()?;
    let (w, h) = (frame.width, frame.height);
    if frame.format == PixelFormat::Mjpeg {
        let data = crate::mjpeg::with_huffman_tables(frame.data);
        let img = image::load_from_memory_with_format(&data, image::ImageFormat::Jpeg)
            .map_err(|e| Error::Decode {
                format: frame.format,
                reason: e.to_string(),
            })?
            .into_rgb8();
        if img.dimensions() != (w, h) {
            return Err(Error::Decode {
                format: frame.format,
                reason: format!(
                    "the JPEG is {}x{}, the stream {w}x{h}",
                    img.width(),
                    img.height()
                ),
            });
        }
        *out = img;
        return Ok(());
    }
    if out.dimensions() != (w, h) {
        *out = RgbImage::new(w, h);
    }
    let (w, h) = (w as usize, h as usize);
    let dst: &mut [u8] = out;
    let src = frame.data;
    match frame.format {
        PixelFormat::Yuyv => {
            for (row, line) in dst.chunks_exact_mut(3 * w).enumerate() {
                let s = &src[row * stride..row * stride + 2 * w];
                for (px, yuyv) in line.chunks_exact_mut(6).zip(s.chunks_exact(4)) {
                    let (a, b) = px.split_at_mut(3);
                    yuv_pixel(yuyv[0], yuyv[1], yuyv[3], a);
                    yuv_pixel(yuyv[2], yuyv[1], yuyv[3], b);
                }
            }
        }
        PixelFormat::Nv12 => {
            let chroma = &src[stride * h..];
            for (row, line) in dst.chunks_exact_mut(3 * w).enumerate() {
                let y = &src[row * stride..row * stride + w];
                let uv = &chroma[(row / 2) * stride..(row / 2) * stride + w];
                for ((px, y2), uv) in line
                    .chunks_exact_mut(6)
                    .zip(y.chunks_exact(2))
                    .zip(uv.chunks_exact(2))
                {
                    let (a, b) = px.split_at_mut(3);
                    yuv_pixel(y2[0], uv[0], uv[1], a);
                    yuv_pixel(y2[1], uv[0], uv[1], b);
                }
            }
        }
        PixelFormat::Rgb3 => {
            for (row, line) in dst.chunks_exact_mut(3 * w).enumerate() {
                line.copy_from_slice(&src[row * stride..row * stride + 3 * w]);
            }
        }
        PixelFormat::Grey => {
            for (row, line) in dst.chunks_exact_mut(3 * w).enumerate() {
                for (px, &g) in line
                    .chunks_exact_mut(3)
                    .zip(&src[row * stride..row * stride + w])
                {
                    px.fill(g);
                }
            }
        }
        PixelFormat::Mjpeg => {}
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neutral_and_extreme_yuv() {
        let mut px = [0u8; 3];
        yuv_pixel(16, 128, 128, &mut px);
        assert_eq!(px, [0, 0, 0]);
        yuv_pixel(235, 128, 128, &mut px);
        assert_eq!(px, [255, 255, 255]);
        yuv_pixel(0, 0, 255, &mut px);
        assert_eq!(px, [203, 0, 0]);
    }

    #[test]
    fn short_buffers_and_odd_widths_are_errors() {
        let mut out = RgbImage::new(1, 1);
        let f = RawFrame {
            format: PixelFormat::Yuyv,
            width: 4,
            height: 2,
            stride: 0,
            data: &[0; 15],
        };
        assert!(matches!(
            to_rgb(&f, &mut out),
            Err(Error::BadFrame {
                expected: 16,
                len: 15,
                ..
            })
        ));
        let f = RawFrame {
            format: PixelFormat::Yuyv,
            width: 3,
            height: 2,
            stride: 0,
            data: &[0; 12],
        };
        assert!(matches!(
            to_rgb(&f, &mut out),
            Err(Error::InvalidParameter { .. })
        ));
        let f = RawFrame {
            format: PixelFormat::Rgb3,
            width: 2,
            height: 2,
            stride: 4,
            data: &[0; 16],
        };
        assert!(matches!(to_rgb(&f, &mut out), Err(Error::BadFrame { .. })));
        let f = RawFrame {
            format: PixelFormat::Mjpeg,
            width: 2,
            height: 2,
            stride: 0,
            data: b"not a jpeg",
        };
        assert!(matches!(to_rgb(&f, &mut out), Err(Error::Decode { .. })));
    }

    #[test]
    fn strides_and_grey() {
        // 2x2 grey with 3 bytes of padding per line.
        let data = [10, 20, 0, 0, 0, 30, 40];
        let f = RawFrame {
            format: PixelFormat::Grey,
            width: 2,
            height: 2,
            stride: 5,
            data: &data,
        };
        let mut out = RgbImage::new(0, 0);
        to_rgb(&f, &mut out).unwrap();
        assert_eq!(
            out.as_raw(),
            &[10, 10, 10, 20, 20, 20, 30, 30, 30, 40, 40, 40]
        );
    }
}
