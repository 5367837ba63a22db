//! The outputs of `btfpt check`: one console line per case, a static `index.html` (no network:
//! PNG files beside it) and `junit.xml` for CI systems.

use super::{Case, Checked, Outcome};
use btfpt::metrics::{self, Verdict};
use std::fmt::Write as _;
use std::path::Path;

/// Full colour of the relative difference image at ±this (10 %).
const DIFF_SCALE: f64 = 0.1;

/// The console line of one case.
pub fn line(case: &Case, seconds: f64, result: &Result<Checked, String>, width: usize) -> String {
    let head = |tag: &str| {
        format!(
            "{tag:5} {:width$}  {:>5} spp {:6.1} s",
            case.name, case.spp, seconds
        )
    };
    match result {
        Err(e) => format!("{}  error: {e}", head("ERROR")),
        Ok(c) => {
            let figures = match &c.comparison.calibrated {
                Some(v) => format!(
                    "relMSE {:.2e}, luminance ratio {:.4}, bias z {:+.2}, {}",
                    c.comparison.relmse,
                    c.comparison.mean_luminance_ratio,
                    v.bias.z,
                    worst_scale(v)
                ),
                None => format!("relMSE {:.2e}", c.comparison.relmse),
            };
            if c.failures.is_empty() {
                format!("{}  {figures}", head("PASS"))
            } else {
                format!(
                    "{}  {figures}\n      {}",
                    head("FAIL"),
                    c.failures.join("\n      ")
                )
            }
        }
    }
}

/// "max |z| Z of T on b×b" for the verdict scale closest to its threshold.
fn worst_scale(v: &Verdict) -> String {
    v.scales
        .iter()
        .filter(|s| s.in_verdict)
        .max_by(|a, b| {
            (a.test.max_abs_z / a.test.threshold).total_cmp(&(b.test.max_abs_z / b.test.threshold))
        })
        .map(|s| {
            format!(
                "max |z| {:.2} of {:.2} on {b}×{b}",
                s.test.max_abs_z,
                s.test.threshold,
                b = s.test.block
            )
        })
        .unwrap_or_default()
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// A file-name-safe form of a case name.
fn file_stem(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Writes the case's four images beside the report; returns their file names.
fn images(dir: &Path, case: &Case, c: &Checked) -> anyhow::Result<[String; 4]> {
    let stem = file_stem(&case.name);
    let names = [
        format!("{stem}.render.png"),
        format!("{stem}.reference.png"),
        format!("{stem}.diff.png"),
        format!("{stem}.z.png"),
    ];
    btfpt::io::write_png_srgb(&dir.join(&names[0]), &c.test)?;
    btfpt::io::write_png_srgb(&dir.join(&names[1]), &c.reference)?;
    let diff = metrics::relative_diff_image(&c.test, &c.reference, DIFF_SCALE)?;
    btfpt::io::write_png_srgb(&dir.join(&names[2]), &metrics::with_legend(&diff, "10%"))?;
    let z = match &c.comparison.calibrated {
        Some(v) => v.pixel_test(),
        None => c.comparison.pixel_test.as_ref().expect("a z-test ran"),
    };
    let zimg = metrics::z_diff_image(z);
    btfpt::io::write_png_srgb(
        &dir.join(&names[3]),
        &metrics::with_legend(&zimg, &format!("{:.2}Z", z.threshold)),
    )?;
    Ok(names)
}

fn figures_table(c: &Checked) -> String {
    let m = &c.comparison;
    let mut s = format!(
        "<table class=fig><tr><td>MAE</td><td>{:.4e}</td></tr><tr><td>RMSE</td><td>{:.4e}</td></tr>\
         <tr><td>relMSE</td><td>{:.4e}</td></tr><tr><td>mean luminance ratio</td><td>{:.5}</td></tr>",
        m.mae, m.rmse, m.relmse, m.mean_luminance_ratio
    );
    if let Some(v) = &m.calibrated {
        let _ = write!(
            s,
            "<tr><td>noise</td><td>{}</td></tr><tr><td>α</td><td>{} over {} tests</td></tr>\
             <tr><td>global bias</td><td>{} weights: mean {:+.3e} = {:+.2} s.e. (limit ±{:.2})</td></tr>",
            esc(&v.noise),
            v.alpha,
            v.tests_in_verdict,
            v.bias.weights,
            v.bias.mean,
            v.bias.z,
            v.bias.threshold
        );
        for sc in &v.scales {
            let t = &sc.test;
            let _ = write!(
                s,
                "<tr><td>{b}×{b} z-test{}</td><td>{} of {} failing (|z| &gt; {:.2}), max |z| {:.2}, var(z) {:.3}</td></tr>",
                if sc.in_verdict { "" } else { " (information)" },
                t.failing,
                t.cells,
                t.threshold,
                t.max_abs_z,
                t.var_z,
                b = t.block
            );
        }
    }
    s.push_str("</table>");
    s
}

/// Writes `dir/index.html`, `dir/junit.xml` and the case images (creating `dir` only).
pub fn write(dir: &Path, suite: &Path, outcomes: &[Outcome]) -> anyhow::Result<()> {
    if !dir.is_dir() {
        std::fs::create_dir(dir).map_err(|e| {
            anyhow::anyhow!("{}: cannot create the report folder: {e}", dir.display())
        })?;
    }
    let passed = outcomes
        .iter()
        .filter(|o| matches!(&o.result, Ok(c) if c.failures.is_empty()))
        .count();
    let mut html = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>btfpt check {s}</title>\n<style>\
         body{{font-family:sans-serif;margin:1em;background:#fafafa}} h2{{margin-bottom:.2em}}\
         .pass{{color:#070}} .fail{{color:#b00}} img{{image-rendering:pixelated;width:256px;margin-right:6px;border:1px solid #ccc}}\
         figure{{display:inline-block;margin:0 6px 0 0}} figcaption{{font-size:80%}}\
         table.fig td{{padding:1px 8px;font-size:90%}} pre{{white-space:pre-wrap;color:#b00}}</style></head><body>\n\
         <h1>btfpt check {s}</h1><p>{passed} of {n} cases passed. The verdict is the calibrated test of \
         docs/model.md: a correct render fails with probability α.</p>\n",
        s = esc(&suite.display().to_string()),
        n = outcomes.len()
    );
    let mut junit = String::new();
    let total: f64 = outcomes.iter().map(|o| o.seconds).sum();
    let failures = outcomes
        .iter()
        .filter(|o| matches!(&o.result, Ok(c) if !c.failures.is_empty()))
        .count();
    let errors = outcomes.iter().filter(|o| o.result.is_err()).count();
    let _ = write!(
        junit,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites tests=\"{n}\" failures=\"{failures}\" errors=\"{errors}\" time=\"{total:.3}\">\n\
         <testsuite name=\"{s}\" tests=\"{n}\" failures=\"{failures}\" errors=\"{errors}\" time=\"{total:.3}\">\n",
        n = outcomes.len(),
        s = esc(&suite.display().to_string())
    );
    for o in outcomes {
        let name = esc(&o.case.name);
        let classname = esc(&o.case.file.display().to_string());
        let _ = write!(
            junit,
            "  <testcase classname=\"{classname}\" name=\"{name}\" time=\"{:.3}\"",
            o.seconds
        );
        let _ = write!(
            html,
            "<h2 id=\"{name}\">{name} <span class=\"{}\">{}</span></h2>\n<p>{} at {} spp, seed {}{}; reference {}</p>\n",
            if matches!(&o.result, Ok(c) if c.failures.is_empty()) {
                "pass"
            } else {
                "fail"
            },
            match &o.result {
                Ok(c) if c.failures.is_empty() => "PASS",
                Ok(_) => "FAIL",
                Err(_) => "ERROR",
            },
            esc(&o.case.scene.display().to_string()),
            o.case.spp,
            o.case.seed,
            if o.case.defines.is_empty() {
                String::new()
            } else {
                let d: Vec<String> = o
                    .case
                    .defines
                    .iter()
                    .map(|(k, v)| format!("-D {k}={v}"))
                    .collect();
                format!(", {}", esc(&d.join(" ")))
            },
            esc(&o.case.reference.display().to_string())
        );
        match &o.result {
            Err(e) => {
                let _ = write!(
                    junit,
                    ">\n    <error message=\"{m}\">{m}</error>\n  </testcase>\n",
                    m = esc(e)
                );
                let _ = writeln!(html, "<pre>{}</pre>", esc(e));
            }
            Ok(c) => {
                if c.failures.is_empty() {
                    junit.push_str("/>\n");
                } else {
                    let _ = write!(
                        junit,
                        ">\n    <failure message=\"{}\">{}</failure>\n  </testcase>\n",
                        esc(&c.failures[0]),
                        esc(&c.failures.join("\n"))
                    );
                    let _ = writeln!(html, "<pre>{}</pre>", esc(&c.failures.join("\n")));
                }
                let names = images(dir, &o.case, c)?;
                let captions = [
                    "render".to_string(),
                    "reference".to_string(),
                    format!(
                        "relative luminance difference (Y<sub>t</sub> − Y<sub>r</sub>)/(Y<sub>r</sub> + 0.01): full blue (darker) / red (brighter) at ±{:.0} %, cyan/magenta beyond",
                        100.0 * DIFF_SCALE
                    ),
                    "per-pixel z (largest |z| channel): full blue/red at the per-pixel threshold, cyan/magenta beyond, yellow non-finite".to_string(),
                ];
                html.push_str("<div>");
                for (n, cap) in names.iter().zip(&captions) {
                    let _ = write!(
                        html,
                        "<figure><img src=\"{}\" alt=\"{}\"><figcaption>{cap}</figcaption></figure>",
                        esc(n),
                        esc(n)
                    );
                }
                html.push_str("</div>\n");
                html.push_str(&figures_table(c));
                html.push('\n');
            }
        }
    }
    junit.push_str("</testsuite>\n</testsuites>\n");
    html.push_str("</body></html>\n");
    for (name, text) in [("index.html", &html), ("junit.xml", &junit)] {
        let p = dir.join(name);
        btfpt::io::write_atomic(&p, |w| {
            w.write_all(text.as_bytes())
                .map_err(|e| btfpt::Error::io(&p, e))
        })?;
    }
    Ok(())
}
