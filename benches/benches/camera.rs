//! Camera benches: projection, pixel-to-ray (Newton undistortion) and the undistortion remap.

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_benches::webcam_on_ring;
use aibr_camera::{Angle, UndistortMap};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use image::{ImageBuffer, Rgb, RgbImage};
use nalgebra::{Point2, Point3};
use std::hint::black_box;

fn camera(c: &mut Criterion) {
    let Ok(cam) = webcam_on_ring(Angle::from_degrees(20.0)) else {
        return;
    };
    let points: Vec<Point3<f64>> = (0..10_000)
        .map(|i| {
            let t = i as f64 * 0.001;
            Point3::new(
                0.1 * (7.0 * t).sin(),
                0.1 * (5.0 * t).cos(),
                0.1 * (3.0 * t).sin(),
            )
        })
        .collect();
    let pixels: Vec<Point2<f64>> = (0..10_000)
        .map(|i| Point2::new((i % 640) as f64, ((i * 7) % 480) as f64))
        .collect();

    let mut g = c.benchmark_group("camera");
    g.throughput(Throughput::Elements(points.len() as u64));
    g.bench_function("project_10k", |b| {
        b.iter(|| {
            points
                .iter()
                .filter_map(|p| cam.project(black_box(p)))
                .count()
        })
    });
    g.bench_function("ray_through_pixel_10k", |b| {
        b.iter(|| {
            pixels
                .iter()
                .filter_map(|p| cam.ray_through_pixel(black_box(*p)))
                .count()
        })
    });

    let src: RgbImage =
        ImageBuffer::from_fn(640, 480, |u, v| Rgb([(u % 256) as u8, (v % 256) as u8, 77]));
    let mut dst = RgbImage::new(640, 480);
    g.throughput(Throughput::Elements(640 * 480));
    g.bench_function("undistort_map_build_vga", |b| {
        b.iter(|| UndistortMap::new(black_box(&cam)))
    });
    let map = UndistortMap::new(&cam);
    g.bench_function("undistort_apply_vga_rgb8", |b| {
        b.iter(|| map.apply_into(black_box(&src), &mut dst))
    });
    g.finish();
}

criterion_group!(benches, camera);
criterion_main!(benches);
