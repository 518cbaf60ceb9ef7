//! Calibration benches on OpenCV's 13-image sample set (9x6 inner corners): board
//! detection with sub-pixel corners, and intrinsic calibration, to compare with OpenCV's
//! findChessboardCorners + cornerSubPix + calibrateCamera on the same images
//! (`fixtures/calib/opencv_golden.py` times those). Images are decoded before timing, as
//! OpenCV's timings exclude imread. Skipped when the data set is not present.

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_calib::{BoardDetection, BoardSpec, DetectorParams, calibrate_intrinsics, detect_board};
use criterion::{Criterion, criterion_group, criterion_main};
use rayon::prelude::*;
use std::hint::black_box;

fn calibration(c: &mut Criterion) {
    let Some(dir) = aibr_testdata::dataset("opencv-chessboard-9x6") else {
        eprintln!("calibration benches skipped: opencv-chessboard-9x6 is not in AIBR_DATA_DIR");
        return;
    };
    let Ok(board) = BoardSpec::new(9, 6, 0.03) else {
        return;
    };
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("left"))
                && p.extension().is_some_and(|e| e == "jpg")
        })
        .collect();
    names.sort();
    let images: Vec<image::GrayImage> = names
        .iter()
        .filter_map(|p| image::open(p).ok())
        .map(|i| i.to_luma8())
        .collect();
    let params = DetectorParams::default();
    let detect_all = || -> Vec<BoardDetection> {
        images
            .par_iter()
            .filter_map(|i| detect_board(i, &board, &params).ok())
            .collect()
    };
    let detections = detect_all();
    if detections.len() != 13 {
        eprintln!(
            "calibration benches skipped: {} of 13 boards found",
            detections.len()
        );
        return;
    }
    let mut group = c.benchmark_group("calibration");
    group.sample_size(30);
    group.bench_function("detect_13", |b| b.iter(|| black_box(detect_all())));
    group.bench_function("calibrate_13", |b| {
        b.iter(|| black_box(calibrate_intrinsics(&board, &detections, &Default::default()).ok()))
    });
    group.bench_function("detect_and_calibrate_13", |b| {
        b.iter(|| {
            let d = detect_all();
            black_box(calibrate_intrinsics(&board, &d, &Default::default()).ok())
        })
    });
    group.finish();
}

criterion_group!(benches, calibration);
criterion_main!(benches);
