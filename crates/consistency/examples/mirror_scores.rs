//! The arc scores of `mirror`'s 12 initial views, with the pixels behind them.
//!
//! `cargo run --release -p aibr-consistency --example mirror_scores`
use aibr_consistency::{ConsistencyParams, score_pairs};
use aibr_scene::{RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = catalogue::mirror()?;
    let pans = scene.rig.uniform_pans(12);
    let shots = scene.shoot(
        &pans,
        &RenderOptions {
            noise_sigma: 1.0 / 255.0,
            seed: 1,
        },
    )?;
    let views: Vec<View<'_>> = shots
        .iter()
        .map(|s| View {
            camera: &s.camera,
            image: &s.image,
            mask: Some(&s.frame.mask),
        })
        .collect();
    let grid = VoxelGrid::with_resolution(scene.bounds(), 96)?;
    let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
    let scores = score_pairs(
        &model,
        &views,
        &pans,
        &scene.rig.pan_range,
        &ConsistencyParams::default(),
    )?;
    for s in &scores {
        let fg: usize = [s.a, s.b]
            .iter()
            .map(|&i| shots[i].frame.mask.pixels().filter(|p| p.0[0] != 0).count())
            .sum();
        println!(
            "{:7.1} .. {:7.1}: score {:8.0}  unexplained {:6}  compared {:6}  foreground {:6}",
            pans[s.a].degrees(),
            pans[s.b].degrees(),
            s.score,
            s.unexplained_pixels,
            s.compared_pixels,
            fg
        );
    }
    Ok(())
}
