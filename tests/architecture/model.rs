//! A crate's module tree read from its source files, and the file-to-file imports found in it:
//! every `use` and every path in code that names one of the crate's own modules (`crate::…`,
//! `super::…`, `self::…`, a child module, or a name a `use` bound to one), resolved to the file
//! that defines the item. Re-exports (`pub use`) are followed to the defining file, so a facade
//! `mod.rs` that only re-exports its children is not a dependency of its own.

use crate::source::{FileScan, PathUse, scan};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Reads a file of the crate (`None` when it does not exist).
pub type ReadFile = dyn Fn(&Path) -> Option<String>;

/// One module: an out-of-line file module or an inline `mod name { … }` inside one.
#[derive(Debug)]
pub struct Module {
    pub path: Vec<String>,
    pub file: usize,
    /// Inline scope inside `file` (empty for the file's own module).
    pub scope: Vec<String>,
    pub parent: Option<usize>,
    pub children: BTreeMap<String, usize>,
    /// Compiled for tests only (`#[cfg(test)] mod …`, or inside one).
    pub test_only: bool,
}

/// Where a path leads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    Module(usize),
    Item(usize, String),
    /// A top-level name that is another crate (`pub use scatterbake_table as table;`).
    External(String),
}

/// One import of one file by another.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Edge {
    pub from: usize,
    pub to: Node,
    pub line: usize,
    pub text: String,
    /// The import is compiled for tests only.
    pub in_test: bool,
}

/// A node of the file graph: a source file, or a top-level name that is another crate.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Node {
    File(usize),
    External(String),
}

pub struct Crate {
    /// Files relative to the crate directory, in load order (the root first).
    pub files: Vec<PathBuf>,
    pub scans: Vec<FileScan>,
    pub modules: Vec<Module>,
    /// Names that stand for other crates: `scatterbake_table` and `table` for
    /// `pub use scatterbake_table as table;` at the root.
    pub externals: BTreeMap<String, String>,
    /// Problems found while loading (missing module files).
    pub problems: Vec<String>,
}

impl Crate {
    /// Loads the crate whose root file is `root` (relative to `dir`), reading files with `read`.
    pub fn load(dir: &Path, root: &str, read: &ReadFile) -> Crate {
        let mut c = Crate {
            files: Vec::new(),
            scans: Vec::new(),
            modules: Vec::new(),
            externals: BTreeMap::new(),
            problems: Vec::new(),
        };
        let root_src = read(&dir.join(root)).unwrap_or_default();
        c.add_file(
            (PathBuf::from(root), root_src),
            Vec::new(),
            None,
            (dir, read),
            false,
        );
        c.find_externals();
        c
    }

    /// Adds the file `rel` with text `src` as the module `path`, and the modules it declares,
    /// read with `read` from `dir`.
    fn add_file(
        &mut self,
        (rel, src): (PathBuf, String),
        path: Vec<String>,
        parent: Option<usize>,
        (dir, read): (&Path, &ReadFile),
        test_only: bool,
    ) -> usize {
        let file = self.files.len();
        self.files.push(rel.clone());
        self.scans.push(scan(&src));
        let top = self.new_module(path, file, Vec::new(), parent);
        self.modules[top].test_only |= test_only;
        let decls = self.scans[file].mods.clone();
        for d in decls {
            let Some(owner) = self.module_at(file, &d.scope) else {
                continue;
            };
            let mut child_path = self.modules[owner].path.clone();
            child_path.push(d.name.clone());
            if d.inline {
                let mut scope = d.scope.clone();
                scope.push(d.name.clone());
                let m = self.new_module(child_path, file, scope, Some(owner));
                self.modules[m].test_only |= d.in_test;
                self.modules[owner].children.insert(d.name, m);
                continue;
            }
            let candidates = child_file_candidates(&rel, &d.scope, &d.name, d.path_attr.as_deref());
            let found = candidates
                .iter()
                .find_map(|p| read(&dir.join(p)).map(|s| (p.clone(), s)));
            match found {
                Some((p, s)) => {
                    let m = self.add_file((p, s), child_path, Some(owner), (dir, read), d.in_test);
                    self.modules[owner].children.insert(d.name, m);
                }
                None => self.problems.push(format!(
                    "{}: `mod {}` has no file (looked for {})",
                    rel.display(),
                    d.name,
                    candidates
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )),
            }
        }
        top
    }

    fn new_module(
        &mut self,
        path: Vec<String>,
        file: usize,
        scope: Vec<String>,
        parent: Option<usize>,
    ) -> usize {
        let test_only = parent.is_some_and(|p| self.modules[p].test_only);
        let children = BTreeMap::new();
        self.modules.push(Module {
            path,
            file,
            scope,
            parent,
            children,
            test_only,
        });
        self.modules.len() - 1
    }

    /// The module of `file` at inline `scope`.
    pub fn module_at(&self, file: usize, scope: &[String]) -> Option<usize> {
        self.modules
            .iter()
            .position(|m| m.file == file && m.scope == scope)
    }

    /// `pub use other_crate as name;` at the root makes `name` (and `other_crate`) external.
    fn find_externals(&mut self) {
        let Some(root) = self.scans.first() else {
            return;
        };
        let mut found = Vec::new();
        for p in root
            .paths
            .iter()
            .filter(|p| p.is_use && p.leaf.segments.len() == 1)
        {
            if let Some(name) = &p.leaf.binds {
                found.push((p.leaf.segments[0].clone(), name.clone()));
            }
        }
        for (krate, name) in found {
            self.externals.insert(krate, name.clone());
            self.externals.insert(name.clone(), name);
        }
    }

    /// Resolves `segs` as written in module `m`; `None` for paths outside the crate.
    pub fn resolve(&self, m: usize, segs: &[String], depth: u32) -> Option<Target> {
        let first = segs.first()?.as_str();
        let (mut cur, rest) = match first {
            "crate" => (0, &segs[1..]),
            "self" => (m, &segs[1..]),
            "super" => {
                let mut cur = m;
                let mut k = 0;
                while segs.get(k).is_some_and(|s| s == "super") {
                    cur = self.modules[cur].parent?;
                    k += 1;
                }
                (cur, &segs[k..])
            }
            _ if self.modules[m].children.contains_key(first) => {
                (self.modules[m].children[first], &segs[1..])
            }
            _ if m == 0 && self.externals.contains_key(first) => {
                return Some(Target::External(self.externals[first].clone()));
            }
            _ if self.externals.contains_key(first) && self.externals[first] != first => {
                return Some(Target::External(self.externals[first].clone()));
            }
            _ => match self.alias(m, first, depth)? {
                Target::Module(k) => (k, &segs[1..]),
                other => return Some(other),
            },
        };
        for s in rest {
            if let Some(&child) = self.modules[cur].children.get(s) {
                cur = child;
            } else if cur == 0 && self.externals.contains_key(s) {
                return Some(Target::External(self.externals[s].clone()));
            } else {
                return Some(self.follow_item(cur, s, depth));
            }
        }
        Some(Target::Module(cur))
    }

    /// What the name `name` bound by a `use` in module `m` stands for.
    fn alias(&self, m: usize, name: &str, depth: u32) -> Option<Target> {
        if depth > 8 {
            return None;
        }
        let file = self.modules[m].file;
        let scope = &self.modules[m].scope;
        let leaf = self.scans[file]
            .paths
            .iter()
            .find(|p| p.is_use && &p.scope == scope && p.leaf.binds.as_deref() == Some(name))?;
        if leaf.leaf.segments.first().map(String::as_str) == Some(name)
            && leaf.leaf.segments.len() == 1
        {
            return None;
        }
        self.resolve(m, &leaf.leaf.segments, depth + 1)
    }

    /// The module that defines `name` as seen in module `cur`, following re-exports.
    fn follow_item(&self, cur: usize, name: &str, depth: u32) -> Target {
        let here = Target::Item(cur, name.to_string());
        if depth > 8 || self.defines(cur, name) {
            return here;
        }
        let file = self.modules[cur].file;
        let scope = &self.modules[cur].scope;
        let reexports: Vec<&PathUse> = self.scans[file]
            .paths
            .iter()
            .filter(|p| p.is_reexport && &p.scope == scope)
            .collect();
        if let Some(p) = reexports
            .iter()
            .find(|p| p.leaf.binds.as_deref() == Some(name))
        {
            return self
                .resolve(cur, &p.leaf.segments, depth + 1)
                .unwrap_or(here);
        }
        for p in reexports.iter().filter(|p| p.leaf.binds.is_none()) {
            let prefix = &p.leaf.segments[..p.leaf.segments.len() - 1];
            if let Some(Target::Module(k)) = self.resolve(cur, prefix, depth + 1) {
                if let Some(&child) = self.modules[k].children.get(name) {
                    return Target::Module(child);
                }
                if self.defines(k, name) || self.reexports(k, name) {
                    return self.follow_item(k, name, depth + 1);
                }
            }
        }
        here
    }

    fn defines(&self, m: usize, name: &str) -> bool {
        let md = &self.modules[m];
        self.scans[md.file]
            .defs
            .get(&md.scope)
            .is_some_and(|d| d.contains(name))
    }

    fn reexports(&self, m: usize, name: &str) -> bool {
        let md = &self.modules[m];
        self.scans[md.file]
            .paths
            .iter()
            .any(|p| p.is_reexport && p.scope == md.scope && p.leaf.binds.as_deref() == Some(name))
    }

    /// The graph node of a target.
    pub fn node(&self, t: &Target) -> Node {
        match t {
            Target::Module(m) | Target::Item(m, _) => Node::File(self.modules[*m].file),
            Target::External(name) => Node::External(name.clone()),
        }
    }

    /// Whether module `a` is `b` or inside it.
    pub fn is_within(&self, a: usize, b: usize) -> bool {
        let mut cur = Some(a);
        while let Some(k) = cur {
            if k == b {
                return true;
            }
            cur = self.modules[k].parent;
        }
        false
    }

    /// Every import of one file by another (re-exports of a module's own descendants left out).
    pub fn edges(&self) -> Vec<Edge> {
        let mut out = BTreeSet::new();
        for (file, scan) in self.scans.iter().enumerate() {
            for p in &scan.paths {
                let Some(m) = self.module_at(file, &p.scope) else {
                    continue;
                };
                let Some(target) = self.resolve(m, &p.leaf.segments, 0) else {
                    continue;
                };
                let own = self.module_at(file, &[]).unwrap_or(m);
                if p.is_reexport
                    && let Some(Target::Module(k)) = self.resolve(m, &p.leaf.segments[..1], 0)
                    && self.is_within(k, own)
                {
                    continue;
                }
                let to = self.node(&target);
                if to != Node::File(file) {
                    let text = p.leaf.segments.join("::");
                    let in_test = p.in_test || self.modules[m].test_only;
                    out.insert(Edge {
                        from: file,
                        to,
                        line: p.line,
                        text,
                        in_test,
                    });
                }
            }
        }
        out.into_iter().collect()
    }

    /// Display name of a node.
    pub fn name(&self, n: &Node) -> String {
        match n {
            Node::File(f) => self.files[*f].display().to_string(),
            Node::External(name) => format!("`{name}` (external crate)"),
        }
    }
}

/// Where the file of `mod name;` declared in `parent_file` (inside inline `scope`) may be.
fn child_file_candidates(
    parent_file: &Path,
    scope: &[String],
    name: &str,
    attr: Option<&str>,
) -> Vec<PathBuf> {
    let dir = parent_file.parent().unwrap_or(Path::new(""));
    if let Some(a) = attr {
        return vec![dir.join(a)];
    }
    let stem = parent_file
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or_default();
    let mut base = if matches!(stem, "mod" | "lib" | "main") {
        dir.to_path_buf()
    } else {
        dir.join(stem)
    };
    for s in scope {
        base.push(s);
    }
    vec![
        base.join(format!("{name}.rs")),
        base.join(name).join("mod.rs"),
    ]
}
