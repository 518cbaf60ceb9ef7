//! The named scenes: `mirror`, `mirror-broad`, `head`, `chair` and `lambertian`.
//!
//! All stand on the turntable (`z = 0`) within 0.1 m of the axis and at most 0.22 m tall, under
//! the same rig and lights:
//!
//! - rig: 640x480, `fx = fy = 900`, principal point at the image centre, no distortion; the
//!   camera 0.55 m from the axis and 0.32 m above the turntable, looking at the axis 0.09 m
//!   up; pan range +-159 degrees like a PTU-46 (a 42 degree opening behind the object);
//! - lights: a lamp on the pan axis 1.2 m up and a sky light. Both are symmetric about the
//!   axis, so the shading of a matte surface is the same at every pan angle (colour
//!   consistency holds), while highlights and reflections, which depend on the camera too,
//!   slide over the object as it turns;
//! - backdrop: dark blue-grey noise fixed in the lab; environment: the studio
//!   ([`Environment::Studio`]; `mirror-broad`'s is [`Environment::BroadStudio`]).
//!
//! | scene | what | ground-truth volume (m) |
//! |---|---|---|
//! | `mirror` | a matchbox (printed label texture) with a mirror panel on its -X side, after the paper's "mirror bound with a matches box" | x -0.0655..0.060, y -0.045..0.045, z -0.005..0.175 |
//! | `mirror-broad` | `mirror` in a studio of broad features only (no fine stripes, floor tiles five times as large), so that how well the mirror renders depends on how densely the views fall near it | as `mirror` |
//! | `head` | glossy textured ellipsoid head with nose and ears on a neck and pedestal (Blinn-Phong highlights) | x -0.080..0.080, y -0.083..0.080, z -0.005..0.230 |
//! | `chair` | a chair with four thin legs, a seat and a slatted back (self-occlusion) | x -0.070..0.070, y -0.070..0.070, z -0.005..0.215 |
//! | `lambertian` | a matte textured block, drum and ball | x -0.070..0.070, y -0.070..0.070, z -0.005..0.200 |
//!
//! (Each volume is the object bounds grown by 5 mm; [`Scene::bounds`] computes it.)

use aibr_camera::{Angle, CircularMotion, Distortion, ImageSize, Intrinsics, PanRange};
use nalgebra::{Point3, Vector3};

use crate::error::{Error, Result};
use crate::scene::{
    Backdrop, Environment, Light, Material, Scene, SceneObject, SceneRig, SkyLight,
};
use crate::shape::Shape;
use crate::texture::{Colour, Texture, rgb8};

/// Names of the catalogue scenes.
pub const SCENE_NAMES: [&str; 5] = ["mirror", "mirror-broad", "head", "chair", "lambertian"];

/// The catalogue scene called `name`.
pub fn by_name(name: &str) -> Result<Scene> {
    match name {
        "mirror" => mirror(),
        "mirror-broad" => mirror_broad(),
        "head" => head(),
        "chair" => chair(),
        "lambertian" => lambertian(),
        _ => Err(Error::UnknownScene {
            name: name.to_owned(),
            known: SCENE_NAMES.join(", "),
        }),
    }
}

/// The rig shared by the catalogue (see the module docs).
pub fn default_rig() -> Result<SceneRig> {
    Ok(SceneRig {
        intrinsics: Intrinsics::new(900.0, 900.0, 319.5, 239.5),
        distortion: Distortion::NONE,
        size: ImageSize::new(640, 480),
        ring: CircularMotion::ring(0.55, 0.32, 0.09)?,
        pan_range: PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?,
    })
}

fn studio_scene(name: &str, objects: Vec<SceneObject>) -> Result<Scene> {
    scene_in(name, objects, Environment::Studio)
}

/// A catalogue scene: `objects` under the shared lights, backdrop and rig, with `environment`
/// in its mirrors.
fn scene_in(name: &str, objects: Vec<SceneObject>, environment: Environment) -> Result<Scene> {
    Scene::new(
        name,
        objects,
        vec![Light {
            position_lab: Point3::new(0.0, 0.0, 1.2),
            colour: Colour::new(0.7, 0.7, 0.68),
        }],
        SkyLight {
            up: Colour::new(0.5, 0.5, 0.52),
            down: Colour::new(0.22, 0.21, 0.2),
        },
        Backdrop::Noise {
            low: Colour::new(0.04, 0.05, 0.07),
            high: Colour::new(0.16, 0.18, 0.22),
            feature: 0.02,
            seed: 99,
        },
        environment,
        default_rig()?,
    )
}

fn label(seed: u64) -> Texture {
    Texture::Patchwork {
        palette: vec![
            rgb8(200, 40, 30),
            rgb8(240, 200, 60),
            rgb8(30, 90, 170),
            rgb8(235, 235, 225),
            rgb8(40, 140, 70),
            rgb8(25, 25, 30),
        ],
        cell_m: 0.008,
        seed,
    }
    .grainy(0.8, seed + 100)
}

fn matte(texture: Texture) -> Material {
    Material::Matte { texture }
}

fn cuboid(min: [f64; 3], max: [f64; 3], material: Material) -> SceneObject {
    SceneObject {
        shape: Shape::Cuboid {
            min: Point3::from(min),
            max: Point3::from(max),
        },
        material,
    }
}

fn cylinder(base: [f64; 3], radius: f64, height: f64, material: Material) -> SceneObject {
    SceneObject {
        shape: Shape::Cylinder {
            base: Point3::from(base),
            radius,
            height,
        },
        material,
    }
}

fn ellipsoid(centre: [f64; 3], radii: [f64; 3], material: Material) -> SceneObject {
    SceneObject {
        shape: Shape::Ellipsoid {
            centre: Point3::from(centre),
            radii: Vector3::from(radii),
        },
        material,
    }
}

/// A matchbox with a mirror panel on its -X side.
pub fn mirror() -> Result<Scene> {
    scene_in("mirror", matchbox_with_mirror(), Environment::Studio)
}

/// [`mirror`] in the [`Environment::BroadStudio`]: the same objects, with a reflection that
/// changes about half as fast with the turn, so that how well the mirror renders depends
/// more on how densely the views fall near it (in `mirror`'s studio a stripe's image lasts
/// 1.5 degrees of turn).
pub fn mirror_broad() -> Result<Scene> {
    scene_in(
        "mirror-broad",
        matchbox_with_mirror(),
        Environment::BroadStudio,
    )
}

/// The objects of [`mirror`]: a matchbox with a mirror panel on its -X side.
fn matchbox_with_mirror() -> Vec<SceneObject> {
    let panel_x = -0.0605; // half a millimetre in front of the box's -X face
    vec![
        cuboid([-0.06, -0.04, 0.0], [0.055, 0.04, 0.17], matte(label(7))),
        SceneObject {
            shape: Shape::Quad {
                corner: Point3::new(panel_x, -0.035, 0.01),
                u: Vector3::new(0.0, 0.07, 0.0),
                v: Vector3::new(0.0, 0.0, 0.15),
            },
            material: Material::Mirror {
                tint: Colour::new(0.92, 0.92, 0.95),
            },
        },
    ]
}

/// A glossy textured head on a neck and pedestal.
pub fn head() -> Result<Scene> {
    let skin = Material::Glossy {
        texture: Texture::Noise {
            low: rgb8(120, 70, 50),
            high: rgb8(235, 190, 150),
            feature_m: 0.012,
            octaves: 4,
            seed: 5,
        }
        .grainy(0.8, 105),
        specular: 0.6,
        shininess: 60.0,
    };
    let stone = matte(
        Texture::Noise {
            low: rgb8(60, 60, 70),
            high: rgb8(200, 200, 190),
            feature_m: 0.01,
            octaves: 3,
            seed: 6,
        }
        .grainy(0.8, 106),
    );
    studio_scene(
        "head",
        vec![
            cuboid([-0.075, -0.075, 0.0], [0.075, 0.075, 0.04], stone),
            cylinder([0.0, 0.0, 0.04], 0.03, 0.07, skin.clone()),
            ellipsoid([0.0, 0.0, 0.15], [0.06, 0.065, 0.075], skin.clone()),
            ellipsoid([0.0, -0.063, 0.145], [0.012, 0.015, 0.02], skin.clone()),
            ellipsoid([0.06, 0.0, 0.15], [0.01, 0.012, 0.02], skin.clone()),
            ellipsoid([-0.06, 0.0, 0.15], [0.01, 0.012, 0.02], skin),
        ],
    )
}

/// A chair with thin legs and a slatted back.
pub fn chair() -> Result<Scene> {
    let wood = Material::Glossy {
        texture: Texture::Noise {
            low: rgb8(90, 50, 20),
            high: rgb8(210, 150, 80),
            feature_m: 0.006,
            octaves: 4,
            seed: 8,
        }
        .grainy(0.8, 108),
        specular: 0.15,
        shininess: 20.0,
    };
    let cushion = matte(label(9));
    let mut objects = Vec::new();
    for (x, y) in [
        (-0.055, -0.055),
        (0.055, -0.055),
        (-0.055, 0.055),
        (0.055, 0.055),
    ] {
        objects.push(cylinder([x, y, 0.0], 0.006, 0.09, wood.clone()));
    }
    objects.push(cuboid(
        [-0.065, -0.065, 0.09],
        [0.065, 0.065, 0.105],
        cushion,
    ));
    // The back: two posts, a top rail and two slats, on the +Y side.
    for x in [-0.055, 0.055] {
        objects.push(cylinder([x, 0.055, 0.105], 0.006, 0.105, wood.clone()));
    }
    objects.push(cuboid(
        [-0.062, 0.048, 0.19],
        [0.062, 0.062, 0.21],
        wood.clone(),
    ));
    for x in [-0.02, 0.02] {
        objects.push(cuboid(
            [x - 0.006, 0.05, 0.105],
            [x + 0.006, 0.06, 0.19],
            wood.clone(),
        ));
    }
    studio_scene("chair", objects)
}

/// A matte textured block, drum and ball.
pub fn lambertian() -> Result<Scene> {
    studio_scene(
        "lambertian",
        vec![
            cuboid([-0.065, -0.065, 0.0], [0.065, 0.065, 0.06], matte(label(3))),
            cylinder(
                [0.0, 0.0, 0.06],
                0.045,
                0.07,
                matte(
                    Texture::Noise {
                        low: rgb8(20, 60, 120),
                        high: rgb8(220, 210, 120),
                        feature_m: 0.01,
                        octaves: 4,
                        seed: 4,
                    }
                    .grainy(0.8, 104),
                ),
            ),
            ellipsoid(
                [0.0, 0.0, 0.165],
                [0.03, 0.03, 0.03],
                matte(
                    Texture::Checker {
                        a: rgb8(200, 60, 60),
                        b: rgb8(240, 240, 230),
                        square_m: 0.012,
                    }
                    .grainy(0.8, 110),
                ),
            ),
        ],
    )
}

/// A calibration target: a printed checkerboard of `cols x rows` squares of `square_m`
/// metres on white paper (a margin of 1.5 squares), lying flat on the turntable (`z = 0`)
/// and centred on the axis, seen by `rig`. Not one of [`SCENE_NAMES`]: it is for
/// calibrating, not reconstructing.
///
/// The square with the smallest x and y is light, so square `(i, j)` (from that corner,
/// `i` along +X) is light when `i + j` is even. Its inner corners lie at
/// `x = (i - cols / 2) square_m`, `y = (j - rows / 2) square_m` for `i` in `1..cols`, `j`
/// in `1..rows`.
pub fn checkerboard(cols: u32, rows: u32, square_m: f64, rig: SceneRig) -> Result<Scene> {
    if cols < 3 || rows < 3 || !(square_m > 0.0 && square_m.is_finite()) {
        return Err(Error::InvalidParameter {
            name: "checkerboard",
            value: square_m,
            reason: "needs at least 3x3 squares of a positive size",
        });
    }
    let (w, h) = (cols as f64 * square_m, rows as f64 * square_m);
    let margin = 1.5 * square_m;
    let white = Colour::new(0.9, 0.9, 0.9);
    let board = SceneObject {
        shape: Shape::Quad {
            corner: Point3::new(-0.5 * w - margin, -0.5 * h - margin, 0.0),
            u: Vector3::new(w + 2.0 * margin, 0.0, 0.0),
            v: Vector3::new(0.0, h + 2.0 * margin, 0.0),
        },
        material: matte(Texture::Board {
            dark: Colour::new(0.06, 0.06, 0.06),
            light: white,
            square_m,
            cols,
            rows,
            origin_xy: [-0.5 * w, -0.5 * h],
            // About a pixel at half a metre for a webcam.
            edge_m: 0.0008,
        }),
    };
    Scene::new(
        "checkerboard",
        vec![board],
        vec![Light {
            position_lab: Point3::new(0.3, -0.2, 1.0),
            colour: Colour::new(0.3, 0.3, 0.3),
        }],
        SkyLight {
            up: Colour::new(0.8, 0.8, 0.8),
            down: Colour::new(0.2, 0.2, 0.2),
        },
        Backdrop::Noise {
            low: Colour::new(0.05, 0.05, 0.05),
            high: Colour::new(0.3, 0.3, 0.3),
            feature: 0.03,
            seed: 7,
        },
        Environment::Solid(Colour::new(0.5, 0.5, 0.5)),
        rig,
    )
}
