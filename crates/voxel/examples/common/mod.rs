//! What the voxel examples share: the views to shoot, the shooting, and the kernel's view of
//! the shots.

use aibr_camera::Angle;
use aibr_scene::{RenderOptions, Scene, Shot};
use aibr_voxel::View;

/// The pan angles of `PANS` (comma-separated degrees), else `n` uniform ones over the rig's
/// range; a bad list is refused naming the value.
pub(crate) fn pans(scene: &Scene, n: usize) -> Result<Vec<Angle>, String> {
    match std::env::var("PANS") {
        Ok(list) => list
            .split(',')
            .map(|d| d.trim().parse().map(Angle::from_degrees))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| format!("PANS: {e} in {list:?}")),
        Err(_) => Ok(scene.rig.uniform_pans(n)),
    }
}

/// The rig's views of `scene` at `pans`, with a grey level of sensor noise (seed 1), as the
/// project's accuracy figures are measured.
pub(crate) fn shoot(scene: &Scene, pans: &[Angle]) -> aibr_scene::Result<Vec<Shot>> {
    let options = RenderOptions {
        noise_sigma: 1.0 / 255.0,
        seed: 1,
    };
    scene.shoot(pans, &options)
}

/// The shots as the kernels take them, with their ground-truth masks as silhouettes.
pub(crate) fn views(shots: &[Shot]) -> Vec<View<'_>> {
    shots
        .iter()
        .map(|s| View {
            camera: &s.camera,
            image: &s.image,
            mask: Some(&s.frame.mask),
        })
        .collect()
}
