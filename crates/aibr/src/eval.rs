//! Active against uniform, measured against ground truth on a synthetic rig.

use std::path::Path;

use aibr_camera::Angle;
use aibr_render::{RenderParams, Renderer, SourceView, metrics};
use aibr_scene::RenderOptions;
use aibr_voxel::Criterion;

use crate::capture::{CaptureParams, Strategy, capture, reconstruct_views};
use crate::error::{Error, Result};
use crate::rig::{SimRig, Turntable};
use crate::session::{LoadedView, Session};

/// Parameters of [`evaluate`].
#[derive(Debug, Clone, PartialEq)]
pub struct EvalParams {
    /// The capture: initial views, budget, refinement, capture grid.
    pub capture: CaptureParams,
    /// View counts at which to measure (each at most the budget), e.g. 12, 24, 36, 48.
    pub checkpoints: Vec<usize>,
    /// Voxels along the longest edge of the models the novel views are rendered from.
    pub grid: usize,
    /// Spacing of the evaluated pan angles (1 degree by default); angles within half a step
    /// of a captured view are skipped (they were captured).
    pub step: Angle,
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
    /// Mean masked SSIM.
    pub mean_ssim: f64,
    /// The worst arc between neighbouring views: its mean masked PSNR, dB.
    pub worst_arc_psnr: f64,
    /// And the arc, as its end angles.
    pub worst_arc: (Angle, Angle),
}

/// One strategy's checkpoints.
#[derive(Debug, Clone, PartialEq)]
pub struct StrategyEval {
    /// The strategy.
    pub strategy: Strategy,
    /// One per checkpoint, in order.
    pub checkpoints: Vec<Checkpoint>,
}

/// Runs each strategy on the synthetic rig `scene` (sessions under `work_dir`), and at every
/// checkpoint renders every pan angle on the evaluation grid that was not captured, from the
/// first views of the active session (or a uniform set of that size), and compares it with
/// the ground truth inside the object mask.
pub fn evaluate(
    scene: &str,
    strategies: &[Strategy],
    params: &EvalParams,
    work_dir: &Path,
    progress: &mut dyn FnMut(String),
) -> Result<Vec<StrategyEval>> {
    if params
        .checkpoints
        .iter()
        .any(|&c| c > params.capture.max || c < 3)
    {
        return Err(Error::InvalidParameter {
            name: "checkpoints",
            reason: format!(
                "each must be between 3 and the budget {}",
                params.capture.max
            ),
        });
    }
    if !(params.step.radians() > 0.0) {
        return Err(Error::InvalidParameter {
            name: "step",
            reason: "the evaluation step must be positive".into(),
        });
    }
    let mut out = Vec::new();
    for &strategy in strategies {
        let mut checkpoints = Vec::new();
        let mut active: Option<Session> = None;
        for &n in &params.checkpoints {
            // The active views at n are the first n of one run; a uniform set is its own run.
            let session = match strategy {
                Strategy::Active => {
                    if active.is_none() {
                        let dir = work_dir.join(format!("{scene}-active"));
                        active = Some(run(
                            scene,
                            &dir,
                            &CaptureParams {
                                strategy,
                                ..params.capture
                            },
                            progress,
                        )?);
                    }
                    active
                        .clone()
                        .ok_or(Error::Rig("no active session".into()))?
                }
                Strategy::Uniform => {
                    let dir = work_dir.join(format!("{scene}-uniform-{n}"));
                    let p = CaptureParams {
                        strategy,
                        max: n,
                        initial: n.min(params.capture.initial).max(3),
                        ..params.capture
                    };
                    run(scene, &dir, &p, progress)?
                }
            };
            let views: Vec<LoadedView> = session.load_views()?.into_iter().take(n).collect();
            progress(format!(
                "{} {n} views: rendering novel views",
                strategy.name()
            ));
            checkpoints.push(measure(scene, &views, &session, params)?);
        }
        out.push(StrategyEval {
            strategy,
            checkpoints,
        });
    }
    Ok(out)
}

fn run(
    scene: &str,
    dir: &Path,
    params: &CaptureParams,
    progress: &mut dyn FnMut(String),
) -> Result<Session> {
    let mut rig = SimRig::new(scene)?;
    let calibration = rig.calibration()?;
    let mut session = if dir.join("session.json").exists() {
        Session::open(dir)?
    } else {
        crate::new_session(dir, &format!("sim:{scene}"), &rig, &calibration, params)?
    };
    let name = params.strategy.name();
    capture(&mut rig, &mut session, params, &mut |p| {
        if let crate::Progress::Captured { count, budget, .. } = p {
            progress(format!("{name}: {count}/{budget} views"));
        }
    })?;
    Ok(session)
}

fn measure(
    scene_name: &str,
    views: &[LoadedView],
    session: &Session,
    params: &EvalParams,
) -> Result<Checkpoint> {
    let rig = SimRig::new(scene_name)?;
    let scene = rig.scene();
    let masks: Vec<_> = views
        .iter()
        .map(|v| {
            v.mask
                .clone()
                .ok_or(Error::Rig("the synthetic rig gives masks".into()))
        })
        .collect::<Result<_>>()?;
    let (rec, _) = reconstruct_views(
        views,
        &masks,
        &session.volume()?,
        params.grid,
        Criterion::default(),
    )?;
    let sources = views
        .iter()
        .map(|v| SourceView {
            camera: v.camera.clone(),
            image: v.image.clone(),
        })
        .collect();
    let renderer = Renderer::new(&rec.model, sources, RenderParams::default())?;
    let mut pans: Vec<Angle> = views
        .iter()
        .map(|v| Angle::from_radians(v.record.pan_rad))
        .collect();
    pans.sort_by(|a, b| a.radians().total_cmp(&b.radians()));
    let range = rig.range();
    let step = params.step.radians();
    let calibration = rig.calibration()?;
    // Per arc between neighbouring views: the PSNR of its novel views.
    let mut arcs: Vec<Vec<f64>> = vec![Vec::new(); pans.len().saturating_sub(1)];
    let (mut psnr_sum, mut ssim_sum, mut n) = (0.0, 0.0, 0usize);
    let mut a = range.min().radians();
    while a <= range.max().radians() + 1e-9 {
        let pan = Angle::from_radians(a);
        a += step;
        if pans
            .iter()
            .any(|p| (p.radians() - pan.radians()).abs() < 0.5 * step)
        {
            continue;
        }
        let camera = calibration.camera_at(pan);
        let truth = scene.render(&camera, &RenderOptions::default())?;
        let truth8 = truth.rgb8();
        let view = renderer.render(&camera)?;
        let psnr = metrics::psnr(&truth8, &view.rgb, Some(&truth.mask))?;
        let ssim = metrics::ssim(&truth8, &view.rgb, Some(&truth.mask))?;
        psnr_sum += psnr;
        ssim_sum += ssim;
        n += 1;
        if let Some(i) = pans
            .windows(2)
            .position(|w| pan.radians() > w[0].radians() && pan.radians() < w[1].radians())
        {
            arcs[i].push(psnr);
        }
    }
    let mut worst = (f64::INFINITY, (Angle::ZERO, Angle::ZERO));
    for (i, values) in arcs.iter().enumerate() {
        if values.is_empty() {
            continue;
        }
        let mean = values.iter().sum::<f64>() / values.len() as f64;
        if mean < worst.0 {
            worst = (mean, (pans[i], pans[i + 1]));
        }
    }
    Ok(Checkpoint {
        views: views.len(),
        pans,
        evaluated: n,
        mean_psnr: psnr_sum / n.max(1) as f64,
        mean_ssim: ssim_sum / n.max(1) as f64,
        worst_arc_psnr: worst.0,
        worst_arc: worst.1,
    })
}
