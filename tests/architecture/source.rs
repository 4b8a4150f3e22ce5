//! Reading Rust source text without compiling it: comments and literals blanked, tokens with
//! their line numbers, and per file the module declarations, `use` trees, paths in code and the
//! names of the items each module defines.

use std::collections::{BTreeMap, BTreeSet};

/// `src` with comments and the contents of string and character literals replaced by spaces
/// (line breaks kept, so line numbers stay those of the file).
pub fn blank_comments_and_literals(src: &str) -> String {
    let c: Vec<char> = src.chars().collect();
    let mut out = String::with_capacity(src.len());
    let blank = |ch: char| if ch == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                let pair = (c[i], c.get(i + 1).copied());
                if pair == ('/', Some('*')) || pair == ('*', Some('/')) {
                    depth += if pair.0 == '/' { 1 } else { -1 };
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(c[i]));
                    i += 1;
                }
            }
        } else if let Some(end) = raw_string_end(&c, i) {
            out.extend(c[i..end].iter().map(|&ch| blank(ch)));
            i = end;
        } else if c[i] == '"' {
            out.push(' ');
            i += 1;
            while i < c.len() && c[i] != '"' {
                let step = if c[i] == '\\' { 2 } else { 1 };
                out.extend(c[i..(i + step).min(c.len())].iter().map(|&ch| blank(ch)));
                i += step;
            }
            out.push(' ');
            i += 1;
        } else if let Some(end) = char_literal_end(&c, i) {
            out.extend(c[i..end].iter().map(|&ch| blank(ch)));
            i = end;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// End (exclusive) of a raw string literal `r"…"`, `r#"…"#`, `br"…"` starting at `i`.
fn raw_string_end(c: &[char], i: usize) -> Option<usize> {
    if i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_') {
        return None;
    }
    let mut j = i;
    if c.get(j) == Some(&'b') || c.get(j) == Some(&'c') {
        j += 1;
    }
    if c.get(j) != Some(&'r') {
        return None;
    }
    j += 1;
    let hashes = c[j..].iter().take_while(|&&ch| ch == '#').count();
    j += hashes;
    if c.get(j) != Some(&'"') {
        return None;
    }
    j += 1;
    while j < c.len() {
        if c[j] == '"'
            && c[j + 1..]
                .iter()
                .take(hashes)
                .filter(|&&ch| ch == '#')
                .count()
                == hashes
        {
            return Some(j + 1 + hashes);
        }
        j += 1;
    }
    Some(c.len())
}

/// End (exclusive) of a character literal starting at `i` (`'a'`, `'\n'`, `'\u{2192}'`); `None`
/// for a lifetime or label (`'a`).
fn char_literal_end(c: &[char], i: usize) -> Option<usize> {
    if c[i] != '\'' {
        return None;
    }
    if c.get(i + 1) == Some(&'\\') {
        let close = c[i + 2..].iter().position(|&ch| ch == '\'')?;
        return Some(i + 2 + close + 1);
    }
    (c.get(i + 2) == Some(&'\'')).then_some(i + 3)
}

/// One token: an identifier (keywords included) or one punctuation mark (`::` is one).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Token {
    pub text: String,
    pub line: usize,
}

impl Token {
    fn is_ident(&self) -> bool {
        self.text
            .chars()
            .next()
            .is_some_and(|ch| ch.is_alphabetic() || ch == '_')
    }
}

/// Tokens of blanked source (numbers are identifiers here; they never follow `::`).
pub fn tokens(blanked: &str) -> Vec<Token> {
    let mut out = Vec::new();
    for (n, line) in blanked.lines().enumerate() {
        let c: Vec<char> = line.chars().collect();
        let mut i = 0;
        while i < c.len() {
            if c[i].is_whitespace() {
                i += 1;
                continue;
            }
            let start = i;
            if c[i].is_alphanumeric() || c[i] == '_' {
                while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                    i += 1;
                }
            } else if c[i] == ':' && c.get(i + 1) == Some(&':') {
                i += 2;
            } else {
                i += 1;
            }
            out.push(Token {
                text: c[start..i].iter().collect(),
                line: n + 1,
            });
        }
    }
    out
}

/// One leaf of a `use` tree: the full path (a glob ends in `*`) and the name it binds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UseLeaf {
    pub segments: Vec<String>,
    /// The bound name (`as` alias or last segment); `None` for globs and `as _`.
    pub binds: Option<String>,
}

/// A `use` declaration or a path in code, inside the inline module `scope` of its file.
#[derive(Debug, Clone)]
pub struct PathUse {
    pub scope: Vec<String>,
    pub line: usize,
    pub leaf: UseLeaf,
    /// From a `use` declaration (not a path in code).
    pub is_use: bool,
    /// From a `pub`/`pub(…)` `use` declaration (a re-export).
    pub is_reexport: bool,
    /// Inside an item marked `#[cfg(test)]`.
    pub in_test: bool,
}

/// A `mod name;` or `mod name { … }` declaration.
#[derive(Debug, Clone)]
pub struct ModDecl {
    pub scope: Vec<String>,
    pub name: String,
    pub inline: bool,
    /// The `#[path = "…"]` attribute of an out-of-line module.
    pub path_attr: Option<String>,
    /// Declared under `#[cfg(test)]`.
    pub in_test: bool,
}

/// What one file declares, imports and defines.
#[derive(Debug, Default)]
pub struct FileScan {
    pub mods: Vec<ModDecl>,
    pub paths: Vec<PathUse>,
    /// Item names defined directly in each module of the file (key: inline scope).
    pub defs: BTreeMap<Vec<String>, BTreeSet<String>>,
}

const ITEM_KEYWORDS: [&str; 8] = [
    "fn", "struct", "enum", "trait", "type", "const", "static", "union",
];
const NOT_NAMES: [&str; 6] = ["fn", "unsafe", "extern", "async", "mut", "_"];

/// Scans one file's source.
pub fn scan(src: &str) -> FileScan {
    let mut s = Scanner {
        toks: tokens(&blank_comments_and_literals(src)),
        path_attrs: path_attributes(src),
        out: FileScan::default(),
        stack: Vec::new(),
        depth: 0,
        pending_inline: None,
        pending_test: false,
        test_depth: None,
    };
    let mut i = 0;
    while i < s.toks.len() {
        i = s.step(i) + 1;
    }
    s.out
}

struct Scanner {
    toks: Vec<Token>,
    path_attrs: BTreeMap<usize, String>,
    out: FileScan,
    /// Inline modules entered: (name, brace depth inside it).
    stack: Vec<(String, usize)>,
    depth: usize,
    pending_inline: Option<String>,
    /// A `#[cfg(test)]` was seen and its item has not started yet.
    pending_test: bool,
    /// Brace depth inside the `#[cfg(test)]` item being read.
    test_depth: Option<usize>,
}

impl Scanner {
    fn text(&self, i: usize) -> &str {
        self.toks.get(i).map_or("", |t| t.text.as_str())
    }

    fn scope(&self) -> Vec<String> {
        self.stack.iter().map(|(n, _)| n.clone()).collect()
    }

    fn at_module_level(&self) -> bool {
        self.depth == self.stack.last().map_or(0, |&(_, d)| d)
    }

    fn in_test(&self) -> bool {
        self.pending_test || self.test_depth.is_some()
    }

    /// Reads the token at `i` (and what it starts); returns the index of the last token used.
    fn step(&mut self, i: usize) -> usize {
        let t = self.text(i).to_string();
        match t.as_str() {
            "{" => self.open_brace(),
            "}" => self.close_brace(),
            ";" if self.test_depth.is_none() => self.pending_test = false,
            "#" if self.text(i + 1) == "["
                && self.text(i + 2) == "cfg"
                && self.text(i + 4) == "test" =>
            {
                self.pending_test = self.text(i + 5) == ")";
            }
            "pub" if self.text(i + 1) == "(" => return matching_paren(&self.toks, i + 1),
            "mod"
                if self.at_module_level() && self.toks.get(i + 1).is_some_and(Token::is_ident) =>
            {
                self.module(i);
                return i + 1;
            }
            "use" if i + 1 < self.toks.len() && self.text(i + 1) != "<" => return self.use_decl(i),
            "macro_rules" if self.text(i + 1) == "!" => {
                self.define(i + 2);
                return i + 2;
            }
            _ if ITEM_KEYWORDS.contains(&t.as_str()) && self.at_module_level() => {
                self.define(i + 1)
            }
            _ if self.toks[i].is_ident() && self.text(i + 1) == "::" => return self.code_path(i),
            _ => {}
        }
        i
    }

    fn open_brace(&mut self) {
        self.depth += 1;
        if let Some(name) = self.pending_inline.take() {
            self.stack.push((name, self.depth));
        }
        if self.pending_test {
            self.pending_test = false;
            self.test_depth = Some(self.depth);
        }
    }

    fn close_brace(&mut self) {
        if self.stack.last().is_some_and(|&(_, d)| d == self.depth) {
            self.stack.pop();
        }
        if self.test_depth == Some(self.depth) {
            self.test_depth = None;
        }
        self.depth = self.depth.saturating_sub(1);
    }

    fn define(&mut self, name_at: usize) {
        let Some(name) = self.toks.get(name_at).filter(|n| n.is_ident()) else {
            return;
        };
        if !NOT_NAMES.contains(&name.text.as_str()) {
            let name = name.text.clone();
            self.out.defs.entry(self.scope()).or_default().insert(name);
        }
    }

    fn module(&mut self, i: usize) {
        let name = self.toks[i + 1].text.clone();
        let inline = self.text(i + 2) == "{";
        if inline {
            self.pending_inline = Some(name.clone());
        }
        let path_attr = self.path_attrs.get(&self.toks[i].line).cloned();
        self.define(i + 1);
        let (scope, in_test) = (self.scope(), self.in_test());
        self.out.mods.push(ModDecl {
            scope,
            name,
            inline,
            path_attr,
            in_test,
        });
    }

    fn use_decl(&mut self, i: usize) -> usize {
        let is_reexport = i > 0 && matches!(self.text(i - 1), "pub" | ")");
        let line = self.toks[i].line;
        let mut leaves = Vec::new();
        let mut j = i + 1;
        parse_use_tree(&self.toks, &mut j, &[], &mut leaves);
        let in_test = self.in_test();
        for leaf in leaves {
            let scope = self.scope();
            self.out.paths.push(PathUse {
                scope,
                line,
                leaf,
                is_use: true,
                is_reexport,
                in_test,
            });
        }
        j.saturating_sub(1)
    }

    fn code_path(&mut self, i: usize) -> usize {
        let mut segments = vec![self.toks[i].text.clone()];
        let mut j = i + 1;
        while self.text(j) == "::" && self.toks.get(j + 1).is_some_and(Token::is_ident) {
            segments.push(self.toks[j + 1].text.clone());
            j += 2;
        }
        if i == 0 || self.text(i - 1) != "::" {
            let leaf = UseLeaf {
                segments,
                binds: None,
            };
            let (line, scope, in_test) = (self.toks[i].line, self.scope(), self.in_test());
            let is_reexport = false;
            self.out.paths.push(PathUse {
                scope,
                line,
                leaf,
                is_use: false,
                is_reexport,
                in_test,
            });
        }
        j - 1
    }
}

/// Index of the `)` matching the `(` at `open`.
fn matching_paren(toks: &[Token], open: usize) -> usize {
    let mut depth = 0;
    for (k, t) in toks.iter().enumerate().skip(open) {
        match t.text.as_str() {
            "(" => depth += 1,
            ")" => {
                depth -= 1;
                if depth == 0 {
                    return k;
                }
            }
            _ => {}
        }
    }
    toks.len()
}

/// Parses one use tree starting at `*j` (after `use` or inside a group) under `prefix`.
fn parse_use_tree(toks: &[Token], j: &mut usize, prefix: &[String], out: &mut Vec<UseLeaf>) {
    let mut segs = prefix.to_vec();
    if toks.get(*j).is_some_and(|t| t.text == "::") {
        *j += 1;
    }
    while let Some(t) = toks.get(*j) {
        match t.text.as_str() {
            "{" => {
                *j += 1;
                while toks.get(*j).is_some_and(|t| t.text != "}") {
                    parse_use_tree(toks, j, &segs, out);
                    if toks.get(*j).is_some_and(|t| t.text == ",") {
                        *j += 1;
                    }
                }
                *j += 1;
                return;
            }
            "*" => {
                segs.push("*".into());
                *j += 1;
                out.push(UseLeaf {
                    segments: segs,
                    binds: None,
                });
                return;
            }
            _ if t.is_ident() => {
                // `self` as a group element names the group's prefix itself.
                let names_prefix = t.text == "self" && !prefix.is_empty() && segs == prefix;
                if !names_prefix {
                    segs.push(t.text.clone());
                }
                *j += 1;
                if toks.get(*j).is_some_and(|t| t.text == "::") {
                    *j += 1;
                    continue;
                }
                let mut binds = segs.last().cloned();
                if toks.get(*j).is_some_and(|t| t.text == "as") {
                    binds = toks
                        .get(*j + 1)
                        .map(|t| t.text.clone())
                        .filter(|n| n != "_");
                    *j += 2;
                }
                out.push(UseLeaf {
                    segments: segs,
                    binds,
                });
                return;
            }
            _ => return,
        }
    }
}

/// `#[path = "…"]` attributes by the line of the `mod` they precede.
fn path_attributes(src: &str) -> BTreeMap<usize, String> {
    let mut out = BTreeMap::new();
    let mut pending: Option<String> = None;
    for (n, line) in src.lines().enumerate() {
        let l = line.trim();
        if let Some(rest) = l.strip_prefix("#[path") {
            let value = rest.split('"').nth(1).unwrap_or_default();
            pending = Some(value.to_string());
        } else if l.starts_with("#[") || l.is_empty() {
            continue;
        } else if let Some(p) = pending.take() {
            out.insert(n + 1, p);
        }
    }
    out
}
