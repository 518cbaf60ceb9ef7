//! Where would a turntable capture render worst, and where to look next.
//!
//! The heart of active image-based rendering (sections 2.2 and 2.4 of the paper):
//!
//! - [`score_pairs`]: for every pair of neighbouring views on the ring, how badly the arc
//!   between them would render, estimated from the colour consistency of the model seen by the
//!   pair: each view's foreground is mapped through the model into the other view (visibility
//!   checked) and compared, both ways; foreground the model does not explain counts as
//!   maximally inconsistent. Scores are summed over pixels, so a large inconsistent area
//!   outranks a small one; per-pixel error maps come with them.
//! - [`plan_next`]: split the worst pair at its middle angle, within the turntable's range,
//!   quantised to its steps, never within a step of an existing view; arcs are ranked by
//!   score times width to a power ([`PlanParams`]). [`plan_next_aimed`] also takes aims,
//!   pans worth a view of their own: near the middle of the chosen arc, the aim nearest it
//!   replaces the middle. The capture loop aims at [`edge_on_pans`], the pans from which a
//!   flat face of the model (`aibr_voxel::planar_faces`) is seen edge-on: a face seen only
//!   at a slant comes out of voxel coloring a few voxels too fat, and a view in its plane
//!   cuts that away; with [`PlanParams::faces_first`] the planner first serves every face
//!   with a view in its plane, in the best-ranked arc holding one of its edge-on pans.
//!   [`arc_contrast`] says whether evenly spaced views see a view-dependent surface (a mirror's
//!   arcs stand out from the rest), where serving faces first pays.
//!   [`plan_next_among`] plans for a turntable that reaches only some pans
//!   (a replayed ring's recorded views): the reachable pan inside the chosen arc nearest
//!   where the split would be, arcs holding none passed over.
//! - [`foreground`]: masks from a dark background, or from the median backdrop of the views.
//!
//! ```
//! use aibr_camera::{Angle, PanRange};
//! use aibr_consistency::{PairScore, PlanParams, TurntableLimits, plan_next};
//! use image::GrayImage;
//!
//! let limits = TurntableLimits::new(
//!     PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?,
//!     Angle::from_degrees(0.0514285),
//! )?;
//! let pans = [-150.0, -50.0, 50.0, 150.0].map(Angle::from_degrees);
//! let score = |a, b, score| PairScore {
//!     a, b, score, unexplained_pixels: 0, compared_pixels: 0,
//!     error_a: GrayImage::new(1, 1), error_b: GrayImage::new(1, 1),
//! };
//! let scores = [score(0, 1, 10.0), score(1, 2, 900.0), score(2, 3, 40.0)];
//! let next = plan_next(&pans, &scores, &limits, &PlanParams::default())?
//!     .ok_or("nothing to split")?;
//! assert_eq!(next.pair, (1, 2));
//! assert!(next.pan.degrees().abs() < 0.06); // the middle of -50 and 50, in whole steps
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! # Conventions
//! Pan angles are `aibr_camera::Angle` in the turntable's own absolute range (a PTU-46 covers
//! about -159 to +159 degrees); views and the model live in the turntable frame.

pub mod error;
pub mod estimator;
pub mod foreground;
pub mod planner;

pub use error::{Error, Result};
pub use estimator::{
    ConsistencyParams, PairScore, VIEW_DEPENDENT_CONTRAST, arc_contrast, ring_pairs, score_pairs,
};
pub use planner::{
    AIM_DONE_DEG, PlanParams, Proposal, TurntableLimits, edge_on_pans, plan_next, plan_next_aimed,
    plan_next_among,
};
