//! Masked PSNR of novel views half-way between uniform captures, for catalogue scenes.
//!
//! `cargo run --release -p aibr-render --example render_quality -- [SCENE...]`
//! (default: every catalogue scene; 12, 24 and 48 views; 128^3 models). Writes a render
//! beside its ground truth for each scene to the temporary folder.
//!
//! Environment: `VIEWS=12,24` chooses the view counts; `K`, `RES` and `OCC` set the
//! renderer's `k`, `resolution_weight` and `occlusion_tolerance_voxels`; `TRUEMODEL=1` renders from the true scene voxelised at 128^3
//! instead of the reconstruction, to separate geometry error from rendering error;
//! `CRITERION=classic:T` or `CRITERION=angular:T:W` (grey levels, degrees) replaces voxel
//! coloring's default criterion.
//! `REFINE=0` turns the renderer's depth refinement off, `REFINE=front:back:steps:radius`
//! sets it (voxels, voxels, depths, pixels), `REFINE=front:back:steps:radius:penalty` also its
//! penalty on depths beyond 4 voxels ([`aibr_render::DepthRefinement::penalty`]). `FILL=0` renders from the model as given instead
//! of closed and filled, `FILL=N` closes it with a cube of `2N + 1` voxels
//! ([`RenderParams::fill`]). `TOPS=1` runs [`aibr_voxel::refine_tops`] on the model first,
//! `TOPS=walls` the same with its steps walled ([`aibr_voxel::TopRefinement::walls`]).
//! `GRID=N` reconstructs on an `N`^3 grid instead of 128^3. `COLUMN=1` reconstructs with
//! voxel coloring's column test ([`aibr_voxel::ColumnTest`], its defaults).
//! `EDGES=1` adds a second table that says where the squared error of the half-way views lies
//! ([`ErrorSplit`]): in the band of 2 pixels inside the true silhouette or in the interior;
//! how much of the interior's lies in the few pixels off by more than 20 grey levels, and how
//! much near the folds and steps of the true surface (edges of faces, occlusion edges); and,
//! where the masked PSNR does not look, the ring of 2 pixels outside the true silhouette.
//! `AT=f` renders the novel views a fraction `f` of the way from each capture to the next
//! (default 0.5, half-way). `REFLECT=1` turns on [`RenderParams::reflections`] (its
//! defaults), with the mirrors the model lacks taken from the masks' visual hull
//! ([`Renderer::with_visual_hull`]); `REFLECT=model` without them. `SPECULAR=g` sets their
//! `specular_rms` (grey levels; only with `REFLECT`). `SAMPLING=bicubic` samples the sources
//! bicubically ([`aibr_render::Sampling`]; `SAMPLING=bilinear`, the default, bilinearly).

use aibr_camera::Angle;
use aibr_render::{RenderParams, Renderer, Sampling, SourceView, metrics};
use aibr_scene::{Frame, RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, ColumnTest, Criterion, View, VoxelGrid, voxel_coloring};
use image::GenericImage;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let names: Vec<String> = if args.is_empty() {
        catalogue::SCENE_NAMES
            .iter()
            .map(|s| s.to_string())
            .collect()
    } else {
        args
    };
    let counts: Vec<usize> = std::env::var("VIEWS")
        .ok()
        .map(|v| v.split(',').filter_map(|n| n.parse().ok()).collect())
        .unwrap_or(vec![12, 24, 48]);
    println!(
        "| scene | views | masked PSNR, half-way views (mean) | worst | masked SSIM (mean) | geometry coverage |"
    );
    println!("|---|---|---|---|---|---|");
    let edges = std::env::var("EDGES").is_ok_and(|e| e == "1");
    let at: f64 = match std::env::var("AT") {
        Ok(f) => f.parse()?,
        Err(_) => 0.5,
    };
    let mut splits = Vec::new();
    for name in &names {
        let scene = catalogue::by_name(name)?;
        let options = RenderOptions {
            noise_sigma: 1.0 / 255.0,
            seed: 1,
        };
        for &n in &counts {
            let pans = scene.rig.uniform_pans(n);
            let shots = scene.shoot(&pans, &options)?;
            let views: Vec<View<'_>> = shots
                .iter()
                .map(|s| View {
                    camera: &s.camera,
                    image: &s.image,
                    mask: Some(&s.frame.mask),
                })
                .collect();
            let resolution = match std::env::var("GRID") {
                Ok(n) => n.parse()?,
                Err(_) => 128,
            };
            let grid = VoxelGrid::with_resolution(scene.bounds(), resolution)?;
            let coloring = ColoringParams {
                criterion: criterion()?,
                column_test: std::env::var("COLUMN")
                    .is_ok_and(|c| c == "1")
                    .then(ColumnTest::default),
                ..ColoringParams::default()
            };
            let mut model = voxel_coloring(&grid, &views, &coloring)?.model;
            match std::env::var("TOPS").as_deref() {
                Ok("1") => {
                    aibr_voxel::refine_tops(&mut model, &views, &Default::default())?;
                }
                Ok("walls") => {
                    let walls = aibr_voxel::TopRefinement {
                        walls: true,
                        ..Default::default()
                    };
                    aibr_voxel::refine_tops(&mut model, &views, &walls)?;
                }
                Ok(other) => return Err(format!("TOPS={other}: expected 1 or walls").into()),
                Err(_) => {}
            }
            if std::env::var("TRUEMODEL").is_ok() {
                // Diagnostic: the true scene voxelised (centre inside an object).
                model = aibr_voxel::VoxelModel::from_centres(grid, |p| scene.inside(p, 0.0));
            }
            let sources = shots
                .iter()
                .map(|s| SourceView {
                    camera: s.camera.clone(),
                    image: s.image.clone(),
                })
                .collect();
            let mut params = RenderParams::default();
            let reflect = std::env::var("REFLECT").ok();
            if let Some(r) = &reflect {
                params.reflections = match r.as_str() {
                    "1" | "model" => Some(Default::default()),
                    "0" => None,
                    other => return Err(format!("REFLECT={other}: expected 0, 1 or model").into()),
                };
            }
            if let Ok(g) = std::env::var("SPECULAR") {
                let Some(r) = &mut params.reflections else {
                    return Err(format!("SPECULAR={g} needs REFLECT=1 or REFLECT=model").into());
                };
                r.specular_rms = g.parse().map_err(|e| format!("SPECULAR={g}: {e}"))?;
            }
            if let Ok(sampling) = std::env::var("SAMPLING") {
                params.sampling = match sampling.as_str() {
                    "bilinear" => Sampling::Bilinear,
                    "bicubic" => Sampling::Bicubic,
                    other => {
                        return Err(
                            format!("SAMPLING={other}: expected bilinear or bicubic").into()
                        );
                    }
                };
            }
            if let Some(k) = std::env::var("K").ok().and_then(|k| k.parse().ok()) {
                params.k = k;
            }
            if let Some(r) = std::env::var("RES").ok().and_then(|k| k.parse().ok()) {
                params.resolution_weight = r;
            }
            if let Ok(occ) = std::env::var("OCC") {
                params.occlusion_tolerance_voxels = occ.parse()?;
            }
            if let Ok(spec) = std::env::var("REFINE") {
                params.refine = refinement(&spec)?;
            }
            if let Ok(fill) = std::env::var("FILL") {
                params.fill = match fill.parse()? {
                    0 => None,
                    n => Some(n),
                };
            }
            let mut renderer = Renderer::new(&model, sources, params)?;
            if reflect.as_deref() == Some("1") {
                renderer = renderer.with_visual_hull(&aibr_voxel::visual_hull(&grid, &views)?)?;
            }
            let (mut sum, mut worst, mut ssim_sum, mut geo, mut m) =
                (0.0, f64::INFINITY, 0.0, 0.0, 0);
            let mut split = edges.then(ErrorSplit::default);
            for (i, pair) in pans.windows(2).enumerate() {
                let camera = scene.camera(pair[0] + (pair[1] - pair[0]) * at)?;
                let truth = scene.render(&camera, &RenderOptions::default())?;
                let view = renderer.render(&camera)?;
                let truth8 = truth.rgb8();
                let p = metrics::psnr(&truth8, &view.rgb, Some(&truth.mask))?;
                if let Some(split) = split.as_mut() {
                    split.add(&truth, &truth8, &view);
                }
                ssim_sum += metrics::ssim(&truth8, &view.rgb, Some(&truth.mask))?;
                geo += view.coverage_shares().0;
                sum += p;
                worst = worst.min(p);
                m += 1;
                if i == n / 2 {
                    let mut sheet = image::RgbImage::new(1280, 480);
                    sheet.copy_from(&truth8, 0, 0)?;
                    sheet.copy_from(&view.rgb, 640, 0)?;
                    sheet.save(std::env::temp_dir().join(format!("render_{name}_{n}.png")))?;
                }
            }
            println!(
                "| {name} | {n} | {:.2} dB | {worst:.2} dB | {:.3} | {:.1}% |",
                sum / m as f64,
                ssim_sum / m as f64,
                100.0 * geo / m as f64
            );
            splits.extend(split.map(|s| (name.clone(), n, s)));
        }
    }
    if !splits.is_empty() {
        println!();
        println!(
            "| scene | views | silhouette band: share of the squared error, pooled PSNR | interior: pooled PSNR | interior pixels off by more than 20 grey levels: share of the pixels, of the interior's squared error | interior within 2 of a fold or step of the true depth: share of the pixels, of the interior's squared error | interior away from them: pooled PSNR | ring of 2 pixels outside the true silhouette: share of the image, pooled PSNR |"
        );
        println!("|---|---|---|---|---|---|---|---|");
        for (name, n, s) in &splits {
            let total = s.band.error + s.interior.error;
            println!(
                "| {name} | {n} | {:.0}%, {:.2} dB | {:.2} dB | {:.1}%, {:.0}% | {:.1}%, {:.0}% | {:.2} dB | {:.2}%, {:.2} dB |",
                100.0 * s.band.error / total,
                s.band.psnr(),
                s.interior.psnr(),
                100.0 * s.large.pixels as f64 / s.interior.pixels as f64,
                100.0 * s.large.error / s.interior.error,
                100.0 * s.folds.pixels as f64 / s.interior.pixels as f64,
                100.0 * s.folds.error / s.interior.error,
                s.away_from_folds().psnr(),
                100.0 * s.halo.pixels as f64 / s.pixels as f64,
                s.halo.psnr(),
            );
        }
    }
    Ok(())
}

/// The smallest second difference of the true depth, as a share of the depth, that
/// [`ErrorSplit`] counts as a fold or step: 0.25 mm at 0.5 m, about half a pixel's footprint
/// there. (On `lambertian` from its true geometry, shares of 0.0002 and 0.001 put 14% and 9%
/// of the interior pixels near folds, holding 65-72% of the interior's error, against 11% and
/// 66-70% with this one.)
const FOLD: f32 = 0.0005;

/// The RMS error over red, green and blue, in grey levels, above which [`ErrorSplit`] counts an
/// interior pixel as off.
const LARGE: f64 = 20.0;

/// Where the squared error of rendered views lies, summed over the views: in the band of
/// pixels within 2 (4-connected steps) of the true silhouette's outside or the image's edge,
/// or in the interior; the interior pixels off by more than [`LARGE`]; and those within 2 of a
/// fold or step of the true depth ([`FOLD`]). These are pixels inside the true silhouette, as
/// the masked PSNR takes; outside it, the ring of pixels within 2 of it (the halo a model too
/// fat paints).
#[derive(Debug, Default)]
struct ErrorSplit {
    band: Tally,
    interior: Tally,
    large: Tally,
    /// Interior pixels within 2 of a fold or step of the true depth.
    folds: Tally,
    /// The ring of pixels outside the true silhouette within 2 of it, where a model a voxel
    /// too fat paints the object.
    halo: Tally,
    /// Every pixel of every view.
    pixels: usize,
}

/// Pixels and their summed squared error (mean over the three channels).
#[derive(Debug, Default)]
struct Tally {
    pixels: usize,
    error: f64,
}

impl Tally {
    fn add(&mut self, error: f64) {
        self.pixels += 1;
        self.error += error;
    }

    /// The PSNR of the pooled mean squared error.
    fn psnr(&self) -> f64 {
        metrics::psnr_of_mse(self.error / self.pixels as f64)
    }
}

impl ErrorSplit {
    /// The interior pixels not within 2 of a fold or step.
    fn away_from_folds(&self) -> Tally {
        Tally {
            pixels: self.interior.pixels - self.folds.pixels,
            error: self.interior.error - self.folds.error,
        }
    }

    /// Adds one view: the ground truth `truth` (its colours quantised in `truth8`, its mask
    /// and depth as the scene rendered them) and the render `view` of the same camera.
    fn add(&mut self, truth: &Frame, truth8: &image::RgbImage, view: &aibr_render::RenderedView) {
        let (mask, depth) = (&truth.mask, &truth.depth);
        let (w, h) = (mask.width() as i64, mask.height() as i64);
        self.pixels += (w * h) as usize;
        let inside = |x: i64, y: i64| {
            (0..w).contains(&x) && (0..h).contains(&y) && mask.get_pixel(x as u32, y as u32)[0] != 0
        };
        let d = |x: i64, y: i64| depth.get_pixel(x as u32, y as u32)[0];
        // A fold or step: the depth's second difference along a row or a column is more than
        // `FOLD` of the depth (a crease of the surface or an occlusion edge).
        let fold = |x: i64, y: i64| {
            let z = d(x, y);
            let across = |(ax, ay): (i64, i64), (bx, by): (i64, i64)| {
                inside(ax, ay)
                    && inside(bx, by)
                    && (d(ax, ay) + d(bx, by) - 2.0 * z).abs() > FOLD * z
            };
            across((x - 1, y), (x + 1, y)) || across((x, y - 1), (x, y + 1))
        };
        let mut folds = vec![false; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                if inside(x, y) && fold(x, y) {
                    folds[(y * w + x) as usize] = true;
                }
            }
        }
        let near_fold = |(a, b): (i64, i64)| {
            (0..w).contains(&a) && (0..h).contains(&b) && folds[(b * w + a) as usize]
        };
        for (x, y, t) in truth8.enumerate_pixels() {
            let (xi, yi) = (i64::from(x), i64::from(y));
            let r = view.rgb.get_pixel(x, y);
            let error = (0..3)
                .map(|c| (f64::from(t[c]) - f64::from(r[c])).powi(2))
                .sum::<f64>()
                / 3.0;
            if !inside(xi, yi) {
                if within_two(xi, yi).any(|(a, b)| inside(a, b)) {
                    self.halo.add(error);
                }
                continue;
            }
            let band = within_two(xi, yi).any(|(a, b)| !inside(a, b));
            if band {
                self.band.add(error);
            } else {
                self.interior.add(error);
                if within_two(xi, yi).any(near_fold) {
                    self.folds.add(error);
                }
                if error > LARGE * LARGE {
                    self.large.add(error);
                }
            }
        }
    }
}

/// The pixels within 2 steps of `(x, y)` (4-connected), itself included.
fn within_two(x: i64, y: i64) -> impl Iterator<Item = (i64, i64)> {
    (-2i64..=2).flat_map(move |dy| (dy.abs() - 2..=2 - dy.abs()).map(move |dx| (x + dx, y + dy)))
}

/// The criterion `CRITERION` asks for, or the default.
fn criterion() -> Result<Criterion, Box<dyn std::error::Error>> {
    let Ok(spec) = std::env::var("CRITERION") else {
        return Ok(Criterion::default());
    };
    let parts: Vec<&str> = spec.split(':').collect();
    match parts.as_slice() {
        ["classic", t] => Ok(Criterion::Classic {
            threshold: t.parse()?,
        }),
        ["angular", t, w] => Ok(Criterion::Angular {
            threshold: t.parse()?,
            window: Angle::from_degrees(w.parse()?),
        }),
        _ => Err(format!("CRITERION={spec}: expected classic:T or angular:T:W").into()),
    }
}

/// `REFINE=0` (off), `REFINE=1` (defaults) or `REFINE=front:back:steps:radius[:penalty]`.
fn refinement(
    spec: &str,
) -> Result<Option<aibr_render::DepthRefinement>, Box<dyn std::error::Error>> {
    let parts: Vec<&str> = spec.split(':').collect();
    let custom = |[f, b, s, r]: [&str; 4], penalty: &str| {
        Ok::<_, Box<dyn std::error::Error>>(Some(aibr_render::DepthRefinement {
            front_voxels: f.parse()?,
            back_voxels: b.parse()?,
            steps: s.parse()?,
            radius: r.parse()?,
            penalty: penalty.parse()?,
            ..Default::default()
        }))
    };
    match parts.as_slice() {
        ["0"] => Ok(None),
        ["1"] => Ok(Some(aibr_render::DepthRefinement::default())),
        [f, b, s, r] => custom([f, b, s, r], "0"),
        [f, b, s, r, p] => custom([f, b, s, r], p),
        _ => {
            Err(format!("REFINE={spec}: expected 0, 1 or front:back:steps:radius[:penalty]").into())
        }
    }
}
