//! Pixel formats and the choice among what a device offers.

use std::fmt;

/// The pixel formats aibr converts to RGB.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum PixelFormat {
    /// `YUYV`: packed 4:2:2, Y0 U Y1 V (BT.601, video range). Uncompressed: preferred.
    Yuyv,
    /// `MJPG`: a JPEG per frame (webcams often omit the Huffman tables).
    Mjpeg,
    /// `RGB3`: packed 8-bit RGB.
    Rgb3,
    /// `GREY`: 8-bit luma.
    Grey,
    /// `NV12`: planar 4:2:0, a Y plane then interleaved U V (BT.601, video range).
    Nv12,
}

impl PixelFormat {
    /// Every format, in the order a device's offers are preferred: uncompressed YUYV, then
    /// MJPEG, then RGB3 or GREY, then NV12.
    pub const PREFERENCE: [PixelFormat; 5] = [
        PixelFormat::Yuyv,
        PixelFormat::Mjpeg,
        PixelFormat::Rgb3,
        PixelFormat::Grey,
        PixelFormat::Nv12,
    ];

    /// The V4L2 four-character code.
    pub fn fourcc(self) -> [u8; 4] {
        match self {
            PixelFormat::Yuyv => *b"YUYV",
            PixelFormat::Mjpeg => *b"MJPG",
            PixelFormat::Rgb3 => *b"RGB3",
            PixelFormat::Grey => *b"GREY",
            PixelFormat::Nv12 => *b"NV12",
        }
    }

    /// The format of a four-character code, if aibr converts it.
    pub fn from_fourcc(code: [u8; 4]) -> Option<PixelFormat> {
        Self::PREFERENCE.into_iter().find(|f| f.fourcc() == code)
    }

    /// The least bytes per line of the (first) plane; 0 for MJPEG.
    pub fn min_stride(self, width: u32) -> usize {
        let w = width as usize;
        match self {
            PixelFormat::Yuyv => 2 * w,
            PixelFormat::Rgb3 => 3 * w,
            PixelFormat::Grey | PixelFormat::Nv12 => w,
            PixelFormat::Mjpeg => 0,
        }
    }

    /// The bytes a frame needs with `stride` bytes per line (`None` for MJPEG, whose size
    /// varies). NV12's chroma plane follows the luma plane with the same stride.
    pub fn frame_len(self, height: u32, stride: usize) -> Option<usize> {
        let h = height as usize;
        match self {
            PixelFormat::Mjpeg => None,
            PixelFormat::Nv12 => stride.checked_mul(h + h.div_ceil(2)),
            _ => stride.checked_mul(h),
        }
    }

    fn rank(self) -> usize {
        Self::PREFERENCE
            .iter()
            .position(|f| *f == self)
            .unwrap_or(usize::MAX)
    }
}

impl fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&String::from_utf8_lossy(&self.fourcc()))
    }
}

/// One format and frame size a device offers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Offer {
    /// The four-character code.
    pub fourcc: [u8; 4],
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
}

impl fmt::Display for Offer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {}x{}",
            String::from_utf8_lossy(&self.fourcc),
            self.width,
            self.height
        )
    }
}

/// Chooses among `offers`: with a `size`, only offers of exactly that size; the most
/// preferred format ([`PixelFormat::PREFERENCE`]) wins, then the largest size. `None` when no
/// offer is usable.
pub fn choose(offers: &[Offer], size: Option<(u32, u32)>) -> Option<(PixelFormat, u32, u32)> {
    offers
        .iter()
        .filter(|o| size.is_none_or(|(w, h)| o.width == w && o.height == h))
        .filter(|o| o.width > 0 && o.height > 0)
        .filter_map(|o| PixelFormat::from_fourcc(o.fourcc).map(|f| (f, o.width, o.height)))
        .min_by_key(|&(f, w, h)| (f.rank(), std::cmp::Reverse(w as u64 * h as u64)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn offer(code: &[u8; 4], width: u32, height: u32) -> Offer {
        Offer {
            fourcc: *code,
            width,
            height,
        }
    }

    #[test]
    fn prefers_uncompressed_then_mjpeg_then_the_rest() {
        let offers = [
            offer(b"MJPG", 1920, 1080),
            offer(b"YUYV", 640, 480),
            offer(b"YUYV", 320, 240),
            offer(b"H264", 1920, 1080),
        ];
        assert_eq!(choose(&offers, None), Some((PixelFormat::Yuyv, 640, 480)));
        assert_eq!(
            choose(&offers, Some((1920, 1080))),
            Some((PixelFormat::Mjpeg, 1920, 1080))
        );
        assert_eq!(choose(&offers, Some((800, 600))), None);
        assert_eq!(
            choose(&[offer(b"GREY", 640, 480), offer(b"RGB3", 640, 480)], None),
            Some((PixelFormat::Rgb3, 640, 480))
        );
        assert_eq!(choose(&[offer(b"H264", 640, 480)], None), None);
    }

    #[test]
    fn sizes() {
        assert_eq!(PixelFormat::Yuyv.frame_len(480, 1280), Some(614_400));
        assert_eq!(PixelFormat::Nv12.frame_len(480, 640), Some(460_800));
        assert_eq!(PixelFormat::Nv12.frame_len(3, 4), Some(20));
        assert_eq!(PixelFormat::Mjpeg.frame_len(480, 0), None);
        for f in PixelFormat::PREFERENCE {
            assert_eq!(PixelFormat::from_fourcc(f.fourcc()), Some(f));
        }
    }
}
