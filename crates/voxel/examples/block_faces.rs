//! Where `lambertian`'s reconstruction errs, face by face, and why it depends on the views.
//!
//! `[PANS=deg,deg,...] cargo run --release -p aibr-voxel --example block_faces -- [VIEWS]`
//! (default 23 uniform views; `PANS` replaces them). Reconstructs the scene at 128^3 with the
//! default parameters and its ground-truth masks, carves the masks' visual hull on the same
//! grid, and for each vertical face of the base block (the lowest 48 layers, sorted by the
//! horizontal direction from the axis) prints how many surface voxels of each lie more than
//! 1.5 voxels from the true surface, and how near the nearest camera centre comes to the
//! face's plane (0 is a view that sees the face edge-on). Also: how many of the model's far
//! voxels lie on the hull's boundary (a 4-neighbour in their layer outside the hull).
//! Figures in `docs/results.md` ("Session 22: a face comes out fat unless a view sees it
//! edge-on").

mod common;

use aibr_scene::catalogue;
use aibr_voxel::metrics::PointIndex;
use aibr_voxel::{ColoringParams, VoxelGrid, VoxelModel, visual_hull, voxel_coloring};

/// Half the width of `lambertian`'s base block (`catalogue::lambertian`), metres.
const HALF_WIDTH: f64 = 0.065;
/// The lowest layers, which hold the block (0.06 m tall, 37 layers at 128^3) and the drum's foot.
const LAYERS: usize = 48;
const FACES: [(&str, [f64; 2]); 4] = [
    ("+x", [1.0, 0.0]),
    ("-x", [-1.0, 0.0]),
    ("+y", [0.0, 1.0]),
    ("-y", [0.0, -1.0]),
];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let views_n: usize = std::env::args().nth(1).map_or(Ok(23), |a| a.parse())?;
    let scene = catalogue::lambertian()?;
    let pans = common::pans(&scene, views_n)?;
    let shots = common::shoot(&scene, &pans)?;
    let views = common::views(&shots);
    let grid = VoxelGrid::with_resolution(scene.bounds(), 128)?;
    let size = grid.voxel_size();
    let model = voxel_coloring(&grid, &views, &ColoringParams::default())?.model;
    let hull = visual_hull(&grid, &views)?;
    let truth = PointIndex::new(&scene.geometry_reference()?.exposed, size);
    let far = |v: &[usize; 3]| truth.nearest_distance(&grid.centre(*v)) / size > 1.5;
    // The face of the block a voxel lies on, as an index into FACES.
    let face_of = |v: &[usize; 3]| {
        let p = grid.centre(*v);
        if p.x.abs() > p.y.abs() {
            usize::from(p.x < 0.0)
        } else {
            2 + usize::from(p.y < 0.0)
        }
    };
    // Each surface voxel with whether it lies far from the truth, distances taken once.
    let judged = |m: &VoxelModel| -> Vec<([usize; 3], bool)> {
        m.surface_voxels()
            .into_iter()
            .map(|v| (v, far(&v)))
            .collect()
    };
    let (model_surface, hull_surface) = (judged(&model), judged(&hull));
    // Per face, among the lowest layers: (surface voxels, far ones).
    let per_face = |surface: &[([usize; 3], bool)]| {
        let mut counts = [(0usize, 0usize); 4];
        for (v, is_far) in surface.iter().filter(|(v, _)| v[2] < LAYERS) {
            let c = &mut counts[face_of(v)];
            c.0 += 1;
            c.1 += usize::from(*is_far);
        }
        counts
    };
    let [nx, ny, _] = grid.dims();
    let on_hull_boundary = |&[i, j, k]: &[usize; 3]| {
        [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)]
            .iter()
            .any(|(di, dj)| {
                let (a, b) = (i as i64 + di, j as i64 + dj);
                a < 0 || b < 0 || a >= nx as i64 || b >= ny as i64 || {
                    !hull.is_occupied([a as usize, b as usize, k])
                }
            })
    };
    let far_voxels: Vec<&[usize; 3]> = model_surface
        .iter()
        .filter(|(_, is_far)| *is_far)
        .map(|(v, _)| v)
        .collect();
    let boundary = far_voxels.iter().filter(|v| on_hull_boundary(v)).count();
    println!(
        "{} views: {} model surface voxels further than 1.5 voxels from the truth, {} of them on the hull's boundary",
        pans.len(),
        far_voxels.len(),
        boundary
    );
    println!(
        "| face | model: far / surface | hull: far / surface | nearest camera to the face's plane (mm, pan) |"
    );
    println!("|---|---|---|---|");
    let (model_faces, hull_faces) = (per_face(&model_surface), per_face(&hull_surface));
    for (((face, normal), (m_surf, m_far)), (h_surf, h_far)) in
        FACES.iter().zip(model_faces).zip(hull_faces)
    {
        let nearest = shots
            .iter()
            .zip(&pans)
            .map(|(s, p)| {
                let c = s.camera.centre();
                (
                    (normal[0] * c.x + normal[1] * c.y - HALF_WIDTH).abs(),
                    p.degrees(),
                )
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap_or((f64::NAN, f64::NAN));
        println!(
            "| {face} | {m_far} / {m_surf} | {h_far} / {h_surf} | {:.0} ({:.1}) |",
            nearest.0 * 1e3,
            nearest.1
        );
    }
    Ok(())
}
