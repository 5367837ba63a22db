//! Subcommands, one file each.

pub mod compare;
pub mod convert;
pub mod figures;
pub mod info;
pub mod merge;
pub mod output;
pub mod render;
pub mod synth;
pub mod tile_preview;

use clap::{Parser, Subcommand};

pub mod eval;
pub mod fit;

/// btfpt: a path tracer for measured BTF materials (raw and PLM-C).
#[derive(Parser, Debug)]
#[command(name = "btfpt", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Summarise a BTF: format, directions, size, encoding, value range, memory.
    Info(info::InfoArgs),
    /// Convert a BTF to a `.btfc` cache or a UBO2003 image folder.
    Convert(convert::ConvertArgs),
    /// Render a scene to EXR (+ PNG preview).
    Render(render::RenderArgs),
    /// Merge partial renders (crop windows, sample ranges) into one image.
    Merge(merge::MergeArgs),
    /// Fit LM / PLM / PLM-C to a measured BTF and write a .plmc model.
    Fit(fit::FitArgs),
    /// Evaluate a .plmc model (and LM/PLM/PLM-C/PCA refits) against the measured BTF.
    Eval(eval::EvalArgs),
    /// Measure a procedural material with the virtual gonioreflectometer (UBO2003 folder).
    Synth(synth::SynthArgs),
    /// Compare a render with a reference: MAE, RMSE, relMSE, luminance ratio, z-tests.
    Compare(compare::CompareArgs),
    /// Render a model's seamless tile(s) for one view and light repeated over a grid (sRGB PNG).
    TilePreview(tile_preview::TilePreviewArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Convert(a) => convert::run(a),
        Command::Render(a) => render::run(a),
        Command::Merge(a) => merge::run(a),
        Command::Fit(a) => fit::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Compare(a) => compare::run(a),
        Command::TilePreview(a) => tile_preview::run(a),
    }
}
