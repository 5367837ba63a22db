//! The single entry point from the scene loaders to measured BTF materials (`<bsdf type="btf">`).
//!
//! The `filename` of a BTF is either a path (UBO2003 folder, UBO2014 `.btf`, `.btfc` cache;
//! relative paths are resolved against the scene folder) or a **synthetic source**
//! `synth:MATERIAL?key=value&...` ([`SynthSpec`]) that btfpt generates with its measurement
//! simulator the first time a scene names it, keeps for the rest of the process, and, when the
//! loader is given a cache folder, keeps there for later processes
//! ([`crate::btf::synth::disk_cache`]). This lets BTF scenes render on a fresh clone without
//! committing measured data. `synth:corduroy?size=32&seed=1` holds exactly the values that
//! `btfpt synth corduroy --size 32 --seed 1 --format exr -o DIR` writes, so Mitsuba renders the
//! same material from `DIR`.

use crate::bsdf::plmc;
use crate::bsdf::{Bsdf, BtfBsdf, BtfMaterial, PlmcBsdf};
use crate::btf::BtfSource;
pub use crate::btf::synth::SynthSpec;
use crate::btf::synth::{SynthOrigin, disk_cache};
use crate::io::shared::{SharedCache, shared_by_path};
use crate::model::{BtfFile, BtfModel, resolve_model_file};
use crate::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Builds the BSDF of a `<bsdf type="btf">` element declared at `file:line`: `filename` as written
/// in the scene (a path, resolved with `resolve`, or a `synth:` source, see the module doc),
/// `uv_scale` (texture repeats per unit uv), `model` (see [`resolve_model_file`] for which file
/// each one reads; `None` renders what the file holds: a `.plmc` file its own model, raw data raw;
/// the loaders pass [`super::LoadOptions::btf_model`] here when set). Synthetic sources exist only
/// as raw data; `synth_cache` is [`super::LoadOptions::synth_cache`]. Returns the BSDF and the
/// file and model it renders (for the scene summary).
pub fn build_btf(
    file: &Path,
    line: u32,
    filename: &str,
    resolve: &dyn Fn(&str) -> PathBuf,
    uv_scale: f32,
    model: Option<BtfModel>,
    synth_cache: Option<&Path>,
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
        let (material, origin) = spec
            .and_then(|s| shared_synth_material(&s, synth_cache))
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
            origin,
            sampling: Some(RawSampling::of(bsdf.material())),
        };
        return Ok((Bsdf::Btf(bsdf), used));
    }
    let path = resolve(filename);
    // The message names the BTF source and the problem; the scene error adds where it is used.
    let source = resolve_model_file(&path, model).map_err(|e| scene_error(format!("btf: {e}")))?;
    let bsdf = match &source {
        BtfFile::Raw(p) => shared_raw_material(p)
            .and_then(|m| BtfBsdf::new(m, uv_scale))
            .map(Bsdf::Btf),
        BtfFile::Model(p) => plmc::shared_material(p)
            .and_then(|m| PlmcBsdf::new(m, uv_scale, false))
            .map(Bsdf::Plmc),
    }
    .map_err(|e| scene_error(format!("btf: {e}")))?;
    let (texels, model, sampling) = match &bsdf {
        Bsdf::Btf(b) => (
            (b.material().btf().width(), b.material().btf().height()),
            BtfModel::Raw,
            Some(RawSampling::of(b.material())),
        ),
        Bsdf::Plmc(b) => (
            (b.material().width(), b.material().height()),
            BtfModel::Fitted(b.material().kind()),
            None,
        ),
        _ => ((0, 0), BtfModel::Raw, None),
    };
    let used = BtfUse {
        file: source.path().to_path_buf(),
        model,
        texels,
        seconds: t0.elapsed().as_secs_f64(),
        origin: None,
        sampling,
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
    /// For a `synth:` source: generated or read from the cache (None when shared with an
    /// earlier element of this process, and for files).
    pub origin: Option<SynthOrigin>,
    /// For raw data: its light-sampling tables (None for fitted models).
    pub sampling: Option<RawSampling>,
}

/// The light-sampling tables of a raw material, for the render summary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawSampling {
    /// Table sets (texel clusters; 1 = the material-wide table).
    pub sets: usize,
    /// Bytes the tables and the texel index take.
    pub bytes: usize,
}

impl RawSampling {
    fn of(m: &BtfMaterial) -> Self {
        RawSampling {
            sets: m.sampler().sets(),
            bytes: m.sampling_bytes(),
        }
    }
}

/// One material per BTF file while anything uses it: a raw BTF can be gigabytes, and several
/// `<bsdf type="btf">` elements (e.g. different `uv_scale`) may name the same file.
fn shared_raw_material(path: &Path) -> Result<Arc<BtfMaterial>> {
    static CACHE: SharedCache<BtfMaterial> = Mutex::new(None);
    shared_by_path(&CACHE, path, BtfMaterial::load)
}

/// Synthetic materials are kept for the whole process (strong references): regenerating one costs
/// seconds, and a small one (32² texels, 81 × 81 directions) is 40 MB. With a cache folder they
/// are read from (or written to) it: see [`disk_cache::load_or_generate`]. The origin is None
/// when the material was already in this process.
fn shared_synth_material(
    spec: &SynthSpec,
    synth_cache: Option<&Path>,
) -> Result<(Arc<BtfMaterial>, Option<SynthOrigin>)> {
    static CACHE: Mutex<Option<HashMap<String, Arc<BtfMaterial>>>> = Mutex::new(None);
    let key = spec.canonical();
    // Generation happens under the lock so two scenes naming the same source generate it once.
    let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let cache = guard.get_or_insert_with(HashMap::new);
    if let Some(m) = cache.get(&key) {
        return Ok((m.clone(), None));
    }
    let (raw, origin) = disk_cache::load_or_generate(spec, synth_cache)?;
    let m = Arc::new(
        BtfMaterial::new(Arc::new(raw)).map_err(|e| Error::Invalid(format!("{key}: {e}")))?,
    );
    cache.insert(key, m.clone());
    Ok((m, Some(origin)))
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
            None,
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
    fn synth_spec_errors_name_the_scene_line() {
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
        // Equality with `btfpt synth ... --format exr` output: tests/images/raw_btf.rs.
        let mine = a.material().btf();
        assert_eq!(
            (mine.width(), mine.height(), mine.views().len()),
            (2, 2, 81)
        );
        assert!(mine.data().iter().any(|v| v.to_f32() > 0.0));
    }
}
