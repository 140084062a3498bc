//! Write only the diagnosis material of the lumped machine (the fast part of `dump`):
//!
//! ```sh
//! cargo run --release -p lumped --example cases -- --out DIR [--seed N] [--random-machine]
//! ```
//!
//! DIR/centre_impact/imp_{x,y}.csv (a healthy impact test at the centre, 5 hits each: a
//! one-pose twin) and DIR/diagnose/<effect>/ with answers.json, every effect's parameters
//! drawn from the seed. `bench/confusion.py` runs it per seed.

use lumped::effects::{case, Effect};
use lumped::measure::{impact_record, Setup};
use lumped::record::write_atomic;
use lumped::structure::{Machine, CENTRE};
use rayon::prelude::*;
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
    let setup = Setup::impact();
    for (a, name) in [(0usize, "x"), (1, "y")] {
        impact_record(
            &machine,
            &setup,
            CENTRE,
            a,
            5,
            2.0,
            seed * 1000 + 700 + a as u64,
        )
        .write_csv(&out.join(format!("centre_impact/imp_{name}.csv")))?;
    }
    let cases: Vec<_> = Effect::ALL
        .par_iter()
        .map(|&e| (e, case(&machine, e, seed)))
        .collect();
    let mut answers = serde_json::Map::new();
    for (e, c) in cases {
        for (name, r) in &c.records {
            r.write_csv(&out.join("diagnose").join(e.folder()).join(name))?;
        }
        answers.insert(e.folder().into(), c.answer.clone());
    }
    write_atomic(
        &out.join("diagnose/answers.json"),
        &serde_json::to_string_pretty(&answers).unwrap_or_default(),
    )?;
    Ok(())
}
