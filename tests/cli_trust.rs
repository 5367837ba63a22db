//! Issue #17, "a CLI users can trust": closed pipes, merge fingerprints, compare self-tests,
//! output extension and output-path rules, and one definition of each reported figure.

use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn btfpt() -> Command {
    Command::new(env!("CARGO_BIN_EXE_btfpt"))
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A 2×2-texel, 3-direction linear BTF cache in `dir`.
fn tiny_cache(dir: &Path) -> PathBuf {
    let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (30.0, 0.0), (60.0, 180.0)]);
    let n = 3 * 3 * 2 * 2;
    let data: Vec<f32> = (0..n).flat_map(|i| [0.25, i as f32 / n as f32, 0.5]).collect();
    let raw = RawBtf::from_f32(d.clone(), d, 2, 2, StoredEncoding::Linear, &data).unwrap();
    let cache = dir.join("t.btfc");
    btf::cache::write_raw(&raw, &cache).unwrap();
    cache
}

/// `btfpt ARGS` with stdout connected to a pipe whose reading end is already closed (what
/// `| head -1` leaves behind): the command must not panic.
fn into_closed_pipe(args: &[&std::ffi::OsStr]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    btfpt()
        .args(args)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

#[test]
fn a_closed_pipe_ends_commands_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let cache = tiny_cache(dir.path());
    for args in [
        vec!["info".as_ref(), cache.as_os_str()],
        vec!["synth".as_ref(), "--list".as_ref()],
    ] {
        let o = into_closed_pipe(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert_ne!(o.status.code(), Some(101), "{args:?}: {err}");
    }
}
