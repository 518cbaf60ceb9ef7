//! Depth-driven image-based rendering for turntable captures, and image metrics.
//!
//! - [`Renderer`]: renders a virtual camera from captured views plus a voxel model
//!   (section 2.2 of the paper): per pixel the model (by default closed and filled,
//!   [`RenderParams::fill`]) is ray cast for the surface point, and
//!   the captured rays through it are blended with unstructured-lumigraph weights (Buehler et
//!   al. 2001), skipping sources that do not see the point. By default each pixel's depth is
//!   then refined near the model's surface where two sources agree best, the nearest and
//!   the nearest across the virtual camera from it ([`DepthRefinement`]), which undoes most
//!   of voxel coloring's fattening. Where the model has no surface the focal surface at the
//!   object's depth stands in. Each pixel reports its [`Coverage`]. The blend samples its
//!   sources bilinearly, or bicubically ([`RenderParams::sampling`], [`Sampling`]), which
//!   keeps more of their texture at some cost a frame.
//! - [`reflection`]: optionally ([`RenderParams::reflections`]), a mirror in the model is
//!   rendered as a reflection of the lab: a pixel takes what the nearest source sees reflected
//!   in the same direction, as a turntable's still camera and surroundings allow.
//! - [`metrics`]: PSNR and SSIM, optionally inside a mask, checked against scikit-image.
//! - [`write_depth_exr`]: depth as OpenEXR.
//!
//! ```
//! use aibr_camera::Angle;
//! use aibr_render::{RenderParams, Renderer, SourceView, metrics};
//! use aibr_scene::{RenderOptions, catalogue};
//! use aibr_voxel::{ColoringParams, View, VoxelGrid, voxel_coloring};
//!
//! let scene = catalogue::lambertian()?;
//! let pans = scene.rig.uniform_pans(24);
//! let cameras: Vec<_> = pans.iter().map(|p| scene.camera(*p)).collect::<Result<_, _>>()?;
//! let frames: Vec<_> = cameras.iter().map(|c| scene.render(c, &RenderOptions::default())).collect::<Result<_, _>>()?;
//! let images: Vec<_> = frames.iter().map(|f| f.rgb8()).collect();
//! let views: Vec<View<'_>> = cameras.iter().zip(&images).zip(&frames)
//!     .map(|((camera, image), f)| View { camera, image, mask: Some(&f.mask) })
//!     .collect();
//! let model = voxel_coloring(&VoxelGrid::with_resolution(scene.bounds(), 64)?, &views, &ColoringParams::default())?.model;
//! let sources = cameras.iter().zip(images).map(|(c, image)| SourceView { camera: c.clone(), image }).collect();
//! let renderer = Renderer::new(&model, sources, RenderParams::default())?;
//!
//! // Half-way between the first two captures, against the ground truth.
//! let virtual_camera = scene.camera((pans[0] + pans[1]) * 0.5)?;
//! let truth = scene.render(&virtual_camera, &RenderOptions::default())?;
//! let view = renderer.render(&virtual_camera)?;
//! let psnr = metrics::psnr(&truth.rgb8(), &view.rgb, Some(&truth.mask))?;
//! assert!(psnr > 20.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! Cameras and the model live in the turntable frame of `aibr-camera`. Source images are
//! 8-bit RGB from pinhole cameras (undistort first). Depth is camera-z in metres. Pixel
//! `(0, 0)` is the centre of the top-left pixel.

pub mod error;
pub mod exr_io;
pub mod metrics;
pub mod reflection;
pub mod renderer;

pub use error::{Error, Result};
pub use exr_io::write_depth_exr;
pub use reflection::{MirrorCounts, MirrorTally, Reflections};
pub use renderer::{
    Coverage, DepthRefinement, MAX_CANDIDATES, MAX_FILL_CLOSING, MAX_OCCLUSION_TOLERANCE,
    MAX_REFINE_PENALTY, MAX_REFINE_STEPS, RenderParams, RenderedView, Renderer, Sampling,
    SourceView,
};
