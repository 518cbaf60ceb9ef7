//! Synthetic turntable scenes with ground truth.
//!
//! aibr must be developed, tested, benchmarked and demonstrated without hardware, and its
//! central claim measured against ground truth. aibr-scene is a small, fast, deterministic
//! ray tracer of objects on a turntable:
//!
//! - analytic [`Shape`]s (ellipsoid/sphere, box, cylinder, quad) with [`Material`]s: matte with
//!   procedural solid [`Texture`]s, glossy (Blinn-Phong), and mirrors (plain or tinted)
//!   reflecting a textured [`Environment`];
//! - the physics of the real rig: the camera and the lamps stay still while the object turns,
//!   so lights, [`Backdrop`] and environment are fixed in the lab;
//! - [`Scene::render`] gives a [`Frame`]: RGB (f32 and 8-bit), depth along the optical axis
//!   (infinite on the backdrop) and the object mask, with optional seeded Gaussian noise,
//!   for any `aibr_camera::Camera` (distortion included); the same bytes at any thread count;
//! - a [`catalogue`] of named scenes (`mirror`, `mirror-broad`, `head`, `chair`, `lambertian`),
//!   each with a default ring rig, a ground-truth volume ([`Scene::bounds`]) and samples of
//!   its visible true surface ([`Scene::surface_samples`]).
//!
//! ```
//! use aibr_camera::Angle;
//! use aibr_scene::{RenderOptions, catalogue};
//!
//! let scene = catalogue::by_name("mirror")?;
//! let camera = scene.camera(Angle::from_degrees(90.0))?; // facing the mirror side
//! let frame = scene.render(&camera, &RenderOptions::default())?;
//! let centre = frame.depth.get_pixel(320, 240).0[0];
//! assert!(centre.is_finite() && centre > 0.4 && centre < 0.7);
//! frame.rgb8().save_with_format(std::env::temp_dir().join("mirror.png"), image::ImageFormat::Png)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! Objects are in the world (turntable) frame of `aibr-camera`: metres, Z up along the pan
//! axis, the turntable surface at `z = 0`. Lights, backdrop and environment are in the lab
//! frame, which equals the world frame at pan 0 and does not turn with the object (see
//! [`Scene`]). Colours are linear RGB in `[0, 1]`; 8-bit output is `round(255 v)`. Depth is
//! the camera-frame z of the first surface, metres.

pub mod catalogue;
pub mod error;
pub mod render;
pub mod rng;
pub mod scene;
pub mod shape;
pub mod texture;

pub use error::{Error, Result};
pub use render::{Frame, RenderOptions, Shot};
pub use scene::{
    Backdrop, Environment, GeometryReference, Light, Material, Scene, SceneHit, SceneObject,
    SceneRig, SkyLight,
};
pub use shape::{Hit, Shape};
pub use texture::{Colour, Texture};
