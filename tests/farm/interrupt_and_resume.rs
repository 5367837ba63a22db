//! Kill tests: a render interrupted by SIGINT and then SIGKILL and resumed twice ends with the same
//! EXR bytes as an uninterrupted render (same seed); so does one stopped the way a scheduler stops a
//! job (SIGTERM at a time limit or on preemption, SIGHUP), resuming where it stopped; a fit killed
//! midway, or stopped by SIGTERM, and rerun writes the same `.plmc` bytes as an uninterrupted fit.
use crate::common;

use btfpt::btf::{self, DirectionSet, RawBtf, StoredEncoding};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant, SystemTime};

/// The binary with stdout discarded and stderr captured (the kill tests read only stderr).
fn btfpt() -> Command {
    let mut c = common::btfpt();
    c.stdout(Stdio::null()).stderr(Stdio::piped());
    c
}

fn signal(child: &Child, sig: &str) {
    let st = Command::new("kill")
        .arg(format!("-{sig}"))
        .arg(child.id().to_string())
        .status()
        .unwrap();
    assert!(st.success(), "kill -{sig} failed");
}

fn mtime(p: &Path) -> Option<SystemTime> {
    std::fs::metadata(p).and_then(|m| m.modified()).ok()
}

/// Waits until `ready()` holds while `child` runs; panics if it exits first or after 60 s.
fn wait_for(child: &mut Child, what: &str, ready: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !ready() {
        if let Some(st) = child.try_wait().unwrap() {
            panic!("the process ended ({st}) before {what}: make the job slower");
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "timeout waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
}

fn stderr_of(child: Child) -> (std::process::ExitStatus, String) {
    let out = child.wait_with_output().unwrap();
    (out.status, String::from_utf8_lossy(&out.stderr).to_string())
}

/// The files of one interrupted-job test: its input, the uninterrupted run's output, the
/// output of the run that is stopped and resumed, and where that run keeps its progress.
struct Job {
    input: PathBuf,
    reference: PathBuf,
    out: PathBuf,
    progress: PathBuf,
}

fn assert_same_bytes(reference: &Path, out: &Path, what: &str) {
    assert!(
        std::fs::read(reference).unwrap() == std::fs::read(out).unwrap(),
        "{what} differs from the uninterrupted one"
    );
}

/// Sized so one thread needs a few seconds even on an idle machine (the interrupted runs must
/// outlive several 0.1 s checkpoint intervals; analytic spheres made the old 24² job too quick).
fn scene() -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="6"/></integrator>
{}    <shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>
        <transform name="to_world"><scale value="0.6"/><rotate y="1" angle="30"/></transform></shape>
    <shape type="rectangle"><bsdf type="diffuse"/>
        <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><translate y="-0.6"/></transform></shape>
    <shape type="sphere"><float name="radius" value="0.3"/><point name="center" x="0.8" y="1.2" z="0.5"/>
        <emitter type="area"><rgb name="radiance" value="20, 18, 15"/></emitter></shape>
</scene>
"#,
        common::perspective_sensor(45.0, 3.5, 4096, 48, 48)
    )
}

fn render_args(scene: &Path, out: &Path) -> Vec<String> {
    [
        "render",
        &scene.display().to_string(),
        "-o",
        &out.display().to_string(),
        "--threads",
        "1",
        "--seed",
        "7",
        "--checkpoint-interval",
        "0.1",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// The scene written to `dir` and rendered once without interruption.
fn render_job(dir: &Path) -> Job {
    let input = dir.join("scene.xml");
    std::fs::write(&input, scene()).unwrap();
    let reference = dir.join("ref.exr");
    let (st, err) = stderr_of(
        btfpt()
            .args(render_args(&input, &reference))
            .spawn()
            .unwrap(),
    );
    assert!(st.success(), "{err}");
    Job {
        input,
        reference,
        out: dir.join("out.exr"),
        progress: dir.join("out.exr.ckpt"),
    }
}

#[test]
fn render_killed_by_sigint_then_sigkill_resumes_bit_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let Job {
        input: scene,
        reference,
        out,
        progress: ckpt,
    } = render_job(dir.path());

    // 1) SIGINT once the first checkpoint exists: the handler writes a final checkpoint, exits ≠ 0.
    let mut child = btfpt().args(render_args(&scene, &out)).spawn().unwrap();
    wait_for(&mut child, "the first checkpoint", || ckpt.exists());
    signal(&child, "INT");
    let (st, err) = stderr_of(child);
    assert!(!st.success(), "an interrupted render must exit non-zero");
    assert!(err.contains("--resume"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(ckpt.exists() && !out.exists(), "{err}");

    // 2) Resume, then SIGKILL right after it wrote a newer checkpoint (no handler runs).
    let first = mtime(&ckpt);
    let mut args = render_args(&scene, &out);
    args.push("--resume".into());
    let mut child = btfpt().args(&args).spawn().unwrap();
    wait_for(&mut child, "a newer checkpoint", || {
        mtime(&ckpt).is_some_and(|t| Some(t) != first)
    });
    child.kill().unwrap();
    let (st, _) = stderr_of(child);
    assert!(!st.success());
    assert!(
        !out.exists(),
        "a killed render must not leave an output image"
    );

    // 3) Resume to completion: identical bytes to the uninterrupted render.
    let (st, err) = stderr_of(btfpt().args(&args).spawn().unwrap());
    assert!(st.success(), "{err}");
    assert!(err.contains("resuming from"), "{err}");
    assert_same_bytes(&reference, &out, "the resumed EXR");
    assert!(!ckpt.exists(), "the checkpoint is removed after success");
}

/// The number just before the first `after` and after the last `before` preceding it: the P of a
/// stopped render's "interrupted at P%" or of its resume's "(P% done)".
fn percent(text: &str, before: &str, after: &str) -> String {
    let j = text
        .find(after)
        .unwrap_or_else(|| panic!("no '{after}' in: {text}"));
    let i = text[..j]
        .rfind(before)
        .unwrap_or_else(|| panic!("no '{before}' before '{after}' in: {text}"))
        + before.len();
    text[i..j].to_string()
}

#[test]
fn render_stopped_by_sigterm_and_sighup_resumes_bit_exactly_without_redoing_samples() {
    let dir = tempfile::tempdir().unwrap();
    let Job {
        input: scene,
        reference,
        out,
        progress: ckpt,
    } = render_job(dir.path());
    let mut resume = render_args(&scene, &out);
    resume.push("--resume".into());
    // SIGTERM (a scheduler's time limit), then SIGHUP on the resumed run: each writes the final
    // checkpoint as Ctrl-C does, exits non-zero, and the next run starts exactly where it stopped.
    let mut stopped_at = None;
    for (sig, args) in [("TERM", render_args(&scene, &out)), ("HUP", resume.clone())] {
        let before = mtime(&ckpt);
        let mut cmd = btfpt();
        cmd.args(&args);
        // SIGHUP at its default disposition: under `nohup` the child would inherit it ignored
        // and, as it should, keep rendering.
        // SAFETY: only an async-signal-safe call between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                libc::signal(libc::SIGHUP, libc::SIG_DFL);
                Ok(())
            });
        }
        let mut child = cmd.spawn().unwrap();
        wait_for(&mut child, "a new checkpoint", || {
            mtime(&ckpt).is_some_and(|t| Some(t) != before)
        });
        signal(&child, sig);
        let (st, err) = stderr_of(child);
        assert!(
            !st.success(),
            "a render stopped by SIG{sig} must exit non-zero"
        );
        assert!(err.contains("--resume"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(ckpt.exists() && !out.exists(), "{err}");
        if let Some(p) = &stopped_at {
            assert_eq!(&percent(&err, "(", "% done"), p, "{err}");
        }
        stopped_at = Some(percent(&err, "interrupted at ", "%; checkpoint"));
    }
    // Started without --variance, the checkpoint holds no second moments: a resume that asks
    // for the variance is refused before it renders, and the checkpoint stays.
    let mut with_variance = resume.clone();
    let var = dir.path().join("var.exr");
    with_variance.extend(["--variance".into(), var.display().to_string()]);
    let (st, err) = stderr_of(btfpt().args(&with_variance).spawn().unwrap());
    assert!(!st.success() && err.contains("without --variance"), "{err}");
    assert!(ckpt.exists() && !out.exists() && !var.exists(), "{err}");
    let (st, err) = stderr_of(btfpt().args(&resume).spawn().unwrap());
    assert!(st.success(), "{err}");
    let p = stopped_at.unwrap();
    assert_eq!(percent(&err, "(", "% done"), p, "{err}");
    assert!(p.parse::<f64>().unwrap() > 0.0, "{err}");
    assert_same_bytes(&reference, &out, "the resumed EXR");
    assert!(!ckpt.exists(), "the checkpoint is removed after success");
}

/// A 4×4-texel BTF on the 81 UBO2003 directions with texture and a light-dependent lobe.
fn fit_data(path: &Path) {
    let d = DirectionSet::ubo2003();
    let (w, h) = (4usize, 4usize);
    let mut data = Vec::with_capacity(81 * 81 * w * h * 3);
    for v in 0..81 {
        for l in 0..81 {
            for t in 0..w * h {
                let g = 0.2 + 0.5 * (((v * 7 + l * 3 + t * 11) % 13) as f32 / 13.0);
                data.extend_from_slice(&[g, g * 0.7, g * 0.4]);
            }
        }
    }
    let raw = RawBtf::from_f32(d.clone(), d, w, h, StoredEncoding::Linear, &data).unwrap();
    btf::cache::write_raw(&raw, path).unwrap();
}

fn fit_args(data: &Path, out: &Path) -> Vec<String> {
    [
        "fit",
        &data.display().to_string(),
        "-o",
        &out.display().to_string(),
        "--model",
        "plmc",
        "--clusters",
        "4",
        "--features",
        "5",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// `btfpt fit` of `data` into `out` on one thread (so the views finish one by one).
fn fit(data: &Path, out: &Path) -> Command {
    let mut c = common::btfpt();
    c.args(fit_args(data, out)).env("RAYON_NUM_THREADS", "1");
    c
}

/// The fit's standard output once it ran to completion (it must succeed).
fn fit_to_completion(data: &Path, out: &Path) -> String {
    let o = fit(data, out).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A fit of `data` into `out` that runs until three views are finished in `parts`.
fn fit_past_three_views(data: &Path, out: &Path, parts: &Path) -> Child {
    let mut child = fit(data, out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_for(&mut child, "a few finished views", || {
        finished_views(parts) >= 3
    });
    child
}

/// The BTF written to `dir` and fitted once without interruption.
fn fit_job(dir: &Path) -> Job {
    let input = dir.join("m.btfc");
    fit_data(&input);
    let reference = dir.join("ref.plmc");
    fit_to_completion(&input, &reference);
    Job {
        input,
        reference,
        out: dir.join("out.plmc"),
        progress: dir.join("out.plmc.parts"),
    }
}

fn file_names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|r| {
            r.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default()
}

/// Views a fit has finished and kept in its parts folder.
fn finished_views(parts: &Path) -> usize {
    file_names(parts)
        .iter()
        .filter(|n| n.ends_with(".part"))
        .count()
}

#[test]
fn fit_killed_midway_and_rerun_writes_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let Job {
        input: data,
        reference,
        out,
        progress: parts,
    } = fit_job(dir.path());
    let mut child = fit_past_three_views(&data, &out, &parts);
    child.kill().unwrap();
    let _ = stderr_of(child);
    assert!(!out.exists(), "a killed fit must not leave a model file");
    let done = finished_views(&parts);
    assert!(
        done < 81,
        "the fit finished before the kill: make it slower"
    );

    let text = fit_to_completion(&data, &out);
    assert!(text.contains("resumed from"), "{text}");
    assert_same_bytes(&reference, &out, "the resumed fit's .plmc");
    assert!(!parts.exists(), "parts are removed after success");
}

#[test]
fn fit_stopped_by_sigterm_keeps_finished_views_and_resumes_to_the_same_model() {
    let dir = tempfile::tempdir().unwrap();
    let Job {
        input: data,
        reference,
        out,
        progress: parts,
    } = fit_job(dir.path());
    let child = fit_past_three_views(&data, &out, &parts);
    signal(&child, "TERM");
    let (st, err) = stderr_of(child);
    assert!(!st.success(), "a fit stopped by SIGTERM must exit non-zero");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists(), "a stopped fit must not leave a model file");
    let kept = finished_views(&parts);
    assert!(
        (3..81).contains(&kept),
        "{kept} views kept: the fit must stop early and keep what it finished"
    );
    assert!(
        err.contains(&format!("interrupted: {kept} of 81 views finished")),
        "{err}"
    );
    assert!(
        file_names(&parts).iter().all(|n| n.ends_with(".part")),
        "no temporary files left: {:?}",
        file_names(&parts)
    );

    let text = fit_to_completion(&data, &out);
    assert!(
        text.contains(&format!("{kept} views resumed from")),
        "every kept view is reused, none refitted: {text}"
    );
    assert_same_bytes(&reference, &out, "the resumed fit's .plmc");
}
