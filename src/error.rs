//! Error pieces shared by every layer: an I/O failure with what was being done and where, and
//! the one-line rendering of an error with its causes.

use std::path::{Path, PathBuf};

/// An I/O failure, with the action (e.g. `writing`) and the path it concerned.
#[derive(Debug, thiserror::Error)]
#[error("{action} {}", path.display())]
pub struct IoError {
    pub action: &'static str,
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

impl IoError {
    /// The conversion of a `std::io::Error` while doing `action` on `path`, for `map_err`.
    pub fn doing(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| IoError {
            action,
            path,
            source,
        }
    }
}

/// An error and its sources, outermost first, joined by `: ` (the form `{:#}` gives in the
/// command line).
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(": ");
        s.push_str(&c.to_string());
        cause = c.source();
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chain_names_action_path_and_cause() {
        let e =
            IoError::doing("writing", Path::new("out/t.sbt"))(std::io::Error::other("disk full"));
        assert_eq!(error_chain(&e), "writing out/t.sbt: disk full");
    }
}
