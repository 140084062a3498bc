//! Write only the diagnosis material of the lumped machine (the fast part of `dump`):
//!
//! ```sh
//! cargo run --release -p lumped --example cases -- --out DIR [--seed N] [--random-machine]
//! ```
//!
//! DIR/centre_impact/imp_{x,y}.csv (a healthy impact test at the centre, 5 hits each: a
//! one-pose twin) and DIR/diagnose/<effect>/ with answers.json, every effect's parameters
//! drawn from the seed. `bench/confusion.py` runs it per seed.

use lumped::effects::write_diagnosis_material;
use lumped::structure::Machine;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: cases --out DIR [--seed N] [--random-machine]";
    let (mut out, mut seed, mut random) = (None, 1u64, false);
    let mut i = 0;
    while i < args.len() {
        match (args[i].as_str(), args.get(i + 1)) {
            ("--out", Some(v)) => {
                out = Some(PathBuf::from(v));
                i += 1;
            }
            ("--seed", Some(v)) => match v.parse() {
                Ok(s) => {
                    seed = s;
                    i += 1;
                }
                Err(_) => {
                    eprintln!("--seed needs a whole number, got {v:?}");
                    return ExitCode::FAILURE;
                }
            },
            ("--random-machine", _) => random = true,
            (other, _) => {
                eprintln!("unknown argument {other:?}; {usage}");
                return ExitCode::FAILURE;
            }
        }
        i += 1;
    }
    let Some(out) = out else {
        eprintln!("missing --out DIR; {usage}");
        return ExitCode::FAILURE;
    };
    match write(&out, seed, random) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn write(out: &Path, seed: u64, random: bool) -> Result<(), lumped::Error> {
    let machine = if random {
        Machine::random(seed)
    } else {
        Machine::nominal()
    };
    write_diagnosis_material(out, &machine, seed)
}
