//! Every repository path cited in README.md, ARCHITECTURE.md, docs/**/*.md and in the comments
//! of the Rust sources exists. A path is cited as `src/…`, `cli/…`, `examples/…`, `tests/…`,
//! `manifests/…`, `python/…`, `c/…` (and the other top-level directories below), as a relative
//! Markdown link, or as a bare `name.rs` after a cited source directory (module tables of the
//! docs): `name.rs` is looked up in the directory of the last `…src/…` path cited before it in the
//! same document. A path followed by `*`, `<` or `{` is a pattern and is not checked.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Top-level directories whose paths are checked.
const TOP_DIRS: [&str; 16] = [
    "src/",
    "cli/",
    "capi/",
    "c/",
    "python/",
    "examples/",
    "tests/",
    "benches/",
    "manifests/",
    "docs/",
    "deploy/",
    "fuzz/",
    "assets/",
    "table-format/",
    ".ci/",
    "build.rs",
];

/// Cited paths that are not files of this repository: (citing file, path, what it is).
const NOT_OURS: [(&str, &str, &str); 3] = [
    (
        "README.md",
        "manifests/x.toml",
        "a manifest named in an example error message",
    ),
    (
        "docs/consumers.md",
        "src/phase/tabphase.cpp",
        "a source file of Mitsuba 3",
    ),
    (
        "src/consumers/export/mitsuba.rs",
        "src/phase/tabphase.cpp",
        "a source file of Mitsuba 3",
    ),
];

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn is_path_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || matches!(c, '_' | '.' | '/' | '-')
}

/// (byte offset, path) of every path citation in `line` that starts with a top-level directory.
fn cited_paths(line: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < line.len() {
        let boundary = line[..i]
            .chars()
            .next_back()
            .is_none_or(|c| !is_path_char(c));
        if boundary && TOP_DIRS.iter().any(|d| line[i..].starts_with(d)) {
            let len = line[i..]
                .find(|c| !is_path_char(c))
                .unwrap_or(line.len() - i);
            let path = line[i..i + len].trim_end_matches('.');
            let pattern = line[i + len..].starts_with(['*', '<', '{', '…']);
            if !pattern {
                out.push((i, path.to_string()));
            }
            i += len.max(1);
        } else {
            i += line[i..].chars().next().map_or(1, char::len_utf8);
        }
    }
    out
}

/// (byte offset, name) of every backticked bare Rust file name (`` `name.rs` ``) in `line`.
fn bare_rust_names(line: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, _) in line.match_indices('`') {
        let rest = &line[i + 1..];
        let Some(end) = rest.find('`') else {
            continue;
        };
        let name = &rest[..end];
        let stem = name.strip_suffix(".rs").unwrap_or_default();
        if !stem.is_empty() && stem.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            out.push((i, name.to_string()));
        }
    }
    out
}

/// (byte offset, target) of every relative Markdown link target in `line` (anchors dropped).
fn link_targets(line: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, _) in line.match_indices("](") {
        let in_code = line[..i].matches('`').count() % 2 == 1;
        if in_code {
            continue;
        }
        let rest = &line[i + 2..];
        let Some(end) = rest.find([')', ' ']) else {
            continue;
        };
        let target = rest[..end].split('#').next().unwrap_or_default();
        let external = target.contains("://") || target.starts_with("mailto:");
        if !target.is_empty() && !external {
            out.push((i, target.to_string()));
        }
    }
    out
}

/// Dead citations in the Markdown document `rel` with text `text`.
fn check_document(rel: &str, text: &str, exists: &dyn Fn(&Path) -> bool) -> Vec<String> {
    let doc_dir = Path::new(rel).parent().unwrap_or(Path::new(""));
    let mut source_dir: Option<PathBuf> = None;
    let mut dead = BTreeSet::new();
    for (n, line) in text.lines().enumerate() {
        let mut items: Vec<(usize, u8, String)> = Vec::new();
        items.extend(cited_paths(line).into_iter().map(|(i, p)| (i, 0, p)));
        items.extend(bare_rust_names(line).into_iter().map(|(i, p)| (i, 1, p)));
        items.extend(link_targets(line).into_iter().map(|(i, p)| (i, 2, p)));
        items.sort();
        for (_, kind, p) in items {
            let (checked, note) = match kind {
                0 => (PathBuf::from(&p), String::new()),
                1 => match &source_dir {
                    Some(d) => (d.join(&p), format!(" (read as {})", d.join(&p).display())),
                    None => {
                        dead.insert(format!("{rel}:{}: `{p}` names no directory", n + 1));
                        continue;
                    }
                },
                _ => (normalise(&doc_dir.join(&p)), format!(" (link to {})", p)),
            };
            if kind == 0 && p.contains("src/") {
                let dir = if p.ends_with('/') {
                    Path::new(&p)
                } else {
                    Path::new(&p).parent().unwrap_or(Path::new(""))
                };
                source_dir = Some(dir.to_path_buf());
            }
            let allowed = NOT_OURS.iter().any(|(f, q, _)| *f == rel && *q == p);
            if !allowed && !exists(&checked) {
                dead.insert(format!(
                    "{rel}:{}: {}{note} does not exist",
                    n + 1,
                    checked.display()
                ));
            }
        }
    }
    dead.into_iter().collect()
}

/// `a/b/../c` → `a/c`.
fn normalise(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            std::path::Component::ParentDir => {
                out.pop();
            }
            std::path::Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// Dead citations in the comments (`//`, `///`, `//!`) of the Rust file `rel`.
fn check_comments(rel: &str, text: &str, exists: &dyn Fn(&Path) -> bool) -> Vec<String> {
    let mut dead = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let Some(at) = line.find("//") else {
            continue;
        };
        if !line[..at].trim().is_empty() {
            continue;
        }
        for (_, p) in cited_paths(&line[at..]) {
            let allowed = NOT_OURS.iter().any(|(f, q, _)| *f == rel && *q == p);
            if !allowed && !exists(Path::new(&p)) {
                dead.push(format!("{rel}:{}: {p} does not exist", n + 1));
            }
        }
    }
    dead
}

/// Files under `dir` (relative to the repository) ending in `ext`, build output left out.
fn files_under(dir: &str, ext: &str) -> Vec<String> {
    let mut todo = vec![repo().join(dir)];
    let mut out = Vec::new();
    while let Some(d) = todo.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries {
            let p = e.expect("directory entry").path();
            if p.is_dir() && !p.ends_with("target") {
                todo.push(p);
            } else if p.extension().is_some_and(|x| x == ext) {
                let rel = p.strip_prefix(repo()).expect("inside the repository");
                out.push(rel.to_string_lossy().replace('\\', "/"));
            }
        }
    }
    out.sort();
    out
}

fn exists_in_repo(p: &Path) -> bool {
    repo().join(p).exists()
}

#[test]
fn documents_cite_existing_paths() {
    let mut docs = vec!["README.md".to_string(), "ARCHITECTURE.md".to_string()];
    docs.extend(files_under("docs", "md"));
    let mut dead = Vec::new();
    let mut read = 0;
    for d in &docs {
        let Ok(text) = std::fs::read_to_string(repo().join(d)) else {
            continue;
        };
        read += 1;
        dead.extend(check_document(d, &text, &exists_in_repo));
    }
    assert!(read >= 10, "only {read} documents found");
    assert!(
        dead.is_empty(),
        "dead paths ({}):\n{}",
        dead.len(),
        dead.join("\n")
    );
}

#[test]
fn comments_cite_existing_paths() {
    let mut dead = Vec::new();
    let mut read = 0;
    let dirs = [
        "src",
        "cli",
        "capi",
        "python/src",
        "table-format",
        "tests",
        "examples",
        "benches",
        "fuzz",
    ];
    for dir in dirs {
        for f in files_under(dir, "rs") {
            let text = std::fs::read_to_string(repo().join(&f)).expect("readable source");
            read += 1;
            dead.extend(check_comments(&f, &text, &exists_in_repo));
        }
    }
    assert!(read >= 100, "only {read} Rust files found");
    assert!(
        dead.is_empty(),
        "dead paths ({}):\n{}",
        dead.len(),
        dead.join("\n")
    );
}

#[test]
fn dead_paths_names_and_links_are_found_and_patterns_skipped() {
    let files = ["src/a/x.rs", "src/a/", "docs/img.png", "manifests/"];
    let exists = |p: &Path| files.iter().any(|f| Path::new(f) == p);
    let doc = "# A (`src/a/`)\n\
               | `x.rs` | `y.rs` |\n\
               see src/a/x.rs. and cli/src/gone.rs, manifests/full/seed-*.toml, ![i](img.png)\n\
               [gone](../src/b.rs) `docs/<name>.md` https://example.org/src/z.rs `[f](x)`\n";
    let dead = check_document("docs/a.md", doc, &exists);
    assert_eq!(
        dead,
        [
            "docs/a.md:2: src/a/y.rs (read as src/a/y.rs) does not exist",
            "docs/a.md:3: cli/src/gone.rs does not exist",
            "docs/a.md:4: src/b.rs (link to ../src/b.rs) does not exist",
        ]
    );
    let no_context = check_document("README.md", "`lone.rs`\n", &exists);
    assert_eq!(no_context, ["README.md:1: `lone.rs` names no directory"]);
    let src = "let s = \"src/nowhere.rs\";\n/// see `src/a/x.rs` and tests/none.rs\n";
    assert_eq!(
        check_comments("src/l.rs", src, &exists),
        ["src/l.rs:2: tests/none.rs does not exist"]
    );
}
