//! `btfpt check`: a suite with one passing and one deliberately failing case, the report files,
//! `--update`, and clear errors for bad suites.

use crate::common::btfpt_output;
use std::path::Path;

fn scene() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/cornell-box/scene.xml")
        .display()
        .to_string()
}

/// A 32×32 Cornell box at 16 spp; `extra` adds TOML lines to the case.
fn case(name: &str, extra: &str) -> String {
    format!(
        "[[case]]\nname = \"{name}\"\nscene = \"{}\"\nreference = \"box.exr\"\nspp = 16\nseed = 3\n\
         reference_spp = 512\ndefines = {{ width = 32, height = 32{extra} }}\n",
        scene()
    )
}

#[test]
fn check_passes_a_correct_render_fails_a_wrong_one_and_writes_the_report() {
    let d = tempfile::tempdir().unwrap();
    let p = |f: &str| d.path().join(f).display().to_string();
    std::fs::write(p("ref.toml"), case("box", "")).unwrap();
    let both = case("box", "") + &case("box-two-bounces", ", max_depth = 2");
    std::fs::write(p("suite.toml"), both).unwrap();

    // The reference: written only for the named case, and said so.
    let (ok, out, err) = btfpt_output(&[
        "check",
        &p("ref.toml"),
        "--update",
        "box",
        "--report",
        &p("r0"),
    ]);
    assert!(ok, "{out}\n{err}");
    assert!(
        out.contains("UPDATED box") && out.contains("512 spp"),
        "{out}"
    );
    for f in ["box.exr", "box_sample_var.exr", "box_var.exr"] {
        assert!(d.path().join(f).is_file(), "{f} not written");
    }

    // The same scene passes; two bounces instead of eight (a darker image) must fail.
    let (ok, out, err) = btfpt_output(&["check", &p("suite.toml"), "--report", &p("report")]);
    assert!(!ok, "the wrong render passed:\n{out}\n{err}");
    let line = |name: &str| {
        out.lines()
            .find(|l| l.split_whitespace().nth(1) == Some(name))
            .unwrap_or_else(|| panic!("no line for {name}:\n{out}"))
            .to_string()
    };
    assert!(line("box").starts_with("PASS"), "{out}");
    assert!(line("box-two-bounces").starts_with("FAIL"), "{out}");
    assert!(
        err.contains("1 of 2 cases failed: box-two-bounces"),
        "{err}"
    );
    let html = std::fs::read_to_string(d.path().join("report/index.html")).unwrap();
    assert!(
        html.contains("box-two-bounces") && !html.contains("http"),
        "network reference in the report"
    );
    for f in [
        "box.render.png",
        "box.reference.png",
        "box.diff.png",
        "box.z.png",
    ] {
        assert!(
            html.contains(f) && d.path().join("report").join(f).is_file(),
            "{f}"
        );
    }
    let junit = std::fs::read_to_string(d.path().join("report/junit.xml")).unwrap();
    assert!(
        junit.contains("tests=\"2\" failures=\"1\" errors=\"0\""),
        "{junit}"
    );
    assert!(junit.contains("<failure message="), "{junit}");
}

#[test]
fn bad_suites_are_clear_errors() {
    let d = tempfile::tempdir().unwrap();
    let p = |f: &str| d.path().join(f).display().to_string();
    std::fs::write(p("bad.toml"), "[[case]\nname = \"x\"").unwrap();
    let (ok, _, err) = btfpt_output(&["check", &p("bad.toml"), "--report", &p("r")]);
    assert!(
        !ok && err.contains("bad.toml") && err.contains("not a valid suite"),
        "{err}"
    );

    std::fs::write(p("noref.toml"), case("lonely", "")).unwrap();
    let (ok, _, err) = btfpt_output(&["check", &p("noref.toml"), "--report", &p("r")]);
    assert!(
        !ok && err.contains("case 'lonely'") && err.contains("box.exr"),
        "{err}"
    );
    assert!(err.contains("--update lonely"), "{err}");

    let missing = case("ghost", "").replace(&scene(), "/nonexistent/scene.xml");
    std::fs::write(p("noscene.toml"), missing).unwrap();
    let (ok, _, err) = btfpt_output(&["check", &p("noscene.toml"), "--report", &p("r")]);
    assert!(
        !ok && err.contains("case 'ghost'") && err.contains("/nonexistent/scene.xml"),
        "{err}"
    );

    let (ok, _, err) = btfpt_output(&["check", &p("noref.toml"), "--update", "nobody"]);
    assert!(
        !ok && err.contains("--update nobody") && err.contains("lonely"),
        "{err}"
    );
    assert!(
        !d.path().join("r").exists(),
        "a report was written for a suite that never ran"
    );
}
