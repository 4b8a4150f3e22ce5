//! Progress of long operations: the tasks and tables of a build, the image rows of a render, the
//! radii of a Lee diagram. The library reports to a [`Progress`] and draws nothing; the command
//! line draws a bar on a terminal and writes one line per table or step otherwise. [`Silent`]
//! ignores everything.
//!
//! Every method may be called from any thread (a build runs its tasks in a rayon pool).

use std::fmt;

/// What happens to one table of a build, in order: [`UpToDate`](TableStep::UpToDate) alone, or
/// [`Computing`](TableStep::Computing) (when this process computes some of its tasks), then
/// [`Writing`](TableStep::Writing) and [`Written`](TableStep::Written), or
/// [`Waiting`](TableStep::Waiting), or [`Failed`](TableStep::Failed). A table left
/// [`Waiting`](TableStep::Waiting) may still be written at the end of the build, when the tasks
/// of other shards or builds arrived meanwhile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableStep {
    /// The table file is current (same content key): nothing to compute.
    UpToDate,
    /// The first of the `tasks` tasks this process computes for the table begins.
    Computing {
        /// Tasks of the table this process computes.
        tasks: usize,
    },
    /// Every task is done: the table is being assembled and written.
    Writing,
    /// The table file is written.
    Written,
    /// This process's tasks of the table are done; tasks of other shards or builds are missing.
    Waiting,
    /// A task or the assembly of the table failed (the build's error says why).
    Failed,
}

impl fmt::Display for TableStep {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TableStep::UpToDate => f.write_str("up to date"),
            TableStep::Computing { tasks: 1 } => f.write_str("computing 1 task"),
            TableStep::Computing { tasks } => write!(f, "computing {tasks} tasks"),
            TableStep::Writing => f.write_str("writing"),
            TableStep::Written => f.write_str("written"),
            TableStep::Waiting => f.write_str("tasks done here, waiting for other shards' tasks"),
            TableStep::Failed => f.write_str("failed"),
        }
    }
}

/// Where a long operation reports how far it is. Every method does nothing by default.
pub trait Progress: Sync {
    /// `total` units of work described by `what` (e.g. `tasks`, `image rows`) begin.
    fn start(&self, _total: u64, _what: &str) {}
    /// `n` more units are done.
    fn advance(&self, _n: u64) {}
    /// Table `name` of a build reached `step`.
    fn table(&self, _name: &str, _step: TableStep) {}
    /// The work begun by [`start`](Progress::start) is over (done or failed).
    fn finish(&self) {}
}

/// A [`Progress`] that reports nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_read_as_one_line() {
        let line = |s: TableStep| format!("w: {s}");
        assert_eq!(
            line(TableStep::Computing { tasks: 1 }),
            "w: computing 1 task"
        );
        assert_eq!(
            line(TableStep::Computing { tasks: 6 }),
            "w: computing 6 tasks"
        );
        assert_eq!(line(TableStep::UpToDate), "w: up to date");
        assert!(!line(TableStep::Waiting).contains('\n'));
    }
}
