//! Renders every catalogue scene at a few pan angles into a folder, with masks and a
//! contact sheet.
//!
//! `cargo run --release -p aibr-scene --example catalogue -- [OUT_DIR]`

use aibr_camera::Angle;
use aibr_scene::{RenderOptions, catalogue};
use image::{GenericImage, RgbImage};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::env::temp_dir().join("aibr-catalogue"));
    std::fs::create_dir_all(&out)?;
    let pans = [-120.0, -40.0, 40.0, 90.0];
    let mut sheet = RgbImage::new(
        320 * pans.len() as u32,
        240 * catalogue::SCENE_NAMES.len() as u32,
    );
    for (row, name) in catalogue::SCENE_NAMES.iter().enumerate() {
        let scene = catalogue::by_name(name)?;
        for (col, pan) in pans.iter().enumerate() {
            let camera = scene.camera(Angle::from_degrees(*pan))?;
            let start = std::time::Instant::now();
            let frame = scene.render(&camera, &RenderOptions::default())?;
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let rgb = frame.rgb8();
            let path = out.join(format!("{name}_{pan:+04}.png"));
            rgb.save(&path)?;
            frame
                .mask
                .save(out.join(format!("{name}_{pan:+04}_mask.png")))?;
            let small = image::imageops::thumbnail(&rgb, 320, 240);
            sheet.copy_from(&small, 320 * col as u32, 240 * row as u32)?;
            println!("{} ({ms:.1} ms)", path.display());
        }
    }
    let path = out.join("contact_sheet.png");
    sheet.save(&path)?;
    println!("{}", path.display());
    Ok(())
}
