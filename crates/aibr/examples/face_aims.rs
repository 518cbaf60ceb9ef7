//! How far the capture loop's face aims on `mirror` lie from the box's true edge-on pans.
//!
//! `cargo run --release -p aibr --example face_aims -- [--mean] WORK [WORK...]`
//!
//! Reads the active capture session of every turn in `WORK`, the folder `aibr eval --rig
//! sim:mirror --turns ... --strategy active --work WORK` kept (`WORK/turnT/mirror@T-active`, or `mirror-active` at turn 0). For
//! each count of views from the session's initial views to one short of its last, it rebuilds
//! the model the capture loop planned the next view from (those views in capture order, voxel
//! coloring at the session's grid with its masks, as `aibr capture` does), finds the model's
//! flat faces with `aibr_voxel::planar_faces` and their edge-on pans with
//! `aibr_consistency::edge_on_pans`: the loop's aims. Each aim is set against the nearest true
//! edge-on pan, the pan from which the camera centre lies in the plane of a face of `mirror`'s
//! box (`aibr_scene::catalogue::mirror`'s cuboid, `Shape::side_planes`, in the scene's frame,
//! which is the model's: `SceneCamera` turns the calibration, not the scene).
//!
//! Prints per turn and count the faces found: for each, the true face it faces, the angle
//! between their normals (degrees), its offset's error (millimetres, positive outward), and its
//! aims' signed errors against the nearest true edge-on pan (degrees; `?` when that pan is
//! another face's). Then the mean absolute error of the aims by count of views and overall; the
//! captured views past the initial ones that lie within 1.5 degrees of a true edge-on pan, with
//! their mean error; and the median time `planar_faces` took on a model. With several `WORK`
//! folders (runs of the same turns with different planners) it prints the summary of each.
//! With `--mean` the faces' planes are those of sessions 25-70 (`FaceParams::profile_quantile`
//! `None`: the mean of the voting normals and the densest offset) instead of the default
//! refit. `docs/results.md`, "Session 71".

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use aibr::camera::Angle;
use aibr::consistency::edge_on_pans;
use aibr::scene::catalogue;
use aibr::voxel::{ColoringParams, FaceParams, PlanarFace, planar_faces};
use aibr::{Session, reconstruct_loaded};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// A captured view this near a true edge-on pan counts as a view at it (degrees).
const SERVED_DEG: f64 = 1.5;

/// The sides of `mirror`'s box, in the scene's frame.
fn true_faces() -> Result<Vec<PlanarFace>> {
    Ok(catalogue::mirror()?
        .objects
        .iter()
        .flat_map(|o| o.shape.side_planes())
        .map(|(normal, offset_m)| PlanarFace {
            normal,
            offset_m,
            voxels: 0,
        })
        .collect())
}

/// Signed degrees from `b` to `a`, round the circle.
fn degrees_between(a: Angle, b: Angle) -> f64 {
    a.wrapped_difference(b).radians().to_degrees()
}

/// The errors one work folder's sessions give.
#[derive(Default)]
struct Summary {
    /// Per count of views: the aims' absolute errors, degrees.
    by_count: BTreeMap<usize, Vec<f64>>,
    /// The captured views within `SERVED_DEG` of a true edge-on pan: signed errors.
    served: Vec<f64>,
    /// Each model's time in `planar_faces`, milliseconds.
    finding: Vec<f64>,
}

impl Summary {
    fn print(&self, work: &Path) {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
        println!("summary of {}", work.display());
        let mut all = Vec::new();
        for (count, errors) in &self.by_count {
            println!(
                "  {count:>2} views: {:>3} aims, mean |error| {:.3} degree",
                errors.len(),
                mean(errors)
            );
            all.extend_from_slice(errors);
        }
        println!(
            "  all: {} aims, mean |error| {:.3} degree, largest {:.3}",
            all.len(),
            mean(&all),
            all.iter().copied().fold(0.0, f64::max)
        );
        let abs: Vec<f64> = self.served.iter().map(|e| e.abs()).collect();
        println!(
            "  views within {SERVED_DEG} degree of a true edge-on pan: {}, mean |error| {:.3}, \
             mean signed {:+.3}, largest {:.3}",
            abs.len(),
            mean(&abs),
            mean(&self.served),
            abs.iter().copied().fold(0.0, f64::max)
        );
        let mut finding = self.finding.clone();
        finding.sort_by(f64::total_cmp);
        println!(
            "  planar_faces on {} models: median {:.1} ms, longest {:.1} ms",
            finding.len(),
            finding.get(finding.len() / 2).copied().unwrap_or(f64::NAN),
            finding.last().copied().unwrap_or(f64::NAN)
        );
    }
}

/// The names of the entries of folder `dir`.
fn entries(dir: &Path) -> Result<Vec<(String, PathBuf)>> {
    let listing = |e: std::io::Error| format!("{}: cannot list: {e}", dir.display());
    std::fs::read_dir(dir)
        .map_err(listing)?
        .map(|entry| {
            let entry = entry.map_err(listing)?;
            Ok((
                entry.file_name().to_string_lossy().into_owned(),
                entry.path(),
            ))
        })
        .collect()
}

/// The active capture sessions of `mirror` in `work` (`turnT/mirror...-active`), by turn.
fn sessions(work: &Path) -> Result<Vec<(f64, PathBuf)>> {
    let mut out = Vec::new();
    for (name, path) in entries(work)? {
        let Some(turn) = name.strip_prefix("turn") else {
            continue;
        };
        let turn: f64 = turn
            .parse()
            .map_err(|_| format!("{}: {name:?} is not turnDEGREES", work.display()))?;
        for (inner, dir) in entries(&path)? {
            if inner.starts_with("mirror") && inner.ends_with("-active") && dir.is_dir() {
                out.push((turn, dir));
            }
        }
    }
    if out.is_empty() {
        return Err(format!("{}: no turnT/mirror...-active sessions", work.display()).into());
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(out)
}

fn measure(work: &Path, face_params: &FaceParams) -> Result<Summary> {
    let mut summary = Summary::default();
    let truth = true_faces()?;
    for (turn, dir) in sessions(work)? {
        let session = Session::open(&dir)?;
        let views = session.load_views()?;
        let parameters = &session.file().parameters;
        let motion = session.calibration()?.motion;
        let (range, _) = session.turntable()?;
        // Every true edge-on pan in the range, with its face.
        let true_pans: Vec<(usize, Angle)> = truth
            .iter()
            .enumerate()
            .flat_map(|(f, face)| {
                edge_on_pans(face, &motion, &range)
                    .into_iter()
                    .map(move |p| (f, p))
            })
            .collect();
        let nearest = |pan: Angle| {
            true_pans
                .iter()
                .map(|&(f, p)| (f, degrees_between(pan, p)))
                .min_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
        };
        println!("turn {turn}");
        for count in parameters.initial..views.len() {
            let (rec, _) = reconstruct_loaded(
                &session,
                &views[..count],
                parameters.grid,
                &ColoringParams::default(),
            )?;
            let started = Instant::now();
            let faces = planar_faces(&rec.model, face_params)?;
            summary.finding.push(started.elapsed().as_secs_f64() * 1e3);
            let mut line = format!("  {count:>2} views:");
            for face in &faces {
                let Some((f, t)) = truth.iter().enumerate().max_by(|a, b| {
                    a.1.normal
                        .dot(&face.normal)
                        .total_cmp(&b.1.normal.dot(&face.normal))
                }) else {
                    continue;
                };
                let tilt = face.normal.angle(&t.normal).to_degrees();
                let outward_mm = (face.offset_m - t.offset_m) * 1e3;
                line += &format!(" [face {f}: {tilt:.2} deg, {outward_mm:+.1} mm; aims");
                for aim in edge_on_pans(face, &motion, &range) {
                    if let Some((g, e)) = nearest(aim) {
                        line += &format!(" {e:+.2}{}", if g == f { "" } else { "?" });
                        summary.by_count.entry(count).or_default().push(e.abs());
                    }
                }
                line += "]";
            }
            println!("{line}");
        }
        for view in views.iter().skip(parameters.initial) {
            let pan = Angle::from_radians(view.record.pan_rad);
            if let Some((_, e)) = nearest(pan).filter(|(_, e)| e.abs() <= SERVED_DEG) {
                summary.served.push(e);
            }
        }
    }
    Ok(summary)
}

fn main() -> Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let face_params = match args.first().map(String::as_str) {
        Some("--mean") => {
            args.remove(0);
            FaceParams {
                profile_quantile: None,
                ..FaceParams::default()
            }
        }
        _ => FaceParams::default(),
    };
    let works: Vec<PathBuf> = args.into_iter().map(PathBuf::from).collect();
    if works.is_empty() || works.iter().any(|w| w.to_string_lossy().starts_with('-')) {
        return Err("usage: face_aims [--mean] WORK [WORK...]".into());
    }
    let summaries = works
        .iter()
        .map(|w| measure(w, &face_params))
        .collect::<Result<Vec<_>>>()?;
    for (work, summary) in works.iter().zip(&summaries) {
        summary.print(work);
    }
    Ok(())
}
