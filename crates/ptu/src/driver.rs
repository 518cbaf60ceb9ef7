//! The driver: a PTU-46 over any `Read + Write` port, which stays in step with the unit.
//!
//! Every exchange has a deadline. A reply that does not come, does not parse, or comes with
//! noise around it makes the driver resynchronise: drain the line until it is quiet, turn echo
//! off and terse feedback on again (a power-cycled unit has lost both), and check that a
//! known query gets its known answer. Only then is an idempotent command sent again; a
//! relative move is never repeated (the driver moves by absolute positions). A position is
//! only reported after three consecutive queries agree, and a move only succeeds when the
//! verified position is its target.

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use crate::emulator::profile;
use crate::error::{Error, Result};
use crate::protocol::{
    Axis, AxisParam, Bound, Command, ControlMode, DeviceError, Event, Execution, Feedback,
    ReplyParser, reply_integer, reply_limits_enabled, reply_number,
};

/// An angle in radians (the driver's unit for angles; steps stay inside this crate).
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Radians(pub f64);

impl Radians {
    /// From degrees.
    pub fn from_degrees(d: f64) -> Self {
        Radians(d.to_radians())
    }

    /// In degrees.
    pub fn degrees(self) -> f64 {
        self.0.to_degrees()
    }
}

/// Timeouts and retries of the driver.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PtuOptions {
    /// How long a reply may take (default 1 s).
    pub reply_timeout: Duration,
    /// Time allowed beyond the computed duration of a move before it counts as lost
    /// (default 2 s).
    pub move_margin: Duration,
    /// How long a reset (homing) may take (default 60 s; a PTU-46 takes about 10 s).
    pub reset_timeout: Duration,
    /// How long the line must stay silent when resynchronising (default 100 ms). The driver
    /// assumes that a line never holds a byte back for longer than this once it has gone
    /// silent (a serial line or a USB adapter holds bytes for milliseconds); a unit that is
    /// busy and answers late is handled by the resynchronisation's check.
    pub quiet: Duration,
    /// Attempts after the first, for a command whose reply is lost or garbled (default 3).
    pub retries: u32,
    /// How far apart two agreeing position answers must be, at least, for the position to
    /// count as settled (default 50 ms). The driver lengthens it to the time the axis takes
    /// for 1.5 steps at its lowest speed (48 ms at the PTU-46's 31 steps/s), so that a slowly
    /// moving axis is never reported as settled.
    pub settle_gap: Duration,
}

impl Default for PtuOptions {
    fn default() -> Self {
        PtuOptions {
            reply_timeout: Duration::from_secs(1),
            move_margin: Duration::from_secs(2),
            reset_timeout: Duration::from_secs(60),
            quiet: Duration::from_millis(100),
            retries: 3,
            settle_gap: Duration::from_millis(50),
        }
    }
}

impl PtuOptions {
    /// The longest one resynchronisation can take.
    pub fn resync_bound(&self) -> Duration {
        // Up to three rounds of: the line going quiet (capped), two short exchanges, and the
        // check, which waits 1, 2 and 4 reply timeouts (the unit may still be busy with a
        // move whose await timed out).
        (self.quiet * 2 + self.drain_cap()) * 3 + self.reply_timeout * 13
    }

    fn drain_cap(&self) -> Duration {
        self.quiet * 4 + self.reply_timeout
    }

    /// The longest [`Ptu::move_to_steps`] (and so [`Ptu::move_to`] and [`Ptu::move_by`])
    /// can block, for a move whose travel at the unit's speed takes `travel`.
    pub fn move_bound(&self, travel: Duration) -> Duration {
        let b = self.command_bound(self.reply_timeout);
        let a = self.command_bound(travel + self.move_margin);
        b * 2 + (b * 2 + a * 2) * (self.retries + 1)
    }

    /// The longest a command with reply timeout `timeout` can take, retries and
    /// resynchronisations included: no call of the driver blocks longer than this bound of
    /// its longest exchange.
    pub fn command_bound(&self, timeout: Duration) -> Duration {
        (timeout + self.resync_bound()) * (self.retries + 1)
    }
}

/// One axis as the unit reported it at connection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisInfo {
    /// Arc seconds per step, queried (`PR` / `TR`).
    pub resolution_arcsec: f64,
    /// Lowest position, steps (`PN`).
    pub min: i32,
    /// Highest position, steps (`PX`).
    pub max: i32,
    /// Lower speed bound, steps/s (`PL`).
    pub lower_speed: i32,
    /// Upper speed bound, steps/s (`PU`).
    pub upper_speed: i32,
    /// Target speed, steps/s (`PS`).
    pub speed: i32,
    /// Base speed, steps/s (`PB`).
    pub base_speed: i32,
    /// Acceleration, steps/s² (`PA`).
    pub acceleration: i32,
}

impl AxisInfo {
    /// Steps to radians.
    pub fn radians(&self, steps: i32) -> Radians {
        Radians((steps as f64 * self.resolution_arcsec / 3600.0).to_radians())
    }

    /// Radians to the nearest step.
    pub fn steps(&self, angle: Radians) -> Result<i32> {
        let s = (angle.0.to_degrees() * 3600.0 / self.resolution_arcsec).round();
        if !s.is_finite() || s.abs() > i32::MAX as f64 {
            return Err(Error::InvalidArgument {
                name: "angle",
                reason: format!("{} rad is not a reachable position", angle.0),
            });
        }
        Ok(s as i32)
    }
}

/// What the unit said of itself at connection.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitInfo {
    /// The answer to `V`.
    pub firmware: String,
    /// The pan axis.
    pub pan: AxisInfo,
    /// The tilt axis.
    pub tilt: AxisInfo,
    /// Whether the soft limits are enforced.
    pub limits_enabled: bool,
    /// Whether the unit echoed commands before the driver turned echo off.
    pub echo_was_on: bool,
}

impl UnitInfo {
    /// One axis.
    pub fn axis(&self, axis: Axis) -> &AxisInfo {
        match axis {
            Axis::Pan => &self.pan,
            Axis::Tilt => &self.tilt,
        }
    }

    fn axis_mut(&mut self, axis: Axis) -> &mut AxisInfo {
        match axis {
            Axis::Pan => &mut self.pan,
            Axis::Tilt => &mut self.tilt,
        }
    }
}

/// How often the driver had to recover.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DriverStats {
    /// Exchanges sent (first attempts and retries).
    pub exchanges: u64,
    /// Retries after a lost or garbled reply.
    pub retries: u64,
    /// Resynchronisations.
    pub resyncs: u64,
}

/// How one exchange ended.
enum Outcome {
    Ok(String),
    Device(DeviceError),
    /// A reply came, but with noise before it: it cannot be trusted.
    Tainted(String),
}

/// A PTU-46 on a port. See the [module docs](self).
#[derive(Debug)]
pub struct Ptu<P> {
    port: P,
    parser: ReplyParser,
    options: PtuOptions,
    info: UnitInfo,
    feedback: Feedback,
    limit_hits: Vec<Axis>,
    stats: DriverStats,
    /// A command failed: replies may still be on their way, so resynchronise first.
    dirty: bool,
}

/// A serial port as the driver opens it.
pub type SerialPtu = Ptu<Box<dyn serialport::SerialPort>>;

impl SerialPtu {
    /// Opens the serial device `path` at `baud` (8N1, no flow control; the PTU-46 default is
    /// 9600) and connects.
    pub fn open(path: &str, baud: u32, options: PtuOptions) -> Result<Self> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(10))
            .open()
            .map_err(|source| Error::Port {
                path: path.to_owned(),
                source,
            })?;
        Ptu::connect(port, options)
    }
}

fn is_wait(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

/// Whether the unit's `error` fits `cmd` as the driver sent it. The driver sends only
/// well-formed commands, so "Illegal Command", or a limit error for a value inside the limit,
/// means the command was garbled on the line (the last attempt's error is still returned
/// when every attempt fails, as old firmware rejects commands it lacks).
fn plausible(cmd: &Command, error: &DeviceError) -> bool {
    match (*cmd, error) {
        (
            Command::Set(a, AxisParam::Position, v),
            DeviceError::PositionLimit { axis, bound, limit },
        ) => {
            a == *axis
                && match bound {
                    Bound::Max => v > *limit,
                    Bound::Min => v < *limit,
                }
        }
        (Command::Set(a, AxisParam::Offset, _), DeviceError::PositionLimit { axis, .. }) => {
            a == *axis
        }
        (
            Command::Set(a, AxisParam::Speed | AxisParam::UpperSpeed | AxisParam::BaseSpeed, v),
            DeviceError::SpeedTooHigh { axis, max },
        ) => a == *axis && v.unsigned_abs() > max.unsigned_abs(),
        (
            Command::Set(_, AxisParam::Speed | AxisParam::LowerSpeed, v),
            DeviceError::SpeedTooLow { min },
        ) => v.unsigned_abs() < min.unsigned_abs(),
        _ => false,
    }
}

/// Errors after which an exchange may be repeated.
fn recoverable(e: &Error) -> bool {
    matches!(
        e,
        Error::Timeout { .. } | Error::BadReply { .. } | Error::OutOfSync(_)
    )
}

impl<P: Read + Write> Ptu<P> {
    /// Connects to the unit on `port`: turns echo off (noting whether it was on), sets terse
    /// feedback, immediate execution and independent control, and queries resolution,
    /// limits, speeds and firmware. The port's reads must time out (serial ports do), so that
    /// the driver's deadlines hold.
    pub fn connect(port: P, options: PtuOptions) -> Result<Self> {
        let axis = AxisInfo {
            resolution_arcsec: 0.0,
            min: 0,
            max: 0,
            lower_speed: 0,
            upper_speed: 0,
            speed: 0,
            base_speed: 0,
            acceleration: 0,
        };
        let mut ptu = Ptu {
            port,
            parser: ReplyParser::new(),
            options,
            info: UnitInfo {
                firmware: String::new(),
                pan: axis,
                tilt: axis,
                limits_enabled: true,
                echo_was_on: false,
            },
            feedback: Feedback::Verbose,
            limit_hits: Vec::new(),
            stats: DriverStats::default(),
            dirty: false,
        };
        ptu.drain()?;
        // Echo: the reply to ED is preceded by "ED " when echo was on.
        let timeout = ptu.options.reply_timeout;
        let mut echoed = false;
        let mut done = false;
        for attempt in 0..=ptu.options.retries {
            if attempt > 0 {
                ptu.resync()?;
            }
            ptu.send(Command::SetEcho(false))?;
            let deadline = Instant::now() + timeout;
            loop {
                match ptu.next_event(deadline)? {
                    None => break,
                    Some(Event::Other(b)) => {
                        echoed |= b.to_ascii_uppercase().starts_with(b"ED");
                    }
                    Some(Event::Limit(a)) => ptu.limit_hits.push(a),
                    Some(Event::Ok(_)) => {
                        done = true;
                        break;
                    }
                    Some(Event::Error(_)) => break,
                }
            }
            if done {
                break;
            }
        }
        if !done {
            return Err(Error::Timeout {
                command: "ED".into(),
                timeout,
            });
        }
        ptu.info.echo_was_on = echoed;
        ptu.command(Command::SetFeedback(Feedback::Terse), timeout)?;
        ptu.feedback = Feedback::Terse;
        ptu.command(Command::SetExecution(Execution::Immediate), timeout)?;
        // Older firmware has no control modes: independent position control is all it does.
        match ptu.command(Command::SetControl(ControlMode::Independent), timeout) {
            Ok(_)
            | Err(Error::Device {
                error: DeviceError::IllegalCommand,
                ..
            }) => {}
            Err(e) => return Err(e),
        }
        for a in Axis::ALL {
            let info = AxisInfo {
                resolution_arcsec: ptu.query_number(a, AxisParam::Resolution)?,
                min: ptu.query_int(a, AxisParam::MinPosition)?,
                max: ptu.query_int(a, AxisParam::MaxPosition)?,
                lower_speed: ptu.query_int(a, AxisParam::LowerSpeed)?,
                upper_speed: ptu.query_int(a, AxisParam::UpperSpeed)?,
                speed: ptu.query_int(a, AxisParam::Speed)?,
                base_speed: ptu.query_int(a, AxisParam::BaseSpeed)?,
                acceleration: ptu.query_int(a, AxisParam::Acceleration)?,
            };
            if !(info.resolution_arcsec > 0.0) {
                return Err(Error::BadReply {
                    command: format!("{}R", a.letter()),
                    reply: info.resolution_arcsec.to_string(),
                    reason: "a resolution must be positive",
                });
            }
            *ptu.info.axis_mut(a) = info;
        }
        ptu.info.limits_enabled = ptu.query_limits()?;
        ptu.info.firmware = ptu.command(Command::Version, timeout)?;
        Ok(ptu)
    }

    /// What the unit said of itself.
    pub fn info(&self) -> &UnitInfo {
        &self.info
    }

    /// Recovery counts so far.
    pub fn stats(&self) -> DriverStats {
        self.stats
    }

    /// The limit hits (`!P` / `!T`) seen since the last call.
    pub fn take_limit_hits(&mut self) -> Vec<Axis> {
        std::mem::take(&mut self.limit_hits)
    }

    /// The options.
    pub fn options(&self) -> &PtuOptions {
        &self.options
    }

    /// The port back.
    pub fn into_inner(self) -> P {
        self.port
    }

    /// The verified position of `axis` in steps: queried until three consecutive answers,
    /// spanning at least [`PtuOptions::settle_gap`], agree (so neither a garbled answer nor a moving axis is reported).
    pub fn position_steps(&mut self, axis: Axis) -> Result<i32> {
        let deadline = Instant::now() + self.options.command_bound(self.options.reply_timeout);
        self.settled_position(axis, deadline)
    }

    /// The verified position of `axis`.
    pub fn position(&mut self, axis: Axis) -> Result<Radians> {
        let s = self.position_steps(axis)?;
        Ok(self.info.axis(axis).radians(s))
    }

    /// Moves `axis` to `target` steps and waits until it has stopped there; returns the
    /// verified position. A target outside the enabled soft limits is refused by the unit
    /// ([`DeviceError::PositionLimit`] with the limit).
    pub fn move_to_steps(&mut self, axis: Axis, target: i32) -> Result<i32> {
        self.limit_hits.clear();
        let from = self.position_steps(axis)?;
        let a = *self.info.axis(axis);
        let distance = (target as f64 - from as f64).abs();
        let travel = profile(
            distance,
            a.base_speed as f64,
            a.speed.max(1) as f64,
            a.acceleration as f64,
        )
        .3;
        let timeout = Duration::from_secs_f64(travel.min(1e6)) + self.options.move_margin;
        let mut reached = from;
        for attempt in 0..=self.options.retries {
            if attempt > 0 {
                self.stats.retries += 1;
            }
            // The motion settings the move's deadline assumes: a garbled command may have
            // changed them on the unit.
            for (param, value) in [
                (AxisParam::Acceleration, a.acceleration),
                (AxisParam::BaseSpeed, a.base_speed),
                (AxisParam::Speed, a.speed),
            ] {
                self.set(axis, param, value)?;
            }
            self.command(
                Command::Set(axis, AxisParam::Position, target),
                self.options.reply_timeout,
            )?;
            match self.command(Command::Await, timeout) {
                Ok(_) => {}
                // The unit may have finished all the same: the position decides.
                Err(e) if recoverable(&e) => {}
                Err(e) => return Err(e),
            }
            let deadline = Instant::now() + self.options.command_bound(timeout);
            reached = self.settled_position(axis, deadline)?;
            if reached == target {
                return Ok(reached);
            }
            if self.limit_hits.contains(&axis) {
                break;
            }
        }
        Err(Error::MoveIncomplete {
            axis,
            target,
            reached,
            limit_hit: self.limit_hits.contains(&axis),
        })
    }

    /// Moves `axis` to `angle` (the nearest step) and waits; returns the verified angle.
    pub fn move_to(&mut self, axis: Axis, angle: Radians) -> Result<Radians> {
        let target = self.info.axis(axis).steps(angle)?;
        let s = self.move_to_steps(axis, target)?;
        Ok(self.info.axis(axis).radians(s))
    }

    /// Moves `axis` by `delta` from where it is (as an absolute move, so that it can be
    /// repeated safely after a lost reply) and waits; returns the verified angle.
    pub fn move_by(&mut self, axis: Axis, delta: Radians) -> Result<Radians> {
        let d = self.info.axis(axis).steps(delta)?;
        let from = self.position_steps(axis)?;
        let target = from.checked_add(d).ok_or(Error::InvalidArgument {
            name: "delta",
            reason: format!("{} rad from step {from} overflows", delta.0),
        })?;
        let s = self.move_to_steps(axis, target)?;
        Ok(self.info.axis(axis).radians(s))
    }

    /// Sets the target speed of `axis`, steps/s.
    pub fn set_speed(&mut self, axis: Axis, steps_per_s: i32) -> Result<()> {
        self.set(axis, AxisParam::Speed, steps_per_s)?;
        self.info.axis_mut(axis).speed = steps_per_s;
        Ok(())
    }

    /// Sets the acceleration of `axis`, steps/s².
    pub fn set_acceleration(&mut self, axis: Axis, steps_per_s2: i32) -> Result<()> {
        self.set(axis, AxisParam::Acceleration, steps_per_s2)?;
        self.info.axis_mut(axis).acceleration = steps_per_s2;
        Ok(())
    }

    /// Sets the base (start) speed of `axis`, steps/s.
    pub fn set_base_speed(&mut self, axis: Axis, steps_per_s: i32) -> Result<()> {
        self.set(axis, AxisParam::BaseSpeed, steps_per_s)?;
        self.info.axis_mut(axis).base_speed = steps_per_s;
        Ok(())
    }

    /// Enables or disables the soft limits, then reads the state back.
    pub fn set_limits(&mut self, enabled: bool) -> Result<bool> {
        self.command(Command::SetLimits(enabled), self.options.reply_timeout)?;
        self.info.limits_enabled = self.query_limits()?;
        Ok(self.info.limits_enabled)
    }

    /// Halts one axis or both at once.
    pub fn halt(&mut self, axis: Option<Axis>) -> Result<()> {
        self.command(Command::Halt(axis), self.options.reply_timeout)
            .map(drop)
    }

    /// Resets (homes) one axis or both, waiting for the unit's `*` after its limit hits (at
    /// most the reset timeout); returns the limit hits it reported.
    pub fn reset(&mut self, axis: Option<Axis>) -> Result<Vec<Axis>> {
        self.limit_hits.clear();
        self.command(Command::Reset(axis), self.options.reset_timeout)?;
        Ok(self.take_limit_hits())
    }

    /// Sends any command and returns the text of its success reply. Typed device errors come
    /// back as [`Error::Device`]. A query must answer with text and any other command with a
    /// bare `*`: a reply of the wrong kind is a late one and is retried like a lost reply.
    pub fn command(&mut self, cmd: Command, timeout: Duration) -> Result<String> {
        let query = cmd.is_query();
        self.transact(cmd, timeout, |t| {
            (query != t.is_empty()).then(|| t.to_owned())
        })
    }

    fn set(&mut self, axis: Axis, param: AxisParam, value: i32) -> Result<()> {
        self.command(Command::Set(axis, param, value), self.options.reply_timeout)
            .map(drop)
    }

    /// One command with its retries: sent, its reply read and `accept`ed; a lost, garbled,
    /// noisy or unacceptable reply makes the driver resynchronise and send it again (if it
    /// may be repeated).
    fn transact<T>(
        &mut self,
        cmd: Command,
        timeout: Duration,
        accept: impl Fn(&str) -> Option<T>,
    ) -> Result<T> {
        if self.dirty {
            self.resync()?;
            self.dirty = false;
        }
        let mut last = None;
        for attempt in 0..=self.options.retries {
            if attempt > 0 {
                self.stats.retries += 1;
                if let Err(e) = self.resync() {
                    self.dirty = true;
                    return Err(e);
                }
            }
            match self.exchange(cmd, timeout) {
                Ok(Outcome::Ok(text)) => match accept(&text) {
                    Some(v) => return Ok(v),
                    None => {
                        last = Some(Error::BadReply {
                            command: cmd.text(),
                            reply: text,
                            reason: "not the answer this command gives",
                        })
                    }
                },
                Ok(Outcome::Device(DeviceError::Other(m))) => {
                    // An unknown message may be a garbled reply: try again.
                    last = Some(Error::BadReply {
                        command: cmd.text(),
                        reply: format!("! {m}"),
                        reason: "an error message the driver does not know",
                    });
                }
                Ok(Outcome::Device(error)) => {
                    let plausible = plausible(&cmd, &error);
                    let e = Error::Device {
                        command: cmd.text(),
                        error,
                    };
                    if plausible {
                        return Err(e);
                    }
                    // An error that does not fit the command as sent: the command was garbled
                    // on its way to the unit.
                    last = Some(e);
                }
                Ok(Outcome::Tainted(text)) => {
                    last = Some(Error::BadReply {
                        command: cmd.text(),
                        reply: text,
                        reason: "noise on the line around the reply",
                    });
                }
                Err(e) if recoverable(&e) => last = Some(e),
                Err(e) => {
                    self.dirty = true;
                    return Err(e);
                }
            }
            if !cmd.idempotent() {
                break;
            }
        }
        self.dirty = true;
        Err(last.unwrap_or(Error::Timeout {
            command: cmd.text(),
            timeout,
        }))
    }

    fn query_int(&mut self, axis: Axis, param: AxisParam) -> Result<i32> {
        let (fb, t) = (self.feedback, self.options.reply_timeout);
        self.transact(Command::Query(axis, param), t, |r| reply_integer(r, fb))
    }

    fn query_number(&mut self, axis: Axis, param: AxisParam) -> Result<f64> {
        let (fb, t) = (self.feedback, self.options.reply_timeout);
        self.transact(Command::Query(axis, param), t, |r| reply_number(r, fb))
    }

    fn query_limits(&mut self) -> Result<bool> {
        let t = self.options.reply_timeout;
        self.transact(Command::QueryLimits, t, reply_limits_enabled)
    }

    fn settled_position(&mut self, axis: Axis, deadline: Instant) -> Result<i32> {
        // Answers that agree across this gap rule out an axis moving at the unit's
        // lowest speed (1.5 steps at least), whatever speed a garbled command may have set.
        let slowest = self.info.axis(axis).lower_speed.max(1) as f64;
        let gap = self
            .options
            .settle_gap
            .max(Duration::from_secs_f64((1.5 / slowest).min(10.0)));
        // Three answers in a row must agree: two garbled the same way (a digit dropped from
        // each) happen at realistic-to-bad error rates; three practically never.
        const AGREE: u32 = 3;
        let mut run: Option<(i32, Instant, u32)> = None;
        loop {
            let p = self.query_int(axis, AxisParam::Position)?;
            let now = Instant::now();
            run = match run {
                Some((q, t, n)) if q == p => Some((q, t, n + 1)),
                _ => Some((p, now, 1)),
            };
            if let Some((q, t, n)) = run {
                let waited = now.duration_since(t);
                if n >= AGREE && waited >= gap {
                    return Ok(q);
                }
                if n + 1 >= AGREE && waited < gap {
                    // Agreeing, but too close together to rule out a slow axis: look again
                    // once the gap has passed.
                    std::thread::sleep(gap - waited);
                }
            }
            if Instant::now() >= deadline {
                self.dirty = true;
                return Err(Error::OutOfSync(format!(
                    "the {axis} position did not settle (last answer {p})"
                )));
            }
        }
    }

    fn send(&mut self, cmd: Command) -> Result<()> {
        self.stats.exchanges += 1;
        let bytes = cmd.encode();
        match self.port.write_all(&bytes).and_then(|_| self.port.flush()) {
            Ok(()) => Ok(()),
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Err(Error::Disconnected),
            Err(e) => Err(e.into()),
        }
    }

    /// The next event, or `None` at the deadline.
    fn next_event(&mut self, deadline: Instant) -> Result<Option<Event>> {
        let mut buf = [0u8; 64];
        loop {
            if let Some(e) = self.parser.next_event() {
                return Ok(Some(e));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            if let Some(n) = self.read_some(&mut buf)? {
                self.parser.push(&buf[..n]);
            }
        }
    }

    /// One read of the port: `Some(bytes read)`, `None` if its timeout passed with nothing;
    /// end of file and a broken pipe are a disconnection.
    fn read_some(&mut self, buf: &mut [u8]) -> Result<Option<usize>> {
        match self.port.read(buf) {
            Ok(0) => Err(Error::Disconnected),
            Ok(n) => Ok(Some(n)),
            Err(e) if is_wait(&e) => Ok(None),
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Err(Error::Disconnected),
            Err(e) => Err(e.into()),
        }
    }

    /// Sends `cmd` and reads up to its reply.
    fn exchange(&mut self, cmd: Command, timeout: Duration) -> Result<Outcome> {
        self.send(cmd)?;
        let deadline = Instant::now() + timeout;
        let mut noise = false;
        loop {
            match self.next_event(deadline)? {
                None => {
                    return Err(Error::Timeout {
                        command: cmd.text(),
                        timeout,
                    });
                }
                Some(Event::Ok(text)) if noise => return Ok(Outcome::Tainted(text)),
                Some(Event::Ok(text)) => return Ok(Outcome::Ok(text)),
                Some(Event::Error(e)) if noise => return Ok(Outcome::Tainted(format!("! {e}"))),
                Some(Event::Error(e)) => return Ok(Outcome::Device(e)),
                Some(Event::Limit(a)) => self.limit_hits.push(a),
                Some(Event::Other(_)) => noise = true,
            }
        }
    }

    /// Reads and discards until the line has been silent for the quiet time (at most the
    /// drain cap).
    fn drain(&mut self) -> Result<()> {
        let start = Instant::now();
        let mut last_byte = start;
        let mut buf = [0u8; 256];
        loop {
            let now = Instant::now();
            if now.duration_since(last_byte) >= self.options.quiet {
                self.parser.clear();
                return Ok(());
            }
            if now.duration_since(start) >= self.options.drain_cap() {
                return Err(Error::OutOfSync(format!(
                    "the line did not go quiet within {:?}",
                    self.options.drain_cap()
                )));
            }
            if self.read_some(&mut buf)?.is_some() {
                last_byte = Instant::now();
            }
        }
    }

    /// Gets back in step: drain, echo off and terse feedback again, then `F` must answer
    /// "terse" (a late reply to an earlier command is skipped). At most three rounds.
    fn resync(&mut self) -> Result<()> {
        self.stats.resyncs += 1;
        let timeout = self.options.reply_timeout;
        let mut why = String::from("no round completed");
        for round in 0..3u32 {
            match self.drain() {
                Ok(()) => {}
                Err(Error::OutOfSync(m)) => {
                    why = m;
                    continue;
                }
                Err(e) => return Err(e),
            }
            // Before connect has set terse feedback, the unit may be in either mode.
            let wanted: &[&str] = match self.feedback {
                Feedback::Terse => &["TERSE"],
                Feedback::Verbose => &["TERSE", "VERBOSE"],
            };
            let mut steps = vec![Command::SetEcho(false)];
            if self.feedback == Feedback::Terse {
                steps.push(Command::SetFeedback(Feedback::Terse));
            }
            for cmd in steps {
                self.send(cmd)?;
                let deadline = Instant::now() + timeout;
                while let Some(e) = self.next_event(deadline)? {
                    match e {
                        Event::Ok(_) | Event::Error(_) => break,
                        Event::Limit(a) => self.limit_hits.push(a),
                        Event::Other(_) => {}
                    }
                }
            }
            self.send(Command::QueryFeedback)?;
            let deadline = Instant::now() + timeout * (1 << round);
            loop {
                match self.next_event(deadline)? {
                    None => {
                        why = "no answer to F".into();
                        break;
                    }
                    Some(Event::Ok(t))
                        if wanted.iter().any(|w| t.to_ascii_uppercase().contains(w)) =>
                    {
                        return Ok(());
                    }
                    Some(Event::Limit(a)) => self.limit_hits.push(a),
                    // Late replies to earlier commands, and noise: skip.
                    Some(_) => {}
                }
            }
        }
        Err(Error::OutOfSync(why))
    }
}
