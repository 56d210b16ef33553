//! A progress bar for long experiments: indicatif on stderr, drawn only when stderr is a
//! terminal (CI logs and redirected runs stay clean), never on stdout.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A counting progress bar over a known number of steps.
///
/// Cheap to clone (clones share the bar), `Sync`, so rayon workers may call
/// [`Progress::inc`] directly. Dropping the last clone leaves the bar as it was; call
/// [`Progress::finish`] to print the final state.
#[derive(Clone, Debug)]
pub struct Progress {
    bar: ProgressBar,
}

impl Progress {
    /// A bar of `total` steps labelled `label` (e.g. `"matchers: sim pairs"`), on stderr, or a
    /// hidden one when stderr is not a terminal.
    pub fn new(label: &str, total: u64) -> Self {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        let style = ProgressStyle::with_template(
            "{prefix:.bold} [{bar:40.cyan/blue}] {pos}/{len} {elapsed_precise} (eta {eta}) {msg}",
        )
        .map(|s| s.progress_chars("=> "))
        .unwrap_or_else(|_| ProgressStyle::default_bar());
        bar.set_style(style);
        bar.set_prefix(label.to_owned());
        Self { bar }
    }

    /// Advances by `n` steps.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
    }

    /// Shows `msg` after the counter (e.g. the current condition).
    pub fn message(&self, msg: impl Into<String>) {
        self.bar.set_message(msg.into());
    }

    /// Marks the bar finished (it stays on screen).
    pub fn finish(&self) {
        self.bar.finish();
    }
}
