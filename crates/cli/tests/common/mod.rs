//! What the `aibr` binary's end-to-end tests share.

// Each test file uses its own part of this module.
#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// What a test returns: any error fails it, with its message.
pub(crate) type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The `aibr` binary under test.
pub(crate) fn aibr() -> Command {
    Command::new(env!("CARGO_BIN_EXE_aibr"))
}

/// A fresh path in the temporary folder for this test process (removed if it exists, not
/// created).
pub(crate) fn temp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("aibr-cli-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// What the command printed, stdout then stderr.
pub(crate) fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// Fails the test, with what the command printed, unless it succeeded.
#[track_caller]
pub(crate) fn assert_success(out: &Output) {
    assert!(out.status.success(), "{}", text(out));
}
