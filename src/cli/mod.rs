//! Subcommands, one file each.

pub mod convert;
pub mod info;

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
    /// Summarise a BTF: format, directions, size, encoding, value range, memory.
    Info(info::InfoArgs),
    /// Convert a BTF to a `.btfc` cache or a UBO2003 image folder.
    Convert(convert::ConvertArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Convert(a) => convert::run(a),
    }
}
