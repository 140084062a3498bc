//! `mtwin`: the command line. Thin glue over the `identify` library: parse arguments,
//! call one library function, print a summary. Exit codes (docs/formats.md, "Exit codes and messages"): 0 success,
//! 2 bad usage or bad input, 1 any other failure.
#![forbid(unsafe_code)]

mod cli;
mod report;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("mtwin: error: {}", cli::error_text(&e));
            if cli::is_bad_input(&e) {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}
