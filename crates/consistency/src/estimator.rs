//! The rendering-quality estimate of each arc between neighbouring views (section 2.4 of the
//! paper).

use aibr_camera::{Angle, PanRange};
use aibr_voxel::{DepthMap, View, VoxelModel};
use image::{GrayImage, RgbImage};
use nalgebra::Point2;
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Parameters of [`score_pairs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConsistencyParams {
    /// RMS colour differences (grey levels) up to this count as consistent: the small
    /// misregistration any model and resampling leave on textured surfaces (default 25).
    pub colour_tolerance: f32,
    /// RMS colour difference (grey levels) at which a pixel counts as fully inconsistent;
    /// between the tolerance and this, in proportion (default 60).
    pub colour_scale: f32,
    /// A point is visible in the other view when at most this many voxels behind that view's
    /// own depth of the model (default 2).
    pub occlusion_tolerance_voxels: f64,
}

impl Default for ConsistencyParams {
    fn default() -> Self {
        ConsistencyParams {
            colour_tolerance: 25.0,
            colour_scale: 60.0,
            occlusion_tolerance_voxels: 2.0,
        }
    }
}

/// The estimate for the arc between two neighbouring views.
#[derive(Debug, Clone, PartialEq)]
pub struct PairScore {
    /// Index of the view at the smaller pan angle.
    pub a: usize,
    /// Index of the view at the larger pan angle.
    pub b: usize,
    /// How badly the arc would render: the summed per-pixel inconsistency of both views'
    /// foreground (in pixels, so a large inconsistent area outranks a small one).
    pub score: f64,
    /// Foreground pixels of both views the model does not explain (no surface there).
    pub unexplained_pixels: usize,
    /// Foreground pixels of both views compared with the other view.
    pub compared_pixels: usize,
    /// Per-pixel inconsistency of view `a`'s foreground against `b` (0-255; 255 also where
    /// the model explains nothing).
    pub error_a: GrayImage,
    /// The same for view `b` against `a`.
    pub error_b: GrayImage,
}

impl PairScore {
    /// The score as a share of the foreground pixels the pair looked at, compared or
    /// unexplained: 0 where all were consistent, 1 where none was. `None` when it looked at
    /// none.
    pub fn share(&self) -> Option<f64> {
        let pixels = self.compared_pixels + self.unexplained_pixels;
        (pixels > 0).then(|| self.score / pixels as f64)
    }

    /// How inconsistent the pixels the model explains are: the score less what the
    /// unexplained pixels add (1 each), over the pixels compared; 0 where all were
    /// consistent, 1 where none was. `None` when it compared none.
    pub fn compared_share(&self) -> Option<f64> {
        (self.compared_pixels > 0).then(|| {
            let unexplained = self.unexplained_pixels as f64 * UNEXPLAINED_SCORE;
            (self.score - unexplained).max(0.0) / self.compared_pixels as f64
        })
    }
}

/// What a foreground pixel the model does not explain adds to its pair's score: as much as
/// the most inconsistent pixel compared. [`PairScore::compared_share`] takes it back out.
const UNEXPLAINED_SCORE: f64 = 1.0;

/// How far the worst arc stands out from the others: the largest
/// [`PairScore::compared_share`] over the median one (the upper median of an even count).
/// `None` with no arc that compared pixels, or when the median arc is wholly consistent.
///
/// Among evenly spaced views a view-dependent surface stands out: a mirror shows what lies
/// around it, so where the model has a surface the two views of an arc that sees the mirror
/// disagree several times as much as elsewhere, while a Lambertian object's arcs score alike
/// ([`VIEW_DEPENDENT_CONTRAST`]). Only the compared pixels count: the pixels the model leaves
/// unexplained mark the mirror's hole from 12 or more views, but from fewer the sweep leaves
/// holes all round an object, and then they weigh every arc alike and hide the mirror
/// (`docs/results.md`, "Session 77"). Among unevenly spaced views the width of each arc
/// weighs in as much as the surface, so this reads the surface only from evenly spaced ones.
///
/// ```
/// use aibr_consistency::{PairScore, arc_contrast};
/// use image::GrayImage;
///
/// let arc = |score, unexplained_pixels| PairScore {
///     a: 0, b: 1, score, unexplained_pixels, compared_pixels: 1000,
///     error_a: GrayImage::new(1, 1), error_b: GrayImage::new(1, 1),
/// };
/// // The last arc's 400 unexplained pixels add 400 to its score, and are not counted.
/// let scores = [arc(100.0, 0), arc(120.0, 0), arc(110.0, 0), arc(880.0, 400)];
/// let contrast = arc_contrast(&scores).ok_or("no arc compared pixels")?;
/// assert!((contrast - 4.0).abs() < 1e-9); // 0.48 against the median 0.12
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn arc_contrast(scores: &[PairScore]) -> Option<f64> {
    let mut shares: Vec<f64> = scores
        .iter()
        .filter_map(PairScore::compared_share)
        .collect();
    shares.sort_by(f64::total_cmp);
    let (worst, median) = (*shares.last()?, shares[shares.len() / 2]);
    (median > 0.0).then(|| worst / median)
}

/// The [`arc_contrast`] of evenly spaced views at or above which the capture loop takes the
/// object to have a view-dependent surface (`aibr::FacesFirst::Auto`). Measured on the five
/// synthetic scenes, 12 uniform views at each of twelve placements (`docs/results.md`,
/// "Session 77"): `lambertian`, `head` and `chair` 1.03 to 1.34; `mirror` and `mirror-broad`
/// 3.30 to 6.87. 2 lies between, 1.49 times the highest of the first and 1.65 times below
/// the lowest of the second. From 10, 14 or 16 views the matte scenes stay at 1.70 or less
/// and the mirrors at 2.47 or more; from 8 the ranges meet (the matte scenes up to 1.59, the
/// mirrors from 1.64).
pub const VIEW_DEPENDENT_CONTRAST: f64 = 2.0;

/// Neighbouring pairs of views on the ring, by pan angle: `(i, j)` with `pans[i] < pans[j]`
/// adjacent. On a full-turn range the last view pairs with the first; on a partial range the
/// opening is not an arc.
pub fn ring_pairs(pans: &[Angle], range: &PanRange) -> Vec<(usize, usize)> {
    let mut order: Vec<usize> = (0..pans.len()).collect();
    order.sort_by(|&a, &b| {
        pans[a]
            .radians()
            .total_cmp(&pans[b].radians())
            .then(a.cmp(&b))
    });
    let mut pairs: Vec<(usize, usize)> = order.windows(2).map(|w| (w[0], w[1])).collect();
    if range.is_full_turn() && order.len() > 2 {
        if let (Some(&first), Some(&last)) = (order.first(), order.last()) {
            pairs.push((last, first));
        }
    }
    pairs
}

/// Scores every neighbouring pair of `views` (whose pan angles are `pans`) through `model`.
///
/// For each foreground pixel of one view: where the model has no surface, the pixel is
/// unexplained and counts 1 (this is what makes the mirror side of the paper's object score
/// worst: voxel coloring leaves a hole there); otherwise the surface point is projected into
/// the other view and, where that view sees it unoccluded, the RMS colour difference counts:
/// nothing up to `colour_tolerance`, 1 from `colour_scale`, in proportion between. Both
/// directions are summed.
pub fn score_pairs(
    model: &VoxelModel,
    views: &[View<'_>],
    pans: &[Angle],
    range: &PanRange,
    params: &ConsistencyParams,
) -> Result<Vec<PairScore>> {
    if pans.len() != views.len() {
        return Err(Error::CountMismatch {
            pans: pans.len(),
            views: views.len(),
        });
    }
    if !(params.colour_tolerance >= 0.0 && params.colour_scale > params.colour_tolerance) {
        return Err(Error::InvalidParameter {
            name: "colour_scale",
            value: params.colour_scale as f64,
            reason: "must exceed a non-negative colour_tolerance",
        });
    }
    for (i, v) in views.iter().enumerate() {
        let Some(mask) = v.mask else {
            return Err(Error::NoMask { view: i });
        };
        let size = v.camera.size;
        for (what, dims) in [("image", v.image.dimensions()), ("mask", mask.dimensions())] {
            if dims != (size.width, size.height) {
                return Err(Error::SizeMismatch {
                    what,
                    width: dims.0,
                    height: dims.1,
                    expected_width: size.width,
                    expected_height: size.height,
                });
            }
        }
    }
    let depths: Vec<DepthMap> = views
        .par_iter()
        .map(|v| model.depth_map(v.camera))
        .collect();
    let tolerance = params.occlusion_tolerance_voxels * model.grid().voxel_size();
    let pairs = ring_pairs(pans, range);
    // Each view's foreground is checked against every view it pairs with in one pass, so each
    // pixel is unprojected once; `slots[i]` says where pair `i`'s two checks land in the lists
    // of its views.
    let mut partners: Vec<Vec<usize>> = vec![Vec::new(); views.len()];
    let mut slots = Vec::with_capacity(pairs.len());
    for &(a, b) in &pairs {
        partners[a].push(b);
        let at_a = partners[a].len() - 1;
        partners[b].push(a);
        slots.push((at_a, partners[b].len() - 1));
    }
    let mut checks: Vec<Vec<OneWay>> = partners
        .par_iter()
        .enumerate()
        .map(|(v, to)| {
            let targets: Vec<(&View<'_>, &DepthMap)> =
                to.iter().map(|&t| (&views[t], &depths[t])).collect();
            check_against(&views[v], &depths[v], &targets, tolerance, params)
        })
        .collect();
    Ok(pairs
        .iter()
        .zip(slots)
        .map(|(&(a, b), (at_a, at_b))| {
            let ab = std::mem::take(&mut checks[a][at_a]);
            let ba = std::mem::take(&mut checks[b][at_b]);
            PairScore {
                a,
                b,
                score: ab.score + ba.score,
                unexplained_pixels: ab.unexplained + ba.unexplained,
                compared_pixels: ab.compared + ba.compared,
                error_a: ab.map,
                error_b: ba.map,
            }
        })
        .collect())
}

/// One view's foreground checked against another view.
#[derive(Debug, Default, PartialEq)]
struct OneWay {
    score: f64,
    unexplained: usize,
    compared: usize,
    map: GrayImage,
}

/// The foreground of `from` checked against each of `targets` (a view and its depth map): one
/// [`OneWay`] per target, in their order, each as if checked alone.
fn check_against(
    from: &View<'_>,
    from_depth: &DepthMap,
    targets: &[(&View<'_>, &DepthMap)],
    tolerance: f64,
    params: &ConsistencyParams,
) -> Vec<OneWay> {
    let size = from.camera.size;
    let mut out: Vec<OneWay> = targets
        .iter()
        .map(|_| OneWay {
            map: GrayImage::new(size.width, size.height),
            ..OneWay::default()
        })
        .collect();
    let Some(mask) = from.mask else {
        return out;
    };
    for (x, y, m) in mask.enumerate_pixels() {
        if m.0[0] == 0 {
            continue;
        }
        let d = from_depth.get_pixel(x, y).0[0];
        if !d.is_finite() {
            for o in &mut out {
                o.unexplained += 1;
                o.score += UNEXPLAINED_SCORE;
                o.map.put_pixel(x, y, image::Luma([255]));
            }
            continue;
        }
        let Some(p) = from
            .camera
            .unproject(Point2::new(x as f64, y as f64), d as f64)
        else {
            continue;
        };
        let s = from.image.get_pixel(x, y).0;
        for (&(to, to_depth), o) in targets.iter().zip(&mut out) {
            let Some(q) = to.camera.project(&p) else {
                continue;
            };
            if !to.camera.size.contains(q) {
                continue;
            }
            let seen = to_depth
                .get_pixel_checked(round_index(q.x), round_index(q.y))
                .map(|t| t.0[0]);
            if seen.is_none_or(|t| to.camera.depth_of(&p) > t as f64 + tolerance) {
                continue; // occluded in the other view: not comparable
            }
            let c = sample(to.image, q.x, q.y);
            let diff = ((0..3).map(|i| (s[i] as f32 - c[i]).powi(2)).sum::<f32>() / 3.0).sqrt();
            let e = ((diff - params.colour_tolerance)
                / (params.colour_scale - params.colour_tolerance))
                .clamp(0.0, 1.0);
            o.score += e as f64;
            o.compared += 1;
            o.map.put_pixel(x, y, image::Luma([grey(e)]));
        }
    }
    out
}

/// `x.round().max(0.0) as u32` (the nearest pixel index, halves away from zero, negatives and
/// NaN to 0) without libm's `round`, a call on baseline x86-64, which has no rounding
/// instruction: `x - trunc(x)` is exact, so the two agree for every `x`.
fn round_index(x: f64) -> u32 {
    let x = x.max(0.0);
    let t = x as u32;
    if x - t as f64 >= 0.5 {
        t.saturating_add(1)
    } else {
        t
    }
}

/// `(e * 255.0).round() as u8` through [`round_index`]: the `f32` widens exactly, so its
/// nearest integer is the same, and above 255 saturates as the cast did.
fn grey(e: f32) -> u8 {
    u8::try_from(round_index(f64::from(e * 255.0))).unwrap_or(u8::MAX)
}

fn sample(img: &RgbImage, u: f64, v: f64) -> [f32; 3] {
    let (w, h) = (img.width() as f64, img.height() as f64);
    let (u, v) = (u.clamp(0.0, w - 1.0), v.clamp(0.0, h - 1.0));
    // Truncation is the floor of the clamped (non-negative) coordinates, without libm's call;
    // a NaN gives 0 and a NaN weight, as `floor` did.
    let (x0, y0) = (u as u32, v as u32);
    let (fx, fy) = ((u - x0 as f64) as f32, (v - y0 as f64) as f32);
    let (x1, y1) = (
        (x0 + 1).min(img.width() - 1),
        (y0 + 1).min(img.height() - 1),
    );
    let p = |x, y| img.get_pixel(x, y).0.map(|c| c as f32);
    let (a, b, c, d) = (p(x0, y0), p(x1, y0), p(x0, y1), p(x1, y1));
    std::array::from_fn(|i| {
        let top = a[i] + (b[i] - a[i]) * fx;
        let bottom = c[i] + (d[i] - c[i]) * fx;
        top + (bottom - top) * fy
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use aibr_scene::{RenderOptions, catalogue};
    use aibr_voxel::{ColoringParams, VoxelGrid, voxel_coloring};
    use proptest::prelude::*;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    proptest! {
        #[test]
        fn round_index_is_libm_round(bits in any::<u64>()) {
            let x = f64::from_bits(bits);
            prop_assert_eq!(round_index(x), x.round().max(0.0) as u32, "x = {}", x);
        }

        #[test]
        fn round_index_is_libm_round_on_pixels(x in -2.0f64..700.0) {
            prop_assert_eq!(round_index(x), x.round().max(0.0) as u32, "x = {}", x);
        }

        #[test]
        fn grey_is_libm_round(bits in any::<u32>()) {
            let e = f32::from_bits(bits);
            prop_assert_eq!(grey(e), (e * 255.0).round() as u8, "e = {}", e);
        }

        #[test]
        fn grey_is_libm_round_on_errors(e in 0.0f32..=1.0) {
            prop_assert_eq!(grey(e), (e * 255.0).round() as u8, "e = {}", e);
        }
    }

    #[test]
    fn rounding_at_the_halves() {
        for (x, r) in [
            (0.5, 1),
            (1.5, 2),
            (2.5, 3),
            (0.49999999999999994, 0),
            (-0.5, 0),
        ] {
            assert_eq!(round_index(x), r, "x = {x}");
        }
        assert_eq!(grey(0.5 / 255.0), (0.5f32 / 255.0 * 255.0).round() as u8);
        assert_eq!(grey(f32::NAN), 0);
        assert_eq!(round_index(f64::NAN), 0);
        assert_eq!(round_index(f64::INFINITY), u32::MAX);
    }

    /// A score over `pixels` pixels, all compared.
    fn arc(score: f64, pixels: usize) -> PairScore {
        PairScore {
            a: 0,
            b: 1,
            score,
            unexplained_pixels: 0,
            compared_pixels: pixels,
            error_a: GrayImage::new(1, 1),
            error_b: GrayImage::new(1, 1),
        }
    }

    proptest! {
        /// The contrast is at least 1, the worst share over the upper median, and does not
        /// change when every arc looks at more pixels in proportion.
        #[test]
        fn contrast_is_the_worst_share_over_the_median(
            arcs in prop::collection::vec((1.0f64..1000.0, 1000usize..5000), 1..20),
            scale in 1usize..5,
        ) {
            let scores: Vec<PairScore> = arcs.iter().map(|&(s, p)| arc(s, p)).collect();
            let contrast = arc_contrast(&scores).ok_or_else(|| TestCaseError::fail("no contrast"))?;
            let mut shares: Vec<f64> = arcs.iter().map(|&(s, p)| s / p as f64).collect();
            shares.sort_by(f64::total_cmp);
            prop_assert!(contrast >= 1.0);
            prop_assert_eq!(contrast, shares[shares.len() - 1] / shares[shares.len() / 2]);
            let scaled: Vec<PairScore> =
                arcs.iter().map(|&(s, p)| arc(s * scale as f64, p * scale)).collect();
            let again = arc_contrast(&scaled).ok_or_else(|| TestCaseError::fail("no contrast"))?;
            prop_assert!((again - contrast).abs() <= 1e-9 * contrast);
        }
    }

    #[test]
    fn no_contrast_without_pixels_or_with_a_consistent_median() {
        assert_eq!(arc_contrast(&[]), None);
        assert_eq!(arc_contrast(&[arc(0.0, 0), arc(5.0, 0)]), None);
        assert_eq!(arc(5.0, 0).share(), None);
        // The median arc wholly consistent: no ratio to take.
        assert_eq!(
            arc_contrast(&[arc(0.0, 100), arc(0.0, 100), arc(9.0, 100)]),
            None
        );
        // Arcs that looked at nothing are left out, not counted as consistent.
        let contrast = arc_contrast(&[arc(1.0, 100), arc(0.0, 0), arc(3.0, 100)]);
        assert_eq!(contrast, Some(1.0));
    }

    /// Pixels the model leaves unexplained do not count: holes all round an object (as the
    /// sweep leaves from sparse views) cannot hide the arc whose compared pixels disagree, nor
    /// can a hole in one arc make it stand out.
    #[test]
    fn contrast_reads_the_compared_pixels_only() -> TestResult {
        let with_holes = |score: f64, unexplained: usize| PairScore {
            unexplained_pixels: unexplained,
            score: score + unexplained as f64,
            ..arc(0.0, 1000)
        };
        // Every arc half unexplained, one disagreeing nearly four times as much where compared.
        let holes_everywhere = [
            with_holes(100.0, 1000),
            with_holes(110.0, 900),
            with_holes(120.0, 1100),
            with_holes(440.0, 1000),
        ];
        let contrast = arc_contrast(&holes_everywhere).ok_or("no contrast")?;
        assert!((contrast - 440.0 / 120.0).abs() < 1e-9, "{contrast}");
        // By the whole share these arcs would look alike (0.53 to 0.72).
        let shares: Vec<f64> = holes_everywhere
            .iter()
            .filter_map(PairScore::share)
            .collect();
        assert!(shares.iter().all(|s| (0.5..0.75).contains(s)), "{shares:?}");
        // One arc with a hole and nothing else wrong does not stand out.
        let one_hole = [arc(100.0, 1000), with_holes(100.0, 3000), arc(100.0, 1000)];
        assert_eq!(arc_contrast(&one_hole), Some(1.0));
        assert_eq!(with_holes(100.0, 3000).compared_share(), Some(0.1));
        assert_eq!(arc(5.0, 0).compared_share(), None);
        Ok(())
    }

    /// Every pair's two checks, each made alone, are what `score_pairs` reports for it: the
    /// shared pass over a view's foreground changes nothing, and each check lands in its pair
    /// (a whole turn, so the last view pairs with the first too).
    #[test]
    fn pairs_hold_their_own_checks() -> TestResult {
        let scene = catalogue::head()?;
        let pans = scene.rig.uniform_pans(5);
        let shots = scene.shoot(&pans, &RenderOptions::default())?;
        let views: Vec<View<'_>> = shots
            .iter()
            .map(|s| View {
                camera: &s.camera,
                image: &s.image,
                mask: Some(&s.frame.mask),
            })
            .collect();
        let grid = VoxelGrid::with_resolution(scene.bounds(), 48)?;
        let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
        let range = PanRange::full_turn();
        let params = ConsistencyParams::default();
        let scores = score_pairs(&model, &views, &pans, &range, &params)?;
        assert_eq!(scores.len(), 5);
        let depths: Vec<DepthMap> = views.iter().map(|v| model.depth_map(v.camera)).collect();
        let tolerance = params.occlusion_tolerance_voxels * grid.voxel_size();
        let alone = |from: usize, to: usize| {
            check_against(
                &views[from],
                &depths[from],
                &[(&views[to], &depths[to])],
                tolerance,
                &params,
            )
            .pop()
        };
        for s in &scores {
            let (Some(ab), Some(ba)) = (alone(s.a, s.b), alone(s.b, s.a)) else {
                return Err("a check made alone gave nothing".into());
            };
            assert!(
                ab.compared > 0 && ba.compared > 0,
                "pair ({}, {})",
                s.a,
                s.b
            );
            assert_eq!(s.score.to_bits(), (ab.score + ba.score).to_bits());
            assert_eq!(s.unexplained_pixels, ab.unexplained + ba.unexplained);
            assert_eq!(s.compared_pixels, ab.compared + ba.compared);
            assert!(
                s.error_a == ab.map && s.error_b == ba.map,
                "pair ({}, {})",
                s.a,
                s.b
            );
        }
        // Two targets in one pass, in either order, give each target's check made alone.
        for targets in [[0, 2], [2, 0]] {
            let both = check_against(
                &views[1],
                &depths[1],
                &targets.map(|t| (&views[t], &depths[t])),
                tolerance,
                &params,
            );
            let apart: Vec<OneWay> = targets.iter().filter_map(|&t| alone(1, t)).collect();
            assert!(both == apart, "targets {targets:?}");
        }
        Ok(())
    }
}
