//! No source file imports another that imports it back, directly or around a loop: the file-level
//! import graph of the non-test code (the library and the `btfpt` binary) has no cycle. A file's
//! edges are its `crate::…`, `super::…` and (in the binary) `btfpt::…` paths, each resolved to the
//! deepest module file it names; a path into an item of a module (`crate::render::film::Tile`)
//! points at that module's file, so an item re-exported by a `mod.rs` points at the `mod.rs`.

use crate::{is_test_file, rust_files, src, strip_comments_and_tests};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Which crate a source file belongs to: the library (`src/lib.rs`) or the binary
/// (`src/main.rs` and `src/cli/`).
#[derive(Clone, Copy, PartialEq)]
enum Crate {
    Lib,
    Bin,
}

fn crate_of(rel: &Path) -> Crate {
    if rel == Path::new("main.rs") || rel.starts_with("cli") {
        Crate::Bin
    } else {
        Crate::Lib
    }
}

/// The module path of a file relative to `src/`: `render/packet/mod.rs` → [render, packet].
fn module_path(rel: &Path) -> Vec<String> {
    let mut segs: Vec<String> = rel
        .iter()
        .map(|c| c.to_string_lossy().into_owned())
        .collect();
    let last = segs.pop().expect("a file name");
    let stem = last.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        segs.push(stem.to_string());
    }
    segs
}

/// The file (relative to `src/`) that holds module `path` of crate `krate`, if it is a file.
fn module_file(krate: Crate, path: &[String]) -> Option<PathBuf> {
    if path.is_empty() {
        return Some(PathBuf::from(match krate {
            Crate::Lib => "lib.rs",
            Crate::Bin => "main.rs",
        }));
    }
    if krate == Crate::Bin && path[0] != "cli" {
        return None;
    }
    let dir: PathBuf = path.iter().collect();
    let file = dir.with_extension("rs");
    if src().join(&file).is_file() {
        return Some(file);
    }
    let m = dir.join("mod.rs");
    src().join(&m).is_file().then_some(m)
}

/// The deepest module file along `base` + `segs` (the rest of the path names items, or inline
/// modules, of that file).
fn resolve(krate: Crate, base: &[String], segs: &[String]) -> PathBuf {
    let mut cur: Vec<String> = Vec::new();
    let mut file = module_file(krate, &cur).expect("crate root");
    for s in base.iter().chain(segs) {
        cur.push(s.clone());
        match module_file(krate, &cur) {
            Some(f) => file = f,
            None => break,
        }
    }
    file
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// The paths of the use tree at the start of `s` (`a::b`, `a::{b, c::{d, e}}`, `a::*`, `x as y`),
/// each a list of segments; `self` inside a group names the group's prefix.
fn use_tree(s: &str) -> Vec<Vec<String>> {
    fn tree(s: &[char], i: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
        let skip_ws = |i: &mut usize| {
            while *i < s.len() && s[*i].is_whitespace() {
                *i += 1;
            }
        };
        let mut path = prefix.to_vec();
        loop {
            skip_ws(i);
            if *i < s.len() && s[*i] == '{' {
                *i += 1;
                loop {
                    skip_ws(i);
                    if *i >= s.len() || s[*i] == '}' {
                        *i += 1;
                        return;
                    }
                    tree(s, i, &path, out);
                    skip_ws(i);
                    if *i < s.len() && s[*i] == ',' {
                        *i += 1;
                    }
                }
            }
            let start = *i;
            while *i < s.len() && is_ident(s[*i]) {
                *i += 1;
            }
            let word: String = s[start..*i].iter().collect();
            if word.is_empty() {
                // `*`, or the end of an expression path (`crate::x::<T>`, `crate::x(`).
                if *i < s.len() && s[*i] == '*' {
                    *i += 1;
                }
                break;
            }
            if word != "self" {
                path.push(word);
            }
            if s.get(*i..*i + 2) == Some(&[':', ':']) {
                *i += 2;
                continue;
            }
            // `x as y`
            let mut j = *i;
            while j < s.len() && s[j].is_whitespace() {
                j += 1;
            }
            if s.get(j..j + 3) == Some(&['a', 's', ' ']) {
                *i = j + 3;
                skip_ws(i);
                while *i < s.len() && is_ident(s[*i]) {
                    *i += 1;
                }
            }
            break;
        }
        out.push(path);
    }
    let chars: Vec<char> = s.chars().collect();
    let mut out = Vec::new();
    tree(&chars, &mut 0, &[], &mut out);
    out
}

/// Inline modules of `code` (`mod NAME {`): (name, body start, body end).
fn inline_modules(code: &str) -> Vec<(String, usize, usize)> {
    let mut out = Vec::new();
    for (at, _) in code.match_indices("mod ") {
        if at > 0 && is_ident(code[..at].chars().next_back().unwrap_or(' ')) {
            continue;
        }
        let rest = &code[at + 4..];
        let name: String = rest.chars().take_while(|&c| is_ident(c)).collect();
        if name.is_empty() || !rest[name.len()..].trim_start().starts_with('{') {
            continue;
        }
        let open = at + 4 + name.len() + rest[name.len()..].find('{').expect("brace");
        let mut depth = 0;
        for (k, c) in code[open..].char_indices() {
            match c {
                '{' => depth += 1,
                '}' => {
                    depth -= 1;
                    if depth == 0 {
                        out.push((name.clone(), open, open + k));
                        break;
                    }
                }
                _ => {}
            }
        }
    }
    out
}

/// The files that the non-test code of `rel` (relative to `src/`) imports, each with the path
/// that makes the edge.
fn imports(rel: &Path, text: &str) -> BTreeMap<PathBuf, String> {
    let krate = crate_of(rel);
    let own = module_path(rel);
    let code = strip_comments_and_tests(text);
    let inline = inline_modules(&code);
    let mut out = BTreeMap::new();
    for prefix in ["crate::", "super::", "btfpt::"] {
        for (at, _) in code.match_indices(prefix) {
            let before = code[..at].chars().next_back().unwrap_or(' ');
            if is_ident(before) || before == ':' {
                continue; // the middle of a longer path (`super::super::`, `x::crate::`)
            }
            // The module this occurrence is written in (inside inline modules, if any).
            let mut here = own.clone();
            for (name, a, b) in &inline {
                if *a < at && at < *b {
                    here.push(name.clone());
                }
            }
            let mut rest = &code[at + prefix.len()..];
            let (target_crate, base) = match prefix {
                "crate::" => (krate, Vec::new()),
                "btfpt::" => (Crate::Lib, Vec::new()),
                _ => {
                    let mut base = here;
                    base.pop();
                    while let Some(r) = rest.strip_prefix("super::") {
                        base.pop();
                        rest = r;
                    }
                    (krate, base)
                }
            };
            if prefix == "btfpt::" && krate == Crate::Lib {
                continue; // a path in a doc example or a string, not an import
            }
            for segs in use_tree(rest) {
                let to = resolve(target_crate, &base, &segs);
                if to != rel {
                    let shown: Vec<String> = base.iter().chain(&segs).cloned().collect();
                    out.entry(to)
                        .or_insert_with(|| format!("{prefix}… = {}", shown.join("::")));
                }
            }
        }
    }
    out
}

/// The file-level import graph of the non-test code: file → (imported file → the path that
/// makes the edge).
fn file_graph() -> BTreeMap<PathBuf, BTreeMap<PathBuf, String>> {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let mut graph = BTreeMap::new();
    for f in files.iter().filter(|f| !is_test_file(f)) {
        let rel = f.strip_prefix(src()).expect("under src/").to_path_buf();
        let text = std::fs::read_to_string(f).expect("readable source");
        graph.insert(rel.clone(), imports(&rel, &text));
    }
    graph
}

/// Each strongly connected component of more than one file (Tarjan's algorithm): its files, and
/// one cycle through it (`a -> b -> … -> a`).
type Component = (Vec<PathBuf>, Vec<PathBuf>);

fn cycles(graph: &BTreeMap<PathBuf, BTreeMap<PathBuf, String>>) -> Vec<Component> {
    let nodes: Vec<&PathBuf> = graph.keys().collect();
    let index_of: BTreeMap<&PathBuf, usize> =
        nodes.iter().enumerate().map(|(i, n)| (*n, i)).collect();
    let succ: Vec<Vec<usize>> = nodes
        .iter()
        .map(|n| {
            graph[*n]
                .keys()
                .filter_map(|t| index_of.get(t).copied())
                .collect()
        })
        .collect();
    // Tarjan's algorithm, recursive (the graph has a few hundred files).
    struct T {
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        sccs: Vec<Vec<usize>>,
    }
    fn visit(v: usize, succ: &[Vec<usize>], t: &mut T) {
        t.index[v] = Some(t.next);
        t.low[v] = t.next;
        t.next += 1;
        t.stack.push(v);
        t.on[v] = true;
        for &w in &succ[v] {
            match t.index[w] {
                None => {
                    visit(w, succ, t);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(iw) if t.on[w] => t.low[v] = t.low[v].min(iw),
                _ => {}
            }
        }
        if Some(t.low[v]) == t.index[v] {
            let mut scc = Vec::new();
            loop {
                let w = t.stack.pop().expect("on the stack");
                t.on[w] = false;
                scc.push(w);
                if w == v {
                    break;
                }
            }
            if scc.len() > 1 {
                t.sccs.push(scc);
            }
        }
    }
    let n = nodes.len();
    let mut t = T {
        index: vec![None; n],
        low: vec![0; n],
        on: vec![false; n],
        stack: Vec::new(),
        next: 0,
        sccs: Vec::new(),
    };
    for v in 0..n {
        if t.index[v].is_none() {
            visit(v, &succ, &mut t);
        }
    }
    // One shortest cycle through the smallest file of each component (breadth-first inside it).
    t.sccs
        .iter()
        .map(|scc| {
            let inside: BTreeSet<usize> = scc.iter().copied().collect();
            let start = *inside.iter().next().expect("non-empty");
            let mut prev: BTreeMap<usize, usize> = BTreeMap::new();
            let mut queue = std::collections::VecDeque::from([start]);
            let mut end = None;
            'search: while let Some(v) = queue.pop_front() {
                for &w in &succ[v] {
                    if w == start {
                        end = Some(v);
                        break 'search;
                    }
                    if inside.contains(&w) && !prev.contains_key(&w) {
                        prev.insert(w, v);
                        queue.push_back(w);
                    }
                }
            }
            let mut path = vec![end.expect("a cycle in a strongly connected component")];
            while let Some(&p) = prev.get(path.last().expect("non-empty")) {
                path.push(p);
            }
            if *path.last().expect("non-empty") != start {
                path.push(start);
            }
            path.reverse();
            path.push(start);
            (
                inside.iter().map(|&i| nodes[i].clone()).collect(),
                path.into_iter().map(|i| nodes[i].clone()).collect(),
            )
        })
        .collect()
}

#[test]
fn no_file_imports_a_file_that_imports_it_back() {
    let graph = file_graph();
    assert!(graph.len() > 100, "only {} source files found", graph.len());
    let found = cycles(&graph);
    let shown: Vec<String> = found
        .iter()
        .map(|(files, c)| {
            let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
            let edges = c
                .windows(2)
                .map(|w| {
                    format!(
                        "  {} -> {}   ({})",
                        w[0].display(),
                        w[1].display(),
                        graph[&w[0]][&w[1]]
                    )
                })
                .collect::<Vec<_>>()
                .join("\n");
            format!("files that reach each other: {}\n{edges}", names.join(", "))
        })
        .collect();
    assert!(
        found.is_empty(),
        "{} import cycles between files (move the item to the file it belongs in):\n{}",
        found.len(),
        shown.join("\n\n")
    );
}

#[test]
fn the_binary_imports_the_library_through_btfpt_paths() {
    let graph = file_graph();
    let render = &graph[Path::new("cli/render.rs")];
    assert!(
        render.keys().any(|f| f.starts_with("render")),
        "cli/render.rs imports nothing of src/render: {render:?}"
    );
}

#[test]
fn paths_resolve_to_the_files_they_name() {
    let trees = use_tree("{film::{self, Tile}, packet::*, math::Vec3 as V}; x");
    assert_eq!(
        trees,
        vec![
            vec!["film".to_string()],
            vec!["film".to_string(), "Tile".to_string()],
            vec!["packet".to_string()],
            vec!["math".to_string(), "Vec3".to_string()],
        ]
    );
    let text = "use super::pool::Pool;\nuse crate::{math::Vec3, render::packet};\nfn f() { super::super::film::Tile::new(crate::math::warp::square_to_disk(p)) }\nmod inner {\n    use super::x::Y;\n}\n";
    let got = imports(Path::new("render/packet/refill.rs"), text);
    let files: BTreeSet<&str> = got.keys().map(|p| p.to_str().unwrap()).collect();
    assert_eq!(
        files,
        [
            "render/packet/pool.rs",
            "render/packet/mod.rs",
            "math/mod.rs",
            "math/warp.rs",
            "render/film.rs"
        ]
        .into_iter()
        .collect(),
        "{got:?}"
    );
    // A test module's imports are not edges.
    let got = imports(
        Path::new("io/pfm.rs"),
        "#[cfg(test)]\nmod tests {\n    use crate::io::image::x;\n}\n",
    );
    assert!(got.is_empty(), "{got:?}");
    // The binary's `btfpt::` paths name library files; its `crate::` paths its own.
    let got = imports(
        Path::new("cli/render.rs"),
        "use btfpt::render::film::Tile;\nuse crate::cli::output::write;\n",
    );
    let files: BTreeSet<&str> = got.keys().map(|p| p.to_str().unwrap()).collect();
    assert_eq!(
        files,
        ["render/film.rs", "cli/output.rs"].into_iter().collect()
    );
}

/// A cycle is found around a loop of three files, and not in a chain.
#[test]
fn cycles_are_found_around_loops() {
    let edge = |a: &str, b: &str| (PathBuf::from(a), PathBuf::from(b));
    let build = |edges: &[(PathBuf, PathBuf)]| {
        let mut g: BTreeMap<PathBuf, BTreeMap<PathBuf, String>> = BTreeMap::new();
        for (a, b) in edges {
            g.entry(a.clone())
                .or_default()
                .insert(b.clone(), "x".into());
            g.entry(b.clone()).or_default();
        }
        g
    };
    let chain = build(&[edge("a", "b"), edge("b", "c"), edge("a", "c")]);
    assert!(cycles(&chain).is_empty());
    let looped = build(&[
        edge("a", "b"),
        edge("b", "c"),
        edge("c", "a"),
        edge("c", "d"),
    ]);
    let found = cycles(&looped);
    assert_eq!(found.len(), 1);
    assert_eq!(found[0].0, ["a", "b", "c"].map(PathBuf::from).to_vec());
    assert_eq!(found[0].1, ["a", "b", "c", "a"].map(PathBuf::from).to_vec());
}
