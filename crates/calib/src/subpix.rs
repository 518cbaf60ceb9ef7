//! Sub-pixel corner refinement.
//!
//! At a corner, every image gradient `g(p)` near it is orthogonal to `p - q`, the vector from
//! the corner `q` to its pixel `p`: within a square the gradient is zero, and on an edge
//! through `q` it is perpendicular to the edge. So `q` minimises
//! `sum_p w(p) (g(p) . (p - q))^2`, a 2x2 linear system, solved again around the new `q`
//! until it moves less than `epsilon` (Förstner's operator, as OpenCV's `cornerSubPix`).
//! The window is `(2 half_window + 1)^2` pixels, weighted by `exp(-(dx^2 + dy^2) / half^2)`
//! and resampled bilinearly around the current estimate; gradients are central differences
//! of the raw image.

use nalgebra::Point2;

use crate::plane::Plane;

/// Settings of the refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubPixParams {
    /// Half the window side: the window is `2 half_window + 1` pixels square (5 gives
    /// OpenCV's `winSize (5, 5)`, 11x11 pixels).
    pub half_window: usize,
    /// Most iterations per corner.
    pub max_iterations: usize,
    /// Stop when the corner moves less than this, pixels.
    pub epsilon: f64,
}

impl Default for SubPixParams {
    /// A 11x11 pixel window, 30 iterations, 0.001 pixel: what OpenCV's calibration samples
    /// pass to `cornerSubPix` with `winSize (5, 5)`.
    fn default() -> Self {
        SubPixParams {
            half_window: 5,
            max_iterations: 30,
            epsilon: 0.001,
        }
    }
}

/// Refines `corner` in `plane`. A corner that would leave the window it started in (no
/// corner there) keeps its starting position.
pub(crate) fn refine_corner(
    plane: &Plane,
    corner: Point2<f64>,
    params: &SubPixParams,
) -> Point2<f64> {
    let half = params.half_window.max(1) as isize;
    let side = (2 * half + 1) as usize;
    let patch_side = side + 2;
    let weights: Vec<f64> = (-half..=half)
        .map(|i| {
            let x = i as f64 / half as f64;
            (-x * x).exp()
        })
        .collect();
    let mut patch = vec![0.0f32; patch_side * patch_side];
    let mut q = corner;
    let eps2 = params.epsilon * params.epsilon;
    for _ in 0..params.max_iterations.max(1) {
        // The patch centred on q: sample (i, j) at q + (j - half - 1, i - half - 1).
        let (x0, y0) = (q.x - (half + 1) as f64, q.y - (half + 1) as f64);
        let (fx, fy) = (x0.floor(), y0.floor());
        let (tx, ty) = ((x0 - fx) as f32, (y0 - fy) as f32);
        let (ix, iy) = (fx as isize, fy as isize);
        for i in 0..patch_side {
            for j in 0..patch_side {
                let (x, y) = (ix + j as isize, iy + i as isize);
                let top = plane.at(x, y) * (1.0 - tx) + plane.at(x + 1, y) * tx;
                let bottom = plane.at(x, y + 1) * (1.0 - tx) + plane.at(x + 1, y + 1) * tx;
                patch[i * patch_side + j] = top * (1.0 - ty) + bottom * ty;
            }
        }
        let (mut a, mut b, mut c, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..side {
            let py = i as f64 - half as f64;
            for j in 0..side {
                let px = j as f64 - half as f64;
                let w = weights[i] * weights[j];
                let at = |r: usize, col: usize| patch[r * patch_side + col] as f64;
                let gx = at(i + 1, j + 2) - at(i + 1, j);
                let gy = at(i + 2, j + 1) - at(i, j + 1);
                let (gxx, gxy, gyy) = (gx * gx * w, gx * gy * w, gy * gy * w);
                a += gxx;
                b += gxy;
                c += gyy;
                bb1 += gxx * px + gxy * py;
                bb2 += gxy * px + gyy * py;
            }
        }
        let det = a * c - b * b;
        if !(det.abs() > f64::EPSILON * (a * c).abs().max(1e-300)) {
            break;
        }
        // The offset of the corner from q solves [a b; b c] d = [bb1; bb2].
        let dx = (c * bb1 - b * bb2) / det;
        let dy = (a * bb2 - b * bb1) / det;
        q = Point2::new(q.x + dx, q.y + dy);
        let outside = q.x < 0.0
            || q.y < 0.0
            || q.x > (plane.width - 1) as f64
            || q.y > (plane.height - 1) as f64;
        if outside || dx * dx + dy * dy <= eps2 {
            break;
        }
    }
    let moved = q - corner;
    if !(moved.x.abs() <= half as f64 && moved.y.abs() <= half as f64) {
        return corner;
    }
    q
}
