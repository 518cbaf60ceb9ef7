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
    Ok(pairs
        .par_iter()
        .map(|&(a, b)| {
            let ab = one_way(
                &views[a], &depths[a], &views[b], &depths[b], tolerance, params,
            );
            let ba = one_way(
                &views[b], &depths[b], &views[a], &depths[a], tolerance, params,
            );
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

struct OneWay {
    score: f64,
    unexplained: usize,
    compared: usize,
    map: GrayImage,
}

/// The foreground of `from` checked against `to`.
fn one_way(
    from: &View<'_>,
    from_depth: &DepthMap,
    to: &View<'_>,
    to_depth: &DepthMap,
    tolerance: f64,
    params: &ConsistencyParams,
) -> OneWay {
    let size = from.camera.size;
    let mut map = GrayImage::new(size.width, size.height);
    let (mut score, mut unexplained, mut compared) = (0.0, 0, 0);
    let Some(mask) = from.mask else {
        return OneWay {
            score,
            unexplained,
            compared,
            map,
        };
    };
    for (x, y, m) in mask.enumerate_pixels() {
        if m.0[0] == 0 {
            continue;
        }
        let d = from_depth.get_pixel(x, y).0[0];
        if !d.is_finite() {
            unexplained += 1;
            score += 1.0;
            map.put_pixel(x, y, image::Luma([255]));
            continue;
        }
        let Some(p) = from
            .camera
            .unproject(Point2::new(x as f64, y as f64), d as f64)
        else {
            continue;
        };
        let Some(q) = to.camera.project(&p) else {
            continue;
        };
        if !to.camera.size.contains(q) {
            continue;
        }
        let (qu, qv) = (q.x.round().max(0.0) as u32, q.y.round().max(0.0) as u32);
        let seen = to_depth.get_pixel_checked(qu, qv).map(|t| t.0[0]);
        if seen.is_none_or(|t| to.camera.depth_of(&p) > t as f64 + tolerance) {
            continue; // occluded in the other view: not comparable
        }
        let c = sample(to.image, q.x, q.y);
        let s = from.image.get_pixel(x, y).0;
        let diff = ((0..3).map(|i| (s[i] as f32 - c[i]).powi(2)).sum::<f32>() / 3.0).sqrt();
        let e = ((diff - params.colour_tolerance)
            / (params.colour_scale - params.colour_tolerance))
            .clamp(0.0, 1.0);
        score += e as f64;
        compared += 1;
        map.put_pixel(x, y, image::Luma([(e * 255.0).round() as u8]));
    }
    OneWay {
        score,
        unexplained,
        compared,
        map,
    }
}

fn sample(img: &RgbImage, u: f64, v: f64) -> [f32; 3] {
    let (w, h) = (img.width() as f64, img.height() as f64);
    let (u, v) = (u.clamp(0.0, w - 1.0), v.clamp(0.0, h - 1.0));
    let (x0, y0) = (u.floor(), v.floor());
    let (fx, fy) = ((u - x0) as f32, (v - y0) as f32);
    let (x0, y0) = (x0 as u32, y0 as u32);
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
