//! A grey image as `f32` samples, with the few filters detection needs.

use image::GrayImage;

/// A single-channel `f32` image, row-major.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Plane {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) data: Vec<f32>,
}

impl Plane {
    pub(crate) fn from_gray(image: &GrayImage) -> Self {
        Plane {
            width: image.width() as usize,
            height: image.height() as usize,
            data: image.as_raw().iter().map(|&v| v as f32).collect(),
        }
    }

    /// The sample at `(x, y)`, clamped to the image (replicated border).
    #[inline]
    pub(crate) fn at(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Bilinear interpolation at `(x, y)` (pixel centres at integers), replicated border.
    #[inline]
    pub(crate) fn bilinear(&self, x: f64, y: f64) -> f32 {
        let (fx, fy) = (x.floor(), y.floor());
        let (tx, ty) = ((x - fx) as f32, (y - fy) as f32);
        let (ix, iy) = (fx as isize, fy as isize);
        let top = self.at(ix, iy) * (1.0 - tx) + self.at(ix + 1, iy) * tx;
        let bottom = self.at(ix, iy + 1) * (1.0 - tx) + self.at(ix + 1, iy + 1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// Gaussian blur with standard deviation `sigma` pixels (separable, replicated border).
    pub(crate) fn gaussian_blur(&self, sigma: f64) -> Plane {
        let radius = (3.0 * sigma).ceil().max(1.0) as usize;
        let mut kernel: Vec<f32> = (0..=2 * radius)
            .map(|i| {
                let d = i as f64 - radius as f64;
                (-d * d / (2.0 * sigma * sigma)).exp() as f32
            })
            .collect();
        let sum: f32 = kernel.iter().sum();
        kernel.iter_mut().for_each(|k| *k /= sum);
        let (w, h) = (self.width, self.height);
        // Horizontal pass over a row padded by the border values.
        let mut horizontal = vec![0.0f32; w * h];
        let mut padded = vec![0.0f32; w + 2 * radius];
        for y in 0..h {
            let row = &self.data[y * w..(y + 1) * w];
            padded[radius..radius + w].copy_from_slice(row);
            padded[..radius].fill(row[0]);
            padded[radius + w..].fill(row[w - 1]);
            let out = &mut horizontal[y * w..(y + 1) * w];
            for (i, &k) in kernel.iter().enumerate() {
                for (o, &p) in out.iter_mut().zip(&padded[i..i + w]) {
                    *o += k * p;
                }
            }
        }
        // Vertical pass, row by row so the inner loop runs along memory.
        let mut data = vec![0.0f32; w * h];
        for y in 0..h {
            let out = &mut data[y * w..(y + 1) * w];
            for (i, &k) in kernel.iter().enumerate() {
                let sy =
                    (y as isize + i as isize - radius as isize).clamp(0, h as isize - 1) as usize;
                for (o, &p) in out.iter_mut().zip(&horizontal[sy * w..(sy + 1) * w]) {
                    *o += k * p;
                }
            }
        }
        Plane {
            width: w,
            height: h,
            data,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blur_keeps_constants_and_mass() {
        let mut img = GrayImage::new(21, 17);
        img.put_pixel(10, 8, image::Luma([255]));
        let p = Plane::from_gray(&img).gaussian_blur(1.5);
        let sum: f32 = p.data.iter().sum();
        assert!((sum - 255.0).abs() < 1e-2, "{sum}");
        // Symmetric around the impulse.
        assert!((p.at(8, 8) - p.at(12, 8)).abs() < 1e-5);
        assert!((p.at(10, 6) - p.at(10, 10)).abs() < 1e-5);
        let flat =
            Plane::from_gray(&GrayImage::from_pixel(9, 9, image::Luma([77]))).gaussian_blur(2.0);
        assert!(flat.data.iter().all(|&v| (v - 77.0).abs() < 1e-3));
    }

    #[test]
    fn bilinear_interpolates() {
        let img = GrayImage::from_raw(2, 2, vec![0, 100, 200, 255]).unwrap_or_default();
        let p = Plane::from_gray(&img);
        assert_eq!(p.bilinear(0.5, 0.0), 50.0);
        assert_eq!(p.bilinear(0.0, 0.5), 100.0);
        assert_eq!(p.bilinear(-3.0, 7.0), 200.0);
    }
}
