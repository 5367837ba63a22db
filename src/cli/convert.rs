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
    /// Input BTF: UBO2003 folder, UBO2014 `.btf` or `.btfc`.
    pub input: PathBuf,
    /// Output: `NAME.btfc` for the cache, or a folder name without extension for UBO2003 images
    /// (any other extension is an error).
    pub output: PathBuf,
    /// Image encoding when the output is a UBO2003 folder.
    #[arg(long, value_enum, default_value = "exr")]
    pub images: Images,
}

/// Converts one BTF.
pub fn run(args: ConvertArgs) -> anyhow::Result<()> {
    let out = super::output::btf_output(&args.output)?;
    let t0 = Instant::now();
    if out == super::output::BtfOutput::Cache {
        let src = btf::open(&args.input)
            .with_context(|| format!("cannot open {}", args.input.display()))?;
        btf::cache::write_cache(src.as_ref(), &args.output)?;
    } else {
        let src = btf::open(&args.input)
            .with_context(|| format!("cannot open {}", args.input.display()))?;
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
        let raw = btf::load_raw(&args.input)?;
        let kind = match args.images {
            Images::Png8 => ImageKind::Png8,
            Images::Png16 => ImageKind::Png16,
            Images::Exr => ImageKind::Exr,
        };
        btf::ubo2003::write_folder(&raw, &args.output, kind)?;
    }
    println!(
        "wrote {} in {:.2} s",
        args.output.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
