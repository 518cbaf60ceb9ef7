//! `aibr calibrate` end to end: OpenCV's sample set, bad input, and a synthetic turntable.

mod common;
use common::*;

use std::path::{Path, PathBuf};
use std::process::Output;

use aibr::calib::CameraFile;
use aibr::camera::{Angle, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange};
use aibr::scene::{RenderOptions, SceneRig};

fn run(args: &[&str]) -> std::io::Result<Output> {
    aibr().args(args).output()
}

/// `aibr calibrate intrinsics --square-mm 30 -o OUTPUT ARGS...` must fail and say `reason`.
fn refused(output: &str, args: &[&str], reason: &str) -> TestResult {
    let mut all = vec!["calibrate", "intrinsics", "--square-mm", "30", "-o", output];
    all.extend_from_slice(args);
    let o = run(&all)?;
    assert!(
        !o.status.success() && text(&o).contains(reason),
        "{}",
        text(&o)
    );
    Ok(())
}

/// A fresh, empty folder.
fn folder(name: &str) -> std::io::Result<PathBuf> {
    let dir = temp(&format!("calib-{name}"));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn sample_images() -> Option<Vec<String>> {
    let dir = aibr_testdata::dataset("opencv-chessboard-9x6")?;
    let mut v: Vec<String> = std::fs::read_dir(&dir)
        .ok()?
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "jpg"))
        .map(|p| p.display().to_string())
        .collect();
    v.sort();
    Some(v)
}

#[test]
fn intrinsics_on_the_opencv_sample_set() -> TestResult {
    let Some(images) = sample_images() else {
        return Ok(());
    };
    let dir = folder("intrinsics")?;
    // A picture with no board is rejected with its reason; the rest calibrate.
    let blank = dir.join("blank.png");
    image::GrayImage::from_pixel(640, 480, image::Luma([120])).save(&blank)?;
    let out = dir.join("camera.yml");
    let mut args = vec![
        "calibrate",
        "intrinsics",
        "--board",
        "9x6",
        "--square-mm",
        "30",
        "-o",
    ];
    let out_s = out.display().to_string();
    let blank_s = blank.display().to_string();
    args.push(&out_s);
    args.push("--json");
    args.extend(images.iter().map(String::as_str));
    args.push(&blank_s);
    let o = run(&args)?;
    assert_success(&o);
    let r: serde_json::Value = serde_json::from_slice(&o.stdout)?;
    assert_eq!(r["views"].as_array().map(Vec::len), Some(13));
    assert_eq!(r["rejected"][0]["image"].as_str(), Some(blank_s.as_str()));
    assert!(
        r["rejected"][0]["reason"]
            .as_str()
            .is_some_and(|s| s.contains("no checkerboard corners"))
    );
    // OpenCV's calibrateCamera on the same images (fixtures/calib/opencv_golden.json).
    let fx = r["fx"].as_f64().unwrap_or(0.0);
    assert!((fx / 532.8268 - 1.0).abs() < 0.005, "fx {fx}");
    assert!(r["rms"].as_f64().is_some_and(|v| v <= 0.25), "{}", r["rms"]);
    let file = CameraFile::read(&out)?;
    assert_eq!(file.intrinsics.fx, fx);
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn bad_sets_are_refused_with_reasons() -> TestResult {
    let Some(images) = sample_images() else {
        return Ok(());
    };
    let dir = folder("bad")?;
    let out = dir.join("camera.yml").display().to_string();
    // Too few views.
    refused(&out, &[&images[0], &images[1]], "at least 3")?;
    // Images of different sizes: the odd one is named.
    let small = dir.join("small.png");
    image::open(&images[2])?
        .resize_exact(320, 240, image::imageops::FilterType::Triangle)
        .save(&small)?;
    let small_s = small.display().to_string();
    refused(
        &out,
        &[&images[0], &images[1], &images[3], &small_s],
        "small.png is 320x240",
    )?;
    // A missing file, a bad board, a bad output format.
    refused(&out, &["/nonexistent/x.png"], "/nonexistent/x.png")?;
    refused(&out, &["--board", "9by6", &images[0]], "9by6")?;
    let txt = dir.join("camera.txt").display().to_string();
    refused(&txt, &[&images[0]], ".yml, .yaml or .json")?;
    assert!(!Path::new(&out).exists(), "nothing is written on failure");
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

#[test]
fn turntable_from_rendered_boards() -> TestResult {
    let dir = folder("turntable")?;
    let intrinsics = Intrinsics::new(820.0, 815.0, 331.0, 244.0);
    let distortion = Distortion {
        k1: -0.25,
        k2: 0.08,
        p1: 0.0,
        p2: 0.0,
        k3: 0.0,
    };
    let size = ImageSize::new(640, 480);
    let rig = SceneRig {
        intrinsics,
        distortion,
        size,
        ring: CircularMotion::ring(0.42, 0.40, 0.0)?,
        pan_range: PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?,
    };
    let scene = aibr::scene::catalogue::checkerboard(10, 7, 0.025, rig)?;
    let camera = dir.join("camera.yml");
    let file = CameraFile {
        image_size: size,
        intrinsics,
        distortion,
        rms: None,
    };
    std::fs::write(&camera, file.to_text(aibr::calib::Format::Yaml)?)?;
    let mut views = Vec::new();
    for (i, deg) in [-150.0, -110.0, -70.0, -30.0, 10.0, 50.0, 90.0, 130.0]
        .iter()
        .enumerate()
    {
        let cam = scene.camera(Angle::from_degrees(*deg))?;
        let frame = scene.render(
            &cam,
            &RenderOptions {
                noise_sigma: 2.0 / 255.0,
                seed: i as u64,
            },
        )?;
        let path = dir.join(format!("board_{i}.png"));
        image::DynamicImage::ImageRgb8(frame.rgb8())
            .to_luma8()
            .save(&path)?;
        views.push(format!("{}@{deg}", path.display()));
    }
    let rig_json = dir.join("rig.json");
    let (camera_s, rig_s) = (camera.display().to_string(), rig_json.display().to_string());
    let mut args = vec![
        "calibrate",
        "turntable",
        "--board",
        "9x6",
        "--square-mm",
        "25",
        "--camera",
        &camera_s,
        "-o",
        &rig_s,
        "--json",
    ];
    args.extend(views.iter().map(String::as_str));
    let o = run(&args)?;
    assert_success(&o);
    let r: serde_json::Value = serde_json::from_slice(&o.stdout)?;
    let radius = r["camera_radius_m"].as_f64().unwrap_or(0.0);
    let height = r["camera_height_m"].as_f64().unwrap_or(0.0);
    assert!(
        (radius - 0.42).abs() < 1e-3 && (height - 0.40).abs() < 1e-3,
        "radius {radius}, height {height}"
    );
    let worst = r["left_out"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|l| l["reprojection_px"].as_f64())
                .fold(0.0, f64::max)
        })
        .unwrap_or(f64::NAN);
    assert!(worst < 0.5, "worst left-out prediction {worst} px");
    // The rig file is what `aibr capture --calibration` reads.
    let record: aibr::session::CalibrationRecord =
        serde_json::from_str(&std::fs::read_to_string(&rig_json)?)?;
    let calibration = record.calibration()?;
    assert_eq!(calibration.camera.intrinsics, intrinsics);
    // A view given without its angle is refused.
    let o = run(&[
        "calibrate",
        "turntable",
        "--square-mm",
        "25",
        "--camera",
        &camera_s,
        "-o",
        &rig_s,
        "board.png",
    ])?;
    assert!(
        !o.status.success() && text(&o).contains("IMAGE@DEGREES"),
        "{}",
        text(&o)
    );
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}
