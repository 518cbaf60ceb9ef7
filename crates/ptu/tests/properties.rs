//! Properties of the protocol: the parser never panics and loses nothing it should keep;
//! commands round-trip through their bytes; every command the emulator executes gets exactly
//! one reply the parser understands.

use std::time::Duration;

use aibr_ptu::protocol::{ControlMode, Execution, Feedback, parse_events};
use aibr_ptu::{Axis, AxisParam, Command, Emulator, EmulatorConfig, Event, ReplyParser};
use proptest::prelude::*;

fn axis() -> impl Strategy<Value = Axis> {
    prop_oneof![Just(Axis::Pan), Just(Axis::Tilt)]
}

fn command() -> impl Strategy<Value = Command> {
    let param = prop::sample::select(AxisParam::ALL.to_vec());
    prop_oneof![
        (axis(), param.clone()).prop_map(|(a, p)| Command::Query(a, p)),
        (axis(), param, -20_000i32..20_000).prop_map(|(a, p, v)| Command::Set(a, p, v)),
        (axis(), any::<i32>()).prop_map(|(a, v)| Command::Set(a, AxisParam::Position, v)),
        Just(Command::Await),
        prop_oneof![Just(Execution::Immediate), Just(Execution::Slaved)]
            .prop_map(Command::SetExecution),
        prop::option::of(axis()).prop_map(Command::Halt),
        Just(Command::QueryLimits),
        any::<bool>().prop_map(Command::SetLimits),
        prop::option::of(axis()).prop_map(Command::Reset),
        Just(Command::QueryFeedback),
        prop_oneof![Just(Feedback::Verbose), Just(Feedback::Terse)].prop_map(Command::SetFeedback),
        Just(Command::QueryEcho),
        any::<bool>().prop_map(Command::SetEcho),
        Just(Command::Version),
        Just(Command::Voltage),
        Just(Command::SaveDefaults),
        Just(Command::RestoreDefaults),
        Just(Command::FactoryDefaults),
        Just(Command::QueryControl),
        prop_oneof![Just(ControlMode::Independent), Just(ControlMode::Velocity)]
            .prop_map(Command::SetControl),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn the_parser_never_panics_and_stays_bounded(chunks in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..300), 0..8)) {
        let mut p = ReplyParser::new();
        for c in &chunks {
            p.push(c);
            while p.next_event().is_some() {}
            prop_assert!(p.pending().len() < aibr_ptu::protocol::MAX_LINE + 2);
        }
    }

    #[test]
    fn splitting_never_changes_the_replies(bytes in prop::collection::vec(prop_oneof![Just(b'*'), Just(b'!'), Just(b'P'), Just(b'\r'), Just(b' '), any::<u8>()], 0..700), cut in any::<prop::sample::Index>()) {
        let events = |chunks: &[&[u8]]| {
            let mut p = ReplyParser::new();
            let mut out = Vec::new();
            for c in chunks {
                p.push(c);
                while let Some(e) = p.next_event() {
                    if !matches!(e, Event::Other(_)) { out.push(e); }
                }
            }
            out
        };
        let (a, b) = bytes.split_at(cut.index(bytes.len() + 1));
        prop_assert_eq!(events(&[&bytes]), events(&[a, b]));
    }

    #[test]
    fn replies_survive_any_split(text in "[ -~]{0,40}", cut in 0usize..60) {
        // A success reply with printable text, split anywhere, parses the same.
        let text = text.replace(['*', '!'], "").trim().to_owned();
        let bytes = format!("* {text}\r\n").into_bytes();
        let cut = cut.min(bytes.len());
        let mut p = ReplyParser::new();
        p.push(&bytes[..cut]);
        let mut events = Vec::new();
        while let Some(e) = p.next_event() { events.push(e); }
        p.push(&bytes[cut..]);
        while let Some(e) = p.next_event() { events.push(e); }
        prop_assert_eq!(events, vec![Event::Ok(text)]);
    }

    #[test]
    fn commands_round_trip(c in command(), lower in any::<bool>()) {
        let mut bytes = c.encode();
        prop_assert_eq!(bytes.pop(), Some(b' '));
        if lower { bytes.make_ascii_lowercase(); }
        prop_assert_eq!(Command::parse(&bytes), Some(c));
    }

    #[test]
    fn every_command_gets_one_understood_reply(cs in prop::collection::vec(command(), 1..20), terse in any::<bool>()) {
        let mut e = Emulator::new(EmulatorConfig::default());
        let mut t = Duration::ZERO;
        e.receive(if terse { b"ED FT " } else { b"ED FV " }, t);
        e.take_output();
        for c in cs {
            // Echo stays off so that every byte out is a reply.
            let c = if c == Command::SetEcho(true) { Command::QueryEcho } else { c };
            e.receive(&c.encode(), t);
            // Let moves, waits and resets finish.
            t += Duration::from_secs(60);
            e.advance(t);
            let (events, rest) = parse_events(&e.take_output());
            prop_assert!(rest.is_empty(), "{c}: left {rest:?}");
            // DF and DR may bring the power-up echo back: the echo of the command is allowed.
            let echo = Event::Other(c.encode());
            let replies: Vec<_> = events.iter().filter(|ev| !matches!(ev, Event::Limit(_)) && **ev != echo).collect();
            prop_assert_eq!(replies.len(), 1, "{} gave {:?}", c, events);
            match replies[0] {
                Event::Ok(text) => prop_assert_eq!(c.is_query(), !text.is_empty(), "{} answered {:?}", c, text),
                Event::Error(_) => {}
                other => prop_assert!(false, "{c} gave {other:?}"),
            }
            e.receive(if terse { b"ED FT " } else { b"ED FV " }, t);
            e.take_output();
        }
    }

    #[test]
    fn the_emulator_never_panics_on_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400)) {
        let mut e = Emulator::new(EmulatorConfig::default());
        e.receive(&bytes, Duration::ZERO);
        e.advance(Duration::from_secs(100));
        let _ = parse_events(&e.take_output());
    }
}
