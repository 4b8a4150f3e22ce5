//! A terminal progress bar for the library's long consumers ([`scatterbake::consumers::Progress`]):
//! drawn on stderr, hidden when stderr is not a terminal (pipes, CI logs, tests).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// Bar layout of a consumer.
const TEMPLATE: &str = "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} {msg}, eta {eta}";

/// A progress bar named after the command (e.g. `render`).
pub struct TerminalProgress {
    bar: ProgressBar,
}

impl TerminalProgress {
    pub fn new(command: &str) -> Self {
        let bar = ProgressBar::new(0);
        if !std::io::stderr().is_terminal() {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
        bar.set_style(ProgressStyle::with_template(TEMPLATE).expect("valid template"));
        bar.set_prefix(command.to_string());
        TerminalProgress { bar }
    }
}

impl scatterbake::consumers::Progress for TerminalProgress {
    fn start(&self, total: u64, what: &str) {
        self.bar.set_length(total);
        self.bar.set_position(0);
        self.bar.set_message(what.to_string());
    }
    fn advance(&self, n: u64) {
        self.bar.inc(n);
    }
}

impl Drop for TerminalProgress {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
