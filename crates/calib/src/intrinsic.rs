//! Intrinsic calibration: Zhang's closed form, then Levenberg-Marquardt over everything.

use aibr_camera::{Distortion, ImageSize, Intrinsics};
use nalgebra::{DMatrix, Isometry3, Matrix3, Point2, Vector3};
use serde::{Deserialize, Serialize};

use crate::board::BoardSpec;
use crate::bundle::{Bundle, CAMERA_PARAMS, SKEW, Solution, camera_from_params, camera_params};
use crate::detect::BoardDetection;
use crate::error::{Error, Result};
use crate::geometry::{homography, null_vector, pose_from_homography};

/// What [`calibrate_intrinsics`] estimates and how.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IntrinsicOptions {
    /// Estimate the skew (off by default, as in OpenCV: modern sensors have none).
    pub estimate_skew: bool,
    /// Keep `fy / fx` at its closed-form value.
    pub fix_aspect_ratio: bool,
    /// Keep the principal point at the image centre.
    pub fix_principal_point: bool,
    /// Distortion terms held at zero, in the order k1 k2 p1 p2 k3 (OpenCV's
    /// `CALIB_FIX_K1`..`K3`, `CALIB_ZERO_TANGENT_DIST`).
    pub fix_distortion: [bool; 5],
    /// Most Levenberg-Marquardt iterations.
    pub max_iterations: usize,
    /// A view whose RMS reprojection error exceeds this multiple of the overall RMS is
    /// flagged as an outlier (reported, not dropped).
    pub outlier_factor: f64,
}

impl Default for IntrinsicOptions {
    /// fx, fy, cx, cy and all five distortion terms free, no skew: OpenCV's
    /// `calibrateCamera` with no flags.
    fn default() -> Self {
        IntrinsicOptions {
            estimate_skew: false,
            fix_aspect_ratio: false,
            fix_principal_point: false,
            fix_distortion: [false; 5],
            max_iterations: 100,
            outlier_factor: 2.0,
        }
    }
}

/// Standard deviations of the camera parameters (0 for those held fixed).
///
/// From the covariance `σ² (JᵀJ)⁻¹` at the solution, with `σ²` the residual variance per
/// coordinate, as OpenCV's `calibrateCameraExtended` computes them. Bouguet's toolbox
/// prints three times these as its "uncertainties".
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParameterStd {
    /// fx, pixels.
    pub fx: f64,
    /// fy, pixels.
    pub fy: f64,
    /// cx, pixels.
    pub cx: f64,
    /// cy, pixels.
    pub cy: f64,
    /// Skew, pixels.
    pub skew: f64,
    /// k1 k2 p1 p2 k3.
    pub distortion: [f64; 5],
}

/// One view's result.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewResult {
    /// Index of the view in the input.
    pub index: usize,
    /// The board pose in this view.
    pub cam_from_board: Isometry3<f64>,
    /// RMS reprojection error of its corners, pixels.
    pub rms: f64,
    /// Whether its error exceeds [`IntrinsicOptions::outlier_factor`] times the overall RMS.
    pub outlier: bool,
}

/// The result of [`calibrate_intrinsics`].
#[derive(Debug, Clone, PartialEq)]
pub struct IntrinsicCalibration {
    /// The image size.
    pub image_size: ImageSize,
    /// Focal lengths, principal point, skew.
    pub intrinsics: Intrinsics,
    /// Lens distortion.
    pub distortion: Distortion,
    /// RMS reprojection error over all corners, pixels (`sqrt(sum |e|² / corners)`, as
    /// OpenCV reports it).
    pub rms: f64,
    /// Per-view poses and errors, in input order.
    pub views: Vec<ViewResult>,
    /// Standard deviations of the camera parameters.
    pub std: ParameterStd,
    /// Levenberg-Marquardt iterations run.
    pub iterations: usize,
}

/// Smallest angle, degrees, that the board planes must span for the focal length to be
/// determined.
const MIN_TILT_SPREAD_DEG: f64 = 3.0;

/// Calibrates a camera from boards detected in at least 3 images of one size.
pub fn calibrate_intrinsics(
    board: &BoardSpec,
    views: &[BoardDetection],
    options: &IntrinsicOptions,
) -> Result<IntrinsicCalibration> {
    const NEEDED: usize = 3;
    if views.len() < NEEDED {
        return Err(Error::TooFewViews {
            found: views.len(),
            needed: NEEDED,
        });
    }
    let size = views[0].image_size;
    for (index, v) in views.iter().enumerate() {
        if v.image_size != size {
            return Err(Error::SizeMismatch {
                index,
                width: v.image_size.width,
                height: v.image_size.height,
                first_width: size.width,
                first_height: size.height,
            });
        }
        board.check_complete(v.corners.len(), || format!("view {index}"))?;
    }
    let plane: Vec<Point2<f64>> = board
        .object_points()
        .iter()
        .map(|p| Point2::new(p.x, p.y))
        .collect();
    let homographies = views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            homography(&plane, &v.corners).ok_or_else(|| {
                Error::Degenerate(format!(
                    "view {i}: the corners do not determine a homography"
                ))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    check_tilt_spread(&homographies, size)?;
    let k = zhang(&homographies, size, options)
        .or_else(|| focal_only(&homographies, size))
        .ok_or_else(|| {
            Error::Degenerate("no focal length fits the views: the boards are probably all parallel or nearly so; tilt the board differently between views".into())
        })?;
    let k_inv = k
        .try_inverse()
        .ok_or_else(|| Error::Degenerate("singular camera matrix".into()))?;
    let poses = homographies
        .iter()
        .enumerate()
        .map(|(i, h)| {
            pose_from_homography(&(k_inv * h))
                .ok_or_else(|| Error::Degenerate(format!("view {i}: no board pose")))
        })
        .collect::<Result<Vec<_>>>()?;

    let mut free = [true; CAMERA_PARAMS];
    free[SKEW] = options.estimate_skew;
    if options.fix_principal_point {
        free[2] = false;
        free[3] = false;
    }
    for (i, &fixed) in options.fix_distortion.iter().enumerate() {
        free[5 + i] = !fixed;
    }
    let object = board.object_points();
    let problem = Bundle {
        object: &object,
        views: views.iter().map(|v| v.corners.as_slice()).collect(),
        free,
        aspect: options.fix_aspect_ratio.then(|| k[(1, 1)] / k[(0, 0)]),
    };
    let start = camera_params(
        &Intrinsics {
            fx: k[(0, 0)],
            fy: k[(1, 1)],
            cx: k[(0, 2)],
            cy: k[(1, 2)],
            skew: if options.estimate_skew {
                k[(0, 1)]
            } else {
                0.0
            },
        },
        &Distortion::NONE,
    );
    let solution = problem.solve(start, &poses, options.max_iterations);
    // Parallel boards leave the focal length free: the solved poses show it directly (the
    // vanishing-line check above can be fooled by lens distortion), and so does its spread.
    let spread = max_angle_between_normals(
        solution
            .poses
            .iter()
            .map(|p| p.rotation * nalgebra::Vector3::z()),
    );
    if spread < MIN_TILT_SPREAD_DEG {
        return Err(Error::Degenerate(format!(
            "the boards are all nearly parallel (their planes span {spread:.1} degrees, at least {MIN_TILT_SPREAD_DEG} needed): tilt the board differently between views"
        )));
    }
    let (fx, fx_std) = (solution.camera[0], solution.camera_std[0]);
    if !(fx_std < 0.1 * fx) {
        return Err(Error::Degenerate(format!(
            "the views do not determine the focal length (fx = {fx:.1} ± {fx_std:.1} px): tilt the board more, or in more directions"
        )));
    }
    result(board, size, solution, options)
}

/// The largest angle between two of the unit normals, degrees.
fn max_angle_between_normals(normals: impl Iterator<Item = Vector3<f64>>) -> f64 {
    let normals: Vec<Vector3<f64>> = normals.collect();
    let mut spread: f64 = 0.0;
    for (i, a) in normals.iter().enumerate() {
        for b in &normals[i + 1..] {
            spread = spread.max(a.dot(b).abs().min(1.0).acos().to_degrees());
        }
    }
    spread
}

fn result(
    board: &BoardSpec,
    size: ImageSize,
    s: Solution,
    options: &IntrinsicOptions,
) -> Result<IntrinsicCalibration> {
    let (intrinsics, distortion) = camera_from_params(&s.camera);
    intrinsics
        .validate()
        .map_err(|e| Error::NoConvergence(format!("the solution is not a camera: {e}")))?;
    let corners = board.corner_count() as f64;
    let total: f64 = s.view_sse.iter().sum();
    let rms = (total / (corners * s.view_sse.len() as f64)).sqrt();
    if !rms.is_finite() {
        return Err(Error::NoConvergence(
            "the reprojection error is not finite".into(),
        ));
    }
    let views = s
        .poses
        .iter()
        .zip(&s.view_sse)
        .enumerate()
        .map(|(index, (pose, sse))| {
            let view_rms = (sse / corners).sqrt();
            ViewResult {
                index,
                cam_from_board: *pose,
                rms: view_rms,
                outlier: view_rms > options.outlier_factor * rms,
            }
        })
        .collect();
    let d = s.camera_std;
    Ok(IntrinsicCalibration {
        image_size: size,
        intrinsics,
        distortion,
        rms,
        views,
        std: ParameterStd {
            fx: d[0],
            fy: d[1],
            cx: d[2],
            cy: d[3],
            skew: d[4],
            distortion: [d[5], d[6], d[7], d[8], d[9]],
        },
        iterations: s.iterations,
    })
}

/// A guess at the camera matrix: focal length the image's larger side, principal point
/// the centre.
fn nominal_k(size: ImageSize) -> Matrix3<f64> {
    let f = size.width.max(size.height) as f64;
    Matrix3::new(
        f,
        0.0,
        0.5 * (size.width as f64 - 1.0),
        0.0,
        f,
        0.5 * (size.height as f64 - 1.0),
        0.0,
        0.0,
        1.0,
    )
}

/// Boards that are all parallel do not determine the focal length (Zhang's degenerate
/// case). Each board plane's normal is `Kᵀ l` with `l = H⁻ᵀ (0, 0, 1)` its vanishing line;
/// with the nominal camera the angles are rough but enough to tell parallel from tilted.
fn check_tilt_spread(homographies: &[Matrix3<f64>], size: ImageSize) -> Result<()> {
    let k = nominal_k(size);
    let spread = max_angle_between_normals(
        homographies
            .iter()
            .filter_map(|h| h.try_inverse())
            .map(|hi| (k.transpose() * hi.transpose() * Vector3::z()).normalize()),
    );
    if !(spread >= MIN_TILT_SPREAD_DEG) {
        return Err(Error::Degenerate(format!(
            "the boards are all nearly parallel (the planes span about {spread:.1} degrees, at least {MIN_TILT_SPREAD_DEG} needed): tilt the board differently between views"
        )));
    }
    Ok(())
}

/// Zhang's closed form (with zero skew unless estimated), in pixel coordinates scaled to
/// about unit size for conditioning. `None` when the solution is not a camera.
fn zhang(
    homographies: &[Matrix3<f64>],
    size: ImageSize,
    options: &IntrinsicOptions,
) -> Option<Matrix3<f64>> {
    let s = 1.0 / size.width.max(size.height) as f64;
    let t = Matrix3::new(s, 0.0, 0.0, 0.0, s, 0.0, 0.0, 0.0, 1.0);
    let v = |h: &Matrix3<f64>, i: usize, j: usize| {
        [
            h[(0, i)] * h[(0, j)],
            h[(0, i)] * h[(1, j)] + h[(1, i)] * h[(0, j)],
            h[(1, i)] * h[(1, j)],
            h[(2, i)] * h[(0, j)] + h[(0, i)] * h[(2, j)],
            h[(2, i)] * h[(1, j)] + h[(1, i)] * h[(2, j)],
            h[(2, i)] * h[(2, j)],
        ]
    };
    let extra = usize::from(!options.estimate_skew);
    let mut a = DMatrix::<f64>::zeros(2 * homographies.len() + extra, 6);
    for (n, h) in homographies.iter().enumerate() {
        let h = t * h;
        let h = h / h.norm();
        let v12 = v(&h, 0, 1);
        let v11 = v(&h, 0, 0);
        let v22 = v(&h, 1, 1);
        a.row_mut(2 * n).copy_from_slice(&v12);
        let d: Vec<f64> = v11.iter().zip(&v22).map(|(a, b)| a - b).collect();
        a.row_mut(2 * n + 1).copy_from_slice(&d);
    }
    if extra == 1 {
        // B12 = 0 (no skew), weighted like the data rows.
        let w = a.row(0).norm().max(1e-12);
        a[(2 * homographies.len(), 1)] = w;
    }
    let mut b = null_vector(&a)?;
    if b[0] < 0.0 {
        b = -b;
    }
    let (b11, b12, b22, b13, b23, b33) = (b[0], b[1], b[2], b[3], b[4], b[5]);
    let den = b11 * b22 - b12 * b12;
    if !(den > 0.0 && b11 > 0.0) {
        return None;
    }
    let v0 = (b12 * b13 - b11 * b23) / den;
    let lambda = b33 - (b13 * b13 + v0 * (b12 * b13 - b11 * b23)) / b11;
    if !(lambda / b11 > 0.0) {
        return None;
    }
    let alpha = (lambda / b11).sqrt();
    let beta = (lambda * b11 / den).sqrt();
    let gamma = -b12 * alpha * alpha * beta / lambda;
    let u0 = gamma * v0 / beta - b13 * alpha * alpha / lambda;
    let kn = Matrix3::new(alpha, gamma, u0, 0.0, beta, v0, 0.0, 0.0, 1.0);
    let k = t.try_inverse()? * kn;
    let plausible = k.iter().all(|x| x.is_finite())
        && k[(0, 2)] > 0.0
        && k[(0, 2)] < size.width as f64
        && k[(1, 2)] > 0.0
        && k[(1, 2)] < size.height as f64
        && k[(1, 1)] / k[(0, 0)] > 0.5
        && k[(1, 1)] / k[(0, 0)] < 2.0;
    plausible.then_some(k)
}

/// The focal lengths alone with the principal point at the image centre (OpenCV's
/// initialisation), for sets where the full closed form fails.
fn focal_only(homographies: &[Matrix3<f64>], size: ImageSize) -> Option<Matrix3<f64>> {
    let (cx, cy) = (
        0.5 * (size.width as f64 - 1.0),
        0.5 * (size.height as f64 - 1.0),
    );
    let shift = Matrix3::new(1.0, 0.0, -cx, 0.0, 1.0, -cy, 0.0, 0.0, 1.0);
    let mut a = DMatrix::<f64>::zeros(2 * homographies.len(), 2);
    let mut rhs = nalgebra::DVector::<f64>::zeros(2 * homographies.len());
    for (n, h) in homographies.iter().enumerate() {
        let h = shift * h;
        let h = h / h.norm();
        // h1ᵀ B h2 = 0 and h1ᵀ B h1 = h2ᵀ B h2 with B = diag(1/fx², 1/fy², 1).
        a[(2 * n, 0)] = h[(0, 0)] * h[(0, 1)];
        a[(2 * n, 1)] = h[(1, 0)] * h[(1, 1)];
        rhs[2 * n] = -h[(2, 0)] * h[(2, 1)];
        a[(2 * n + 1, 0)] = h[(0, 0)].powi(2) - h[(0, 1)].powi(2);
        a[(2 * n + 1, 1)] = h[(1, 0)].powi(2) - h[(1, 1)].powi(2);
        rhs[2 * n + 1] = -(h[(2, 0)].powi(2) - h[(2, 1)].powi(2));
    }
    let x = a.svd(true, true).solve(&rhs, 1e-15).ok()?;
    if !(x[0] > 0.0 && x[1] > 0.0) {
        return None;
    }
    Some(Matrix3::new(
        1.0 / x[0].sqrt(),
        0.0,
        cx,
        0.0,
        1.0 / x[1].sqrt(),
        cy,
        0.0,
        0.0,
        1.0,
    ))
}
