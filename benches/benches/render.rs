//! Renderer bench (group `render`, entry `vga`): a 640x480 frame from 48 views of `lambertian`
//! and its 128^3 model, half-way between two captures, into preallocated buffers.
//!
//! `cargo bench -p aibr-benches --bench render`

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_render::{RenderParams, RenderedView, Renderer, SourceView};
use aibr_scene::{RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let Ok(scene) = catalogue::lambertian() else {
        return;
    };
    let pans = scene.rig.uniform_pans(48);
    let Ok(cameras) = pans
        .iter()
        .map(|p| scene.camera(*p))
        .collect::<Result<Vec<_>, _>>()
    else {
        return;
    };
    let Ok(frames) = cameras
        .iter()
        .map(|cam| scene.render(cam, &RenderOptions::default()))
        .collect::<Result<Vec<_>, _>>()
    else {
        return;
    };
    let images: Vec<_> = frames.iter().map(|f| f.rgb8()).collect();
    let views: Vec<View<'_>> = cameras
        .iter()
        .zip(&images)
        .zip(&frames)
        .map(|((camera, image), f)| View {
            camera,
            image,
            mask: Some(&f.mask),
        })
        .collect();
    let Ok(grid) = VoxelGrid::with_resolution(scene.bounds(), 128) else {
        return;
    };
    let Ok(out) = voxel_coloring(&grid, &views, &ColoringParams::default()) else {
        return;
    };
    let sources = cameras
        .iter()
        .zip(images.iter().cloned())
        .map(|(cam, image)| SourceView {
            camera: cam.clone(),
            image,
        })
        .collect();
    let Ok(renderer) = Renderer::new(&out.model, sources, RenderParams::default()) else {
        return;
    };
    let Ok(camera) = scene.camera((pans[20] + pans[21]) * 0.5) else {
        return;
    };
    let mut buffers = RenderedView::new(camera.size);
    let mut g = c.benchmark_group("render");
    g.throughput(Throughput::Elements(640 * 480));
    g.bench_function("vga", |b| {
        b.iter(|| renderer.render_into(&camera, &mut buffers))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
