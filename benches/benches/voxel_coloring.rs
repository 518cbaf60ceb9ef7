//! Voxel coloring benches (group `voxel_coloring`): the `lambertian` scene, 48 views of
//! 640x480 spread over the pan range, ground-truth masks; entries `128` and `256` (voxels
//! along the longest edge), `128_sample_inset_0.5` (the option for dense views),
//! `128_column_test` (the option for geometry, [`aibr_voxel::ColumnTest`]), and the scalar
//! reference at 128 as the naive baseline.
//!
//! `cargo bench -p aibr-benches --bench voxel_coloring`

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_scene::{RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, ColumnTest, VoxelGrid, voxel_coloring, voxel_coloring_reference};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let Ok(scene) = catalogue::lambertian() else {
        return;
    };
    let options = RenderOptions {
        noise_sigma: 1.0 / 255.0,
        seed: 1,
    };
    let Ok(shots) = scene.shoot(&scene.rig.uniform_pans(48), &options) else {
        return;
    };
    let views = aibr_benches::views_of(&shots);
    let params = ColoringParams::default();
    let mut g = c.benchmark_group("voxel_coloring");
    g.sample_size(10);
    for resolution in [128usize, 256] {
        let Ok(grid) = VoxelGrid::with_resolution(scene.bounds(), resolution) else {
            continue;
        };
        g.throughput(Throughput::Elements(grid.len() as u64));
        g.bench_function(resolution.to_string(), |b| {
            b.iter(|| voxel_coloring(&grid, &views, &params))
        });
    }
    if let Ok(grid) = VoxelGrid::with_resolution(scene.bounds(), 128) {
        g.throughput(Throughput::Elements(grid.len() as u64));
        // The option for dense views: sampled at the pixels whose centres lie inside each
        // voxel's projected square (`ColoringParams::sample_inset`).
        let inset = ColoringParams {
            sample_inset: 0.5,
            ..params
        };
        g.bench_function("128_sample_inset_0.5", |b| {
            b.iter(|| voxel_coloring(&grid, &views, &inset))
        });
        // The option for geometry: tops passed over where the views agree better below.
        let column = ColoringParams {
            column_test: Some(ColumnTest::default()),
            ..params
        };
        g.bench_function("128_column_test", |b| {
            b.iter(|| voxel_coloring(&grid, &views, &column))
        });
        g.bench_function("reference_128", |b| {
            b.iter(|| voxel_coloring_reference(&grid, &views, &params))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
