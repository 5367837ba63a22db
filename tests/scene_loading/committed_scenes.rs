//! Corpus test: every Mitsuba XML scene committed under `scenes/` and `reference-images/` loads
//! (files that another scene `<include>`s are fragments and load through it). Public scene
//! collections are tried by `scripts/mitsuba-corpus.sh`, results in docs/mitsuba-scenes.md.

use btfpt::scene::{self, LoadOptions};
use std::path::{Path, PathBuf};

fn xml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = rd.filter_map(|e| e.ok().map(|e| e.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            // The Python venv of the reference pipeline is not part of the repository.
            if p.file_name().is_some_and(|n| n == ".venv") {
                continue;
            }
            xml_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "xml") {
            out.push(p);
        }
    }
}

/// The files named by `<include filename="…">` in `p` (resolved against its folder).
fn includes(p: &Path) -> Vec<PathBuf> {
    let text = std::fs::read_to_string(p).unwrap_or_default();
    let mut out = Vec::new();
    for part in text.split("<include").skip(1) {
        if let Some(rest) = part.split("filename=\"").nth(1)
            && let Some(name) = rest.split('"').next()
        {
            let f = p.parent().unwrap_or(Path::new(".")).join(name);
            out.push(f.canonicalize().unwrap_or(f));
        }
    }
    out
}

#[test]
fn every_committed_scene_loads() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    xml_files(&root.join("scenes"), &mut files);
    xml_files(&root.join("reference-images"), &mut files);
    let fragments: Vec<PathBuf> = files.iter().flat_map(|f| includes(f)).collect();
    let mut loaded = 0;
    let mut failures = Vec::new();
    for f in &files {
        let canon = f.canonicalize().unwrap_or(f.clone());
        if fragments.contains(&canon) {
            continue;
        }
        match scene::load(f, &LoadOptions::default()) {
            Ok(s) => {
                assert!(!s.meshes.is_empty(), "{}: no shapes", f.display());
                loaded += 1;
            }
            Err(e) => failures.push(format!("{}: {e}", f.display())),
        }
    }
    assert!(
        failures.is_empty(),
        "scenes that do not load:\n{}",
        failures.join("\n")
    );
    assert!(loaded >= 9, "only {loaded} scenes found");
}
