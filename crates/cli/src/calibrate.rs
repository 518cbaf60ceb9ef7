//! `aibr calibrate`: intrinsics and the turntable from checkerboard images.

use std::path::{Path, PathBuf};
use std::time::Instant;

use aibr::calib::{
    BoardDetection, BoardSpec, CameraFile, DetectorParams, Error as CalibError, Format,
    IntrinsicOptions, PanView, PatternSize, SubPixParams, calibrate_intrinsics,
    calibrate_turntable, detect_board,
};
use aibr::camera::{Angle, Camera, PanRange};
use anyhow::{Context, Result, bail};
use rayon::prelude::*;
use serde_json::json;

#[derive(clap::Subcommand)]
pub(crate) enum CalibrateCommand {
    /// Intrinsics and lens distortion from images of a checkerboard held at different tilts
    /// (Zhang's closed form, then Levenberg-Marquardt). Writes OpenCV YAML (.yml) or JSON
    /// (.json); prints the parameters with their standard deviations and each image's error.
    Intrinsics(IntrinsicsArgs),
    /// The camera's motion about the pan axis from images of a board lying on the turntable
    /// at several pan angles. Writes the rig calibration that `aibr capture --calibration`
    /// takes; prints each position's error, the fitted circle's residuals and how well each
    /// position is predicted from the others.
    Turntable(TurntableArgs),
}

#[derive(clap::Args)]
pub(crate) struct BoardArgs {
    /// Inner corners of the board, columns x rows.
    #[arg(long, default_value = "9x6")]
    board: PatternSize,
    /// Side of a square, millimetres.
    #[arg(long, value_name = "MM")]
    square_mm: f64,
    /// Half the side of the sub-pixel refinement window, pixels (5: an 11x11 window).
    #[arg(long, default_value_t = 5)]
    window: usize,
}

impl BoardArgs {
    fn spec(&self) -> Result<(BoardSpec, DetectorParams)> {
        let board = BoardSpec::new(self.board.cols, self.board.rows, self.square_mm * 1e-3)?;
        if !(1..=50).contains(&self.window) {
            bail!("--window {}: expected 1 to 50 pixels", self.window);
        }
        let params = DetectorParams {
            subpix: SubPixParams {
                half_window: self.window,
                ..Default::default()
            },
            ..Default::default()
        };
        Ok((board, params))
    }
}

#[derive(clap::Args)]
pub(crate) struct IntrinsicsArgs {
    /// The images (PNG, JPEG or PNM, all one size).
    #[arg(required = true)]
    images: Vec<PathBuf>,
    #[command(flatten)]
    board: BoardArgs,
    /// Where to write the calibration: .yml / .yaml (OpenCV FileStorage) or .json.
    #[arg(short, long)]
    output: PathBuf,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Estimate the skew too.
    #[arg(long)]
    skew: bool,
    /// Keep fy / fx at its closed-form value.
    #[arg(long)]
    fix_aspect: bool,
    /// Keep the principal point at the image centre.
    #[arg(long)]
    fix_principal_point: bool,
    /// Hold k3 at zero (advisable for lenses with little distortion or few views).
    #[arg(long)]
    fix_k3: bool,
    /// Hold p1 and p2 at zero.
    #[arg(long)]
    zero_tangent: bool,
}

#[derive(clap::Args)]
pub(crate) struct TurntableArgs {
    /// Board images with the pan angle each was taken at, as IMAGE@DEGREES
    /// (for example board_030.png@30).
    #[arg(required = true, value_name = "IMAGE@DEGREES")]
    views: Vec<String>,
    #[command(flatten)]
    board: BoardArgs,
    /// The camera's intrinsics: a file written by `aibr calibrate intrinsics` (.yml or .json).
    #[arg(long)]
    camera: PathBuf,
    /// The turntable's pan range in degrees, MIN:MAX (default: the span of the views).
    #[arg(long, value_name = "MIN:MAX", allow_hyphen_values = true)]
    range: Option<String>,
    /// Where to write the rig calibration (JSON, as session.json's "calibration" record).
    #[arg(short, long)]
    output: PathBuf,
    /// Print the result as JSON on stdout.
    #[arg(long)]
    json: bool,
}

pub(crate) fn run(command: CalibrateCommand) -> Result<()> {
    match command {
        CalibrateCommand::Intrinsics(a) => intrinsics(a),
        CalibrateCommand::Turntable(a) => turntable(a),
    }
}

/// The boards found in a set of images.
struct Detected {
    /// Index in the input of each image whose board was found.
    images: Vec<usize>,
    /// Their detections, in the same order.
    detections: Vec<BoardDetection>,
    /// The images rejected, with the reason.
    rejected: Vec<(PathBuf, String)>,
}

/// Reads every image and detects the board in it, in parallel. Unreadable files are errors;
/// images without the whole board are rejected with the reason (and said so on stderr).
fn detect_all(paths: &[PathBuf], board: &BoardSpec, params: &DetectorParams) -> Result<Detected> {
    let results: Vec<Result<_>> = paths
        .par_iter()
        .map(|path| {
            let image = image::open(path).with_context(|| format!("reading {}", path.display()))?;
            Ok(detect_board(&image.to_luma8(), board, params))
        })
        .collect();
    let mut found = Detected {
        images: Vec::new(),
        detections: Vec::new(),
        rejected: Vec::new(),
    };
    for (index, (path, result)) in paths.iter().zip(results).enumerate() {
        match result? {
            Ok(d) => {
                found.images.push(index);
                found.detections.push(d);
            }
            Err(reason) => {
                eprintln!("{}: rejected: {reason}", path.display());
                found.rejected.push((path.clone(), reason.to_string()));
            }
        }
    }
    Ok(found)
}

fn intrinsics(a: IntrinsicsArgs) -> Result<()> {
    let (board, params) = a.board.spec()?;
    let format = Format::of(&a.output)?;
    let t0 = Instant::now();
    let Detected {
        images: used,
        detections,
        rejected,
    } = detect_all(&a.images, &board, &params)?;
    let detect_s = t0.elapsed().as_secs_f64();
    if used.len() < 3 {
        bail!(
            "the board ({}) was found in {} of {} images; a calibration needs at least 3",
            a.board.board,
            used.len(),
            a.images.len()
        );
    }
    let options = IntrinsicOptions {
        estimate_skew: a.skew,
        fix_aspect_ratio: a.fix_aspect,
        fix_principal_point: a.fix_principal_point,
        fix_distortion: [false, false, a.zero_tangent, a.zero_tangent, a.fix_k3],
        ..Default::default()
    };
    let t1 = Instant::now();
    let image = |i: usize| &a.images[used[i]];
    let cal = match calibrate_intrinsics(&board, &detections, &options) {
        Ok(cal) => cal,
        // One image size per set, named by file.
        Err(CalibError::SizeMismatch {
            index,
            width,
            height,
            first_width,
            first_height,
        }) => bail!(
            "{} is {width}x{height} pixels but {} is {first_width}x{first_height}: one calibration needs one image size",
            image(index).display(),
            image(0).display()
        ),
        Err(e) => return Err(e).context("calibration failed"),
    };
    let calibrate_s = t1.elapsed().as_secs_f64();
    let file = CameraFile {
        image_size: cal.image_size,
        intrinsics: cal.intrinsics,
        distortion: cal.distortion,
        rms: Some(cal.rms),
    };
    aibr::write_atomic(&a.output, file.to_text(format)?.as_bytes())?;
    let i = cal.intrinsics;
    let s = cal.std;
    if a.json {
        let report = json!({
            "image_width": cal.image_size.width,
            "image_height": cal.image_size.height,
            "fx": i.fx, "fy": i.fy, "cx": i.cx, "cy": i.cy, "skew": i.skew,
            "distortion": cal.distortion.to_array(),
            "rms": cal.rms,
            "std": {"fx": s.fx, "fy": s.fy, "cx": s.cx, "cy": s.cy, "skew": s.skew, "distortion": s.distortion},
            "iterations": cal.iterations,
            "views": cal.views.iter().map(|v| json!({
                "image": image(v.index).display().to_string(),
                "rms": v.rms,
                "outlier": v.outlier,
            })).collect::<Vec<_>>(),
            "rejected": rejected_json(&rejected),
            "seconds": {"detect": detect_s, "calibrate": calibrate_s},
            "output": a.output.display().to_string(),
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!("{:<32} {:>10}", "image", "rms px");
    for v in &cal.views {
        let flag = if v.outlier { "  outlier" } else { "" };
        println!("{:<32} {:>10.4}{flag}", short(image(v.index)), v.rms);
    }
    for (p, r) in &rejected {
        println!("{:<32} rejected: {r}", short(p));
    }
    println!(
        "\n{} of {} images used, {} iterations",
        used.len(),
        a.images.len(),
        cal.iterations
    );
    println!(
        "fx {:.4} ± {:.4}   fy {:.4} ± {:.4}",
        i.fx, s.fx, i.fy, s.fy
    );
    println!(
        "cx {:.4} ± {:.4}   cy {:.4} ± {:.4}",
        i.cx, s.cx, i.cy, s.cy
    );
    if a.skew {
        println!("skew {:.5} ± {:.5}", i.skew, s.skew);
    }
    let d = cal.distortion.to_array();
    let names = ["k1", "k2", "p1", "p2", "k3"];
    let line: Vec<String> = names
        .iter()
        .zip(d.iter().zip(&s.distortion))
        .map(|(n, (v, e))| format!("{n} {v:.6} ± {e:.6}"))
        .collect();
    println!("{}", line.join("   "));
    println!(
        "rms reprojection error {:.4} px   (± are standard deviations)",
        cal.rms
    );
    println!(
        "detection {:.3} s, calibration {:.3} s; wrote {}",
        detect_s,
        calibrate_s,
        a.output.display()
    );
    Ok(())
}

/// The rejected images of a JSON report.
fn rejected_json(rejected: &[(PathBuf, String)]) -> serde_json::Value {
    rejected
        .iter()
        .map(|(p, r)| json!({"image": p.display().to_string(), "reason": r}))
        .collect()
}

fn short(p: &Path) -> String {
    p.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

/// `IMAGE@DEGREES`.
fn parse_view(s: &str) -> Result<(PathBuf, Angle)> {
    let (path, deg) = s
        .rsplit_once('@')
        .with_context(|| format!("{s:?}: expected IMAGE@DEGREES, like board_030.png@30"))?;
    let deg: f64 = deg
        .trim()
        .parse()
        .ok()
        .filter(|d: &f64| d.is_finite())
        .with_context(|| format!("{s:?}: {deg:?} is not an angle in degrees"))?;
    if path.is_empty() {
        bail!("{s:?}: no image before the @");
    }
    Ok((PathBuf::from(path), Angle::from_degrees(deg)))
}

fn parse_range(s: &str) -> Result<PanRange> {
    let (a, b) = s
        .split_once(':')
        .with_context(|| format!("--range {s:?}: expected MIN:MAX in degrees"))?;
    let degrees = |x: &str| -> Result<Angle> {
        let d: f64 = x
            .trim()
            .parse()
            .with_context(|| format!("--range {s:?}: {x:?} is not a number"))?;
        Ok(Angle::from_degrees(d))
    };
    Ok(PanRange::new(degrees(a)?, degrees(b)?)?)
}

fn turntable(a: TurntableArgs) -> Result<()> {
    let (board, params) = a.board.spec()?;
    let camera = CameraFile::read(&a.camera)?;
    let views: Vec<(PathBuf, Angle)> = a
        .views
        .iter()
        .map(|v| parse_view(v))
        .collect::<Result<_>>()?;
    let paths: Vec<PathBuf> = views.iter().map(|(p, _)| p.clone()).collect();
    let found = detect_all(&paths, &board, &params)?;
    let rejected = found.rejected;
    let used: Vec<&PathBuf> = found.images.iter().map(|&i| &paths[i]).collect();
    if let Some((p, d)) = used
        .iter()
        .zip(&found.detections)
        .find(|(_, d)| d.image_size != camera.image_size)
    {
        bail!(
            "{} is {}x{} pixels but the camera in {} was calibrated at {}x{}",
            p.display(),
            d.image_size.width,
            d.image_size.height,
            a.camera.display(),
            camera.image_size.width,
            camera.image_size.height
        );
    }
    let pan_views: Vec<PanView> = found
        .images
        .iter()
        .zip(found.detections)
        .map(|(&i, detection)| PanView {
            pan: views[i].1,
            detection,
        })
        .collect();
    let range = match &a.range {
        Some(r) => parse_range(r)?,
        None => {
            let pans = pan_views.iter().map(|v| v.pan.radians());
            let lo = pans.clone().fold(f64::INFINITY, f64::min);
            let hi = pans.fold(f64::NEG_INFINITY, f64::max);
            PanRange::new(Angle::from_radians(lo), Angle::from_radians(hi))
                .context("the views' pan angles do not form a range; give --range MIN:MAX")?
        }
    };
    let cal = calibrate_turntable(
        &board,
        &camera.intrinsics,
        &camera.distortion,
        &pan_views,
        range,
    )
    .context("turntable calibration failed")?;
    let rig = aibr::Calibration {
        camera: Camera::new(
            camera.intrinsics,
            camera.distortion,
            cal.fit.model.cam_from_world_at_zero,
            camera.image_size,
        )?,
        motion: cal.fit.model,
    };
    let record = aibr::session::CalibrationRecord::of(&rig);
    aibr::write_atomic(
        &a.output,
        format!("{}\n", serde_json::to_string_pretty(&record)?).as_bytes(),
    )?;
    let c0 = cal.fit.model.centre_at_zero();
    if a.json {
        let report = json!({
            "positions": cal.poses.iter().zip(&used).zip(&cal.fit.residuals).map(|((p, img), r)| json!({
                "image": img.display().to_string(),
                "pan_deg": p.pan.degrees(),
                "rms_px": p.rms,
                "circle_residual_mm": r.centre_m * 1e3,
                "circle_residual_deg": r.rotation.degrees(),
            })).collect::<Vec<_>>(),
            "left_out": cal.left_out.iter().map(|l| json!({
                "pan_deg": l.pan.degrees(),
                "reprojection_px": l.reprojection_px,
                "centre_mm": l.centre_m * 1e3,
                "rotation_deg": l.rotation.degrees(),
            })).collect::<Vec<_>>(),
            "rejected": rejected_json(&rejected),
            "circle_rms_mm": cal.fit.rms_centre_m() * 1e3,
            "circle_rms_deg": cal.fit.rms_rotation().degrees(),
            "camera_radius_m": c0.coords.xy().norm(),
            "camera_height_m": c0.z,
            "calibration": record,
            "output": a.output.display().to_string(),
        });
        println!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    println!(
        "{:<28} {:>9} {:>9} {:>11} {:>11}",
        "image", "pan deg", "rms px", "circle mm", "left out px"
    );
    for ((p, img), r) in cal.poses.iter().zip(&used).zip(&cal.fit.residuals) {
        let lo = cal
            .left_out
            .iter()
            .find(|l| l.pan == p.pan)
            .map(|l| format!("{:.3}", l.reprojection_px))
            .unwrap_or_else(|| "-".into());
        println!(
            "{:<28} {:>9.2} {:>9.4} {:>11.3} {:>11}",
            short(img),
            p.pan.degrees(),
            p.rms,
            r.centre_m * 1e3,
            lo
        );
    }
    for (p, r) in &rejected {
        println!("{:<28} rejected: {r}", short(p));
    }
    println!(
        "\ncircle: camera {:.1} mm from the axis, {:.1} mm above the board; residuals rms {:.3} mm, {:.4} deg",
        c0.coords.xy().norm() * 1e3,
        c0.z * 1e3,
        cal.fit.rms_centre_m() * 1e3,
        cal.fit.rms_rotation().degrees()
    );
    println!("wrote {}", a.output.display());
    Ok(())
}
