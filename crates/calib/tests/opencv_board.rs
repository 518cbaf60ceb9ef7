//! Detection and calibration on OpenCV's sample chessboard set, against OpenCV's own answers
//! (`fixtures/calib/opencv_golden.py` made them).

// Test helpers too may stop a test loudly.
#![allow(clippy::panic)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use aibr_calib::{BoardDetection, BoardSpec, DetectorParams, detect_board};
use serde_json::Value;

fn golden() -> Value {
    let path = aibr_testdata::workspace_root().join("fixtures/calib/opencv_golden.json");
    let text = std::fs::read_to_string(&path).unwrap_or_default();
    serde_json::from_str(&text).unwrap_or(Value::Null)
}

/// The set's folder, or `None` (with a note) when the data is not here.
fn set() -> Option<PathBuf> {
    aibr_testdata::dataset("opencv-chessboard-9x6")
}

/// The 13 image names, in the golden file's order.
fn image_names(g: &Value) -> Vec<String> {
    g["images"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|v| v.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

fn board() -> BoardSpec {
    BoardSpec::new(9, 6, 0.03).unwrap_or_else(|e| panic!("{e}"))
}

fn grey(dir: &Path, name: &str) -> image::GrayImage {
    image::open(dir.join(name))
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .to_luma8()
}

/// The boards of all 13 images, detected once per test process.
fn views(dir: &Path) -> &'static [BoardDetection] {
    static VIEWS: OnceLock<Vec<BoardDetection>> = OnceLock::new();
    VIEWS.get_or_init(|| {
        image_names(&golden())
            .iter()
            .map(|name| {
                detect_board(&grey(dir, name), &board(), &DetectorParams::default())
                    .unwrap_or_else(|e| panic!("{name}: {e}"))
            })
            .collect()
    })
}

#[test]
fn detects_all_13_boards_like_opencv() {
    let Some(dir) = set() else { return };
    let g = golden();
    let names = image_names(&g);
    assert_eq!(names.len(), 13);
    let mut worst = 0.0f64;
    let mut sum2 = 0.0;
    let mut n = 0;
    for (name, det) in names.iter().zip(views(&dir)) {
        let theirs: Vec<(f64, f64)> = g["corners_5x5"][name]
            .as_array()
            .map(|a| {
                a.iter()
                    .map(|p| {
                        (
                            p[0].as_f64().unwrap_or(f64::NAN),
                            p[1].as_f64().unwrap_or(f64::NAN),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default();
        assert_eq!(det.corners.len(), 54);
        for c in &det.corners {
            let d = theirs
                .iter()
                .map(|&(x, y)| ((c.x - x).powi(2) + (c.y - y).powi(2)).sqrt())
                .fold(f64::MAX, f64::min);
            worst = worst.max(d);
            sum2 += d * d;
            n += 1;
        }
    }
    eprintln!(
        "corner distance to OpenCV: rms {:.4} px, worst {:.4} px",
        (sum2 / n as f64).sqrt(),
        worst
    );
    assert!(worst < 0.02, "worst corner {worst} px from OpenCV's");
}

#[test]
fn calibration_agrees_with_opencv() {
    let Some(dir) = set() else { return };
    let g = golden();
    let board = board();
    let views = views(&dir);
    let t0 = std::time::Instant::now();
    let cal = aibr_calib::calibrate_intrinsics(&board, views, &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "calibration {:?}, {} iterations",
        t0.elapsed(),
        cal.iterations
    );
    let o = &g["window_5x5"];
    let f = |k: &str| o[k].as_f64().unwrap_or(f64::NAN);
    let i = cal.intrinsics;
    eprintln!(
        "ours   fx {:.4} fy {:.4} cx {:.4} cy {:.4} rms {:.4} dist {:?}",
        i.fx,
        i.fy,
        i.cx,
        i.cy,
        cal.rms,
        cal.distortion.to_array()
    );
    eprintln!(
        "opencv fx {:.4} fy {:.4} cx {:.4} cy {:.4} rms {:.4} dist {}",
        f("fx"),
        f("fy"),
        f("cx"),
        f("cy"),
        f("rms"),
        o["distortion"]
    );
    eprintln!("std ours {:?}\nstd opencv {}", cal.std, o["std_intrinsics"]);
    for v in &cal.views {
        eprintln!(
            "view {} rms {:.4} (opencv {:.4}){}",
            v.index,
            v.rms,
            o["per_view_rms"][v.index].as_f64().unwrap_or(f64::NAN),
            if v.outlier { " outlier" } else { "" }
        );
    }
    assert!(
        (i.fx / f("fx") - 1.0).abs() < 0.005,
        "fx {} vs {}",
        i.fx,
        f("fx")
    );
    assert!(
        (i.fy / f("fy") - 1.0).abs() < 0.005,
        "fy {} vs {}",
        i.fy,
        f("fy")
    );
    assert!((i.cx - f("cx")).abs() < 1.0, "cx {} vs {}", i.cx, f("cx"));
    assert!((i.cy - f("cy")).abs() < 1.0, "cy {} vs {}", i.cy, f("cy"));
    assert!(cal.rms <= 0.25, "rms {}", cal.rms);
}

#[test]
fn standard_deviations_and_per_view_errors_match_opencv() {
    let Some(dir) = set() else { return };
    let g = golden();
    let board = board();
    let views = views(&dir);
    let cal = aibr_calib::calibrate_intrinsics(&board, views, &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let o = &g["window_5x5"];
    let theirs: Vec<f64> = o["std_intrinsics"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_f64()).collect())
        .unwrap_or_default();
    let s = cal.std;
    let ours = [
        s.fx,
        s.fy,
        s.cx,
        s.cy,
        s.distortion[0],
        s.distortion[1],
        s.distortion[2],
        s.distortion[3],
        s.distortion[4],
    ];
    assert_eq!(theirs.len(), 9);
    for (k, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert!((a / b - 1.0).abs() < 0.02, "std {k}: {a} vs OpenCV {b}");
    }
    for v in &cal.views {
        let theirs = o["per_view_rms"][v.index].as_f64().unwrap_or(f64::NAN);
        assert!(
            (v.rms - theirs).abs() < 0.005,
            "view {}: {} vs {}",
            v.index,
            v.rms,
            theirs
        );
        assert!(!v.outlier);
    }
}

#[test]
fn reads_the_sample_output_of_opencv() {
    let Some(dir) = set() else { return };
    let c = aibr_calib::CameraFile::read(&dir.join("left_intrinsics.yml"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((c.image_size.width, c.image_size.height), (640, 480));
    assert!((c.intrinsics.fx - 535.916).abs() < 1e-3 && (c.intrinsics.cx - 342.283).abs() < 1e-3);
    assert!((c.distortion.k1 + 0.26637).abs() < 1e-5);
}
