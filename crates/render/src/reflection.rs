//! Mirror reflections on a turntable: where the model's surface is a mirror, a novel view's
//! pixel takes the colour the nearest source sees reflected in the same direction of the lab.
//!
//! On a turntable the camera, the lamps and everything the object reflects stay still while
//! the object turns. In the camera's own frame a distant environment is therefore the same
//! for every view: a ray leaving a mirror in the direction `e` (camera coordinates) shows the
//! same colour in every view. Blending the sources at the mirror's surface point, as the
//! renderer does elsewhere, shows each source's reflection where the novel view has its own,
//! and the reflection turns twice as fast as the object, so even views a few degrees apart
//! disagree everywhere on a mirror (`docs/render.md`, "Mirror reflections").
//!
//! For a pixel whose ray meets a mirror voxel at `p` with normal `n`, the reflected ray
//! `r = d - 2 (d . n) n` is expressed in the novel camera's frame, `e`, and carried into the
//! nearest source's world frame, `r_s`. The source sees that direction reflected where its
//! own ray `q = r_s - 2 (r_s . n) n` meets the mirror's plane; the pixel takes the colour
//! there when that point is on the image, the source's surface is there, and it lies on the
//! same mirror (a mirror voxel whose normal agrees, within a reach of `p`). Elsewhere the
//! pixel keeps its blend. Exact for a planar mirror and an environment far from it; on a
//! curved mirror the plane through `p` stands in for the surface.
//!
//! Which voxels are mirrors, and their normals, come from the model and the sources when
//! the renderer is made: each surface voxel's normal is the least direction
//! of the surface voxels around it; it is a mirror when the colours the sources see at it
//! differ from those of their angularly nearest neighbour (within 20 degrees) by more than a
//! threshold, and a share of the surface voxels around it do too (a mirror is a surface: on a
//! matte object the views disagree on scattered voxels where the model is wrong).
//!
//! Voxel coloring carves a mirror away, since no two views agree on it, and leaves a dent
//! whose floor renders as a blur of reflections. Given the visual hull
//! ([`crate::Renderer::with_visual_hull`]), the mirrors the model lacks are taken from it: a
//! surface voxel of the hull farther than a few voxels from the model is a mirror when, besides
//! disagreeing with its neighbours as above, what the sources see through it is not explained by
//! the model's surface behind it (a source's colour there against what its angularly nearest
//! neighbour sees at the same point of the surface behind), and, as for the model, when a share
//! of the hull's surface voxels around it pass both tests too. A hull floating over a matte
//! surface that the views do see, such as the hull's lid over a chair's seat, fails the second
//! test; the share drops the few of its voxels that pass it by chance.
//! A ray that meets such a mirror voxel in front of the model's surface takes its reflection;
//! where the nearest source does not see the reflected direction on the mirror, the pixel keeps
//! its blend at the model's surface behind, which for a mirror's image of the distant lab
//! renders better than the mirror's own plane would.
//!
//! # Conventions
//! The renderer's: the turntable frame of `aibr-camera`. The model assumes that every view
//! comes from one camera fixed in the lab (the object turns, not the camera).

use nalgebra::{Matrix3, Point3, Rotation3, SymmetricEigen, Vector3};
use rayon::prelude::*;

use aibr_voxel::{VoxelGrid, VoxelModel};

use crate::error::{Error, Result};
use crate::renderer::{Source, bilinear};

/// Mirror reflections ([`crate::RenderParams::reflections`]; see the [module
/// documentation](self)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reflections {
    /// A surface voxel is a mirror when the colours the sources that see it find there differ
    /// from those of their angularly nearest neighbour (within 20 degrees) by more than this,
    /// as a mean RMS over the channels in grey levels (default 40; a matte surface seen
    /// where the model is right differs by a few grey levels).
    pub specular_rms: f64,
    /// A voxel that passes `specular_rms` stays a mirror only when at least this share of the
    /// model's surface voxels within `normal_radius` of it pass too (default 1/3; 0 keeps every
    /// one). A mirror is a surface, not a speck: where the model is wrong on a matte object
    /// (a fat edge, a silhouette) the views disagree on scattered voxels, which this drops,
    /// while the voxels of a mirror's face pass together. Applies to the model's own voxels,
    /// and to the visual hull's candidates against the hull's surface around them.
    pub mirror_share: f64,
    /// Radius in voxels of the surface voxels around a voxel that its normal is fitted to
    /// (default 3; 1 to 8).
    pub normal_radius: usize,
    /// How far from the novel view's point, in voxels, the source's mirror point may lie
    /// (default 60, the size of a mirror much larger than the voxel).
    pub reach_voxels: f64,
    /// With a visual hull ([`crate::Renderer::with_visual_hull`]), how far in voxels a hull
    /// surface voxel must lie from every voxel of the model to be a candidate mirror the model
    /// lacks (default 3; 1 to 8).
    pub hull_gap_voxels: usize,
    /// With a visual hull, how badly the model's surface behind a candidate must explain what
    /// the sources see through it for the candidate to be a mirror: the mean RMS difference
    /// over the channels, in grey levels, between a source's colour there and what its
    /// angularly nearest neighbour (within 20 degrees) sees at the same point of the surface
    /// behind (default 30; on `mirror`'s panel 38 to 73, over `chair`'s seat 9 to 22).
    pub see_through_rms: f64,
}

impl Default for Reflections {
    fn default() -> Self {
        Reflections {
            specular_rms: 40.0,
            mirror_share: 1.0 / 3.0,
            normal_radius: 3,
            reach_voxels: 60.0,
            hull_gap_voxels: 3,
            see_through_rms: 30.0,
        }
    }
}

impl Reflections {
    /// Checks the parameters: each out of its domain is [`Error::InvalidParameter`].
    pub(crate) fn validate(&self) -> Result<()> {
        if !(self.specular_rms.is_finite() && self.specular_rms >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "reflections.specular_rms",
                value: self.specular_rms,
                reason: "grey levels, finite and not negative",
            });
        }
        if !(0.0..=1.0).contains(&self.mirror_share) {
            return Err(Error::InvalidParameter {
                name: "reflections.mirror_share",
                value: self.mirror_share,
                reason: "a share, from 0 to 1",
            });
        }
        if !(1..=8).contains(&self.normal_radius) {
            return Err(Error::InvalidParameter {
                name: "reflections.normal_radius",
                value: self.normal_radius as f64,
                reason: "between 1 and 8 voxels",
            });
        }
        if !(self.reach_voxels.is_finite() && self.reach_voxels > 0.0) {
            return Err(Error::InvalidParameter {
                name: "reflections.reach_voxels",
                value: self.reach_voxels,
                reason: "voxels, finite and positive",
            });
        }
        if !(1..=8).contains(&self.hull_gap_voxels) {
            return Err(Error::InvalidParameter {
                name: "reflections.hull_gap_voxels",
                value: self.hull_gap_voxels as f64,
                reason: "between 1 and 8 voxels",
            });
        }
        if !(self.see_through_rms.is_finite() && self.see_through_rms >= 0.0) {
            return Err(Error::InvalidParameter {
                name: "reflections.see_through_rms",
                value: self.see_through_rms,
                reason: "grey levels, finite and not negative",
            });
        }
        Ok(())
    }
}

/// The cosine two sources' directions from a voxel make at least for their colours there to
/// be compared (20 degrees).
const NEIGHBOUR_COSINE: f64 = 0.94;

/// The cosine two normals of one mirror make at least (15 degrees).
const SAME_PLANE_COSINE: f64 = 0.966;

/// How many surface voxels the reflections judged, and how many came out mirrors
/// ([`MirrorCounts`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MirrorTally {
    /// The surface voxels judged.
    pub surface: usize,
    /// Those that passed the tests of a mirror voxel: for the model, that the sources
    /// disagree there ([`Reflections::specular_rms`]); for the visual hull's layer, that and
    /// lying far from the model and not being explained by the model behind
    /// ([`Reflections::hull_gap_voxels`], [`Reflections::see_through_rms`]).
    pub passed: usize,
    /// Those of them kept as mirrors: with at least [`Reflections::mirror_share`] of the
    /// surface voxels around them passing too.
    pub mirrors: usize,
}

/// What a renderer with reflections found mirrors ([`crate::Renderer::mirror_counts`]): among
/// the model's surface voxels, and among the visual hull's when it was given one
/// ([`crate::Renderer::with_visual_hull`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MirrorCounts {
    /// The model's surface voxels.
    pub model: MirrorTally,
    /// The visual hull's surface voxels, judged for the layer of mirrors the model lacks;
    /// `None` without a hull.
    pub hull: Option<MirrorTally>,
}

/// The model's surface voxels with their normals, and which of them are mirrors.
pub(crate) struct MirrorMap {
    grid: VoxelGrid,
    /// The surface voxels, in the order of their slots.
    surface: Vec<[usize; 3]>,
    /// Per voxel of the grid, its slot among the surface voxels (`u32::MAX` for none).
    slot: Vec<u32>,
    /// Per surface voxel, its unit normal (its sign is arbitrary: a reflection does not depend
    /// on it) and whether it is a mirror.
    normal: Vec<Vector3<f64>>,
    mirror: Vec<bool>,
    /// The reach, in metres.
    reach: f64,
    /// How far from a source's own depth, in front or behind, a point on its surface may lie,
    /// in metres.
    tolerance: f64,
    /// Whether the map's surface lies in front of the sources' own (a layer from the visual
    /// hull, over a dent the model has): a source's mirror point then need only not be hidden,
    /// instead of lying on the source's surface.
    floating: bool,
}

impl MirrorMap {
    /// The map of `model`'s `surface` voxels, judged by `sources` (seeing a point within
    /// `tolerance` metres of their own depth), with how many passed and were kept.
    pub(crate) fn new(
        model: &VoxelModel,
        surface: &[[usize; 3]],
        sources: &[Source],
        tolerance: f64,
        params: &Reflections,
    ) -> (Self, MirrorTally) {
        let passed = surface
            .par_iter()
            .map(|&v| {
                specular_rms(&model.grid().centre(v), sources, tolerance) > params.specular_rms
            })
            .collect();
        let (map, tally) = Self::judged(
            model.grid(),
            surface.to_vec(),
            passed,
            tolerance,
            params,
            false,
        );
        (map.with_normals(params), tally)
    }

    /// The map of the `surface` voxels of a grid whose mirrors are those that `passed` the
    /// tests with enough company ([`Self::mirrors_in_company`]), without their normals, and
    /// how many passed and were kept.
    fn judged(
        grid: &VoxelGrid,
        surface: Vec<[usize; 3]>,
        passed: Vec<bool>,
        tolerance: f64,
        params: &Reflections,
        floating: bool,
    ) -> (Self, MirrorTally) {
        let map = Self::indexed(grid, surface, passed, tolerance, params, floating);
        let mirror = map.mirrors_in_company(params);
        let count = |flags: &[bool]| flags.iter().filter(|&&f| f).count();
        let tally = MirrorTally {
            surface: map.surface.len(),
            passed: count(&map.mirror),
            mirrors: count(&mirror),
        };
        (MirrorMap { mirror, ..map }, tally)
    }

    /// Which of the map's surface voxels (in its order) stay mirrors: those that are, with at
    /// least `params.mirror_share` of the surface voxels within `params.normal_radius` of them
    /// (themselves included).
    fn mirrors_in_company(&self, params: &Reflections) -> Vec<bool> {
        let r = params.normal_radius as i64;
        self.surface
            .par_iter()
            .zip(&self.mirror)
            .map(|(&v, &mirror)| {
                if !mirror {
                    return false;
                }
                let (mut around, mut mirrors) = (0u32, 0u32);
                for (_, s) in self.surface_around(v, r) {
                    around += 1;
                    mirrors += u32::from(self.mirror[s]);
                }
                f64::from(mirrors) >= params.mirror_share * f64::from(around)
            })
            .collect()
    }

    /// The map of the `surface` voxels of a grid, `mirror` telling which are mirrors, without
    /// their normals ([`Self::with_normals`]): enough for [`Self::mirrors_in_company`].
    fn indexed(
        grid: &VoxelGrid,
        surface: Vec<[usize; 3]>,
        mirror: Vec<bool>,
        tolerance: f64,
        params: &Reflections,
        floating: bool,
    ) -> Self {
        let grid = *grid;
        let [nx, ny, _] = grid.dims();
        let mut slot = vec![u32::MAX; grid.len()];
        for (n, &[i, j, k]) in surface.iter().enumerate() {
            slot[(k * ny + j) * nx + i] = n as u32;
        }
        MirrorMap {
            grid,
            surface,
            slot,
            normal: Vec::new(),
            mirror,
            reach: params.reach_voxels * grid.voxel_size(),
            tolerance,
            floating,
        }
    }

    /// The map with the normals of its surface voxels fitted.
    fn with_normals(self, params: &Reflections) -> Self {
        let r = params.normal_radius as i64;
        let normal = self
            .surface
            .par_iter()
            .map(|&v| self.fitted_normal(v, r))
            .collect();
        MirrorMap { normal, ..self }
    }

    /// The slot of the surface voxel at `[i, j, k]` (signed, possibly off the grid).
    fn slot_at(&self, i: i64, j: i64, k: i64) -> Option<usize> {
        let [nx, ny, nz] = self.grid.dims();
        if i < 0 || j < 0 || k < 0 || i >= nx as i64 || j >= ny as i64 || k >= nz as i64 {
            return None;
        }
        let s = self.slot[(k as usize * ny + j as usize) * nx + i as usize];
        (s != u32::MAX).then_some(s as usize)
    }

    /// The surface voxels within `r` voxels of `[i, j, k]` (itself included): each one's
    /// offset from it and its slot.
    fn surface_around(
        &self,
        [i, j, k]: [usize; 3],
        r: i64,
    ) -> impl Iterator<Item = (Vector3<f64>, usize)> + '_ {
        let span = move || -r..=r;
        span()
            .flat_map(move |dk| span().flat_map(move |dj| span().map(move |di| (di, dj, dk))))
            .filter(move |(di, dj, dk)| di * di + dj * dj + dk * dk <= r * r)
            .filter_map(move |(di, dj, dk)| {
                let s = self.slot_at(i as i64 + di, j as i64 + dj, k as i64 + dk)?;
                Some((Vector3::new(di as f64, dj as f64, dk as f64), s))
            })
    }

    /// The least direction of the surface voxels within `r` voxels of `v` (the normal of the
    /// plane they fit best); a zero vector where they span no plane.
    fn fitted_normal(&self, v: [usize; 3], r: i64) -> Vector3<f64> {
        let offsets: Vec<Vector3<f64>> = self.surface_around(v, r).map(|(o, _)| o).collect();
        if offsets.len() < 3 {
            return Vector3::zeros();
        }
        let mean = offsets.iter().sum::<Vector3<f64>>() / offsets.len() as f64;
        let scatter = offsets
            .iter()
            .map(|o| (o - mean) * (o - mean).transpose())
            .sum::<Matrix3<f64>>();
        let eigen = SymmetricEigen::new(scatter);
        let least = eigen.eigenvalues.imin();
        eigen.eigenvectors.column(least).normalize()
    }

    /// The normal of the mirror at `x`: that of the surface voxel nearest `x` among the 27
    /// around it, when that voxel is a mirror with a normal.
    pub(crate) fn mirror_at(&self, x: &Point3<f64>) -> Option<Vector3<f64>> {
        let f = (x - self.grid.bounds().min) / self.grid.voxel_size();
        let (ci, cj, ck) = (f.x.floor() as i64, f.y.floor() as i64, f.z.floor() as i64);
        let mut nearest: Option<(f64, usize)> = None;
        for dk in -1..=1 {
            for dj in -1..=1 {
                for di in -1..=1 {
                    let (i, j, k) = (ci + di, cj + dj, ck + dk);
                    let Some(s) = self.slot_at(i, j, k) else {
                        continue;
                    };
                    let d =
                        (self.grid.centre([i as usize, j as usize, k as usize]) - x).norm_squared();
                    if nearest.is_none_or(|(best, _)| d < best) {
                        nearest = Some((d, s));
                    }
                }
            }
        }
        let (_, s) = nearest?;
        let n = self.normal[s];
        (self.mirror[s] && n != Vector3::zeros()).then_some(n)
    }

    /// The colour `source` sees reflected in the direction a novel view from `eye` sees
    /// reflected at `p` (`cam_from_world` is the novel camera's rotation), when `p` is on a
    /// mirror and the source sees that direction on the same mirror.
    pub(crate) fn reflected(
        &self,
        p: &Point3<f64>,
        eye: &Point3<f64>,
        cam_from_world: &Rotation3<f64>,
        source: &Source,
    ) -> Option<[u8; 3]> {
        let n = self.mirror_at(p)?;
        let reflect = |d: Vector3<f64>| d - n * (2.0 * d.dot(&n));
        // The reflected ray's direction in the lab, which is the camera's frame for every view.
        let lab = cam_from_world * reflect((p - eye).normalize());
        let q = reflect(source.world_from_cam() * lab);
        let towards = q.dot(&n);
        if towards.abs() < 1e-9 {
            return None;
        }
        let t = (p - source.centre()).dot(&n) / towards;
        if !(t > 0.0) {
            return None;
        }
        let x = source.centre() + q * t;
        if (x - p).norm() > self.reach {
            return None;
        }
        let (u, v) = if self.floating {
            source.sees(&x, Some(self.tolerance))?
        } else {
            source.on_surface(&x, self.tolerance)?
        };
        let m = self.mirror_at(&x)?;
        if m.dot(&n).abs() < SAME_PLANE_COSINE {
            return None;
        }
        let c = bilinear(source.image(), u as f32, v as f32);
        // Bytes interpolated: in [0, 255] up to rounding, and `as` saturates.
        Some([(c[0] + 0.5) as u8, (c[1] + 0.5) as u8, (c[2] + 0.5) as u8])
    }
}

/// The mirrors the model lacks, from the visual hull (see the [module documentation](self)).
pub(crate) struct MirrorLayer {
    /// The layer's voxels.
    voxels: VoxelModel,
    /// Their normals; every one is a mirror.
    map: MirrorMap,
    /// The box of the layer's voxels, against which a ray is tested before it is cast.
    min: Point3<f64>,
    max: Point3<f64>,
}

impl MirrorLayer {
    /// The layer of `hull`'s surface voxels that lie more than `params.hull_gap_voxels` from
    /// every voxel of `model` and that the `sources` (their depths from `model`) find mirrors,
    /// with at least `params.mirror_share` of the hull's surface voxels within
    /// `params.normal_radius` of them; `None` when there is none. `hull` is on `model`'s grid.
    /// With the layer, how many of the hull's surface voxels passed the tests and were kept.
    pub(crate) fn new(
        model: &VoxelModel,
        hull: &VoxelModel,
        sources: &[Source],
        tolerance: f64,
        params: &Reflections,
    ) -> (Option<Self>, MirrorTally) {
        let grid = *model.grid();
        let [nx, ny, nz] = grid.dims();
        let gap = params.hull_gap_voxels;
        let far_from_model = |[i, j, k]: [usize; 3]| {
            let near = |c: usize, n: usize| c.saturating_sub(gap)..(c + gap + 1).min(n);
            !near(k, nz).any(|kk| {
                near(j, ny).any(|jj| near(i, nx).any(|ii| model.is_occupied([ii, jj, kk])))
            })
        };
        // Every surface voxel of the hull is judged, so that a candidate is weighed against the
        // hull's surface around it, as the model's mirrors are against the model's.
        let surface = hull.surface_voxels();
        let passed = surface
            .par_iter()
            .map(|&v| {
                let x = grid.centre(v);
                far_from_model(v)
                    && specular_rms(&x, sources, tolerance) > params.specular_rms
                    && see_through_rms(&x, sources, tolerance) > params.see_through_rms
            })
            .collect();
        Self::of_surface(&grid, surface, passed, tolerance, params)
    }

    /// The layer of those of the hull's `surface` voxels that `passed` the tests, with at least
    /// `params.mirror_share` of the `surface` voxels within `params.normal_radius` passing too
    /// (`None` when there is none), and how many passed and were kept.
    fn of_surface(
        grid: &VoxelGrid,
        surface: Vec<[usize; 3]>,
        passed: Vec<bool>,
        tolerance: f64,
        params: &Reflections,
    ) -> (Option<Self>, MirrorTally) {
        let grid = *grid;
        let (judged, tally) = MirrorMap::judged(&grid, surface, passed, tolerance, params, true);
        let layer: Vec<[usize; 3]> = judged
            .surface
            .iter()
            .zip(&judged.mirror)
            .filter_map(|(&v, &kept)| kept.then_some(v))
            .collect();
        let Some(&first) = layer.first() else {
            return (None, tally);
        };
        let first = grid.centre(first);
        let (mut min, mut max) = (first, first);
        let mut voxels = VoxelModel::empty(grid);
        for &v in &layer {
            let c = grid.centre(v);
            min = min.inf(&c);
            max = max.sup(&c);
            voxels.set(v, [255; 3]);
        }
        let half = Vector3::repeat(0.5 * grid.voxel_size());
        let mirror = vec![true; layer.len()];
        let map =
            MirrorMap::indexed(&grid, layer, mirror, tolerance, params, true).with_normals(params);
        let layer = MirrorLayer {
            voxels,
            map,
            min: min - half,
            max: max + half,
        };
        (Some(layer), tally)
    }

    /// [`MirrorMap::reflected`] where the ray from `eye` to the model's surface point `p` meets
    /// the layer at least a voxel in front of `p`.
    pub(crate) fn reflected(
        &self,
        p: &Point3<f64>,
        eye: &Point3<f64>,
        cam_from_world: &Rotation3<f64>,
        source: &Source,
    ) -> Option<[u8; 3]> {
        let to_p = p - eye;
        let distance = to_p.norm();
        let dir = to_p / distance;
        let (enter, _) = aibr_camera::aabb::slab(&self.min, &self.max, eye, &dir)?;
        let in_front = distance - self.voxels.grid().voxel_size();
        if enter > in_front {
            return None;
        }
        let hit = self.voxels.raycast_from(eye, &dir, enter.max(0.0))?;
        if hit.t > in_front {
            return None;
        }
        self.map
            .reflected(&(eye + dir * hit.t), eye, cam_from_world, source)
    }
}

/// How badly the surface the `sources` have behind `x` explains what they see at `x`: for each
/// source that sees `x` with its surface behind it, the RMS difference over the channels, in
/// grey levels, between its colour at `x` and the colour its angularly nearest neighbour
/// (within 20 degrees) sees at that point of the surface; the mean (0 when there is none).
fn see_through_rms(x: &Point3<f64>, sources: &[Source], tolerance: f64) -> f64 {
    let towards: Vec<Vector3<f64>> = sources
        .iter()
        .map(|s| (s.centre() - x).normalize())
        .collect();
    mean_or_zero(sources.iter().enumerate().filter_map(|(a, source)| {
        let (u, v) = source.sees(x, Some(tolerance))?;
        let behind = source.surface_behind(x)?;
        let other = &sources[angular_neighbour(&towards, a)?];
        let (ub, vb) = other.sees(&behind, Some(tolerance))?;
        Some(rms_difference(
            &bilinear(source.image(), u as f32, v as f32),
            &bilinear(other.image(), ub as f32, vb as f32),
        ))
    }))
}

/// How much the colours the `sources` see at `x` differ from those of their angularly nearest
/// neighbour among them, when that lies within 20 degrees: the mean over such pairs of the RMS
/// difference over the channels, in grey levels (0 when there is none).
fn specular_rms(x: &Point3<f64>, sources: &[Source], tolerance: f64) -> f64 {
    let (towards, colours): (Vec<Vector3<f64>>, Vec<[f32; 4]>) = sources
        .iter()
        .filter_map(|s| {
            let (u, v) = s.sees(x, Some(tolerance))?;
            let c = bilinear(s.image(), u as f32, v as f32);
            Some(((s.centre() - x).normalize(), c))
        })
        .unzip();
    mean_or_zero((0..colours.len()).filter_map(|a| {
        let b = angular_neighbour(&towards, a)?;
        Some(rms_difference(&colours[a], &colours[b]))
    }))
}

/// The index of the direction among `towards` angularly nearest `towards[a]` (the largest
/// cosine; the last of equals), when it lies within 20 degrees of it.
fn angular_neighbour(towards: &[Vector3<f64>], a: usize) -> Option<usize> {
    towards
        .iter()
        .enumerate()
        .filter(|&(b, _)| b != a)
        .map(|(b, d)| (towards[a].dot(d), b))
        .max_by(|p, q| p.0.total_cmp(&q.0))
        .filter(|&(cosine, _)| cosine >= NEIGHBOUR_COSINE)
        .map(|(_, b)| b)
}

/// The RMS difference of two bilinear samples over red, green and blue, in grey levels.
fn rms_difference(a: &[f32; 4], b: &[f32; 4]) -> f64 {
    let sq: f32 = (0..3).map(|ch| (a[ch] - b[ch]).powi(2)).sum();
    f64::from(sq / 3.0).sqrt()
}

/// The mean of `values`, 0 when there is none.
fn mean_or_zero(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0u32), |(sum, n), v| (sum + v, n + 1));
    if n == 0 { 0.0 } else { sum / f64::from(n) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use aibr_camera::Aabb;

    #[test]
    fn parameters_out_of_their_domain_are_refused() {
        assert!(Reflections::default().validate().is_ok());
        let bad = [
            Reflections {
                specular_rms: f64::NAN,
                ..Default::default()
            },
            Reflections {
                specular_rms: -1.0,
                ..Default::default()
            },
            Reflections {
                mirror_share: f64::NAN,
                ..Default::default()
            },
            Reflections {
                mirror_share: -0.1,
                ..Default::default()
            },
            Reflections {
                mirror_share: 1.5,
                ..Default::default()
            },
            Reflections {
                normal_radius: 0,
                ..Default::default()
            },
            Reflections {
                normal_radius: 9,
                ..Default::default()
            },
            Reflections {
                reach_voxels: 0.0,
                ..Default::default()
            },
            Reflections {
                hull_gap_voxels: 0,
                ..Default::default()
            },
            Reflections {
                hull_gap_voxels: 9,
                ..Default::default()
            },
            Reflections {
                see_through_rms: f64::INFINITY,
                ..Default::default()
            },
            Reflections {
                see_through_rms: -1.0,
                ..Default::default()
            },
            Reflections {
                reach_voxels: f64::INFINITY,
                ..Default::default()
            },
        ];
        for r in bad {
            assert!(
                matches!(r.validate(), Err(Error::InvalidParameter { .. })),
                "{r:?}"
            );
        }
    }

    /// A slab of voxels around a tilted plane: the normals fitted to its surface voxels lie
    /// within a few degrees of the plane's, and with no source nothing is a mirror.
    #[test]
    fn normals_are_fitted_to_the_surface_around() -> Result<(), Box<dyn std::error::Error>> {
        let bounds = Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 1.0, 1.0))?;
        let grid = VoxelGrid::with_resolution(bounds, 40)?;
        let n = Vector3::new(1.0, 2.0, 3.0).normalize();
        let centre = Point3::new(0.5, 0.5, 0.5);
        let half = 0.6 * grid.voxel_size();
        let model = VoxelModel::from_centres(grid, |p| (p - centre).dot(&n).abs() < half);
        let surface = model.surface_voxels();
        let (map, tally) = MirrorMap::new(&model, &surface, &[], 0.0, &Reflections::default());
        let mut checked = 0;
        for (v, normal) in surface.iter().zip(&map.normal) {
            if (grid.centre(*v) - centre).norm() > 0.3 {
                continue;
            }
            let angle = normal.dot(&n).abs().min(1.0).acos().to_degrees();
            assert!(angle < 5.0, "{v:?}: {angle} degrees off");
            checked += 1;
        }
        assert!(checked > 100, "{checked}");
        assert!(map.mirror.iter().all(|&m| !m));
        let judged = surface.len();
        assert_eq!(
            tally,
            MirrorTally {
                surface: judged,
                passed: 0,
                mirrors: 0
            }
        );
        assert_eq!(map.mirror_at(&centre), None);
        Ok(())
    }

    /// A grid, the surface voxels of a slab on it, and which of them pass a test.
    type Slab = (VoxelGrid, Vec<[usize; 3]>, Vec<bool>);

    /// A flat slab two voxels thick on a 40^3 grid (every voxel of it on the surface), its
    /// surface voxels, and which of them pass a test: a 10 x 10 patch, and one voxel far from it
    /// ([`speck`]).
    fn slab_with_a_patch_and_a_speck() -> Result<Slab, Box<dyn std::error::Error>> {
        let bounds = Aabb::new(Point3::new(0.0, 0.0, 0.0), Point3::new(1.0, 1.0, 1.0))?;
        let grid = VoxelGrid::with_resolution(bounds, 40)?;
        let slab = VoxelModel::from_centres(grid, |p| (p.z - 0.5).abs() < 0.6 * grid.voxel_size());
        let surface = slab.surface_voxels();
        let patch = |[i, j, _]: [usize; 3]| (10..20).contains(&i) && (10..20).contains(&j);
        let passed = surface.iter().map(|&v| patch(v) || speck(v)).collect();
        Ok((grid, surface, passed))
    }

    /// Whether `v` is inside the patch of [`slab_with_a_patch_and_a_speck`], off its edge.
    fn inside_the_patch([i, j, _]: [usize; 3]) -> bool {
        (11..19).contains(&i) && (11..19).contains(&j)
    }

    /// Whether `v` is the lone voxel that passes in [`slab_with_a_patch_and_a_speck`].
    fn speck([i, j, _]: [usize; 3]) -> bool {
        i == 30 && j == 30
    }

    /// A mirror is a surface: a patch of voxels that pass the colour test stays, a voxel that
    /// passes alone on a matte surface (as where the model is wrong) does not.
    #[test]
    fn a_mirror_needs_mirrors_around_it() -> Result<(), Box<dyn std::error::Error>> {
        let (grid, surface, passed) = slab_with_a_patch_and_a_speck()?;
        let params = Reflections::default();
        let map = MirrorMap::indexed(&grid, surface.clone(), passed.clone(), 0.0, &params, false);

        let kept = map.mirrors_in_company(&params);
        for ((&v, &p), &k) in surface.iter().zip(&passed).zip(&kept) {
            // The patch's inside stays; its edge, with fewer mirrors around, is not asked.
            if speck(v) || !p {
                assert!(!k, "{v:?} kept");
            } else if inside_the_patch(v) {
                assert!(k, "{v:?} dropped");
            }
        }
        assert!(surface.iter().any(|&v| speck(v)));
        // With no share asked for, every voxel that passed stays.
        let all = Reflections {
            mirror_share: 0.0,
            ..params
        };
        assert_eq!(map.mirrors_in_company(&all), passed);
        Ok(())
    }

    /// The layer of mirrors from the visual hull is a surface too: of the hull's surface voxels
    /// that pass the layer's tests, a patch stays and a lone voxel (as a few over a matte seat
    /// do by chance) does not.
    #[test]
    fn the_layer_from_the_hull_is_a_surface() -> Result<(), Box<dyn std::error::Error>> {
        // The slab stands in for the hull.
        let (grid, surface, passed) = slab_with_a_patch_and_a_speck()?;
        let params = Reflections::default();

        let layer = MirrorLayer::of_surface(&grid, surface.clone(), passed.clone(), 0.0, &params)
            .0
            .ok_or("the patch makes no layer")?;
        for (&v, &p) in surface.iter().zip(&passed) {
            let kept = layer.voxels.is_occupied(v);
            assert!(!kept || p, "{v:?} kept without passing");
            assert!(!(speck(v) && kept), "{v:?}, alone, kept");
            assert!(
                !inside_the_patch(v) || kept,
                "{v:?}, inside the patch, dropped"
            );
        }
        // Every voxel of the layer is a mirror, with the slab's normal.
        let centre = grid.centre([15, 15, 20]);
        let n = layer
            .map
            .mirror_at(&centre)
            .ok_or("no mirror at the patch")?;
        assert!(n.z.abs() > 0.99, "{n}");

        // The speck alone makes no layer; with no share asked for, it does.
        let alone: Vec<bool> = surface.iter().map(|&v| speck(v)).collect();
        assert!(
            MirrorLayer::of_surface(&grid, surface.clone(), alone.clone(), 0.0, &params)
                .0
                .is_none()
        );
        let all = Reflections {
            mirror_share: 0.0,
            ..params
        };
        let layer = MirrorLayer::of_surface(&grid, surface.clone(), alone, 0.0, &all)
            .0
            .ok_or("a share of 0 drops the speck")?;
        assert!(
            surface
                .iter()
                .filter(|&&v| speck(v))
                .all(|&v| layer.voxels.is_occupied(v))
        );
        Ok(())
    }
}
