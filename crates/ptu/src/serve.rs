//! Running the [`Emulator`] on the wall clock: in memory as a `Read + Write` port (with
//! optional fault injection), or served on a pseudo-terminal so a driver talks to it through
//! a real serial device file.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::emulator::Emulator;
use crate::error::{Error, Result};

/// Faults to inject on a line, each byte independently, in both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Faults {
    /// The seed of the fault sequence: the same seed, the same faults.
    pub seed: u64,
    /// Probability that a byte is lost.
    pub drop: f64,
    /// Probability that a byte is replaced by a random one.
    pub corrupt: f64,
    /// Probability that the line stalls before a byte (bytes keep their order).
    pub delay: f64,
    /// The longest stall.
    pub max_delay: Duration,
    /// After this many bytes from the unit, the line goes dead: reads give end of file and
    /// writes fail, as when a USB adapter is pulled in the middle of a reply.
    pub disconnect_after: Option<usize>,
}

impl Default for Faults {
    /// No faults.
    fn default() -> Self {
        Faults {
            seed: 0,
            drop: 0.0,
            corrupt: 0.0,
            delay: 0.0,
            max_delay: Duration::ZERO,
            disconnect_after: None,
        }
    }
}

/// A small deterministic generator (SplitMix64) for fault injection.
#[derive(Debug, Clone)]
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// What the faults did, counted.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FaultCounts {
    /// Bytes lost.
    pub dropped: u64,
    /// Bytes replaced.
    pub corrupted: u64,
    /// Stalls.
    pub delayed: u64,
    /// Whether the line went dead.
    pub disconnected: bool,
}

/// Applies [`Faults`] to a byte stream.
#[derive(Debug, Clone)]
struct FaultLine {
    faults: Faults,
    rng: SplitMix,
    counts: FaultCounts,
}

impl FaultLine {
    fn new(faults: Faults, stream: u64) -> Self {
        FaultLine {
            faults,
            rng: SplitMix(faults.seed ^ stream.wrapping_mul(0xA076_1D64_78BD_642F)),
            counts: FaultCounts::default(),
        }
    }

    /// The byte after the line, or `None` if lost; and a stall before it.
    fn pass(&mut self, b: u8) -> (Option<u8>, Duration) {
        let f = self.faults;
        let mut stall = Duration::ZERO;
        if f.delay > 0.0 && self.rng.unit() < f.delay {
            stall = f.max_delay.mul_f64(self.rng.unit());
            self.counts.delayed += 1;
        }
        if f.drop > 0.0 && self.rng.unit() < f.drop {
            self.counts.dropped += 1;
            return (None, stall);
        }
        if f.corrupt > 0.0 && self.rng.unit() < f.corrupt {
            self.counts.corrupted += 1;
            return (Some((self.rng.next_u64() & 0xFF) as u8), stall);
        }
        (Some(b), stall)
    }
}

struct PortState {
    emulator: Emulator,
    /// Bytes from the unit with the time they reach the host.
    incoming: VecDeque<(Duration, u8)>,
    /// Bytes from the host with the time they reach the unit.
    outgoing: VecDeque<(Duration, u8)>,
    to_host: FaultLine,
    to_unit: FaultLine,
    delivered: usize,
    dead: bool,
}

impl PortState {
    /// Runs the unit to `now` and moves bytes along both lines.
    fn pump(&mut self, now: Duration) {
        while self.outgoing.front().is_some_and(|&(t, _)| t <= now) {
            if let Some((t, b)) = self.outgoing.pop_front() {
                self.emulator.receive(&[b], t);
            }
        }
        self.emulator.advance(now);
        let mut last = self.incoming.back().map_or(now, |&(t, _)| t.max(now));
        for b in self.emulator.take_output() {
            let (b, stall) = self.to_host.pass(b);
            last += stall;
            if let Some(b) = b {
                self.incoming.push_back((last, b));
            }
        }
    }

    fn next_wake(&self) -> Option<Duration> {
        [
            self.emulator.next_deadline(),
            self.incoming.front().map(|e| e.0),
            self.outgoing.front().map(|e| e.0),
        ]
        .into_iter()
        .flatten()
        .min()
    }
}

/// The emulator as an in-memory port on the wall clock, with optional faults: what the
/// driver's tests talk to. Clones share the same unit, so a test can look at its true state
/// ([`EmulatedPort::emulator`]) while a driver owns the port.
#[derive(Clone)]
pub struct EmulatedPort {
    state: Arc<Mutex<PortState>>,
    start: Instant,
    timeout: Duration,
}

impl std::fmt::Debug for EmulatedPort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmulatedPort")
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

impl EmulatedPort {
    /// A port to `emulator` on a clean line; a read waits at most `timeout` for a byte
    /// (then fails with [`io::ErrorKind::TimedOut`], as a serial port does).
    pub fn new(emulator: Emulator, timeout: Duration) -> Self {
        Self::with_faults(emulator, timeout, Faults::default())
    }

    /// A port to `emulator` on a line with `faults`.
    pub fn with_faults(emulator: Emulator, timeout: Duration, faults: Faults) -> Self {
        EmulatedPort {
            state: Arc::new(Mutex::new(PortState {
                emulator,
                incoming: VecDeque::new(),
                outgoing: VecDeque::new(),
                to_host: FaultLine::new(faults, 1),
                to_unit: FaultLine::new(faults, 2),
                delivered: 0,
                dead: false,
            })),
            start: Instant::now(),
            timeout,
        }
    }

    fn lock(&self) -> MutexGuard<'_, PortState> {
        // A panic while holding the lock leaves the emulator usable: take it anyway.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn now(&self) -> Duration {
        self.start.elapsed()
    }

    /// Runs `f` on the emulated unit, brought up to the present.
    pub fn emulator<T>(&self, f: impl FnOnce(&mut Emulator) -> T) -> T {
        let now = self.now();
        let mut s = self.lock();
        s.pump(now);
        f(&mut s.emulator)
    }

    /// What the faults have done so far (both directions).
    pub fn fault_counts(&self) -> FaultCounts {
        let s = self.lock();
        let (a, b) = (s.to_host.counts, s.to_unit.counts);
        FaultCounts {
            dropped: a.dropped + b.dropped,
            corrupted: a.corrupted + b.corrupted,
            delayed: a.delayed + b.delayed,
            disconnected: s.dead,
        }
    }
}

impl Read for EmulatedPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        let deadline = self.now() + self.timeout;
        loop {
            let now = self.now();
            let wake = {
                let mut s = self.lock();
                if s.dead {
                    return Ok(0);
                }
                s.pump(now);
                let mut n = 0;
                while n < buf.len() && s.incoming.front().is_some_and(|&(t, _)| t <= now) {
                    if let Some(limit) = s.to_host.faults.disconnect_after {
                        if s.delivered >= limit {
                            s.dead = true;
                            break;
                        }
                    }
                    if let Some((_, b)) = s.incoming.pop_front() {
                        buf[n] = b;
                        n += 1;
                        s.delivered += 1;
                    }
                }
                if n > 0 {
                    return Ok(n);
                }
                if s.dead {
                    return Ok(0);
                }
                s.next_wake()
            };
            if now >= deadline {
                return Err(io::Error::new(
                    io::ErrorKind::TimedOut,
                    "no byte before the timeout",
                ));
            }
            let until = wake.map_or(deadline, |w| w.clamp(now, deadline));
            std::thread::sleep(
                (until - now).clamp(Duration::from_micros(200), Duration::from_millis(5)),
            );
        }
    }
}

impl Write for EmulatedPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let now = self.now();
        let mut s = self.lock();
        if s.dead {
            return Err(io::Error::new(
                io::ErrorKind::BrokenPipe,
                "the line is dead",
            ));
        }
        let mut last = s.outgoing.back().map_or(now, |&(t, _)| t.max(now));
        for &b in buf {
            let (b, stall) = s.to_unit.pass(b);
            last += stall;
            if let Some(b) = b {
                s.outgoing.push_back((last, b));
            }
        }
        s.pump(now);
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The emulator served on a pseudo-terminal: a driver opens [`PtyServer::path`] as it would
/// open `/dev/ttyUSB0`.
pub struct PtyServer {
    master: serialport::TTYPort,
    // Held open so the terminal survives drivers that open and close it.
    _slave: serialport::TTYPort,
    path: String,
    emulator: Emulator,
    start: Instant,
}

impl std::fmt::Debug for PtyServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PtyServer")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

impl PtyServer {
    /// Opens a pseudo-terminal for `emulator`.
    pub fn open(emulator: Emulator) -> Result<Self> {
        let (master, slave) = serialport::TTYPort::pair().map_err(|source| Error::Port {
            path: "a new pseudo-terminal".into(),
            source,
        })?;
        let path = serialport::SerialPort::name(&slave).unwrap_or_default();
        if path.is_empty() {
            return Err(Error::Io(io::Error::other(
                "the new pseudo-terminal has no device path",
            )));
        }
        Ok(PtyServer {
            master,
            _slave: slave,
            path,
            emulator,
            start: Instant::now(),
        })
    }

    /// The device path a driver opens (`/dev/pts/N`).
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Serves until `stop` is set (checked at least every 20 ms).
    pub fn serve(&mut self, stop: &AtomicBool) -> Result<()> {
        let mut buf = [0u8; 256];
        while !stop.load(Ordering::Relaxed) {
            let now = self.start.elapsed();
            let wait = self
                .emulator
                .next_deadline()
                .map_or(Duration::from_millis(20), |t| t.saturating_sub(now))
                .clamp(Duration::from_millis(1), Duration::from_millis(20));
            serialport::SerialPort::set_timeout(&mut self.master, wait).map_err(|source| {
                Error::Port {
                    path: self.path.clone(),
                    source,
                }
            })?;
            match self.master.read(&mut buf) {
                Ok(n) => {
                    let now = self.start.elapsed();
                    self.emulator.receive(&buf[..n], now);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                            | io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(e.into()),
            }
            self.emulator.advance(self.start.elapsed());
            let out = self.emulator.take_output();
            if !out.is_empty() {
                self.master.write_all(&out)?;
                self.master.flush()?;
            }
        }
        Ok(())
    }
}
