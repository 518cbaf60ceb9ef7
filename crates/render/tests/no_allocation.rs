//! `Renderer::render_into` allocates nothing once its buffers have seen a frame: counted by a
//! global allocator, in a test binary of its own so that nothing else runs beside it.

// The counting allocator forwards to the system's; implementing `GlobalAlloc` is unsafe.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

use aibr_camera::{Aabb, Angle, Camera, CircularMotion, Distortion, ImageSize, Intrinsics};
use aibr_render::{RenderParams, RenderedView, Renderer, SourceView};
use aibr_voxel::{VoxelGrid, VoxelModel};
use image::{Rgb, RgbImage};
use nalgebra::Point3;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

// SAFETY: every call is forwarded unchanged to the system allocator.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: the caller's contract is passed on.
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        // SAFETY: the caller's contract is passed on.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn frames_after_the_first_allocate_nothing() -> Result<(), Box<dyn std::error::Error>> {
    let grid = VoxelGrid::with_resolution(
        Aabb {
            min: Point3::new(-0.1, -0.1, 0.0),
            max: Point3::new(0.1, 0.1, 0.2),
        },
        24,
    )?;
    // A block with a textured top and sides, so that every path of the renderer runs: focal
    // plane, model surface, refinement.
    let mut model = VoxelModel::empty(grid);
    for k in 4..18 {
        for j in 6..18 {
            for i in 6..18 {
                model.set([i, j, k], [(i * 10) as u8, (j * 10) as u8, (k * 10) as u8]);
            }
        }
    }
    let ring = CircularMotion::ring(0.6, 0.3, 0.1)?;
    let size = ImageSize::new(128, 96);
    let camera = |degrees: f64| {
        Camera::new(
            Intrinsics::new(220.0, 220.0, 63.5, 47.5),
            Distortion::NONE,
            ring.cam_from_world(Angle::from_degrees(degrees)),
            size,
        )
    };
    let sources = (0..8)
        .map(|i| {
            let image = RgbImage::from_fn(size.width, size.height, |x, y| {
                Rgb([(x * 2) as u8, (y * 2) as u8, ((x + y + 20 * i) % 256) as u8])
            });
            Ok(SourceView {
                camera: camera(f64::from(i) * 45.0)?,
                image,
            })
        })
        .collect::<Result<Vec<_>, aibr_camera::Error>>()?;
    let renderer = Renderer::new(&model, sources, RenderParams::default())?;
    let cameras = [10.0, 22.5, 30.0, 100.0]
        .into_iter()
        .map(camera)
        .collect::<Result<Vec<_>, _>>()?;
    let mut buffers = RenderedView::new(size);
    // The first pass sizes the buffers for the largest frame.
    for c in &cameras {
        renderer.render_into(c, &mut buffers)?;
    }
    let before = ALLOCATIONS.load(Ordering::SeqCst);
    for c in &cameras {
        renderer.render_into(c, &mut buffers)?;
    }
    let allocations = ALLOCATIONS.load(Ordering::SeqCst) - before;
    assert_eq!(allocations, 0, "{allocations} allocations in four frames");
    // And the frames drew something: the block and the backdrop.
    let (geometry, fallback, _) = buffers.coverage_shares();
    assert!(geometry > 0.05 && fallback > 0.2, "{geometry} {fallback}");
    Ok(())
}
