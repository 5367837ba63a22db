//! The `btfpt` command line: parses arguments, calls the library, prints, sets the exit code.

// See lib.rs: `!(x >= 0.0)` deliberately rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod cli;

use clap::Parser;

fn main() -> std::process::ExitCode {
    restore_sigpipe();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", message(&e));
            std::process::ExitCode::FAILURE
        }
    }
}

/// Rust ignores SIGPIPE, so `println!` into a closed pipe (`btfpt info X | head -1`) panics;
/// the default action ends the process quietly the way every Unix filter does.
fn restore_sigpipe() {
    #[cfg(unix)]
    // SAFETY: setting the disposition of SIGPIPE to its default before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message already
/// holds (an I/O error names its OS error once, not once per layer).
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}
