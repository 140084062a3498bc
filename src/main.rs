//! `mtwin`: the command line. Thin glue over the `identify` library.
use std::process::ExitCode;

fn main() -> ExitCode {
    eprintln!("mtwin: work in progress");
    ExitCode::from(1)
}
