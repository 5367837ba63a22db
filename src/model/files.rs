//! Which file holds which representation of a measured material, and which one a scene renders.
//!
//! Convention: the material `S` has its raw data at `S` (UBO2003 folder), `S.btfc` or `S.btf`,
//! and its fitted models at `S.plmc` (any kind) or `S.<model>.plmc`.

use super::{ModelKind, codec};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// A representation of a measured material that a `<bsdf type="btf">` can render.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BtfModel {
    /// The measured data itself (UBO2003 folder, UBO2014 `.btf`, `.btfc` cache or `synth:`).
    Raw,
    /// A fitted model from a `.plmc` file.
    Fitted(ModelKind),
}

impl BtfModel {
    /// The names `<bsdf type="btf" model=…>` and `--btf-model` accept.
    pub const NAMES: [&str; 4] = ["raw", "lm", "plm", "plmc"];

    /// Parses one of [`BtfModel::NAMES`].
    pub fn parse(name: &str) -> Result<Self> {
        Ok(match name {
            "raw" => BtfModel::Raw,
            "lm" => BtfModel::Fitted(ModelKind::Lm),
            "plm" => BtfModel::Fitted(ModelKind::Plm),
            "plmc" => BtfModel::Fitted(ModelKind::PlmC),
            _ => {
                return Err(Error::Invalid(format!(
                    "btf model \"{name}\" is not one of raw, lm, plm, plmc"
                )));
            }
        })
    }

    /// Lower-case name, as on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BtfModel::Raw => "raw",
            BtfModel::Fitted(k) => k.name(),
        }
    }
}

impl std::fmt::Display for BtfModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// True if `path` names a `.plmc` model file (by extension).
pub fn is_model_file(path: &Path) -> bool {
    path.to_string_lossy()
        .to_ascii_lowercase()
        .ends_with(".plmc")
}

/// The kind a readable `.plmc` file holds (None if it is not one).
fn kind_of(path: &Path) -> Option<ModelKind> {
    codec::read_header(path).ok().map(|h| h.kind)
}

/// A BTF file resolved by [`resolve_model_file`]: which reader takes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BtfFile {
    /// Raw measured data (a UBO2003 folder, a UBO2014 `.btf` or a `.btfc` cache).
    Raw(PathBuf),
    /// A `.plmc` model file; which model it holds is learned by reading it.
    Model(PathBuf),
}

impl BtfFile {
    /// The file's path.
    pub fn path(&self) -> &Path {
        match self {
            BtfFile::Raw(p) | BtfFile::Model(p) => p,
        }
    }
}

/// The file holding `model` of the material named by `filename` (a raw BTF or a `.plmc` model).
/// `None` renders what the file itself holds: a `.plmc` file is returned as is, unread (its
/// reader learns the model, so the file is read once), anything else as raw data. A requested
/// fitted kind is found among the candidate `.plmc` files by their headers (the named file
/// first, used as is when it holds that kind or cannot be read).
pub fn resolve_model_file(filename: &Path, model: Option<BtfModel>) -> Result<BtfFile> {
    let is_plmc = is_model_file(filename);
    let model = match model {
        Some(m) => m,
        None if is_plmc => return Ok(BtfFile::Model(filename.to_path_buf())),
        None => BtfModel::Raw,
    };
    let name = filename.to_string_lossy();
    // The material stem: without .plmc / .lm.plmc / .btfc / .btf.
    let stem: String = if is_plmc {
        let s = &name[..name.len() - 5];
        ["lm", "plm", "plmc"]
            .iter()
            .find_map(|m| s.strip_suffix(&format!(".{m}")))
            .unwrap_or(s)
            .to_string()
    } else {
        let lower = name.to_ascii_lowercase();
        [".btfc", ".btf"]
            .iter()
            .find(|e| lower.ends_with(*e))
            .map_or(name.to_string(), |e| {
                name[..name.len() - e.len()].to_string()
            })
    };
    let mut tried = Vec::new();
    match model {
        BtfModel::Raw => {
            if !is_plmc {
                return Ok(BtfFile::Raw(filename.to_path_buf()));
            }
            for c in [stem.clone(), format!("{stem}.btfc"), format!("{stem}.btf")] {
                let p = PathBuf::from(&c);
                if p.exists() {
                    return Ok(BtfFile::Raw(p));
                }
                tried.push(c);
            }
        }
        BtfModel::Fitted(kind) => {
            // The named model file itself, if it is of that kind, or unreadable (the reader will
            // say precisely what is wrong with it).
            if is_plmc && kind_of(filename).is_none_or(|k| k == kind) {
                return Ok(BtfFile::Model(filename.to_path_buf()));
            }
            // The named file was looked at above (or is raw data): only the stem's model files
            // remain, each header read once.
            tried.push(name.to_string());
            let own = format!("{stem}.{}.plmc", kind.name());
            let plain = format!("{stem}.plmc");
            for c in [own, plain].into_iter().filter(|c| *c != name) {
                let p = PathBuf::from(&c);
                if is_model_file(&p) && kind_of(&p) == Some(kind) {
                    return Ok(BtfFile::Model(p));
                }
                tried.push(c);
            }
        }
    }
    Err(Error::format(
        filename,
        format!(
            "no {model} data for this material (looked for {}{})",
            tried.join(", "),
            if model == BtfModel::Raw {
                ""
            } else {
                " holding a model of that kind"
            }
        ),
    ))
}
