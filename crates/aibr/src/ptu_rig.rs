//! The PTU-46 as the rig's turntable: the one place where its steps become angles.

use std::io::{Read, Write};

use aibr_camera::{Angle, PanRange};
use aibr_ptu::{Axis, Ptu, Radians};

use crate::error::Result;
use crate::rig::Turntable;

/// A PTU-46 (through the [`aibr_ptu`] driver) turning the object on its pan axis. Its range
/// is the unit's pan limits and its step the resolution the unit reports, so a
/// microstepping unit works unchanged.
#[derive(Debug)]
pub struct PtuTurntable<P> {
    ptu: Ptu<P>,
    range: PanRange,
    step: Angle,
}

impl<P: Read + Write> PtuTurntable<P> {
    /// The turntable on a connected unit. The pan range is the unit's soft limits (`PN` /
    /// `PX`), which keep the object clear of the hard stops.
    pub fn new(ptu: Ptu<P>) -> Result<Self> {
        let pan = ptu.info().pan;
        let range = PanRange::new(
            Angle::from_radians(pan.radians(pan.min).0),
            Angle::from_radians(pan.radians(pan.max).0),
        )?;
        let step = Angle::from_radians(pan.radians(1).0);
        Ok(PtuTurntable { ptu, range, step })
    }

    /// The driver, for anything beyond turning (speeds, limits, reset).
    pub fn ptu(&mut self) -> &mut Ptu<P> {
        &mut self.ptu
    }
}

impl<P: Read + Write> Turntable for PtuTurntable<P> {
    fn move_to(&mut self, pan: Angle) -> Result<Angle> {
        let pan = self.range.check(pan)?;
        let reached = self.ptu.move_to(Axis::Pan, Radians(pan.radians()))?;
        Ok(Angle::from_radians(reached.0))
    }

    fn range(&self) -> PanRange {
        self.range
    }

    fn step(&self) -> Angle {
        self.step
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use aibr_ptu::{EmulatedPort, Emulator, EmulatorConfig, PtuOptions};

    use super::*;

    #[test]
    fn turns_by_the_resolution_the_unit_reports() {
        let mut cfg = EmulatorConfig::default().faster(50.0);
        cfg.pan.resolution_arcsec = 46.2857;
        cfg.pan.soft_min = -12000;
        cfg.pan.soft_max = 12000;
        let port = EmulatedPort::new(Emulator::new(cfg), Duration::from_millis(5));
        let unit = port.clone();
        let options = PtuOptions {
            quiet: Duration::from_millis(20),
            settle_gap: Duration::from_millis(2),
            ..PtuOptions::default()
        };
        let mut t = PtuTurntable::new(Ptu::connect(port, options).unwrap()).unwrap();
        assert!((t.step().degrees() - 46.2857 / 3600.0).abs() < 1e-12);
        assert!((t.range().max().degrees() - 12000.0 * 46.2857 / 3600.0).abs() < 1e-9);
        let reached = t.move_to(Angle::from_degrees(-100.0)).unwrap();
        let steps = unit.emulator(|e| e.position(Axis::Pan));
        assert_eq!(steps, (-100.0 * 3600.0 / 46.2857_f64).round() as i32);
        assert!((reached.degrees() - steps as f64 * 46.2857 / 3600.0).abs() < 1e-9);
        // Outside the unit's range: refused before anything moves.
        assert!(t.move_to(Angle::from_degrees(170.0)).is_err());
        assert_eq!(unit.emulator(|e| e.position(Axis::Pan)), steps);
    }
}
