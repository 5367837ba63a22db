//! `btfpt merge`: combine partial renders (crop windows and/or sample ranges of one film and
//! seed) into the image a single render would have produced.

use btfpt::render::partial::{
    merge_with, missing_parts, read_partial_exr_with, write_partial_exr_with,
};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `btfpt merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Partial renders written by `btfpt render` (--crop / --spp-range).
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Merged EXR, named `.exr` (an sRGB PNG preview is written next to it).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Runs `btfpt merge`.
pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    use super::output::{ImageFile, image_file};
    image_file(&args.output, &[ImageFile::Exr], "the merged image (-o)")?;
    let png = args.output.with_extension("png");
    super::output::check_file(&png)?;
    let parts = args
        .inputs
        .iter()
        .map(|p| read_partial_exr_with(p))
        .collect::<Result<Vec<_>, _>>()?;
    let names: Vec<String> = args
        .inputs
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let (img, extra, meta) = merge_with(&parts, &names)?;
    write_partial_exr_with(&args.output, &img, &extra, &meta)?;
    btfpt::io::write_png_srgb(&png, &img)?;
    if let Some(m) = missing_parts(&meta) {
        eprintln!("warning: {m}");
    }
    let [x, y, w, h] = meta.crop;
    eprintln!(
        "merged {} inputs: window {x},{y},{w}×{h} of {}×{}, samples {}..{} → {}",
        parts.len(),
        meta.width,
        meta.height,
        meta.spp_begin,
        meta.spp_end,
        args.output.display()
    );
    Ok(())
}
