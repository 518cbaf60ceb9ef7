//! Writing depth maps as OpenEXR (a single float channel `Z`).

use std::io::{Seek, Write};

use aibr_voxel::DepthMap;

use crate::error::Result;

/// Writes `depth` (metres; infinity where nothing was seen) as a one-channel (`Z`, f32)
/// OpenEXR image to `out`.
pub fn write_depth_exr<W: Write + Seek>(depth: &DepthMap, out: W) -> Result<()> {
    use exr::prelude::*;
    let (w, h) = (depth.width() as usize, depth.height() as usize);
    let data = depth.as_raw();
    let channels = SpecificChannels::build()
        .with_channel("Z")
        .with_pixel_fn(|pos: Vec2<usize>| (data[pos.y() * w + pos.x()],));
    let image = Image::from_channels((w, h), channels);
    image
        .write()
        .to_buffered(out)
        .map_err(|e| crate::error::Error::Exr(e.to_string()))
}
