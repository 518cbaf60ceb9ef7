//! Conversion against OpenCV's golden values, and MJPEG as webcams send it.

// Test helpers too may stop a test loudly.
#![allow(clippy::unwrap_used)]

use aibr_v4l::{PixelFormat, RawFrame, to_rgb};
use image::RgbImage;
use proptest::prelude::*;

fn golden() -> serde_json::Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../fixtures/v4l/yuv_golden.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn bytes(v: &serde_json::Value) -> Vec<u8> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as u8)
        .collect()
}

#[test]
fn yuyv_and_nv12_match_opencv_byte_for_byte() {
    let g = golden();
    let (w, h) = (
        g["width"].as_u64().unwrap() as u32,
        g["height"].as_u64().unwrap() as u32,
    );
    for (format, input, output) in [
        (PixelFormat::Yuyv, "yuyv", "rgb_from_yuyv"),
        (PixelFormat::Nv12, "nv12", "rgb_from_nv12"),
    ] {
        let data = bytes(&g[input]);
        let mut out = RgbImage::new(0, 0);
        to_rgb(
            &RawFrame {
                format,
                width: w,
                height: h,
                stride: 0,
                data: &data,
            },
            &mut out,
        )
        .unwrap();
        let expected = bytes(&g[output]);
        let diff = out
            .as_raw()
            .iter()
            .zip(&expected)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            diff, 0,
            "{format}: {diff} bytes differ from OpenCV {}",
            g["opencv"]
        );
    }
}

#[test]
fn padded_lines_give_the_same_image() {
    let g = golden();
    let data = bytes(&g["yuyv"]);
    let (w, h) = (16usize, 8usize);
    let stride = 2 * w + 12;
    let mut padded = vec![0xAA; stride * h];
    for r in 0..h {
        padded[r * stride..r * stride + 2 * w].copy_from_slice(&data[r * 2 * w..(r + 1) * 2 * w]);
    }
    let (mut a, mut b) = (RgbImage::new(0, 0), RgbImage::new(0, 0));
    to_rgb(
        &RawFrame {
            format: PixelFormat::Yuyv,
            width: 16,
            height: 8,
            stride: 0,
            data: &data,
        },
        &mut a,
    )
    .unwrap();
    to_rgb(
        &RawFrame {
            format: PixelFormat::Yuyv,
            width: 16,
            height: 8,
            stride,
            data: &padded,
        },
        &mut b,
    )
    .unwrap();
    assert_eq!(a, b);
}

fn test_image() -> RgbImage {
    RgbImage::from_fn(64, 48, |x, y| {
        image::Rgb([(x * 4) as u8, (y * 5) as u8, ((x + y) * 2) as u8])
    })
}

fn jpeg(img: &RgbImage) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 95)
        .encode_image(img)
        .unwrap();
    out
}

/// Removes the Huffman tables (DHT segments), as many webcams' MJPEG frames come.
fn without_dht(jpeg: &[u8]) -> Vec<u8> {
    let mut out = jpeg[..2].to_vec();
    let mut i = 2;
    while i + 4 <= jpeg.len() && jpeg[i] == 0xFF {
        let marker = jpeg[i + 1];
        let len = u16::from_be_bytes([jpeg[i + 2], jpeg[i + 3]]) as usize;
        if marker == 0xDA {
            out.extend_from_slice(&jpeg[i..]);
            return out;
        }
        if marker != 0xC4 {
            out.extend_from_slice(&jpeg[i..i + 2 + len]);
        }
        i += 2 + len;
    }
    out
}

fn mean_abs_diff(a: &RgbImage, b: &RgbImage) -> f64 {
    a.as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| (*x as f64 - *y as f64).abs())
        .sum::<f64>()
        / a.as_raw().len() as f64
}

#[test]
fn mjpeg_frames_decode() {
    let img = test_image();
    let data = jpeg(&img);
    let mut out = RgbImage::new(0, 0);
    to_rgb(
        &RawFrame {
            format: PixelFormat::Mjpeg,
            width: 64,
            height: 48,
            stride: 0,
            data: &data,
        },
        &mut out,
    )
    .unwrap();
    assert!(mean_abs_diff(&img, &out) < 2.0);
    // A frame of the wrong size is an error, not a silently different image.
    let r = to_rgb(
        &RawFrame {
            format: PixelFormat::Mjpeg,
            width: 32,
            height: 48,
            stride: 0,
            data: &data,
        },
        &mut out,
    );
    assert!(r.is_err());
}

#[test]
fn mjpeg_frames_without_huffman_tables_decode() {
    // The encoder writes the standard tables, which are also what MJPEG decoders assume
    // when a frame has none.
    let img = test_image();
    let stripped = without_dht(&jpeg(&img));
    let mut out = RgbImage::new(0, 0);
    to_rgb(
        &RawFrame {
            format: PixelFormat::Mjpeg,
            width: 64,
            height: 48,
            stride: 0,
            data: &stripped,
        },
        &mut out,
    )
    .unwrap();
    assert!(mean_abs_diff(&img, &out) < 2.0);
}

proptest! {
    #[test]
    fn conversion_never_panics(w in 0u32..40, h in 0u32..40, stride in 0usize..200, data in prop::collection::vec(any::<u8>(), 0..6000), f in 0usize..5) {
        let format = PixelFormat::PREFERENCE[f];
        let mut out = RgbImage::new(0, 0);
        if to_rgb(&RawFrame { format, width: w, height: h, stride, data: &data }, &mut out).is_ok() {
            prop_assert_eq!(out.dimensions(), (w, h));
        }
    }
}
