//! The active capture loop (section 2.4 of the paper), and reconstruction and rendering from a
//! session.

use std::time::Instant;

use aibr_camera::{Aabb, Angle, CircularMotion, PanRange};
use aibr_consistency::foreground::{BackdropDifference, foreground_from_backdrop, median_backdrop};
use aibr_consistency::{
    ConsistencyParams, PairScore, PlanParams, TurntableLimits, VIEW_DEPENDENT_CONTRAST,
    arc_contrast, edge_on_pans, plan_next_among, score_pairs,
};
use aibr_render::{RenderParams, RenderedView, Renderer, SourceView};
use aibr_voxel::{
    CarvingParams, ColoringParams, FaceParams, Reconstruction, RefineStats, TopRefinement, View,
    VoxelGrid, check_cameras_above, planar_faces, refine_tops, space_carving, visual_hull,
    voxel_coloring,
};
use image::GrayImage;

use crate::error::{Error, Result};
use crate::rig::{FrameSource, Turntable};
use crate::session::{LoadedView, Session};

/// How the views beyond the initial ones are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Strategy {
    /// Split the arc the consistency estimate says renders worst.
    Active,
    /// The baseline: every view spread uniformly over the range.
    Uniform,
}

impl Strategy {
    /// `active` or `uniform`.
    pub fn name(&self) -> &'static str {
        match self {
            Strategy::Active => "active",
            Strategy::Uniform => "uniform",
        }
    }

    /// Parses `active` or `uniform`.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "active" => Ok(Strategy::Active),
            "uniform" => Ok(Strategy::Uniform),
            _ => Err(Error::InvalidParameter {
                name: "strategy",
                reason: format!("{s:?} is not active or uniform"),
            }),
        }
    }
}

/// Whether the active planner serves every flat face of the model with a view in its plane
/// before splitting arcs by rank alone ([`PlanParams::faces_first`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "FacesFirstRecord", into = "FacesFirstRecord")]
pub enum FacesFirst {
    /// Never: arcs are split by rank, at a face's edge-on pan only near their middle.
    Off,
    /// Always.
    On,
    /// When the initial views show a view-dependent surface: their arcs' [`arc_contrast`] at
    /// or above [`VIEW_DEPENDENT_CONTRAST`]. Decided once, from the evenly spaced initial
    /// views, where a mirror's arcs stand out (among uneven arcs their widths weigh in as
    /// much). The default: serving faces first renders `mirror` and `mirror-broad` better
    /// than not at 24, 36 and 48 views, but puts `lambertian` 0.36 dB behind uniform capture
    /// at 24 views and costs `head` its lead (`docs/results.md`, "Session 75" and "Session
    /// 76"). From 10, 12, 14 or 16 initial views the mirror scenes decide for it at every
    /// placement measured and the matte ones against; from 8 the mirrors decide for it at 18
    /// of 24 placements and the matte ones against ("Session 77").
    Auto,
}

impl FacesFirst {
    /// `false`, `true` or `auto`, as `session.json` and the command line write it.
    pub fn name(&self) -> &'static str {
        match self {
            FacesFirst::Off => "false",
            FacesFirst::On => "true",
            FacesFirst::Auto => "auto",
        }
    }

    /// Parses `false`, `true` or `auto`.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "false" => Ok(FacesFirst::Off),
            "true" => Ok(FacesFirst::On),
            "auto" => Ok(FacesFirst::Auto),
            _ => Err(Error::InvalidParameter {
                name: "faces_first",
                reason: format!("{s:?} is not false, true or auto"),
            }),
        }
    }
}

impl std::fmt::Display for FacesFirst {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// [`FacesFirst`] in `session.json`: a boolean, as files written before `auto` hold it, or
/// `"auto"`.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
enum FacesFirstRecord {
    Bool(bool),
    Name(String),
}

impl TryFrom<FacesFirstRecord> for FacesFirst {
    type Error = Error;

    fn try_from(record: FacesFirstRecord) -> Result<Self> {
        match record {
            FacesFirstRecord::Bool(on) => Ok(if on { FacesFirst::On } else { FacesFirst::Off }),
            FacesFirstRecord::Name(name) => FacesFirst::parse(&name),
        }
    }
}

impl From<FacesFirst> for FacesFirstRecord {
    fn from(f: FacesFirst) -> Self {
        match f {
            FacesFirst::Off => FacesFirstRecord::Bool(false),
            FacesFirst::On => FacesFirstRecord::Bool(true),
            FacesFirst::Auto => FacesFirstRecord::Name(f.name().to_owned()),
        }
    }
}

/// Parameters of [`capture`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CaptureParams {
    /// The strategy (default active).
    pub strategy: Strategy,
    /// Views captured uniformly first (default 12).
    pub initial: usize,
    /// The budget (default 48).
    pub max: usize,
    /// Reconstruct again every this many captures (default 1).
    pub refine_every: usize,
    /// Voxels along the longest edge of the volume (default 96).
    pub grid: usize,
    /// Arcs scoring at or below this are consistent; when all are, capture stops (default 0:
    /// only the budget stops it).
    pub consistent_below: f64,
    /// The planner ranks arcs by score times width to this power (default 3,
    /// [`PlanParams::width_power`]).
    pub width_power: f64,
    /// How far from an arc's middle the edge-on pan of a flat face of the model may draw the
    /// next view, as a share of the arc's half-width (default 0.5; 0 splits every arc at its
    /// middle; [`PlanParams::aim_reach`]).
    pub aim_reach: f64,
    /// Serve every flat face of the model with a view in its plane before splitting arcs by
    /// rank alone: never, always, or when the initial views show a view-dependent surface
    /// (default [`FacesFirst::Auto`]).
    pub faces_first: FacesFirst,
    /// Serving faces first, a face is served by a view within this many degrees of its plane
    /// (default 1; [`PlanParams::face_served_deg`]).
    pub face_served_deg: f64,
}

impl Default for CaptureParams {
    fn default() -> Self {
        CaptureParams {
            strategy: Strategy::Active,
            initial: 12,
            max: 48,
            refine_every: 1,
            grid: 96,
            consistent_below: 0.0,
            width_power: PlanParams::default().width_power,
            aim_reach: PlanParams::default().aim_reach,
            faces_first: FacesFirst::Auto,
            face_served_deg: PlanParams::default().face_served_deg,
        }
    }
}

impl CaptureParams {
    /// Checks the counts. Uniform capture takes its whole budget evenly, so there the budget
    /// must be at least 3 views and the initial count is not asked.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason: String| Err(Error::InvalidParameter { name, reason });
        let (name, start) = match self.strategy {
            Strategy::Active => ("initial", self.initial),
            Strategy::Uniform => ("max", self.max),
        };
        if start < 3 {
            return bad(
                name,
                format!("at least 3 views are needed to start, not {start}"),
            );
        }
        if self.strategy == Strategy::Active && self.max < self.initial {
            return bad(
                "max",
                format!(
                    "the budget, {} views, is below the initial views, {}",
                    self.max, self.initial
                ),
            );
        }
        if self.refine_every == 0 {
            return bad("refine_every", "must be at least 1, not 0".into());
        }
        if !(8..=512).contains(&self.grid) {
            return bad(
                "grid",
                format!("must be between 8 and 512 voxels, not {}", self.grid),
            );
        }
        self.plan(self.faces_first != FacesFirst::Off).validate()?;
        Ok(())
    }

    /// The planner's part, serving faces first or not as `serve_faces` says (for
    /// [`FacesFirst::Auto`] the capture loop decides that from the initial views).
    pub fn plan(&self, serve_faces: bool) -> PlanParams {
        PlanParams {
            consistent_below: self.consistent_below,
            width_power: self.width_power,
            aim_reach: self.aim_reach,
            faces_first: serve_faces,
            face_served_deg: self.face_served_deg,
        }
    }
}

/// What the loop reports as it goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// A view was captured (`count` of at most `budget`).
    Captured {
        /// Views in the session now.
        count: usize,
        /// The budget.
        budget: usize,
        /// The angle reached.
        pan: Angle,
    },
    /// A model was reconstructed from `views` views.
    Reconstructed {
        /// Views used.
        views: usize,
        /// `voxel coloring` or `space carving`.
        algorithm: &'static str,
    },
    /// The next view was planned.
    Planned {
        /// Where.
        pan: Angle,
        /// The score of the arc it splits.
        score: f64,
    },
    /// With [`FacesFirst::Auto`], what the initial views decided.
    FacesFirstDecided {
        /// Their arcs' [`arc_contrast`] (`None` when no arc could be compared).
        contrast: Option<f64>,
        /// Whether the planner serves faces first.
        serve: bool,
    },
}

/// Wall time per stage, milliseconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageTimings {
    /// Moving and capturing (including rendering, on the synthetic rig) and saving.
    pub capture_ms: f64,
    /// Reconstruction (voxel coloring or space carving).
    pub coloring_ms: f64,
    /// The consistency estimate.
    pub scoring_ms: f64,
    /// Everything.
    pub total_ms: f64,
}

/// The outcome of [`capture`].
#[derive(Debug, Clone, PartialEq)]
pub struct CaptureReport {
    /// The pan angles captured, in capture order.
    pub pans: Vec<Angle>,
    /// Views that were already in the session when this run started.
    pub resumed_from: usize,
    /// True when the loop stopped before the budget (every arc consistent, or none can be
    /// split).
    pub stopped_early: bool,
    /// Wall time per stage.
    pub timings: StageTimings,
    /// The reconstruction algorithm used (the last one).
    pub algorithm: &'static str,
    /// Active capture: whether the planner served faces first ([`CaptureParams::faces_first`],
    /// for [`FacesFirst::Auto`] as the initial views decided). False for uniform capture.
    pub served_faces_first: bool,
    /// With [`FacesFirst::Auto`], the initial views' [`arc_contrast`] that decided it.
    pub initial_contrast: Option<f64>,
}

/// `n` pan angles spread over `range`, limits included, in whole steps.
pub fn uniform_pans(range: &PanRange, step: Angle, n: usize) -> Vec<Angle> {
    let limits = TurntableLimits {
        range: *range,
        step,
    };
    (0..n)
        .map(|i| {
            let t = if n > 1 {
                i as f64 / (n - 1) as f64
            } else {
                0.5
            };
            let a = limits.quantise(range.min() + range.span() * t);
            // Rounding can step past a limit: stay inside.
            let s = step.radians();
            let mut r = a.radians();
            if r > range.max().radians() {
                r -= s;
            }
            if r < range.min().radians() {
                r += s;
            }
            Angle::from_radians(r)
        })
        .collect()
}

/// Estimates the reconstruction volume from the foreground of `views`: the intersection of
/// their viewing cones (a visual hull on a 64^3 grid over `search`, less what some view does
/// not see at all), its bounds grown by a voxel and `margin_m` on every side. Errors when no voxel survives (the masks or the search box are
/// wrong).
pub fn estimate_volume(views: &[LoadedView], search: &Aabb, margin_m: f64) -> Result<Aabb> {
    let masks = masks_of(views)?;
    let grid = VoxelGrid::with_resolution(*search, 64)?;
    let vs = voxel_views(views, &masks);
    let hull = space_carving(
        &grid,
        &vs,
        &CarvingParams {
            max_passes: 0,
            ..CarvingParams::default()
        },
    )?;
    // Silhouettes cannot carve what a view does not see; on a turntable every view frames
    // the object, so a point outside any view's image is not part of it.
    let centres = hull
        .model
        .occupied
        .indexed_iter()
        .filter(|(_, o)| **o)
        .map(|((k, j, i), _)| grid.centre([i, j, k]))
        .filter(|c| {
            views.iter().all(|v| {
                v.camera
                    .project(c)
                    .is_some_and(|px| v.camera.size.contains(px))
            })
        });
    let bounds = Aabb::around(centres).ok_or_else(|| Error::InvalidParameter {
        name: "volume",
        reason: "no point is inside every view's foreground: check the masks".into(),
    })?;
    Ok(bounds.expanded(grid.voxel_size() + margin_m))
}

/// The views with their masks, as the voxel kernels take them.
pub(crate) fn voxel_views<'a>(views: &'a [LoadedView], masks: &'a [GrayImage]) -> Vec<View<'a>> {
    views
        .iter()
        .zip(masks)
        .map(|(v, m)| View {
            camera: &v.camera,
            image: &v.image,
            mask: Some(m),
        })
        .collect()
}

/// Foreground masks of the views: the recorded ones, or else estimated from the median
/// backdrop of all the views.
fn masks_of(views: &[LoadedView]) -> Result<Vec<GrayImage>> {
    if views.iter().all(|v| v.mask.is_some()) {
        return Ok(views.iter().filter_map(|v| v.mask.clone()).collect());
    }
    let images: Vec<_> = views.iter().map(|v| &v.image).collect();
    let estimate = median_backdrop(&images)?;
    views
        .iter()
        .map(|v| match &v.mask {
            Some(m) => Ok(m.clone()),
            None => Ok(foreground_from_backdrop(
                &v.image,
                &estimate,
                &BackdropDifference::default(),
            )?),
        })
        .collect()
}

/// The name [`reconstruct_views`] gives voxel coloring.
pub(crate) const VOXEL_COLORING: &str = "voxel coloring";

/// Why [`reconstruct_views`] would take space carving for these views in `volume` at `grid`:
/// the error naming the first camera that is not above the volume, or `None` when every camera
/// is above it and voxel coloring applies (and with it the [`ColoringParams`]).
pub fn why_not_voxel_coloring(
    views: &[LoadedView],
    volume: &Aabb,
    grid: usize,
) -> Result<Option<aibr_voxel::Error>> {
    let grid = VoxelGrid::with_resolution(*volume, grid)?;
    let cameras: Vec<View<'_>> = views
        .iter()
        .map(|v| View {
            camera: &v.camera,
            image: &v.image,
            mask: None,
        })
        .collect();
    Ok(check_cameras_above(&grid, &cameras).err())
}

/// Reconstructs a model from loaded views: voxel coloring with `coloring` where every camera
/// is above the volume, space carving otherwise ([`why_not_voxel_coloring`]). Returns the
/// reconstruction and the algorithm's name.
pub fn reconstruct_views(
    views: &[LoadedView],
    masks: &[GrayImage],
    volume: &Aabb,
    grid: usize,
    coloring: &ColoringParams,
) -> Result<(Reconstruction, &'static str)> {
    let grid = VoxelGrid::with_resolution(*volume, grid)?;
    let vs = voxel_views(views, masks);
    if check_cameras_above(&grid, &vs).is_ok() {
        Ok((voxel_coloring(&grid, &vs, coloring)?, VOXEL_COLORING))
    } else {
        Ok((
            space_carving(&grid, &vs, &CarvingParams::default())?,
            "space carving",
        ))
    }
}

/// Reconstructs the model of a session.
pub fn reconstruct(
    session: &Session,
    grid: usize,
    coloring: &ColoringParams,
) -> Result<(Reconstruction, &'static str)> {
    reconstruct_loaded(session, &session.load_views()?, grid, coloring)
}

/// [`reconstruct`] with the session's views already loaded.
pub fn reconstruct_loaded(
    session: &Session,
    views: &[LoadedView],
    grid: usize,
    coloring: &ColoringParams,
) -> Result<(Reconstruction, &'static str)> {
    let masks = masks_of(views)?;
    reconstruct_views(views, &masks, &session.volume()?, grid, coloring)
}

/// [`reconstruct_loaded`], then [`aibr_voxel::refine_tops`] on the model with `tops`: the
/// upward-facing surface moved down to where the views agree best. Better geometry (on the
/// synthetic `head`, 2.99 -> 1.23 voxels), but gaps where the sweep's fillets hid the
/// surface, which cost renders unless [`TopRefinement::walls`] closes them (which costs
/// accuracy: `head` 2.02 voxels); the capture loop and the renderer do not use it
/// (`docs/voxel.md`, "Refining the tops").
pub fn reconstruct_refined(
    session: &Session,
    views: &[LoadedView],
    grid: usize,
    coloring: &ColoringParams,
    tops: &TopRefinement,
) -> Result<(Reconstruction, &'static str, RefineStats)> {
    let masks = masks_of(views)?;
    let (mut rec, algorithm) =
        reconstruct_views(views, &masks, &session.volume()?, grid, coloring)?;
    let stats = refine_tops(&mut rec.model, &voxel_views(views, &masks), tops)?;
    Ok((rec, algorithm, stats))
}

/// Renders the view at pan angle `pan` from a session and its model.
pub fn render_session(
    session: &Session,
    model: &aibr_voxel::VoxelModel,
    pan: Angle,
) -> Result<RenderedView> {
    render_loaded(session, &session.load_views()?, model, pan)
}

/// [`render_session`] with the session's views already loaded.
pub fn render_loaded(
    session: &Session,
    views: &[LoadedView],
    model: &aibr_voxel::VoxelModel,
    pan: Angle,
) -> Result<RenderedView> {
    let (range, _) = session.turntable()?;
    let pan = range.check(pan)?;
    let calibration = session.calibration()?;
    Ok(renderer_for(views, model)?.render(&calibration.camera_at(pan))?)
}

/// A renderer over loaded views and their model, for rendering several novel views, with the
/// default [`RenderParams`].
pub fn renderer_for<'m>(
    views: &[LoadedView],
    model: &'m aibr_voxel::VoxelModel,
) -> Result<Renderer<'m>> {
    renderer_with(views, model, RenderParams::default())
}

/// [`renderer_for`] with other [`RenderParams`] (for example `refine: None`, faster). With
/// [`RenderParams::reflections`], the mirrors the model lacks are taken from the visual hull
/// of the views' masks, the recorded ones or else estimated from the backdrop as for the
/// reconstruction ([`Renderer::with_visual_hull`]).
pub fn renderer_with<'m>(
    views: &[LoadedView],
    model: &'m aibr_voxel::VoxelModel,
    params: RenderParams,
) -> Result<Renderer<'m>> {
    let masks = match params.reflections {
        Some(_) => masks_of(views)?,
        None => Vec::new(),
    };
    renderer_with_masks(views, &masks, model, params)
}

/// [`renderer_with`] with the views' masks already at hand, one per view (read only with
/// [`RenderParams::reflections`], for the visual hull).
pub(crate) fn renderer_with_masks<'m>(
    views: &[LoadedView],
    masks: &[GrayImage],
    model: &'m aibr_voxel::VoxelModel,
    params: RenderParams,
) -> Result<Renderer<'m>> {
    let sources = views
        .iter()
        .map(|v| SourceView {
            camera: v.camera.clone(),
            image: v.image.clone(),
        })
        .collect();
    let renderer = Renderer::new(model, sources, params)?;
    if params.reflections.is_none() {
        return Ok(renderer);
    }
    let hull = visual_hull(model.grid(), &voxel_views(views, masks))?;
    Ok(renderer.with_visual_hull(&hull)?)
}

/// Runs the capture loop on `rig` into `session` (which may already hold views: the loop
/// continues it, and since every step is deterministic, ends with the views an uninterrupted
/// run would have).
///
/// 1. The initial views, uniform over the range (for the uniform strategy, all `max`).
/// 2. Active: reconstruct every `refine_every` captures; score each arc between neighbouring
///    views; split the worst at its middle angle, or at a pan near it that sees a flat face
///    of the model edge-on ([`CaptureParams::aim_reach`]); capture there. With
///    [`CaptureParams::faces_first`], a face no view sees edge-on yet is served first, in the
///    best-ranked arc that holds one of its edge-on pans ([`FacesFirst::Auto`]: when the
///    initial views' arcs show a view-dependent surface, decided once). A rig that reaches
///    only some pans ([`Turntable::reachable`], a replayed ring) is asked for the one inside
///    that arc nearest that split, and an arc holding none is passed over. Stop at the budget,
///    or when every arc is consistent, too short to split or holds nothing reachable.
pub fn capture<R: Turntable + FrameSource>(
    rig: &mut R,
    session: &mut Session,
    params: &CaptureParams,
    progress: &mut dyn FnMut(Progress),
) -> Result<CaptureReport> {
    params.validate()?;
    let start = Instant::now();
    let mut timings = StageTimings::default();
    let range = rig.range();
    let step = rig.step();
    let limits = TurntableLimits::new(range, step)?;
    let resumed_from = session.file().views.len();
    let mut algorithm = "none";
    let planned_initial = match params.strategy {
        Strategy::Active => uniform_pans(&range, step, params.initial),
        Strategy::Uniform => uniform_pans(&range, step, params.max),
    };
    for pan in planned_initial.iter().skip(session.file().views.len()) {
        shoot(rig, session, *pan, params.max, &mut timings, progress)?;
    }
    let mut stopped_early = false;
    // Serving faces first: as asked, or for `Auto` as the initial views' arcs decide.
    let mut serve_faces = match params.faces_first {
        FacesFirst::Off => Some(false),
        FacesFirst::On => Some(true),
        FacesFirst::Auto => None,
    };
    let mut initial_contrast = None;
    if session.volume_pending() {
        let views = session.load_views()?;
        let search = search_box(&views);
        let volume = estimate_volume(&views, &search, 0.005)?;
        session.set_volume(&volume)?;
    }
    if params.strategy == Strategy::Active {
        let volume = session.volume()?;
        // The calibration's pose model, when the planner aims at the model's flat faces.
        let motion = session.calibration()?.motion;
        let aims_from =
            (params.aim_reach > 0.0 || params.faces_first != FacesFirst::Off).then_some(&motion);
        let mut scores: Vec<PairScore> = Vec::new();
        let mut aims: Vec<Vec<Angle>> = Vec::new();
        let mut since_refine = 0usize;
        // On resume, the views after the initial ones were planned from reconstructions made
        // every `refine_every` captures: restart the count where an uninterrupted run was.
        let extra = session.file().views.len().saturating_sub(params.initial);
        let mut must_refine = true;
        // Decoded once; each capture adds its own view (not the whole session again).
        let mut views = session.load_views()?;
        // What `Auto` decided from the initial views' scores.
        let mut decide = |scores: &[PairScore], progress: &mut dyn FnMut(Progress)| {
            let contrast = arc_contrast(scores);
            let serve = contrast.is_some_and(|c| c >= VIEW_DEPENDENT_CONTRAST);
            progress(Progress::FacesFirstDecided { contrast, serve });
            initial_contrast = contrast;
            serve
        };
        if serve_faces.is_none() && views.len() > params.initial {
            // Resumed past the initial views: score them again, as the run that captured
            // them did.
            let (initial_scores, _) = score_views(
                &views[..params.initial],
                &volume,
                params,
                &range,
                None,
                &mut timings,
                &mut algorithm,
            )?;
            serve_faces = Some(decide(&initial_scores, progress));
        }
        if extra % params.refine_every != 0 {
            // Rebuild the scores the uninterrupted run had at its last refinement.
            let refined_at = params.initial + extra - extra % params.refine_every;
            (scores, aims) = score_views(
                &views[..refined_at],
                &volume,
                params,
                &range,
                aims_from,
                &mut timings,
                &mut algorithm,
            )?;
            // Remove the arcs that later captures split.
            let pans: Vec<Angle> = views
                .iter()
                .map(|v| Angle::from_radians(v.record.pan_rad))
                .collect();
            for v in refined_at..views.len() {
                scores.retain(|s| !splits(&pans, s, pans[v]));
            }
            since_refine = extra % params.refine_every;
            must_refine = false;
        }
        while session.file().views.len() < params.max {
            if must_refine || since_refine >= params.refine_every {
                views.extend(session.load_views_from(views.len())?);
                (scores, aims) = score_views(
                    &views,
                    &volume,
                    params,
                    &range,
                    aims_from,
                    &mut timings,
                    &mut algorithm,
                )?;
                progress(Progress::Reconstructed {
                    views: views.len(),
                    algorithm,
                });
                since_refine = 0;
                must_refine = false;
            }
            // The first refinement of a fresh run is of the initial views.
            let serve = match serve_faces {
                Some(serve) => serve,
                None => *serve_faces.insert(decide(&scores, progress)),
            };
            let pans = session.pans();
            let reachable = rig.reachable();
            let planned = plan_next_among(
                &pans,
                &scores,
                &aims,
                reachable.as_deref(),
                &limits,
                &params.plan(serve),
            )?;
            let Some(next) = planned else {
                stopped_early = true;
                break;
            };
            progress(Progress::Planned {
                pan: next.pan,
                score: next.score,
            });
            scores.retain(|s| (s.a, s.b) != next.pair);
            shoot(rig, session, next.pan, params.max, &mut timings, progress)?;
            since_refine += 1;
        }
    }
    timings.total_ms = start.elapsed().as_secs_f64() * 1e3;
    Ok(CaptureReport {
        pans: session.pans(),
        resumed_from,
        stopped_early,
        timings,
        algorithm,
        served_faces_first: params.strategy == Strategy::Active && serve_faces == Some(true),
        initial_contrast,
    })
}

/// Moves, captures and saves one view.
fn shoot<R: Turntable + FrameSource>(
    rig: &mut R,
    session: &mut Session,
    pan: Angle,
    budget: usize,
    timings: &mut StageTimings,
    progress: &mut dyn FnMut(Progress),
) -> Result<()> {
    let t = Instant::now();
    let step = rig.step();
    let reached = rig.move_to(pan)?;
    let frame = rig.capture()?;
    let steps = (reached.radians() / step.radians()).round() as i64;
    session.add_view(reached, steps, &frame.image, frame.mask.as_ref())?;
    timings.capture_ms += t.elapsed().as_secs_f64() * 1e3;
    progress(Progress::Captured {
        count: session.file().views.len(),
        budget,
        pan: reached,
    });
    Ok(())
}

/// Where to look for the object: a box around the pan axis reaching half-way to the nearest
/// camera, from the turntable up to the cameras' height.
fn search_box(views: &[LoadedView]) -> Aabb {
    let (mut reach, mut top) = (f64::INFINITY, 0.0f64);
    for v in views {
        let c = v.camera.centre();
        reach = reach.min((c.x * c.x + c.y * c.y).sqrt());
        top = top.max(c.z);
    }
    let r = 0.5 * reach;
    Aabb {
        min: nalgebra::Point3::new(-r, -r, -0.25 * r),
        max: nalgebra::Point3::new(r, r, top.max(r)),
    }
}

/// True when `pan` lies inside the arc of `s`.
fn splits(pans: &[Angle], s: &PairScore, pan: Angle) -> bool {
    let (a, b) = (pans[s.a].radians(), pans[s.b].radians());
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    pan.radians() > lo && pan.radians() < hi
}

/// The consistency score of every pair of neighbouring views of `session` (its loaded
/// `views`), from their model at `grid` voxels along the longest edge: what the active planner
/// ranks. Returns the views' pan angles (in capture order; the scores index into them) and the
/// scores.
pub fn pair_scores(
    session: &Session,
    views: &[LoadedView],
    grid: usize,
) -> Result<(Vec<Angle>, Vec<PairScore>)> {
    let (range, _) = session.turntable()?;
    let params = CaptureParams {
        grid,
        ..CaptureParams::default()
    };
    let mut timings = StageTimings::default();
    let mut algorithm = "none";
    let (scores, _) = score_views(
        views,
        &session.volume()?,
        &params,
        &range,
        None,
        &mut timings,
        &mut algorithm,
    )?;
    let pans = views
        .iter()
        .map(|v| Angle::from_radians(v.record.pan_rad))
        .collect();
    Ok((pans, scores))
}

/// The scores of `views`' neighbouring pairs from their model; with the turntable's pose
/// model `aims_from`, also the pans that see the model's flat faces edge-on ([`face_aims`]).
fn score_views(
    views: &[LoadedView],
    volume: &Aabb,
    params: &CaptureParams,
    range: &PanRange,
    aims_from: Option<&CircularMotion>,
    timings: &mut StageTimings,
    algorithm: &mut &'static str,
) -> Result<(Vec<PairScore>, Vec<Vec<Angle>>)> {
    let masks = masks_of(views)?;
    let t = Instant::now();
    let (rec, alg) = reconstruct_views(
        views,
        &masks,
        volume,
        params.grid,
        &ColoringParams::default(),
    )?;
    timings.coloring_ms += t.elapsed().as_secs_f64() * 1e3;
    *algorithm = alg;
    let t = Instant::now();
    let vs = voxel_views(views, &masks);
    let pans: Vec<Angle> = views
        .iter()
        .map(|v| Angle::from_radians(v.record.pan_rad))
        .collect();
    let scores = score_pairs(&rec.model, &vs, &pans, range, &ConsistencyParams::default())?;
    let aims = match aims_from {
        Some(motion) => face_aims(&rec.model, motion, range)?,
        None => Vec::new(),
    };
    timings.scoring_ms += t.elapsed().as_secs_f64() * 1e3;
    Ok((scores, aims))
}

/// The pans of `range` that see a flat face of `model` edge-on, for a camera moving by
/// `motion`: where the planner aims.
fn face_aims(
    model: &aibr_voxel::VoxelModel,
    motion: &CircularMotion,
    range: &PanRange,
) -> Result<Vec<Vec<Angle>>> {
    let faces = planar_faces(model, &FaceParams::default())?;
    Ok(faces
        .iter()
        .map(|f| edge_on_pans(f, motion, range))
        .filter(|pans| !pans.is_empty())
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The message `params`' refusal gives.
    fn refusal(params: CaptureParams) -> String {
        match params.validate() {
            Err(e @ Error::InvalidParameter { .. }) => e.to_string(),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn refusals_name_the_values() {
        let counts = |initial, max| CaptureParams {
            initial,
            max,
            ..CaptureParams::default()
        };
        assert_eq!(
            refusal(counts(50, 48)),
            "invalid max: the budget, 48 views, is below the initial views, 50"
        );
        assert_eq!(
            refusal(counts(2, 48)),
            "invalid initial: at least 3 views are needed to start, not 2"
        );
        let grid = CaptureParams {
            grid: 600,
            ..CaptureParams::default()
        };
        assert_eq!(
            refusal(grid),
            "invalid grid: must be between 8 and 512 voxels, not 600"
        );
        assert!(CaptureParams::default().validate().is_ok());
        // Uniform capture takes its budget evenly: the initial count is not asked.
        let uniform = |max| CaptureParams {
            strategy: Strategy::Uniform,
            ..counts(12, max)
        };
        assert!(uniform(6).validate().is_ok());
        assert_eq!(
            refusal(uniform(2)),
            "invalid max: at least 3 views are needed to start, not 2"
        );
    }
}
