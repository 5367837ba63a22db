//! The single entry point from the scene loaders to measured BTF materials (`<bsdf type="btf">`).
//!
//! The `filename` of a BTF is either a path (UBO2003 folder, UBO2014 `.btf`, `.btfc` cache;
//! relative paths are resolved against the scene folder) or a **synthetic source**
//! `synth:MATERIAL?key=value&...` that btfpt generates in memory with its measurement simulator
//! (`btf::synth`) the first time a scene names it, and keeps for the rest of the process. This
//! lets BTF scenes render on a fresh clone without committing measured data. Keys (all optional,
//! defaults equal to `btfpt synth`'s): `size` (N or WxH texels, 64), `seed` (1), `strata`
//! (sub-texel samples per axis, 2), `subdiv` (height-field cells per texel axis, 4),
//! `directions` (ubo2003 | ubo2014, ubo2003). `synth:corduroy?size=32&seed=1` holds exactly the
//! values that `btfpt synth corduroy --size 32 --seed 1 --format exr -o DIR` writes, so Mitsuba
//! renders the same material from `DIR`.

use crate::bsdf::plmc;
use crate::bsdf::{Bsdf, BtfBsdf, BtfMaterial, PlmcBsdf};
use crate::btf::synth::{MaterialKind, SynthSettings, measure};
use crate::btf::{BtfSource, DirectionSet, RawBtf};
use crate::io::shared::{SharedCache, shared_by_path};
use crate::model::{BtfModel, resolve_model_file};
use crate::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Builds the BSDF of a `<bsdf type="btf">` element declared at `file:line`: `filename` as written
/// in the scene (a path, resolved with `resolve`, or a `synth:` source, see the module doc),
/// `uv_scale` (texture repeats per unit uv), `model` (see [`resolve_model_file`] for which file
/// each one reads; `None` renders what the file holds: a `.plmc` file its own model, raw data raw;
/// the loaders pass [`super::LoadOptions::btf_model`] here when set). Synthetic sources exist only
/// as raw data. Returns the BSDF and the file and model it renders (for the scene summary).
pub fn build_btf(
    file: &Path,
    line: u32,
    filename: &str,
    resolve: &dyn Fn(&str) -> PathBuf,
    uv_scale: f32,
    model: Option<BtfModel>,
) -> Result<(Bsdf, BtfUse)> {
    let t0 = std::time::Instant::now();
    let scene_error = |msg: String| Error::Scene {
        file: file.to_path_buf(),
        line,
        msg,
    };
    if let Some(spec) = SynthSpec::parse(filename) {
        if let Some(m @ BtfModel::Fitted(_)) = model {
            return Err(scene_error(format!(
                "btf: \"{filename}\" is a synthetic raw BTF; model \"{m}\" needs a fitted .plmc file"
            )));
        }
        let material = spec
            .and_then(|s| shared_synth_material(&s))
            .map_err(|e| scene_error(format!("btf: {e}")))?;
        let bsdf = BtfBsdf::new(material, uv_scale).map_err(|e| scene_error(e.to_string()))?;
        let used = BtfUse {
            file: PathBuf::from(filename),
            model: BtfModel::Raw,
            texels: (
                bsdf.material().btf().width(),
                bsdf.material().btf().height(),
            ),
            seconds: t0.elapsed().as_secs_f64(),
        };
        return Ok((Bsdf::Btf(bsdf), used));
    }
    let path = resolve(filename);
    // The message names the BTF source and the problem; the scene error adds where it is used.
    let (source, model) =
        resolve_model_file(&path, model).map_err(|e| scene_error(format!("btf: {e}")))?;
    let bsdf = match model {
        BtfModel::Raw => shared_raw_material(&source)
            .and_then(|m| BtfBsdf::new(m, uv_scale))
            .map(Bsdf::Btf),
        BtfModel::Fitted(_) => plmc::shared_material(&source)
            .and_then(|m| PlmcBsdf::new(m, uv_scale, false))
            .map(Bsdf::Plmc),
    }
    .map_err(|e| scene_error(format!("btf: {e}")))?;
    let texels = match &bsdf {
        Bsdf::Btf(b) => (b.material().btf().width(), b.material().btf().height()),
        Bsdf::Plmc(b) => (b.material().width(), b.material().height()),
        _ => (0, 0),
    };
    let used = BtfUse {
        file: source,
        model,
        texels,
        seconds: t0.elapsed().as_secs_f64(),
    };
    Ok((bsdf, used))
}

/// Which file and model a `<bsdf type="btf">` renders (after the model-file convention and
/// `--btf-model` were applied), and what loading it cost: for the render summary.
#[derive(Clone, Debug, PartialEq)]
pub struct BtfUse {
    /// The file read (raw data or a `.plmc` model), or the `synth:` source as written.
    pub file: PathBuf,
    /// The representation rendered.
    pub model: BtfModel,
    /// Texels (width, height) of the data or model planes.
    pub texels: (usize, usize),
    /// Wall-clock seconds to load or generate it (≈ 0 when shared with an earlier element).
    pub seconds: f64,
}

/// One material per BTF file while anything uses it: a raw BTF can be gigabytes, and several
/// `<bsdf type="btf">` elements (e.g. different `uv_scale`) may name the same file.
fn shared_raw_material(path: &Path) -> Result<Arc<BtfMaterial>> {
    static CACHE: SharedCache<BtfMaterial> = Mutex::new(None);
    shared_by_path(&CACHE, path, BtfMaterial::load)
}

/// Synthetic materials are kept for the whole process (strong references): regenerating one costs
/// seconds, and a small one (32² texels, 81 × 81 directions) is 40 MB.
fn shared_synth_material(spec: &SynthSpec) -> Result<Arc<BtfMaterial>> {
    static CACHE: Mutex<Option<HashMap<String, Arc<BtfMaterial>>>> = Mutex::new(None);
    let key = spec.canonical();
    // Generation happens under the lock so two scenes naming the same source generate it once.
    let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let cache = guard.get_or_insert_with(HashMap::new);
    if let Some(m) = cache.get(&key) {
        return Ok(m.clone());
    }
    let raw = spec.generate()?;
    let m = Arc::new(
        BtfMaterial::new(Arc::new(raw)).map_err(|e| Error::Invalid(format!("{key}: {e}")))?,
    );
    cache.insert(key, m.clone());
    Ok(m)
}

/// A deterministic synthetic BTF source, `synth:MATERIAL?key=value&...` (see the module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSpec {
    /// Procedural material.
    pub material: MaterialKind,
    /// Texels per row.
    pub width: usize,
    /// Rows of texels.
    pub height: usize,
    /// Seed of the material's noise and of the simulator's sampling.
    pub seed: u64,
    /// Stratified sub-texel samples per axis.
    pub strata: usize,
    /// Height-field cells per texel axis.
    pub subdiv: usize,
    /// Direction set name for views and lights: "ubo2003" or "ubo2014".
    pub directions: &'static str,
}

/// Largest texel count per axis of a `synth:` source (a 256² material is 2.6 GB in memory).
const SYNTH_MAX_SIZE: usize = 256;

impl SynthSpec {
    /// The prefix that marks a synthetic source in a `filename`.
    pub const PREFIX: &'static str = "synth:";

    /// `None` if `value` is not a `synth:` source; otherwise the parsed spec or an error naming
    /// the source and the problem.
    pub fn parse(value: &str) -> Option<Result<Self>> {
        let body = value.trim().strip_prefix(Self::PREFIX)?;
        Some(Self::parse_body(value, body))
    }

    fn parse_body(value: &str, body: &str) -> Result<Self> {
        let err = |msg: String| Error::Invalid(format!("\"{value}\": {msg}"));
        let (name, query) = body.split_once('?').unwrap_or((body, ""));
        let material = MaterialKind::from_name(name.trim()).map_err(|e| err(e.to_string()))?;
        let mut spec = SynthSpec {
            material,
            width: 64,
            height: 64,
            seed: 1,
            strata: 2,
            subdiv: 4,
            directions: "ubo2003",
        };
        for pair in query.split('&').filter(|p| !p.trim().is_empty()) {
            let Some((k, v)) = pair.split_once('=') else {
                return Err(err(format!("\"{pair}\" is not key=value")));
            };
            let (k, v) = (k.trim(), v.trim());
            let int = |lo: usize, hi: usize| -> Result<usize> {
                v.parse::<usize>()
                    .ok()
                    .filter(|n| (lo..=hi).contains(n))
                    .ok_or_else(|| err(format!("{k}={v} is not an integer in {lo}..={hi}")))
            };
            match k {
                "size" => {
                    let (w, h) = match v.split_once(['x', 'X']) {
                        Some((w, h)) => (w.trim(), h.trim()),
                        None => (v, v),
                    };
                    let dim = |s: &str| {
                        s.parse::<usize>()
                            .ok()
                            .filter(|n| (1..=SYNTH_MAX_SIZE).contains(n))
                            .ok_or_else(|| {
                                err(format!(
                                    "size={v} is not N or WxH with 1 ≤ N ≤ {SYNTH_MAX_SIZE}"
                                ))
                            })
                    };
                    spec.width = dim(w)?;
                    spec.height = dim(h)?;
                }
                "seed" => {
                    spec.seed = v
                        .parse()
                        .map_err(|_| err(format!("seed={v} is not an unsigned integer")))?;
                }
                "strata" => spec.strata = int(1, 16)?,
                "subdiv" => spec.subdiv = int(1, 16)?,
                "directions" => {
                    spec.directions = match v.to_ascii_lowercase().as_str() {
                        "ubo2003" => "ubo2003",
                        "ubo2014" => "ubo2014",
                        _ => {
                            return Err(err(format!(
                                "directions={v} is unknown (expected ubo2003 or ubo2014)"
                            )));
                        }
                    }
                }
                _ => {
                    return Err(err(format!(
                        "unknown key \"{k}\" (known: size, seed, strata, subdiv, directions)"
                    )));
                }
            }
        }
        Ok(spec)
    }

    /// A canonical form of the source (all keys, fixed order): the cache key.
    pub fn canonical(&self) -> String {
        format!(
            "synth:{}?size={}x{}&seed={}&strata={}&subdiv={}&directions={}",
            self.material.name(),
            self.width,
            self.height,
            self.seed,
            self.strata,
            self.subdiv,
            self.directions
        )
    }

    /// The measurement settings `btfpt synth` uses for this spec (one clamped bounce).
    pub fn settings(&self) -> SynthSettings {
        let dirs = if self.directions == "ubo2014" {
            DirectionSet::ubo2014()
        } else {
            DirectionSet::ubo2003()
        };
        SynthSettings {
            views: dirs.clone(),
            lights: dirs,
            strata: self.strata,
            seed: self.seed,
            interreflection: true,
            indirect_clamp: 1.0,
            progress: false,
        }
    }

    /// Builds the micro-surface and measures it (on the current rayon pool; deterministic).
    pub fn generate(&self) -> Result<RawBtf> {
        let surface = self
            .material
            .build(self.width, self.height, self.subdiv, self.seed)
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.canonical())))?;
        measure(&surface, &self.settings())
            .map_err(|e| Error::Invalid(format!("{}: {e}", self.canonical())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::{BtfSource, DirectionSet, RawBtf, StoredEncoding};

    fn build(line: u32, filename: &str, uv_scale: f32, model: &str) -> Result<Bsdf> {
        build_btf(
            Path::new("scene.xml"),
            line,
            filename,
            &|f| PathBuf::from(f),
            uv_scale,
            Some(BtfModel::parse(model)?),
        )
        .map(|(bsdf, _)| bsdf)
    }

    #[test]
    fn raw_btf_from_a_cache_file_is_shared_and_errors_name_the_place() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.btfc");
        let set = DirectionSet::ubo2003();
        let data: Vec<f32> = (0..81 * 81 * 2 * 2 * 3)
            .map(|i| (i % 7) as f32 * 0.1)
            .collect();
        let raw = RawBtf::from_f32(set.clone(), set, 2, 2, StoredEncoding::Linear, &data).unwrap();
        crate::btf::cache::write_raw(&raw, &path).unwrap();
        let name = path.to_str().unwrap();
        let a = build(3, name, 1.0, "raw").unwrap();
        let b = build(9, name, 4.0, "raw").unwrap();
        let (Bsdf::Btf(a), Bsdf::Btf(b)) = (a, b) else {
            panic!("not a BTF bsdf");
        };
        assert!(Arc::ptr_eq(a.material(), b.material()));
        let e = build(5, name, 1.0, "plmx").unwrap_err().to_string();
        assert!(e.contains("plmx"), "{e}");
        let e = build(6, name, 0.0, "raw").unwrap_err().to_string();
        assert!(e.contains("scene.xml:6") && e.contains("uv_scale"), "{e}");
        let missing = dir.path().join("missing.btfc");
        let e = build(7, missing.to_str().unwrap(), 1.0, "raw")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("scene.xml:7") && e.contains("missing.btfc"),
            "{e}"
        );
    }

    #[test]
    fn synth_specs_parse_with_cli_defaults_and_reject_bad_keys() {
        assert!(SynthSpec::parse("data/corduroy").is_none());
        let s = SynthSpec::parse("synth:corduroy").unwrap().unwrap();
        assert_eq!(
            (s.material, s.width, s.height, s.seed, s.strata, s.subdiv),
            (MaterialKind::Corduroy, 64, 64, 1, 2, 4)
        );
        let s =
            SynthSpec::parse("synth:Wool?size=16x8&seed=7&strata=1&subdiv=2&directions=UBO2014")
                .unwrap()
                .unwrap();
        assert_eq!(
            (s.material, s.width, s.height, s.seed, s.strata, s.subdiv),
            (MaterialKind::Wool, 16, 8, 7, 1, 2)
        );
        assert_eq!(s.settings().lights.len(), 151);
        assert_eq!(
            s.canonical(),
            "synth:wool?size=16x8&seed=7&strata=1&subdiv=2&directions=ubo2014"
        );
        assert_eq!(
            SynthSpec::parse(&s.canonical()).unwrap().unwrap(),
            s,
            "the canonical form parses back"
        );
        for (bad, what) in [
            ("synth:velvet", "velvet"),
            ("synth:wool?size=0", "size=0"),
            ("synth:wool?size=300", "size=300"),
            ("synth:wool?size=8y8", "size=8y8"),
            ("synth:wool?seed=-1", "seed=-1"),
            ("synth:wool?strata=0", "strata=0"),
            ("synth:wool?colour=red", "colour"),
            ("synth:wool?size", "\"size\""),
            ("synth:wool?directions=ubo1999", "ubo1999"),
        ] {
            let e = SynthSpec::parse(bad).unwrap().unwrap_err().to_string();
            assert!(e.contains(bad) && e.contains(what), "{bad}: {e}");
        }
        let e = build(4, "synth:wool?size=0", 1.0, "raw")
            .unwrap_err()
            .to_string();
        assert!(e.contains("scene.xml:4") && e.contains("size=0"), "{e}");
    }

    #[test]
    fn synth_source_is_generated_once_per_process() {
        let spec = "synth:leather?size=2&seed=3&strata=1&subdiv=1";
        let a = build(1, spec, 1.0, "raw").unwrap();
        let b = build(
            2,
            " synth:leather?seed=3&size=2x2&subdiv=1&strata=1",
            2.0,
            "raw",
        )
        .unwrap();
        let (Bsdf::Btf(a), Bsdf::Btf(b)) = (a, b) else {
            panic!("not a BTF bsdf");
        };
        assert!(
            Arc::ptr_eq(a.material(), b.material()),
            "one material per canonical source and process"
        );
        // Equality with `btfpt synth ... --format exr` output: tests/regression_btf.rs.
        let mine = a.material().btf();
        assert_eq!(
            (mine.width(), mine.height(), mine.views().len()),
            (2, 2, 81)
        );
        assert!(mine.data().iter().any(|v| v.to_f32() > 0.0));
    }
}
