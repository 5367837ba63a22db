//! Subcommands, one file each.

use clap::{Parser, Subcommand};

/// btfpt: a path tracer for measured BTF materials (raw and PLM-C).
#[derive(Parser, Debug)]
#[command(name = "btfpt", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {}
}
