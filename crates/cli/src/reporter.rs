//! Progress of long work, on a terminal or in a log.

use std::time::{Duration, Instant};

use indicatif::ProgressBar;

/// How often a run whose standard error is not a terminal writes a progress line.
const LOG_EVERY: Duration = Duration::from_secs(30);

/// Reports progress messages. On a terminal they go to `bar` (a spinner or a bar, styled by
/// its maker). Where standard error is not a terminal (a run in the background writing a log)
/// the bar draws nothing, so they are written as lines, `[elapsed] message` (with the bar's
/// position when it has a length): the first, then at most one every [`LOG_EVERY`], so that
/// an hour's evaluation leaves a log of how far it got without a line for every step.
pub(crate) struct Reporter {
    bar: ProgressBar,
    /// Whether the bar draws nothing (standard error is not a terminal), asked once: it does
    /// not change during a run, and asking is a system call.
    hidden: bool,
    start: Instant,
    every: Duration,
    last: Option<Instant>,
}

impl Reporter {
    /// Reports through `bar`, or in lines every [`LOG_EVERY`] when it is hidden.
    pub(crate) fn new(bar: ProgressBar) -> Self {
        Reporter::every(bar, LOG_EVERY)
    }

    /// Reports through `bar`, or in lines at most every `every` when it is hidden.
    pub(crate) fn every(bar: ProgressBar, every: Duration) -> Self {
        Reporter {
            hidden: bar.is_hidden(),
            bar,
            start: Instant::now(),
            every,
            last: None,
        }
    }

    /// The bar, for its position.
    pub(crate) fn bar(&self) -> &ProgressBar {
        &self.bar
    }

    /// Shows `message`.
    pub(crate) fn message(&mut self, message: String) {
        if self.hidden {
            if let Some(line) = self.line(&message, Instant::now()) {
                eprintln!("{line}");
            }
        } else {
            self.bar.set_message(message);
        }
    }

    /// The log line for `message` at `now`, or `None` within [`Reporter::every`] of the
    /// last.
    fn line(&mut self, message: &str, now: Instant) -> Option<String> {
        if self
            .last
            .is_some_and(|last| now.saturating_duration_since(last) < self.every)
        {
            return None;
        }
        self.last = Some(now);
        let seconds = now.saturating_duration_since(self.start).as_secs();
        let elapsed = format!(
            "{}:{:02}:{:02}",
            seconds / 3600,
            seconds / 60 % 60,
            seconds % 60
        );
        Some(match self.bar.length() {
            Some(length) => format!("[{elapsed}] {}/{length} {message}", self.bar.position()),
            None => format!("[{elapsed}] {message}"),
        })
    }

    /// Clears the bar from the terminal.
    pub(crate) fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_log_gets_the_first_line_then_one_per_interval() {
        let mut r = Reporter::every(ProgressBar::hidden(), Duration::from_secs(30));
        let t0 = r.start;
        let at = |s: u64| t0 + Duration::from_secs(s);
        assert_eq!(r.line("turn 0", at(0)).as_deref(), Some("[0:00:00] turn 0"));
        assert_eq!(r.line("step", at(29)), None);
        assert_eq!(
            r.line("turn 2.5", at(3725)).as_deref(),
            Some("[1:02:05] turn 2.5")
        );
        assert_eq!(r.line("step", at(3740)), None);
        // A bar with a length gives its position.
        let mut r = Reporter::every(ProgressBar::hidden(), Duration::ZERO);
        r.bar.set_length(48);
        r.bar.set_position(13);
        let line = r.line("captured at 12.50 deg", r.start);
        assert_eq!(
            line.as_deref(),
            Some("[0:00:00] 13/48 captured at 12.50 deg")
        );
    }
}
