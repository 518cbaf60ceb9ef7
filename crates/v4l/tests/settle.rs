//! Flushing stale frames by timestamp, averaging, and streams that fail.

// Test helpers too may stop a test loudly.
#![allow(clippy::unwrap_used)]

use std::time::{Duration, Instant};

use aibr_v4l::{
    Error, FrameStream, PixelFormat, RawFrame, SettlePolicy, StreamFrame, TimestampSource,
    capture_settled,
};

/// A 30 fps stream of grey frames: value `stale` for frames exposed before `switch`, then
/// `fresh` plus seeded noise of ±`noise`; `corrupt_every` makes every n-th frame short;
/// after `stop_after` frames it delivers nothing.
struct Synthetic {
    t: Duration,
    seq: u32,
    switch: Duration,
    stale: u8,
    fresh: u8,
    noise: u8,
    source: TimestampSource,
    corrupt_every: u32,
    stop_after: u32,
    buf: Vec<u8>,
}

impl Synthetic {
    fn new(switch_ms: u64) -> Self {
        Synthetic {
            t: Duration::from_secs(100),
            seq: 0,
            switch: Duration::from_millis(switch_ms),
            stale: 10,
            fresh: 200,
            noise: 0,
            source: TimestampSource::StartOfExposure,
            corrupt_every: 0,
            stop_after: u32::MAX,
            buf: Vec::new(),
        }
    }
}

impl FrameStream for Synthetic {
    fn next_frame(&mut self, timeout: Duration) -> aibr_v4l::Result<Option<StreamFrame<'_>>> {
        if self.seq >= self.stop_after {
            std::thread::sleep(timeout.min(Duration::from_millis(20)));
            return Ok(None);
        }
        self.t += Duration::from_micros(33_333);
        self.seq += 1;
        // The scene changes when the exposure starts after the switch.
        let start = match self.source {
            TimestampSource::StartOfExposure => self.t,
            TimestampSource::EndOfFrame => self.t - Duration::from_micros(33_333),
        };
        let base = if start >= self.switch {
            self.fresh
        } else {
            self.stale
        };
        let (w, h) = (8usize, 4usize);
        self.buf.clear();
        for i in 0..w * h {
            let k = (self.seq as usize * 7919 + i * 104_729) % (2 * self.noise as usize + 1);
            self.buf
                .push((base as i32 + k as i32 - self.noise as i32).clamp(0, 255) as u8);
        }
        let short = self.corrupt_every > 0 && self.seq % self.corrupt_every == 0;
        let data = if short { &self.buf[..5] } else { &self.buf[..] };
        Ok(Some(StreamFrame {
            raw: RawFrame {
                format: PixelFormat::Grey,
                width: w as u32,
                height: h as u32,
                stride: 0,
                data,
            },
            timestamp: self.t,
            source: self.source,
            sequence: self.seq,
        }))
    }
}

#[test]
fn stale_frames_never_reach_the_image() {
    // The turntable stopped at 100.5 s; frames from before then show the old position.
    let motion_end = Duration::from_millis(100_500);
    for source in [
        TimestampSource::StartOfExposure,
        TimestampSource::EndOfFrame,
    ] {
        let mut s = Synthetic::new(100_500);
        s.source = source;
        let policy = SettlePolicy {
            settle: Duration::ZERO,
            frame_interval: Duration::from_micros(33_334),
            frames: 3,
            ..SettlePolicy::default()
        };
        let shot = capture_settled(&mut s, motion_end, &policy).unwrap();
        assert!(
            shot.image.as_raw().iter().all(|&v| v == 200),
            "{source:?}: a stale frame was used"
        );
        assert_eq!(shot.averaged, 3);
        assert!(shot.stale >= 14, "{source:?}: {}", shot.stale);
        assert!(shot.first_timestamp >= motion_end);
    }
}

#[test]
fn the_settle_time_is_waited_out() {
    let mut s = Synthetic::new(0);
    let motion_end = Duration::from_millis(100_500);
    let policy = SettlePolicy {
        settle: Duration::from_millis(200),
        ..SettlePolicy::default()
    };
    let shot = capture_settled(&mut s, motion_end, &policy).unwrap();
    assert!(shot.first_timestamp >= Duration::from_millis(100_700));
    assert_eq!(shot.stale, 21);
}

#[test]
fn averaging_reduces_noise() {
    let std_of = |frames: u32| {
        let mut s = Synthetic::new(0);
        s.noise = 20;
        let policy = SettlePolicy {
            settle: Duration::ZERO,
            frames,
            ..SettlePolicy::default()
        };
        let img = capture_settled(&mut s, Duration::ZERO, &policy)
            .unwrap()
            .image;
        let v: Vec<f64> = img.as_raw().iter().map(|&x| x as f64).collect();
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
    };
    let (one, sixteen) = (std_of(1), std_of(16));
    assert!(one > 8.0, "{one}");
    assert!(sixteen < one / 2.5, "1 frame: {one}, 16 frames: {sixteen}");
}

#[test]
fn corrupt_frames_are_skipped() {
    let mut s = Synthetic::new(0);
    s.corrupt_every = 2;
    let policy = SettlePolicy {
        settle: Duration::ZERO,
        frames: 4,
        ..SettlePolicy::default()
    };
    let shot = capture_settled(&mut s, Duration::ZERO, &policy).unwrap();
    assert_eq!((shot.averaged, shot.corrupt), (4, 3));
}

#[test]
fn a_stream_that_stops_is_a_timeout_not_a_hang() {
    let mut s = Synthetic::new(100_500);
    s.stop_after = 20;
    let policy = SettlePolicy {
        settle: Duration::ZERO,
        frames: 8,
        timeout: Duration::from_millis(300),
        ..SettlePolicy::default()
    };
    let t = Instant::now();
    match capture_settled(&mut s, Duration::from_millis(100_500), &policy) {
        Err(Error::Timeout {
            wanted: 8,
            fresh,
            stale,
            ..
        }) => {
            assert_eq!(fresh + stale, 20);
            assert!(fresh < 8);
        }
        other => panic!("{other:?}"),
    }
    assert!(
        t.elapsed() < Duration::from_millis(600),
        "{:?}",
        t.elapsed()
    );
}

#[test]
fn the_monotonic_clock_moves_forward() {
    let a = aibr_v4l::monotonic_now();
    std::thread::sleep(Duration::from_millis(5));
    let b = aibr_v4l::monotonic_now();
    assert!(b > a && b - a >= Duration::from_millis(5));
}
