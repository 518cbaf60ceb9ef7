//! The estimator and the planner on synthetic turntable scenes.

use aibr_camera::{Angle, Camera, CircularMotion, PanRange, TurntableAxis};
use aibr_consistency::foreground::{BackdropDifference, foreground_from_backdrop, median_backdrop};
use aibr_consistency::{
    AIM_DONE_DEG, ConsistencyParams, Error, PairScore, PlanParams, Proposal, TurntableLimits,
    edge_on_pans, plan_next, plan_next_aimed, plan_next_among, ring_pairs, score_pairs,
};
use aibr_scene::{Frame, RenderOptions, catalogue};
use aibr_voxel::{ColoringParams, PlanarFace, View, VoxelGrid, VoxelModel, voxel_coloring};
use image::{GrayImage, RgbImage};
use nalgebra::{Point3, Unit, Vector3};
use proptest::prelude::*;

type TestResult = Result<(), Box<dyn std::error::Error>>;

struct Capture {
    pans: Vec<Angle>,
    cameras: Vec<Camera>,
    frames: Vec<Frame>,
    images: Vec<RgbImage>,
    model: VoxelModel,
    range: PanRange,
}

fn capture(name: &str, n: usize) -> Result<Capture, Box<dyn std::error::Error>> {
    let scene = catalogue::by_name(name)?;
    let pans = scene.rig.uniform_pans(n);
    let options = RenderOptions {
        noise_sigma: 1.0 / 255.0,
        seed: 2,
    };
    let (mut cameras, mut frames, mut images) = (Vec::new(), Vec::new(), Vec::new());
    for s in scene.shoot(&pans, &options)? {
        cameras.push(s.camera);
        frames.push(s.frame);
        images.push(s.image);
    }
    let views: Vec<View<'_>> = cameras
        .iter()
        .zip(&images)
        .zip(&frames)
        .map(|((camera, image), f)| View {
            camera,
            image,
            mask: Some(&f.mask),
        })
        .collect();
    let grid = VoxelGrid::with_resolution(scene.bounds(), 96)?;
    let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
    Ok(Capture {
        pans,
        cameras,
        frames,
        images,
        model,
        range: scene.rig.pan_range,
    })
}

impl Capture {
    fn views(&self) -> Vec<View<'_>> {
        self.cameras
            .iter()
            .zip(&self.images)
            .zip(&self.frames)
            .map(|((camera, image), f)| View {
                camera,
                image,
                mask: Some(&f.mask),
            })
            .collect()
    }

    fn scores(&self) -> Result<Vec<PairScore>, aibr_consistency::Error> {
        score_pairs(
            &self.model,
            &self.views(),
            &self.pans,
            &self.range,
            &ConsistencyParams::default(),
        )
    }
}

/// The paper's figure 7: on the mirror object the worst arc is on the mirror side.
#[test]
fn the_mirror_side_scores_worst() -> TestResult {
    let mirror = capture("mirror", 12)?;
    let scores = mirror.scores()?;
    assert_eq!(scores.len(), 11, "12 views on a partial range: 11 arcs");
    let worst = scores
        .iter()
        .max_by(|a, b| a.score.total_cmp(&b.score))
        .ok_or("no pairs")?;
    let middle = (mirror.pans[worst.a] + mirror.pans[worst.b]) * 0.5;
    // The mirror faces -X: the camera at pan 90 degrees looks straight at it.
    assert!(
        (30.0..=150.0).contains(&middle.degrees()),
        "worst arc around {} (scores {:?})",
        middle,
        scores.iter().map(|s| s.score.round()).collect::<Vec<_>>()
    );
    assert!(
        worst.unexplained_pixels > 0,
        "the hole voxel coloring leaves on the mirror"
    );
    // The error maps mark that view's foreground.
    assert!(worst.error_a.pixels().any(|p| p.0[0] == 255));

    // The matte object of about the same image size has no arc as bad.
    let matte = capture("lambertian", 12)?;
    let matte_worst = matte.scores()?.iter().map(|s| s.score).fold(0.0, f64::max);
    assert!(
        worst.score > 1.2 * matte_worst,
        "mirror {} vs lambertian {matte_worst}",
        worst.score
    );
    Ok(())
}

#[test]
fn estimator_rejects_bad_input() -> TestResult {
    let c = capture("chair", 4)?;
    let mut views = c.views();
    views[2].mask = None;
    assert!(matches!(
        score_pairs(
            &c.model,
            &views,
            &c.pans,
            &c.range,
            &ConsistencyParams::default()
        ),
        Err(Error::NoMask { view: 2 })
    ));
    assert!(matches!(
        score_pairs(
            &c.model,
            &c.views(),
            &c.pans[..3],
            &c.range,
            &ConsistencyParams::default()
        ),
        Err(Error::CountMismatch { pans: 3, views: 4 })
    ));
    Ok(())
}

#[test]
fn the_median_backdrop_finds_the_object() -> TestResult {
    let c = capture("lambertian", 12)?;
    let refs: Vec<&RgbImage> = c.images.iter().collect();
    let backdrop = median_backdrop(&refs)?;
    for (image, frame) in c.images.iter().zip(&c.frames).step_by(4) {
        let mask = foreground_from_backdrop(image, &backdrop, &BackdropDifference::default())?;
        let (mut both, mut either) = (0usize, 0usize);
        for (a, b) in mask.pixels().zip(frame.mask.pixels()) {
            both += usize::from(a.0[0] != 0 && b.0[0] != 0);
            either += usize::from(a.0[0] != 0 || b.0[0] != 0);
        }
        let iou = both as f64 / either as f64;
        // Measured 0.79: where the object covers a pixel in most of the 12 views, neither the
        // median nor the spread can tell backdrop from object there (docs/consistency.md).
        assert!(iou > 0.75, "IoU {iou}");
    }
    assert!(matches!(
        median_backdrop(&refs[..2]),
        Err(Error::TooFewImages { found: 2, .. })
    ));
    Ok(())
}

#[test]
fn ring_pairs_wrap_only_on_a_full_turn() -> TestResult {
    let pans = [10.0, -100.0, 120.0, 0.0].map(Angle::from_degrees);
    let partial = PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?;
    assert_eq!(ring_pairs(&pans, &partial), vec![(1, 3), (3, 0), (0, 2)]);
    assert_eq!(
        ring_pairs(&pans, &PanRange::full_turn()),
        vec![(1, 3), (3, 0), (0, 2), (2, 1)]
    );
    Ok(())
}

fn pair(a: usize, b: usize, score: f64) -> PairScore {
    PairScore {
        a,
        b,
        score,
        unexplained_pixels: 0,
        compared_pixels: 0,
        error_a: GrayImage::new(1, 1),
        error_b: GrayImage::new(1, 1),
    }
}

/// A PTU-46's pan range (+-159 degrees) in whole-degree steps.
fn ptu_range_in_degrees() -> Result<TurntableLimits, Box<dyn std::error::Error>> {
    Ok(TurntableLimits::new(
        PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?,
        Angle::from_degrees(1.0),
    )?)
}

#[test]
fn planner_skips_short_and_consistent_arcs() -> TestResult {
    let limits = ptu_range_in_degrees()?;
    let pans = [-10.0, -9.0, 0.0, 40.0].map(Angle::from_degrees);
    // The worst arc is one step long: nothing fits between; the next worst is split.
    let scores = [pair(0, 1, 1e9), pair(1, 2, 5e3), pair(2, 3, 1.0)];
    let plan = PlanParams::default();
    let p = plan_next(&pans, &scores, &limits, &plan)?.ok_or("no proposal")?;
    assert_eq!(p.pair, (1, 2));
    assert!((p.pan.degrees() - -5.0).abs() < 1e-9 || (p.pan.degrees() - -4.0).abs() < 1e-9);
    // Everything consistent: nothing to do.
    let strict = PlanParams {
        consistent_below: 1e9,
        ..plan
    };
    assert_eq!(plan_next(&pans, &scores, &limits, &strict)?, None);
    // The wrap-around arc of a full turn is split across +-180.
    let full = TurntableLimits::new(PanRange::full_turn(), Angle::from_degrees(1.0))?;
    let pans = [170.0, -170.0].map(Angle::from_degrees);
    let p = plan_next(&pans, &[pair(0, 1, 5.0)], &full, &plan)?.ok_or("no proposal")?;
    assert!(
        (p.pan.wrapped().degrees().abs() - 180.0).abs() < 1e-9,
        "{}",
        p.pan
    );
    assert!(TurntableLimits::new(PanRange::full_turn(), Angle::ZERO).is_err());
    Ok(())
}

#[test]
fn the_width_power_trades_score_against_width() -> TestResult {
    let limits = ptu_range_in_degrees()?;
    // A narrow arc (10 degrees) scoring five times a wide one (30 degrees).
    let pans = [0.0, 10.0, 40.0].map(Angle::from_degrees);
    let scores = [pair(0, 1, 500.0), pair(1, 2, 100.0)];
    let split = |width_power| -> Result<(usize, usize), Box<dyn std::error::Error>> {
        let plan = PlanParams {
            consistent_below: 0.0,
            width_power,
            ..PlanParams::default()
        };
        Ok(plan_next(&pans, &scores, &limits, &plan)?
            .ok_or("no proposal")?
            .pair)
    };
    // Score alone, or its mass over the arc (500 x 10 > 100 x 30): the narrow arc.
    assert_eq!(split(0.0)?, (0, 1));
    assert_eq!(split(1.0)?, (0, 1));
    // Width squared and cubed (500 x 100 < 100 x 900): the wide one.
    assert_eq!(split(2.0)?, (1, 2));
    assert_eq!(split(3.0)?, (1, 2));
    // Out of the domain: refused, naming the parameter.
    for bad in [-1.0, 8.5, f64::NAN, f64::INFINITY] {
        let err = split(bad).err().ok_or("accepted a bad width power")?;
        assert!(err.to_string().contains("width_power"), "{err}");
    }
    let negative = PlanParams {
        consistent_below: -1.0,
        ..PlanParams::default()
    };
    assert!(plan_next(&pans, &scores, &limits, &negative).is_err());
    Ok(())
}

#[test]
fn edge_on_pans_put_the_camera_centre_in_the_face_plane() -> TestResult {
    let scene = catalogue::lambertian()?;
    let range = scene.rig.pan_range;
    let motion = scene.rig.ring;
    // The faces of a box 0.13 m wide about the axis, and one leaning 10 degrees.
    let lean = 10f64.to_radians();
    let faces = [
        (Vector3::new(1.0, 0.0, 0.0), 0.065),
        (Vector3::new(0.0, -1.0, 0.0), 0.065),
        (Vector3::new(lean.cos(), 0.0, lean.sin()), 0.08),
    ];
    for (normal, offset_m) in faces {
        let face = PlanarFace {
            normal,
            offset_m,
            voxels: 1,
        };
        let pans = edge_on_pans(&face, &motion, &range);
        assert!(!pans.is_empty(), "{normal:?}");
        for pan in pans {
            let c = scene.camera(pan)?.centre();
            assert!(
                (normal.dot(&c.coords) - offset_m).abs() < 1e-9,
                "{normal:?} at {pan}: {}",
                normal.dot(&c.coords)
            );
        }
    }
    // The -y face is seen edge-on at +-acos(0.065 / 0.55) = +-83.2 degrees from pan 0 (the
    // pan that faces it), both inside the range.
    let face = PlanarFace {
        normal: Vector3::new(0.0, -1.0, 0.0),
        offset_m: 0.065,
        voxels: 1,
    };
    let mut pans: Vec<f64> = edge_on_pans(&face, &motion, &range)
        .iter()
        .map(|a| a.degrees())
        .collect();
    pans.sort_by(f64::total_cmp);
    let want = (0.065f64 / 0.55).acos().to_degrees();
    assert_eq!(pans.len(), 2, "{pans:?}");
    assert!(
        (pans[0] + want).abs() < 1e-9 && (pans[1] - want).abs() < 1e-9,
        "{pans:?}"
    );
    // A plane the circle never meets.
    let far = PlanarFace {
        normal: Vector3::new(1.0, 0.0, 0.0),
        offset_m: 0.6,
        voxels: 1,
    };
    assert!(edge_on_pans(&far, &motion, &range).is_empty());
    // A calibrated axis need not be the frame's Z: off the origin and leaning, the camera's
    // centre at each pan returned still lies in the plane.
    let leaning = CircularMotion {
        axis: TurntableAxis {
            point: Point3::new(0.04, 0.01, 0.0),
            direction: Unit::new_normalize(Vector3::new(0.05, -0.02, 1.0)),
        },
        ..motion
    };
    let face = PlanarFace {
        normal: Vector3::new(1.0, 0.0, 0.0),
        offset_m: 0.1,
        voxels: 1,
    };
    let pans = edge_on_pans(&face, &leaning, &range);
    assert!(!pans.is_empty());
    for pan in pans {
        let c = leaning
            .cam_from_world(pan)
            .inverse_transform_point(&Point3::origin());
        assert!((c.x - 0.1).abs() < 1e-9, "{pan}: {c:?}");
    }
    Ok(())
}

/// The pans at `d` degrees.
fn degrees(d: &[f64]) -> Vec<Angle> {
    d.iter().map(|d| Angle::from_degrees(*d)).collect()
}

/// Faces of one edge-on pan each, at `d` degrees.
fn faces(d: &[f64]) -> Vec<Vec<Angle>> {
    degrees(d).into_iter().map(|a| vec![a]).collect()
}

/// Where a planner splits, in degrees to a millionth (so that a pan compares with the figure
/// it was given in), and which pair.
type Split = Option<(f64, (usize, usize))>;

/// The [`Split`] of a proposal.
fn split(p: Option<Proposal>) -> Split {
    p.map(|p| ((p.pan.degrees() * 1e6).round() / 1e6, p.pair))
}

#[test]
fn an_aim_near_the_middle_of_the_chosen_arc_draws_the_view() -> TestResult {
    let limits = ptu_range_in_degrees()?;
    let pans = [0.0, 20.0, 60.0].map(Angle::from_degrees);
    // The 20-60 arc is chosen (wider, same score); its middle is 40.
    let scores = [pair(0, 1, 100.0), pair(1, 2, 100.0)];
    let plan = PlanParams::default();
    let with = |aims: &[f64]| -> Result<f64, Box<dyn std::error::Error>> {
        let aims = faces(aims);
        let p = plan_next_aimed(&pans, &scores, &aims, &limits, &plan)?.ok_or("no proposal")?;
        assert_eq!(p.pair, (1, 2));
        Ok(p.pan.degrees())
    };
    assert!((with(&[])? - 40.0).abs() < 1e-9);
    // Within the middle half (30 to 50): the aim, quantised to whole steps; the one nearest
    // the middle when several are.
    assert!((with(&[46.3])? - 46.0).abs() < 1e-9);
    assert!((with(&[33.0, 46.0, 10.0])? - 46.0).abs() < 1e-9);
    // Outside it, or in another arc: the middle.
    assert!((with(&[27.0, 55.0, 10.0])? - 40.0).abs() < 1e-9);
    // An aim with a view within AIM_DONE_DEG of it is done (a view the scores do not know
    // of, which leaves the arcs as they were).
    let seen = [0.0, 20.0, 60.0, 46.0 + 0.6 * AIM_DONE_DEG].map(Angle::from_degrees);
    let aims = faces(&[46.0]);
    let p = plan_next_aimed(&seen, &scores, &aims, &limits, &plan)?.ok_or("no proposal")?;
    assert!((p.pan.degrees() - 40.0).abs() < 1e-9, "{}", p.pan);
    // A reach of 0 never moves the view; a reach outside 0..=1 is refused.
    let never = PlanParams {
        aim_reach: 0.0,
        ..plan
    };
    let aims = faces(&[46.0]);
    let p = plan_next_aimed(&pans, &scores, &aims, &limits, &never)?.ok_or("no proposal")?;
    assert!((p.pan.degrees() - 40.0).abs() < 1e-9);
    for bad in [-0.1, 1.5, f64::NAN] {
        let plan = PlanParams {
            aim_reach: bad,
            ..plan
        };
        let err = plan_next_aimed(&pans, &scores, &aims, &limits, &plan)
            .err()
            .ok_or("accepted a bad reach")?;
        assert!(err.to_string().contains("aim_reach"), "{err}");
    }
    Ok(())
}

#[test]
fn serving_faces_first_splits_the_best_arc_holding_an_open_face() -> TestResult {
    let limits = ptu_range_in_degrees()?;
    let pans = [-90.0, 0.0, 20.0, 60.0].map(Angle::from_degrees);
    // By rank: -90..0 (widest), 20..60, then 0..20.
    let scores = [pair(0, 1, 100.0), pair(1, 2, 100.0), pair(2, 3, 100.0)];
    let first = PlanParams {
        faces_first: true,
        ..PlanParams::default()
    };
    let plan = |pans: &[Angle], aims: &[Vec<Angle>], params: &PlanParams| {
        plan_next_aimed(pans, &scores, aims, &limits, params).map(split)
    };
    // A face whose edge-on pans lie at 3.4 and 140 (outside the views' arcs): served in the
    // only arc that holds one, the least ranked, anywhere in it, quantised to whole steps.
    let face = vec![degrees(&[3.4, 140.0])];
    assert_eq!(plan(&pans, &face, &first)?, Some((3.0, (1, 2))));
    // Without serving faces first the ranks decide: the middle of -90..0 (3.4 is not in it).
    assert_eq!(
        plan(&pans, &face, &PlanParams::default())?,
        Some((-45.0, (0, 1)))
    );
    // Two open faces: the best-ranked arc holding one serves it, at the pan nearest its
    // middle.
    let two = vec![degrees(&[3.4]), degrees(&[-80.0, 100.0]), degrees(&[-50.0])];
    assert_eq!(plan(&pans, &two, &first)?, Some((-50.0, (0, 1))));
    // A face is done when a view lies within `face_served_deg` (AIM_DONE_DEG unless set) of
    // either of its pans: a view near 140 serves the first face (a view the scores do not know
    // of), and the ranks decide.
    let served = first.face_served_deg;
    assert_eq!(served, AIM_DONE_DEG);
    let seen = degrees(&[-90.0, 0.0, 20.0, 60.0, 140.0 - 0.9 * served]);
    assert_eq!(plan(&seen, &face, &first)?, Some((-45.0, (0, 1))));
    // Beyond the tolerance the face is still open; a wider one counts the same view as
    // serving it.
    let near = degrees(&[-90.0, 0.0, 20.0, 60.0, 140.0 - 1.5 * served]);
    assert_eq!(plan(&near, &face, &first)?, Some((3.0, (1, 2))));
    let wide = PlanParams {
        face_served_deg: 2.0 * served,
        ..first
    };
    assert_eq!(plan(&near, &face, &wide)?, Some((-45.0, (0, 1))));
    // A tighter one asks again for a face whose view lies beside its pan, not within it.
    let beside = degrees(&[-90.0, 0.0, 20.0, 60.0, 3.4 + 0.7 * served]);
    assert_eq!(plan(&beside, &face, &first)?, Some((-45.0, (0, 1))));
    let tight = PlanParams {
        face_served_deg: 0.5 * served,
        ..first
    };
    assert_eq!(plan(&beside, &face, &tight)?, Some((3.0, (1, 2))));
    // No face open at all: the ranks alone, as without the option.
    assert_eq!(
        plan(&pans, &[], &first)?,
        plan(&pans, &[], &PlanParams::default())?
    );
    // Among recorded views, only a pan within the tolerance of the face's serves it: none
    // does in the second case, so the ranks decide among what is reachable.
    let among = |reachable: &[f64]| {
        let reachable = degrees(reachable);
        plan_next_among(&pans, &scores, &face, Some(&reachable), &limits, &first).map(split)
    };
    assert_eq!(
        among(&[-40.0, 3.4 + 0.9 * served])?,
        Some((3.4 + 0.9 * served, (1, 2)))
    );
    assert_eq!(among(&[-40.0, 3.4 + 1.1 * served])?, Some((-40.0, (0, 1))));
    // A tolerance outside (0, 10] degrees is refused, naming the field.
    for bad in [0.0, -1.0, 10.5, f64::NAN] {
        let bad = PlanParams {
            face_served_deg: bad,
            ..first
        };
        let err = plan(&pans, &face, &bad)
            .err()
            .ok_or("accepted a bad tolerance")?;
        assert!(err.to_string().contains("face_served_deg"), "{err}");
    }
    Ok(())
}

#[test]
fn among_reachable_pans_the_one_nearest_the_split_is_proposed() -> TestResult {
    let limits = ptu_range_in_degrees()?;
    let pans = [-90.0, 0.0, 30.0, 60.0].map(Angle::from_degrees);
    // -90..0 ranks first (the widest), then 0..30, then 30..60.
    let scores = [pair(0, 1, 100.0), pair(1, 2, 100.0), pair(2, 3, 50.0)];
    let plan = PlanParams::default();
    let among = |reachable: &[f64], aims: &[f64]| -> Result<Split, aibr_consistency::Error> {
        let (reachable, aims) = (degrees(reachable), faces(aims));
        plan_next_among(&pans, &scores, &aims, Some(&reachable), &limits, &plan).map(split)
    };
    // Anything reachable inside the widest arc: the pan nearest its middle, as it is (a
    // recorded view need not lie on a whole step).
    assert_eq!(
        among(&[-80.0, -47.3, -20.0, 15.0], &[])?,
        Some((-47.3, (0, 1)))
    );
    // Nothing inside it: the next arc, not a request that would bring back a view elsewhere.
    assert_eq!(
        among(&[-100.0, 12.0, 20.0, 45.0], &[])?,
        Some((12.0, (1, 2)))
    );
    // Pans on an existing view, within a step of one, or outside the range do not count.
    assert_eq!(
        among(&[-90.0, 0.5, 29.2, 170.0, 45.0], &[])?,
        Some((45.0, (2, 3)))
    );
    assert_eq!(among(&[-100.0, 70.0], &[])?, None);
    // An aim within reach moves the target: the reachable pan nearest the aim.
    assert_eq!(
        among(&[-60.0, -45.0, -20.0], &[-28.0])?,
        Some((-20.0, (0, 1)))
    );
    // With every whole step reachable, the plans agree with `plan_next_aimed`.
    let steps: Vec<f64> = (-159..=159).map(f64::from).collect();
    let aimed = plan_next_aimed(&pans, &scores, &[], &limits, &plan)?;
    assert_eq!(among(&steps, &[])?, split(aimed));
    Ok(())
}

/// A PTU-46's range, the views at `degrees` (sorted here) and each neighbouring pair scored
/// from `raw_scores` in turn.
fn ring(degrees: &mut [f64], raw_scores: &[f64]) -> (PanRange, Vec<Angle>, Vec<PairScore>) {
    degrees.sort_by(f64::total_cmp);
    let range =
        PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0)).unwrap_or_default();
    let pans: Vec<Angle> = degrees.iter().map(|d| Angle::from_degrees(*d)).collect();
    let scores = (1..pans.len())
        .map(|i| pair(i - 1, i, raw_scores[i - 1]))
        .collect();
    (range, pans, scores)
}

proptest! {
    /// Whatever the scores and aims, a proposal is inside the range, a whole number of steps, and at
    /// least a step from every existing view.
    #[test]
    fn proposals_respect_the_turntable(
        mut degrees in prop::collection::vec(-159.0..159.0f64, 2..20),
        step in 0.01..5.0f64,
        raw_scores in prop::collection::vec(0.0..1000.0f64, 19),
        aims in prop::collection::vec(prop::collection::vec(-200.0..200.0f64, 0..3), 0..6),
        aim_reach in 0.0..=1.0f64,
        faces_first: bool,
        face_served_deg in 0.1..=10.0f64,
    ) {
        let (range, pans, scores) = ring(&mut degrees, &raw_scores);
        let limits = TurntableLimits::new(range, Angle::from_degrees(step));
        prop_assert!(limits.is_ok());
        let Ok(limits) = limits else { return Ok(()) };
        let aims: Vec<Vec<Angle>> = aims
            .iter()
            .map(|face| face.iter().map(|d| Angle::from_degrees(*d)).collect())
            .collect();
        let plan = PlanParams { aim_reach, faces_first, face_served_deg, ..PlanParams::default() };
        let planned = plan_next_aimed(&pans, &scores, &aims, &limits, &plan);
        prop_assert!(planned.is_ok());
        if let Ok(Some(p)) = planned {
            prop_assert!(p.pan.radians() >= range.min().radians() && p.pan.radians() <= range.max().radians());
            let steps = p.pan.radians() / limits.step.radians();
            prop_assert!((steps - steps.round()).abs() < 1e-6);
            for q in &pans {
                prop_assert!(p.pan.wrapped_difference(*q).radians().abs() >= limits.step.radians() - 1e-9);
            }
        }
    }

    /// Among reachable pans, a proposal is one of them, inside the arc it splits and the
    /// range, and at least a step from every existing view; and an arc is passed over only
    /// when it holds no such pan (the proposal splits the best-ranked arc that does).
    #[test]
    fn proposals_among_reachable_pans_are_reachable(
        mut degrees in prop::collection::vec(-159.0..159.0f64, 2..12),
        step in 0.01..5.0f64,
        raw_scores in prop::collection::vec(1.0..1000.0f64, 11),
        reachable in prop::collection::vec(-170.0..170.0f64, 0..40),
    ) {
        let (range, pans, scores) = ring(&mut degrees, &raw_scores);
        let Ok(limits) = TurntableLimits::new(range, Angle::from_degrees(step)) else {
            return Err(TestCaseError::fail("limits refused"));
        };
        let reachable: Vec<Angle> = reachable.iter().map(|d| Angle::from_degrees(*d)).collect();
        let planned = plan_next_among(&pans, &scores, &[], Some(&reachable), &limits, &PlanParams::default());
        prop_assert!(planned.is_ok());
        // The arcs with a usable pan inside, by rank (score times width cubed).
        let usable = |i: usize| reachable.iter().any(|r| {
            let d = r.radians();
            d > pans[i].radians() && d < pans[i + 1].radians()
                && d >= range.min().radians() && d <= range.max().radians()
                && pans.iter().all(|q| (d - q.radians()).abs() >= limits.step.radians() - 1e-9)
        });
        let rank = |i: usize| raw_scores[i] * (pans[i + 1].radians() - pans[i].radians()).powi(3);
        let best = (0..pans.len() - 1).filter(|&i| usable(i)).max_by(|&x, &y| rank(x).total_cmp(&rank(y)));
        match planned {
            Ok(Some(p)) => {
                prop_assert!(reachable.contains(&p.pan));
                let (a, b) = p.pair;
                prop_assert!(p.pan.radians() > pans[a].radians() && p.pan.radians() < pans[b].radians());
                prop_assert!(usable(a));
                prop_assert!(best.is_some_and(|i| rank(a) >= rank(i) * (1.0 - 1e-9)), "{:?} against {:?}", a, best);
            }
            Ok(None) => prop_assert!(best.is_none()),
            Err(_) => {}
        }
    }
}
