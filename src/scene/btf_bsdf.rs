//! The single entry point from the scene loaders to measured BTF materials (`<bsdf type="btf">`).

use crate::bsdf::Bsdf;
use crate::{Error, Result};
use std::path::Path;

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
    let _ = (filename, uv_scale, model);
    Err(Error::Scene {
        file: file.to_path_buf(),
        line,
        msg: "btf materials are not available in this build".into(),
    })
}
