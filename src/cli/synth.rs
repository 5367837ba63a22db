//! `btfpt synth`: measure a procedural material with the virtual gonioreflectometer and write it
//! as a UBO2003 folder or a `.btfc` cache (the output's extension decides).

use super::output::BtfOutput;
use anyhow::{Context, bail};
use btfpt::btf::DirectionSet;
use btfpt::btf::cache::write_raw;
use btfpt::btf::synth::{MaterialKind, SynthSettings, measure};
use btfpt::btf::ubo2003::{ImageKind, write_folder};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `btfpt synth`.
#[derive(Args, Debug)]
pub struct SynthArgs {
    /// Material name (see --list).
    pub material: Option<String>,
    /// List the built-in materials and exit.
    #[arg(long)]
    pub list: bool,
    /// Tile size in texels: N (square) or WxH.
    #[arg(long, default_value = "64")]
    pub size: String,
    /// Direction set for views and lights: ubo2003 (81) or ubo2014 (151; needs a .btfc output,
    /// a UBO2003 folder holds only the 81 UBO2003 directions).
    #[arg(long, default_value = "ubo2003")]
    pub directions: String,
    /// Output: a folder name without extension for UBO2003 images, or NAME.btfc for the cache.
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// Random seed (noise of the material and sampling).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Image format of a UBO2003 folder: png8, png16 (sRGB, values above 1 are clipped, with a
    /// warning saying how many) or exr (linear floats, nothing clipped).
    #[arg(long, default_value = "png8")]
    pub format: String,
    /// Stratified samples per texel axis (samples per texel = strata²).
    #[arg(long, default_value_t = 2)]
    pub strata: usize,
    /// Height-field cells per texel axis.
    #[arg(long, default_value_t = 4)]
    pub subdiv: usize,
    /// Direct light only (no inter-reflection bounce).
    #[arg(long)]
    pub no_bounce: bool,
    /// Largest B one sample's inter-reflection may add (inf = unbiased, noisier).
    #[arg(long, default_value_t = 1.0)]
    pub indirect_clamp: f32,
    /// Write into an existing non-empty folder, replacing the UBO2003 images it holds.
    #[arg(long)]
    pub force: bool,
}

fn parse_size(s: &str) -> anyhow::Result<(usize, usize)> {
    let parse = |t: &str| -> anyhow::Result<usize> {
        let v: usize = t
            .trim()
            .parse()
            .with_context(|| format!("--size: '{s}' is not N or WxH"))?;
        if v == 0 || v > 4096 {
            bail!("--size: {v} texels is out of range 1..=4096");
        }
        Ok(v)
    };
    match s.split_once(['x', 'X']) {
        Some((w, h)) => Ok((parse(w)?, parse(h)?)),
        None => {
            let n = parse(s)?;
            Ok((n, n))
        }
    }
}

/// Runs the subcommand.
pub fn run(args: SynthArgs) -> anyhow::Result<()> {
    if args.list {
        for m in MaterialKind::ALL {
            println!("{:<10} {}", m.name(), m.description());
        }
        return Ok(());
    }
    let Some(name) = args.material.as_deref() else {
        bail!("synth: give a material name (or --list to see them)");
    };
    let material = MaterialKind::from_name(name)?;
    let (w, h) = parse_size(&args.size)?;
    let dirs = match args.directions.to_ascii_lowercase().as_str() {
        "ubo2003" => DirectionSet::ubo2003(),
        "ubo2014" => DirectionSet::ubo2014(),
        other => bail!("--directions: unknown set '{other}' (expected ubo2003 or ubo2014)"),
    };
    let kind = match args.format.to_ascii_lowercase().as_str() {
        "png8" => ImageKind::Png8,
        "png16" => ImageKind::Png16,
        "exr" => ImageKind::Exr,
        other => bail!("--format: unknown '{other}' (expected png8, png16 or exr)"),
    };
    let Some(out) = args.output else {
        bail!("synth: give an output with -o (a folder, or NAME.btfc)");
    };
    let target = super::output::btf_output(&out, args.force)?;
    if target == BtfOutput::Folder && args.directions.eq_ignore_ascii_case("ubo2014") {
        bail!(
            "{}: --directions ubo2014 has 151 directions but a UBO2003 folder holds the 81 \
             UBO2003 directions; write the .btfc cache instead (-o NAME.btfc)",
            out.display()
        );
    }
    if !(1..=16).contains(&args.subdiv) {
        bail!("--subdiv: {} is out of range 1..=16", args.subdiv);
    }
    let t0 = std::time::Instant::now();
    let surface = material.build(w, h, args.subdiv, args.seed)?;
    let settings = SynthSettings {
        views: dirs.clone(),
        lights: dirs,
        strata: args.strata,
        seed: args.seed,
        interreflection: !args.no_bounce,
        indirect_clamp: args.indirect_clamp,
        progress: true,
    };
    let btf = measure(&surface, &settings)?;
    let secs = t0.elapsed().as_secs_f64();
    eprintln!(
        "synth {}: {w}×{h} texels, {} views × {} lights, {} samples/texel in {secs:.1} s ({} threads)",
        material.name(),
        settings.views.len(),
        settings.lights.len(),
        args.strata * args.strata,
        rayon::current_num_threads()
    );
    match target {
        BtfOutput::Cache => write_raw(&btf, &out)?,
        BtfOutput::Folder => {
            if kind != ImageKind::Exr {
                super::output::warn_clipped(&btf, &format!("--format {}", args.format));
            }
            super::output::clear_btf_folder(&out)?;
            write_folder(&btf, &out, kind)
                .with_context(|| format!("writing the UBO2003 folder {}", out.display()))?
        }
    }
    eprintln!("wrote {}", out.display());
    Ok(())
}
