//! Procedural solid textures: colour as a function of a point in the object frame, so every
//! view of a surface point sees the same albedo (colour consistency carries information).

use nalgebra::{Point3, Vector3};

use crate::rng::{hash3, hash3_unit};

/// Linear RGB in `[0, 1]`.
pub type Colour = Vector3<f32>;

/// A colour from 8-bit sRGB-looking components (taken as linear).
pub fn rgb8(r: u8, g: u8, b: u8) -> Colour {
    Colour::new(r as f32 / 255.0, g as f32 / 255.0, b as f32 / 255.0)
}

/// A solid texture.
#[derive(Debug, Clone, PartialEq)]
pub enum Texture {
    /// One colour.
    Solid(Colour),
    /// Fractal value noise between two colours: features of `feature_m` metres with
    /// `octaves` finer layers (each half the size).
    Noise {
        /// Colour at noise 0.
        low: Colour,
        /// Colour at noise 1.
        high: Colour,
        /// Size of the coarsest features, metres.
        feature_m: f64,
        /// Number of layers (1 to 8).
        octaves: u32,
        /// Seed of the lattice.
        seed: u64,
    },
    /// A 3D checkerboard of cubes of `square_m` metres, with soft edges.
    Checker {
        /// First colour.
        a: Colour,
        /// Second colour.
        b: Colour,
        /// Edge of a cube, metres.
        square_m: f64,
    },
    /// A printed calibration checkerboard in the XY plane (the same at every height):
    /// `cols x rows` squares of `square_m` metres from `origin_xy` (the corner of the squared
    /// area with the smallest x and y) on `light` paper. The square at `origin_xy` is light;
    /// edges are anti-aliased over `edge_m` metres, as a camera pixel would blur them, and
    /// corners stay sharp crossings (unlike [`Texture::Checker`]).
    Board {
        /// Colour of the dark squares.
        dark: Colour,
        /// Colour of the light squares and the paper around them.
        light: Colour,
        /// Edge of a square, metres.
        square_m: f64,
        /// Squares along x.
        cols: u32,
        /// Squares along y.
        rows: u32,
        /// Corner of the squared area with the smallest x and y, metres.
        origin_xy: [f64; 2],
        /// Width of the anti-aliased transition at an edge, metres.
        edge_m: f64,
    },
    /// Another texture with fine multiplicative grain: the colour is scaled by
    /// `1 + amplitude (n - 1/2)` with `n` two-octave noise of `feature_m` metres. Real
    /// surfaces carry detail at every scale; grain gives colour consistency something to
    /// lock onto at the scale of a voxel.
    Grain {
        /// The texture underneath.
        base: Box<Texture>,
        /// Strength of the grain (0 to 1).
        amplitude: f32,
        /// Size of the grain, metres.
        feature_m: f64,
        /// Seed of the noise.
        seed: u64,
    },
    /// A colour from `palette` at every point of a lattice of `cell_m` metres, blended
    /// smoothly in between: strong colour changes, like a printed label, without edges
    /// sharper than a camera would resolve.
    Patchwork {
        /// The colours cells choose from.
        palette: Vec<Colour>,
        /// Edge of a cell, metres.
        cell_m: f64,
        /// Seed of the choice.
        seed: u64,
    },
}

impl Texture {
    /// This texture with [`Texture::Grain`] of the given strength at 4 mm.
    pub fn grainy(self, amplitude: f32, seed: u64) -> Texture {
        Texture::Grain {
            base: Box::new(self),
            amplitude,
            feature_m: 0.004,
            seed,
        }
    }

    /// The albedo at `p` (object frame).
    pub fn colour_at(&self, p: &Point3<f64>) -> Colour {
        match self {
            Texture::Solid(c) => *c,
            Texture::Noise {
                low,
                high,
                feature_m,
                octaves,
                seed,
            } => {
                let t = fbm(&(p.coords / *feature_m), *octaves, *seed) as f32;
                low + (high - low) * t
            }
            Texture::Grain {
                base,
                amplitude,
                feature_m,
                seed,
            } => {
                let n = fbm(&(p.coords / *feature_m), 2, *seed) as f32;
                base.colour_at(p) * (1.0 + amplitude * (n - 0.5))
            }
            Texture::Checker { a, b, square_m } => {
                // sin x sin y sin z changes sign on the cube faces; tanh makes it a checker
                // whose edges are soft over about a tenth of a square (band-limited).
                let c = p.coords * (std::f64::consts::PI / *square_m);
                let v = (c.x.sin() * c.y.sin() * c.z.sin() * 6.0).tanh() as f32;
                b + (a - b) * (0.5 + 0.5 * v)
            }
            Texture::Board {
                dark,
                light,
                square_m,
                cols,
                rows,
                origin_xy,
                edge_m,
            } => {
                let u = (p.x - origin_xy[0]) / square_m;
                let v = (p.y - origin_xy[1]) / square_m;
                let e = (edge_m / square_m).clamp(1e-6, 0.5);
                // +1 in even squares, -1 in odd ones, a linear ramp of width e across edges.
                let parity = |t: f64| {
                    ((std::f64::consts::PI * t).sin() / (0.5 * std::f64::consts::PI * e).sin())
                        .clamp(-1.0, 1.0)
                };
                // 1 inside the squared area, 0 on the paper, the same ramp at the outline.
                let inside = |t: f64, n: u32| ((t.min(n as f64 - t)) / e + 0.5).clamp(0.0, 1.0);
                let blend = inside(u, *cols) * inside(v, *rows);
                let value = (blend * parity(u) * parity(v) + (1.0 - blend)) as f32;
                dark + (light - dark) * (0.5 + 0.5 * value)
            }
            Texture::Patchwork {
                palette,
                cell_m,
                seed,
            } => {
                if palette.is_empty() {
                    return Colour::zeros();
                }
                // Palette colours at the lattice points, blended smoothly in between: strong
                // colour changes, band-limited so that a camera (which integrates over its
                // pixels) would not alias them.
                let c = p.coords / *cell_m;
                let (fx, fy, fz) = (c.x.floor(), c.y.floor(), c.z.floor());
                let s = |t: f64| (t * t * (3.0 - 2.0 * t)) as f32;
                let (tx, ty, tz) = (s(c.x - fx), s(c.y - fy), s(c.z - fz));
                let at = |dx: i64, dy: i64, dz: i64| {
                    let h = hash3(fx as i64 + dx, fy as i64 + dy, fz as i64 + dz, *seed);
                    palette[(h % palette.len() as u64) as usize]
                };
                let lerp = |a: Colour, b: Colour, t: f32| a + (b - a) * t;
                let x00 = lerp(at(0, 0, 0), at(1, 0, 0), tx);
                let x10 = lerp(at(0, 1, 0), at(1, 1, 0), tx);
                let x01 = lerp(at(0, 0, 1), at(1, 0, 1), tx);
                let x11 = lerp(at(0, 1, 1), at(1, 1, 1), tx);
                lerp(lerp(x00, x10, ty), lerp(x01, x11, ty), tz)
            }
        }
    }
}

/// Smooth value noise in `[0, 1]` at `p` (lattice spacing 1).
pub fn value_noise(p: &Vector3<f64>, seed: u64) -> f64 {
    let (fx, fy, fz) = (p.x.floor(), p.y.floor(), p.z.floor());
    let (ix, iy, iz) = (fx as i64, fy as i64, fz as i64);
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let (tx, ty, tz) = (s(p.x - fx), s(p.y - fy), s(p.z - fz));
    let v = |dx: i64, dy: i64, dz: i64| hash3_unit(ix + dx, iy + dy, iz + dz, seed);
    let lerp = |a: f64, b: f64, t: f64| a + (b - a) * t;
    let x00 = lerp(v(0, 0, 0), v(1, 0, 0), tx);
    let x10 = lerp(v(0, 1, 0), v(1, 1, 0), tx);
    let x01 = lerp(v(0, 0, 1), v(1, 0, 1), tx);
    let x11 = lerp(v(0, 1, 1), v(1, 1, 1), tx);
    lerp(lerp(x00, x10, ty), lerp(x01, x11, ty), tz)
}

/// Fractal sum of `octaves` layers of value noise, normalised to `[0, 1]` and stretched so
/// that its values use most of that range.
pub fn fbm(p: &Vector3<f64>, octaves: u32, seed: u64) -> f64 {
    let octaves = octaves.clamp(1, 8);
    let (mut sum, mut norm, mut amp, mut freq) = (0.0, 0.0, 1.0, 1.0);
    for o in 0..octaves {
        sum += amp * value_noise(&(p * freq), seed.wrapping_add(o as u64 * 0x1000_0001));
        norm += amp;
        amp *= 0.5;
        freq *= 2.0;
    }
    // Sums of noise cluster around 0.5: stretch by 2 and clamp, for contrast.
    ((sum / norm - 0.5) * 2.0 + 0.5).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_is_bounded_and_continuous() {
        let mut prev = value_noise(&Vector3::new(0.0, 0.3, 0.7), 1);
        for i in 1..1000 {
            let v = value_noise(&Vector3::new(i as f64 * 0.001, 0.3, 0.7), 1);
            assert!((0.0..=1.0).contains(&v));
            assert!((v - prev).abs() < 0.01);
            prev = v;
        }
    }

    #[test]
    fn patchwork_uses_its_palette() {
        let t = Texture::Patchwork {
            palette: vec![rgb8(255, 0, 0), rgb8(0, 0, 255)],
            cell_m: 0.01,
            seed: 3,
        };
        let c = t.colour_at(&Point3::new(0.003, 0.004, 0.005));
        // A blend of the two palette colours: no green, red and blue summing to one.
        assert!(c.y == 0.0 && (c.x + c.z - 1.0).abs() < 1e-5, "{c}");
    }
}
