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

/// An error and its sources, outermost first, joined by `: ` (what the command line prints). A
/// source whose text the message already ends with (an error that quotes its cause and also
/// returns it as its source) is not repeated.
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        let text = c.to_string();
        if !s.ends_with(&text) {
            s.push_str(": ");
            s.push_str(&text);
        }
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

    /// An error that quotes its source in its own message prints the source once.
    #[test]
    fn a_quoted_source_is_not_repeated() {
        #[derive(Debug, thiserror::Error)]
        #[error("{path}: {source}")]
        struct Quoting {
            path: String,
            source: std::io::Error,
        }
        let e = Quoting {
            path: "nope.sbt".into(),
            source: std::io::Error::from(std::io::ErrorKind::NotFound),
        };
        assert_eq!(error_chain(&e), "nope.sbt: entity not found");
    }
}
