//! PLY export of voxel models (opens in MeshLab and Blender).
//!
//! Checked by their own readers: `fixtures/ply/ply_peer.py` opens what [`write_ply`] writes
//! for a small model with pymeshlab and with Blender's Python module, and
//! `tests/ply.rs` checks what they read (every vertex's position and colour, the faces, the
//! volume the cubes enclose).

use std::io::Write;

use crate::error::{Error, Result};
use crate::grid::VoxelModel;

/// What [`write_ply`] writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PlyOptions {
    /// Write each voxel as a cube (8 vertices, the faces toward empty neighbours) instead of
    /// one coloured point at its centre.
    pub cubes: bool,
    /// Binary little-endian instead of ASCII.
    pub binary: bool,
}

const NEIGHBOURS: [([i64; 3], [usize; 4]); 6] = [
    // (offset of the neighbour, the face's corners as bit patterns x|y<<1|z<<2, outward CCW)
    ([-1, 0, 0], [0, 4, 6, 2]),
    ([1, 0, 0], [1, 3, 7, 5]),
    ([0, -1, 0], [0, 1, 5, 4]),
    ([0, 1, 0], [2, 6, 7, 3]),
    ([0, 0, -1], [0, 2, 3, 1]),
    ([0, 0, 1], [4, 5, 7, 6]),
];

/// Writes the occupied voxels of `model` as PLY to `out` (points with colours, or cubes).
pub fn write_ply<W: Write>(model: &VoxelModel, out: W, options: &PlyOptions) -> Result<()> {
    let io = |source| Error::Io {
        what: "PLY",
        source,
    };
    let mut out = std::io::BufWriter::new(out);
    let grid = model.grid();
    let [nx, ny, nz] = grid.dims();
    let s = grid.voxel_size();
    let voxels: Vec<[usize; 3]> = model
        .occupied
        .indexed_iter()
        .filter(|(_, o)| **o)
        .map(|((k, j, i), _)| [i, j, k])
        .collect();
    let empty = |v: [usize; 3], d: [i64; 3]| {
        let n = [v[0] as i64 + d[0], v[1] as i64 + d[1], v[2] as i64 + d[2]];
        n.iter()
            .zip([nx, ny, nz])
            .any(|(&c, m)| c < 0 || c >= m as i64)
            || !model.is_occupied([n[0] as usize, n[1] as usize, n[2] as usize])
    };
    let faces: usize = if options.cubes {
        voxels
            .iter()
            .map(|&v| NEIGHBOURS.iter().filter(|(d, _)| empty(v, *d)).count())
            .sum()
    } else {
        0
    };
    let vertices = voxels.len() * if options.cubes { 8 } else { 1 };
    let format = if options.binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    write!(
        out,
        "ply\nformat {format} 1.0\ncomment aibr voxel model, voxel size {s} m, {nx}x{ny}x{nz}\n\
         element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n"
    )
    .map_err(io)?;
    if options.cubes {
        write!(
            out,
            "element face {faces}\nproperty list uchar int vertex_indices\n"
        )
        .map_err(io)?;
    }
    writeln!(out, "end_header").map_err(io)?;
    let vertex =
        |out: &mut std::io::BufWriter<W>, p: [f32; 3], c: [u8; 3]| -> std::io::Result<()> {
            if options.binary {
                for v in p {
                    out.write_all(&v.to_le_bytes())?;
                }
                out.write_all(&c)
            } else {
                writeln!(out, "{} {} {} {} {} {}", p[0], p[1], p[2], c[0], c[1], c[2])
            }
        };
    for &v in &voxels {
        let c = model.colour_of(v).unwrap_or([128; 3]);
        let centre = grid.centre(v);
        if options.cubes {
            for corner in 0..8 {
                let off = |bit: usize| if corner & bit != 0 { 0.5 * s } else { -0.5 * s };
                let p = [
                    (centre.x + off(1)) as f32,
                    (centre.y + off(2)) as f32,
                    (centre.z + off(4)) as f32,
                ];
                vertex(&mut out, p, c).map_err(io)?;
            }
        } else {
            vertex(
                &mut out,
                [centre.x as f32, centre.y as f32, centre.z as f32],
                c,
            )
            .map_err(io)?;
        }
    }
    if options.cubes {
        for (n, &v) in voxels.iter().enumerate() {
            for (d, corners) in &NEIGHBOURS {
                if !empty(v, *d) {
                    continue;
                }
                let idx = corners.map(|c| (8 * n + c) as i32);
                if options.binary {
                    out.write_all(&[4u8]).map_err(io)?;
                    for i in idx {
                        out.write_all(&i.to_le_bytes()).map_err(io)?;
                    }
                } else {
                    writeln!(out, "4 {} {} {} {}", idx[0], idx[1], idx[2], idx[3]).map_err(io)?;
                }
            }
        }
    }
    out.flush().map_err(io)
}
