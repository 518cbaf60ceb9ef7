//! `aibr`: capture, reconstruct and render turntable sessions.

use std::path::{Path, PathBuf};

use aibr::camera::Angle;
use aibr::voxel::{ColoringParams, ColumnTest, Criterion, PlyOptions, TopRefinement, write_ply};
use aibr::{CaptureParams, EvalModel, Progress, Session, SimRig, Strategy, write_atomic};
use anyhow::{Context, Result, bail};

mod calibrate;
mod demo;
mod reporter;
use clap::{ArgMatches, CommandFactory, FromArgMatches, Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};

/// Active image-based rendering on a turntable.
///
/// A camera looks at an object turning on a pan unit. `aibr capture` takes a few uniform
/// views, reconstructs the object, estimates where a rendering would be worst, turns the
/// object there, captures one more view, and repeats until the budget. The built-in
/// synthetic rig (`--rig sim:SCENE`) needs no hardware.
#[derive(clap::Parser)]
#[command(name = "aibr", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job: active against uniform capture on the synthetic mirror, written as a
    /// report folder (plots, renders beside the truth, error maps, pair scores, the model,
    /// index.html); prints a short table and the report's path.
    Demo(demo::DemoArgs),
    /// Capture a session: initial uniform views, then one view at a time where the rendering
    /// is estimated worst (or uniformly, as the baseline).
    Capture(CaptureArgs),
    /// Reconstruct a session's voxel model and write it as model.ply into the session.
    Reconstruct(ReconstructArgs),
    /// Render novel views of a session: one pan angle, or a sweep of them into a folder.
    Render(RenderArgs),
    /// Active against uniform capture, measured against ground truth: at each checkpoint,
    /// every uncaptured pan angle on a fine grid is rendered and compared with the truth
    /// inside the object mask (masked PSNR and SSIM, mean and worst arc; and the PSNR of the
    /// views' pooled squared error, which weighs the worst renders most).
    Eval(EvalArgs),
    /// Drive a PTU-46 pan-tilt unit on a serial port, or emulate one on a pseudo-terminal.
    Ptu(PtuArgs),
    /// Webcams (V4L2; needs a build with the v4l feature).
    V4l {
        #[command(subcommand)]
        command: V4lCommand,
    },
    /// Calibrate the camera (intrinsics, distortion) and the turntable (the camera's motion
    /// about the pan axis) from checkerboard images.
    Calibrate {
        #[command(subcommand)]
        command: calibrate::CalibrateCommand,
    },
    /// Synthetic scenes.
    Scene {
        #[command(subcommand)]
        command: SceneCommand,
    },
}

#[derive(clap::Args)]
struct CaptureArgs {
    /// The rig: sim:SCENE (mirror, mirror-broad, head, chair or lambertian) is the built-in
    /// synthetic rig; sim:SCENE@DEGREES stands the scene turned that far on its turntable
    /// (-180 to 180).
    #[arg(long, default_value = "sim:mirror", conflicts_with = "turntable")]
    rig: String,
    /// A real turntable instead of the synthetic rig's: ptu:PATH is a PTU-46 on serial
    /// device PATH (needs --camera).
    #[arg(long, value_name = "ptu:PATH", requires = "camera")]
    turntable: Option<String>,
    /// The camera that looks at the turntable: sim:SCENE renders a synthetic scene at the
    /// angle the turntable reports; v4l:DEVICE is a webcam (needs --calibration, and a build
    /// with the v4l feature).
    #[arg(long, value_name = "sim:SCENE|v4l:DEVICE", requires = "turntable")]
    camera: Option<String>,
    /// The rig's calibration for a webcam (--camera v4l:DEVICE): JSON in the form of
    /// session.json's "calibration" record (intrinsics, distortion, size, pan axis, pose at
    /// pan 0), as `aibr calibrate turntable` writes it.
    #[arg(long, value_name = "FILE", requires = "camera")]
    calibration: Option<PathBuf>,
    /// Webcam: fresh frames averaged per view (after the turntable stopped).
    #[arg(long, default_value_t = 1, value_name = "K", requires = "camera")]
    average: u32,
    /// Webcam exposure: lock (turn automatic exposure off at the current value), auto, or a
    /// value in the device's units (100 µs for exposure_absolute).
    #[arg(long, default_value = "lock", requires = "camera")]
    exposure: String,
    /// Webcam white balance: lock, auto, or a temperature in kelvin.
    #[arg(long, default_value = "lock", requires = "camera")]
    white_balance: String,
    /// Webcam gain: lock, auto, or a value.
    #[arg(long, default_value = "lock", requires = "camera")]
    gain: String,
    /// The PTU-46's serial speed (with --turntable).
    #[arg(long, default_value_t = 9600, requires = "turntable")]
    baud: u32,
    /// Views captured uniformly over the pan range first (active capture).
    #[arg(long, default_value_t = 12)]
    initial: usize,
    /// The budget of views (uniform capture takes them all evenly over the pan range).
    #[arg(long, default_value_t = 48)]
    max: usize,
    /// How views beyond the initial ones are chosen.
    #[arg(long, value_enum, default_value_t = StrategyArg::Active)]
    strategy: StrategyArg,
    /// Reconstruct again every K captures (1: before every planned view).
    #[arg(long, default_value_t = 1, value_name = "K")]
    refine_every: usize,
    /// Voxels along the longest edge of the reconstruction volume, while capturing.
    #[arg(long, default_value_t = 96)]
    grid: usize,
    /// Stop before the budget once every arc between neighbouring views scores at or below
    /// this (the summed per-pixel inconsistency of the pair, in pixels); 0 stops only at the
    /// budget.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "SCORE",
        allow_hyphen_values = true
    )]
    consistent_below: f64,
    #[command(flatten)]
    plan: PlanArgs,
    /// The reconstruction volume: `scene` (the synthetic scene's true box), `auto` (estimated
    /// from the foreground of the initial views: the intersection of their viewing cones,
    /// with a margin), or a box `x0,y0,z0,x1,y1,z1` in metres in the turntable frame.
    #[arg(long, default_value = "scene", allow_hyphen_values = true)]
    volume: String,
    /// The session folder to create (or, with --resume, to continue).
    #[arg(long, value_name = "SESSION")]
    out: PathBuf,
    /// Continue the session in --out where it stopped.
    #[arg(long)]
    resume: bool,
    /// Print a machine-readable summary on standard output.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct PtuArgs {
    /// The unit's serial device (for example /dev/ttyUSB0, or the path `aibr ptu emulate`
    /// prints).
    #[arg(long, global = true, value_name = "PATH")]
    port: Option<String>,
    /// The serial speed (the PTU-46 default is 9600).
    #[arg(long, global = true, default_value_t = 9600)]
    baud: u32,
    /// Print machine-readable output (info, move, home).
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    action: PtuAction,
}

#[derive(Subcommand)]
enum PtuAction {
    /// The unit's firmware, resolution, limits, speeds and pan position.
    Info,
    /// Turn the pan axis to an angle (degrees) and wait until it is there.
    Move {
        /// The angle, degrees (positive is the unit's positive direction).
        #[arg(allow_hyphen_values = true)]
        degrees: f64,
        /// Turn by the angle from where the axis is, instead of to it.
        #[arg(long)]
        relative: bool,
    },
    /// Reset (home) the pan axis: it finds its limits and returns to 0. Tilt is left alone,
    /// so nothing on the turntable is tipped.
    Home,
    /// Stop both axes at once.
    Halt,
    /// Enforce the soft limits (on) or allow the full range to the hard stops (off).
    Limits {
        /// on or off.
        #[arg(value_enum)]
        state: OnOff,
    },
    /// Emulate a PTU-46 on a new pseudo-terminal: prints the device path, then serves until
    /// stopped (Ctrl-C).
    Emulate {
        /// Move this many times faster than a real unit (speeds, acceleration, homing).
        #[arg(long, default_value_t = 1.0)]
        speedup: f64,
    },
}

#[derive(Subcommand)]
enum V4lCommand {
    /// The capture devices, their formats and frame sizes.
    List {
        /// Print machine-readable output.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum OnOff {
    /// Enabled.
    On,
    /// Disabled.
    Off,
}

/// How deep the renderer's depth refinement searches, and whether it renders mirrors as
/// reflections (`aibr render`, `aibr eval` and `aibr demo`).
#[derive(clap::Args)]
struct RefineArgs {
    /// How far behind the model's surface the renderer's depth refinement searches, voxels
    /// (default 4, at most 64). Models from few views come out fatter than that: a reach of 6
    /// renders four of the five catalogue scenes 0.1-0.4 dB better from 12 views, in about
    /// the same time a frame, and chair's thin parts a little worse (docs/render.md, "The
    /// refinement's reach"). Deeper, add depths (--refine-steps) and a --reach-penalty.
    #[arg(long, value_name = "VOXELS", value_parser = parse_reach)]
    reach: Option<f64>,
    /// How many depths the refinement tries between half a voxel in front of the surface and
    /// the reach, evenly spaced (default 7, from 2 to 64).
    #[arg(long, value_name = "N", value_parser = parse_refine_steps)]
    refine_steps: Option<usize>,
    /// How much better a depth more than 4 voxels behind the surface must agree to be taken:
    /// its cost is multiplied by 1 + P x (voxels beyond 4) (default 0, at most 100). With
    /// --reach 8 --refine-steps 12 --reach-penalty 0.3, four catalogue scenes render 0.07-0.68
    /// dB better than by default and chair within 0.09 dB, in about 7% more time a frame
    /// (docs/render.md, "A penalised deep search").
    #[arg(long, value_name = "P", value_parser = parse_penalty)]
    reach_penalty: Option<f64>,
    /// Which two sources the refinement compares: the nearest and the nearest across the novel
    /// view from it, or the two nearest (the rule until session 46, which active capture's
    /// uneven arcs can put on one side of the view; docs/render.md, "The refinement's pair of
    /// sources"). Evenly spread views give the same pair either way.
    #[arg(long, value_enum, default_value_t = RefinePair::Across)]
    refine_pair: RefinePair,
    /// Render mirrors as reflections: where the surface is a mirror, a pixel takes what the
    /// nearest view sees reflected in the same direction of the lab (the camera and the
    /// surroundings stay still while the object turns). Voxel coloring carves a mirror away,
    /// so the mirrors the model lacks are taken from the visual hull of the views' masks
    /// where the surface behind does not explain what the views see (docs/render.md, "Mirror
    /// reflections"). Near captured views the mirror side renders better; elsewhere nothing
    /// changes. `aibr eval --json` reports at each checkpoint how many surface voxels of the
    /// model and of the hull were judged, passed the tests of a mirror and were kept
    /// (`mirrors`).
    #[arg(long, value_enum, default_value_t = OnOff::Off)]
    reflections: OnOff,
    /// How the renderer reads a captured view's colour between its pixels: bilinear (2x2
    /// pixels) or Catmull-Rom bicubic (4x4 pixels), which blurs textures less
    /// (docs/render.md, "Bicubic sampling").
    #[arg(long, value_enum, default_value_t = SamplingArg::Bilinear)]
    sampling: SamplingArg,
    /// How far behind a source's own depth a surface point may lie and still count as seen by
    /// it, voxels (default 2, at most 64). 4 renders every catalogue scene as well or up to
    /// 0.10 dB better, and with --reach 6 up to 0.44 dB better (docs/render.md, "The occlusion
    /// tolerance").
    #[arg(long, value_name = "VOXELS", value_parser = parse_occlusion_tolerance)]
    occlusion_tolerance: Option<f64>,
}

/// How the renderer reads a view between its pixels.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum SamplingArg {
    /// The 2x2 pixels around the point.
    Bilinear,
    /// The 4x4 pixels around the point, weighted by the Catmull-Rom spline.
    Bicubic,
}

/// The two sources the renderer's depth refinement compares.
#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum RefinePair {
    /// The nearest source and the nearest candidate across the novel view from it.
    Across,
    /// The two nearest sources.
    Nearest,
}

impl RefineArgs {
    /// The renderer's defaults, the refinement searching as asked.
    fn render_params(&self) -> aibr::render::RenderParams {
        let mut params = aibr::render::RenderParams::default();
        if let Some(r) = params.refine.as_mut() {
            r.back_voxels = self.reach.unwrap_or(r.back_voxels);
            r.steps = self.refine_steps.unwrap_or(r.steps);
            r.penalty = self.reach_penalty.unwrap_or(r.penalty);
            r.bracketing = self.refine_pair == RefinePair::Across;
        }
        if self.reflections == OnOff::On {
            params.reflections = Some(aibr::render::Reflections::default());
        }
        params.sampling = match self.sampling {
            SamplingArg::Bilinear => aibr::render::Sampling::Bilinear,
            SamplingArg::Bicubic => aibr::render::Sampling::Bicubic,
        };
        params.occlusion_tolerance_voxels = self
            .occlusion_tolerance
            .unwrap_or(params.occlusion_tolerance_voxels);
        params
    }

    /// Records the search the renderer takes in a JSON object: `reach_voxels`,
    /// `refine_steps`, `reach_penalty` and `refine_pair` (null without the refinement),
    /// `reflections` (true or false), `sampling` ("bilinear" or "bicubic") and
    /// `occlusion_tolerance_voxels`.
    fn record(&self, out: &mut serde_json::Value) {
        let params = self.render_params();
        let r = params.refine;
        if let Some(map) = out.as_object_mut() {
            map.insert("reflections".into(), params.reflections.is_some().into());
            map.insert("reach_voxels".into(), r.map(|r| r.back_voxels).into());
            map.insert("refine_steps".into(), r.map(|r| r.steps).into());
            map.insert("reach_penalty".into(), r.map(|r| r.penalty).into());
            let pair = r.map(|r| if r.bracketing { "across" } else { "nearest" });
            map.insert("refine_pair".into(), pair.into());
            let sampling = match params.sampling {
                aibr::render::Sampling::Bilinear => "bilinear",
                aibr::render::Sampling::Bicubic => "bicubic",
            };
            map.insert("sampling".into(), sampling.into());
            map.insert(
                "occlusion_tolerance_voxels".into(),
                params.occlusion_tolerance_voxels.into(),
            );
        }
    }
}

/// How the active planner ranks arcs (`aibr capture` and `aibr eval`).
#[derive(clap::Args)]
struct PlanArgs {
    /// The active planner ranks the arcs between neighbouring views by their score times
    /// their angular width to this power: 1 follows the score's mass, higher powers split
    /// wide arcs first unless a narrow one scores far worse (0 to 8).
    #[arg(
        long,
        default_value_t = CaptureParams::default().width_power,
        value_name = "P",
        allow_hyphen_values = true
    )]
    width_power: f64,
    /// The active planner moves a view from the middle of the arc it splits to a pan that
    /// sees a flat face of the model edge-on when one lies within this share of the arc's
    /// half-width from the middle (0 to 1; 0 always splits at the middle).
    #[arg(
        long,
        default_value_t = CaptureParams::default().aim_reach,
        value_name = "SHARE",
        allow_hyphen_values = true
    )]
    aim_reach: f64,
    /// The active planner first serves every flat face of the model: while a face has no view
    /// within `--face-served-deg` of a pan that sees it edge-on, it splits the best-ranked arc
    /// holding such a pan there, and only then splits arcs by rank alone. true, false, or auto:
    /// when the initial views' arcs show a view-dependent surface (a mirror), decided once.
    #[arg(
        long,
        default_value_t = CaptureParams::default().faces_first,
        value_name = "false|true|auto",
        value_parser = parse_faces_first
    )]
    faces_first: aibr::FacesFirst,
    /// Serving faces first, a face counts as served when a view lies within this many degrees
    /// of a pan that sees it edge-on (more than 0, at most 10).
    #[arg(
        long,
        default_value_t = CaptureParams::default().face_served_deg,
        value_name = "DEG",
        allow_hyphen_values = true
    )]
    face_served_deg: f64,
}

impl PlanArgs {
    /// `params` with the planner these options ask for.
    fn apply(&self, params: CaptureParams) -> CaptureParams {
        CaptureParams {
            width_power: self.width_power,
            aim_reach: self.aim_reach,
            faces_first: self.faces_first,
            face_served_deg: self.face_served_deg,
            ..params
        }
    }
}

#[derive(clap::Args)]
struct EvalArgs {
    /// The rig: sim:SCENE (the truth is the scene, rendered at every uncaptured angle;
    /// sim:SCENE@DEGREES with the scene turned that far on the turntable, -180 to 180, to see
    /// how much a result owes to where the object happens to stand), or replay:DIR, a
    /// Middlebury-style ring folder (*_par.txt and images) whose recorded views play turntable
    /// and camera: active capture asks only for views not yet taken, and the views never
    /// captured are the truth.
    #[arg(long, default_value = "sim:mirror")]
    rig: String,
    /// Views active capture takes uniformly first; also the first checkpoint, unless
    /// --checkpoints gives them.
    #[arg(long, default_value_t = 12)]
    initial: usize,
    /// The budget of views (default 48; on a replay rig, three quarters of its views, so
    /// that a quarter is held out).
    #[arg(long)]
    max: Option<usize>,
    /// The strategies to compare.
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "active,uniform"
    )]
    strategy: Vec<StrategyArg>,
    /// View counts to measure at, increasing (default: the initial count, then every 12 up to
    /// the budget; a budget below the default initial count, which only uniform capture
    /// accepts, is the one checkpoint); each at most the budget and, with active capture, at
    /// least the initial count.
    #[arg(long, value_delimiter = ',')]
    checkpoints: Vec<usize>,
    /// Voxels along the longest edge of the models rendered from.
    #[arg(long, default_value_t = 128)]
    grid: usize,
    /// Voxels along the longest edge while capturing.
    #[arg(long, default_value_t = 96)]
    capture_grid: usize,
    #[command(flatten)]
    plan: PlanArgs,
    /// Spacing of the evaluated pan angles, degrees (an angle within half a step, and within
    /// half a degree, of a captured view counts as captured and is skipped).
    #[arg(long, default_value_t = 1.0)]
    step_deg: f64,
    /// The geometry the novel views are rendered from: the reconstruction (the system as it
    /// runs), the reconstruction with its tops refined and their steps walled, the
    /// reconstruction with voxel coloring's column test, the visual hull of the object masks,
    /// or the true geometry (synthetic rigs only). The capture is the
    /// same whichever it is, so comparing them on one --work folder tells what the geometry
    /// costs apart from what the choice of views does.
    #[arg(long, value_enum, default_value = "reconstructed")]
    model: ModelArg,
    #[command(flatten)]
    refine: RefineArgs,
    /// Folder for the sessions the evaluation captures (kept; a rerun reuses them).
    #[arg(long, default_value = "aibr-eval")]
    work: PathBuf,
    /// Evaluate a synthetic scene several times, turned on its turntable by each of these
    /// angles in degrees (a list such as 0,10,20, or FROM:TO:STEP such as 0:27.5:2.5;
    /// sessions in --work/turnDEGREES), and summarise active minus uniform over the turns
    /// (mean, its standard error, range, and at how many turns active is ahead): one
    /// placement of the object can favour either strategy.
    #[arg(long, allow_hyphen_values = true, value_name = "DEGREES", value_parser = parse_turns)]
    turns: Option<Turns>,
    /// Also report the figures of the novel views on this arc of the object's own pan
    /// angles, FROM:TO in degrees (e.g. 20:160, the side from which mirror's panel is seen),
    /// and of the others, with how many captured views lie on it; the arc turns with a
    /// turned scene. With --turns, active - uniform on and off the arc is summarised too.
    #[arg(long, value_name = "FROM:TO", allow_hyphen_values = true, value_parser = parse_arc)]
    arc: Option<aibr::ObjectArc>,
    /// Print a machine-readable summary on standard output. On a synthetic rig each
    /// checkpoint also scores the model rendered from against the scene's true surface
    /// ("geometry": accuracy in voxels, completeness; null on a replay rig); with both
    /// strategies, "common_angles" holds each checkpoint's figures over only the angles
    /// neither captured.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum StrategyArg {
    /// Split the arc the consistency estimate says renders worst.
    Active,
    /// The baseline: every view spread uniformly.
    Uniform,
}

impl From<StrategyArg> for Strategy {
    fn from(s: StrategyArg) -> Self {
        match s {
            StrategyArg::Active => Strategy::Active,
            StrategyArg::Uniform => Strategy::Uniform,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum ModelArg {
    /// The voxel model reconstructed from the views.
    Reconstructed,
    /// The reconstruction with its tops refined and their steps walled
    /// (`aibr_voxel::refine_tops`).
    Refined,
    /// The reconstruction with voxel coloring's column test (`aibr_voxel::ColumnTest`).
    Column,
    /// The visual hull of the views' object masks.
    Hull,
    /// The true geometry, voxelised (synthetic rigs only): a diagnostic.
    Truth,
}

#[derive(Clone, Copy, ValueEnum)]
enum CriterionArg {
    /// The paper's non-Lambertian criterion: views agree only with their angular neighbours.
    Angular,
    /// Seitz and Dyer's: all views agree.
    Classic,
}

#[derive(clap::Args)]
struct ReconstructArgs {
    /// The session folder.
    session: PathBuf,
    /// Voxels along the longest edge of the volume.
    #[arg(long, default_value_t = 128)]
    grid: usize,
    /// Voxel coloring: the colour-consistency criterion. (Where a camera is not above the
    /// volume, space carving reconstructs the session instead, with its own lenient
    /// criterion, and refuses the options for voxel coloring.)
    #[arg(long, value_enum, default_value_t = CriterionArg::Angular)]
    criterion: CriterionArg,
    /// Voxel coloring: leave out, for a voxel on the boundary of the masks' visual hull, the
    /// views whose direction makes a cosine below this with the hull's outward normal (they
    /// see it through the object); `off` asks every view, as Seitz and Dyer do. Default: the
    /// library's (-0.3).
    #[arg(long, value_name = "COSINE|off", value_parser = parse_behind_hull, allow_hyphen_values = true)]
    behind_hull: Option<BehindHull>,
    /// Voxel coloring: judge each voxel only by the pixels this far inside its footprint
    /// (0.5: those whose centres lie inside its projected square). With 48 views, about a
    /// sixth less time and as good a model (measured on the synthetic scenes); from 12 or 24
    /// views the models come out fatter. Default 0, every pixel of the footprint
    /// (`docs/voxel.md`, "Sampled pixels").
    #[arg(long, value_name = "PIXELS", value_parser = parse_sample_inset)]
    sample_inset: Option<f32>,
    /// Voxel coloring: pass over a top voxel whose views agree clearly better further down
    /// its column, with the tops around it, and go on judging the voxels below
    /// (`aibr_voxel::ColumnTest`, its defaults): on the synthetic `head`, 2.99 -> 1.16 voxels
    /// of accuracy at 128^3 from 48 views, in two to three times the time. Unlike
    /// `--refine-tops` it goes on to reconstruct what a passed-over top hid. `aibr render`
    /// does not use it (`docs/voxel.md`, "The column test").
    #[arg(long)]
    column_test: bool,
    /// After the reconstruction, move the upward-facing surface down to where the views
    /// agree best (`aibr_voxel::refine_tops`, its defaults): on the synthetic `head`, 2.99 ->
    /// 1.23 voxels of accuracy at 128^3 from 48 views. It leaves gaps where the sweep's
    /// fillets hid the surface (see `--walls`); `aibr render` does not use it (`docs/voxel.md`,
    /// "Refining the tops").
    #[arg(long)]
    refine_tops: bool,
    /// With `--refine-tops`: wall the steps the moved tops leave, so the model stays as
    /// closed as the sweep's (its silhouettes and the views rendered from it are then as good
    /// as the sweep's), at a cost in accuracy where columns beside them did not move (`head`:
    /// 2.02 voxels instead of 1.23; `docs/voxel.md`, "Walls for the steps").
    #[arg(long, requires = "refine_tops")]
    walls: bool,
    /// Write model.ply as cubes (each voxel's faces toward its empty neighbours, closed and
    /// facing out) instead of one coloured point a voxel: MeshLab and Blender then show a
    /// solid. The file is about eight times as large.
    #[arg(long)]
    cubes: bool,
    /// Print a machine-readable summary on standard output.
    #[arg(long)]
    json: bool,
}

/// Whether the library takes the default [`ColoringParams`] changed by `set`: the options'
/// parsers refuse what `ColoringParams::validate` would, before the session is read.
fn coloring_accepts(set: impl FnOnce(&mut ColoringParams)) -> bool {
    let mut params = ColoringParams::default();
    set(&mut params);
    params.validate().is_ok()
}

/// `--sample-inset`: pixels inside the footprint, in [0, 8].
fn parse_sample_inset(s: &str) -> std::result::Result<f32, String> {
    match s.parse::<f32>() {
        Ok(inset) if coloring_accepts(|p| p.sample_inset = inset) => Ok(inset),
        _ => Err(format!("`{s}` is not a number of pixels in [0, 8]")),
    }
}

/// `--behind-hull`: a cosine in [-1, 1], or `off`.
#[derive(Clone, Copy, Debug)]
struct BehindHull(Option<f64>);

fn parse_behind_hull(s: &str) -> std::result::Result<BehindHull, String> {
    if s.eq_ignore_ascii_case("off") {
        return Ok(BehindHull(None));
    }
    match s.parse::<f64>() {
        Ok(c) if coloring_accepts(|p| p.behind_hull = Some(c)) => Ok(BehindHull(Some(c))),
        _ => Err(format!("`{s}` is neither a cosine in [-1, 1] nor `off`")),
    }
}

#[derive(clap::Args)]
struct RenderArgs {
    /// The session folder.
    session: PathBuf,
    /// The pan angle to render, degrees (inside the turntable's range).
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "sweep",
        conflicts_with = "sweep"
    )]
    pan: Option<f64>,
    /// Render a sweep of pan angles instead, FROM:TO:STEP in degrees (TO included when the
    /// steps land on it; STEP negative to turn the other way), into the folder -o names:
    /// frame_0000.png, frame_0001.png, ..., frame i at FROM + i STEP (a turntable animation of
    /// novel views; `ffmpeg -i DIR/frame_%04d.png` makes a video of them). The model and the
    /// renderer are built once.
    /// Every angle must lie inside the turntable's range, and no frame may exist already.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_sweep)]
    sweep: Option<Sweep>,
    /// The output image (PNG, a name ending in .png); with --sweep, the folder for the frames
    /// (made if missing).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write the depth as OpenEXR (a name ending in .exr; one view only).
    #[arg(long, conflicts_with = "sweep")]
    depth: Option<PathBuf>,
    /// Also write how each pixel was made (PNG, a name ending in .png; one view only): white
    /// where the model's surface was met, grey where the focal surface stood in, black where
    /// no capture sees the point.
    #[arg(long, conflicts_with = "sweep")]
    coverage: Option<PathBuf>,
    /// Voxels along the longest edge of the model used.
    #[arg(long, default_value_t = 128)]
    grid: usize,
    /// Render at the model's surface, without the depth refinement: about a quarter less time
    /// a frame, but blurrier texture (1-1.7 dB lower masked PSNR on the catalogue's textured
    /// objects at 24 views). For quick looks and long sweeps.
    #[arg(long, conflicts_with_all = ["reach", "refine_steps", "reach_penalty", "refine_pair"])]
    no_refine: bool,
    #[command(flatten)]
    refine: RefineArgs,
    /// Render from the model as reconstructed, a shell with gaps, instead of the shell closed
    /// and filled (rays through a gap then meet what lies behind it).
    #[arg(long)]
    no_fill: bool,
}

/// Angles from `from` to `to` (included when the steps land on it) by `step`, degrees: the
/// pan angles of `render --sweep`, the turns of `eval --turns FROM:TO:STEP`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Sweep {
    from: f64,
    to: f64,
    step: f64,
}

/// The most frames a sweep may have.
const MAX_SWEEP_FRAMES: usize = 100_000;

impl Sweep {
    /// The number of angles.
    fn len(&self) -> usize {
        // A hair of slack so that 0:10:0.1 ends at 10 despite rounding.
        (((self.to - self.from) / self.step + 1e-9).floor() as usize).saturating_add(1)
    }

    fn angles(&self) -> impl Iterator<Item = f64> + '_ {
        (0..self.len()).map(|i| self.from + i as f64 * self.step)
    }
}

/// The turns of `aibr eval --turns`, degrees.
#[derive(Debug, Clone)]
struct Turns(Vec<f64>);

/// The most turns one `--turns` may ask for (a run takes minutes each).
const MAX_TURNS: usize = 360;

fn parse_turns(text: &str) -> std::result::Result<Turns, String> {
    let too_many = || format!("{text:?}: more than {MAX_TURNS} turns");
    let parts: Vec<&str> = text.split(':').collect();
    let turns = match parts.as_slice() {
        [from, to, step] => {
            let range = Sweep {
                from: degrees_in(text, "FROM", from)?,
                to: degrees_in(text, "TO", to)?,
                step: degrees_in(text, "STEP", step)?,
            };
            if !(range.step > 0.0) || range.to < range.from {
                return Err(format!(
                    "{text:?}: STEP must be positive and TO at least FROM"
                ));
            }
            // Counted before any is made: `len` saturates, so 0:1e300:1 is refused too.
            if range.len() > MAX_TURNS {
                return Err(too_many());
            }
            // Rounded to a nanodegree, so that 0:0.3:0.1 names its folders turn0.1, turn0.2,
            // turn0.3 (`angles` computes each from FROM, not by summing steps).
            range.angles().map(|t| (t * 1e9).round() / 1e9).collect()
        }
        [_] => {
            let list = text
                .split(',')
                .map(|v| degrees_in(text, "turn", v))
                .collect::<std::result::Result<Vec<_>, _>>()?;
            if list.len() > MAX_TURNS {
                return Err(too_many());
            }
            list
        }
        _ => {
            return Err(format!(
                "{text:?}: expected a list of degrees such as 0,10,20, or FROM:TO:STEP such as 0:27.5:2.5"
            ));
        }
    };
    // A placement twice would be captured into one folder and counted twice in the summary.
    if let Some((i, t)) = turns
        .iter()
        .enumerate()
        .find(|&(i, t)| turns[..i].contains(t))
    {
        return Err(format!(
            "{text:?}: turn {t} is given twice (turn {})",
            i + 1
        ));
    }
    Ok(Turns(turns))
}

/// The part `name` of an argument `text` (`v`, such as the FROM of FROM:TO), as a finite
/// number of degrees, or the error that names both.
fn degrees_in(text: &str, name: &str, v: &str) -> std::result::Result<f64, String> {
    v.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| format!("{text:?}: {name} {v:?} is not a number of degrees"))
}

/// `--faces-first`: false, true or auto.
fn parse_faces_first(text: &str) -> std::result::Result<aibr::FacesFirst, String> {
    aibr::FacesFirst::parse(text).map_err(|e| e.to_string())
}

fn parse_arc(text: &str) -> std::result::Result<aibr::ObjectArc, String> {
    let Some((from, to)) = text.split_once(':') else {
        return Err(format!(
            "{text:?}: expected FROM:TO in degrees, such as 20:160"
        ));
    };
    let (from, to) = (degrees_in(text, "FROM", from)?, degrees_in(text, "TO", to)?);
    if (to - from).rem_euclid(360.0) == 0.0 {
        return Err(format!(
            "{text:?}: FROM and TO are the same angle, which makes no arc"
        ));
    }
    Ok(aibr::ObjectArc {
        from: Angle::from_degrees(from),
        to: Angle::from_degrees(to),
    })
}

/// A number from 0 to `most`, or the message that says what was expected (`what`: "a number
/// of voxels", "a number").
fn number_up_to(text: &str, most: f64, what: &str) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if (0.0..=most).contains(&v) => Ok(v),
        _ => Err(format!("{text:?}: expected {what} from 0 to {most}")),
    }
}

/// `--reach`: voxels behind the model's surface, from 0 to [`MAX_REACH`].
fn parse_reach(text: &str) -> std::result::Result<f64, String> {
    number_up_to(text, MAX_REACH, "a number of voxels")
}

/// `--refine-steps`: the depths the renderer takes, from 2 to its most.
fn parse_refine_steps(text: &str) -> std::result::Result<usize, String> {
    let most = aibr::render::MAX_REFINE_STEPS;
    match text.trim().parse::<usize>() {
        Ok(n) if (2..=most).contains(&n) => Ok(n),
        _ => Err(format!(
            "{text:?}: expected a number of depths from 2 to {most}"
        )),
    }
}

/// `--reach-penalty`: from 0 to the renderer's largest.
fn parse_penalty(text: &str) -> std::result::Result<f64, String> {
    number_up_to(text, aibr::render::MAX_REFINE_PENALTY, "a number")
}

/// `--occlusion-tolerance`: voxels, from 0 to the renderer's largest.
fn parse_occlusion_tolerance(text: &str) -> std::result::Result<f64, String> {
    number_up_to(
        text,
        aibr::render::MAX_OCCLUSION_TOLERANCE,
        "a number of voxels",
    )
}

/// The deepest `--reach`, voxels: half the default grid's edge.
const MAX_REACH: f64 = 64.0;

fn parse_sweep(text: &str) -> std::result::Result<Sweep, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let [from, to, step] = parts.as_slice() else {
        return Err(format!(
            "{text:?}: expected FROM:TO:STEP in degrees, such as 20:150:1"
        ));
    };
    let sweep = Sweep {
        from: degrees_in(text, "FROM", from)?,
        to: degrees_in(text, "TO", to)?,
        step: degrees_in(text, "STEP", step)?,
    };
    if sweep.step == 0.0 || (sweep.to - sweep.from) * sweep.step < 0.0 {
        return Err(format!(
            "{text:?}: STEP must be non-zero and turn from FROM towards TO"
        ));
    }
    // `len` saturates, so a count too large for usize is refused too.
    let frames = sweep.len();
    if frames > MAX_SWEEP_FRAMES {
        return Err(format!(
            "{text:?}: {frames} frames, more than {MAX_SWEEP_FRAMES}"
        ));
    }
    Ok(sweep)
}

#[derive(Subcommand)]
enum SceneCommand {
    /// Render a catalogue scene at a pan angle of its default rig.
    Render {
        /// mirror, mirror-broad, head, chair or lambertian.
        scene: String,
        /// The pan angle, degrees.
        #[arg(long, allow_hyphen_values = true)]
        pan: f64,
        /// The output image (PNG, a name ending in .png).
        #[arg(short, long)]
        output: PathBuf,
        /// Also write the depth as OpenEXR (a name ending in .exr).
        #[arg(long)]
        depth: Option<PathBuf>,
        /// Also write the object mask (PNG, a name ending in .png).
        #[arg(long)]
        mask: Option<PathBuf>,
    },
}

fn main() {
    let matches = Cli::command().get_matches();
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
    if let Err(e) = run(cli, &matches) {
        eprintln!("error: {}", report(&e));
        std::process::exit(1);
    }
}

/// Which of a subcommand's options were given on the command line rather than left at their
/// defaults, so that a run can refuse those it would leave unused.
struct Given<'a>(Option<&'a ArgMatches>);

impl Given<'_> {
    /// The first of `ids` (the options' field names) given, spelt as on the command line.
    fn first(&self, ids: &[&str]) -> Option<String> {
        let matches = self.0?;
        ids.iter()
            .find(|id| matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine))
            .map(|id| format!("--{}", id.replace('_', "-")))
    }
}

/// The options of a webcam capture (a synthetic camera uses none of them) by their field
/// names.
const WEBCAM_OPTIONS: [&str; 5] = [
    "calibration",
    "average",
    "exposure",
    "white_balance",
    "gain",
];

/// The options of the active planner ([`PlanArgs`]) by their field names.
const PLANNER_OPTIONS: [&str; 4] = ["width_power", "aim_reach", "faces_first", "face_served_deg"];

/// The error and its causes on one line, `: ` between them. The library's errors name their
/// cause in their own message (so that it shows wherever they are printed) and also give it
/// as their source, so a cause the message before already ends with is left out rather than
/// said twice.
fn report(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

fn run(cli: Cli, matches: &ArgMatches) -> Result<()> {
    let given = Given(matches.subcommand().map(|(_, m)| m));
    match cli.command {
        Command::Demo(a) => demo::run(a).map(drop),
        Command::Capture(a) => capture(a, &given),
        Command::Reconstruct(a) => reconstruct(a, &given),
        Command::Render(a) => render(a),
        Command::Eval(a) => eval(a, &given),
        Command::Ptu(a) => ptu(a),
        Command::V4l { command } => v4l(command),
        Command::Calibrate { command } => calibrate::run(command),
        Command::Scene { command } => scene(command),
    }
}

#[cfg(feature = "v4l")]
fn v4l(command: V4lCommand) -> Result<()> {
    let V4lCommand::List { json } = command;
    let devices = aibr::v4l::device::list()?;
    if json {
        let list: Vec<_> = devices
            .iter()
            .map(|d| {
                serde_json::json!({
                    "path": d.path, "card": d.card, "driver": d.driver, "bus": d.bus,
                    "formats": d.offers.iter().map(|o| o.to_string()).collect::<Vec<_>>(),
                })
            })
            .collect();
        println!("{}", serde_json::to_string_pretty(&list)?);
        return Ok(());
    }
    if devices.is_empty() {
        println!("no video capture devices");
    }
    for d in devices {
        println!("{}: {} ({}, {})", d.path.display(), d.card, d.driver, d.bus);
        for o in &d.offers {
            let usable = aibr::v4l::PixelFormat::from_fourcc(o.fourcc).is_some();
            println!("    {o}{}", if usable { "" } else { " (not usable)" });
        }
    }
    Ok(())
}

#[cfg(not(feature = "v4l"))]
fn v4l(_command: V4lCommand) -> Result<()> {
    bail!("{NO_WEBCAM}")
}

/// What a build without the v4l feature says when asked for a webcam.
#[cfg(not(feature = "v4l"))]
const NO_WEBCAM: &str = "this aibr was built without webcam support; build it with \
     `cargo build --release -p aibr-cli --features v4l` (needs libclang: apt-get install libclang-dev)";

fn open_ptu(port: &str, baud: u32) -> Result<aibr::ptu::SerialPtu> {
    aibr::ptu::SerialPtu::open(port, baud, aibr::ptu::PtuOptions::default())
        .with_context(|| format!("connecting to the PTU on {port}"))
}

fn ptu(a: PtuArgs) -> Result<()> {
    use aibr::ptu::{Axis, Radians};
    if let PtuAction::Emulate { speedup } = a.action {
        if !(speedup > 0.0 && speedup.is_finite()) {
            bail!("--speedup {speedup}: must be a positive number");
        }
        let unit = aibr::ptu::Emulator::new(aibr::ptu::EmulatorConfig::default().faster(speedup));
        let mut server = aibr::ptu::PtyServer::open(unit)?;
        println!("{}", server.path());
        eprintln!(
            "emulating a PTU-46 on {} (Ctrl-C to stop); try: aibr ptu --port {} info",
            server.path(),
            server.path()
        );
        std::io::Write::flush(&mut std::io::stdout())?;
        server.serve(&std::sync::atomic::AtomicBool::new(false))?;
        return Ok(());
    }
    let Some(port) = a.port.as_deref() else {
        bail!("--port PATH is required (the unit's serial device)");
    };
    let mut unit = open_ptu(port, a.baud)?;
    let report = |unit: &mut aibr::ptu::SerialPtu, json: bool| -> Result<()> {
        let steps = unit.position_steps(Axis::Pan)?;
        let deg = unit.info().pan.radians(steps).degrees();
        if json {
            println!(
                "{}",
                serde_json::to_string_pretty(
                    &serde_json::json!({"pan_deg": deg, "pan_steps": steps})
                )?
            );
        } else {
            println!("pan at {deg:.4} deg ({steps} steps)");
        }
        Ok(())
    };
    match a.action {
        PtuAction::Info => {
            let pos = unit.position_steps(Axis::Pan)?;
            let info = unit.info().clone();
            let axis = |x: &aibr::ptu::AxisInfo| {
                serde_json::json!({
                    "resolution_arcsec": x.resolution_arcsec,
                    "min_steps": x.min, "max_steps": x.max,
                    "min_deg": x.radians(x.min).degrees(), "max_deg": x.radians(x.max).degrees(),
                    "speed_steps_per_s": x.speed, "base_speed_steps_per_s": x.base_speed,
                    "lower_speed_steps_per_s": x.lower_speed, "upper_speed_steps_per_s": x.upper_speed,
                    "acceleration_steps_per_s2": x.acceleration,
                })
            };
            if a.json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&serde_json::json!({
                        "port": port,
                        "firmware": info.firmware,
                        "limits_enabled": info.limits_enabled,
                        "echo_was_on": info.echo_was_on,
                        "pan_steps": pos,
                        "pan_deg": info.pan.radians(pos).degrees(),
                        "pan": axis(&info.pan),
                        "tilt": axis(&info.tilt),
                    }))?
                );
            } else {
                let p = &info.pan;
                println!("firmware:   {}", info.firmware);
                println!(
                    "pan:        {:.4} deg ({pos} steps) of {:.2} .. {:.2} deg; {} arc seconds a step",
                    p.radians(pos).degrees(),
                    p.radians(p.min).degrees(),
                    p.radians(p.max).degrees(),
                    p.resolution_arcsec
                );
                println!(
                    "speed:      {} steps/s (bounds {} .. {}), acceleration {} steps/s^2",
                    p.speed, p.lower_speed, p.upper_speed, p.acceleration
                );
                println!(
                    "limits:     {}",
                    if info.limits_enabled {
                        "enforced"
                    } else {
                        "off (hard stops only)"
                    }
                );
            }
        }
        PtuAction::Move { degrees, relative } => {
            if !degrees.is_finite() {
                bail!("move {degrees}: not an angle");
            }
            let angle = Radians::from_degrees(degrees);
            // The unit's refusals speak in steps: say what was asked in degrees too.
            if relative {
                unit.move_by(Axis::Pan, angle)
                    .with_context(|| format!("move by {degrees} deg"))?;
            } else {
                unit.move_to(Axis::Pan, angle)
                    .with_context(|| format!("move to {degrees} deg"))?;
            }
            report(&mut unit, a.json)?;
        }
        PtuAction::Home => {
            unit.reset(Some(Axis::Pan))?;
            report(&mut unit, a.json)?;
        }
        PtuAction::Halt => {
            unit.halt(None)?;
            report(&mut unit, a.json)?;
        }
        PtuAction::Limits { state } => {
            let on = unit.set_limits(state == OnOff::On)?;
            println!(
                "limits {}",
                if on {
                    "enforced"
                } else {
                    "off (hard stops only)"
                }
            );
        }
        PtuAction::Emulate { .. } => {}
    }
    Ok(())
}

/// An image format the command line writes: its extension and its name.
type Format = (&'static str, &'static str);
const PNG: Format = ("png", "PNG");
const EXR: Format = ("exr", "OpenEXR");

/// Refuses an output file whose name says another format than the one written into it
/// (`--depth view.png` would hold OpenEXR), for each given output: its option, its path, and
/// the format written there. Extensions are compared without case. Checked before the work,
/// so a long render does not end in a misnamed file.
fn check_extensions(outputs: &[(&str, Option<&PathBuf>, Format)]) -> Result<()> {
    for &(flag, path, (ext, format)) in outputs {
        let Some(path) = path else { continue };
        let given = path.extension().and_then(|e| e.to_str());
        if !given.is_some_and(|g| g.eq_ignore_ascii_case(ext)) {
            bail!(
                "{flag} {}: this is written as {format}; give the file name the .{ext} extension",
                path.display()
            );
        }
    }
    Ok(())
}

fn png(path: &Path, img: &impl PngEncodable) -> Result<()> {
    let bytes = img.png_bytes()?;
    write_atomic(path, &bytes).with_context(|| format!("writing {}", path.display()))
}

trait PngEncodable {
    fn png_bytes(&self) -> Result<Vec<u8>>;
}

impl<P> PngEncodable for image::ImageBuffer<P, Vec<u8>>
where
    P: image::Pixel<Subpixel = u8> + image::PixelWithColorType,
{
    fn png_bytes(&self) -> Result<Vec<u8>> {
        let mut out = std::io::Cursor::new(Vec::new());
        self.write_to(&mut out, image::ImageFormat::Png)?;
        Ok(out.into_inner())
    }
}

fn exr(path: &Path, depth: &aibr::voxel::DepthMap) -> Result<()> {
    let mut out = std::io::Cursor::new(Vec::new());
    aibr::render::write_depth_exr(depth, &mut out)?;
    write_atomic(path, &out.into_inner()).with_context(|| format!("writing {}", path.display()))
}

fn capture(a: CaptureArgs, given: &Given<'_>) -> Result<()> {
    if a.strategy == StrategyArg::Uniform {
        let active_loop = ["initial", "refine_every", "grid", "consistent_below"];
        if let Some(option) = given
            .first(&active_loop)
            .or_else(|| given.first(&PLANNER_OPTIONS))
        {
            bail!(
                "{option} steers active capture; --strategy uniform captures --max views evenly \
                 over the pan range and reconstructs nothing while capturing"
            );
        }
    }
    match (a.turntable.clone(), a.camera.clone()) {
        (Some(t), Some(c)) => {
            let Some(port) = t.strip_prefix("ptu:") else {
                bail!("--turntable {t:?}: expected ptu:PATH (a PTU-46 on serial device PATH)");
            };
            let spec = format!("{t}+{c}");
            if let Some(device) = c.strip_prefix("v4l:") {
                return capture_webcam(a, &spec, port, device);
            }
            if let Some(option) = given.first(&WEBCAM_OPTIONS) {
                bail!(
                    "{option} is for a webcam (--camera v4l:DEVICE): --camera {c:?} renders its \
                     scene with the scene's own calibration and nothing to average or adjust"
                );
            }
            let turntable = aibr::PtuTurntable::new(open_ptu(port, a.baud)?)?;
            let camera = aibr::SceneCamera::from_spec(&c, aibr::Turntable::step(&turntable))
                .with_context(|| format!("--camera {c:?}: expected sim:SCENE or v4l:DEVICE"))?;
            let calibration = camera.calibration()?;
            let mut rig = aibr::Rig { turntable, camera };
            capture_on(a, &spec, &mut rig, &calibration)
        }
        _ => {
            if a.rig.starts_with("replay:") {
                bail!(
                    "--rig {:?}: a replayed data set serves `aibr eval` only, where its views \
                     left out are the truth; aibr capture takes sim:SCENE, or --turntable \
                     ptu:PATH with --camera",
                    a.rig
                );
            }
            let mut rig = SimRig::from_spec(&a.rig)?;
            let calibration = rig.calibration()?;
            let spec = a.rig.clone();
            capture_on(a, &spec, &mut rig, &calibration)
        }
    }
}

/// Reads a calibration in the form of session.json's "calibration" record.
#[cfg_attr(not(feature = "v4l"), allow(dead_code))]
fn read_calibration(path: &Path) -> Result<aibr::Calibration> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let record: aibr::session::CalibrationRecord = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a calibration record", path.display()))?;
    record
        .calibration()
        .with_context(|| format!("{}: invalid calibration", path.display()))
}

#[cfg(feature = "v4l")]
fn control_setting(name: &str, value: &str) -> Result<aibr::v4l::device::ControlSetting> {
    use aibr::v4l::device::ControlSetting;
    Ok(match value {
        "lock" => ControlSetting::Lock,
        "auto" => ControlSetting::Auto,
        v => ControlSetting::Manual(
            v.parse()
                .with_context(|| format!("--{name} {v:?}: expected lock, auto or an integer"))?,
        ),
    })
}

#[cfg(feature = "v4l")]
fn capture_webcam(a: CaptureArgs, spec: &str, port: &str, device: &str) -> Result<()> {
    let Some(path) = a.calibration.clone() else {
        bail!(
            "--camera v4l:{device} needs --calibration FILE (the webcam's intrinsics and the pan axis)"
        );
    };
    if a.average == 0 {
        bail!("--average 0: at least one frame");
    }
    let mut calibration = read_calibration(&path)?;
    let options = aibr::v4l::device::WebcamOptions {
        exposure: control_setting("exposure", &a.exposure)?,
        white_balance: control_setting("white-balance", &a.white_balance)?,
        gain: control_setting("gain", &a.gain)?,
        ..Default::default()
    };
    let policy = aibr::v4l::SettlePolicy {
        frames: a.average,
        ..Default::default()
    };
    let camera = aibr::V4lCamera::open(Path::new(device), &calibration.camera, options, policy)?;
    // The views are stored undistorted: the session's camera has no distortion.
    calibration.camera.distortion = aibr::camera::Distortion::default();
    let turntable = aibr::PtuTurntable::new(open_ptu(port, a.baud)?)?;
    let mut rig = aibr::Rig { turntable, camera };
    capture_on(a, spec, &mut rig, &calibration)
}

#[cfg(not(feature = "v4l"))]
fn capture_webcam(a: CaptureArgs, _spec: &str, _port: &str, device: &str) -> Result<()> {
    if let Some(path) = &a.calibration {
        read_calibration(path)?;
    }
    bail!("--camera v4l:{device}: {NO_WEBCAM}")
}

fn capture_on<R: aibr::Turntable + aibr::FrameSource>(
    a: CaptureArgs,
    spec: &str,
    rig: &mut R,
    calibration: &aibr::Calibration,
) -> Result<()> {
    let params = a.plan.apply(CaptureParams {
        strategy: a.strategy.into(),
        initial: a.initial,
        max: a.max,
        refine_every: a.refine_every,
        grid: a.grid,
        consistent_below: a.consistent_below,
        ..CaptureParams::default()
    });
    let mut session = if a.resume {
        let s = Session::open(&a.out).with_context(|| format!("resuming {}", a.out.display()))?;
        s.check_parameters(spec, &params)?;
        s
    } else {
        aibr::new_session_with_volume(
            &a.out,
            spec,
            rig,
            calibration,
            &params,
            volume_source(&a.volume)?,
        )?
    };
    let bar = ProgressBar::new(params.max as u64);
    bar.set_style(ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} views {msg}",
    )?);
    bar.set_position(session.file().views.len() as u64);
    let mut reporter = reporter::Reporter::new(bar);
    let report = aibr::capture(rig, &mut session, &params, &mut |p| match p {
        Progress::Captured { count, pan, .. } => {
            reporter.bar().set_position(count as u64);
            reporter.message(format!("captured at {:.2} deg", pan.degrees()));
        }
        Progress::Reconstructed { views, algorithm } => {
            reporter.message(format!("{algorithm} from {views} views"))
        }
        Progress::Planned { pan, score } => reporter.message(format!(
            "next at {:.2} deg (arc score {score:.0})",
            pan.degrees()
        )),
        Progress::FacesFirstDecided { contrast, serve } => reporter.message(format!(
            "initial arcs' contrast {}: {}",
            contrast.map_or("none".into(), |c| format!("{c:.2}")),
            if serve {
                "a view-dependent surface, faces served first"
            } else {
                "faces not served first"
            }
        )),
    })?;
    reporter.finish();
    if a.json {
        let views: Vec<_> = report
            .pans
            .iter()
            .enumerate()
            .map(|(i, p)| serde_json::json!({"index": i, "pan_deg": p.degrees()}))
            .collect();
        let t = report.timings;
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "session": a.out,
                "rig": spec,
                "strategy": params.strategy.name(),
                "resumed_from": report.resumed_from,
                "stopped_early": report.stopped_early,
                "algorithm": report.algorithm,
                "faces_first": params.faces_first.name(),
                "served_faces_first": report.served_faces_first,
                "initial_contrast": report.initial_contrast,
                "views": views,
                "timings_ms": {"capture_ms": t.capture_ms, "coloring_ms": t.coloring_ms, "scoring_ms": t.scoring_ms, "total_ms": t.total_ms},
            }))?
        );
    } else {
        let mut pans: Vec<f64> = report.pans.iter().map(|p| p.degrees()).collect();
        pans.sort_by(f64::total_cmp);
        println!(
            "{} views in {} ({} strategy, {:.1} s)",
            report.pans.len(),
            a.out.display(),
            params.strategy.name(),
            report.timings.total_ms / 1e3
        );
        if let Some(contrast) = report.initial_contrast {
            println!(
                "faces first: auto, the initial arcs' contrast {contrast:.2} ({})",
                if report.served_faces_first {
                    "served"
                } else {
                    "not served"
                }
            );
        }
        println!(
            "pan angles (deg): {}",
            pans.iter()
                .map(|p| format!("{p:.1}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    Ok(())
}

fn volume_source(spec: &str) -> Result<aibr::VolumeSource> {
    match spec {
        "scene" => Ok(aibr::VolumeSource::Scene),
        "auto" => Ok(aibr::VolumeSource::Estimated),
        _ => {
            let v: Vec<f64> = spec
                .split(',')
                .map(|t| t.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .with_context(|| {
                    format!(
                        "--volume {spec:?}: expected scene, auto or six numbers x0,y0,z0,x1,y1,z1"
                    )
                })?;
            if v.len() != 6 {
                bail!(
                    "--volume {spec:?}: expected six numbers x0,y0,z0,x1,y1,z1, got {}",
                    v.len()
                );
            }
            let b = aibr::camera::Aabb::new([v[0], v[1], v[2]].into(), [v[3], v[4], v[5]].into())
                .with_context(|| format!("--volume {spec:?}"))?;
            Ok(aibr::VolumeSource::Given(b))
        }
    }
}

/// One evaluation of `a` on the rig `spec`, its sessions in `work`.
fn run_eval(
    a: &EvalArgs,
    given: &Given<'_>,
    spec: &str,
    work: &Path,
) -> Result<Vec<aibr::StrategyEval>> {
    enum EvalOn {
        Sim(Box<aibr::SimRig>, String),
        Replay(aibr::ReplayRig, String),
    }
    let on = if let Some(scene) = spec.strip_prefix("sim:") {
        EvalOn::Sim(
            Box::new(aibr::SimRig::new(scene).with_context(|| format!("--rig {spec:?}"))?),
            scene.to_owned(),
        )
    } else if spec.starts_with("replay:") {
        let rig = aibr::ReplayRig::from_spec(spec).with_context(|| format!("--rig {spec:?}"))?;
        let name = rig
            .dir()
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "replay".into());
        EvalOn::Replay(rig, name)
    } else {
        bail!("--rig {spec:?}: eval needs sim:SCENE or replay:DIR");
    };
    let max = match (&on, a.max) {
        (_, Some(m)) => m,
        (EvalOn::Sim(..), None) => 48,
        (EvalOn::Replay(r, _), None) => r.views().len() * 3 / 4,
    };
    if let EvalOn::Replay(r, _) = &on {
        if max >= r.views().len() {
            bail!(
                "--max {max}: {} has {} views, and the budget must leave some out as the truth",
                r.dir().display(),
                r.views().len()
            );
        }
    }
    let checkpoints = if a.checkpoints.is_empty() {
        // Uniform capture alone may be given a budget below the default initial count, which
        // it does not take; an --initial given is the first checkpoint as given (the library
        // refuses one above the budget, as it refuses such a budget for active capture).
        let first = match given.first(&["initial"]) {
            Some(_) => a.initial,
            None => a.initial.min(max),
        };
        let mut c = vec![first];
        let mut n = first.div_ceil(12) * 12;
        while n <= max {
            if n > first {
                c.push(n);
            }
            n += 12;
        }
        if c.last() != Some(&max) {
            c.push(max);
        }
        c
    } else {
        a.checkpoints.clone()
    };
    let strategies: Vec<Strategy> = a.strategy.iter().map(|&s| s.into()).collect();
    let params = aibr::EvalParams {
        capture: a.plan.apply(CaptureParams {
            initial: a.initial,
            max,
            grid: a.capture_grid,
            ..CaptureParams::default()
        }),
        checkpoints,
        grid: a.grid,
        step: Angle::from_degrees(a.step_deg),
        model: eval_model(a.model),
        render: a.refine.render_params(),
    };
    // No folder is made here: the sessions make theirs, so a refused evaluation leaves none.
    let mut reporter = reporter::Reporter::new(ProgressBar::new_spinner());
    let mut progress = |m: String| reporter.message(format!("{spec}: {m}"));
    let results = match &on {
        EvalOn::Sim(rig, name) => aibr::evaluate_rig(
            rig.as_ref(),
            name,
            spec,
            &strategies,
            &params,
            work,
            &mut progress,
        )?,
        EvalOn::Replay(rig, name) => {
            aibr::evaluate_rig(rig, name, spec, &strategies, &params, work, &mut progress)?
        }
    };
    reporter.finish();
    Ok(results)
}

fn eval_model(m: ModelArg) -> EvalModel {
    match m {
        ModelArg::Reconstructed => EvalModel::Reconstructed,
        ModelArg::Refined => EvalModel::Refined,
        ModelArg::Column => EvalModel::ColumnTest,
        ModelArg::Hull => EvalModel::VisualHull,
        ModelArg::Truth => EvalModel::Truth,
    }
}

fn eval(a: EvalArgs, given: &Given<'_>) -> Result<()> {
    if !a.strategy.contains(&StrategyArg::Active) {
        if let Some(option) = given
            .first(&["capture_grid"])
            .or_else(|| given.first(&PLANNER_OPTIONS))
        {
            bail!("{option} steers active capture, and --strategy evaluates uniform capture only");
        }
        // Without --checkpoints, --initial is the first checkpoint.
        if let Some(option) = given
            .first(&["initial"])
            .filter(|_| !a.checkpoints.is_empty())
        {
            bail!(
                "{option} is active capture's initial views and the first checkpoint, and \
                 --strategy evaluates uniform capture only at the --checkpoints given"
            );
        }
    }
    if let Some(turns) = &a.turns {
        return eval_turns(&a, given, &turns.0);
    }
    let results = run_eval(&a, given, &a.rig, &a.work)?;
    let arc = arc_report(&a, &a.rig)?;
    if a.json {
        let mut out = serde_json::json!({
            "rig": a.rig,
            "model": eval_model(a.model).name(),
            "results": results_json(&results, arc.as_ref()),
        });
        a.refine.record(&mut out);
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_eval_table(&results, arc.as_ref());
    }
    Ok(())
}

/// `--arc`, and how far the rig's object stands turned (a synthetic `sim:SCENE@DEGREES`;
/// nothing else is turned).
struct ArcReport {
    arc: aibr::ObjectArc,
    turn: Angle,
}

fn arc_report(a: &EvalArgs, spec: &str) -> Result<Option<ArcReport>> {
    let Some(arc) = a.arc else { return Ok(None) };
    let turn = if spec.starts_with("sim:") {
        SimRig::from_spec(spec)
            .with_context(|| format!("--rig {spec:?}"))?
            .turn()
    } else {
        Angle::ZERO
    };
    Ok(Some(ArcReport { arc, turn }))
}

/// Active - uniform at one checkpoint of `aibr eval --turns`, one figure per turn and
/// measure, dB (`None` where a turn has no such figure: no common angle, or no novel view on
/// the `--arc`).
struct Lead {
    /// The checkpoint's view count.
    views: usize,
    /// Mean masked PSNR.
    mean: Vec<Option<f64>>,
    /// Pooled masked PSNR.
    pooled: Vec<Option<f64>>,
    /// Mean masked PSNR over the angles neither strategy captured.
    common: Vec<Option<f64>>,
    /// Mean masked PSNR of the novel views on the `--arc`, and of the others.
    inside: Vec<Option<f64>>,
    outside: Vec<Option<f64>>,
}

/// The figures of a lead over the turns that have one: mean, standard error of the mean
/// (sample standard deviation over the square root of their number; none for one turn), least,
/// greatest, and at how many turns active is ahead.
struct OverTurns {
    mean: f64,
    error: Option<f64>,
    min: f64,
    max: f64,
    ahead: usize,
    turns: usize,
}

impl OverTurns {
    fn of(by_turn: &[Option<f64>]) -> Option<Self> {
        let xs: Vec<f64> = by_turn.iter().flatten().copied().collect();
        let n = xs.len();
        if n == 0 {
            return None;
        }
        let mean = xs.iter().sum::<f64>() / n as f64;
        let error = (n > 1).then(|| {
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            (var / n as f64).sqrt()
        });
        Some(OverTurns {
            mean,
            error,
            min: xs.iter().copied().fold(f64::INFINITY, f64::min),
            max: xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            ahead: xs.iter().filter(|&&x| x > 0.0).count(),
            turns: n,
        })
    }

    fn json(by_turn: &[Option<f64>]) -> serde_json::Value {
        let over = Self::of(by_turn);
        serde_json::json!({
            "by_turn": by_turn,
            "mean": over.as_ref().map(|o| o.mean),
            "standard_error": over.as_ref().and_then(|o| o.error),
            "min": over.as_ref().map(|o| o.min),
            "max": over.as_ref().map(|o| o.max),
            "turns_ahead": over.as_ref().map(|o| o.ahead),
        })
    }
}

/// `aibr eval --turns`: the evaluation once per turn of the scene, then active - uniform
/// over the turns.
fn eval_turns(a: &EvalArgs, given: &Given<'_>, turns: &[f64]) -> Result<()> {
    let scene = match a.rig.strip_prefix("sim:") {
        Some(scene) if !scene.contains('@') => scene,
        _ => bail!(
            "--turns {turns:?}: needs an unturned synthetic rig (--rig sim:SCENE), not {:?}",
            a.rig
        ),
    };
    // Unturned, the plain rig, so that its sessions are those of `--rig sim:SCENE`.
    let specs: Vec<String> = turns
        .iter()
        .map(|&turn| {
            if turn == 0.0 {
                format!("sim:{scene}")
            } else {
                format!("sim:{scene}@{turn}")
            }
        })
        .collect();
    // Every turn checked before the first evaluation starts.
    for spec in &specs {
        aibr::SimRig::from_spec(spec).with_context(|| format!("--turns: {spec:?}"))?;
    }
    let mut runs = Vec::new();
    for (&turn, spec) in turns.iter().zip(specs) {
        let results = run_eval(a, given, &spec, &a.work.join(format!("turn{turn}")))?;
        if !a.json {
            println!("{spec}");
            print_eval_table(&results, arc_report(a, &spec)?.as_ref());
            println!();
        }
        runs.push((turn, spec, results));
    }
    // Active - uniform at each checkpoint, one figure per turn (every turn ran the same
    // strategies and checkpoints; without both strategies there is no lead).
    let mut leads: Vec<Lead> = Vec::new();
    for (_, spec, results) in &runs {
        let of = |s: Strategy| results.iter().find(|r| r.strategy == s);
        let (Some(active), Some(uniform)) = (of(Strategy::Active), of(Strategy::Uniform)) else {
            continue;
        };
        let arc = arc_report(a, spec)?;
        for (k, (x, y)) in active
            .checkpoints
            .iter()
            .zip(&uniform.checkpoints)
            .enumerate()
        {
            if leads.len() <= k {
                leads.push(Lead {
                    views: x.views,
                    mean: Vec::new(),
                    pooled: Vec::new(),
                    common: Vec::new(),
                    inside: Vec::new(),
                    outside: Vec::new(),
                });
            }
            let lead = &mut leads[k];
            let minus = |p: Option<f64>, q: Option<f64>| Some(p? - q?);
            lead.mean.push(Some(x.mean_psnr - y.mean_psnr));
            lead.pooled.push(Some(x.pooled_psnr - y.pooled_psnr));
            lead.common.push(minus(
                x.common.map(|c| c.mean_psnr),
                y.common.map(|c| c.mean_psnr),
            ));
            if let Some(r) = &arc {
                let (sx, sy) = (x.split(&r.arc, r.turn), y.split(&r.arc, r.turn));
                let side = |f: Option<aibr::ViewFigures>| f.map(|f| f.mean_psnr);
                lead.inside.push(minus(side(sx.inside), side(sy.inside)));
                lead.outside.push(minus(side(sx.outside), side(sy.outside)));
            }
        }
    }
    if a.json {
        let turns: Vec<_> = runs
            .iter()
            .map(|(turn, spec, results)| {
                let arc = arc_report(a, spec)?;
                Ok(serde_json::json!({
                    "turn_deg": turn,
                    "rig": spec,
                    "results": results_json(results, arc.as_ref()),
                }))
            })
            .collect::<Result<_>>()?;
        let summary: Vec<_> = leads
            .iter()
            .map(|lead| {
                let mut s = serde_json::json!({
                    "views": lead.views,
                    "mean_masked_psnr_db": OverTurns::json(&lead.mean),
                    "pooled_masked_psnr_db": OverTurns::json(&lead.pooled),
                    "common_angles_mean_masked_psnr_db": OverTurns::json(&lead.common),
                });
                if a.arc.is_some() {
                    s["arc_inside_mean_masked_psnr_db"] = OverTurns::json(&lead.inside);
                    s["arc_outside_mean_masked_psnr_db"] = OverTurns::json(&lead.outside);
                }
                s
            })
            .collect();
        let mut out = serde_json::json!({
            "rig": a.rig,
            "model": eval_model(a.model).name(),
            "turns": turns,
            "active_minus_uniform": summary,
        });
        a.refine.record(&mut out);
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else if !leads.is_empty() {
        println!("active - uniform, mean masked PSNR (dB), by turn of the scene (degrees)");
        let mut header = format!("{:>5} {:<8}", "views", "over");
        for (turn, _, _) in &runs {
            header += &format!(" {:>7}", turn);
        }
        println!(
            "{header} {:>7} {:>7} {:>7} {:>7} {:>7}",
            "mean", "s.e.", "min", "max", "ahead"
        );
        for lead in &leads {
            let mut rows = vec![("all", &lead.mean), ("common", &lead.common)];
            if a.arc.is_some() {
                rows.push(("on arc", &lead.inside));
                rows.push(("off arc", &lead.outside));
            }
            for (over, by_turn) in rows {
                let mut line = format!("{:>5} {over:<8}", lead.views);
                for d in by_turn {
                    line += &d.map_or_else(|| format!(" {:>7}", "-"), |d| format!(" {d:>+7.2}"));
                }
                let Some(o) = OverTurns::of(by_turn) else {
                    println!("{line}");
                    continue;
                };
                let error = o
                    .error
                    .map_or_else(|| format!("{:>7}", "-"), |e| format!("{e:>7.2}"));
                let ahead = format!("{}/{}", o.ahead, o.turns);
                // The extremes to a thousandth, since they are read against bounds such as
                // "no worse than 0.2 dB", and a lead of -0.2047 reads -0.20 to two decimals.
                println!(
                    "{line} {:>+7.2} {error} {:>+7.3} {:>+7.3} {ahead:>7}",
                    o.mean, o.min, o.max
                );
            }
        }
    }
    Ok(())
}

/// The JSON of an evaluation's results: per strategy, its checkpoints.
fn results_json(results: &[aibr::StrategyEval], arc: Option<&ArcReport>) -> Vec<serde_json::Value> {
    results
        .iter()
        .map(|r| {
            let checkpoints: Vec<_> = r
                .checkpoints
                .iter()
                .map(|c| checkpoint_json(c, arc))
                .collect();
            serde_json::json!({
                "strategy": r.strategy.name(),
                "served_faces_first": r.served_faces_first,
                "initial_contrast": r.initial_contrast,
                "checkpoints": checkpoints,
            })
        })
        .collect()
}

/// The JSON of one checkpoint; with `arc`, its figures on and off the arc too.
fn checkpoint_json(c: &aibr::Checkpoint, arc: Option<&ArcReport>) -> serde_json::Value {
    let figures = |f: Option<aibr::ViewFigures>| {
        f.map(|k| {
            serde_json::json!({
                "angles": k.angles,
                "mean_masked_psnr_db": k.mean_psnr,
                "pooled_masked_psnr_db": k.pooled_psnr,
                "mean_masked_ssim": k.mean_ssim,
            })
        })
    };
    let mut checkpoint = serde_json::json!({
        "views": c.views,
        "evaluated_views": c.evaluated,
        "mean_masked_psnr_db": c.mean_psnr,
        "pooled_masked_psnr_db": c.pooled_psnr,
        "mean_masked_ssim": c.mean_ssim,
        "worst_arc_psnr_db": c.worst_arc_psnr,
        "worst_arc_deg": [c.worst_arc.0.degrees(), c.worst_arc.1.degrees()],
        "pans_deg": c.pans.iter().map(|p| p.degrees()).collect::<Vec<_>>(),
        "geometry": c.geometry.map(|g| serde_json::json!({
            "accuracy_voxels": g.accuracy_voxels,
            "completeness": g.completeness,
            "surface_voxels": g.surface_voxels,
        })),
        "common_angles": figures(c.common),
        "novel_views": c.novel.iter().map(|v| serde_json::json!({
            "pan_deg": v.pan.degrees(),
            "masked_psnr_db": v.psnr,
            "masked_ssim": v.ssim,
        })).collect::<Vec<_>>(),
    });
    if let Some(m) = c.mirrors {
        let tally = |t: aibr::render::MirrorTally| {
            serde_json::json!({
                "surface_voxels": t.surface,
                "passed": t.passed,
                "mirrors": t.mirrors,
            })
        };
        checkpoint["mirrors"] = serde_json::json!({
            "model": tally(m.model),
            "visual_hull": m.hull.map(tally),
        });
    }
    if let Some(r) = arc {
        let split = c.split(&r.arc, r.turn);
        checkpoint["arc"] = serde_json::json!({
            "from_deg": r.arc.from.degrees(),
            "to_deg": r.arc.to.degrees(),
            "scene_turn_deg": r.turn.degrees(),
            "captured_on_arc": split.captured_inside,
            "on_arc": figures(split.inside),
            "off_arc": figures(split.outside),
        });
    }
    checkpoint
}

/// The short table of an evaluation: one line per strategy and checkpoint.
fn print_eval_table(results: &[aibr::StrategyEval], arc: Option<&ArcReport>) {
    // With --arc, a column of the mean PSNR on and off the arc, and the captured views on it.
    let arc_header = arc.map_or(String::new(), |r| {
        format!(
            " {:>24}",
            format!(
                "{:.0}:{:.0} on / off / n",
                r.arc.from.degrees(),
                r.arc.to.degrees()
            )
        )
    });
    println!(
        "{:<8} {:>5} {:>12} {:>14} {:>8} {:>16} {:>20} {:>18}{arc_header}",
        "strategy",
        "views",
        "PSNR (dB)",
        "pooled (dB)",
        "SSIM",
        "worst arc (dB)",
        "geometry (vox / %)",
        "common (dB / n)"
    );
    for r in results {
        for c in &r.checkpoints {
            // Accuracy (voxels) and completeness of the model, where the rig knows the truth.
            let geometry = c.geometry.map_or("-".to_string(), |g| {
                format!("{:.2} / {:.1}", g.accuracy_voxels, 100.0 * g.completeness)
            });
            // The mean over the angles no strategy captured, and how many there are.
            let common = c.common.map_or("-".to_string(), |k| {
                format!("{:.2} / {}", k.mean_psnr, k.angles)
            });
            let on_arc = arc.map_or(String::new(), |r| {
                let split = c.split(&r.arc, r.turn);
                let mean = |f: Option<aibr::ViewFigures>| {
                    f.map_or("-".to_string(), |f| format!("{:.2}", f.mean_psnr))
                };
                format!(
                    " {:>24}",
                    format!(
                        "{} / {} / {}",
                        mean(split.inside),
                        mean(split.outside),
                        split.captured_inside
                    )
                )
            });
            println!(
                "{:<8} {:>5} {:>12.2} {:>14.2} {:>8.3} {:>16.2} {:>20} {:>18}{on_arc}",
                r.strategy.name(),
                c.views,
                c.mean_psnr,
                c.pooled_psnr,
                c.mean_ssim,
                c.worst_arc_psnr,
                geometry,
                common
            );
        }
    }
}

fn criterion(c: CriterionArg) -> Criterion {
    match c {
        CriterionArg::Angular => Criterion::angular(),
        CriterionArg::Classic => Criterion::classic(),
    }
}

fn reconstruct(a: ReconstructArgs, given: &Given<'_>) -> Result<()> {
    let session = Session::open(&a.session)?;
    let start = std::time::Instant::now();
    let views = session.load_views()?;
    if let Some(option) = given.first(&["criterion", "behind_hull", "sample_inset", "column_test"])
    {
        if let Some(why) = aibr::why_not_voxel_coloring(&views, &session.volume()?, a.grid)? {
            bail!(
                "{option} is for voxel coloring, which cannot reconstruct {}: {why} (run without \
                 {option}: space carving takes none of voxel coloring's options)",
                a.session.display()
            );
        }
    }
    let mut coloring = ColoringParams {
        criterion: criterion(a.criterion),
        ..ColoringParams::default()
    };
    if let Some(BehindHull(b)) = a.behind_hull {
        coloring.behind_hull = b;
    }
    if let Some(inset) = a.sample_inset {
        coloring.sample_inset = inset;
    }
    if a.column_test {
        coloring.column_test = Some(ColumnTest::default());
    }
    let (rec, algorithm, refined) = if a.refine_tops {
        let (rec, algorithm, stats) = aibr::reconstruct_refined(
            &session,
            &views,
            a.grid,
            &coloring,
            &TopRefinement {
                walls: a.walls,
                ..TopRefinement::default()
            },
        )?;
        (rec, algorithm, Some(stats))
    } else {
        let (rec, algorithm) = aibr::reconstruct_loaded(&session, &views, a.grid, &coloring)?;
        (rec, algorithm, None)
    };
    let coloring_ms = start.elapsed().as_secs_f64() * 1e3;
    let mut bytes = Vec::new();
    write_ply(
        &rec.model,
        &mut bytes,
        &PlyOptions {
            cubes: a.cubes,
            binary: true,
        },
    )?;
    let path = session.write_output("model.ply", &bytes)?;
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "session": a.session,
                "model": path,
                "algorithm": algorithm,
                "views": session.file().views.len(),
                "grid": rec.model.grid().dims(),
                "voxels": rec.model.occupied_count(),
                "column_test": a.column_test.then(|| serde_json::json!({"sunk": rec.stats.sunk})),
                "refine_tops": refined.map(|r| serde_json::json!({
                    "tops": r.tops,
                    "judged": r.judged,
                    "moved": r.moved,
                    "lone": r.lone,
                    "cleared": r.cleared,
                    "walled": r.walled,
                })),
                "timings_ms": {"coloring_ms": coloring_ms},
            }))?
        );
    } else {
        println!(
            "{algorithm}: {} voxels from {} views -> {}",
            rec.model.occupied_count(),
            session.file().views.len(),
            path.display()
        );
        if a.column_test {
            println!(
                "column test: {} top voxels passed over for the surface below",
                rec.stats.sunk
            );
        }
        if let Some(r) = refined {
            println!(
                "tops refined: {} of {} judged tops moved down, {} voxels cleared, {} walled",
                r.moved, r.judged, r.cleared, r.walled
            );
        }
    }
    Ok(())
}

fn render(a: RenderArgs) -> Result<()> {
    check_extensions(&[
        ("-o", a.sweep.is_none().then_some(&a.output), PNG),
        ("--depth", a.depth.as_ref(), EXR),
        ("--coverage", a.coverage.as_ref(), PNG),
    ])?;
    let session = Session::open(&a.session)?;
    // Every angle is checked, and no frame may be overwritten, before the (slow) model. Each
    // target is a pan angle and the PNG it goes to.
    let (range, _) = session.turntable()?;
    let targets: Vec<(Angle, PathBuf)> = match (a.pan, a.sweep) {
        (_, Some(sweep)) => {
            let targets = sweep
                .angles()
                .enumerate()
                .map(|(i, p)| {
                    let frame = a.output.join(format!("frame_{i:04}.png"));
                    Ok((range.check(Angle::from_degrees(p))?, frame))
                })
                .collect::<Result<Vec<_>>>()
                .context("--sweep")?;
            if let Some((_, f)) = targets.iter().find(|(_, f)| f.exists()) {
                bail!(
                    "{} exists: a sweep does not overwrite frames; remove them or choose another folder",
                    f.display()
                );
            }
            std::fs::create_dir_all(&a.output)
                .with_context(|| format!("creating {}", a.output.display()))?;
            targets
        }
        (Some(pan), None) => vec![(range.check(Angle::from_degrees(pan))?, a.output.clone())],
        (None, None) => bail!("give --pan or --sweep"),
    };
    // Decoded once, for both the model and the renderer.
    let views = session.load_views()?;
    let (rec, _) = aibr::reconstruct_loaded(&session, &views, a.grid, &ColoringParams::default())?;
    let mut params = a.refine.render_params();
    if a.no_refine {
        params.refine = None;
    }
    if a.no_fill {
        params.fill = None;
    }
    let renderer = aibr::renderer_with(&views, &rec.model, params)?;
    let calibration = session.calibration()?;
    let mut view = aibr::render::RenderedView::new(calibration.camera.size);
    let bar = ProgressBar::new(targets.len() as u64);
    bar.set_style(ProgressStyle::with_template(
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} frames {msg}",
    )?);
    let mut reporter = reporter::Reporter::new(bar);
    let mut times = Vec::with_capacity(targets.len());
    for (pan, file) in &targets {
        let start = std::time::Instant::now();
        renderer.render_into(&calibration.camera_at(*pan), &mut view)?;
        times.push(start.elapsed().as_secs_f64());
        png(file, &view.rgb)?;
        reporter.bar().inc(1);
        reporter.message(format!("{:.2} deg", pan.degrees()));
    }
    reporter.finish();
    if a.sweep.is_some() {
        times.sort_by(f64::total_cmp);
        let median = times.get(times.len() / 2).copied().unwrap_or(0.0);
        println!(
            "{} frames in {} ({:.1} ms a frame to render, median)",
            targets.len(),
            a.output.display(),
            1e3 * median
        );
        return Ok(());
    }
    // One view: its extra outputs, from the buffers of its render.
    if let Some(d) = &a.depth {
        exr(d, &view.depth)?;
    }
    if let Some(c) = &a.coverage {
        png(c, &view.coverage_image())?;
    }
    let (g, f, _) = view.coverage_shares();
    println!(
        "{} ({:.1}% geometry, {:.1}% focal surface)",
        a.output.display(),
        100.0 * g,
        100.0 * f
    );
    Ok(())
}

fn scene(c: SceneCommand) -> Result<()> {
    match c {
        SceneCommand::Render {
            scene,
            pan,
            output,
            depth,
            mask,
        } => {
            check_extensions(&[
                ("-o", Some(&output), PNG),
                ("--depth", depth.as_ref(), EXR),
                ("--mask", mask.as_ref(), PNG),
            ])?;
            let s = aibr::scene::catalogue::by_name(&scene)?;
            let camera = s.camera(Angle::from_degrees(pan))?;
            let frame = s.render(&camera, &aibr::scene::RenderOptions::default())?;
            png(&output, &frame.rgb8())?;
            if let Some(d) = &depth {
                exr(d, &frame.depth)?;
            }
            if let Some(m) = &mask {
                png(m, &frame.mask)?;
            }
            println!("{}", output.display());
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// A sweep written out from its first angle, step and count parses back to that many
        /// angles, from the first to the last in equal steps.
        #[test]
        fn sweeps_round_trip(
            from in -180.0f64..180.0,
            step in prop_oneof![0.01f64..50.0, -50.0f64..-0.01],
            n in 1usize..2000,
        ) {
            let to = from + (n - 1) as f64 * step;
            let sweep = parse_sweep(&format!("{from}:{to}:{step}"));
            prop_assert!(sweep.is_ok(), "{sweep:?}");
            let angles: Vec<f64> = sweep.iter().flat_map(|s| s.angles()).collect();
            prop_assert_eq!(angles.len(), n);
            prop_assert_eq!(angles[0], from);
            prop_assert!((angles[n - 1] - to).abs() <= 1e-9 * (1.0 + to.abs()));
        }

        /// Any text gives a sweep or an error that quotes it, never a panic.
        #[test]
        fn any_text_parses_or_is_refused(text in "[-0-9.:einfNa ]{0,24}") {
            match parse_sweep(&text) {
                Ok(sweep) => prop_assert!((1..=MAX_SWEEP_FRAMES).contains(&sweep.len())),
                Err(e) => {
                    let quoted = format!("{text:?}");
                    prop_assert!(e.starts_with(&quoted), "{} does not quote {}", e, quoted);
                }
            }
        }
    }

    #[test]
    fn a_cause_is_said_once() {
        let missing = std::path::Path::new("/nonexistent/session.json");
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = anyhow::Error::new(aibr::Error::Io {
            action: "reading",
            path: missing.into(),
            source: io,
        })
        .context("--rig \"replay:/nonexistent\"");
        assert_eq!(
            report(&e),
            "--rig \"replay:/nonexistent\": reading /nonexistent/session.json: no such file"
        );
        // A cause the message does not already give is kept.
        let e = anyhow::anyhow!("the port is busy").context("opening /dev/ttyUSB0");
        assert_eq!(report(&e), "opening /dev/ttyUSB0: the port is busy");
    }

    #[test]
    fn sweeps_parse_and_list_their_angles() {
        let angles = |text: &str| parse_sweep(text).map(|s| s.angles().collect::<Vec<_>>());
        assert_eq!(angles("20:30:5"), Ok(vec![20.0, 25.0, 30.0]));
        // TO is included only when a step lands on it, and rounding does not lose it.
        assert_eq!(angles("20:29:5"), Ok(vec![20.0, 25.0]));
        assert_eq!(angles("0:1:0.1").map(|a| a.len()), Ok(11));
        assert_eq!(angles("-10:-20:-5"), Ok(vec![-10.0, -15.0, -20.0]));
        assert_eq!(angles("7:7:1"), Ok(vec![7.0]));
    }

    #[test]
    fn bad_sweeps_name_what_is_wrong() {
        let error = |text: &str| parse_sweep(text).err().unwrap_or_default();
        assert!(error("20:30").contains("expected FROM:TO:STEP"));
        assert!(error("20:30:5:1").contains("expected FROM:TO:STEP"));
        assert!(error("a:30:5").contains("FROM \"a\""));
        assert!(error("0:inf:5").contains("TO \"inf\""));
        assert!(error("0:NaN:5").contains("TO \"NaN\""));
        assert!(error("0:30:0").contains("STEP must be non-zero"));
        assert!(error("0:30:-1").contains("turn from FROM towards TO"));
        assert!(error("0:360:0.001").contains("more than 100000"));
        assert!(error("0:1e300:1").contains("more than 100000"));
    }

    #[test]
    fn turns_are_a_list_or_a_range_and_name_their_folders_plainly() {
        let turns = |text: &str| parse_turns(text).map(|t| t.0);
        assert_eq!(turns("0,10,-20"), Ok(vec![0.0, 10.0, -20.0]));
        assert_eq!(turns("5"), Ok(vec![5.0]));
        assert_eq!(turns("0:27.5:2.5").map(|t| t.len()), Ok(12));
        assert_eq!(turns("0:27.5:2.5").map(|t| t[11]), Ok(27.5));
        // Computed from FROM and rounded, so the folders read turn0.1, turn0.2, turn0.3.
        let tenths = turns("0:0.3:0.1").unwrap_or_default();
        let names: Vec<String> = tenths.iter().map(|t| format!("turn{t}")).collect();
        assert_eq!(names, ["turn0", "turn0.1", "turn0.2", "turn0.3"]);
        let error = |text: &str| parse_turns(text).err().unwrap_or_default();
        assert!(error("0,ten").contains("turn \"ten\""));
        assert!(error("0:10").contains("expected a list"));
        assert!(error("10:0:5").contains("TO at least FROM"));
        assert!(error("0:10:0").contains("STEP must be positive"));
        assert!(error("0:360:0.5").contains("more than 360"));
        assert!(error("0,10,0").contains("turn 0 is given twice (turn 3)"));
    }
}
