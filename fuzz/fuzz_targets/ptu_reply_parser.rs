//! Fuzzes the PTU-46 reply parser and the emulator's command input with arbitrary bytes.
//!
//! Properties checked: no panic; the parser's buffer stays bounded; every event it gives is
//! well formed (an `Ok` text has no line end, an `Other` is never empty); and splitting the
//! input anywhere gives the same events as feeding it whole.
#![no_main]

use std::time::Duration;

use aibr_ptu::protocol::{Event, MAX_LINE, ReplyParser};
use aibr_ptu::{Emulator, EmulatorConfig};
use libfuzzer_sys::fuzz_target;

fn events(chunks: &[&[u8]]) -> Vec<Event> {
    let mut p = ReplyParser::new();
    let mut out = Vec::new();
    for c in chunks {
        p.push(c);
        while let Some(e) = p.next_event() {
            out.push(e);
        }
        assert!(p.pending().len() <= MAX_LINE + 1);
    }
    out
}

fuzz_target!(|data: &[u8]| {
    let whole = events(&[data]);
    for e in &whole {
        match e {
            Event::Ok(t) => assert!(!t.contains(['\r', '\n'])),
            Event::Other(b) => assert!(!b.is_empty()),
            _ => {}
        }
    }
    if let Some((&cut, rest)) = data.split_first() {
        let cut = (cut as usize).min(rest.len());
        let (a, b) = rest.split_at(cut);
        // Splitting can only change where noise (Other) runs are cut, never the replies.
        let replies = |v: Vec<Event>| -> Vec<Event> {
            v.into_iter().filter(|e| !matches!(e, Event::Other(_))).collect()
        };
        assert_eq!(replies(events(&[rest])), replies(events(&[a, b])));
    }
    let mut unit = Emulator::new(EmulatorConfig::default());
    unit.receive(data, Duration::ZERO);
    unit.advance(Duration::from_secs(120));
    let _ = events(&[&unit.take_output()]);
});
