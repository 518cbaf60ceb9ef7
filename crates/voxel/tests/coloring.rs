//! Voxel coloring and space carving on synthetic turntable scenes with ground truth.

mod common;

use aibr_camera::{Angle, Camera, Distortion};
use aibr_scene::{Frame, RenderOptions, Scene, catalogue};
use aibr_voxel::metrics::geometry_score;
use aibr_voxel::{
    CarvingParams, ColoringParams, ColumnTest, Criterion, Error, FaceParams, PlyOptions,
    Reconstruction, TopRefinement, View, VoxelGrid, refine_tops, space_carving, visual_hull,
    voxel_coloring, voxel_coloring_reference, write_ply,
};
use common::{element_count, split_ply};
use image::{GrayImage, RgbImage};
use nalgebra::Point3;

type TestResult = Result<(), Box<dyn std::error::Error>>;

struct Capture {
    cameras: Vec<Camera>,
    frames: Vec<Frame>,
    images: Vec<RgbImage>,
}

fn capture(scene: &Scene, n: usize) -> Result<Capture, Box<dyn std::error::Error>> {
    capture_at(scene, &scene.rig.uniform_pans(n))
}

/// Views of `scene` at `pans` (the scene's pans: a turn of the object adds to them).
fn capture_at(scene: &Scene, pans: &[Angle]) -> Result<Capture, Box<dyn std::error::Error>> {
    let options = RenderOptions {
        noise_sigma: 1.0 / 255.0,
        seed: 3,
    };
    let mut cap = Capture {
        cameras: Vec::new(),
        frames: Vec::new(),
        images: Vec::new(),
    };
    for s in scene.shoot(pans, &options)? {
        cap.cameras.push(s.camera);
        cap.frames.push(s.frame);
        cap.images.push(s.image);
    }
    Ok(cap)
}

impl Capture {
    fn views(&self, masks: bool) -> Vec<View<'_>> {
        self.cameras
            .iter()
            .zip(&self.images)
            .zip(&self.frames)
            .map(|((camera, image), f)| View {
                camera,
                image,
                mask: masks.then_some(&f.mask),
            })
            .collect()
    }
}

/// Runs the fast path and the reference; asserts a model worth comparing, the same model
/// voxel for voxel and the same counts; returns the fast path's reconstruction.
fn fast_equals_reference(
    grid: &VoxelGrid,
    views: &[View<'_>],
    params: &ColoringParams,
    case: &str,
) -> Result<Reconstruction, Box<dyn std::error::Error>> {
    let fast = voxel_coloring(grid, views, params)?;
    let reference = voxel_coloring_reference(grid, views, params)?;
    assert!(fast.model.occupied_count() > 100, "{case}");
    assert!(fast.model == reference.model, "{case}");
    assert_eq!(fast.stats.tested, reference.stats.tested, "{case}");
    assert_eq!(fast.stats.kept, reference.stats.kept, "{case}");
    assert_eq!(fast.stats.sunk, reference.stats.sunk, "{case}");
    Ok(fast)
}

#[test]
fn fast_path_equals_the_reference_voxel_for_voxel() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 12)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 40)?;
    for masks in [true, false] {
        for criterion in [Criterion::angular(), Criterion::classic()] {
            for visible_only in [true, false] {
                let mut models = Vec::new();
                for behind_hull in [Some(-0.3), None] {
                    let params = ColoringParams {
                        criterion,
                        visible_only,
                        behind_hull,
                        ..ColoringParams::default()
                    };
                    let case = format!(
                        "masks {masks}, {criterion:?}, visible_only {visible_only}, \
                         behind_hull {behind_hull:?}"
                    );
                    models.push(
                        fast_equals_reference(&grid, &cap.views(masks), &params, &case)?.model,
                    );
                }
                // The views behind the hull are left out only where there is a hull, and
                // then they change the model: the comparison above tests that path too.
                assert_eq!(
                    models[0] != models[1],
                    masks,
                    "{criterion:?} {visible_only}"
                );
            }
        }
    }
    Ok(())
}

/// More than 64 views: the fast path's per-voxel flags of the views a voxel saw open (which
/// decide where a kept voxel claims) span more than one word.
#[test]
fn fast_path_equals_the_reference_with_more_than_64_views() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 72)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 32)?;
    fast_equals_reference(
        &grid,
        &cap.views(true),
        &ColoringParams::default(),
        "72 views",
    )?;
    Ok(())
}

/// The sampled pixels inset into the footprints (`ColoringParams::sample_inset`): the fast
/// path equals the reference at any inset, and the inset changes what is judged.
#[test]
fn fast_path_equals_the_reference_at_any_sample_inset() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 12)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 40)?;
    let mut tested = Vec::new();
    for sample_inset in [0.0, 0.5, 1.0, 2.5, 8.0] {
        let params = ColoringParams {
            sample_inset,
            ..ColoringParams::default()
        };
        let fast = fast_equals_reference(
            &grid,
            &cap.views(true),
            &params,
            &format!("inset {sample_inset}"),
        )?;
        tested.push(fast.stats.tested);
    }
    // A deeper inset leaves fewer voxels seen by enough views to be judged: those whose
    // open pixels lie only at the rim of their footprints.
    assert!(tested.windows(2).all(|w| w[1] <= w[0]), "{tested:?}");
    assert!(tested[0] > tested[1], "{tested:?}");
    Ok(())
}

/// The column test ([`ColumnTest`]): the fast path equals the reference with it, with and
/// without masks and at an inset, and it passes over voxels the criterion kept.
#[test]
fn fast_path_equals_the_reference_with_the_column_test() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 24)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 64)?;
    for (masks, sample_inset) in [(true, 0.0), (false, 0.0), (true, 0.5)] {
        let params = ColoringParams {
            sample_inset,
            column_test: Some(ColumnTest::default()),
            ..ColoringParams::default()
        };
        let case = format!("masks {masks}, inset {sample_inset}");
        let with = fast_equals_reference(&grid, &cap.views(masks), &params, &case)?;
        assert!(with.stats.sunk > 100, "{case}: {:?}", with.stats);
        let without = voxel_coloring(
            &grid,
            &cap.views(masks),
            &ColoringParams {
                column_test: None,
                ..params
            },
        )?;
        assert_eq!(without.stats.sunk, 0);
        assert!(with.model != without.model, "{case}");
    }
    Ok(())
}

#[test]
fn a_column_test_out_of_range_is_refused() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 6)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 16)?;
    let bad = [
        ColumnTest {
            ratio: 1.5,
            ..ColumnTest::default()
        },
        ColumnTest {
            neighbours: f32::NAN,
            ..ColumnTest::default()
        },
        ColumnTest {
            margin: -1.0,
            ..ColumnTest::default()
        },
        ColumnTest {
            depth: 0,
            ..ColumnTest::default()
        },
    ];
    for test in bad {
        let params = ColoringParams {
            column_test: Some(test),
            ..ColoringParams::default()
        };
        for result in [
            voxel_coloring(&grid, &cap.views(true), &params),
            voxel_coloring_reference(&grid, &cap.views(true), &params),
        ] {
            assert!(
                matches!(result, Err(Error::InvalidParameter { name, .. }) if name.starts_with("column_test.")),
                "{test:?}"
            );
        }
    }
    Ok(())
}

/// A camera zoomed in so far that the object leaves every image: the blocks and bricks whose
/// bounds the image's edge cuts hold voxels a view does not see at all, which that view must
/// neither reject nor judge.
#[test]
fn fast_path_equals_the_reference_where_the_object_leaves_the_images() -> TestResult {
    let mut scene = catalogue::lambertian()?;
    scene.rig.intrinsics.fx *= 2.5;
    scene.rig.intrinsics.fy *= 2.5;
    let cap = capture(&scene, 8)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 48)?;
    let b = scene.object_bounds();
    let off = cap.cameras.iter().all(|c| {
        [b.min, b.max]
            .iter()
            .any(|p| c.project(p).is_none_or(|q| !c.size.contains(q)))
    });
    assert!(off, "the object must leave every image");
    for behind_hull in [Some(-0.3), None] {
        let params = ColoringParams {
            behind_hull,
            ..ColoringParams::default()
        };
        fast_equals_reference(
            &grid,
            &cap.views(true),
            &params,
            &format!("{behind_hull:?}"),
        )?;
    }
    Ok(())
}

/// `mirror`'s box: voxel coloring carves the mirror, and the views that look through the hole
/// at the box's other faces from inside then tear those faces too, unless the views behind the
/// visual hull are left out (`ColoringParams::behind_hull`; docs/voxel.md).
#[test]
fn views_behind_the_hull_no_longer_tear_the_mirror_box() -> TestResult {
    let scene = catalogue::mirror()?;
    let cap = capture(&scene, 24)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 64)?;
    let truth = scene.geometry_reference_of(100_000, 20_000)?;
    let (surface, visible) = (truth.exposed, truth.visible);
    let score = |behind_hull| -> Result<_, Box<dyn std::error::Error>> {
        let params = ColoringParams {
            behind_hull,
            ..ColoringParams::default()
        };
        let out = voxel_coloring(&grid, &cap.views(true), &params)?;
        Ok(geometry_score(&out.model, &surface, &visible))
    };
    let (with, without) = (score(Some(-0.3))?, score(None)?);
    println!("mirror 64^3, 24 views: with {with:?}, without {without:?}");
    assert!(
        with.completeness > without.completeness + 0.08,
        "{with:?} against {without:?}"
    );
    assert!(with.accuracy_voxels <= without.accuracy_voxels + 0.1);
    Ok(())
}

/// `f` run on a pool of `threads` threads.
fn on_threads<T: Send>(
    threads: usize,
    f: impl FnOnce() -> T + Send,
) -> Result<T, Box<dyn std::error::Error>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    Ok(pool.install(f))
}

#[test]
fn same_model_at_any_thread_count() -> TestResult {
    let scene = catalogue::chair()?;
    let cap = capture(&scene, 16)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 64)?;
    let run = |threads: usize| -> Result<_, Box<dyn std::error::Error>> {
        Ok(on_threads(threads, || {
            voxel_coloring(&grid, &cap.views(true), &ColoringParams::default())
        })??)
    };
    let one = run(1)?;
    assert!(one.model == run(2)?.model);
    assert!(one.model == run(5)?.model);
    let carve = |threads: usize| -> Result<_, Box<dyn std::error::Error>> {
        Ok(on_threads(threads, || {
            space_carving(&grid, &cap.views(true), &CarvingParams::default())
        })??)
    };
    assert!(carve(1)?.model == carve(3)?.model);
    let refine = |threads: usize| -> Result<_, Box<dyn std::error::Error>> {
        let mut model = one.model.clone();
        let stats = on_threads(threads, || {
            refine_tops(&mut model, &cap.views(true), &TopRefinement::default())
        })??;
        Ok((model, stats))
    };
    let (refined, stats) = refine(1)?;
    assert!(stats.moved > 0, "{stats:?}");
    assert!(refine(3)? == (refined, stats));
    let column = |threads: usize| -> Result<_, Box<dyn std::error::Error>> {
        let params = ColoringParams {
            column_test: Some(ColumnTest::default()),
            ..ColoringParams::default()
        };
        Ok(on_threads(threads, || {
            voxel_coloring(&grid, &cap.views(true), &params)
        })??)
    };
    let sunk = column(1)?;
    assert!(sunk.stats.sunk > 0, "{:?}", sunk.stats);
    assert!(sunk == column(3)?);
    Ok(())
}

/// The same targets reached by the sweep itself, with the column test: a floating top is
/// passed over while the layers below are still to be judged, so the surface under it is
/// reconstructed (where [`refine_tops`] leaves it open).
#[test]
fn head_within_its_targets_with_the_column_test() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 48)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 128)?;
    let params = ColoringParams {
        column_test: Some(ColumnTest::default()),
        ..ColoringParams::default()
    };
    let run = voxel_coloring(&grid, &cap.views(true), &params)?;
    let truth = scene.geometry_reference_of(300_000, 20_000)?;
    let score = geometry_score(&run.model, &truth.exposed, &truth.visible);
    eprintln!("head 128^3 x 48, column test: {score:?}, {:?}", run.stats);
    assert!(score.accuracy_voxels <= 1.5, "{score:?}");
    assert!(score.completeness >= 0.90, "{score:?}");
    assert!(run.stats.sunk > 1000, "{:?}", run.stats);
    Ok(())
}

/// The figures on `head`: 48 uniform views, 128^3, targets accuracy 1.5 voxels or
/// better and completeness 90% or more. The sweep alone leaves the pedestal top a layer or
/// two high and a fillet in the corner under the neck (about 3 voxels, 86%); moving the
/// tops down to where their views agree best ([`refine_tops`]) reaches the targets.
#[test]
fn head_within_its_targets_once_the_tops_are_refined() -> TestResult {
    let scene = catalogue::head()?;
    let cap = capture(&scene, 48)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 128)?;
    let views = cap.views(true);
    let mut model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
    let truth = scene.geometry_reference_of(300_000, 20_000)?;
    let before = geometry_score(&model, &truth.exposed, &truth.visible);
    let stats = refine_tops(&mut model, &views, &TopRefinement::default())?;
    let after = geometry_score(&model, &truth.exposed, &truth.visible);
    eprintln!("head 128^3 x 48: {before:?} -> {after:?}, {stats:?}");
    assert!(after.accuracy_voxels <= 1.5, "{after:?}");
    assert!(after.completeness >= 0.90, "{after:?}");
    assert!(
        after.accuracy_voxels < before.accuracy_voxels - 0.5,
        "{before:?}"
    );
    assert!(
        stats.moved > 1000 && stats.moved < stats.judged,
        "{stats:?}"
    );
    Ok(())
}

#[test]
fn refining_an_empty_model_changes_nothing_and_bad_input_is_refused() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 6)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 16)?;
    let views = cap.views(true);
    let mut model = aibr_voxel::VoxelModel::empty(grid);
    let stats = refine_tops(&mut model, &views, &TopRefinement::default())?;
    assert_eq!(stats, aibr_voxel::RefineStats::default());
    assert_eq!(model.occupied_count(), 0);
    let few = refine_tops(&mut model, &views[..3], &TopRefinement::default());
    assert!(
        matches!(
            few,
            Err(Error::TooFewViews {
                found: 3,
                needed: 4
            })
        ),
        "{few:?}"
    );
    let bad = TopRefinement {
        margin: f32::NAN,
        ..TopRefinement::default()
    };
    let refused = refine_tops(&mut model, &views, &bad);
    assert!(
        matches!(refused, Err(Error::InvalidParameter { name: "margin", .. })),
        "{refused:?}"
    );
    Ok(())
}

/// The figures on `lambertian`: 48 uniform views, 128^3. Targets: accuracy 1.5 voxels
/// or better (90% of model surface voxels) and completeness 90% or more (true surface within
/// 1.5 voxels). Completeness is met; accuracy reaches about 1.6 (docs/results.md), so the
/// bound guards what is reached. `head` is measured by the `voxel_accuracy` example.
#[test]
fn lambertian_accuracy_and_completeness() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 48)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 128)?;
    let out = voxel_coloring(&grid, &cap.views(true), &ColoringParams::default())?;
    let truth = scene.geometry_reference_of(300_000, 20_000)?;
    let (surface, visible) = (truth.exposed, truth.visible);
    let score = geometry_score(&out.model, &surface, &visible);
    eprintln!("lambertian 128^3 x 48: {score:?}");
    assert!(score.accuracy_voxels <= 1.7, "{score:?}");
    assert!(score.completeness >= 0.90, "{score:?}");
    Ok(())
}

#[test]
fn errors_name_the_view() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 4)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 16)?;
    let params = ColoringParams::default();

    // A camera below the top of the volume.
    let mut cameras = cap.cameras.clone();
    let low = aibr_camera::CircularMotion::ring(0.55, 0.1, 0.09)?;
    cameras[2] = cameras[2].with_pose(low.cam_from_world(Angle::from_degrees(30.0)));
    let views: Vec<View<'_>> = cameras
        .iter()
        .zip(&cap.images)
        .map(|(camera, image)| View {
            camera,
            image,
            mask: None,
        })
        .collect();
    match voxel_coloring(&grid, &views, &params) {
        Err(e @ Error::CameraNotAbove { view: 2, .. }) => {
            assert!(e.to_string().contains("view 2"), "{e}");
        }
        other => panic!(
            "expected CameraNotAbove for view 2, got {:?}",
            other.map(|o| o.stats)
        ),
    }
    // Space carving takes that rig.
    assert!(space_carving(&grid, &views, &CarvingParams::default()).is_ok());

    // A distorted camera.
    let mut cameras = cap.cameras.clone();
    cameras[1].distortion = Distortion {
        k1: -0.2,
        ..Distortion::NONE
    };
    let views: Vec<View<'_>> = cameras
        .iter()
        .zip(&cap.images)
        .map(|(camera, image)| View {
            camera,
            image,
            mask: None,
        })
        .collect();
    assert!(matches!(
        voxel_coloring(&grid, &views, &params),
        Err(Error::Distorted { view: 1 })
    ));

    // A mask of the wrong size.
    let small = GrayImage::new(10, 10);
    let mut views = cap.views(false);
    views[3].mask = Some(&small);
    assert!(matches!(
        voxel_coloring(&grid, &views, &params),
        Err(Error::ViewSize {
            view: 3,
            what: "mask",
            ..
        })
    ));

    // A cosine that is none.
    for cosine in [1.5, -1.01, f64::NAN] {
        let params = ColoringParams {
            behind_hull: Some(cosine),
            ..ColoringParams::default()
        };
        match voxel_coloring(&grid, &cap.views(true), &params) {
            Err(
                e @ Error::InvalidParameter {
                    name: "behind_hull",
                    ..
                },
            ) => {
                assert!(e.to_string().contains("behind_hull"), "{e}");
            }
            other => panic!(
                "{cosine}: expected InvalidParameter, got {:?}",
                other.map(|o| o.stats)
            ),
        }
    }

    // An inset that is no number of pixels inside the footprint.
    for sample_inset in [-0.5, 8.5, f32::NAN, f32::INFINITY] {
        let params = ColoringParams {
            sample_inset,
            ..ColoringParams::default()
        };
        assert!(
            matches!(
                voxel_coloring(&grid, &cap.views(true), &params),
                Err(Error::InvalidParameter {
                    name: "sample_inset",
                    ..
                })
            ),
            "{sample_inset}"
        );
    }

    // Too few views.
    assert!(matches!(
        voxel_coloring(&grid, &cap.views(false)[..2], &params),
        Err(Error::TooFewViews {
            found: 2,
            needed: 3
        })
    ));
    Ok(())
}

#[test]
fn space_carving_keeps_the_silhouettes() -> TestResult {
    let scene = catalogue::chair()?;
    let cap = capture(&scene, 16)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 64)?;
    let out = space_carving(&grid, &cap.views(true), &CarvingParams::default())?;
    for (camera, frame) in cap.cameras.iter().zip(&cap.frames).step_by(5) {
        let depth = out.model.depth_map(camera);
        let a = aibr_voxel::metrics::silhouette_agreement(&depth, &frame.mask);
        // 3.4 mm voxels around 12 mm chair legs: the conservative silhouette test spills.
        assert!(a.coverage > 0.9 && a.spill < 0.25, "{a:?}");
    }
    // Carving starts from the visual hull and only removes voxels.
    let hull = visual_hull(&grid, &cap.views(true))?;
    let outside = out
        .model
        .occupied
        .indexed_iter()
        .filter(|((k, j, i), o)| **o && !hull.is_occupied([*i, *j, *k]))
        .count();
    assert_eq!(outside, 0);
    assert_eq!(
        grid.len() - hull.occupied_count(),
        out.stats.silhouette_rejected
    );
    // The hull of the chair holds the true surface points the views see (all but a few in
    // voxels the object only grazes: a voxel's footprint is the square of its projected
    // edge about its centre, not its whole outline).
    let samples = scene.surface_samples(4000, 1)?;
    let inside = samples
        .iter()
        .filter(|(p, _)| grid.index_of(p).is_some_and(|idx| hull.is_occupied(idx)))
        .count();
    eprintln!(
        "{inside} of {} surface samples inside the hull",
        samples.len()
    );
    assert!(inside as f64 >= 0.975 * samples.len() as f64);
    Ok(())
}

#[test]
fn ply_files_parse_back() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 8)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 24)?;
    let out = voxel_coloring(&grid, &cap.views(true), &ColoringParams::default())?;
    let n = out.model.occupied_count();
    assert!(n > 50);

    let mut ascii = Vec::new();
    write_ply(&out.model, &mut ascii, &PlyOptions::default())?;
    let (header, body) = split_ply(&ascii)?;
    assert!(header.starts_with("ply\nformat ascii 1.0\n"));
    assert!(header.contains(&format!("element vertex {n}\n")));
    let rows: Vec<Vec<f64>> = std::str::from_utf8(body)?
        .lines()
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse::<f64>())
                .collect::<Result<_, _>>()
        })
        .collect::<Result<_, _>>()?;
    assert_eq!(rows.len(), n);
    for r in &rows {
        assert_eq!(r.len(), 6);
        let p = Point3::new(r[0], r[1], r[2]);
        let v = grid.index_of(&p).ok_or("vertex outside the grid")?;
        assert!(out.model.is_occupied(v));
        assert_eq!(
            out.model.colour_of(v).map(|c| c.map(f64::from)),
            Some([r[3], r[4], r[5]])
        );
    }

    let mut cubes = Vec::new();
    write_ply(
        &out.model,
        &mut cubes,
        &PlyOptions {
            cubes: true,
            binary: true,
        },
    )?;
    let (header, body) = split_ply(&cubes)?;
    assert!(header.contains("format binary_little_endian 1.0"));
    assert!(header.contains(&format!("element vertex {}\n", 8 * n)));
    let faces = element_count(header, "face")?;
    // 15 bytes per vertex, 17 per quad face.
    assert_eq!(body.len(), 8 * n * 15 + faces * 17);
    assert!(faces >= out.model.surface_voxels().len());
    Ok(())
}

/// The four side faces of `lambertian`'s block (0.13 m square about the axis, 0.06 m high)
/// are found in a model voxel coloring made from 24 views: the Hough vote's directions within
/// a degree, its planes within two voxels (the model's faces are fat by up to that much).
#[test]
fn the_block_faces_of_a_colored_model_are_found() -> TestResult {
    let scene = catalogue::lambertian()?;
    let cap = capture(&scene, 24)?;
    let grid = VoxelGrid::with_resolution(scene.bounds(), 96)?;
    let model = voxel_coloring(&grid, &cap.views(true), &ColoringParams::default())?.model;
    let faces = aibr_voxel::planar_faces(&model, &aibr_voxel::FaceParams::default())?;
    for (x, y) in [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0)] {
        let n = nalgebra::Vector3::new(x, y, 0.0);
        let face = faces
            .iter()
            .find(|f| f.normal.dot(&n) > 1f64.to_radians().cos())
            .ok_or_else(|| format!("no face facing ({x}, {y}) within a degree: {faces:?}"))?;
        let off = face.offset_m - 0.065;
        assert!(
            off.abs() <= 2.0 * grid.voxel_size(),
            "({x}, {y}): plane {:.4} m, {off:+.4} from the block's",
            face.offset_m
        );
    }
    // Nothing else: the drum and the ball are round.
    assert_eq!(faces.len(), 4, "{faces:?}");
    Ok(())
}

/// `mirror`'s box seen from 8 uniform views, as `aibr eval --initial 8` starts, with the box
/// turned 12.5 and 15 degrees on the turntable: its faces come out of voxel coloring fat, as
/// wedges of the visual hull, yet the planes refitted to their outer profiles lie within 0.1
/// degree and half a voxel of the true faces, where the mean of the voting normals leans by
/// a degree or more (`docs/results.md`, "Session 71").
#[test]
fn the_faces_of_a_fat_model_are_refitted_onto_the_true_planes() -> TestResult {
    let scene = catalogue::mirror()?;
    // The box's sides: outward normal and offset.
    let truth: Vec<_> = scene
        .objects
        .iter()
        .flat_map(|o| o.shape.side_planes())
        .collect();
    assert_eq!(truth.len(), 4, "{truth:?}");
    let grid = VoxelGrid::with_resolution(scene.bounds(), 96)?;
    let mut worst_mean_deg = 0f64;
    for turn in [12.5, 15.0] {
        let pans: Vec<Angle> = scene
            .rig
            .uniform_pans(8)
            .into_iter()
            .map(|p| p + Angle::from_degrees(turn))
            .collect();
        let cap = capture_at(&scene, &pans)?;
        let model = voxel_coloring(&grid, &cap.views(true), &ColoringParams::default())?.model;
        // Each face found against the true face it faces: (degrees off, metres outward).
        let judged = |params: &FaceParams| -> Result<Vec<(f64, f64)>, Box<dyn std::error::Error>> {
            let faces = aibr_voxel::planar_faces(&model, params)?;
            Ok(faces
                .iter()
                .filter_map(|f| {
                    truth
                        .iter()
                        .find(|(n, _)| f.normal.dot(n) > 10f64.to_radians().cos())
                        .map(|(n, d)| (f.normal.angle(n).to_degrees(), f.offset_m - d))
                })
                .collect())
        };
        let refitted = judged(&FaceParams::default())?;
        assert!(refitted.len() >= 3, "turn {turn}: {refitted:?}");
        for &(deg, out) in &refitted {
            assert!(deg < 0.1, "turn {turn}: {refitted:?}");
            assert!(
                out.abs() < 0.5 * grid.voxel_size(),
                "turn {turn}: {refitted:?}"
            );
        }
        let mean = judged(&FaceParams {
            profile_quantile: None,
            ..FaceParams::default()
        })?;
        worst_mean_deg = mean.iter().fold(worst_mean_deg, |w, &(deg, _)| w.max(deg));
    }
    assert!(worst_mean_deg > 1.0, "{worst_mean_deg}");
    Ok(())
}
