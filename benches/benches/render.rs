//! Renderer bench (group `render`, entry `vga`): a 640x480 frame from 48 views of `lambertian`
//! and its 128^3 model, half-way between two captures, into preallocated buffers; entry
//! `vga_unrefined` renders the same frame without the depth refinement, entry `vga_bicubic`
//! with the sources sampled bicubically. Group `metrics`, entries `psnr` and `ssim`: that
//! frame against the scene's ground truth, inside the object's mask, as `aibr eval` measures
//! every novel view.
//!
//! `cargo bench -p aibr-benches --bench render`

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_render::{RenderParams, RenderedView, Renderer, Sampling, SourceView, metrics};
use aibr_scene::{RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, VoxelGrid, voxel_coloring};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

fn bench(c: &mut Criterion) {
    let Ok(scene) = catalogue::lambertian() else {
        return;
    };
    let pans = scene.rig.uniform_pans(48);
    let Ok(shots) = scene.shoot(&pans, &RenderOptions::default()) else {
        return;
    };
    let views = aibr_benches::views_of(&shots);
    let Ok(grid) = VoxelGrid::with_resolution(scene.bounds(), 128) else {
        return;
    };
    let Ok(out) = voxel_coloring(&grid, &views, &ColoringParams::default()) else {
        return;
    };
    let sources = || {
        shots
            .iter()
            .map(|s| SourceView {
                camera: s.camera.clone(),
                image: s.image.clone(),
            })
            .collect::<Vec<_>>()
    };
    let Ok(renderer) = Renderer::new(&out.model, sources(), RenderParams::default()) else {
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
    // The same frame without the depth refinement (`RenderParams::refine: None`).
    let plain = RenderParams {
        refine: None,
        ..RenderParams::default()
    };
    if let Ok(unrefined) = Renderer::new(&out.model, sources(), plain) {
        g.bench_function("vga_unrefined", |b| {
            b.iter(|| unrefined.render_into(&camera, &mut buffers))
        });
    }
    // The same frame with the sources sampled bicubically (`RenderParams::sampling`).
    let bicubic = RenderParams {
        sampling: Sampling::Bicubic,
        ..RenderParams::default()
    };
    if let Ok(sharper) = Renderer::new(&out.model, sources(), bicubic) {
        g.bench_function("vga_bicubic", |b| {
            b.iter(|| sharper.render_into(&camera, &mut buffers))
        });
    }
    g.finish();

    let Ok(truth) = scene.render(&camera, &RenderOptions::default()) else {
        return;
    };
    let truth_rgb = truth.rgb8();
    if renderer.render_into(&camera, &mut buffers).is_err() {
        return;
    }
    let mut g = c.benchmark_group("metrics");
    g.throughput(Throughput::Elements(640 * 480));
    g.bench_function("psnr", |b| {
        b.iter(|| metrics::psnr(&truth_rgb, &buffers.rgb, Some(&truth.mask)))
    });
    g.bench_function("ssim", |b| {
        b.iter(|| metrics::ssim(&truth_rgb, &buffers.rgb, Some(&truth.mask)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
