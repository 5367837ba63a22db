//! What the scene-loading tests share: writing a scene file, loading it, and checking the error
//! a bad one gives.

use btfpt::scene::{self, LoadOptions, Scene};
use std::path::{Path, PathBuf};

/// Writes `text` to `dir/name` (creating its folders) and returns the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).unwrap();
    }
    std::fs::write(&p, text).unwrap();
    p
}

/// The scene at `p`, which must load.
pub fn load(p: &Path) -> Scene {
    scene::load(p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// The message loading `p` with `defines` fails with (panics if it loads).
pub fn load_err(p: &Path, defines: &[(String, String)]) -> String {
    match scene::load(p, &LoadOptions::with_defines(defines)) {
        Ok(_) => panic!("{} loaded, an error was expected", p.display()),
        Err(e) => e.to_string(),
    }
}

/// Asserts that the error message `e` names `file` and `line` (as `:line:`) and contains every
/// one of `needles`.
pub fn assert_names(e: &str, file: &str, line: u32, needles: &[&str]) {
    assert!(e.contains(file), "no file name {file} in: {e}");
    assert!(
        e.contains(&format!(":{line}:")),
        "expected line {line} in: {e}"
    );
    for n in needles {
        assert!(e.contains(n), "expected {n:?} in: {e}");
    }
}
