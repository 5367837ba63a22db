//! Measured BTF data: direction sets and their interpolation, the raw BTF in memory, its file
//! formats, the measurement simulator, and (later) the PLM-C evaluation core.

pub mod cache;
pub mod delaunay;
pub mod directions;
pub mod locate16;
pub mod raw;
pub mod synth;
pub mod tiling;
pub mod ubo2003;
pub mod ubo2014;

pub use directions::DirectionSet;
pub use raw::{BtfSource, RawBtf, StoredEncoding};

use crate::{Error, Result};
use std::path::Path;

/// The on-disk BTF formats we recognise, decided from the path alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BtfFormat {
    /// A folder of UBO2003 images.
    Ubo2003Folder,
    /// A Bonn UBO2014 `.btf` file (FMF/DFMF).
    Ubo2014,
    /// Our `.btfc` binary cache.
    Cache,
    /// A fitted `.plmc` model file (a model, not raw data: handled by the PLM-C module).
    Plmc,
}

impl BtfFormat {
    /// Human-readable name.
    pub fn name(self) -> &'static str {
        match self {
            BtfFormat::Ubo2003Folder => "UBO2003 image folder",
            BtfFormat::Ubo2014 => "UBO2014 .btf",
            BtfFormat::Cache => "btfpt cache .btfc",
            BtfFormat::Plmc => "PLM-C model .plmc",
        }
    }
}

/// Decides the format of `path`: a directory is a UBO2003 folder, otherwise the extension
/// (`.btf`, `.btfc`, `.plmc`, case-insensitive) decides.
pub fn detect_format(path: &Path) -> Result<BtfFormat> {
    if path.is_dir() {
        return Ok(BtfFormat::Ubo2003Folder);
    }
    if !path.exists() {
        return Err(Error::format(path, "no such file or folder"));
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "btf" => Ok(BtfFormat::Ubo2014),
        "btfc" => Ok(BtfFormat::Cache),
        "plmc" => Ok(BtfFormat::Plmc),
        _ => Err(Error::format(
            path,
            "unknown BTF format (expected a UBO2003 folder, .btf, .btfc or .plmc)",
        )),
    }
}

fn not_raw(path: &Path) -> Error {
    Error::format(
        path,
        "a .plmc file is a fitted model, not raw BTF data: this command needs the measured data \
         (a UBO2003 folder, a UBO2014 .btf, a .btfc cache or a synth: source); to inspect the \
         model run `btfpt info MODEL.plmc`, to compare it with its data `btfpt eval MODEL.plmc \
         --against DATA`, to render it name it in a scene's <bsdf type=\"btf\">",
    )
}

/// Opens any BTF on disk (UBO2003 folder, UBO2014 `.btf`, our cache) for per-view streaming.
/// Folders and `.btf` files decode views on demand; a cache is memory-mapped.
pub fn open(path: &Path) -> Result<Box<dyn BtfSource + Send>> {
    Ok(match detect_format(path)? {
        BtfFormat::Ubo2003Folder => Box::new(ubo2003::open_folder(path)?),
        BtfFormat::Ubo2014 => Box::new(ubo2014::open_btf(path)?),
        BtfFormat::Cache => Box::new(cache::load_cache(path)?),
        BtfFormat::Plmc => return Err(not_raw(path)),
    })
}

/// Loads a whole BTF into memory (for rendering the raw data); a `.btfc` cache is memory-mapped.
pub fn load_raw(path: &Path) -> Result<RawBtf> {
    match detect_format(path)? {
        BtfFormat::Ubo2003Folder => ubo2003::load_folder(path),
        BtfFormat::Ubo2014 => ubo2014::load_btf(path),
        BtfFormat::Cache => cache::load_cache(path),
        BtfFormat::Plmc => Err(not_raw(path)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open_err(p: &Path) -> String {
        match open(p) {
            Err(e) => e.to_string(),
            Ok(_) => panic!("{} should not open", p.display()),
        }
    }

    #[test]
    fn open_and_load_raw_dispatch_on_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let d = DirectionSet::from_angles_deg(vec![(0.0, 0.0), (40.0, 120.0)]);
        let data: Vec<f32> = (0..2 * 2 * 3 * 2 * 3).map(|i| i as f32 / 64.0).collect();
        let btf = RawBtf::from_f32(d.clone(), d, 3, 2, StoredEncoding::Linear, &data).unwrap();
        let p = dir.path().join("x.BTFC");
        cache::write_raw(&btf, &p).unwrap();
        assert_eq!(detect_format(&p).unwrap(), BtfFormat::Cache);
        assert_eq!(load_raw(&p).unwrap().data(), btf.data());
        assert_eq!(
            open(&p).unwrap().load_view(1).unwrap(),
            btf.load_view(1).unwrap()
        );
        assert_eq!(detect_format(dir.path()).unwrap(), BtfFormat::Ubo2003Folder);

        let plmc = dir.path().join("m.plmc");
        std::fs::write(&plmc, b"PLMC").unwrap();
        assert!(load_raw(&plmc).unwrap_err().to_string().contains("m.plmc"));
        let other = dir.path().join("m.txt");
        std::fs::write(&other, b"x").unwrap();
        assert!(open_err(&other).contains("unknown BTF format"));
        let missing = dir.path().join("missing.btf");
        assert!(
            load_raw(&missing)
                .unwrap_err()
                .to_string()
                .contains("missing.btf")
        );
        // A .btf that is really something else.
        let fake = dir.path().join("fake.btf");
        std::fs::write(&fake, b"hello").unwrap();
        assert!(open_err(&fake).contains("not a UBO2014"));
    }
}
