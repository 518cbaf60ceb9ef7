//! Accuracy and completeness of voxel coloring on every catalogue scene, both criteria.
//!
//! `cargo run --release -p aibr-voxel --example voxel_accuracy -- [RESOLUTION] [VIEWS] [SCENE...]`
//! (defaults: 128, 48, every catalogue scene). Views are spread uniformly over the pan range;
//! the ground-truth masks are used as silhouettes. Environment variables change the
//! defaults: `THRESH` and `WINDOW` (the angular criterion), `CTHRESH` (the classic one),
//! `MINV` (`min_views`), `INSET` (`sample_inset`, pixels) and `BEHIND_HULL` (a cosine, or
//! `off` to ask every view); `PANS`, a comma-separated list of pan angles in degrees,
//! replaces the uniform views (for instance the `pans_deg` of an `aibr eval --json`
//! checkpoint; `VIEWS` is then ignored). `REFINE=1` runs [`aibr_voxel::refine_tops`] with its
//! defaults on each model before scoring it, `REFINE=MARGIN:RATIO:DEPTH` with those
//! [`aibr_voxel::TopRefinement`] fields; `WALLS=1` walls the steps the refinement leaves
//! ([`aibr_voxel::TopRefinement::walls`]). `COLUMN=1` turns on the column test
//! ([`aibr_voxel::ColumnTest`]) with its defaults, `COLUMN=MARGIN:RATIO:DEPTH:NEIGHBOURS`
//! with those fields; `REF=1` runs [`aibr_voxel::voxel_coloring_reference`] instead of the
//! fast kernel.

mod common;

use aibr_scene::catalogue;
use aibr_voxel::metrics::geometry_score;
use aibr_voxel::{
    ColoringParams, ColumnTest, Criterion, TopRefinement, VoxelGrid, refine_tops, voxel_coloring,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let resolution: usize = args.first().map_or(Ok(128), |a| a.parse())?;
    let n_views: usize = args.get(1).map_or(Ok(48), |a| a.parse())?;
    let names: Vec<String> = if args.len() > 2 {
        args[2..].to_vec()
    } else {
        catalogue::SCENE_NAMES
            .iter()
            .map(|s| s.to_string())
            .collect()
    };
    println!(
        "| scene | criterion | accuracy (voxels, 90%) | completeness (1.5 voxels) | surface voxels | coloring (ms) | tops refined (ms) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let refine = match std::env::var("REFINE") {
        Err(_) => None,
        Ok(spec) => Some(TopRefinement {
            walls: std::env::var("WALLS").is_ok_and(|w| w == "1"),
            ..refinement(&spec)?
        }),
    };
    for name in &names {
        let scene = catalogue::by_name(name)?;
        let pans = common::pans(&scene, n_views)?;
        let shots = common::shoot(&scene, &pans)?;
        let views = common::views(&shots);
        let reference = scene.geometry_reference()?;
        let grid = VoxelGrid::with_resolution(scene.bounds(), resolution)?;
        let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
        let angular = match (env("THRESH"), env("WINDOW")) {
            (Some(t), Some(w)) => Criterion::Angular {
                threshold: t as f32,
                window: aibr_camera::Angle::from_degrees(w),
            },
            _ => Criterion::angular(),
        };
        let classic = env("CTHRESH").map_or(Criterion::classic(), |t| Criterion::Classic {
            threshold: t as f32,
        });
        for (label, criterion) in [("angular", angular), ("classic", classic)] {
            let mut params = ColoringParams {
                criterion,
                ..ColoringParams::default()
            };
            match std::env::var("BEHIND_HULL").as_deref() {
                Ok("off") => params.behind_hull = None,
                Ok(c) => params.behind_hull = Some(c.parse()?),
                Err(_) => {}
            }
            if let Some(m) = env("MINV") {
                params.min_views = m as usize;
            }
            if let Some(inset) = env("INSET") {
                params.sample_inset = inset as f32;
            }
            if let Ok(spec) = std::env::var("COLUMN") {
                params.column_test = Some(column_test(&spec)?);
            }
            let start = std::time::Instant::now();
            let mut model = if std::env::var("REF").is_ok_and(|r| r == "1") {
                aibr_voxel::voxel_coloring_reference(&grid, &views, &params)?.model
            } else {
                voxel_coloring(&grid, &views, &params)?.model
            };
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let refined = if let Some(refine) = &refine {
                let start = std::time::Instant::now();
                refine_tops(&mut model, &views, refine)?;
                format!("{:.0}", start.elapsed().as_secs_f64() * 1e3)
            } else {
                "-".to_string()
            };
            let score = geometry_score(&model, &reference.exposed, &reference.visible);
            println!(
                "| {name} | {label} | {:.2} | {:.1}% | {} | {ms:.0} | {refined} |",
                score.accuracy_voxels,
                100.0 * score.completeness,
                score.surface_voxels
            );
        }
    }
    Ok(())
}

/// `1` (the defaults) or `MARGIN:RATIO:DEPTH:NEIGHBOURS`.
fn column_test(spec: &str) -> Result<ColumnTest, String> {
    let bad = || format!("COLUMN={spec}: expected 1 or MARGIN:RATIO:DEPTH:NEIGHBOURS");
    let parts: Vec<&str> = spec.split(':').collect();
    match parts.as_slice() {
        ["1"] => Ok(ColumnTest::default()),
        [m, r, d, n] => Ok(ColumnTest {
            margin: m.parse().map_err(|_| bad())?,
            ratio: r.parse().map_err(|_| bad())?,
            depth: d.parse().map_err(|_| bad())?,
            neighbours: n.parse().map_err(|_| bad())?,
        }),
        _ => Err(bad()),
    }
}

/// `1` (the defaults) or `MARGIN:RATIO:DEPTH`.
fn refinement(spec: &str) -> Result<TopRefinement, String> {
    let bad = || format!("REFINE={spec}: expected 1 or MARGIN:RATIO:DEPTH");
    let parts: Vec<&str> = spec.split(':').collect();
    match parts.as_slice() {
        ["1"] => Ok(TopRefinement::default()),
        [m, r, d] => Ok(TopRefinement {
            margin: m.parse().map_err(|_| bad())?,
            ratio: r.parse().map_err(|_| bad())?,
            max_depth: d.parse().map_err(|_| bad())?,
            ..TopRefinement::default()
        }),
        _ => Err(bad()),
    }
}
