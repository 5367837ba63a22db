//! The single entry point from the scene loaders to measured BTF materials (`<bsdf type="btf">`).

use crate::bsdf::{Bsdf, BtfBsdf, BtfMaterial, PlmcBsdf};
use crate::btf::plmc;
use crate::{Error, Result};
use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

/// Builds the BSDF of a `<bsdf type="btf">` element declared at `file:line`: `filename` (already
/// resolved against the scene folder), `uv_scale` (texture repeats per unit uv), `model` ("raw",
/// "lm", "plm" or "plmc"; see [`plmc::resolve_model_file`] for which file each one reads; a
/// [`with_model_override`] in force replaces it).
pub fn build_btf(
    file: &Path,
    line: u32,
    filename: &Path,
    uv_scale: f32,
    model_attr: &str,
) -> Result<Bsdf> {
    let scene_error = |msg: String| Error::Scene {
        file: file.to_path_buf(),
        line,
        msg,
    };
    let model = MODEL_OVERRIDE.with(|m| m.borrow().clone());
    let model = model.as_deref().unwrap_or(model_attr);
    let resolved;
    let filename = if model == "raw" {
        resolved = plmc::resolve_model_file(filename, "raw")
            .map_err(|e| scene_error(format!("btf: {e}")))?;
        &resolved
    } else {
        filename
    };
    match model {
        "raw" => {
            // The message names the BTF file and the problem; the scene error adds where it is used.
            let material =
                shared_raw_material(filename).map_err(|e| scene_error(format!("btf: {e}")))?;
            let bsdf = BtfBsdf::new(material, uv_scale).map_err(|e| scene_error(e.to_string()))?;
            Ok(Bsdf::Btf(bsdf))
        }
        "lm" | "plm" | "plmc" => {
            let bsdf = plmc::resolve_model_file(filename, model)
                .and_then(|p| plmc::shared_material(&p))
                .and_then(|m| PlmcBsdf::new(m, uv_scale, false))
                .map_err(|e| scene_error(format!("btf: {e}")))?;
            Ok(Bsdf::Plmc(bsdf))
        }
        other => Err(scene_error(format!(
            "btf model \"{other}\" is not one of \"raw\", \"lm\", \"plm\", \"plmc\""
        ))),
    }
}

thread_local! {
    static MODEL_OVERRIDE: RefCell<Option<String>> = const { RefCell::new(None) };
}

/// Runs `f` (a scene load on this thread) with every `<bsdf type="btf">` using `model` instead of
/// its own `model` property (the CLI's `--btf-model`); `None` leaves the scene as written.
pub fn with_model_override<R>(model: Option<&str>, f: impl FnOnce() -> R) -> R {
    let prev = MODEL_OVERRIDE.with(|m| m.replace(model.map(str::to_string)));
    let out = f();
    MODEL_OVERRIDE.with(|m| *m.borrow_mut() = prev);
    out
}

/// One material per BTF file while anything uses it: a raw BTF can be gigabytes, and several
/// `<bsdf type="btf">` elements (e.g. different `uv_scale`) may name the same file.
fn shared_raw_material(path: &Path) -> Result<Arc<BtfMaterial>> {
    static CACHE: Mutex<Option<HashMap<PathBuf, Weak<BtfMaterial>>>> = Mutex::new(None);
    let key = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    let mut guard = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    let cache = guard.get_or_insert_with(HashMap::new);
    if let Some(m) = cache.get(&key).and_then(Weak::upgrade) {
        return Ok(m);
    }
    cache.retain(|_, w| w.strong_count() > 0);
    let m = Arc::new(BtfMaterial::load(path)?);
    cache.insert(key, Arc::downgrade(&m));
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::btf::{DirectionSet, RawBtf, StoredEncoding};

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
        let scene = Path::new("scene.xml");
        let a = build_btf(scene, 3, &path, 1.0, "raw").unwrap();
        let b = build_btf(scene, 9, &path, 4.0, "raw").unwrap();
        let (Bsdf::Btf(a), Bsdf::Btf(b)) = (a, b) else {
            panic!("not a BTF bsdf");
        };
        assert!(Arc::ptr_eq(a.material(), b.material()));
        let e = build_btf(scene, 5, &path, 1.0, "plmx")
            .unwrap_err()
            .to_string();
        assert!(e.contains("scene.xml:5") && e.contains("plmx"), "{e}");
        let e = build_btf(scene, 6, &path, 0.0, "raw")
            .unwrap_err()
            .to_string();
        assert!(e.contains("scene.xml:6") && e.contains("uv_scale"), "{e}");
        let missing = dir.path().join("missing.btfc");
        let e = build_btf(scene, 7, &missing, 1.0, "raw")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("scene.xml:7") && e.contains("missing.btfc"),
            "{e}"
        );
    }
}
