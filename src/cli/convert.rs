//! `btfpt convert IN OUT`: rewrites a BTF as a `.btfc` cache (streamed one view at a time) or as
//! a flat UBO2003 image folder.

use anyhow::Context;
use btfpt::btf::{self, ubo2003::ImageKind};
use std::path::PathBuf;
use std::time::Instant;

/// Image encoding of a UBO2003 output folder.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum Images {
    /// 8-bit sRGB PNG.
    Png8,
    /// 16-bit sRGB PNG.
    Png16,
    /// 32-bit float linear EXR.
    Exr,
}

/// Arguments of `btfpt convert`.
#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// Input BTF: UBO2003 folder, UBO2014 `.btf`, `.btfc` or a `synth:` source.
    pub input: PathBuf,
    /// Output: `NAME.btfc` for the cache, or a folder name without extension for UBO2003 images
    /// (any other extension is an error).
    pub output: PathBuf,
    /// Image encoding when the output is a UBO2003 folder.
    #[arg(long, value_enum, default_value = "exr")]
    pub images: Images,
    /// Write into an existing non-empty folder, replacing the UBO2003 images it holds.
    #[arg(long)]
    pub force: bool,
}

/// Converts one BTF.
pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    let out = super::output::btf_output(&args.output, args.force)?;
    let input = super::btf_input::resolve(&args.input)?;
    if args.input.is_dir()
        && args.output.is_dir()
        && args.input.canonicalize().ok() == args.output.canonicalize().ok()
    {
        anyhow::bail!(
            "{}: the output is the input folder; convert into another folder",
            args.output.display()
        );
    }
    let t0 = Instant::now();
    if out == super::output::BtfOutput::Cache {
        let src =
            btf::open(&input).with_context(|| format!("cannot open {}", args.input.display()))?;
        btf::cache::write_cache(src.as_ref(), &args.output)?;
    } else {
        let src =
            btf::open(&input).with_context(|| format!("cannot open {}", args.input.display()))?;
        let (nv, nl) = (src.views().len(), src.lights().len());
        drop(src);
        if (nv, nl) != (81, 81) {
            anyhow::bail!(
                "{}: a UBO2003 folder holds the 81 UBO2003 directions, {} has {nv} views × {nl} \
                 lights; convert it to a .btfc cache instead",
                args.output.display(),
                args.input.display()
            );
        }
        let raw = btf::load_raw(&input)?;
        let kind = match args.images {
            Images::Png8 => ImageKind::Png8,
            Images::Png16 => ImageKind::Png16,
            Images::Exr => ImageKind::Exr,
        };
        if !matches!(args.images, Images::Exr) {
            let flag = match args.images {
                Images::Png8 => "--images png8",
                _ => "--images png16",
            };
            super::output::warn_clipped(&raw, flag);
        }
        super::output::clear_btf_folder(&args.output)?;
        btf::ubo2003::write_folder(&raw, &args.output, kind)?;
    }
    println!(
        "wrote {} in {:.2} s",
        args.output.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
