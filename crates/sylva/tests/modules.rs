//! The engine's module graph has no cycle (issue 22): no module of `crates/sylva/src`
//! imports one that imports it back, at any level of the module tree, and the graph of
//! the top-level modules in `docs/architecture.md` is the one the code has.
//!
//! The check reads the sources: every `crate::…`, `super::…` and `self::…` path (and
//! `use` of a child module), resolved to the deepest module file it names, through
//! `pub use` re-exports, so a path through a parent's re-export counts as an import of
//! the module that defines the item. Edges between a module and its own ancestors or
//! descendants (declarations, re-exports, `super::` helpers) are not cycles; two
//! sibling subtrees that import each other, directly or around a circle, are. Library
//! code only: `#[cfg(test)]` items may use any module.
//!
//! `SYLVA_MODULES_WRITE=1 cargo test --test modules` rewrites the graph in the docs.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

type ModPath = Vec<String>;

/// Tokens of Rust source without comments, string and character literals: identifiers
/// and single punctuation characters, `::` as one token.
fn tokens(src: &str) -> Vec<String> {
    let c: Vec<char> = src.chars().collect();
    let (mut out, mut i) = (Vec::new(), 0);
    let ident = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied().unwrap_or(' ');
        if ch == '/' && next == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
        } else if ch == 'r' && (next == '"' || next == '#') {
            // A raw string r"…" / r#"…"# (or an identifier starting with r).
            let mut j = i + 1;
            while c.get(j) == Some(&'#') {
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                let s = i;
                while i < c.len() && ident(c[i]) {
                    i += 1;
                }
                out.push(c[s..i].iter().collect());
                continue;
            }
            let hashes = j - i - 1;
            i = j + 1;
            while i < c.len() && !(c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#'))) {
                i += 1;
            }
            i += 1 + hashes;
        } else if ch == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
        } else if ch == '\'' {
            // A character literal, or a lifetime / label ('a).
            if next == '\\' {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
            }
        } else if ident(ch) {
            let s = i;
            while i < c.len() && ident(c[i]) {
                i += 1;
            }
            out.push(c[s..i].iter().collect());
        } else if ch == ':' && next == ':' {
            out.push("::".into());
            i += 2;
        } else if ch.is_whitespace() {
            i += 1;
        } else {
            out.push(ch.to_string());
            i += 1;
        }
    }
    out
}

/// The tokens with every `#[cfg(test)]` item removed.
fn without_tests(t: Vec<String>) -> Vec<String> {
    let pat = ["#", "[", "cfg", "(", "test", ")", "]"];
    let mut out = Vec::with_capacity(t.len());
    let mut i = 0;
    while i < t.len() {
        if i + pat.len() <= t.len() && (0..pat.len()).all(|k| t[i + k] == pat[k]) {
            i += pat.len();
            let mut depth = 0i32;
            while i < t.len() {
                match t[i].as_str() {
                    "{" => depth += 1,
                    "}" => {
                        depth -= 1;
                        if depth == 0 {
                            i += 1;
                            break;
                        }
                    }
                    ";" if depth == 0 => {
                        i += 1;
                        break;
                    }
                    _ => {}
                }
                i += 1;
            }
        } else {
            out.push(t[i].clone());
            i += 1;
        }
    }
    out
}

fn is_ident(t: &str) -> bool {
    t.chars().next().is_some_and(|c| c.is_alphabetic() || c == '_')
}

/// Parses a use tree at `t[i..]` under `prefix`; pushes (path, name it binds) per leaf.
fn use_tree(t: &[String], mut i: usize, prefix: &[String], out: &mut Vec<(ModPath, String)>) -> usize {
    let mut path = prefix.to_vec();
    while i < t.len() {
        let tok = t[i].as_str();
        if tok == "{" {
            i += 1;
            while i < t.len() && t[i] != "}" {
                i = use_tree(t, i, &path, out);
                if i < t.len() && t[i] == "," {
                    i += 1;
                }
            }
            return i + 1;
        }
        if tok == "*" {
            out.push((path, "*".into()));
            return i + 1;
        }
        if !is_ident(tok) {
            break;
        }
        if tok != "self" {
            path.push(tok.to_string());
        }
        i += 1;
        if t.get(i).is_some_and(|s| s == "::") {
            i += 1;
            continue;
        }
        let mut name = path.last().cloned().unwrap_or_default();
        if t.get(i).is_some_and(|s| s == "as") {
            name = t.get(i + 1).cloned().unwrap_or_default();
            i += 2;
        }
        out.push((path, name));
        return i;
    }
    out.push((path.clone(), path.last().cloned().unwrap_or_default()));
    i
}

/// Where a path starting at token `i` (`crate`, `super`, `self`) is rooted, and the
/// index of its first segment after that root.
fn path_root(t: &[String], i: usize, here: &[String]) -> (ModPath, usize) {
    match t[i].as_str() {
        "crate" => (Vec::new(), i + 2),
        "self" => (here.to_vec(), i + 2),
        _ => {
            let mut base = here.to_vec();
            base.pop();
            let mut j = i + 2;
            while j + 1 < t.len() && t[j] == "super" && t[j + 1] == "::" {
                base.pop();
                j += 2;
            }
            (base, j)
        }
    }
}

struct Crate {
    /// Module path → its file.
    files: BTreeMap<ModPath, PathBuf>,
    /// Module path → the paths it names (full, from the crate root).
    named: BTreeMap<ModPath, Vec<ModPath>>,
    /// Module path → name → the full path it re-exports.
    reexports: BTreeMap<ModPath, BTreeMap<String, ModPath>>,
}

fn module_path(src: &Path, file: &Path) -> ModPath {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut p: ModPath = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
    if matches!(p.last().map(String::as_str), Some("mod" | "lib")) {
        p.pop();
    }
    p
}

fn read_crate(src: &Path) -> Crate {
    let mut stack = vec![src.to_path_buf()];
    let mut files = BTreeMap::new();
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files.insert(module_path(src, &p), p);
            }
        }
    }
    let (mut named, mut reexports) = (BTreeMap::new(), BTreeMap::new());
    for (m, f) in &files {
        let t = without_tests(tokens(&std::fs::read_to_string(f).unwrap()));
        let mut paths = Vec::new();
        let mut re: BTreeMap<String, ModPath> = BTreeMap::new();
        for i in 0..t.len() {
            let rooted = matches!(t[i].as_str(), "crate" | "super" | "self")
                && t.get(i + 1).is_some_and(|s| s == "::")
                && (i == 0 || t[i - 1] != "::");
            // `use child::…` names a child module relative to this one.
            let child_use = t[i] != "crate"
                && t[i] != "super"
                && t[i] != "self"
                && i > 0
                && t[i - 1] == "use"
                && files.contains_key(&[m.clone(), vec![t[i].clone()]].concat());
            if !rooted && !child_use {
                continue;
            }
            let (root, j) = if rooted { path_root(&t, i, m) } else { (m.clone(), i) };
            let mut leaves = Vec::new();
            use_tree(&t, j, &root, &mut leaves);
            // A re-export: `pub use …;` or `pub(crate) use …;` starting here.
            let is_use = i > 0 && t[i - 1] == "use";
            let public =
                is_use && i >= 2 && (t[i - 2] == "pub" || (i >= 5 && t[i - 2] == ")" && t[i - 5] == "pub"));
            for (p, name) in leaves {
                if public && name != "*" {
                    re.insert(name, p.clone());
                }
                paths.push(p);
            }
        }
        named.insert(m.clone(), paths);
        reexports.insert(m.clone(), re);
    }
    Crate { files, named, reexports }
}

impl Crate {
    /// The module file a full path lands in, following re-exports.
    fn resolve(&self, path: &[String]) -> ModPath {
        let mut path = path.to_vec();
        for _ in 0..8 {
            let k = (0..=path.len()).rev().find(|&k| self.files.contains_key(&path[..k])).unwrap_or(0);
            let module = path[..k].to_vec();
            match path.get(k).and_then(|n| self.reexports[&module].get(n)) {
                Some(target) if target != &path => {
                    let mut next = target.clone();
                    next.extend_from_slice(&path[k + 1..]);
                    path = next;
                }
                _ => return module,
            }
        }
        path
    }

    /// Module → the modules it imports (not itself, its ancestors or descendants).
    fn edges(&self) -> BTreeMap<ModPath, BTreeSet<ModPath>> {
        let related = |a: &ModPath, b: &ModPath| a.starts_with(b) || b.starts_with(a);
        self.named
            .iter()
            .map(|(m, paths)| {
                let to = paths.iter().map(|p| self.resolve(p)).filter(|t| !related(m, t)).collect();
                (m.clone(), to)
            })
            .collect()
    }
}

/// The graph of the children of `parent`: an edge a → b where a file under child a
/// imports a file under child b.
fn sibling_graph(
    edges: &BTreeMap<ModPath, BTreeSet<ModPath>>,
    parent: &[String],
) -> BTreeMap<String, BTreeSet<String>> {
    let d = parent.len();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (a, tos) in edges {
        if a.len() <= d || !a.starts_with(parent) {
            continue;
        }
        for b in tos {
            if b.len() > d && b.starts_with(parent) && a[d] != b[d] {
                g.entry(a[d].clone()).or_default().insert(b[d].clone());
            }
        }
    }
    g
}

/// A cycle in `g`, if it has one.
fn find_cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn dfs(
        v: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        stack.push(v.to_string());
        for w in g.get(v).into_iter().flatten() {
            match state.get(w.as_str()).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|s| s == w).unwrap();
                    let mut c = stack[at..].to_vec();
                    c.push(w.clone());
                    return Some(c);
                }
                0 => {
                    if let Some(c) = dfs(w, g, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in g.keys() {
        if state.get(v.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = dfs(v, g, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

fn src_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let krate = read_crate(&src_dir());
    let edges = krate.edges();
    let mut problems = Vec::new();
    for parent in krate.files.keys() {
        if let Some(cycle) = find_cycle(&sibling_graph(&edges, parent)) {
            let prefix = if parent.is_empty() { String::new() } else { format!("{}::", parent.join("::")) };
            let mut why = Vec::new();
            for w in cycle.windows(2) {
                let (a, b) = (
                    [parent.clone(), vec![w[0].clone()]].concat(),
                    [parent.clone(), vec![w[1].clone()]].concat(),
                );
                for (from, tos) in &edges {
                    for to in tos.iter().filter(|to| from.starts_with(&a) && to.starts_with(&b)) {
                        why.push(format!("    {} imports {}", from.join("::"), to.join("::")));
                    }
                }
            }
            problems.push(format!("{prefix}{{{}}} form a cycle:\n{}", cycle.join(" → "), why.join("\n")));
        }
    }
    assert!(problems.is_empty(), "module cycles in crates/sylva/src:\n{}", problems.join("\n"));
}

/// The top-level graph as the text block `docs/architecture.md` shows.
fn top_level_block(edges: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> String {
    let g = sibling_graph(edges, &[]);
    let krate_top: BTreeSet<String> = edges.keys().filter_map(|m| m.first().cloned()).collect();
    let width = krate_top.iter().map(String::len).max().unwrap_or(0);
    let mut out = String::new();
    for m in &krate_top {
        let to: Vec<&str> = g.get(m).into_iter().flatten().map(String::as_str).collect();
        let to = if to.is_empty() { "(nothing)".to_string() } else { to.join(", ") };
        out.push_str(&format!("{m:<width$} → {to}\n"));
    }
    out
}

#[test]
fn the_module_graph_in_the_docs_is_the_codes() {
    let edges = read_crate(&src_dir()).edges();
    let block = top_level_block(&edges);
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/architecture.md");
    let text = std::fs::read_to_string(&docs).unwrap();
    let (begin, end) = ("<!-- module-graph:begin -->\n```text\n", "```\n<!-- module-graph:end -->");
    let (a, b) = match (text.find(begin), text.find(end)) {
        (Some(a), Some(b)) if a < b => (a + begin.len(), b),
        _ => panic!("docs/architecture.md has no `{begin}` … `{end}` block; it should hold:\n{block}"),
    };
    if std::env::var_os("SYLVA_MODULES_WRITE").is_some() {
        std::fs::write(&docs, format!("{}{block}{}", &text[..a], &text[b..])).unwrap();
        return;
    }
    assert_eq!(
        text[a..b],
        block,
        "the module graph in docs/architecture.md is stale; rerun with SYLVA_MODULES_WRITE=1"
    );
}

#[test]
fn the_checker_sees_a_cycle_through_a_reexport() {
    // Two sibling modules, one importing the other through their parent's re-export.
    let dir = std::env::temp_dir().join(format!("sylva-modules-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::write(dir.join("lib.rs"), "pub mod a;\n").unwrap();
    std::fs::write(dir.join("a/mod.rs"), "pub mod x;\npub mod y;\npub use y::Thing;\n").unwrap();
    std::fs::write(dir.join("a/x.rs"), "use super::Thing;\npub struct X;\n// crate::a::y::Thing\n").unwrap();
    std::fs::write(
        dir.join("a/y.rs"),
        "pub struct Thing;\nfn f() -> crate::a::x::X { let _ = \"crate::nothing\"; todo!() }\n#[cfg(test)]\nmod tests { use crate::b::Z; }\n",
    )
    .unwrap();
    let krate = read_crate(&dir);
    let edges = krate.edges();
    let g = sibling_graph(&edges, &["a".to_string()]);
    let cycle = find_cycle(&g);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(cycle, Some(vec!["x".to_string(), "y".to_string(), "x".to_string()]), "{g:?}");
    assert_eq!(
        edges[&vec!["a".to_string(), "y".to_string()]].len(),
        1,
        "comments, strings and tests are not imports"
    );
}
