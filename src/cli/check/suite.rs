//! A `btfpt check` suite: TOML files of cases (scene, defines, spp, seed, reference, thresholds),
//! read into resolved [`Case`]s with every path made relative to the file that names it.
//!
//! ```toml
//! [defaults]              # optional, for every case of this file
//! spp = 16
//!
//! [[case]]
//! name = "cornell-box"
//! scene = "../scenes/cornell-box/scene.xml"
//! reference = "../reference-images/cornell-box/cornell-box.exr"
//! defines = { max_depth = 8 }
//! seed = 1
//! ```

use anyhow::{Context, bail};
use btfpt::metrics::Calibration;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The fields of a case (and of `[defaults]`) as written; unknown fields are an error.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFields {
    name: Option<String>,
    scene: Option<PathBuf>,
    defines: Option<BTreeMap<String, toml::Value>>,
    spp: Option<u32>,
    seed: Option<u64>,
    reference: Option<PathBuf>,
    sample_variance: Option<PathBuf>,
    variance: Option<PathBuf>,
    reference_variance: Option<bool>,
    reference_spp: Option<u32>,
    alpha: Option<f64>,
    scales: Option<Vec<usize>>,
    sample_variance_floor: Option<f64>,
    max_relmse: Option<f64>,
}

impl CaseFields {
    /// `self` with every missing field taken from `d`.
    fn or(self, d: &CaseFields) -> CaseFields {
        CaseFields {
            name: self.name.or(d.name.clone()),
            scene: self.scene.or(d.scene.clone()),
            defines: match (self.defines, &d.defines) {
                (Some(mut m), Some(dm)) => {
                    for (k, v) in dm {
                        m.entry(k.clone()).or_insert(v.clone());
                    }
                    Some(m)
                }
                (m, dm) => m.or(dm.clone()),
            },
            spp: self.spp.or(d.spp),
            seed: self.seed.or(d.seed),
            reference: self.reference.or(d.reference.clone()),
            sample_variance: self.sample_variance.or(d.sample_variance.clone()),
            variance: self.variance.or(d.variance.clone()),
            reference_variance: self.reference_variance.or(d.reference_variance),
            reference_spp: self.reference_spp.or(d.reference_spp),
            alpha: self.alpha.or(d.alpha),
            scales: self.scales.or(d.scales.clone()),
            sample_variance_floor: self.sample_variance_floor.or(d.sample_variance_floor),
            max_relmse: self.max_relmse.or(d.max_relmse),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SuiteFile {
    defaults: Option<CaseFields>,
    #[serde(default, rename = "case")]
    cases: Vec<CaseFields>,
}

/// One resolved case of a suite.
#[derive(Clone, Debug)]
pub struct Case {
    pub name: String,
    /// The suite file that defines it (for messages).
    pub file: PathBuf,
    pub scene: PathBuf,
    pub defines: Vec<(String, String)>,
    pub spp: u32,
    pub seed: u64,
    pub reference: PathBuf,
    /// The reference's per-sample variance (predicts the test's noise), if used.
    pub sample_variance: Option<PathBuf>,
    /// The reference's variance of its mean, if used.
    pub variance: Option<PathBuf>,
    /// Samples per pixel of a reference written by `--update`.
    pub reference_spp: u32,
    pub calibration: Calibration,
    /// Extra bound on relMSE, if any.
    pub max_relmse: Option<f64>,
}

/// `dir/stem{suffix}.exr` for `dir/stem.exr`.
pub fn beside(reference: &Path, suffix: &str) -> PathBuf {
    let stem = reference
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    reference.with_file_name(format!("{stem}{suffix}.exr"))
}

fn define_value(v: &toml::Value) -> Option<String> {
    match v {
        toml::Value::String(s) => Some(s.clone()),
        toml::Value::Integer(i) => Some(i.to_string()),
        toml::Value::Float(f) => Some(f.to_string()),
        toml::Value::Boolean(b) => Some(b.to_string()),
        _ => None,
    }
}

/// Reads the suite `path`: one TOML file, or every `*.toml` file of a folder (sorted by name).
pub fn load(path: &Path) -> anyhow::Result<Vec<Case>> {
    let files: Vec<PathBuf> = if path.is_dir() {
        let mut v: Vec<PathBuf> = std::fs::read_dir(path)
            .with_context(|| format!("{}: cannot list the suite folder", path.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "toml") && p.is_file())
            .collect();
        v.sort();
        if v.is_empty() {
            bail!("{}: the suite folder has no .toml files", path.display());
        }
        v
    } else if path.is_file() {
        vec![path.to_path_buf()]
    } else {
        bail!("{}: suite file or folder not found", path.display());
    };
    let mut cases: Vec<Case> = Vec::new();
    for f in &files {
        for c in load_file(f)? {
            if let Some(o) = cases.iter().find(|o| o.name == c.name) {
                bail!(
                    "{}: case '{}' is also defined in {} (case names must be unique)",
                    c.file.display(),
                    c.name,
                    o.file.display()
                );
            }
            cases.push(c);
        }
    }
    Ok(cases)
}

fn load_file(file: &Path) -> anyhow::Result<Vec<Case>> {
    let text = std::fs::read_to_string(file)
        .with_context(|| format!("{}: cannot read the suite file", file.display()))?;
    let suite: SuiteFile = toml::from_str(&text)
        .map_err(|e| anyhow::anyhow!("{}: not a valid suite file: {e}", file.display()))?;
    if suite.cases.is_empty() {
        bail!(
            "{}: the suite has no cases (add [[case]] tables)",
            file.display()
        );
    }
    let dir = file.parent().unwrap_or(Path::new("."));
    let defaults = suite.defaults.unwrap_or_default();
    suite
        .cases
        .into_iter()
        .enumerate()
        .map(|(i, c)| resolve(file, dir, i, c.or(&defaults)))
        .collect()
}

fn resolve(file: &Path, dir: &Path, index: usize, c: CaseFields) -> anyhow::Result<Case> {
    let name = match &c.name {
        Some(n) if !n.trim().is_empty() => n.trim().to_string(),
        Some(_) => bail!("{}: case {} has an empty name", file.display(), index + 1),
        None => match &c.reference {
            Some(r) => r
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| format!("case{}", index + 1)),
            None => format!("case{}", index + 1),
        },
    };
    let at = format!("{}: case '{name}'", file.display());
    let scene = dir.join(c.scene.with_context(|| format!("{at}: no scene given"))?);
    let reference = dir.join(
        c.reference
            .with_context(|| format!("{at}: no reference given"))?,
    );
    let spp = c.spp.unwrap_or(16);
    if spp < 2 {
        bail!("{at}: spp {spp} must be at least 2 (the test estimates its own variance)");
    }
    let mut defines = Vec::new();
    for (k, v) in c.defines.unwrap_or_default() {
        let Some(s) = define_value(&v) else {
            bail!("{at}: define '{k}' must be a string, number or boolean");
        };
        defines.push((k, s));
    }
    let use_ref_var = c.reference_variance.unwrap_or(true);
    let pick = |given: Option<PathBuf>, suffix: &str| -> anyhow::Result<Option<PathBuf>> {
        match given {
            Some(p) if use_ref_var => {
                let p = dir.join(p);
                if !p.is_file() {
                    bail!("{at}: variance file {} not found", p.display());
                }
                Ok(Some(p))
            }
            Some(_) => bail!("{at}: a variance file is named but reference_variance = false"),
            None if use_ref_var => Ok(Some(beside(&reference, suffix)).filter(|p| p.is_file())),
            None => Ok(None),
        }
    };
    let sample_variance = pick(c.sample_variance, "_sample_var")?;
    let variance = pick(c.variance, "_var")?;
    let d = Calibration::default();
    let calibration = Calibration {
        alpha: c.alpha.unwrap_or(d.alpha),
        scales: c.scales.unwrap_or(d.scales.clone()),
        sample_variance_floor: c.sample_variance_floor.unwrap_or(d.sample_variance_floor),
        ..d
    };
    if !(calibration.alpha > 0.0 && calibration.alpha < 1.0) {
        bail!("{at}: alpha {} must be in (0, 1)", calibration.alpha);
    }
    if calibration.scales.is_empty() || calibration.scales.contains(&0) {
        bail!("{at}: scales must be a non-empty list of block sides ≥ 1");
    }
    if !(calibration.sample_variance_floor >= 0.0) {
        bail!("{at}: sample_variance_floor must be a non-negative number");
    }
    if let Some(m) = c.max_relmse
        && !(m >= 0.0)
    {
        bail!("{at}: max_relmse must be a non-negative number");
    }
    Ok(Case {
        name,
        file: file.to_path_buf(),
        scene,
        defines,
        spp,
        seed: c.seed.unwrap_or(0),
        reference,
        sample_variance,
        variance,
        reference_spp: c.reference_spp.unwrap_or(spp.saturating_mul(16).max(256)),
        calibration,
        max_relmse: c.max_relmse,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    /// `reference-images/suite.toml` parses, its scenes and references exist, and it lists
    /// every committed reference (`reference-images/<name>/<name>.exr`).
    #[test]
    fn the_committed_suite_lists_every_committed_reference() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("reference-images");
        let cases = load(&root.join("suite.toml")).unwrap_or_else(|e| panic!("{e:#}"));
        for c in &cases {
            assert!(
                c.scene.is_file(),
                "{}: no scene {}",
                c.name,
                c.scene.display()
            );
            assert!(
                c.reference.is_file(),
                "{}: no {}",
                c.name,
                c.reference.display()
            );
        }
        for dir in std::fs::read_dir(&root).unwrap() {
            let dir = dir.unwrap().path();
            let name = dir.file_name().unwrap().to_string_lossy().to_string();
            if dir.join(format!("{name}.exr")).is_file() {
                assert!(
                    cases.iter().any(|c| c.name == name),
                    "reference-images/{name} is not a case of suite.toml"
                );
            }
        }
    }

    #[test]
    fn cases_take_defaults_and_resolve_paths() {
        let d = tempfile::tempdir().unwrap();
        let f = write(
            d.path(),
            "s.toml",
            r#"
            [defaults]
            spp = 8
            defines = { max_depth = 3, width = "32" }
            [[case]]
            scene = "a/scene.xml"
            reference = "refs/a.exr"
            defines = { max_depth = 5 }
            [[case]]
            name = "b"
            scene = "b.xml"
            reference = "b.exr"
            spp = 4
            seed = 2
            scales = [8]
            "#,
        );
        let c = load(&f).unwrap();
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].name, "a");
        assert_eq!(c[0].scene, d.path().join("a/scene.xml"));
        assert_eq!(c[0].spp, 8);
        assert_eq!(
            c[0].defines,
            vec![
                ("max_depth".to_string(), "5".to_string()),
                ("width".to_string(), "32".to_string())
            ]
        );
        assert_eq!((c[1].spp, c[1].seed), (4, 2));
        assert_eq!(c[1].calibration.scales, vec![8]);
        assert_eq!(c[1].reference_spp, 256);
        assert!(c[0].sample_variance.is_none());
    }

    #[test]
    fn bad_suites_name_the_file_and_the_case() {
        let d = tempfile::tempdir().unwrap();
        let e = |text: &str| {
            let f = write(d.path(), "bad.toml", text);
            format!("{:#}", load(&f).unwrap_err())
        };
        let m = e("[[case]\nname = 1");
        assert!(
            m.contains("bad.toml") && m.contains("not a valid suite"),
            "{m}"
        );
        let m = e("[[case]]\nname = \"x\"\nreference = \"r.exr\"");
        assert!(m.contains("case 'x'") && m.contains("no scene"), "{m}");
        let m = e("[[case]]\nname = \"x\"\nscene = \"s.xml\"\nreference = \"r.exr\"\nspeed = 3");
        assert!(m.contains("speed"), "{m}");
        let m = e("[[case]]\nname = \"y\"\nscene = \"s.xml\"\nreference = \"r.exr\"\nalpha = 2.0");
        assert!(m.contains("case 'y'") && m.contains("alpha"), "{m}");
        let m = e(
            "[[case]]\nname = \"y\"\nscene = \"s.xml\"\nreference = \"r.exr\"\nvariance = \"v.exr\"",
        );
        assert!(m.contains("case 'y'") && m.contains("v.exr"), "{m}");
        let m = e(
            "[[case]]\nname = \"z\"\nscene = \"s.xml\"\nreference = \"r.exr\"\n[[case]]\nname = \"z\"\nscene = \"s.xml\"\nreference = \"r.exr\"",
        );
        assert!(m.contains("'z'") && m.contains("unique"), "{m}");
        let m = e("# nothing");
        assert!(m.contains("no cases"), "{m}");
        let m = format!("{:#}", load(&d.path().join("missing.toml")).unwrap_err());
        assert!(m.contains("missing.toml") && m.contains("not found"), "{m}");
    }
}
