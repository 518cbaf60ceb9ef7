//! Named angles and the pan range of a turntable.

use std::f64::consts::{PI, TAU};
use std::fmt;

use crate::error::{Error, Result};

/// An angle, stored in radians.
///
/// Public APIs take `Angle` rather than a bare `f64` so that the unit is never in doubt.
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Angle(f64);

impl Angle {
    /// Zero.
    pub const ZERO: Angle = Angle(0.0);

    /// An angle of `radians`.
    pub const fn from_radians(radians: f64) -> Self {
        Angle(radians)
    }

    /// An angle of `degrees`.
    pub fn from_degrees(degrees: f64) -> Self {
        Angle(degrees.to_radians())
    }

    /// The angle in radians.
    pub const fn radians(self) -> f64 {
        self.0
    }

    /// The angle in degrees.
    pub fn degrees(self) -> f64 {
        self.0.to_degrees()
    }

    /// The same direction, wrapped into (-pi, pi].
    pub fn wrapped(self) -> Self {
        let mut a = self.0.rem_euclid(TAU);
        if a > PI {
            a -= TAU;
        }
        Angle(a)
    }

    /// The signed difference `self - other`, wrapped into (-pi, pi].
    pub fn wrapped_difference(self, other: Angle) -> Angle {
        Angle(self.0 - other.0).wrapped()
    }
}

impl std::ops::Add for Angle {
    type Output = Angle;
    fn add(self, rhs: Angle) -> Angle {
        Angle(self.0 + rhs.0)
    }
}

impl std::ops::Sub for Angle {
    type Output = Angle;
    fn sub(self, rhs: Angle) -> Angle {
        Angle(self.0 - rhs.0)
    }
}

impl std::ops::Neg for Angle {
    type Output = Angle;
    fn neg(self) -> Angle {
        Angle(-self.0)
    }
}

impl std::ops::Mul<f64> for Angle {
    type Output = Angle;
    fn mul(self, rhs: f64) -> Angle {
        Angle(self.0 * rhs)
    }
}

impl fmt::Display for Angle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:.4} deg", self.degrees())
    }
}

/// The pan range a turntable can reach, as absolute angles `min <= max`.
///
/// A PTU-46 covers about 310-318 degrees, not a full turn, so a range is stored as the
/// absolute limits the unit reports (for example -158.9 to +158.9 degrees). A full turn
/// (`max - min >= 2 pi`) is allowed and then every direction is reachable.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PanRange {
    min: Angle,
    max: Angle,
}

impl PanRange {
    /// A range from `min` to `max`; rejects non-finite limits, `min > max` and spans over
    /// one turn.
    pub fn new(min: Angle, max: Angle) -> Result<Self> {
        for (name, v) in [("pan range minimum", min.0), ("pan range maximum", max.0)] {
            if !v.is_finite() {
                return Err(Error::InvalidParameter {
                    name,
                    value: v,
                    reason: "must be finite",
                });
            }
        }
        if min.0 > max.0 {
            return Err(Error::InvalidParameter {
                name: "pan range maximum",
                value: max.0,
                reason: "must not be below the minimum",
            });
        }
        if max.0 - min.0 > TAU + 1e-9 {
            return Err(Error::InvalidParameter {
                name: "pan range span",
                value: max.0 - min.0,
                reason: "must not exceed one turn (2 pi)",
            });
        }
        Ok(PanRange { min, max })
    }

    /// How many turns away from the range [`PanRange::normalize`] still brings an angle
    /// back: a thousand, where a double resolves an angle to about 1e-12 radians.
    pub const MAX_TURNS: f64 = 1000.0;

    /// A full turn, `[-pi, pi]`.
    pub fn full_turn() -> Self {
        PanRange {
            min: Angle(-PI),
            max: Angle(PI),
        }
    }

    /// Lower limit.
    pub fn min(&self) -> Angle {
        self.min
    }

    /// Upper limit.
    pub fn max(&self) -> Angle {
        self.max
    }

    /// `max - min`.
    pub fn span(&self) -> Angle {
        self.max - self.min
    }

    /// True when the range covers a whole turn.
    pub fn is_full_turn(&self) -> bool {
        self.span().0 >= TAU - 1e-9
    }

    /// The representative of `angle` (modulo one turn) inside the range, if any.
    ///
    /// `normalize(370 deg)` in a `[0, 360]` range is 10 deg; in a `[-159, 159]` range,
    /// 200 deg wraps to -160 deg, which is outside, so the answer is `None`. Also `None` for
    /// an angle that is not finite or lies more than [`PanRange::MAX_TURNS`] turns from the
    /// range, where a double no longer places it within a turn (`1e300` degrees would
    /// otherwise come out as some arbitrary direction).
    pub fn normalize(&self, angle: Angle) -> Option<Angle> {
        if !angle.0.is_finite() || (angle.0 - self.min.0).abs() > Self::MAX_TURNS * TAU {
            return None;
        }
        let k = ((angle.0 - self.min.0) / TAU).floor();
        let a = angle.0 - k * TAU;
        // `a` is in [min, min + 2 pi). Accept a hair of rounding at the upper limit.
        if a <= self.max.0 + 1e-12 {
            Some(Angle(a.min(self.max.0)))
        } else if (a - TAU - self.min.0).abs() <= 1e-12 {
            Some(self.min)
        } else {
            None
        }
    }

    /// Like [`normalize`](Self::normalize) but with an error that names the angle and range.
    pub fn check(&self, angle: Angle) -> Result<Angle> {
        self.normalize(angle).ok_or(Error::AngleOutOfRange {
            angle_deg: angle.degrees(),
            min_deg: self.min.degrees(),
            max_deg: self.max.degrees(),
        })
    }
}

impl Default for PanRange {
    fn default() -> Self {
        PanRange::full_turn()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping() {
        assert!((Angle::from_degrees(190.0).wrapped().degrees() + 170.0).abs() < 1e-9);
        assert!((Angle::from_degrees(-180.0).wrapped().degrees() - 180.0).abs() < 1e-9);
        let d = Angle::from_degrees(10.0).wrapped_difference(Angle::from_degrees(350.0));
        assert!((d.degrees() - 20.0).abs() < 1e-9);
    }

    #[test]
    fn angles_too_many_turns_away_are_not_placed() -> Result<()> {
        let ptu = PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?;
        let turns = |n: f64| Angle::from_degrees(40.0 + 360.0 * n);
        let back = ptu.normalize(turns(PanRange::MAX_TURNS - 1.0));
        assert!(
            back.is_some_and(|a| (a.degrees() - 40.0).abs() < 1e-6),
            "{back:?}"
        );
        assert!(ptu.normalize(turns(-(PanRange::MAX_TURNS - 1.0))).is_some());
        for far in [PanRange::MAX_TURNS + 1.0, -PanRange::MAX_TURNS - 1.0, 1e297] {
            assert_eq!(ptu.normalize(turns(far)), None, "{far} turns");
        }
        assert!(ptu.check(Angle::from_degrees(1e300)).is_err());
        Ok(())
    }

    #[test]
    fn range_normalize() -> Result<()> {
        let full = PanRange::new(Angle::ZERO, Angle::from_degrees(360.0))?;
        let a = full
            .normalize(Angle::from_degrees(370.0))
            .map(Angle::degrees);
        assert!(a.is_some_and(|a| (a - 10.0).abs() < 1e-9));
        let ptu = PanRange::new(Angle::from_degrees(-159.0), Angle::from_degrees(159.0))?;
        assert_eq!(ptu.normalize(Angle::from_degrees(200.0)), None);
        // -200 deg is 160 deg modulo a turn: past the +159 deg limit.
        assert_eq!(ptu.normalize(Angle::from_degrees(-200.0)), None);
        let c = ptu
            .normalize(Angle::from_degrees(480.0))
            .map(Angle::degrees);
        assert!(c.is_some_and(|c| (c - 120.0).abs() < 1e-9));
        assert!(matches!(
            ptu.check(Angle::from_degrees(170.0)),
            Err(Error::AngleOutOfRange { .. })
        ));
        Ok(())
    }

    #[test]
    fn range_rejects_bad_limits() {
        assert!(PanRange::new(Angle::from_degrees(10.0), Angle::ZERO).is_err());
        assert!(PanRange::new(Angle::ZERO, Angle::from_degrees(400.0)).is_err());
        assert!(PanRange::new(Angle::from_radians(f64::NAN), Angle::ZERO).is_err());
    }
}
