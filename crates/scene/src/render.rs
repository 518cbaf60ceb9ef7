//! The renderer: RGB, depth along the optical axis and the object mask, in parallel and
//! deterministic.

use aibr_camera::Camera;
use image::{GrayImage, ImageBuffer, Luma, Rgb, Rgb32FImage, RgbImage};
use nalgebra::{Point3, Rotation3, Vector3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::rng::SplitMix64;
use crate::scene::{MAX_BOUNCES, Material, SURFACE_EPSILON, Scene, SceneHit};
use crate::texture::Colour;

/// Options of [`Scene::render`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RenderOptions {
    /// Standard deviation of Gaussian sensor noise added to each channel, in units of full
    /// scale (`2.0 / 255.0` is two grey levels). 0 for none.
    pub noise_sigma: f32,
    /// Seed of the noise; each pixel draws from its own stream, so the result does not
    /// depend on the thread count.
    pub seed: u64,
}

/// One rendered view.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Linear RGB in `[0, 1]`.
    pub rgb: Rgb32FImage,
    /// Depth along the optical axis (camera z), metres; `f32::INFINITY` on the backdrop.
    pub depth: ImageBuffer<Luma<f32>, Vec<f32>>,
    /// 255 where the pixel sees an object, 0 on the backdrop.
    pub mask: GrayImage,
}

impl Frame {
    /// The colour image quantised to 8 bits (`round(255 v)`).
    pub fn rgb8(&self) -> RgbImage {
        let (w, h) = self.rgb.dimensions();
        let data = self.rgb.as_raw().iter().map(|&v| quantise(v)).collect();
        RgbImage::from_raw(w, h, data).unwrap_or_else(|| RgbImage::new(w, h))
    }
}

#[inline]
fn quantise(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Per-render constants.
struct Context<'a> {
    scene: &'a Scene,
    lab_from_world: Rotation3<f64>,
    lights_world: Vec<(Point3<f64>, Colour)>,
}

/// One view of a synthetic capture: the pan angle, its camera, the render and its 8-bit
/// image.
#[derive(Debug, Clone, PartialEq)]
pub struct Shot {
    /// The pan angle of the rig.
    pub pan: aibr_camera::Angle,
    /// The rig camera there.
    pub camera: Camera,
    /// The render (f32 colour, depth, mask).
    pub frame: Frame,
    /// The colour quantised to 8 bits.
    pub image: RgbImage,
}

impl Scene {
    /// Renders the rig's views at `pans` (a synthetic capture).
    pub fn shoot(&self, pans: &[aibr_camera::Angle], options: &RenderOptions) -> Result<Vec<Shot>> {
        pans.iter()
            .map(|&pan| {
                let camera = self.camera(pan)?;
                let frame = self.render(&camera, options)?;
                let image = frame.rgb8();
                Ok(Shot {
                    pan,
                    camera,
                    frame,
                    image,
                })
            })
            .collect()
    }

    /// Per-render constants for `camera`.
    fn context(&self, camera: &Camera) -> Context<'_> {
        let lab_from_world = Scene::lab_from_world(camera);
        let world_from_lab = lab_from_world.inverse();
        Context {
            scene: self,
            lab_from_world,
            lights_world: self
                .lights
                .iter()
                .map(|l| (world_from_lab * l.position_lab, l.colour))
                .collect(),
        }
    }

    /// The noise-free colour and depth seen by `camera` at a sub-pixel position (exact ground
    /// truth between pixel centres); `None` where the pixel has no ray. Depth is infinite on
    /// the backdrop.
    pub fn render_pixel(
        &self,
        camera: &Camera,
        pixel: nalgebra::Point2<f64>,
    ) -> Option<(Colour, f32)> {
        let n = camera.normalized_from_pixel(pixel)?;
        let dir = camera.world_from_cam().rotation * Vector3::new(n.x, n.y, 1.0);
        Some(self.context(camera).primary(&camera.centre(), &dir))
    }

    /// Renders the view of `camera` (any pose, intrinsics and distortion).
    ///
    /// Pixels whose ray cannot be computed (outside the valid domain of a strong distortion)
    /// show the backdrop at infinite depth.
    pub fn render(&self, camera: &Camera, options: &RenderOptions) -> Result<Frame> {
        if !(options.noise_sigma >= 0.0 && options.noise_sigma.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "noise_sigma",
                value: options.noise_sigma as f64,
                reason: "must be finite and non-negative",
            });
        }
        let (w, h) = (camera.size.width as usize, camera.size.height as usize);
        let ctx = self.context(camera);
        let world_from_cam = camera.world_from_cam();
        let rot = world_from_cam.rotation.to_rotation_matrix();
        let origin = camera.centre();
        let k = camera.intrinsics;
        let pinhole = camera.distortion.is_none();

        let mut rgb = vec![0f32; w * h * 3];
        let mut depth = vec![0f32; w * h];
        let mut mask = vec![0u8; w * h];
        rgb.par_chunks_mut(w * 3)
            .zip(depth.par_chunks_mut(w))
            .zip(mask.par_chunks_mut(w))
            .enumerate()
            .for_each(|(v, ((rgb_row, depth_row), mask_row))| {
                for u in 0..w {
                    let px = nalgebra::Point2::new(u as f64, v as f64);
                    let normal = if pinhole {
                        Some(k.normalized_from_pixel(px))
                    } else {
                        camera.normalized_from_pixel(px)
                    };
                    let (colour, z) = match normal {
                        Some(n) => {
                            // Unnormalised direction with camera z = 1: t is the depth.
                            let dir = rot * Vector3::new(n.x, n.y, 1.0);
                            ctx.primary(&origin, &dir)
                        }
                        None => (Colour::zeros(), f32::INFINITY),
                    };
                    let mut c = colour;
                    if options.noise_sigma > 0.0 {
                        let mut rng = SplitMix64::for_item(options.seed, (v * w + u) as u64);
                        for i in 0..3 {
                            c[i] += options.noise_sigma * rng.gaussian() as f32;
                        }
                    }
                    for i in 0..3 {
                        rgb_row[3 * u + i] = c[i].clamp(0.0, 1.0);
                    }
                    depth_row[u] = z;
                    mask_row[u] = if z.is_finite() { 255 } else { 0 };
                }
            });
        let size_err = || Error::InvalidParameter {
            name: "image size",
            value: (w * h) as f64,
            reason: "buffer does not match the image size",
        };
        Ok(Frame {
            rgb: ImageBuffer::<Rgb<f32>, _>::from_raw(w as u32, h as u32, rgb)
                .ok_or_else(size_err)?,
            depth: ImageBuffer::from_raw(w as u32, h as u32, depth).ok_or_else(size_err)?,
            mask: GrayImage::from_raw(w as u32, h as u32, mask).ok_or_else(size_err)?,
        })
    }
}

impl Context<'_> {
    /// Colour and depth of a primary ray (`dir` has camera z = 1).
    fn primary(&self, origin: &Point3<f64>, dir: &Vector3<f64>) -> (Colour, f32) {
        match self.scene.first_hit(origin, dir, 0.0, f64::INFINITY) {
            Some(hit) => {
                let unit = dir.normalize();
                let p = origin + dir * hit.hit.t;
                (self.shade(&hit, &p, &unit, 0), hit.hit.t as f32)
            }
            None => (
                self.scene
                    .backdrop_colour(&(self.lab_from_world * dir.normalize())),
                f32::INFINITY,
            ),
        }
    }

    /// Radiance leaving `p` toward the ray that arrived along the unit direction `incoming`.
    fn shade(
        &self,
        hit: &SceneHit,
        p: &Point3<f64>,
        incoming: &Vector3<f64>,
        bounce: u32,
    ) -> Colour {
        let mut n = hit.hit.normal;
        if n.dot(incoming) > 0.0 {
            n = -n;
        }
        let object = &self.scene.objects[hit.object];
        match &object.material {
            Material::Matte { texture } => {
                self.lit(p, &n, incoming, texture.colour_at(p), 0.0, 1.0)
            }
            Material::Glossy {
                texture,
                specular,
                shininess,
            } => self.lit(p, &n, incoming, texture.colour_at(p), *specular, *shininess),
            Material::Mirror { tint } => {
                let r = incoming - n * (2.0 * incoming.dot(&n));
                let start = p + n * SURFACE_EPSILON;
                let reflected = if bounce < MAX_BOUNCES {
                    self.scene
                        .first_hit(&start, &r, 0.0, f64::INFINITY)
                        .map(|h| self.shade(&h, &(start + r * h.hit.t), &r, bounce + 1))
                } else {
                    None
                };
                let c = reflected
                    .unwrap_or_else(|| self.scene.environment_colour(&(self.lab_from_world * r)));
                tint.component_mul(&c)
            }
        }
    }

    /// Sky light plus point lights with shadows; Blinn-Phong highlight when `specular > 0`.
    fn lit(
        &self,
        p: &Point3<f64>,
        n: &Vector3<f64>,
        incoming: &Vector3<f64>,
        albedo: Colour,
        specular: f32,
        shininess: f32,
    ) -> Colour {
        let sky = &self.scene.sky;
        let up = (0.5 + 0.5 * n.z) as f32;
        let mut irradiance = sky.down + (sky.up - sky.down) * up;
        let mut highlight = Colour::zeros();
        let start = p + n * SURFACE_EPSILON;
        for (position, colour) in &self.lights_world {
            let to_light = position - p;
            let dist = to_light.norm();
            let l = to_light / dist;
            let ndotl = n.dot(&l);
            if ndotl <= 0.0 || self.scene.occluded(&start, &l, 0.0, dist) {
                continue;
            }
            irradiance += colour * ndotl as f32;
            if specular > 0.0 {
                let half = (l - incoming).normalize();
                let s = n.dot(&half).max(0.0).powf(shininess as f64) as f32;
                highlight += colour * (specular * s);
            }
        }
        albedo.component_mul(&irradiance) + highlight
    }
}
