//! How well a hand-picked set of views reconstructs and renders a catalogue scene.
//!
//! `cargo run --release -p aibr --example view_set -- SCENE TURN PANS [STEP]`
//!
//! Shoots `SCENE` (a catalogue name) turned by `TURN` degrees on its turntable (as `aibr eval
//! --rig sim:SCENE@TURN` does) at the pan angles `PANS` (comma-separated degrees), with a grey
//! level of sensor noise, reconstructs it at 128^3 by voxel coloring with the default
//! parameters, and renders every `STEP` degrees (default 2) of the pan range not within half
//! a degree of a view, compared with the truth inside the object mask. Prints the model's
//! accuracy (voxels) and completeness against the true surface, and the mean masked PSNR of
//! the novel views: all of them, those on the side from which `mirror`'s panel is seen (the
//! object's pans 20 to 160 degrees) and the rest. Where `aibr eval` compares strategies, this
//! answers "what if these views had been taken instead": `docs/results.md`, "Session 24",
//! moves three of an active capture's views into the planes of the box's faces.

use aibr::camera::Angle;
use aibr::render::{RenderParams, Renderer, SourceView, metrics};
use aibr::scene::{RenderOptions, catalogue};
use aibr::voxel::metrics::geometry_score;
use aibr::voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn degrees(what: &str, text: &str) -> Result<f64> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{what}: {text:?} is not a number of degrees").into())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let [_, scene, turn, pans, rest @ ..] = args.as_slice() else {
        return Err("usage: view_set SCENE TURN PANS [STEP]".into());
    };
    let scene = catalogue::by_name(scene)?;
    let turn = degrees("TURN", turn)?;
    let pans: Vec<f64> = pans
        .split(',')
        .map(|p| degrees("PANS", p))
        .collect::<Result<_>>()?;
    let step = match rest.first() {
        Some(s) => degrees("STEP", s)?,
        None => 2.0,
    };
    if !(step > 0.0) {
        return Err(format!("STEP {step}: must be positive").into());
    }
    let range = scene.rig.pan_range;
    for &p in &pans {
        range.check(Angle::from_degrees(p))?;
    }
    // The scene turned by TURN shows at pan p what the catalogue scene shows at p + TURN.
    let at = |p: f64| Angle::from_degrees(p + turn);
    let noise = RenderOptions {
        noise_sigma: 1.0 / 255.0,
        seed: 7,
    };
    let shots = scene.shoot(&pans.iter().map(|&p| at(p)).collect::<Vec<_>>(), &noise)?;
    let views: Vec<View<'_>> = shots
        .iter()
        .map(|s| View {
            camera: &s.camera,
            image: &s.image,
            mask: Some(&s.frame.mask),
        })
        .collect();
    let grid = VoxelGrid::with_resolution(scene.bounds(), 128)?;
    let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
    let reference = scene.geometry_reference()?;
    let geometry = geometry_score(&model, &reference.exposed, &reference.visible);
    let sources = shots
        .iter()
        .map(|s| SourceView {
            camera: s.camera.clone(),
            image: s.image.clone(),
        })
        .collect();
    let renderer = Renderer::new(&model, sources, RenderParams::default())?;
    let (mut all, mut side, mut others) = (Vec::new(), Vec::new(), Vec::new());
    let (min, max) = (range.min().degrees(), range.max().degrees());
    let mut k = 0;
    loop {
        let pan = min + f64::from(k) * step;
        k += 1;
        if pan > max + 1e-9 {
            break;
        }
        if pans.iter().any(|p| (p - pan).abs() < 0.5) {
            continue;
        }
        let camera = scene.camera(at(pan))?;
        let truth = scene.render(&camera, &RenderOptions::default())?;
        let view = renderer.render(&camera)?;
        let psnr = metrics::psnr(&truth.rgb8(), &view.rgb, Some(&truth.mask))?;
        all.push(psnr);
        let object = (pan + turn + 180.0).rem_euclid(360.0) - 180.0;
        if (20.0..=160.0).contains(&object) {
            side.push(psnr);
        } else {
            others.push(psnr);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    println!(
        "{} views: model {:.2} voxels / {:.1}%; novel views ({}) {:.2} dB, on the mirror's side \
         ({}) {:.2} dB, the rest ({}) {:.2} dB",
        pans.len(),
        geometry.accuracy_voxels,
        100.0 * geometry.completeness,
        all.len(),
        mean(&all),
        side.len(),
        mean(&side),
        others.len(),
        mean(&others)
    );
    Ok(())
}
