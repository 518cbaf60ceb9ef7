//! The driver against the emulator: in memory and over a pseudo-terminal.

// Test helpers too may stop a test loudly.
#![allow(clippy::unwrap_used)]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use aibr_ptu::protocol::Bound;
use aibr_ptu::{
    Axis, DeviceError, EmulatedPort, Emulator, EmulatorConfig, Error, Ptu, PtuOptions, PtyServer,
    Radians, SerialPtu,
};

fn fast_options() -> PtuOptions {
    PtuOptions {
        reply_timeout: Duration::from_millis(300),
        move_margin: Duration::from_millis(500),
        reset_timeout: Duration::from_secs(5),
        quiet: Duration::from_millis(30),
        retries: 3,
        settle_gap: Duration::from_millis(5),
    }
}

fn unit() -> Emulator {
    Emulator::new(EmulatorConfig::default().faster(50.0))
}

fn connect() -> (Ptu<EmulatedPort>, EmulatedPort) {
    let port = EmulatedPort::new(unit(), Duration::from_millis(5));
    let handle = port.clone();
    (Ptu::connect(port, fast_options()).unwrap(), handle)
}

#[test]
fn connect_reads_the_unit() {
    let (ptu, _) = connect();
    let info = ptu.info();
    assert!(info.echo_was_on, "a unit powers up echoing");
    assert_eq!(info.pan.resolution_arcsec, 185.1428);
    assert_eq!((info.pan.min, info.pan.max), (-3090, 3090));
    assert_eq!((info.tilt.min, info.tilt.max), (-907, 604));
    // The emulated unit is 50 times faster than a PTU-46 (31 steps/s at the least).
    assert_eq!(info.pan.lower_speed, 31 * 50);
    assert!(info.limits_enabled);
    assert!(
        info.firmware.contains("Pan-Tilt Controller"),
        "{}",
        info.firmware
    );
    assert_eq!(ptu.stats().retries, 0);
}

#[test]
fn resolution_is_queried_not_assumed() {
    // A microstepping unit: a quarter of the PTU-46 step.
    let mut cfg = EmulatorConfig::default().faster(50.0);
    cfg.pan.resolution_arcsec = 46.2857;
    cfg.pan.soft_min = -12360;
    cfg.pan.soft_max = 12360;
    let port = EmulatedPort::new(Emulator::new(cfg), Duration::from_millis(5));
    let handle = port.clone();
    let mut ptu = Ptu::connect(port, fast_options()).unwrap();
    let reached = ptu.move_to(Axis::Pan, Radians::from_degrees(90.0)).unwrap();
    let steps = handle.emulator(|e| e.position(Axis::Pan));
    assert_eq!(steps, (90.0 * 3600.0 / 46.2857_f64).round() as i32);
    assert!((reached.degrees() - 90.0).abs() <= 46.2857 / 3600.0 / 2.0 + 1e-9);
}

#[test]
fn moves_absolute_and_relative() {
    let (mut ptu, unit) = connect();
    assert_eq!(ptu.move_to_steps(Axis::Pan, 1500).unwrap(), 1500);
    assert_eq!(unit.emulator(|e| e.position(Axis::Pan)), 1500);
    let r = ptu
        .move_by(Axis::Pan, Radians::from_degrees(-10.0))
        .unwrap();
    let expected = 1500 - (10.0 * 3600.0 / 185.1428_f64).round() as i32;
    assert_eq!(unit.emulator(|e| e.position(Axis::Pan)), expected);
    assert!((r.0 - ptu.info().pan.radians(expected).0).abs() < 1e-12);
    assert_eq!(ptu.position_steps(Axis::Pan).unwrap(), expected);
    assert_eq!(ptu.move_to_steps(Axis::Tilt, -300).unwrap(), -300);
    assert_eq!(unit.emulator(|e| e.position(Axis::Tilt)), -300);
}

#[test]
fn device_errors_are_typed() {
    let (mut ptu, _) = connect();
    match ptu.move_to_steps(Axis::Pan, 3200) {
        Err(Error::Device {
            error:
                DeviceError::PositionLimit {
                    axis: Axis::Pan,
                    bound: Bound::Max,
                    limit: 3090,
                },
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    match ptu.set_speed(Axis::Pan, 1_000_000) {
        Err(Error::Device {
            error:
                DeviceError::SpeedTooHigh {
                    axis: Axis::Pan,
                    max,
                },
            ..
        }) => {
            assert_eq!(max, ptu.info().pan.upper_speed)
        }
        other => panic!("{other:?}"),
    }
    match ptu.set_speed(Axis::Pan, 10) {
        Err(Error::Device {
            error: DeviceError::SpeedTooLow { min: 1550 },
            ..
        }) => {}
        other => panic!("{other:?}"),
    }
    // The error left the driver in step.
    assert_eq!(ptu.move_to_steps(Axis::Pan, 100).unwrap(), 100);
}

#[test]
fn limits_off_reach_the_hard_stop() {
    let (mut ptu, unit) = connect();
    assert!(!ptu.set_limits(false).unwrap());
    assert_eq!(ptu.move_to_steps(Axis::Pan, 3200).unwrap(), 3200);
    match ptu.move_to_steps(Axis::Pan, 5000) {
        Err(Error::MoveIncomplete {
            axis: Axis::Pan,
            target: 5000,
            reached,
            limit_hit: true,
        }) => {
            assert_eq!(reached, 3250);
            assert_eq!(unit.emulator(|e| e.position(Axis::Pan)), 3250);
        }
        other => panic!("{other:?}"),
    }
    assert!(ptu.set_limits(true).unwrap());
}

#[test]
fn reset_reports_its_limit_hits() {
    let (mut ptu, unit) = connect();
    ptu.move_to_steps(Axis::Pan, 2000).unwrap();
    let hits = ptu.reset(None).unwrap();
    assert_eq!(hits, vec![Axis::Tilt, Axis::Tilt, Axis::Pan, Axis::Pan]);
    assert_eq!(unit.emulator(|e| e.position(Axis::Pan)), 0);
    assert_eq!(ptu.position_steps(Axis::Pan).unwrap(), 0);
    assert_eq!(
        ptu.reset(Some(Axis::Pan)).unwrap(),
        vec![Axis::Pan, Axis::Pan]
    );
}

#[test]
fn halt_stops_the_axis() {
    let (mut ptu, unit) = connect();
    let slowest = ptu.info().pan.lower_speed;
    ptu.set_speed(Axis::Pan, slowest).unwrap();
    ptu.command(
        aibr_ptu::Command::Set(Axis::Pan, aibr_ptu::AxisParam::Position, 3000),
        Duration::from_millis(300),
    )
    .unwrap();
    std::thread::sleep(Duration::from_millis(50));
    ptu.halt(Some(Axis::Pan)).unwrap();
    let stopped = unit.emulator(|e| e.position(Axis::Pan));
    assert!(stopped > 0 && stopped < 3000, "{stopped}");
    assert!(!unit.emulator(|e| e.moving(Axis::Pan)));
    assert_eq!(ptu.position_steps(Axis::Pan).unwrap(), stopped);
}

#[test]
fn recovers_when_the_unit_is_power_cycled() {
    let (mut ptu, unit) = connect();
    ptu.move_to_steps(Axis::Pan, 700).unwrap();
    // Power-up defaults come back: echo on, verbose feedback (and two stray replies).
    unit.emulator(|e| {
        let now = e.now();
        e.receive(b"EE FV ", now)
    });
    assert_eq!(ptu.position_steps(Axis::Pan).unwrap(), 700);
    assert_eq!(ptu.move_to_steps(Axis::Pan, -700).unwrap(), -700);
    assert!(ptu.stats().resyncs >= 1);
}

#[test]
fn a_dead_line_is_an_error_not_a_hang() {
    let port = EmulatedPort::with_faults(
        unit(),
        Duration::from_millis(5),
        aibr_ptu::Faults {
            disconnect_after: Some(0),
            ..Default::default()
        },
    );
    let t = Instant::now();
    match Ptu::connect(port, fast_options()) {
        Err(Error::Disconnected) => {}
        other => panic!("{other:?}"),
    }
    assert!(t.elapsed() < Duration::from_secs(2));
}

#[test]
fn a_silent_unit_times_out() {
    #[derive(Debug)]
    struct Silent;
    impl std::io::Read for Silent {
        fn read(&mut self, _: &mut [u8]) -> std::io::Result<usize> {
            std::thread::sleep(Duration::from_millis(5));
            Err(std::io::ErrorKind::TimedOut.into())
        }
    }
    impl std::io::Write for Silent {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let options = PtuOptions {
        retries: 1,
        ..fast_options()
    };
    let t = Instant::now();
    let r = Ptu::connect(Silent, options);
    assert!(
        matches!(r, Err(Error::Timeout { .. }) | Err(Error::OutOfSync(_))),
        "{r:?}"
    );
    assert!(
        t.elapsed() <= options.command_bound(options.reply_timeout),
        "{:?}",
        t.elapsed()
    );
}

#[test]
fn over_a_pseudo_terminal() {
    let mut server = PtyServer::open(unit()).unwrap();
    let path = server.path().to_owned();
    assert!(path.starts_with("/dev/"), "{path}");
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let serving = std::thread::spawn(move || server.serve(&s));

    let options = PtuOptions {
        settle_gap: Duration::from_millis(20),
        ..fast_options()
    };
    let mut ptu = SerialPtu::open(&path, 9600, options).unwrap();
    assert!(ptu.info().echo_was_on);
    assert_eq!(ptu.info().pan.resolution_arcsec, 185.1428);
    let r = ptu.move_to(Axis::Pan, Radians::from_degrees(45.0)).unwrap();
    assert!((r.degrees() - 45.0).abs() < 0.03);
    assert!(matches!(
        ptu.move_to_steps(Axis::Pan, -4000),
        Err(Error::Device {
            error: DeviceError::PositionLimit {
                bound: Bound::Min,
                limit: -3090,
                ..
            },
            ..
        })
    ));
    assert_eq!(
        ptu.reset(Some(Axis::Pan)).unwrap(),
        vec![Axis::Pan, Axis::Pan]
    );
    assert_eq!(ptu.position_steps(Axis::Pan).unwrap(), 0);
    drop(ptu);

    // The terminal outlives a driver: a second one connects (echo is off by now).
    let mut again = SerialPtu::open(&path, 9600, options).unwrap();
    assert!(!again.info().echo_was_on);
    assert_eq!(again.move_to_steps(Axis::Pan, 250).unwrap(), 250);
    drop(again);

    stop.store(true, Ordering::Relaxed);
    serving.join().unwrap().unwrap();
}

#[test]
fn opening_a_missing_device_names_it() {
    match SerialPtu::open("/dev/aibr-no-such-port", 9600, fast_options()) {
        Err(e @ Error::Port { .. }) => assert!(e.to_string().contains("/dev/aibr-no-such-port")),
        other => panic!("{other:?}"),
    }
}

#[test]
fn connects_to_a_unit_left_terse_over_a_noisy_line() {
    // An earlier session left the unit terse with echo off; the line garbles the first bytes
    // the driver sends, so connect must resynchronise before it knows the mode.
    let mut unit = unit();
    unit.receive(b"ED FT ", Duration::ZERO);
    unit.take_output();
    let mut resyncs = 0;
    for seed in 0..16 {
        let port = EmulatedPort::with_faults(
            unit.clone(),
            Duration::from_millis(5),
            aibr_ptu::Faults {
                seed,
                corrupt: 0.01,
                ..Default::default()
            },
        );
        let mut ptu = Ptu::connect(port, fast_options())
            .unwrap_or_else(|e| panic!("seed {seed}: connect: {e}"));
        assert!(!ptu.info().echo_was_on);
        assert_eq!(ptu.info().pan.resolution_arcsec, 185.1428);
        let r = ptu.move_to_steps(Axis::Pan, 321);
        assert_eq!(
            r.unwrap_or_else(|e| panic!("seed {seed}: move: {e} {:?}", ptu.stats())),
            321
        );
        resyncs += ptu.stats().resyncs;
    }
    assert!(
        resyncs > 0,
        "the line should have needed a resynchronisation"
    );
}
