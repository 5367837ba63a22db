//! The single entry point from the scene loaders to measured BTF materials (`<bsdf type="btf">`).

use crate::bsdf::{Bsdf, BtfBsdf, BtfMaterial};
use crate::{Error, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, Weak};

/// Builds the BSDF of a `<bsdf type="btf">` element declared at `file:line`: `filename` (already
/// resolved against the scene folder), `uv_scale` (texture repeats per unit uv), `model` ("raw" or
/// a fitted model name).
pub fn build_btf(
    file: &Path,
    line: u32,
    filename: &Path,
    uv_scale: f32,
    model: &str,
) -> Result<Bsdf> {
    let scene_error = |msg: String| Error::Scene {
        file: file.to_path_buf(),
        line,
        msg,
    };
    match model {
        "raw" => {
            // The message names the BTF file and the problem; the scene error adds where it is used.
            let material =
                shared_raw_material(filename).map_err(|e| scene_error(format!("btf: {e}")))?;
            let bsdf = BtfBsdf::new(material, uv_scale).map_err(|e| scene_error(e.to_string()))?;
            Ok(Bsdf::Btf(bsdf))
        }
        other => Err(scene_error(format!(
            "btf model \"{other}\" is not available in this build (supported: \"raw\")"
        ))),
    }
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
