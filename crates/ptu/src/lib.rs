//! # aibr-ptu
//!
//! The Directed Perception / FLIR PTU-46 pan-tilt unit, which turns the object in an aibr
//! rig:
//!
//! - [`protocol`]: the ASCII protocol as pure functions over bytes: every command encoded
//!   and parsed ([`Command`]), and the unit's output split into replies, typed errors and
//!   asynchronous limit events ([`ReplyParser`]), in verbose or terse feedback, with echo
//!   on or off.
//! - [`Ptu`]: the driver, generic over `Read + Write` ([`SerialPtu::open`] for a serial
//!   device). It queries the unit's resolution and limits (it never assumes 185.1428 arc
//!   seconds a step), moves by angle and waits, and resynchronises after noise, timeouts and
//!   surprises instead of drifting out of step with its requests.
//! - [`Emulator`]: the unit's state machine over virtual time, run in memory
//!   ([`EmulatedPort`], with [`Faults`] injected on the line) or served on a pseudo-terminal
//!   ([`PtyServer`]) so the driver can be tested over a real serial device file.
//!
//! ```
//! use std::time::Duration;
//! use aibr_ptu::{Axis, EmulatedPort, Emulator, EmulatorConfig, Ptu, PtuOptions, Radians};
//!
//! // An emulated unit that moves 20 times faster than a real one.
//! let unit = Emulator::new(EmulatorConfig::default().faster(20.0));
//! let port = EmulatedPort::new(unit, Duration::from_millis(5));
//! let mut ptu = Ptu::connect(port, PtuOptions::default())?;
//! assert_eq!(ptu.info().pan.resolution_arcsec, 185.1428);
//! let reached = ptu.move_to(Axis::Pan, Radians::from_degrees(30.0))?;
//! // The unit moves in whole steps of 185.1428 arc seconds.
//! assert!((reached.degrees() - 30.0).abs() < 0.03);
//! # Ok::<(), aibr_ptu::Error>(())
//! ```
//!
//! # Conventions
//! - Positions, speeds and accelerations are in the unit's steps (steps/s, steps/s²) inside
//!   this crate only; angles cross its boundary as [`Radians`], converted with the resolution
//!   the unit reports.
//! - Positive pan is the unit's positive direction ("to the left" in the manual).
//! - Every wait has a deadline ([`PtuOptions`]): no call blocks longer than
//!   [`PtuOptions::command_bound`] of its longest exchange.

pub mod driver;
pub mod emulator;
mod error;
pub mod protocol;
pub mod serve;

pub use driver::{AxisInfo, DriverStats, Ptu, PtuOptions, Radians, SerialPtu, UnitInfo};
pub use emulator::{AxisConfig, Emulator, EmulatorConfig};
pub use error::{Error, Result};
pub use protocol::{Axis, AxisParam, Command, DeviceError, Event, ReplyParser};
pub use serve::{EmulatedPort, FaultCounts, Faults, PtyServer};
