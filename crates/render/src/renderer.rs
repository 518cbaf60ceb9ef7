//! The depth-driven IBR renderer (section 2.2 of the paper): a virtual ray is interpolated
//! from captured rays through the surface point it meets.

use std::borrow::Cow;

use aibr_camera::{Camera, ImageSize};
use aibr_voxel::{DepthMap, VoxelModel};
use image::{GrayImage, RgbImage};
use nalgebra::{Point2, Point3, Rotation3, Vector3};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::reflection::{MirrorCounts, MirrorLayer, MirrorMap, Reflections};

/// A captured view: a pinhole camera and its image.
#[derive(Debug, Clone)]
pub struct SourceView {
    /// The camera (no lens distortion: undistort the image first).
    pub camera: Camera,
    /// The image.
    pub image: RgbImage,
}

/// Parameters of the blend (Buehler et al.'s unstructured lumigraph).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderParams {
    /// Sources blended per pixel (default 3).
    pub k: usize,
    /// Sources considered per frame: the nearest in angle to the virtual camera as seen from
    /// the object (default 4: the `k` blended and the one that sets their threshold; at most
    /// 16).
    pub candidates: usize,
    /// Weight of the resolution penalty (a source farther from the point than the virtual
    /// camera sees it coarser) against the angular one (default 0.2).
    pub resolution_weight: f64,
    /// A source sees a surface point when the point is at most this many voxels behind the
    /// source's own depth there (default 2, from 0 to [`MAX_OCCLUSION_TOLERANCE`]; 4
    /// renders every catalogue scene as well or a little better, by up to 0.10 dB, and is
    /// not the default only because every render figure would have to be measured again:
    /// `docs/render.md`, "The occlusion tolerance").
    pub occlusion_tolerance_voxels: f64,
    /// Refine each pixel's depth near the model's surface by photo-consistency (default on,
    /// with [`DepthRefinement::default`]; `None` renders at the model's surface).
    pub refine: Option<DepthRefinement>,
    /// Render from the model closed and filled, [`VoxelModel::filled`] with this closing
    /// (default `Some(1)`: gaps in the model's shell up to about two voxels wide bridged, and
    /// what the shell then encloses filled; at most 8). A voxel coloring model is a shell
    /// with gaps and an empty inside; a ray through a gap meets what lies behind, such as the
    /// far side's inner face. `None` renders from the model as given.
    pub fill: Option<usize>,
    /// Mirror reflections on a turntable (default `None`, off): where the model's surface is
    /// a mirror, a pixel takes the colour the nearest source sees reflected in the same
    /// direction of the lab ([`crate::reflection`]). Voxel coloring carves a mirror away: give
    /// the renderer the visual hull ([`Renderer::with_visual_hull`]) to take the mirrors its
    /// models lack from it (`docs/render.md`, "Mirror reflections"). The renderer then keeps 4
    /// bytes per voxel of the model's grid, and a normal per surface voxel (with the hull's
    /// mirrors, 8 bytes more per voxel).
    pub reflections: Option<Reflections>,
    /// How the blend reads a source's colour between its pixel centres at the points the
    /// model gives (default [`Sampling::Bilinear`]). The focal surface of the fallback, the
    /// depth refinement's colour costs and the reflections are sampled bilinearly either way.
    pub sampling: Sampling,
}

/// How the renderer reads a source image between its pixel centres.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Sampling {
    /// The 2x2 pixels around the point, weighted by their distance along each axis.
    #[default]
    Bilinear,
    /// The 4x4 pixels around the point, weighted by the Catmull-Rom spline along each axis:
    /// sharper, since bilinear weights blur a texture half-way between pixels. Half-way
    /// views of the catalogue render up to 0.5 dB better, more the denser the views, and
    /// the bench frame takes about 7% longer (`docs/render.md`, "Bicubic sampling").
    Bicubic,
}

/// Depth refinement near the model's surface.
///
/// Voxel coloring leaves surfaces a voxel or two in front of where they are (sheets of
/// photo-consistent voxels, `docs/render.md`). For each pixel that meets the model, depths from
/// `front_voxels` in front of the hit to `back_voxels` behind it are tried; at each, two
/// sources near the virtual camera (the nearest in angle and, with
/// [`DepthRefinement::bracketing`], the nearest candidate on its other side) are sampled and
/// their squared colour difference summed over a window of neighbouring pixels on the same
/// surface (within 1.5 voxels of the pixel's depth), each at its own depth plus the same
/// offset. The pixel is blended at the offset where the sources agree best. Only pixels with
/// `Geometry` coverage are refined, so a search cannot move a pixel onto another surface far
/// away.
///
/// A deep search helps where the model is fat (from few views) but can settle on a depth that
/// agrees by chance; [`DepthRefinement::penalty`] asks the depths beyond
/// [`DepthRefinement::free_voxels`] to agree clearly better before they are taken. Measured on
/// the catalogue (`docs/render.md`, "A penalised deep search"), a reach of 8 voxels in 12
/// depths with a penalty of 0.3 renders four scenes 0.07-0.68 dB better than the default and
/// `chair` within 0.09 dB; the default stays the session-7 search until every figure is
/// measured again with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthRefinement {
    /// Nearest depth tried, in voxels in front of the model's first hit (default 0.5).
    pub front_voxels: f64,
    /// Farthest depth tried, in voxels behind the hit (default 4).
    pub back_voxels: f64,
    /// Depths tried, evenly spaced (default 7, three quarters of a voxel apart; at least 2,
    /// at most 64).
    pub steps: usize,
    /// Half-width of the square window the costs are summed over (default 1: 3x3 pixels; at
    /// most 16).
    pub radius: usize,
    /// How much better a depth deeper than [`DepthRefinement::free_voxels`] behind the hit must
    /// agree: its window's summed cost is multiplied by `1 + penalty x d`, `d` being how many
    /// voxels deeper it lies (default 0: every depth weighs alike; finite, at most 100).
    pub penalty: f64,
    /// Voxels behind the hit within which no depth is penalised (default 4, the default
    /// reach; finite).
    pub free_voxels: f64,
    /// Compare the nearest source with the nearest of the frame's other candidates that lies
    /// on the other side of the virtual camera, when one does (default true), instead of with
    /// the second nearest. Where views are spread unevenly, as active capture leaves them, the
    /// two nearest can lie on the same side, and the depth they agree on is then taken from a
    /// short baseline to one side of the novel ray (`docs/render.md`, "The refinement's pair
    /// of sources"). Views spread evenly always have the two nearest on both sides, so there
    /// the two rules are one.
    pub bracketing: bool,
}

impl Default for DepthRefinement {
    fn default() -> Self {
        DepthRefinement {
            front_voxels: 0.5,
            back_voxels: 4.0,
            steps: 7,
            radius: 1,
            penalty: 0.0,
            free_voxels: 4.0,
            bracketing: true,
        }
    }
}

impl Default for RenderParams {
    fn default() -> Self {
        RenderParams {
            k: 3,
            candidates: 4,
            resolution_weight: 0.2,
            occlusion_tolerance_voxels: 2.0,
            refine: Some(DepthRefinement::default()),
            fill: Some(1),
            reflections: None,
            sampling: Sampling::Bilinear,
        }
    }
}

impl RenderParams {
    /// Checks what [`Renderer::new`] would refuse: `k` or `candidates` zero, or more than
    /// [`MAX_CANDIDATES`] candidates; a resolution weight negative or NaN; an occlusion
    /// tolerance outside 0-[`MAX_OCCLUSION_TOLERANCE`] or NaN; a refinement of fewer than 2
    /// or more than 64 depths, an
    /// empty or non-finite span of depths, a window radius over 16 pixels, a penalty outside
    /// 0-100 or NaN, or a non-finite free depth; a
    /// [`RenderParams::fill`] closing over [`MAX_FILL_CLOSING`]. Each is
    /// [`Error::InvalidParameter`], naming the field and its value.
    pub fn validate(&self) -> Result<()> {
        if self.k == 0 || self.candidates == 0 || self.candidates > MAX_CANDIDATES {
            return Err(Error::InvalidParameter {
                name: "candidates",
                value: self.candidates as f64,
                reason: "k and candidates must be positive, candidates at most 16",
            });
        }
        if !(self.resolution_weight >= 0.0 && self.resolution_weight.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "resolution_weight",
                value: self.resolution_weight,
                reason: "must be finite and not negative",
            });
        }
        if !(0.0..=MAX_OCCLUSION_TOLERANCE).contains(&self.occlusion_tolerance_voxels) {
            return Err(Error::InvalidParameter {
                name: "occlusion_tolerance_voxels",
                value: self.occlusion_tolerance_voxels,
                reason: "between 0 and 64 voxels",
            });
        }
        if let Some(r) = self.refine {
            if !(2..=MAX_REFINE_STEPS).contains(&r.steps) {
                return Err(Error::InvalidParameter {
                    name: "refine.steps",
                    value: r.steps as f64,
                    reason: "between 2 and 64 depths",
                });
            }
            if !(r.front_voxels.is_finite()
                && r.back_voxels.is_finite()
                && -r.front_voxels < r.back_voxels)
            {
                return Err(Error::InvalidParameter {
                    name: "refine.back_voxels",
                    value: r.back_voxels,
                    reason: "the searched depths must be finite and not empty",
                });
            }
            if r.radius > 16 {
                return Err(Error::InvalidParameter {
                    name: "refine.radius",
                    value: r.radius as f64,
                    reason: "at most 16 pixels",
                });
            }
            if !(0.0..=MAX_REFINE_PENALTY).contains(&r.penalty) {
                return Err(Error::InvalidParameter {
                    name: "refine.penalty",
                    value: r.penalty,
                    reason: "between 0 and 100",
                });
            }
            if !r.free_voxels.is_finite() {
                return Err(Error::InvalidParameter {
                    name: "refine.free_voxels",
                    value: r.free_voxels,
                    reason: "must be finite",
                });
            }
        }
        if let Some(reflections) = &self.reflections {
            reflections.validate()?;
        }
        if let Some(closing) = self.fill.filter(|&c| c > MAX_FILL_CLOSING) {
            return Err(Error::InvalidParameter {
                name: "fill",
                value: closing as f64,
                reason: "a closing of at most 8 voxels",
            });
        }
        Ok(())
    }
}

/// The largest closing [`RenderParams::fill`] takes.
pub const MAX_FILL_CLOSING: usize = 8;

/// The most depths [`DepthRefinement::steps`] takes (the fewest is 2).
pub const MAX_REFINE_STEPS: usize = 64;

/// The largest [`DepthRefinement::penalty`].
pub const MAX_REFINE_PENALTY: f64 = 100.0;

/// Most candidate sources per frame.
pub const MAX_CANDIDATES: usize = 16;

/// The largest [`RenderParams::occlusion_tolerance_voxels`]: half the edge of a 128^3 grid,
/// beyond which a source on the far side of most objects would count as seeing the point.
pub const MAX_OCCLUSION_TOLERANCE: f64 = 64.0;

/// The refinement's costs per pixel are kept in groups of this many depths.
const COST_LANES: usize = 8;

/// [`Source::pixels`]'s `u` for a point a source does not see on its image (a pixel there has
/// `u >= 0`).
const OFF_IMAGE: f64 = -1.0;

/// How a rendered pixel was made (values of [`RenderedView::coverage`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Coverage {
    /// No source sees the pixel's point: black, infinite depth.
    Nothing = 0,
    /// The model has no surface there (or no source sees it): blended at the focal surface,
    /// the depth of the object centre, or, for a ray that passes within a splat of the model's
    /// outline without meeting a voxel, at the nearest splatted surface depth.
    Fallback = 1,
    /// Blended at the model's surface point, from the sources that see it (for a ray
    /// through a pinhole in the model's surface, at the depth of the surface around the hole).
    Geometry = 2,
}

/// One rendered view.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedView {
    /// Colour.
    pub rgb: RgbImage,
    /// Camera-z of the point used per pixel (model surface or focal surface), metres;
    /// infinite where nothing was rendered.
    pub depth: DepthMap,
    /// [`Coverage`] per pixel, as its `u8` value.
    pub coverage: GrayImage,
    /// Per pixel, the nearest splatted surface-voxel depth of the last frame (scratch).
    splat: Vec<f32>,
    /// The refinement's scratch (empty unless refining): per pixel its slot in `refined`
    /// (`u32::MAX` for none), the refined pixels, and per refined pixel its cost per depth.
    slots: Vec<u32>,
    refined: Vec<u32>,
    costs: Vec<f32>,
}

impl RenderedView {
    /// Buffers for views of `size`, to pass to [`Renderer::render_into`] frame after frame.
    pub fn new(size: ImageSize) -> Self {
        RenderedView {
            rgb: RgbImage::new(size.width, size.height),
            depth: DepthMap::new(size.width, size.height),
            coverage: GrayImage::new(size.width, size.height),
            splat: vec![f32::INFINITY; size.pixel_count()],
            slots: Vec::new(),
            refined: Vec::new(),
            costs: Vec::new(),
        }
    }

    /// The coverage of pixel `(x, y)` (`Nothing` off the image).
    pub fn coverage_at(&self, x: u32, y: u32) -> Coverage {
        match self.coverage.get_pixel_checked(x, y).map(|p| p.0[0]) {
            Some(2) => Coverage::Geometry,
            Some(1) => Coverage::Fallback,
            _ => Coverage::Nothing,
        }
    }

    /// Share of pixels with each coverage: `(geometry, fallback, nothing)`.
    pub fn coverage_shares(&self) -> (f64, f64, f64) {
        let mut n = [0usize; 3];
        for p in self.coverage.pixels() {
            n[p.0[0].min(2) as usize] += 1;
        }
        let total = self.coverage.len().max(1) as f64;
        (
            n[2] as f64 / total,
            n[1] as f64 / total,
            n[0] as f64 / total,
        )
    }

    /// The coverage as an image to look at: white where the model's surface was met
    /// (`Geometry`), mid grey where the focal surface stood in (`Fallback`), black where no
    /// source sees the point (`Nothing`).
    ///
    /// ```
    /// use aibr_camera::ImageSize;
    /// use aibr_render::RenderedView;
    ///
    /// let mut view = RenderedView::new(ImageSize::new(3, 1));
    /// view.coverage.as_mut().copy_from_slice(&[2, 1, 0]);
    /// assert_eq!(view.coverage_image().as_raw(), &[255, 128, 0]);
    /// ```
    pub fn coverage_image(&self) -> GrayImage {
        let (geometry, fallback) = (Coverage::Geometry as u8, Coverage::Fallback as u8);
        let mut img = self.coverage.clone();
        for p in img.iter_mut() {
            *p = match *p {
                c if c == geometry => 255,
                c if c == fallback => 128,
                _ => 0,
            };
        }
        img
    }
}

/// A source view prepared for rendering: its image, its depth map splatted from the model, and
/// its projection.
pub(crate) struct Source {
    image: RgbImage,
    world_from_cam: Rotation3<f64>,
    depth: Vec<f32>,
    p: [[f64; 4]; 3],
    centre: Point3<f64>,
    width: u32,
    height: u32,
}

impl Source {
    /// The image.
    pub(crate) fn image(&self) -> &RgbImage {
        &self.image
    }

    /// The camera's centre.
    pub(crate) fn centre(&self) -> Point3<f64> {
        self.centre
    }

    /// The camera's rotation from its frame to the world.
    pub(crate) fn world_from_cam(&self) -> &Rotation3<f64> {
        &self.world_from_cam
    }

    /// The pixel where this source sees the world point `x` on its own surface: on the image,
    /// and within `tolerance` of the source's depth there, in front or behind.
    pub(crate) fn on_surface(&self, x: &Point3<f64>, tolerance: f64) -> Option<(f64, f64)> {
        let h = self.homogeneous(x);
        let (u, v) = self.pixel(h)?;
        ((h[2] - self.depth_at(u, v)).abs() <= tolerance).then_some((u, v))
    }

    /// The point of this source's own surface on its ray through the world point `x`, when `x`
    /// is on its image and the source has a surface there.
    pub(crate) fn surface_behind(&self, x: &Point3<f64>) -> Option<Point3<f64>> {
        let h = self.homogeneous(x);
        let (u, v) = self.pixel(h)?;
        let depth = self.depth_at(u, v);
        // The third homogeneous coordinate is the point's depth along the camera's axis.
        depth
            .is_finite()
            .then(|| self.centre + (x - self.centre) * (depth / h[2]))
    }

    /// The source's own depth at the pixel nearest `(u, v)`, a point on its image (so
    /// `u, v >= 0`: adding a half and truncating rounds them, through `i32`, one instruction on
    /// x86-64 where `usize` takes several).
    #[inline]
    fn depth_at(&self, u: f64, v: f64) -> f64 {
        let (x, y) = ((u + 0.5) as i32 as usize, (v + 0.5) as i32 as usize);
        f64::from(self.depth[y * self.width as usize + x])
    }

    /// Homogeneous image coordinates of the world point `x`.
    #[inline]
    fn homogeneous(&self, x: &Point3<f64>) -> [f64; 3] {
        self.p.map(|r| r[0] * x.x + r[1] * x.y + r[2] * x.z + r[3])
    }

    /// Homogeneous image coordinates of the world direction `d` (the change per unit along it).
    #[inline]
    fn direction(&self, d: &Vector3<f64>) -> [f64; 3] {
        self.p.map(|r| r[0] * d.x + r[1] * d.y + r[2] * d.z)
    }

    /// The pixel where this source sees the world point `p`: `Some((u, v))` when `p` projects
    /// onto the image and, with `occlusion`, is not behind the source's own depth there by
    /// more than that tolerance.
    #[inline]
    pub(crate) fn sees(&self, p: &Point3<f64>, occlusion: Option<f64>) -> Option<(f64, f64)> {
        let h = self.homogeneous(p);
        let (u, v) = self.pixel(h)?;
        if let Some(tolerance) = occlusion {
            if h[2] > self.depth_at(u, v) + tolerance {
                return None;
            }
        }
        Some((u, v))
    }

    /// [`Source::pixel`] of the homogeneous coordinates `base + t slope` for a group of
    /// [`COST_LANES`] values of `t`: the pixels, with `u` set to [`OFF_IMAGE`] where the point is
    /// behind the camera or off the image. Without branches (a select rather than a flag), so
    /// that the compiler does the lanes as vectors.
    #[inline(always)]
    fn pixels(
        &self,
        base: [f64; 3],
        slope: [f64; 3],
        ts: &[f64],
    ) -> ([f64; COST_LANES], [f64; COST_LANES]) {
        let (mut us, mut vs) = ([0.0; COST_LANES], [0.0; COST_LANES]);
        for (l, &t) in ts.iter().take(COST_LANES).enumerate() {
            let (u, v, on) = self.project(std::array::from_fn(|i| base[i] + t * slope[i]));
            us[l] = if on { u } else { OFF_IMAGE };
            vs[l] = v;
        }
        (us, vs)
    }

    /// The pixel of homogeneous coordinates `h`: `Some((u, v))` when in front of the camera and
    /// on the image (so `u, v >= 0`).
    #[inline]
    fn pixel(&self, h: [f64; 3]) -> Option<(f64, f64)> {
        let (u, v, on) = self.project(h);
        on.then_some((u, v))
    }

    /// The pixel `(u, v)` of homogeneous coordinates `h`, and whether it is in front of the
    /// camera and on the image; `&`, not `&&`, so that it has no branches.
    #[inline(always)]
    fn project(&self, h: [f64; 3]) -> (f64, f64, bool) {
        let inv_z = 1.0 / h[2];
        let (u, v) = (h[0] * inv_z, h[1] * inv_z);
        let (max_u, max_v) = ((self.width - 1) as f64, (self.height - 1) as f64);
        let on = (h[2] > 0.0) & (u >= 0.0) & (v >= 0.0) & (u <= max_u) & (v <= max_v);
        (u, v, on)
    }
}

/// The ray through pixel `(u, v)` of `camera` in the world, scaled to camera z = 1 (`rot` is
/// the camera's world-from-camera rotation); `None` where lens distortion has no inverse.
#[inline]
fn pixel_ray(camera: &Camera, rot: &Rotation3<f64>, u: usize, v: usize) -> Option<Vector3<f64>> {
    let px = Point2::new(u as f64, v as f64);
    let n = if camera.distortion.is_none() {
        Some(camera.intrinsics.normalized_from_pixel(px))
    } else {
        camera.normalized_from_pixel(px)
    }?;
    Some(rot * Vector3::new(n.x, n.y, 1.0))
}

/// Renders novel views from captured views and a voxel model.
///
/// By default rays are cast into the model closed and filled, not into the shell as given
/// ([`RenderParams::fill`]). Per pixel: the model is ray cast (3D DDA) for the surface point;
/// each candidate source that sees the point (its own depth, splatted from the model at
/// set-up, is not nearer by more than the tolerance) gets the unstructured-lumigraph penalty
/// `angle + resolution_weight * resolution` (angle between the rays from the point to the
/// virtual and the source camera, as a chord of unit vectors; resolution the relative excess
/// distance of the source). The `k` best are blended with weights `(1 - p / p_(k+1)) / p`,
/// which fall smoothly to zero as a source leaves the `k` best, so the image changes
/// continuously with the camera. A ray whose point no source sees, because it went through a
/// pinhole in the model's surface and met the far side, is blended instead at the depth of
/// the surface splatted around the hole, when the sources see that. Then, by default, each
/// such pixel's depth is refined near the model's surface ([`DepthRefinement`]) and the
/// pixel blended again there. Where the model has no surface the point is taken on the focal
/// surface at the depth of the object centre (or, beside the model's outline, at the nearest
/// surface voxel's depth), so the image degrades like a light field instead of showing holes.
pub struct Renderer<'a> {
    /// The model rays are cast into: the caller's, or it closed and filled
    /// ([`RenderParams::fill`]).
    model: Cow<'a, VoxelModel>,
    sources: Vec<Source>,
    params: RenderParams,
    focus: Point3<f64>,
    tolerance: f64,
    /// Centres of the model's surface voxels, splatted every frame.
    surface: Vec<Point3<f64>>,
    /// How far in front of the nearest splat a ray's DDA starts
    /// ([`aibr_voxel::SPLAT_MARGIN_VOXELS`], in metres).
    splat_margin: f64,
    /// The model's mirrors, with [`RenderParams::reflections`].
    mirrors: Option<MirrorMap>,
    /// The mirrors the model lacks, from the visual hull ([`Renderer::with_visual_hull`]).
    layer: Option<MirrorLayer>,
    /// How many voxels the reflections judged and found mirrors.
    counts: Option<MirrorCounts>,
}

impl<'a> Renderer<'a> {
    /// Prepares the sources: their depth maps are splatted from the model's surface voxels.
    pub fn new(
        model: &'a VoxelModel,
        sources: Vec<SourceView>,
        params: RenderParams,
    ) -> Result<Self> {
        if sources.is_empty() {
            return Err(Error::NoSources);
        }
        params.validate()?;
        let model = match params.fill {
            Some(closing) => Cow::Owned(model.filled(closing)),
            None => Cow::Borrowed(model),
        };
        let grid = *model.grid();
        let surface = model.surface_voxels();
        let s = grid.voxel_size();
        let focus = if surface.is_empty() {
            grid.bounds().centre()
        } else {
            let sum = surface
                .iter()
                .fold(Vector3::zeros(), |a, v| a + grid.centre(*v).coords);
            Point3::from(sum / surface.len() as f64)
        };
        let prepared = sources
            .into_par_iter()
            .enumerate()
            .map(|(i, sv)| {
                let cam = &sv.camera;
                if !cam.distortion.is_none() {
                    return Err(Error::Distorted { view: i });
                }
                if sv.image.dimensions() != (cam.size.width, cam.size.height) {
                    return Err(Error::SizeMismatch {
                        what: "source image",
                        width: sv.image.width(),
                        height: sv.image.height(),
                        expected_width: cam.size.width,
                        expected_height: cam.size.height,
                    });
                }
                let m = cam.projection_matrix();
                let p: [[f64; 4]; 3] = std::array::from_fn(|r| std::array::from_fn(|c| m[(r, c)]));
                let (w, h) = (cam.size.width as i64, cam.size.height as i64);
                let mut depth = vec![f32::INFINITY; (w * h) as usize];
                let f = cam.intrinsics.fx.max(cam.intrinsics.fy);
                for v in &surface {
                    let x = grid.centre(*v);
                    let Some(px) = cam.project(&x) else { continue };
                    let z = cam.depth_of(&x);
                    // Half the projected voxel edge, as the voxel kernels use.
                    let r = 0.5 * s * f / z;
                    let (u0, u1) = ((px.x - r).round() as i64, (px.x + r).round() as i64);
                    let (v0, v1) = ((px.y - r).round() as i64, (px.y + r).round() as i64);
                    for yy in v0.max(0)..=v1.min(h - 1) {
                        for xx in u0.max(0)..=u1.min(w - 1) {
                            let d = &mut depth[(yy * w + xx) as usize];
                            *d = d.min(z as f32);
                        }
                    }
                }
                Ok(Source {
                    world_from_cam: cam.world_from_cam().rotation.to_rotation_matrix(),
                    centre: cam.centre(),
                    width: cam.size.width,
                    height: cam.size.height,
                    image: sv.image,
                    depth,
                    p,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let tolerance = params.occlusion_tolerance_voxels * s;
        let (mirrors, model_tally) = params
            .reflections
            .map(|r| MirrorMap::new(&model, &surface, &prepared, tolerance, &r))
            .unzip();
        Ok(Renderer {
            layer: None,
            mirrors,
            counts: model_tally.map(|model| MirrorCounts { model, hull: None }),
            model,
            sources: prepared,
            params,
            focus,
            tolerance,
            surface: surface.iter().map(|v| grid.centre(*v)).collect(),
            splat_margin: aibr_voxel::SPLAT_MARGIN_VOXELS * s,
        })
    }

    /// With [`RenderParams::reflections`], takes the mirrors the model lacks from `hull`, the
    /// visual hull of the sources' silhouettes on the model's grid (for example
    /// [`aibr_voxel::visual_hull`]): voxel coloring carves a mirror away, and the hull keeps
    /// its surface. See [`crate::reflection`] for which of the hull's voxels become mirrors.
    /// Without reflections the renderer is returned as it is.
    ///
    /// # Errors
    /// [`Error::GridMismatch`] when `hull` is not on the model's grid.
    pub fn with_visual_hull(mut self, hull: &VoxelModel) -> Result<Self> {
        if hull.grid() != self.model.grid() {
            return Err(Error::GridMismatch {
                what: "visual hull",
            });
        }
        if let Some(params) = &self.params.reflections {
            let (layer, tally) =
                MirrorLayer::new(&self.model, hull, &self.sources, self.tolerance, params);
            self.layer = layer;
            if let Some(counts) = &mut self.counts {
                counts.hull = Some(tally);
            }
        }
        Ok(self)
    }

    /// With [`RenderParams::reflections`], how many of the model's surface voxels (and of the
    /// visual hull's, given one) were judged, passed the tests of a mirror and were kept as
    /// mirrors; `None` without reflections.
    pub fn mirror_counts(&self) -> Option<MirrorCounts> {
        self.counts
    }

    /// The focal point: the centroid of the model's surface voxels.
    pub fn focus(&self) -> Point3<f64> {
        self.focus
    }

    /// Renders the view of `camera` into new buffers.
    pub fn render(&self, camera: &Camera) -> Result<RenderedView> {
        let mut out = RenderedView::new(camera.size);
        self.render_into(camera, &mut out)?;
        Ok(out)
    }

    /// Renders the view of `camera` into `out` (of the camera's size); no allocation.
    pub fn render_into(&self, camera: &Camera, out: &mut RenderedView) -> Result<()> {
        let (w, h) = (camera.size.width, camera.size.height);
        for (what, dims) in [
            ("rgb buffer", out.rgb.dimensions()),
            ("depth buffer", out.depth.dimensions()),
            ("coverage buffer", out.coverage.dimensions()),
        ] {
            if dims != (w, h) {
                return Err(Error::SizeMismatch {
                    what,
                    width: dims.0,
                    height: dims.1,
                    expected_width: w,
                    expected_height: h,
                });
            }
        }
        let centre = camera.centre();
        let (candidates, n_cand) = self.candidates(&centre);
        let candidates = &candidates[..n_cand];
        // Splat the surface voxels (half their diagonal, so every ray that meets a voxel
        // lands in its splat): each ray's DDA then starts just before the nearest splat, and
        // a pixel no splat covers meets no voxel at all.
        if out.splat.len() != (w * h) as usize {
            out.splat.resize((w * h) as usize, f32::INFINITY);
        }
        let s = self.model.grid().voxel_size();
        aibr_voxel::splat_depths(&self.surface, s, camera, &mut out.splat);
        let rot = camera.world_from_cam().rotation.to_rotation_matrix();
        let cam_rot = rot.inverse();
        let focal_depth = camera.depth_of(&self.focus).max(1e-6);
        let pinhole = camera.distortion.is_none();
        // The refinement blends every Geometry pixel again, so the main pass only finds them.
        let refining = self.params.refine.is_some() && candidates.len() >= 2 && pinhole;
        let width = w as usize;
        let splat = &out.splat;
        out.rgb
            .par_chunks_mut(width * 3)
            .zip(out.depth.par_chunks_mut(width))
            .zip(out.coverage.par_chunks_mut(width))
            .enumerate()
            .for_each(|(v, ((rgb_row, depth_row), cov_row))| {
                let splat_row = &splat[v * width..(v + 1) * width];
                // Pixels that no splat covers lie on the focal plane: shaded by runs, along
                // which every quantity of the blend is linear in `u`.
                let plane = if pinhole {
                    FocalRow::new(self, camera, &rot, v, focal_depth, candidates)
                } else {
                    None
                };
                let mut u = 0;
                while u < width {
                    if let Some(plane) = &plane {
                        let run = splat_row[u..]
                            .iter()
                            .take_while(|d| d.is_infinite())
                            .count();
                        if run > 0 {
                            let end = u + run;
                            self.shade_focal_run(
                                plane,
                                u,
                                &mut rgb_row[3 * u..3 * end],
                                &mut depth_row[u..end],
                                &mut cov_row[u..end],
                            );
                            u = end;
                            continue;
                        }
                    }
                    let (colour, depth, coverage) = match pixel_ray(camera, &rot, u, v) {
                        Some(dir) => {
                            let (mut colour, depth, coverage) = self.shade(
                                &centre,
                                &dir,
                                splat[v * width + u] as f64,
                                focal_depth,
                                candidates,
                                !refining,
                            );
                            if coverage == Coverage::Geometry && !refining {
                                let p = centre + dir * f64::from(depth);
                                if let Some(c) = self.reflected(&p, &centre, &cam_rot, candidates) {
                                    colour = c;
                                }
                            }
                            (colour, depth, coverage)
                        }
                        None => ([0; 3], f32::INFINITY, Coverage::Nothing),
                    };
                    rgb_row[3 * u..3 * u + 3].copy_from_slice(&colour);
                    depth_row[u] = depth;
                    cov_row[u] = coverage as u8;
                    u += 1;
                }
            });
        if let (Some(refine), true) = (self.params.refine, refining) {
            self.refine(camera, (&rot, &cam_rot), refine, candidates, out);
        }
        Ok(())
    }

    /// The frame's candidates, `(1 - cos angle, source)` for the sources nearest in angle to
    /// a virtual camera at `centre` as seen from the focus, nearest first, and their number.
    fn candidates(&self, centre: &Point3<f64>) -> ([(f64, usize); MAX_CANDIDATES], usize) {
        let to_virtual = (centre - self.focus).normalize();
        let mut candidates = [(f64::INFINITY, usize::MAX); MAX_CANDIDATES];
        let n_cand = self.params.candidates.min(self.sources.len());
        for (i, s) in self.sources.iter().enumerate() {
            let a = 1.0 - (s.centre - self.focus).normalize().dot(&to_virtual);
            if a < candidates[n_cand - 1].0 {
                candidates[n_cand - 1] = (a, i);
                candidates[..n_cand].sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            }
        }
        (candidates, n_cand)
    }

    /// The two sources the depth refinement compares for a virtual camera at `centre`, given
    /// the frame's `candidates` (at least two, nearest first): the nearest and, `bracketing`,
    /// the nearest other candidate on the other side of the virtual camera (its direction from
    /// the focus, less its part along the virtual camera's, points against the nearest's), or
    /// the second nearest when none is or without `bracketing`.
    fn refinement_pair(
        &self,
        centre: &Point3<f64>,
        candidates: &[(f64, usize)],
        bracketing: bool,
    ) -> (usize, usize) {
        let nearest = candidates[0].1;
        let second = candidates[1].1;
        if !bracketing {
            return (nearest, second);
        }
        let to_virtual = (centre - self.focus).normalize();
        let across = |i: usize| {
            let d = (self.sources[i].centre - self.focus).normalize();
            d - to_virtual * d.dot(&to_virtual)
        };
        let side = across(nearest);
        let other = candidates[1..]
            .iter()
            .map(|c| c.1)
            .find(|&i| across(i).dot(&side) < 0.0);
        (nearest, other.unwrap_or(second))
    }

    /// The depth refinement pass (see [`DepthRefinement`]) over a rendered frame; `rot` is
    /// the camera's world-from-camera rotation and `cam_rot` its inverse.
    fn refine(
        &self,
        camera: &Camera,
        (rot, cam_rot): (&Rotation3<f64>, &Rotation3<f64>),
        refine: DepthRefinement,
        candidates: &[(f64, usize)],
        out: &mut RenderedView,
    ) {
        let (w, h) = (camera.size.width as usize, camera.size.height as usize);
        let steps = refine.steps;
        let s = self.model.grid().voxel_size();
        let span = refine.front_voxels + refine.back_voxels;
        let offsets: [f64; 64] = std::array::from_fn(|k| {
            s * (-refine.front_voxels + span * k as f64 / (steps - 1) as f64)
        });
        let centre = camera.centre();
        let (a, b) = self.refinement_pair(&centre, candidates, refine.bracketing);
        let (a, b) = (&self.sources[a], &self.sources[b]);
        // The frame's depths, read while the colours and depths are rewritten, and the
        // Geometry pixels in a compact list with their cost slots.
        out.splat.copy_from_slice(out.depth.as_raw());
        let geometry = Coverage::Geometry as u8;
        out.slots.resize(w * h, u32::MAX);
        out.refined.clear();
        for (i, (slot, &c)) in out.slots.iter_mut().zip(out.coverage.as_raw()).enumerate() {
            *slot = if c == geometry {
                out.refined.push(i as u32);
                (out.refined.len() - 1) as u32
            } else {
                u32::MAX
            };
        }
        // Each pixel's costs in a cell of whole groups of eight, so that the window sums below
        // add eight depths at a time; the padding stays zero and is never read.
        let stride = steps.next_multiple_of(COST_LANES);
        out.costs.resize(out.refined.len() * stride, 0.0);
        let depths = &out.splat;
        out.costs
            .par_chunks_mut(stride)
            .zip(out.refined.par_iter())
            .for_each(|(cell, &i)| {
                let (u, v) = (i as usize % w, i as usize / w);
                let Some(dir) = pixel_ray(camera, rot, u, v) else {
                    return;
                };
                let p = centre + dir * depths[i as usize] as f64;
                // The point `p + t dir` in each source, homogeneous: `base + t slope`.
                let (ba, sa) = (a.homogeneous(&p), a.direction(&dir));
                let (bb, sb) = (b.homogeneous(&p), b.direction(&dir));
                let groups = cell
                    .chunks_exact_mut(COST_LANES)
                    .zip(offsets.chunks_exact(COST_LANES));
                for (g, (group, ts)) in groups.enumerate() {
                    // Where each depth's point falls in the two sources, for a group of depths
                    // at once; then the samples, one depth at a time.
                    let (ua, va) = a.pixels(ba, sa, ts);
                    let (ub, vb) = b.pixels(bb, sb, ts);
                    let depths_here = COST_LANES.min(steps - g * COST_LANES);
                    for (l, cost) in group[..depths_here].iter_mut().enumerate() {
                        *cost = if ua[l] != OFF_IMAGE && ub[l] != OFF_IMAGE {
                            let ca = bilinear(&a.image, ua[l] as f32, va[l] as f32);
                            let cb = bilinear(&b.image, ub[l] as f32, vb[l] as f32);
                            let (dr, dg, db) = (ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2]);
                            dr * dr + dg * dg + db * db
                        } else {
                            // Off a source: as bad as the worst colour difference.
                            3.0 * 255.0 * 255.0
                        };
                    }
                }
            });
        let (costs, slots) = (&out.costs, &out.slots);
        let same_surface = (1.5 * s) as f32;
        // Each depth's weight: 1 within the free depth, more beyond it.
        let weights: [f32; 64] = std::array::from_fn(|k| {
            let beyond = (offsets[k] / s - refine.free_voxels).max(0.0);
            (1.0 + refine.penalty * beyond) as f32
        });
        let penalised = refine.penalty > 0.0;
        let r = refine.radius;
        out.rgb
            .par_chunks_mut(w * 3)
            .zip(out.depth.par_chunks_mut(w))
            .enumerate()
            .for_each(|(v, (rgb_row, depth_row))| {
                let mut total = [0f32; 64];
                for u in 0..w {
                    if slots[v * w + u] == u32::MAX {
                        continue;
                    }
                    let z = depths[v * w + u];
                    total[..stride].fill(0.0);
                    for vv in v.saturating_sub(r)..(v + r + 1).min(h) {
                        for uu in u.saturating_sub(r)..(u + r + 1).min(w) {
                            let i = vv * w + uu;
                            let slot = slots[i] as usize;
                            if slot == u32::MAX as usize || (depths[i] - z).abs() > same_surface {
                                continue;
                            }
                            let cell = &costs[slot * stride..(slot + 1) * stride];
                            for (t, c) in total
                                .chunks_exact_mut(COST_LANES)
                                .zip(cell.chunks_exact(COST_LANES))
                            {
                                for l in 0..COST_LANES {
                                    t[l] += c[l];
                                }
                            }
                        }
                    }
                    if penalised {
                        for (t, w) in total[..steps].iter_mut().zip(&weights) {
                            *t *= w;
                        }
                    }
                    // The first of equal minima: ties keep the nearest depth.
                    let best = (0..steps).fold(0, |m, k| if total[k] < total[m] { k } else { m });
                    let zb = z as f64 + offsets[best];
                    let Some(dir) = pixel_ray(camera, rot, u, v) else {
                        continue;
                    };
                    let p = centre + dir * zb;
                    // Moved back by up to the offset, the point is that much deeper in every
                    // source than the model's surface the source depths come from.
                    let tolerance = self.tolerance + offsets[best].max(0.0);
                    let refined = self.blend_preferring_seen(&p, &centre, candidates, tolerance);
                    // Where no candidate takes the refined point (off their images), the
                    // pixel is blended where the main pass found it seen.
                    let (colour, depth) = match refined {
                        Some(c) => (Some(c), zb as f32),
                        None => {
                            let at = centre + dir * z as f64;
                            let colour = self.blend_preferring_seen(
                                &at,
                                &centre,
                                candidates,
                                self.tolerance,
                            );
                            (colour, z)
                        }
                    };
                    // On a mirror, what the nearest source sees reflected the same way, at the
                    // model's surface (the refinement finds no depth where a mirror agrees).
                    let at = centre + dir * f64::from(z);
                    let (colour, depth) = match self.reflected(&at, &centre, cam_rot, candidates) {
                        Some(c) => (Some(c), z),
                        None => (colour, depth),
                    };
                    if let Some(c) = colour {
                        rgb_row[3 * u..3 * u + 3].copy_from_slice(&c);
                        depth_row[u] = depth;
                    }
                }
            });
    }

    /// Shades the pixels `u0..u0 + depth.len()` of a row whose points lie on the focal plane
    /// (no splat covers them), as [`Renderer::shade`] would, a chunk of pixels at a time.
    fn shade_focal_run(
        &self,
        plane: &FocalRow,
        u0: usize,
        rgb: &mut [u8],
        depth: &mut [f32],
        coverage: &mut [u8],
    ) {
        const LANES: usize = 8;
        let n_cand = plane.len;
        let rw = self.params.resolution_weight as f32;
        let focal = plane.focal_depth as f32;
        // Per candidate and lane: its pixel and penalty (infinite where off the source).
        let mut pen = [[0f32; LANES]; MAX_CANDIDATES];
        let mut us = [[0f32; LANES]; MAX_CANDIDATES];
        let mut vs = [[0f32; LANES]; MAX_CANDIDATES];
        // Per pixel, the candidates on whose image its point lies.
        let mut found = [(0usize, 0f32, 0f32); MAX_CANDIDATES];
        let mut penalty = [0f32; MAX_CANDIDATES];
        for (chunk, start) in (0..depth.len()).step_by(LANES).enumerate() {
            let lanes = LANES.min(depth.len() - start);
            let x0 = (u0 + start) as f32;
            let xs: [f32; LANES] = std::array::from_fn(|l| x0 + l as f32);
            // The eye seen from each lane's point: its direction and inverse distance.
            let mut eye = [[0f32; LANES]; 3];
            let mut inv_eye = [0f32; LANES];
            let ([r0x, r0y, r0z], [rdx, rdy, rdz]) = (plane.ray0, plane.ray_du);
            for l in 0..LANES {
                let x = xs[l];
                let (ex, ey, ez) = (
                    -(r0x + x * rdx) * focal,
                    -(r0y + x * rdy) * focal,
                    -(r0z + x * rdz) * focal,
                );
                let inv = 1.0 / (ex * ex + ey * ey + ez * ez).sqrt();
                eye[0][l] = ex * inv;
                eye[1][l] = ey * inv;
                eye[2][l] = ez * inv;
                inv_eye[l] = inv;
            }
            for (j, c) in plane.sources[..n_cand].iter().enumerate() {
                let ([h0x, h0y, h0z], [dhx, dhy, dhz]) = (c.h0, c.dh);
                let ([t0x, t0y, t0z], [dpx, dpy, dpz]) = (c.to_src0, plane.dp);
                let (pen, us, vs) = (&mut pen[j], &mut us[j], &mut vs[j]);
                for l in 0..LANES {
                    let x = xs[l];
                    let (hx, hy, hz) = (h0x + x * dhx, h0y + x * dhy, h0z + x * dhz);
                    let inv_z = 1.0 / hz;
                    let (su, sv) = (hx * inv_z, hy * inv_z);
                    // `&`, not `&&`: without branches the lanes are computed as vectors.
                    let inside =
                        (hz > 0.0) & (su >= 0.0) & (sv >= 0.0) & (su <= c.max_u) & (sv <= c.max_v);
                    let to_src = [t0x - x * dpx, t0y - x * dpy, t0z - x * dpz];
                    let to_eye = [eye[0][l], eye[1][l], eye[2][l]];
                    let p = penalty_of(to_src, to_eye, inv_eye[l], rw);
                    pen[l] = if inside { p } else { f32::INFINITY };
                    us[l] = su;
                    vs[l] = sv;
                }
            }
            for l in 0..lanes {
                let mut n = 0;
                for j in 0..n_cand {
                    if pen[j][l].is_finite() {
                        found[n] = (plane.sources[j].index, us[j][l], vs[j][l]);
                        penalty[n] = pen[j][l];
                        n += 1;
                    }
                }
                let i = chunk * LANES + l;
                if n == 0 {
                    rgb[3 * i..3 * i + 3].fill(0);
                    depth[i] = f32::INFINITY;
                    coverage[i] = Coverage::Nothing as u8;
                } else {
                    // The focal plane only stands in for the surface: sharper samples of
                    // sources that disagree there would buy nothing (`Sampling`).
                    let colour = self.mix(&found[..n], &penalty[..n], Sampling::Bilinear);
                    rgb[3 * i..3 * i + 3].copy_from_slice(&colour);
                    depth[i] = focal;
                    coverage[i] = Coverage::Fallback as u8;
                }
            }
        }
    }

    /// Colour, depth and coverage of one virtual ray (`dir` has camera z = 1) whose nearest
    /// splatted surface depth is `splat` (infinite where no splat covers it).
    fn shade(
        &self,
        centre: &Point3<f64>,
        dir: &Vector3<f64>,
        splat: f64,
        focal_depth: f64,
        candidates: &[(f64, usize)],
        colour_geometry: bool,
    ) -> ([u8; 3], f32, Coverage) {
        // The colour of a Geometry pixel, or, when the refinement will blend it again anyway,
        // only whether a candidate sees its point (black for now).
        let geometry = |p: &Point3<f64>| {
            if colour_geometry {
                self.blend(p, centre, candidates, Some(self.tolerance))
            } else {
                let seen = candidates
                    .iter()
                    .any(|&(_, i)| self.sources[i].sees(p, Some(self.tolerance)).is_some());
                seen.then_some([0; 3])
            }
        };
        let hit = if splat.is_finite() {
            let start = splat - self.splat_margin;
            self.model.raycast_from(centre, dir, start.max(0.0))
        } else {
            None
        };
        if let Some(hit) = hit {
            let p = centre + dir * hit.t;
            if let Some(c) = geometry(&p) {
                return (c, hit.t as f32, Coverage::Geometry);
            }
            // No source sees the point. Where the ray went through a pinhole in the model's
            // surface (voxel coloring leaves some), it met the far side of the object, often
            // ten voxels or more behind; the surface splatted around the hole is where the ray
            // meets the object, if the sources see that.
            if splat < hit.t {
                let q = centre + dir * splat;
                if let Some(c) = geometry(&q) {
                    return (c, splat as f32, Coverage::Geometry);
                }
            }
            if let Some(c) = self.blend(&p, centre, candidates, None) {
                return (c, hit.t as f32, Coverage::Fallback);
            }
        }
        // A ray that passes within a splat of the surface but meets no voxel grazes the
        // model's outline (where carving took the object's edge): the nearest splatted surface
        // depth stands in for the focal surface there.
        let depth = if splat.is_finite() {
            splat
        } else {
            focal_depth
        };
        let p = centre + dir * depth;
        match self.blend(&p, centre, candidates, None) {
            Some(c) => (c, depth as f32, Coverage::Fallback),
            None => ([0; 3], f32::INFINITY, Coverage::Nothing),
        }
    }

    /// With [`RenderParams::reflections`], the colour the nearest candidate sees reflected as a
    /// virtual camera at `eye` (rotation `cam_from_world`) sees a mirror: one of the visual
    /// hull's that the ray to the surface point `p` meets in front of it
    /// ([`MirrorLayer::reflected`]), or else the model's at `p` ([`MirrorMap::reflected`]); when
    /// the candidate sees the same direction on that mirror.
    fn reflected(
        &self,
        p: &Point3<f64>,
        eye: &Point3<f64>,
        cam_from_world: &Rotation3<f64>,
        candidates: &[(f64, usize)],
    ) -> Option<[u8; 3]> {
        let &(_, nearest) = candidates.first()?;
        let source = &self.sources[nearest];
        let from_layer = self
            .layer
            .as_ref()
            .and_then(|layer| layer.reflected(p, eye, cam_from_world, source));
        from_layer.or_else(|| {
            let mirrors = self.mirrors.as_ref()?;
            mirrors.reflected(p, eye, cam_from_world, source)
        })
    }

    /// The unstructured-lumigraph blend of the candidates that see `p`: with `occlusion`, those
    /// whose own depth there is not nearer than the point's by more than that tolerance.
    fn blend(
        &self,
        p: &Point3<f64>,
        eye: &Point3<f64>,
        candidates: &[(f64, usize)],
        occlusion: Option<f64>,
    ) -> Option<[u8; 3]> {
        let to_eye = eye - p;
        let eye_dist = to_eye.norm();
        let inv_eye = 1.0 / eye_dist;
        let to_eye = to_eye * inv_eye;
        // Each source that sees p: the vector from p to it (one array per axis, so the
        // penalties below are computed four sources at a time), its index and (u, v).
        let mut to_src = [[0f32; MAX_CANDIDATES]; 3];
        let mut found = [(0usize, 0f32, 0f32); MAX_CANDIDATES];
        let mut n = 0;
        for &(_, i) in candidates {
            let s = &self.sources[i];
            let Some((u, v)) = s.sees(p, occlusion) else {
                continue;
            };
            let t = s.centre - p;
            for (axis, value) in to_src.iter_mut().zip([t.x, t.y, t.z]) {
                axis[n] = value as f32;
            }
            found[n] = (i, u as f32, v as f32);
            n += 1;
        }
        if n == 0 {
            return None;
        }
        // The penalties (`penalty_of`), four sources at a time so that they share each
        // square root.
        let (ex, ey, ez) = (to_eye.x as f32, to_eye.y as f32, to_eye.z as f32);
        let (inv_eye, rw) = (inv_eye as f32, self.params.resolution_weight as f32);
        let mut penalty = [0f32; MAX_CANDIDATES];
        let [xs, ys, zs] = &to_src;
        for (((x, y), z), pen) in xs
            .chunks_exact(4)
            .zip(ys.chunks_exact(4))
            .zip(zs.chunks_exact(4))
            .zip(penalty.chunks_exact_mut(4))
            .take(n.div_ceil(4))
        {
            for l in 0..4 {
                pen[l] = penalty_of([x[l], y[l], z[l]], [ex, ey, ez], inv_eye, rw);
            }
        }
        Some(self.mix(&found[..n], &penalty[..n], self.params.sampling))
    }

    /// The blend of the candidates that see `p` within `tolerance`, or, when none does, of
    /// those on whose images it lies (the refinement's rule for a moved point).
    fn blend_preferring_seen(
        &self,
        p: &Point3<f64>,
        eye: &Point3<f64>,
        candidates: &[(f64, usize)],
        tolerance: f64,
    ) -> Option<[u8; 3]> {
        self.blend(p, eye, candidates, Some(tolerance))
            .or_else(|| self.blend(p, eye, candidates, None))
    }

    /// The blend proper: the `k` sources of least penalty among `found` (source, `u`, `v`),
    /// with weights `(1 - p / p_(k+1)) / p`, sampled at their `(u, v)` as `sampling` says.
    /// `found` is not empty.
    // Always inlined, like `bilinear`: left out of line (as the compiler chose), the frame
    // took about 4-7% longer in alternated runs, with the same output (session 12,
    // `docs/render.md`).
    #[inline(always)]
    fn mix(&self, found: &[(usize, f32, f32)], penalty: &[f32], sampling: Sampling) -> [u8; 3] {
        let n = found.len();
        // The sources in penalty order; ties keep the candidates' order.
        let mut order = [0u8; MAX_CANDIDATES];
        for j in 0..n {
            let mut at = j;
            while at > 0 && penalty[order[at - 1] as usize] > penalty[j] {
                order[at] = order[at - 1];
                at -= 1;
            }
            order[at] = j as u8;
        }
        let k = self.params.k.min(n);
        let penalty_at = |rank: usize| penalty[order[rank] as usize] as f64;
        // The (k+1)-th penalty is where weights reach zero; without one, twice the k-th.
        let threshold = if n > k {
            penalty_at(k)
        } else {
            2.0 * penalty_at(k - 1)
        } + 1e-12;
        let inv_threshold = 1.0 / threshold;
        let (mut acc, mut total) = ([0f32; 4], 0f64);
        for rank in 0..k {
            let pen = penalty_at(rank);
            let (i, u, v) = found[order[rank] as usize];
            // Reaches zero at the threshold, and grows without bound as the penalty vanishes, so
            // a virtual camera at a source reproduces it (epipole consistency).
            let wgt = (1.0 - pen * inv_threshold).max(0.0) / (pen + 1e-6) + 1e-12;
            let image = &self.sources[i].image;
            let c = match sampling {
                Sampling::Bilinear => bilinear(image, u, v),
                Sampling::Bicubic => bicubic(image, u, v),
            };
            for ch in 0..4 {
                acc[ch] += wgt as f32 * c[ch];
            }
            total += wgt;
        }
        let inv_total = (1.0 / total) as f32;
        // A weighted mean of bytes: in [0, 255] up to rounding, and `as` saturates.
        let [r, g, b, _] = acc;
        [
            (r * inv_total + 0.5) as u8,
            (g * inv_total + 0.5) as u8,
            (b * inv_total + 0.5) as u8,
        ]
    }
}

/// The unstructured-lumigraph penalty of a source seen from a point: the angle between the
/// rays to the virtual camera (`to_eye`, unit) and to the source (`to_src`, the vector from the
/// point to the source's centre), as the chord of unit vectors, plus `rw` times the source's
/// relative excess distance (`inv_eye` is one over the distance to the virtual camera).
/// Single precision is ample for weights, and lets loops over sources or pixels vectorise.
#[inline]
fn penalty_of(to_src: [f32; 3], to_eye: [f32; 3], inv_eye: f32, rw: f32) -> f32 {
    let [x, y, z] = to_src;
    let dist = (x * x + y * y + z * z).sqrt();
    let inv = 1.0 / dist;
    let (ax, ay, az) = (
        x * inv - to_eye[0],
        y * inv - to_eye[1],
        z * inv - to_eye[2],
    );
    let angle = (ax * ax + ay * ay + az * az).sqrt();
    angle + rw * (dist * inv_eye - 1.0).max(0.0)
}

/// One row's focal plane, for [`Renderer::shade_focal_run`]: the point of pixel `u` is
/// `centre + (ray0 + u ray_du) focal_depth`, so its homogeneous coordinates in each candidate
/// source and its offset from each source's centre are linear in `u` too. Single precision:
/// source pixel positions to about 1e-4 pixel, colours within a rounding of the per-pixel
/// path (test `focal_runs_equal_shading_each_pixel`).
struct FocalRow {
    ray0: [f32; 3],
    ray_du: [f32; 3],
    /// The point's step per pixel.
    dp: [f32; 3],
    focal_depth: f64,
    sources: [FocalSource; MAX_CANDIDATES],
    len: usize,
}

/// A candidate source along a [`FocalRow`].
#[derive(Clone, Copy, Default)]
struct FocalSource {
    /// The source's index in the renderer.
    index: usize,
    /// Homogeneous image coordinates of the point of pixel 0, and their step per pixel.
    h0: [f32; 3],
    dh: [f32; 3],
    /// The source's centre from the point of pixel 0.
    to_src0: [f32; 3],
    /// The last pixel centre of the source's image.
    max_u: f32,
    max_v: f32,
}

impl FocalRow {
    fn new(
        renderer: &Renderer<'_>,
        camera: &Camera,
        rot: &Rotation3<f64>,
        v: usize,
        focal_depth: f64,
        candidates: &[(f64, usize)],
    ) -> Option<FocalRow> {
        let ray0 = pixel_ray(camera, rot, 0, v)?;
        let ray_du = pixel_ray(camera, rot, 1, v)? - ray0;
        let centre = camera.centre();
        let p0 = centre + ray0 * focal_depth;
        let dp = ray_du * focal_depth;
        let f = |x: Vector3<f64>| [x.x as f32, x.y as f32, x.z as f32];
        let mut sources = [FocalSource::default(); MAX_CANDIDATES];
        for (slot, &(_, index)) in sources.iter_mut().zip(candidates) {
            let s = &renderer.sources[index];
            *slot = FocalSource {
                index,
                h0: s.homogeneous(&p0).map(|x| x as f32),
                dh: s.direction(&dp).map(|x| x as f32),
                to_src0: f(s.centre - p0),
                max_u: (s.width - 1) as f32,
                max_v: (s.height - 1) as f32,
            };
        }
        Some(FocalRow {
            ray0: f(ray0),
            ray_du: f(ray_du),
            dp: f(dp),
            focal_depth,
            sources,
            len: candidates.len().min(MAX_CANDIDATES),
        })
    }
}

/// The Catmull-Rom weights of the four pixels at -1, 0, 1 and 2 from a sample a fraction `t`
/// (0 to 1) of the way from pixel 0 to pixel 1: Keys' cubic convolution with `a = -1/2`,
/// which passes through the pixels, sums to 1 and reproduces polynomials up to the second
/// degree.
#[inline(always)]
fn catmull_rom(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        0.5 * (2.0 * t2 - t3 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (4.0 * t2 - 3.0 * t3 + t),
        0.5 * (t3 - t2),
    ]
}

/// Catmull-Rom bicubic sample at `(u, v)` (pixel centres at integers, `0 <= u <= width - 1`,
/// `0 <= v <= height - 1`), lanes as [`bilinear`] gives them: the 4x4 pixels around the point
/// weighted by [`catmull_rom`] along each axis, rows and columns beyond the image taken from
/// its edge. Near a sharp edge a lane can overshoot 0-255 (the spline's negative lobes).
/// Images less than 4 pixels wide or high are sampled bilinearly.
#[inline(always)]
pub(crate) fn bicubic(img: &RgbImage, u: f32, v: f32) -> [f32; 4] {
    let (w, h) = (img.width() as i32, img.height() as i32);
    if w < 4 || h < 4 {
        return bilinear(img, u, v);
    }
    let raw = img.as_raw();
    // `as` saturates a NaN to 0; the clamps keep every index inside the image.
    let (x0, y0) = (
        (u.floor() as i32).clamp(0, w - 1),
        (v.floor() as i32).clamp(0, h - 1),
    );
    let (wx, wy) = (
        catmull_rom((u - x0 as f32).clamp(0.0, 1.0)),
        catmull_rom((v - y0 as f32).clamp(0.0, 1.0)),
    );
    let mut out = [0f32; 4];
    // Away from the image's edge (nearly every sample), each row's four texels are two pairs
    // of neighbours, weighed four at a time as the bilinear sample weighs its four. (One path
    // for every sample, each texel read at its clamped column, was 3% slower a frame.)
    if x0 >= 1 && x0 + 2 < w && y0 >= 1 && y0 + 2 < h {
        let first = (y0 - 1) as usize * w as usize * 3 + (x0 - 1) as usize * 3;
        for (j, wj) in wy.into_iter().enumerate() {
            let row = first + j * w as usize * 3;
            let (Some(left), Some(right)) = (texel_words(raw, row), texel_words(raw, row + 6))
            else {
                continue;
            };
            let sum = weigh_texels(left, right, wx.map(|wi| wi * wj));
            for (o, s) in out.iter_mut().zip(sum) {
                *o += s;
            }
        }
        return out;
    }
    let column: [usize; 4] =
        std::array::from_fn(|i| (x0 + i as i32 - 1).clamp(0, w - 1) as usize * 3);
    for (j, wj) in wy.into_iter().enumerate() {
        let row = (y0 + j as i32 - 1).clamp(0, h - 1) as usize * w as usize * 3;
        let mut sum = [0f32; 3];
        for (&x, wi) in column.iter().zip(wx) {
            let Some(&[r, g, b]) = raw
                .get(row + x..row + x + 3)
                .and_then(|t| <&[u8; 3]>::try_from(t).ok())
            else {
                continue;
            };
            sum[0] += wi * f32::from(r);
            sum[1] += wi * f32::from(g);
            sum[2] += wi * f32::from(b);
        }
        for (o, s) in out.iter_mut().zip(sum) {
            *o += wj * s;
        }
    }
    out
}

/// Bilinear sample at `(u, v)` (pixel centres at integers, `0 <= u <= width - 1`,
/// `0 <= v <= height - 1`) of an image at least 2 pixels wide and high: red, green and blue,
/// and a fourth lane that is zero, so that callers can work on all four lanes at once.
#[inline(always)]
pub(crate) fn bilinear(img: &RgbImage, u: f32, v: f32) -> [f32; 4] {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let raw = img.as_raw();
    if w < 2 || h < 2 {
        let (x, y) = (
            (u as usize).min(w.saturating_sub(1)),
            (v as usize).min(h.saturating_sub(1)),
        );
        let at = (y * w + x) * 3;
        return std::array::from_fn(|c| match c {
            0..3 => raw.get(at + c).copied().unwrap_or(0) as f32,
            _ => 0.0,
        });
    }
    // Truncation is the floor for u, v >= 0; the last pixel samples the last cell's far edge.
    // In `i32`, since x86-64 converts between `f32` and `usize` only in several instructions.
    let x0 = (u as i32).clamp(0, w as i32 - 2);
    let y0 = (v as i32).clamp(0, h as i32 - 2);
    let (fx, fy) = (u - x0 as f32, v - y0 as f32);
    let top = (y0 as usize * w + x0 as usize) * 3;
    let bottom = top + w * 3;
    let (Some(t), Some(b)) = (texel_words(raw, top), texel_words(raw, bottom)) else {
        return [0.0; 4];
    };
    // The four texels' weights, then one multiply-add per texel and lane.
    let (gx, gy) = (1.0 - fx, 1.0 - fy);
    weigh_texels(t, b, [gx * gy, fx * gy, gx * fy, fx * fy])
}

/// The two RGB texels at byte `at` of `raw` and the next, each as a little-endian word with
/// red in the low byte and zero in the high one.
#[inline(always)]
fn texel_words(raw: &[u8], at: usize) -> Option<[u32; 2]> {
    let bytes: &[u8; 6] = raw.get(at..at + 6)?.try_into().ok()?;
    let [r0, g0, b0, r1, g1, b1] = *bytes;
    Some([
        u32::from_le_bytes([r0, g0, b0, r1]) & 0x00ff_ffff,
        u32::from_le_bytes([b0, r1, g1, b1]) >> 8,
    ])
}

/// `w[0] top[0] + w[1] top[1] + w[2] bottom[0] + w[3] bottom[1]` for texels as
/// [`texel_words`] gives them, lane by lane (red, green, blue, zero), in that order of
/// operations.
///
/// On x86-64 in SSE2 vectors (baseline there; the intrinsics' `unsafe` is only for that, see
/// `docs/architecture.md`): the compiler left the portable form ([`weigh_texels_portable`],
/// which gives the same bits) with a scalar conversion and multiply-add per byte, and the
/// samples were about a third of a frame's instructions (session 14, `docs/render.md`).
#[cfg(all(target_arch = "x86_64", target_feature = "sse2"))]
#[allow(unsafe_code)]
#[inline(always)]
fn weigh_texels(top: [u32; 2], bottom: [u32; 2], w: [f32; 4]) -> [f32; 4] {
    use std::arch::x86_64::{
        _mm_add_ps, _mm_cvtepi32_ps, _mm_cvtss_f32, _mm_mul_ps, _mm_set_epi32, _mm_set1_ps,
        _mm_setzero_si128, _mm_shuffle_ps, _mm_unpackhi_epi8, _mm_unpackhi_epi16,
        _mm_unpacklo_epi8, _mm_unpacklo_epi16,
    };
    // SAFETY: the intrinsics are `unsafe` only for the SSE2 they need, which this function is
    // compiled with (`cfg` above: baseline on x86-64); they touch no memory.
    unsafe {
        let zero = _mm_setzero_si128();
        let words = _mm_set_epi32(
            bottom[1] as i32,
            bottom[0] as i32,
            top[1] as i32,
            top[0] as i32,
        );
        // Bytes widened to 16 bits, then 32, then converted: one vector per texel.
        let (upper, lower) = (
            _mm_unpacklo_epi8(words, zero),
            _mm_unpackhi_epi8(words, zero),
        );
        let texel = [
            _mm_unpacklo_epi16(upper, zero),
            _mm_unpackhi_epi16(upper, zero),
            _mm_unpacklo_epi16(lower, zero),
            _mm_unpackhi_epi16(lower, zero),
        ]
        .map(|x| _mm_cvtepi32_ps(x));
        let term = |i: usize| _mm_mul_ps(texel[i], _mm_set1_ps(w[i]));
        let sum = _mm_add_ps(_mm_add_ps(_mm_add_ps(term(0), term(1)), term(2)), term(3));
        [
            _mm_cvtss_f32(sum),
            _mm_cvtss_f32(_mm_shuffle_ps::<0x55>(sum, sum)),
            _mm_cvtss_f32(_mm_shuffle_ps::<0xaa>(sum, sum)),
            _mm_cvtss_f32(_mm_shuffle_ps::<0xff>(sum, sum)),
        ]
    }
}

/// [`weigh_texels`] elsewhere.
#[cfg(not(all(target_arch = "x86_64", target_feature = "sse2")))]
#[inline(always)]
fn weigh_texels(top: [u32; 2], bottom: [u32; 2], w: [f32; 4]) -> [f32; 4] {
    weigh_texels_portable(top, bottom, w)
}

/// [`weigh_texels`] in portable code.
#[cfg_attr(all(target_arch = "x86_64", target_feature = "sse2"), allow(dead_code))]
#[inline(always)]
fn weigh_texels_portable(top: [u32; 2], bottom: [u32; 2], w: [f32; 4]) -> [f32; 4] {
    let lanes = |x: u32| x.to_le_bytes().map(f32::from);
    let (t0, t1, b0, b1) = (
        lanes(top[0]),
        lanes(top[1]),
        lanes(bottom[0]),
        lanes(bottom[1]),
    );
    std::array::from_fn(|c| t0[c] * w[0] + t1[c] * w[1] + b0[c] * w[2] + b1[c] * w[3])
}

#[cfg(test)]
mod tests {
    use super::*;
    use aibr_camera::{Aabb, Angle, CircularMotion, Distortion, Intrinsics};
    use aibr_voxel::VoxelGrid;
    use image::Rgb;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    proptest::proptest! {
        /// The refinement's group of depths projected at once gives, lane by lane, what
        /// [`Source::pixel`] gives for each depth on its own, bit for bit.
        #[test]
        fn a_group_of_depths_projects_as_each_alone(
            base in proptest::array::uniform3(-400.0f64..1000.0),
            slope in proptest::array::uniform3(-300.0f64..300.0),
            t0 in -0.01f64..0.01,
            dt in 0.0f64..0.005,
        ) {
            let (width, height) = (64, 48);
            let source = Source {
                image: RgbImage::new(width, height),
                world_from_cam: Rotation3::identity(),
                depth: Vec::new(),
                p: [[0.0; 4]; 3],
                centre: Point3::origin(),
                width,
                height,
            };
            let ts: [f64; COST_LANES] = std::array::from_fn(|l| t0 + dt * l as f64);
            let (us, vs) = source.pixels(base, slope, &ts);
            for (l, &t) in ts.iter().enumerate() {
                let h = [base[0] + t * slope[0], base[1] + t * slope[1], base[2] + t * slope[2]];
                match source.pixel(h) {
                    Some((u, v)) => {
                        proptest::prop_assert_eq!((us[l].to_bits(), vs[l].to_bits()), (u.to_bits(), v.to_bits()));
                    }
                    None => proptest::prop_assert_eq!(us[l], OFF_IMAGE),
                }
            }
        }

        /// The texels weighed in vectors give the portable form's bits (on other targets the
        /// two are one function).
        #[test]
        fn texels_weigh_alike_in_vectors_and_in_portable_code(
            words in proptest::array::uniform4(0u32..=0x00ff_ffff),
            w in proptest::array::uniform4(0.0f32..=1.0),
        ) {
            let (top, bottom) = ([words[0], words[1]], [words[2], words[3]]);
            proptest::prop_assert_eq!(
                weigh_texels(top, bottom, w).map(f32::to_bits),
                weigh_texels_portable(top, bottom, w).map(f32::to_bits)
            );
        }

        /// The bilinear sample's four lanes: red, green and blue as the textbook formula gives
        /// them from the four texels around `(u, v)`, and zero.
        #[test]
        fn bilinear_samples_the_four_texels_around(
            pixels in proptest::collection::vec(proptest::num::u8::ANY, 5 * 4 * 3),
            u in 0.0f32..=4.0,
            v in 0.0f32..=3.0,
        ) {
            let img = RgbImage::from_raw(5, 4, pixels).ok_or(proptest::test_runner::TestCaseError::fail("image"))?;
            let (x0, y0) = ((u as u32).min(3), (v as u32).min(2));
            let (fx, fy) = (u - x0 as f32, v - y0 as f32);
            let texel = |x: u32, y: u32, c: usize| img.get_pixel(x, y).0[c] as f32;
            let got = bilinear(&img, u, v);
            for (c, &lane) in got.iter().take(3).enumerate() {
                let want = texel(x0, y0, c) * (1.0 - fx) * (1.0 - fy)
                    + texel(x0 + 1, y0, c) * fx * (1.0 - fy)
                    + texel(x0, y0 + 1, c) * (1.0 - fx) * fy
                    + texel(x0 + 1, y0 + 1, c) * fx * fy;
                proptest::prop_assert!((lane - want).abs() <= 1e-3, "lane {}: {} against {}", c, lane, want);
            }
            proptest::prop_assert_eq!(got[3], 0.0);
        }

        /// The bicubic sample's four lanes: red, green and blue as the Catmull-Rom formula
        /// gives them from the 4x4 texels around `(u, v)`, those beyond the image taken from
        /// its edge, and zero.
        #[test]
        fn bicubic_samples_the_sixteen_texels_around(
            pixels in proptest::collection::vec(proptest::num::u8::ANY, 6 * 5 * 3),
            u in 0.0f32..=5.0,
            v in 0.0f32..=4.0,
        ) {
            let img = RgbImage::from_raw(6, 5, pixels).ok_or(proptest::test_runner::TestCaseError::fail("image"))?;
            let (x0, y0) = (u.floor() as i64, v.floor() as i64);
            let (fx, fy) = (u as f64 - x0 as f64, v as f64 - y0 as f64);
            // Keys' cubic convolution kernel with a = -1/2, as the textbook writes it.
            let keys = |d: f64| {
                let d = d.abs();
                if d < 1.0 {
                    1.5 * d * d * d - 2.5 * d * d + 1.0
                } else if d < 2.0 {
                    -0.5 * d * d * d + 2.5 * d * d - 4.0 * d + 2.0
                } else {
                    0.0
                }
            };
            let texel = |x: i64, y: i64, c: usize| {
                img.get_pixel(x.clamp(0, 5) as u32, y.clamp(0, 4) as u32).0[c] as f64
            };
            let got = bicubic(&img, u, v);
            for (c, &lane) in got.iter().take(3).enumerate() {
                let mut want = 0.0;
                for j in -1..=2 {
                    for i in -1..=2 {
                        want += texel(x0 + i, y0 + j, c) * keys(i as f64 - fx) * keys(j as f64 - fy);
                    }
                }
                proptest::prop_assert!((lane as f64 - want).abs() <= 1e-2, "lane {}: {} against {}", c, lane, want);
            }
            proptest::prop_assert_eq!(got[3], 0.0);
        }
    }

    /// At a pixel centre the bicubic sample is the pixel; between centres it follows an image
    /// that is a ramp along x and a parabola along y exactly, where bilinear weights miss the
    /// parabola.
    #[test]
    fn bicubic_passes_through_the_pixels_and_follows_a_parabola() {
        let parabola = |x: u32, y: u32| 40 + 5 * x + y * y;
        let img = RgbImage::from_fn(12, 10, |x, y| {
            let p = parabola(x, y) as u8; // at most 176
            Rgb([p, 255 - p, (x * 20) as u8])
        });
        for (x, y) in [(0, 0), (5, 4), (11, 9), (11, 0)] {
            let got = bicubic(&img, x as f32, y as f32);
            let want = img.get_pixel(x, y).0.map(f32::from);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 1e-3,
                    "{x}, {y}: {got:?} against {want:?}"
                );
            }
        }
        // Inside, away from the clamped edge: the parabola between its integer samples.
        for (u, v) in [(3.25f32, 2.5f32), (6.5, 5.75), (8.1, 3.3)] {
            let want = 40.0 + 5.0 * u + v * v;
            let got = bicubic(&img, u, v)[0];
            assert!((got - want).abs() < 1e-3, "{u}, {v}: {got} against {want}");
            let flat = bilinear(&img, u, v)[0];
            assert!((flat - want).abs() > 0.05, "bilinear at {u}, {v}: {flat}");
        }
    }

    /// A pillar of 4x4x10 voxels in a 20^3 grid, 0.2 m on a side, and the ring its test
    /// cameras lie on.
    fn pillar_on_a_ring()
    -> std::result::Result<(VoxelModel, CircularMotion), Box<dyn std::error::Error>> {
        let grid = VoxelGrid::with_resolution(
            Aabb {
                min: Point3::new(-0.1, -0.1, 0.0),
                max: Point3::new(0.1, 0.1, 0.2),
            },
            20,
        )?;
        let mut model = VoxelModel::empty(grid);
        for k in 5..15 {
            for j in 8..12 {
                for i in 8..12 {
                    model.set([i, j, k], [128; 3]);
                }
            }
        }
        Ok((model, CircularMotion::ring(0.6, 0.3, 0.1)?))
    }

    /// The refinement's pair: the nearest source and the nearest candidate across the virtual
    /// camera from it; the two nearest where no candidate is across, or without bracketing.
    #[test]
    fn the_refinement_pairs_sources_across_the_virtual_camera() -> TestResult {
        let (model, ring) = pillar_on_a_ring()?;
        let size = ImageSize::new(32, 24);
        let camera = |degrees: f64| {
            Camera::new(
                Intrinsics::new(40.0, 40.0, 16.0, 12.0),
                Distortion::NONE,
                ring.cam_from_world(Angle::from_degrees(degrees)),
                size,
            )
        };
        let pans = [-30.0, -12.0, 0.0, 4.0, 25.0, 40.0];
        let sources = pans
            .into_iter()
            .map(|d| {
                Ok(SourceView {
                    camera: camera(d)?,
                    image: RgbImage::new(size.width, size.height),
                })
            })
            .collect::<std::result::Result<Vec<_>, aibr_camera::Error>>()?;
        let renderer = Renderer::new(&model, sources, RenderParams::default())?;
        let pair = |centre: Point3<f64>, bracketing: bool| {
            let (candidates, n) = renderer.candidates(&centre);
            renderer.refinement_pair(&centre, &candidates[..n], bracketing)
        };
        let at = |degrees: f64| camera(degrees).map(|c| c.centre());
        // At 7 degrees the two nearest (4 and 0) are both below it; 25 is across.
        assert_eq!(pair(at(7.0)?, true), (3, 4));
        assert_eq!(pair(at(7.0)?, false), (3, 2));
        // At 1.5 degrees the two nearest (0 and 4) are already on both sides.
        assert_eq!(pair(at(1.5)?, true), (2, 3));
        assert_eq!(pair(at(1.5)?, false), (2, 3));
        // Below -30 degrees every candidate is on one side: the two nearest.
        assert_eq!(pair(at(-50.0)?, true), (0, 1));
        Ok(())
    }

    /// The focal-plane runs of the main pass (pixels no splat covers, shaded a chunk at a
    /// time in single precision) give what shading each pixel on its own gives.
    #[test]
    fn focal_runs_equal_shading_each_pixel() -> TestResult {
        let (model, ring) = pillar_on_a_ring()?;
        let size = ImageSize::new(97, 61);
        let camera = |degrees: f64| {
            Camera::new(
                Intrinsics::new(120.0, 125.0, 48.0, 30.5),
                Distortion::NONE,
                ring.cam_from_world(Angle::from_degrees(degrees)),
                size,
            )
        };
        // Smooth, distinct textures, so that where each source is sampled matters.
        let texture = |phase: f64| {
            RgbImage::from_fn(size.width, size.height, |x, y| {
                let (x, y) = (x as f64, y as f64);
                Rgb([
                    (127.0 + 120.0 * (0.31 * x + phase).sin()) as u8,
                    (127.0 + 120.0 * (0.23 * y - phase).cos()) as u8,
                    (127.0 + 120.0 * (0.11 * (x + y) + 2.0 * phase).sin()) as u8,
                ])
            })
        };
        let sources = [-30.0, -12.0, 0.0, 9.0, 25.0, 40.0]
            .into_iter()
            .enumerate()
            .map(|(i, d)| {
                Ok(SourceView {
                    camera: camera(d)?,
                    image: texture(i as f64),
                })
            })
            .collect::<std::result::Result<Vec<_>, aibr_camera::Error>>()?;
        let params = RenderParams {
            refine: None,
            ..RenderParams::default()
        };
        let renderer = Renderer::new(&model, sources, params)?;
        let virtual_camera = camera(4.5)?;
        let view = renderer.render(&virtual_camera)?;
        let centre = virtual_camera.centre();
        let (candidates, n) = renderer.candidates(&centre);
        let rot = virtual_camera
            .world_from_cam()
            .rotation
            .to_rotation_matrix();
        let focal_depth = virtual_camera.depth_of(&renderer.focus()).max(1e-6);
        let (mut runs, mut worst) = (0, 0);
        for v in 0..size.height {
            for u in 0..size.width {
                if view.splat[(v * size.width + u) as usize].is_finite() {
                    continue;
                }
                runs += 1;
                let dir = pixel_ray(&virtual_camera, &rot, u as usize, v as usize).ok_or("ray")?;
                let (colour, depth, coverage) = renderer.shade(
                    &centre,
                    &dir,
                    f64::INFINITY,
                    focal_depth,
                    &candidates[..n],
                    true,
                );
                assert_eq!(view.coverage_at(u, v), coverage, "pixel ({u}, {v})");
                assert_eq!(view.depth.get_pixel(u, v).0[0], depth, "pixel ({u}, {v})");
                let got = view.rgb.get_pixel(u, v).0;
                for c in 0..3 {
                    worst = worst.max(got[c].abs_diff(colour[c]));
                }
            }
        }
        // Most of the frame is backdrop; single precision moves a colour by a rounding at most.
        assert!(runs > size.pixel_count() / 2, "{runs} focal pixels");
        assert!(worst <= 1, "colours differ by {worst}");
        Ok(())
    }
}
