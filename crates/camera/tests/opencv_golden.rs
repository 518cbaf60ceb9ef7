//! Agreement with OpenCV on fixed inputs. The golden values and the script that made them are
//! in `fixtures/opencv/` (`camera_golden.py`).

#![allow(clippy::panic, clippy::expect_used)]

use aibr_camera::{Camera, Distortion, ImageSize, Intrinsics, UndistortMap, decompose_projection};
use nalgebra::{Isometry3, Matrix3, Matrix3x4, Point2, Point3, Vector3};
use serde_json::Value;

fn golden() -> Value {
    let path = aibr_testdata::workspace_root().join("fixtures/opencv/camera_golden.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).expect("golden file is JSON")
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("number")
}

fn vec(v: &Value) -> Vec<f64> {
    v.as_array().expect("array").iter().map(f).collect()
}

fn rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().expect("array").iter().map(vec).collect()
}

fn lens(g: &Value) -> (Intrinsics, Distortion, ImageSize) {
    let k = rows(&g["K"]);
    let k = Matrix3::from_fn(|r, c| k[r][c]);
    let size = vec(&g["size"]);
    (
        Intrinsics::from_matrix(&k).expect("K"),
        Distortion::from_opencv(&vec(&g["dist"])).expect("dist"),
        ImageSize::new(size[0] as u32, size[1] as u32),
    )
}

#[test]
fn project_points_matches_opencv() {
    let g = golden();
    let (k, d, size) = lens(&g);
    let p = &g["project"];
    let pose = Isometry3::new(
        Vector3::from_vec(vec(&p["tvec"])),
        Vector3::from_vec(vec(&p["rvec"])),
    );
    let cam = Camera::new(k, d, pose, size).expect("camera");
    let mut worst = 0.0f64;
    for (pt, px) in rows(&p["points"]).iter().zip(rows(&p["pixels"])) {
        let ours = cam
            .project(&Point3::new(pt[0], pt[1], pt[2]))
            .expect("in front");
        worst = worst.max((ours - Point2::new(px[0], px[1])).norm());
    }
    assert!(worst < 1e-9, "worst difference {worst} px");
}

#[test]
fn undistort_points_matches_opencv_to_the_corners() {
    let g = golden();
    let (k, d, size) = lens(&g);
    let cam = Camera::new(k, d, Isometry3::identity(), size).expect("camera");
    let u = &g["undistort"];
    let reproj = vec(&u["opencv_reprojection_px"]);
    let mut compared = 0;
    for ((px, n), e) in rows(&u["pixels"])
        .iter()
        .zip(rows(&u["normalized"]))
        .zip(reproj)
    {
        let ours = cam
            .normalized_from_pixel(Point2::new(px[0], px[1]))
            .expect("converges");
        // Our answer reprojects to the pixel...
        let back = cam
            .project(&Point3::new(ours.x, ours.y, 1.0))
            .expect("in front");
        assert!((back - Point2::new(px[0], px[1])).norm() < 1e-9, "{px:?}");
        // ...and agrees with OpenCV's wherever OpenCV's iteration converged.
        if e < 1e-9 {
            assert!((ours - Point2::new(n[0], n[1])).norm() < 1e-10, "{px:?}");
            compared += 1;
        }
    }
    assert!(compared >= 60, "only {compared} converged OpenCV points");
}

#[test]
fn undistort_map_matches_init_undistort_rectify_map() {
    let g = golden();
    let (k, d, size) = lens(&g);
    let cam = Camera::new(k, d, Isometry3::identity(), size).expect("camera");
    let map = UndistortMap::new(&cam);
    let mut compared = 0;
    for s in rows(&g["remap"]) {
        let (u, v, mx, my) = (s[0] as u32, s[1] as u32, s[2], s[3]);
        let inside = mx >= -0.5 && my >= -0.5 && mx <= 639.5 && my <= 479.5;
        match map.source_of(u, v) {
            Some(p) if inside => {
                // OpenCV's map is f32; on the outermost pixels ours is clamped to the image.
                let (cx, cy) = (mx.clamp(0.0, 639.0), my.clamp(0.0, 479.0));
                assert!(
                    (p.x as f64 - cx).abs() < 2e-3 && (p.y as f64 - cy).abs() < 2e-3,
                    "({u},{v}): ours {p}, OpenCV ({mx},{my})"
                );
                compared += 1;
            }
            None => assert!(!inside, "({u},{v}) maps to ({mx},{my}) inside the image"),
            Some(p) => panic!("({u},{v}): ours {p} but OpenCV ({mx},{my}) is off the image"),
        }
    }
    assert!(compared > 60);
}

#[test]
fn decompose_projection_matches_opencv() {
    let g = golden();
    for case in g["decompose"].as_array().expect("cases") {
        let p = rows(&case["P"]);
        let p = Matrix3x4::from_fn(|r, c| p[r][c]);
        let ours = decompose_projection(&p).expect("decomposes");
        // OpenCV leaves negative focal lengths when P has a negative scale; ours are fixed
        // positive. Map OpenCV's answer to that convention: K D and D R, D = diag(sign K_ii).
        let k = rows(&case["K"]);
        let r = rows(&case["R"]);
        let sign: Vec<f64> = (0..3).map(|i| k[i][i].signum()).collect();
        let k: Vec<Vec<f64>> = (0..3)
            .map(|i| (0..3).map(|j| k[i][j] * sign[j]).collect())
            .collect();
        let r: Vec<Vec<f64>> = (0..3)
            .map(|i| (0..3).map(|j| r[i][j] * sign[i]).collect())
            .collect();
        let c = vec(&case["centre"]);
        let km = ours.intrinsics.matrix();
        let rm = ours.cam_from_world.rotation.to_rotation_matrix();
        for i in 0..3 {
            for j in 0..3 {
                assert!((km[(i, j)] - k[i][j]).abs() < 1e-7 * k[0][0], "K[{i}][{j}]");
                assert!((rm[(i, j)] - r[i][j]).abs() < 1e-9, "R[{i}][{j}]");
            }
        }
        let centre = ours
            .cam_from_world
            .inverse_transform_point(&Point3::origin());
        assert!((centre - Point3::new(c[0], c[1], c[2])).norm() < 1e-9);
    }
}
