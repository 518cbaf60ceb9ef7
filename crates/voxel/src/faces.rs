//! Large flat faces of a voxel model: where a view would see the object edge-on.
//!
//! A face of a box seen only at a slant comes out of voxel coloring a few voxels too fat: the
//! visual hull there is a shallow wedge bounded by the silhouette rays of the views on either
//! side of the face's plane, and the wedge's voxels see nearly the same texture from those
//! views, so the colour test passes them (`docs/results.md`, "a face comes out fat unless a
//! view sees it edge-on"). A view whose centre lies in the face's plane cuts the wedge away.
//! [`planar_faces`] finds the model's large flat faces so that a planner can aim views at their
//! planes.
//!
//! The method is a Hough vote over the surface voxels' normals. A voxel's normal is the
//! direction in which the surface voxels within `r` voxels of it spread least (voxel coloring
//! leaves a shell, the voxels it saw, so the model's solid cannot be used), turned away from
//! the model's centre; voxels whose neighbourhood is not flat do not vote. The normals vote in
//! a histogram of their horizontal direction, smoothed over a few degrees so that a wedge's
//! two facets (a few degrees either side of the true face) vote for the face between them;
//! each peak holding enough of the votes becomes a plane through the densest offset of its
//! voxels, kept when enough voxels lie on it and they span enough of it. The facets of a
//! visual hull from few views are flat too, and are found as faces while they are wide.
//!
//! The mean of a fat face's normals is only as good as the wedge is even: a wedge's facet
//! tilted further than the smoothing from the face does not vote for it, and the mean leans
//! to the other facet, by a degree or more on `mirror` from 8 views (`docs/results.md`,
//! "Session 71"). So by default ([`FaceParams::profile_quantile`]) the plane is then refitted
//! to the face's outer profile: for each voxel column along the face and each layer, the
//! outermost surface voxel near the plane, and the line under a small share of those (a
//! quantile regression over tilts within a few degrees). The facets pivot on the face's true
//! edges, so the model's outer profile lies on or outside the true face, bulging between
//! its ends; the line under its lowest cells runs from edge to edge, along the face itself.
//! On `mirror`'s models from 8 to 23 views it puts the faces within 0.05 degree of the truth
//! where the mean leaned up to 2 degrees. It needs the profile's ends: a steep facet only a
//! few voxels wide, whose voxels' normals fail the flatness test, leaves the line along the
//! other facet (a wedge of 2 and 9 degrees modelled at 96^3 across 0.2 m comes out 1.8
//! degrees off, where the mean happens to be right).
//!
//! # Conventions
//! The model's grid frame (the turntable frame of `aibr-camera`, metres, Z up). A plane is the
//! points `x` with `normal . x = offset_m`, `normal` a unit vector pointing away from the
//! model's centre (out of the object, for a convex one).

use std::collections::BTreeMap;

use aibr_camera::Angle;
use nalgebra::{Matrix3, Point3, SymmetricEigen, Vector3};

use crate::error::{Error, Result};
use crate::grid::VoxelModel;

/// Parameters of [`planar_faces`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaceParams {
    /// Radius, in voxels, of the ball over which a surface voxel's normal is estimated
    /// (default 3).
    pub normal_radius: usize,
    /// Only faces whose normal is within this angle of horizontal, degrees (default 20): the
    /// faces a camera circling above the object can see edge-on.
    pub max_tilt_deg: f64,
    /// Width of the smoothing of the direction histogram, degrees either side (default 6).
    pub smoothing_deg: f64,
    /// A peak must hold at least this share of the votes (default 0.02).
    pub min_share: f64,
    /// And at least this many voxels must lie within two voxels of its plane (default 150).
    pub min_voxels: usize,
    /// And those must span at least this many voxels along the face (default 20).
    pub min_span_voxels: f64,
    /// The plane refitted as the line under this share of the face's outer profile (see the
    /// module docs), over 0 and under 0.5 (default `Some(0.15)`); `None` keeps the mean of
    /// the voxels' normals and the densest offset (sessions 25-70's estimate).
    pub profile_quantile: Option<f64>,
}

impl Default for FaceParams {
    fn default() -> Self {
        FaceParams {
            normal_radius: 3,
            max_tilt_deg: 20.0,
            smoothing_deg: 6.0,
            min_share: 0.02,
            min_voxels: 150,
            min_span_voxels: 20.0,
            profile_quantile: Some(0.15),
        }
    }
}

impl FaceParams {
    /// Rejects values outside their domains.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, value: f64, reason| Error::InvalidParameter {
            name,
            value,
            reason,
        };
        if !(1..=16).contains(&self.normal_radius) {
            return Err(bad(
                "normal_radius",
                self.normal_radius as f64,
                "must be 1 to 16 voxels",
            ));
        }
        if !(self.max_tilt_deg >= 0.0 && self.max_tilt_deg < 90.0) {
            return Err(bad(
                "max_tilt_deg",
                self.max_tilt_deg,
                "must be 0 or more and under 90 degrees",
            ));
        }
        if !(self.smoothing_deg >= 0.0 && self.smoothing_deg <= 45.0) {
            return Err(bad(
                "smoothing_deg",
                self.smoothing_deg,
                "must be 0 to 45 degrees",
            ));
        }
        if !(self.min_share > 0.0 && self.min_share <= 1.0) {
            return Err(bad(
                "min_share",
                self.min_share,
                "must be over 0 and at most 1",
            ));
        }
        if !(self.min_span_voxels >= 0.0 && self.min_span_voxels.is_finite()) {
            return Err(bad(
                "min_span_voxels",
                self.min_span_voxels,
                "must be a finite 0 or more",
            ));
        }
        if let Some(q) = self.profile_quantile {
            if !(q > 0.0 && q < 0.5) {
                return Err(bad("profile_quantile", q, "must be over 0 and under 0.5"));
            }
        }
        Ok(())
    }
}

/// A large flat face of a model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarFace {
    /// Its unit normal: horizontal (that of the line refitted to its outer profile, or the
    /// mean direction of its voxels' normals in the turntable plane, tilted or not), away
    /// from the model's centre.
    pub normal: Vector3<f64>,
    /// Its plane is `normal . x = offset_m` (metres).
    pub offset_m: f64,
    /// Surface voxels within two voxels of the plane whose normals voted for it.
    pub voxels: usize,
}

/// The large flat faces of `model` whose normals are nearly horizontal, largest first (see the
/// module docs). An empty list when the model has none (a ball, a drum) or no surface.
pub fn planar_faces(model: &VoxelModel, params: &FaceParams) -> Result<Vec<PlanarFace>> {
    params.validate()?;
    let votes = normal_votes(model, params);
    let size = model.grid().voxel_size();
    // The window of votes that make a face, either side of its peak.
    let half = (params.smoothing_deg.max(1.0)).to_radians();
    let mut faces: Vec<PlanarFace> = Vec::new();
    for peak in direction_peaks(&votes, params) {
        let Some(face) = face_at_peak(&votes, peak, half, size, params) else {
            continue;
        };
        // One face per direction: a peak within the smoothing width of a kept face's
        // direction and plane is that face again.
        let again = faces.iter().any(|f| {
            f.normal.dot(&face.normal) > half.cos()
                && (f.offset_m - face.offset_m).abs() <= 3.0 * size
        });
        if !again {
            faces.push(face);
        }
    }
    faces.sort_by_key(|f| std::cmp::Reverse(f.voxels));
    Ok(faces)
}

/// The surface voxels of `model` whose neighbourhood is flat and whose normal is nearly
/// horizontal: their centres and the horizontal directions of their normals (radians).
///
/// Voxel coloring leaves a shell (only the voxels it saw and kept), so a voxel's normal is
/// that of the surface voxels around it: the least direction of their spread within a ball of
/// `params.normal_radius` voxels, turned away from the model's centre.
fn normal_votes(model: &VoxelModel, params: &FaceParams) -> Vec<(Point3<f64>, f64)> {
    let grid = *model.grid();
    let surface = model.surface_voxels();
    let mut on_surface = ndarray::Array3::from_elem(grid.shape(), false);
    for &[i, j, k] in &surface {
        on_surface[[k, j, i]] = true;
    }
    let at = |i: isize, j: isize, k: isize| -> bool {
        match (usize::try_from(i), usize::try_from(j), usize::try_from(k)) {
            (Ok(i), Ok(j), Ok(k)) => on_surface.get([k, j, i]).copied().unwrap_or(false),
            _ => false,
        }
    };
    // The ball's offsets, once.
    let r = params.normal_radius as isize;
    let ball: Vec<[isize; 3]> = (-r..=r)
        .flat_map(|dk| (-r..=r).flat_map(move |dj| (-r..=r).map(move |di| [di, dj, dk])))
        .filter(|[di, dj, dk]| di * di + dj * dj + dk * dk <= r * r)
        .collect();
    let centroid = {
        let sum = surface
            .iter()
            .fold(Vector3::zeros(), |s, &v| s + grid.centre(v).coords);
        sum / surface.len().max(1) as f64
    };
    let max_tilt = params.max_tilt_deg.to_radians().sin();
    let mut votes = Vec::new();
    for &[i, j, k] in &surface {
        let (ci, cj, ck) = (i as isize, j as isize, k as isize);
        let (mut count, mut sum, mut outer) = (0.0, Vector3::zeros(), Matrix3::zeros());
        for &[di, dj, dk] in ball
            .iter()
            .filter(|[di, dj, dk]| at(ci + di, cj + dj, ck + dk))
        {
            let d = Vector3::new(di as f64, dj as f64, dk as f64);
            count += 1.0;
            sum += d;
            outer += d * d.transpose();
        }
        if count < 6.0 {
            continue;
        }
        let mean = sum / count;
        let spread = outer / count - mean * mean.transpose();
        let eigen = SymmetricEigen::new(spread);
        let least = eigen.eigenvalues.imin();
        let mut n: Vector3<f64> = eigen.eigenvectors.column(least).into_owned();
        // A plane's neighbourhood spreads in two directions and hardly in the third.
        let mut values = [
            eigen.eigenvalues[0],
            eigen.eigenvalues[1],
            eigen.eigenvalues[2],
        ];
        values.sort_by(f64::total_cmp);
        if !(values[0] <= 0.1 * values[1]) {
            continue;
        }
        let centre = grid.centre([i, j, k]);
        // Away from the model's centre.
        if n.dot(&(centre.coords - centroid)) < 0.0 {
            n = -n;
        }
        if n.z.abs() > max_tilt {
            continue;
        }
        votes.push((centre, n.y.atan2(n.x)));
    }
    votes
}

/// The peaks of the votes' direction histogram (one bin a degree, smoothed with a triangle
/// of `params.smoothing_deg` either side) holding at least `params.min_share` of the votes
/// within that width, highest first.
fn direction_peaks(votes: &[(Point3<f64>, f64)], params: &FaceParams) -> Vec<usize> {
    const BINS: usize = 360;
    let bin_of = |a: f64| -> usize {
        let d = a.to_degrees().rem_euclid(360.0);
        (d.floor() as usize).min(BINS - 1)
    };
    let mut histogram = [0f64; BINS];
    for &(_, a) in votes {
        histogram[bin_of(a)] += 1.0;
    }
    // Bin `b + d`, round the circle.
    let around = |b: usize, d: isize| (b as isize + d).rem_euclid(BINS as isize) as usize;
    let w = params.smoothing_deg.round() as isize;
    let mut smooth = [0f64; BINS];
    for (b, s) in smooth.iter_mut().enumerate() {
        for d in -w..=w {
            let weight = (w + 1 - d.abs()) as f64 / (w + 1) as f64;
            *s += weight * histogram[around(b, d)];
        }
    }
    // A peak's share: the votes within the smoothing width of it, over all votes.
    let total = votes.len() as f64;
    let window = |b: usize| -> f64 { (-w..=w).map(|d| histogram[around(b, d)]).sum() };
    let mut peaks: Vec<usize> = (0..BINS)
        .filter(|&b| {
            let (prev, next) = (smooth[around(b, -1)], smooth[around(b, 1)]);
            smooth[b] > prev && smooth[b] >= next && window(b) >= params.min_share * total
        })
        .collect();
    peaks.sort_by(|&a, &b| smooth[b].total_cmp(&smooth[a]));
    peaks
}

/// The face of the votes within `half` (radians) of the direction of bin `peak`: its normal
/// the votes' circular mean, its plane through their densest offset (bins of one voxel of
/// `size` metres, a window of five), then refitted to the face's outer profile
/// ([`profile_line`]) when `params.profile_quantile` is set; `None` when fewer than
/// `params.min_voxels` lie within two voxels of the plane or they span less than
/// `params.min_span_voxels`.
fn face_at_peak(
    votes: &[(Point3<f64>, f64)],
    peak: usize,
    half: f64,
    size: f64,
    params: &FaceParams,
) -> Option<PlanarFace> {
    let centre = (peak as f64 + 0.5).to_radians();
    let members: Vec<&(Point3<f64>, f64)> = votes
        .iter()
        .filter(|(_, a)| turn_between(*a, centre) <= half)
        .collect();
    let (s, c) = members
        .iter()
        .fold((0.0, 0.0), |(s, c), (_, a)| (s + a.sin(), c + a.cos()));
    let direction = s.atan2(c);
    let mut normal = horizontal(direction);
    let mut offsets: Vec<f64> = members.iter().map(|(p, _)| normal.dot(&p.coords)).collect();
    let lo = offsets.iter().copied().fold(f64::INFINITY, f64::min);
    let bins = ((offsets.iter().copied().fold(f64::NEG_INFINITY, f64::max) - lo) / size).floor()
        as usize
        + 1;
    let mut counts = vec![0usize; bins];
    for t in &offsets {
        counts[(((t - lo) / size).floor() as usize).min(bins - 1)] += 1;
    }
    let (best, _) = (0..bins)
        .map(|b| {
            (
                b,
                counts[b.saturating_sub(2)..(b + 3).min(bins)]
                    .iter()
                    .sum::<usize>(),
            )
        })
        .max_by(|x, y| x.1.cmp(&y.1).then(y.0.cmp(&x.0)))?;
    let mut plane = lo + (best as f64 + 0.5) * size;
    let refitted = params
        .profile_quantile
        .and_then(|q| profile_line(votes, direction, plane, size, q));
    if let Some((n, d)) = refitted {
        (normal, plane) = (n, d);
        offsets = members.iter().map(|(p, _)| normal.dot(&p.coords)).collect();
    }
    let on: Vec<(&Point3<f64>, f64)> = members
        .iter()
        .zip(&offsets)
        .filter(|(_, t)| (*t - plane).abs() <= 2.0 * size)
        .map(|((p, _), t)| (p, *t))
        .collect();
    if on.len() < params.min_voxels {
        return None;
    }
    let along = Vector3::new(-normal.y, normal.x, 0.0);
    let (a_lo, a_hi) = on
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), (p, _)| {
            let a = along.dot(&p.coords);
            (l.min(a), h.max(a))
        });
    if (a_hi - a_lo) / size < params.min_span_voxels {
        return None;
    }
    let offset_m = match refitted {
        Some(_) => plane,
        None => on.iter().map(|(_, t)| t).sum::<f64>() / on.len() as f64,
    };
    Some(PlanarFace {
        normal,
        offset_m,
        voxels: on.len(),
    })
}

/// The horizontal unit vector in direction `direction` (radians from +X towards +Y).
fn horizontal(direction: f64) -> Vector3<f64> {
    Vector3::new(direction.cos(), direction.sin(), 0.0)
}

/// How far apart directions `a` and `b` are (radians, 0 to pi), round the circle.
fn turn_between(a: f64, b: f64) -> f64 {
    Angle::from_radians(a)
        .wrapped_difference(Angle::from_radians(b))
        .radians()
        .abs()
}

/// Votes within this angle of a face's direction make its outer profile (degrees): wider
/// than the smoothing, so that a wedge's steeper facet is in it.
const PROFILE_WINDOW_DEG: f64 = 15.0;
/// And within this many voxels of its plane, either side: a fat face's wedge, not the
/// object's far side.
const PROFILE_BAND_VOXELS: f64 = 6.0;
/// The refitted plane turns at most this far from the votes' mean direction (degrees), in
/// steps of [`PROFILE_STEP_DEG`].
const PROFILE_TILT_DEG: f64 = 4.0;
const PROFILE_STEP_DEG: f64 = 0.02;
/// Fewer cells than this in the profile leave the plane as it was.
const PROFILE_MIN_CELLS: usize = 10;

/// The plane of the face near direction `direction` (radians) and offset `plane` (metres),
/// refitted to its outer profile: the outermost vote in each cell of one voxel (`size`)
/// along the face by one layer, among the votes within [`PROFILE_WINDOW_DEG`] of the
/// direction and [`PROFILE_BAND_VOXELS`] of the plane; the plane is the line under a share
/// `q` of those cells, found by quantile regression (the tilt within [`PROFILE_TILT_DEG`]
/// minimising the check loss, the offset the cells' `q`-quantile at that tilt). Returns its
/// normal and offset; `None` when the profile has too few cells.
fn profile_line(
    votes: &[(Point3<f64>, f64)],
    direction: f64,
    plane: f64,
    size: f64,
    q: f64,
) -> Option<(Vector3<f64>, f64)> {
    let normal = horizontal(direction);
    let along = Vector3::new(-normal.y, normal.x, 0.0);
    let window = PROFILE_WINDOW_DEG.to_radians();
    // (column, layer) -> the outermost vote's (offset, position along the face).
    let mut cells: BTreeMap<(i64, i64), (f64, f64)> = BTreeMap::new();
    for (p, a) in votes {
        let t = normal.dot(&p.coords);
        if turn_between(*a, direction) > window || (t - plane).abs() > PROFILE_BAND_VOXELS * size {
            continue;
        }
        let u = along.dot(&p.coords);
        let key = ((u / size).round() as i64, (p.z / size).round() as i64);
        let cell = cells.entry(key).or_insert((t, u));
        if t > cell.0 {
            *cell = (t, u);
        }
    }
    if cells.len() < PROFILE_MIN_CELLS {
        return None;
    }
    let mid = cells.values().map(|&(_, u)| u).sum::<f64>() / cells.len() as f64;
    let rank = ((q * (cells.len() - 1) as f64).round() as usize).min(cells.len() - 1);
    let mut residuals = Vec::with_capacity(cells.len());
    // (loss, tilt, offset at `mid`) of the best line yet.
    let mut best: Option<(f64, f64, f64)> = None;
    let steps = (PROFILE_TILT_DEG / PROFILE_STEP_DEG).round() as i64;
    for step in -steps..=steps {
        let tilt = (step as f64 * PROFILE_STEP_DEG).to_radians();
        let slope = tilt.tan();
        residuals.clear();
        residuals.extend(cells.values().map(|&(t, u)| t - slope * (u - mid)));
        let (_, &mut at, _) = residuals.select_nth_unstable_by(rank, f64::total_cmp);
        let loss: f64 = residuals
            .iter()
            .map(|r| {
                if *r >= at {
                    q * (r - at)
                } else {
                    (1.0 - q) * (at - r)
                }
            })
            .sum();
        if best.is_none_or(|(l, _, _)| loss < l) {
            best = Some((loss, tilt, at));
        }
    }
    let (_, tilt, at) = best?;
    // The line t = at + tan(tilt) (u - mid) has the normal turned by -tilt.
    let turned = horizontal(direction - tilt);
    Some((turned, turned.dot(&(normal * at + along * mid))))
}

#[cfg(test)]
mod tests {
    use aibr_camera::Aabb;

    use super::*;
    use crate::grid::VoxelGrid;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    fn grid(n: usize) -> Result<VoxelGrid> {
        VoxelGrid::with_resolution(
            Aabb {
                min: Point3::new(-0.1, -0.1, 0.0),
                max: Point3::new(0.1, 0.1, 0.2),
            },
            n,
        )
    }

    fn rotated_box(angle_deg: f64, half: [f64; 2], height: f64) -> impl Fn(&Point3<f64>) -> bool {
        let (s, c) = angle_deg.to_radians().sin_cos();
        move |p: &Point3<f64>| {
            let (u, v) = (c * p.x + s * p.y, -s * p.x + c * p.y);
            u.abs() < half[0] && v.abs() < half[1] && p.z > 0.01 && p.z < height
        }
    }

    #[test]
    fn a_turned_box_has_its_four_side_faces_found() -> TestResult {
        let angle = 17.0f64;
        let half = [0.06, 0.04];
        let model = VoxelModel::from_centres(grid(96)?, rotated_box(angle, half, 0.15));
        let faces = planar_faces(&model, &FaceParams::default())?;
        assert_eq!(faces.len(), 4, "{faces:?}");
        for (k, h) in [
            (0.0, half[0]),
            (90.0, half[1]),
            (180.0, half[0]),
            (270.0, half[1]),
        ] {
            let want = (angle + k).to_radians();
            let n = horizontal(want);
            let f = faces
                .iter()
                .find(|f| f.normal.dot(&n) > 0.99)
                .ok_or(format!("no face at {k} degrees: {faces:?}"))?;
            let size = model.grid().voxel_size();
            assert!(f.normal.dot(&n) > 0.9995, "{k}: {:?}", f.normal);
            assert!(
                (f.offset_m - h).abs() < 1.5 * size,
                "{k}: {} vs {h}",
                f.offset_m
            );
        }
        Ok(())
    }

    #[test]
    fn a_wedge_of_two_shallow_facets_votes_for_the_face_between_them() -> TestResult {
        // The +x face pushed out into a roof of two facets 3 degrees either side of it.
        let wedge = |p: &Point3<f64>| {
            let roof = 0.05 + (0.05 - p.y.abs()) * 3f64.to_radians().tan();
            p.x > -0.05 && p.x < roof && p.y.abs() < 0.05 && p.z > 0.01 && p.z < 0.15
        };
        let model = VoxelModel::from_centres(grid(96)?, wedge);
        let faces = planar_faces(&model, &FaceParams::default())?;
        let f = faces
            .iter()
            .find(|f| f.normal.x > 0.9)
            .ok_or(format!("no +x face: {faces:?}"))?;
        assert!(
            f.normal.y.abs() < 0.5f64.to_radians().sin(),
            "{:?}",
            f.normal
        );
        Ok(())
    }

    #[test]
    fn round_things_have_no_faces() -> TestResult {
        let drum =
            |p: &Point3<f64>| p.x * p.x + p.y * p.y < 0.06f64.powi(2) && p.z > 0.01 && p.z < 0.1;
        let ball = |p: &Point3<f64>| (p - Point3::new(0.0, 0.0, 0.1)).norm() < 0.07;
        for (what, model) in [
            ("drum", VoxelModel::from_centres(grid(96)?, drum)),
            ("ball", VoxelModel::from_centres(grid(96)?, ball)),
            ("nothing", VoxelModel::empty(grid(32)?)),
        ] {
            let faces = planar_faces(&model, &FaceParams::default())?;
            assert!(faces.is_empty(), "{what}: {faces:?}");
        }
        Ok(())
    }

    #[test]
    fn parameters_out_of_their_domain_are_refused() -> TestResult {
        let model = VoxelModel::empty(grid(4)?);
        for p in [
            FaceParams {
                normal_radius: 0,
                ..FaceParams::default()
            },
            FaceParams {
                max_tilt_deg: 90.0,
                ..FaceParams::default()
            },
            FaceParams {
                smoothing_deg: f64::NAN,
                ..FaceParams::default()
            },
            FaceParams {
                min_share: 0.0,
                ..FaceParams::default()
            },
            FaceParams {
                min_span_voxels: f64::INFINITY,
                ..FaceParams::default()
            },
            FaceParams {
                profile_quantile: Some(0.5),
                ..FaceParams::default()
            },
            FaceParams {
                profile_quantile: Some(0.0),
                ..FaceParams::default()
            },
        ] {
            assert!(planar_faces(&model, &p).is_err(), "{p:?}");
        }
        Ok(())
    }
}
