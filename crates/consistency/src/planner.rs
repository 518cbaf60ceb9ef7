//! The split planner: where to capture the next view.

use aibr_camera::{Angle, CircularMotion, PanRange};
use aibr_voxel::PlanarFace;

use crate::error::{Error, Result};
use crate::estimator::PairScore;

/// What the turntable can do, for planning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurntableLimits {
    /// The pan range it can reach.
    pub range: PanRange,
    /// Its resolution: the angle of one step. Proposals are whole steps, and never closer
    /// than one step to an existing view.
    pub step: Angle,
}

impl TurntableLimits {
    /// Limits of a turntable with `range` and `step`; rejects a step that is not positive.
    pub fn new(range: PanRange, step: Angle) -> Result<Self> {
        if !(step.radians() > 0.0 && step.radians().is_finite()) {
            return Err(Error::InvalidParameter {
                name: "turntable step (rad)",
                value: step.radians(),
                reason: "must be positive",
            });
        }
        Ok(TurntableLimits { range, step })
    }

    /// `angle` rounded to a whole number of steps.
    pub fn quantise(&self, angle: Angle) -> Angle {
        let s = self.step.radians();
        Angle::from_radians((angle.radians() / s).round() * s)
    }
}

/// A proposal of the planner.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Proposal {
    /// The pan angle to capture next (quantised, inside the range).
    pub pan: Angle,
    /// The pair whose arc it splits.
    pub pair: (usize, usize),
    /// That pair's score.
    pub score: f64,
}

/// How [`plan_next`] ranks the arcs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanParams {
    /// Arcs scoring at or below this already render well and are never split; when every arc
    /// does, the planner proposes nothing (default 0: only a perfectly consistent arc).
    pub consistent_below: f64,
    /// Arcs are ranked by their score times their angular width to this power (default 3;
    /// between 0 and 8). Width 1 ranks by the score's mass over the arc; higher powers
    /// split wide arcs first unless a narrow one scores far worse, which keeps the views
    /// nearer to even, the measure a mean of per-view PSNRs rewards (`docs/consistency.md`).
    pub width_power: f64,
    /// How far from the middle of the arc to split an aim may draw the proposal, as a share
    /// of the arc's half-width (default 0.5: the middle half of the arc; 0 never moves it).
    /// Aims are the pans that see a flat face of the model edge-on ([`edge_on_pans`]): a
    /// view there cuts away the wedge of visual hull a face seen only at a slant keeps.
    pub aim_reach: f64,
    /// Serve every face first (default false): while a flat face of the model has no view
    /// within `face_served_deg` of any of its edge-on pans, the best-ranked arc that holds one
    /// of those pans is split there, whatever `aim_reach`; only then are arcs split by rank
    /// alone ([`plan_next_aimed`]). On `mirror` it puts a view in every face's plane by 24
    /// views and renders better there, at a cost on `lambertian` and a large one on `head`,
    /// whose many faces take most of the views (`docs/results.md`, "Session 38"). Since each
    /// face's plane is refitted to its outer profile (session 71), the cost on `lambertian`
    /// is 0.36 dB against uniform capture at 24 views from 12 initial ones, beyond issue 7's
    /// 0.2 dB bound, and 0.19 at 36 (`docs/results.md`, "Session 74"). So `aibr`'s capture
    /// loop sets it, by default, only when its initial views show a view-dependent surface
    /// ([`arc_contrast`](crate::arc_contrast) at least
    /// [`VIEW_DEPENDENT_CONTRAST`](crate::VIEW_DEPENDENT_CONTRAST)).
    pub faces_first: bool,
    /// Serving faces first, a face counts as served when a view lies within this many degrees
    /// of one of its edge-on pans (default [`AIM_DONE_DEG`], 1; more than 0, at most
    /// [`PlanParams::MAX_FACE_SERVED_DEG`]). Unused without `faces_first`. At 2.5 degrees
    /// `lambertian` and `head` rendered a little better with 24 views and `mirror` worse, some
    /// of its faces fat again; at 0.5, `mirror` spent views in pairs a degree apart and
    /// rendered worse with 24 views, better with 36 and 48 (`docs/results.md`, "Session 39").
    /// Since each face's plane is refitted to its outer profile (session 71), 0.5 renders
    /// `mirror` best with 24 views from 8 initial ones, by 0.04 dB, and the same as 1 from 12.
    pub face_served_deg: f64,
}

impl Default for PlanParams {
    fn default() -> Self {
        PlanParams {
            consistent_below: 0.0,
            width_power: 3.0,
            aim_reach: 0.5,
            faces_first: false,
            face_served_deg: AIM_DONE_DEG,
        }
    }
}

impl PlanParams {
    /// The largest width power accepted.
    pub const MAX_WIDTH_POWER: f64 = 8.0;

    /// The widest tolerance for a face served (degrees). A view that far from a face's plane
    /// sees it at a slant: faces came out thin only with a view within about 2.5 degrees
    /// (`docs/results.md`, "Session 22").
    pub const MAX_FACE_SERVED_DEG: f64 = 10.0;

    /// Rejects a negative or non-finite threshold, a width power outside
    /// `0..=MAX_WIDTH_POWER`, an aim reach outside `0..=1` and a face tolerance outside
    /// `(0, MAX_FACE_SERVED_DEG]`.
    pub fn validate(&self) -> Result<()> {
        if !(self.consistent_below >= 0.0 && self.consistent_below.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "consistent_below",
                value: self.consistent_below,
                reason: "must be a finite score of 0 or more",
            });
        }
        if !(0.0..=Self::MAX_WIDTH_POWER).contains(&self.width_power) {
            return Err(Error::InvalidParameter {
                name: "width_power",
                value: self.width_power,
                reason: "must be between 0 and 8",
            });
        }
        if !(0.0..=1.0).contains(&self.aim_reach) {
            return Err(Error::InvalidParameter {
                name: "aim_reach",
                value: self.aim_reach,
                reason: "must be between 0 and 1",
            });
        }
        if !(self.face_served_deg > 0.0 && self.face_served_deg <= Self::MAX_FACE_SERVED_DEG) {
            return Err(Error::InvalidParameter {
                name: "face_served_deg",
                value: self.face_served_deg,
                reason: "must be more than 0 and at most 10 degrees",
            });
        }
        Ok(())
    }
}

/// An aim is done when a view lies within this angle of it (1 degree): the faces of
/// `docs/results.md` came out thin with a camera centre 1-13 mm from their plane, 0.1-1.4
/// degrees of pan at the catalogue's 0.55 m.
pub const AIM_DONE_DEG: f64 = 1.0;

/// The pans of `range` from which the camera sees `face` edge-on: where its centre lies in
/// the face's plane. `motion` is the turntable's pose model, in the frame of the model the
/// face was found in; its axis may be any line (the plane and the camera's circle are taken
/// into the turntable frame of `motion`, where the axis is +Z through the origin and the
/// centre at pan `t` is `Rot_z(-t)` of the centre at pan 0, `aibr-camera`'s convention).
/// Empty when the circle misses the plane.
pub fn edge_on_pans(face: &PlanarFace, motion: &CircularMotion, range: &PanRange) -> Vec<Angle> {
    let to_turntable = motion.turntable_from_world();
    let n = to_turntable.rotation * face.normal;
    // n . y = offset + n . translation for the plane's points y in the turntable frame.
    let offset = face.offset_m + n.dot(&to_turntable.translation.vector);
    let c = to_turntable * motion.centre_at_zero();
    let (m, rho) = (n.x.hypot(n.y), c.x.hypot(c.y));
    if !(m * rho > 1e-12) {
        return Vec::new();
    }
    // n . Rot_z(-t) c = (Rot_z(t) n) . c = m rho cos(phi + t - alpha) + n_z c_z.
    let q = (offset - n.z * c.z) / (m * rho);
    if !(q.abs() <= 1.0) {
        return Vec::new();
    }
    let base = c.y.atan2(c.x) - n.y.atan2(n.x);
    let spread = q.acos();
    let mut out: Vec<Angle> = [base - spread, base + spread]
        .into_iter()
        .filter_map(|t| range.normalize(Angle::from_radians(t)))
        .collect();
    out.dedup_by(|a, b| a.wrapped_difference(*b).radians().abs() < 1e-9);
    out
}

/// Splits the worst arc at its middle angle: [`plan_next_aimed`] with no aims.
pub fn plan_next(
    pans: &[Angle],
    scores: &[PairScore],
    limits: &TurntableLimits,
    params: &PlanParams,
) -> Result<Option<Proposal>> {
    plan_next_aimed(pans, scores, &[], limits, params)
}

/// Splits the worst arc at its middle angle, or at an aim near it.
///
/// Arcs are ranked by their score times their angular width (radians) to the power
/// `params.width_power`: an inconsistency the model cannot explain (the hole voxel coloring
/// leaves on a mirror) shows in every view near it, however close, so the score alone would
/// split the same arc again and again, while the rendering error over an arc grows with its
/// width. Arcs scoring at or below `params.consistent_below` are skipped (they already render
/// well); the first whose middle angle, quantised to the turntable's steps, lies inside the
/// range and at least one step from every existing view is proposed. `Ok(None)` when every
/// arc is consistent or too short to split; an error when `params` are out of their domain.
///
/// `aims` are pans worth a view of their own, one list per flat face of the model: the pans
/// that see it edge-on ([`edge_on_pans`]). An aim with a view within [`AIM_DONE_DEG`] is done.
/// When one that is not lies inside the chosen arc within `params.aim_reach` of its
/// half-width from the middle, the one nearest the middle is proposed instead of the middle:
/// the arc to split is the estimate's choice, where in it the aims' (`docs/consistency.md`).
///
/// With `params.faces_first`, a face is done when a view lies within
/// `params.face_served_deg` (instead of [`AIM_DONE_DEG`]) of any of its pans (either sees the
/// same plane), and while one is not, the best-ranked arc that holds one of its pans is split
/// there (the one nearest the arc's middle when several are), wherever in the arc it lies;
/// only when no arc holds a pan of an open face are arcs split as above.
pub fn plan_next_aimed(
    pans: &[Angle],
    scores: &[PairScore],
    aims: &[Vec<Angle>],
    limits: &TurntableLimits,
    params: &PlanParams,
) -> Result<Option<Proposal>> {
    plan_next_among(pans, scores, aims, None, limits, params)
}

/// [`plan_next_aimed`] for a turntable that reaches only the pans of `reachable` (`None`: every
/// whole step of the range, which is [`plan_next_aimed`]): a rig replaying a recorded ring
/// returns recorded views only. The arcs are ranked as there; the proposal is the pan of
/// `reachable` inside the chosen arc, inside the range and at least a step from every existing
/// view, nearest to where [`plan_next_aimed`] would split it (an aim within reach, else the
/// middle). An arc that holds no such pan is passed over, as an arc too short to split is:
/// asking for its middle would bring back a view from another arc, and the arc would stay the
/// worst, so every later request would too.
///
/// ```
/// use aibr_camera::{Angle, PanRange};
/// use aibr_consistency::{PairScore, PlanParams, TurntableLimits, plan_next_among};
/// use image::GrayImage;
///
/// let limits = TurntableLimits::new(PanRange::full_turn(), Angle::from_degrees(0.1))?;
/// let pans = [-90.0, 0.0, 30.0].map(Angle::from_degrees);
/// let score = |a, b, score| PairScore {
///     a, b, score, unexplained_pixels: 0, compared_pixels: 0,
///     error_a: GrayImage::new(1, 1), error_b: GrayImage::new(1, 1),
/// };
/// let scores = [score(0, 1, 100.0), score(1, 2, 100.0)];
/// // The wide arc ranks first, but nothing can be reached inside it.
/// let reachable = [-100.0, 12.0, 20.0].map(Angle::from_degrees);
/// let plan = PlanParams::default();
/// let next = plan_next_among(&pans, &scores, &[], Some(&reachable), &limits, &plan)?
///     .ok_or("nothing to split")?;
/// assert_eq!(next.pair, (1, 2));
/// assert_eq!(next.pan, Angle::from_degrees(12.0)); // the nearest to the middle, 15
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn plan_next_among(
    pans: &[Angle],
    scores: &[PairScore],
    aims: &[Vec<Angle>],
    reachable: Option<&[Angle]>,
    limits: &TurntableLimits,
    params: &PlanParams,
) -> Result<Option<Proposal>> {
    params.validate()?;
    // An aim is done when a view lies within `done` of it; serving faces, a face is done when
    // one lies within that of any of its edge-on pans; otherwise each pan is an aim of its own
    // (as measured since session 25).
    let done = if params.faces_first {
        params.face_served_deg
    } else {
        AIM_DONE_DEG
    }
    .to_radians();
    // How far `pan` lies from the nearest view (radians; infinite with none).
    let from_views = |pan: Angle| {
        pans.iter()
            .map(|p| pan.wrapped_difference(*p).radians().abs())
            .fold(f64::INFINITY, f64::min)
    };
    let open = |a: &Angle| from_views(*a) > done;
    let open_aims: Vec<Angle> = aims
        .iter()
        .filter(|face| !params.faces_first || face.iter().all(open))
        .flatten()
        .copied()
        .filter(open)
        .collect();
    // The arc from a to b, in the pair's own order (b after a, a turn later across the wrap).
    let gap = |s: &PairScore| -> Option<f64> {
        let (pa, pb) = (pans.get(s.a)?, pans.get(s.b)?);
        let mut g = pb.radians() - pa.radians();
        if g <= 0.0 {
            g += std::f64::consts::TAU;
        }
        Some(g)
    };
    let mut order: Vec<(f64, &PairScore)> = scores
        .iter()
        .filter(|s| s.score > params.consistent_below)
        .filter_map(|s| gap(s).map(|g| (s.score * g.powf(params.width_power), s)))
        .collect();
    order.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.a.cmp(&y.1.a)));
    let step = limits.step.radians();
    let far_enough = |pan: Angle| from_views(pan) >= step - 1e-9;
    // The reachable pans a proposal may be: inside the range, a step from every view.
    let candidates: Option<Vec<Angle>> = reachable.map(|r| {
        r.iter()
            .filter_map(|p| limits.range.normalize(*p))
            .filter(|p| far_enough(*p))
            .collect()
    });
    // Where in the arc of `s` to split. With `serve_faces`, only at an open aim anywhere inside
    // it, at a pan within `done` of the aim (`None` when there is none); otherwise at the open
    // aim nearest the middle within reach, else the middle.
    let split = |s: &PairScore, serve_faces: bool| -> Option<Angle> {
        let (pa, gap) = (pans.get(s.a)?, gap(s)?);
        let middle = gap / 2.0;
        // Offsets from the arc's start.
        let offset = |pan: &Angle| (pan.radians() - pa.radians()).rem_euclid(std::f64::consts::TAU);
        let reach = if serve_faces {
            middle
        } else {
            params.aim_reach * middle
        };
        // The aims within reach, nearest the middle first.
        let mut aims: Vec<f64> = open_aims
            .iter()
            .map(offset)
            .filter(|o| *o > 0.0 && *o < gap && (o - middle).abs() <= reach)
            .collect();
        aims.sort_by(|x, y| (x - middle).abs().total_cmp(&(y - middle).abs()));
        // The pan for a split at offset `o`, and how far from `o` it may lie.
        let at = |o: f64, within: f64| -> Option<Angle> {
            match &candidates {
                None => {
                    let pan = limits.quantise(Angle::from_radians(pa.radians() + o));
                    limits.range.normalize(pan).filter(|p| far_enough(*p))
                }
                Some(candidates) => candidates
                    .iter()
                    .map(|p| (offset(p), *p))
                    .filter(|(c, _)| *c > 0.0 && *c < gap && (c - o).abs() <= within)
                    .min_by(|x, y| (x.0 - o).abs().total_cmp(&(y.0 - o).abs()))
                    .map(|(_, p)| p),
            }
        };
        if serve_faces {
            // A face is served only by a pan that serves it (on a replayed ring, a recorded
            // view within `done` of its pan).
            aims.iter().find_map(|&o| at(o, done))
        } else {
            // Anywhere in the arc, nearest the aim, else nearest the middle.
            let anywhere = |o: f64| at(o, f64::INFINITY);
            aims.first()
                .and_then(|&o| anywhere(o))
                .or_else(|| anywhere(middle))
        }
    };
    // Serving faces first: a pass over the arcs for an open face, then one for the rank alone.
    let passes: &[bool] = if params.faces_first {
        &[true, false]
    } else {
        &[false]
    };
    for &serve_faces in passes {
        for (_, s) in &order {
            if let Some(pan) = split(s, serve_faces) {
                return Ok(Some(Proposal {
                    pan,
                    pair: (s.a, s.b),
                    score: s.score,
                }));
            }
        }
    }
    Ok(None)
}
