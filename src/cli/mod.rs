//! Subcommands, one file each.

pub mod btf_input;
pub mod check;
pub mod compare;
pub mod convert;
pub mod figures;
pub mod info;
pub mod interrupt;
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
    ///
    /// For a .plmc model: clusters = K-means clusters per view and colour channel as produced;
    /// file 1:R = 8-bit RGB raw size of the model's own texels (views × lights × W × H × 3 bytes)
    /// / file size, the same figure `fit` and `eval` print (docs/model.md). Value statistics are
    /// linear, cosine-baked B = π·f·cos θ_l (docs/conventions.md).
    Info(info::InfoArgs),
    /// Convert a BTF to a `.btfc` cache or a UBO2003 image folder.
    Convert(convert::ConvertArgs),
    /// Render a scene to EXR (+ PNG preview).
    Render(render::RenderArgs),
    /// Merge partial renders (crop windows, sample ranges) into one image.
    Merge(merge::MergeArgs),
    /// Fit LM / PLM / PLM-C to a measured BTF and write a .plmc model.
    ///
    /// Prints the compression 1:R (8-bit RGB raw size of the model's texels / file size) and the
    /// clusters per view and colour channel, defined as in `info` and `eval` (docs/model.md).
    /// Ctrl-C keeps the finished views in OUTPUT.parts/; the same command resumes.
    Fit(fit::FitArgs),
    /// Evaluate a .plmc model (and LM/PLM/PLM-C/PCA refits) against the measured BTF.
    ///
    /// MAE: mean absolute error on values in the data's stored encoding normalised to [0, 1]
    /// (8-bit sRGB: code/255), per view then averaged over views (the paper's measure); MAE
    /// linear: the same on linear values; RMSE: stored encoding; bytes: file or refit size;
    /// ratio: 8-bit raw size of the model's texels / bytes; seam ratio: neighbour difference
    /// across tile edges / inside (1 = invisible seams). See docs/model.md.
    Eval(eval::EvalArgs),
    /// Measure a procedural material with the virtual gonioreflectometer (UBO2003 folder).
    Synth(synth::SynthArgs),
    /// Compare a render with a reference: MAE, RMSE, relMSE, luminance ratio, calibrated z-tests.
    ///
    /// MAE/RMSE in radiance units; relMSE = mean((t − r)² / (r² + 0.01)); luminance ratio = mean
    /// Rec.709 luminance of test / reference. With a variance (--spp with the reference's
    /// per-sample variance, --test-variance, --variance) the calibrated test runs: z-tests on
    /// 4–32 px block means and a global bias test sharing α, so a correct render fails with
    /// probability α. Without a variance it prints "no statistical test run". See docs/model.md.
    Compare(compare::CompareArgs),
    /// Run a regression suite: render every case, compare it with its reference by the
    /// calibrated test, print one line per case, write report/index.html and report/junit.xml;
    /// non-zero exit when any case fails.
    Check(check::CheckArgs),
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
        Command::Check(a) => check::run(a),
        Command::TilePreview(a) => tile_preview::run(a),
    }
}
