//! The checkerboard: inner-corner counts, square size, and the board frame.

use std::fmt;
use std::str::FromStr;

use nalgebra::Point3;

use crate::error::{Error, Result};

/// A checkerboard described by its inner corners (OpenCV's "pattern size") and its square
/// size.
///
/// The board frame: the origin at inner corner 0, x along a row of corners, y down the
/// columns, z into the board (away from a camera that sees its face), metres. Corner `(c, r)`
/// lies at `(c s, r s, 0)`, and corners are listed row by row, `index = r * cols + c`.
///
/// Which inner corner is number 0: the corner of the board's dark corner square. When
/// `cols + rows` is odd (9x6, 7x8, ...) two opposite corner squares are dark and two light,
/// so the labelling is unique and poses of the board are comparable between views (a
/// turntable calibration needs this). When it is even the board looks the same after a
/// half turn and the labelling is only unique up to it; intrinsic calibration does not mind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardSpec {
    /// Inner corners per row (at least 2).
    pub cols: usize,
    /// Rows of inner corners (at least 2).
    pub rows: usize,
    /// Edge of a square, metres.
    pub square_m: f64,
}

impl BoardSpec {
    /// A board of `cols x rows` inner corners with squares of `square_m` metres.
    pub fn new(cols: usize, rows: usize, square_m: f64) -> Result<Self> {
        if cols < 2 || rows < 2 || cols > 1000 || rows > 1000 {
            return Err(Error::InvalidParameter {
                name: "board",
                value: format!("{cols}x{rows}"),
                reason: "needs 2 to 1000 inner corners each way",
            });
        }
        if !(square_m > 0.0 && square_m.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "square size",
                value: square_m.to_string(),
                reason: "must be positive and finite",
            });
        }
        Ok(BoardSpec {
            cols,
            rows,
            square_m,
        })
    }

    /// Number of inner corners.
    pub fn corner_count(&self) -> usize {
        self.cols * self.rows
    }

    /// Whether the corner colours fix the labelling (`cols + rows` odd).
    pub fn is_unambiguous(&self) -> bool {
        (self.cols + self.rows) % 2 == 1
    }

    /// Checks that `what` (a view, described for the error) holds every inner corner.
    pub(crate) fn check_complete(
        &self,
        corners: usize,
        what: impl FnOnce() -> String,
    ) -> Result<()> {
        if corners == self.corner_count() {
            return Ok(());
        }
        Err(Error::InvalidParameter {
            name: "detection",
            value: format!("{} with {corners} corners", what()),
            reason: "needs all the board's corners",
        })
    }

    /// The inner corners in the board frame, row by row.
    pub fn object_points(&self) -> Vec<Point3<f64>> {
        (0..self.rows)
            .flat_map(|r| {
                (0..self.cols).map(move |c| {
                    Point3::new(c as f64 * self.square_m, r as f64 * self.square_m, 0.0)
                })
            })
            .collect()
    }
}

/// Inner-corner counts as written on the command line: `9x6` (columns x rows).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PatternSize {
    /// Inner corners per row.
    pub cols: usize,
    /// Rows of inner corners.
    pub rows: usize,
}

impl FromStr for PatternSize {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        let bad = || Error::InvalidParameter {
            name: "board",
            value: s.to_string(),
            reason: "expected inner-corner counts like 9x6",
        };
        let (c, r) = s.trim().split_once(['x', 'X']).ok_or_else(bad)?;
        let cols: usize = c.trim().parse().map_err(|_| bad())?;
        let rows: usize = r.trim().parse().map_err(|_| bad())?;
        BoardSpec::new(cols, rows, 1.0)?;
        Ok(PatternSize { cols, rows })
    }
}

impl fmt::Display for PatternSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.cols, self.rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn object_points_are_row_major() -> Result<()> {
        let b = BoardSpec::new(9, 6, 0.03)?;
        let p = b.object_points();
        assert_eq!(p.len(), 54);
        assert_eq!(p[1], Point3::new(0.03, 0.0, 0.0));
        assert_eq!(p[9], Point3::new(0.0, 0.03, 0.0));
        assert!(b.is_unambiguous());
        assert!(!BoardSpec::new(8, 6, 0.03)?.is_unambiguous());
        Ok(())
    }

    #[test]
    fn rejects_bad_boards() {
        assert!(BoardSpec::new(1, 6, 0.03).is_err());
        assert!(BoardSpec::new(9, 6, 0.0).is_err());
        assert!(BoardSpec::new(9, 6, f64::NAN).is_err());
        for s in ["9", "9x", "x6", "9x6x2", "-9x6", "9 by 6", "1x6", ""] {
            assert!(s.parse::<PatternSize>().is_err(), "{s}");
        }
    }

    proptest! {
        #[test]
        fn pattern_round_trips(c in 2usize..1000, r in 2usize..1000) {
            let p = PatternSize { cols: c, rows: r };
            prop_assert_eq!(p.to_string().parse::<PatternSize>().ok(), Some(p));
        }

        #[test]
        fn pattern_parser_never_panics(s in ".{0,12}") {
            let _ = s.parse::<PatternSize>();
        }
    }
}
