//! Averaging K frames to reduce sensor noise (the paper smooths its noisy webcam images).

use image::RgbImage;

use crate::error::{Error, Result};

/// Sums frames of one size and gives their rounded mean.
#[derive(Debug, Clone, Default)]
pub struct FrameAverager {
    sum: Vec<u32>,
    count: u32,
    width: u32,
    height: u32,
}

impl FrameAverager {
    /// An empty averager.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a frame; every frame must have the size of the first.
    pub fn add(&mut self, frame: &RgbImage) -> Result<()> {
        let (w, h) = frame.dimensions();
        if self.count == 0 {
            self.width = w;
            self.height = h;
            self.sum.clear();
            self.sum.resize(frame.as_raw().len(), 0);
        } else if (w, h) != (self.width, self.height) {
            return Err(Error::SizeMismatch {
                width: self.width,
                height: self.height,
                got_width: w,
                got_height: h,
            });
        }
        for (s, &v) in self.sum.iter_mut().zip(frame.as_raw()) {
            *s += v as u32;
        }
        self.count += 1;
        Ok(())
    }

    /// Frames added so far.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The mean of the frames added, rounded half up; `None` before the first.
    pub fn mean(&self) -> Option<RgbImage> {
        if self.count == 0 {
            return None;
        }
        let n = self.count;
        let data = self.sum.iter().map(|&s| ((s + n / 2) / n) as u8).collect();
        RgbImage::from_raw(self.width, self.height, data)
    }

    /// Forgets the frames added.
    pub fn clear(&mut self) {
        self.count = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_mean_and_sizes() {
        let mut a = FrameAverager::new();
        assert!(a.mean().is_none());
        a.add(&RgbImage::from_raw(1, 1, vec![0, 10, 255]).unwrap())
            .unwrap();
        a.add(&RgbImage::from_raw(1, 1, vec![1, 11, 255]).unwrap())
            .unwrap();
        assert_eq!(a.mean().unwrap().as_raw(), &[1, 11, 255]);
        assert!(matches!(
            a.add(&RgbImage::new(2, 1)),
            Err(Error::SizeMismatch { .. })
        ));
        a.clear();
        a.add(&RgbImage::new(2, 1)).unwrap();
        assert_eq!(a.count(), 1);
    }
}
