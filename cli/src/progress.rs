//! How the command line shows the library's progress reports
//! ([`scatterbake::progress::Progress`]), always on stderr: on a terminal, a bar whose message
//! names what is running (the tables being computed and those being written), with each table's
//! outcome printed above it; otherwise (logs, pipes, job arrays) one line per table or step;
//! nothing when quiet.

use indicatif::{ProgressBar, ProgressStyle};
use scatterbake::progress::{Progress, TableStep};
use std::io::IsTerminal;
use std::sync::Mutex;

/// Bar layout.
const TEMPLATE: &str = "{prefix} [{elapsed_precise}, eta {eta}] {bar:30} {pos}/{len} {msg}";
/// Tables named per group (computing, writing) in the bar's message; the others are counted.
const NAMED: usize = 3;

/// Where the reports go.
enum Output {
    /// A bar on the terminal.
    Bar(ProgressBar),
    /// One line per table or step.
    Lines,
    /// Nothing.
    Quiet,
}

/// What has been reported so far.
#[derive(Debug, Default)]
struct State {
    /// Units of the current work (`tasks`, `image rows`).
    what: String,
    total: u64,
    done: u64,
    /// Tables computing or being written, in the order they began.
    running: Vec<(String, TableStep)>,
}

impl State {
    /// Note that table `name` reached `step`.
    fn step(&mut self, name: &str, step: TableStep) {
        let at = self.running.iter().position(|(n, _)| n == name);
        match (step, at) {
            (TableStep::Computing { .. } | TableStep::Writing, Some(i)) => self.running[i].1 = step,
            (TableStep::Computing { .. } | TableStep::Writing, None) => {
                self.running.push((name.to_string(), step));
            }
            (_, Some(i)) => {
                self.running.remove(i);
            }
            (_, None) => {}
        }
    }

    /// The bar's message: the units, then the tables computing and those being written.
    fn message(&self) -> String {
        let group = |verb: &str, writing: bool| {
            let names: Vec<&str> = self
                .running
                .iter()
                .filter(|(_, s)| (*s == TableStep::Writing) == writing)
                .map(|(n, _)| n.as_str())
                .collect();
            match names.len() {
                0 => None,
                n if n <= NAMED => Some(format!(
                    "{verb} {}",
                    crate::display::text(&names.join(", "))
                )),
                n => Some(format!(
                    "{verb} {} and {} more",
                    crate::display::text(&names[..NAMED].join(", ")),
                    n - NAMED
                )),
            }
        };
        let running: Vec<String> = [group("computing", false), group("writing", true)]
            .into_iter()
            .flatten()
            .collect();
        if running.is_empty() {
            self.what.clone()
        } else {
            format!("{}: {}", self.what, running.join("; "))
        }
    }

    /// The line reporting table `name` at `step`, with the work done so far after an outcome.
    fn line(&self, command: &str, name: &str, step: TableStep) -> String {
        let name = crate::display::text(name);
        let outcome = matches!(
            step,
            TableStep::Written | TableStep::Waiting | TableStep::Failed
        );
        if outcome && self.total > 0 {
            format!(
                "{command}: {name}: {step} [{}/{} {}]",
                self.done, self.total, self.what
            )
        } else {
            format!("{command}: {name}: {step}")
        }
    }
}

/// Progress of one command (e.g. `build`, `render`) on stderr.
pub struct TerminalProgress {
    command: String,
    output: Output,
    state: Mutex<State>,
}

impl TerminalProgress {
    /// A bar when stderr is a terminal, lines otherwise, nothing when `quiet`.
    pub fn new(command: &str, quiet: bool) -> Self {
        let output = if quiet {
            Output::Quiet
        } else if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(0);
            bar.set_style(ProgressStyle::with_template(TEMPLATE).expect("valid template"));
            bar.set_prefix(command.to_string());
            Output::Bar(bar)
        } else {
            Output::Lines
        };
        TerminalProgress {
            command: command.to_string(),
            output,
            state: Mutex::default(),
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl Progress for TerminalProgress {
    fn start(&self, total: u64, what: &str) {
        let mut state = self.state();
        *state = State {
            what: what.to_string(),
            total,
            ..State::default()
        };
        match &self.output {
            Output::Bar(bar) => {
                bar.set_length(total);
                bar.set_position(0);
                bar.set_message(state.message());
            }
            Output::Lines if total > 0 => eprintln!("{}: {total} {what}", self.command),
            Output::Lines | Output::Quiet => {}
        }
    }

    fn advance(&self, n: u64) {
        self.state().done += n;
        if let Output::Bar(bar) = &self.output {
            bar.inc(n);
        }
    }

    fn table(&self, name: &str, step: TableStep) {
        let mut state = self.state();
        state.step(name, step);
        match &self.output {
            Output::Bar(bar) => {
                if !matches!(step, TableStep::Computing { .. } | TableStep::Writing) {
                    bar.println(state.line(&self.command, name, step));
                }
                bar.set_message(state.message());
            }
            Output::Lines => eprintln!("{}", state.line(&self.command, name, step)),
            Output::Quiet => {}
        }
    }

    fn finish(&self) {
        if let Output::Bar(bar) = &self.output {
            bar.finish_and_clear();
        }
    }
}

impl Drop for TerminalProgress {
    fn drop(&mut self) {
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The message names what runs now: a table being written while others compute is shown
    /// as writing, the others as computing, and finished tables leave the message.
    #[test]
    fn message_names_the_tables_computing_and_writing() {
        let mut s = State {
            what: "tasks".into(),
            total: 12,
            ..State::default()
        };
        assert_eq!(s.message(), "tasks");
        s.step("a", TableStep::Computing { tasks: 4 });
        s.step("b", TableStep::Computing { tasks: 4 });
        s.step("c", TableStep::Writing);
        assert_eq!(s.message(), "tasks: computing a, b; writing c");
        s.step("a", TableStep::Writing);
        assert_eq!(s.message(), "tasks: computing b; writing a, c");
        s.step("c", TableStep::Written);
        s.step("a", TableStep::Written);
        assert_eq!(s.message(), "tasks: computing b");
        s.step("b", TableStep::Waiting);
        s.step("u", TableStep::UpToDate);
        assert_eq!(s.message(), "tasks");
        for n in ["d", "e", "f", "g", "h"] {
            s.step(n, TableStep::Computing { tasks: 1 });
        }
        assert_eq!(s.message(), "tasks: computing d, e, f and 2 more");
    }

    #[test]
    fn outcome_lines_state_the_work_done() {
        let mut s = State {
            what: "tasks".into(),
            total: 12,
            ..State::default()
        };
        s.done = 5;
        let computing = TableStep::Computing { tasks: 4 };
        assert_eq!(
            s.line("build", "w", computing),
            "build: w: computing 4 tasks"
        );
        assert_eq!(
            s.line("build", "w", TableStep::Written),
            "build: w: written [5/12 tasks]"
        );
        assert_eq!(
            s.line("build", "v", TableStep::UpToDate),
            "build: v: up to date"
        );
    }
}
