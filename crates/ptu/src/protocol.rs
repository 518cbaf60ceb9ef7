//! The PTU-46 ASCII protocol as pure functions over bytes: commands encoded and parsed, and
//! the unit's output split into events (replies, errors, asynchronous limit hits, echo).
//!
//! Framing (PTU-D46 manual, section 4.2): a command is ASCII, case-insensitive, ended by a
//! space or a carriage return. The unit answers `*` (success), `* <result>` (a query's result)
//! or `! <message>` (an error), each ended by CR LF, and reports a limit hit at any time as
//! `!P` or `!T` without a line end (a reset answers `!T!T!P!P*`). With echo on, the unit
//! first echoes the characters it receives.

use std::fmt;

/// An axis of the unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// The pan axis (the turntable).
    Pan,
    /// The tilt axis.
    Tilt,
}

impl Axis {
    /// Both axes, pan first.
    pub const ALL: [Axis; 2] = [Axis::Pan, Axis::Tilt];

    /// The command letter: `P` or `T`.
    pub fn letter(self) -> char {
        match self {
            Axis::Pan => 'P',
            Axis::Tilt => 'T',
        }
    }

    /// The axis as the unit's messages name it: `Pan` or `Tilt`.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Pan => "Pan",
            Axis::Tilt => "Tilt",
        }
    }

    fn from_letter(c: u8) -> Option<Axis> {
        match c.to_ascii_uppercase() {
            b'P' => Some(Axis::Pan),
            b'T' => Some(Axis::Tilt),
            _ => None,
        }
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Axis::Pan => "pan",
            Axis::Tilt => "tilt",
        })
    }
}

/// A per-axis quantity: the second letter of `PP`, `TS`, `PN`, ...
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AxisParam {
    /// `P`: absolute position (steps). Settable.
    Position,
    /// `O`: relative offset (steps; positive is to the left). Settable; queried, it answers
    /// the current position.
    Offset,
    /// `S`: target speed (steps/s; signed in velocity mode). Settable.
    Speed,
    /// `A`: acceleration (steps/s²). Settable.
    Acceleration,
    /// `B`: base (start-up) speed (steps/s). Settable.
    BaseSpeed,
    /// `U`: upper speed bound (steps/s). Settable.
    UpperSpeed,
    /// `L`: lower speed bound (steps/s). Settable.
    LowerSpeed,
    /// `N`: minimum position (soft limit found at reset). Query only.
    MinPosition,
    /// `X`: maximum position. Query only.
    MaxPosition,
    /// `R`: resolution (arc seconds per step). Query only.
    Resolution,
}

impl AxisParam {
    /// Every parameter.
    pub const ALL: [AxisParam; 10] = [
        AxisParam::Position,
        AxisParam::Offset,
        AxisParam::Speed,
        AxisParam::Acceleration,
        AxisParam::BaseSpeed,
        AxisParam::UpperSpeed,
        AxisParam::LowerSpeed,
        AxisParam::MinPosition,
        AxisParam::MaxPosition,
        AxisParam::Resolution,
    ];

    /// The command letter after the axis letter.
    pub fn letter(self) -> char {
        match self {
            AxisParam::Position => 'P',
            AxisParam::Offset => 'O',
            AxisParam::Speed => 'S',
            AxisParam::Acceleration => 'A',
            AxisParam::BaseSpeed => 'B',
            AxisParam::UpperSpeed => 'U',
            AxisParam::LowerSpeed => 'L',
            AxisParam::MinPosition => 'N',
            AxisParam::MaxPosition => 'X',
            AxisParam::Resolution => 'R',
        }
    }

    /// Whether the unit accepts a value for it.
    pub fn settable(self) -> bool {
        !matches!(
            self,
            AxisParam::MinPosition | AxisParam::MaxPosition | AxisParam::Resolution
        )
    }

    fn from_letter(c: u8) -> Option<AxisParam> {
        AxisParam::ALL
            .into_iter()
            .find(|p| p.letter() as u8 == c.to_ascii_uppercase())
    }
}

/// Feedback mode: verbose sentences or terse bare values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feedback {
    /// `FV`: "Current Pan position is 1000".
    Verbose,
    /// `FT`: "1000".
    Terse,
}

/// Control mode of the axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ControlMode {
    /// `CI`: independent position control (the default): position commands move, the speed
    /// is a magnitude.
    Independent,
    /// `CV`: pure velocity control: a signed speed turns the axis until it is changed or a
    /// limit is hit.
    Velocity,
}

/// Execution mode of position commands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Execution {
    /// `I`: position commands start at once (the default).
    Immediate,
    /// `S`: position commands wait for the next `A`.
    Slaved,
}

/// A command of the unit. [`Command::encode`] gives its bytes, [`Command::parse`] reads them
/// back (as the unit does: case-insensitive).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// Query a per-axis quantity (`PP`, `TS`, `PR`, ...).
    Query(Axis, AxisParam),
    /// Set a per-axis quantity (`PP1500`, `PS-300`, ...). Query-only parameters are rejected
    /// by the unit.
    Set(Axis, AxisParam, i32),
    /// `A`: await the completion of the last position command.
    Await,
    /// `I` or `S`: set the execution mode.
    SetExecution(Execution),
    /// `H`, `HP`, `HT`: halt both axes or one.
    Halt(Option<Axis>),
    /// `L`: query whether soft limits are enforced.
    QueryLimits,
    /// `LE` / `LD`: enable or disable the soft limits.
    SetLimits(bool),
    /// `R`, `RP`, `RT`: reset (home) both axes or one.
    Reset(Option<Axis>),
    /// `F`: query the feedback mode.
    QueryFeedback,
    /// `FV` / `FT`: set the feedback mode.
    SetFeedback(Feedback),
    /// `E`: query echo.
    QueryEcho,
    /// `EE` / `ED`: enable or disable echo.
    SetEcho(bool),
    /// `V`: firmware version.
    Version,
    /// `O`: input voltage and temperature.
    Voltage,
    /// `DS`: save the current settings as the power-up defaults.
    SaveDefaults,
    /// `DR`: restore the saved defaults.
    RestoreDefaults,
    /// `DF`: restore the factory defaults.
    FactoryDefaults,
    /// `C`: query the control mode.
    QueryControl,
    /// `CI` / `CV`: set the control mode.
    SetControl(ControlMode),
}

impl Command {
    /// The command's text, upper case, without its delimiter.
    pub fn text(&self) -> String {
        match *self {
            Command::Query(a, p) => format!("{}{}", a.letter(), p.letter()),
            Command::Set(a, p, v) => format!("{}{}{}", a.letter(), p.letter(), v),
            Command::Await => "A".into(),
            Command::SetExecution(Execution::Immediate) => "I".into(),
            Command::SetExecution(Execution::Slaved) => "S".into(),
            Command::Halt(None) => "H".into(),
            Command::Halt(Some(a)) => format!("H{}", a.letter()),
            Command::QueryLimits => "L".into(),
            Command::SetLimits(true) => "LE".into(),
            Command::SetLimits(false) => "LD".into(),
            Command::Reset(None) => "R".into(),
            Command::Reset(Some(a)) => format!("R{}", a.letter()),
            Command::QueryFeedback => "F".into(),
            Command::SetFeedback(Feedback::Verbose) => "FV".into(),
            Command::SetFeedback(Feedback::Terse) => "FT".into(),
            Command::QueryEcho => "E".into(),
            Command::SetEcho(true) => "EE".into(),
            Command::SetEcho(false) => "ED".into(),
            Command::Version => "V".into(),
            Command::Voltage => "O".into(),
            Command::SaveDefaults => "DS".into(),
            Command::RestoreDefaults => "DR".into(),
            Command::FactoryDefaults => "DF".into(),
            Command::QueryControl => "C".into(),
            Command::SetControl(ControlMode::Independent) => "CI".into(),
            Command::SetControl(ControlMode::Velocity) => "CV".into(),
        }
    }

    /// The bytes to send: the text and a space delimiter.
    pub fn encode(&self) -> Vec<u8> {
        let mut b = self.text().into_bytes();
        b.push(b' ');
        b
    }

    /// Whether the unit answers it with text (`* <result>`) rather than a bare `*`.
    pub fn is_query(&self) -> bool {
        matches!(
            self,
            Command::Query(..)
                | Command::QueryLimits
                | Command::QueryFeedback
                | Command::QueryEcho
                | Command::QueryControl
                | Command::Version
                | Command::Voltage
        )
    }

    /// Whether sending it twice has the same effect as sending it once, so the driver may
    /// repeat it after a lost reply (relative offsets may not be repeated).
    pub fn idempotent(&self) -> bool {
        !matches!(self, Command::Set(_, AxisParam::Offset, _))
    }

    /// Parses one command's text (without its delimiter), case-insensitively, as the unit
    /// does. `None` when the unit would answer "Illegal Command"; a settable parameter with a
    /// malformed number also gives `None`.
    pub fn parse(text: &[u8]) -> Option<Command> {
        let upper: Vec<u8> = text.iter().map(u8::to_ascii_uppercase).collect();
        let fixed = match upper.as_slice() {
            b"A" => Some(Command::Await),
            b"I" => Some(Command::SetExecution(Execution::Immediate)),
            b"S" => Some(Command::SetExecution(Execution::Slaved)),
            b"H" => Some(Command::Halt(None)),
            b"HP" => Some(Command::Halt(Some(Axis::Pan))),
            b"HT" => Some(Command::Halt(Some(Axis::Tilt))),
            b"L" => Some(Command::QueryLimits),
            b"LE" => Some(Command::SetLimits(true)),
            b"LD" => Some(Command::SetLimits(false)),
            b"R" => Some(Command::Reset(None)),
            b"RP" => Some(Command::Reset(Some(Axis::Pan))),
            b"RT" => Some(Command::Reset(Some(Axis::Tilt))),
            b"F" => Some(Command::QueryFeedback),
            b"FV" => Some(Command::SetFeedback(Feedback::Verbose)),
            b"FT" => Some(Command::SetFeedback(Feedback::Terse)),
            b"E" => Some(Command::QueryEcho),
            b"EE" => Some(Command::SetEcho(true)),
            b"ED" => Some(Command::SetEcho(false)),
            b"V" => Some(Command::Version),
            b"O" => Some(Command::Voltage),
            b"DS" => Some(Command::SaveDefaults),
            b"DR" => Some(Command::RestoreDefaults),
            b"DF" => Some(Command::FactoryDefaults),
            b"C" => Some(Command::QueryControl),
            b"CI" => Some(Command::SetControl(ControlMode::Independent)),
            b"CV" => Some(Command::SetControl(ControlMode::Velocity)),
            _ => None,
        };
        if fixed.is_some() {
            return fixed;
        }
        let (&a, rest) = upper.split_first()?;
        let axis = Axis::from_letter(a)?;
        let (&p, number) = rest.split_first()?;
        let param = AxisParam::from_letter(p)?;
        if number.is_empty() {
            return Some(Command::Query(axis, param));
        }
        let value = parse_i32(number)?;
        Some(Command::Set(axis, param, value))
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text())
    }
}

/// A strict signed decimal: optional sign, 1 to 10 digits, nothing else.
fn parse_i32(b: &[u8]) -> Option<i32> {
    let digits = match b.first() {
        Some(b'-' | b'+') => &b[1..],
        _ => b,
    };
    if digits.is_empty() || digits.len() > 10 || !digits.iter().all(u8::is_ascii_digit) {
        return None;
    }
    std::str::from_utf8(b).ok()?.parse().ok()
}

/// Which bound a limit error names.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Bound {
    /// The lower bound.
    Min,
    /// The upper bound.
    Max,
}

/// An error the unit reports (`! <message>`), typed where the message is known.
#[derive(Debug, Clone, PartialEq, Eq, Hash, thiserror::Error)]
#[non_exhaustive]
pub enum DeviceError {
    /// "Maximum allowable Pan position is 3090" (and Minimum, and Tilt).
    #[error("{} allowable {} position is {limit}", match bound { Bound::Min => "Minimum", Bound::Max => "Maximum" }, axis.name())]
    PositionLimit {
        /// The axis.
        axis: Axis,
        /// Which limit.
        bound: Bound,
        /// The limit, steps.
        limit: i32,
    },
    /// "Pan speed cannot exceed 2902 positions/sec".
    #[error("{} speed cannot exceed {max} positions/sec", axis.name())]
    SpeedTooHigh {
        /// The axis.
        axis: Axis,
        /// The upper bound, steps/s.
        max: i32,
    },
    /// "Motor speed cannot be less than 31 pos/sec".
    #[error("Motor speed cannot be less than {min} pos/sec")]
    SpeedTooLow {
        /// The lower bound, steps/s.
        min: i32,
    },
    /// "Illegal Command": the unit does not know the command.
    #[error("Illegal Command")]
    IllegalCommand,
    /// "Illegal Argument": the value is malformed or the parameter is query-only.
    #[error("Illegal Argument")]
    IllegalArgument,
    /// Any other message, verbatim.
    #[error("{0}")]
    Other(String),
}

impl DeviceError {
    /// Types an error message (the text after `! `). Unknown messages become
    /// [`DeviceError::Other`].
    pub fn from_message(message: &str) -> DeviceError {
        let m = message.trim();
        let words: Vec<&str> = m.split_whitespace().collect();
        let number = || words.iter().find_map(|w| w.parse::<i32>().ok());
        let axis = |w: Option<&&str>| match w.map(|s| s.to_ascii_lowercase()) {
            Some(s) if s == "pan" => Some(Axis::Pan),
            Some(s) if s == "tilt" => Some(Axis::Tilt),
            _ => None,
        };
        let lower = m.to_ascii_lowercase();
        if lower == "illegal command" {
            return DeviceError::IllegalCommand;
        }
        if lower == "illegal argument" {
            return DeviceError::IllegalArgument;
        }
        if lower.contains("allowable") && lower.contains("position is") {
            let bound = if lower.starts_with("maximum") {
                Some(Bound::Max)
            } else if lower.starts_with("minimum") {
                Some(Bound::Min)
            } else {
                None
            };
            if let (Some(bound), Some(axis), Some(limit)) = (bound, axis(words.get(2)), number()) {
                return DeviceError::PositionLimit { axis, bound, limit };
            }
        }
        if lower.contains("speed cannot exceed") {
            if let (Some(axis), Some(max)) = (axis(words.first()), number()) {
                return DeviceError::SpeedTooHigh { axis, max };
            }
        }
        if lower.contains("cannot be less than") {
            if let Some(min) = number() {
                return DeviceError::SpeedTooLow { min };
            }
        }
        DeviceError::Other(m.to_owned())
    }
}

/// One thing the unit said.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Event {
    /// `*` or `* <text>`: success, with the query's result or the empty string.
    Ok(String),
    /// `! <message>`: the command failed.
    Error(DeviceError),
    /// `!P` or `!T`: the axis hit a limit (asynchronous).
    Limit(Axis),
    /// Bytes that are neither: the echo of a command, or line noise.
    Other(Vec<u8>),
}

/// The longest reply line the parser waits for; longer runs are reported as noise.
pub const MAX_LINE: usize = 256;

/// Splits the unit's output into [`Event`]s. Sans-IO: push bytes as they arrive, then take
/// events until it has none. Never panics, whatever the bytes.
#[derive(Debug, Clone, Default)]
pub struct ReplyParser {
    buf: Vec<u8>,
}

fn is_eol(b: u8) -> bool {
    b == b'\r' || b == b'\n'
}

impl ReplyParser {
    /// An empty parser.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds bytes read from the unit.
    pub fn push(&mut self, bytes: &[u8]) {
        self.buf.extend_from_slice(bytes);
    }

    /// Forgets everything not yet parsed (after a resynchronisation).
    pub fn clear(&mut self) {
        self.buf.clear();
    }

    /// Bytes received but not yet parsed into an event.
    pub fn pending(&self) -> &[u8] {
        &self.buf
    }

    /// The next complete event, if the bytes so far hold one.
    pub fn next_event(&mut self) -> Option<Event> {
        let start = self
            .buf
            .iter()
            .position(|&b| !(is_eol(b) || b == b' '))
            .unwrap_or(self.buf.len());
        self.buf.drain(..start);
        let first = *self.buf.first()?;
        match first {
            b'*' => {
                let eol = self.line_end()?;
                let text = String::from_utf8_lossy(&self.buf[1..eol]).trim().to_owned();
                self.buf.drain(..eol);
                Some(Event::Ok(text))
            }
            b'!' => {
                let second = *self.buf.get(1)?;
                if let Some(axis) =
                    Axis::from_letter(second).filter(|_| second.is_ascii_uppercase())
                {
                    self.buf.drain(..2);
                    return Some(Event::Limit(axis));
                }
                let eol = self.line_end()?;
                let text = String::from_utf8_lossy(&self.buf[1..eol]).into_owned();
                self.buf.drain(..eol);
                if second == b' ' {
                    Some(Event::Error(DeviceError::from_message(&text)))
                } else {
                    let mut other = vec![b'!'];
                    other.extend_from_slice(text.as_bytes());
                    Some(Event::Other(other))
                }
            }
            _ => {
                // Echo or noise: up to the next reply marker or line end.
                let end = self
                    .buf
                    .iter()
                    .take(MAX_LINE)
                    .position(|&b| b == b'*' || b == b'!' || is_eol(b));
                let end = match end {
                    Some(e) => e,
                    None if self.buf.len() >= MAX_LINE => self.buf.len(),
                    None => return None,
                };
                let other: Vec<u8> = self.buf.drain(..end).collect();
                Some(Event::Other(other))
            }
        }
    }

    /// The index of the line end of the reply at the front, if it has arrived; a reply that
    /// runs past [`MAX_LINE`] is cut there.
    fn line_end(&self) -> Option<usize> {
        // Only the first MAX_LINE bytes count, so that how the bytes were split as they
        // arrived never changes the events.
        match self.buf.iter().take(MAX_LINE).position(|&b| is_eol(b)) {
            Some(e) => Some(e),
            None if self.buf.len() >= MAX_LINE => Some(MAX_LINE),
            None => None,
        }
    }
}

/// Parses every event in `bytes` (a convenience over [`ReplyParser`]); trailing bytes that do
/// not yet form an event are returned too.
pub fn parse_events(bytes: &[u8]) -> (Vec<Event>, Vec<u8>) {
    let mut p = ReplyParser::new();
    p.push(bytes);
    let mut events = Vec::new();
    while let Some(e) = p.next_event() {
        events.push(e);
    }
    (events, p.buf)
}

/// The integer a reply carries: in terse mode the whole text (strictly); in verbose mode
/// the first whole-number word ("Current Pan position is -500").
pub fn reply_integer(text: &str, feedback: Feedback) -> Option<i32> {
    match feedback {
        Feedback::Terse => parse_i32(text.trim().as_bytes()),
        Feedback::Verbose => text
            .split_whitespace()
            .find_map(|w| parse_i32(w.as_bytes())),
    }
}

/// The number a reply carries (the resolution, "185.1428 seconds arc per Pan position"): in
/// terse mode the whole text, in verbose mode the first numeric word.
pub fn reply_number(text: &str, feedback: Feedback) -> Option<f64> {
    let parse = |w: &str| {
        let ok = !w.is_empty()
            && w.bytes()
                .all(|b| b.is_ascii_digit() || b == b'.' || b == b'-' || b == b'+')
            && w.bytes().any(|b| b.is_ascii_digit());
        if ok {
            w.parse::<f64>().ok().filter(|v| v.is_finite())
        } else {
            None
        }
    };
    match feedback {
        Feedback::Terse => parse(text.trim()),
        Feedback::Verbose => text.split_whitespace().find_map(parse),
    }
}

/// Whether a reply to `L` says the soft limits are enforced ("Limit bounds are ENABLED",
/// or a terse `E`).
pub fn reply_limits_enabled(text: &str) -> Option<bool> {
    let t = text.trim().to_ascii_uppercase();
    if t.contains("ENABLED") || t == "E" {
        Some(true)
    } else if t.contains("DISABLED") || t == "D" {
        Some(false)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodes_like_the_manual() {
        assert_eq!(
            Command::Set(Axis::Pan, AxisParam::Position, -500).encode(),
            b"PP-500 "
        );
        assert_eq!(
            Command::Query(Axis::Tilt, AxisParam::Resolution).text(),
            "TR"
        );
        assert_eq!(Command::Reset(Some(Axis::Pan)).text(), "RP");
        assert_eq!(Command::SetLimits(false).text(), "LD");
        assert_eq!(
            Command::parse(b"po1500"),
            Some(Command::Set(Axis::Pan, AxisParam::Offset, 1500))
        );
        assert_eq!(
            Command::parse(b"pp"),
            Some(Command::Query(Axis::Pan, AxisParam::Position))
        );
        assert_eq!(Command::parse(b"PPx"), None);
        assert_eq!(Command::parse(b"Q"), None);
        assert_eq!(Command::parse(b""), None);
    }

    #[test]
    fn parses_the_manual_exchanges() {
        let (events, rest) = parse_events(
            b"PP-500 *\r\nPO * Current Pan position is -500\r\nPP3200 ! Maximum allowable Pan position is 3090\r\n",
        );
        assert!(rest.is_empty());
        assert_eq!(
            events,
            vec![
                Event::Other(b"PP-500 ".to_vec()),
                Event::Ok(String::new()),
                Event::Other(b"PO ".to_vec()),
                Event::Ok("Current Pan position is -500".into()),
                Event::Other(b"PP3200 ".to_vec()),
                Event::Error(DeviceError::PositionLimit {
                    axis: Axis::Pan,
                    bound: Bound::Max,
                    limit: 3090
                }),
            ]
        );
        let (events, _) = parse_events(b"!T!T!P!P*\r\n");
        assert_eq!(
            events,
            vec![
                Event::Limit(Axis::Tilt),
                Event::Limit(Axis::Tilt),
                Event::Limit(Axis::Pan),
                Event::Limit(Axis::Pan),
                Event::Ok(String::new())
            ]
        );
        assert_eq!(
            DeviceError::from_message("Pan speed cannot exceed 2902 positions/sec"),
            DeviceError::SpeedTooHigh {
                axis: Axis::Pan,
                max: 2902
            }
        );
        assert_eq!(
            DeviceError::from_message("Motor speed cannot be less than 31 pos/sec"),
            DeviceError::SpeedTooLow { min: 31 }
        );
        assert_eq!(
            DeviceError::from_message("Illegal Command"),
            DeviceError::IllegalCommand
        );
    }

    #[test]
    fn waits_for_line_ends() {
        let mut p = ReplyParser::new();
        p.push(b"* 10");
        assert_eq!(p.next_event(), None);
        p.push(b"00\r");
        assert_eq!(p.next_event(), Some(Event::Ok("1000".into())));
        p.push(b"!");
        assert_eq!(p.next_event(), None);
        p.push(b"P");
        assert_eq!(p.next_event(), Some(Event::Limit(Axis::Pan)));
    }

    #[test]
    fn reads_values() {
        assert_eq!(
            reply_integer("Current Pan position is -500", Feedback::Verbose),
            Some(-500)
        );
        assert_eq!(reply_integer("-500", Feedback::Terse), Some(-500));
        assert_eq!(reply_integer("-5a0", Feedback::Terse), None);
        assert_eq!(
            reply_number("185.1428 seconds arc per Pan position", Feedback::Verbose),
            Some(185.1428)
        );
        assert_eq!(reply_number("46.2857", Feedback::Terse), Some(46.2857));
        assert_eq!(
            reply_limits_enabled("Limit bounds are ENABLED (soft limits enabled)"),
            Some(true)
        );
        assert_eq!(
            reply_limits_enabled("Limit bounds are DISABLED (hard limits only: use care)"),
            Some(false)
        );
    }
}
