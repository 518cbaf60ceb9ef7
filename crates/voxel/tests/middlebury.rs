//! Real data: the Middlebury sparse rings in `AIBR_DATA_DIR`, brought into the turntable
//! frame by the ring fit of aibr-camera, with silhouettes by thresholding (the dino's README
//! recipe for the dino; for the temple, whose README has none, a higher threshold and only
//! the largest region of the thresholded pixels, which drops lit parts of the gantry). The
//! dino lies below the camera ring, so voxel coloring applies; the temple's box reaches above
//! it, so voxel coloring must refuse and space carving must reconstruct it.
//!
//! Print the figures with
//! `cargo test --release -p aibr-voxel --test middlebury -- --nocapture`.

use std::path::Path;

use aibr_camera::readers::read_middlebury_par;
use aibr_camera::{Aabb, Angle, Camera, ImageSize, fit_ring};
use aibr_voxel::foreground::{DarkBackground, clip_to_volume, dark_background_mask};
use aibr_voxel::metrics::silhouette_agreement;
use aibr_voxel::{
    CarvingParams, ColoringParams, ColumnTest, Criterion, Error, Reconstruction, TopRefinement,
    View, VoxelGrid, refine_tops, space_carving, visual_hull, voxel_coloring,
};
use image::{GrayImage, RgbImage};
use nalgebra::Point3;

/// Margin around the READMEs' tight boxes, metres (the grids and the silhouette clipping).
const MARGIN: f64 = 0.003;

/// The temple's silhouettes. Its README gives no recipe (the dino's gives 0.19, dilate 10,
/// erode 7), and the dino's threshold does not fit it: the black cloth of the gantry beside
/// the temple has lit folds whose brightest channel lies at 41-63 (median 52) where it
/// touches the temple's left end in templeSR0002, just over 0.19's 48, so they join the
/// temple's region, and no other view's silhouette holds them (the visual hull then covers
/// only 94.9% of that view). At 0.22 (56) the folds go and the temple's lit plaster, far
/// brighter, stays; the closing mends its shadowed rim. Only the largest thresholded region
/// is kept, before the closing, because lit parts of the gantry that do not touch the temple
/// pass any such threshold and the closing would join them to it. Figures for 0.19 to 0.25:
/// `docs/results.md`, "Voxel coloring on real data".
const TEMPLE_SILHOUETTES: DarkBackground = DarkBackground {
    threshold: 0.22,
    dilate_px: 10,
    erode_px: 7,
    largest_component: true,
};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// Real images carry lighting and sensor differences the synthetic scenes do not: these sets
/// are reconstructed with more lenient thresholds than the defaults (tuned on the
/// synthetic catalogue).
fn real_data_criterion(threshold: f32) -> Criterion {
    Criterion::Angular {
        threshold,
        window: Angle::from_degrees(45.0),
    }
}

struct Dataset {
    cameras: Vec<Camera>,
    images: Vec<RgbImage>,
    masks: Vec<GrayImage>,
    names: Vec<String>,
    volume: Aabb,
}

/// Loads a ring data set in the turntable frame; `box_min`/`box_max` are the README's
/// bounding box in the data set's own frame.
fn load(
    dir: &Path,
    par: &str,
    box_min: [f64; 3],
    box_max: [f64; 3],
    silhouettes: &DarkBackground,
) -> Result<Dataset, Box<dyn std::error::Error>> {
    let views = read_middlebury_par(dir.join(par))?;
    let poses: Vec<_> = views.iter().map(|v| v.cam_from_world).collect();
    let ring = fit_ring(&poses)?;
    // The README's box, in the turntable frame: the box around its eight corners, with the
    // margin the tests' grids add.
    let b = Aabb::new(Point3::from(box_min), Point3::from(box_max))?;
    let volume = Aabb::around(b.corners().iter().map(|c| ring.turntable_from_world * c))
        .ok_or("empty box")?
        .expanded(MARGIN);
    let mut cameras = Vec::new();
    let mut images = Vec::new();
    let mut masks = Vec::new();
    for v in &views {
        let image = image::open(dir.join(&v.image))?.to_rgb8();
        let size = ImageSize::new(image.width(), image.height());
        let camera = v
            .camera(size)?
            .with_pose(ring.to_turntable(&v.cam_from_world));
        // Thresholding also marks lit parts of the gantry beside the temple; the object is
        // inside its box, so the silhouette is too.
        let mut mask = dark_background_mask(&image, silhouettes);
        clip_to_volume(&mut mask, &camera, &volume)?;
        masks.push(mask);
        cameras.push(camera);
        images.push(image);
    }
    Ok(Dataset {
        cameras,
        images,
        masks,
        names: views.iter().map(|v| v.image.clone()).collect(),
        volume,
    })
}

impl Dataset {
    fn views(&self) -> Vec<View<'_>> {
        self.cameras
            .iter()
            .zip(&self.images)
            .zip(&self.masks)
            .map(|((camera, image), mask)| View {
                camera,
                image,
                mask: Some(mask),
            })
            .collect()
    }

    /// Per view: coverage and spill of the model's projection against the silhouette.
    fn agreement(&self, out: &Reconstruction, only: Option<&[String]>) -> (f64, f64, f64) {
        let (mut worst_cov, mut sum_cov, mut worst_spill, mut n) = (1.0f64, 0.0, 0.0f64, 0);
        for (i, camera) in self.cameras.iter().enumerate() {
            if only.is_some_and(|o| !o.contains(&self.names[i])) {
                continue;
            }
            let depth = out.model.depth_map(camera);
            let a = silhouette_agreement(&depth, &self.masks[i]);
            worst_cov = worst_cov.min(a.coverage);
            worst_spill = worst_spill.max(a.spill);
            sum_cov += a.coverage;
            n += 1;
        }
        (worst_cov, sum_cov / n.max(1) as f64, worst_spill)
    }
}

#[test]
fn dino_by_voxel_coloring() -> TestResult {
    let Some(dir) = aibr_testdata::dataset("middlebury-dinoSparseRing") else {
        return Ok(());
    };
    let data = load(
        &dir,
        "dinoSR_par.txt",
        [-0.061897, -0.018874, -0.057845],
        [0.010897, 0.068227, 0.015495],
        &DarkBackground::default(),
    )?;
    let good: Vec<String> = std::fs::read_to_string(dir.join("dinoSR_good_silhouette_images.txt"))?
        .lines()
        .map(|l| l.trim().to_owned())
        .filter(|l| !l.is_empty())
        .collect();
    let grid = VoxelGrid::with_resolution(data.volume, 128)?;
    let start = std::time::Instant::now();
    let params = ColoringParams {
        criterion: real_data_criterion(30.0),
        ..ColoringParams::default()
    };
    let out = voxel_coloring(&grid, &data.views(), &params)?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let (worst, mean, spill) = data.agreement(&out, Some(&good));
    eprintln!(
        "dinoSparseRing, voxel coloring 128^3, 16 views ({ms:.0} ms): {} voxels; silhouette coverage \
         mean {:.1}%, worst {:.1}%; worst spill {:.1}% (over the {} good-silhouette views)",
        out.model.occupied_count(),
        100.0 * mean,
        100.0 * worst,
        100.0 * spill,
        good.len()
    );
    assert!(worst >= 0.95, "coverage {worst}");
    assert!(spill <= 0.10, "spill {spill}");
    // The tops refined with their steps walled keep the coverage: without the walls the
    // pits the pass digs where the sweep's fillets stood leave the worst view at 93%
    // (docs/voxel.md, "Walls for the steps").
    let mut refined = out;
    let walls = TopRefinement {
        walls: true,
        ..TopRefinement::default()
    };
    let stats = refine_tops(&mut refined.model, &data.views(), &walls)?;
    let (worst, mean, spill) = data.agreement(&refined, Some(&good));
    eprintln!(
        "  tops refined, steps walled ({stats:?}): coverage mean {:.1}%, worst {:.1}%; worst \
         spill {:.1}%",
        100.0 * mean,
        100.0 * worst,
        100.0 * spill
    );
    assert!(stats.moved > 0 && stats.walled > 0, "{stats:?}");
    assert!(worst >= 0.95, "coverage {worst}");
    assert!(spill <= 0.10, "spill {spill}");
    // The column test: the floating tops are passed over during the sweep, which then
    // reconstructs what lies below them.
    let column = ColoringParams {
        column_test: Some(ColumnTest::default()),
        ..params
    };
    let out = voxel_coloring(&grid, &data.views(), &column)?;
    let (worst, mean, spill) = data.agreement(&out, Some(&good));
    eprintln!(
        "  with the column test ({:?}): coverage mean {:.1}%, worst {:.1}%; worst spill {:.1}%",
        out.stats,
        100.0 * mean,
        100.0 * worst,
        100.0 * spill
    );
    assert!(out.stats.sunk > 0, "{:?}", out.stats);
    assert!(worst >= 0.95, "coverage {worst}");
    assert!(spill <= 0.10, "spill {spill}");
    Ok(())
}

#[test]
fn temple_refused_by_voxel_coloring_carved_by_space_carving() -> TestResult {
    let Some(dir) = aibr_testdata::dataset("middlebury-templeSparseRing") else {
        return Ok(());
    };
    let data = load(
        &dir,
        "templeSR_par.txt",
        [-0.073568, 0.021728, -0.012445],
        [0.028855, 0.181892, 0.062736],
        &TEMPLE_SILHOUETTES,
    )?;
    let grid = VoxelGrid::with_resolution(data.volume, 128)?;
    let top = grid.bounds().max.z;
    let highest = data
        .cameras
        .iter()
        .map(|c| c.centre().z)
        .fold(f64::NEG_INFINITY, f64::max);
    eprintln!("templeSparseRing: box top {top:.4} m, camera ring at {highest:.4} m");
    match voxel_coloring(&grid, &data.views(), &ColoringParams::default()) {
        Err(e @ Error::CameraNotAbove { .. }) => eprintln!("voxel coloring refuses: {e}"),
        other => panic!(
            "voxel coloring should refuse the temple, got {:?}",
            other.map(|o| o.stats)
        ),
    }
    let start = std::time::Instant::now();
    // The carving defaults (60 grey levels within 45 degrees) suit the real images as they are.
    let out = space_carving(&grid, &data.views(), &CarvingParams::default())?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let (worst, mean, spill) = data.agreement(&out, None);
    eprintln!(
        "templeSparseRing, space carving 128^3, 16 views ({ms:.0} ms): {} voxels; silhouette \
         coverage mean {:.1}%, worst {:.1}%; worst spill {:.1}%",
        out.model.occupied_count(),
        100.0 * mean,
        100.0 * worst,
        100.0 * spill
    );
    // No model that respects every silhouette covers more of a view's silhouette than the
    // visual hull does, so the hull's figure beside each view tells whether a shortfall is
    // the carving's or the silhouettes' (where they disagree with each other).
    let hull = visual_hull(&grid, &data.views())?;
    for (i, camera) in data.cameras.iter().enumerate() {
        let carved = silhouette_agreement(&out.model.depth_map(camera), &data.masks[i]);
        let bound = silhouette_agreement(&hull.depth_map(camera), &data.masks[i]);
        eprintln!(
            "  {}: coverage {:.1}% (visual hull {:.1}%), spill {:.1}%",
            data.names[i],
            100.0 * carved.coverage,
            100.0 * bound.coverage,
            100.0 * carved.spill
        );
    }
    // The targets, in every view.
    assert!(worst >= 0.95, "coverage {worst}");
    assert!(spill <= 0.10, "spill {spill}");
    Ok(())
}
