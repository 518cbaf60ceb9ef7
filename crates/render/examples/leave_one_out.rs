//! Leave-one-out on a Middlebury ring: every view rendered from the others, with the model
//! reconstructed from those others; masked PSNR against the held-out image.
//!
//! `cargo run --release -p aibr-render --example leave_one_out -- [DIR] [RESOLUTION]`
//! (default: `$AIBR_DATA_DIR/middlebury-templeRing`, 96). The ring frame comes from
//! `aibr_camera::fit_ring`; silhouettes by the README's recipe, clipped to the projection of
//! the README's bounding box (templeRing's box is built in). Cameras are not all above
//! the object's box, so the model is made by space carving. `FILL=0` renders from the model
//! as given instead of closed and filled ([`RenderParams::fill`]).

use aibr_camera::readers::read_middlebury_par;
use aibr_camera::{Aabb, ImageSize, fit_ring};
use aibr_render::{RenderParams, Renderer, SourceView, metrics};
use aibr_voxel::foreground::{DarkBackground, clip_to_volume, dark_background_mask};
use aibr_voxel::{CarvingParams, View, VoxelGrid, space_carving};
use nalgebra::Point3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let data = std::env::var("AIBR_DATA_DIR").unwrap_or_else(|_| "../shared/data".into());
    let dir = args
        .first()
        .cloned()
        .unwrap_or(format!("{data}/middlebury-templeRing"));
    let resolution: usize = args.get(1).map_or(Ok(96), |r| r.parse())?;
    let dir = std::path::Path::new(&dir);
    let par = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.to_string_lossy().ends_with("_par.txt"))
        .ok_or("no *_par.txt in the folder")?;
    let views = read_middlebury_par(&par)?;
    let ring = fit_ring(&views.iter().map(|v| v.cam_from_world).collect::<Vec<_>>())?;
    let mut cameras = Vec::new();
    let mut images = Vec::new();
    for v in &views {
        let image = image::open(dir.join(&v.image))?.to_rgb8();
        let size = ImageSize::new(image.width(), image.height());
        cameras.push(
            v.camera(size)?
                .with_pose(ring.to_turntable(&v.cam_from_world)),
        );
        images.push(image);
    }
    // templeRing's README box, in the data set's frame.
    let b = Aabb::new(
        Point3::new(-0.023121, -0.038009, -0.091940),
        Point3::new(0.078626, 0.121636, -0.017395),
    )?;
    let volume = Aabb::around(b.corners().iter().map(|c| ring.turntable_from_world * c))
        .ok_or("box")?
        .expanded(0.003);
    // Thresholding also marks lit parts of the gantry; the object is inside its box.
    let mut masks = Vec::new();
    for (image, camera) in images.iter().zip(&cameras) {
        let mut mask = dark_background_mask(image, &DarkBackground::default());
        clip_to_volume(&mut mask, camera, &volume)?;
        masks.push(mask);
    }
    let grid = VoxelGrid::with_resolution(volume, resolution)?;
    let mut values = Vec::new();
    for held in 0..views.len() {
        let others: Vec<usize> = (0..views.len()).filter(|&i| i != held).collect();
        let vs: Vec<View<'_>> = others
            .iter()
            .map(|&i| View {
                camera: &cameras[i],
                image: &images[i],
                mask: Some(&masks[i]),
            })
            .collect();
        let model = space_carving(&grid, &vs, &CarvingParams::default())?.model;
        let sources = others
            .iter()
            .map(|&i| SourceView {
                camera: cameras[i].clone(),
                image: images[i].clone(),
            })
            .collect();
        let params = RenderParams {
            fill: match std::env::var("FILL").as_deref() {
                Ok("0") => None,
                _ => RenderParams::default().fill,
            },
            ..RenderParams::default()
        };
        let renderer = Renderer::new(&model, sources, params)?;
        let view = renderer.render(&cameras[held])?;
        let p = metrics::psnr(&images[held], &view.rgb, Some(&masks[held]))?;
        println!("{}: {p:.2} dB", views[held].image);
        values.push(p);
    }
    let mean = values.iter().sum::<f64>() / values.len() as f64;
    println!("mean masked PSNR over {} views: {mean:.2} dB", values.len());
    Ok(())
}
