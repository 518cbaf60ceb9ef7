//! Consistency estimator bench (group `consistency`): `score_pairs` on the `mirror` scene, the
//! paper's object, with its ground-truth masks and the 96^3 voxel coloring model the capture
//! loop reconstructs (`aibr::CaptureParams::grid`); entries `score_pairs_24` and
//! `score_pairs_48` (uniform views of 640x480 over the pan range). This is the step the
//! active loop runs after every capture: a depth map per view, then every neighbouring pair
//! checked both ways.
//!
//! `cargo bench -p aibr-benches --bench consistency`

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_consistency::{ConsistencyParams, score_pairs};
use aibr_scene::{RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, VoxelGrid, voxel_coloring};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let Ok(scene) = catalogue::mirror() else {
        return;
    };
    let mut g = c.benchmark_group("consistency");
    g.sample_size(10);
    for count in [24usize, 48] {
        let pans = scene.rig.uniform_pans(count);
        let Ok(shots) = scene.shoot(&pans, &RenderOptions::default()) else {
            return;
        };
        let views = aibr_benches::views_of(&shots);
        let Ok(grid) = VoxelGrid::with_resolution(scene.bounds(), 96) else {
            return;
        };
        let Ok(out) = voxel_coloring(&grid, &views, &ColoringParams::default()) else {
            return;
        };
        let params = ConsistencyParams::default();
        // Throughput in views scored.
        g.throughput(Throughput::Elements(count as u64));
        g.bench_function(format!("score_pairs_{count}"), |b| {
            b.iter(|| score_pairs(&out.model, &views, &pans, &scene.rig.pan_range, &params))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
