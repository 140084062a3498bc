//! Write only the diagnosis material of the lumped machine (the fast part of `dump`):
//!
//! ```sh
//! cargo run --release -p lumped --example cases -- --out DIR [--seed N] [--random-machine]
//!     [--centre-only --centre-noise S]
//! ```
//!
//! DIR/centre_impact/imp_{x,y}.csv (a healthy impact test at the centre, 5 hits each: a
//! one-pose twin) and DIR/diagnose/<effect>/ with answers.json, every effect's parameters
//! drawn from the seed. `bench/confusion.py` runs it per seed.
//!
//! `--centre-only` writes only DIR/centre_impact (the twin's data), and `--centre-noise S`
//! scales its accelerometer's noise (white and 1/f) by S: with S = 0.1 (a sensor 20 dB
//! quieter) the one-pose twin is sound down to the band's lower edge, so a diagnosis of the
//! same cases can be judged apart from the twin's own error there.

use lumped::effects::write_diagnosis_material;
use lumped::structure::Machine;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage =
        "usage: cases --out DIR [--seed N] [--random-machine] [--centre-only] [--centre-noise S]";
    let (mut out, mut seed, mut random) = (None, 1u64, false);
    let (mut centre_only, mut centre_noise) = (false, 1.0f64);
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
            ("--centre-only", _) => centre_only = true,
            ("--centre-noise", Some(v)) => match v.parse::<f64>() {
                Ok(s) if s >= 0.0 => {
                    centre_noise = s;
                    i += 1;
                }
                _ => {
                    eprintln!("--centre-noise needs a scale >= 0, got {v:?}");
                    return ExitCode::FAILURE;
                }
            },
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
    let result = if centre_only {
        write_centre(&out, seed, random, centre_noise)
    } else if centre_noise != 1.0 {
        eprintln!("--centre-noise needs --centre-only (the cases keep their own noise)");
        return ExitCode::FAILURE;
    } else {
        write(&out, seed, random)
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}

fn machine(seed: u64, random: bool) -> Machine {
    if random {
        Machine::random(seed)
    } else {
        Machine::nominal()
    }
}

fn write(out: &Path, seed: u64, random: bool) -> Result<(), lumped::Error> {
    write_diagnosis_material(out, &machine(seed, random), seed)
}

/// The centre impact test alone, as [`write_diagnosis_material`] writes it (same hits,
/// same seeds), with the accelerometer noise scaled by `noise`.
fn write_centre(out: &Path, seed: u64, random: bool, noise: f64) -> Result<(), lumped::Error> {
    let mut setup = lumped::measure::Setup::impact();
    setup.response_noise.white *= noise;
    setup.response_noise.pink *= noise;
    let m = machine(seed, random);
    for (a, name) in [(0usize, "x"), (1, "y")] {
        lumped::measure::impact_record(
            &m,
            &setup,
            lumped::structure::CENTRE,
            a,
            5,
            2.0,
            seed * 1000 + 700 + a as u64,
        )
        .write_csv(&out.join(format!("centre_impact/imp_{name}.csv")))?;
    }
    Ok(())
}
