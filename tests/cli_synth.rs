//! `btfpt synth` command line: listing and clear errors on bad arguments.
mod common;
use common::btfpt_output as btfpt;

#[test]
fn list_names_all_five_materials() {
    let (ok, out, _) = btfpt(&["synth", "--list"]);
    assert!(ok);
    for m in ["wool", "corduroy", "leather", "wood", "foil"] {
        assert!(
            out.lines().any(|l| l.starts_with(m)),
            "{m} missing in:\n{out}"
        );
    }
}

#[test]
fn bad_arguments_fail_with_a_clear_message() {
    let dir = tempfile::tempdir().expect("tempdir");
    let o = dir.path().join("x");
    let o = o.to_str().expect("utf-8 temp path");
    for (args, needle) in [
        (
            vec!["synth", "velvet", "-o", o],
            "unknown synth material 'velvet'",
        ),
        (vec!["synth", "wool", "--size", "0", "-o", o], "--size"),
        (vec!["synth", "wool", "--size", "8y8", "-o", o], "--size"),
        (
            vec!["synth", "wool", "--directions", "ubo1999", "-o", o],
            "--directions",
        ),
        (
            vec!["synth", "wool", "--format", "jpg", "-o", o],
            "--format",
        ),
        (vec!["synth", "wool"], "-o"),
        (vec!["synth"], "--list"),
    ] {
        let (ok, _, err) = btfpt(&args);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(needle), "{args:?}: '{err}' lacks '{needle}'");
    }
}
