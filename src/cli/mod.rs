//! Subcommands, one file each.

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
    /// Fit LM / PLM / PLM-C to a measured BTF and write a .plmc model.
    Fit(fit::FitArgs),
    /// Evaluate a .plmc model (and LM/PLM/PLM-C/PCA refits) against the measured BTF.
    Eval(eval::EvalArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Fit(a) => fit::run(a),
        Command::Eval(a) => eval::run(a),
    }
}
