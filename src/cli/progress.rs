//! Progress bars on stderr (indicatif), shown once a run has taken longer than a second;
//! hidden with `--quiet` or when stderr is not a terminal.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

static QUIET: AtomicBool = AtomicBool::new(false);

/// Steps of a bar per unit of `total` (fractions of a unit show).
const RESOLUTION: f64 = 1000.0;

/// Hides every progress bar from now on (`--quiet`).
pub fn set_quiet(quiet: bool) {
    QUIET.store(quiet, Ordering::Relaxed);
}

/// A progress bar over `0..total`, drawn after the first second.
pub struct Progress {
    bar: ProgressBar,
    start: Instant,
    enabled: bool,
    shown: bool,
}

impl Progress {
    /// A bar labelled `label` that is full at `total`.
    pub fn new(label: &str, total: f64) -> Self {
        let bar = ProgressBar::with_draw_target(
            Some((total * RESOLUTION).max(1.0) as u64),
            ProgressDrawTarget::hidden(),
        );
        if let Ok(style) = ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}%  {elapsed}") {
            bar.set_style(style.progress_chars("#> "));
        }
        bar.set_message(label.to_string());
        Self {
            bar,
            start: Instant::now(),
            enabled: !QUIET.load(Ordering::Relaxed) && std::io::stderr().is_terminal(),
            shown: false,
        }
    }

    /// Progress so far, in units of `total`.
    pub fn update(&mut self, done: f64) {
        if self.enabled && !self.shown && self.start.elapsed() >= Duration::from_secs(1) {
            self.bar.set_draw_target(ProgressDrawTarget::stderr());
            self.shown = true;
        }
        self.bar.set_position((done.max(0.0) * RESOLUTION) as u64);
    }

    /// Progress so far with what is being done now: the bar's label becomes `label: stage`.
    pub fn update_stage(&mut self, label: &str, stage: &str, done: f64) {
        self.bar.set_message(format!("{label}: {stage}"));
        self.update(done);
    }

    /// Ends the bar, leaving it on its line if it was shown.
    pub fn finish(&self) {
        if self.shown {
            // Leaves the bar as it is and ends its line.
            self.bar.abandon();
            eprintln!();
        }
    }
}
