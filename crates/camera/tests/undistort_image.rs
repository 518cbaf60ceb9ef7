//! Undistorting a whole image with the precomputed remap gives the pinhole image.

use aibr_camera::{Camera, Distortion, Error, ImageSize, Intrinsics, UndistortMap};
use image::{ImageBuffer, Luma, Rgb, RgbImage};
use nalgebra::{Isometry3, Point2};

fn pattern(n: Point2<f64>) -> f64 {
    127.5 + 100.0 * (9.0 * n.x).sin() * (7.0 * n.y).cos()
}

fn webcam() -> Camera {
    Camera {
        intrinsics: Intrinsics::new(536.0, 536.0, 342.3, 235.5),
        distortion: Distortion {
            k1: -0.27,
            k2: -0.04,
            p1: 0.0018,
            p2: -0.0003,
            k3: 0.24,
        },
        cam_from_world: Isometry3::identity(),
        size: ImageSize::new(640, 480),
    }
}

#[test]
fn remap_gives_the_pinhole_image() -> Result<(), Error> {
    let cam = webcam();
    // What the distorted camera sees of a smooth pattern on the normalised plane.
    let distorted: ImageBuffer<Luma<f32>, Vec<f32>> = ImageBuffer::from_fn(640, 480, |u, v| {
        let n = cam.normalized_from_pixel(Point2::new(u as f64, v as f64));
        Luma([n.map_or(0.0, pattern) as f32])
    });
    let map = UndistortMap::new(&cam);
    let out = map.apply(&distorted)?;
    let (mut sum, mut worst, mut count) = (0.0, 0.0f64, 0usize);
    for (u, v, p) in out.enumerate_pixels() {
        if map.source_of(u, v).is_none() {
            assert_eq!(p.0[0], 0.0, "pixels that see past the source are zero");
            continue;
        }
        let truth = pattern(
            cam.intrinsics
                .normalized_from_pixel(Point2::new(u as f64, v as f64)),
        );
        let e = (p.0[0] as f64 - truth).abs();
        sum += e;
        worst = worst.max(e);
        count += 1;
    }
    let mean = sum / count as f64;
    // Bilinear interpolation of a pattern with a period of ~40 px: errors well under a grey
    // level on average.
    assert!(count > 250_000, "{count} valid pixels");
    assert!(mean < 0.1 && worst < 1.0, "mean {mean}, worst {worst}");
    Ok(())
}

#[test]
fn eight_bit_rgb_and_reuse() -> Result<(), Error> {
    let cam = webcam();
    let map = UndistortMap::new(&cam);
    let src: RgbImage = ImageBuffer::from_fn(640, 480, |u, v| {
        Rgb([(u % 256) as u8, (v % 256) as u8, 200])
    });
    let mut dst = RgbImage::new(640, 480);
    // One map, many frames, no allocation per frame.
    for _ in 0..2 {
        map.apply_into(&src, &mut dst)?;
    }
    let centre = dst.get_pixel(342, 235);
    assert_eq!(
        centre.0,
        [86, 235, 200],
        "the principal point does not move"
    );
    Ok(())
}

#[test]
fn wrong_size_is_an_error() {
    let map = UndistortMap::new(&webcam());
    let small: RgbImage = RgbImage::new(320, 240);
    match map.apply(&small) {
        Err(Error::ImageSize {
            expected_width: 640,
            actual_width: 320,
            ..
        }) => {}
        other => panic!("expected a size error, got {:?}", other.map(|_| ())),
    }
}
