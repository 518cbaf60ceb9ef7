//! The split planner: where to capture the next view.

use aibr_camera::{Angle, PanRange};

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
}

impl Default for PlanParams {
    fn default() -> Self {
        PlanParams {
            consistent_below: 0.0,
            width_power: 3.0,
        }
    }
}

impl PlanParams {
    /// The largest width power accepted.
    pub const MAX_WIDTH_POWER: f64 = 8.0;

    /// Rejects a negative or non-finite threshold, and a width power outside
    /// `0..=MAX_WIDTH_POWER`.
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
        Ok(())
    }
}

/// Splits the worst arc at its middle angle.
///
/// Arcs are ranked by their score times their angular width (radians) to the power
/// `params.width_power`: an inconsistency the model cannot explain (the hole voxel coloring
/// leaves on a mirror) shows in every view near it, however close, so the score alone would
/// split the same arc again and again, while the rendering error over an arc grows with its
/// width. Arcs scoring at or below `params.consistent_below` are skipped (they already render
/// well); the first whose middle angle, quantised to the turntable's steps, lies inside the
/// range and at least one step from every existing view is proposed. `Ok(None)` when every
/// arc is consistent or too short to split; an error when `params` are out of their domain.
pub fn plan_next(
    pans: &[Angle],
    scores: &[PairScore],
    limits: &TurntableLimits,
    params: &PlanParams,
) -> Result<Option<Proposal>> {
    params.validate()?;
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
    for (_, s) in order {
        let (Some(pa), Some(gap)) = (pans.get(s.a), gap(s)) else {
            continue;
        };
        let middle = limits.quantise(Angle::from_radians(pa.radians() + gap / 2.0));
        let Some(middle) = limits.range.normalize(middle) else {
            continue;
        };
        let far_enough = pans
            .iter()
            .all(|p| middle.wrapped_difference(*p).radians().abs() >= step - 1e-9);
        if far_enough {
            return Ok(Some(Proposal {
                pan: middle,
                pair: (s.a, s.b),
                score: s.score,
            }));
        }
    }
    Ok(None)
}
