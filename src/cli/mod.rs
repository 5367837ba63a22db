//! Subcommands, one file each.

pub mod merge;
pub mod render;

use clap::{Parser, Subcommand};

/// btfpt: a path tracer for measured BTF materials (raw and PLM-C).
#[derive(Parser, Debug)]
#[command(name = "btfpt", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene to EXR (+ PNG preview).
    Render(render::RenderArgs),
    /// Merge partial renders (crop windows, sample ranges) into one image.
    Merge(merge::MergeArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(a) => render::run(a),
        Command::Merge(a) => merge::run(a),
    }
}
