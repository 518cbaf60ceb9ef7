//! `aibr demo`: active against uniform capture on a synthetic scene, as a report folder with
//! an `index.html`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

use aibr::camera::Angle;
use aibr::voxel::{ColoringParams, PlyOptions, write_ply};
use aibr::{
    CaptureParams, Checkpoint, EvalModel, EvalParams, Session, SimRig, Strategy, StrategyEval,
};
use anyhow::{Context, Result, bail};
use image::{Rgb, RgbImage};
use plotters::prelude::*;

/// Options of `aibr demo`.
#[derive(clap::Args)]
pub(crate) struct DemoArgs {
    /// The catalogue scene.
    #[arg(long, default_value = "mirror")]
    scene: String,
    /// The report folder: a new or empty one, or an earlier report (its sessions are kept
    /// and reused by a rerun). A folder holding other files is refused, since the report's
    /// would overwrite them.
    #[arg(long, default_value = "aibr-demo")]
    out: PathBuf,
    /// A smaller run (6 -> 12 views, coarse grids) that finishes in seconds: for tests.
    #[arg(long)]
    quick: bool,
    #[command(flatten)]
    refine: crate::RefineArgs,
}

struct Setup {
    params: EvalParams,
    model_grid: usize,
}

fn setup(quick: bool) -> Setup {
    if quick {
        Setup {
            params: EvalParams {
                capture: CaptureParams {
                    initial: 6,
                    max: 12,
                    grid: 40,
                    ..CaptureParams::default()
                },
                checkpoints: vec![6, 9, 12],
                grid: 48,
                step: Angle::from_degrees(8.0),
                model: EvalModel::Reconstructed,
                ..EvalParams::default()
            },
            model_grid: 48,
        }
    } else {
        Setup {
            params: EvalParams {
                capture: CaptureParams::default(),
                checkpoints: vec![12, 24, 36, 48],
                grid: 96,
                step: Angle::from_degrees(5.0),
                model: EvalModel::Reconstructed,
                ..EvalParams::default()
            },
            model_grid: 96,
        }
    }
}

fn svg_error(e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("drawing a plot: {e}")
}

/// Draws a chart's series labels at `position`, on white in a black frame.
fn legend<'a, DB: DrawingBackend + 'a, CT: plotters::coord::CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE)
        .border_style(BLACK)
        .draw()
        .map_err(svg_error)
}

const ACTIVE: RGBColor = RGBColor(214, 39, 40);
const UNIFORM: RGBColor = RGBColor(31, 119, 180);

fn colour(s: Strategy) -> RGBColor {
    match s {
        Strategy::Active => ACTIVE,
        Strategy::Uniform => UNIFORM,
    }
}

/// Capture positions of both strategies at the budget, on two circles (the paper's figure 7).
fn polar_plot(results: &[StrategyEval], range: (f64, f64)) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (520, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(svg_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "capture positions (pan angle; outer: active, inner: uniform)",
                ("sans-serif", 15),
            )
            .margin(10)
            .build_cartesian_2d(-1.25f64..1.25f64, -1.25f64..1.25f64)
            .map_err(svg_error)?;
        // The usable pan range, and every 30 degrees.
        let arc: Vec<(f64, f64)> = (0..=200)
            .map(|k| {
                let a = range.0 + (range.1 - range.0) * k as f64 / 200.0;
                (a.to_radians().cos() * 1.12, a.to_radians().sin() * 1.12)
            })
            .collect();
        chart
            .draw_series(LineSeries::new(arc, BLACK.mix(0.4)))
            .map_err(svg_error)?;
        for deg in (-150..=180).step_by(30) {
            let a = (deg as f64).to_radians();
            chart
                .draw_series(std::iter::once(Text::new(
                    format!("{deg}°"),
                    (a.cos() * 1.19 - 0.05, a.sin() * 1.19 + 0.03),
                    ("sans-serif", 11),
                )))
                .map_err(svg_error)?;
        }
        for r in results {
            let Some(last) = r.checkpoints.last() else {
                continue;
            };
            let radius = match r.strategy {
                Strategy::Active => 1.0,
                Strategy::Uniform => 0.8,
            };
            let c = colour(r.strategy);
            chart
                .draw_series(last.pans.iter().map(|p| {
                    let a = p.radians();
                    Circle::new((a.cos() * radius, a.sin() * radius), 4, c.filled())
                }))
                .map_err(svg_error)?
                .label(format!("{} ({} views)", r.strategy.name(), last.views))
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, c.filled()));
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        root.present().map_err(svg_error)?;
    }
    Ok(svg)
}

/// Mean, pooled and worst-arc masked PSNR against the number of views.
fn psnr_plot(results: &[StrategyEval]) -> Result<String> {
    let all: Vec<&Checkpoint> = results.iter().flat_map(|r| &r.checkpoints).collect();
    let lo = all
        .iter()
        .map(|c| c.worst_arc_psnr.min(c.pooled_psnr))
        .fold(f64::INFINITY, f64::min);
    let hi = all
        .iter()
        .map(|c| c.mean_psnr)
        .fold(f64::NEG_INFINITY, f64::max);
    let (x0, x1) = all.iter().fold((usize::MAX, 0), |(a, b), c| {
        (a.min(c.views), b.max(c.views))
    });
    if all.is_empty() || !lo.is_finite() || !hi.is_finite() {
        bail!("no checkpoints to plot");
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(svg_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("masked PSNR of novel views", ("sans-serif", 16))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(
                (x0 as f64 - 1.0)..(x1 as f64 + 1.0),
                (lo.floor() - 1.0)..(hi.ceil() + 1.0),
            )
            .map_err(svg_error)?;
        chart
            .configure_mesh()
            .x_desc("views")
            .y_desc("PSNR (dB)")
            .draw()
            .map_err(svg_error)?;
        for r in results {
            let c = colour(r.strategy);
            let series = |f: fn(&Checkpoint) -> f64| -> Vec<(f64, f64)> {
                r.checkpoints
                    .iter()
                    .map(|k| (k.views as f64, f(k)))
                    .collect()
            };
            let mean = series(|k| k.mean_psnr);
            chart
                .draw_series(LineSeries::new(mean.clone(), c.stroke_width(2)))
                .map_err(svg_error)?
                .label(format!("{}: mean", r.strategy.name()))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2))
                });
            chart
                .draw_series(mean.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(svg_error)?;
            chart
                .draw_series(DashedLineSeries::new(
                    series(|k| k.pooled_psnr),
                    2,
                    3,
                    c.stroke_width(2),
                ))
                .map_err(svg_error)?
                .label(format!("{}: pooled", r.strategy.name()))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 4, y)], c.stroke_width(2))
                });
            chart
                .draw_series(DashedLineSeries::new(
                    series(|k| k.worst_arc_psnr),
                    5,
                    4,
                    c.stroke_width(1),
                ))
                .map_err(svg_error)?
                .label(format!("{}: worst arc", r.strategy.name()))
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c));
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)?;
        root.present().map_err(svg_error)?;
    }
    Ok(svg)
}

/// Masked PSNR of every novel view against its pan angle at the last checkpoint, with each
/// strategy's capture positions as ticks along the bottom: where a strategy's views went and
/// what they bought there.
fn angle_plot(results: &[StrategyEval], range: (f64, f64)) -> Result<String> {
    let last: Vec<(Strategy, &Checkpoint)> = results
        .iter()
        .filter_map(|r| r.checkpoints.last().map(|c| (r.strategy, c)))
        .collect();
    let values = last
        .iter()
        .flat_map(|(_, c)| c.novel.iter().map(|v| v.psnr));
    let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        bail!("no novel views to plot");
    }
    let views = last.iter().map(|(_, c)| c.views).max().unwrap_or(0);
    let (y0, y1) = (lo.floor() - 2.0, hi.ceil() + 1.0);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (760, 420)).into_drawing_area();
        root.fill(&WHITE).map_err(svg_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("masked PSNR of each novel view, {views} views"),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(48)
            .build_cartesian_2d(range.0..range.1, y0..y1)
            .map_err(svg_error)?;
        chart
            .configure_mesh()
            .x_desc("pan angle (degrees)")
            .y_desc("PSNR (dB)")
            .draw()
            .map_err(svg_error)?;
        for (k, (strategy, c)) in last.iter().enumerate() {
            let colour = colour(*strategy);
            let line: Vec<(f64, f64)> = c.novel.iter().map(|v| (v.pan.degrees(), v.psnr)).collect();
            chart
                .draw_series(LineSeries::new(line, colour.stroke_width(2)))
                .map_err(svg_error)?
                .label(format!("{} ({} views)", strategy.name(), c.views))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2))
                });
            // Capture positions: one row of ticks per strategy along the bottom.
            let base = y0 + 0.5 + 0.8 * k as f64;
            chart
                .draw_series(c.pans.iter().map(|p| {
                    PathElement::new(
                        vec![(p.degrees(), base), (p.degrees(), base + 0.6)],
                        colour.stroke_width(2),
                    )
                }))
                .map_err(svg_error)?;
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(svg_error)?;
    }
    Ok(svg)
}

/// The per-pair consistency scores of a session (what the active planner ranked).
fn scores_plot(pans: &[Angle], scores: &[aibr::consistency::PairScore]) -> Result<String> {
    let bars: Vec<(f64, f64, f64)> = scores
        .iter()
        .filter_map(|s| {
            let (a, b) = (pans.get(s.a)?.degrees(), pans.get(s.b)?.degrees());
            Some((a.min(b), a.max(b), s.score))
        })
        .collect();
    let top = bars.iter().map(|b| b.2).fold(1.0, f64::max);
    let (x0, x1) = bars
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), b| {
            (l.min(b.0), h.max(b.1))
        });
    if bars.is_empty() {
        bail!("no pair scores to plot");
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 320)).into_drawing_area();
        root.fill(&WHITE).map_err(svg_error)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "consistency score per arc between neighbouring views (active, final)",
                ("sans-serif", 15),
            )
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, 0.0..top * 1.05)
            .map_err(svg_error)?;
        chart
            .configure_mesh()
            .x_desc("pan angle (degrees)")
            .y_desc("score (pixels)")
            .draw()
            .map_err(svg_error)?;
        chart
            .draw_series(
                bars.iter()
                    .map(|&(a, b, s)| Rectangle::new([(a, 0.0), (b, s)], ACTIVE.mix(0.6).filled())),
            )
            .map_err(svg_error)?;
        root.present().map_err(svg_error)?;
    }
    Ok(svg)
}

/// |a - b| averaged over the channels, times 4, as a dark-to-bright heat image.
fn error_map(a: &RgbImage, b: &RgbImage) -> RgbImage {
    RgbImage::from_fn(a.width(), a.height(), |x, y| {
        let (p, q) = (a.get_pixel(x, y).0, b.get_pixel(x, y).0);
        let e = (0..3)
            .map(|c| (p[c] as i32 - q[c] as i32).abs())
            .sum::<i32>()
            / 3;
        let v = (e * 4).min(255) as u8;
        Rgb([v, (v as u16 * 3 / 4) as u8, v / 4])
    })
}

fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    aibr::write_atomic(path, bytes).with_context(|| format!("writing {}", path.display()))
}

fn png(path: &Path, img: &RgbImage) -> Result<()> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)?;
    write(path, &out.into_inner())
}

/// The start of the report page's title, by which a folder is known as a demo report.
const TITLE: &str = "<title>aibr demo: ";

/// Refuses a report folder that holds anything but an earlier report: the report's files
/// (`index.html`, `model.ply`, the plots and renders) would overwrite files of the same names.
/// A folder is an earlier report, finished or not, when it holds the demo's `sessions` folder
/// or an `index.html` the demo wrote.
fn check_out(out: &Path) -> Result<()> {
    let mut entries = match std::fs::read_dir(out) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        other => other.with_context(|| format!("reading --out {}", out.display()))?,
    };
    let Some(first) = entries.next() else {
        return Ok(());
    };
    let first = first.with_context(|| format!("reading --out {}", out.display()))?;
    if out.join("sessions").is_dir() {
        return Ok(());
    }
    let index = out.join("index.html");
    if index.is_file() {
        let page = std::fs::read(&index).with_context(|| format!("reading {}", index.display()))?;
        if page.windows(TITLE.len()).any(|w| w == TITLE.as_bytes()) {
            return Ok(());
        }
    }
    bail!(
        "--out {} is not empty ({} is there) and is not an aibr demo report, whose files would \
         overwrite it: choose a new or empty folder",
        out.display(),
        first.file_name().to_string_lossy()
    )
}

/// What the active capture decided about serving faces first, and from what contrast, for
/// the report page (HTML).
fn describe_faces_first(results: &[StrategyEval]) -> String {
    let Some((served, contrast)) = results
        .iter()
        .find_map(|r| Some((r.served_faces_first?, r.initial_contrast)))
    else {
        return String::new();
    };
    let contrast = contrast.map_or(String::new(), |c| {
        format!(
            ": the worst arc scored {c:.2} times the median one, against the {} that decides",
            aibr::consistency::VIEW_DEPENDENT_CONTRAST
        )
    });
    let (surface, plan) = if served {
        (
            "a view-dependent surface (one arc scoring far worse than the rest, as a mirror's do",
            "first put a view in the plane of every flat face of the model",
        )
    } else {
        (
            "no view-dependent surface (no arc scoring far worse than the rest",
            "split arcs by rank alone, aiming at the model's flat faces only near an arc's middle",
        )
    };
    format!(
        " The initial views showed {surface}{contrast}), so active {plan} \
         (<code>--faces-first auto</code>)."
    )
}

/// One sentence for the report page (HTML) saying how `params` render the novel views.
fn describe_renderer(params: &aibr::render::RenderParams) -> String {
    let depth = match params.refine {
        Some(r) => {
            let penalty = if r.penalty > 0.0 {
                format!(", penalised by {} a voxel beyond 4", r.penalty)
            } else {
                String::new()
            };
            let pair = if r.bracketing {
                "the nearest source with the nearest across the novel view"
            } else {
                "the two nearest sources"
            };
            format!(
                "with each pixel's depth refined by photo-consistency up to {} voxels behind \
                 the model's surface in {} depths{penalty}, comparing {pair}",
                r.back_voxels, r.steps
            )
        }
        None => "at the model's surface".to_owned(),
    };
    let mirrors = if params.reflections.is_some() {
        "as reflections (<code>--reflections on</code>)"
    } else {
        "in the colours the model holds (<code>--reflections off</code>)"
    };
    let defaults = if *params == aibr::render::RenderParams::default() {
        " These are the renderer's defaults."
    } else {
        ""
    };
    format!("The novel views are rendered {depth}, and mirrors {mirrors}.{defaults}")
}

/// Runs the demo and writes the report; returns the path of `index.html`.
pub(crate) fn run(a: DemoArgs) -> Result<PathBuf> {
    let start = Instant::now();
    check_out(&a.out)?;
    let rig = SimRig::new(&a.scene).with_context(|| format!("--scene {:?}", a.scene))?;
    let Setup {
        mut params,
        model_grid,
    } = setup(a.quick);
    params.render = a.refine.render_params();
    let sessions = a.out.join("sessions");
    std::fs::create_dir_all(&sessions)
        .with_context(|| format!("creating {}", sessions.display()))?;
    let strategies = [Strategy::Active, Strategy::Uniform];
    let mut reporter = crate::reporter::Reporter::new(indicatif::ProgressBar::new_spinner());
    let results = aibr::evaluate(&a.scene, &strategies, &params, &sessions, &mut |m| {
        reporter.message(m);
        reporter.bar().tick();
    })?;
    reporter.message("writing the report".into());

    let range = aibr::Turntable::range(&rig);
    let range_deg = (range.min().degrees(), range.max().degrees());
    write(
        &a.out.join("positions.svg"),
        polar_plot(&results, range_deg)?.as_bytes(),
    )?;
    write(&a.out.join("psnr.svg"), psnr_plot(&results)?.as_bytes())?;
    write(
        &a.out.join("angles.svg"),
        angle_plot(&results, range_deg)?.as_bytes(),
    )?;

    // The final sessions: the active one, and the uniform one of the same size.
    let max = params.capture.max;
    let active = Session::open(&sessions.join(format!("{}-active", a.scene)))?;
    let uniform = Session::open(&sessions.join(format!("{}-uniform-{max}", a.scene)))?;
    // Each session decoded once, for its scores, its model and its renders.
    let active_views = active.load_views()?;
    let uniform_views = uniform.load_views()?;
    let (pans, scores) = aibr::pair_scores(&active, &active_views, params.capture.grid)?;
    write(
        &a.out.join("scores.svg"),
        scores_plot(&pans, &scores)?.as_bytes(),
    )?;

    let coloring = ColoringParams::default();
    let (active_model, _) =
        aibr::reconstruct_loaded(&active, &active_views, model_grid, &coloring)?;
    let (uniform_model, _) =
        aibr::reconstruct_loaded(&uniform, &uniform_views, model_grid, &coloring)?;
    let mut ply = Vec::new();
    write_ply(
        &active_model.model,
        &mut ply,
        &PlyOptions {
            cubes: false,
            binary: true,
        },
    )?;
    write(&a.out.join("model.ply"), &ply)?;

    // Renders at the middle of the active capture's worst arc and of the uniform one's.
    let calibration = rig.calibration()?;
    let mut renders = Vec::new();
    for r in &results {
        let Some(last) = r.checkpoints.last() else {
            continue;
        };
        let mid =
            Angle::from_radians(0.5 * (last.worst_arc.0.radians() + last.worst_arc.1.radians()));
        let label = format!("middle of the {} capture's worst arc", r.strategy.name());
        renders.push((mid, label));
    }
    let renderers = [
        (
            "active",
            aibr::renderer_with(&active_views, &active_model.model, params.render)?,
        ),
        (
            "uniform",
            aibr::renderer_with(&uniform_views, &uniform_model.model, params.render)?,
        ),
    ];
    let mut panels = String::new();
    for (k, (pan, label)) in renders.iter().enumerate() {
        let camera = calibration.camera_at(*pan);
        let truth = rig
            .scene()
            .render(&camera, &aibr::scene::RenderOptions::default())?
            .rgb8();
        png(&a.out.join(format!("truth-{k}.png")), &truth)?;
        write!(
            panels,
            "<h3>{:.1}° ({label})</h3>\n<div class=\"row\"><figure><img src=\"truth-{k}.png\" alt=\"ground truth\"><figcaption>ground truth</figcaption></figure>\n",
            pan.degrees()
        )?;
        for (name, renderer) in &renderers {
            let view = renderer.render(&camera)?;
            png(&a.out.join(format!("{name}-{k}.png")), &view.rgb)?;
            png(
                &a.out.join(format!("{name}-{k}-error.png")),
                &error_map(&truth, &view.rgb),
            )?;
            write!(
                panels,
                "<figure><img src=\"{name}-{k}.png\" alt=\"{name} render\"><figcaption>{name} ({max} views)</figcaption></figure>\n<figure><img src=\"{name}-{k}-error.png\" alt=\"{name} error\"><figcaption>{name}: |error| x4</figcaption></figure>\n"
            )?;
        }
        panels.push_str("</div>\n");
    }

    let mut table = String::from(
        "<table><tr><th>strategy</th><th>views</th><th>mean PSNR (dB)</th><th>pooled PSNR (dB)</th><th>mean SSIM</th><th>worst arc (dB)</th><th>worst arc (degrees)</th><th>model accuracy (voxels)</th><th>model completeness</th><th>mean PSNR at the angles neither captured (dB)</th></tr>\n",
    );
    for r in &results {
        for c in &r.checkpoints {
            let (accuracy, completeness) = c.geometry.map_or(("-".into(), "-".into()), |g| {
                (
                    format!("{:.2}", g.accuracy_voxels),
                    format!("{:.1}%", 100.0 * g.completeness),
                )
            });
            let common = c.common.map_or("-".into(), |k| {
                format!("{:.2} ({} angles)", k.mean_psnr, k.angles)
            });
            writeln!(
                table,
                "<tr><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{:.3}</td><td>{:.2}</td><td>{:.1} to {:.1}</td><td>{accuracy}</td><td>{completeness}</td><td>{common}</td></tr>",
                r.strategy.name(),
                c.views,
                c.mean_psnr,
                c.pooled_psnr,
                c.mean_ssim,
                c.worst_arc_psnr,
                c.worst_arc.0.degrees(),
                c.worst_arc.1.degrees()
            )?;
        }
    }
    table.push_str("</table>\n");
    let elapsed = start.elapsed().as_secs_f64();
    let html = format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">{TITLE}{scene}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}} .row{{display:flex;flex-wrap:wrap;gap:8px}} figure{{margin:0}} img{{max-width:200px}} .plots img{{max-width:100%}} table{{border-collapse:collapse}} td,th{{border:1px solid #aaa;padding:3px 8px;text-align:right}}</style></head>
<body>
<h1>Active against uniform capture: <code>{scene}</code></h1>
<p>{initial} uniform views first, then one view at a time up to {max}: <b>active</b> splits the
arc the consistency estimate ranks worst, <b>uniform</b> spreads every view evenly.{faces} Each
checkpoint renders every uncaptured pan angle (every {step:.0}°) from a {grid}<sup>3</sup> model
and compares it with the ground truth inside the object mask (a coarse grid, to keep the demo
short: <code>aibr eval --rig sim:{scene}</code> measures every degree, and its means differ by
a few tenths of a decibel). <i>Mean PSNR</i> averages the
novel views' PSNRs; <i>pooled PSNR</i> is the PSNR of their mean squared error, where the views
that render worst (on a mirror, say) weigh the most. <i>Model accuracy</i> is the distance
within which 90% of the model's surface voxels lie from the true surface, <i>completeness</i>
the share of the visible true surface within 1.5 voxels of the model: renders follow the
geometry, and which views are taken changes it. {renderer} Made by <code>aibr demo</code>
in {elapsed:.0} s.</p>
<p>One run measures one placement of the object on the turntable, and on <code>mirror</code>
that alone can favour either strategy by a decibel at 24 and 36 views: <code>aibr eval --rig
sim:{scene} --turns 0:27.5:2.5 --arc 20:160</code> measures
twelve placements and the mirror's side apart (the project's figures: <code>docs/results.md</code>,
"Session 24").</p>
<h2>Results</h2>
{table}
<div class="plots"><h2>Capture positions</h2><img src="positions.svg" alt="capture positions">
<h2>PSNR against views</h2><img src="psnr.svg" alt="PSNR against views">
<h2>PSNR against pan angle</h2><p>Every novel view at the budget; the ticks along the bottom
are each strategy's capture positions.</p><img src="angles.svg" alt="PSNR against pan angle">
<h2>Consistency scores</h2><img src="scores.svg" alt="consistency scores per pair"></div>
<h2>Novel views</h2>
{panels}
<h2>Files</h2>
<ul><li><a href="model.ply">model.ply</a>: the active session's voxel model ({max} views)</li>
<li><a href="sessions/{scene}-active/session.json">the active session</a></li>
<li><a href="sessions/{scene}-uniform-{max}/session.json">the uniform session</a></li></ul>
<script>
// Marks whether every image loaded (read by the report's browser test).
window.addEventListener('load', () => {{
  const imgs = [...document.images];
  const ok = imgs.filter(i => i.complete && i.naturalWidth > 0).length;
  document.body.dataset.images = ok + '/' + imgs.length;
}});
</script>
</body></html>
"#,
        scene = a.scene,
        faces = describe_faces_first(&results),
        initial = params.capture.initial,
        step = params.step.degrees(),
        grid = params.grid,
        renderer = describe_renderer(&params.render),
    );
    let index = a.out.join("index.html");
    write(&index, html.as_bytes())?;
    reporter.finish();

    crate::print_eval_table(&results, None);
    println!("report: {} ({elapsed:.0} s)", index.display());
    Ok(index)
}
