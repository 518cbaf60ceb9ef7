//! Active against uniform, measured against ground truth: on a synthetic rig (every
//! uncaptured angle of a fine grid, rendered by the scene) or on a replay rig (every recorded
//! view that was not captured).

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::Path;

use aibr_camera::{Angle, Camera};
use aibr_render::{MirrorCounts, RenderParams, metrics};
use aibr_scene::{GeometryReference, RenderOptions, Scene};
use aibr_voxel::metrics::{GeometryScore, geometry_score};
use aibr_voxel::{
    ColoringParams, ColumnTest, TopRefinement, VoxelGrid, VoxelModel, refine_tops, visual_hull,
};
use image::{GrayImage, RgbImage};

use crate::capture::{
    CaptureParams, CaptureReport, Strategy, VOXEL_COLORING, capture, reconstruct_views,
    renderer_with_masks, voxel_views,
};
use crate::error::{Error, Result};
use crate::replay::ReplayRig;
use crate::rig::{Calibration, FrameSource, SimRig, Turntable};
use crate::session::{LoadedView, Session};

/// A rig that knows the truth, so that capture strategies can be measured on it.
pub trait EvalRig: Turntable + FrameSource + Sized {
    /// The rig in its initial state, for a new capture.
    fn fresh(&self) -> Result<Self>;
    /// The rig's calibration.
    fn eval_calibration(&self) -> Result<Calibration>;
    /// Tells a resumed rig which views its session already holds.
    fn already_captured(&mut self, _pans: &[Angle]) {}
    /// The novel views to measure when `captured` were captured, with their true cameras;
    /// `step` is the spacing of a grid of angles, where the rig can render any angle.
    fn novel_views(&self, captured: &[Angle], step: Angle) -> Result<Vec<(Angle, Camera)>>;
    /// The true image and object mask of a novel view.
    fn truth(&self, pan: Angle, camera: &Camera) -> Result<(RgbImage, GrayImage)>;
    /// The true geometry, where the rig knows it (a synthetic scene), for
    /// [`EvalModel::Truth`]; `None` by default.
    fn true_geometry(&self) -> Option<&Scene> {
        None
    }
}

impl EvalRig for SimRig {
    fn fresh(&self) -> Result<Self> {
        SimRig::new(self.scene_name())
    }

    fn eval_calibration(&self) -> Result<Calibration> {
        self.calibration()
    }

    fn novel_views(&self, captured: &[Angle], step: Angle) -> Result<Vec<(Angle, Camera)>> {
        self.novel_views_offset(captured, step, Angle::ZERO)
    }

    fn truth(&self, _pan: Angle, camera: &Camera) -> Result<(RgbImage, GrayImage)> {
        let truth = self.scene().render(camera, &RenderOptions::default())?;
        Ok((truth.rgb8(), truth.mask))
    }

    fn true_geometry(&self) -> Option<&Scene> {
        Some(self.scene())
    }
}

impl SimRig {
    /// [`EvalRig::novel_views`] on a grid moved `offset` along: every `step` from the pan
    /// range's start plus `offset`, leaving out the angles near a captured view by the same
    /// rule as the grid itself (within half a `step`, never more than half a degree). With
    /// `offset` half a step it scores the angles between the grid's, which a choice of views
    /// fitted to the grid was not chosen against.
    pub fn novel_views_offset(
        &self,
        captured: &[Angle],
        step: Angle,
        offset: Angle,
    ) -> Result<Vec<(Angle, Camera)>> {
        let calibration = self.calibration()?;
        let range = self.range();
        let step = step.radians();
        let taken = captured_within(step);
        let mut out = Vec::new();
        let mut a = range.min().radians() + offset.radians();
        while a <= range.max().radians() + 1e-9 {
            let pan = Angle::from_radians(a);
            a += step;
            if !captured
                .iter()
                .any(|p| (p.radians() - pan.radians()).abs() < taken)
            {
                out.push((pan, calibration.camera_at(pan)));
            }
        }
        Ok(out)
    }
}

/// How close to a captured view an angle of the evaluation grid counts as captured, radians:
/// half the grid's step, but never more than half a degree.
///
/// Half a step alone would make a coarse grid biased: at 5 degrees, every grid angle within 2.5
/// degrees of a capture would be skipped, so a strategy that clusters its views (active capture
/// on a mirror, 2-4 degrees apart) would have most of that region, where it renders worst,
/// left out of its mean, and uniform capture would not.
fn captured_within(step: f64) -> f64 {
    (0.5 * step).min(0.5f64.to_radians())
}

impl EvalRig for ReplayRig {
    fn fresh(&self) -> Result<Self> {
        Ok(ReplayRig::fresh(self))
    }

    fn eval_calibration(&self) -> Result<Calibration> {
        Ok(self.calibration())
    }

    fn already_captured(&mut self, pans: &[Angle]) {
        for &p in pans {
            self.mark_served(p);
        }
    }

    fn novel_views(&self, captured: &[Angle], _step: Angle) -> Result<Vec<(Angle, Camera)>> {
        let taken: Vec<usize> = captured.iter().filter_map(|&p| self.view_at(p)).collect();
        Ok(self
            .views()
            .iter()
            .enumerate()
            .filter(|(i, _)| !taken.contains(i))
            .map(|(_, v)| (v.pan, v.camera.clone()))
            .collect())
    }

    fn truth(&self, pan: Angle, _camera: &Camera) -> Result<(RgbImage, GrayImage)> {
        let i = self
            .view_at(pan)
            .ok_or_else(|| Error::Rig(format!("no recorded view at {:.4} deg", pan.degrees())))?;
        let v = &self.views()[i];
        Ok((v.image.clone(), v.mask.clone()))
    }
}

/// The geometry the novel views of an evaluation are rendered from.
///
/// The capture does not depend on it (the loop always plans from its own reconstructions),
/// so evaluations that differ only here measure the same views, and what the geometry costs
/// can be told apart from what the choice of views does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EvalModel {
    /// The voxel model reconstructed from the views (voxel coloring, or space carving where
    /// the cameras are not all above the volume): the system as it runs.
    #[default]
    Reconstructed,
    /// The reconstruction with its upward-facing surface refined and the refinement's steps
    /// walled ([`aibr_voxel::refine_tops`] with [`aibr_voxel::TopRefinement::walls`]): the
    /// geometry a renderer could use instead of the sweep's (`docs/voxel.md`, "Walls for the
    /// steps"). Only where voxel coloring made the model; a space-carved one is used as it is.
    Refined,
    /// The views reconstructed by voxel coloring with its column test
    /// ([`aibr_voxel::ColoringParams::column_test`], its defaults): better geometry on
    /// textured tops (`docs/voxel.md`, "The column test"). Where the cameras are not all
    /// above the volume, space carving's model, as for [`EvalModel::Reconstructed`].
    ColumnTest,
    /// The visual hull of the views' object masks: geometry from silhouettes alone.
    VisualHull,
    /// The rig's true geometry voxelised on the same grid ([`EvalRig::true_geometry`];
    /// synthetic rigs only): a diagnostic, what the renderer and the choice of views give
    /// with perfect geometry.
    Truth,
}

impl EvalModel {
    /// Its name on the command line and in reports: `reconstructed`, `refined`, `column`,
    /// `hull`, `truth`.
    pub fn name(self) -> &'static str {
        match self {
            EvalModel::Reconstructed => "reconstructed",
            EvalModel::Refined => "refined",
            EvalModel::ColumnTest => "column",
            EvalModel::VisualHull => "hull",
            EvalModel::Truth => "truth",
        }
    }
}

/// Parameters of [`evaluate`].
#[derive(Debug, Clone, PartialEq)]
pub struct EvalParams {
    /// The capture: initial views, budget, refinement, capture grid (its strategy is each
    /// evaluated one's in turn). Uniform capture takes each checkpoint's views evenly, so
    /// when it is evaluated alone only the budget is asked of the counts.
    pub capture: CaptureParams,
    /// View counts at which to measure, increasing (each at most the budget, and with
    /// [`Strategy::Active`] at least the initial count), e.g. 12, 24, 36, 48.
    pub checkpoints: Vec<usize>,
    /// Voxels along the longest edge of the models the novel views are rendered from.
    pub grid: usize,
    /// Spacing of the evaluated pan angles (default 1 degree); angles within half a step
    /// (at most half a degree) of a captured view are skipped (they were captured).
    pub step: Angle,
    /// The geometry the novel views are rendered from (default: the reconstruction).
    pub model: EvalModel,
    /// How the novel views are rendered (default: [`RenderParams::default`]).
    pub render: RenderParams,
}

impl Default for EvalParams {
    /// The paper's experiment as `aibr eval` runs it by default: 12 uniform views, a budget
    /// of 48, measured at 12, 24, 36 and 48 views on a 1-degree grid, rendered from 128^3
    /// reconstructions.
    fn default() -> Self {
        let capture = CaptureParams::default();
        EvalParams {
            checkpoints: vec![capture.initial, 24, 36, capture.max],
            capture,
            grid: 128,
            step: Angle::from_degrees(1.0),
            model: EvalModel::Reconstructed,
            render: RenderParams::default(),
        }
    }
}

/// The measurement of one set of views.
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    /// Views in the set.
    pub views: usize,
    /// Their pan angles, sorted.
    pub pans: Vec<Angle>,
    /// Novel views evaluated.
    pub evaluated: usize,
    /// Mean masked PSNR of the novel views, dB.
    pub mean_psnr: f64,
    /// Masked PSNR of the novel views' mean squared error, dB
    /// ([`aibr_render::metrics::pooled_psnr`]): their errors pooled before the logarithm, so
    /// the views that render worst weigh the most. Never above `mean_psnr`.
    pub pooled_psnr: f64,
    /// Mean masked SSIM.
    pub mean_ssim: f64,
    /// The worst arc between neighbouring views: its mean masked PSNR, dB.
    pub worst_arc_psnr: f64,
    /// And the arc, as its end angles.
    pub worst_arc: (Angle, Angle),
    /// Every novel view evaluated, in pan order.
    pub novel: Vec<NovelView>,
    /// Accuracy and completeness of the model the novel views were rendered from, against
    /// the rig's true surface ([`Scene::geometry_reference`]); `None` on a rig that does
    /// not know its geometry (a replay). Renders depend on the geometry as much as on the
    /// views, and which views are taken changes the geometry (`docs/results.md`).
    pub geometry: Option<GeometryScore>,
    /// The novel views at the angles that no strategy of the evaluation captured at this
    /// checkpoint; `None` when only one strategy was evaluated (or no angle is common). Each
    /// strategy's mean is otherwise over its own novel views, which leave out the angles it
    /// chose to capture, so this is the like-for-like comparison.
    pub common: Option<ViewFigures>,
    /// With [`RenderParams::reflections`], how many surface voxels of the model and of the
    /// views' visual hull the renderer judged and found mirrors
    /// ([`aibr_render::Renderer::mirror_counts`]); `None` without reflections.
    pub mirrors: Option<MirrorCounts>,
}

/// The figures of a set of a checkpoint's novel views: all of them, those at the angles every
/// evaluated strategy left out ([`Checkpoint::common`]), or those on an arc of the object
/// ([`Checkpoint::split`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewFigures {
    /// How many angles.
    pub angles: usize,
    /// Mean masked PSNR over them, dB.
    pub mean_psnr: f64,
    /// Masked PSNR of their mean squared error, dB.
    pub pooled_psnr: f64,
    /// Mean masked SSIM over them.
    pub mean_ssim: f64,
}

/// An arc of the object's own pan angles, from `from` up to `to` (through the full turn when
/// `to` is below `from`), as the object stands where the catalogue places it: on a scene
/// turned on its turntable (`sim:SCENE@DEGREES`) the view reported at pan `p` sees the object
/// at `p` plus the turn. It names a side of the object, such as `mirror`'s panel side, however
/// the object is turned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectArc {
    /// Where the arc starts.
    pub from: Angle,
    /// Where it ends.
    pub to: Angle,
}

impl ObjectArc {
    /// Whether the object's pan angle `pan` lies on the arc (its ends included; angles
    /// compared modulo a full turn).
    pub fn contains(&self, pan: Angle) -> bool {
        let tau = std::f64::consts::TAU;
        let span = (self.to.radians() - self.from.radians()).rem_euclid(tau);
        (pan.radians() - self.from.radians()).rem_euclid(tau) <= span + 1e-12
    }
}

/// A checkpoint's novel views split by an [`ObjectArc`] ([`Checkpoint::split`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcSplit {
    /// The figures of the novel views on the arc; `None` when there are none.
    pub inside: Option<ViewFigures>,
    /// Those of the others.
    pub outside: Option<ViewFigures>,
    /// How many of the checkpoint's captured views lie on the arc.
    pub captured_inside: usize,
}

impl Checkpoint {
    /// The figures of the novel views whose object pan angle (the reported pan plus `turn`,
    /// how far the object stands turned on the turntable) lies on `arc`, and of the others.
    pub fn split(&self, arc: &ObjectArc, turn: Angle) -> ArcSplit {
        let on_arc = |pan: Angle| arc.contains(pan + turn);
        let (inside, outside): (Vec<&NovelView>, Vec<&NovelView>) =
            self.novel.iter().partition(|v| on_arc(v.pan));
        ArcSplit {
            inside: ViewFigures::of(&inside),
            outside: ViewFigures::of(&outside),
            captured_inside: self.pans.iter().filter(|&&p| on_arc(p)).count(),
        }
    }
}

/// The measurement of one novel view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NovelView {
    /// Its pan angle.
    pub pan: Angle,
    /// Masked PSNR against the truth, dB.
    pub psnr: f64,
    /// Masked SSIM.
    pub ssim: f64,
}

/// One strategy's checkpoints.
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyEval {
    /// The strategy.
    pub strategy: Strategy,
    /// Active capture: whether its planner served faces first
    /// ([`CaptureParams::faces_first`](crate::CaptureParams::faces_first); with
    /// [`FacesFirst::Auto`](crate::FacesFirst::Auto), as its initial views decided). `None`
    /// for uniform capture.
    pub served_faces_first: Option<bool>,
    /// Active capture with [`FacesFirst::Auto`](crate::FacesFirst::Auto): the initial views'
    /// [`arc_contrast`](crate::consistency::arc_contrast) that decided it. `None` otherwise,
    /// or when no arc could be compared.
    pub initial_contrast: Option<f64>,
    /// One per checkpoint, in order.
    pub checkpoints: Vec<Checkpoint>,
}

/// Runs each strategy on the synthetic rig `scene` (sessions under `work_dir`), and at every
/// checkpoint renders every pan angle on the evaluation grid that was not captured, from the
/// first views of the active session (or a uniform set of that size), and compares it with
/// the ground truth inside the object mask. Strategies (at least one, each once), counts,
/// checkpoints and the renderer's parameters are checked before anything is captured, and a
/// bad one is named in [`Error::InvalidParameter`].
///
/// Each ground-truth view is rendered once and kept for the whole evaluation (about 1.2 MB
/// per evaluated angle at 640x480: some 380 MB for every degree of the default pan range).
pub fn evaluate(
    scene: &str,
    strategies: &[Strategy],
    params: &EvalParams,
    work_dir: &Path,
    progress: &mut dyn FnMut(String),
) -> Result<Vec<StrategyEval>> {
    let rig = SimRig::new(scene)?;
    evaluate_rig(
        &rig,
        scene,
        &format!("sim:{scene}"),
        strategies,
        params,
        work_dir,
        progress,
    )
}

/// What is wrong with `params.checkpoints` for evaluating `strategies`, if anything: each
/// must lie between 3 and the budget, they must increase (each set measured once, in the
/// order the report gives them), at least one is needed, and with active capture none may
/// be below the initial count (its first views are the initial uniform ones, so fewer would
/// be part of that set, the first few of its pans, not a capture of that many views).
fn checkpoints_fault(params: &EvalParams, strategies: &[Strategy]) -> Option<String> {
    let (checkpoints, max) = (&params.checkpoints, params.capture.max);
    if checkpoints.iter().any(|&c| c > max || c < 3) {
        return Some(format!("each must be between 3 and the budget {max}"));
    }
    if let Some(w) = checkpoints.windows(2).find(|w| w[1] <= w[0]) {
        return Some(format!("they must increase, not {} then {}", w[0], w[1]));
    }
    if checkpoints.is_empty() {
        return Some("none given: nothing would be measured".into());
    }
    let initial = params.capture.initial;
    if strategies.contains(&Strategy::Active) {
        if let Some(c) = checkpoints.iter().find(|&&c| c < initial) {
            return Some(format!(
                "{c} is below the initial {initial} views: active capture's first {initial} \
                 views are its initial uniform ones, so each checkpoint must be at least \
                 {initial} when active capture is evaluated"
            ));
        }
    }
    None
}

/// [`evaluate`] on any rig that knows its truth: `name` names its sessions under
/// `work_dir`, `spec` is recorded in them.
pub fn evaluate_rig<R: EvalRig>(
    rig: &R,
    name: &str,
    spec: &str,
    strategies: &[Strategy],
    params: &EvalParams,
    work_dir: &Path,
    progress: &mut dyn FnMut(String),
) -> Result<Vec<StrategyEval>> {
    if strategies.is_empty() {
        return Err(Error::InvalidParameter {
            name: "strategies",
            reason: "none given: nothing would be evaluated".into(),
        });
    }
    if let Some(twice) = (1..strategies.len())
        .find(|&i| strategies[..i].contains(&strategies[i]))
        .map(|i| strategies[i])
    {
        return Err(Error::InvalidParameter {
            name: "strategies",
            reason: format!(
                "{} is given twice: each strategy is evaluated once",
                twice.name()
            ),
        });
    }
    // The counts first: a bad initial count or budget is named as such, not as a checkpoint
    // out of range. They are checked as the strategies evaluated use them: the initial count
    // only where active capture is (uniform capture takes each checkpoint's views evenly).
    let counted = if strategies.contains(&Strategy::Active) {
        Strategy::Active
    } else {
        Strategy::Uniform
    };
    CaptureParams {
        strategy: counted,
        ..params.capture
    }
    .validate()?;
    if let Some(reason) = checkpoints_fault(params, strategies) {
        return Err(Error::InvalidParameter {
            name: "checkpoints",
            reason,
        });
    }
    if !(params.step.radians() > 0.0) {
        return Err(Error::InvalidParameter {
            name: "step",
            reason: "the evaluation step must be positive".into(),
        });
    }
    // A grid of one angle, the range's first, which the initial views capture: nothing
    // would be left to measure (`measure` refuses any checkpoint that leaves nothing).
    let span = rig.range().span();
    if params.step.radians() > span.radians() {
        return Err(Error::InvalidParameter {
            name: "step",
            reason: format!(
                "{:.1} degrees is wider than the rig's pan range of {:.1} degrees: no angle \
                 would be left to measure",
                params.step.degrees(),
                span.degrees()
            ),
        });
    }
    // The renderer's parameters too, before any view is captured.
    params.render.validate()?;
    let geometry = match params.model {
        EvalModel::Reconstructed => Geometry::Reconstructed,
        EvalModel::Refined => Geometry::Refined,
        EvalModel::ColumnTest => Geometry::ColumnTest,
        EvalModel::VisualHull => Geometry::VisualHull,
        EvalModel::Truth => {
            Geometry::Truth(rig.true_geometry().ok_or_else(|| Error::InvalidParameter {
                name: "model",
                reason: format!(
                    "the rig {spec} does not know its true geometry (only synthetic rigs do): \
                     render from the reconstruction or the visual hull"
                ),
            })?)
        }
    };
    // The true surface, sampled once, to score every checkpoint's model against.
    let reference = match rig.true_geometry() {
        Some(scene) => {
            progress("sampling the true surface".into());
            Some(scene.geometry_reference()?)
        }
        None => None,
    };
    let model = Measure {
        geometry,
        reference: reference.as_ref(),
    };
    let mut out = Vec::new();
    // Ground truth per evaluated pan angle, rendered (or read) once for every checkpoint
    // of every strategy: most angles recur.
    let mut truths = TruthCache::default();
    for &strategy in strategies {
        let mut checkpoints = Vec::new();
        // The active views at n are the first n of one run (decoded once); a uniform set is
        // its own run.
        // Active capture's report: what its initial views decided about faces first.
        let mut active_report = None;
        let active = match strategy {
            Strategy::Active if !params.checkpoints.is_empty() => {
                let dir = work_dir.join(format!("{name}-active"));
                let p = CaptureParams {
                    strategy,
                    ..params.capture
                };
                let (session, captured) = run(rig, spec, &dir, &p, progress)?;
                active_report = Some(captured);
                let views = session.load_views()?;
                Some((session, views))
            }
            _ => None,
        };
        for &n in &params.checkpoints {
            let uniform;
            let (session, all) = match &active {
                Some((s, v)) => (s, v),
                None => {
                    let dir = work_dir.join(format!("{name}-uniform-{n}"));
                    let p = CaptureParams {
                        strategy,
                        max: n,
                        initial: n.min(params.capture.initial).max(3),
                        ..params.capture
                    };
                    let (s, _) = run(rig, spec, &dir, &p, progress)?;
                    let v = s.load_views()?;
                    uniform = (s, v);
                    (&uniform.0, &uniform.1)
                }
            };
            let views = &all[..n.min(all.len())];
            progress(format!(
                "{} {n} views: rendering novel views",
                strategy.name()
            ));
            checkpoints.push(measure(rig, views, session, params, model, &mut truths)?);
        }
        out.push(StrategyEval {
            strategy,
            served_faces_first: active_report.as_ref().map(|r| r.served_faces_first),
            initial_contrast: active_report.and_then(|r| r.initial_contrast),
            checkpoints,
        });
    }
    if out.len() > 1 {
        add_common_angles(&mut out);
    }
    Ok(out)
}

/// Fills every checkpoint's [`Checkpoint::common`]: the strategies' checkpoints at the same
/// position share a view count, and their novel angles come from one evaluation grid, so an
/// angle is the same bits in each.
fn add_common_angles(results: &mut [StrategyEval]) {
    let checkpoints = results
        .iter()
        .map(|r| r.checkpoints.len())
        .min()
        .unwrap_or(0);
    for i in 0..checkpoints {
        let mut common: Option<std::collections::HashSet<u64>> = None;
        for r in results.iter() {
            let pans = r.checkpoints[i]
                .novel
                .iter()
                .map(|v| v.pan.radians().to_bits());
            common = Some(match common {
                None => pans.collect(),
                Some(c) => pans.filter(|p| c.contains(p)).collect(),
            });
        }
        let common = common.unwrap_or_default();
        for r in results.iter_mut() {
            let c = &mut r.checkpoints[i];
            let views: Vec<&NovelView> = c
                .novel
                .iter()
                .filter(|v| common.contains(&v.pan.radians().to_bits()))
                .collect();
            c.common = ViewFigures::of(&views);
        }
    }
}

impl ViewFigures {
    /// The figures of `views` (a checkpoint's reports the same over all its novel views);
    /// `None` for none.
    fn of(views: &[&NovelView]) -> Option<Self> {
        Some(ViewFigures {
            angles: views.len(),
            mean_psnr: mean_of(views, |v| v.psnr),
            pooled_psnr: metrics::pooled_psnr(views.iter().map(|v| v.psnr))?,
            mean_ssim: mean_of(views, |v| v.ssim),
        })
    }
}

/// The mean of `f` over `views` (0 for none).
fn mean_of(views: &[&NovelView], f: fn(&NovelView) -> f64) -> f64 {
    views.iter().map(|v| f(v)).sum::<f64>() / views.len().max(1) as f64
}

/// Captures (or continues) the session in `dir`; with the capture's report (whether its
/// planner served faces first, and the contrast that decided it).
fn run<R: EvalRig>(
    template: &R,
    spec: &str,
    dir: &Path,
    params: &CaptureParams,
    progress: &mut dyn FnMut(String),
) -> Result<(Session, CaptureReport)> {
    let mut rig = template.fresh()?;
    let calibration = rig.eval_calibration()?;
    let mut session = if dir.join("session.json").exists() {
        let s = Session::open(dir)?;
        s.check_parameters(spec, params)?;
        let pans: Vec<Angle> = s
            .file()
            .views
            .iter()
            .map(|v| Angle::from_radians(v.pan_rad))
            .collect();
        rig.already_captured(&pans);
        s
    } else {
        let volume = if rig.known_volume().is_some() {
            crate::VolumeSource::Scene
        } else {
            crate::VolumeSource::Estimated
        };
        crate::new_session_with_volume(dir, spec, &rig, &calibration, params, volume)?
    };
    let name = params.strategy.name();
    let report = capture(&mut rig, &mut session, params, &mut |p| match p {
        crate::Progress::Captured { count, budget, .. } => {
            progress(format!("{name}: {count}/{budget} views"));
        }
        crate::Progress::FacesFirstDecided { contrast, serve } => progress(format!(
            "{name}: initial arcs' contrast {}, faces first {serve}",
            contrast.map_or("none".into(), |c| format!("{c:.2}"))
        )),
        _ => {}
    })?;
    Ok((session, report))
}

/// Ground-truth image and object mask per pan angle (its radians' bits).
type TruthCache = HashMap<u64, (RgbImage, GrayImage)>;

/// [`EvalModel`] resolved against the rig: what each checkpoint renders from.
#[derive(Clone, Copy)]
enum Geometry<'a> {
    Reconstructed,
    Refined,
    ColumnTest,
    VisualHull,
    Truth(&'a Scene),
}

/// What a checkpoint renders from, and the true surface to score that against.
#[derive(Clone, Copy)]
struct Measure<'a> {
    geometry: Geometry<'a>,
    reference: Option<&'a GeometryReference>,
}

fn measure<R: EvalRig>(
    rig: &R,
    views: &[LoadedView],
    session: &Session,
    params: &EvalParams,
    Measure {
        geometry,
        reference,
    }: Measure<'_>,
    truths: &mut TruthCache,
) -> Result<Checkpoint> {
    let mut pans: Vec<Angle> = views
        .iter()
        .map(|v| Angle::from_radians(v.record.pan_rad))
        .collect();
    pans.sort_by(|a, b| a.radians().total_cmp(&b.radians()));
    // What is left to measure, before anything is reconstructed.
    let novel_views = rig.novel_views(&pans, params.step)?;
    if novel_views.is_empty() {
        return Err(Error::InvalidParameter {
            name: "step",
            reason: format!(
                "at {} views no uncaptured angle is left to measure (a synthetic rig's grid \
                 is {:.1} degrees apart, a replay rig's is its recorded views)",
                views.len(),
                params.step.degrees()
            ),
        });
    }
    let masks: Vec<_> = views
        .iter()
        .map(|v| {
            v.mask.clone().ok_or(Error::Rig(
                "an evaluation needs the rig's object masks".into(),
            ))
        })
        .collect::<Result<_>>()?;
    let model = match geometry {
        Geometry::Reconstructed | Geometry::Refined | Geometry::ColumnTest => {
            let coloring = ColoringParams {
                column_test: matches!(geometry, Geometry::ColumnTest).then(ColumnTest::default),
                ..ColoringParams::default()
            };
            let (rec, algorithm) =
                reconstruct_views(views, &masks, &session.volume()?, params.grid, &coloring)?;
            let mut model = rec.model;
            if matches!(geometry, Geometry::Refined) && algorithm == VOXEL_COLORING {
                let walled = TopRefinement {
                    walls: true,
                    ..TopRefinement::default()
                };
                refine_tops(&mut model, &voxel_views(views, &masks), &walled)?;
            }
            model
        }
        Geometry::VisualHull => {
            let grid = VoxelGrid::with_resolution(session.volume()?, params.grid)?;
            visual_hull(&grid, &voxel_views(views, &masks))?
        }
        Geometry::Truth(scene) => {
            let grid = VoxelGrid::with_resolution(session.volume()?, params.grid)?;
            VoxelModel::from_centres(grid, |p| scene.inside(p, 0.0))
        }
    };
    let score = reference.map(|r| geometry_score(&model, &r.exposed, &r.visible));
    let renderer = renderer_with_masks(views, &masks, &model, params.render)?;
    let mut novel = Vec::new();
    for (pan, camera) in novel_views {
        let (truth, mask) = match truths.entry(pan.radians().to_bits()) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => e.insert(rig.truth(pan, &camera)?),
        };
        let view = renderer.render(&camera)?;
        let psnr = metrics::psnr(truth, &view.rgb, Some(mask))?;
        let ssim = metrics::ssim(truth, &view.rgb, Some(mask))?;
        novel.push(NovelView { pan, psnr, ssim });
    }
    novel.sort_by(|a, b| a.pan.radians().total_cmp(&b.pan.radians()));
    // The arc between neighbouring views whose novel views render worst on average.
    let mut worst = (f64::INFINITY, (Angle::ZERO, Angle::ZERO));
    for w in pans.windows(2) {
        let inside: Vec<&NovelView> = novel
            .iter()
            .filter(|v| v.pan.radians() > w[0].radians() && v.pan.radians() < w[1].radians())
            .collect();
        if inside.is_empty() {
            continue;
        }
        let arc = mean_of(&inside, |v| v.psnr);
        if arc < worst.0 {
            worst = (arc, (w[0], w[1]));
        }
    }
    // Over all the novel views: the figures `ViewFigures` gives a subset of them (0 for none).
    let all = ViewFigures::of(&novel.iter().collect::<Vec<_>>());
    Ok(Checkpoint {
        views: views.len(),
        pans,
        evaluated: novel.len(),
        mean_psnr: all.map_or(0.0, |a| a.mean_psnr),
        pooled_psnr: all.map_or(0.0, |a| a.pooled_psnr),
        mean_ssim: all.map_or(0.0, |a| a.mean_ssim),
        worst_arc_psnr: worst.0,
        worst_arc: worst.1,
        novel,
        geometry: score,
        common: None,
        mirrors: renderer.mirror_counts(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arc_of_the_object_splits_the_novel_views_however_the_object_is_turned() {
        let deg = Angle::from_degrees;
        let arc = ObjectArc {
            from: deg(20.0),
            to: deg(160.0),
        };
        for (pan, on) in [
            (20.0, true),
            (90.0, true),
            (160.0, true),
            (19.9, false),
            (-90.0, false),
        ] {
            assert_eq!(arc.contains(deg(pan)), on, "{pan}");
        }
        // Through the full turn: from 150 up to -150 is the 60 degrees behind.
        let behind = ObjectArc {
            from: deg(150.0),
            to: deg(-150.0),
        };
        for (pan, on) in [
            (180.0, true),
            (-170.0, true),
            (150.0, true),
            (0.0, false),
            (140.0, false),
        ] {
            assert_eq!(behind.contains(deg(pan)), on, "{pan}");
        }
        let novel = |pan: f64, psnr: f64| NovelView {
            pan: deg(pan),
            psnr,
            ssim: 0.9,
        };
        let checkpoint = Checkpoint {
            views: 3,
            pans: vec![deg(-100.0), deg(0.0), deg(100.0)],
            evaluated: 4,
            mean_psnr: 25.0,
            pooled_psnr: 25.0,
            mean_ssim: 0.9,
            worst_arc_psnr: 20.0,
            worst_arc: (deg(0.0), deg(100.0)),
            novel: vec![
                novel(-50.0, 30.0),
                novel(10.0, 28.0),
                novel(50.0, 20.0),
                novel(150.0, 22.0),
            ],
            geometry: None,
            common: None,
            mirrors: None,
        };
        // Unturned: the novel views at 50 and 150 lie on the arc, and the captured one at 100.
        let plain = checkpoint.split(&arc, Angle::ZERO);
        assert_eq!(plain.captured_inside, 1);
        let figures = |f: Option<ViewFigures>| f.map(|f| (f.angles, f.mean_psnr));
        assert_eq!(figures(plain.inside), Some((2, 21.0)));
        assert_eq!(figures(plain.outside), Some((2, 29.0)));
        // Turned by 40 degrees, the pans of the object are 40 more: -10, 50, 90, 190 for the
        // novel views, -60, 40, 140 for the captured ones.
        let turned = checkpoint.split(&arc, deg(40.0));
        assert_eq!(turned.captured_inside, 2);
        assert_eq!(figures(turned.inside), Some((2, 24.0)));
        assert_eq!(figures(turned.outside), Some((2, 26.0)));
    }

    /// The grid angles a synthetic rig measures, in whole degrees.
    fn novel_degrees(captured: &[f64], step: f64) -> Result<Vec<i64>> {
        let rig = SimRig::new("lambertian")?;
        let captured: Vec<Angle> = captured.iter().map(|&d| Angle::from_degrees(d)).collect();
        Ok(rig
            .novel_views(&captured, Angle::from_degrees(step))?
            .iter()
            .map(|(p, _)| p.degrees().round() as i64)
            .collect())
    }

    /// A scene turned on the turntable is reconstructed in the scene's own frame and
    /// rendered against its own truth: a frame error would put the model beside the true
    /// surface and every render out of register.
    #[test]
    fn a_turned_scene_is_measured_against_its_own_truth() -> Result<()> {
        let params = EvalParams {
            capture: CaptureParams {
                initial: 8,
                max: 8,
                grid: 24,
                ..CaptureParams::default()
            },
            checkpoints: vec![8],
            grid: 48,
            step: Angle::from_degrees(20.0),
            model: EvalModel::Reconstructed,
            render: RenderParams::default(),
        };
        let measure = |scene: &str| -> Result<Checkpoint> {
            let work = std::env::temp_dir()
                .join(format!("aibr-eval-turned-{}-{scene}", std::process::id()));
            let result = evaluate(scene, &[Strategy::Uniform], &params, &work, &mut |_| {});
            let _ = std::fs::remove_dir_all(&work);
            result?
                .pop()
                .and_then(|mut s| s.checkpoints.pop())
                .ok_or_else(|| Error::InvalidParameter {
                    name: "checkpoints",
                    reason: "none measured".into(),
                })
        };
        let (plain, turned) = (measure("lambertian")?, measure("lambertian@35")?);
        let score = |c: &Checkpoint| {
            c.geometry.ok_or(Error::InvalidParameter {
                name: "geometry",
                reason: "not scored".into(),
            })
        };
        let (p, t) = (score(&plain)?, score(&turned)?);
        // The same object from other angles: a model as close to the truth and renders of
        // the same quality (measured: 1.33 / 78.8% / 18.8 dB unturned, 1.36 / 78.1% / 18.6 dB
        // turned; with the calibration left unturned, 1.90 / 64.9% / 13.9 dB).
        assert!(
            (p.accuracy_voxels - t.accuracy_voxels).abs() < 0.3
                && (p.completeness - t.completeness).abs() < 0.05,
            "{t:?} against {p:?}"
        );
        assert!(
            (plain.mean_psnr - turned.mean_psnr).abs() < 1.0,
            "{} against {}",
            turned.mean_psnr,
            plain.mean_psnr
        );
        Ok(())
    }

    #[test]
    fn bad_parameters_are_named_before_anything_is_captured() {
        let work = std::env::temp_dir().join(format!("aibr-eval-refused-{}", std::process::id()));
        // The parameter `evaluate` names when it refuses `params` for `strategies`.
        let refused_for = |strategies: &[Strategy], params: &EvalParams| match evaluate(
            "lambertian",
            strategies,
            params,
            &work,
            &mut |_| {},
        ) {
            Err(Error::InvalidParameter { name, .. })
            | Err(Error::Render(aibr_render::Error::InvalidParameter { name, .. })) => name,
            other => panic!("{other:?}"),
        };
        let refused = |params: &EvalParams| refused_for(&[Strategy::Uniform], params);
        // Each strategy once, and at least one.
        assert_eq!(refused_for(&[], &EvalParams::default()), "strategies");
        let twice = [Strategy::Uniform, Strategy::Active, Strategy::Uniform];
        assert_eq!(refused_for(&twice, &EvalParams::default()), "strategies");
        // The counts before the checkpoints.
        let counts = |initial: usize, max: usize| EvalParams {
            capture: CaptureParams {
                initial,
                max,
                ..CaptureParams::default()
            },
            checkpoints: vec![initial, max],
            ..EvalParams::default()
        };
        let both = [Strategy::Active, Strategy::Uniform];
        assert_eq!(refused_for(&both, &counts(1, 48)), "initial");
        assert_eq!(refused_for(&both, &counts(12, 8)), "max");
        // Uniform capture alone takes each checkpoint's views evenly: its budget is checked,
        // not the initial count (these pass the counts and are refused by the renderer's
        // parameters, checked next).
        assert_eq!(refused(&counts(12, 2)), "max");
        let mut render = RenderParams::default();
        if let Some(r) = render.refine.as_mut() {
            r.back_voxels = f64::NAN;
        }
        for (initial, max, with_active) in [(12, 8, "max"), (1, 48, "initial")] {
            let params = EvalParams {
                checkpoints: vec![4, max],
                render,
                ..counts(initial, max)
            };
            assert_eq!(refused(&params), "refine.back_voxels");
            assert_eq!(refused_for(&both, &params), with_active);
        }
        // Each set once, in order; and at least one.
        for checkpoints in [vec![12, 24, 24], vec![24, 12], vec![]] {
            let params = EvalParams {
                checkpoints,
                ..EvalParams::default()
            };
            assert_eq!(refused(&params), "checkpoints");
        }
        // Active capture measured at fewer views than its initial ones would measure the
        // first few of those.
        let below_initial = EvalParams {
            checkpoints: vec![7, 48],
            ..EvalParams::default()
        };
        let active = evaluate(
            "lambertian",
            &[Strategy::Uniform, Strategy::Active],
            &below_initial,
            &work,
            &mut |_| {},
        );
        match active {
            Err(Error::InvalidParameter { name, reason }) => {
                assert_eq!(name, "checkpoints");
                assert!(reason.contains("7 is below the initial 12"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        // The renderer's parameters before any view is captured.
        let bad_render = EvalParams {
            render,
            ..EvalParams::default()
        };
        assert_eq!(refused(&bad_render), "refine.back_voxels");
        // A grid of one angle, which the initial views capture.
        let wide_step = EvalParams {
            step: Angle::from_degrees(400.0),
            ..EvalParams::default()
        };
        assert_eq!(refused(&wide_step), "step");
        // Nothing was made for a refused evaluation.
        assert!(!work.exists());
    }

    /// A grid whose every angle was captured leaves nothing to measure: refused, not
    /// reported as figures of no views.
    #[test]
    fn a_checkpoint_with_nothing_left_to_measure_is_refused() -> Result<()> {
        let work = std::env::temp_dir().join(format!("aibr-eval-nothing-{}", std::process::id()));
        let span = SimRig::new("lambertian")?.range().span();
        // Three angles, the range's ends and middle: the three uniform views capture them.
        let params = EvalParams {
            capture: CaptureParams {
                initial: 3,
                max: 3,
                grid: 16,
                ..CaptureParams::default()
            },
            checkpoints: vec![3],
            grid: 16,
            step: span * 0.5,
            ..EvalParams::default()
        };
        let result = evaluate(
            "lambertian",
            &[Strategy::Uniform],
            &params,
            &work,
            &mut |_| {},
        );
        let _ = std::fs::remove_dir_all(&work);
        match result {
            Err(Error::InvalidParameter { name, reason }) => {
                assert_eq!(name, "step");
                assert!(reason.contains("at 3 views"), "{reason}");
            }
            other => panic!("{other:?}"),
        }
        Ok(())
    }

    #[test]
    fn only_grid_angles_next_to_a_capture_count_as_captured() -> Result<()> {
        let range = SimRig::new("lambertian")?.range();
        let (lo, hi) = (range.min().degrees(), range.max().degrees());
        // A 5-degree grid from the range's start; a capture on one of its angles and two
        // between others, 1 and 2 degrees from their nearest grid angle.
        let on = lo + 5.0 * 30.0;
        let grid: Vec<i64> = (0..)
            .map(|k| lo + 5.0 * f64::from(k))
            .take_while(|a| *a <= hi + 1e-9)
            .map(|a| a.round() as i64)
            .collect();
        let novel = novel_degrees(&[on, on + 6.0, on + 12.0], 5.0)?;
        let expected: Vec<i64> = grid
            .iter()
            .copied()
            .filter(|&a| a != on.round() as i64)
            .collect();
        // Half a 5-degree step would also have skipped the grid angles 1 and 2 degrees from
        // the other two captures.
        assert_eq!(novel, expected);
        // On a 1-degree grid, half a step: the grid angle 0.4 degrees from a capture is
        // skipped, the one 0.6 degrees away is not.
        let novel = novel_degrees(&[lo + 10.4], 1.0)?;
        let ten = (lo + 10.0).round() as i64;
        assert!(!novel.contains(&ten) && novel.contains(&(ten + 1)));
        assert_eq!(novel.len(), (hi - lo).round() as usize);
        Ok(())
    }

    #[test]
    fn a_grid_moved_half_a_step_lies_between_the_grid_angles_and_leaves_out_captures_alike()
    -> Result<()> {
        let rig = SimRig::new("lambertian")?;
        let range = rig.range();
        let (lo, hi) = (range.min().degrees(), range.max().degrees());
        let deg = Angle::from_degrees;
        let captured = [deg(lo + 10.4)];
        let plain = rig.novel_views(&captured, deg(1.0))?;
        let unmoved = rig.novel_views_offset(&captured, deg(1.0), Angle::ZERO)?;
        let pans = |views: &[(Angle, Camera)]| -> Vec<f64> {
            views.iter().map(|(p, _)| p.degrees()).collect()
        };
        assert_eq!(pans(&unmoved), pans(&plain));
        // The half degrees: 10.5 lies 0.1 degree from the capture and is left out, 9.5 lies
        // 0.9 from it and is kept, and the grid ends half a degree before the range does.
        let moved = pans(&rig.novel_views_offset(&captured, deg(1.0), deg(0.5))?);
        let off = |pan: f64| pan - lo;
        assert!(
            moved.iter().all(|&p| (off(p).fract() - 0.5).abs() < 1e-6),
            "{moved:?}"
        );
        assert!(!moved.iter().any(|&p| (off(p) - 10.5).abs() < 1e-6));
        assert!(moved.iter().any(|&p| (off(p) - 9.5).abs() < 1e-6));
        assert_eq!(moved.len(), (hi - lo).round() as usize - 1);
        Ok(())
    }
}
