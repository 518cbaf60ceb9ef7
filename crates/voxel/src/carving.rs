//! Space carving (Kutulakos and Seitz 2000): multi-sweep, for rigs whose cameras are not all
//! above the object.

use rayon::prelude::*;

use crate::coloring::{KernelStats, Reconstruction};
use crate::error::Result;
use crate::grid::{VoxelGrid, VoxelModel};
use crate::kernel::{
    Consistency, Criterion, Judge, Pixels, Projector, Sample, View, claim, prepare_views,
};

/// Parameters of [`space_carving`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CarvingParams {
    /// The consistency criterion (default: angular, 60 grey levels within 45 degrees).
    /// Carving is destructive and repeats: every false rejection exposes the voxel behind it
    /// to the next pass, so it needs a more lenient test than voxel coloring's single sweep.
    pub criterion: Criterion,
    /// A voxel is judged (and possibly carved) only when at least this many views of a
    /// sweep see unclaimed pixels of it (default 2).
    pub min_views: usize,
    /// Full passes of six sweeps at most; carving stops earlier when a pass carves nothing
    /// (default 6).
    pub max_passes: usize,
}

impl Default for CarvingParams {
    fn default() -> Self {
        CarvingParams {
            criterion: Criterion::Angular {
                threshold: 60.0,
                window: aibr_camera::Angle::from_degrees(45.0),
            },
            min_views: 2,
            max_passes: 6,
        }
    }
}

/// The visual hull: the voxels of `grid` that no view's mask shows as background at every
/// pixel of their footprint (views without a mask reject nothing). Every reconstruction
/// that respects the silhouettes lies inside it, so its projection bounds how much of a
/// silhouette any such model can cover. Kept voxels are grey.
///
/// Errors: no views, or image or mask sizes that differ from their camera, or distorted
/// cameras.
pub fn visual_hull(grid: &VoxelGrid, views: &[View<'_>]) -> Result<VoxelModel> {
    let (projectors, pixels) = prepare_views(grid, views, 1)?;
    let mut model = VoxelModel::full(*grid);
    carve_hull(&mut model, &projectors, &pixels);
    Ok(model)
}

/// Clears the voxels of `model` outside the visual hull; returns how many.
pub(crate) fn carve_hull(
    model: &mut VoxelModel,
    projectors: &[Projector],
    pixels: &[Pixels<'_>],
) -> usize {
    let grid = *model.grid();
    let [nx, ny, nz] = grid.dims();
    let hull: Vec<Vec<bool>> = (0..nz)
        .into_par_iter()
        .map(|k| {
            let mut layer = vec![true; nx * ny];
            for j in 0..ny {
                let bases: Vec<[f32; 3]> =
                    projectors.iter().map(|p| p.row_base(&grid, j, k)).collect();
                for i in 0..nx {
                    layer[j * nx + i] =
                        !projectors
                            .iter()
                            .zip(pixels)
                            .zip(&bases)
                            .any(|((p, px), b)| {
                                p.footprint(p.along_row(b, i))
                                    .is_some_and(|fp| px.all_background(&fp))
                            });
                }
            }
            layer
        })
        .collect();
    let mut outside = 0;
    for (k, layer) in hull.iter().enumerate() {
        for (idx, &inside) in layer.iter().enumerate() {
            if !inside {
                model.clear([idx % nx, idx / nx, k]);
                outside += 1;
            }
        }
    }
    outside
}

/// Space carving by repeated plane sweeps along +-x, +-y and +-z.
///
/// The model starts full; voxels that some view's mask shows as background are carved
/// first (the visual hull). Each sweep moves a plane through the grid and judges the
/// occupied voxels in the plane using only the cameras the plane has not yet passed (whose
/// occluders are therefore known), with the pixels already claimed by surviving voxels
/// nearer those cameras masked out; inconsistent voxels are carved. Passes repeat until one
/// carves nothing. Voxels never seen keep their place (the interior stays solid) and a grey
/// colour; seen ones take the mean colour of their last judgement.
pub fn space_carving(
    grid: &VoxelGrid,
    views: &[View<'_>],
    params: &CarvingParams,
) -> Result<Reconstruction> {
    let (projectors, pixels) = prepare_views(grid, views, params.min_views.max(1))?;
    let centres: Vec<_> = projectors.iter().map(|p| p.centre).collect();
    let criterion = Consistency::from(&params.criterion);
    let mut model = VoxelModel::full(*grid);
    let mut stats = KernelStats {
        voxels: grid.len(),
        ..KernelStats::default()
    };

    stats.silhouette_rejected = carve_hull(&mut model, &projectors, &pixels);

    let mut claimed: Vec<Vec<u8>> = pixels.iter().map(|p| vec![0u8; p.rgb.len() / 3]).collect();
    for _pass in 0..params.max_passes {
        let mut carved_this_pass = 0;
        for axis in [2usize, 0, 1] {
            for forward in [false, true] {
                for c in &mut claimed {
                    c.fill(0);
                }
                let len = grid.dims()[axis];
                let s = grid.voxel_size();
                let lo = grid.bounds().min[axis];
                for step in 0..len {
                    let p = if forward { step } else { len - 1 - step };
                    // Cameras the plane has not passed yet.
                    let (face_lo, face_hi) = (lo + p as f64 * s, lo + (p + 1) as f64 * s);
                    let active: Vec<usize> = (0..views.len())
                        .filter(|&v| {
                            let c = centres[v][axis];
                            if forward { c < face_lo } else { c > face_hi }
                        })
                        .collect();
                    if active.is_empty() {
                        continue;
                    }
                    let (a1, a2) = match axis {
                        0 => (1, 2),
                        1 => (0, 2),
                        _ => (0, 1),
                    };
                    let (n1, n2) = (grid.dims()[a1], grid.dims()[a2]);
                    let index = |u: usize, w: usize| {
                        let mut idx = [0usize; 3];
                        idx[axis] = p;
                        idx[a1] = u;
                        idx[a2] = w;
                        idx
                    };
                    let occupied = &model.occupied;
                    let claimed_ref = &claimed;
                    // Judge the plane's occupied voxels, lines in parallel.
                    let verdicts: Vec<Vec<(usize, Option<[u8; 3]>)>> = (0..n2)
                        .into_par_iter()
                        .map(|w| {
                            let mut out = Vec::new();
                            let mut samples = Vec::with_capacity(active.len());
                            let mut judge = Judge::new(criterion);
                            for u in 0..n1 {
                                let idx = index(u, w);
                                if !occupied[[idx[2], idx[1], idx[0]]] {
                                    continue;
                                }
                                let x = grid.centre(idx);
                                samples.clear();
                                for &v in &active {
                                    let h = projectors[v].project_point(&x);
                                    if let Some(fp) = projectors[v].footprint(h) {
                                        let (sum, n) = pixels[v].gather(&fp, &claimed_ref[v]);
                                        if n > 0 {
                                            samples.push(Sample::new(v, sum, n));
                                        }
                                    }
                                }
                                if samples.len() >= params.min_views {
                                    let verdict = judge.decide(&samples, &centres, &x);
                                    out.push((u, verdict));
                                }
                            }
                            out
                        })
                        .collect();
                    for (w, line) in verdicts.iter().enumerate() {
                        for &(u, verdict) in line {
                            let idx = index(u, w);
                            match verdict {
                                Some(c) => model.colour[[idx[2], idx[1], idx[0]]] = c,
                                None => {
                                    model.clear(idx);
                                    carved_this_pass += 1;
                                }
                            }
                        }
                    }
                    // The survivors claim their pixels in the active views.
                    let occupied = &model.occupied;
                    claimed.par_iter_mut().enumerate().for_each(|(v, cl)| {
                        if !active.contains(&v) {
                            return;
                        }
                        for w in 0..n2 {
                            for u in 0..n1 {
                                let idx = index(u, w);
                                if !occupied[[idx[2], idx[1], idx[0]]] {
                                    continue;
                                }
                                let h = projectors[v].project_point(&grid.centre(idx));
                                if let Some(fp) = projectors[v].footprint(h) {
                                    claim(cl, pixels[v].width, &fp);
                                }
                            }
                        }
                    });
                }
            }
        }
        stats.tested += carved_this_pass;
        if carved_this_pass == 0 {
            break;
        }
    }
    stats.kept = model.occupied_count();
    Ok(Reconstruction { model, stats })
}
