//! A PTU-46 emulator: the device's state machine over virtual time.
//!
//! [`Emulator`] is sans-IO: feed it the bytes the host sends with [`Emulator::receive`],
//! tell it the time with [`Emulator::advance`], and take what it says with
//! [`Emulator::take_output`]. Positions are in steps; motion follows a trapezoidal speed
//! profile (base speed, acceleration, target speed), so moves take time. Commands are
//! executed one after another: `A` (await) and `R` (reset) hold the commands behind them
//! until they finish. [`EmulatedPort`](crate::EmulatedPort) runs it in memory on the wall
//! clock and [`PtyServer`](crate::PtyServer) serves it on a pseudo-terminal.
//!
//! Replies are worded as in the PTU-D46 manual. Where the sources show only numbers for the
//! terse mode, the non-numeric answers (`L`, `E`, `F`, `V`, `O`, `C`) are the same sentences
//! in both modes.

use std::collections::VecDeque;
use std::time::Duration;

use crate::protocol::Axis;
use crate::protocol::{AxisParam, Bound, Command, ControlMode, DeviceError, Execution, Feedback};

/// The factory settings of one axis.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisConfig {
    /// Arc seconds per step (PTU-46: 185.1428; later firmware microsteps finer).
    pub resolution_arcsec: f64,
    /// Soft limits (steps), enforced while limits are enabled (`LE`).
    pub soft_min: i32,
    /// Upper soft limit, steps.
    pub soft_max: i32,
    /// Steps between a soft limit and the hard stop beyond it.
    pub hard_margin: i32,
    /// Upper speed bound at power-up and the most `PU` accepts, steps/s.
    pub upper_speed: i32,
    /// Lower speed bound at power-up and the least `PL` accepts, steps/s.
    pub lower_speed: i32,
    /// Target speed at power-up, steps/s.
    pub speed: i32,
    /// Acceleration at power-up, steps/s².
    pub acceleration: i32,
    /// Base (start) speed at power-up, steps/s.
    pub base_speed: i32,
}

impl AxisConfig {
    /// The pan axis of a PTU-D46-17 as the manual's examples show it.
    pub fn ptu46_pan() -> Self {
        AxisConfig {
            resolution_arcsec: 185.1428,
            soft_min: -3090,
            soft_max: 3090,
            hard_margin: 160,
            upper_speed: 2902,
            lower_speed: 31,
            speed: 1000,
            acceleration: 2000,
            base_speed: 1000,
        }
    }

    /// The tilt axis of a PTU-D46-17.
    pub fn ptu46_tilt() -> Self {
        AxisConfig {
            soft_min: -907,
            soft_max: 604,
            ..Self::ptu46_pan()
        }
    }
}

/// The emulated unit.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorConfig {
    /// The pan axis.
    pub pan: AxisConfig,
    /// The tilt axis.
    pub tilt: AxisConfig,
    /// The answer to `V`.
    pub firmware: String,
    /// How long a reset of both axes takes (one axis: half).
    pub reset_duration: Duration,
}

impl Default for EmulatorConfig {
    /// A PTU-D46-17 at its factory settings.
    fn default() -> Self {
        EmulatorConfig {
            pan: AxisConfig::ptu46_pan(),
            tilt: AxisConfig::ptu46_tilt(),
            firmware: "Pan-Tilt Controller v2.12.1d1(C14/E) emulated by aibr-ptu".into(),
            reset_duration: Duration::from_secs(8),
        }
    }
}

impl EmulatorConfig {
    /// A unit that moves `factor` times faster (speed bounds and settings, acceleration and
    /// reset), for tests.
    pub fn faster(mut self, factor: f64) -> Self {
        for a in [&mut self.pan, &mut self.tilt] {
            let scale = |v: i32| ((v as f64) * factor).round().clamp(1.0, i32::MAX as f64) as i32;
            a.upper_speed = scale(a.upper_speed);
            a.lower_speed = scale(a.lower_speed);
            a.speed = scale(a.speed);
            a.base_speed = scale(a.base_speed);
            a.acceleration = scale(scale(a.acceleration));
        }
        self.reset_duration = self.reset_duration.div_f64(factor.max(1e-9));
        self
    }

    fn axis(&self, axis: Axis) -> &AxisConfig {
        match axis {
            Axis::Pan => &self.pan,
            Axis::Tilt => &self.tilt,
        }
    }
}

/// The settings `DS` saves and `DR` restores.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Settings {
    speed: [i32; 2],
    acceleration: [i32; 2],
    base_speed: [i32; 2],
    upper_speed: [i32; 2],
    lower_speed: [i32; 2],
    limits: bool,
    echo: bool,
    feedback: Feedback,
}

impl Settings {
    fn factory(cfg: &EmulatorConfig) -> Self {
        let both = |f: fn(&AxisConfig) -> i32| [f(&cfg.pan), f(&cfg.tilt)];
        Settings {
            speed: both(|a| a.speed),
            acceleration: both(|a| a.acceleration),
            base_speed: both(|a| a.base_speed),
            upper_speed: both(|a| a.upper_speed),
            lower_speed: both(|a| a.lower_speed),
            limits: true,
            echo: true,
            feedback: Feedback::Verbose,
        }
    }
}

/// How an axis is moving.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    Still(f64),
    /// A trapezoidal move from `from` to `to`, started at `start`.
    Move {
        from: f64,
        to: f64,
        start: Duration,
        base: f64,
        speed: f64,
        accel: f64,
    },
    /// Constant velocity (velocity mode) from `from`, stopping at `stop`.
    Velocity {
        from: f64,
        velocity: f64,
        start: Duration,
        stop: f64,
    },
}

/// The trapezoidal profile: time to cover `d` and distance covered at `t`.
pub(crate) fn profile(d: f64, base: f64, speed: f64, accel: f64) -> (f64, f64, f64, f64) {
    // Returns (accelerating time, accelerating distance, peak speed, total time).
    if d <= 0.0 || speed <= 0.0 {
        return (0.0, 0.0, speed.max(1.0), 0.0);
    }
    let v0 = base.clamp(0.0, speed);
    if accel <= 0.0 || v0 >= speed {
        return (0.0, 0.0, speed, d / speed);
    }
    let vp = speed.min((v0 * v0 + accel * d).sqrt());
    let ta = (vp - v0) / accel;
    let da = (vp * vp - v0 * v0) / (2.0 * accel);
    let cruise = ((d - 2.0 * da) / vp).max(0.0);
    (ta, da, vp, 2.0 * ta + cruise)
}

fn travelled(d: f64, base: f64, speed: f64, accel: f64, t: f64) -> f64 {
    let (ta, da, vp, total) = profile(d, base, speed, accel);
    let v0 = base.clamp(0.0, speed);
    if t >= total {
        d
    } else if ta == 0.0 {
        vp * t
    } else if t < ta {
        v0 * t + 0.5 * accel * t * t
    } else if t < total - ta {
        da + vp * (t - ta)
    } else {
        let r = total - t;
        d - (v0 * r + 0.5 * accel * r * r)
    }
}

impl Motion {
    fn position(&self, now: Duration) -> f64 {
        match *self {
            Motion::Still(p) => p,
            Motion::Move {
                from,
                to,
                start,
                base,
                speed,
                accel,
            } => {
                let t = now.saturating_sub(start).as_secs_f64();
                let d = (to - from).abs();
                from + (to - from).signum() * travelled(d, base, speed, accel, t)
            }
            Motion::Velocity {
                from,
                velocity,
                start,
                stop,
            } => {
                let p = from + velocity * now.saturating_sub(start).as_secs_f64();
                if velocity >= 0.0 {
                    p.min(stop)
                } else {
                    p.max(stop)
                }
            }
        }
    }

    /// When the motion ends.
    fn end(&self) -> Duration {
        match *self {
            Motion::Still(_) => Duration::ZERO,
            Motion::Move {
                from,
                to,
                start,
                base,
                speed,
                accel,
            } => start + Duration::from_secs_f64(profile((to - from).abs(), base, speed, accel).3),
            Motion::Velocity {
                from,
                velocity,
                start,
                stop,
            } => {
                if velocity == 0.0 {
                    start
                } else {
                    start + Duration::from_secs_f64(((stop - from) / velocity).max(0.0))
                }
            }
        }
    }
}

/// What holds the command queue.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Block {
    /// `A`: until both axes have stopped.
    Await(Duration),
    /// `R`: until the reset ends; which axes.
    Reset(Duration, Option<Axis>),
}

/// The longest command the emulator buffers; longer input is an illegal command.
const MAX_COMMAND: usize = 32;

/// The emulated PTU-46. See the [module docs](self).
#[derive(Debug, Clone)]
pub struct Emulator {
    cfg: EmulatorConfig,
    settings: Settings,
    saved: Settings,
    motion: [Motion; 2],
    pending: [Option<i32>; 2],
    execution: Execution,
    control: ControlMode,
    line: Vec<u8>,
    overflow: bool,
    queue: VecDeque<Option<Command>>,
    block: Option<Block>,
    /// Output due later: (time, axis it belongs to, bytes), in time order.
    scheduled: Vec<(Duration, Option<Axis>, Vec<u8>)>,
    out: Vec<u8>,
    now: Duration,
}

fn index(axis: Axis) -> usize {
    match axis {
        Axis::Pan => 0,
        Axis::Tilt => 1,
    }
}

impl Emulator {
    /// A unit just powered up (echo on, verbose feedback, limits enabled, at position 0).
    pub fn new(cfg: EmulatorConfig) -> Self {
        let settings = Settings::factory(&cfg);
        Emulator {
            cfg,
            settings,
            saved: settings,
            motion: [Motion::Still(0.0); 2],
            pending: [None; 2],
            execution: Execution::Immediate,
            control: ControlMode::Independent,
            line: Vec::new(),
            overflow: false,
            queue: VecDeque::new(),
            block: None,
            scheduled: Vec::new(),
            out: Vec::new(),
            now: Duration::ZERO,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &EmulatorConfig {
        &self.cfg
    }

    /// The true position of `axis` at the current time, in steps (rounded).
    pub fn position(&self, axis: Axis) -> i32 {
        self.motion[index(axis)].position(self.now).round() as i32
    }

    /// Whether `axis` is moving now.
    pub fn moving(&self, axis: Axis) -> bool {
        !matches!(self.motion[index(axis)], Motion::Still(_))
            && self.motion[index(axis)].end() > self.now
    }

    /// The time up to which the emulator has run.
    pub fn now(&self) -> Duration {
        self.now
    }

    /// The bytes the host sends, arriving at `now`.
    pub fn receive(&mut self, bytes: &[u8], now: Duration) {
        self.advance(now);
        for &b in bytes {
            if self.settings.echo {
                self.out.push(b);
            }
            if b == b' ' || b == b'\r' || b == b'\n' {
                if self.overflow {
                    self.queue.push_back(None);
                } else if !self.line.is_empty() {
                    self.queue.push_back(Command::parse(&self.line));
                }
                self.line.clear();
                self.overflow = false;
                // The unit acts on a command as soon as its delimiter arrives, so an echo
                // change applies to the very next byte.
                self.run_queue();
            } else if self.line.len() >= MAX_COMMAND {
                self.overflow = true;
            } else {
                self.line.push(b);
            }
        }
        self.run_queue();
    }

    /// Runs the unit up to `now` (never backwards): motion, due events, finished waits.
    pub fn advance(&mut self, now: Duration) {
        loop {
            let next_event = self.scheduled.first().map(|e| e.0);
            let block_end = match self.block {
                Some(Block::Await(t) | Block::Reset(t, _)) => Some(t),
                None => None,
            };
            let due = match (next_event, block_end) {
                (Some(e), Some(b)) => e.min(b),
                (Some(e), None) => e,
                (None, Some(b)) => b,
                (None, None) => break,
            };
            if due > now {
                break;
            }
            self.now = self.now.max(due);
            if next_event == Some(due) {
                let (_, _, bytes) = self.scheduled.remove(0);
                self.out.extend_from_slice(&bytes);
                continue;
            }
            match self.block.take() {
                Some(Block::Reset(_, axes)) => {
                    for a in Axis::ALL {
                        if axes.is_none_or(|x| x == a) {
                            self.motion[index(a)] = Motion::Still(0.0);
                        }
                    }
                    self.reply_ok("");
                }
                Some(Block::Await(_)) => self.reply_ok(""),
                None => {}
            }
            self.run_queue();
        }
        self.now = self.now.max(now);
        self.settle();
    }

    /// The next time something will happen without input, if any: a reply held by `A` or `R`,
    /// or an asynchronous limit event.
    pub fn next_deadline(&self) -> Option<Duration> {
        let block = match self.block {
            Some(Block::Await(t) | Block::Reset(t, _)) => Some(t),
            None => None,
        };
        let event = self.scheduled.first().map(|e| e.0);
        match (block, event) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// What the unit has said since the last call.
    pub fn take_output(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.out)
    }

    /// Turns finished motions into still positions.
    fn settle(&mut self) {
        for m in &mut self.motion {
            if !matches!(m, Motion::Still(_)) && m.end() <= self.now {
                *m = Motion::Still(m.position(self.now));
            }
        }
    }

    fn run_queue(&mut self) {
        while self.block.is_none() {
            let Some(cmd) = self.queue.pop_front() else {
                break;
            };
            self.settle();
            match cmd {
                Some(c) => self.execute(c),
                None => self.reply_err(DeviceError::IllegalCommand),
            }
        }
    }

    fn reply_ok(&mut self, text: &str) {
        self.out.push(b'*');
        if !text.is_empty() {
            self.out.push(b' ');
            self.out.extend_from_slice(text.as_bytes());
        }
        self.out.extend_from_slice(b"\r\n");
    }

    fn reply_err(&mut self, e: DeviceError) {
        self.out.extend_from_slice(format!("! {e}\r\n").as_bytes());
    }

    /// A query's answer in the current feedback mode.
    fn reply_value(&mut self, verbose: String, terse: String) {
        let text = match self.settings.feedback {
            Feedback::Verbose => verbose,
            Feedback::Terse => terse,
        };
        self.reply_ok(&text);
    }

    fn axis_cfg(&self, axis: Axis) -> &AxisConfig {
        self.cfg.axis(axis)
    }

    /// The bounds a position may reach now: soft limits when enabled, else the hard stops.
    fn bounds(&self, axis: Axis) -> (i32, i32) {
        let c = self.axis_cfg(axis);
        if self.settings.limits {
            (c.soft_min, c.soft_max)
        } else {
            (
                c.soft_min.saturating_sub(c.hard_margin),
                c.soft_max.saturating_add(c.hard_margin),
            )
        }
    }

    fn hard_bounds(&self, axis: Axis) -> (i32, i32) {
        let c = self.axis_cfg(axis);
        (
            c.soft_min.saturating_sub(c.hard_margin),
            c.soft_max.saturating_add(c.hard_margin),
        )
    }

    fn cancel_events(&mut self, axis: Axis) {
        self.scheduled.retain(|e| e.1 != Some(axis));
    }

    fn schedule(&mut self, at: Duration, axis: Option<Axis>, bytes: &[u8]) {
        let i = self.scheduled.partition_point(|e| e.0 <= at);
        self.scheduled.insert(i, (at, axis, bytes.to_vec()));
    }

    /// Starts a move of `axis` to `target` now; a target beyond the hard stop ends there
    /// with a limit event.
    fn start_move(&mut self, axis: Axis, target: i32) {
        let i = index(axis);
        self.cancel_events(axis);
        let from = self.motion[i].position(self.now);
        let (lo, hi) = self.hard_bounds(axis);
        let to = target.clamp(lo, hi);
        let m = Motion::Move {
            from,
            to: to as f64,
            start: self.now,
            base: self.settings.base_speed[i] as f64,
            speed: (self.settings.speed[i] as f64).abs().max(1.0),
            accel: self.settings.acceleration[i] as f64,
        };
        self.motion[i] = m;
        if to != target {
            let ev = [b'!', axis.letter() as u8];
            self.schedule(m.end(), Some(axis), &ev);
        }
    }

    fn start_velocity(&mut self, axis: Axis, velocity: i32) {
        let i = index(axis);
        self.cancel_events(axis);
        let from = self.motion[i].position(self.now);
        if velocity == 0 {
            self.motion[i] = Motion::Still(from);
            return;
        }
        let (lo, hi) = self.bounds(axis);
        let stop = if velocity > 0 { hi } else { lo } as f64;
        let m = Motion::Velocity {
            from,
            velocity: velocity as f64,
            start: self.now,
            stop,
        };
        self.motion[i] = m;
        let ev = [b'!', axis.letter() as u8];
        self.schedule(m.end(), Some(axis), &ev);
    }

    fn halt(&mut self, axis: Axis) {
        let i = index(axis);
        self.cancel_events(axis);
        self.motion[i] = Motion::Still(self.motion[i].position(self.now).round());
        self.pending[i] = None;
    }

    /// The current commanded target of `axis` (where it is going, or where it is).
    fn target(&self, axis: Axis) -> i32 {
        let i = index(axis);
        if let Some(p) = self.pending[i] {
            return p;
        }
        match self.motion[i] {
            Motion::Move { to, .. } => to as i32,
            m => m.position(self.now).round() as i32,
        }
    }

    fn set_position(&mut self, axis: Axis, target: i32) {
        let (lo, hi) = self.bounds(axis);
        if self.settings.limits && target > hi {
            return self.reply_err(DeviceError::PositionLimit {
                axis,
                bound: Bound::Max,
                limit: hi,
            });
        }
        if self.settings.limits && target < lo {
            return self.reply_err(DeviceError::PositionLimit {
                axis,
                bound: Bound::Min,
                limit: lo,
            });
        }
        match self.execution {
            Execution::Immediate => self.start_move(axis, target),
            Execution::Slaved => self.pending[index(axis)] = Some(target),
        }
        self.reply_ok("");
    }

    fn query(&mut self, axis: Axis, param: AxisParam) {
        let i = index(axis);
        let n = axis.name();
        let s = &self.settings;
        let (verbose, value) = match param {
            AxisParam::Position | AxisParam::Offset => {
                let p = self.position(axis);
                (format!("Current {n} position is {p}"), p.to_string())
            }
            AxisParam::Speed => {
                let v = match (self.control, self.motion[i]) {
                    (ControlMode::Velocity, Motion::Velocity { velocity, .. }) => velocity as i32,
                    (ControlMode::Velocity, _) => 0,
                    _ => s.speed[i],
                };
                (
                    format!("Target {n} speed is {v} positions/sec"),
                    v.to_string(),
                )
            }
            AxisParam::Acceleration => {
                let v = s.acceleration[i];
                (
                    format!("{n} acceleration is {v} positions/sec^2"),
                    v.to_string(),
                )
            }
            AxisParam::BaseSpeed => {
                let v = s.base_speed[i];
                (
                    format!("Current {n} base speed is {v} positions/sec"),
                    v.to_string(),
                )
            }
            AxisParam::UpperSpeed => {
                let v = s.upper_speed[i];
                (
                    format!("Maximum {n} speed is {v} positions/sec"),
                    v.to_string(),
                )
            }
            AxisParam::LowerSpeed => {
                let v = s.lower_speed[i];
                (
                    format!("Minimum {n} speed is {v} positions/sec"),
                    v.to_string(),
                )
            }
            AxisParam::MinPosition => {
                let v = self.axis_cfg(axis).soft_min;
                (format!("Minimum {n} position is {v}"), v.to_string())
            }
            AxisParam::MaxPosition => {
                let v = self.axis_cfg(axis).soft_max;
                (format!("Maximum {n} position is {v}"), v.to_string())
            }
            AxisParam::Resolution => {
                let r = self.axis_cfg(axis).resolution_arcsec;
                (format!("{r} seconds arc per {n} position"), r.to_string())
            }
        };
        self.reply_value(verbose, value);
    }

    fn set(&mut self, axis: Axis, param: AxisParam, v: i32) {
        let i = index(axis);
        let s = self.settings;
        match param {
            AxisParam::Position => self.set_position(axis, v),
            AxisParam::Offset => {
                let target = self.target(axis).saturating_add(v);
                self.set_position(axis, target)
            }
            AxisParam::Speed => {
                let magnitude = v.unsigned_abs();
                if magnitude > s.upper_speed[i] as u32 {
                    return self.reply_err(DeviceError::SpeedTooHigh {
                        axis,
                        max: s.upper_speed[i],
                    });
                }
                match self.control {
                    ControlMode::Independent => {
                        if v < 0 {
                            return self.reply_err(DeviceError::IllegalArgument);
                        }
                        if v < s.lower_speed[i] {
                            return self.reply_err(DeviceError::SpeedTooLow {
                                min: s.lower_speed[i],
                            });
                        }
                        self.settings.speed[i] = v;
                    }
                    ControlMode::Velocity => {
                        if v != 0 && magnitude < s.lower_speed[i] as u32 {
                            return self.reply_err(DeviceError::SpeedTooLow {
                                min: s.lower_speed[i],
                            });
                        }
                        self.start_velocity(axis, v);
                    }
                }
                self.reply_ok("");
            }
            AxisParam::Acceleration => {
                if v <= 0 {
                    return self.reply_err(DeviceError::IllegalArgument);
                }
                self.settings.acceleration[i] = v;
                self.reply_ok("");
            }
            AxisParam::BaseSpeed => {
                if v < 0 || v > s.upper_speed[i] {
                    return self.reply_err(DeviceError::IllegalArgument);
                }
                self.settings.base_speed[i] = v;
                self.reply_ok("");
            }
            AxisParam::UpperSpeed => {
                let ceiling = self.axis_cfg(axis).upper_speed;
                if v > ceiling {
                    return self.reply_err(DeviceError::SpeedTooHigh { axis, max: ceiling });
                }
                if v < s.lower_speed[i] {
                    return self.reply_err(DeviceError::IllegalArgument);
                }
                self.settings.upper_speed[i] = v;
                self.settings.speed[i] = self.settings.speed[i].min(v);
                self.reply_ok("");
            }
            AxisParam::LowerSpeed => {
                let floor = self.axis_cfg(axis).lower_speed;
                if v < floor {
                    return self.reply_err(DeviceError::SpeedTooLow { min: floor });
                }
                if v > s.upper_speed[i] {
                    return self.reply_err(DeviceError::IllegalArgument);
                }
                self.settings.lower_speed[i] = v;
                self.settings.speed[i] = self.settings.speed[i].max(v);
                self.reply_ok("");
            }
            AxisParam::MinPosition | AxisParam::MaxPosition | AxisParam::Resolution => {
                self.reply_err(DeviceError::IllegalArgument)
            }
        }
    }

    fn execute(&mut self, cmd: Command) {
        match cmd {
            Command::Query(axis, param) => self.query(axis, param),
            Command::Set(axis, param, v) => self.set(axis, param, v),
            Command::Await => {
                for a in Axis::ALL {
                    if let Some(t) = self.pending[index(a)].take() {
                        self.start_move(a, t);
                    }
                }
                let end = self
                    .motion
                    .iter()
                    .map(Motion::end)
                    .max()
                    .unwrap_or_default();
                if end > self.now {
                    self.block = Some(Block::Await(end));
                } else {
                    self.reply_ok("");
                }
            }
            Command::SetExecution(e) => {
                self.execution = e;
                self.reply_ok("");
            }
            Command::Halt(axis) => {
                for a in Axis::ALL {
                    if axis.is_none_or(|x| x == a) {
                        self.halt(a);
                    }
                }
                self.reply_ok("");
            }
            Command::QueryLimits => {
                let text = if self.settings.limits {
                    "Limit bounds are ENABLED (soft limits enabled)"
                } else {
                    "Limit bounds are DISABLED (hard limits only: use care)"
                };
                self.reply_ok(text);
            }
            Command::SetLimits(on) => {
                self.settings.limits = on;
                self.reply_ok("");
            }
            Command::Reset(axis) => {
                let axes: Vec<Axis> = [Axis::Tilt, Axis::Pan]
                    .into_iter()
                    .filter(|a| axis.is_none_or(|x| x == *a))
                    .collect();
                for &a in &axes {
                    self.halt(a);
                }
                let total = self.cfg.reset_duration.mul_f64(axes.len() as f64 / 2.0);
                // Each axis hits one limit, then the other, then returns to its centre.
                let hits = axes.len() * 2;
                for (k, a) in axes.iter().flat_map(|a| [a, a]).enumerate() {
                    let at = self.now + total.mul_f64((k + 1) as f64 / (hits + 1) as f64);
                    self.schedule(at, None, &[b'!', a.letter() as u8]);
                }
                self.block = Some(Block::Reset(self.now + total, axis));
            }
            Command::QueryFeedback => {
                let text = match self.settings.feedback {
                    Feedback::Verbose => "ASCII verbose mode",
                    Feedback::Terse => "ASCII terse mode",
                };
                self.reply_ok(text);
            }
            Command::SetFeedback(f) => {
                self.settings.feedback = f;
                self.reply_ok("");
            }
            Command::QueryEcho => {
                let text = if self.settings.echo {
                    "Echoing ON"
                } else {
                    "Echoing OFF"
                };
                self.reply_ok(text);
            }
            Command::SetEcho(on) => {
                self.settings.echo = on;
                self.reply_ok("");
            }
            Command::Version => {
                let v = self.cfg.firmware.clone();
                self.reply_ok(&v);
            }
            Command::Voltage => self.reply_ok("Input 30 VDC @ 86 degF"),
            Command::SaveDefaults => {
                self.saved = self.settings;
                self.reply_ok("");
            }
            Command::RestoreDefaults => {
                self.settings = self.saved;
                self.reply_ok("");
            }
            Command::FactoryDefaults => {
                self.settings = Settings::factory(&self.cfg);
                self.saved = self.settings;
                self.reply_ok("");
            }
            Command::QueryControl => {
                let text = match self.control {
                    ControlMode::Independent => "Independent position control mode",
                    ControlMode::Velocity => "Velocity control mode",
                };
                self.reply_ok(text);
            }
            Command::SetControl(c) => {
                if c != self.control {
                    for a in Axis::ALL {
                        self.halt(a);
                    }
                }
                self.control = c;
                self.reply_ok("");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::{Event, parse_events};

    fn say(e: &mut Emulator, text: &str, at_ms: u64) -> Vec<Event> {
        e.receive(text.as_bytes(), Duration::from_millis(at_ms));
        parse_events(&e.take_output()).0
    }

    #[test]
    fn replays_the_manual() {
        let mut e = Emulator::new(EmulatorConfig::default());
        assert_eq!(
            String::from_utf8_lossy(&{
                e.receive(b"PP-500 ", Duration::ZERO);
                e.take_output()
            }),
            "PP-500 *\r\n"
        );
        let ev = say(&mut e, "ED A ", 0);
        // The echo of "ED " and its reply; echo is off for "A ", which waits for the move.
        assert_eq!(
            ev,
            vec![Event::Other(b"ED ".to_vec()), Event::Ok(String::new())]
        );
        assert_eq!(e.take_output(), b"");
        // The move of 500 steps at 1000 steps/s takes about half a second.
        e.advance(Duration::from_millis(2000));
        assert_eq!(
            parse_events(&e.take_output()).0,
            vec![Event::Ok(String::new())]
        );
        assert_eq!(
            say(&mut e, "PO ", 2000),
            vec![Event::Ok("Current Pan position is -500".into())]
        );
        assert_eq!(
            say(&mut e, "PP3200 ", 2000),
            vec![Event::Error(DeviceError::PositionLimit {
                axis: Axis::Pan,
                bound: Bound::Max,
                limit: 3090
            })]
        );
        assert_eq!(
            say(&mut e, "PS3300 PL20 FT PR ", 2000),
            vec![
                Event::Error(DeviceError::SpeedTooHigh {
                    axis: Axis::Pan,
                    max: 2902
                }),
                Event::Error(DeviceError::SpeedTooLow { min: 31 }),
                Event::Ok(String::new()),
                Event::Ok("185.1428".into()),
            ]
        );
        assert_eq!(
            say(&mut e, "XYZ ", 2000),
            vec![Event::Error(DeviceError::IllegalCommand)]
        );
    }

    #[test]
    fn moves_take_time_and_await_waits() {
        let mut e = Emulator::new(EmulatorConfig::default());
        say(&mut e, "ED FT PP1000 A PP ", 0);
        assert!(e.moving(Axis::Pan));
        // Held behind A: nothing yet for the PP query.
        let mid = say(&mut e, "", 400);
        assert!(mid.is_empty(), "{mid:?}");
        let p = e.position(Axis::Pan);
        assert!(0 < p && p < 1000, "{p}");
        let end = e.next_deadline().unwrap();
        e.advance(end);
        assert_eq!(
            parse_events(&e.take_output()).0,
            vec![Event::Ok(String::new()), Event::Ok("1000".into())]
        );
        assert!(!e.moving(Axis::Pan));
    }

    #[test]
    fn reset_reports_limit_hits_then_success() {
        let mut e = Emulator::new(EmulatorConfig::default());
        say(&mut e, "ED PP500 A ", 0);
        e.advance(Duration::from_secs(2));
        e.take_output();
        e.receive(b"R ", Duration::from_secs(2));
        e.advance(Duration::from_secs(20));
        assert_eq!(e.take_output(), b"!T!T!P!P*\r\n");
        assert_eq!(e.position(Axis::Pan), 0);
    }

    #[test]
    fn hard_stop_without_soft_limits() {
        let mut e = Emulator::new(EmulatorConfig::default().faster(10.0));
        say(&mut e, "ED LD PP9999 A ", 0);
        e.advance(Duration::from_secs(10));
        let (ev, _) = parse_events(&e.take_output());
        assert_eq!(ev, vec![Event::Limit(Axis::Pan), Event::Ok(String::new())]);
        assert_eq!(e.position(Axis::Pan), 3250);
    }

    #[test]
    fn velocity_mode_runs_to_the_limit() {
        let mut e = Emulator::new(EmulatorConfig::default());
        say(&mut e, "ED CV PS-2000 ", 0);
        e.advance(Duration::from_millis(500));
        assert_eq!(e.position(Axis::Pan), -1000);
        e.advance(Duration::from_secs(5));
        assert_eq!(
            parse_events(&e.take_output()).0,
            vec![Event::Limit(Axis::Pan)]
        );
        assert_eq!(e.position(Axis::Pan), -3090);
    }

    #[test]
    fn trapezoid_is_continuous_and_ends_at_target() {
        for (d, base, speed, accel) in [
            (1000.0, 100.0, 1000.0, 2000.0),
            (10.0, 0.0, 1000.0, 50.0),
            (500.0, 2000.0, 1000.0, 10.0),
        ] {
            let total = profile(d, base, speed, accel).3;
            let mut last = 0.0;
            for k in 0..=1000 {
                let t = total * k as f64 / 1000.0;
                let x = travelled(d, base, speed, accel, t);
                assert!(x + 1e-9 >= last && x <= d + 1e-9, "{d} {t} {x} {last}");
                assert!(x - last <= speed * total / 1000.0 + 1e-6);
                last = x;
            }
            assert!((last - d).abs() < 1e-9);
        }
    }
}
