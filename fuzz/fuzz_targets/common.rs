//! Shared helper: the loaders take paths, so each input is written to a per-process scratch file.

use std::path::PathBuf;

/// Writes `data` to `<tmp>/btfpt-fuzz-<pid>/<name>` and returns the path.
pub fn scratch(name: &str, data: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("btfpt-fuzz-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let p = dir.join(name);
    std::fs::write(&p, data).expect("scratch file in the temp dir");
    p
}
