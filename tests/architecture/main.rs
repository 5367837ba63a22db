//! The module structure of `src/` (docs/architecture.md) is checked here, so a cycle cannot come
//! back unnoticed: data flow raw BTF → fit → model file → render means each top-level module
//! may use only the modules of lower layers, and `fit` and `bsdf` (model writer and reader) never
//! each other. Test code (`tests.rs` files, `tests/` folders, `#[cfg(test)]` modules) is exempt.
//! Also checked: no non-test source file is over 900 lines (a file holds one concept).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

mod import_cycles;

/// Layer of each top-level module of the library: a module may use only lower layers.
const LAYERS: &[(&str, u32)] = &[
    ("math", 0),
    ("io", 1),
    ("plugin", 1),
    ("geometry", 2),
    ("metrics", 2),
    ("btf", 3),
    ("model", 4),
    ("fit", 5),
    ("bsdf", 5),
    ("light", 6),
    ("scene", 7),
    ("render", 8),
    ("cli", 9),
];

/// Largest non-test source file, in lines.
const MAX_LINES: usize = 900;

fn src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// Module names declared `#[cfg(test)] mod NAME;` in `text`.
fn test_only_mods(text: &str) -> BTreeSet<String> {
    let lines: Vec<&str> = text.lines().map(str::trim).collect();
    let mut out = BTreeSet::new();
    for w in lines.windows(2) {
        if w[0] == "#[cfg(test)]"
            && let Some(rest) = w[1]
                .strip_prefix("mod ")
                .or_else(|| w[1].strip_prefix("pub(crate) mod "))
            && let Some(name) = rest.strip_suffix(';')
        {
            out.insert(name.to_string());
        }
    }
    out
}

/// True if `file` is test code: a `tests.rs` or a file under a `tests/` folder, or a module its
/// parent declares under `#[cfg(test)]`.
fn is_test_file(file: &Path) -> bool {
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let in_tests_folder = file
        .strip_prefix(src())
        .is_ok_and(|rel| rel.parent().is_some_and(|d| d.iter().any(|c| c == "tests")));
    if stem == "tests" || in_tests_folder {
        return true;
    }
    let dir = file.parent().expect("file in a folder");
    let (parent, name) = if stem == "mod" {
        let up = dir.parent().expect("module folder in a folder");
        let name = dir.file_name().and_then(|s| s.to_str()).unwrap_or("");
        (up.join("mod.rs"), name.to_string())
    } else {
        (dir.join("mod.rs"), stem.to_string())
    };
    let parent = if parent.exists() {
        parent
    } else {
        // A top-level folder module is declared in lib.rs.
        src().join("lib.rs")
    };
    std::fs::read_to_string(&parent).is_ok_and(|t| test_only_mods(&t).contains(&name))
}

/// The non-test code of a file: without comment lines and without a trailing `#[cfg(test)] mod`.
fn code(text: &str) -> String {
    let cut = text.find("#[cfg(test)]\nmod tests {").unwrap_or(text.len());
    text[..cut]
        .lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The non-test code of a file: without comment lines and without any item under
/// `#[cfg(test)]` (a `mod … { … }`, a `mod …;`, a `use …;`, a function).
fn strip_comments_and_tests(text: &str) -> String {
    let mut code = code(&text.replace("#[cfg(test)]\nmod tests {", "#[cfg(test)]\nmod tests_ {"));
    while let Some(at) = code.find("#[cfg(test)]") {
        let rest = &code[at..];
        let semi = rest.find(';').unwrap_or(rest.len());
        let end = match rest.find('{') {
            Some(open) if open < semi => {
                let mut depth = 0;
                let mut end = rest.len();
                for (k, c) in rest[open..].char_indices() {
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                end = open + k + 1;
                                break;
                            }
                        }
                        _ => {}
                    }
                }
                end
            }
            _ => (semi + 1).min(rest.len()),
        };
        code.replace_range(at..at + end, "");
    }
    code
}

/// Top-level modules `code` refers to through `crate::…` paths (also inside `use crate::{…}`).
fn references(code: &str, modules: &BTreeSet<&str>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + 7..];
        if let Some(group) = rest.strip_prefix('{') {
            // use crate::{a::b, c, d::{e, f}}: the first segment of each top-level item.
            let mut depth = 0;
            let mut item_start = true;
            let mut word = String::new();
            for ch in group.chars() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => item_start = true,
                    c if c.is_alphanumeric() || c == '_' => {
                        if item_start {
                            word.push(c);
                        }
                        continue;
                    }
                    _ => {}
                }
                if !word.is_empty() {
                    if modules.contains(word.as_str()) {
                        out.insert(word.clone());
                    }
                    word.clear();
                    if ch != ',' {
                        item_start = false;
                    }
                }
            }
        } else {
            let word: String = rest
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            if modules.contains(word.as_str()) {
                out.insert(word);
            }
        }
    }
    out
}

/// Edges `module → used module` of the non-test code, with the files that make each one.
fn graph() -> BTreeMap<(String, String), Vec<String>> {
    let modules: BTreeSet<&str> = LAYERS.iter().map(|l| l.0).collect();
    let mut edges: BTreeMap<(String, String), Vec<String>> = BTreeMap::new();
    for &(m, _) in LAYERS {
        let dir = src().join(m);
        assert!(dir.is_dir(), "src/{m} is missing (update LAYERS)");
        let mut files = Vec::new();
        rust_files(&dir, &mut files);
        for f in files.iter().filter(|f| !is_test_file(f)) {
            let mut text = std::fs::read_to_string(f).expect("readable source");
            if m == "cli" {
                // The binary names the library's modules as `btfpt::…`.
                text = text.replace("btfpt::", "crate::");
            }
            for r in references(&code(&text), &modules) {
                if r != m {
                    let rel = f.strip_prefix(src()).unwrap_or(f).display().to_string();
                    edges.entry((m.to_string(), r)).or_default().push(rel);
                }
            }
        }
    }
    edges
}

#[test]
fn every_top_level_module_is_in_a_layer() {
    let layered: BTreeSet<&str> = LAYERS.iter().map(|l| l.0).collect();
    for e in std::fs::read_dir(src()).expect("src/") {
        let p = e.expect("entry").path();
        if p.is_dir() {
            let name = p.file_name().and_then(|s| s.to_str()).unwrap_or("");
            assert!(
                layered.contains(name),
                "src/{name} has no layer in tests/architecture/main.rs"
            );
        }
    }
}

#[test]
fn modules_use_only_lower_layers() {
    let layer: BTreeMap<&str, u32> = LAYERS.iter().copied().collect();
    let edges = graph();
    let mut bad = Vec::new();
    println!("module graph (non-test code):");
    for ((a, b), files) in &edges {
        println!("  {a} -> {b}   ({} files)", files.len());
        if layer[b.as_str()] >= layer[a.as_str()] {
            bad.push(format!("{a} -> {b} in {}", files.join(", ")));
        }
    }
    assert!(
        bad.is_empty(),
        "dependencies against the layering (docs/architecture.md):\n{}",
        bad.join("\n")
    );
}

#[test]
fn references_are_found_in_paths_and_use_groups() {
    let modules: BTreeSet<&str> = ["math", "io", "btf", "fit"].into_iter().collect();
    let text = "use crate::{math::Vec3, io::bytes::{Reader, Writer}, Error};\nlet x = crate::btf::open(p);";
    let found = references(text, &modules);
    assert_eq!(
        found,
        ["btf", "io", "math"]
            .iter()
            .map(|s| s.to_string())
            .collect()
    );
    assert!(references("// crate::fit::x\n", &modules).contains("fit"));
    assert!(!references(&code("// crate::fit::x\n"), &modules).contains("fit"));
}

#[test]
fn no_source_file_is_over_the_line_limit() {
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    let long: Vec<String> = files
        .iter()
        .filter(|f| !is_test_file(f))
        .filter_map(|f| {
            let n = std::fs::read_to_string(f).ok()?.lines().count();
            (n > MAX_LINES).then(|| format!("{} ({n} lines)", f.display()))
        })
        .collect();
    assert!(
        long.is_empty(),
        "split these files (one concept each):\n{}",
        long.join("\n")
    );
}

/// Every page under docs/ that a comment in `src/` or `tests/` points to exists, and no comment points
/// to the design notes kept outside the repository (their content lives in docs/).
#[test]
fn doc_pointers_in_comments_name_files_that_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    rust_files(&src(), &mut files);
    rust_files(&root.join("tests"), &mut files);
    let mut bad = Vec::new();
    let mut pointers = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (i, line) in text.lines().enumerate() {
            let Some(comment) = line.find("//").map(|c| &line[c..]) else {
                continue;
            };
            if comment.contains("DESIGN") {
                bad.push(format!("{}:{}: cites DESIGN", f.display(), i + 1));
            }
            for (at, _) in comment.match_indices("docs/") {
                let name: String = comment[at..]
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || "/_-.".contains(*c))
                    .collect();
                let name = name.trim_end_matches('.');
                if name.ends_with(".md") {
                    pointers += 1;
                    if !root.join(name).is_file() {
                        bad.push(format!("{}:{}: {name} does not exist", f.display(), i + 1));
                    }
                }
            }
        }
    }
    assert!(pointers > 10, "only {pointers} doc pointers found");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// Items of `crate::bsdf` that `code` names: the first segment after each `crate::bsdf::`
/// (each top-level item of a `use crate::bsdf::{…}` group).
fn bsdf_items(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = code;
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    while let Some(i) = rest.find("crate::bsdf::") {
        rest = &rest[i + "crate::bsdf::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0;
            let mut start = true;
            for (k, ch) in group.char_indices() {
                match ch {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && (c.is_alphanumeric() || c == '_') => {
                        out.insert(ident(&group[k..]));
                        start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out
}

#[test]
fn render_names_no_bsdf_model() {
    // The integrators see BSDFs only through the `Bsdf` interface (with its lobe flags) and the
    // batched interface `bsdf::batch`: adding a BSDF or a batched kernel never touches render/.
    let allowed: BTreeSet<&str> = ["Bsdf", "BsdfFlags", "batch"].into();
    let mut files = Vec::new();
    rust_files(&src().join("render"), &mut files);
    let mut bad = Vec::new();
    for f in files.iter().filter(|f| !is_test_file(f)) {
        let text = std::fs::read_to_string(f).expect("source file");
        for item in bsdf_items(&code(&text)) {
            if !allowed.contains(item.as_str()) {
                bad.push(format!("{}: bsdf::{item}", f.display()));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "render/ names BSDF internals:\n{}",
        bad.join("\n")
    );
    // The scanner itself finds paths and groups.
    let found = bsdf_items(
        "use crate::bsdf::{Bsdf, batch::{BsdfBatch, L}, plmc::PlmcBsdf};\nlet x = crate::bsdf::Texture::new();",
    );
    assert_eq!(
        found,
        ["Bsdf", "Texture", "batch", "plmc"]
            .into_iter()
            .map(String::from)
            .collect()
    );
}
