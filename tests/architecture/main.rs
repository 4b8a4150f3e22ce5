//! The layering of the `scatterbake` crate, checked on its source text (nothing here links the
//! library): the layer table in the module documentation of `src/lib.rs` names every top-level
//! module; every import (`use crate::…`, `super::…`, paths in code) goes to a module of the same
//! or a lower layer; no file imports itself through others (no cycle between files). The
//! command line (`cli/src`) has no cycle between its files either.

mod model;
mod source;

use model::{Crate, Edge, Node};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read_file(p: &Path) -> Option<String> {
    std::fs::read_to_string(p).ok()
}

/// The layer of each top-level module, from the table in `lib_src`'s module documentation:
/// rows `//! | <layer> | `name`, `name`, … | … |`.
fn layer_table(lib_src: &str) -> BTreeMap<String, u32> {
    let mut layers = BTreeMap::new();
    for line in lib_src.lines() {
        let Some(row) = line.strip_prefix("//!").map(str::trim) else {
            continue;
        };
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        if cells.len() < 4 || !cells[0].is_empty() {
            continue;
        }
        let Ok(layer) = cells[1].parse::<u32>() else {
            continue;
        };
        for name in cells[2].split(',') {
            let name = name.trim().trim_matches(|c| matches!(c, '[' | ']' | '`'));
            layers.insert(name.to_string(), layer);
        }
    }
    layers
}

/// Top-level module (first path segment) of a node; `None` for the crate root itself.
fn top_module(c: &Crate, n: &Node) -> Option<String> {
    match n {
        Node::File(f) => {
            let m = c.module_at(*f, &[])?;
            c.modules[m].path.first().cloned()
        }
        Node::External(name) => Some(name.clone()),
    }
}

/// Imports that go up the layer table, and top-level modules missing from it.
fn layer_problems(c: &Crate, layers: &BTreeMap<String, u32>) -> Vec<String> {
    let mut problems = Vec::new();
    for &child in c.modules[0].children.values() {
        let name = &c.modules[child].path[0];
        if !layers.contains_key(name) {
            problems.push(format!(
                "module `{name}` is not in the layer table of src/lib.rs"
            ));
        }
    }
    for e in c.edges() {
        let from = top_module(c, &Node::File(e.from));
        let to = top_module(c, &e.to);
        let (Some(from), Some(to)) = (from, to) else {
            continue;
        };
        let (Some(&lf), Some(&lt)) = (layers.get(&from), layers.get(&to)) else {
            continue;
        };
        if lt > lf {
            problems.push(format!(
                "{}:{}: `{}` (layer {lf}) imports `{}` (layer {lt}): {}{}",
                c.files[e.from].display(),
                e.line,
                from,
                e.text,
                c.name(&e.to),
                if e.in_test { " [test code]" } else { "" }
            ));
        }
    }
    problems
}

/// Strongly connected components of more than one node (Tarjan), each sorted.
fn cycles(edges: &[Edge]) -> Vec<Vec<Node>> {
    let mut adj: BTreeMap<Node, BTreeSet<Node>> = BTreeMap::new();
    for e in edges {
        adj.entry(Node::File(e.from))
            .or_default()
            .insert(e.to.clone());
        adj.entry(e.to.clone()).or_default();
    }
    let mut t = Tarjan {
        adj: &adj,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        next: 0,
        out: Vec::new(),
    };
    for n in adj.keys() {
        if !t.index.contains_key(n) {
            t.visit(n);
        }
    }
    t.out
}

struct Tarjan<'a> {
    adj: &'a BTreeMap<Node, BTreeSet<Node>>,
    index: BTreeMap<Node, usize>,
    low: BTreeMap<Node, usize>,
    stack: Vec<Node>,
    on_stack: BTreeSet<Node>,
    next: usize,
    out: Vec<Vec<Node>>,
}

impl Tarjan<'_> {
    fn visit(&mut self, v: &Node) {
        self.index.insert(v.clone(), self.next);
        self.low.insert(v.clone(), self.next);
        self.next += 1;
        self.stack.push(v.clone());
        self.on_stack.insert(v.clone());
        for w in &self.adj[v] {
            if !self.index.contains_key(w) {
                self.visit(w);
                let lw = self.low[w];
                let lv = self.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if self.on_stack.contains(w) {
                let iw = self.index[w];
                let lv = self.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if self.low[v] == self.index[v] {
            let mut component = Vec::new();
            while let Some(w) = self.stack.pop() {
                self.on_stack.remove(&w);
                let done = &w == v;
                component.push(w);
                if done {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                self.out.push(component);
            }
        }
    }
}

/// One message per cycle: its files and the imports that close it.
fn cycle_problems(c: &Crate) -> Vec<String> {
    let edges = c.edges();
    let mut problems = Vec::new();
    for component in cycles(&edges) {
        let members: BTreeSet<&Node> = component.iter().collect();
        let names: Vec<String> = component.iter().map(|n| c.name(n)).collect();
        let mut msg = format!(
            "import cycle between {} files: {}",
            names.len(),
            names.join(", ")
        );
        // One line per importing pair: its first import, and how many more there are.
        let mut pairs: BTreeMap<(usize, &Node), Vec<&Edge>> = BTreeMap::new();
        for e in edges
            .iter()
            .filter(|e| members.contains(&Node::File(e.from)) && members.contains(&e.to))
        {
            pairs.entry((e.from, &e.to)).or_default().push(e);
        }
        for ((from, to), mut imports) in pairs {
            imports.sort_by_key(|e| e.line);
            let more = match imports.len() - 1 {
                0 => String::new(),
                n => format!(", {n} more"),
            };
            let tests = if imports.iter().all(|e| e.in_test) {
                " [test code only]"
            } else {
                ""
            };
            msg.push_str(&format!(
                "\n    {}:{} → {} ({}{more}){tests}",
                c.files[from].display(),
                imports[0].line,
                c.name(to),
                imports[0].text
            ));
        }
        let mutual: Vec<String> = members
            .iter()
            .flat_map(|a| members.iter().map(move |b| (*a, *b)))
            .filter(|(a, b)| a < b && imports_of(&edges, a, b) && imports_of(&edges, b, a))
            .map(|(a, b)| format!("{} ↔ {}", c.name(a), c.name(b)))
            .collect();
        if !mutual.is_empty() {
            msg.push_str(&format!(
                "\n  files importing each other: {}",
                mutual.join("; ")
            ));
        }
        problems.push(msg);
    }
    problems
}

/// Whether `a` imports `b` directly.
fn imports_of(edges: &[Edge], a: &Node, b: &Node) -> bool {
    edges.iter().any(|e| &Node::File(e.from) == a && &e.to == b)
}

/// `.rs` files under `dir` (relative to `base`) that are not modules of `c`.
fn files_outside_module_tree(c: &Crate, base: &Path, dir: &str) -> Vec<String> {
    let known: BTreeSet<&PathBuf> = c.files.iter().collect();
    let mut todo = vec![base.join(dir)];
    let mut out = Vec::new();
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(&d).expect("readable source directory") {
            let p = entry.expect("directory entry").path();
            if p.is_dir() {
                todo.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(base).expect("under base").to_path_buf();
                if !known.contains(&rel) {
                    out.push(format!("{} is not part of the module tree", rel.display()));
                }
            }
        }
    }
    out.sort();
    out
}

fn library() -> Crate {
    Crate::load(repo(), "src/lib.rs", &read_file)
}

fn cli() -> Crate {
    Crate::load(&repo().join("cli"), "src/main.rs", &read_file)
}

fn assert_none(what: &str, problems: &[String]) {
    assert!(
        problems.is_empty(),
        "{what} ({}):\n{}",
        problems.len(),
        problems.join("\n")
    );
}

/// The top level of the repository (ARCHITECTURE.md, "Workspace" and "Where things live"):
/// anything else there is a stray file, such as a shell redirection gone wrong.
const TOP_LEVEL: &[&str] = &[
    "ARCHITECTURE.md",
    "Cargo.lock",
    "Cargo.toml",
    "LICENSE",
    "README.md",
    "assets",
    "benches",
    "build.rs",
    "c",
    "capi",
    "cli",
    "clippy.toml",
    "deploy",
    "docs",
    "examples",
    "fuzz",
    "manifests",
    "python",
    "src",
    "table-format",
    "tests",
    // Build outputs (ignored by git): cargo's target directory and the default tables.
    "target",
    "tables",
];

fn stray_top_level_entries(root: &Path) -> Vec<String> {
    let mut stray: Vec<String> = std::fs::read_dir(root)
        .expect("the repository root is readable")
        .map(|e| {
            e.expect("a directory entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .filter(|name| !name.starts_with('.') && !TOP_LEVEL.contains(&name.as_str()))
        .collect();
    stray.sort();
    stray
}

#[test]
fn the_repository_root_holds_only_the_workspace_layout() {
    let stray = stray_top_level_entries(repo());
    assert_none(
        "entries at the repository root that are not part of the layout (move or delete them, \
         or add them to TOP_LEVEL and ARCHITECTURE.md)",
        &stray,
    );
}

#[test]
fn a_stray_file_at_the_root_is_found() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    for name in ["Cargo.toml", "src", ".git", "3.029e-1"] {
        std::fs::write(dir.path().join(name), "").expect("write a file");
    }
    assert_eq!(
        stray_top_level_entries(dir.path()),
        vec!["3.029e-1".to_string()]
    );
}

#[test]
fn every_source_file_is_in_the_module_tree() {
    let lib = library();
    let mut problems = lib.problems.clone();
    problems.extend(files_outside_module_tree(&lib, repo(), "src"));
    let cli = cli();
    problems.extend(cli.problems.clone());
    problems.extend(files_outside_module_tree(&cli, &repo().join("cli"), "src"));
    assert_none("files the layering checks would not see", &problems);
}

#[test]
fn imports_go_to_the_same_or_a_lower_layer() {
    let lib_src = read_file(&repo().join("src/lib.rs")).expect("src/lib.rs");
    let layers = layer_table(&lib_src);
    assert!(
        layers.len() >= 10,
        "layer table of src/lib.rs not found: {layers:?}"
    );
    assert_none(
        "imports against the layer table of src/lib.rs",
        &layer_problems(&library(), &layers),
    );
}

#[test]
fn no_import_cycle_between_library_files() {
    assert_none("import cycles in src/", &cycle_problems(&library()));
}

#[test]
fn no_import_cycle_between_command_line_files() {
    assert_none("import cycles in cli/src/", &cycle_problems(&cli()));
}

/// A crate held in memory, for the tests of the checks themselves.
fn in_memory(files: &[(&str, &str)]) -> Crate {
    let map: BTreeMap<PathBuf, String> = files
        .iter()
        .map(|(p, s)| (PathBuf::from(p), s.to_string()))
        .collect();
    Crate::load(Path::new(""), "src/lib.rs", &move |p: &Path| {
        map.get(p).cloned()
    })
}

const LIB: &str = "//! | layer | modules | role |\n//! |---|---|---|\n//! | 0 | `low`, `absent` | x |\n//! | 1 | `high` | y |\npub mod low;\npub mod high;\n";

#[test]
fn an_upward_import_is_found_with_its_line() {
    let c = in_memory(&[
        ("src/lib.rs", LIB),
        (
            "src/low.rs",
            "// crate::high::f in a comment\n\nfn g() { let _ = \"crate::high\"; crate::high::f(); }\n",
        ),
        ("src/high.rs", "pub fn f() {}\n"),
    ]);
    let layers = layer_table(LIB);
    assert_eq!(layers.get("absent"), Some(&0));
    let p = layer_problems(&c, &layers);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].starts_with("src/low.rs:3: `low` (layer 0) imports `crate::high::f`"),
        "{p:?}"
    );
    assert!(cycle_problems(&c).is_empty());
}

#[test]
fn a_cycle_through_super_and_a_reexport_is_found() {
    let c = in_memory(&[
        ("src/lib.rs", "pub mod a;\n"),
        (
            "src/a/mod.rs",
            "mod x;\nmod y;\npub use y::Y;\npub struct Top;\n",
        ),
        (
            "src/a/x.rs",
            "use super::Y;\npub struct X;\n#[cfg(test)]\nmod tests { use super::*; }\n",
        ),
        (
            "src/a/y.rs",
            "pub struct Y;\nfn f() -> super::x::X { todo!() }\n",
        ),
    ]);
    let p = cycle_problems(&c);
    assert_eq!(p.len(), 1, "{p:?}");
    assert!(
        p[0].contains("between 2 files: src/a/x.rs, src/a/y.rs"),
        "{p:?}"
    );
    assert!(
        p[0].contains("src/a/x.rs:1 → src/a/y.rs (super::Y)"),
        "{p:?}"
    );
}

#[test]
fn modules_in_inline_blocks_path_attributes_and_groups_resolve() {
    let c = in_memory(&[
        ("src/lib.rs", "pub mod a;\npub mod b;\n"),
        (
            "src/a.rs",
            "#[path = \"a_impl.rs\"]\nmod imp;\npub mod inner { pub use crate::b::{self, B as Bee}; }\n",
        ),
        ("src/a_impl.rs", "pub fn f(c: char) -> bool { c == '}' }\n"),
        (
            "src/b.rs",
            "pub struct B;\nfn g() { crate::a::imp::f('{'); }\n",
        ),
    ]);
    assert!(c.problems.is_empty(), "{:?}", c.problems);
    let edges: BTreeSet<String> = c
        .edges()
        .iter()
        .map(|e| format!("{}:{}>{}", c.files[e.from].display(), e.line, c.name(&e.to)))
        .collect();
    let expected = ["src/a.rs:3>src/b.rs", "src/b.rs:2>src/a_impl.rs"];
    assert_eq!(edges, expected.iter().map(|s| s.to_string()).collect());
    assert!(cycle_problems(&c).is_empty());
}
