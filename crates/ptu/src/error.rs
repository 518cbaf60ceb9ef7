//! The one error type of aibr-ptu.

use std::time::Duration;

use crate::protocol::{Axis, DeviceError};

/// Errors of aibr-ptu.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The unit rejected a command with an error reply (`! ...`).
    #[error("the unit rejected {command:?}: {error}")]
    Device {
        /// The command as sent (without its delimiter).
        command: String,
        /// The unit's error.
        error: DeviceError,
    },
    /// No complete reply came in time.
    #[error("no reply to {command:?} within {timeout:?}")]
    Timeout {
        /// The command as sent.
        command: String,
        /// How long the driver waited.
        timeout: Duration,
    },
    /// The reply could not be understood, even after resynchronising and retrying.
    #[error("reply to {command:?} not understood: {reply:?} ({reason})")]
    BadReply {
        /// The command as sent.
        command: String,
        /// What came back (lossily decoded).
        reply: String,
        /// Why it was rejected.
        reason: &'static str,
    },
    /// The line would not become quiet or answer a known query: the driver could not get back
    /// in step with the unit.
    #[error("cannot resynchronise with the unit: {0}")]
    OutOfSync(String),
    /// The port reported end of file: the unit or its adapter was disconnected.
    #[error("the port was disconnected")]
    Disconnected,
    /// A move stopped short of its target.
    #[error(
        "{axis} stopped at position {reached} instead of {target}{}",
        if *.limit_hit { " after hitting a limit" } else { "" }
    )]
    MoveIncomplete {
        /// The axis.
        axis: Axis,
        /// The commanded position, steps.
        target: i32,
        /// The position the unit reports, steps.
        reached: i32,
        /// Whether the unit reported a limit hit (`!P` / `!T`) during the move.
        limit_hit: bool,
    },
    /// A requested angle or value is outside what the unit accepts.
    #[error("invalid {name}: {reason}")]
    InvalidArgument {
        /// The argument.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The port failed.
    #[error("serial port {path}: {source}")]
    Port {
        /// The device path.
        path: String,
        /// The reason.
        #[source]
        source: serialport::Error,
    },
    /// Reading or writing the port failed.
    #[error("port i/o: {0}")]
    Io(#[from] std::io::Error),
}

/// Result alias of aibr-ptu.
pub type Result<T, E = Error> = std::result::Result<T, E>;
