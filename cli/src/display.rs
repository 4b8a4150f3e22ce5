//! Text from outside the program (file names, table names, header strings, error messages that
//! quote them) made safe to print on a terminal: every command prints paths and names through
//! these functions.

use std::path::Path;

/// Whether `c` is shown escaped: control characters (escape sequences, carriage returns,
/// newlines, tabs) and the bidirectional overrides and isolates, which reorder what follows.
fn is_unsafe(c: char) -> bool {
    c.is_control()
        || ('\u{202a}'..='\u{202e}').contains(&c)
        || ('\u{2066}'..='\u{2069}').contains(&c)
}

/// `s` with every unsafe character shown as a Rust escape, e.g. `\n`, `\u{1b}`. Idempotent: the
/// escapes contain no unsafe character.
pub fn text(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if is_unsafe(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

/// A path as [`text`] shows it.
pub fn path(p: &Path) -> String {
    text(&p.to_string_lossy())
}

/// A message whose lines are meant as lines (an error listing several failures): each line as
/// [`text`] shows it, the line breaks kept.
pub fn lines(s: &str) -> String {
    s.split('\n').map(text).collect::<Vec<_>>().join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_characters_and_overrides_are_escaped_once() {
        let raw = "a\nb\u{1b}[31mc\rd\te\u{202e}f µ β.sbt";
        let shown = text(raw);
        assert_eq!(shown, "a\\nb\\u{1b}[31mc\\rd\\te\\u{202e}f µ β.sbt");
        assert_eq!(text(&shown), shown);
        assert_eq!(path(Path::new("x\ny.sbt")), "x\\ny.sbt");
        assert_eq!(lines("one\u{7}\ntwo"), "one\\u{7}\ntwo");
    }
}
