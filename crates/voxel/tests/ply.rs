//! PLY export, checked three ways:
//!
//! - the files [`write_ply`] writes for a small fixed model are the ones in `fixtures/ply/`,
//!   which MeshLab's and Blender's own readers opened (`fixtures/ply/ply_peer.py`; what they
//!   read is in `ply_peer.json`, checked here against the model);
//! - for any model, every cube face written lies between an occupied voxel and an empty one
//!   (or the grid's outside), faces away from the occupied one, and no such face is missing;
//! - a writer that fails part-way gives its I/O error, typed, with nothing written after it.

use std::collections::HashSet;
use std::path::PathBuf;

use aibr_camera::aabb::Aabb;
use aibr_voxel::{PlyOptions, VoxelGrid, VoxelModel, write_ply};
use nalgebra::Point3;
use proptest::prelude::*;

mod common;
use common::{element_count, split_ply};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The four kinds of file, by their names in `fixtures/ply/`.
const KINDS: [(&str, PlyOptions); 4] = [
    (
        "points_ascii",
        PlyOptions {
            cubes: false,
            binary: false,
        },
    ),
    (
        "points_binary",
        PlyOptions {
            cubes: false,
            binary: true,
        },
    ),
    (
        "cubes_ascii",
        PlyOptions {
            cubes: true,
            binary: false,
        },
    ),
    (
        "cubes_binary",
        PlyOptions {
            cubes: true,
            binary: true,
        },
    ),
];

/// The fixture: 1 cm voxels on a 4 x 3 x 3 grid whose corner is off the origin, holding an L
/// of four voxels on the floor, a column of two on its corner, and a voxel alone in the far
/// corner of the grid (its faces on the grid's boundary are written too): 32 faces. No two
/// voxels touch along an edge or at a corner only, so each piece is a closed two-manifold
/// surface once the cubes' shared corners are merged, and the peers can measure its volume:
/// 7 cm^3.
fn fixture() -> Result<VoxelModel, Box<dyn std::error::Error>> {
    let bounds = Aabb::new(
        Point3::new(-0.02, -0.015, 0.1),
        Point3::new(0.02, 0.015, 0.13),
    )?;
    let mut model = VoxelModel::empty(VoxelGrid::new(bounds, 0.01)?);
    let voxels: [([usize; 3], [u8; 3]); 7] = [
        ([0, 0, 0], [200, 30, 30]),
        ([1, 0, 0], [30, 200, 30]),
        ([2, 0, 0], [30, 30, 200]),
        ([0, 1, 0], [250, 250, 10]),
        ([0, 0, 1], [10, 250, 250]),
        ([0, 0, 2], [250, 10, 250]),
        ([3, 2, 2], [128, 64, 0]),
    ];
    for (v, c) in voxels {
        model.set(v, c);
    }
    Ok(model)
}

/// The folder of the PLY fixtures and what the peers read of them.
fn fixtures() -> PathBuf {
    aibr_testdata::workspace_root().join("fixtures/ply")
}

/// FNV-1a, 64 bits: `ply_peer.py` records it for each file it read, so that what the peers
/// read is known to be these bytes.
fn fnv1a64(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// `AIBR_WRITE_PLY_FIXTURES=1` writes the fixtures instead of comparing; then run
/// `fixtures/ply/ply_peer.py` to have the peers read them again.
#[test]
fn write_ply_writes_the_files_the_peers_read() -> TestResult {
    let model = fixture()?;
    let golden: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixtures().join("ply_peer.json"))?)?;
    let n = model.occupied_count();
    let s = model.grid().voxel_size();
    // Every vertex the file should hold, as the script records them: [x, y, z] in
    // micrometres and [r, g, b], sorted. A cube's corners are its centre +- s/2.
    let expected = |cubes: bool| {
        let mut out = Vec::new();
        for ((k, j, i), &occupied) in model.occupied.indexed_iter() {
            if !occupied {
                continue;
            }
            let c = model.grid().centre([i, j, k]);
            let rgb = model.colour[[k, j, i]].map(i64::from);
            // A point is the centre; corner `b` of a cube lies `half` past it along axis `a`
            // where bit `a` of `b` is set, and `half` short of it where it is not.
            let (corners, half) = if cubes { (8, 0.5 * s) } else { (1, 0.0) };
            for b in 0..corners {
                let um = |a: usize| {
                    let d = if b >> a & 1 == 1 { half } else { -half };
                    ((c[a] + d) * 1e6).round() as i64
                };
                out.push([um(0), um(1), um(2), rgb[0], rgb[1], rgb[2]]);
            }
        }
        out.sort_unstable();
        out
    };
    for (name, options) in KINDS {
        let mut bytes = Vec::new();
        write_ply(&model, &mut bytes, &options)?;
        let path = fixtures().join(format!("{name}.ply"));
        if std::env::var("AIBR_WRITE_PLY_FIXTURES").is_ok_and(|v| v == "1") {
            std::fs::write(&path, &bytes)?;
            continue;
        }
        let committed = std::fs::read(&path)?;
        assert!(
            committed == bytes,
            "{} differs from what write_ply writes now: if the change is meant, write the \
             fixtures again (AIBR_WRITE_PLY_FIXTURES=1 cargo test -p aibr-voxel --test ply) and \
             have the peers read them (python3 fixtures/ply/ply_peer.py)",
            path.display()
        );

        let peers = &golden["files"][name];
        let field = |peer: &str, key: &str| {
            peers[peer][key]
                .as_f64()
                .ok_or_else(|| format!("ply_peer.json: no {peer}.{key} for {name}"))
        };
        assert_eq!(
            peers["fnv1a64"].as_str(),
            Some(format!("{:016x}", fnv1a64(&bytes)).as_str()),
            "ply_peer.json was written from other bytes than {name}.ply: run ply_peer.py again"
        );
        // Neither reader merges the cubes' coincident corners (the script merges them before
        // it measures the volume), so both count 8 vertices a cube; MeshLab splits each
        // square face into two triangles, Blender keeps it.
        let vertices = if options.cubes { 8 * n } else { n };
        let quads = if options.cubes { 32 } else { 0 };
        for (peer, faces) in [("meshlab", 2 * quads), ("blender", quads)] {
            assert_eq!(field(peer, "vertices")?, vertices as f64, "{peer}, {name}");
            assert_eq!(field(peer, "faces")?, faces as f64, "{peer}, {name}");
            let read: Vec<[i64; 6]> = peers[peer]["points"]
                .as_array()
                .ok_or("no points")?
                .iter()
                .map(|p| {
                    let p = p
                        .as_array()
                        .filter(|p| p.len() == 6)
                        .ok_or("not 6 numbers")?;
                    let mut v = [0i64; 6];
                    for (o, x) in v.iter_mut().zip(p) {
                        *o = x.as_i64().ok_or("not an integer")?;
                    }
                    Ok(v)
                })
                .collect::<Result<_, Box<dyn std::error::Error>>>()?;
            assert_eq!(
                read,
                expected(options.cubes),
                "{peer}, {name}: each vertex's position and colour"
            );
            if options.cubes {
                // The volume the surface encloses, 7 cm^3, comes out whole only when every
                // face looks out of its cube: a face turned inward counts its share negative.
                let volume = field(peer, "volume_m3")?;
                assert!(
                    (volume - 7e-6).abs() < 1e-10,
                    "{peer}, {name}: volume {volume} m^3, not 7e-6"
                );
            }
        }
        if options.cubes {
            assert_eq!(
                field("meshlab", "boundary_edges")?,
                0.0,
                "meshlab, {name}: a closed surface has no boundary edge"
            );
            assert_eq!(
                peers["meshlab"]["two_manifold"].as_bool(),
                Some(true),
                "meshlab, {name}"
            );
        }
    }
    Ok(())
}

/// A writer that takes `room` bytes, then fails as a full disk does.
struct FullAfter {
    room: usize,
    taken: Vec<u8>,
}

impl std::io::Write for FullAfter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.taken.len() >= self.room {
            return Err(std::io::Error::from_raw_os_error(28)); // ENOSPC
        }
        let n = buf.len().min(self.room - self.taken.len());
        self.taken.extend_from_slice(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A writer that fails anywhere, in the header, the vertices or the faces, gives the I/O error
/// as `Error::Io` of the PLY, after writing only a prefix of the file.
#[test]
fn a_failing_writer_gives_the_io_error() -> TestResult {
    let model = fixture()?;
    for (name, options) in KINDS {
        let mut whole = Vec::new();
        write_ply(&model, &mut whole, &options)?;
        for room in [0, 1, 100, whole.len() / 2, whole.len() - 1] {
            let mut out = FullAfter {
                room,
                taken: Vec::new(),
            };
            match write_ply(&model, &mut out, &options) {
                Err(aibr_voxel::Error::Io {
                    what: "PLY",
                    source,
                }) => {
                    assert_eq!(source.raw_os_error(), Some(28), "{name}, room {room}")
                }
                other => panic!("{name}, room {room}: {other:?}"),
            }
            assert!(whole.starts_with(&out.taken), "{name}, room {room}");
        }
    }
    Ok(())
}

/// One face of a binary cube file: its four corners in voxel units from the grid's corner.
type Quad = [[i64; 3]; 4];

/// Reads the faces of a binary cube PLY and the colour of each cube's first vertex, with the
/// corners rounded to the grid's voxel corners (asserting that they lie on them).
fn read_cubes(bytes: &[u8], grid: &VoxelGrid) -> Result<(Vec<Quad>, Vec<[u8; 3]>), String> {
    let (header, body) = split_ply(bytes)?;
    let (vertices, faces) = (
        element_count(header, "vertex")?,
        element_count(header, "face")?,
    );
    if body.len() != vertices * 15 + faces * 17 {
        return Err(format!("{} bytes after the header", body.len()));
    }
    let origin = grid.bounds().min;
    let s = grid.voxel_size();
    let mut corners = Vec::with_capacity(vertices);
    let mut colours = Vec::new();
    for (n, v) in body[..vertices * 15].chunks_exact(15).enumerate() {
        let mut q = [0i64; 3];
        for (a, o) in q.iter_mut().enumerate() {
            let x = f32::from_le_bytes([v[4 * a], v[4 * a + 1], v[4 * a + 2], v[4 * a + 3]]);
            let u = (f64::from(x) - origin[a]) / s;
            if (u - u.round()).abs() > 1e-3 {
                return Err(format!(
                    "vertex {n} is {u} voxels along axis {a}, off the corners"
                ));
            }
            *o = u.round() as i64;
        }
        corners.push(q);
        if n % 8 == 0 {
            colours.push([v[12], v[13], v[14]]);
        }
    }
    let mut quads = Vec::with_capacity(faces);
    for f in body[vertices * 15..].chunks_exact(17) {
        if f[0] != 4 {
            return Err(format!("a face of {} vertices", f[0]));
        }
        let mut quad = [[0i64; 3]; 4];
        for (c, q) in quad.iter_mut().enumerate() {
            let i = i32::from_le_bytes([f[1 + 4 * c], f[2 + 4 * c], f[3 + 4 * c], f[4 + 4 * c]]);
            *q = *usize::try_from(i)
                .ok()
                .and_then(|i| corners.get(i))
                .ok_or(format!("vertex index {i} of {vertices}"))?;
        }
        quads.push(quad);
    }
    Ok((quads, colours))
}

fn arbitrary_model() -> impl Strategy<Value = VoxelModel> {
    (1usize..5, 1usize..5, 1usize..5, -1.0f64..1.0, 0.002f64..0.1)
        .prop_flat_map(|(nx, ny, nz, offset, s)| {
            (
                Just((nx, ny, nz, offset, s)),
                prop::collection::vec(any::<Option<[u8; 3]>>(), nx * ny * nz),
            )
        })
        .prop_filter_map("a valid grid", |((nx, ny, nz, offset, s), cells)| {
            let min = Point3::new(offset, -offset, 0.5 * offset);
            let max = min + nalgebra::Vector3::new(nx as f64, ny as f64, nz as f64) * s;
            let grid = VoxelGrid::new(Aabb::new(min, max).ok()?, s).ok()?;
            (grid.dims() == [nx, ny, nz]).then_some(())?;
            let mut model = VoxelModel::empty(grid);
            for (n, c) in cells.into_iter().enumerate() {
                if let Some(c) = c {
                    model.set([n % nx, n / nx % ny, n / (nx * ny)], c);
                }
            }
            Some(model)
        })
}

proptest! {
    #[test]
    fn cube_faces_are_the_boundary_and_face_out(model in arbitrary_model()) {
        let mut bytes = Vec::new();
        write_ply(&model, &mut bytes, &PlyOptions { cubes: true, binary: true })
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        let (quads, colours) = read_cubes(&bytes, model.grid()).map_err(TestCaseError::fail)?;
        let [nx, ny, nz] = model.grid().dims();
        let occupied = |v: [i64; 3]| {
            v.iter().zip([nx, ny, nz]).all(|(&c, m)| c >= 0 && (c as usize) < m)
                && model.is_occupied(v.map(|c| c as usize))
        };

        // Each face: a unit square whose corners turn counter-clockwise seen from outside,
        // with the occupied voxel behind it and an empty one (or the outside) in front.
        let mut seen = HashSet::new();
        for q in &quads {
            let e1: [i64; 3] = std::array::from_fn(|a| q[1][a] - q[0][a]);
            let e2: [i64; 3] = std::array::from_fn(|a| q[3][a] - q[0][a]);
            let normal = [
                e1[1] * e2[2] - e1[2] * e2[1],
                e1[2] * e2[0] - e1[0] * e2[2],
                e1[0] * e2[1] - e1[1] * e2[0],
            ];
            prop_assert_eq!(normal.iter().map(|c| c.abs()).sum::<i64>(), 1, "{:?}", q);
            for c in 0..4 {
                let diagonal: [i64; 3] = std::array::from_fn(|a| q[(c + 2) % 4][a] - q[c][a]);
                prop_assert_eq!(diagonal.iter().map(|d| d.abs()).sum::<i64>(), 2, "{:?}", q);
            }
            // The voxel behind the face: its lowest corner is the square's lowest corner,
            // stepped back along the normal when the normal points down an axis.
            let low: [i64; 3] = std::array::from_fn(|a| q.iter().map(|c| c[a]).min().unwrap_or(0));
            let inside: [i64; 3] = std::array::from_fn(|a| low[a] - i64::from(normal[a] > 0));
            let outside: [i64; 3] = std::array::from_fn(|a| inside[a] + normal[a]);
            prop_assert!(occupied(inside), "face {:?}: voxel {:?} behind it is empty", q, inside);
            prop_assert!(!occupied(outside), "face {:?}: voxel {:?} in front is occupied", q, outside);
            prop_assert!(seen.insert((inside, outside)), "face {:?} written twice", q);
        }
        // And no face is missing: one for every occupied voxel's empty (or outside) neighbour.
        let mut boundary = 0;
        let mut cube_colours = Vec::new();
        for k in 0..nz as i64 {
            for j in 0..ny as i64 {
                for i in 0..nx as i64 {
                    if !occupied([i, j, k]) {
                        continue;
                    }
                    cube_colours.push(model.colour_of([i, j, k].map(|c| c as usize)));
                    for a in 0..3 {
                        for d in [-1, 1] {
                            let mut n = [i, j, k];
                            n[a] += d;
                            boundary += usize::from(!occupied(n));
                        }
                    }
                }
            }
        }
        prop_assert_eq!(quads.len(), boundary);
        prop_assert_eq!(colours.into_iter().map(Some).collect::<Vec<_>>(), cube_colours);
    }
}
