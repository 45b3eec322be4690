//! Progress bars on stderr (indicatif) for the library's [`Progress`] reports: hidden when
//! stderr is not a terminal (indicatif's stderr target checks) or when the user asked for
//! quiet.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::progress::Progress;

/// A bar on stderr counting `unit`s; each phase the library starts resets it.
pub struct Bar(pub ProgressBar);

/// A bar over `len` items with a `what` label, drawn on stderr unless `quiet`.
pub fn bar(len: u64, what: &str, unit: &str, quiet: bool) -> Bar {
    if quiet {
        return Bar(ProgressBar::hidden());
    }
    let pb = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    let template = format!("{{msg:>14}} [{{bar:40}}] {{pos}}/{{len}} {unit} ({{eta}})");
    pb.set_style(
        ProgressStyle::with_template(&template)
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    Bar(pb)
}

impl Bar {
    /// Removes the bar from the terminal.
    pub fn finish(&self) {
        self.0.finish_and_clear();
    }
}

impl Progress for Bar {
    fn start(&self, phase: &str, total: u64) {
        self.0.set_length(total);
        self.0.set_position(0);
        self.0.reset_eta();
        self.0.set_message(phase.to_string());
    }

    fn inc(&self, n: u64) {
        self.0.inc(n);
    }
}
