//! Scene benches: one 640x480 render of each catalogue scene (group `scene`).
//!
//! `cargo bench -p aibr-benches --bench scene`

// criterion's macros generate undocumented public items.
#![allow(missing_docs)]

use aibr_camera::Angle;
use aibr_scene::{RenderOptions, catalogue};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;

fn scene(c: &mut Criterion) {
    let mut g = c.benchmark_group("scene");
    g.throughput(Throughput::Elements(640 * 480));
    g.sample_size(30);
    for name in catalogue::SCENE_NAMES {
        let Ok(scene) = catalogue::by_name(name) else {
            continue;
        };
        // A three-quarter view, where each scene shows most of its features.
        let Ok(camera) = scene.camera(Angle::from_degrees(40.0)) else {
            continue;
        };
        g.bench_function(name, |b| {
            b.iter(|| scene.render(black_box(&camera), &RenderOptions::default()))
        });
    }
    g.finish();
}

criterion_group!(benches, scene);
criterion_main!(benches);
